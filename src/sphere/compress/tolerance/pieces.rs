//! A long line's degree-1 fit in pieces cut at sharp corners, fitted in parallel and joined.

use crate::sphere::certify::two_way::{two_way_distance, TwoWayDistance};
use crate::sphere::compress::simplify::douglas_peucker_ordered;
use crate::sphere::compress::tolerance::fitter::Fitter;
use crate::sphere::compress::tolerance::{
    decide_options, internal_target, Curve, KnotRule, Line, ToleranceOptions, VERTEX_SHARES,
};
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
///
/// The joined curve is decided here ("two-way distance within `tolerance_rad`?", the caller's
/// decision, handed over in [`Curve::decided`]). When it misses, each piece is decided on its
/// own (the whole curve's two-way distance is the largest of its pieces': they meet at
/// junction points, matched there on both sides) and a piece that misses is fitted again at
/// the lower [`VERTEX_SHARES`], then replaced by its own points: the line is not fitted again
/// whole at the next share and then given up for a Douglas–Peucker fallback, as the largest
/// land rings were at 5 km (`docs/speed.md`, "Across tolerances").
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
    // Piece k's points and their starting parameters.
    let piece_line = |k: usize| -> Option<(PointSet, Vec<f64>)> {
        let (a, b) = (junctions[k], junctions[k + 1]);
        let sub =
            PointSet::from_flat_unchecked(dim, points.as_flat()[a * dim..(b + 1) * dim].to_vec());
        let params = parameters(&sub, options.parameterization).ok()?;
        Some((sub, params))
    };
    // Seed, refinement and knot removal of one piece from the vertices `kept`.
    let fit = |sub: &PointSet, params: &[f64], kept: &[usize], target: f64| {
        let n = sub.len();
        let line = Line {
            points: sub,
            params,
            free: true,
        };
        let mut f = Fitter::from_kept(d, g, line, kept, n, &piece_options)?;
        f.reweight = options.reweight;
        f.refine(target, n);
        if f.max_error() <= target {
            f.reduce(target);
        }
        // Degree 1 on uniform knots is the same polyline: errors unchanged.
        let u = f.to_uniform(f64::INFINITY)?;
        Some((u, f.max_error()))
    };
    let pieces: Vec<Option<(Curve, f64)>> = (0..junctions.len() - 1)
        .into_par_iter()
        .map(|k| {
            let _scope = cancel.enter();
            let (sub, params) = piece_line(k)?;
            // The whole line's seed between the junctions: its chords are the piece's, so it
            // keeps the piece's points in order within the target as it does the line's (and
            // the piece needs no Douglas–Peucker of its own).
            let (a, b) = (junctions[k], junctions[k + 1]);
            let from = seed.partition_point(|&i| i < a);
            let to = seed.partition_point(|&i| i <= b);
            let kept: Vec<usize> = seed[from..to].iter().map(|&i| i - a).collect();
            fit(&sub, &params, &kept, target)
        })
        .collect();
    if crate::sphere::cancel::cancelled() {
        return None;
    }
    let mut pieces: Vec<(Curve, f64)> = pieces.into_iter().collect::<Option<_>>()?;
    let (mut curve, mut met) = join(dim, points.len(), &pieces, target)?;
    // The decision the caller makes on the joined curve, made here (the same curve, points,
    // parameters and options, so the same answer) and handed over with it.
    let check = decide_options(tolerance_rad, points.len());
    let mut decided = two_way_distance(&curve.spline, points, &curve.params, &check).ok();
    let within = |tw: &TwoWayDistance| !tw.exceeded && tw.upper_rad <= tolerance_rad;
    if met && !decided.as_ref().is_some_and(within) {
        // The whole curve's two-way distance is the largest of its pieces' (they meet at
        // junction points, matched there on both sides): a piece beyond the tolerance is
        // fitted again closer (the lower vertex shares, then its own polyline), alone,
        // instead of the whole line at the next share.
        pieces = pieces
            .into_par_iter()
            .enumerate()
            .map(|(k, (c, e))| {
                let _scope = cancel.enter();
                let (sub, params) = piece_line(k)?;
                let piece_check = decide_options(tolerance_rad, sub.len());
                let certified = |c: &Curve| {
                    two_way_distance(&c.spline, &sub, &c.params, &piece_check)
                        .is_ok_and(|tw| within(&tw))
                };
                if certified(&c) {
                    return Some((c, e));
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
                    let refit = fit(&sub, &params, &kept, lower)
                        .filter(|(c, e)| *e <= lower && certified(c));
                    if refit.is_some() {
                        return refit;
                    }
                }
                // The piece's own polyline: every point a vertex, error 0.
                let n = sub.len();
                let spline = SphericalBSpline::try_new(1, clamped_uniform_knots(n, 1), sub).ok()?;
                let params = (0..n).map(|j| j as f64 / (n - 1) as f64).collect();
                let curve = Curve {
                    spline,
                    params,
                    rule: KnotRule::Uniform,
                    decided: None,
                };
                Some((curve, 0.0))
            })
            .collect::<Option<Vec<_>>>()?;
        if crate::sphere::cancel::cancelled() {
            return None;
        }
        (curve, met) = join(dim, points.len(), &pieces, target)?;
        decided = two_way_distance(&curve.spline, points, &curve.params, &check).ok();
    }
    curve.decided = decided;
    Some((curve, met))
}

