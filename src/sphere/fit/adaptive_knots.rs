//! Adaptive knots for real lines (`KnotPlacement::Adaptive`): the paper's geodesic-difference
//! feature function, made to work on lines built of corners, straight stretches and uneven
//! sampling (borders, coastlines, tracks).
//!
//! The paper's placement (`KnotPlacement::Geodesic`, [`super::knots`]) puts knots at equal levels
//! of the CDF of `|q^(p)|^(1/p)`. On the 10m US–Mexico border that piles knots into the densely
//! sampled, meandering Rio Grande and leaves the long straight land border with a handful, and
//! every sharp turn of the polyline is one large spike of the p-th difference that several knots
//! chase without ever making a corner. Three changes, each measured on real borders
//! (`examples/default_fit_study.rs`; the numbers are in `docs/default-fit.md`):
//!
//! * **Corners become C0 joints.** A vertex where the polyline turns by at least
//!   [`CORNER_ANGLE_RAD`] is a corner candidate; the sharpest ones (at most
//!   [`CORNER_KNOT_SHARE`] of the interior knots go to corners) get a knot of multiplicity p at
//!   their parameter, so the curve passes through a control point there and may turn sharply,
//!   while the pieces between corners stay C^(p−1).
//! * **Differences do not cross corners.** The feature function is computed piece by piece, so a
//!   corner's spike no longer drags the knots of its neighbourhood towards it.
//! * **The CDF is mixed with arc length.** The knots of the pieces sit at equal levels of
//!   `(1 − w) F(u) / F(1) + w u` (u: the chord-length parameter, so `u` is arc length) with
//!   `w =` [`ARC_LENGTH_SHARE`]: detail still draws knots, but a sparse straight stretch keeps
//!   a share of them proportional to its length, which is what the paper's CDF takes away.
//!
//! With no corner candidates and no arc-length share this is exactly the paper's placement.
//!
//! The default Earth fit (`earth::curve::fitting`) starts from these knots and adds knots and C0
//! joints where the curve misses the line ([`refine`]). The measurements behind each choice, the
//! candidates the default once compared and the ideas measured and dropped are in
//! `docs/default-fit.md`.

use crate::sphere::fit::knots::feature_function;
use crate::sphere::geometry::point::{dot, Dim, PointSet};

/// Turning angle (between the incoming and the outgoing great-circle direction at a vertex) from
/// which a vertex is a corner candidate: 50°. Measured on the 10m borders of the README's
/// table at half the positions: 40° and 60° both raised the worst max error of these knots
/// (2.8 and 1.5 km against 1.2 km).
pub const CORNER_ANGLE_RAD: f64 = 50.0 * std::f64::consts::PI / 180.0;

/// At most this share of the interior knots (counted with multiplicity) go to corners, the
/// sharpest first: the smooth pieces keep the rest.
pub const CORNER_KNOT_SHARE: f64 = 0.4;

/// Weight of arc length in the mixed CDF.
pub const ARC_LENGTH_SHARE: f64 = 0.4;

/// Weight of the point count in the mixed CDF (knots at equal numbers of data points, the
/// averaging placement of least-squares approximation, Piegl & Tiller §9.4.1).
pub const COUNT_SHARE: f64 = 0.0;

/// Smallest gap between neighbouring knots of a smooth piece (and between them and the piece's
/// ends), as a fraction of the uniform spacing: as [`super::knots::MIN_KNOT_GAP_FRACTION`].
const MIN_GAP_FRACTION: f64 = 1e-6;

/// How the adaptive placement is tuned; [`AdaptiveKnots::default`] is what
/// `KnotPlacement::Adaptive` uses.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdaptiveKnots {
    /// See [`CORNER_ANGLE_RAD`]; `f64::INFINITY` finds no corners.
    pub corner_angle_rad: f64,
    /// See [`CORNER_KNOT_SHARE`].
    pub corner_knot_share: f64,
    /// See [`ARC_LENGTH_SHARE`].
    pub arc_length_share: f64,
    /// See [`COUNT_SHARE`].
    pub count_share: f64,
}

impl Default for AdaptiveKnots {
    fn default() -> Self {
        AdaptiveKnots {
            corner_angle_rad: CORNER_ANGLE_RAD,
            corner_knot_share: CORNER_KNOT_SHARE,
            arc_length_share: ARC_LENGTH_SHARE,
            count_share: COUNT_SHARE,
        }
    }
}

