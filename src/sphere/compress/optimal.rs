//! The optimal subset polyline on S^n: the fewest input vertices (ends kept) such that every
//! input point is within a tolerance of the output segment that spans it. The compression bench
//! (`examples/compression.rs`) compares [`fit_to_tolerance`](super::tolerance::fit_to_tolerance)
//! and [`douglas_peucker`](super::simplify::douglas_peucker) with it.
//!
//! # What is optimal
//! A *shortcut* `i -> j` (i < j) is valid when every point `k` in `i < k < j` is within `T`
//! of the minor arc `p_i p_j`, measured by [`distance_to_arc`] (the same cross-track distance
//! Douglas–Peucker uses), and `p_i`, `p_j` are not (nearly) antipodal (such a pair has no minor
//! arc; Douglas–Peucker always splits it too). `i -> i + 1` is always valid. The result is a
//! shortest path from 0 to n − 1 in this graph (Imai & Iri 1988, "Polygonal approximations of
//! a curve — formulations and algorithms"), so it never keeps more vertices than
//! Douglas–Peucker, whose segments are valid shortcuts.
//!
//! # How it avoids the O(n³) graph (S^2)
//! Write `D_A(q, u)` for the distance from `q` to the half great circle leaving `A` in the
//! tangent direction `u`. For an arc `AB` shorter than π/2 and a point `q` within π/2 of both
//! ends, `d(q, AB) = max(D_A(q, u_AB), D_B(q, u_BA))` (the two half circles overlap exactly in
//! `AB`; outside it the nearer end is the one the other half circle does not reach). With
//! `ρ = d(A, q)` and `α` the angle at `A` between `u` and the direction to `q`,
//! `D_A <= T` iff `ρ <= T` or `α <= asin(sin T / sin ρ)` (spherical right triangle, the foot
//! ahead of `A`). So the directions from `A` that pass every point of `A+1 .. j−1` form an
//! intersection of *wedges* (arcs of the circle of directions, each narrower than π: one
//! interval), as in Chan & Chin (1992) for the plane. From each `i` the forward wedge is swept
//! over `j` in O(1) per step; since it only shrinks, once it is empty no shortcut `i -> j` to a
//! later `j` can be valid, and the sweep stops: **this cut is exact, not a heuristic**. A
//! backward sweep from each `j` does the same at `B`; a shortcut is valid iff both sweeps pass
//! it. Points farther than π/2 − 10⁻⁶ from the apex empty the wedge (they are more than `T`
//! from any short arc at that apex).
//!
//! Rounding: each sweep runs twice, at `T − δ` and `T + δ` (`δ = 10⁻¹² + 10⁻⁸ T`). A shortcut
//! inside both inner wedges is valid, outside either outer wedge invalid; the rare ones between
//! (and arcs under [`WELL_CONDITIONED_ARC_RAD`], whose direction is ill-defined) are decided by
//! [`distance_to_arc`] on every point. So the graph is exactly the one [`distance_to_arc`]
//! defines (the tests compare it with that graph, built in O(n³)).
//!
//! Shortcuts of π/2 − T − 10⁻⁶ or longer (a line spanning a quarter of the Earth) are checked
//! point by point, with the first point out of tolerance ending the check; only pairs whose
//! polyline path is that long are looked at. On S^n with n > 2 the directions form a
//! (n−1)-sphere and the wedges are round cones: there every candidate is checked point by point,
//! and the sweep stops when two cones are disjoint (also exact).
//!
//! # Cost
//! S^2: O(Σ_i w_i) time, `w_i` the sweep length from `i` (how far the wedge stays open: about
//! the longest shortcut from `i`), so O(n²) only for a line that is straight within `T`; O(n)
//! memory (the open sweeps' states), plus the shortcuts of a quarter circle or longer found.
//! S^n, n > 2: O(Σ_i w_i²) time.

use crate::sphere::geometry::arc::{distance_to_arc, ArcFrame};
use crate::sphere::geometry::point::{
    angle, dot, normalize, Dim, Fixed, PointSet, ANTIPODAL_MARGIN_RAD,
};
use std::f64::consts::{FRAC_PI_2, PI};

