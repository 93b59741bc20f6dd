//! Fitting to a tolerance: every point within `tolerance_rad` of the curve, with as few stored
//! numbers as possible.
//!
//! # What is counted
//! [`stored_numbers`]: `dim − 1` numbers per control point (a unit vector in R^dim has dim − 1
//! degrees of freedom; on the Earth, lon/lat), one per stored interior knot (the end knots are
//! 0 and 1 by convention), and one for the degree. Douglas–Peucker stores `dim − 1` per kept
//! vertex ([`polyline_numbers`]). The error is the parametric one (GLS-PIA eqs. 35–36): the
//! angle between each point and the curve at that point's parameter, measured afresh on the
//! returned curve; it is never smaller than the distance to the nearest point of the curve.
//!
//! # How
//! For each candidate degree (1, 2, 3 by default, lowest first) the fewest stored numbers found
//! win; ties go to the smaller error.
//! * **Parameters are unknowns.** Without given parameters, each point's parameter is moved to
//!   its foot point on the curve (Newton on |q − C(t)|², kept non-decreasing, ends pinned at 0
//!   and 1) between Gauss–Newton steps on the control points. The curve then only has to pass
//!   *near* each point, not near it at a prescribed speed. Given parameters (timestamps) are
//!   never moved.
//! * **Degree 1 starts from the ordered Douglas–Peucker.** The spherical Douglas–Peucker
//!   polyline that keeps the points in order along its chords
//!   ([`super::simplify::douglas_peucker_ordered`]) is a degree-1 spline whose foot-point errors
//!   (kept non-decreasing) are within the tolerance before any fitting. Plain Douglas–Peucker
//!   cuts across fjords and spikes whose points then run backwards along the chord; seeded
//!   with it, a coastline spent its time inserting knots back.
//! * **Greedy knot removal with local refits.** Each interior knot in turn is removed, the
//!   p + 1 affected control points and one more on each side are refitted (Gauss–Newton with
//!   Levenberg–Marquardt damping on that window, the rest of the curve untouched, with foot-point
//!   correction), and the removal is kept when every point of the window is still within the
//!   tolerance. Because the vertices of the refitted polyline are free (not data points), it
//!   needs fewer of them than Douglas–Peucker.
//! * **Lawson reweighting.** A least-squares refit can miss the tolerance at one point while a
//!   minimax fit would not: when a removal misses by less than 1.5 times, the points are
//!   reweighted by `1 + (e / tol)^4` and refitted (twice at most).
//! * **Knots by rule, not stored.** With free parameters a degree-1 curve's shape does not depend
//!   on its knots, so they are replaced by uniform ones (parameters mapped span by span, errors
//!   unchanged): 2 numbers per vertex plus 1. For degrees 2 and 3 the fewest control points on
//!   uniform knots that meet the tolerance are found by bisection (only counts that could beat
//!   the best curve so far are tried).
//! * **Knot insertion where the error is too large** (at the worst point of each offending span,
//!   or the span's middle), after a Gauss–Newton fit of the whole curve, until the tolerance is
//!   met: this is how fits with given parameters and all seeds reach the tolerance.
//! * With given parameters, degrees 2 and 3 start from knots at the vertices Douglas–Peucker
//!   keeps at [`ToleranceOptions::seed_factor`] times the tolerance (dominant points), then
//!   insertion and removal as above, knots stored.
//! * With given parameters (times: the vertex error is then the synchronized distance) the
//!   polyline fallbacks and the yardstick are the time-aware Douglas–Peucker's (TD-TR,
//!   [`synchronized_douglas_peucker`]), then the polyline through every point with knots at
//!   the parameters.
//! * The solver is a converged Gauss–Newton (a few passes), never 30 GLS-PIA iterations.
//!
//! # Measured (`scripts/compression_bench.sh --ablation`)
//! Stored numbers summed over tolerances 1, 5, 25, 100 and 500 m, as a fraction of
//! Douglas–Peucker's at the same tolerance, with one idea switched off at a time:
//!
//! | variant | border 10m | GPS tracks | smooth track | flight |
//! |---|---:|---:|---:|---:|
//! | all ideas (default) | 0.96 | 0.88 | 0.30 | 0.09 |
//! | cubic only | 1.00 | 1.02 | 0.32 | 0.09 |
//! | degree 1 only | 0.96 | 0.88 | 0.74 | 0.81 |
//! | no knot removal | 1.00 | 1.02 | 0.32 | 0.09 |
//! | no Lawson reweighting | 0.97 | 0.92 | 0.30 | 0.09 |
//! | no degree probe (degrees 2, 3 always tried) | 0.96 | 0.88 | 0.30 | 0.09 |
//! | no parameter correction | 1.43 | 1.28 | 0.38 | 0.20 |
//! | no knots by rule (all stored) | 1.00 | 1.02 | 1.01 | 1.00 |
//! | plus stored-knot fits of degree 2, 3 (DP-seeded) | 0.96 | 0.88 | 0.30 | 0.09 |
//!
//! Kept: everything in the default. Parameter correction and unstored knots pay most; removal
//! with reweighting is what beats Douglas–Peucker on real lines (borders and GPS tracks are
//! best served by a free-vertex polyline); degree 3 on uniform knots wins on smooth tracks.
//! The degree probe changes no total and no time here (3.3 s with it, 3.2 s without: the
//! smooth lines pass it and the others are short); on coastlines it halves the fitting time
//! (see Cost).
//! Dropped from the default (`adaptive_knots: false`): DP-seeded stored-knot fits of degree >= 2
//! with free parameters save 4 numbers (0.2 %) on the GPS tracks and nothing elsewhere, at 5x
//! the time (17.5 s against 3.3 s for the ablation run); the seed factor (1, 4 or 16) changed no
//! total. Not done:
//! knots of multiplicity p at sharp corners and curvature-guided knots (the winning curves on
//! cornered data are degree 1, where every knot is already a corner).
//!
//! # Cost
//! O(n) per Gauss–Newton pass; removals refit windows of about (p + 3) control points, so a
//! fit costs a few dozen passes' worth of work: milliseconds to seconds for thousands of points
//! (the bench prints the times). What keeps it linear: a removal saves and undoes only its
//! window, in buffers kept between removals; a polyline removal with a point two tolerances
//! from the replacing chord is not refitted; a removal that failed is retried in a later sweep
//! only where a removal since changed its neighbourhood; a line of 1,024 or more seed vertices
//! is cut into pieces of about 512 at pinned seed vertices (sharp corners), fitted in parallel
//! (shifting the vertices behind a removal, and back when it fails, grows with the line). What keeps it fast on real lines:
//! * **A degree probe.** Degrees 2 and 3 are tried only when the best polyline bends the way a
//!   smooth curve does: two thirds or more of its neighbouring turns bend the same way (bends
//!   of three or more vertices between inflections). Coastlines and GPS tracks at small
//!   tolerances turn left, right, left at nearly every vertex; there the polyline is already
//!   the cheapest curve, and the uniform-knot search spent half of a coastline's fitting time
//!   proving it. On the compression bench this changed no result. Nor are they tried where
//!   Douglas–Peucker keeps four fifths of the points or more (every point a corner at the
//!   tolerance: short island rings), which halved the instructions of the short coastline
//!   rings for 0.03 % more numbers.
//! * The uniform-knot search stops a fit whose last pass's gain, kept up for every pass left,
//!   would not reach the target.
//! * The polyline fallbacks are only built when the search found nothing.
//! * Polyline foot points in closed form (the along-track angle on the span's arc); the
//!   two-way checks of polylines in closed form ([`crate::sphere::certify::two_way`]); the pieces of a
//!   long line seeded from the whole line's Douglas–Peucker, not one each.
//!
//! `scripts/speed_bench.sh` measures whole datasets against mapshaper, and
//! `scripts/callgrind_bench.sh` counts instructions (stable on a shared machine).

use super::simplify::{douglas_peucker, douglas_peucker_ordered, synchronized_douglas_peucker};
use crate::sphere::certify::two_way::{
    polyline_length, two_way_distance, TwoWayDistance, TwoWayOptions,
};
use crate::sphere::curve::bspline::{
    clamped_uniform_knots, with_degree, Degree, Frame, Scratch, SphericalBSpline, MAX_DEGREE,
};
use crate::sphere::fit::adaptive_knots::turning_angles;
use crate::sphere::fit::knots::{
    greville_control_points, normalize_parameters, parameters, Parameterization,
};
use crate::sphere::fit::metrics::{measure, ErrorMetrics};
use crate::sphere::geometry::arc::{distance_key, distance_to_arc, ArcFrame};
use crate::sphere::geometry::point::{
    angle, angle_from_chords, angle_from_sine, diff_sum_sq, dot, exp_in_place, slerp, Dim,
    PointSet, SERIES_ANGLE_MAX_RAD,
};
use crate::sphere::linalg::banded::{BandCholesky, SymmetricBand};
use crate::sphere::SphereError;
use serde::{Deserialize, Serialize};

/// How the interior knots of a returned curve are known to a reader.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum KnotRule {
    /// Every interior knot is stored (one number each).
    Stored,
    /// Interior knots are `i / (N − p)`, i = 1 .. N − p − 1: derived from the control point
    /// count N and the degree p, so none is stored.
    Uniform,
}

/// One curve tried while fitting to a tolerance (one per degree and knot strategy).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Candidate {
    /// Spline degree.
    pub degree: usize,
    /// How its knots were placed.
    pub knot_rule: KnotRule,
    /// Control points of the smallest curve found.
    pub control_points: usize,
    /// Numbers that curve stores ([`stored_numbers`]).
    pub stored_numbers: usize,
    /// Vertex error (parametric, at the curve's data parameters).
    pub max_error_rad: f64,
    /// The fitter only decides whether the certified two-way distance to the input polyline
    /// (see [`crate::sphere::certify::two_way`]) is within the tolerance: for a curve that meets it,
    /// the proven bound found (at most the tolerance); for one that does not, the distance of
    /// a curve point or vertex found beyond the tolerance (a lower bound of the distance).
    pub two_way_rad: f64,
    /// Curve length over input polyline length.
    pub curve_length_ratio: f64,
    /// Two-way distance within the tolerance and length ratio within [`MAX_LENGTH_RATIO`].
    pub tolerance_met: bool,
}

