//! Fitting one line: a B-spline by GLS-PIA or Gauss–Newton at a control-point count
//! ([`fit_line`]) or to a tolerance in metres ([`fit_line_to_tolerance`]), rounded to the
//! output precision and measured as returned.

use crate::earth::curve::compact::encode_compact;
use crate::earth::curve::line::{ErrorSums, LineRef, OutputSpec};
use crate::earth::curve::output::{
    auto_tolerance_rad, compression_ratio, finish_dense, round_up_m, sample_curve, sampling_start,
    CurveOutput, CurveReport, KeptPolyline,
};
use crate::earth::curve::positions::{
    fits_closed, median_step_rad, prepare_line, round_m, sphere_error, DistinctPositions,
    LinePositions,
};
use crate::earth::curve::times::{DenseTimes, LineTimeInput, Timed};
use crate::earth::curve::tolerance_rule::ToleranceRule;
use crate::earth::error::{EarthError, Problem};
use crate::earth::json_out::JsonOut;
use crate::earth::lonlat::{lonlat_to_unit, m_to_rad, rad_to_m, round_to, unit_to_lonlat};
use crate::earth::sampling::AUTO_DEVIATION_FRACTION;
use crate::sphere::certify::two_way::{polyline_length, two_way_distance, TwoWayOptions};
use crate::sphere::compress::tolerance::{
    fit_to_tolerance, stored_numbers, KnotRule, ToleranceOptions,
};
use crate::sphere::curve::bspline::SphericalBSpline;
use crate::sphere::fit::adaptive_knots::{refine, turning_angles};
use crate::sphere::fit::knots::KnotPlacement;
use crate::sphere::fit::metrics::pointwise_errors;
use crate::sphere::fit::options::{default_control_points, FitOptions};
use crate::sphere::geometry::densify::densify;
use crate::sphere::geometry::point::{angle_between, PointSet};
use crate::sphere::{fit, SphereError};
use serde_json::{json, Map, Value};

/// Without `control_points`, a fit at a quarter of the distinct positions is refitted at half
/// of them when its max error exceeds this share of the median step between positions. On the
/// 10m borders of the README's "Default fit" table a quarter leaves 1.8–1.9 km on the
/// Canada–USA border (median steps 3.8 and 6.2 km), half leaves at most 1 km everywhere; dense
/// smooth tracks keep a quarter.
pub const AUTO_COUNT_STEP_SHARE: f64 = 0.25;

/// Knot refinement puts a C0 joint (a knot of multiplicity p) at the worst point of a span when
/// the line turns there by at least this much: 30° (the initial knots take corners from 50°,
/// `sphere::fit::adaptive_knots::CORNER_ANGLE_RAD`). On the world-atlas 10m borders 50° left
/// 2,063 m on a 117-point border and 30° 453 m; 20° was no better overall.
pub const REFINE_CORNER_ANGLE_RAD: f64 = 30.0 * std::f64::consts::PI / 180.0;

/// Rounds of knot refinement of the default fit (each refits once): on the 10m US–Mexico
/// border the max error goes 3,356 / 878 / 384 / 342 / 306 m over the start and four rounds.
pub const REFINE_ROUNDS: usize = 4;

/// A fit (not to a tolerance) whose certified two-way distance exceeds this many times its max
/// error at the positions (at least 1 m) ...
pub const WANDER_DISTANCE_SHARE: f64 = 3.0;

/// ... or whose curve is longer than this times the line wanders from the line: it is refitted
/// once with twice the control points when the count is automatic, and carries a warning in
/// `properties.fit.warnings` (and a log line) if it still wanders.
pub const WANDER_LENGTH_RATIO: f64 = 1.2;

/// The default fit refines its knots where a point of the (densified) line is farther from the
/// curve than this share of the line's median step. On the 10m US–Mexico border 0.25 left
/// 517 m (two-way 1,097 m), 0.15 leaves 306 m (two-way 348 m) at 619 control points.
pub const REFINE_STEP_SHARE: f64 = 0.15;

/// ... and at most this many metres: on sparse borders a share of the median step is too
/// coarse (W. Sahara–Mauritania, median step 10 km, was left 1,051 m off, and Morocco–W. Sahara
/// 1,295 m). With 750 m the world-atlas 10m borders' worst max error is 879 m (500 m: 808 m at
/// 0.4 % more control points); lines sampled finer than 5 km are not affected.
pub const REFINE_MAX_M: f64 = 750.0;

/// The faithful default fit inserts points into segments longer than this share of the median
/// step of the line (so no step is longer), so that knot refinement finds data in every span
/// it splits (3 median steps stalled the refinement at 993 m on the 10m US–Mexico border) ...
pub const DENSIFY_STEP_SHARE: f64 = 0.5;

/// ... up to this many times the line's distinct positions in all.
pub const DENSIFY_MAX_FACTOR: usize = 4;