/// A point this far (or farther) from a wedge's apex empties it: it lies more than the
/// tolerance from every arc at the apex that the wedges decide (see [`short_arc_limit`]).
const FAR_FROM_APEX_RAD: f64 = FRAC_PI_2 - 1e-6;

/// Shortcuts shorter than this have a tangent direction at their ends accurate to
/// ~10⁻¹⁶ / 10⁻⁷ = 10⁻⁹ rad, so the wedge tests stay within the rounding margin
/// (`rounding_margin`) for tolerances up to ~10⁻³ rad and points within the tolerance of
/// the arc; shorter ones are checked point by point.
pub const WELL_CONDITIONED_ARC_RAD: f64 = 1e-7;

/// The band around the tolerance where the wedge tests defer to [`distance_to_arc`]: their
/// rounding (about 10⁻¹⁶ rad, 10⁻⁹ T for short arcs) stays far inside it.
fn rounding_margin(tolerance_rad: f64) -> f64 {
    1e-12 + 1e-8 * tolerance_rad
}

/// Arcs at least this long are not decided by wedges: the wedge argument needs the arc shorter
/// than π/2 and every point that matters within [`FAR_FROM_APEX_RAD`] of both ends.
fn short_arc_limit(outer_tolerance_rad: f64) -> f64 {
    FAR_FROM_APEX_RAD - outer_tolerance_rad - 1e-9
}

/// The optimal subset polyline: the indices (ascending, first and last always kept) of the
/// fewest input points such that every point is within `tolerance_rad` (geodesic, radians) of
/// the minor arc between the kept vertices that bracket it (see the module docs). Ties between
/// equally short subsets are broken towards the earliest predecessor.
///
/// A non-positive or NaN tolerance keeps every point (as Douglas–Peucker does).
///
/// # Example
/// ```
/// use spherefit::sphere::{compress::optimal::optimal_subset, compress::simplify::douglas_peucker, PointSet};
/// // A zig-zag of amplitude 1e-4 rad along the equator: at 2e-4 it is one arc.
/// let rows: Vec<[f64; 3]> = (0..50)
///     .map(|i| { let (lon, lat): (f64, f64) = (0.01 * i as f64, if i % 2 == 0 { 0.0 } else { 1e-4 }); [lat.cos() * lon.cos(), lat.cos() * lon.sin(), lat.sin()] })
///     .collect();
/// let line = PointSet::try_from_rows(&rows).unwrap();
/// assert_eq!(optimal_subset(&line, 2e-4), vec![0, 49]);
/// assert!(optimal_subset(&line, 5e-5).len() <= douglas_peucker(&line, 5e-5).len());
/// ```
pub fn optimal_subset(points: &PointSet, tolerance_rad: f64) -> Vec<usize> {
    let n = points.len();
    if n <= 2 {
        return (0..n).collect();
    }
    let mut paths = Paths::new(n);
    for_each_shortcut(points, tolerance_rad, |i, j| paths.relax(i, j));
    paths.path()
}

/// Shortest paths from vertex 0, fed shortcuts `(i, j)` in an order where every shortcut into
/// `i` comes before any out of `i`.
struct Paths {
    hops: Vec<u32>,
    pred: Vec<u32>,
}

impl Paths {
    fn new(n: usize) -> Paths {
        let mut hops = vec![u32::MAX; n];
        hops[0] = 0;
        Paths {
            hops,
            pred: vec![0; n],
        }
    }

    fn relax(&mut self, i: usize, j: usize) {
        debug_assert!(self.hops[i] != u32::MAX, "shortcuts into {i} come first");
        let h = self.hops[i] + 1;
        if h < self.hops[j] || (h == self.hops[j] && (i as u32) < self.pred[j]) {
            self.hops[j] = h;
            self.pred[j] = i as u32;
        }
    }

    fn path(&self) -> Vec<usize> {
        let mut out = vec![self.hops.len() - 1];
        while let Some(&v) = out.last() {
            if v == 0 {
                break;
            }
            out.push(self.pred[v] as usize);
        }
        out.reverse();
        out
    }
}

