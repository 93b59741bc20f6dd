//! Spherical Douglas–Peucker: the baseline that [`fit_to_tolerance`](super::tolerance::fit_to_tolerance)
//! must beat.
//!
//! The error of a point is its *cross-track* distance to the simplified line: the geodesic
//! distance (radians) from the point to the minor great-circle arc between the two kept vertices
//! that bracket it, or to the nearer end of that arc when the closest point of the great circle
//! lies outside it ([`distance_to_arc`](crate::sphere::geometry::arc::distance_to_arc)). This works on any S^n: the arc spans a plane through
//! the origin, and the distance comes from the point's components in and out of that plane.
//!
//! The recursion of Douglas & Peucker (1973) runs on an explicit stack, so a million points, or
//! a pathological line that splits one vertex at a time, cannot overflow the call stack. Cost:
//! O(n log n) on typical lines, O(n²) in the worst case, like the planar algorithm.

use crate::sphere::geometry::arc::{chord_key, distance_key, ArcFrame};
use crate::sphere::geometry::point::{
    angle, angle_between, diff_sq, dot, Dim, PointSet, ANTIPODAL_MARGIN_RAD,
};

/// Spherical Douglas–Peucker: the indices of the points kept (ascending, always the first and
/// the last) so that every point lies within `tolerance_rad` of the minor arc between the kept
/// vertices that bracket it.
///
/// Repeated points are harmless. Two kept neighbours that are (nearly) antipodal have no minor
/// arc: such a segment is always split.
///
/// # Example
/// ```
/// use spherefit::sphere::{compress::simplify::douglas_peucker, PointSet};
/// let rows: Vec<[f64; 3]> = (0..5).map(|i| { let a = 0.1 * i as f64; [a.cos(), a.sin(), 0.0] }).collect();
/// let line = PointSet::try_from_rows(&rows).unwrap();
/// assert_eq!(douglas_peucker(&line, 1e-9), vec![0, 4]); // all on one great circle
/// ```
pub fn douglas_peucker(points: &PointSet, tolerance_rad: f64) -> Vec<usize> {
    let n = points.len();
    if n <= 2 {
        return (0..n).collect();
    }
    crate::with_dim!(points.dim(), |d| douglas_peucker_dim(
        d,
        points,
        tolerance_rad
    ))
}

fn douglas_peucker_dim<D: Dim>(d: D, points: &PointSet, tolerance_rad: f64) -> Vec<usize> {
    split_until_within(points.len(), distance_key(tolerance_rad), |i0, i1| {
        let frame = ArcFrame::new(d, points.get(i0), points.get(i1));
        if frame.is_antipodal() {
            return None;
        }
        Some(worst_of(i0, i1, |j| frame.distance_key(d, points.get(j))))
    })
}

/// The Douglas–Peucker recursion, on an explicit stack: ends 0 and n − 1 kept, and a span
/// (i0, i1) split at its worst interior point while that point's error exceeds `tolerance`.
/// `worst(i0, i1)` gives (error, index) of the worst point, or `None` when the span's kept
/// ends are (nearly) antipodal: such a span is split at its middle.
fn split_until_within(
    n: usize,
    tolerance: f64,
    mut worst: impl FnMut(usize, usize) -> Option<(f64, usize)>,
) -> Vec<usize> {
    if n <= 2 {
        return (0..n).collect();
    }
    let mut keep = vec![false; n];
    keep[0] = true;
    keep[n - 1] = true;
    let mut stack = vec![(0, n - 1)];
    while let Some((i0, i1)) = stack.pop() {
        if i1 <= i0 + 1 {
            continue;
        }
        let split = match worst(i0, i1) {
            None => Some((i0 + i1) / 2),
            Some((e, at)) => (e > tolerance).then_some(at),
        };
        if let Some(j) = split {
            keep[j] = true;
            stack.push((j, i1));
            stack.push((i0, j));
        }
    }
    (0..n).filter(|&i| keep[i]).collect()
}

/// The largest `error(j)` over the interior points of (i0, i1), and where: of equals, the one
/// nearest the middle, so that a line of equal errors (a regular zigzag) splits in halves and
/// costs n log n, not n².
fn worst_of(i0: usize, i1: usize, mut error: impl FnMut(usize) -> f64) -> (f64, usize) {
    let (mut worst, mut at) = (-1.0, i0 + 1);
    let mid = i0 + (i1 - i0) / 2;
    for j in i0 + 1..i1 {
        let e = error(j);
        if e > worst || (e == worst && j.abs_diff(mid) < at.abs_diff(mid)) {
            worst = e;
            at = j;
        }
    }
    (worst, at)
}

