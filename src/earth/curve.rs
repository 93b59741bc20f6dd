//! One line or ring on the Earth: positions parsed and checked, repeats dropped, fitted (or
//! interpolated, or read from a spline document), rounded and sampled densely.
//!
//! Pointers in errors are relative to the document: `pointer` is where the line's coordinates
//! array sits (`/features/3/geometry/coordinates`), and a position error adds `/17` or `/17/1`.

use super::lonlat::{lonlat_to_unit, m_to_rad, rad_to_m, round_to, unit_to_lonlat, LonLat};
use super::sampling::{
    sample, DenseCurve, Sampling, AUTO_DEVIATION_FLOOR_M, AUTO_DEVIATION_FRACTION,
};
use super::sampling::{sample_at, time_parameters};
use super::time::{check_times, times_from_array, LineTimes, TimeFormat, TimeMap, TimeOrigin};
use super::{EarthError, InterpolateSettings, Limits, OutputOptions, Problem};
use crate::document::BetaDocument;
use crate::sphere::beta::{interpolate, InterpolationOptions, SphericalBetaSpline};
use crate::sphere::fit::default_control_points;
use crate::sphere::geometry::densify::densify;
use crate::sphere::knots::KnotPlacement;
use crate::sphere::metrics::pointwise_errors;
use crate::sphere::point::{angle_between, ANTIPODAL_MARGIN_RAD};
use crate::sphere::tolerance::{
    fit_to_tolerance, stored_numbers, KnotRule, ToleranceOptions, MAX_LENGTH_RATIO,
};
use crate::sphere::two_way::{polyline_length, two_way_distance, TwoWayOptions};
use crate::sphere::AnyCurve;
use crate::sphere::{fit, FitOptions, InputSite, PointSet, SphereError, SphericalBSpline};
use serde_json::{json, Map, Value};

/// Consecutive positions closer than this (radians; 0.6 mm on the Earth) are repeats: far below
/// the 1.1 cm resolution of 7-decimal coordinates, far above rounding noise.
pub const REPEAT_ANGLE_RAD: f64 = 1e-10;

/// Automatic sampling of an interpolating curve keeps the polyline within this share of the
/// mean vertex spacing of the curve (and at least `AUTO_DEVIATION_FLOOR_M`): the curve has no
/// fit error to compare with, and 0.5 % of a step is far below what the vertices resolve.
pub const INTERPOLATION_DEVIATION_FRACTION: f64 = 0.005;

/// Without `control_points`, a fit at a quarter of the distinct positions is refitted at half
/// of them when its max error exceeds this share of the median step between positions. On the
/// 10m borders of the README's "Default fit" table a quarter leaves 1.8–1.9 km on the
/// Canada–USA border (median steps 3.8 and 6.2 km), half leaves at most 1 km everywhere; dense
/// smooth tracks keep a quarter.
pub const AUTO_COUNT_STEP_SHARE: f64 = 0.25;

/// The faithful default fit inserts points into segments longer than this many median steps
/// of the line (so no step is longer) ...
pub const DENSIFY_STEP_SHARE: f64 = 3.0;

/// ... up to this many times the line's distinct positions in all.
pub const DENSIFY_MAX_FACTOR: usize = 4;

/// Output altitudes are rounded to millimetres.
const ALTITUDE_DECIMALS: u32 = 3;

/// Reported metres are rounded to millimetres.
fn round_m(x: f64) -> f64 {
    round_to(x, 3)
}

/// The positions of one line as unit vectors, with altitudes when every position has one.
#[derive(Clone, Debug, PartialEq)]
pub struct LinePositions {
    /// The positions as unit vectors.
    pub points: Vec<[f64; 3]>,
    /// One altitude per position, when every position has one.
    pub alts: Option<Vec<f64>>,
    /// The 4th number of every position (a time), when read with `allow_m` and every
    /// position has one.
    pub m: Option<Vec<f64>>,
}

/// Reads `[[lon, lat(, alt)], ...]`, checking types, ranges and that either all positions or
/// none have an altitude.
///
/// # Errors
/// [`Problem::InvalidGeoJson`] when `v` is not an array; [`Problem::InvalidCoordinate`] at the
/// offending position or number.
pub fn parse_positions(v: &Value, pointer: &str) -> Result<LinePositions, EarthError> {
    parse_positions_with(v, pointer, false)
}

/// As [`parse_positions`]; with `allow_m`, positions may also be `[lon, lat, alt, t]` (all of
/// a line alike), the 4th number kept in [`LinePositions::m`].
///
/// # Errors
/// As [`parse_positions`].
pub fn parse_positions_with(
    v: &Value,
    pointer: &str,
    allow_m: bool,
) -> Result<LinePositions, EarthError> {
    let max_len = if allow_m { 4 } else { 3 };
    let arr = v.as_array().ok_or_else(|| {
        EarthError::new(
            pointer,
            Problem::InvalidGeoJson("expected an array of positions [longitude, latitude]".into()),
        )
    })?;
    let mut points = Vec::with_capacity(arr.len());
    let mut alts = Vec::new();
    let mut ms = Vec::new();
    let mut with_alt: Option<usize> = None;
    for (i, pos) in arr.iter().enumerate() {
        let bad = |ptr: String, msg: String| EarthError::new(ptr, Problem::InvalidCoordinate(msg));
        let nums = pos.as_array().ok_or_else(|| {
            bad(
                format!("{pointer}/{i}"),
                "a position is an array [longitude, latitude] or [longitude, latitude, altitude]"
                    .into(),
            )
        })?;
        if nums.len() < 2 || nums.len() > max_len {
            return Err(bad(
                format!("{pointer}/{i}"),
                if allow_m {
                    format!(
                        "a position has 2 to 4 numbers ([longitude, latitude(, altitude(, time))]), this one has {}",
                        nums.len()
                    )
                } else {
                    format!(
                        "a position has 2 or 3 numbers ([longitude, latitude(, altitude)]), this one has {}{}",
                        nums.len(),
                        if nums.len() == 4 {
                            " (a 4th number is read as a time only with parameterization=time)"
                        } else {
                            ""
                        }
                    )
                },
            ));
        }
        let mut xs = [0.0; 4];
        for (k, x) in nums.iter().enumerate() {
            xs[k] = x.as_f64().ok_or_else(|| {
                bad(
                    format!("{pointer}/{i}/{k}"),
                    format!("expected a number, got {}", json_kind(x)),
                )
            })?;
        }
        match with_alt {
            None => with_alt = Some(nums.len()),
            Some(w) if w != nums.len() => {
                return Err(bad(
                    format!("{pointer}/{i}"),
                    format!(
                        "this position has {} numbers but the first has {w}: give an altitude{} for every position of a line or for none",
                        nums.len(),
                        if allow_m { " (and a time)" } else { "" }
                    ),
                ));
            }
            Some(_) => {}
        }
        let has_alt = nums.len() >= 3;
        let ll = LonLat::try_new(xs[0], xs[1]).map_err(|e| {
            let k = match e {
                super::lonlat::LonLatError::LatitudeOutOfRange { .. } => 1,
                _ => 0,
            };
            bad(format!("{pointer}/{i}/{k}"), e.to_string())
        })?;
        points.push(ll.to_unit());
        if has_alt {
            alts.push(xs[2]);
        }
        if nums.len() == 4 {
            ms.push(xs[3]);
        }
    }
    Ok(LinePositions {
        points,
        alts: (with_alt >= Some(3)).then_some(alts),
        m: (with_alt == Some(4)).then_some(ms),
    })
}