/// Calls `f(i, j)` once for every valid shortcut `i -> j` (the graph of the module docs),
/// every shortcut into a vertex before any out of it.
fn for_each_shortcut(points: &PointSet, tolerance_rad: f64, mut f: impl FnMut(usize, usize)) {
    let n = points.len();
    if tolerance_rad.is_nan() || tolerance_rad <= 0.0 {
        (1..n).for_each(|j| f(j - 1, j));
        return;
    }
    let margin = rounding_margin(tolerance_rad);
    let outer = tolerance_rad + margin;
    let short = short_arc_limit(outer);
    let long = long_shortcuts(points, tolerance_rad, short);
    if points.dim() == 3 {
        sweep_s2(points, tolerance_rad, margin, short, &long, &mut f);
    } else {
        crate::with_dim!(points.dim(), |d| sweep_cones(
            d,
            points,
            tolerance_rad,
            short,
            &long,
            &mut f
        ));
    }
}

/// Every point of `i+1 .. j-1` is within `tolerance_rad` of the arc `p_i p_j`, and that arc
/// is a minor arc (ends not nearly antipodal).
fn valid_by_points<D: Dim>(
    d: D,
    points: &PointSet,
    i: usize,
    j: usize,
    tolerance_rad: f64,
) -> bool {
    let frame = ArcFrame::new(d, points.get(i), points.get(j));
    if frame.theta > PI - ANTIPODAL_MARGIN_RAD {
        return false;
    }
    (i + 1..j).all(|k| frame.distance(d, points.get(k)) <= tolerance_rad)
}

/// Valid shortcuts whose arc is at least `short` long, grouped by their end `j` (ascending
/// `i` within each): only pairs whose polyline path is at least that long are candidates.
fn long_shortcuts(points: &PointSet, tolerance_rad: f64, short: f64) -> Vec<Vec<usize>> {
    let n = points.len();
    let mut by_end: Vec<Vec<usize>> = vec![Vec::new(); n];
    let mut path = Vec::with_capacity(n);
    let mut total = 0.0;
    for k in 0..n {
        if k > 0 {
            total +=
                crate::sphere::geometry::point::angle_between(points.get(k - 1), points.get(k));
        }
        path.push(total);
    }
    crate::with_dim!(points.dim(), |d| {
        for i in 0..n {
            // d(p_i, p_j) <= path length from i to j: shorter paths cannot give long arcs.
            let first = path.partition_point(|&s| s - path[i] < short).max(i + 2);
            for j in first..n {
                if angle(d, points.get(i), points.get(j)) >= short
                    && valid_by_points(d, points, i, j, tolerance_rad)
                {
                    by_end[j].push(i);
                }
            }
        }
    });
    by_end
}

/// What a wedge sweep says about one shortcut.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Verdict {
    /// Inside the inner wedge: valid at this end.
    Yes,
    /// Between the wedges, or too short for a direction: check point by point.
    Maybe,
    /// Outside the outer wedge, or long (handled by [`long_shortcuts`]).
    No,
}

/// The circle of tangent directions at a point of S^2, as angles in an orthonormal tangent frame.
struct Apex {
    p: [f64; 3],
    e1: [f64; 3],
    e2: [f64; 3],
}

impl Apex {
    fn new(p: &[f64]) -> Apex {
        let p = [p[0], p[1], p[2]];
        // The axis least aligned with p, made tangent.
        let k = (0..3)
            .min_by(|&a, &b| p[a].abs().total_cmp(&p[b].abs()))
            .unwrap_or(0);
        let mut e1 = [0.0; 3];
        e1[k] = 1.0;
        let c = p[k];
        (0..3).for_each(|m| e1[m] -= c * p[m]);
        normalize(Fixed::<3>, &mut e1);
        let e2 = [
            p[1] * e1[2] - p[2] * e1[1],
            p[2] * e1[0] - p[0] * e1[2],
            p[0] * e1[1] - p[1] * e1[0],
        ];
        Apex { p, e1, e2 }
    }

    /// Distance from the apex to `q` and the direction angle of `q` at the apex.
    fn polar(&self, q: &[f64]) -> (f64, f64) {
        let d = Fixed::<3>;
        let rho = angle(d, &self.p, q);
        let phi = dot(d, q, &self.e2).atan2(dot(d, q, &self.e1));
        (rho, phi)
    }
}