/// Fits one line (or ring, when `closed`) given as a GeoJSON coordinates array.
///
/// With `time`, the line is fitted as position against time: each position's parameter is its
/// time mapped to [0, 1] (never moved), so the error reported at a position is its
/// synchronized distance; long segments get no points inserted (nothing says where the track
/// was between its times), and a line that returns to its start stays open. A curve in time
/// that strays from the line ([`TIME_STRAY_SHARE`]) is refitted with GLS-PIA.
///
/// # Errors
/// Invalid positions or times, an open or short ring, fewer than 2 distinct positions,
/// antipodal neighbours, more control points than distinct positions, or output over the
/// limits.
pub fn fit_line(
    src: LineRef<'_>,
    options: &FitOptions,
    time: Option<&LineTimeInput<'_>>,
    out: OutputSpec<'_>,
) -> Result<CurveOutput, EarthError> {
    let (output, limits, pointer) = (out.output, out.limits, src.pointer);
    let (line, distinct, timed) = prepare_line(src.value, pointer, src.closed, time)?;
    let closed = fits_closed(src.closed, &distinct, timed.as_ref());
    let src = LineRef { closed, ..src };
    let given = timed.as_ref().map(|t| t.params.as_slice());
    let m = distinct.len();
    let degree = options.degree.min(m - 1);
    let cap = limits.max_control_points.max(degree + 1);
    let control_points = match options.control_points {
        Some(n) if n > m => {
            return Err(EarthError::new(
                pointer,
                Problem::TooManyControlPoints {
                    control_points: n,
                    distinct: m,
                },
            ))
        }
        Some(n) => n,
        None => default_control_points(m, degree).min(cap),
    };
    let points = distinct.point_set();
    let fit_err = |e: SphereError| sphere_error(e, pointer, &distinct.input_index);
    // The faithful default fits the line, not only its vertices: long segments get points
    // along them (see `sphere::geometry::densify`), and the vertices' parameters are read off
    // the fit. The paper's placements fit the vertices as given.
    let (fit_points, at) = if options.knots == KnotPlacement::Adaptive && timed.is_none() {
        densify(
            &points,
            DENSIFY_STEP_SHARE * median_step_rad(&distinct),
            DENSIFY_MAX_FACTOR * m,
        )
        .map_err(fit_err)?
    } else {
        (points.clone(), (0..m).collect())
    };
    let run_opts = |opts: &FitOptions| {
        if closed {
            fit_closed(&fit_points, opts)
        } else {
            fit(&fit_points, given, opts)
        }
    };
    let run_with = |n_ctrl: usize, solver: crate::sphere::Solver| {
        let mut opts = options
            .clone()
            .with_degree(degree)
            .with_control_points(n_ctrl);
        opts.solver = solver;
        run_opts(&opts)
    };
    let run = |n_ctrl: usize| run_with(n_ctrl, options.solver);
    let refining = options.control_points.is_none() && options.knots == KnotPlacement::Adaptive;
    // Open lines refined with the accelerated solver: every round but the one kept is fitted
    // with a single update, which already lands at the fixed point to about 1e-9 (the second
    // update of a full fit only confirms it); the round kept is then resumed. Closed lines
    // are closed after each fit, so they keep full fits.
    let quick = refining && !closed && options.solver == crate::sphere::Solver::GlsPiaAccelerated;
    let mut r = if quick {
        let mut opts = options
            .clone()
            .with_degree(degree)
            .with_control_points(control_points);
        opts.iterations = opts.iterations.min(1);
        run_opts(&opts)
    } else {
        run(control_points)
    }
    .map_err(fit_err)?;
    let count_cap = m.min(cap);
    let mut r_quick = quick;
    if refining {
        // The count from the data: knots are added where the curve misses the line (any
        // position of the densified line farther than a share of the median step), a knot
        // in the middle of each such span, for a few rounds.
        let threshold =
            (REFINE_STEP_SHARE * median_step_rad(&distinct)).min(m_to_rad(REFINE_MAX_M));
        let turns = turning_angles(&fit_points);
        for round in 0..REFINE_ROUNDS {
            if options.cancel.is_cancelled() {
                break;
            }
            let n_now = r.spline.control_points().len();
            // The solver's last pass measured this curve at these parameters already.
            let errors = if r.point_errors_rad.len() == fit_points.len() {
                std::mem::take(&mut r.point_errors_rad)
            } else {
                pointwise_errors(&r.spline, &fit_points, &r.parameters)
            };
            let Some(knots) = refine(
                r.spline.knots(),
                r.spline.degree(),
                &r.parameters,
                &errors,
                &turns,
                REFINE_CORNER_ANGLE_RAD,
                threshold,
                count_cap.saturating_sub(n_now),
            ) else {
                break;
            };
            let mut opts = options.clone().with_degree(degree).with_knot_vector(knots);
            opts.control_points = None;
            r_quick = quick && round + 1 < REFINE_ROUNDS;
            if r_quick {
                opts.iterations = opts.iterations.min(1);
            }
            r = run_opts(&opts).map_err(fit_err)?;
        }
        if r_quick {
            let opts = options.clone().with_degree(degree);
            r = crate::sphere::fit::solve::resume_accelerated(r, &fit_points, &opts)
                .map_err(fit_err)?;
        }
    } else if options.control_points.is_none() {
        // The count from the data: a quarter of the positions, or half of them when a quarter
        // leaves a position farther from the curve than a quarter of the line's median step
        // (the curve should follow the line at a finer scale than the line is sampled).
        let more = m.div_ceil(2).max(degree + 1).min(cap);
        if more > control_points
            && r.metrics.max_error_rad > AUTO_COUNT_STEP_SHARE * median_step_rad(&distinct)
        {
            let r2 = run(more).map_err(fit_err)?;
            if r2.metrics.max_error_rad < r.metrics.max_error_rad {
                r = r2;
            }
        }
    }
    // Rounded, and judged against the whole line both ways (certified).
    let measured = |r: crate::sphere::FitReport| -> Result<_, EarthError> {
        let r_max_rad = r.metrics.max_error_rad;
        let params: Vec<f64> = at.iter().map(|&k| r.parameters[k]).collect();
        let n_ctrl = r.spline.control_points().len();
        let solver = r.solver;
        let (spline, control_ll, control_rows) =
            round_spline_rows(&r.spline, output.precision).map_err(fit_err)?;
        let tw = two_way_distance(
            &spline,
            &points,
            &params,
            &TwoWayOptions::default()
                .with_precision_rad(
                    (REPORT_TWO_WAY_PRECISION * r_max_rad)
                        .max(REPORT_TWO_WAY_LENGTH_SHARE * polyline_length(&points))
                        .max(m_to_rad(0.5)),
                )
                .with_max_evaluations(REPORT_TWO_WAY_EVALUATIONS + 64 * points.len()),
        )
        .map_err(fit_err)?;
        Ok((
            spline,
            control_ll,
            params,
            r.iterations,
            r.converged,
            tw,
            r_max_rad,
            n_ctrl,
            solver,
            control_rows,
        ))
    };
    let mut m_best = measured(r)?;
    let input_len = polyline_length(&points);
    let wanders = |tw: &crate::sphere::certify::two_way::TwoWayDistance, max_rad: f64| {
        tw.upper_rad > WANDER_DISTANCE_SHARE * max_rad.max(m_to_rad(1.0))
            || tw.curve_length_rad > WANDER_LENGTH_RATIO * input_len
    };
    // A curve that wanders away from the line between its positions: refitted once with twice
    // the control points when the count is the fit's own choice (the curve nearer the line
    // kept), and reported with a warning if it still wanders.
    if options.control_points.is_none() && wanders(&m_best.5, m_best.6) {
        let more = (2 * m_best.7).min(count_cap);
        if more > m_best.7 {
            let alt = measured(run(more).map_err(fit_err)?)?;
            if alt.5.upper_rad < m_best.5.upper_rad {
                m_best = alt;
            }
        }
    }
    // In time, spans between positions far apart in time have little data, and Gauss-Newton's
    // least squares can send the curve far from the line there while every position stays
    // close (a fixture track went 160 km off). When the curve strays from the line more than
    // TIME_STRAY_SHARE times its max error, GLS-PIA (which moves control points only towards
    // the data) is tried with the same control points, and the curve nearer the line kept.
    if timed.is_some()
        && options.solver != crate::sphere::Solver::GlsPia
        && m_best.5.upper_rad > TIME_STRAY_SHARE * m_best.6.max(m_to_rad(1.0))
    {
        let alt = measured(run_with(m_best.7, crate::sphere::Solver::GlsPia).map_err(fit_err)?)?;
        if alt.5.upper_rad < m_best.5.upper_rad {
            m_best = alt;
        }
    }
    let mut warnings = Vec::new();
    if wanders(&m_best.5, m_best.6) {
        let w = format!(
            "the curve wanders from the line: two-way distance {:.0} m against a max error of \
             {:.0} m at the positions, curve {:.2} times as long as the line; try more \
             control_points, knots=adaptive or tolerance_m",
            rad_to_m(m_best.5.upper_rad),
            rad_to_m(m_best.6),
            m_best.5.curve_length_rad / input_len.max(f64::MIN_POSITIVE)
        );
        warnings.push(w);
    }
    let (spline, control_ll, params, iterations, converged, tw, _, _, solver, control_rows) =
        m_best;
    let (mut out, _) = finish_fit(
        Fitted {
            input: Prepared {
                line: &line,
                distinct: &distinct,
                points: &points,
                time: timed.as_ref(),
            },
            spline,
            control_ll,
            control_rows,
            params,
            iterations,
            converged,
            knots: serde_json::to_value(options.knots).expect("enum serialises"),
            parameterization: options.parameterization,
            sampling_aim_rad: None,
        },
        src,
        out,
    )?;
    let f = &mut out.report.fields;
    f.insert(
        "two_way_distance_m".into(),
        json!(round_up_m(rad_to_m(tw.upper_rad))),
    );
    let ratio = if input_len > 0.0 {
        tw.curve_length_rad / input_len
    } else {
        1.0
    };
    f.insert("curve_length_ratio".into(), json!(round_to(ratio, 4)));
    f.insert("solver".into(), json!(solver.name()));
    if !warnings.is_empty() {
        f.insert("warnings".into(), json!(warnings));
    }
    Ok(out)
}

