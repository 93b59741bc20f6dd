//! One pass over the data: evaluate C(t_j) with its contribution coefficients, measure the
//! geodesic error, and (for GLS-PIA) share the error vectors out to the control points.
//!
//! This is the hot loop of fitting. The data are cut into chunks that rayon runs in parallel;
//! each chunk accumulates only into the control points its spans touch, and chunk results are
//! merged in order, so the result does not depend on the number of threads.

use super::bspline::{control_arcs, Frame, Scratch, SphericalBSpline};
use super::metrics::ErrorSums;
use super::point::{Dim, PointSet};
use rayon::prelude::*;

/// Data points per parallel work item: large enough to amortise the per-chunk buffers, small
/// enough to balance two to a few dozen cores on 100k-point inputs.
const CHUNK: usize = 8192;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum PassMode {
    /// Errors only.
    Measure,
    /// Errors plus `Σ_j D_i(t_j) δ_j` and `Σ_j D_i(t_j)` per control point.
    Accumulate,
}

pub(crate) struct PassResult {
    pub errors: ErrorSums,
    /// `Σ_j D_i(t_j) δ_j`, control point after control point (empty when measuring).
    pub moves: Vec<f64>,
    /// `Σ_j D_i(t_j)` per control point (empty when measuring).
    pub weights: Vec<f64>,
}

struct ChunkResult {
    errors: ErrorSums,
    first_ctrl: usize,
    moves: Vec<f64>,
    weights: Vec<f64>,
}

/// Runs one pass. `params` must be non-decreasing (they are, by construction).
pub(crate) fn run_pass(
    spline: &SphericalBSpline,
    points: &PointSet,
    params: &[f64],
    mode: PassMode,
) -> PassResult {
    crate::with_dim!(spline.dim(), |d| run_pass_dim(
        d, spline, points, params, mode
    ))
}

fn run_pass_dim<D: Dim>(
    d: D,
    spline: &SphericalBSpline,
    points: &PointSet,
    params: &[f64],
    mode: PassMode,
) -> PassResult {
    let (p, dim, n_ctrl) = (spline.degree(), d.get(), spline.control_points().len());
    let arcs = control_arcs(d, spline.control_points());
    let frame = Frame::with_arcs(p, spline.knots(), spline.control_points(), &arcs);
    let chunks: Vec<ChunkResult> = params
        .par_chunks(CHUNK)
        .enumerate()
        .map(|(c, ts)| {
            let offset = c * CHUNK;
            let k_first = frame.span(ts[0]);
            let k_last = frame.span(ts[ts.len() - 1]).max(k_first);
            let first_ctrl = k_first - p;
            let local = k_last - first_ctrl + 1;
            let mut out = ChunkResult {
                errors: ErrorSums::default(),
                first_ctrl,
                moves: Vec::new(),
                weights: Vec::new(),
            };
            let mut scratch = Scratch::new(p, dim);
            let mut c_pt = vec![0.0; dim];
            let mut k = k_first;
            match mode {
                PassMode::Measure => {
                    for (j, &t) in ts.iter().enumerate() {
                        k = frame.span_from(k, t);
                        frame.eval::<D, false>(d, k, t, &mut scratch, &mut c_pt);
                        let q = points.get(offset + j);
                        let (theta, _) = error_arc(d, q, &c_pt);
                        out.errors.add(offset + j, theta);
                    }
                }
                PassMode::Accumulate => {
                    out.moves = vec![0.0; local * dim];
                    out.weights = vec![0.0; local];
                    for (j, &t) in ts.iter().enumerate() {
                        k = frame.span_from(k, t);
                        frame.eval::<D, true>(d, k, t, &mut scratch, &mut c_pt);
                        let q = points.get(offset + j);
                        let (theta, scale) = error_arc(d, q, &c_pt);
                        out.errors.add(offset + j, theta);
                        // δ_j = (q − C) / |q − C| · θ: chord direction, geodesic length.
                        let base = k - p - first_ctrl;
                        let coef = &scratch.coef[p];
                        for m in 0..=p {
                            let w = coef[m];
                            out.weights[base + m] += w;
                            let ws = w * scale;
                            let mv = &mut out.moves[(base + m) * dim..(base + m + 1) * dim];
                            let (q, c) = (&q[..dim], &c_pt[..dim]);
                            for x in 0..dim {
                                mv[x] += ws * (q[x] - c[x]);
                            }
                        }
                    }
                }
            }
            out
        })
        .collect();

    let mut result = PassResult {
        errors: ErrorSums::default(),
        moves: Vec::new(),
        weights: Vec::new(),
    };
    if mode == PassMode::Accumulate {
        result.moves = vec![0.0; n_ctrl * dim];
        result.weights = vec![0.0; n_ctrl];
    }
    for c in &chunks {
        result.errors.merge(&c.errors);
        for (i, w) in c.weights.iter().enumerate() {
            result.weights[c.first_ctrl + i] += w;
        }
        let start = c.first_ctrl * dim;
        for (i, m) in c.moves.iter().enumerate() {
            result.moves[start + i] += m;
        }
    }
    result
}

/// The geodesic error angle between data point `q` and curve point `c`, and the factor
/// `θ / |q − c|` that scales the chord `q − c` to geodesic length (1 when they coincide).
#[inline(always)]
fn error_arc<D: Dim>(d: D, q: &[f64], c: &[f64]) -> (f64, f64) {
    let (q, c) = (&q[..d.get()], &c[..d.get()]);
    let (mut m2, mut p2) = (0.0, 0.0);
    for x in 0..d.get() {
        let (a, b) = (q[x] - c[x], q[x] + c[x]);
        m2 += a * a;
        p2 += b * b;
    }
    let m = m2.sqrt();
    let theta = 2.0 * m.atan2(p2.sqrt());
    let scale = if m > 0.0 { theta / m } else { 1.0 };
    (theta, scale)
}