/// The directions at an apex whose half great circle passes within `tolerance` of every point
/// added so far: one interval of angles, relative to the first constraining point's direction
/// (each constraint is narrower than π, so the intersection never wraps).
struct Wedge {
    tolerance: f64,
    reference: Option<f64>,
    lo: f64,
    hi: f64,
    empty: bool,
}

/// `x` wrapped into (−π, π].
fn wrap(x: f64) -> f64 {
    let mut y = x % (2.0 * PI);
    if y > PI {
        y -= 2.0 * PI;
    } else if y <= -PI {
        y += 2.0 * PI;
    }
    y
}

impl Wedge {
    fn new(tolerance: f64) -> Wedge {
        Wedge {
            tolerance,
            reference: None,
            lo: f64::NEG_INFINITY,
            hi: f64::INFINITY,
            empty: false,
        }
    }

    /// Adds the point at distance `rho`, direction `phi` from the apex.
    fn add(&mut self, rho: f64, phi: f64) {
        if self.empty || rho <= self.tolerance {
            return;
        }
        if rho >= FAR_FROM_APEX_RAD || self.tolerance <= 0.0 {
            self.empty = true;
            return;
        }
        let half = (self.tolerance.sin() / rho.sin()).asin();
        let reference = *self.reference.get_or_insert(phi);
        let c = wrap(phi - reference);
        self.lo = self.lo.max(c - half);
        self.hi = self.hi.min(c + half);
        self.empty = self.lo > self.hi;
    }

    fn contains(&self, phi: f64) -> bool {
        if self.empty {
            return false;
        }
        match self.reference {
            None => true,
            Some(r) => (self.lo..=self.hi).contains(&wrap(phi - r)),
        }
    }
}

/// One sweep from an apex: the inner and outer wedges.
struct Sweep {
    inner: Wedge,
    outer: Wedge,
    short: f64,
}

impl Sweep {
    /// The verdict on the shortcut from the apex to the point at (`c`, `phi`), then that point
    /// added as a constraint for the shortcuts beyond it. `adjacent`: no point lies between.
    fn step(&mut self, c: f64, phi: f64, adjacent: bool) -> Verdict {
        let v = if adjacent {
            Verdict::Yes
        } else if c >= self.short {
            Verdict::No
        } else if c < WELL_CONDITIONED_ARC_RAD {
            if self.outer.empty {
                Verdict::No
            } else {
                Verdict::Maybe
            }
        } else if self.inner.contains(phi) {
            Verdict::Yes
        } else if self.outer.contains(phi) {
            Verdict::Maybe
        } else {
            Verdict::No
        };
        self.inner.add(c, phi);
        self.outer.add(c, phi);
        v
    }
}

/// A forward sweep still open: its apex `start`, swept up to the current end.
struct OpenSweep {
    start: usize,
    apex: Apex,
    sweep: Sweep,
}

/// Both sweeps run together, ends `j` ascending: the forward sweeps from every `i` whose outer
/// wedge is still open advance by one point per `j` (so only their states are kept: O(open)
/// memory, not the O(n²) of stored verdicts), then the backward sweep from `j` meets them.
fn sweep_s2(
    points: &PointSet,
    tolerance_rad: f64,
    margin: f64,
    short: f64,
    long: &[Vec<usize>],
    f: &mut impl FnMut(usize, usize),
) {
    let n = points.len();
    let new_sweep = || Sweep {
        inner: Wedge::new(tolerance_rad - margin),
        outer: Wedge::new(tolerance_rad + margin),
        short,
    };
    let d = Fixed::<3>;
    let mut open: Vec<OpenSweep> = Vec::new();
    // The forward verdict on `i -> j` for the current `j` (No for sweeps already closed).
    let mut forward = vec![Verdict::No; n];
    for j in 1..n {
        open.push(OpenSweep {
            start: j - 1,
            apex: Apex::new(points.get(j - 1)),
            sweep: new_sweep(),
        });
        let q = points.get(j);
        for s in open.iter_mut() {
            let (c, phi) = s.apex.polar(q);
            forward[s.start] = s.sweep.step(c, phi, s.start + 1 == j);
        }
        let apex = Apex::new(q);
        let mut sweep = new_sweep();
        for i in (0..j).rev() {
            let (c, phi) = apex.polar(points.get(i));
            let back = sweep.step(c, phi, i + 1 == j);
            let valid = match (forward[i], back) {
                (Verdict::No, _) | (_, Verdict::No) => false,
                (Verdict::Yes, Verdict::Yes) => true,
                _ => valid_by_points(d, points, i, j, tolerance_rad),
            };
            if valid {
                f(i, j);
            }
            if sweep.outer.empty {
                break;
            }
        }
        for &i in &long[j] {
            f(i, j);
        }
        for s in &open {
            forward[s.start] = Verdict::No;
        }
        // An empty outer wedge stays empty: no later shortcut from that start is short-valid.
        open.retain(|s| !s.sweep.outer.empty);
    }
}

