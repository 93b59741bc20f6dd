//! GeoJSON documents walked feature by feature.
//!
//! [`Document::parse`] splits a FeatureCollection, Feature, bare geometry or (for evaluation) a
//! bare lon/lat spline document into [`FeatureSlot`]s; [`process_feature`] (or
//! [`FeatureSlot::process`]) turns one into its output Feature, independently of the others,
//! so callers may run them in parallel or stream them; [`Document::into_feature_collection`]
//! puts the results back together in order, with the collection's foreign members.

use super::antimeridian::rejoin::rejoin_cut_polygons;
use super::antimeridian::{cut_line, split_polygon_around};
use super::area;
use super::curve::{
    compression_ratio, evaluate_curve, fit_line, fit_line_to_tolerance, interpolate_line,
    json_kind, output_position, output_positions,
};
use super::curve::{curve_in_time, CurveOutput, CurveReport, LineTimeInput};
use super::lonlat::lonlat_to_unit;
use super::small_rings;
use super::time::{motion, TimeOrigin, TIME_PROPERTIES};
use super::{EarthError, Job, JsonOut, Operation, Problem};
use crate::sphere::geometry::crossing::polylines_cross;
use rayon::prelude::*;
use serde_json::{json, Map, Value};
use std::collections::BTreeMap;

/// Geometry types that hold curves.
const CURVE_TYPES: [&str; 4] = ["LineString", "MultiLineString", "Polygon", "MultiPolygon"];
/// Geometry types that pass through unchanged.
const OTHER_TYPES: [&str; 3] = ["Point", "MultiPoint", "GeometryCollection"];

fn invalid(pointer: impl Into<String>, msg: impl Into<String>) -> EarthError {
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

/// A parsed input document, split into independent slots.
#[derive(Clone, Debug, PartialEq)]
pub struct Document {
    /// Foreign members of a FeatureCollection (everything but `type`, `features`).
    pub members: Map<String, Value>,
    /// The features in input order.
    pub slots: Vec<FeatureSlot>,
}

impl Document {
    /// Splits `value` (a FeatureCollection, Feature or geometry; with `allow_spline`, also a
    /// bare spline document with `"crs": "lonlat"`) into slots. Only the outer structure is
    /// checked here; each slot is checked when processed.
    ///
    /// # Errors
    /// [`Problem::InvalidGeoJson`] for anything else.
    pub fn parse(value: Value, allow_spline: bool) -> Result<Document, EarthError> {
        let Value::Object(mut map) = value else {
            return Err(invalid(
                "",
                format!(
                    "expected a GeoJSON object (FeatureCollection, Feature or geometry), got {}",
                    json_kind(&value)
                ),
            ));
        };
        let is_spline_doc = allow_spline
            && (map.contains_key("control_points") || map.contains_key("segments"))
            && matches!(
                map.get("type").map(|t| t.as_str()),
                None | Some(Some("bspline")) | Some(Some("beta"))
            );
        if is_spline_doc {
            if map.get("crs").and_then(Value::as_str) != Some("lonlat") {
                return Err(invalid(
                    "/crs",
                    "a bare spline document needs \"crs\": \"lonlat\" (a document of unit vectors is an S^n document: evaluate it on S^n)",
                ));
            }
            return Ok(Document {
                members: Map::new(),
                slots: vec![FeatureSlot {
                    pointer: String::new(),
                    source: Source::Spline(Value::Object(map)),
                }],
            });
        }
        let kind = match map.get("type") {
            Some(Value::String(s)) => s.clone(),
            Some(other) => {
                return Err(invalid(
                    "/type",
                    format!("\"type\" must be a string, got {}", json_kind(other)),
                ))
            }
            None => {
                return Err(invalid(
                    "",
                    "missing \"type\": expected a FeatureCollection, Feature or geometry",
                ))
            }
        };
        check_bbox(&map, "")?;
        match kind.as_str() {
            "FeatureCollection" => {
                let features = match map.remove("features") {
                    Some(Value::Array(a)) => a,
                    Some(other) => {
                        return Err(invalid(
                            "/features",
                            format!("\"features\" must be an array, got {}", json_kind(&other)),
                        ))
                    }
                    None => return Err(invalid("", "a FeatureCollection needs \"features\"")),
                };
                map.remove("type");
                let slots = features
                    .into_iter()
                    .enumerate()
                    .map(|(i, f)| FeatureSlot {
                        pointer: format!("/features/{i}"),
                        source: Source::Feature {
                            feature: f,
                            geometry_pointer: format!("/features/{i}/geometry"),
                        },
                    })
                    .collect();
                Ok(Document {
                    members: map,
                    slots,
                })
            }
            "Feature" => Ok(Document {
                members: Map::new(),
                slots: vec![FeatureSlot {
                    pointer: String::new(),
                    source: Source::Feature {
                        feature: Value::Object(map),
                        geometry_pointer: "/geometry".into(),
                    },
                }],
            }),
            t if CURVE_TYPES.contains(&t) || OTHER_TYPES.contains(&t) => Ok(Document {
                members: Map::new(),
                slots: vec![FeatureSlot {
                    pointer: String::new(),
                    source: Source::Feature {
                        feature: json!({"type": "Feature", "properties": null, "geometry": Value::Object(map)}),
                        geometry_pointer: String::new(),
                    },
                }],
            }),
            t => Err(invalid(
                "/type",
                format!("unknown GeoJSON type {t:?}: expected FeatureCollection, Feature or a geometry type"),
            )),
        }
    }

    /// Input positions in the curve geometries of all slots (what a fit or interpolation will
    /// process), counted without validating them; for limits. The second value is the index
    /// of the first slot at which the running count exceeds `limit`, if any.
    pub fn curve_positions(&self, limit: usize) -> (usize, Option<usize>) {
        let mut total = 0usize;
        let mut first_over = None;
        for (i, slot) in self.slots.iter().enumerate() {
            if let Source::Feature { feature, .. } = &slot.source {
                if let Some(g) = feature.get("geometry") {
                    total += count_positions(g);
                }
            }
            if total > limit && first_over.is_none() {
                first_over = Some(i);
            }
        }
        (total, first_over)
    }

    /// The output FeatureCollection: `features` in input order and the input collection's
    /// foreign members (its `bbox` is dropped when any feature changed).
    pub fn into_feature_collection(self, features: Vec<JsonOut>, changed: bool) -> JsonOut {
        let mut out = BTreeMap::new();
        for (k, v) in self.members {
            if k == "bbox" && changed {
                continue;
            }
            out.insert(k, JsonOut::Value(v));
        }
        out.insert("type".into(), JsonOut::Value(json!("FeatureCollection")));
        out.insert("features".into(), JsonOut::Array(features));
        JsonOut::Object(out)
    }
}

/// Lines and rings in a curve geometry, counted without validating it.
fn count_curves(geometry: &Value) -> usize {
    let kind = geometry.get("type").and_then(Value::as_str).unwrap_or("");
    let c = geometry.get("coordinates").and_then(Value::as_array);
    match (kind, c) {
        ("LineString", Some(_)) => 1,
        ("MultiLineString" | "Polygon", Some(a)) => a.len(),
        ("MultiPolygon", Some(a)) => a.iter().map(|p| p.as_array().map_or(0, Vec::len)).sum(),
        _ => 0,
    }
}

fn count_positions(geometry: &Value) -> usize {
    let kind = geometry.get("type").and_then(Value::as_str).unwrap_or("");
    let depth = match kind {
        "LineString" => 1,
        "MultiLineString" | "Polygon" => 2,
        "MultiPolygon" => 3,
        _ => return 0,
    };
    fn count(v: &Value, depth: usize) -> usize {
        match v.as_array() {
            None => 0,
            Some(a) if depth == 1 => a.len(),
            Some(a) => a.iter().map(|x| count(x, depth - 1)).sum(),
        }
    }
    geometry.get("coordinates").map_or(0, |c| count(c, depth))
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
    let Some((geometry_out, info, stats, time_props)) = result else {
        return Ok(ProcessedFeature {
            feature: JsonOut::Value(feature.clone()),
            stats: FeatureStats::default(),
        });
    };
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

/// Output geometry, `properties.fit` (or ...), counters, and properties to set (the times of
/// the dense output, under the name they came in).
type Made = Option<Assembled>;

/// What [`assemble`] makes (see [`Made`]).
type Assembled = (JsonOut, JsonOut, FeatureStats, Vec<(String, Value)>);

/// Where a feature's times are, for a fit in time.
#[derive(Clone, Debug)]
enum FeatureTimes<'a> {
    /// Not a fit in time.
    None,
    /// `properties[name]`, at `pointer`.
    Property {
        value: &'a Value,
        pointer: String,
        name: String,
    },
    /// The 4th coordinate.
    M,
}

/// Escapes a key for a JSON pointer (RFC 6901: `~` as `~0`, `/` as `~1`).
fn pointer_key(k: &str) -> String {
    k.replace('~', "~0").replace('/', "~1")
}

/// Finds a feature's times for a fit in time ([`super::time`]).
fn feature_times<'a>(
    feature: &'a Map<String, Value>,
    pointer: &str,
    job: &Job,
) -> Result<FeatureTimes<'a>, EarthError> {
    let Some(source) = &job.time.fit_in_time else {
        return Ok(FeatureTimes::None);
    };
    let props = feature.get("properties").and_then(Value::as_object);
    let found = |name: &str| {
        props
            .and_then(|p| p.get(name))
            .map(|value| FeatureTimes::Property {
                value,
                pointer: format!("{pointer}/properties/{}", pointer_key(name)),
                name: name.to_string(),
            })
    };
    match source {
        super::TimeSource::Property(name) => found(name).ok_or_else(|| {
            EarthError::new(
                format!("{pointer}/properties"),
                Problem::InvalidTime(format!(
                    "no property {name:?} (time_property) holding this feature's times"
                )),
            )
        }),
        super::TimeSource::Auto => Ok(TIME_PROPERTIES
            .iter()
            .find_map(|n| found(n))
            .unwrap_or(FeatureTimes::M)),
    }
}

