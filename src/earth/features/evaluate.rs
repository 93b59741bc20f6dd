//! Evaluation: the curves stored in `properties.fit` (or `interpolation`) read back and
//! sampled, evaluated at times, or a bare lon/lat spline document sampled.

use crate::earth::curve::output::output_position;
use crate::earth::curve::stored::{curve_in_time, spline_of_geometry};
use crate::earth::error::{EarthError, Problem};
use crate::earth::features::run::run_curves;
use crate::earth::features::{
    array_at, assemble, invalid, Assembled, CurveJob, FeatureStats, Made, ProcessedFeature,
    CURVE_TYPES,
};
use crate::earth::job::{Job, Operation};
use crate::earth::json_out::JsonOut;
use crate::earth::time::{motion, TimeOrigin};

use serde_json::{json, Map, Value};

/// Reads the curves stored in `properties.fit` (or `properties.interpolation`) for evaluation;
/// `None` when the feature has none.
pub(super) fn curves_of_fit<'a>(
    feature: &'a Map<String, Value>,
    ptr: &str,
    job: &Job,
) -> Result<Made, EarthError> {
    let props = match feature.get("properties") {
        Some(Value::Object(p)) => p,
        _ => return Ok(None),
    };
    let (key, doc_key) = if props.get("fit").is_some_and(Value::is_object) {
        ("fit", "spline")
    } else if props.get("interpolation").is_some_and(Value::is_object) {
        ("interpolation", "curve")
    } else {
        return Ok(None);
    };
    let info = &props[key];
    let iptr = format!("{ptr}/properties/{key}");
    let known = |v: &Value| v.get("max_error_m").and_then(Value::as_f64);
    let time_of = |v: &'a Value, p: &str| v.get("time").map(|t| (t, format!("{p}/time")));
    let geometry = feature.get("geometry");
    if let Some(doc) = info.get(doc_key) {
        let pointer = format!("{iptr}/{doc_key}");
        let whole = spline_of_geometry(doc, &pointer, geometry, "LineString", &[])?;
        let jobs = vec![CurveJob {
            value: whole.as_ref().unwrap_or(doc),
            pointer,
            path: vec![],
            closed: false,
            known_error_m: known(info),
            times: None,
            time_doc: time_of(info, &iptr),
        }];
        if let Some(at) = &job.time.at_unix_s {
            return evaluate_at(&jobs, &iptr, at, job).map(Some);
        }
        let outputs = run_curves(&jobs, job)?;
        return assemble("LineString", outputs, &[], job).map(Some);
    }
    let Some(parts) = info.get("parts") else {
        return Err(invalid(
            iptr,
            format!(
                "expected \"{doc_key}\" or \"parts\" (as a fit or an interpolation writes them)"
            ),
        ));
    };
    let kind =
        match info.get("geometry").and_then(Value::as_str) {
            Some(k) if CURVE_TYPES.contains(&k) => k,
            _ => return Err(invalid(
                format!("{iptr}/geometry"),
                "expected the geometry type of the parts: MultiLineString, Polygon or MultiPolygon",
            )),
        };
    let need_path = match kind {
        "MultiPolygon" => 2,
        "LineString" => 0,
        _ => 1,
    };
    // Each part's document, made whole when it refers to the geometry's positions.
    let mut docs = Vec::new();
    for (i, part) in array_at(parts, &format!("{iptr}/parts"), "parts")?
        .iter()
        .enumerate()
    {
        let pptr = format!("{iptr}/parts/{i}");
        let path: Option<Vec<usize>> = part
            .get("path")
            .and_then(Value::as_array)
            .and_then(|a| a.iter().map(|x| x.as_u64().map(|u| u as usize)).collect());
        let path = match path {
            Some(p) if p.len() == need_path => p,
            _ => {
                return Err(invalid(
                    format!("{pptr}/path"),
                    format!("expected {need_path} indices locating this part in a {kind}"),
                ))
            }
        };
        let doc = part
            .get(doc_key)
            .ok_or_else(|| invalid(&pptr, format!("a part needs \"{doc_key}\"")))?;
        let pointer = format!("{pptr}/{doc_key}");
        let whole = spline_of_geometry(doc, &pointer, geometry, kind, &path)?;
        docs.push((part, pptr, pointer, path, doc, whole));
    }
    let mut jobs = Vec::with_capacity(docs.len());
    for (part, pptr, pointer, path, doc, whole) in &docs {
        jobs.push(CurveJob {
            value: whole.as_ref().unwrap_or(doc),
            pointer: pointer.clone(),
            path: path.clone(),
            closed: kind.ends_with("Polygon"),
            known_error_m: known(part),
            times: None,
            time_doc: time_of(part, pptr),
        });
    }
    if jobs.is_empty() {
        return Ok(None);
    }
    // Parts in geometry order, whatever order the document lists them in.
    jobs.sort_by(|a, b| a.path.cmp(&b.path));
    if let Some(at) = &job.time.at_unix_s {
        return evaluate_at(&jobs, &iptr, at, job).map(Some);
    }
    let outputs = run_curves(&jobs, job)?;
    assemble(kind, outputs, &[], job).map(Some)
}