/// The turning angle at every point (0 at the ends and where a neighbour coincides with it):
/// the angle between the directions from the previous point and to the next one, in the
/// tangent plane at the point.
pub fn turning_angles(points: &PointSet) -> Vec<f64> {
    crate::with_dim!(points.dim(), |d| turning_angles_dim(d, points))
}

fn turning_angles_dim<D: Dim>(d: D, points: &PointSet) -> Vec<f64> {
    let n = points.len();
    let dim = d.get();
    let mut out = vec![0.0; n];
    let mut a = vec![0.0; dim];
    let mut b = vec![0.0; dim];
    for i in 1..n.saturating_sub(1) {
        let (qp, q, qn) = (points.get(i - 1), points.get(i), points.get(i + 1));
        // Tangent directions at q: towards the previous point (reversed) and the next one.
        let (cp, cn) = (dot(d, qp, q), dot(d, qn, q));
        for k in 0..dim {
            a[k] = q[k] * cp - qp[k];
            b[k] = qn[k] - q[k] * cn;
        }
        let (na, nb) = (dot(d, &a, &a).sqrt(), dot(d, &b, &b).sqrt());
        if na <= 1e-15 || nb <= 1e-15 {
            continue;
        }
        let c = (dot(d, &a, &b) / (na * nb)).clamp(-1.0, 1.0);
        out[i] = c.acos();
    }
    out
}

/// The indices of the corners: points turning by at least `angle` with a parameter strictly
/// inside (0, 1) and different from every other corner's, the sharpest `max_corners` of them,
/// in order along the line.
pub fn corners(points: &PointSet, params: &[f64], angle: f64, max_corners: usize) -> Vec<usize> {
    if max_corners == 0 || !angle.is_finite() {
        return Vec::new();
    }
    let turns = turning_angles(points);
    let n = points.len();
    let arm = |i: usize| {
        let a = crate::sphere::geometry::point::angle_between(points.get(i - 1), points.get(i));
        let b = crate::sphere::geometry::point::angle_between(points.get(i), points.get(i + 1));
        a.min(b)
    };
    // How far a smooth curve cutting the corner would pass from it: the turn times its shorter
    // arm. A sharp turn between short steps costs little; a moderate one between long steps a
    // lot.
    let weight: Vec<f64> = (0..n)
        .map(|i| {
            if i == 0 || i + 1 == n {
                0.0
            } else {
                (turns[i] / 2.0).sin() * arm(i)
            }
        })
        .collect();
    let mut cand: Vec<usize> = (1..n.saturating_sub(1))
        .filter(|&i| turns[i] >= angle && params[i] > 0.0 && params[i] < 1.0)
        .collect();
    cand.sort_by(|&a, &b| weight[b].total_cmp(&weight[a]).then(a.cmp(&b)));
    let mut chosen: Vec<usize> = Vec::new();
    for i in cand {
        if chosen.len() == max_corners {
            break;
        }
        if chosen.iter().all(|&j| params[j] != params[i]) {
            chosen.push(i);
        }
    }
    chosen.sort_unstable();
    chosen
}

/// A smooth piece between two corners (or a line end): the data parameters `t_j0 ..= t_j1` and,
/// at each, the running integral of the piece's feature function.
struct Piece {
    t: Vec<f64>,
    feature: Vec<f64>,
}

impl Piece {
    fn new(points: &PointSet, params: &[f64], j0: usize, j1: usize, p: usize) -> Piece {
        let dim = points.dim();
        let t = params[j0..=j1].to_vec();
        let mut feature = vec![0.0; t.len()];
        if j1 - j0 > p {
            let sub = PointSet::from_flat_unchecked(
                dim,
                points.as_flat()[j0 * dim..(j1 + 1) * dim].to_vec(),
            );
            let (u, f) = feature_function(&sub, &t, p, true);
            // The integral of the piecewise linear feature function up to each data parameter.
            let mut s = 0;
            let mut acc = 0.0;
            for (k, &x) in t.iter().enumerate() {
                while s + 1 < u.len() && u[s + 1] <= x {
                    acc += 0.5 * (u[s + 1] - u[s]) * (f[s] + f[s + 1]);
                    s += 1;
                }
                let partial = if s + 1 < u.len() && x > u[s] {
                    let w = u[s + 1] - u[s];
                    let y = x - u[s];
                    f[s] * y + (f[s + 1] - f[s]) * y * y / (2.0 * w)
                } else {
                    0.0
                };
                feature[k] = acc + partial;
            }
            if !feature.iter().all(|x| x.is_finite()) {
                feature.iter_mut().for_each(|x| *x = 0.0);
            }
        }
        Piece { t, feature }
    }

