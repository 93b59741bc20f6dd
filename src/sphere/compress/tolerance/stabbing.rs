//! A polyline on S^2 with free vertices in one pass: the greedy ordered stabbing.
//!
//! From each vertex v the polyline takes the longest run of the following points that one
//! great circle through v passes within `eps` of, in order; the next vertex is that circle's
//! point furthest along the run (the largest foot), and the next run starts there. The great
//! circles through v are the lines through the origin of v's gnomonic plane (the tangent plane
//! at v, points projected from the sphere's centre), so "within `eps` of every point so far" is
//! a wedge of directions narrowed point by point: linear in the points, no refits. Which
//! direction of the wedge a run takes decides where the next run starts: after short runs,
//! of the wedge's middle and edges the one whose vertex starts the longest next run is taken
//! (a look-ahead of one run).
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

use crate::sphere::compress::tolerance::{Curve, KnotRule};
use crate::sphere::curve::bspline::{clamped_uniform_knots, SphericalBSpline};
use crate::sphere::geometry::point::{angle, dot, Fixed, PointSet};

type V3 = [f64; 3];

const D3: Fixed<3> = Fixed::<3>;

/// A point further than this cosine from the run's vertex (60 degrees) ends the run: the
/// gnomonic plane stretches too much beyond it to judge by.
const FAR_COSINE: f64 = 0.5;

/// The directions a run's line is tried at, as shares of the way across its wedge, middle
/// first (ties keep it): the one whose vertex starts the longest next run is taken. On the
/// 10m land outlines this stores 0.7 % / 3.9 % / 1.3 % fewer numbers at 100 m / 1 km / 5 km
/// than the middle alone, and a noisy 1 Hz track 19 % fewer at 5 m (docs/speed.md, "sixth
/// session").
const LOOK_AHEAD: [f64; 3] = [0.5, 0.0, 1.0];

/// Runs of more points than this (or of one point) take the middle of their wedge without
/// looking ahead. On the 10m land outlines at 1 km, looking ahead after every run cost 3 %
/// of the wall time for 0.15 % fewer numbers than after runs of 8 points or fewer; after
/// one-point runs too, 100 m stored 3.6 % fewer numbers but 10 m took 12 % longer (a ratio
/// to mapshaper of 0.49 against 0.42).
const LOOK_AHEAD_MOST_POINTS: usize = 8;

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

/// A run of points from a vertex: it ends before `j`, its line's direction `u` and wedge, and
/// the gnomonic coordinates of its points in the vertex's plane (kept for the look-ahead and
/// the parameters; perhaps one point more).
struct Run {
    j: usize,
    u: Dir,
    wedge: Option<Wedge>,
    xy: Vec<Dir>,
}

/// The greedy pass itself (see the module docs).
fn stab(pts: &[V3], eps: f64) -> Stabbed {
    let n = pts.len();
    let mut vertices = vec![pts[0]];
    let mut at = vec![(0usize, 0.0f64); n];
    let mut i = 1;
    // The run from the next vertex, when the look-ahead has found it already, and coordinate
    // buffers to reuse.
    let mut next_run: Option<Run> = None;
    let mut spare: Vec<Vec<Dir>> = Vec::new();
    while i < n {
        let v = *vertices.last().expect("the first point is a vertex");
        let k = vertices.len() - 1;
        let plane = Plane::at(v);
        let mut run = match next_run.take() {
            Some(run) => run,
            None => ordered_run(pts, i, n, &plane, eps, spare.pop().unwrap_or_default()),
        };
        let j = run.j;
        if j > i + 1 && j < n && j - i <= LOOK_AHEAD_MOST_POINTS {
            if let Some(w) = run.wedge {
                // Look ahead: of the wedge's edges and its middle, the direction whose vertex
                // starts the longest next run (that run is kept for the next vertex).
                let xy = &run.xy[..j - i];
                let mut best: Option<(Dir, Run)> = None;
                for f in LOOK_AHEAD {
                    let uc = between(w, f);
                    if in_order_until(xy, false, uc, eps).is_some() {
                        continue;
                    }
                    let w = plane.along(uc, far_foot(xy, uc));
                    let buf = spare.pop().unwrap_or_default();
                    let next = ordered_run(pts, j, n, &Plane::at(w), eps, buf);
                    match best {
                        Some((_, ref b)) if b.j >= next.j => spare.push(next.xy),
                        _ => {
                            if let Some((_, old)) = best.replace((uc, next)) {
                                spare.push(old.xy);
                            }
                        }
                    }
                }
                if let Some((u, next)) = best {
                    run.u = u;
                    next_run = Some(next);
                }
            }
        }
        if j == i {
            // Not even the next point fits (it is beyond FAR_COSINE): it becomes a vertex.
            vertices.push(pts[i]);
            at[i] = (k, 1.0);
            i += 1;
            spare.push(run.xy);
            continue;
        }
        // The run's end: the last point itself, or the furthest foot.
        let u = run.u;
        let xy = &run.xy[..j - i];
        let end = if j == n {
            pts[n - 1]
        } else {
            plane.along(u, far_foot(xy, u))
        };
        let span = angle(D3, &v, &end);
        if span <= 0.0 || span.is_nan() {
            // Every point of the run is at the vertex (within eps, no foot ahead of it); where
            // the run ends the line, the vertex is the last point.
            at[i..j].iter_mut().for_each(|a| *a = (k, 0.0));
            if let Some(next) = next_run.take() {
                spare.push(next.xy);
            }
            if j == n {
                *vertices.last_mut().expect("a vertex") = pts[n - 1];
            }
            i = j;
            spare.push(run.xy);
            continue;
        }
        let mut reach = 0.0f64;
        for (m, &(x, y)) in xy.iter().enumerate() {
            reach = reach.max(x * u.0 + y * u.1);
            at[i + m] = (k, (reach.atan() / span).min(1.0));
        }
        vertices.push(end);
        i = j;
        spare.push(run.xy);
    }
    Stabbed { vertices, at }
}