/// The JSON type of a value, for messages.
pub(crate) fn json_kind(v: &Value) -> &'static str {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "an array",
        Value::Object(_) => "an object",
    }
}

/// A line with repeated consecutive positions dropped.
#[derive(Clone, Debug)]
pub struct DistinctPositions {
    /// The kept positions.
    pub points: Vec<[f64; 3]>,
    /// Index of each kept position in the input.
    pub input_index: Vec<usize>,
    /// How many input positions each kept one stands for (1 + its repeats).
    pub multiplicity: Vec<usize>,
    /// Altitude of each kept position (that of its first copy; zeros without altitudes).
    pub alts: Vec<f64>,
}

impl DistinctPositions {
    /// Drops repeats (within [`REPEAT_ANGLE_RAD`] of the previous kept position).
    pub fn from_line(line: &LinePositions) -> DistinctPositions {
        let mut d = DistinctPositions {
            points: Vec::with_capacity(line.points.len()),
            input_index: Vec::with_capacity(line.points.len()),
            multiplicity: Vec::with_capacity(line.points.len()),
            alts: Vec::with_capacity(line.points.len()),
        };
        for (i, p) in line.points.iter().enumerate() {
            if let Some(last) = d.points.last() {
                if angle_between(last, p) <= REPEAT_ANGLE_RAD {
                    *d.multiplicity.last_mut().expect("non-empty") += 1;
                    continue;
                }
            }
            d.points.push(*p);
            d.input_index.push(i);
            d.multiplicity.push(1);
            d.alts.push(line.alts.as_ref().map_or(0.0, |a| a[i]));
        }
        d
    }

    /// Drops the positions flagged in `duplicate` (records repeated exactly, time and
    /// position), keeping every other one, even where the position repeats at a later time.
    pub fn from_line_timed(line: &LinePositions, duplicate: &[bool]) -> DistinctPositions {
        let mut d = DistinctPositions {
            points: Vec::with_capacity(line.points.len()),
            input_index: Vec::with_capacity(line.points.len()),
            multiplicity: Vec::with_capacity(line.points.len()),
            alts: Vec::with_capacity(line.points.len()),
        };
        for (i, p) in line.points.iter().enumerate() {
            if duplicate[i] && !d.points.is_empty() {
                *d.multiplicity.last_mut().expect("non-empty") += 1;
                continue;
            }
            d.points.push(*p);
            d.input_index.push(i);
            d.multiplicity.push(1);
            d.alts.push(line.alts.as_ref().map_or(0.0, |a| a[i]));
        }
        d
    }

    /// Number of distinct positions.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// True when there are none.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    fn point_set(&self) -> PointSet {
        PointSet::try_from_rows(&self.points).expect("lon/lat positions are unit vectors")
    }

    /// Errors unless there are at least 2 distinct positions and no antipodal neighbours.
    fn check_curve(&self, pointer: &str) -> Result<(), EarthError> {
        if self.len() < 2 {
            return Err(EarthError::new(
                pointer,
                Problem::TooFewPoints {
                    distinct: self.len(),
                    need: 2,
                },
            ));
        }
        for i in 1..self.len() {
            let a = angle_between(&self.points[i - 1], &self.points[i]);
            if a >= std::f64::consts::PI - ANTIPODAL_MARGIN_RAD {
                return Err(EarthError::new(
                    format!("{pointer}/{}", self.input_index[i]),
                    Problem::Antipodal {
                        angle_deg: a.to_degrees(),
                    },
                ));
            }
        }
        Ok(())
    }
}

/// Checks that a ring is closed (last position = first) and has at least 4 positions.
fn check_ring(line: &LinePositions, pointer: &str) -> Result<(), EarthError> {
    let n = line.points.len();
    if n < 4 {
        return Err(EarthError::new(
            pointer,
            Problem::InvalidRing(format!(
                "a Polygon ring needs at least 4 positions (the last repeating the first), got {n}"
            )),
        ));
    }
    if angle_between(&line.points[0], &line.points[n - 1]) > REPEAT_ANGLE_RAD {
        return Err(EarthError::new(
            format!("{pointer}/{}", n - 1),
            Problem::InvalidRing(
                "a Polygon ring must end where it starts: the last position differs from the first"
                    .into(),
            ),
        ));
    }
    Ok(())
}

/// Everything reported about one fitted, interpolated or evaluated curve.
#[derive(Clone, Debug, PartialEq)]
pub struct CurveReport {
    /// Where the curve sits in its geometry's coordinates (`[]` for a LineString, `[i]` for a
    /// MultiLineString part or Polygon ring, `[polygon, ring]` for a MultiPolygon).
    pub path: Vec<usize>,
    /// A ring (closed curve).
    pub closed: bool,
    /// Fields of `properties.fit` (or `interpolation`) for this curve, spline/curve included.
    pub fields: Map<String, Value>,
    /// Input positions (repeats included); 0 for evaluation.
    pub input_points: usize,
    /// Dense output points.
    pub output_points: usize,
    /// Numbers that store the curve (control point coordinates, knots, degree).
    pub stored_numbers: usize,
    /// Max error in metres (0 for evaluation).
    pub max_error_m: f64,
    /// Sum of errors and of squared errors (metres), for pooled means.
    pub error_sum_m: f64,
    /// Sum of squared errors, square metres.
    pub error_sq_sum_m2: f64,
}

/// A curve ready for output: dense unit vectors with altitudes, and its report.
#[derive(Clone, Debug)]
pub struct CurveOutput {
    /// Where the curve's coordinates (or document) sit in the input.
    pub pointer: String,
    /// The dense curve as unit vectors.
    pub points: Vec<[f64; 3]>,
    /// The altitude of each dense point (0 without altitudes).
    pub alts: Vec<f64>,
    /// Whether the input had altitudes, so the output positions carry a third value.
    pub has_alt: bool,
    /// What was done and how well.
    pub report: CurveReport,
    /// The time of each dense point, for a curve in time.
    pub time: Option<DenseTimes>,
}