/// What to try. `Default` is every idea that paid off in the measurements of the module docs;
/// the switches exist so that the bench (`examples/compression.rs`) can measure each one.
#[derive(Clone, Debug, PartialEq)]
pub struct ToleranceOptions {
    /// Degrees to try; the curve with the fewest stored numbers wins.
    pub degrees: Vec<usize>,
    /// How data points get their initial parameters when none are given.
    pub parameterization: Parameterization,
    /// When no parameters are given, move each point's parameter to its foot point on the
    /// curve (the errors are then close to closest-point distances). Given parameters
    /// (timestamps) are never moved.
    pub correct_parameters: bool,
    /// Remove knots one by one (with a local refit) while the tolerance still holds.
    pub reduce: bool,
    /// When a removal's least-squares refit misses the tolerance narrowly, reweight the points
    /// towards the minimax fit (Lawson) and try again.
    pub reweight: bool,
    /// Also try uniform knots (not stored) where parameters are free.
    pub uniform_knots: bool,
    /// For degrees >= 2 with free parameters, also fit with stored knots seeded at
    /// Douglas–Peucker vertices (with given parameters this is always done).
    pub adaptive_knots: bool,
    /// For degrees >= 2 the first knots sit at the vertices Douglas–Peucker keeps at
    /// `seed_factor × tolerance`; knots are then inserted where the error is too large.
    pub seed_factor: f64,
    /// Most control points per curve (default: the number of points).
    pub max_control_points: Option<usize>,
    /// Keep the end control points at the first and last point, exactly: a clamped curve then
    /// starts and ends at those points bit for bit (pieces of a coverage meeting at a junction,
    /// a ring closed at its seam). Without it the end control points move with the fit, so the
    /// curve ends near (within the tolerance of) the end points only.
    pub pin_ends: bool,
    /// With free parameters, try degrees >= 2 only when the best degree-1 curve bends smoothly
    /// (two thirds of its neighbouring turns the same way; see the module docs): where the
    /// polyline zigzags at the tolerance's scale, a smooth curve needs more control points
    /// than the polyline has vertices, and proving so cost half the fitting time of a
    /// coastline.
    pub degree_probe: bool,
    /// Measure the returned curve's two-way distance to 2 % of the tolerance for
    /// [`ToleranceFit::two_way_rad`]. Off, that field is the bound the fitter decided by
    /// (proven, at most the tolerance, but looser) and the length ratio is the decision's (a
    /// curve that misses is still measured): for callers that measure the curve themselves
    /// after rounding it (the Earth layer); it saved a tenth of a coastline's fitting time.
    pub measure_result: bool,
    /// Stops the fit (with [`SphereError::Cancelled`]) when cancelled or past its deadline.
    pub cancel: crate::sphere::cancel::Cancel,
}

impl Default for ToleranceOptions {
    fn default() -> Self {
        ToleranceOptions {
            degrees: vec![1, 2, 3],
            parameterization: Parameterization::Chord,
            correct_parameters: true,
            reduce: true,
            reweight: true,
            uniform_knots: true,
            adaptive_knots: false,
            seed_factor: 4.0,
            max_control_points: None,
            pin_ends: false,
            degree_probe: true,
            measure_result: true,
            cancel: crate::sphere::cancel::Cancel::inherit(),
        }
    }
}

impl ToleranceOptions {
    /// Sets the candidate degrees.
    pub fn with_degrees(mut self, degrees: &[usize]) -> Self {
        self.degrees = degrees.to_vec();
        self
    }
    /// Switches parameter correction on or off.
    pub fn with_correct_parameters(mut self, on: bool) -> Self {
        self.correct_parameters = on;
        self
    }
    /// Switches knot removal on or off.
    pub fn with_reduce(mut self, on: bool) -> Self {
        self.reduce = on;
        self
    }
    /// Switches Lawson reweighting in removals on or off.
    pub fn with_reweight(mut self, on: bool) -> Self {
        self.reweight = on;
        self
    }
    /// Switches the uniform-knot candidates on or off.
    pub fn with_uniform_knots(mut self, on: bool) -> Self {
        self.uniform_knots = on;
        self
    }
    /// Switches the stored-knot fits of degree >= 2 with free parameters on or off.
    pub fn with_adaptive_knots(mut self, on: bool) -> Self {
        self.adaptive_knots = on;
        self
    }
    /// Sets the Douglas–Peucker seed factor.
    pub fn with_seed_factor(mut self, f: f64) -> Self {
        self.seed_factor = f;
        self
    }
    /// Caps the number of control points.
    pub fn with_max_control_points(mut self, n: usize) -> Self {
        self.max_control_points = Some(n);
        self
    }
    /// Pins (or frees) the end control points at the first and last point.
    pub fn with_pin_ends(mut self, on: bool) -> Self {
        self.pin_ends = on;
        self
    }

    /// Switches the degree probe ([`ToleranceOptions::degree_probe`]) on or off.
    pub fn with_degree_probe(mut self, on: bool) -> Self {
        self.degree_probe = on;
        self
    }
}

/// The result of [`fit_to_tolerance`].
#[derive(Clone, Debug)]
pub struct ToleranceFit {
    /// The curve.
    pub spline: SphericalBSpline,
    /// How its interior knots are known (stored, or derived by rule).
    pub knot_rule: KnotRule,
    /// The data parameters the errors are measured at, in [0, 1], non-decreasing: the given
    /// ones (normalised), or, without given ones, the corrected foot points.
    pub parameters: Vec<f64>,
    /// Errors at those parameters (the parametric geodesic error, radians), measured afresh
    /// on the returned curve.
    pub metrics: ErrorMetrics,
    /// Certified upper bound of the two-way distance between the curve and the input polyline,
    /// with the points matched in order at `parameters` ([`crate::sphere::certify::two_way`]), radians.
    pub two_way_rad: f64,
    /// A two-way distance attained by the curve (a lower bound of it): `two_way_rad` minus this
    /// is how tight that bound is, so a caller can tell whether it serves as a measurement.
    pub two_way_lower_rad: f64,
    /// The curve's length over the input polyline's length.
    pub curve_length_ratio: f64,
    /// The tolerance asked for, radians.
    pub tolerance_rad: f64,
    /// `two_way_rad <= tolerance_rad` (so also every vertex error), and the curve no longer
    /// than [`MAX_LENGTH_RATIO`] times the input.
    pub tolerance_met: bool,
    /// The degree chosen.
    pub degree: usize,
    /// Numbers needed to rebuild the curve, see [`stored_numbers`].
    pub stored_numbers: usize,
    /// Numbers in the input, `(dim − 1)` per point.
    pub input_numbers: usize,
    /// `input_numbers / stored_numbers`.
    pub compression_ratio: f64,
    /// Every curve tried, for diagnostics.
    pub candidates: Vec<Candidate>,
}

/// Numbers needed to rebuild a curve: `dim − 1` per control point (a unit vector in R^dim has
/// dim − 1 degrees of freedom; on the Earth these are lon/lat), one per stored interior knot
/// (the end knots are 0 and 1 by convention), and one for the degree. With [`KnotRule::Uniform`]
/// no knot is stored.
pub fn stored_numbers(spline: &SphericalBSpline, rule: KnotRule) -> usize {
    let n = spline.control_points().len();
    let knots = match rule {
        KnotRule::Stored => n - spline.degree() - 1,
        KnotRule::Uniform => 0,
    };
    (spline.dim() - 1) * n + knots + 1
}

/// Numbers a polyline with `vertices` vertices on S^(dim−1) stores (what Douglas–Peucker keeps).
pub fn polyline_numbers(vertices: usize, dim: usize) -> usize {
    (dim - 1) * vertices
}

