//! What a curve gives back: its report ([`CurveReport`]), the dense line and its times
//! ([`CurveOutput`]), and positions as written.

use crate::earth::curve::line::OutputSpec;
use crate::earth::curve::positions::ALTITUDE_DECIMALS;
use crate::earth::curve::times::DenseTimes;
use crate::earth::error::EarthError;
use crate::earth::json_out::JsonOut;
use crate::earth::lonlat::{lonlat_to_unit, m_to_rad, round_to};
use crate::earth::sampling::{
    sample, sample_at, time_parameters, DenseCurve, Sampling, AUTO_DEVIATION_FLOOR_M,
    AUTO_DEVIATION_FRACTION,
};
use crate::earth::time::TimeMap;
use crate::sphere::geometry::point::PointSet;
use crate::sphere::SphereError;
use serde_json::{json, Map, Value};

/// Everything reported about one fitted, interpolated or evaluated curve.
#[derive(Clone, Debug, PartialEq)]
pub struct CurveReport {
    /// Where the curve sits in its geometry's coordinates (`[]` for a LineString, `[i]` for a
    /// MultiLineString part or Polygon ring, `[polygon, ring]` for a MultiPolygon).
    pub path: Vec<usize>,
    /// A ring (closed curve).
    pub closed: bool,
    /// Fields of `properties.fit` (or `interpolation`) for this curve; an interpolation's
    /// `curve` included, a fit's `spline` apart in [`CurveReport::spline`].
    pub fields: Map<String, Value>,
    /// A fit's `spline` document, kept as numbers until written ([`JsonOut`]).
    pub spline: Option<JsonOut>,
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

impl CurveReport {
    /// The report's members as output: [`CurveReport::fields`] and the spline.
    pub fn into_members(self) -> std::collections::BTreeMap<String, JsonOut> {
        let mut m: std::collections::BTreeMap<String, JsonOut> = self
            .fields
            .into_iter()
            .map(|(k, v)| (k, JsonOut::Value(v)))
            .collect();
        if let Some(spline) = self.spline {
            m.insert("spline".into(), spline);
        }
        m
    }
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
    /// A tolerance fit's polyline as fitted, when it is written as its vertices, so that a
    /// ring found meeting another can be refitted around the meeting only.
    pub kept: Option<Box<KeptPolyline>>,
}

/// A polyline fitted to a tolerance (degree 1 on uniform knots, its dense points its
/// vertices) and the parameters of its positions on it: what [`refit_line_around`](crate::earth::polygon::splice::refit_line_around) splices.
///
/// Refitting a whole ring for one meeting stored a long coast's every stretch at the tighter
/// tolerance (docs/speed.md, "eighth session").
#[derive(Clone, Debug)]
pub struct KeptPolyline {
    /// Its vertices as written (a ring's seam closed): the spline's control points are these
    /// made unit vectors ([`lonlat_to_unit`]) and normalised (as `round_spline_rows` made
    /// them), so they are not kept twice (the 10m countries per feature held about 10 MB more
    /// with them).
    pub(crate) control_ll: Vec<[f64; 2]>,
    /// The parameters of the line's distinct positions on it.
    pub(crate) params: Vec<f64>,
    /// An upper bound of its two-way distance from the line, radians.
    pub(crate) two_way_rad: f64,
}

impl KeptPolyline {
    /// The vertices as unit vectors, as [`lonlat_to_unit`] makes them, and as the spline's
    /// control points (normalised).
    pub(crate) fn rows(&self) -> Result<(Vec<[f64; 3]>, PointSet), SphereError> {
        let rows: Vec<[f64; 3]> = self
            .control_ll
            .iter()
            .map(|p| lonlat_to_unit(p[0], p[1]))
            .collect();
        let set = PointSet::try_from_rows(&rows)?;
        Ok((rows, set))
    }
}

/// The number of points automatic sampling starts from: a few per control point.
pub(crate) fn sampling_start(control_points: usize) -> usize {
    (4 * control_points).max(16)
}

/// Automatic sampling tolerance for a curve whose max error is `max_error_rad`.
pub fn auto_tolerance_rad(max_error_rad: f64) -> f64 {
    (AUTO_DEVIATION_FRACTION * max_error_rad).max(m_to_rad(AUTO_DEVIATION_FLOOR_M))
}

/// Samples a curve densely as the output options say; `spacing_s` needs the curve's times.
pub(super) fn sample_curve(
    curve: &dyn crate::sphere::SphericalCurve,
    out: OutputSpec<'_>,
    closed: bool,
    auto_tolerance_rad: f64,
    start: usize,
    time: Option<&TimeMap>,
) -> Result<DenseCurve, EarthError> {
    let (output, limits) = (out.output, out.limits);
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

/// Metres rounded up to millimetres: for bounds, which must not shrink in print.
pub(crate) fn round_up_m(x: f64) -> f64 {
    (x * 1000.0).ceil() / 1000.0
}

/// `2 × input positions / stored numbers`, to 3 decimals.
pub fn compression_ratio(input_points: usize, stored_numbers: usize) -> f64 {
    round_to(2.0 * input_points as f64 / stored_numbers.max(1) as f64, 3)
}

/// Dense points (a ring ends exactly where it starts) and altitudes interpolated linearly over
/// the data parameters.
pub(super) fn finish_dense(
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
    // Without altitudes (every one +0.0) each interpolated altitude is +0.0: a position's own,
    // or (1 − f)·0 + f·0 with f in [0, 1). Not searching the parameters for each dense point
    // saved 64 M instructions on the 10m land outlines at 10 m.
    let mut alts: Vec<f64> = if !data_alts.is_empty() && data_alts.iter().all(|a| a.to_bits() == 0)
    {
        vec![0.0; dense.params.len()]
    } else {
        dense
            .params
            .iter()
            .map(|&t| interpolate_altitude(data_params, data_alts, t))
            .collect()
    };
    if closed && alts.len() > 1 {
        let last = alts.len() - 1;
        alts[last] = alts[0];
    }
    (pts, alts)
}

pub(super) fn interpolate_altitude(params: &[f64], alts: &[f64], t: f64) -> f64 {
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
pub(super) fn ring_sampling(sampling: Sampling, closed: bool) -> Sampling {
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

/// Positions rounded for output as [`output_position`] rounds them, as rows.
pub fn output_positions(ps: &[[f64; 3]], has_alt: bool, precision: u32) -> JsonOut {
    let width = if has_alt { 3 } else { 2 };
    let mut numbers = Vec::with_capacity(ps.len() * width);
    for p in ps {
        numbers.push(round_to(p[0], precision));
        numbers.push(round_to(p[1], precision));
        if has_alt {
            numbers.push(round_to(p[2], ALTITUDE_DECIMALS));
        }
    }
    JsonOut::Rows { numbers, width }
}