    fn feature_total(&self) -> f64 {
        *self.feature.last().expect("at least two parameters")
    }

    fn mix(&self, w: &Mix, k: usize) -> f64 {
        w.feature * self.feature[k] + w.arc * (self.t[k] - self.t[0]) + w.count * k as f64
    }

    fn mass(&self, w: &Mix) -> f64 {
        self.mix(w, self.t.len() - 1)
    }

    /// The parameter where the mixed CDF reaches `level` (linear between data parameters).
    fn invert(&self, w: &Mix, level: f64) -> f64 {
        let last = self.t.len() - 1;
        let mut k = 0;
        while k + 1 < last && self.mix(w, k + 1) < level {
            k += 1;
        }
        let (ga, gb) = (self.mix(w, k), self.mix(w, k + 1));
        let (ta, tb) = (self.t[k], self.t[k + 1]);
        if gb <= ga {
            return ta;
        }
        (ta + (tb - ta) * ((level - ga) / (gb - ga)).clamp(0.0, 1.0)).clamp(ta, tb)
    }
}

/// Weights of the three CDFs, each already divided by its total over the whole line.
struct Mix {
    feature: f64,
    arc: f64,
    count: f64,
}

/// A clamped knot vector on [0, 1] for `n_ctrl` control points of degree `p` (`n_ctrl >= p + 1`,
/// `params` non-decreasing from 0 to 1, one per point).
pub fn place(
    points: &PointSet,
    params: &[f64],
    n_ctrl: usize,
    p: usize,
    cfg: &AdaptiveKnots,
) -> Vec<f64> {
    let interior_total = n_ctrl - p - 1;
    let max_corners = if p == 0 {
        0
    } else {
        ((cfg.corner_knot_share * interior_total as f64) / p as f64).floor() as usize
    };
    let corner_idx = corners(points, params, cfg.corner_angle_rad, max_corners);
    let n = points.len();
    let mut bounds = vec![0];
    bounds.extend(&corner_idx);
    bounds.push(n - 1);
    let pieces: Vec<Piece> = bounds
        .windows(2)
        .map(|w| Piece::new(points, params, w[0], w[1], p))
        .collect();
    let smooth = interior_total - p * corner_idx.len();
    let f_all: f64 = pieces.iter().map(Piece::feature_total).sum();
    let wa = cfg.arc_length_share.clamp(0.0, 1.0);
    let wc = cfg.count_share.clamp(0.0, 1.0 - wa);
    let mut wf = 1.0 - wa - wc;
    let mut wa = wa;
    if f_all <= 0.0 {
        // No curvature anywhere (great-circle arcs): arc length takes the feature's share.
        wa += wf;
        wf = 0.0;
    }
    let span = params[n - 1] - params[0];
    let mix = Mix {
        feature: if f_all > 0.0 { wf / f_all } else { 0.0 },
        arc: wa / span,
        count: wc / (n - 1) as f64,
    };
    let mass: Vec<f64> = pieces.iter().map(|pc| pc.mass(&mix)).collect();
    let counts = share_out(&mass, smooth);
    let gap = MIN_GAP_FRACTION / (n_ctrl - p) as f64;
    let mut knots = Vec::with_capacity(n_ctrl + p + 1);
    knots.extend(std::iter::repeat_n(0.0, p + 1));
    for (k, pc) in pieces.iter().enumerate() {
        let (a, b) = (pc.t[0], pc.t[pc.t.len() - 1]);
        if k > 0 {
            knots.extend(std::iter::repeat_n(a, p));
        }
        let m = counts[k];
        let mut inner: Vec<f64> = (1..=m)
            .map(|i| pc.invert(&mix, mass[k] * i as f64 / (m + 1) as f64))
            .collect();
        // Keep the piece's knots strictly inside it and a hair apart (no multiplicity above 1).
        let mut prev = a;
        for u in inner.iter_mut() {
            *u = u.max(prev + gap);
            prev = *u;
        }
        let mut next = b;
        for u in inner.iter_mut().rev() {
            *u = u.min(next - gap);
            next = *u;
        }
        knots.extend(inner);
    }
    knots.extend(std::iter::repeat_n(1.0, p + 1));
    knots
}