/// The times of line `part` (`None` for a LineString) of a feature in time.
fn line_times<'a>(
    times: &FeatureTimes<'a>,
    part: Option<usize>,
) -> Result<Option<LineTimeInput<'a>>, EarthError> {
    match (times, part) {
        (FeatureTimes::None, _) => Ok(None),
        (FeatureTimes::M, _) => Ok(Some(LineTimeInput::M)),
        (
            FeatureTimes::Property {
                value,
                pointer,
                name,
            },
            None,
        ) => Ok(Some(LineTimeInput::Property {
            value,
            pointer: pointer.clone(),
            name: name.clone(),
        })),
        (
            FeatureTimes::Property {
                value,
                pointer,
                name,
            },
            Some(i),
        ) => {
            let v = value.as_array().and_then(|a| a.get(i)).ok_or_else(|| {
                EarthError::new(
                    pointer.clone(),
                    Problem::InvalidTime(format!(
                        "a MultiLineString's times are one array per line ([[t, ...], [t, ...]]): line {i} has none"
                    )),
                )
            })?;
            Ok(Some(LineTimeInput::Property {
                value: v,
                pointer: format!("{pointer}/{i}"),
                name: name.clone(),
            }))
        }
    }
}

fn array_at<'a>(v: &'a Value, pointer: &str, what: &str) -> Result<&'a Vec<Value>, EarthError> {
    v.as_array().ok_or_else(|| {
        invalid(
            pointer,
            format!("expected an array of {what}, got {}", json_kind(v)),
        )
    })
}