/// The number of points automatic sampling starts from: a few per control point.
pub(crate) fn sampling_start(control_points: usize) -> usize {
    (4 * control_points).max(16)
}

/// Automatic sampling tolerance for a curve whose max error is `max_error_rad`.
pub fn auto_tolerance_rad(max_error_rad: f64) -> f64 {
    (AUTO_DEVIATION_FRACTION * max_error_rad).max(m_to_rad(AUTO_DEVIATION_FLOOR_M))
}

/// Where one line's times are, for a fit in time.
#[derive(Clone, Debug)]
pub enum LineTimeInput<'a> {
    /// This line's array in the property `name`, found at `pointer`.
    Property {
        /// The array (one time per position).
        value: &'a Value,
        /// Its JSON pointer.
        pointer: String,
        /// The property's name.
        name: String,
    },
    /// The 4th number of each position.
    M,
}

/// A line's times, checked, for a fit in time.
#[derive(Clone, Debug)]
pub struct Timed {
    /// Times <-> curve parameter.
    pub map: TimeMap,
    /// Where the times came from (and go to in the output).
    pub origin: TimeOrigin,
    /// The curve parameter of each distinct position: its time mapped to [0, 1].
    pub params: Vec<f64>,
}

/// The dense output's times.
#[derive(Clone, Debug)]
pub struct DenseTimes {
    /// Unix seconds of each dense point.
    pub unix_s: Vec<f64>,
    /// How to write them.
    pub format: TimeFormat,
    /// Where to write them.
    pub origin: TimeOrigin,
}

/// Reads and checks a line's times ([`super::time`]) and drops duplicate records.
fn timed_line(
    line: &LinePositions,
    pointer: &str,
    input: &LineTimeInput<'_>,
) -> Result<(DistinctPositions, Timed), EarthError> {
    let times = match input {
        LineTimeInput::Property {
            value,
            pointer: tp,
            name,
        } => times_from_array(
            value,
            tp,
            line.points.len(),
            TimeOrigin::Property(name.clone()),
        )?,
        LineTimeInput::M => LineTimes {
            unix_s: line.m.clone().ok_or_else(|| {
                EarthError::new(
                    pointer,
                    Problem::InvalidTime(format!(
                        "no times for this line: the feature's properties have none of {} and its positions no 4th number [lon, lat, alt, time]; name the property with time_property",
                        super::time::TIME_PROPERTIES.join(", ")
                    )),
                )
            })?,
            format: TimeFormat::UnixS,
            origin: TimeOrigin::M,
            pointer: pointer.to_string(),
        },
    };
    let duplicate = check_times(&times, |i| {
        angle_between(&line.points[i - 1], &line.points[i]) <= REPEAT_ANGLE_RAD
    })?;
    let distinct = DistinctPositions::from_line_timed(line, &duplicate);
    if distinct.len() < 2 {
        return Err(EarthError::new(
            pointer,
            Problem::TooFewPoints {
                distinct: distinct.len(),
                need: 2,
            },
        ));
    }
    let kept: Vec<f64> = distinct
        .input_index
        .iter()
        .map(|&i| times.unix_s[i])
        .collect();
    let map = TimeMap {
        start_unix_s: kept[0],
        end_unix_s: kept[kept.len() - 1],
        format: times.format,
    };
    let mut params: Vec<f64> = kept.iter().map(|&t| map.param(t)).collect();
    let last = params.len() - 1;
    params[last] = 1.0;
    Ok((
        distinct,
        Timed {
            map,
            origin: times.origin,
            params,
        },
    ))
}

/// The start every curve operation shares: parse the positions, check a ring is closed, drop
/// repeated consecutive positions and make sure enough distinct ones remain. With `time`, the
/// line's times are read and checked, only duplicate records (same time and position) are
/// dropped, and the line is never closed.
pub(crate) fn prepare_line(
    coords: &Value,
    pointer: &str,
    closed: bool,
    time: Option<&LineTimeInput<'_>>,
) -> Result<(LinePositions, DistinctPositions, Option<Timed>), EarthError> {
    let line = parse_positions_with(coords, pointer, matches!(time, Some(LineTimeInput::M)))?;
    if let Some(input) = time {
        let (distinct, timed) = timed_line(&line, pointer, input)?;
        distinct.check_curve(pointer)?;
        return Ok((line, distinct, Some(timed)));
    }
    if closed {
        check_ring(&line, pointer)?;
    }
    let distinct = DistinctPositions::from_line(&line);
    distinct.check_curve(pointer)?;
    Ok((line, distinct, None))
}

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
#[allow(clippy::too_many_arguments)]
pub fn fit_line(
    coords: &Value,
    pointer: &str,
    path: Vec<usize>,
    closed: bool,
    options: &FitOptions,
    output: &OutputOptions,
    limits: &Limits,
    time: Option<&LineTimeInput<'_>>,
) -> Result<CurveOutput, EarthError> {
    let (line, distinct, timed) = prepare_line(coords, pointer, closed, time)?;
    let closed = timed.is_none() && (closed || is_closed_line(&distinct));
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
    let run_with = |n_ctrl: usize, solver: crate::sphere::Solver| {
        let mut opts = options
            .clone()
            .with_degree(degree)
            .with_control_points(n_ctrl);
        opts.solver = solver;
        if closed {
            fit_closed(&fit_points, &opts)
        } else {
            fit(&fit_points, given, &opts)
        }
    };
    let run = |n_ctrl: usize| run_with(n_ctrl, options.solver);
    let mut r = run(control_points).map_err(fit_err)?;
    if options.control_points.is_none() {
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
        let (spline, control_ll) = round_spline(&r.spline, output.precision).map_err(fit_err)?;
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
        ))
    };
    let mut m_best = measured(r)?;
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
    let (spline, control_ll, params, iterations, converged, tw, _, _) = m_best;
    let input_len = polyline_length(&points);
    let (mut out, _) = finish_fit(
        Fitted {
            line: &line,
            distinct: &distinct,
            points: &points,
            spline,
            control_ll,
            params,
            iterations,
            converged,
            knots: serde_json::to_value(options.knots).expect("enum serialises"),
            parameterization: options.parameterization,
            sampling_aim_rad: None,
            time: timed.as_ref(),
        },
        pointer,
        path,
        closed,
        output,
        limits,
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
    Ok(out)
}

/// A fitted curve (control points already rounded) and what it was fitted to.
struct Fitted<'a> {
    line: &'a LinePositions,
    distinct: &'a DistinctPositions,
    points: &'a PointSet,
    spline: SphericalBSpline,
    control_ll: Vec<[f64; 2]>,
    params: Vec<f64>,
    iterations: usize,
    converged: bool,
    knots: Value,
    parameterization: crate::sphere::Parameterization,
    /// What automatic dense sampling aims for; by default a share of the max error.
    sampling_aim_rad: Option<f64>,
    /// The line's times, for a fit in time.
    time: Option<&'a Timed>,
}