/// `total` shared out in proportion to `mass` (largest remainders; all to the largest mass when
/// every mass is zero).
fn share_out(mass: &[f64], total: usize) -> Vec<usize> {
    let sum: f64 = mass.iter().sum();
    let mut counts = vec![0usize; mass.len()];
    if total == 0 || mass.is_empty() {
        return counts;
    }
    if sum.is_nan() || sum <= 0.0 {
        counts[0] = total;
        return counts;
    }
    let exact: Vec<f64> = mass.iter().map(|m| m / sum * total as f64).collect();
    for (c, e) in counts.iter_mut().zip(&exact) {
        *c = e.floor() as usize;
    }
    let mut left = total - counts.iter().sum::<usize>();
    let mut order: Vec<usize> = (0..mass.len()).collect();
    order.sort_by(|&a, &b| (exact[b] - exact[b].floor()).total_cmp(&(exact[a] - exact[a].floor())));
    for &i in order.iter().cycle() {
        if left == 0 {
            break;
        }
        counts[i] += 1;
        left -= 1;
    }
    counts
}

/// One round of error-driven refinement: every knot span (of positive width) holding a data
/// parameter whose error exceeds `threshold` gets a knot, at most `max_new` spans (the largest
/// errors first). Where the worst point of the span is a corner (it turns by at least
/// `corner_angle_rad`, `turns` from [`turning_angles`]) the new knot sits at that point with
/// multiplicity p (a C0 joint, so the curve may turn there); elsewhere it splits the span
/// between its two middle data parameters, so that both halves keep at least
/// [`REFINE_MIN_POINTS`] (a span without data leaves its control points free to swing away from
/// the line). `None` when no span needs or can take a knot.
///
/// The default Earth fit starts from [`place`] at a quarter of the positions and refines where
/// the curve misses the line by more than a share of its median step, so knots go where the
/// line needs them rather than everywhere (`earth::curve::fitting`).
#[allow(clippy::too_many_arguments)]
pub fn refine(
    knots: &[f64],
    p: usize,
    params: &[f64],
    errors: &[f64],
    turns: &[f64],
    corner_angle_rad: f64,
    threshold: f64,
    max_new: usize,
) -> Option<Vec<f64>> {
    let n_ctrl = knots.len() - p - 1;
    // Worst error (and where) and the data parameters per span (span k: knots[k] <= t <
    // knots[k + 1], p <= k < n_ctrl).
    let mut worst = vec![0.0f64; knots.len()];
    let mut worst_at = vec![0usize; knots.len()];
    let mut first = vec![usize::MAX; knots.len()];
    let mut count = vec![0usize; knots.len()];
    let mut k = p;
    for (j, (&t, &e)) in params.iter().zip(errors).enumerate() {
        while k + 1 < n_ctrl && t >= knots[k + 1] {
            k += 1;
        }
        if e > worst[k] {
            worst[k] = e;
            worst_at[k] = j;
        }
        if count[k] == 0 {
            first[k] = j;
        }
        count[k] += 1;
    }
    // An interior knot of multiplicity 1, which a joint next to it may replace.
    let simple =
        |i: usize| i > p && i < n_ctrl && knots[i - 1] < knots[i] && knots[i] < knots[i + 1];
    let mut dropped: Vec<usize> = Vec::new();
    let mut split: Vec<(usize, f64, usize)> = (p..n_ctrl)
        .filter(|&k| worst[k] > threshold)
        .filter_map(|k| {
            let j = worst_at[k];
            let u = params[j];
            if turns[j] >= corner_angle_rad && u > knots[k] && u < knots[k + 1] {
                // A joint within a quarter span of a simple knot replaces it: the short span
                // left between them held too few data for its control points, and the cubic
                // there looped away from the line while passing near its positions (1.8 km
                // in 60 m of the Ireland–United Kingdom border, 10m).
                let w = knots[k + 1] - knots[k];
                if u - knots[k] < JOINT_NEAR_SHARE * w && simple(k) {
                    dropped.push(k);
                } else if knots[k + 1] - u < JOINT_NEAR_SHARE * w && simple(k + 1) {
                    dropped.push(k + 1);
                }
                return Some((k, u, p));
            }
            if count[k] < 2 * REFINE_MIN_POINTS {
                return None;
            }
            let mid = first[k] + count[k] / 2;
            let u = 0.5 * (params[mid - 1] + params[mid]);
            (u > knots[k] && u < knots[k + 1]).then_some((k, u, 1))
        })
        .collect();
    if max_new == 0 || split.is_empty() {
        return None;
    }
    split.sort_by(|a, b| worst[b.0].total_cmp(&worst[a.0]).then(a.0.cmp(&b.0)));
    let mut added = 0;
    split.retain(|s| {
        added += s.2;
        added <= max_new
    });
    if split.is_empty() {
        return None;
    }
    split.sort_unstable_by_key(|s| s.0);
    // Only the knots next to joints that are kept.
    dropped.retain(|&i| split.iter().any(|s| s.2 > 1 && (s.0 == i || s.0 + 1 == i)));
    let mut out = Vec::with_capacity(knots.len() + added);
    let mut s = split.iter().peekable();
    for (k, &u) in knots.iter().enumerate() {
        if !dropped.contains(&k) {
            out.push(u);
        }
        if let Some(&&(_, v, mult)) = s.peek().filter(|x| x.0 == k) {
            out.extend(std::iter::repeat_n(v, mult));
            s.next();
        }
    }
    Some(out)
}