/// Fits or interpolates the curves of a geometry; `None` for geometries that pass through.
fn curves_of_geometry(
    geometry: &Value,
    ptr: &str,
    job: &Job,
    (feature, feature_pointer): (&Map<String, Value>, &str),
) -> Result<Made, EarthError> {
    if geometry.is_null() {
        return Ok(None);
    }
    let gmap = geometry.as_object().ok_or_else(|| {
        invalid(
            ptr,
            format!(
                "a geometry must be an object or null, got {}",
                json_kind(geometry)
            ),
        )
    })?;
    let kind = match gmap.get("type") {
        Some(Value::String(s)) => s.as_str(),
        _ => {
            return Err(invalid(
                format!("{ptr}/type"),
                "a geometry needs a string \"type\"",
            ))
        }
    };
    check_bbox(gmap, ptr)?;
    if OTHER_TYPES.contains(&kind) {
        check_other_geometry(gmap, kind, ptr, 0)?;
        return Ok(None);
    }
    if !CURVE_TYPES.contains(&kind) {
        return Err(invalid(
            format!("{ptr}/type"),
            format!("unknown geometry type {kind:?}"),
        ));
    }
    let cptr = format!("{ptr}/coordinates");
    let coords = gmap
        .get("coordinates")
        .ok_or_else(|| invalid(ptr, format!("a {kind} needs \"coordinates\"")))?;
    // Only a feature with lines needs times: others pass through whatever their properties.
    let times = &feature_times(feature, feature_pointer, job)?;
    if !matches!(times, FeatureTimes::None) && kind.ends_with("Polygon") {
        return Err(EarthError::new(
            format!("{ptr}/type"),
            Problem::InvalidTime(format!(
                "a fit in time (parameterization time) is for tracks (LineString, MultiLineString); a {kind}'s rings have no time order"
            )),
        ));
    }
    let mut jobs = Vec::new();
    let mk = |value, pointer, path, closed, times| CurveJob {
        value,
        pointer,
        path,
        closed,
        known_error_m: None,
        times,
        time_doc: None,
    };
    match kind {
        "LineString" => jobs.push(mk(
            coords,
            cptr.clone(),
            vec![],
            false,
            line_times(times, None)?,
        )),
        "MultiLineString" | "Polygon" => {
            let closed = kind == "Polygon";
            let what = if closed { "rings" } else { "lines" };
            for (i, part) in array_at(coords, &cptr, what)?.iter().enumerate() {
                jobs.push(mk(
                    part,
                    format!("{cptr}/{i}"),
                    vec![i],
                    closed,
                    line_times(times, Some(i))?,
                ));
            }
        }
        _ => {
            for (i, poly) in array_at(coords, &cptr, "polygons")?.iter().enumerate() {
                let pptr = format!("{cptr}/{i}");
                for (r, ring) in array_at(poly, &pptr, "rings")?.iter().enumerate() {
                    jobs.push(mk(ring, format!("{pptr}/{r}"), vec![i, r], true, None));
                }
            }
        }
    }
    // Polygons cut at ±180 (parts on either side, polar caps closed along the meridian and
    // the pole) are fitted as the rings on the sphere they are.
    let rejoined = match kind {
        "Polygon" => rejoin_cut_polygons(&[(cptr.clone(), coords)]),
        "MultiPolygon" => coords.as_array().and_then(|polys| {
            let polys: Vec<(String, &Value)> = polys
                .iter()
                .enumerate()
                .map(|(i, p)| (format!("{cptr}/{i}"), p))
                .collect();
            rejoin_cut_polygons(&polys)
        }),
        _ => None,
    };
    let rejoined = rejoined.transpose().map_err(no_area_on_the_sphere)?;
    let kind = match &rejoined {
        Some(polys) if kind == "Polygon" && polys.len() == 1 => "Polygon",
        Some(_) => "MultiPolygon",
        None => kind,
    };
    if let Some(polys) = &rejoined {
        jobs.clear();
        for (i, poly) in polys.iter().enumerate() {
            for (r, (pointer, ring)) in poly.rings.iter().enumerate() {
                let path = if kind == "Polygon" {
                    vec![r]
                } else {
                    vec![i, r]
                };
                jobs.push(mk(ring, pointer.clone(), path, true, None));
            }
        }
    }
    if jobs.is_empty() {
        return Ok(None);
    }
    let mut outputs = run_curves(&jobs, job)?;
    if kind.ends_with("Polygon") {
        tighten_crossing_rings(&jobs, &mut outputs, job)?;
    }
    // Spherical area before and after, as shared fitting reports it: the input rings as read
    // (rejoined where they came cut) against the fitted rings before they are cut at ±180.
    let areas = kind.ends_with("Polygon").then(|| {
        let by_polygon = |path: &[usize]| if kind == "Polygon" { 0 } else { path[0] };
        let mut before: Vec<(usize, Vec<Vec<[f64; 3]>>)> = Vec::new();
        for j in &jobs {
            let key = by_polygon(&j.path);
            match before.last_mut() {
                Some((k, rings)) if *k == key => rings.push(ring_units(j.value)),
                _ => before.push((key, vec![ring_units(j.value)])),
            }
        }
        let mut after: Vec<(usize, Vec<&[[f64; 3]]>)> = Vec::new();
        for c in &outputs {
            let key = by_polygon(&c.report.path);
            match after.last_mut() {
                Some((k, rings)) if *k == key => rings.push(&c.points),
                _ => after.push((key, vec![&c.points[..]])),
            }
        }
        let sum_before: f64 = before.iter().map(|(_, r)| area::polygon_area_m2(r)).sum();
        let sum_after: f64 = after.iter().map(|(_, r)| area::polygon_area_m2(r)).sum();
        (sum_after, area::area_change(sum_before, sum_after))
    });
    // The pole each rejoined polygon was closed along in the input, kept in the output.
    let poles: Vec<Option<f64>> = rejoined.iter().flatten().map(|p| p.pole).collect();
    let (mut geometry_out, mut info, stats, extra) = assemble(kind, outputs, &poles, job)?;
    if let (Some((area_m2, change)), JsonOut::Object(m)) = (areas, &mut info) {
        m.insert(
            "area_m2".into(),
            JsonOut::Value(json!(super::lonlat::round_to(area_m2, 0))),
        );
        m.insert(
            "area_change".into(),
            JsonOut::Value(json!(super::lonlat::round_to(change, 9))),
        );
    }
    // Foreign members of the geometry object come back with it (RFC 7946 §6.1).
    if let JsonOut::Object(m) = &mut geometry_out {
        for (k, v) in gmap {
            if !matches!(k.as_str(), "type" | "coordinates" | "bbox") {
                m.insert(k.clone(), JsonOut::Value(v.clone()));
            }
        }
    }
    Ok(Some((geometry_out, info, stats, extra)))
}