/// Douglas–Peucker for lines matched in order: every point within `tolerance_rad` of its chord
/// at an along-chord position that never goes back.
///
/// Plain Douglas–Peucker lets a chord cut across a fjord or an out-and-back spike whose points
/// all lie near the chord but run along it forwards and then backwards; matched in order (the
/// two-way distance of [`crate::sphere::certify::two_way`]), the points coming back are far from where
/// the curve already is. Here a point's error is its distance to the chord point at the
/// furthest along-chord position reached so far (its own when it is further on), so a kept
/// chord is within the tolerance of its points in order. Never fewer vertices than
/// [`douglas_peucker`] at the same tolerance.
///
/// # Example
/// ```
/// use spherefit::sphere::{compress::simplify::{douglas_peucker, douglas_peucker_ordered}, PointSet};
/// // Along the equator to 0.3 rad, back to 0.1, on to 0.5: every point is on one great circle.
/// let rows: Vec<[f64; 3]> = [0.0, 0.3, 0.1, 0.5]
///     .iter()
///     .map(|&a: &f64| [a.cos(), a.sin(), 0.0])
///     .collect();
/// let line = PointSet::try_from_rows(&rows).unwrap();
/// assert_eq!(douglas_peucker(&line, 1e-3), vec![0, 3]);
/// assert_eq!(douglas_peucker_ordered(&line, 1e-3), vec![0, 1, 2, 3]);
/// ```
pub fn douglas_peucker_ordered(points: &PointSet, tolerance_rad: f64) -> Vec<usize> {
    crate::with_dim!(points.dim(), |d| {
        let mut at_reach = vec![0.0; d.get()];
        // Distances compared by their keys, as in [`douglas_peucker`].
        split_until_within(points.len(), distance_key(tolerance_rad), |i0, i1| {
            let frame = ArcFrame::new(d, points.get(i0), points.get(i1));
            if frame.is_antipodal() {
                return None;
            }
            if frame.degenerate() {
                return Some(worst_of(i0, i1, |j| frame.distance_key(d, points.get(j))));
            }
            // The reach, an along-chord angle in [0, theta], as a direction (rx, ry) in the
            // chord's plane (not normalised): a point's angle phi = atan2(y, x) is at or past
            // it when (x, y) lies in the half-turn counter-clockwise from it (rx y - ry x >= 0,
            // y >= 0 as phi <= pi). No atan2 per point: it was a tenth of a coastline's fit.
            let (mut rx, mut ry) = (1.0, 0.0);
            let (ct, st) = (frame.cos_theta(), frame.sin_theta());
            Some(worst_of(i0, i1, |j| {
                let q = points.get(j);
                let x = dot(d, q, &frame.e1);
                let y = dot(d, q, &frame.e2);
                if y >= 0.0 && rx * y - ry * x >= 0.0 {
                    // Past the chord's end (phi > theta): the reach stops at theta.
                    (rx, ry) = if ct * y - st * x > 0.0 {
                        (ct, st)
                    } else {
                        (x, y)
                    };
                    frame.distance_key_in_plane(d, q, x, y)
                } else {
                    let r = (rx * rx + ry * ry).sqrt();
                    let (c, s) = (rx / r, ry / r);
                    for k in 0..d.get() {
                        at_reach[k] = c * frame.e1[k] + s * frame.e2[k];
                    }
                    chord_key(diff_sq(d, q, &at_reach))
                }
            }))
        })
    })
}

