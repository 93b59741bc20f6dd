//! The polyline fallbacks: Douglas–Peucker's vertices (plain, then ordered) at the tolerance
//! and a hair under it, then every point, for when no fitted curve meets the tolerance (and as the yardstick a
//! fitted curve must store fewer numbers than).

use crate::sphere::compress::simplify::{
    douglas_peucker, douglas_peucker_ordered, synchronized_douglas_peucker,
};
use crate::sphere::compress::tolerance::{Curve, KnotRule, Line};
use crate::sphere::curve::bspline::{clamped_uniform_knots, SphericalBSpline};

/// How many polyline fallbacks [`polyline_candidate`] knows.
pub(super) const POLYLINE_CANDIDATES: usize = 5;

/// The `k`-th polyline fallback, degree 1 on uniform knots (none stored): the Douglas–Peucker
/// vertices at the tolerance, those of the ordered Douglas–Peucker, both again a hair under
/// it, then every point. Each point's parameter is
/// where it projects on its segment (kept non-decreasing). With given parameters the vertices
/// are the time-aware Douglas–Peucker's (TD-TR, the error at a point's own parameter) and the
/// knots are the kept points' parameters (stored); the polyline through every point then has
/// error 0 at every parameter, so strictly increasing parameters always meet the tolerance.
pub(super) fn polyline_candidate(line: Line, tolerance_rad: f64, k: usize) -> Option<Curve> {
    polyline_through(line, &polyline_vertices(line, tolerance_rad, k)?)
}

/// The first polyline fallback ([`polyline_candidate`] 0) as the yardstick: its stored
/// numbers, and the curve itself only when it is asked for. Most lines never fall back, and
/// building the curve (a parameter per point from three angles) was a fifth of the
/// yardstick's cost (10m land outlines at 10 m: 0.14 G of 0.69 G instructions).
pub(super) struct Yardstick<'a> {
    line: Line<'a>,
    kept: Option<Vec<usize>>,
    curve: Option<Curve>,
    /// [`stored_numbers`](super::stored_numbers) of the curve, `usize::MAX` without one.
    pub numbers: usize,
}

impl<'a> Yardstick<'a> {
    pub(super) fn new(line: Line<'a>, tolerance_rad: f64) -> Self {
        let dim = line.points.dim();
        let kept = polyline_vertices(line, tolerance_rad, 0);
        if line.free {
            // On uniform knots: dim − 1 numbers per vertex and the degree, when the curve is
            // valid (no two neighbouring vertices antipodal, as `SphericalBSpline::try_new`
            // checks).
            let numbers = kept
                .as_ref()
                .filter(|kept| {
                    kept.len() >= 2
                        && line
                            .points
                            .subset(kept)
                            .check_no_antipodal_neighbours()
                            .is_ok()
                })
                .map_or(usize::MAX, |kept| (dim - 1) * kept.len() + 1);
            return Yardstick {
                line,
                kept,
                curve: None,
                numbers,
            };
        }
        let curve = kept.and_then(|kept| polyline_through(line, &kept));
        let numbers = curve
            .as_ref()
            .map_or(usize::MAX, |c| super::stored_numbers(&c.spline, c.rule));
        Yardstick {
            line,
            kept: None,
            curve,
            numbers,
        }
    }

    /// The curve, built now if it was not yet (`None` when it is not a valid curve).
    pub(super) fn take_curve(&mut self) -> Option<Curve> {
        match self.kept.take() {
            Some(kept) => polyline_through(self.line, &kept),
            None => self.curve.take(),
        }
    }
}

/// The vertices of the `k`-th polyline fallback (see [`polyline_candidate`]).
fn polyline_vertices(line: Line, tolerance_rad: f64, k: usize) -> Option<Vec<usize>> {
    let Line {
        points,
        params: base_params,
        free,
    } = line;
    // Douglas–Peucker bounds the vertices' distance to the kept chords; the ordered two-way
    // distance can be a little more, hence the second try a hair under the tolerance.
    // With given parameters (times) the vertex error is the synchronized distance, so the
    // time-aware Douglas–Peucker (TD-TR) chooses the vertices, and the polyline through every
    // point (error 0 at every parameter) is the last resort. With free parameters, after plain
    // Douglas–Peucker comes the one whose chords keep the points in order (fjords and spikes
    // that plain Douglas–Peucker cuts across, and the two-way distance then catches), at the
    // tolerance and then a hair under it, before every point.
    let every = || (0..points.len()).collect::<Vec<usize>>();
    let kept = match (free, k) {
        (true, 0) => douglas_peucker(points, tolerance_rad),
        (true, 1) => douglas_peucker_ordered(points, tolerance_rad),
        (true, 2) => douglas_peucker(points, 0.95 * tolerance_rad),
        (true, 3) => douglas_peucker_ordered(points, 0.95 * tolerance_rad),
        (true, 4) => every(),
        (false, 0) => synchronized_douglas_peucker(points, base_params, tolerance_rad),
        (false, 1) => synchronized_douglas_peucker(points, base_params, 0.95 * tolerance_rad),
        (false, 2) => every(),
        _ => return None,
    };
    Some(kept)
}

fn polyline_through(line: Line, kept: &[usize]) -> Option<Curve> {
    let Line {
        points,
        params: base_params,
        free,
    } = line;
    let ctrl = points.subset(kept);
    let m = kept.len();
    if free {
        let knots = clamped_uniform_knots(m, 1);
        let mut params = Vec::with_capacity(points.len());
        let mut last: f64 = 0.0;
        for w in 0..m - 1 {
            let (a, b) = (points.get(kept[w]), points.get(kept[w + 1]));
            let theta = crate::sphere::geometry::point::angle_between(a, b);
            let lo = if w == 0 { kept[0] } else { kept[w] + 1 };
            for j in lo..=kept[w + 1] {
                let frac = if j == kept[w + 1] {
                    1.0
                } else if theta > 0.0 {
                    let q = points.get(j);
                    let ta = crate::sphere::geometry::point::angle_between(a, q);
                    let tb = crate::sphere::geometry::point::angle_between(q, b);
                    // Along-track position from the two end distances (law of cosines form).
                    (0.5 + (ta * ta - tb * tb) / (2.0 * theta * theta)).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let t = ((w as f64 + frac) / (m - 1) as f64).max(last);
                last = t;
                params.push(t);
            }
        }
        let last = params.len() - 1;
        params[last] = 1.0;
        let spline = SphericalBSpline::try_new(1, knots, ctrl).ok()?;
        Some(Curve {
            spline,
            params,
            rule: KnotRule::Uniform,
            decided: None,
        })
    } else {
        let mut knots = vec![base_params[kept[0]]; 2];
        for &i in &kept[1..m - 1] {
            knots.push(base_params[i]);
        }
        knots.extend([base_params[kept[m - 1]]; 2]);
        let spline = SphericalBSpline::try_new(1, knots, ctrl).ok()?;
        Some(Curve {
            spline,
            params: base_params.to_vec(),
            rule: KnotRule::Stored,
            decided: None,
        })
    }
}