/// A line as read for a fit: its positions, the distinct ones (also as unit vectors) and, for a
/// fit in time, its times.
#[derive(Clone, Copy)]
pub(crate) struct Prepared<'a> {
    pub(crate) line: &'a LinePositions,
    pub(crate) distinct: &'a DistinctPositions,
    pub(crate) points: &'a PointSet,
    pub(crate) time: Option<&'a Timed>,
}

/// A fitted curve (control points already rounded) and what it was fitted to.
pub(super) struct Fitted<'a> {
    input: Prepared<'a>,
    spline: SphericalBSpline,
    pub(crate) control_ll: Vec<[f64; 2]>,
    /// The control points as [`lonlat_to_unit`] made them of `control_ll`, before the spline's
    /// point set normalised them ([`round_spline_rows`]).
    control_rows: Vec<[f64; 3]>,
    pub(crate) params: Vec<f64>,
    iterations: usize,
    converged: bool,
    knots: Value,
    parameterization: crate::sphere::Parameterization,
    /// What automatic dense sampling aims for; by default a share of the max error.
    sampling_aim_rad: Option<f64>,
}

/// Measures a fitted curve as returned, samples it and writes its `properties.fit` fields.
/// Also returns the max error in radians.
pub(super) fn finish_fit(
    f: Fitted<'_>,
    src: LineRef<'_>,
    out: OutputSpec<'_>,
) -> Result<(CurveOutput, f64), EarthError> {
    let (pointer, closed) = (src.pointer, src.closed);
    let Fitted {
        input:
            Prepared {
                line,
                distinct,
                points,
                time,
            },
        spline,
        control_ll,
        control_rows,
        params,
        iterations,
        converged,
        knots,
        parameterization,
        sampling_aim_rad,
    } = f;
    let control_points = spline.control_points().len();
    // Errors of the spline as returned, each distinct position counted once per input copy.
    let errs = pointwise_errors(&spline, points, &params);
    let errors = ErrorSums::of(errs.into_iter().zip(distinct.multiplicity.iter().copied()));
    let ErrorSums {
        max_rad,
        sum_rad,
        sq_rad,
    } = errors;
    let n_in = line.points.len();
    let dense = sample_curve(
        &spline,
        out,
        closed,
        sampling_aim_rad.unwrap_or_else(|| auto_tolerance_rad(max_rad)),
        sampling_start(control_points),
        time.map(|t| &t.map),
    )
    .map_err(|e| EarthError::new(pointer, e.problem))?;
    let (points_out, alts) = finish_dense(&dense, closed, &params, &distinct.alts);
    let dense_times = time.map(|t| DenseTimes {
        unix_s: dense.params.iter().map(|&u| t.map.time(u)).collect(),
        format: t.map.format,
        origin: t.origin.clone(),
    });

    let compact = out
        .output
        .compact_splines
        .then(|| encode_compact(&spline, &control_ll, out.output.precision))
        .flatten();
    let spline_doc = match compact {
        Some(text) => JsonOut::Value(Value::String(text)),
        None => JsonOut::object([
            ("degree", JsonOut::Value(json!(spline.degree()))),
            ("knots", JsonOut::Numbers(spline.knots().to_vec())),
            ("control_points", JsonOut::rows(&control_ll)),
        ]),
    };
    let mut fields = Map::new();
    fields.insert("max_error_m".into(), json!(round_m(rad_to_m(max_rad))));
    fields.insert(
        "mean_error_m".into(),
        json!(round_m(rad_to_m(sum_rad / n_in as f64))),
    );
    fields.insert(
        "rms_error_m".into(),
        json!(round_m(rad_to_m((sq_rad / n_in as f64).sqrt()))),
    );
    fields.insert("input_points".into(), json!(n_in));
    fields.insert("control_points".into(), json!(control_points));
    fields.insert("iterations".into(), json!(iterations));
    fields.insert("converged".into(), json!(converged));
    fields.insert("knots".into(), knots);
    match time {
        Some(t) => {
            fields.insert("parameterization".into(), json!("time"));
            fields.insert("time".into(), t.map.to_json(&t.origin));
        }
        None => {
            fields.insert(
                "parameterization".into(),
                serde_json::to_value(parameterization).expect("enum serialises"),
            );
        }
    }
    fields.insert("output_points".into(), json!(points_out.len()));
    // What is written is each sample rounded to the output's decimals: the written polyline
    // is within the largest such shift of the sampled one, so the deviation it reports counts
    // it (a degree-1 curve's samples are its rounded vertices and shift by nothing; a smooth
    // curve's at 3 decimals by up to 79 m, which the report missed before).
    //
    // A sample that is a control point bit for bit (a polyline's samples are its vertices)
    // rounds back onto that control point as rounded ([`SAME_GRID_MAX_DECIMALS`]): its shift is
    // measured against the rounded point kept, without converting it to degrees and back (on
    // the 10m land outlines at 10 m those conversions were 300 M instructions, 3.5 % of the run).
    let precision = out.output.precision;
    let control = spline.control_points();
    let kept = precision <= SAME_GRID_MAX_DECIMALS && points_out.len() == control_rows.len();
    let shift = points_out
        .iter()
        .enumerate()
        .map(|(i, p)| {
            if kept && same_bits(p, control.get(i)) {
                angle_between(p, &control_rows[i])
            } else {
                written_shift_rad(p, precision)
            }
        })
        .fold(0.0f64, f64::max);
    fields.insert(
        "sampling_deviation_m".into(),
        json!(round_up_m(rad_to_m(dense.max_deviation_rad + shift))),
    );
    Ok((
        CurveOutput {
            pointer: pointer.to_string(),
            has_alt: line.alts.is_some(),
            report: CurveReport {
                spline: Some(spline_doc),
                output_points: points_out.len(),
                stored_numbers: bspline_stored_numbers(&spline),
                ..CurveReport::of_line(src, fields, n_in, errors)
            },
            points: points_out,
            alts,
            time: dense_times,
            kept: None,
        },
        max_rad,
    ))
}