/// Fits a spherical B-spline so that every point is within `tolerance_rad` of the curve at its
/// parameter, with as few stored numbers ([`stored_numbers`]) as the strategies in the module
/// docs find.
///
/// `params` (timestamps, say) are normalised to [0, 1] and kept; without them, parameters are
/// chord length to begin with and then corrected to foot points (when
/// `options.correct_parameters`).
///
/// When no curve meets the tolerance (given parameters that repeat for distinct points, a
/// control point cap, a tolerance below rounding), the curve with the smallest max error found
/// is returned with `tolerance_met: false`.
///
/// # Errors
/// Fewer than 2 points, all points equal, antipodal neighbours, invalid parameters, a
/// non-positive or non-finite tolerance, or no usable degree in `options.degrees`.
///
/// # Example
/// ```
/// use spherefit::sphere::{fit_to_tolerance, PointSet, ToleranceOptions};
/// let rows: Vec<[f64; 3]> = (0..400)
///     .map(|i| { let a = i as f64 * 0.002; let lat = 0.05 * (8.0 * a).sin(); [lat.cos() * a.cos(), lat.cos() * a.sin(), lat.sin()] })
///     .collect();
/// let points = PointSet::try_from_rows(&rows).unwrap();
/// // 1e-5 rad: the polyline's own chords sag 1.6e-6 rad off the wave, so at 1e-6 only a
/// // polyline stays within the tolerance of the line, both ways.
/// let fit = fit_to_tolerance(&points, None, 1e-5, &ToleranceOptions::default()).unwrap();
/// assert!(fit.tolerance_met && fit.two_way_rad <= 1e-5);
/// assert!(fit.stored_numbers < 2 * 400 / 10);
/// ```
pub fn fit_to_tolerance(
    points: &PointSet,
    params: Option<&[f64]>,
    tolerance_rad: f64,
    options: &ToleranceOptions,
) -> Result<ToleranceFit, SphereError> {
    let n = points.len();
    if n < 2 {
        return Err(SphereError::TooFewPoints { got: n, need: 2 });
    }
    if !(tolerance_rad > 0.0 && tolerance_rad.is_finite()) {
        return Err(SphereError::InvalidParameters {
            reason: format!("tolerance_rad {tolerance_rad} must be a positive finite number"),
        });
    }
    points.check_no_antipodal_neighbours()?;
    let _scope = options.cancel.enter();
    let (base_params, free) = match params {
        Some(t) => (normalize_parameters(t, n)?, false),
        None => (
            parameters(points, options.parameterization)?,
            options.correct_parameters,
        ),
    };
    let degrees: Vec<usize> = options
        .degrees
        .iter()
        .copied()
        .filter(|&p| (1..=MAX_DEGREE).contains(&p) && p < n)
        .collect();
    if degrees.is_empty() {
        return Err(SphereError::InvalidDegree {
            got: options.degrees.first().copied().unwrap_or(0),
            max: MAX_DEGREE.min(n - 1),
        });
    }
    let cap = options.max_control_points.unwrap_or(n).max(2);
    let mut degrees = degrees;
    degrees.sort_unstable();
    degrees.dedup();
    let input_length = polyline_length(points);
    let measure_options = TwoWayOptions::default()
        .with_precision_rad(TWO_WAY_PRECISION * tolerance_rad)
        .with_max_evaluations(two_way_budget(n));
    // Candidates are only asked "within the tolerance?": intervals proven under it are not
    // refined further, and a sample beyond it ends the check.
    let tw_options = measure_options
        .clone()
        .deciding(tolerance_rad)
        .with_max_evaluations(decide_budget(n));
    let mut candidates: Vec<Candidate> = Vec::new();
    // The best curve that misses, by two-way distance, in case nothing meets.
    let mut best_miss: Option<(Curve, ErrorMetrics, TwoWayDistance)> = None;
    let mut chosen: Option<(Curve, ErrorMetrics, TwoWayDistance)> = None;
    // The curve closest at the vertices among those that miss even the vertex target, for
    // when nothing else is left (parameters that repeat for distinct points, a cap).
    let mut closest: Option<(Curve, ErrorMetrics)> = None;
    // Douglas–Peucker's polyline is the yardstick: a curve storing more numbers than it is
    // never worth proving.
    // The other fallbacks are only built when they are needed.
    let mut first_fallback = polyline_candidate(points, &base_params, free, tolerance_rad, 0);
    let yardstick = first_fallback
        .as_ref()
        .map(|c| stored_numbers(&c.spline, c.rule))
        .unwrap_or(usize::MAX);
    'shares: for &share in VERTEX_SHARES.iter() {
        let (found, near) = search(
            points,
            &base_params,
            free,
            internal_target(share * tolerance_rad),
            cap,
            options,
            &degrees,
            yardstick,
        )?;
        // Lower shares only need more numbers: once the best curve at this share stores as
        // much as the yardstick, no later share can win.
        let cheapest = found
            .iter()
            .map(|(c, _)| stored_numbers(&c.spline, c.rule))
            .min();
        let last_share = cheapest.is_some_and(|s| s >= yardstick);
        if let Some((c, m)) = near {
            if closest
                .as_ref()
                .is_none_or(|(_, b)| m.max_error_rad < b.max_error_rad)
            {
                closest = Some((c, m));
            }
        }
        // Fewest stored numbers first among the curves that meet the vertex target.
        let mut order: Vec<usize> = (0..found.len()).collect();
        order.sort_by_key(|&i| stored_numbers(&found[i].0.spline, found[i].0.rule));
        let mut found: Vec<Option<(Curve, ErrorMetrics)>> = found.into_iter().map(Some).collect();
        for i in order {
            let (c, m) = found[i].take().expect("each curve is taken once");
            if stored_numbers(&c.spline, c.rule) >= yardstick {
                break;
            }
            let tw = two_way_distance(&c.spline, points, &c.params, &tw_options)?;
            let met = accepts(&tw, tolerance_rad, input_length);
            candidates.push(candidate(&c, &m, &tw, met, input_length));
            if met {
                chosen = Some((c, m, tw));
                break 'shares;
            }
            if best_miss
                .as_ref()
                .is_none_or(|b| miss_score(&tw) < miss_score(&b.2))
            {
                best_miss = Some((c, m, tw));
            }
        }
        if last_share {
            break;
        }
    }
    if chosen.is_none() {
        // Towards the polyline: Douglas–Peucker's vertices, then every point.
        for c in (0..POLYLINE_CANDIDATES)
            .filter_map(|k| match k {
                0 => first_fallback.take(),
                _ => polyline_candidate(points, &base_params, free, tolerance_rad, k),
            })
            .filter(|c| c.spline.control_points().len() <= cap)
        {
            let m = measure(&c.spline, points, &c.params);
            let tw = two_way_distance(&c.spline, points, &c.params, &tw_options)?;
            let met = accepts(&tw, tolerance_rad, input_length);
            candidates.push(candidate(&c, &m, &tw, met, input_length));
            if met {
                chosen = Some((c, m, tw));
                break;
            }
            if best_miss
                .as_ref()
                .is_none_or(|b| miss_score(&tw) < miss_score(&b.2))
            {
                best_miss = Some((c, m, tw));
            }
        }
    }
    let met = chosen.is_some();
    let (curve, metrics, decided) = match chosen.or(best_miss) {
        Some((c, m, tw)) => (c, m, Some(tw)),
        None => {
            let (c, m) = closest.ok_or(SphereError::NoValidFit)?;
            (c, m, None)
        }
    };
    // The decision said yes or no; the report gives the distance itself. Both are proven
    // upper bounds, so the smaller one is.
    let tw = match (options.measure_result, decided) {
        (false, Some(tw)) if !tw.exceeded => tw,
        (_, decided) => {
            let mut tw = two_way_distance(&curve.spline, points, &curve.params, &measure_options)?;
            if let Some(d) = decided.filter(|d| !d.exceeded) {
                tw.upper_rad = tw.upper_rad.min(d.upper_rad);
                tw.lower_rad = tw.lower_rad.max(d.lower_rad);
            }
            tw
        }
    };
    let stored = stored_numbers(&curve.spline, curve.rule);
    let input_numbers = polyline_numbers(n, points.dim());
    Ok(ToleranceFit {
        degree: curve.spline.degree(),
        knot_rule: curve.rule,
        tolerance_met: met,
        parameters: curve.params,
        spline: curve.spline,
        metrics,
        two_way_rad: tw.upper_rad,
        two_way_lower_rad: tw.lower_rad.min(tw.upper_rad),
        curve_length_ratio: length_ratio(tw.curve_length_rad, input_length),
        tolerance_rad,
        stored_numbers: stored,
        input_numbers,
        compression_ratio: input_numbers as f64 / stored as f64,
        candidates,
    })
}

/// The shares of the tolerance the vertex errors are fitted to, tried in turn until a curve's
/// two-way distance meets the tolerance: the curve strays between the points, so the points
/// must sit closer than the tolerance; lower shares cost numbers but follow the line tighter.
pub const VERTEX_SHARES: [f64; 3] = [0.8, 0.55, 0.3];

/// Precision of the two-way distances the fitter decides by, as a share of the tolerance.
const TWO_WAY_PRECISION: f64 = 0.02;

/// A curve meeting the two-way bound may still be no longer than this many times the input
/// polyline (plus a tolerance's worth): a curve that wanders within the band is rejected.
pub const MAX_LENGTH_RATIO: f64 = 1.2;

/// Curve evaluations allowed per two-way check: generous, and linear in the input.
fn two_way_budget(n: usize) -> usize {
    4_000_000 + 400 * n
}

/// Curve evaluations allowed per candidate's decision: real lines need tens of thousands (the
/// 10m US–Mexico border at 25 m: 22k); a candidate that needs far more (a tolerance tiny
/// against a curve whose control arcs are near a half turn, where the speed bound is loose) is
/// not proven and so not taken.
fn decide_budget(n: usize) -> usize {
    1_000_000 + 400 * n
}

fn accepts(tw: &TwoWayDistance, tolerance_rad: f64, input_length: f64) -> bool {
    tw.upper_rad <= tolerance_rad
        && tw.curve_length_rad <= MAX_LENGTH_RATIO * input_length + tolerance_rad
}

/// How far a decided curve is known to be: its proven bound, or, when a sample beyond the
/// tolerance ended the check, that sample's distance.
fn miss_score(tw: &TwoWayDistance) -> f64 {
    if tw.exceeded {
        tw.lower_rad
    } else {
        tw.upper_rad
    }
}

fn length_ratio(curve: f64, input: f64) -> f64 {
    if input > 0.0 {
        curve / input
    } else {
        1.0
    }
}

fn candidate(
    c: &Curve,
    m: &ErrorMetrics,
    tw: &TwoWayDistance,
    met: bool,
    input_length: f64,
) -> Candidate {
    Candidate {
        degree: c.spline.degree(),
        knot_rule: c.rule,
        control_points: c.spline.control_points().len(),
        stored_numbers: stored_numbers(&c.spline, c.rule),
        max_error_rad: m.max_error_rad,
        two_way_rad: miss_score(tw),
        curve_length_ratio: length_ratio(tw.curve_length_rad, input_length),
        tolerance_met: met,
    }
}