/// The largest foot of a run's points (gnomonic) along `u`.
fn far_foot(xy: &[Dir], u: Dir) -> f64 {
    xy.iter()
        .fold(0.0f64, |a, &(x, y)| a.max(x * u.0 + y * u.1))
}

/// The longest run from `i` that one line through the plane's origin passes within `eps` of
/// in order (its points' coordinates in `xy`, a buffer to reuse).
fn ordered_run(pts: &[V3], i: usize, end: usize, plane: &Plane, eps: f64, mut xy: Vec<Dir>) -> Run {
    xy.clear();
    let last = pts.len() - 1;
    let (mut j, mut u, mut wedge) = widest_run(pts, i, end, plane, eps, &mut xy);
    while j > i {
        let Some(cut) = in_order_until(&xy[..j - i], j - 1 == last, u, eps) else {
            break;
        };
        (j, u, wedge) = widest_run(pts, i, i + cut, plane, eps, &mut xy);
    }
    Run { j, u, wedge, xy }
}

/// Directions in a gnomonic plane (unit vectors), and the wedge of those left for a run: from
/// its clockwise edge `.0` counter-clockwise to `.1`, less than a half turn wide.
type Dir = (f64, f64);
type Wedge = (Dir, Dir);

/// `b` counter-clockwise of `a` (within a half turn): positive.
fn cross2(a: Dir, b: Dir) -> f64 {
    a.0 * b.1 - a.1 * b.0
}

/// `x` within the wedge.
fn inside(x: Dir, w: Wedge) -> bool {
    cross2(w.0, x) >= 0.0 && cross2(x, w.1) >= 0.0
}

/// A direction between the wedge's edges, at share `f` of the way from the clockwise one.
fn between(w: Wedge, f: f64) -> Dir {
    let (x, y) = (
        (1.0 - f) * w.0 .0 + f * w.1 .0,
        (1.0 - f) * w.0 .1 + f * w.1 .1,
    );
    let r = x.hypot(y);
    if r > 0.0 {
        (x / r, y / r)
    } else {
        w.0
    }
}

/// The longest run `i..j` (j <= `end`) of points one line through the plane's origin passes
/// within `eps` of (the last point of the line exactly), that line's direction (the middle of
/// the wedge of directions left), and the wedge. Two wedges narrower than a half turn meet in
/// one piece at most, whose edges are the edges of either that lie inside the other: no
/// angles, no trigonometry.
fn widest_run(
    pts: &[V3],
    i: usize,
    end: usize,
    plane: &Plane,
    eps: f64,
    xy: &mut Vec<Dir>,
) -> (usize, Dir, Option<Wedge>) {
    let n = pts.len();
    let mut wedge: Option<Wedge> = None;
    let mut j = i;
    while j < end {
        if xy.len() == j - i {
            match plane.xy(&pts[j]) {
                Some(p) => xy.push(p),
                None => break,
            }
        }
        let (x, y) = xy[j - i];
        let r = x.hypot(y);
        let slack = if j == n - 1 { 0.0 } else { eps };
        if r > slack {
            // The directions passing within `slack` of the point: its own, turned either way by
            // the angle whose sine is slack / r.
            let (px, py) = (x / r, y / r);
            let sin = slack / r;
            let cos = (1.0 - sin * sin).max(0.0).sqrt();
            let new: Wedge = (
                (px * cos + py * sin, py * cos - px * sin),
                (px * cos - py * sin, py * cos + px * sin),
            );
            let met = match wedge {
                None => Some(new),
                Some(w) => {
                    // Each edge of the meet: the new wedge's where it lies in the old, else
                    // the old's where it lies in the new.
                    let edge = |fresh: Dir, old: Dir| {
                        (inside(fresh, w).then_some(fresh)).or(inside(old, new).then_some(old))
                    };
                    let (cw, ccw) = (edge(new.0, w.0), edge(new.1, w.1));
                    cw.zip(ccw).filter(|&(a, b)| cross2(a, b) >= 0.0)
                }
            };
            match met {
                Some(w) => wedge = Some(w),
                None => break,
            }
        }
        j += 1;
    }
    let u = wedge.map_or((1.0, 0.0), |w| between(w, 0.5));
    (j, u, wedge)
}