/// How far a sample moves when written at `precision` decimals, in radians: the angle between
/// it and its position rounded, as a unit vector.
fn written_shift_rad(p: &[f64; 3], precision: u32) -> f64 {
    let (lon, lat) = unit_to_lonlat(p);
    angle_between(
        p,
        &lonlat_to_unit(round_to(lon, precision), round_to(lat, precision)),
    )
}

/// Up to this many decimals a control point rounded by [`round_spline_rows`] (its degrees on
/// the grid, converted to a unit vector and normalised) rounds back onto the same unit vector:
/// degrees to a unit vector and back stray by about 1e-13 degrees (a few units in the last
/// place of each step), far inside half a step of the grid (5e-11 degrees at 10 decimals); at
/// a pole and at ±180 degrees, where the degrees read back differ, they give the same vector.
/// Checked over random and edge positions in the tests.
const SAME_GRID_MAX_DECIMALS: u32 = 10;

/// The same `f64`s, bit for bit.
fn same_bits(a: &[f64], b: &[f64]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
}

/// How far rounding a control point to `precision` decimals of a degree can move it, in
/// radians (half a unit in the last place of longitude and of latitude).
pub fn rounding_bound_rad(precision: u32) -> f64 {
    (0.5 * 10f64.powi(-(precision as i32)) * std::f64::consts::SQRT_2).to_radians()
}

