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
//! * **On S^2, a greedy polyline first.** One linear pass with free vertices (`stabbing`: from
//!   each vertex the longest run of points one great circle passes within 0.95 of the
//!   tolerance of, in order; the next vertex at the run's furthest foot) is decided by the
//!   two-way check; when it meets the tolerance it is degree 1's curve and the seeded fit
//!   below is not run (10m land outlines: half the time or less at 100 m to 5 km, and fewer
//!   numbers; on noisy tracks at a tolerance near the noise it stores more, measured in
//!   `docs/speed.md`, "sixth session"). Coverage arcs, rounded to a coarse grid, keep the
//!   seeded fit ([`ToleranceOptions::stabbing`]).
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
//!   reweighted by `1 + (e / tol)^4` and refitted (twice at most; the second time only when
//!   the first brought the miss within 1.2 times).
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
//!   [`super::simplify::synchronized_douglas_peucker`]), then the polyline through every point
//!   with knots at the parameters.
//! * The solver is a converged Gauss–Newton (a few passes), never 30 GLS-PIA iterations.
//!
//! # Measured
//! What each idea gains (an ablation: stored numbers with one idea switched off at a time), what
//! was dropped from the default and why, and the timings behind the speed work below are in
//! `docs/tolerance-fitting.md`, each with the command and the commit it was measured at. In
//! short: parameter correction and unstored knots pay most; removal with reweighting is what
//! beats Douglas–Peucker on real lines; degree 3 on uniform knots wins on smooth tracks.
//! DP-seeded stored-knot fits of degree >= 2 with free parameters (`adaptive_knots`) are off by
//! default: they saved almost nothing at several times the time. Not done: knots of
//! multiplicity p at sharp corners and curvature-guided knots (the winning curves on cornered
//! data are degree 1, where every knot is already a corner).
//!
//! # Cost
//! O(n) per Gauss–Newton pass; removals refit windows of about (p + 3) control points, so a
//! fit costs a few dozen passes' worth of work: milliseconds to seconds for thousands of points
//! (the bench prints the times). What keeps it linear: a removal saves and undoes only its
//! window, in buffers kept between removals; a polyline removal with a point two tolerances
//! from the replacing chord is not refitted; a removal that failed is retried in a later sweep
//! only where a removal since changed its neighbourhood; a line of 1,024 or more seed vertices
//! is cut into pieces of about 512 at pinned seed vertices (sharp corners), fitted in parallel
//! (shifting the vertices behind a removal, and back when it fails, grows with the line); a
//! piece whose two-way distance misses is refitted alone at the lower shares, not the whole
//! line; a polyline with four or more points per span (a coarse tolerance) refits only a
//! removed vertex's two neighbours. What keeps it fast on real lines:
//! * **A degree probe.** Degrees 2 and 3 are tried only when the best polyline bends the way a
//!   smooth curve does: two thirds or more of its neighbouring turns bend the same way (bends
//!   of three or more vertices between inflections). Coastlines and GPS tracks at small
//!   tolerances turn left, right, left at nearly every vertex; there the polyline is already
//!   the cheapest curve, and the uniform-knot search spent half of a coastline's fitting time
//!   proving it. Short polylines (islets at 1 km) are judged alike. Nor are they tried where Douglas–Peucker keeps four fifths of the points or
//!   more (every point a corner at the tolerance: short island rings). Degree 3 is tried
//!   only where degree 2 found a curve storing fewer numbers than the polyline.
//! * A uniform-knot fit still 1.5 targets out after three passes is given up, and a removal's
//!   second Lawson round is tried only when the first left it within 1.2 targets.
//! * Where a polyline has two or more points per span, a removal moves the points of the
//!   replacing span to their feet on it before the refit (fewer removals fail on a first
//!   step spent on the parameters: fewer numbers at 1 km and 5 km).
//! * The uniform-knot search stops a fit whose last pass's gain, kept up for every pass left,
//!   would not reach the target.
//! * The polyline fallbacks are only built when the search found nothing.
//! * Polyline foot points in closed form (the along-track angle on the span's arc); the
//!   two-way checks of polylines in closed form ([`crate::sphere::certify::two_way`]); the
//!   pieces of a long line seeded from the whole line's Douglas–Peucker, not one each.
//!
//! `scripts/speed_bench.sh` measures whole datasets against mapshaper, and
//! `scripts/callgrind_bench.sh` counts instructions (stable on a shared machine).
//!
//! # Where the code is
//! * this file: the public API ([`fit_to_tolerance`], its options and report) and the choice
//!   among candidates by their two-way distance;
//! * `degree`: one vertex target's curves of every degree (the degree probe, the uniform-knot
//!   search);
//! * `pieces`: a long polyline cut at sharp corners and fitted in parallel;
//! * `stabbing`: the greedy polyline with free vertices on S^2;
//! * `fallback`: the polylines through Douglas–Peucker's vertices or every point;
//! * `fitter`: the working curve of one fit and its moves: foot-point correction, Gauss–Newton
//!   refits, knot insertion and greedy knot removal;
//! * `tests`: unit tests (the integration tests are in `tests/it/tolerance.rs`).