/// Measures a fitted curve as returned, samples it and writes its `properties.fit` fields.
/// Also returns the max error in radians.
fn finish_fit(
    f: Fitted<'_>,
    pointer: &str,
    path: Vec<usize>,
    closed: bool,
    output: &OutputOptions,
    limits: &Limits,
) -> Result<(CurveOutput, f64), EarthError> {
    let Fitted {
        line,
        distinct,
        points,
        spline,
        control_ll,
        params,
        iterations,
        converged,
        knots,
        parameterization,
        sampling_aim_rad,
        time,
    } = f;
    let control_points = spline.control_points().len();
    // Errors of the spline as returned, each distinct position counted once per input copy.
    let errs = pointwise_errors(&spline, points, &params);
    let (mut max_rad, mut sum_rad, mut sq_rad) = (0.0f64, 0.0, 0.0);
    for (e, &k) in errs.iter().zip(&distinct.multiplicity) {
        max_rad = max_rad.max(*e);
        sum_rad += e * k as f64;
        sq_rad += e * e * k as f64;
    }
    let n_in = line.points.len();
    let dense = sample_curve(
        &spline,
        output,
        closed,
        sampling_aim_rad.unwrap_or_else(|| auto_tolerance_rad(max_rad)),
        sampling_start(control_points),
        limits,
        time.map(|t| &t.map),
    )
    .map_err(|e| EarthError::new(pointer, e.problem))?;
    let (points_out, alts) = finish_dense(&dense, closed, &params, &distinct.alts);
    let dense_times = time.map(|t| DenseTimes {
        unix_s: dense.params.iter().map(|&u| t.map.time(u)).collect(),
        format: t.map.format,
        origin: t.origin.clone(),
    });

    let spline_doc = json!({
        "degree": spline.degree(),
        "knots": spline.knots(),
        "control_points": control_ll,
    });
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
    fields.insert(
        "sampling_deviation_m".into(),
        json!(round_m(rad_to_m(dense.max_deviation_rad))),
    );
    fields.insert("spline".into(), spline_doc);
    Ok((
        CurveOutput {
            pointer: pointer.to_string(),
            has_alt: line.alts.is_some(),
            report: CurveReport {
                path,
                closed,
                fields,
                input_points: n_in,
                output_points: points_out.len(),
                stored_numbers: bspline_stored_numbers(&spline),
                max_error_m: rad_to_m(max_rad),
                error_sum_m: rad_to_m(sum_rad),
                error_sq_sum_m2: rad_to_m(rad_to_m(sq_rad)),
            },
            points: points_out,
            alts,
            time: dense_times,
        },
        max_rad,
    ))
}

