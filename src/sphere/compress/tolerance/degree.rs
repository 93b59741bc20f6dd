//! One vertex target's curves of every degree: the degree probe, the seeded fits with knot
//! insertion and removal, and the fewest control points on uniform knots.

use crate::sphere::compress::tolerance::fitter::{Fitter, Stale, REFIT_ITERATIONS};
use crate::sphere::compress::tolerance::pieces::polyline_in_pieces;
use crate::sphere::compress::tolerance::{stored_numbers, Curve, KnotRule, Line, ToleranceOptions};
use crate::sphere::curve::bspline::{clamped_uniform_knots, with_degree, Degree};
use crate::sphere::fit::metrics::{measure, ErrorMetrics};
use crate::sphere::geometry::point::{Dim, PointSet};
use crate::sphere::SphereError;

/// Every degree's curves at one vertex target (see the module docs), with honest errors;
/// `polyline`, when given, is degree 1's curve (decided already) instead of a fit.
#[allow(clippy::too_many_arguments)]
pub(super) fn search(
    line: Line,
    target_of: &dyn Fn(usize) -> f64,
    tolerance_rad: f64,
    cap: usize,
    options: &ToleranceOptions,
    degrees: &[usize],
    yardstick: usize,
    polyline: Option<(Curve, ErrorMetrics)>,
) -> Result<Searched, SphereError> {
    let (points, free) = (line.points, line.free);
    let mut found: Vec<(Curve, ErrorMetrics)> = Vec::new();
    let mut closest: Option<(Curve, ErrorMetrics)> = None;
    // A polyline already decided (the greedy stabbing's) stands for degree 1.
    let given = polyline.is_some();
    found.extend(polyline);
    let closed = points.get(0) == points.get(points.len() - 1);
    for &p in degrees {
        options.cancel.check()?;
        let target = target_of(p);
        // An open line whose polyline has few vertices is tried at every degree: the greedy
        // stabbing polyline's vertices sit at the edges of the tolerance's band, so it may
        // zigzag, and may store fewer numbers than a quadratic, on a smooth track (20 km at
        // 25 m: 23 numbers where a cubic stores 21), and such a line's smooth fits are cheap.
        // Rings (islets at 1 km) are still probed.
        let short_open = |c: &Curve| {
            options.short_open_at_every_degree
                && !closed
                && c.spline.control_points().len() <= SHORT_OPEN
        };
        let short_polyline = found
            .iter()
            .any(|(c, _)| c.spline.degree() == 1 && short_open(c));
        // The seeded polyline fit too, where the given one is short (it is then cheap, and
        // its least-squares vertices may need one fewer: the same track at 500 m, 7 numbers
        // against 9).
        if p == 1 && given && !short_polyline {
            continue;
        }
        // A degree is tried only after the one below it found a curve within the budget: a
        // line that no quadratic stores in fewer numbers than the polyline turns corners at
        // this scale, and a cubic rarely does better (10m land outlines, 2 threads: 19 % less
        // CPU at 1 km and 16 % at 5 km, for 0.04 % and 0.09 % more stored numbers; none at
        // 10 m and 100 m).
        if p >= 3
            && free
            && options.degree_probe
            && !short_polyline
            && degrees.contains(&(p - 1))
            && !found.iter().any(|(c, _)| c.spline.degree() == p - 1)
        {
            continue;
        }
        if p >= 2 && free && options.degree_probe {
            // The probe reads the smallest degree-1 curve that met the target, if any.
            let polyline = found
                .iter()
                .filter(|(c, _)| c.spline.degree() == 1)
                .min_by_key(|(c, _)| c.spline.control_points().len());
            if polyline
                .is_some_and(|(c, _)| !short_open(c) && !smooth_bends(c.spline.control_points()))
            {
                continue;
            }
            // Douglas–Peucker keeps nearly every point: each one is a corner at this
            // tolerance, which a smooth curve must turn within a tolerance of, at the cost of
            // control points clustered there; the polyline is already the cheapest curve.
            let kept = yardstick.saturating_sub(1) / (points.dim() - 1);
            if yardstick < usize::MAX
                && kept * SPARSE_DENOMINATOR >= SPARSE_NUMERATOR * points.len()
            {
                continue;
            }
        }
        // Curves storing as much as Douglas–Peucker (the yardstick) are never proven, so the
        // uniform-knot search does not look at them either.
        let budget = found
            .iter()
            .map(|(c, _)| stored_numbers(&c.spline, c.rule))
            .chain((yardstick < usize::MAX).then_some(yardstick))
            .min();
        let curves = crate::with_dim!(points.dim(), |d| with_degree!(p, |g| fit_degree(
            d,
            g,
            line,
            target,
            tolerance_rad,
            cap,
            budget,
            options
        )));
        for c in curves {
            // Honest errors: measured afresh by the library's own pass on the returned curve.
            let m = measure(&c.spline, points, &c.params);
            if m.max_error_rad <= target {
                found.push((c, m));
            } else if closest
                .as_ref()
                .is_none_or(|(_, b): &(Curve, ErrorMetrics)| m.max_error_rad < b.max_error_rad)
            {
                closest = Some((c, m));
            }
        }
    }
    options.cancel.check()?;
    Ok((found, closest))
}