/// S^n, n > 2: candidates checked point by point; the sweep from `i` stops when the cones of
/// directions (outer tolerance) of two points are disjoint.
fn sweep_cones<D: Dim>(
    d: D,
    points: &PointSet,
    tolerance_rad: f64,
    short: f64,
    long: &[Vec<usize>],
    f: &mut impl FnMut(usize, usize),
) {
    let n = points.len();
    let outer = tolerance_rad + rounding_margin(tolerance_rad);
    let dim = d.get();
    let mut long_from: Vec<Vec<usize>> = vec![Vec::new(); n];
    for (j, starts) in long.iter().enumerate() {
        for &i in starts {
            long_from[i].push(j);
        }
    }
    for i in 0..n - 1 {
        let p = points.get(i);
        let mut cones: Vec<(Vec<f64>, f64)> = Vec::new();
        for j in i + 1..n {
            let q = points.get(j);
            let c = angle(d, p, q);
            if j == i + 1 || (c < short && valid_by_points(d, points, i, j, tolerance_rad)) {
                f(i, j);
            }
            if c <= outer {
                continue;
            }
            if c >= FAR_FROM_APEX_RAD {
                break;
            }
            let pq = dot(d, p, q);
            let mut w: Vec<f64> = (0..dim).map(|k| q[k] - pq * p[k]).collect();
            normalize(d, &mut w);
            let half = (outer.sin() / c.sin()).asin();
            let disjoint = cones
                .iter()
                .any(|(v, h)| angle(d, v, &w) > h + half + 1e-12);
            if disjoint {
                break;
            }
            cones.push((w, half));
        }
        for &j in &long_from[i] {
            f(i, j);
        }
    }
}

/// Is `kept` (ascending, ends included) a subset polyline within `tolerance_rad` by the
/// definition of the module docs? For tests and the bench; O(n).
pub fn subset_within(points: &PointSet, kept: &[usize], tolerance_rad: f64) -> bool {
    let n = points.len();
    if kept.first() != Some(&0) || kept.last() != Some(&(n - 1)) {
        return false;
    }
    kept.windows(2).all(|w| {
        w[0] < w[1]
            && (w[1] == w[0] + 1
                || (crate::sphere::geometry::point::angle_between(
                    points.get(w[0]),
                    points.get(w[1]),
                ) <= PI - ANTIPODAL_MARGIN_RAD
                    && (w[0] + 1..w[1]).all(|k| {
                        distance_to_arc(points.get(k), points.get(w[0]), points.get(w[1]))
                            <= tolerance_rad
                    })))
    })
}