/// Fits one line (or ring, when `closed`) to a tolerance in metres with
/// [`fit_to_tolerance`] (lon/lat unit vectors, after repeats are dropped).
///
/// The fitter aims at the tolerance minus 1.5 times [`rounding_bound_rad`] so that the curve
/// still meets it once its control points are rounded to `precision`; the errors are then
/// measured on the rounded curve, and `tolerance_met` is [`ToleranceRule::met`]. When
/// rounding pushes a fit that met its target over the tolerance, it is refitted once with a
/// target lowered by the excess ([`ToleranceRule::retry_target_rad`]); a coverage's arcs are
/// judged and retried by the same rule.
///
/// A ring (or a LineString whose last position repeats its first) is fitted as an open line
/// through its positions (first = last) and then closed by pinning the end control points
/// together (to their normalised mean, [`crate::sphere::fit::seam::close_seam`] without the C1
/// condition); the errors are those of the closed curve, so pinning can cost the tolerance
/// (`tolerance_met: false`, never hidden).
///
/// `options.degree` caps the degrees tried (1 ..= degree, at most 3); `options.parameterization`
/// gives the starting parameters, which the fitter then moves to foot points. `iterations` is
/// reported as 0 and `converged` as `tolerance_met`.
///
/// # Errors
/// As [`fit_line`].
pub fn fit_line_to_tolerance(
    src: LineRef<'_>,
    options: &FitOptions,
    tolerance_m: f64,
    time: Option<&LineTimeInput<'_>>,
    out: OutputSpec<'_>,
) -> Result<CurveOutput, EarthError> {
    let (output, pointer) = (out.output, src.pointer);
    let (line, distinct, timed) = prepare_line(src.value, pointer, src.closed, time)?;
    let closed = fits_closed(src.closed, &distinct, timed.as_ref());
    let src = LineRef { closed, ..src };
    let given = timed.as_ref().map(|t| t.params.as_slice());
    let points = distinct.point_set();
    let fit_err = |e: SphereError| sphere_error(e, pointer, &distinct.input_index);
    let rule = ToleranceRule::new(tolerance_m, output.precision);
    let tol_rad = rule.tol_rad;
    // A polyline is written as its rounded vertices (no sampling margin): it aims at the
    // tolerance less its vertices' rounding, and curves of degree >= 2 keep the rest of the
    // margin, as a coverage's arcs do (10m land outlines: 682,606 -> 675,664 stored numbers
    // at 100 m, 243,958 -> 236,416 at 1 km, 80,910 -> 77,984 at 5 km, the time unchanged).
    let mut target = rule.polyline_target_rad();
    let input = Prepared {
        line: &line,
        distinct: &distinct,
        points: &points,
        time: timed.as_ref(),
    };
    // No control-point cap below the input's own size here: a long line at a small tolerance
    // may need nearly a control point per position, and the input limits already bound that.
    let mut topts = ToleranceOptions {
        parameterization: options.parameterization,
        max_control_points: Some(distinct.len()),
        // The curve is measured below, as returned (rounded, closed).
        measure_result: false,
        smooth_margin_rad: rule.polyline_target_rad() - rule.first_target_rad(),
        ..ToleranceOptions::default()
    };
    topts.degrees.retain(|&p| p <= options.degree.max(1));
    let mut attempt = 0;
    loop {
        let r = fit_to_tolerance(&points, given, target, &topts).map_err(fit_err)?;
        let spline = if closed {
            crate::sphere::fit::seam::close_seam(&r.spline, false).map_err(fit_err)?
        } else {
            r.spline.clone()
        };
        let (spline, control_ll, control_rows) =
            round_spline_rows(&spline, output.precision).map_err(fit_err)?;
        // The two-way distance of the curve as returned (rounded, and closed for a ring): the
        // fitter's own bound moved by the rounding where that is proven and tight enough,
        // else measured afresh.
        let tw = match moved_polyline_bound(&r, &spline, REPORT_TWO_WAY_PRECISION * tol_rad) {
            Some(tw) => tw,
            None => reported_two_way(
                &spline,
                &points,
                &r.parameters,
                REPORT_TWO_WAY_PRECISION * tol_rad,
                pointer,
            )?,
        };
        let (out, worst) = finish_tolerance_fit(
            input,
            ToleranceCurve {
                spline,
                control_ll,
                control_rows,
                params: r.parameters,
                knot_rule: r.knot_rule,
                degree: r.degree,
                tw,
                parameterization: options.parameterization,
            },
            &rule,
            src,
            out,
        )?;
        // Rounding (or closing the ring) took a fit that met its target over the tolerance:
        // aim lower by the excess, once.
        if let Some(lower) = rule.retry_target_rad(target, worst, r.tolerance_met, attempt) {
            target = lower;
            attempt += 1;
            continue;
        }
        return Ok(out);
    }
}

/// A curve fitted to a tolerance as returned (rounded, a ring's seam closed), before it is
/// sampled and reported.
pub(crate) struct ToleranceCurve {
    pub(crate) spline: SphericalBSpline,
    pub(crate) control_ll: Vec<[f64; 2]>,
    pub(crate) control_rows: Vec<[f64; 3]>,
    /// The parameters of the line's distinct positions on it.
    pub(crate) params: Vec<f64>,
    pub(crate) knot_rule: KnotRule,
    pub(crate) degree: usize,
    /// Its two-way distance from the line, measured as returned.
    pub(crate) tw: ReportedTwoWay,
    /// The starting parameters asked for (reported).
    pub(crate) parameterization: crate::sphere::Parameterization,
}

/// The two-way distance of a curve as returned from the line (`points` at `params`), to
/// `precision`.
pub(crate) fn reported_two_way(
    spline: &SphericalBSpline,
    points: &PointSet,
    params: &[f64],
    precision: f64,
    pointer: &str,
) -> Result<ReportedTwoWay, EarthError> {
    let tw = two_way_distance(
        spline,
        points,
        params,
        &TwoWayOptions::default()
            .with_precision_rad(precision)
            .with_max_evaluations(4_000_000 + 400 * points.len()),
    )
    .map_err(|e| sphere_error(e, pointer, &[]))?;
    Ok(ReportedTwoWay {
        upper_rad: tw.upper_rad,
        curve_length_rad: tw.curve_length_rad,
    })
}