/// The pieces' polylines joined into one on uniform knots (see [`polyline_in_pieces`]), and
/// whether every piece's vertex errors are within `target`.
fn join(
    dim: usize,
    n_points: usize,
    pieces: &[(Curve, f64)],
    target: f64,
) -> Option<(Curve, bool)> {
    let total: usize = pieces
        .iter()
        .map(|(c, _)| c.spline.control_points().len() - 1)
        .sum::<usize>()
        + 1;
    let mut coords = Vec::with_capacity(total * dim);
    let mut params = Vec::with_capacity(n_points);
    let mut offset = 0usize;
    let mut max = 0.0f64;
    for (k, (c, e)) in pieces.iter().enumerate() {
        let ctrl = c.spline.control_points();
        let m = ctrl.len();
        // A junction is the last vertex of one piece and the first of the next.
        let from = usize::from(k > 0);
        coords.extend_from_slice(&ctrl.as_flat()[from * dim..]);
        append_piece_parameters(&mut params, &c.params[from..], offset, m, total);
        offset += m - 1;
        max = max.max(*e);
    }
    *params.last_mut()? = 1.0;
    let ctrl = PointSet::from_flat_unchecked(dim, coords);
    let spline = SphericalBSpline::try_new(1, clamped_uniform_knots(total, 1), ctrl).ok()?;
    Some((
        Curve {
            spline,
            params,
            rule: KnotRule::Uniform,
            decided: None,
        },
        max <= target,
    ))
}

/// Appends a piece's local parameters `local` (of its `m` vertices, `offset` segments of the
/// whole's `total` vertices before it) mapped onto the whole line's uniform knots, kept
/// non-decreasing across the junction: `base + 1 · scale` of one piece can round an ulp
/// above the next piece's `base` (0.1 + 0.2 > 0.3; a land ring at 1 km came back refused,
/// "parameter 6123 is smaller than parameter 6122").
fn append_piece_parameters(
    params: &mut Vec<f64>,
    local: &[f64],
    offset: usize,
    m: usize,
    total: usize,
) {
    let scale = (m - 1) as f64 / (total - 1) as f64;
    let base = offset as f64 / (total - 1) as f64;
    for &t in local {
        let prev = params.last().copied().unwrap_or(0.0);
        params.push((base + t * scale).min(1.0).max(prev));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn joined_parameters_never_decrease_at_a_junction() {
        // Pieces of 1, 2 and 2 segments (6 vertices): the second ends at
        // 1/5 + 1 · 2/5 = 0.6000000000000001 > 0.6, where the third begins (its first point
        // after the junction has its foot point on the junction, t = 0).
        let mut params = vec![0.0];
        append_piece_parameters(&mut params, &[1.0], 0, 2, 6);
        append_piece_parameters(&mut params, &[0.5, 1.0], 1, 3, 6);
        append_piece_parameters(&mut params, &[0.0, 0.5, 1.0], 3, 3, 6);
        assert!(params.windows(2).all(|w| w[0] <= w[1]), "{params:?}");
        assert_eq!(*params.last().unwrap(), 1.0);
    }
}