/// The first point of a run (its points' gnomonic coordinates `xy`) whose parameter along
/// direction `u`, kept non-decreasing, would sit more than `eps` from it (a point more than
/// `eps` behind the furthest foot so far, or, where the run `ends_line`, beyond its last point),
/// as an index into `xy`; `None` when there is none.
fn in_order_until(xy: &[Dir], ends_line: bool, u: Dir, eps: f64) -> Option<usize> {
    let end_foot = ends_line.then(|| xy.last().map_or(0.0, |&(x, y)| x * u.0 + y * u.1));
    let mut reach: f64 = 0.0;
    for (m, &(x, y)) in xy.iter().enumerate() {
        let t = x * u.0 + y * u.1;
        if t < reach && (x - reach * u.0).hypot(y - reach * u.1) > eps {
            return Some(m);
        }
        reach = reach.max(t);
        if let Some(e) = end_foot {
            if t > e && (x - e * u.0).hypot(y - e * u.1) > eps {
                return Some(m);
            }
        }
    }
    None
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
    fn a_jagged_band_is_crossed_in_few_spans() {
        // 600 points 1e-3 rad apart along the equator, jagged 1e-4 rad either side: one arc
        // from the band's middle would do, but the first vertex is the first point, on its
        // edge. Taking the middle of each wedge put the next vertex at the band's edge again
        // and again (61 vertices); the look-ahead keeps the runs long.
        let rows: Vec<(f64, f64)> = (0..600)
            .map(|i| {
                let jag = ((i * 7919) % 13) as f64 / 12.0 - 0.5;
                (0.001f64.to_degrees() * i as f64, (2e-4 * jag).to_degrees())
            })
            .collect();
        let pts = lonlat(&rows);
        let c = check(&pts, 1.9e-4);
        assert!(
            c.spline.control_points().len() <= 20,
            "{}",
            c.spline.control_points().len()
        );
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

    proptest::proptest! {
        #![proptest_config(proptest::test_runner::Config::with_cases(512))]
        /// Random walks (steps of any direction and length up to a hundred times eps, with
        /// repeats and turns back) keep every promise, or give no polyline.
        #[test]
        fn random_walks_keep_every_promise(
            steps in proptest::collection::vec((0.0f64..std::f64::consts::TAU, 0.0f64..100.0), 1..120),
            eps in 1e-6f64..1e-3,
        ) {
            let mut rows = vec![(10.0f64, 20.0f64)];
            for &(dir, len) in &steps {
                let (lon, lat) = *rows.last().unwrap();
                let d = (len * eps).to_degrees();
                rows.push((lon + d * dir.cos(), (lat + d * dir.sin()).clamp(-80.0, 80.0)));
            }
            let pts = lonlat(&rows);
            if pts.check_no_antipodal_neighbours().is_ok() {
                if let Some(c) = stabbing_polyline(&pts, eps) {
                    let n = pts.len();
                    let ctrl = c.spline.control_points();
                    proptest::prop_assert_eq!(ctrl.get(0), pts.get(0));
                    proptest::prop_assert_eq!(ctrl.get(ctrl.len() - 1), pts.get(n - 1));
                    proptest::prop_assert!(c.params.windows(2).all(|w| w[0] <= w[1]));
                    let m = measure(&c.spline, &pts, &c.params);
                    proptest::prop_assert!(m.max_error_rad <= eps * (1.0 + 1e-9));
                    let tw = two_way_distance(
                        &c.spline,
                        &pts,
                        &c.params,
                        &TwoWayOptions::default().with_precision_rad(0.01 * eps),
                    )
                    .unwrap();
                    proptest::prop_assert!(tw.upper_rad <= 1.011 * eps, "{} > {}", tw.upper_rad, eps);
                }
            }
        }
    }

    #[test]
    fn other_dimensions_are_left_to_the_fitter() {
        let pts = PointSet::try_from_rows(&[[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]]).unwrap();
        assert!(stabbing_polyline(&pts, 1e-3).is_none());
    }
}