/// Time-aware Douglas–Peucker (TD-TR, Meratnia & de By 2004): the indices of the points kept
/// so that every point is within `tolerance_rad` of the simplified track *at its own
/// parameter* (its time): the synchronized distance of point `j` between kept `a` and `b` is its
/// distance to the SLERP from `a` to `b` at `(t_j − t_a) / (t_b − t_a)`.
///
/// `params` must not decrease; a segment whose ends share a parameter measures each point
/// against its start. The recursion runs on an explicit stack as [`douglas_peucker`]'s does;
/// (nearly) antipodal kept neighbours are split at the middle.
///
/// # Panics
/// If `params` is not one per point.
///
/// # Example
/// ```
/// use spherefit::sphere::{compress::simplify::synchronized_douglas_peucker, PointSet};
/// // Five points on one great circle, but the middle one is late: only time shows it.
/// let rows: Vec<[f64; 3]> = (0..5).map(|i| { let a = 0.1 * i as f64; [a.cos(), a.sin(), 0.0] }).collect();
/// let line = PointSet::try_from_rows(&rows).unwrap();
/// assert_eq!(synchronized_douglas_peucker(&line, &[0.0, 1.0, 2.0, 3.0, 4.0], 1e-9), vec![0, 4]);
/// assert_eq!(synchronized_douglas_peucker(&line, &[0.0, 1.0, 3.0, 3.5, 4.0], 1e-9).len(), 4);
/// ```
pub fn synchronized_douglas_peucker(
    points: &PointSet,
    params: &[f64],
    tolerance_rad: f64,
) -> Vec<usize> {
    let n = points.len();
    assert_eq!(params.len(), n, "one parameter per point");
    split_until_within(n, tolerance_rad, |i0, i1| {
        let (a, b) = (points.get(i0), points.get(i1));
        if angle_between(a, b) >= std::f64::consts::PI - ANTIPODAL_MARGIN_RAD {
            return None;
        }
        let span = params[i1] - params[i0];
        Some(worst_of(i0, i1, |j| {
            let f = if span > 0.0 {
                (params[j] - params[i0]) / span
            } else {
                0.0
            };
            match crate::sphere::geometry::point::slerp(a, b, f) {
                Ok(c) => angle_between(points.get(j), &c),
                Err(_) => f64::INFINITY,
            }
        }))
    })
}

/// The largest distance (radians) of any point from the simplified line given by `kept`
/// (ascending indices including the first and last point): each point is measured against the
/// arc between the kept vertices that bracket it, as Douglas–Peucker does.
///
/// # Panics
/// If `kept` does not start at 0, end at the last point, or is not increasing.
pub fn max_deviation(points: &PointSet, kept: &[usize]) -> f64 {
    let n = points.len();
    assert!(!kept.is_empty() && kept[0] == 0 && kept[kept.len() - 1] == n - 1);
    assert!(
        kept.windows(2).all(|w| w[0] < w[1]),
        "kept indices increase"
    );
    crate::with_dim!(points.dim(), |d| {
        let mut worst: f64 = 0.0;
        for w in kept.windows(2) {
            let (a, b) = (points.get(w[0]), points.get(w[1]));
            let frame = ArcFrame::new(d, a, b);
            for j in w[0] + 1..w[1] {
                let q = points.get(j);
                let e = if frame.is_antipodal() {
                    angle(d, q, a).min(angle(d, q, b))
                } else {
                    frame.distance(d, q)
                };
                worst = worst.max(e);
            }
        }
        worst
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sphere::geometry::arc::tests::on_equator;

    #[test]
    fn simplification_meets_the_tolerance_and_keeps_corners() {
        // Two great-circle legs with a corner at index 50 (east, then north), and a bump at 75.
        let rows: Vec<[f64; 3]> = (0..101)
            .map(|i| {
                let s = i as f64 / 100.0;
                match i {
                    0..=50 => on_equator(s, 0.0),
                    75 => on_equator(0.502, s - 0.5),
                    _ => on_equator(0.5, s - 0.5),
                }
            })
            .collect();
        let line = PointSet::try_from_rows(&rows).unwrap();
        let kept = douglas_peucker(&line, 1e-4);
        for v in [0, 50, 75, 100] {
            assert!(kept.contains(&v), "{kept:?}");
        }
        assert!(max_deviation(&line, &kept) <= 1e-4);
        let coarse = douglas_peucker(&line, 1e-2);
        assert_eq!(coarse, vec![0, 50, 100]);
        assert!(max_deviation(&line, &coarse) <= 1e-2);
        assert!(max_deviation(&line, &[0, 100]) > 0.1);
    }

    #[test]
    fn a_million_points_do_not_overflow_the_stack() {
        // A zig-zag forces a split at every vertex: the worst case for recursion depth.
        let n = 1_000_000;
        let rows: Vec<[f64; 3]> = (0..n)
            .map(|i| on_equator(i as f64 * 1e-6, if i % 2 == 0 { 0.0 } else { 1e-5 }))
            .collect();
        let line = PointSet::try_from_rows(&rows).unwrap();
        let kept = douglas_peucker(&line, 1e-6);
        assert_eq!(kept.len(), n);
    }
}
