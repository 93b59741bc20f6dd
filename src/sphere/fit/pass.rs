//! One pass over the data: evaluate C(t_j) with its contribution coefficients, measure the
//! geodesic error, and (for GLS-PIA) share the error vectors out to the control points.
//!
//! This is the hot loop of fitting. The data are cut into chunks that rayon runs in parallel;
//! each chunk accumulates only into the control points its spans touch, and chunk results are
//! merged in order, so the result does not depend on the number of threads.

use crate::sphere::curve::bspline::{with_degree, Degree, Frame, Scratch, SphericalBSpline};
use crate::sphere::fit::jacobian::{eval_with_jacobian, tangent_bases, JacobianScratch};
use crate::sphere::fit::metrics::ErrorSums;
use crate::sphere::geometry::point::SERIES_ANGLE_MAX_RAD;
use crate::sphere::geometry::point::{
    angle_from_chords, diff_sum_sq, dot, sinc_series, Dim, PointSet,
};
use crate::sphere::linalg::banded::SymmetricBand;
use rayon::prelude::*;

/// Dimensions up to this keep the error vector on the stack (S^2, S^3, Kendall S^14 ...).
const MAX_DIM_ON_STACK: usize = 16;

/// Data points per parallel work item: large enough to amortise the per-chunk buffers, small
/// enough to balance two to a few dozen cores on 100k-point inputs.
const CHUNK: usize = 8192;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum PassMode {
    /// Errors only.
    Measure,
    /// Errors plus `Σ_j D_i(t_j) δ_j` and `Σ_j D_i(t_j)` per control point.
    Accumulate,
    /// Errors plus the normal equations of the linearised least-squares step: `AᵀA` (banded,
    /// `A_ji = D_i(t_j)`) in `band` and `Aᵀ r` in `moves`, with `r_j = log_{C(t_j)}(q_j)`.
    Normal,
    /// As [`PassMode::Normal`], but `moves` holds GLS-PIA's error allocation `Σ_j D_i(t_j) δ_j`
    /// with the paper's `δ_j` (chord direction, geodesic length): accelerated GLS-PIA
    /// preconditions that update by `AᵀA`.
    Preconditioned,
    /// Errors plus the Gauss–Newton normal equations with the exact Jacobian of C(t_j) in the
    /// tangent coordinates of each control point (`jacobian.rs`): `JᵀJ` in `band` (unknowns
    /// ordered control by control, `dim − 1` each), `Jᵀ r` in `moves`, the bases in `bases`.
    Exact,
}

pub(crate) struct PassResult {
    pub errors: ErrorSums,
    /// The error of every point (radians), in order: the adaptive-knot refinement reads the
    /// last pass's instead of measuring the curve again.
    pub each: Vec<f64>,
    /// `Σ_j D_i(t_j) δ_j`, control point after control point (empty when measuring).
    pub moves: Vec<f64>,
    /// `Σ_j D_i(t_j)` per control point (empty when measuring).
    pub weights: Vec<f64>,
    /// `AᵀA` in [`PassMode::Normal`], `JᵀJ` in [`PassMode::Exact`].
    pub band: Option<SymmetricBand>,
    /// The tangent bases of the control points in [`PassMode::Exact`].
    pub bases: Vec<f64>,
}