/// Rounds a speed (m/s) to 0.1 mm/s and a heading to a thousandth of a degree for output.
pub(super) fn round_motion(speed_mps: f64, heading_deg: f64) -> (f64, f64) {
    (
        crate::earth::lonlat::round_to(speed_mps, 4),
        crate::earth::lonlat::round_to(heading_deg, 3) % 360.0,
    )
}

/// Evaluates the fits in time of one feature at the times `at` (unix seconds): a MultiPoint of
/// the positions in the order asked, and `properties.evaluation` with the times (`at`, in the
/// fit's convention), `speed_mps` and `heading_deg` from the curve's derivative. Each time is
/// taken on the first part whose times span it.
pub(super) fn evaluate_at(
    jobs: &[CurveJob<'_>],
    info_pointer: &str,
    at: &[f64],
    job: &Job,
) -> Result<Assembled, EarthError> {
    let mut curves = Vec::with_capacity(jobs.len());
    for c in jobs {
        let (time, time_pointer) = match &c.time_doc {
            Some((v, p)) => (Some(*v), p.clone()),
            None => (None, info_pointer.to_string()),
        };
        curves.push(curve_in_time(c.value, &c.pointer, time, &time_pointer)?);
    }
    let first = &curves[0];
    let format = first.map.format;
    let name = match &first.origin {
        TimeOrigin::Property(n) => n.clone(),
        TimeOrigin::M => "times".to_string(),
    };
    let precision = job.output.precision;
    let (mut coords, mut times, mut speeds, mut headings) = (vec![], vec![], vec![], vec![]);
    for &t in at {
        let Some(c) = curves
            .iter()
            .find(|c| c.map.start_unix_s <= t && t <= c.map.end_unix_s)
        else {
            let spans: Vec<String> = curves
                .iter()
                .map(|c| {
                    format!(
                        "{} to {}",
                        c.map.format.write(c.map.start_unix_s),
                        c.map.format.write(c.map.end_unix_s)
                    )
                })
                .collect();
            return Err(EarthError::new(
                info_pointer,
                Problem::InvalidTime(format!(
                    "at={} is outside this track's times ({}): a track is not extrapolated",
                    format.write(t),
                    spans.join(", ")
                )),
            ));
        };
        let m = motion(&c.spline, &c.map, t);
        let (lon, lat) = crate::earth::lonlat::unit_to_lonlat(&m.point);
        coords.push(output_position(&[lon, lat, 0.0], false, precision));
        times.push(format.write(t));
        let (sp, hd) = round_motion(m.speed_mps, m.heading_deg);
        speeds.push(json!(sp));
        headings.push(json!(hd));
    }
    let n = coords.len();
    let info = json!({
        "output_points": n,
        "at": times,
        "speed_mps": speeds,
        "heading_deg": headings,
    });
    let stats = FeatureStats {
        curves: curves.len(),
        output_points: n,
        ..FeatureStats::default()
    };
    Ok((
        json!({"type": "MultiPoint", "coordinates": coords}).into(),
        info.into(),
        stats,
        vec![(name, Value::Array(times))],
    ))
}

/// Samples a bare lon/lat spline document (`{"crs": "lonlat", "degree", "knots",
/// "control_points"}` or a Beta-spline document) at `pointer` into a Feature whose
/// `properties.evaluation` says how densely.
///
/// # Errors
/// An invalid document, or output over the limits.
pub fn evaluate_spline_document(
    doc: &Value,
    pointer: &str,
    job: &Job,
) -> Result<ProcessedFeature, EarthError> {
    let jobs = [CurveJob {
        value: doc,
        pointer: pointer.to_string(),
        path: vec![],
        closed: false,
        known_error_m: None,
        times: None,
        time_doc: None,
    }];
    if job.time.at_unix_s.is_some() {
        return Err(EarthError::new(
            pointer,
            Problem::InvalidSpline(
                "a bare spline document has no times: evaluate the Feature of a fit made with parameterization time to evaluate at times".into(),
            ),
        ));
    }
    let evaluate = Job {
        operation: Operation::Evaluate,
        ..job.clone()
    };
    let outputs = run_curves(&jobs, &evaluate)?;
    let (geometry, info, stats, _) = assemble("LineString", outputs, &[], job)?;
    Ok(ProcessedFeature {
        feature: JsonOut::object([
            ("type", JsonOut::Value(json!("Feature"))),
            ("properties", JsonOut::object([("evaluation", info)])),
            ("geometry", geometry),
        ]),
        stats,
    })
}