/// A joint this close to a simple knot (as a share of the span) replaces it.
pub const JOINT_NEAR_SHARE: f64 = 0.25;

/// A span is split between data parameters only if each half keeps at least this many.
pub const REFINE_MIN_POINTS: usize = 2;

#[cfg(test)]
mod tests {
    use super::*;

    /// 51 evenly spaced parameters, the error high only at `at`, a sharp turn there.
    fn one_bad_point(at: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let params: Vec<f64> = (0..=50).map(|j| j as f64 / 50.0).collect();
        let mut errors = vec![0.0; params.len()];
        let mut turns = vec![0.0; params.len()];
        errors[at] = 1.0;
        turns[at] = 1.5;
        (params, errors, turns)
    }

    #[test]
    fn a_joint_next_to_a_simple_knot_replaces_it() {
        let knots = [0.0, 0.0, 0.0, 0.0, 0.3, 0.5, 1.0, 1.0, 1.0, 1.0];
        // t = 0.32: 0.02 from the knot 0.3 in a span of 0.2.
        let (params, errors, turns) = one_bad_point(16);
        let out = refine(&knots, 3, &params, &errors, &turns, 0.8, 0.5, 10).unwrap();
        assert_eq!(
            out,
            vec![0.0, 0.0, 0.0, 0.0, 0.32, 0.32, 0.32, 0.5, 1.0, 1.0, 1.0, 1.0]
        );
    }

    #[test]
    fn a_joint_mid_span_keeps_the_knots_around_it() {
        let knots = [0.0, 0.0, 0.0, 0.0, 0.3, 0.5, 1.0, 1.0, 1.0, 1.0];
        let (params, errors, turns) = one_bad_point(20);
        let out = refine(&knots, 3, &params, &errors, &turns, 0.8, 0.5, 10).unwrap();
        assert_eq!(
            out,
            vec![0.0, 0.0, 0.0, 0.0, 0.3, 0.4, 0.4, 0.4, 0.5, 1.0, 1.0, 1.0, 1.0]
        );
    }

    #[test]
    fn a_clamped_end_or_a_joint_is_never_dropped() {
        // t = 0.02, next to the clamped start; t = 0.52, next to a joint at 0.5.
        let knots = [0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.5, 1.0, 1.0, 1.0, 1.0];
        for (at, want) in [(1, 0.02), (26, 0.52)] {
            let (params, errors, turns) = one_bad_point(at);
            let out = refine(&knots, 3, &params, &errors, &turns, 0.8, 0.5, 10).unwrap();
            assert_eq!(out.len(), knots.len() + 3, "{out:?}");
            assert_eq!(out.iter().filter(|&&u| u == want).count(), 3, "{out:?}");
            assert_eq!(out.iter().filter(|&&u| u == 0.5).count(), 3, "{out:?}");
        }
    }
}