struct ChunkResult {
    errors: ErrorSums,
    each: Vec<f64>,
    first_ctrl: usize,
    moves: Vec<f64>,
    weights: Vec<f64>,
    band: Option<SymmetricBand>,
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

pub(crate) fn run_pass_dim<D: Dim>(
    d: D,
    spline: &SphericalBSpline,
    points: &PointSet,
    params: &[f64],
    mode: PassMode,
) -> PassResult {
    with_degree!(spline.degree(), |g| run_pass_kernel(
        d, g, spline, points, params, mode
    ))
}

fn run_pass_kernel<D: Dim, G: Degree>(
    d: D,
    g: G,
    spline: &SphericalBSpline,
    points: &PointSet,
    params: &[f64],
    mode: PassMode,
) -> PassResult {
    let (p, dim, n_ctrl) = (g.get(), d.get(), spline.control_points().len());
    let frame = Frame::cached(d, p, spline.knots(), spline.control_points());
    let nb = dim - 1;
    let bases = if mode == PassMode::Exact {
        tangent_bases(spline.control_points())
    } else {
        Vec::new()
    };
    // Numbers per control point in `moves`: one per coordinate, or one per tangent direction.
    let stride = if mode == PassMode::Exact { nb } else { dim };
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
                each: Vec::with_capacity(ts.len()),
                first_ctrl,
                moves: Vec::new(),
                weights: Vec::new(),
                band: None,
            };
            let mut scratch = Scratch::new(p, dim);
            let mut c_pt = vec![0.0; dim];
            let mut k = k_first;
            match mode {
                PassMode::Measure => {
                    for (j, &t) in ts.iter().enumerate() {
                        k = frame.span_from(k, t);
                        frame.eval::<D, G, false, true>(d, g, k, t, &mut scratch, &mut c_pt);
                        let q = points.get(offset + j);
                        let (theta, _) = error_arc(d, q, &c_pt);
                        out.errors.add(offset + j, theta);
                        out.each.push(theta);
                    }
                }
                PassMode::Accumulate => {
                    out.moves = vec![0.0; local * dim];
                    out.weights = vec![0.0; local];
                    for (j, &t) in ts.iter().enumerate() {
                        k = frame.span_from(k, t);
                        frame.eval::<D, G, true, true>(d, g, k, t, &mut scratch, &mut c_pt);
                        let q = points.get(offset + j);
                        let (theta, scale) = error_arc(d, q, &c_pt);
                        out.errors.add(offset + j, theta);
                        out.each.push(theta);
                        // δ_j = (q − C) / |q − C| · θ: chord direction, geodesic length.
                        let mut delta = [0.0; MAX_DIM_ON_STACK];
                        let delta = &mut delta[..dim.min(MAX_DIM_ON_STACK)];
                        let use_stack = dim <= MAX_DIM_ON_STACK;
                        if use_stack {
                            for x in 0..dim {
                                delta[x] = scale * (q[x] - c_pt[x]);
                            }
                        }
                        let base = k - p - first_ctrl;
                        let coef = &scratch.contrib;
                        for m in 0..p + 1 {
                            let w = coef[m];
                            out.weights[base + m] += w;
                            let mv = &mut out.moves[(base + m) * dim..(base + m + 1) * dim];
                            if use_stack {
                                for x in 0..dim {
                                    mv[x] += w * delta[x];
                                }
                            } else {
                                let ws = w * scale;
                                for x in 0..dim {
                                    mv[x] += ws * (q[x] - c_pt[x]);
                                }
                            }
                        }
                    }
                }
                PassMode::Normal | PassMode::Preconditioned => {
                    let chord = mode == PassMode::Preconditioned;
                    out.moves = vec![0.0; local * dim];
                    let mut band = SymmetricBand::zeros(local, p);
                    for (j, &t) in ts.iter().enumerate() {
                        k = frame.span_from(k, t);
                        frame.eval::<D, G, true, true>(d, g, k, t, &mut scratch, &mut c_pt);
                        let q = points.get(offset + j);
                        let (theta, scale) = if chord {
                            error_arc(d, q, &c_pt)
                        } else {
                            log_residual(d, q, &c_pt)
                        };
                        out.errors.add(offset + j, theta);
                        out.each.push(theta);
                        let base = k - p - first_ctrl;
                        let coef = &scratch.contrib;
                        // r_j = scale · (q − (q·C) C), the log map of q at C; or GLS-PIA's
                        // δ_j = scale · (q − C), the chord scaled to the geodesic length.
                        let cos = if chord { 1.0 } else { dot(d, q, &c_pt) };
                        for m in 0..p + 1 {
                            let w = coef[m];
                            for m2 in m..p + 1 {
                                band.add_upper(base + m, base + m2, w * coef[m2]);
                            }
                            let ws = w * scale;
                            let mv = &mut out.moves[(base + m) * dim..(base + m + 1) * dim];
                            for x in 0..dim {
                                mv[x] += ws * (q[x] - cos * c_pt[x]);
                            }
                        }
                    }
                    out.band = Some(band);
                }
                PassMode::Exact => {
                    let ndir = (p + 1) * nb;
                    out.moves = vec![0.0; local * nb];
                    let mut band = SymmetricBand::zeros(local * nb, ndir - 1);
                    let mut js = JacobianScratch::new(p, dim);
                    let mut r = vec![0.0; dim];
                    for (j, &t) in ts.iter().enumerate() {
                        k = frame.span_from(k, t);
                        eval_with_jacobian(spline, &bases, k, t, &mut js, &mut c_pt);
                        let q = points.get(offset + j);
                        let (theta, scale) = log_residual(d, q, &c_pt);
                        out.errors.add(offset + j, theta);
                        out.each.push(theta);
                        let cos = dot(d, q, &c_pt);
                        for x in 0..dim {
                            r[x] = scale * (q[x] - cos * c_pt[x]);
                        }
                        let base = (k - p - first_ctrl) * nb;
                        let jac = &js.jac;
                        for u in 0..ndir {
                            let ju = &jac[u * dim..(u + 1) * dim];
                            out.moves[base + u] += dot(d, ju, &r);
                            for v in u..ndir {
                                let jv = &jac[v * dim..(v + 1) * dim];
                                band.add_upper(base + u, base + v, dot(d, ju, jv));
                            }
                        }
                    }
                    out.band = Some(band);
                }
            }
            out
        })
        .collect();

    let mut result = PassResult {
        errors: ErrorSums::default(),
        each: Vec::with_capacity(params.len()),
        moves: Vec::new(),
        weights: Vec::new(),
        band: None,
        bases: Vec::new(),
    };
    match mode {
        PassMode::Measure => {}
        PassMode::Accumulate => {
            result.moves = vec![0.0; n_ctrl * dim];
            result.weights = vec![0.0; n_ctrl];
        }
        PassMode::Normal | PassMode::Preconditioned => {
            result.moves = vec![0.0; n_ctrl * dim];
            result.band = Some(SymmetricBand::zeros(n_ctrl, p));
        }
        PassMode::Exact => {
            result.moves = vec![0.0; n_ctrl * nb];
            result.band = Some(SymmetricBand::zeros(n_ctrl * nb, (p + 1) * nb - 1));
        }
    }
    let band_stride = if mode == PassMode::Exact { nb } else { 1 };
    for c in &chunks {
        if let (Some(total), Some(part)) = (result.band.as_mut(), c.band.as_ref()) {
            total.add_block(c.first_ctrl * band_stride, part);
        }
        result.errors.merge(&c.errors);
        result.each.extend_from_slice(&c.each);
        for (i, w) in c.weights.iter().enumerate() {
            result.weights[c.first_ctrl + i] += w;
        }
        let start = c.first_ctrl * stride;
        for (i, m) in c.moves.iter().enumerate() {
            result.moves[start + i] += m;
        }
    }
    result.bases = bases;
    result
}

/// The geodesic error angle between data point `q` and curve point `c`, and the factor
/// `θ / |q − c|` that scales the chord `q − c` to geodesic length (1 when they coincide).
#[inline(always)]
fn error_arc<D: Dim>(d: D, q: &[f64], c: &[f64]) -> (f64, f64) {
    let (m2, p2) = diff_sum_sq(d, q, c);
    angle_from_chords(m2, p2)
}

/// The error angle θ between `q` and `c`, and the factor `θ / sin θ` that turns the tangent
/// component `q − (q·c) c` (length sin θ) into the log map of `q` at `c` (length θ).
#[inline(always)]
pub(crate) fn log_residual<D: Dim>(d: D, q: &[f64], c: &[f64]) -> (f64, f64) {
    let (m2, p2) = diff_sum_sq(d, q, c);
    let (theta, _) = angle_from_chords(m2, p2);
    let scale = if theta <= SERIES_ANGLE_MAX_RAD {
        1.0 / sinc_series(theta)
    } else {
        let sin = 0.5 * m2.sqrt() * p2.sqrt();
        // Antipodal: the direction is undefined; pull nowhere rather than divide by zero.
        if sin > 0.0 {
            theta / sin
        } else {
            0.0
        }
    };
    (theta, scale)
}
