//! GeoJSON documents walked feature by feature.
//!
//! [`Document::parse`] splits a FeatureCollection, Feature, bare geometry or (for evaluation) a
//! bare lon/lat spline document into [`FeatureSlot`]s; [`process_feature`] (or
//! [`FeatureSlot::process`]) turns one into its output Feature, independently of the others,
//! so callers may run them in parallel or stream them; [`Document::into_feature_collection`]
//! puts the results back together in order, with the collection's foreign members.
//!
//! The files: `document` (a document split into slots), `curves` (a geometry's lines and rings
//! made), `times` (a feature's times), `checks` (what passes through, `bbox`), `run` (the curves
//! made in parallel), `tighten` (rings that cross refitted), `assemble` (the output feature) and
//! `evaluate` (stored fits read back).

use crate::earth::curve::line::LineRef;
use crate::earth::curve::positions::json_kind;
use crate::earth::curve::times::LineTimeInput;
use crate::earth::error::{EarthError, Problem};
use crate::earth::job::{Carry, Job, Operation};
use crate::earth::json_out::JsonOut;
use serde_json::{json, Value};
use std::collections::BTreeMap;

mod assemble;
mod checks;
mod curves;
mod document;
mod evaluate;
mod run;
#[cfg(test)]
mod tests;
mod tighten;
mod times;

use assemble::assemble;
pub(super) use checks::check_bbox;
use curves::curves_of_geometry;
pub(super) use curves::{array_at, no_area_on_the_sphere};
use document::count_curves;
pub use document::{parse_json, Document};
use evaluate::curves_of_fit;
pub use evaluate::evaluate_spline_document;

/// Geometry types that hold curves.
const CURVE_TYPES: [&str; 4] = ["LineString", "MultiLineString", "Polygon", "MultiPolygon"];
/// Geometry types that pass through unchanged.
const OTHER_TYPES: [&str; 3] = ["Point", "MultiPoint", "GeometryCollection"];

pub(in crate::earth) fn invalid(pointer: impl Into<String>, msg: impl Into<String>) -> EarthError {
    EarthError::new(pointer, Problem::InvalidGeoJson(msg.into()))
}

/// What one slot of a document holds.
#[derive(Clone, Debug, PartialEq)]
pub enum Source {
    /// A Feature (a bare geometry is wrapped in one), with the pointer of its geometry.
    Feature {
        /// The Feature.
        feature: Value,
        /// JSON pointer of its geometry in the input.
        geometry_pointer: String,
    },
    /// A bare lon/lat spline document (evaluation only).
    Spline(Value),
}

/// One unit of work: a feature (or spline document) and where it sits in the input.
#[derive(Clone, Debug, PartialEq)]
pub struct FeatureSlot {
    /// JSON pointer of the feature in the input (`/features/3`, or "" for a lone Feature).
    pub pointer: String,
    /// What the slot holds.
    pub source: Source,
}

/// Counters for one processed feature (all zero when it passed through unchanged).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FeatureStats {
    /// Curves fitted, interpolated or evaluated.
    pub curves: usize,
    /// Input positions of those curves (repeats included).
    pub input_points: usize,
    /// Dense output points.
    pub output_points: usize,
    /// Numbers stored in the curves (control point coordinates, knots, degrees).
    pub stored_numbers: usize,
    /// Largest error of any curve, metres.
    pub max_error_m: f64,
}

impl FeatureStats {
    /// Adds another feature's counters.
    pub fn merge(&mut self, o: &FeatureStats) {
        self.curves += o.curves;
        self.input_points += o.input_points;
        self.output_points += o.output_points;
        self.stored_numbers += o.stored_numbers;
        self.max_error_m = self.max_error_m.max(o.max_error_m);
    }
}

/// An output Feature and its counters.
#[derive(Clone, Debug, PartialEq)]
pub struct ProcessedFeature {
    /// The output Feature: serialise it as it is, or take it as a [`Value`] with
    /// [`JsonOut::into_value`].
    pub feature: JsonOut,
    /// What was done to it.
    pub stats: FeatureStats,
}

impl FeatureSlot {
    /// The curves processing this slot makes, counted without validating anything (for output
    /// limits checked before the work): lines and rings of its geometry, or with `evaluate`,
    /// the parts of its stored fit or interpolation.
    pub fn curve_count(&self, evaluate: bool) -> usize {
        let feature = match &self.source {
            Source::Spline(_) => return 1,
            Source::Feature { feature, .. } => feature,
        };
        if !evaluate {
            return feature.get("geometry").map_or(0, count_curves);
        }
        let props = feature.get("properties");
        ["fit", "interpolation"]
            .iter()
            .find_map(|k| props.and_then(|p| p.get(*k)))
            .map_or(0, |info| {
                info.get("parts")
                    .and_then(Value::as_array)
                    .map_or(1, Vec::len)
            })
    }