/// The error for a ring that [`rejoin_cut_polygons`] found to bound no area on the sphere.
pub(super) fn no_area_on_the_sphere(pointer: String) -> EarthError {
    EarthError::new(
        pointer,
        Problem::InvalidRing(
            "on the sphere this ring has fewer than 3 distinct positions and bounds no area: \
             its edges along -180 and 180 (one meridian) and the poles meet themselves. A \
             latitude band or the whole world drawn in the lon/lat plane needs vertices along \
             its parallels"
                .into(),
        ),
    )
}

/// Checks a `bbox` member, if any: an array of 2n numbers, n >= 2 (RFC 7946 §5).
fn check_bbox(map: &Map<String, Value>, ptr: &str) -> Result<(), EarthError> {
    let Some(b) = map.get("bbox") else {
        return Ok(());
    };
    let ok = b
        .as_array()
        .is_some_and(|a| (a.len() == 4 || a.len() == 6) && a.iter().all(Value::is_number));
    if ok {
        Ok(())
    } else {
        Err(invalid(
            format!("{ptr}/bbox"),
            "a bbox is an array of 4 or 6 numbers",
        ))
    }
}

/// Nesting limit for GeometryCollections (RFC 7946 discourages nesting them at all).
const MAX_COLLECTION_DEPTH: usize = 32;

/// Checks a geometry that passes through unchanged (Point, MultiPoint, GeometryCollection):
/// the same position rules as for lines, so what comes out is valid GeoJSON.
fn check_other_geometry(
    gmap: &Map<String, Value>,
    kind: &str,
    ptr: &str,
    depth: usize,
) -> Result<(), EarthError> {
    if kind == "GeometryCollection" {
        if depth >= MAX_COLLECTION_DEPTH {
            return Err(invalid(ptr, "GeometryCollections nested too deeply"));
        }
        let gptr = format!("{ptr}/geometries");
        let geoms = gmap
            .get("geometries")
            .ok_or_else(|| invalid(ptr, "a GeometryCollection needs \"geometries\""))?;
        for (i, g) in array_at(geoms, &gptr, "geometries")?.iter().enumerate() {
            let iptr = format!("{gptr}/{i}");
            let m = g.as_object().ok_or_else(|| {
                invalid(
                    &iptr,
                    format!("a geometry must be an object, got {}", json_kind(g)),
                )
            })?;
            let k = m.get("type").and_then(Value::as_str).unwrap_or("");
            check_bbox(m, &iptr)?;
            if OTHER_TYPES.contains(&k) {
                check_other_geometry(m, k, &iptr, depth + 1)?;
            } else if CURVE_TYPES.contains(&k) {
                let depth_of = match k {
                    "LineString" => 1,
                    "MultiLineString" | "Polygon" => 2,
                    _ => 3,
                };
                let c = m
                    .get("coordinates")
                    .ok_or_else(|| invalid(&iptr, format!("a {k} needs \"coordinates\"")))?;
                let rings = k.ends_with("Polygon");
                check_nested_positions(c, &format!("{iptr}/coordinates"), depth_of, rings)?;
            } else {
                return Err(invalid(
                    format!("{iptr}/type"),
                    format!("unknown geometry type {k:?}"),
                ));
            }
        }
        return Ok(());
    }
    let c = gmap
        .get("coordinates")
        .ok_or_else(|| invalid(ptr, format!("a {kind} needs \"coordinates\"")))?;
    let cptr = format!("{ptr}/coordinates");
    if kind == "Point" {
        check_position(c, &cptr)
    } else {
        for (i, p) in array_at(c, &cptr, "positions")?.iter().enumerate() {
            check_position(p, &format!("{cptr}/{i}"))?;
        }
        Ok(())
    }
}

/// Checks one position of a geometry that passes through: an array of at least two numbers,
/// longitude and latitude in range. Its other numbers (altitude, measures) are the user's and
/// come back as they are, whatever the other positions have.
fn check_position(p: &Value, ptr: &str) -> Result<(), EarthError> {
    let nums = p.as_array().ok_or_else(|| {
        EarthError::new(
            ptr,
            Problem::InvalidCoordinate(format!(
                "a position is an array [longitude, latitude, ...], got {}",
                json_kind(p)
            )),
        )
    })?;
    if nums.len() < 2 {
        return Err(EarthError::new(
            ptr,
            Problem::InvalidCoordinate(format!(
                "a position has at least 2 numbers ([longitude, latitude, ...]), this one has {}",
                nums.len()
            )),
        ));
    }
    for (k, x) in nums.iter().enumerate().skip(2) {
        if !x.is_number() {
            return Err(EarthError::new(
                format!("{ptr}/{k}"),
                Problem::InvalidCoordinate(format!("expected a number, got {}", json_kind(x))),
            ));
        }
    }
    super::curve::parse_positions(&Value::Array(vec![Value::Array(nums[..2].to_vec())]), "")
        .map_err(|e| EarthError::new(format!("{ptr}{}", &e.pointer[2..]), e.problem))?;
    Ok(())
}

/// Checks arrays of positions nested `depth` deep (1: a line's positions, or a ring's when
/// `rings`): every position, at least 2 positions in a line, and rings closed with at least 4
/// (RFC 7946 §3.1.4, §3.1.6), as for the lines and rings that are fitted.
fn check_nested_positions(
    v: &Value,
    ptr: &str,
    depth: usize,
    rings: bool,
) -> Result<(), EarthError> {
    if depth == 1 {
        let positions = array_at(v, ptr, "positions")?;
        for (i, p) in positions.iter().enumerate() {
            check_position(p, &format!("{ptr}/{i}"))?;
        }
        let n = positions.len();
        let lonlat = |p: &Value| [p[0].as_f64(), p[1].as_f64()];
        if rings && n < 4 {
            return Err(EarthError::new(
                ptr,
                Problem::InvalidRing(format!(
                    "a Polygon ring needs at least 4 positions (the last repeating the first), got {n}"
                )),
            ));
        }
        if rings && lonlat(&positions[0]) != lonlat(&positions[n - 1]) {
            return Err(EarthError::new(
                format!("{ptr}/{}", n - 1),
                Problem::InvalidRing(
                    "a Polygon ring must end where it starts: the last position differs from the first"
                        .into(),
                ),
            ));
        }
        if !rings && n < 2 {
            return Err(EarthError::new(
                ptr,
                Problem::TooFewPoints {
                    distinct: n,
                    need: 2,
                },
            ));
        }
        return Ok(());
    }
    for (i, x) in array_at(v, ptr, "arrays of positions")?.iter().enumerate() {
        check_nested_positions(x, &format!("{ptr}/{i}"), depth - 1, rings)?;
    }
    Ok(())
}

