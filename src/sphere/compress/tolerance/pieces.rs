//! A long line's degree-1 fit in pieces cut at sharp corners, fitted in parallel and joined.

use super::fitter::Fitter;
use super::{
    decide_budget, internal_target, Curve, KnotRule, Line, ToleranceOptions, TWO_WAY_PRECISION,
    VERTEX_SHARES,
};
use crate::sphere::certify::two_way::{two_way_distance, TwoWayOptions};
use crate::sphere::compress::simplify::douglas_peucker_ordered;
use crate::sphere::curve::bspline::{clamped_uniform_knots, Degree, SphericalBSpline};
use crate::sphere::fit::adaptive_knots::turning_angles;
use crate::sphere::fit::knots::parameters;
use crate::sphere::geometry::point::{Dim, PointSet};

/// Seed vertices per piece of [`polyline_in_pieces`]; a line whose seed has fewer than twice
/// this many is fitted whole.
const PIECE_VERTICES: usize = 512;

/// Seed vertices on each side of a nominal junction of [`polyline_in_pieces`] among which the
/// sharpest corner is taken.
const JUNCTION_REACH: usize = 32;

/// The degree-1 fit (seed, refinement, knot removal) of a long line, in pieces fitted in
/// parallel: `None` when the line is too short to cut.
///
/// The seed (the ordered Douglas–Peucker polyline) keeps data points as vertices; the line is
/// cut at every [`PIECE_VERTICES`]-th of them and each piece is fitted on its own with its
/// ends pinned at those junction points, which the whole curve then passes through exactly.
/// A removal only ever reads a few neighbouring vertices, so the pieces find what the whole
/// line would, less at most a vertex or so per junction (a junction cannot move or go), while
/// each removal's bookkeeping (shifting the vertices behind it) is bounded by a piece and the
/// pieces run on all threads.
///
/// Each junction is the sharpest corner among the seed vertices within [`JUNCTION_REACH`] of
/// every [`PIECE_VERTICES`]-th: a vertex the line turns hard at is kept by any fit, so pinning
/// it loses nothing. The times and the choice of piece size and junctions are measured in
/// `docs/tolerance-fitting.md` ("Long lines in pieces").
///
/// The pieces' polylines join into one on uniform knots: piece k's local parameter t of its
/// m_k vertices maps to (o_k + t (m_k − 1)) / (M − 1), o_k being the segments before it and M
/// the vertices of the whole; the errors are the pieces'.
pub(super) fn polyline_in_pieces<D: Dim, G: Degree>(
    d: D,
    g: G,
    points: &PointSet,
    target: f64,
    tolerance_rad: f64,
    options: &ToleranceOptions,
) -> Option<(Curve, bool)> {
    use rayon::prelude::*;
    let seed = douglas_peucker_ordered(points, target);
    if seed.len() < 2 * PIECE_VERTICES {
        return None;
    }
    // Every PIECE_VERTICES-th seed vertex, moved to the sharpest corner near it: a vertex the
    // line turns hard at stays in any fit, so pinning it there costs nothing.
    let last = points.len() - 1;
    let turns = turning_angles(&points.subset(&seed));
    let mut junctions: Vec<usize> = vec![0];
    let mut k = PIECE_VERTICES;
    while k + PIECE_VERTICES < seed.len() {
        let sharpest = (k - JUNCTION_REACH..=k + JUNCTION_REACH)
            .max_by(|&a, &b| turns[a].total_cmp(&turns[b]))
            .unwrap_or(k);
        junctions.push(seed[sharpest]);
        k += PIECE_VERTICES;
    }
    junctions.push(last);
    let dim = d.get();
    let cancel = crate::sphere::cancel::current();
    let piece_options = ToleranceOptions {
        pin_ends: true,
        ..options.clone()
    };
    // Each piece is certified on its own (its two-way distance to its points within the
    // tolerance): the whole curve's two-way distance is the largest of its pieces', so a
    // piece that misses is fitted again closer (lower vertex shares), alone, instead of the
    // whole line at the next share.
    let check = TwoWayOptions::default()
        .with_precision_rad(TWO_WAY_PRECISION * tolerance_rad)
        .deciding(tolerance_rad);
    let pieces: Vec<Option<(Curve, f64)>> = junctions
        .par_windows(2)
        .map(|w| {
            let _scope = cancel.enter();
            let (a, b) = (w[0], w[1]);
            let sub = PointSet::from_flat_unchecked(
                dim,
                points.as_flat()[a * dim..(b + 1) * dim].to_vec(),
            );
            let params = parameters(&sub, options.parameterization).ok()?;
            let n = sub.len();
            let line = Line {
                points: &sub,
                params: &params,
                free: true,
            };
            let fit = |kept: &[usize], target: f64| -> Option<(Curve, f64)> {
                let mut f = Fitter::from_kept(d, g, line, kept, n, &piece_options)?;
                f.reweight = options.reweight;
                f.refine(target, n);
                let max = f.max_error();
                if max <= target {
                    f.reduce(target);
                }
                // Degree 1 on uniform knots is the same polyline: errors unchanged.
                let u = f.to_uniform(f64::INFINITY)?;
                Some((u, f.max_error()))
            };
            let certified = |c: &Curve| {
                two_way_distance(
                    &c.spline,
                    &sub,
                    &c.params,
                    &check.clone().with_max_evaluations(decide_budget(n)),
                )
                .is_ok_and(|tw| !tw.exceeded && tw.upper_rad <= tolerance_rad)
            };
            // The whole line's seed between the junctions: its chords are the piece's, so it
            // keeps the piece's points in order within the target as it does the line's (and
            // the piece needs no Douglas–Peucker of its own).
            let from = seed.partition_point(|&i| i < a);
            let to = seed.partition_point(|&i| i <= b);
            let kept: Vec<usize> = seed[from..to].iter().map(|&i| i - a).collect();
            let first = fit(&kept, target)?;
            if first.1 > target || certified(&first.0) {
                return Some(first);
            }
            for lower in VERTEX_SHARES
                .iter()
                .map(|&s| internal_target(s * tolerance_rad))
                .filter(|&t| t < target)
            {
                if crate::sphere::cancel::cancelled() {
                    return None;
                }
                let kept = douglas_peucker_ordered(&sub, lower);
                if let Some((c, e)) = fit(&kept, lower).filter(|(c, e)| *e <= lower && certified(c))
                {
                    return Some((c, e));
                }
            }
            // The piece's own polyline: every point a vertex, error 0.
            let spline =
                SphericalBSpline::try_new(1, clamped_uniform_knots(n, 1), sub.clone()).ok()?;
            let params = (0..n).map(|j| j as f64 / (n - 1) as f64).collect();
            let curve = Curve {
                spline,
                params,
                rule: KnotRule::Uniform,
            };
            Some((curve, 0.0))
        })
        .collect();
    if crate::sphere::cancel::cancelled() {
        return None;
    }
    let pieces: Vec<(Curve, f64)> = pieces.into_iter().collect::<Option<_>>()?;
    let total: usize = pieces
        .iter()
        .map(|(c, _)| c.spline.control_points().len() - 1)
        .sum::<usize>()
        + 1;
    let mut coords = Vec::with_capacity(total * dim);
    let mut params = Vec::with_capacity(points.len());
    let mut offset = 0usize;
    let mut max = 0.0f64;
    for (k, (c, e)) in pieces.iter().enumerate() {
        let ctrl = c.spline.control_points();
        let m = ctrl.len();
        // A junction is the last vertex of one piece and the first of the next.
        let from = usize::from(k > 0);
        coords.extend_from_slice(&ctrl.as_flat()[from * dim..]);
        let scale = (m - 1) as f64 / (total - 1) as f64;
        let base = offset as f64 / (total - 1) as f64;
        params.extend(
            c.params[from..]
                .iter()
                .map(|&t| (base + t * scale).min(1.0)),
        );
        offset += m - 1;
        max = max.max(*e);
    }
    *params.last_mut()? = 1.0;
    let ctrl = PointSet::from_flat_unchecked(dim, coords);
    let spline = SphericalBSpline::try_new(1, clamped_uniform_knots(total, 1), ctrl).ok()?;
    let met = max <= target;
    Some((
        Curve {
            spline,
            params,
            rule: KnotRule::Uniform,
        },
        met,
    ))
}