    /// Processes this slot with `job`.
    ///
    /// # Errors
    /// The first problem found, with a pointer into the input document.
    pub fn process(&self, job: &Job) -> Result<ProcessedFeature, EarthError> {
        match &self.source {
            Source::Feature {
                feature,
                geometry_pointer,
            } => process_feature_at(feature, &self.pointer, geometry_pointer, job),
            Source::Spline(doc) => evaluate_spline_document(doc, &self.pointer, job),
        }
    }
}

/// Processes one GeoJSON Feature found at `pointer` in its document (`/features/3`; "" for a
/// lone Feature or one record of a text sequence). Curve geometries are fitted, interpolated or
/// evaluated as `job` says; anything else comes back unchanged with zero stats.
///
/// # Errors
/// The first problem found, with a pointer into the input document.
pub fn process_feature(
    feature: &Value,
    pointer: &str,
    job: &Job,
) -> Result<ProcessedFeature, EarthError> {
    process_feature_at(feature, pointer, &format!("{pointer}/geometry"), job)
}

/// Processes a bare geometry found at `pointer`, returning a Feature (`properties` holds only
/// what the operation adds).
///
/// # Errors
/// As [`process_feature`].
pub fn process_geometry(
    geometry: &Value,
    pointer: &str,
    job: &Job,
) -> Result<ProcessedFeature, EarthError> {
    let feature = json!({"type": "Feature", "properties": null, "geometry": geometry});
    process_feature_at(&feature, pointer, pointer, job)
}

fn process_feature_at(
    feature: &Value,
    pointer: &str,
    geometry_pointer: &str,
    job: &Job,
) -> Result<ProcessedFeature, EarthError> {
    let map = feature.as_object().ok_or_else(|| {
        invalid(
            pointer,
            format!("expected a Feature object, got {}", json_kind(feature)),
        )
    })?;
    if map.get("type").and_then(Value::as_str) != Some("Feature") {
        return Err(invalid(
            format!("{pointer}/type"),
            "expected \"type\": \"Feature\"",
        ));
    }
    let geometry = map.get("geometry").ok_or_else(|| {
        invalid(
            pointer,
            "a Feature needs a \"geometry\" member (null for none)",
        )
    })?;
    match map.get("properties") {
        Some(Value::Null) | Some(Value::Object(_)) => {}
        None => {
            return Err(invalid(
                pointer,
                "a Feature needs a \"properties\" member (null for none)",
            ))
        }
        Some(other) => {
            return Err(invalid(
                format!("{pointer}/properties"),
                format!(
                    "\"properties\" must be an object or null, got {}",
                    json_kind(other)
                ),
            ))
        }
    }
    match map.get("id") {
        None | Some(Value::String(_)) | Some(Value::Number(_)) => {}
        Some(other) => {
            return Err(invalid(
                format!("{pointer}/id"),
                format!(
                    "a Feature id must be a string or a number, got {}",
                    json_kind(other)
                ),
            ))
        }
    }
    check_bbox(map, pointer)?;
    let result = match &job.operation {
        Operation::Fit(_) | Operation::FitToTolerance { .. } | Operation::Interpolate(_) => {
            curves_of_geometry(geometry, geometry_pointer, job, (map, pointer))?
        }
        Operation::Evaluate => curves_of_fit(map, pointer, job)?,
    };
    let Some((mut geometry_out, mut info, stats, time_props)) = result else {
        return Ok(ProcessedFeature {
            feature: JsonOut::Value(feature.clone()),
            stats: FeatureStats::default(),
        });
    };
    match job.carry {
        Carry::Both => {}
        Carry::Geometry => drop_splines(&mut info),
        Carry::Spline => geometry_out = JsonOut::Value(Value::Null),
    }
    // Every member but the input geometry (replaced, and not worth a deep copy), the bbox
    // and the properties (rebuilt below).
    let mut out: BTreeMap<String, JsonOut> = map
        .iter()
        .filter(|(k, _)| !matches!(k.as_str(), "geometry" | "bbox" | "properties"))
        .map(|(k, v)| (k.clone(), JsonOut::Value(v.clone())))
        .collect();
    out.insert("geometry".into(), geometry_out);
    let key = match job.operation {
        Operation::Fit(_) | Operation::FitToTolerance { .. } => "fit",
        Operation::Interpolate(_) => "interpolation",
        Operation::Evaluate => "evaluation",
    };
    if let Some(mine) = map.get("properties").and_then(|p| p.get(key)) {
        if !written_by_spherefit(mine) {
            return Err(invalid(
                format!("{pointer}/properties/{key}"),
                format!(
                    "the feature has its own property \"{key}\", where the {key} report goes: rename it (a \"{key}\" object spherefit wrote is replaced)"
                ),
            ));
        }
    }
    let mut props: BTreeMap<String, JsonOut> = match map.get("properties") {
        Some(Value::Object(p)) => p
            .iter()
            .map(|(k, v)| (k.clone(), JsonOut::Value(v.clone())))
            .collect(),
        _ => BTreeMap::new(),
    };
    props.insert(key.into(), info);
    for (k, v) in time_props {
        props.insert(k, JsonOut::Value(v));
    }
    out.insert("properties".into(), JsonOut::Object(props));
    Ok(ProcessedFeature {
        feature: JsonOut::Object(out),
        stats,
    })
}

