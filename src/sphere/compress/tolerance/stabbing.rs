//! A polyline on S^2 with free vertices in one pass: the greedy ordered stabbing.
//!
//! From each vertex v the polyline takes the longest run of the following points that one
//! great circle through v passes within `eps` of, in order; the next vertex is that circle's
//! point furthest along the run (the largest foot), and the next run starts there. The great
//! circles through v are the lines through the origin of v's gnomonic plane (the tangent plane
//! at v, points projected from the sphere's centre), so "within `eps` of every point so far" is
//! a wedge of directions narrowed point by point: linear in the points, no refits.
//!
//! Why: the tolerance fitter's degree-1 curve (Douglas–Peucker's ordered polyline refined and
//! reduced by knot removal with local Gauss–Newton refits) spent most of a coastline's time at
//! 1 km and 5 km on removals, and still kept more vertices than this pass does (10m land
//! outlines: docs/speed.md, "sixth session").
//!
//! What it promises, with `eps` below a tenth of a radian: every point's parametric error (the
//! angle to the curve at its parameter, parameters non-decreasing, the ends at 0 and 1) is at
//! most `eps`, so the curve and the line are within `eps` of each other both ways (between
//! two points matched in order, the curve and the chord stay within the larger of their two
//! errors; the certification in [`crate::sphere::certify::two_way`] proves it for the curve
//! returned). The first and last vertices are the first and last points exactly.
//!
//! Gnomonic distances are never shorter than the angles they stand for (the projection
//! stretches in every direction), so every test below is on the safe side.

use super::{Curve, KnotRule};
use crate::sphere::curve::bspline::{clamped_uniform_knots, SphericalBSpline};
use crate::sphere::geometry::point::{angle, dot, Fixed, PointSet};

type V3 = [f64; 3];

const D3: Fixed<3> = Fixed::<3>;

/// A point further than this cosine from the run's vertex (60 degrees) ends the run: the
/// gnomonic plane stretches too much beyond it to judge by.
const FAR_COSINE: f64 = 0.5;

/// The polyline of the greedy ordered stabbing of `points` (on S^2) at `eps` radians, as a
/// degree-1 curve on uniform knots with its points' parameters; `None` when the points are not
/// on S^2 or when the polyline would be degenerate (fewer than two vertices, or fewer than
/// four round a closed ring), for the fitter's other paths to handle.
pub(super) fn stabbing_polyline(points: &PointSet, eps: f64) -> Option<Curve> {
    let n = points.len();
    if points.dim() != 3 || n < 2 || !(eps > 0.0 && eps < 0.1) {
        return None;
    }
    let pts: Vec<V3> = (0..n)
        .map(|i| {
            let p = points.get(i);
            [p[0], p[1], p[2]]
        })
        .collect();
    let Stabbed { vertices, at } = stab(&pts, eps);
    let m = vertices.len();
    let closed = pts[0] == pts[n - 1];
    if m < 2 || (closed && m < 4) || vertices.windows(2).any(|w| w[0] == w[1]) {
        return None;
    }
    let last = (m - 1) as f64;
    let mut params: Vec<f64> = at.iter().map(|&(k, s)| (k as f64 + s) / last).collect();
    params[0] = 0.0;
    params[n - 1] = 1.0;
    // (k + s) / last rounds; the runs are in order, so a running max only mends ulps.
    for i in 1..n {
        params[i] = params[i].clamp(params[i - 1], 1.0);
    }
    let flat: Vec<f64> = vertices.iter().flatten().copied().collect();
    let ctrl = PointSet::from_flat_unchecked(3, flat);
    let spline = SphericalBSpline::try_new(1, clamped_uniform_knots(m, 1), ctrl).ok()?;
    Some(Curve {
        spline,
        params,
        rule: KnotRule::Uniform,
        decided: None,
    })
}

/// The vertices, and for each point its segment and the share of that segment's angle at which
/// its parameter sits.
struct Stabbed {
    vertices: Vec<V3>,
    at: Vec<(usize, f64)>,
}

/// The tangent plane at a vertex, with an orthonormal frame.
struct Plane {
    v: V3,
    e1: V3,
    e2: V3,
}

impl Plane {
    fn at(v: V3) -> Plane {
        let a = if v[0].abs() < 0.9 {
            [1.0, 0.0, 0.0]
        } else {
            [0.0, 1.0, 0.0]
        };
        let e1 = unit(cross(&v, &a));
        let e2 = cross(&v, &e1);
        Plane { v, e1, e2 }
    }

    /// Gnomonic coordinates of `q`, or `None` beyond [`FAR_COSINE`].
    fn xy(&self, q: &V3) -> Option<(f64, f64)> {
        let c = dot(D3, q, &self.v);
        (c > FAR_COSINE).then(|| (dot(D3, q, &self.e1) / c, dot(D3, q, &self.e2) / c))
    }

    /// The point of the sphere at gnomonic `t` along direction `u`.
    fn along(&self, u: (f64, f64), t: f64) -> V3 {
        let g = [0, 1, 2].map(|k| self.v[k] + t * (u.0 * self.e1[k] + u.1 * self.e2[k]));
        unit(g)
    }
}