/// Vertices of an open line's polyline up to which degrees 2 and 3 are tried whatever its
/// turns (see [`search`]).
const SHORT_OPEN: usize = 16;

/// A line whose Douglas–Peucker polyline keeps this share of its points or more
/// (`SPARSE_NUMERATOR / SPARSE_DENOMINATOR`) is only fitted by polylines (see [`search`]).
const SPARSE_NUMERATOR: usize = 4;
/// See [`SPARSE_NUMERATOR`].
const SPARSE_DENOMINATOR: usize = 5;

/// Least share of neighbouring turns bending the same way for a polyline to count as smooth.
///
/// Polylines of fewer than ten turns were always tried at degrees 2 and 3 until 2026-12-06;
/// they are most of a coastline dataset's rings (islets at 1 km and 5 km), and each one's
/// uniform-knot search cost more than its fit. Judged like the others, on the 10m land
/// outlines (callgrind, 1 thread): 8.6 % fewer instructions at 1 km and 9.3 % at 5 km for
/// 0.19 % and 0.36 % more stored numbers, which the removals' feet-first refits (the fitter's
/// `FEET_FIRST_POINTS_PER_SPAN`) more than pay back at both (half their turns: -4.0 % and
/// -6.3 % for +0.06 % and +0.17 %).
const PROBE_AGREEMENT: f64 = 2.0 / 3.0;

/// Whether a polyline (the best degree-1 fit) bends the way a smooth curve does at the
/// tolerance's scale: at least [`PROBE_AGREEMENT`] of its neighbouring turns bend the same
/// way, that is bends of three or more vertices on average between inflections. A smooth
/// curve replaces a bend of several vertices by fewer control points; a polyline that turns
/// left, right, left at nearly every vertex (a coastline, a jittery track at a small
/// tolerance) is already the cheapest curve through its corners, and a smooth one needs
/// more control points than it has vertices.
///
/// How often real lines agree is measured in `docs/tolerance-fitting.md` ("The degree
/// probe"). The turn at vertex b is the
/// change of direction there, `unit(c − b) − unit(b − a)` (in any dimension; unit chords, so
/// uneven vertex spacing does not tilt it along the line); two turns agree when their dot
/// product is positive.
fn smooth_bends(ctrl: &PointSet) -> bool {
    let (n, dim) = (ctrl.len(), ctrl.dim());
    // Two turns at least to compare.
    if n < 4 {
        return true;
    }
    let unit_chord = |a: &[f64], b: &[f64], out: &mut [f64]| {
        let mut norm = 0.0;
        for x in 0..dim {
            out[x] = b[x] - a[x];
            norm += out[x] * out[x];
        }
        let inv = if norm > 0.0 { 1.0 / norm.sqrt() } else { 0.0 };
        out.iter_mut().for_each(|v| *v *= inv);
    };
    let (mut before, mut after) = (vec![0.0; dim], vec![0.0; dim]);
    let (mut prev, mut turn) = (vec![0.0; dim], vec![0.0; dim]);
    unit_chord(ctrl.get(0), ctrl.get(1), &mut before);
    let (mut agree, mut pairs) = (0usize, 0usize);
    for i in 1..n - 1 {
        unit_chord(ctrl.get(i), ctrl.get(i + 1), &mut after);
        for x in 0..dim {
            turn[x] = after[x] - before[x];
        }
        if i > 1 {
            pairs += 1;
            let same: f64 = (0..dim).map(|x| turn[x] * prev[x]).sum();
            agree += usize::from(same > 0.0);
        }
        std::mem::swap(&mut prev, &mut turn);
        std::mem::swap(&mut before, &mut after);
    }
    agree as f64 >= PROBE_AGREEMENT * pairs as f64
}

/// What [`search`] found: the curves meeting the vertex target, and the one closest to it
/// among the others.
pub(super) type Searched = (Vec<(Curve, ErrorMetrics)>, Option<(Curve, ErrorMetrics)>);