mod degree;
mod fallback;
mod fitter;
mod pieces;
mod stabbing;
#[cfg(test)]
mod tests;

use crate::sphere::certify::two_way::{
    polyline_length, two_way_distance, TwoWayDistance, TwoWayOptions,
};
use crate::sphere::compress::tolerance::degree::search;
use crate::sphere::compress::tolerance::fallback::{
    polyline_candidate, Yardstick, POLYLINE_CANDIDATES,
};
use crate::sphere::compress::tolerance::stabbing::stabbing_polyline;
use crate::sphere::curve::bspline::{SphericalBSpline, MAX_DEGREE};
use crate::sphere::fit::knots::{normalize_parameters, parameters, Parameterization};
use crate::sphere::fit::metrics::{measure, ErrorMetrics};
use crate::sphere::geometry::point::PointSet;
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
    /// An open line whose polyline has few vertices (16 or fewer) is tried at every degree
    /// whatever its turns, and by the seeded polyline fit too: a track's smooth stretch, whose
    /// greedy polyline may zigzag within the band. Off, such lines are probed as rings are:
    /// a coverage's arcs are pieces of rings, most of them short (see `degree`).
    pub short_open_at_every_degree: bool,
    /// Measure the returned curve's two-way distance to 2 % of the tolerance for
    /// [`ToleranceFit::two_way_rad`]. Off, that field is the bound the fitter decided by
    /// (proven, at most the tolerance, but looser) and the length ratio is the decision's (a
    /// curve that misses is still measured): for callers that measure the curve themselves
    /// after rounding it (the Earth layer); it saved a tenth of a coastline's fitting time.
    pub measure_result: bool,
    /// Curves of degree >= 2 meet `tolerance − smooth_margin_rad` (at most half the tolerance
    /// taken): a caller that writes them densely sampled keeps room for the samples' deviation
    /// from the curve, while a polyline is written as it is and may use the whole tolerance.
    pub smooth_margin_rad: f64,
    /// The share of the tolerance a polyline's vertex errors are fitted to first. Above the
    /// first of [`VERTEX_SHARES`], polylines are fitted one share ahead of smooth curves: a
    /// polyline strays from the line between its vertices only where it cuts the line's own
    /// corners, which the two-way check catches (and the next share fixes). It stores fewer
    /// numbers ([`POLYLINE_FIRST_SHARE`]: 7 % fewer on the 50m countries' borders at 1 km)
    /// but costs a second polyline search where the first misses: on the 10m land outlines
    /// at 1 km, fitted one by one, 7 % fewer numbers for 46 % more CPU time, so the default
    /// is off (the first vertex share) and coverage arcs switch it on.
    pub polyline_first_share: f64,
    /// On S^2 with free parameters, try first the polyline of one greedy pass with free
    /// vertices ([`STABBING_SHARE`] of the tolerance, see `stabbing`): when its two-way
    /// distance meets the tolerance it is the degree-1 curve, and the seeded polyline fit with
    /// knot removal is not run.
    pub stabbing: bool,
    /// The share of the tolerance the greedy stabbing polyline is built to
    /// ([`STABBING_SHARE`] by default). A polyline's two-way distance is bounded in closed
    /// form, tight to far less than the decision's 2 % (`sphere::certify::polyline`),
    /// so a caller may leave the decision less room: a coverage's first fit of its arcs takes
    /// 0.99 (`earth::coverage`). Not the default: rings fitted per feature at 0.99 meet one
    /// another more often, and their refits cost more than the vertices saved (world-atlas
    /// countries-10m at 20 km: 138,510 stored numbers against 92,842 at 0.95).
    pub stabbing_share: f64,
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
            short_open_at_every_degree: true,
            measure_result: true,
            smooth_margin_rad: 0.0,
            polyline_first_share: VERTEX_SHARES[0],
            stabbing: true,
            stabbing_share: STABBING_SHARE,
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
    with_fields! {
        /// Switches parameter correction on or off.
        with_correct_parameters(correct_parameters: bool);
        /// Switches knot removal on or off.
        with_reduce(reduce: bool);
        /// Switches Lawson reweighting in removals on or off.
        with_reweight(reweight: bool);
        /// Switches the uniform-knot candidates on or off.
        with_uniform_knots(uniform_knots: bool);
        /// Switches the stored-knot fits of degree >= 2 with free parameters on or off.
        with_adaptive_knots(adaptive_knots: bool);
        /// Sets the Douglas–Peucker seed factor.
        with_seed_factor(seed_factor: f64);
        /// Caps the number of control points.
        with_max_control_points(max_control_points: usize) = Some;
        /// Pins (or frees) the end control points at the first and last point.
        with_pin_ends(pin_ends: bool);
        /// Switches the degree probe ([`ToleranceOptions::degree_probe`]) on or off.
        with_degree_probe(degree_probe: bool);
        /// Switches [`ToleranceOptions::short_open_at_every_degree`] on or off.
        with_short_open_at_every_degree(short_open_at_every_degree: bool);
        /// Sets the margin kept by curves of degree >= 2 ([`ToleranceOptions::smooth_margin_rad`]).
        with_smooth_margin_rad(smooth_margin_rad: f64);
        /// Switches the greedy stabbing polyline ([`ToleranceOptions::stabbing`]) on or off.
        with_stabbing(stabbing: bool);
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
    let tw_options = decide_options(tolerance_rad, n);
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
    let line = Line {
        points,
        params: &base_params,
        free,
    };
    let mut first_fallback = Yardstick::new(line, tolerance_rad);
    let yardstick = first_fallback.numbers;
    // The tolerance a curve of degree `p` must meet.
    let tolerance_of = |p: usize| {
        if p >= 2 {
            (tolerance_rad - options.smooth_margin_rad.max(0.0)).max(0.5 * tolerance_rad)
        } else {
            tolerance_rad
        }
    };
    // The greedy stabbing polyline, decided once: when it meets the tolerance it stands for
    // degree 1 in the first pass (and the smooth degrees are probed against it).
    let mut stabbed: Option<(Curve, ErrorMetrics)> = None;
    if options.stabbing && free && degrees.contains(&1) {
        options.cancel.check()?;
        let share = options.stabbing_share.clamp(0.5, 0.995);
        let stab = stabbing_polyline(points, internal_target(share * tolerance_rad)).filter(|c| {
            c.spline.control_points().len() <= cap && stored_numbers(&c.spline, c.rule) < yardstick
        });
        if let Some(c) = stab {
            let m = measure(&c.spline, points, &c.params);
            let tw = two_way_distance(&c.spline, points, &c.params, &tw_options)?;
            let met = accepts(&tw, tolerance_rad, input_length);
            if met {
                stabbed = Some((
                    Curve {
                        decided: Some(tw),
                        ..c
                    },
                    m,
                ));
            } else {
                candidates.push(candidate(&c, &m, &tw, met, input_length));
                best_miss = Some((c, m, tw));
            }
        }
    }
    // With a polyline share above the first vertex share, polylines take one share more than
    // smooth curves in each pass (see [`ToleranceOptions::polyline_first_share`]), and the
    // last pass is the polyline's alone.
    let shifted = options.polyline_first_share > VERTEX_SHARES[0];
    let passes = VERTEX_SHARES.len() + usize::from(shifted);
    'shares: for pass in 0..passes {
        let share_of = |p: usize| match p {
            1 if shifted && pass == 0 => options.polyline_first_share,
            1 if shifted => VERTEX_SHARES[pass - 1],
            _ => VERTEX_SHARES[pass],
        };
        let pass_degrees: Vec<usize> = degrees
            .iter()
            .copied()
            .filter(|&p| p == 1 || pass < VERTEX_SHARES.len())
            .collect();
        if pass_degrees.is_empty() {
            break;
        }
        let (found, near) = search(
            line,
            &|p| internal_target(share_of(p) * tolerance_of(p)),
            tolerance_rad,
            cap,
            options,
            &pass_degrees,
            yardstick,
            stabbed.take(),
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
            let (mut c, m) = found[i].take().expect("each curve is taken once");
            if stored_numbers(&c.spline, c.rule) >= yardstick {
                break;
            }
            // A long line's pieces come with this decision made (`Curve::decided`).
            let tw = match c.decided.take() {
                Some(tw) => tw,
                None => two_way_distance(&c.spline, points, &c.params, &tw_options)?,
            };
            let met = accepts(&tw, tolerance_of(c.spline.degree()), input_length);
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
                0 => first_fallback.take_curve(),
                _ => polyline_candidate(line, tolerance_rad, k),
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

/// A [`ToleranceOptions::polyline_first_share`] of the whole tolerance. On the world-atlas 50m
/// countries at 1 km (shared borders) it stored 7 % fewer numbers than the default
/// (112,174 -> 104,382 with the rest unchanged).
pub const POLYLINE_FIRST_SHARE: f64 = 1.0;

/// The share of the tolerance the greedy stabbing polyline ([`ToleranceOptions::stabbing`]) is
/// built to by default ([`ToleranceOptions::stabbing_share`]): its two-way distance is at most
/// that share (up to rounding), and the decision proves bounds to 2 % of the tolerance, so the
/// rest is the decision's room.
pub const STABBING_SHARE: f64 = 0.95;

/// Precision of the two-way distances the fitter decides by, as a share of the tolerance.
const TWO_WAY_PRECISION: f64 = 0.02;

/// A curve meeting the two-way bound may still be no longer than this many times the input
/// polyline (plus a tolerance's worth): a curve that wanders within the band is rejected.
pub const MAX_LENGTH_RATIO: f64 = 1.2;

/// Curve evaluations allowed per two-way check: generous, and linear in the input.
fn two_way_budget(n: usize) -> usize {
    4_000_000 + 400 * n
}

/// How a candidate is decided on a line of `n` points: "two-way distance within
/// `tolerance_rad`?", to [`TWO_WAY_PRECISION`], within [`decide_budget`].
fn decide_options(tolerance_rad: f64, n: usize) -> TwoWayOptions {
    TwoWayOptions::default()
        .with_precision_rad(TWO_WAY_PRECISION * tolerance_rad)
        .deciding(tolerance_rad)
        .with_max_evaluations(decide_budget(n))
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

/// The error bound the fitter works to: a hair below the tolerance, so that a fresh measurement
/// by another code path (rounding differences of ~1e-16 rad) cannot land above it.
fn internal_target(tolerance_rad: f64) -> f64 {
    tolerance_rad * (1.0 - 1e-9) - 1e-15
}

/// The line being fitted: its points, the parameters fits start from (given, or from the
/// parameterization), and whether those move to foot points (`free`) or are given (times).
#[derive(Clone, Copy)]
struct Line<'a> {
    points: &'a PointSet,
    params: &'a [f64],
    free: bool,
}

/// A finished curve and its data parameters.
struct Curve {
    spline: SphericalBSpline,
    params: Vec<f64>,
    rule: KnotRule,
    /// The candidate's decision ([`decide_options`] at the tolerance), when the fit that made
    /// the curve has already made it (a long line's pieces do).
    decided: Option<TwoWayDistance>,
}
