//! GPX 1.0 / 1.1 (read with the `gpx` crate), as GDAL presents it: the layers `waypoints`,
//! `routes` and `tracks` (those that have features), in that order.
//!
//! * A track is one `LineString` (a `MultiLineString` when it has several non-empty segments);
//!   when every point has a `<time>`, `properties.coordTimes` holds them as RFC 3339 strings
//!   (one array per line for a `MultiLineString`), which is the time parameterisation
//!   [`crate::earth::time`] picks up by itself: a track is fitted in time.
//! * A route is a `LineString`, with `coordTimes` the same way.
//! * A waypoint is a `Point`, its `<time>` in `properties.time`.
//!
//! Elevations (`<ele>`) are the third number of the positions when every point of the line
//! has one. `name`, `cmt`, `desc`, `src`, `sym`, `type` and `number` are properties.

use crate::formats::crs::Crs;
use crate::formats::{feature, position, FeatureResult, FormatError, Layer, ReadOptions};
use serde_json::{json, Map, Value};
use std::fs::File;
use std::io::BufReader;
use std::path::Path;

/// A GPX file is parsed whole: larger files are refused (split them first).
pub const MAX_GPX_BYTES: u64 = 512 << 20;

/// Opens a GPX file.
pub fn open(path: &Path, name: &str, options: &ReadOptions) -> Result<Vec<Layer>, FormatError> {
    let file =
        File::open(path).map_err(|e| FormatError::file(name, format!("cannot open: {e}")))?;
    let size = file.metadata().map(|m| m.len()).unwrap_or(0);
    if size > MAX_GPX_BYTES {
        return Err(FormatError::file(
            name,
            format!("{size} bytes: GPX files of at most {MAX_GPX_BYTES} bytes are read"),
        ));
    }
    let parsed = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        gpx::read(BufReader::new(file))
    }));
    let doc = match parsed {
        Ok(Ok(d)) => d,
        Ok(Err(e)) => {
            return Err(FormatError::file(
                name,
                format!("not a valid GPX document: {e}"),
            ))
        }
        Err(_) => {
            return Err(FormatError::file(
                name,
                "not a valid GPX document (the reader failed on it)",
            ))
        }
    };
    let waypoints: Vec<FeatureResult> = doc.waypoints.iter().map(|w| Ok(waypoint(w))).collect();
    let routes: Vec<FeatureResult> = doc
        .routes
        .iter()
        .map(|r| {
            let mut p = common(&r.name, &r.comment, &r.description, &r.source, &r.type_);
            if let Some(n) = r.number {
                p.insert("number".into(), json!(n));
            }
            Ok(line_feature(&[&r.points[..]], p))
        })
        .collect();
    let tracks: Vec<FeatureResult> = doc
        .tracks
        .iter()
        .map(|t| {
            let mut p = common(&t.name, &t.comment, &t.description, &t.source, &t.type_);
            if let Some(n) = t.number {
                p.insert("number".into(), json!(n));
            }
            let segs: Vec<&[gpx::Waypoint]> = t
                .segments
                .iter()
                .map(|s| &s.points[..])
                .filter(|s| !s.is_empty())
                .collect();
            Ok(line_feature(&segs, p))
        })
        .collect();
    let mut layers: Vec<(&str, Vec<FeatureResult>)> = vec![
        ("waypoints", waypoints),
        ("routes", routes),
        ("tracks", tracks),
    ];
    match &options.layer {
        Some(l) => {
            layers.retain(|(n, _)| n == l);
            if layers.is_empty() {
                return Err(FormatError::file(
                    name,
                    format!(
                        "--layer {l:?}: a GPX file has the layers waypoints, routes and tracks"
                    ),
                ));
            }
        }
        None => layers.retain(|(_, f)| !f.is_empty()),
    }
    Ok(layers
        .into_iter()
        .map(|(n, f)| Layer {
            name: n.to_string(),
            crs: Crs::lonlat("EPSG:4326"),
            features: Box::new(f.into_iter()),
        })
        .collect())
}

fn common(
    name: &Option<String>,
    cmt: &Option<String>,
    desc: &Option<String>,
    src: &Option<String>,
    kind: &Option<String>,
) -> Map<String, Value> {
    let mut p = Map::new();
    for (k, v) in [
        ("name", name),
        ("cmt", cmt),
        ("desc", desc),
        ("src", src),
        ("type", kind),
    ] {
        if let Some(v) = v {
            p.insert(k.into(), Value::from(v.clone()));
        }
    }
    p
}

/// The RFC 3339 text of a GPX time (UTC, fractional seconds only when there are any).
fn rfc3339(t: gpx::Time) -> Option<String> {
    let dt: time::OffsetDateTime = t.into();
    let ns = dt.unix_timestamp_nanos();
    jiff::Timestamp::from_nanosecond(ns)
        .ok()
        .map(|ts| ts.to_string())
}

fn waypoint(w: &gpx::Waypoint) -> Value {
    let p = w.point();
    let mut props = common(&w.name, &w.comment, &w.description, &w.source, &w.type_);
    if let Some(s) = &w.symbol {
        props.insert("sym".into(), Value::from(s.clone()));
    }
    if let Some(t) = w.time.and_then(rfc3339) {
        props.insert("time".into(), Value::from(t));
    }
    feature(
        json!({"type": "Point", "coordinates": position(p.x(), p.y(), w.elevation)}),
        props,
        None,
    )
}

/// A line feature of one or more point lists, with `coordTimes` when every point has a time.
fn line_feature(lines: &[&[gpx::Waypoint]], mut props: Map<String, Value>) -> Value {
    let coords: Vec<Value> = lines
        .iter()
        .map(|pts| {
            let all_ele = pts.iter().all(|p| p.elevation.is_some());
            Value::Array(
                pts.iter()
                    .map(|w| {
                        let p = w.point();
                        position(p.x(), p.y(), if all_ele { w.elevation } else { None })
                    })
                    .collect(),
            )
        })
        .collect();
    let times: Option<Vec<Value>> = lines
        .iter()
        .map(|pts| {
            pts.iter()
                .map(|w| w.time.and_then(rfc3339).map(Value::from))
                .collect::<Option<Vec<_>>>()
                .map(Value::Array)
        })
        .collect();
    let geometry = match coords.len() {
        0 => Value::Null,
        1 => json!({"type": "LineString", "coordinates": coords[0]}),
        _ => json!({"type": "MultiLineString", "coordinates": coords}),
    };
    if let Some(mut t) = times.filter(|t| !t.is_empty()) {
        props.insert(
            "coordTimes".into(),
            if t.len() == 1 {
                t.remove(0)
            } else {
                Value::Array(t)
            },
        );
    }
    feature(geometry, props, None)
}