/// Every degree's curves at one vertex target (see the module docs), with honest errors.
#[allow(clippy::too_many_arguments)]
fn search(
    points: &PointSet,
    base_params: &[f64],
    free: bool,
    target: f64,
    cap: usize,
    options: &ToleranceOptions,
    degrees: &[usize],
    yardstick: usize,
) -> Result<Searched, SphereError> {
    let mut found: Vec<(Curve, ErrorMetrics)> = Vec::new();
    let mut closest: Option<(Curve, ErrorMetrics)> = None;
    for &p in degrees {
        options.cancel.check()?;
        if p >= 2 && free && options.degree_probe {
            // The probe reads the smallest degree-1 curve that met the target, if any.
            let polyline = found
                .iter()
                .filter(|(c, _)| c.spline.degree() == 1)
                .min_by_key(|(c, _)| c.spline.control_points().len());
            if polyline.is_some_and(|(c, _)| !smooth_bends(c.spline.control_points())) {
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
            .filter(|(_, m)| m.max_error_rad <= target)
            .map(|(c, _)| stored_numbers(&c.spline, c.rule))
            .chain((yardstick < usize::MAX).then_some(yardstick))
            .min();
        let curves = crate::with_dim!(points.dim(), |d| with_degree!(p, |g| fit_degree(
            d,
            g,
            points,
            base_params,
            free,
            target,
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

/// Fewest turns (interior vertices) of a polyline for [`smooth_bends`] to judge it; a shorter
/// one is always tried at every degree (its fits are cheap).
const PROBE_MIN_TURNS: usize = 10;

/// A line whose Douglas–Peucker polyline keeps this share of its points or more
/// (`SPARSE_NUMERATOR / SPARSE_DENOMINATOR`) is only fitted by polylines (see [`search`]).
const SPARSE_NUMERATOR: usize = 4;
/// See [`SPARSE_NUMERATOR`].
const SPARSE_DENOMINATOR: usize = 5;

/// Least share of neighbouring turns bending the same way for a polyline to count as smooth.
const PROBE_AGREEMENT: f64 = 2.0 / 3.0;

/// Whether a polyline (the best degree-1 fit) bends the way a smooth curve does at the
/// tolerance's scale: at least [`PROBE_AGREEMENT`] of its neighbouring turns bend the same
/// way, that is bends of three or more vertices on average between inflections. A smooth
/// curve replaces a bend of several vertices by fewer control points; a polyline that turns
/// left, right, left at nearly every vertex (a coastline, a jittery track at a small
/// tolerance) is already the cheapest curve through its corners, and a smooth one needs
/// more control points than it has vertices.
///
/// Measured (`scripts/compression_bench.sh`, `RAYON_NUM_THREADS=1`): the polylines of the
/// borders, the GPS tracks and the noisy track agree on 0.14–0.60 of their turns, the
/// smooth track and the flight where cubics win on 0.75–0.99; on the 10m land outlines no
/// ring that degree 2 or 3 won is skipped. The turn at vertex b is the
/// change of direction there, `unit(c − b) − unit(b − a)` (in any dimension; unit chords, so
/// uneven vertex spacing does not tilt it along the line); two turns agree when their dot
/// product is positive.
fn smooth_bends(ctrl: &PointSet) -> bool {
    let (n, dim) = (ctrl.len(), ctrl.dim());
    if n < PROBE_MIN_TURNS + 2 {
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
type Searched = (Vec<(Curve, ErrorMetrics)>, Option<(Curve, ErrorMetrics)>);

/// How many polyline fallbacks [`polyline_candidate`] knows.
const POLYLINE_CANDIDATES: usize = 4;

/// The `k`-th polyline fallback, degree 1 on uniform knots (none stored): the Douglas–Peucker
/// vertices at the tolerance and a hair under it, then every point. Each point's parameter is
/// where it projects on its segment (kept non-decreasing). With given parameters the vertices
/// are the time-aware Douglas–Peucker's (TD-TR, the error at a point's own parameter) and the
/// knots are the kept points' parameters (stored); the polyline through every point then has
/// error 0 at every parameter, so strictly increasing parameters always meet the tolerance.
fn polyline_candidate(
    points: &PointSet,
    base_params: &[f64],
    free: bool,
    tolerance_rad: f64,
    k: usize,
) -> Option<Curve> {
    // Douglas–Peucker bounds the vertices' distance to the kept chords; the ordered two-way
    // distance can be a little more, hence the second try a hair under the tolerance.
    // With given parameters (times) the vertex error is the synchronized distance, so the
    // time-aware Douglas–Peucker (TD-TR) chooses the vertices, and the polyline through every
    // point (error 0 at every parameter) is the last resort. With free parameters, after plain
    // Douglas–Peucker come the chords that keep the points in order (fjords and spikes that
    // plain Douglas–Peucker cuts across), before every point.
    let every = || (0..points.len()).collect::<Vec<usize>>();
    let kept = match (free, k) {
        (true, 0) => douglas_peucker(points, tolerance_rad),
        (true, 1) => douglas_peucker(points, 0.95 * tolerance_rad),
        (true, 2) => douglas_peucker_ordered(points, 0.95 * tolerance_rad),
        (true, 3) => every(),
        (false, 0) => synchronized_douglas_peucker(points, base_params, tolerance_rad),
        (false, 1) => synchronized_douglas_peucker(points, base_params, 0.95 * tolerance_rad),
        (false, 2) => every(),
        _ => return None,
    };
    polyline_through(points, base_params, free, &kept)
}

fn polyline_through(
    points: &PointSet,
    base_params: &[f64],
    free: bool,
    kept: &[usize],
) -> Option<Curve> {
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
        })
    }
}

/// The error bound the fitter works to: a hair below the tolerance, so that a fresh measurement
/// by another code path (rounding differences of ~1e-16 rad) cannot land above it.
fn internal_target(tolerance_rad: f64) -> f64 {
    tolerance_rad * (1.0 - 1e-9) - 1e-15
}

/// The best state seen while refining: (max error, knots, control points, parameters, errors).
type Snapshot = (f64, Vec<f64>, PointSet, Vec<f64>, Vec<f64>);

/// A finished curve and its data parameters.
struct Curve {
    spline: SphericalBSpline,
    params: Vec<f64>,
    rule: KnotRule,
}

/// Gauss–Newton passes per (local) refit. The fits start close to their optimum (after a knot
/// insertion or removal only a few control points move), and the tolerance test, not the
/// optimum, decides.
const REFIT_ITERATIONS: usize = 6;

/// Foot-point Newton steps per point and refit.
const FOOT_POINT_STEPS: usize = 1;

/// See [`Fitter::refit_or_give_up`].
const GIVE_UP_AFTER: usize = 3;

/// Lawson reweighting rounds when a removal misses the tolerance by less than
/// [`REWEIGHT_WITHIN`] times.
const REWEIGHT_ROUNDS: usize = 2;

/// See [`REWEIGHT_ROUNDS`].
const REWEIGHT_WITHIN: f64 = 1.5;

/// Extra control points freed on each side of a removed knot's p + 1 affected ones.
const REMOVAL_MARGIN: usize = 1;

/// See [`Fitter::hopeless_removal`]: a point this many targets from the chord that would
/// replace a removed vertex's two segments is not brought back by the window's refit.
const HOPELESS_REMOVAL: f64 = 2.0;

/// Removal sweeps over all knots (each sweep stops early when nothing could be removed).
const REMOVAL_SWEEPS: usize = 3;

#[allow(clippy::too_many_arguments)]
fn fit_degree<D: Dim, G: Degree>(
    d: D,
    g: G,
    points: &PointSet,
    base_params: &[f64],
    free: bool,
    target: f64,
    cap: usize,
    budget: Option<usize>,
    options: &ToleranceOptions,
) -> Vec<Curve> {
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
        if let Some((c, met)) = polyline_in_pieces(d, g, points, target, options) {
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
        let Some(mut f) = Fitter::seeded(d, g, points, base_params, free, target, cap, options)
        else {
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
        if let Some(u) = uniform_search(d, g, points, base_params, target, most, options.pin_ends) {
            out.push(u);
        }
    }
    out
}

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
/// pieces run on all threads. The 81,341-point outline of Afro-Eurasia at 100 m
/// (`spherefit fit --tolerance-m 100`, the whole command): 0.74–0.78 s whole on one thread,
/// 0.65 s in pieces of 2,048 on one thread and 0.44 s on two.
///
/// Each junction is the sharpest corner among the seed vertices within [`JUNCTION_REACH`] of
/// every [`PIECE_VERTICES`]-th: a vertex the line turns hard at is kept by any fit, so pinning
/// it loses nothing. Measured (`scripts/callgrind_bench.sh`, `scripts/compression_bench.sh`):
/// pieces of 2,048 at every 2,048th vertex: every 12th 10m land ring 1.383 G instructions,
/// noisy track at 5 m 2,717 numbers; of 512 at every 512th: 1.301 G, 2,745 (+1.0 %); of 512
/// at sharp corners: 1.302 G, 2,709 (no other row of the compression bench moved); of 256:
/// 1.285 G, but the 10m border at 100 m stores 2 more numbers.
///
/// The pieces' polylines join into one on uniform knots: piece k's local parameter t of its
/// m_k vertices maps to (o_k + t (m_k − 1)) / (M − 1), o_k being the segments before it and M
/// the vertices of the whole; the errors are the pieces'.
fn polyline_in_pieces<D: Dim, G: Degree>(
    d: D,
    g: G,
    points: &PointSet,
    target: f64,
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
            // The whole line's seed between the junctions: its chords are the piece's, so it
            // keeps the piece's points in order within the target as it does the line's (and
            // the piece needs no Douglas–Peucker of its own).
            let from = seed.partition_point(|&i| i < a);
            let to = seed.partition_point(|&i| i <= b);
            let kept: Vec<usize> = seed[from..to].iter().map(|&i| i - a).collect();
            let mut f = Fitter::from_kept(d, g, &sub, &params, true, &kept, n, &piece_options)?;
            f.reweight = options.reweight;
            f.refine(target, n);
            let max = f.max_error();
            if max <= target {
                f.reduce(target);
            }
            // Degree 1 on uniform knots is the same polyline: errors unchanged.
            let u = f.to_uniform(f64::INFINITY)?;
            Some((u, f.max_error()))
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

/// Uniform knots, no knot stored: the fewest control points, by bisection between p + 1 and
/// `most`, whose fit with corrected parameters meets the target.
fn uniform_search<D: Dim, G: Degree>(
    d: D,
    g: G,
    points: &PointSet,
    base_params: &[f64],
    target: f64,
    most: usize,
    pin_ends: bool,
) -> Option<Curve> {
    let p = g.get();
    if most < p + 1 {
        return None;
    }
    let try_count = |n_ctrl: usize| -> Option<Fitter<D, G>> {
        let knots = clamped_uniform_knots(n_ctrl, p);
        let mut f = Fitter::with_knots(d, g, points, base_params.to_vec(), true, knots)?;
        if pin_ends {
            f.pin_ends();
        }
        f.correct_all(4);
        f.refit_or_give_up(0, f.n_ctrl(), 3 * REFIT_ITERATIONS, target, 3.0, true);
        Some(f)
    };
    let hi_limit = most;
    let mut lo = p + 1;
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

/// The working state of one degree's fit: knots, control points, data parameters and the error
/// of every point, with local refits on windows of control points.
struct Fitter<'a, D: Dim, G: Degree> {
    d: D,
    g: G,
    points: &'a PointSet,
    free: bool,
    /// Use Lawson reweighting in removals.
    reweight: bool,
    /// The end control points are the first and last point and never move.
    pinned: bool,
    params: Vec<f64>,
    knots: Vec<f64>,
    ctrl: PointSet,
    err: Vec<f64>,
    /// Least-squares weight of each point: 1, raised around points that stay out of tolerance
    /// while a removal is tried (Lawson-style reweighting towards the minimax fit).
    weight: Vec<f64>,
    scratch: Scratch,
    c: Vec<f64>,
    c2: Vec<f64>,
    /// Kept between refits: a removal sweep refits thousands of small windows.
    buffers: RefitBuffers,
    /// What a removal saves to undo itself, kept between removals.
    undo: Undo,
    /// The span of the last evaluation ([`eval_curve`]).
    span_hint: usize,
}

/// The window a knot removal changes, saved before its refit ([`Fitter::try_remove`]).
#[derive(Default)]
struct Undo {
    removed: Vec<f64>,
    ctrl: Vec<f64>,
    params: Vec<f64>,
    err: Vec<f64>,
}

/// The working arrays of one Gauss–Newton refit ([`Fitter::refit_or_give_up`]).
#[derive(Default)]
struct RefitBuffers {
    band: SymmetricBand,
    chol: BandCholesky,
    rhs: Vec<f64>,
    step: Vec<f64>,
    saved: Vec<f64>,
}

/// C(t) into `out`; with `CONTRIB` the contribution coefficients are in `scratch.contrib`.
/// Returns the span, and keeps it in `hint`: the fitter's passes go through the points in
/// order, so the next span is this one or the next and no binary search over the knots is
/// needed.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn eval_curve<D: Dim, G: Degree, const CONTRIB: bool>(
    d: D,
    g: G,
    knots: &[f64],
    ctrl: &PointSet,
    t: f64,
    hint: &mut usize,
    scratch: &mut Scratch,
    out: &mut [f64],
) -> usize {
    let frame = Frame::new(g.get(), knots, ctrl);
    let k = frame.span_from((*hint).clamp(frame.p, frame.last_span), t);
    *hint = k;
    frame.eval::<D, G, CONTRIB, false>(d, g, k, t, scratch, out);
    k
}

impl<'a, D: Dim, G: Degree> Fitter<'a, D, G> {
    fn with_knots(
        d: D,
        g: G,
        points: &'a PointSet,
        params: Vec<f64>,
        free: bool,
        knots: Vec<f64>,
    ) -> Option<Self> {
        let p = g.get();
        let ctrl = greville_control_points(points, &params, &knots, p).ok()?;
        let mut f = Fitter {
            d,
            g,
            points,
            free,
            reweight: false,
            pinned: false,
            err: vec![0.0; points.len()],
            weight: vec![1.0; points.len()],
            params,
            knots,
            ctrl,
            scratch: Scratch::new(p, d.get()),
            c: vec![0.0; d.get()],
            c2: vec![0.0; d.get()],
            buffers: RefitBuffers::default(),
            undo: Undo::default(),
            span_hint: p,
        };
        f.measure_range(0, points.len());
        Some(f)
    }

    /// The first curve: for degree 1 the Douglas–Peucker polyline at the tolerance itself (which
    /// meets it once parameters are foot points); for higher degrees knots at the vertices of a
    /// coarser Douglas–Peucker, the curve then fitted.
    #[allow(clippy::too_many_arguments)]
    fn seeded(
        d: D,
        g: G,
        points: &'a PointSet,
        base_params: &[f64],
        free: bool,
        target: f64,
        cap: usize,
        options: &ToleranceOptions,
    ) -> Option<Self> {
        let p = g.get();
        let factor = if p == 1 { 1.0 } else { options.seed_factor };
        // The polyline seed keeps the points in order along its chords (fjords, spikes), so it
        // meets the target once parameters are foot points, without knot insertions.
        let kept = if p == 1 {
            douglas_peucker_ordered(points, target)
        } else {
            douglas_peucker(points, target * factor)
        };
        Self::from_kept(d, g, points, base_params, free, &kept, cap, options)
    }

    /// [`seeded`](Self::seeded) from the vertices `kept` (ascending, the first and the last
    /// point among them) of a Douglas–Peucker polyline already computed.
    #[allow(clippy::too_many_arguments)]
    fn from_kept(
        d: D,
        g: G,
        points: &'a PointSet,
        base_params: &[f64],
        free: bool,
        kept: &[usize],
        cap: usize,
        options: &ToleranceOptions,
    ) -> Option<Self> {
        let p = g.get();
        let last = points.len() - 1;
        let mut vertices = vec![0];
        let mut interior: Vec<f64> = Vec::with_capacity(kept.len());
        for &i in &kept[1..kept.len() - 1] {
            let u = base_params[i];
            if u > interior.last().copied().unwrap_or(0.0) && u < 1.0 {
                interior.push(u);
                vertices.push(i);
            }
        }
        vertices.push(last);
        if vertices.len() + p - 1 > cap {
            // Too many for the cap: the cap's count of control points on uniform knots.
            let mut f = Fitter::with_knots(
                d,
                g,
                points,
                base_params.to_vec(),
                free,
                clamped_uniform_knots(cap, p),
            )?;
            if options.pin_ends {
                f.pin_ends();
            }
            if free {
                f.correct_all(4);
            }
            return Some(f);
        }
        let mut knots = vec![0.0; p + 1];
        knots.extend(interior);
        knots.extend(std::iter::repeat_n(1.0, p + 1));
        let mut f = if p == 1 {
            // The polyline itself: control points at the kept vertices.
            let dim = d.get();
            let mut f = Fitter {
                d,
                g,
                points,
                free,
                reweight: false,
                pinned: false,
                err: vec![0.0; points.len()],
                weight: vec![1.0; points.len()],
                params: base_params.to_vec(),
                knots,
                ctrl: points.subset(&vertices),
                scratch: Scratch::new(p, dim),
                c: vec![0.0; dim],
                c2: vec![0.0; dim],
                buffers: RefitBuffers::default(),
                undo: Undo::default(),
                span_hint: p,
            };
            f.measure_range(0, points.len());
            f
        } else {
            Fitter::with_knots(d, g, points, base_params.to_vec(), free, knots)?
        };
        if options.pin_ends {
            f.pin_ends();
        }
        if free {
            f.correct_all(4);
        }
        Some(f)
    }

    /// Puts the end control points on the first and last point and keeps them there.
    fn pin_ends(&mut self) {
        let (n, last) = (self.n_ctrl(), self.points.len() - 1);
        self.ctrl.get_mut(0).copy_from_slice(self.points.get(0));
        self.ctrl
            .get_mut(n - 1)
            .copy_from_slice(self.points.get(last));
        self.pinned = true;
        self.measure_range(0, self.points.len());
    }

    fn p(&self) -> usize {
        self.g.get()
    }

    /// The line ends where it starts (a ring given as a line).
    fn closed(&self) -> bool {
        let n = self.points.len();
        n > 2 && self.points.get(0) == self.points.get(n - 1)
    }

    fn n_ctrl(&self) -> usize {
        self.ctrl.len()
    }

    fn max_error(&self) -> f64 {
        self.err.iter().fold(0.0, |a, &b| a.max(b))
    }

    /// The fitted spline; `None` when it is not a valid spline (two neighbouring control
    /// points (nearly) antipodal, as a fit along a great circle can make): that candidate is
    /// dropped rather than returned.
    fn into_curve(self, rule: KnotRule) -> Option<Curve> {
        let spline = SphericalBSpline::try_new(self.p(), self.knots, self.ctrl).ok()?;
        Some(Curve {
            spline,
            params: self.params,
            rule,
        })
    }

    fn last_span(&self) -> usize {
        let (p, n) = (self.p(), self.n_ctrl());
        (p..n)
            .rev()
            .find(|&k| self.knots[k] < self.knots[k + 1])
            .unwrap_or(p)
    }

    /// The data points whose curve point depends on control points `c0 .. c1`.
    fn window_points(&self, c0: usize, c1: usize) -> (usize, usize) {
        let p = self.p();
        let last = self.last_span();
        let kmin = c0.max(p);
        let kmax = (c1 + p - 1).min(last);
        if kmin > kmax {
            return (0, 0);
        }
        let lo = if kmin == p {
            f64::NEG_INFINITY
        } else {
            self.knots[kmin]
        };
        let hi = if kmax == last {
            f64::INFINITY
        } else {
            self.knots[kmax + 1]
        };
        let j0 = self.params.partition_point(|&t| t < lo);
        let j1 = self.params.partition_point(|&t| t < hi);
        (j0, j1)
    }

    fn error_at(&mut self, j: usize, t: f64) -> f64 {
        eval_curve::<D, G, false>(
            self.d,
            self.g,
            &self.knots,
            &self.ctrl,
            t,
            &mut self.span_hint,
            &mut self.scratch,
            &mut self.c,
        );
        angle(self.d, self.points.get(j), &self.c)
    }

    /// Measures points `j0 .. j1` into `err`; returns (max, sum of squares).
    fn measure_range(&mut self, j0: usize, j1: usize) -> (f64, f64) {
        let (mut max, mut sq): (f64, f64) = (0.0, 0.0);
        for j in j0..j1 {
            let e = self.error_at(j, self.params[j]);
            self.err[j] = e;
            max = max.max(e);
            sq += self.weight[j] * e * e;
        }
        (max, sq)
    }

    /// Moves the parameters of points `j0 .. j1` towards their foot points (Newton on
    /// |q − C(t)|², central differences for C'), keeping them non-decreasing and the end points
    /// at 0 and 1. A step is kept only when it lowers that point's error.
    fn correct_range(&mut self, j0: usize, j1: usize, steps: usize) {
        if !self.free {
            return;
        }
        if self.p() == 1 {
            self.correct_range_polyline(j0, j1);
            return;
        }
        let n = self.points.len();
        let dim = self.d.get();
        for j in j0.max(1)..j1.min(n - 1) {
            let (lo, hi) = (self.params[j - 1], self.params[j + 1]);
            let mut t = self.params[j];
            let mut e = self.err[j];
            for _ in 0..steps {
                if e == 0.0 {
                    break;
                }
                let k = eval_curve::<D, G, false>(
                    self.d,
                    self.g,
                    &self.knots,
                    &self.ctrl,
                    t,
                    &mut self.span_hint,
                    &mut self.scratch,
                    &mut self.c,
                );
                let width = (self.knots[k + 1] - self.knots[k]).max(1e-12);
                let h = 1e-4 * width;
                // Forward difference inside the span (backward at its end): C' is smooth there.
                let (ta, tb) = if t + h <= self.knots[k + 1] {
                    (t, t + h)
                } else {
                    (t - h, t)
                };
                eval_curve::<D, G, false>(
                    self.d,
                    self.g,
                    &self.knots,
                    &self.ctrl,
                    tb,
                    &mut self.span_hint,
                    &mut self.scratch,
                    &mut self.c2,
                );
                let mut dc = [0.0; 16];
                let mut heap = Vec::new();
                let dc: &mut [f64] = if dim <= 16 {
                    &mut dc[..dim]
                } else {
                    heap.resize(dim, 0.0);
                    &mut heap
                };
                dc.copy_from_slice(&self.c2[..dim]);
                let inv = 1.0 / (tb - ta);
                if ta == t {
                    for x in 0..dim {
                        dc[x] = (dc[x] - self.c[x]) * inv;
                    }
                } else {
                    eval_curve::<D, G, false>(
                        self.d,
                        self.g,
                        &self.knots,
                        &self.ctrl,
                        ta,
                        &mut self.span_hint,
                        &mut self.scratch,
                        &mut self.c2,
                    );
                    for x in 0..dim {
                        dc[x] = (dc[x] - self.c2[x]) * inv;
                    }
                }
                let q = self.points.get(j);
                let mut num = 0.0;
                for x in 0..dim {
                    num += (q[x] - self.c[x]) * dc[x];
                }
                let den = dot(self.d, dc, dc);
                if den <= 0.0 || !num.is_finite() {
                    break;
                }
                let tn = (t + num / den).clamp(lo, hi);
                if tn == t {
                    break;
                }
                let en = self.error_at(j, tn);
                if en < e {
                    t = tn;
                    e = en;
                } else {
                    break;
                }
            }
            self.params[j] = t;
            self.err[j] = e;
        }
    }

    /// [`correct_range`](Self::correct_range) for a polyline: the foot point on the arc of the
    /// span holding the parameter, in closed form (the arc's along-track angle over its
    /// length), instead of Newton steps with finite differences (three curve evaluations per
    /// point, a sixth of a coastline's fitting time). A foot beyond the span's end stops at
    /// its vertex; the next correction carries on from the next span. Kept non-decreasing
    /// and only where it lowers the point's error, as the Newton steps are.
    fn correct_range_polyline(&mut self, j0: usize, j1: usize) {
        let n = self.points.len();
        let d = self.d;
        let last = self.last_span();
        let mut k = 1;
        for j in j0.max(1)..j1.min(n - 1) {
            let e = self.err[j];
            if e == 0.0 {
                continue;
            }
            let (lo, hi) = (self.params[j - 1], self.params[j + 1]);
            let t = self.params[j];
            if !(self.knots[k] <= t && (t < self.knots[k + 1] || k == last)) {
                k = self
                    .knots
                    .partition_point(|&u| u <= t)
                    .saturating_sub(1)
                    .clamp(1, last);
            }
            let q = self.points.get(j);
            // The foot on span k's arc, as (parameter, where it fell: -1 before the arc's
            // start, 1 past its end, 0 on it, and then the point's distance to it).
            let foot = |k: usize| -> Option<(f64, i8, f64)> {
                let (u0, u1) = (self.knots[k], self.knots[k + 1]);
                let arc = ArcFrame::new(d, self.ctrl.get(k - 1), self.ctrl.get(k));
                if arc.degenerate() || arc.is_antipodal() || u1 <= u0 {
                    return None;
                }
                let (x, y) = (dot(d, q, &arc.e1), dot(d, q, &arc.e2));
                // The along-track angle atan2(y, x), by its sine where it is small (a point
                // near a short arc), without libm's atan2.
                let r = (x * x + y * y).sqrt();
                let phi = if x > 0.0 && y.abs() <= 0.1 * r {
                    angle_from_sine(y.abs() / r).copysign(y)
                } else {
                    y.atan2(x)
                };
                let alpha = phi / arc.theta;
                if alpha < 0.0 {
                    return Some((u0, -1, f64::NAN));
                }
                if alpha > 1.0 {
                    return Some((u1, 1, f64::NAN));
                }
                // The curve point at the foot is q's projection on the arc's great circle:
                // the error there is the cross-track distance, asin |q - x e1 - y e2|.
                let mut perp_sq = 0.0;
                for c in 0..d.get() {
                    let r = q[c] - x * arc.e1[c] - y * arc.e2[c];
                    perp_sq += r * r;
                }
                let dist = angle_from_sine(perp_sq.sqrt());
                Some((u0 + alpha * (u1 - u0), 0, dist))
            };
            let Some(mut best) = foot(k) else {
                continue;
            };
            // Past a vertex: the foot may lie on the next arc (or the one before).
            let next = match best.1 {
                1 if k < last => foot(k + 1),
                -1 if k > 1 => foot(k - 1),
                _ => None,
            };
            if let Some(f @ (_, 0, _)) = next {
                best = f;
            }
            let (tn, side, dist) = best;
            let clamped = tn.clamp(lo, hi);
            if clamped == t {
                continue;
            }
            // On the arc and not held back by a neighbour's parameter: the distance is known
            // (evaluating the curve there gives the same to rounding); otherwise measure.
            let en = if side == 0 && clamped == tn && dist < 0.1 {
                dist
            } else {
                self.error_at(j, clamped)
            };
            if en < e {
                self.params[j] = clamped;
                self.err[j] = en;
            }
        }
    }

    fn correct_all(&mut self, steps: usize) {
        self.correct_range(0, self.points.len(), steps);
    }

    /// Gauss–Newton with Levenberg–Marquardt damping on control points `c0 .. c1` (the others
    /// fixed), alternating with foot-point correction; stops once the window's max error is at
    /// or below `target`, or when it stops improving. Returns the window's max error.
    fn refit(&mut self, c0: usize, c1: usize, iterations: usize, target: f64) -> f64 {
        self.refit_or_give_up(c0, c1, iterations, target, f64::INFINITY, false)
    }

    /// [`refit`](Self::refit) that stops after [`GIVE_UP_AFTER`] iterations when the max error
    /// is still above `give_up × target`: used where a miss is cheap (bisection, removals).
    /// With `stall`, it also stops once even the last pass's gain, kept up for every pass
    /// left, would not reach the target (the passes slow down, they do not speed up): the
    /// long whole-curve fits of the uniform-knot search, where a doomed fit otherwise runs
    /// all its passes. (Not in removals: there the short refits decide which knots go, and
    /// stopping them early changed the greedy order for the worse on the 10m border.)
    #[allow(clippy::too_many_arguments)]
    fn refit_or_give_up(
        &mut self,
        c0: usize,
        c1: usize,
        iterations: usize,
        target: f64,
        give_up: f64,
        stall: bool,
    ) -> f64 {
        // A closed line keeps its seam, and pinned ends (junctions of a coverage) stay: the
        // end control points stay on the first and last points, so a ring is closed as
        // fitted and closing it later moves nothing.
        let (c0, c1) = if self.pinned || self.closed() {
            (c0.max(1), c1.min(self.n_ctrl() - 1))
        } else {
            (c0, c1)
        };
        if c0 >= c1 {
            // Nothing free to move (two pinned control points): the window's error as it is.
            let (j0, j1) = self.window_points(0, self.n_ctrl());
            return self.measure_range(j0, j1).0;
        }
        let (j0, j1) = self.window_points(c0, c1);
        if j0 >= j1 {
            return 0.0;
        }
        let (p, dim, d) = (self.p(), self.d.get(), self.d);
        let nf = c1 - c0;
        let (mut max, mut loss) = self.measure_range(j0, j1);
        let mut lambda = 0.0;
        let mut buffers = std::mem::take(&mut self.buffers);
        buffers.saved.resize(nf * dim, 0.0);
        let mut before = f64::INFINITY;
        for it in 0..iterations {
            let stalled = stall
                && it >= GIVE_UP_AFTER
                && max - target > (iterations - it) as f64 * (before - max);
            if max <= target
                || (it >= GIVE_UP_AFTER && max > give_up * target)
                || stalled
                || crate::sphere::cancel::cancelled()
            {
                break;
            }
            before = max;
            let RefitBuffers {
                band,
                chol,
                rhs,
                step,
                saved,
            } = &mut buffers;
            band.reset(nf, p);
            rhs.clear();
            rhs.resize(nf * dim, 0.0);
            for j in j0..j1 {
                let t = self.params[j];
                let k = eval_curve::<D, G, true>(
                    d,
                    self.g,
                    &self.knots,
                    &self.ctrl,
                    t,
                    &mut self.span_hint,
                    &mut self.scratch,
                    &mut self.c,
                );
                let q = self.points.get(j);
                let (m2, p2) = diff_sum_sq(d, q, &self.c);
                let (theta, _) = angle_from_chords(m2, p2);
                let scale = if theta <= SERIES_ANGLE_MAX_RAD {
                    1.0 / crate::sphere::geometry::point::sinc_series(theta)
                } else {
                    let s = 0.5 * m2.sqrt() * p2.sqrt();
                    if s > 0.0 {
                        theta / s
                    } else {
                        0.0
                    }
                };
                let cos = dot(d, q, &self.c);
                let wj = self.weight[j];
                let coef = &self.scratch.contrib;
                let first = k - p;
                for m in 0..=p {
                    let i = first + m;
                    if i < c0 || i >= c1 {
                        continue;
                    }
                    let w = wj * coef[m];
                    for m2 in m..=p {
                        let i2 = first + m2;
                        if i2 >= c1 {
                            break;
                        }
                        band.add_upper(i - c0, i2 - c0, w * coef[m2]);
                    }
                    let ws = w * scale;
                    let row = &mut rhs[(i - c0) * dim..(i - c0 + 1) * dim];
                    for x in 0..dim {
                        row[x] += ws * (q[x] - cos * self.c[x]);
                    }
                }
            }
            let ridge = 1e-12 * band.max_diagonal().max(f64::MIN_POSITIVE);
            saved.clear();
            saved.extend_from_slice(&self.ctrl.as_flat()[c0 * dim..c1 * dim]);
            let mut accepted = None;
            for _ in 0..8 {
                if !band.cholesky_into(lambda, ridge, chol) {
                    lambda = (lambda * 10.0).max(1e-6);
                    continue;
                }
                step.clear();
                step.extend_from_slice(rhs);
                chol.solve_in_place(step, dim);
                for i in 0..nf {
                    move_along_geodesic(
                        d,
                        self.ctrl.get_mut(c0 + i),
                        &step[i * dim..(i + 1) * dim],
                    );
                }
                let (nmax, nloss) = self.measure_range(j0, j1);
                if nloss < loss {
                    lambda = if lambda < 1e-9 { 0.0 } else { lambda / 10.0 };
                    accepted = Some((nmax, nloss));
                    break;
                }
                self.restore(c0, saved);
                lambda = if lambda == 0.0 { 1e-4 } else { lambda * 10.0 };
            }
            let Some((nmax, nloss)) = accepted else {
                max = self.measure_range(j0, j1).0;
                break;
            };
            let gain = loss - nloss;
            max = nmax;
            loss = nloss;
            if self.free {
                self.correct_range(j0, j1, FOOT_POINT_STEPS);
                let (m, l) = (
                    self.err[j0..j1].iter().fold(0.0, |a: f64, &b| a.max(b)),
                    (j0..j1)
                        .map(|j| self.weight[j] * self.err[j] * self.err[j])
                        .sum::<f64>(),
                );
                max = m;
                loss = l;
            } else if gain <= 1e-6 * loss {
                break;
            }
        }
        self.buffers = buffers;
        max
    }

    fn restore(&mut self, c0: usize, saved: &[f64]) {
        let dim = self.d.get();
        for (i, row) in saved.chunks_exact(dim).enumerate() {
            self.ctrl.get_mut(c0 + i).copy_from_slice(row);
        }
    }

    /// Inserts knots where points are out of tolerance (at the worst point's parameter, or the
    /// span's middle when that is too close to a knot) and refits, until the target is met, the
    /// cap is reached or nothing can be inserted.
    fn refine(&mut self, target: f64, cap: usize) {
        let mut best: Option<Snapshot> = None;
        loop {
            let n = self.n_ctrl();
            let max = self.refit(0, n, REFIT_ITERATIONS, target);
            let max = max.max(self.max_error());
            if best.as_ref().is_none_or(|b| max < b.0) {
                best = Some((
                    max,
                    self.knots.clone(),
                    self.ctrl.clone(),
                    self.params.clone(),
                    self.err.clone(),
                ));
            }
            if max <= target || n >= cap || crate::sphere::cancel::cancelled() {
                break;
            }
            // Worst out-of-tolerance point per span.
            let frame_last = self.last_span();
            let p = self.p();
            let mut worst: Vec<(usize, usize, f64)> = Vec::new(); // (span, j, err)
            for j in 0..self.points.len() {
                if self.err[j] <= target {
                    continue;
                }
                let t = self.params[j];
                let k = (self.knots.partition_point(|&u| u <= t).saturating_sub(1))
                    .clamp(p, frame_last);
                match worst.last_mut() {
                    Some(w) if w.0 == k => {
                        if self.err[j] > w.2 {
                            *w = (k, j, self.err[j]);
                        }
                    }
                    _ => worst.push((k, j, self.err[j])),
                }
            }
            let mut inserted = 0;
            for &(k, j, _) in worst.iter().rev() {
                if self.n_ctrl() >= cap {
                    break;
                }
                let (a, b) = (self.knots[k], self.knots[k + 1]);
                let w = b - a;
                if w <= 1e-12 {
                    continue;
                }
                let t = self.params[j];
                let u = if t - a > 0.1 * w && b - t > 0.1 * w {
                    t
                } else {
                    0.5 * (a + b)
                };
                self.insert_knot(k, u);
                inserted += 1;
            }
            if inserted == 0 {
                break;
            }
        }
        if let Some((max, knots, ctrl, params, err)) = best {
            if max < self.max_error() {
                self.knots = knots;
                self.ctrl = ctrl;
                self.params = params;
                self.err = err;
            }
        }
    }

    /// Boehm's knot insertion with SLERP in place of the affine combinations: `u` in span k.
    fn insert_knot(&mut self, k: usize, u: f64) {
        let (p, dim) = (self.p(), self.d.get());
        let n = self.n_ctrl();
        let old = self.ctrl.as_flat();
        let mut coords = Vec::with_capacity((n + 1) * dim);
        coords.extend_from_slice(&old[..(k + 1 - p) * dim]);
        for i in k + 1 - p..=k {
            let den = self.knots[i + p] - self.knots[i];
            let alpha = if den > 0.0 {
                ((u - self.knots[i]) / den).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let (a, b) = (self.ctrl.get(i - 1), self.ctrl.get(i));
            match slerp(a, b, alpha) {
                Ok(v) => coords.extend_from_slice(&v),
                Err(_) => coords.extend_from_slice(b),
            }
        }
        coords.extend_from_slice(&old[k * dim..]);
        self.ctrl = PointSet::from_flat_unchecked(dim, coords);
        self.knots.insert(k + 1, u);
    }

    /// Greedy knot removal: each interior knot in turn is removed, the p + 1 + 2·margin control
    /// points around it refitted, and the removal kept when the tolerance still holds.
    ///
    /// A removal that failed is tried again in a later sweep only when a removal since then
    /// changed what it reads (the control points, parameters and errors within reach of its
    /// window): the refit is deterministic, so an unchanged neighbourhood fails again. This
    /// skips most of the second and third sweeps without changing the result.
    fn reduce(&mut self, target: f64) {
        let p = self.p();
        // Per knot: its removal failed and nothing within its reach changed since.
        let mut clean = vec![false; self.knots.len()];
        for _ in 0..REMOVAL_SWEEPS {
            let mut removed = 0;
            let mut r = p + 1;
            while r < self.n_ctrl() && !crate::sphere::cancel::cancelled() {
                if clean[r] {
                    r += 1;
                } else if let Some((c0, c1)) = self.try_remove(r, target) {
                    removed += 1;
                    clean.remove(r);
                    // Windows that read control points c0 .. c1 (or their points) belong to
                    // knots from about c0 − p − margin to c1 + 2p + margin.
                    let lo = c0.saturating_sub(p + REMOVAL_MARGIN + 2);
                    let hi = (c1 + 2 * p + REMOVAL_MARGIN + 3).min(clean.len());
                    clean[lo..hi].iter_mut().for_each(|c| *c = false);
                } else {
                    clean[r] = true;
                    r += 1;
                }
            }
            if removed == 0 {
                break;
            }
        }
    }

    /// Tries to remove knot `r`: the refitted window of control points when kept.
    fn try_remove(&mut self, r: usize, target: f64) -> Option<(usize, usize)> {
        let (p, dim) = (self.p(), self.d.get());
        let n = self.n_ctrl();
        if n <= p + 1 {
            return None;
        }
        let c = r - p.div_ceil(2);
        if p == 1 && self.hopeless_removal(c, target) {
            return None;
        }
        // Only the window changes: it alone is saved, and the removal is undone in place.
        let mut undo = std::mem::take(&mut self.undo);
        let knot_removed = self.knots.remove(r);
        undo.removed.clear();
        undo.removed.extend_from_slice(self.ctrl.get(c));
        self.ctrl.remove(c);
        let n = n - 1;
        let c0 = (r + 1).saturating_sub(p + 2 + REMOVAL_MARGIN);
        let c1 = (r + REMOVAL_MARGIN).min(n);
        undo.ctrl.clear();
        undo.ctrl
            .extend_from_slice(&self.ctrl.as_flat()[c0 * dim..c1 * dim]);
        let (j0, j1) = self.window_points(c0, c1);
        undo.params.clear();
        undo.params.extend_from_slice(&self.params[j0..j1]);
        undo.err.clear();
        undo.err.extend_from_slice(&self.err[j0..j1]);
        let mut max = self.refit_or_give_up(c0, c1, REFIT_ITERATIONS, target, 4.0, false);
        if self.reweight {
            let mut round = 0;
            while max > target && max <= REWEIGHT_WITHIN * target && round < REWEIGHT_ROUNDS {
                for j in j0..j1 {
                    let r = self.err[j] / target;
                    self.weight[j] *= 1.0 + r * r * r * r;
                }
                max = self.refit(c0, c1, REFIT_ITERATIONS, target);
                round += 1;
            }
            self.weight[j0..j1].iter_mut().for_each(|w| *w = 1.0);
        }
        let kept = max <= target && self.vertices_near_the_line(c0, c1, target);
        if !kept {
            self.restore(c0, &undo.ctrl);
            self.ctrl.insert(c, &undo.removed);
            self.knots.insert(r, knot_removed);
            self.params[j0..j1].copy_from_slice(&undo.params);
            self.err[j0..j1].copy_from_slice(&undo.err);
        }
        self.undo = undo;
        kept.then_some((c0, c1))
    }

    /// For a polyline (degree 1): removing vertex `c` replaces its two segments by the chord
    /// between its neighbours; when a data point of those segments lies farther than
    /// [`HOPELESS_REMOVAL`] times the target from that chord, the local refit (which moves the
    /// neighbours a little) cannot bring it back, and trying costs a Gauss–Newton refit.
    fn hopeless_removal(&self, c: usize, target: f64) -> bool {
        let n = self.n_ctrl();
        if c == 0 || c + 1 >= n {
            return false;
        }
        // Degree 1: control point i sits at knot i + 1; the two spans around c run from
        // knot c to knot c + 2.
        let (lo, hi) = (self.knots[c], self.knots[c + 2]);
        let j0 = self.params.partition_point(|&t| t < lo);
        let j1 = self.params.partition_point(|&t| t <= hi);
        let chord = ArcFrame::new(self.d, self.ctrl.get(c - 1), self.ctrl.get(c + 1));
        let limit = HOPELESS_REMOVAL * target;
        if chord.is_antipodal() {
            return (j0..j1).any(|j| chord.distance_dyn(self.points.get(j)) > limit);
        }
        // Compared by their keys: no square root or arcsine per point.
        let key = distance_key(limit);
        (j0..j1).any(|j| chord.distance_key(self.d, self.points.get(j)) > key)
    }

    /// For a polyline (degree 1), whether control points `c0 .. c1` lie within `target` of the
    /// input segment at their parameter. The vertex errors bound the input's vertices against
    /// the curve; the curve's own corners are what can stray from the input between them (a
    /// removal that cuts across a fjord whose points all stay near the new chord, in order),
    /// and such a curve would fail the two-way check later, after all the work. Higher degrees
    /// are left to that check.
    fn vertices_near_the_line(&self, c0: usize, c1: usize, target: f64) -> bool {
        if self.p() != 1 {
            return true;
        }
        let n = self.points.len();
        (c0.max(1)..c1.min(self.n_ctrl() - 1)).all(|i| {
            let u = self.knots[i + 1];
            let j = self.params.partition_point(|&t| t <= u).clamp(1, n - 1) - 1;
            let v = self.ctrl.get(i);
            let d = distance_to_arc(v, self.points.get(j), self.points.get(j + 1));
            // At a data parameter exactly, either neighbouring segment will do.
            d <= target
                || (j > 0
                    && self.params[j] == u
                    && distance_to_arc(v, self.points.get(j - 1), self.points.get(j)) <= target)
        })
    }

    /// The same curve family with uniform knots (none stored). For degree 1 the polyline is
    /// unchanged (only its speed changes), so parameters are mapped span by span and the errors
    /// stay the same; for higher degrees the curve is refitted. `None` when the target is missed.
    fn to_uniform(&self, target: f64) -> Option<Curve> {
        let p = self.p();
        let n = self.n_ctrl();
        let knots = clamped_uniform_knots(n, p);
        let last = self.last_span();
        let params: Vec<f64> = self
            .params
            .iter()
            .map(|&t| {
                let k = (self.knots.partition_point(|&u| u <= t).saturating_sub(1)).clamp(p, last);
                let (a, b) = (self.knots[k], self.knots[k + 1]);
                let f = if b > a {
                    ((t - a) / (b - a)).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                knots[k] + f * (knots[k + 1] - knots[k])
            })
            .collect();
        let mut f = Fitter {
            d: self.d,
            g: self.g,
            points: self.points,
            free: true,
            reweight: false,
            pinned: self.pinned,
            params,
            knots,
            ctrl: self.ctrl.clone(),
            err: vec![0.0; self.points.len()],
            weight: vec![1.0; self.points.len()],
            scratch: Scratch::new(p, self.d.get()),
            c: vec![0.0; self.d.get()],
            c2: vec![0.0; self.d.get()],
            buffers: RefitBuffers::default(),
            undo: Undo::default(),
            span_hint: p,
        };
        let mut max = f.measure_range(0, self.points.len()).0;
        if max > target && p >= 2 {
            f.correct_all(4);
            max = f
                .refit(0, n, 3 * REFIT_ITERATIONS, target)
                .max(f.max_error());
        }
        if max <= target {
            f.into_curve(KnotRule::Uniform)
        } else {
            None
        }
    }
}

/// `P ← exp_P(v)` with `v` projected onto the tangent plane at P.
fn move_along_geodesic<D: Dim>(d: D, pt: &mut [f64], v: &[f64]) {
    let along = dot(d, pt, v);
    let mut stack = [0.0; 16];
    let mut heap = Vec::new();
    let t: &mut [f64] = if d.get() <= 16 {
        &mut stack[..d.get()]
    } else {
        heap.resize(d.get(), 0.0);
        &mut heap
    };
    for x in 0..d.get() {
        t[x] = v[x] - along * pt[x];
    }
    exp_in_place(d, pt, t);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wave(n: usize, amplitude: f64, dim: usize) -> PointSet {
        let rows: Vec<Vec<f64>> = (0..n)
            .map(|i| {
                let a = i as f64 / (n - 1) as f64;
                let lat = amplitude * (9.0 * a).sin();
                let mut v = vec![lat.cos() * a.cos(), lat.cos() * a.sin(), lat.sin()];
                v.resize(dim, 0.0);
                if dim > 3 {
                    v[3] = 0.1 * (4.0 * a).cos();
                }
                let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
                v.iter().map(|x| x / norm).collect()
            })
            .collect();
        PointSet::try_from_rows(&rows).unwrap()
    }

    #[test]
    fn stored_numbers_count_control_points_knots_and_the_degree() {
        let pts = wave(50, 0.01, 3);
        let knots = clamped_uniform_knots(6, 3);
        let ctrl = greville_control_points(
            &pts,
            &parameters(&pts, Parameterization::Chord).unwrap(),
            &knots,
            3,
        )
        .unwrap();
        let s = SphericalBSpline::try_new(3, knots, ctrl).unwrap();
        assert_eq!(stored_numbers(&s, KnotRule::Stored), 2 * 6 + 2 + 1);
        assert_eq!(stored_numbers(&s, KnotRule::Uniform), 2 * 6 + 1);
        assert_eq!(polyline_numbers(10, 4), 30);
    }

    #[test]
    fn a_great_circle_within_the_tolerance_is_one_arc() {
        // Points on a great circle with wiggles of 1e-7 rad: at 1e-6 one arc suffices.
        let rows: Vec<[f64; 3]> = (0..200)
            .map(|i| {
                let a = i as f64 * 0.001;
                let lat = 1e-7 * (i as f64 * 0.7).sin();
                [lat.cos() * a.cos(), lat.cos() * a.sin(), lat.sin()]
            })
            .collect();
        let pts = PointSet::try_from_rows(&rows).unwrap();
        let fit = fit_to_tolerance(&pts, None, 1e-6, &ToleranceOptions::default()).unwrap();
        assert!(fit.tolerance_met);
        assert_eq!(fit.degree, 1);
        assert_eq!(fit.spline.control_points().len(), 2);
        assert_eq!(fit.stored_numbers, 5);
        assert_eq!(fit.knot_rule, KnotRule::Uniform);
    }

    #[test]
    fn removal_beats_the_douglas_peucker_seed_and_the_errors_are_honest() {
        let pts = wave(600, 0.02, 3);
        let tol = 2e-5;
        let dp = douglas_peucker(&pts, tol).len();
        let opts = ToleranceOptions::default().with_degrees(&[1]);
        let fit = fit_to_tolerance(&pts, None, tol, &opts).unwrap();
        assert!(fit.tolerance_met);
        assert!(
            fit.spline.control_points().len() < dp,
            "{} vs {dp}",
            fit.spline.control_points().len()
        );
        let again = measure(&fit.spline, &pts, &fit.parameters);
        assert_eq!(again.max_error_rad, fit.metrics.max_error_rad);
        // Without removal the curve would be the Douglas–Peucker seed at the first vertex
        // share, which stores more than Douglas–Peucker at the tolerance: that polyline (or
        // the one a hair under it, when DP at the tolerance misses the ordered two-way
        // bound) is returned instead.
        let no_removal =
            fit_to_tolerance(&pts, None, tol, &opts.clone().with_reduce(false)).unwrap();
        let seed = douglas_peucker(&pts, internal_target(VERTEX_SHARES[0] * tol)).len();
        assert!(seed > dp);
        assert!(no_removal.tolerance_met);
        let dp_under = douglas_peucker(&pts, 0.95 * tol).len();
        assert!(no_removal.spline.control_points().len() <= dp_under);
        // The two-way distance is certified and met.
        let tw = two_way_distance(
            &fit.spline,
            &pts,
            &fit.parameters,
            &TwoWayOptions::default(),
        )
        .unwrap();
        assert!(tw.upper_rad <= tol && fit.two_way_rad <= tol);
        assert!(fit.curve_length_ratio < 1.01, "{}", fit.curve_length_ratio);
    }

    #[test]
    fn works_on_s3_with_three_numbers_per_control_point() {
        let pts = wave(300, 0.05, 4);
        let fit = fit_to_tolerance(&pts, None, 1e-4, &ToleranceOptions::default()).unwrap();
        assert!(fit.tolerance_met, "{:e}", fit.metrics.max_error_rad);
        assert_eq!(fit.input_numbers, 3 * 300);
        let n = fit.spline.control_points().len();
        let knots = match fit.knot_rule {
            KnotRule::Stored => n - fit.degree - 1,
            KnotRule::Uniform => 0,
        };
        assert_eq!(fit.stored_numbers, 3 * n + knots + 1);
        assert!(fit.compression_ratio > 5.0, "{}", fit.compression_ratio);
    }

    #[test]
    fn pinned_ends_are_the_end_points_bit_for_bit() {
        let pts = wave(400, 0.03, 3);
        let last = pts.len() - 1;
        for degrees in [&[1usize][..], &[2], &[3], &[1, 2, 3]] {
            let opts = ToleranceOptions::default()
                .with_degrees(degrees)
                .with_pin_ends(true);
            let fit = fit_to_tolerance(&pts, None, 2e-5, &opts).unwrap();
            assert!(fit.tolerance_met, "{degrees:?}");
            let c = fit.spline.control_points();
            assert_eq!(c.get(0), pts.get(0), "{degrees:?}");
            assert_eq!(c.get(c.len() - 1), pts.get(last), "{degrees:?}");
        }
        // A closed line pinned at its seam closes exactly.
        let rows: Vec<[f64; 3]> = (0..=200)
            .map(|i| {
                let a = std::f64::consts::TAU * (i % 200) as f64 / 200.0;
                let lat = 0.2 + 0.05 * a.sin() + 0.01 * (5.0 * a).cos();
                let lon = 0.08 * a.cos();
                [lat.cos() * lon.cos(), lat.cos() * lon.sin(), lat.sin()]
            })
            .collect();
        let ring = PointSet::try_from_rows(&rows).unwrap();
        let opts = ToleranceOptions::default().with_pin_ends(true);
        let fit = fit_to_tolerance(&ring, None, 1e-5, &opts).unwrap();
        assert!(fit.tolerance_met);
        let c = fit.spline.control_points();
        assert_eq!(c.get(0), c.get(c.len() - 1));
    }

    #[test]
    fn given_parameters_use_stored_knots_and_stay_put() {
        let pts = wave(300, 0.02, 3);
        let t: Vec<f64> = (0..300).map(|i| (i as f64).powf(1.1)).collect();
        let fit = fit_to_tolerance(&pts, Some(&t), 1e-5, &ToleranceOptions::default()).unwrap();
        assert!(fit.tolerance_met);
        assert_eq!(fit.knot_rule, KnotRule::Stored);
        let expected = normalize_parameters(&t, 300).unwrap();
        assert_eq!(fit.parameters, expected);
    }
}