/// Samples a curve densely as the output options say; `spacing_s` needs the curve's times.
fn sample_curve(
    curve: &dyn crate::sphere::SphericalCurve,
    output: &OutputOptions,
    closed: bool,
    auto_tolerance_rad: f64,
    start: usize,
    limits: &Limits,
    time: Option<&TimeMap>,
) -> Result<DenseCurve, EarthError> {
    match (output.sampling, time) {
        (Sampling::SpacingS(s), Some(map)) => Ok(sample_at(
            curve,
            time_parameters(map.duration_s(), s, limits.max_samples)?,
        )),
        (sampling, _) => sample(
            curve,
            ring_sampling(sampling, closed),
            auto_tolerance_rad,
            start,
            limits.max_samples,
        ),
    }
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
/// measured on the rounded curve, and `tolerance_met` is true only when that max error (and
/// its value rounded to millimetres) is within the tolerance. When rounding pushes a fit that
/// met its target over the tolerance, it is refitted once with a target lowered by the excess.
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
#[allow(clippy::too_many_arguments)]
pub fn fit_line_to_tolerance(
    coords: &Value,
    pointer: &str,
    path: Vec<usize>,
    closed: bool,
    options: &FitOptions,
    tolerance_m: f64,
    output: &OutputOptions,
    limits: &Limits,
    time: Option<&LineTimeInput<'_>>,
) -> Result<CurveOutput, EarthError> {
    let (line, distinct, timed) = prepare_line(coords, pointer, closed, time)?;
    let closed = timed.is_none() && (closed || is_closed_line(&distinct));
    let given = timed.as_ref().map(|t| t.params.as_slice());
    let points = distinct.point_set();
    let fit_err = |e: SphereError| sphere_error(e, pointer, &distinct.input_index);
    let tol_rad = m_to_rad(tolerance_m);
    let bound = rounding_bound_rad(output.precision);
    // The dense output adds its deviation to the curve's distance from the line.
    let dense_margin = AUTO_DEVIATION_FRACTION * tol_rad;
    let mut target = tolerance_target_rad(tol_rad, output.precision);
    // No control-point cap below the input's own size here: a long line at a small tolerance
    // may need nearly a control point per position, and the input limits already bound that.
    let mut topts = ToleranceOptions {
        parameterization: options.parameterization,
        max_control_points: Some(distinct.len()),
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
        let (spline, control_ll) = round_spline(&spline, output.precision).map_err(fit_err)?;
        // The two-way distance of the curve as returned (rounded, and closed for a ring).
        let tw = two_way_distance(
            &spline,
            &points,
            &r.parameters,
            &TwoWayOptions::default()
                .with_precision_rad(REPORT_TWO_WAY_PRECISION * tol_rad)
                .with_max_evaluations(4_000_000 + 400 * points.len()),
        )
        .map_err(fit_err)?;
        let input_len = polyline_length(&points);
        let length_ratio = if input_len > 0.0 {
            tw.curve_length_rad / input_len
        } else {
            1.0
        };
        let stored = stored_numbers(&spline, r.knot_rule);
        let knot_rule = serde_json::to_value(r.knot_rule).expect("enum serialises");
        let (mut out, max_rad) = finish_fit(
            Fitted {
                line: &line,
                distinct: &distinct,
                points: &points,
                spline,
                control_ll,
                params: r.parameters,
                iterations: 0,
                converged: false,
                knots: knot_rule.clone(),
                parameterization: options.parameterization,
                // The margin the fit left for the dense output, so the returned geometry
                // stays within the tolerance too.
                sampling_aim_rad: Some(dense_margin),
                time: timed.as_ref(),
            },
            pointer,
            path.clone(),
            closed,
            output,
            limits,
        )?;
        let worst = max_rad.max(tw.upper_rad);
        let met = worst <= tol_rad
            && round_m(rad_to_m(worst)) <= tolerance_m
            && tw.curve_length_rad <= MAX_LENGTH_RATIO * input_len + tol_rad;
        if !met && r.tolerance_met && attempt == 0 && worst > tol_rad {
            // Rounding (or closing the ring) took a fit that met its target over the
            // tolerance: aim lower by the excess, once.
            let lower = target - 2.0 * (worst - tol_rad) - bound;
            if lower > 0.25 * tol_rad {
                target = lower;
                attempt += 1;
                continue;
            }
        }
        let n_in = line.points.len();
        let f = &mut out.report.fields;
        f.insert("converged".into(), json!(met));
        f.insert("tolerance_m".into(), json!(tolerance_m));
        f.insert("tolerance_met".into(), json!(met));
        f.insert(
            "two_way_distance_m".into(),
            json!(round_up_m(rad_to_m(tw.upper_rad))),
        );
        f.insert(
            "curve_length_ratio".into(),
            json!(round_to(length_ratio, 4)),
        );
        f.insert("degree".into(), json!(r.degree));
        f.insert("knot_rule".into(), knot_rule);
        f.insert("stored_numbers".into(), json!(stored));
        f.insert(
            "compression_ratio".into(),
            json!(compression_ratio(n_in, stored)),
        );
        out.report.stored_numbers = stored;
        return Ok(out);
    }
}

/// A fit in time whose two-way distance exceeds this many times its max error (at least
/// 1 m) is refitted with GLS-PIA, and the curve nearer the line kept (see [`fit_line`]).
pub const TIME_STRAY_SHARE: f64 = 4.0;

/// Precision of the reported two-way distance, as a share of the tolerance.
const REPORT_TWO_WAY_PRECISION: f64 = 0.01;

/// Without a tolerance the two-way distance is reported to 1 % of the max error or to this
/// share of the line's length, whichever is coarser (at least half a metre): near-exact fits of
/// long lines would otherwise spend seconds proving centimetres (the speed bound of the SLERP
/// triangle is first-order tight, so the cost grows as length / precision) ...
const REPORT_TWO_WAY_LENGTH_SHARE: f64 = 1e-5;

/// ... with at most this many curve evaluations (plus 64 per position); past them the bound
/// stays proven, only looser.
const REPORT_TWO_WAY_EVALUATIONS: usize = 50_000;

/// Metres rounded up to millimetres: for bounds, which must not shrink in print.
pub(crate) fn round_up_m(x: f64) -> f64 {
    (x * 1000.0).ceil() / 1000.0
}

/// Numbers a B-spline stores ([`stored_numbers`]), its knots counted unless they are the clamped
/// uniform ones, which need no storing: the same count whichever path made the spline.
fn bspline_stored_numbers(spline: &SphericalBSpline) -> usize {
    let rule = if spline.has_clamped_uniform_knots() {
        KnotRule::Uniform
    } else {
        KnotRule::Stored
    };
    stored_numbers(spline, rule)
}

/// `2 × input positions / stored numbers`, to 3 decimals.
pub fn compression_ratio(input_points: usize, stored_numbers: usize) -> f64 {
    round_to(2.0 * input_points as f64 / stored_numbers.max(1) as f64, 3)
}

/// Dense points (a ring ends exactly where it starts) and altitudes interpolated linearly over
/// the data parameters.
fn finish_dense(
    dense: &DenseCurve,
    closed: bool,
    data_params: &[f64],
    data_alts: &[f64],
) -> (Vec<[f64; 3]>, Vec<f64>) {
    let mut pts = dense.points.clone();
    if closed && pts.len() > 1 {
        let last = pts.len() - 1;
        pts[last] = pts[0];
    }
    let mut alts: Vec<f64> = dense
        .params
        .iter()
        .map(|&t| interpolate_altitude(data_params, data_alts, t))
        .collect();
    if closed && alts.len() > 1 {
        let last = alts.len() - 1;
        alts[last] = alts[0];
    }
    (pts, alts)
}

fn interpolate_altitude(params: &[f64], alts: &[f64], t: f64) -> f64 {
    let j = params.partition_point(|&u| u <= t);
    if j == 0 {
        return alts[0];
    }
    if j >= params.len() {
        return alts[alts.len() - 1];
    }
    let (ta, tb) = (params[j - 1], params[j]);
    if tb <= ta {
        return alts[j];
    }
    let f = (t - ta) / (tb - ta);
    // This form cannot overflow for finite altitudes of opposite signs.
    (1.0 - f) * alts[j - 1] + f * alts[j]
}

/// A ring needs at least 4 output positions (RFC 7946 §3.1.6).
fn ring_sampling(sampling: Sampling, closed: bool) -> Sampling {
    match sampling {
        Sampling::Samples(n) if closed && n < 4 => Sampling::Samples(4),
        Sampling::SpacingAndSamples { spacing_m, samples } if closed && samples < 4 => {
            Sampling::SpacingAndSamples {
                spacing_m,
                samples: 4,
            }
        }
        Sampling::SpacingM(spacing_m) if closed => Sampling::SpacingAndSamples {
            spacing_m,
            samples: 4,
        },
        s => s,
    }
}

/// A spline whose control points are rounded to `precision` decimals of a degree, and those
/// control points as `[lon, lat]`.
pub(crate) fn round_spline(
    s: &SphericalBSpline,
    precision: u32,
) -> Result<(SphericalBSpline, Vec<[f64; 2]>), SphereError> {
    let ll: Vec<[f64; 2]> = s
        .control_points()
        .iter()
        .map(|p| {
            let (lon, lat) = unit_to_lonlat(p);
            [round_to(lon, precision), round_to(lat, precision)]
        })
        .collect();
    let rows: Vec<[f64; 3]> = ll.iter().map(|p| lonlat_to_unit(p[0], p[1])).collect();
    let control = PointSet::try_from_rows(&rows)?;
    Ok((
        SphericalBSpline::try_new(s.degree(), s.knots().to_vec(), control)?,
        ll,
    ))
}

/// Fits a closed line: [`crate::sphere::fit::seam::fit_closed`] (first position = last; smooth
/// across the seam unless the line turns sharply there).
fn fit_closed(
    points: &PointSet,
    options: &FitOptions,
) -> Result<crate::sphere::FitReport, SphereError> {
    crate::sphere::fit::seam::fit_closed(points, options)
}

/// A LineString whose last position repeats its first (within [`REPEAT_ANGLE_RAD`]) with at
/// least 4 distinct positions is a closed curve, like a Polygon ring.
fn is_closed_line(d: &DistinctPositions) -> bool {
    let n = d.len();
    n >= 4 && angle_between(&d.points[0], &d.points[n - 1]) <= REPEAT_ANGLE_RAD
}

/// The median distance between consecutive distinct positions (radians).
fn median_step_rad(d: &DistinctPositions) -> f64 {
    let mut steps: Vec<f64> = d
        .points
        .windows(2)
        .map(|w| angle_between(&w[0], &w[1]))
        .collect();
    if steps.is_empty() {
        return 0.0;
    }
    let k = steps.len() / 2;
    *steps.select_nth_unstable_by(k, f64::total_cmp).1
}

/// Maps a math-core error on distinct positions to a GeoJSON error: at the input position
/// when it names a point ([`SphereError::site`]), else at the line (`pointer`).
pub(crate) fn sphere_error(e: SphereError, pointer: &str, input_index: &[usize]) -> EarthError {
    let at = match e.site() {
        InputSite::Point { index, .. } => format!(
            "{pointer}/{}",
            input_index.get(index).copied().unwrap_or(index)
        ),
        _ => pointer.to_string(),
    };
    let problem = match e {
        SphereError::Antipodal { angle_rad, .. } => Problem::Antipodal {
            angle_deg: angle_rad.to_degrees(),
        },
        SphereError::TooFewPoints { got, need } => Problem::TooFewPoints {
            distinct: got,
            need,
        },
        SphereError::AllPointsEqual { count } => Problem::TooFewPoints {
            distinct: count.min(1),
            need: 2,
        },
        SphereError::NotInterpolated { .. } | SphereError::DegenerateArc { .. } => {
            Problem::Interpolation(e)
        }
        other => Problem::Fit(other),
    };
    EarthError::new(at, problem)
}

/// What a tolerance fit aims at so that the curve as returned meets `tol_rad`: below it by
/// the rounding of the control points to `precision` decimals (when that leaves room), and by
/// the deviation the dense output adds to the curve's distance from the line (when at least
/// half the tolerance is left).
pub(crate) fn tolerance_target_rad(tol_rad: f64, precision: u32) -> f64 {
    let bound = rounding_bound_rad(precision);
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

/// Interpolates every distinct position of one line (or ring) with a spherical Beta-spline.
///
/// # Errors
/// As [`fit_line`], plus [`Problem::Interpolation`] when the shape parameters cannot be met.
pub fn interpolate_line(
    coords: &Value,
    pointer: &str,
    path: Vec<usize>,
    closed: bool,
    settings: &InterpolateSettings,
    output: &OutputOptions,
    limits: &Limits,
) -> Result<CurveOutput, EarthError> {
    let (line, distinct, _) = prepare_line(coords, pointer, closed, None)?;
    let points = distinct.point_set();
    let opts = InterpolationOptions::default()
        .with_beta1(settings.beta1)
        .with_beta2(settings.beta2);
    let fit_err = |e: SphereError| sphere_error(e, pointer, &distinct.input_index);
    let r = interpolate(&points, &opts).map_err(fit_err)?;
    let (curve, doc) = round_beta(&r.spline, output.precision).map_err(|e| {
        EarthError::new(
            pointer,
            Problem::InvalidSpline(format!("rounding the curve: {e}")),
        )
    })?;
    // Distance from each input position to the rounded curve at its parameter j.
    let params: Vec<f64> = (0..distinct.len()).map(|j| j as f64).collect();
    let at = curve.evaluate_many(&params);
    let (mut max_rad, mut sum_rad, mut sq_rad) = (0.0f64, 0.0, 0.0);
    for (j, c) in at.iter().enumerate() {
        let e = angle_between(&distinct.points[j], c);
        let k = distinct.multiplicity[j] as f64;
        max_rad = max_rad.max(e);
        sum_rad += e * k;
        sq_rad += e * e * k;
    }
    let n_in = line.points.len();
    let segments = distinct.len() - 1;
    // No fit error to stay below here: automatic sampling keeps within a small share of the
    // mean vertex spacing instead.
    let mean_step_rad = distinct
        .points
        .windows(2)
        .map(|w| angle_between(&w[0], &w[1]))
        .sum::<f64>()
        / segments as f64;
    let dense = sample(
        &curve,
        ring_sampling(output.sampling, closed),
        (INTERPOLATION_DEVIATION_FRACTION * mean_step_rad).max(m_to_rad(AUTO_DEVIATION_FLOOR_M)),
        sampling_start(segments),
        limits.max_samples,
    )
    .map_err(|e| EarthError::new(pointer, e.problem))?;
    let (points_out, alts) = finish_dense(&dense, closed, &params, &distinct.alts);
    let mut fields = Map::new();
    fields.insert("max_error_m".into(), json!(round_m(rad_to_m(max_rad))));
    fields.insert("input_points".into(), json!(n_in));
    fields.insert("segments".into(), json!(segments));
    fields.insert("output_points".into(), json!(points_out.len()));
    fields.insert(
        "sampling_deviation_m".into(),
        json!(round_m(rad_to_m(dense.max_deviation_rad))),
    );
    fields.insert("curve".into(), doc);
    Ok(CurveOutput {
        pointer: pointer.to_string(),
        has_alt: line.alts.is_some(),
        report: CurveReport {
            path,
            closed,
            fields,
            input_points: n_in,
            output_points: points_out.len(),
            stored_numbers: curve.stored_numbers(),
            max_error_m: rad_to_m(max_rad),
            error_sum_m: rad_to_m(sum_rad),
            error_sq_sum_m2: rad_to_m(rad_to_m(sq_rad)),
        },
        points: points_out,
        alts,
        time: None,
    })
}

/// A Beta-spline with control points rounded to `precision`, and its lon/lat document.
fn round_beta(
    s: &SphericalBetaSpline,
    precision: u32,
) -> Result<(SphericalBetaSpline, Value), crate::sphere::document::InputError> {
    let doc = BetaDocument::from(s);
    let round_pt = |p: &Vec<f64>| {
        let (lon, lat) = unit_to_lonlat(p);
        [round_to(lon, precision), round_to(lat, precision)]
    };
    let ll_segments: Vec<Vec<[f64; 2]>> = doc
        .segments
        .iter()
        .map(|seg| seg.iter().map(round_pt).collect())
        .collect();
    let unit_doc = BetaDocument {
        kind: doc.kind.clone(),
        beta1: doc.beta1.clone(),
        beta2: doc.beta2.clone(),
        segments: ll_segments
            .iter()
            .map(|seg| std::array::from_fn(|k| lonlat_to_unit(seg[k][0], seg[k][1]).to_vec()))
            .collect(),
    };
    let spline = unit_doc.to_spline()?;
    let json_doc = json!({
        "type": "beta",
        "beta1": doc.beta1,
        "beta2": doc.beta2,
        "segments": ll_segments,
    });
    Ok((spline, json_doc))
}

/// Reads a lon/lat curve document at `pointer`: a B-spline `{"degree", "knots",
/// "control_points": [[lon, lat], ...]}` or a Beta-spline `{"type": "beta", "beta1", "beta2",
/// "segments"}`. `"crs"`, when present, must be `"lonlat"`.
///
/// # Errors
/// [`Problem::InvalidSpline`] or [`Problem::InvalidCoordinate`] at the offending field.
pub fn curve_from_lonlat_json(v: &Value, pointer: &str) -> Result<AnyCurve, EarthError> {
    let invalid = |ptr: String, msg: String| EarthError::new(ptr, Problem::InvalidSpline(msg));
    let map = v.as_object().ok_or_else(|| {
        invalid(
            pointer.to_string(),
            "expected a spline document {\"degree\", \"knots\", \"control_points\": [[lon, lat], ...]}".into(),
        )
    })?;
    if let Some(crs) = map.get("crs") {
        if crs.as_str() != Some("lonlat") {
            return Err(invalid(
                format!("{pointer}/crs"),
                "only \"lonlat\" is supported here (a document of unit vectors is an S^n document: evaluate it on S^n)"
                    .into(),
            ));
        }
    }
    let is_beta =
        map.get("type").and_then(Value::as_str) == Some("beta") || map.contains_key("segments");
    // Convert lon/lat positions to unit vectors in a copy of the document, then let the math
    // core's document reader validate it (its pointers are relative to the document).
    let mut unit = map.clone();
    unit.remove("crs");
    let convert = |v: &Value, ptr: &str| -> Result<Value, EarthError> {
        let line = parse_positions(v, ptr)?;
        Ok(json!(line.points))
    };
    if is_beta {
        let segs = map
            .get("segments")
            .and_then(Value::as_array)
            .ok_or_else(|| {
                invalid(
                    format!("{pointer}/segments"),
                    "expected an array of segments".into(),
                )
            })?;
        let mut out = Vec::with_capacity(segs.len());
        for (i, s) in segs.iter().enumerate() {
            out.push(convert(s, &format!("{pointer}/segments/{i}"))?);
        }
        unit.insert("segments".into(), Value::Array(out));
        let spline = BetaDocument::from_json(&Value::Object(unit))
            .and_then(|d| d.to_spline())
            .map_err(|e| invalid(format!("{pointer}{}", e.pointer), e.message))?;
        Ok(AnyCurve::Beta(spline))
    } else {
        let cps = map.get("control_points").ok_or_else(|| {
            invalid(
                pointer.to_string(),
                "missing \"control_points\" ([[lon, lat], ...])".into(),
            )
        })?;
        unit.insert(
            "control_points".into(),
            convert(cps, &format!("{pointer}/control_points"))?,
        );
        let spline = crate::sphere::document::spline_from_json(&Value::Object(unit))
            .map_err(|e| invalid(format!("{pointer}{}", e.pointer), e.message))?;
        Ok(AnyCurve::BSpline(spline))
    }
}

/// Samples a stored curve densely (for `evaluate`). `known_error_m` (the fit's max error, when
/// the document carries it) sets the automatic sampling tolerance.
///
/// # Errors
/// An invalid document, or output over the limits.
///
/// `time` is the stored `time` of a fit in time and its pointer: the dense points then carry
/// their times (an evaluated line has no altitudes, so the times of a track whose times were
/// its 4th coordinate go to the property `times`, in unix seconds), and `spacing_s` applies.
#[allow(clippy::too_many_arguments)]
pub fn evaluate_curve(
    doc: &Value,
    pointer: &str,
    path: Vec<usize>,
    closed: bool,
    known_error_m: Option<f64>,
    output: &OutputOptions,
    limits: &Limits,
    time: Option<(&Value, &str)>,
) -> Result<CurveOutput, EarthError> {
    let curve = curve_from_lonlat_json(doc, pointer)?;
    let time = time.map(|(v, p)| TimeMap::from_json(v, p)).transpose()?;
    let (start, stored) = match &curve {
        AnyCurve::BSpline(s) => {
            let n = s.control_points().len();
            (sampling_start(n), bspline_stored_numbers(s))
        }
        AnyCurve::Beta(s) => {
            let n = s.segment_count();
            (sampling_start(n), s.stored_numbers())
        }
    };
    let tol = auto_tolerance_rad(m_to_rad(known_error_m.unwrap_or(0.0).max(0.0)));
    let dense = sample_curve(
        &curve,
        output,
        closed,
        tol,
        start,
        limits,
        time.as_ref().map(|(m, _)| m),
    )
    .map_err(|e| EarthError::new(pointer, e.problem))?;
    let (points, alts) = finish_dense(&dense, closed, &[0.0], &[0.0]);
    let dense_times = time.map(|(map, origin)| DenseTimes {
        unix_s: dense.params.iter().map(|&u| map.time(u)).collect(),
        format: map.format,
        origin: match origin {
            TimeOrigin::M => TimeOrigin::Property("times".into()),
            o => o,
        },
    });
    let mut fields = Map::new();
    fields.insert("output_points".into(), json!(points.len()));
    fields.insert(
        "sampling_deviation_m".into(),
        json!(round_m(rad_to_m(dense.max_deviation_rad))),
    );
    Ok(CurveOutput {
        pointer: pointer.to_string(),
        has_alt: false,
        report: CurveReport {
            path,
            closed,
            fields,
            input_points: 0,
            output_points: points.len(),
            stored_numbers: stored,
            max_error_m: 0.0,
            error_sum_m: 0.0,
            error_sq_sum_m2: 0.0,
        },
        points,
        alts,
        time: dense_times,
    })
}

/// A stored fit in time: its spline and the map from times to its parameter.
#[derive(Clone, Debug)]
pub struct CurveInTime {
    /// The spline (parameter on [0, 1]).
    pub spline: SphericalBSpline,
    /// Times <-> parameter.
    pub map: TimeMap,
    /// Where its times came from.
    pub origin: TimeOrigin,
}

/// Reads a fit in time: the lon/lat B-spline `doc` at `pointer` and its `time` member.
///
/// # Errors
/// [`Problem::InvalidSpline`] for a bad document, or when `time` is missing (the fit was not
/// made with `parameterization=time`).
pub fn curve_in_time(
    doc: &Value,
    pointer: &str,
    time: Option<&Value>,
    time_pointer: &str,
) -> Result<CurveInTime, EarthError> {
    let Some(time) = time else {
        return Err(EarthError::new(
            time_pointer,
            Problem::InvalidSpline(
                "this fit is not in time (no \"time\" beside the spline): fit with parameterization=time to evaluate at times".into(),
            ),
        ));
    };
    let (map, origin) = TimeMap::from_json(time, time_pointer)?;
    match curve_from_lonlat_json(doc, pointer)? {
        AnyCurve::BSpline(spline) => Ok(CurveInTime {
            spline,
            map,
            origin,
        }),
        AnyCurve::Beta(_) => Err(EarthError::new(
            pointer,
            Problem::InvalidSpline("a Beta-spline is not a curve in time".into()),
        )),
    }
}

/// Rounds a position for output: degrees to `precision`, altitude to millimetres.
pub fn output_position(p: &[f64; 3], has_alt: bool, precision: u32) -> Value {
    let lon = round_to(p[0], precision);
    let lat = round_to(p[1], precision);
    if has_alt {
        json!([lon, lat, round_to(p[2], ALTITUDE_DECIMALS)])
    } else {
        json!([lon, lat])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn coords(n: usize, f: impl Fn(f64) -> (f64, f64)) -> Value {
        json!((0..n)
            .map(|i| {
                let (a, b) = f(i as f64 / (n - 1) as f64);
                [a, b]
            })
            .collect::<Vec<_>>())
    }

    #[test]
    fn positions_are_checked_with_pointers() {
        let e = parse_positions(&json!([[0, 0], [1, 91]]), "/c").unwrap_err();
        assert_eq!(e.pointer, "/c/1/1");
        let e = parse_positions(&json!([[0, 0], [181, 1]]), "/c").unwrap_err();
        assert_eq!(e.pointer, "/c/1/0");
        let e = parse_positions(&json!([[0, 0], ["1", 1]]), "/c").unwrap_err();
        assert_eq!(e.pointer, "/c/1/0");
        let e = parse_positions(&json!([[0, 0, 5], [1, 1]]), "/c").unwrap_err();
        assert_eq!(e.pointer, "/c/1");
        let e = parse_positions(&json!([[0, 0], [1]]), "/c").unwrap_err();
        assert_eq!(e.pointer, "/c/1");
        let ok = parse_positions(&json!([[0, 0, 5], [1, 1, 6]]), "/c").unwrap();
        assert_eq!(ok.alts, Some(vec![5.0, 6.0]));
    }

    #[test]
    fn repeats_are_dropped_but_counted() {
        let line =
            parse_positions(&json!([[0, 0], [0, 0], [1, 0], [1, 0], [1, 0], [2, 0]]), "").unwrap();
        let d = DistinctPositions::from_line(&line);
        assert_eq!(d.len(), 3);
        assert_eq!(d.multiplicity, vec![2, 3, 1]);
        assert_eq!(d.input_index, vec![0, 2, 5]);
    }

    #[test]
    fn too_few_distinct_points_lower_the_degree_or_fail() {
        let opts = FitOptions::default();
        let out = OutputOptions::default();
        let lim = Limits::default();
        let r = fit_line(
            &json!([[0, 0], [1, 1], [1, 1]]),
            "/c",
            vec![],
            false,
            &opts,
            &out,
            &lim,
            None,
        )
        .unwrap();
        assert_eq!(r.report.fields["spline"]["degree"], 1);
        assert_eq!(r.report.fields["input_points"], 3);
        let e = fit_line(
            &json!([[0, 0], [0, 0]]),
            "/c",
            vec![],
            false,
            &opts,
            &out,
            &lim,
            None,
        )
        .unwrap_err();
        assert!(matches!(
            e.problem,
            Problem::TooFewPoints { distinct: 1, .. }
        ));
    }

    #[test]
    fn antipodal_neighbours_point_at_the_second() {
        let e = fit_line(
            &json!([[0, 0], [10, 0], [-170, 0]]),
            "/c",
            vec![],
            false,
            &FitOptions::default(),
            &OutputOptions::default(),
            &Limits::default(),
            None,
        )
        .unwrap_err();
        assert_eq!(e.pointer, "/c/2");
        assert!(matches!(e.problem, Problem::Antipodal { .. }));
    }

    #[test]
    fn a_ring_closes_exactly() {
        let ring = coords(61, |u| {
            let a = u * std::f64::consts::TAU;
            (
                10.0 + 3.0 * a.cos(),
                45.0 + 2.0 * a.sin() + 0.2 * (5.0 * a).sin(),
            )
        });
        let r = fit_line(
            &ring,
            "/c",
            vec![0],
            true,
            &FitOptions::default().with_control_points(12),
            &OutputOptions::default(),
            &Limits::default(),
            None,
        )
        .unwrap();
        assert_eq!(r.points.first(), r.points.last());
        let cps = r.report.fields["spline"]["control_points"]
            .as_array()
            .unwrap();
        assert_eq!(cps.first(), cps.last());
        assert!(r.report.max_error_m < 20_000.0, "{}", r.report.max_error_m);
        let e = fit_line(
            &json!([[0, 0], [1, 0], [1, 1], [0, 1]]),
            "/c",
            vec![0],
            true,
            &FitOptions::default(),
            &OutputOptions::default(),
            &Limits::default(),
            None,
        )
        .unwrap_err();
        assert_eq!(e.pointer, "/c/3");
    }

    #[test]
    fn altitude_follows_the_parameter() {
        let line = json!([
            [0, 0, 0],
            [1, 0, 100],
            [2, 0, 200],
            [3, 0, 300],
            [4, 0, 400]
        ]);
        let r = fit_line(
            &line,
            "",
            vec![],
            false,
            &FitOptions::default(),
            &OutputOptions::default(),
            &Limits::default(),
            None,
        )
        .unwrap();
        assert!(r.has_alt);
        assert_eq!(r.alts[0], 0.0);
        assert_eq!(*r.alts.last().unwrap(), 400.0);
        // Along a great circle at constant speed, altitude ~ 100 m per degree of longitude.
        for (p, a) in r.points.iter().zip(&r.alts) {
            let (lon, _) = unit_to_lonlat(p);
            assert!((a - 100.0 * lon).abs() < 1.0, "{lon} {a}");
        }
    }

    #[test]
    fn reported_errors_are_those_of_the_returned_spline() {
        let line = coords(200, |u| (-20.0 + 40.0 * u, 5.0 * (8.0 * u).sin()));
        let r = fit_line(
            &line,
            "",
            vec![],
            false,
            &FitOptions::default().with_control_points(15),
            &OutputOptions::default(),
            &Limits::default(),
            None,
        )
        .unwrap();
        let doc = &r.report.fields["spline"];
        let curve = match curve_from_lonlat_json(doc, "").unwrap() {
            AnyCurve::BSpline(s) => s,
            _ => unreachable!(),
        };
        let pts = parse_positions(&line, "").unwrap().points;
        let params = crate::sphere::knots::parameters(
            &PointSet::try_from_rows(&pts).unwrap(),
            crate::sphere::Parameterization::Chord,
        )
        .unwrap();
        let c = curve.evaluate_many(&params);
        let max = pts
            .iter()
            .zip(c.iter())
            .map(|(p, q)| rad_to_m(angle_between(p, q)))
            .fold(0.0, f64::max);
        let reported = r.report.fields["max_error_m"].as_f64().unwrap();
        assert!((max - reported).abs() < 0.001, "{max} vs {reported}");
    }
}