/// Samples and reports a curve fitted to `rule`'s tolerance ([`finish_fit`] and the tolerance
/// fields); also returns the larger of its max error and two-way distance. A polyline written
/// as its vertices keeps its curve ([`CurveOutput::kept`]).
pub(crate) fn finish_tolerance_fit(
    input: Prepared<'_>,
    c: ToleranceCurve,
    rule: &ToleranceRule,
    src: LineRef<'_>,
    out: OutputSpec<'_>,
) -> Result<(CurveOutput, f64), EarthError> {
    let ToleranceCurve {
        spline,
        control_ll,
        control_rows,
        params,
        knot_rule,
        degree,
        mut tw,
        parameterization,
    } = c;
    let points = input.points;
    let tol_rad = rule.tol_rad;
    // A bound over the tolerance may be the slack of the report's precision (or of the
    // rounding's move) alone, for a curve that meets it: measured closer before it counts as
    // a miss (a polyline aims within millimetres of the tolerance at fine precisions).
    if tw.upper_rad > tol_rad {
        let fine = reported_two_way(
            &spline,
            points,
            &params,
            FINE_TWO_WAY_PRECISION * tol_rad,
            src.pointer,
        )?;
        if fine.upper_rad < tw.upper_rad {
            tw = fine;
        }
    }
    let input_len = polyline_length(points);
    let length_ratio = if input_len > 0.0 {
        tw.curve_length_rad / input_len
    } else {
        1.0
    };
    let stored = stored_numbers(&spline, knot_rule);
    let keep = (degree == 1
        && input.time.is_none()
        && knot_rule == KnotRule::Uniform
        && spline.has_clamped_uniform_knots())
    .then(|| KeptPolyline {
        control_ll: control_ll.clone(),
        params: params.clone(),
        two_way_rad: tw.upper_rad,
    });
    let knot_rule = serde_json::to_value(knot_rule).expect("enum serialises");
    let (mut out, max_rad) = finish_fit(
        Fitted {
            input,
            spline,
            control_ll,
            control_rows,
            params,
            iterations: 0,
            converged: false,
            knots: knot_rule.clone(),
            parameterization,
            // The margin the fit left for the dense output, so the returned geometry stays
            // within the tolerance too.
            sampling_aim_rad: Some(AUTO_DEVIATION_FRACTION * tol_rad),
        },
        src,
        out,
    )?;
    let worst = max_rad.max(tw.upper_rad);
    let met = rule.met(worst, tw.curve_length_rad, input_len);
    let n_in = input.line.points.len();
    let f = &mut out.report.fields;
    f.insert("converged".into(), json!(met));
    f.insert("tolerance_m".into(), json!(rule.tolerance_m));
    f.insert("tolerance_met".into(), json!(met));
    f.insert(
        "two_way_distance_m".into(),
        json!(round_up_m(rad_to_m(tw.upper_rad))),
    );
    f.insert(
        "curve_length_ratio".into(),
        json!(round_to(length_ratio, 4)),
    );
    f.insert("degree".into(), json!(degree));
    f.insert("knot_rule".into(), knot_rule);
    f.insert("stored_numbers".into(), json!(stored));
    f.insert(
        "compression_ratio".into(),
        json!(compression_ratio(n_in, stored)),
    );
    out.report.stored_numbers = stored;
    // Kept only when what is written is the polyline's vertices, one dense point each.
    out.kept = keep
        .filter(|k| out.points.len() == k.control_ll.len())
        .map(Box::new);
    Ok((out, worst))
}

/// The two-way distance reported for a fitted curve, and the curve's length.
pub(crate) struct ReportedTwoWay {
    pub(crate) upper_rad: f64,
    pub(crate) curve_length_rad: f64,
}

/// The two-way distance of `finished` (the fitter's polyline `r.spline` with its vertices
/// moved: rounded, and the ring's seam closed) from the fitter's own bound, without measuring
/// again: `None` unless both are polylines on the same knots, the bound so found is within
/// `precision` of the true distance (the fitter's bound close enough to a distance it
/// attained: a measurement, not only a decision), and every segment of both, lengthened by
/// its ends' moves, is at most a quarter turn. On the 10m land outlines at 100 m every ring
/// takes this path, and the bound is 1.6–4.4 cm above a fresh measurement.
///
/// Why it holds: the distance is the largest Hausdorff distance between an input segment and
/// the curve over that segment's parameters, and at every parameter the two curves are
/// SLERPs at the same fraction α of arcs AB and A'B'. Moving one end (A to A', B fixed)
/// moves the point at fraction α by at most 3·d(A, A') on arcs of at most a quarter turn: the
/// points at the same distance s from B along BA and along BA' are 2·asin(sin s · sin(φ/2))
/// apart (the isosceles spherical triangle, φ its angle at B), which grows with s up to a
/// quarter turn and so is at most d(A, A'') ≤ d(A, A') + |BA − BA'| ≤ 2·d(A, A') (A'' on BA'
/// at A's distance from B, by the triangle inequality); and the two points at fraction α lie
/// at distances from B that differ by at most |BA − BA'| ≤ d(A, A'). So every point
/// moves by at most 3·(d(A, A') + d(B, B')), and by the triangle inequality the Hausdorff
/// distance of each piece, and so the bound, grows by at most the largest such move.
pub(crate) fn moved_polyline_bound(
    r: &crate::sphere::ToleranceFit,
    finished: &SphericalBSpline,
    precision: f64,
) -> Option<ReportedTwoWay> {
    let (a, b) = (&r.spline, finished);
    if a.degree() != 1 || b.degree() != 1 || a.knots() != b.knots() {
        return None;
    }
    let (pa, pb) = (a.control_points(), b.control_points());
    if pa.len() != pb.len() || pa.len() < 2 {
        return None;
    }
    let quarter = std::f64::consts::FRAC_PI_2;
    let mut moved: f64 = 0.0;
    let mut length = 0.0;
    let mut shift_prev = angle_between(pa.get(0), pb.get(0));
    for i in 1..pa.len() {
        let shift = angle_between(pa.get(i), pb.get(i));
        let (before, after) = (
            angle_between(pa.get(i - 1), pa.get(i)),
            angle_between(pb.get(i - 1), pb.get(i)),
        );
        // Both arcs, and the one between the steps (A' to B), within a quarter turn.
        if before.max(after) + shift_prev + shift > quarter {
            return None;
        }
        moved = moved.max(3.0 * (shift_prev + shift));
        length += after;
        shift_prev = shift;
    }
    // The angles above are each good to a few units in the last place.
    let moved = moved + 1e-14;
    // The true distance of `finished` is at least the attained one less the move, so the
    // bound below stays within `precision` of it, as a measurement would.
    if r.two_way_rad - r.two_way_lower_rad + 2.0 * moved > precision {
        return None;
    }
    Some(ReportedTwoWay {
        upper_rad: r.two_way_rad + moved,
        curve_length_rad: length,
    })
}

