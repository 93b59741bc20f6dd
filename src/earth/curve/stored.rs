//! Curves stored as lon/lat documents (`properties.fit`, `properties.interpolation`, a bare
//! spline document): read back ([`curve_from_lonlat_json`]) and evaluated, densely or in time.

use crate::document::beta::BetaDocument;
use crate::earth::curve::compact::decode_compact;
use crate::earth::curve::fitting::bspline_stored_numbers;
use crate::earth::curve::line::{ErrorSums, LineRef, OutputSpec};
use crate::earth::curve::output::{
    auto_tolerance_rad, finish_dense, sample_curve, sampling_start, CurveOutput, CurveReport,
};
use crate::earth::curve::positions::{parse_positions, round_m};
use crate::earth::curve::times::DenseTimes;
use crate::earth::error::{EarthError, Problem};
use crate::earth::lonlat::{m_to_rad, rad_to_m};
use crate::earth::time::{TimeMap, TimeOrigin};
use crate::sphere::curve::bspline::SphericalBSpline;
use crate::sphere::curve::AnyCurve;
use serde_json::{json, Map, Value};

/// Most control points a compact curve may declare. The decoder also refuses any count its
/// bytes cannot hold, so what it allocates is bounded by the input's length either way.
pub const MAX_COMPACT_CONTROL_POINTS: usize = 1_000_000;

/// The value of a degree-1 spline's `control_points` in `properties.fit` that stands for the
/// positions of the feature's own geometry: `{"degree": 1, "control_points": "geometry"}`.
///
/// A degree-1 fit's dense geometry *is* its control points (a polyline's dense output is its
/// vertices), so with `carry=both` the spline refers to them instead of repeating them. The
/// positions are those of the Feature's `geometry` at the part's `path` (its `coordinates` for
/// a LineString's own `spline`; `coordinates[i]` for `path` `[i]`, `coordinates[p][r]` for
/// `[p, r]`), `[lon, lat]` of each, altitudes and times ignored; the geometry's type is the
/// fit's (`LineString`, or `properties.fit.geometry` for parts). `knots` is then left out when
/// they are the clamped uniform ones (`n + 2` knots `0, 0, 1/(n-1), ..., 1, 1`). The writer uses it
/// only when those positions are exactly the control points it would have written, so reading
/// either gives the same spline. A bare spline document has no geometry to refer to.
pub const CONTROL_POINTS_OF_GEOMETRY: &str = "geometry";

/// `[lon, lat]` of each position of a GeoJSON position array (altitudes and times ignored);
/// `None` if it is not one.
pub fn lonlat_of_positions(v: &Value) -> Option<Vec<[f64; 2]>> {
    v.as_array()?
        .iter()
        .map(|p| {
            let p = p.as_array()?;
            Some([p.first()?.as_f64()?, p.get(1)?.as_f64()?])
        })
        .collect()
}

/// A spline document whose control points are [`CONTROL_POINTS_OF_GEOMETRY`] made whole: its
/// control points are `geometry`'s positions at `path` (checked to be of type `kind`), and
/// clamped uniform knots are filled in when it has none. Any other document is `None` (read
/// as it is).
///
/// # Errors
/// [`Problem::InvalidSpline`] at `pointer/control_points` when the geometry has no positions
/// at `path` or is not of type `kind`.
pub fn spline_of_geometry(
    doc: &Value,
    pointer: &str,
    geometry: Option<&Value>,
    kind: &str,
    path: &[usize],
) -> Result<Option<Value>, EarthError> {
    let Some(map) = doc.as_object() else {
        return Ok(None);
    };
    if map.get("control_points").and_then(Value::as_str) != Some(CONTROL_POINTS_OF_GEOMETRY) {
        return Ok(None);
    }
    let fail = |why: String| {
        EarthError::new(
            format!("{pointer}/control_points"),
            Problem::InvalidSpline(format!(
                "\"{CONTROL_POINTS_OF_GEOMETRY}\" stands for the positions of the feature's geometry at path {path:?}: {why}"
            )),
        )
    };
    if map.get("degree").and_then(Value::as_u64) != Some(1) {
        return Err(fail(
            "only a degree-1 spline's control points are its geometry's positions".into(),
        ));
    }
    let g = geometry
        .filter(|g| !g.is_null())
        .ok_or_else(|| fail("there is no geometry".into()))?;
    let g_kind = g.get("type").and_then(Value::as_str).unwrap_or("");
    if g_kind != kind {
        return Err(fail(format!(
            "the geometry is a {g_kind}, the fit's a {kind}"
        )));
    }
    let mut at = &g["coordinates"];
    for &i in path {
        at = &at[i];
    }
    let ll = lonlat_of_positions(at)
        .filter(|ll| !ll.is_empty())
        .ok_or_else(|| fail("there is no position array there".into()))?;
    let mut whole = map.clone();
    if !whole.contains_key("knots") {
        whole.insert(
            "knots".into(),
            json!(crate::sphere::curve::bspline::clamped_uniform_knots(
                ll.len(),
                1
            )),
        );
    }
    whole.insert("control_points".into(), json!(ll));
    Ok(Some(Value::Object(whole)))
}

/// Reads a lon/lat curve document at `pointer`: a B-spline `{"degree", "knots",
/// "control_points": [[lon, lat], ...]}`, the same as a compact curve (a base64 string,
/// [`decode_compact`]), or a Beta-spline `{"type": "beta", "beta1", "beta2",
/// "segments"}`. `"crs"`, when present, must be `"lonlat"`.
///
/// # Errors
/// [`Problem::InvalidSpline`] or [`Problem::InvalidCoordinate`] at the offending field.
pub fn curve_from_lonlat_json(v: &Value, pointer: &str) -> Result<AnyCurve, EarthError> {
    let invalid = |ptr: String, msg: String| EarthError::new(ptr, Problem::InvalidSpline(msg));
    // A compact curve (`carry=spline`): the document it stands for, checked as any other.
    if let Value::String(text) = v {
        let doc = decode_compact(text, MAX_COMPACT_CONTROL_POINTS)
            .map_err(|m| EarthError::new(pointer, Problem::CorruptCompactCurve(m)))?;
        return curve_from_lonlat_json(&doc, pointer);
    }
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
        if cps.as_str() == Some(CONTROL_POINTS_OF_GEOMETRY) {
            return Err(invalid(
                format!("{pointer}/control_points"),
                format!("\"{CONTROL_POINTS_OF_GEOMETRY}\" stands for the positions of a Feature's geometry: evaluate the Feature whose properties.fit holds this spline"),
            ));
        }
        unit.insert(
            "control_points".into(),
            convert(cps, &format!("{pointer}/control_points"))?,
        );
        let spline = crate::document::spline_from_json(&Value::Object(unit))
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
pub fn evaluate_curve(
    src: LineRef<'_>,
    known_error_m: Option<f64>,
    time: Option<(&Value, &str)>,
    out: OutputSpec<'_>,
) -> Result<CurveOutput, EarthError> {
    let (doc, pointer, closed) = (src.value, src.pointer, src.closed);
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
        out,
        closed,
        tol,
        start,
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
            output_points: points.len(),
            stored_numbers: stored,
            ..CurveReport::of_line(src, fields, 0, ErrorSums::default())
        },
        points,
        alts,
        time: dense_times,
        kept: None,
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
                "this fit is not in time (no \"time\" beside the spline): fit with parameterization time to evaluate at times".into(),
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