/// Reads the curves stored in `properties.fit` (or `properties.interpolation`) for evaluation;
/// `None` when the feature has none.
fn curves_of_fit<'a>(
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
    if let Some(doc) = info.get(doc_key) {
        let jobs = vec![CurveJob {
            value: doc,
            pointer: format!("{iptr}/{doc_key}"),
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
    let mut jobs = Vec::new();
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
        jobs.push(CurveJob {
            value: doc,
            pointer: format!("{pptr}/{doc_key}"),
            path,
            closed: kind.ends_with("Polygon"),
            known_error_m: known(part),
            times: None,
            time_doc: time_of(part, &pptr),
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

/// Runs the curves of one geometry in parallel; the first error in order wins.
fn run_curves(jobs: &[CurveJob<'_>], job: &Job) -> Result<Vec<CurveOutput>, EarthError> {
    let one = |c: &CurveJob<'_>| {
        if matches!(job.operation, Operation::Evaluate) {
            check_stored_size(c, &job.limits)?;
        }
        // The job's token, entered on whichever (rayon) thread runs this curve: the fitters
        // inside see it even where their options inherit.
        let _scope = job.cancel.enter();
        job.cancel
            .check()
            .map_err(|e| EarthError::new(c.pointer.clone(), Problem::Fit(e)))?;
        let made = one_curve(c, job);
        if !c.closed || matches!(job.operation, Operation::Evaluate) {
            return made;
        }
        // A ring too small to fit, or one whose fit collapsed, is kept (small_rings): a
        // feature is never refused for one of its rings being small.
        let tolerance_m = match &job.operation {
            Operation::FitToTolerance { tolerance_m, .. } => Some(*tolerance_m),
            _ => None,
        };
        match made {
            Err(e) if matches!(e.problem, Problem::TooFewPoints { .. }) => {
                small_rings::keep(c.value, &c.pointer, c.path.clone(), tolerance_m).map(|k| k.0)
            }
            Ok(out) if small_rings::collapsed(&out, job.output.precision) => {
                small_rings::keep(c.value, &c.pointer, c.path.clone(), tolerance_m).map(|k| k.0)
            }
            other => other,
        }
    };
    if jobs.len() == 1 {
        return Ok(vec![one(&jobs[0])?]);
    }
    jobs.par_iter()
        .map(one)
        .collect::<Vec<_>>()
        .into_iter()
        .collect()
}

/// How many times a ring whose fit crosses itself or another ring of its polygon is refitted at
/// half its tolerance (as the shared fit does with its arcs).
const TIGHTEN_ROUNDS: usize = 3;

/// Validity: the fitted rings of one polygon (exterior and holes) must not cross themselves or
/// each other where the input's rings did not. At a loose tolerance a fitted ring can cut across
/// a narrow inlet or touch its hole (Antarctica's peninsula at 10 km does); each ring of such a
/// pair is refitted at half its tolerance, up to [`TIGHTEN_ROUNDS`] times, and its report gives
/// the tolerance it was fitted to. Only tolerance fits tighten: a fit to a fixed number of
/// control points, or an interpolation, is what was asked for.
fn tighten_crossing_rings(
    jobs: &[CurveJob<'_>],
    outputs: &mut [CurveOutput],
    job: &Job,
) -> Result<(), EarthError> {
    let Operation::FitToTolerance {
        options,
        tolerance_m,
    } = &job.operation
    else {
        return Ok(());
    };
    // Rings by polygon: the path without its last index.
    let mut polygons: BTreeMap<&[usize], Vec<usize>> = BTreeMap::new();
    for (i, c) in jobs.iter().enumerate() {
        if c.closed && !c.path.is_empty() {
            polygons
                .entry(&c.path[..c.path.len() - 1])
                .or_default()
                .push(i);
        }
    }
    let pairs: Vec<(usize, usize)> = polygons
        .values()
        .flat_map(|rings| {
            rings
                .iter()
                .enumerate()
                .flat_map(move |(k, &a)| rings[k..].iter().map(move |&b| (a, b)))
        })
        .collect();
    let cross = |p: &[[f64; 3]], q: &[[f64; 3]], same| polylines_cross(p, q, same);
    let input: Vec<Vec<[f64; 3]>> = jobs.iter().map(|c| ring_units(c.value)).collect();
    let input_crossing: Vec<bool> = pairs
        .par_iter()
        .map(|&(a, b)| cross(&input[a], &input[b], a == b))
        .collect();
    let mut tolerance = vec![*tolerance_m; jobs.len()];
    for _ in 0..TIGHTEN_ROUNDS {
        let crossing: Vec<(usize, usize)> = pairs
            .par_iter()
            .zip(&input_crossing)
            .filter(|&(&(a, b), &was)| {
                !was && cross(&outputs[a].points, &outputs[b].points, a == b)
            })
            .map(|(&p, _)| p)
            .collect();
        if crossing.is_empty() {
            break;
        }
        let mut redo: Vec<usize> = crossing.iter().flat_map(|&(a, b)| [a, b]).collect();
        redo.sort_unstable();
        redo.dedup();
        let refits: Vec<(usize, CurveOutput)> = redo
            .par_iter()
            .map(|&i| {
                let _scope = job.cancel.enter();
                let c = &jobs[i];
                let t = 0.5 * tolerance[i];
                fit_line_to_tolerance(
                    c.value,
                    &c.pointer,
                    c.path.clone(),
                    c.closed,
                    options,
                    t,
                    &job.output,
                    &job.limits,
                    c.times.as_ref(),
                )
                .map(|out| (i, out))
            })
            .collect::<Result<_, _>>()?;
        for (i, out) in refits {
            tolerance[i] *= 0.5;
            // A refit that collapsed (or shrank below a triangle) keeps the earlier fit.
            if !small_rings::collapsed(&out, job.output.precision) {
                outputs[i] = out;
            }
        }
    }
    Ok(())
}

/// A ring's positions as unit vectors (positions that are not two numbers are skipped: they
/// were refused before any fit ran).
fn ring_units(ring: &Value) -> Vec<[f64; 3]> {
    ring.as_array()
        .map(|ps| {
            ps.iter()
                .filter_map(|p| Some(lonlat_to_unit(p.get(0)?.as_f64()?, p.get(1)?.as_f64()?)))
                .collect()
        })
        .unwrap_or_default()
}

/// A stored curve with more control points (or segments) than the limit is refused before it is
/// read.
fn check_stored_size(c: &CurveJob<'_>, limits: &super::Limits) -> Result<(), EarthError> {
    for key in ["control_points", "segments"] {
        if let Some(n) = c.value.get(key).and_then(Value::as_array).map(Vec::len) {
            if n > limits.max_control_points {
                return Err(EarthError::new(
                    format!("{}/{key}", c.pointer),
                    Problem::InvalidSpline(format!(
                        "{n} {}, more than the limit of {} per curve",
                        key.replace('_', " "),
                        limits.max_control_points
                    )),
                ));
            }
        }
    }
    Ok(())
}

/// One curve of [`run_curves`].
fn one_curve(c: &CurveJob<'_>, job: &Job) -> Result<CurveOutput, EarthError> {
    match &job.operation {
        Operation::Fit(o) => fit_line(
            c.value,
            &c.pointer,
            c.path.clone(),
            c.closed,
            o,
            &job.output,
            &job.limits,
            c.times.as_ref(),
        ),
        Operation::FitToTolerance {
            options,
            tolerance_m,
        } => fit_line_to_tolerance(
            c.value,
            &c.pointer,
            c.path.clone(),
            c.closed,
            options,
            *tolerance_m,
            &job.output,
            &job.limits,
            c.times.as_ref(),
        ),
        Operation::Interpolate(s) => interpolate_line(
            c.value,
            &c.pointer,
            c.path.clone(),
            c.closed,
            s,
            &job.output,
            &job.limits,
        ),
        Operation::Evaluate => evaluate_curve(
            c.value,
            &c.pointer,
            c.path.clone(),
            c.closed,
            c.known_error_m,
            &job.output,
            &job.limits,
            c.time_doc.as_ref().map(|(v, p)| (*v, p.as_str())),
        ),
    }
}

/// A geometry object of `kind` with these coordinates.
fn geometry(kind: &str, coordinates: JsonOut) -> JsonOut {
    JsonOut::object([
        ("type", JsonOut::Value(Value::from(kind))),
        ("coordinates", coordinates),
    ])
}

/// Builds the output geometry, the properties object and the stats from fitted curves.
/// `poles[i]`: the pole polygon `i` is closed along if it goes round one (cut-form input,
/// [`super::antimeridian::rejoin::RejoinedPolygon::pole`]); empty when none is known.
fn assemble(
    kind: &str,
    mut outputs: Vec<CurveOutput>,
    poles: &[Option<f64>],
    job: &Job,
) -> Result<Assembled, EarthError> {
    let precision = job.output.precision;
    // drop_small_rings: the rings kept as small are dropped (small_rings::drop_kept); they
    // still count as curves read.
    let (dropped, dropped_curves, dropped_input) =
        if job.drop_small_rings && kind.ends_with("Polygon") {
            let input: usize = outputs.iter().map(|c| c.report.input_points).sum();
            let n = outputs.len();
            let dropped = small_rings::drop_kept(&mut outputs);
            let left: usize = outputs.iter().map(|c| c.report.input_points).sum();
            (Some(dropped), n - outputs.len(), input - left)
        } else {
            (None, 0, 0)
        };
    // A curve whose knots or parameters under- or overflow samples to non-finite points; that
    // is the input's fault and is said so (never `null` coordinates or an empty geometry).
    for c in &outputs {
        if let Some(i) = c
            .points
            .iter()
            .position(|p| p.iter().any(|x| !x.is_finite()))
        {
            return Err(EarthError::new(
                c.pointer.clone(),
                Problem::Fit(crate::sphere::SphereError::NonFinite {
                    what: "the sampled curve",
                    why: format!("output point {i} is not a number: the knot spans or parameters under- or overflow in floating point; rescale them"),
                }),
            ));
        }
    }
    // Times of the dense output kept in a property: one array per output line.
    let mut time_pieces: Vec<Value> = Vec::new();
    let mut time_name: Option<String> = None;
    // Whether the output is a single LineString (its times are then one array, not nested).
    let mut is_line_string = false;
    let geometry = match kind {
        "LineString" | "MultiLineString" => {
            let mut pieces = Vec::new();
            for c in &outputs {
                let cut = cut_line(&c.points, &c.alts);
                let Some(t) = &c.time else {
                    for piece in cut {
                        pieces.push(output_positions(&piece, c.has_alt, precision));
                    }
                    continue;
                };
                // The same cut with the times in the place of the altitudes: the same pieces,
                // with the times interpolated where a piece meets the antimeridian.
                let cut_t = cut_line(&c.points, &t.unix_s);
                for (piece, tp) in cut.iter().zip(&cut_t) {
                    match &t.origin {
                        TimeOrigin::M => pieces.push(JsonOut::Value(Value::Array(
                            piece
                                .iter()
                                .zip(tp)
                                .map(|(p, q)| {
                                    let mut v = output_position(p, true, precision);
                                    if let Value::Array(a) = &mut v {
                                        a.push(t.format.write(q[2]));
                                    }
                                    v
                                })
                                .collect(),
                        ))),
                        TimeOrigin::Property(name) => {
                            pieces.push(output_positions(piece, c.has_alt, precision));
                            time_name = Some(name.clone());
                            time_pieces.push(Value::Array(
                                tp.iter().map(|q| t.format.write(q[2])).collect(),
                            ));
                        }
                    }
                }
            }
            if kind == "LineString" && pieces.len() == 1 {
                is_line_string = true;
                geometry("LineString", pieces.pop().expect("one piece"))
            } else {
                geometry("MultiLineString", JsonOut::Array(pieces))
            }
        }
        _ => {
            // Group rings by polygon (path [ring] for a Polygon, [polygon, ring] otherwise).
            let mut polygons: Vec<(usize, Vec<&CurveOutput>)> = Vec::new();
            for c in &outputs {
                let key = if kind == "Polygon" {
                    0
                } else {
                    c.report.path[0]
                };
                match polygons.last_mut() {
                    Some((k, rings)) if *k == key => rings.push(c),
                    _ => polygons.push((key, vec![c])),
                }
            }
            let mut pieces = Vec::new();
            for (key, rings) in &polygons {
                let has_alt = rings.iter().all(|r| r.has_alt);
                let lonlat_rings: Vec<Vec<[f64; 3]>> = rings
                    .iter()
                    .map(|r| {
                        r.points
                            .iter()
                            .zip(&r.alts)
                            .map(|(p, &alt)| {
                                let (lon, lat) = super::lonlat::unit_to_lonlat(p);
                                [lon, lat, alt]
                            })
                            .collect()
                    })
                    .collect();
                // Output positions are rounded when written; the pieces need no rounding here.
                let pole = poles.get(*key).copied().flatten();
                let split = split_polygon_around(&lonlat_rings, &|x| x, pole);
                for poly in split {
                    pieces.push(JsonOut::Array(
                        poly.iter()
                            .map(|ring| output_positions(ring, has_alt, precision))
                            .collect(),
                    ));
                }
            }
            if kind == "Polygon" && pieces.len() == 1 {
                geometry("Polygon", pieces.pop().expect("one piece"))
            } else {
                geometry("MultiPolygon", JsonOut::Array(pieces))
            }
        }
    };
    let mut stats = FeatureStats::default();
    for c in &outputs {
        stats.curves += 1;
        stats.input_points += c.report.input_points;
        stats.output_points += c.report.output_points;
        stats.stored_numbers += c.report.stored_numbers;
        stats.max_error_m = stats.max_error_m.max(c.report.max_error_m);
    }
    stats.curves += dropped_curves;
    stats.input_points += dropped_input;
    // Rings kept whole because they were too small to fit (small_rings), by pointer, as
    // shared fitting lists them.
    let kept: Vec<String> = outputs
        .iter()
        .filter(|c| c.report.fields.contains_key("small_ring"))
        .map(|c| c.pointer.clone())
        .collect();
    let mut info = properties_object(kind, outputs.into_iter().map(|c| c.report).collect(), job);
    if kind.ends_with("Polygon") {
        if let JsonOut::Object(m) = &mut info {
            m.insert("kept_rings".into(), JsonOut::Value(json!(kept)));
            if let Some(d) = &dropped {
                m.insert("dropped_rings".into(), JsonOut::Value(json!(d)));
            }
        }
    }
    let mut extra = Vec::new();
    if let Some(name) = time_name {
        let value = if is_line_string && time_pieces.len() == 1 {
            time_pieces.pop().expect("one piece")
        } else {
            Value::Array(time_pieces)
        };
        extra.push((name, value));
    }
    Ok((geometry, info, stats, extra))
}

/// Rounds a speed (m/s) to 0.1 mm/s and a heading to a thousandth of a degree for output.
fn round_motion(speed_mps: f64, heading_deg: f64) -> (f64, f64) {
    (
        super::lonlat::round_to(speed_mps, 4),
        super::lonlat::round_to(heading_deg, 3) % 360.0,
    )
}

/// Evaluates the fits in time of one feature at the times `at` (unix seconds): a MultiPoint of
/// the positions in the order asked, and `properties.evaluation` with the times (`at`, in the
/// fit's convention), `speed_mps` and `heading_deg` from the curve's derivative. Each time is
/// taken on the first part whose times span it.
fn evaluate_at(
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
        let (lon, lat) = super::lonlat::unit_to_lonlat(&m.point);
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

/// `properties.fit` (or `interpolation`, `evaluation`): a LineString's fields directly; for
/// other geometries, totals over the parts plus `geometry` and `parts`.
fn properties_object(kind: &str, mut reports: Vec<CurveReport>, job: &Job) -> JsonOut {
    if kind == "LineString" && reports.len() == 1 {
        return JsonOut::Object(reports.pop().expect("one report").into_members());
    }
    let mut out = Map::new();
    let n_in: usize = reports.iter().map(|r| r.input_points).sum();
    let sum = |f: &dyn Fn(&CurveReport) -> usize| reports.iter().map(f).sum::<usize>();
    let round_m = |x: f64| super::lonlat::round_to(x, 3);
    if !matches!(job.operation, Operation::Evaluate) {
        let max = reports.iter().map(|r| r.max_error_m).fold(0.0, f64::max);
        out.insert("max_error_m".into(), json!(round_m(max)));
        if job.operation.fit_options().is_some() {
            let s: f64 = reports.iter().map(|r| r.error_sum_m).sum();
            let sq: f64 = reports.iter().map(|r| r.error_sq_sum_m2).sum();
            let n = n_in.max(1) as f64;
            out.insert("mean_error_m".into(), json!(round_m(s / n)));
            out.insert("rms_error_m".into(), json!(round_m((sq / n).sqrt())));
        }
        out.insert("input_points".into(), json!(n_in));
    }
    if let Operation::FitToTolerance { tolerance_m, .. } = &job.operation {
        let met = reports
            .iter()
            .all(|r| r.fields.get("tolerance_met") == Some(&Value::Bool(true)));
        let stored = sum(&|r: &CurveReport| r.stored_numbers);
        out.insert("tolerance_m".into(), json!(tolerance_m));
        out.insert("tolerance_met".into(), json!(met));
        out.insert("stored_numbers".into(), json!(stored));
        out.insert(
            "compression_ratio".into(),
            json!(compression_ratio(n_in, stored)),
        );
    }
    if let Some(o) = job.operation.fit_options() {
        let ctrl: usize = reports
            .iter()
            .filter_map(|r| r.fields.get("control_points").and_then(Value::as_u64))
            .sum::<u64>() as usize;
        out.insert("control_points".into(), json!(ctrl));
        let iters = reports
            .iter()
            .filter_map(|r| r.fields.get("iterations").and_then(Value::as_u64))
            .max()
            .unwrap_or(0);
        out.insert("iterations".into(), json!(iters));
        let converged = reports
            .iter()
            .all(|r| r.fields.get("converged") == Some(&Value::Bool(true)));
        out.insert("converged".into(), json!(converged));
        if matches!(job.operation, Operation::Fit(_)) {
            out.insert(
                "knots".into(),
                serde_json::to_value(o.knots).expect("enum serialises"),
            );
        }
        out.insert(
            "parameterization".into(),
            if job.time.fit_in_time.is_some() {
                json!("time")
            } else {
                serde_json::to_value(o.parameterization).expect("enum serialises")
            },
        );
    }
    out.insert(
        "output_points".into(),
        json!(sum(&|r: &CurveReport| r.output_points)),
    );
    let dev = reports
        .iter()
        .filter_map(|r| r.fields.get("sampling_deviation_m").and_then(Value::as_f64))
        .fold(0.0, f64::max);
    out.insert("sampling_deviation_m".into(), json!(dev));
    out.insert("geometry".into(), json!(kind));
    let parts: Vec<JsonOut> = reports
        .into_iter()
        .map(|r| {
            let (path, closed) = (json!(r.path), json!(r.closed));
            let mut m = r.into_members();
            m.insert("path".into(), JsonOut::Value(path));
            m.insert("closed".into(), JsonOut::Value(closed));
            JsonOut::Object(m)
        })
        .collect();
    let mut out = JsonOut::from(out);
    if let JsonOut::Object(m) = &mut out {
        m.insert("parts".into(), JsonOut::Array(parts));
    }
    out
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sphere::FitOptions;

    fn wave(n: usize, lon0: f64) -> Value {
        json!((0..n)
            .map(|i| [lon0 + i as f64 * 0.05, 2.0 * (i as f64 * 0.2).sin()])
            .collect::<Vec<_>>())
    }

    #[test]
    fn collection_order_ids_and_members_survive() {
        let doc = json!({
            "type": "FeatureCollection", "name": "test", "bbox": [0, 0, 1, 1],
            "features": [
                {"type": "Feature", "id": "a", "properties": {"k": 1}, "geometry": {"type": "Point", "coordinates": [1, 2]}},
                {"type": "Feature", "id": 2, "properties": null, "foo": [1], "bbox": [0, 0, 0, 0],
                 "geometry": {"type": "LineString", "coordinates": wave(40, 0.0)}},
                {"type": "Feature", "properties": {}, "geometry": null}
            ]
        });
        let d = Document::parse(doc.clone(), false).unwrap();
        let job = Job::fit(FitOptions::default());
        let outs: Vec<ProcessedFeature> =
            d.slots.iter().map(|s| s.process(&job).unwrap()).collect();
        assert_eq!(outs[0].feature.clone().into_value(), doc["features"][0]);
        assert_eq!(outs[2].feature.clone().into_value(), doc["features"][2]);
        let f = outs[1].feature.clone().into_value();
        assert_eq!(f["id"], 2);
        assert_eq!(f["foo"], json!([1]));
        assert!(f.get("bbox").is_none());
        assert!(f["properties"]["fit"]["max_error_m"].is_number());
        assert_eq!(outs[1].stats.curves, 1);
        let fc = d
            .into_feature_collection(outs.into_iter().map(|o| o.feature).collect(), true)
            .into_value();
        assert_eq!(fc["name"], "test");
        assert!(fc.get("bbox").is_none());
        assert_eq!(fc["features"].as_array().unwrap().len(), 3);
    }

    #[test]
    fn errors_point_into_the_collection() {
        let doc = json!({"type": "FeatureCollection", "features": [
            {"type": "Feature", "properties": {}, "geometry": {"type": "LineString", "coordinates": wave(10, 0.0)}},
            {"type": "Feature", "properties": {}, "geometry": {"type": "MultiLineString", "coordinates": [wave(10, 0.0), [[0, 0], [1, 95]]]}}
        ]});
        let d = Document::parse(doc, false).unwrap();
        let job = Job::fit(FitOptions::default());
        assert!(d.slots[0].process(&job).is_ok());
        let e = d.slots[1].process(&job).unwrap_err();
        assert_eq!(e.pointer, "/features/1/geometry/coordinates/1/1/1");
    }

    #[test]
    fn fit_then_evaluate_reproduces_the_geometry() {
        let doc =
            json!({"type": "MultiLineString", "coordinates": [wave(30, 0.0), wave(30, 20.0)]});
        let job =
            Job::fit(FitOptions::default()).with_sampling(super::super::Sampling::Samples(50));
        let fitted = Document::parse(doc, false).unwrap().slots[0]
            .process(&job)
            .unwrap()
            .feature
            .into_value();
        assert_eq!(
            fitted["properties"]["fit"]["parts"]
                .as_array()
                .unwrap()
                .len(),
            2
        );
        let ev_job = Job::evaluate().with_sampling(super::super::Sampling::Samples(50));
        let evaluated = process_feature(&fitted, "", &ev_job)
            .unwrap()
            .feature
            .into_value();
        assert_eq!(evaluated["geometry"], fitted["geometry"]);
    }

    #[test]
    fn bare_spline_documents_need_a_crs() {
        let doc = json!({"degree": 1, "knots": [0, 0, 1, 1], "control_points": [[0, 0], [10, 0]]});
        let e = Document::parse(doc.clone(), true).unwrap_err();
        assert_eq!(e.pointer, "/crs");
        let mut with_crs = doc;
        with_crs["crs"] = json!("lonlat");
        let d = Document::parse(with_crs, true).unwrap();
        let out = d.slots[0]
            .process(&Job::evaluate().with_sampling(super::super::Sampling::Samples(11)))
            .unwrap();
        let out = out.feature.into_value();
        let coords = out["geometry"]["coordinates"].as_array().unwrap();
        assert_eq!(coords.len(), 11);
        assert_eq!(coords[5], json!([5.0, 0.0]));
    }
}