/// The members of `properties.fit` a feature keeps when it carries only its geometry
/// (`carry=geometry`): the certified bound and whether it meets the tolerance. The rest of
/// the report (errors, counts, the parts with their splines) is what made a fitted file larger
/// than its input; the run's summary (`--stats`, the service's headers) still counts it.
pub const GEOMETRY_ONLY_FIT_MEMBERS: [&str; 3] =
    ["tolerance_met", "two_way_distance_m", "max_error_m"];

/// `properties.fit` for `carry=geometry`: only [`GEOMETRY_ONLY_FIT_MEMBERS`] (for a fit
/// without a tolerance, `two_way_distance_m` is left out by the report itself).
///
/// What such a feature carries is its geometry, not the curve: its `two_way_distance_m`
/// becomes the curve's plus the geometry's `sampling_deviation_m` (the samples' deviation from
/// the curve and their rounding), a bound of the geometry as written, and `tolerance_met` says
/// whether that is within the tolerance. (A smooth curve's samples at 3 decimals were written
/// up to 47 m farther from the line than the curve's reported distance: the 10m land ring 3441
/// at 880 m, 762.80 m measured against 715.46 m reported.)
fn drop_splines(info: &mut JsonOut) {
    if let JsonOut::Object(m) = info {
        let number = |m: &BTreeMap<String, JsonOut>, k: &str| match m.get(k) {
            Some(JsonOut::Value(v)) => v.as_f64(),
            _ => None,
        };
        if let (Some(tw), Some(dev)) = (
            number(m, "two_way_distance_m"),
            number(m, "sampling_deviation_m"),
        ) {
            let written = super::curve::output::round_up_m(tw + dev);
            m.insert("two_way_distance_m".into(), JsonOut::Value(json!(written)));
            if number(m, "tolerance_m").is_some_and(|t| written > t) {
                m.insert("tolerance_met".into(), JsonOut::Value(json!(false)));
            }
        }
        m.retain(|k, _| GEOMETRY_ONLY_FIT_MEMBERS.contains(&k.as_str()));
    }
}

/// `drop_splines` for a report held as a [`Value`] (a coverage's features).
pub fn keep_geometry_only_members(fit: &mut Value) {
    if let Value::Object(m) = fit {
        m.retain(|k, _| GEOMETRY_ONLY_FIT_MEMBERS.contains(&k.as_str()));
    }
}

/// Whether a `properties.fit` (or `interpolation`, `evaluation`) value is a report spherefit
/// wrote, which a new run replaces (so a fitted output can be fitted again); any other value is
/// the user's.
fn written_by_spherefit(v: &Value) -> bool {
    v.as_object().is_some_and(|m| {
        m.contains_key("output_points")
            && (m.contains_key("max_error_m") || m.contains_key("sampling_deviation_m"))
    })
}

/// A curve to make: its coordinates (or document), pointer, path and whether it is a ring.
struct CurveJob<'a> {
    value: &'a Value,
    pointer: String,
    path: Vec<usize>,
    closed: bool,
    known_error_m: Option<f64>,
    /// For a fit in time: where this line's times are.
    times: Option<LineTimeInput<'a>>,
    /// For evaluation: the stored `time` beside the spline, and its pointer.
    time_doc: Option<(&'a Value, String)>,
}

impl CurveJob<'_> {
    /// The line (or stored curve) and where it sits.
    fn line(&self) -> LineRef<'_> {
        LineRef {
            value: self.value,
            pointer: &self.pointer,
            path: &self.path,
            closed: self.closed,
        }
    }
}

/// Output geometry, `properties.fit` (or ...), counters, and properties to set (the times of
/// the dense output, under the name they came in).
type Made = Option<Assembled>;

/// What [`assemble`] makes (see [`Made`]).
type Assembled = (JsonOut, JsonOut, FeatureStats, Vec<(String, Value)>);