#[allow(clippy::too_many_arguments)]
fn fit_degree<D: Dim, G: Degree>(
    d: D,
    g: G,
    line: Line,
    target: f64,
    tolerance_rad: f64,
    cap: usize,
    budget: Option<usize>,
    options: &ToleranceOptions,
) -> Vec<Curve> {
    let (points, free) = (line.points, line.free);
    let p = g.get();
    let mut out = Vec::new();
    if p + 1 > cap {
        return out;
    }
    let dim = d.get();
    let mut budget = budget;
    let mut offer = |c: Curve, met: bool, out: &mut Vec<Curve>| {
        if met {
            let s = stored_numbers(&c.spline, c.rule);
            budget = Some(budget.map_or(s, |b: usize| b.min(s)));
        }
        out.push(c);
    };
    // (Pieces only where no cap on control points binds: a piece does not know the others.)
    if free && p == 1 && options.reduce && cap >= points.len() {
        if let Some((c, met)) = polyline_in_pieces(d, g, points, target, tolerance_rad, options) {
            if options.uniform_knots {
                offer(c, met, &mut out);
            } else {
                let stored = Curve {
                    rule: KnotRule::Stored,
                    ..c
                };
                offer(stored, met, &mut out);
            }
            return out;
        }
    }
    if !free || p == 1 || options.adaptive_knots {
        let Some(mut f) = Fitter::seeded(d, g, line, target, cap, options) else {
            return out;
        };
        f.reweight = options.reweight;
        f.refine(target, cap);
        let met = f.max_error() <= target;
        if options.reduce && met {
            f.reduce(target);
        }
        if free && options.uniform_knots {
            if let Some(u) = f.to_uniform(target) {
                offer(u, true, &mut out);
                if p == 1 {
                    // The same polyline with its knots stored: more numbers and the same
                    // distances, never chosen, and measuring it was 1.5 % of a 10 m fit.
                    return out;
                }
            }
        }
        if let Some(c) = f.into_curve(KnotRule::Stored) {
            offer(c, met, &mut out);
        }
    }
    if free && options.uniform_knots && p >= 2 {
        // Only counts that store fewer numbers than the best curve so far can win.
        let most = match budget {
            Some(b) => (b.saturating_sub(2) / (dim - 1)).min(cap),
            None => cap.min(points.len()),
        };
        if let Some(u) = uniform_search(d, g, line, target, most, options.pin_ends) {
            out.push(u);
        }
    }
    out
}

/// Newton steps per point of the foot-point correction before a uniform-knot fit: the refit
/// corrects them again after each pass. On the small rings (under 512 points) of the 10m land
/// outlines 2 steps instead of 4 took 2.4 % fewer instructions at 1 km and 1.8 % at 5 km, the
/// stored numbers unchanged at 1 km and 8 fewer at 5 km.
const UNIFORM_FOOT_STEPS: usize = 2;

/// A uniform-knot fit still farther than this many targets after its first passes is given up
/// (see [`Fitter::refit_from`]). On the 10m land outlines (callgrind, 1 thread, 2026-12-06)
/// 1.5 instead of 3 took 2.7 % fewer instructions at 1 km and 1.7 % at 5 km for 42 and 14
/// more stored numbers (0.02 %): a fit that far out after three passes seldom comes in.
const UNIFORM_GIVE_UP: f64 = 1.5;