/// A fit in time whose two-way distance exceeds this many times its max error (at least
/// 1 m) is refitted with GLS-PIA, and the curve nearer the line kept (see [`fit_line`]).
pub const TIME_STRAY_SHARE: f64 = 4.0;

/// Precision of the reported two-way distance, as a share of the tolerance.
pub(crate) const REPORT_TWO_WAY_PRECISION: f64 = 0.01;

/// Precision (a share of the tolerance) a curve's two-way distance is measured to again when
/// the reported bound is over the tolerance, before the fit counts as a miss.
const FINE_TWO_WAY_PRECISION: f64 = 1e-4;

/// Without a tolerance the two-way distance is reported to 1 % of the max error or to this
/// share of the line's length, whichever is coarser (at least half a metre): near-exact fits of
/// long lines would otherwise spend seconds proving centimetres (the speed bound of the SLERP
/// triangle is first-order tight, so the cost grows as length / precision) ...
pub(super) const REPORT_TWO_WAY_LENGTH_SHARE: f64 = 1e-5;

/// ... with at most this many curve evaluations (plus 64 per position); past them the bound
/// stays proven, only looser.
pub(super) const REPORT_TWO_WAY_EVALUATIONS: usize = 50_000;

/// Numbers a B-spline stores ([`stored_numbers`]), its knots counted unless they are the clamped
/// uniform ones, which need no storing: the same count whichever path made the spline.
pub(super) fn bspline_stored_numbers(spline: &SphericalBSpline) -> usize {
    let rule = if spline.has_clamped_uniform_knots() {
        KnotRule::Uniform
    } else {
        KnotRule::Stored
    };
    stored_numbers(spline, rule)
}

/// A spline whose control points' degrees are rounded by `round` (a coverage's grid,
/// [`crate::earth::job::round_to_grid`]), and those control points as `[lon, lat]`.
pub(crate) fn round_spline_with(
    s: &SphericalBSpline,
    round: &dyn Fn(f64) -> f64,
) -> Result<(SphericalBSpline, Vec<[f64; 2]>), SphereError> {
    round_with_rows(s, round).map(|(spline, ll, _)| (spline, ll))
}

/// A rounded spline, its control points as `[lon, lat]` and as unit vectors before the point
/// set normalised them.
type RoundedSpline = (SphericalBSpline, Vec<[f64; 2]>, Vec<[f64; 3]>);

/// A spline whose control points are rounded to `precision` decimals of a degree, those
/// control points as `[lon, lat]`, and as [`lonlat_to_unit`] gave them (before the point set
/// normalised them), for [`finish_fit`].
pub(crate) fn round_spline_rows(
    s: &SphericalBSpline,
    precision: u32,
) -> Result<RoundedSpline, SphereError> {
    round_with_rows(s, &|x| round_to(x, precision))
}

/// A control point rounded by `round`: its `[lon, lat]` and their unit vector.
fn round_point(p: &[f64], round: &dyn Fn(f64) -> f64) -> ([f64; 2], [f64; 3]) {
    let (lon, lat) = unit_to_lonlat(p);
    let (lon, lat) = (round(lon), round(lat));
    ([lon, lat], lonlat_to_unit(lon, lat))
}

fn round_with_rows(
    s: &SphericalBSpline,
    round: &dyn Fn(f64) -> f64,
) -> Result<RoundedSpline, SphereError> {
    let n = s.control_points().len();
    let (mut ll, mut rows) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for p in s.control_points().iter() {
        let (q, row) = round_point(p, round);
        ll.push(q);
        rows.push(row);
    }
    let control = PointSet::try_from_rows(&rows)?;
    Ok((
        SphericalBSpline::try_new(s.degree(), s.knots().to_vec(), control)?,
        ll,
        rows,
    ))
}

/// Fits a closed line: [`crate::sphere::fit::seam::fit_closed`] (first position = last; smooth
/// across the seam unless the line turns sharply there).
pub(super) fn fit_closed(
    points: &PointSet,
    options: &FitOptions,
) -> Result<crate::sphere::FitReport, SphereError> {
    crate::sphere::fit::seam::fit_closed(points, options)
}