/// A subset polyline (`kept`: ascending indices, ends included, such as [`optimal_subset`] or
/// [`douglas_peucker`](super::simplify::douglas_peucker) return) as what the certified two-way
/// distance measures: a degree-1 spline through the kept points on uniform knots (none stored,
/// [`KnotRule::Uniform`](super::tolerance::KnotRule)), and each input point's parameter at the
/// foot of its perpendicular on the segment that spans it (clamped to the segment, then kept
/// non-decreasing, the ends at 0 and 1): the ordered matching of
/// [`two_way_distance`](crate::sphere::certify::two_way::two_way_distance).
///
/// # Errors
/// From [`SphericalBSpline::try_new`](crate::sphere::SphericalBSpline::try_new): fewer than 2
/// kept points or (nearly) antipodal kept neighbours.
///
/// # Panics
/// If `kept` does not start at 0, end at the last point and increase.
pub fn subset_curve(
    points: &PointSet,
    kept: &[usize],
) -> Result<(crate::sphere::SphericalBSpline, Vec<f64>), crate::sphere::SphereError> {
    let n = points.len();
    assert!(
        kept.first() == Some(&0)
            && kept.last() == Some(&(n - 1))
            && kept.windows(2).all(|w| w[0] < w[1]),
        "kept indices run from 0 to the last point, increasing"
    );
    let m = kept.len();
    let ctrl = points.subset(kept);
    let spline = crate::sphere::SphericalBSpline::try_new(
        1,
        crate::sphere::curve::bspline::clamped_uniform_knots(m, 1),
        ctrl,
    )?;
    let mut params = Vec::with_capacity(n);
    params.push(0.0);
    let mut last: f64 = 0.0;
    crate::with_dim!(points.dim(), |d| {
        for w in 0..m - 1 {
            let frame = ArcFrame::new(d, points.get(kept[w]), points.get(kept[w + 1]));
            for j in kept[w] + 1..=kept[w + 1] {
                let frac = if j == kept[w + 1] {
                    1.0
                } else if frame.degenerate() {
                    0.0
                } else {
                    let q = points.get(j);
                    let phi = dot(d, q, &frame.e2).atan2(dot(d, q, &frame.e1));
                    (phi / frame.theta).clamp(0.0, 1.0)
                };
                let t = ((w as f64 + frac) / (m - 1) as f64).max(last);
                last = t;
                params.push(t);
            }
        }
    });
    params[n - 1] = 1.0;
    Ok((spline, params))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sphere::compress::simplify::douglas_peucker;
    use proptest::prelude::*;

    /// The graph of the module docs, built point by point in O(n³).
    fn brute_force_edges(points: &PointSet, tol: f64) -> Vec<(usize, usize)> {
        let n = points.len();
        let mut out = Vec::new();
        for j in 1..n {
            for i in 0..j {
                if subset_within_pair(points, i, j, tol) {
                    out.push((i, j));
                }
            }
        }
        out
    }

    fn subset_within_pair(points: &PointSet, i: usize, j: usize, tol: f64) -> bool {
        if j == i + 1 {
            return true;
        }
        let (a, b) = (points.get(i), points.get(j));
        crate::sphere::geometry::point::angle_between(a, b) <= PI - ANTIPODAL_MARGIN_RAD
            && (i + 1..j).all(|k| distance_to_arc(points.get(k), a, b) <= tol)
    }

    /// Fewest vertices by breadth-first search over the brute-force graph.
    fn brute_force_count(points: &PointSet, tol: f64) -> usize {
        let n = points.len();
        let edges = brute_force_edges(points, tol);
        let mut hops = vec![usize::MAX; n];
        hops[0] = 0;
        for (i, j) in edges {
            // Edges come ordered by their end, so hops[i] is final.
            hops[j] = hops[j].min(hops[i] + 1);
        }
        hops[n - 1] + 1
    }

    fn fast_edges(points: &PointSet, tol: f64) -> Vec<(usize, usize)> {
        let mut out = Vec::new();
        for_each_shortcut(points, tol, |i, j| out.push((i, j)));
        out.sort_unstable_by_key(|&(i, j)| (j, i));
        out
    }

    /// A random walk on S^(dim-1) with steps of `step` rad, turning by up to `turn` rad, with
    /// some repeated points and some steps backwards.
    fn walk(dim: usize, n: usize, step: f64, turn: f64, seed: u64) -> PointSet {
        let mut state = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let mut rnd = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64) / ((1u64 << 53) as f64)
        };
        let mut p = vec![0.0; dim];
        p[0] = 1.0;
        let mut dir = vec![0.0; dim];
        dir[1] = 1.0;
        let mut rows = vec![p.clone()];
        for _ in 1..n {
            let r = rnd();
            if r < 0.05 {
                rows.push(p.clone());
                continue;
            }
            // Turn: mix in a random tangent vector.
            let mut t: Vec<f64> = (0..dim).map(|_| rnd() - 0.5).collect();
            let pt: f64 = (0..dim).map(|k| t[k] * p[k]).sum();
            (0..dim).for_each(|k| t[k] -= pt * p[k]);
            let tn = (t.iter().map(|x| x * x).sum::<f64>()).sqrt();
            let dt: f64 = (0..dim).map(|k| t[k] * dir[k]).sum::<f64>() / tn;
            let a = turn * (2.0 * rnd() - 1.0);
            let mut nd: Vec<f64> = (0..dim)
                .map(|k| dir[k] * a.cos() + (t[k] / tn - dt * dir[k]) * a.sin())
                .collect();
            let l = (nd.iter().map(|x| x * x).sum::<f64>()).sqrt();
            nd.iter_mut().for_each(|x| *x /= l);
            let s = if r < 0.12 {
                -step
            } else {
                step * (0.2 + rnd())
            };
            let np: Vec<f64> = (0..dim).map(|k| p[k] * s.cos() + nd[k] * s.sin()).collect();
            // Parallel transport of the direction (keep it tangent).
            let mut tdir: Vec<f64> = (0..dim).map(|k| nd[k] * s.cos() - p[k] * s.sin()).collect();
            let pn: f64 = (0..dim).map(|k| tdir[k] * np[k]).sum();
            (0..dim).for_each(|k| tdir[k] -= pn * np[k]);
            let l = (tdir.iter().map(|x| x * x).sum::<f64>()).sqrt();
            tdir.iter_mut().for_each(|x| *x /= l);
            p = np;
            dir = tdir;
            rows.push(p.clone());
        }
        PointSet::try_from_rows(&rows).unwrap()
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(160))]

        /// The accelerated graph is the brute-force graph, so the subset is as short as the
        /// breadth-first search finds; it meets the tolerance and never loses to DP.
        #[test]
        fn equals_the_exhaustive_graph(
            seed in any::<u64>(),
            dim in prop::sample::select(vec![3usize, 3, 3, 4, 5]),
            n in 3usize..40,
            scale in prop::sample::select(vec![1e-6, 1e-4, 1e-2, 0.3]),
            turn in prop::sample::select(vec![0.05, 0.5, 2.0]),
            ratio in prop::sample::select(vec![0.1, 0.5, 2.0, 10.0]),
        ) {
            let points = walk(dim, n, scale, turn, seed);
            let tol = ratio * scale;
            prop_assert_eq!(fast_edges(&points, tol), brute_force_edges(&points, tol));
            let kept = optimal_subset(&points, tol);
            prop_assert_eq!(kept.len(), brute_force_count(&points, tol));
            prop_assert!(subset_within(&points, &kept, tol));
            prop_assert!(crate::sphere::compress::simplify::max_deviation(&points, &kept) <= tol);
            let dp = douglas_peucker(&points, tol);
            prop_assert!(kept.len() <= dp.len(), "{} > DP {}", kept.len(), dp.len());
        }
    }

    #[test]
    fn lines_longer_than_a_quarter_circle_use_long_shortcuts() {
        // Points along the equator over 300 degrees, with a 1e-3 bump every 7th point: at
        // 2e-3 only the ends and no bump are needed, but no arc may exceed pi (antipodal).
        let rows: Vec<[f64; 3]> = (0..301)
            .map(|i| {
                let lon = (i as f64).to_radians();
                let lat: f64 = if i % 7 == 3 { 1e-3 } else { 0.0 };
                [lat.cos() * lon.cos(), lat.cos() * lon.sin(), lat.sin()]
            })
            .collect();
        let points = PointSet::try_from_rows(&rows).unwrap();
        let kept = optimal_subset(&points, 2e-3);
        assert_eq!(kept.len(), brute_force_count(&points, 2e-3));
        assert_eq!(kept.len(), 3, "{kept:?}");
        assert!(subset_within(&points, &kept, 2e-3));
        // Below the bump height every bump is a vertex.
        let fine = optimal_subset(&points, 5e-4);
        assert!(fine.len() > 44, "{}", fine.len());
        assert!(subset_within(&points, &fine, 5e-4));
    }

    #[test]
    fn corner_and_degenerate_inputs() {
        let on = |lon: f64, lat: f64| [lat.cos() * lon.cos(), lat.cos() * lon.sin(), lat.sin()];
        // An L: east then north, 20 points each; the corner must be kept.
        let mut rows: Vec<[f64; 3]> = (0..20).map(|i| on(i as f64 * 1e-3, 0.0)).collect();
        rows.extend((1..20).map(|i| on(19e-3, i as f64 * 1e-3)));
        let points = PointSet::try_from_rows(&rows).unwrap();
        assert_eq!(optimal_subset(&points, 1e-5), vec![0, 19, 38]);
        // All points equal but one, repeated points: still a valid subset.
        let rows = vec![
            on(0.0, 0.0),
            on(0.0, 0.0),
            on(1e-6, 0.0),
            on(0.0, 0.0),
            on(0.0, 0.0),
        ];
        let points = PointSet::try_from_rows(&rows).unwrap();
        let kept = optimal_subset(&points, 1e-7);
        assert_eq!(kept.len(), brute_force_count(&points, 1e-7));
        assert!(subset_within(&points, &kept, 1e-7));
        assert_eq!(optimal_subset(&points, 1e-5), vec![0, 4]);
        // Non-positive and NaN tolerances keep every point, two points stay two.
        assert_eq!(optimal_subset(&points, 0.0), vec![0, 1, 2, 3, 4]);
        assert_eq!(optimal_subset(&points, f64::NAN), vec![0, 1, 2, 3, 4]);
        let two = PointSet::try_from_rows(&rows[..2]).unwrap();
        assert_eq!(optimal_subset(&two, 1.0), vec![0, 1]);
    }

    #[test]
    fn a_subset_curve_is_certified_within_the_tolerance_on_a_forward_line() {
        use crate::sphere::certify::two_way::{two_way_distance, TwoWayOptions};
        // A forward-only wiggle (no backtracking): the ordered matching at the feet keeps every
        // vertex error at its cross-track distance, so the two-way distance meets T.
        let on = |lon: f64, lat: f64| [lat.cos() * lon.cos(), lat.cos() * lon.sin(), lat.sin()];
        let rows: Vec<[f64; 3]> = (0..200)
            .map(|i| on(i as f64 * 1e-4, 3e-5 * (i as f64 * 0.37).sin()))
            .collect();
        let points = PointSet::try_from_rows(&rows).unwrap();
        for tol in [5e-6, 2e-5, 1e-4] {
            let kept = optimal_subset(&points, tol);
            let (curve, params) = subset_curve(&points, &kept).unwrap();
            assert_eq!(curve.control_points().len(), kept.len());
            assert_eq!((params[0], params[199]), (0.0, 1.0));
            assert!(params.windows(2).all(|w| w[0] <= w[1]));
            let options = TwoWayOptions::default().with_precision_rad(1e-7 * tol);
            let tw = two_way_distance(&curve, &points, &params, &options).unwrap();
            assert!(!tw.budget_exhausted);
            // Within T up to the bulge of short arcs (1 + c^2/8) and the rounding slack.
            assert!(
                tw.upper_rad <= tol * (1.0 + 1e-6) + 2e-12,
                "{} > {tol}",
                tw.upper_rad
            );
            assert!(
                tw.lower_rad > 0.5 * tol,
                "{} is far below {tol}",
                tw.lower_rad
            );
            // Every kept point sits at its own knot.
            for (v, &i) in kept.iter().enumerate() {
                assert!((params[i] - v as f64 / (kept.len() - 1) as f64).abs() < 1e-15);
            }
        }
    }

    #[test]
    fn independent_check_rejects_bad_subsets() {
        let points = walk(3, 30, 1e-3, 0.5, 7);
        let kept = optimal_subset(&points, 1e-4);
        assert!(subset_within(&points, &kept, 1e-4));
        // Dropping any interior vertex of an optimal subset breaks it (else it was not optimal).
        for v in 1..kept.len() - 1 {
            let mut fewer = kept.clone();
            fewer.remove(v);
            assert!(
                !subset_within(&points, &fewer, 1e-4),
                "vertex {v} of {kept:?}"
            );
        }
        assert!(!subset_within(&points, &[0, 29], 1e-4));
        assert!(!subset_within(&points, &[1, 29], 1.0));
    }
}