fn cross(a: &V3, b: &V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn unit(a: V3) -> V3 {
    let n = dot(D3, &a, &a).sqrt();
    [a[0] / n, a[1] / n, a[2] / n]
}

/// The greedy pass itself (see the module docs).
fn stab(pts: &[V3], eps: f64) -> Stabbed {
    let n = pts.len();
    let mut vertices = vec![pts[0]];
    let mut at = vec![(0usize, 0.0f64); n];
    let mut i = 1;
    while i < n {
        let v = *vertices.last().expect("the first point is a vertex");
        let k = vertices.len() - 1;
        let plane = Plane::at(v);
        let (mut j, mut u) = widest_run(pts, i, n, &plane, eps);
        while j > i {
            let cut = in_order_until(pts, i, j, &plane, u, eps);
            if cut == j {
                break;
            }
            (j, u) = widest_run(pts, i, cut, &plane, eps);
        }
        if j == i {
            // Not even the next point fits (it is beyond FAR_COSINE): it becomes a vertex.
            vertices.push(pts[i]);
            at[i] = (k, 1.0);
            i += 1;
            continue;
        }
        // The run's end: the last point itself, or the furthest foot.
        let feet: Vec<f64> = pts[i..j]
            .iter()
            .map(|q| {
                let (x, y) = plane.xy(q).expect("within the run");
                x * u.0 + y * u.1
            })
            .collect();
        let far = feet.iter().fold(0.0f64, |a, &t| a.max(t));
        let end = if j == n {
            pts[n - 1]
        } else {
            plane.along(u, far)
        };
        let span = angle(D3, &v, &end);
        if span <= 0.0 || span.is_nan() {
            // Every point of the run is at the vertex (within eps, no foot ahead of it); where
            // the run ends the line, the vertex is the last point.
            at[i..j].iter_mut().for_each(|a| *a = (k, 0.0));
            if j == n {
                *vertices.last_mut().expect("a vertex") = pts[n - 1];
            }
            i = j;
            continue;
        }
        let mut reach = 0.0f64;
        for (m, &t) in feet.iter().enumerate() {
            reach = reach.max(t);
            at[i + m] = (k, (reach.atan() / span).min(1.0));
        }
        vertices.push(end);
        i = j;
    }
    Stabbed { vertices, at }
}

/// The longest run `i..j` (j <= `end`) of points one line through the plane's origin passes
/// within `eps` of (the last point of the line exactly), and that line's direction: the
/// middle of the wedge of directions left.
fn widest_run(pts: &[V3], i: usize, end: usize, plane: &Plane, eps: f64) -> (usize, (f64, f64)) {
    use std::f64::consts::PI;
    let n = pts.len();
    let (mut lo, mut hi, mut base) = (f64::NEG_INFINITY, f64::INFINITY, None::<f64>);
    let mut j = i;
    while j < end {
        let Some((x, y)) = plane.xy(&pts[j]) else {
            break;
        };
        let r = x.hypot(y);
        let slack = if j == n - 1 { 0.0 } else { eps };
        if r > slack {
            let phi = y.atan2(x);
            let half = (slack / r).min(1.0).asin();
            let b = *base.get_or_insert(phi);
            let d = (phi - b + PI).rem_euclid(2.0 * PI) - PI;
            let (nlo, nhi) = (lo.max(d - half), hi.min(d + half));
            if nlo > nhi {
                break;
            }
            (lo, hi) = (nlo, nhi);
        }
        j += 1;
    }
    let psi = match base {
        None => 0.0,
        Some(b) if lo == f64::NEG_INFINITY => b,
        Some(b) => b + 0.5 * (lo + hi),
    };
    (j, (psi.cos(), psi.sin()))
}

/// The first point of the run `i..j` along direction `u` whose parameter, kept non-decreasing,
/// would sit more than `eps` from it (a point more than `eps` behind the furthest foot so far,
/// or, where the run ends the line, beyond the last point), or `j` when there is none.
fn in_order_until(pts: &[V3], i: usize, j: usize, plane: &Plane, u: (f64, f64), eps: f64) -> usize {
    let xy = |q: &V3| plane.xy(q).expect("within the run");
    let end_foot = (j == pts.len()).then(|| {
        let (x, y) = xy(&pts[j - 1]);
        x * u.0 + y * u.1
    });
    let mut reach: f64 = 0.0;
    for (m, q) in pts.iter().enumerate().take(j).skip(i) {
        let (x, y) = xy(q);
        let t = x * u.0 + y * u.1;
        if t < reach && (x - reach * u.0).hypot(y - reach * u.1) > eps {
            return m;
        }
        reach = reach.max(t);
        if let Some(e) = end_foot {
            if t > e && (x - e * u.0).hypot(y - e * u.1) > eps {
                return m;
            }
        }
    }
    j
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sphere::certify::two_way::{two_way_distance, TwoWayOptions};
    use crate::sphere::fit::metrics::measure;

    fn lonlat(rows: &[(f64, f64)]) -> PointSet {
        let rows: Vec<V3> = rows
            .iter()
            .map(|&(lon, lat)| {
                let (lon, lat) = (lon.to_radians(), lat.to_radians());
                [lat.cos() * lon.cos(), lat.cos() * lon.sin(), lat.sin()]
            })
            .collect();
        PointSet::try_from_rows(&rows).unwrap()
    }

    /// Every promise of the module docs, checked on `points` at `eps`.
    fn check(points: &PointSet, eps: f64) -> Curve {
        let c = stabbing_polyline(points, eps).expect("a polyline");
        let ctrl = c.spline.control_points();
        let n = points.len();
        assert_eq!(ctrl.get(0), points.get(0));
        assert_eq!(ctrl.get(ctrl.len() - 1), points.get(n - 1));
        assert_eq!((c.params[0], c.params[n - 1]), (0.0, 1.0));
        assert!(c.params.windows(2).all(|w| w[0] <= w[1]));
        let m = measure(&c.spline, points, &c.params);
        assert!(
            m.max_error_rad <= eps * (1.0 + 1e-9),
            "{} > {eps}",
            m.max_error_rad
        );
        let tw = two_way_distance(
            &c.spline,
            points,
            &c.params,
            &TwoWayOptions::default().with_precision_rad(0.01 * eps),
        )
        .unwrap();
        // Proven to 1 % of eps.
        assert!(tw.upper_rad <= 1.011 * eps, "{} > {eps}", tw.upper_rad);
        c
    }

    #[test]
    fn a_zigzag_within_eps_is_one_arc() {
        // 0.001 degrees (1.75e-5 rad) either side of the equator, from and to the equator.
        let rows: Vec<(f64, f64)> = (0..50)
            .map(|i| {
                let side = if i % 2 == 0 { 1.0 } else { -1.0 };
                let lat = if i == 0 || i == 49 { 0.0 } else { 0.001 * side };
                (0.01 * i as f64, lat)
            })
            .collect();
        let pts = lonlat(&rows);
        let c = check(&pts, 2e-5);
        assert_eq!(c.spline.control_points().len(), 2);
        // Below the zigzag's half width, more.
        assert!(check(&pts, 1.5e-5).spline.control_points().len() > 2);
    }

    #[test]
    fn a_spike_out_and_back_keeps_its_tip() {
        // East 1 degree, then up a spike of 0.5 degrees and back down, then on east.
        let mut rows: Vec<(f64, f64)> = (0..=10).map(|i| (0.1 * i as f64, 0.0)).collect();
        rows.extend((1..=5).map(|i| (1.0, 0.1 * i as f64)));
        rows.extend((0..5).rev().map(|i| (1.0, 0.1 * i as f64)));
        rows.extend((1..=10).map(|i| (1.0 + 0.1 * i as f64, 0.0)));
        let pts = lonlat(&rows);
        let c = check(&pts, 1e-4);
        // The tip is within eps of a vertex: the curve goes up and comes back.
        let tip = pts.get(15);
        let ctrl = c.spline.control_points();
        let nearest = (0..ctrl.len())
            .map(|k| angle(D3, ctrl.get(k), tip))
            .fold(f64::INFINITY, f64::min);
        assert!(nearest <= 1e-4, "{nearest}");
    }

    #[test]
    fn a_line_that_overshoots_its_end_is_followed_back() {
        // East to 2 degrees, then back west to 1 degree (along the same circle): the last
        // run may not end at the last point with the overshoot's feet beyond it.
        let mut rows: Vec<(f64, f64)> = (0..=20).map(|i| (0.1 * i as f64, 0.0)).collect();
        rows.extend((10..20).rev().map(|i| (0.1 * i as f64, 1e-4)));
        let pts = lonlat(&rows);
        let c = check(&pts, 1e-4);
        assert!(c.spline.control_points().len() >= 3);
    }

    #[test]
    fn a_closed_ring_starts_and_ends_at_its_seam() {
        let rows: Vec<(f64, f64)> = (0..=40)
            .map(|i| {
                let a = std::f64::consts::TAU * (i % 40) as f64 / 40.0;
                (2.0 * a.cos(), 1.0 * a.sin())
            })
            .collect();
        let pts = lonlat(&rows);
        let c = check(&pts, 2e-4);
        assert!(c.spline.control_points().len() >= 4);
        // Every point within eps of the seam: no ring of four vertices, so none.
        assert!(stabbing_polyline(&pts, 0.09).is_none());
    }

    #[test]
    fn far_jumps_and_repeated_points_are_kept() {
        // A jump of 70 degrees (beyond the gnomonic plane's reach), then repeated points.
        let rows = [
            (0.0, 0.0),
            (0.5, 0.0),
            (70.0, 0.0),
            (70.0, 0.0),
            (70.5, 0.0),
            (70.5, 0.0),
            (71.0, 0.01),
        ];
        let pts = lonlat(&rows);
        check(&pts, 1e-5);
    }

    #[test]
    fn other_dimensions_are_left_to_the_fitter() {
        let pts = PointSet::try_from_rows(&[[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]]).unwrap();
        assert!(stabbing_polyline(&pts, 1e-3).is_none());
    }
}