/// What a tolerance fit aims at so that the curve as returned meets `tol_rad`: below it by
/// `bound`, the most rounding the control points moves a position (when that leaves room:
/// [`rounding_bound_rad`] of the precision, or a coverage's TopoJSON grid's), and by the
/// deviation the dense output adds to the curve's distance from the line (when at least half
/// the tolerance is left).
///
/// That target serves every degree. A polyline written as it is needs less
/// ([`polyline_target_rad`]).
pub(crate) fn tolerance_target_rad(tol_rad: f64, bound: f64) -> f64 {
    let mut target = if tol_rad > 3.0 * bound {
        tol_rad - 1.5 * bound
    } else {
        tol_rad
    };
    let dense_margin = AUTO_DEVIATION_FRACTION * tol_rad;
    if target - dense_margin > 0.5 * tol_rad {
        target -= dense_margin;
    }
    target
}

/// What a polyline (a degree-1 curve, written as its vertices) aims at so that it meets
/// `tol_rad` once rounded: below it by the rounding of its vertices alone (`bound`, as in
/// [`tolerance_target_rad`]). Rounding moves each vertex by at most `bound` and a
/// great-circle step by no more than its ends, and its dense output is its vertices (no
/// sampling margin). What the bound misses (the sphere's curvature over a step) is caught by
/// measuring the rounded curve and retried ([`ToleranceRule::retry_target_rad`]).
pub(crate) fn polyline_target_rad(tol_rad: f64, bound: f64) -> f64 {
    if tol_rad > 3.0 * bound {
        tol_rad - bound
    } else {
        tol_rad
    }
    .max(tolerance_target_rad(tol_rad, bound))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sphere::{fit_to_tolerance, PointSet, ToleranceOptions};

    /// A jagged coastline-like line of lon/lat points, as unit vectors.
    fn jagged(n: usize) -> PointSet {
        let rows: Vec<[f64; 3]> = (0..n)
            .map(|i| {
                let x = i as f64;
                let lon = 10.0 + 0.01 * x + 0.004 * (x * 1.7).sin();
                let lat = 45.0 + 0.006 * (x * 0.9).cos() + 0.003 * ((x * 3.1).sin()).signum();
                lonlat_to_unit(lon, lat)
            })
            .collect();
        PointSet::try_from_rows(&rows).expect("unit vectors")
    }

    /// A polyline fit of [`jagged`]`(n)` at `tol_m` metres: the points, the fit, the
    /// tolerance and the report precision in radians.
    fn polyline_fit(n: usize, tol_m: f64) -> (PointSet, crate::sphere::ToleranceFit, f64, f64) {
        let points = jagged(n);
        let tol = m_to_rad(tol_m);
        let r = fit_to_tolerance(
            &points,
            None,
            tol,
            &ToleranceOptions::default().with_degrees(&[1]),
        )
        .expect("fits");
        assert_eq!(r.spline.degree(), 1);
        (points, r, tol, REPORT_TWO_WAY_PRECISION * tol)
    }

    #[test]
    fn a_moved_polyline_keeps_a_proven_bound_within_the_precision() {
        let (points, r, tol, precision) = polyline_fit(400, 100.0);
        // Rounded to 7 decimals (about a centimetre) and to 5 (about a metre): the bound moves
        // with the vertices, and stays above every distance the moved curve attains.
        for decimals in [7, 5] {
            let (moved, _, _) = round_spline_rows(&r.spline, decimals).expect("rounds");
            let Some(reused) = moved_polyline_bound(&r, &moved, precision) else {
                assert_eq!(decimals, 5, "a centimetre's rounding keeps the bound");
                continue;
            };
            let fresh = two_way_distance(
                &moved,
                &points,
                &r.parameters,
                &TwoWayOptions::default().with_precision_rad(1e-4 * tol),
            )
            .expect("measures");
            assert!(reused.upper_rad >= fresh.upper_rad - 1e-4 * tol);
            assert!(reused.upper_rad >= fresh.lower_rad);
            assert!(reused.upper_rad <= fresh.lower_rad + precision);
            assert!((reused.curve_length_rad - fresh.curve_length_rad).abs() <= 1e-9);
        }
    }

    #[test]
    fn a_rounded_control_point_rounds_back_onto_itself() {
        // finish_fit's shortcut: a sample equal to a rounded control point shifts, when
        // written, as far from it as from the unit vector its rounded degrees gave.
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let edges = [
            -180.0,
            -179.999_999_99,
            -90.0,
            -1e-9,
            0.0,
            1e-9,
            90.0,
            180.0,
        ];
        let mut positions: Vec<(f64, f64)> = Vec::new();
        for &lon in &edges {
            for &lat in &[
                -90.0,
                -89.999_999_99,
                -45.0,
                0.0,
                1e-12,
                89.999_999_99,
                90.0,
            ] {
                positions.push((lon, lat));
            }
        }
        for _ in 0..20_000 {
            positions.push((360.0 * next() - 180.0, 180.0 * next() - 90.0));
        }
        for decimals in 0..=SAME_GRID_MAX_DECIMALS {
            for &(lon, lat) in &positions {
                let (_, row) = round_point(&lonlat_to_unit(lon, lat), &|x| round_to(x, decimals));
                let set = PointSet::try_from_rows(&[row]).expect("a unit vector");
                let p = set.get(0);
                let p = [p[0], p[1], p[2]];
                assert_eq!(
                    written_shift_rad(&p, decimals).to_bits(),
                    angle_between(&p, &row).to_bits(),
                    "({lon}, {lat}) at {decimals} decimals"
                );
            }
        }
    }

    #[test]
    fn a_moved_curve_on_other_knots_or_degrees_is_measured_again() {
        let (points, r, _, precision) = polyline_fit(200, 50.0);
        let other = SphericalBSpline::try_new(
            1,
            crate::sphere::curve::bspline::clamped_uniform_knots(3, 1),
            PointSet::try_from_rows(
                &[points.get(0), points.get(100), points.get(199)].map(|p| [p[0], p[1], p[2]]),
            )
            .expect("unit vectors"),
        )
        .expect("a spline");
        assert!(moved_polyline_bound(&r, &other, precision).is_none());
    }
}