/// Uniform knots, no knot stored: the fewest control points, by bisection between p + 1 and
/// `most`, whose fit with corrected parameters meets the target.
fn uniform_search<D: Dim, G: Degree>(
    d: D,
    g: G,
    line: Line,
    target: f64,
    most: usize,
    pin_ends: bool,
) -> Option<Curve> {
    let p = g.get();
    // A ring's curve starts and ends at its seam: with three control points the third is the
    // first again, and the curve runs out along one great circle and back, never round a ring
    // (on the 10m land outlines at 5 km, 1,159 triangles were tried so, a tenth of the small
    // rings' instructions, and none won).
    let n = line.points.len();
    let closed = n > 2 && line.points.get(0) == line.points.get(n - 1);
    let fewest = if closed { (p + 1).max(4) } else { p + 1 };
    if most < fewest {
        return None;
    }
    let try_count = |n_ctrl: usize| -> Option<Fitter<D, G>> {
        let knots = clamped_uniform_knots(n_ctrl, p);
        let mut f = Fitter::with_knots(d, g, Line { free: true, ..line }, knots)?;
        if pin_ends {
            f.pin_ends();
        }
        f.correct_all(UNIFORM_FOOT_STEPS);
        // The correction has measured every point.
        let measured = Stale::Points(0, 0);
        f.refit_from(
            0,
            f.n_ctrl(),
            3 * REFIT_ITERATIONS,
            target,
            UNIFORM_GIVE_UP,
            true,
            measured,
        );
        Some(f)
    };
    let hi_limit = most;
    let mut lo = fewest;
    let mut hi = hi_limit;
    // Is the top of the range feasible at all?
    let top = try_count(hi)?;
    if top.max_error() > target {
        return None;
    }
    let mut best = Some(top);
    while lo < hi && !crate::sphere::cancel::cancelled() {
        let mid = (lo + hi) / 2;
        match try_count(mid) {
            Some(f) if f.max_error() <= target => {
                hi = mid;
                best = Some(f);
            }
            _ => lo = mid + 1,
        }
    }
    best.and_then(|f| f.into_curve(KnotRule::Uniform))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sphere::curve::bspline::Deg;
    use crate::sphere::fit::knots::{parameters, Parameterization};
    use crate::sphere::geometry::point::Fixed;

    /// A closed ring of `n` points on an ellipse (semi-axes `a`, `b` radians) round (1, 0, 0).
    fn ellipse(n: usize, a: f64, b: f64) -> PointSet {
        let rows: Vec<[f64; 3]> = (0..=n)
            .map(|i| {
                let s = std::f64::consts::TAU * (i % n) as f64 / n as f64;
                let (y, z) = (a * s.cos(), b * s.sin());
                let norm = (1.0 + y * y + z * z).sqrt();
                [1.0 / norm, y / norm, z / norm]
            })
            .collect();
        PointSet::try_from_rows(&rows).unwrap()
    }

    fn search_ring(points: &PointSet, target: f64, most: usize) -> Option<Curve> {
        let params = parameters(points, Parameterization::Chord).unwrap();
        let line = Line {
            points,
            params: &params,
            free: true,
        };
        uniform_search(Fixed::<3>, Deg::<2>, line, target, most, false)
    }

    /// Vertices 0.01 rad apart in longitude along the equator, at latitudes `lats`.
    fn at_lats(lats: &[f64]) -> PointSet {
        let rows: Vec<[f64; 3]> = lats
            .iter()
            .enumerate()
            .map(|(i, &lat)| {
                let lon = 0.01 * i as f64;
                [lat.cos() * lon.cos(), lat.cos() * lon.sin(), lat.sin()]
            })
            .collect();
        PointSet::try_from_rows(&rows).unwrap()
    }

    #[test]
    fn short_polylines_are_probed_like_long_ones() {
        // Fewer than ten turns: a zigzag (every turn the other way) is not tried at degrees 2
        // and 3, one bend (every turn the same way) is, and so is a polyline of three
        // vertices (one turn: nothing to compare).
        let zigzag = |n: usize| -> Vec<f64> { (0..n).map(|i| 0.002 * (i % 2) as f64).collect() };
        let bend: Vec<f64> = (0..8).map(|i| 0.0005 * (i * i) as f64).collect();
        assert!(!smooth_bends(&at_lats(&zigzag(8))));
        assert!(smooth_bends(&at_lats(&bend)));
        assert!(smooth_bends(&at_lats(&zigzag(3))));
        // Two thirds of the pairs agreeing is enough, half is not.
        // Turns left, left, left, right: two of three pairs agree.
        assert!(smooth_bends(&at_lats(&[
            0.0, 0.0, 0.001, 0.003, 0.006, 0.008
        ])));
        // Turns left, left, right, right, left: two of four.
        assert!(!smooth_bends(&at_lats(&[
            0.0, 0.0, 0.001, 0.003, 0.004, 0.004, 0.005
        ])));
    }

    #[test]
    fn a_ring_is_never_searched_with_three_control_points() {
        // A "ring" out along a great circle and back: a quadratic through three control
        // points, the third the first again, runs out and back along one great circle and
        // could stand for it, but bounds no area (and never beat the polyline on real rings),
        // so it is not tried.
        let rows: Vec<[f64; 3]> = (0..=24)
            .map(|i| {
                let a = 0.02 * (12 - (12i32 - i).abs()) as f64 / 12.0;
                [a.cos(), a.sin(), 0.0]
            })
            .collect();
        let sliver = PointSet::try_from_rows(&rows).unwrap();
        assert!(search_ring(&sliver, 5e-3, 3).is_none());
        // With four control points a ring is tried, and an ellipse is met.
        let oval = ellipse(24, 0.02, 0.01);
        let c = search_ring(&oval, 4e-3, 4).expect("four control points round an ellipse");
        assert_eq!(c.spline.control_points().len(), 4);
    }
}
