//! TopoJSON read: each object of the topology a layer (or the one `layer` names), each of its
//! geometries a feature (an object that is not a `GeometryCollection` is one feature), with
//! its `id` and `properties`, its coordinates decoded from the arcs as `topojson-client`'s
//! `feature()` decodes them: quantised arcs (with a `transform`) are delta-decoded and scaled,
//! a negative index `~i` is arc `i` reversed, the shared end point of consecutive arcs is kept
//! once, and a ring shorter than 4 positions is padded with its first.
//!
//! The file is parsed whole (arcs come after the objects that use them).

use crate::formats::crs::Crs;
use crate::formats::{feature, number, FeatureResult, FormatError, Layer, ReadOptions};
use serde_json::{json, Map, Value};
use std::path::Path;

/// TopoJSON files larger than this are refused (they are parsed whole).
pub const MAX_TOPOJSON_BYTES: u64 = 1 << 30;

/// Opens a TopoJSON file.
pub fn open(path: &Path, name: &str, options: &ReadOptions) -> Result<Vec<Layer>, FormatError> {
    let size = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
    if size > MAX_TOPOJSON_BYTES {
        return Err(FormatError::file(
            name,
            format!("{size} bytes: TopoJSON files of at most {MAX_TOPOJSON_BYTES} bytes are read"),
        ));
    }
    let text =
        std::fs::read(path).map_err(|e| FormatError::file(name, format!("cannot read: {e}")))?;
    let text = text.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(&text);
    let mut topo: Value = serde_json::from_slice(text).map_err(|e| {
        let byte = byte_of(text, e.line(), e.column());
        FormatError::file(name, format!("not valid JSON: {e}")).at_byte(byte)
    })?;
    decode(&mut topo, name, options)
}

/// The byte offset of 1-based `line` and `column` in `text`.
fn byte_of(text: &[u8], line: usize, column: usize) -> u64 {
    let mut at = 0usize;
    for _ in 1..line {
        match text[at..].iter().position(|&b| b == b'\n') {
            Some(i) => at += i + 1,
            None => break,
        }
    }
    (at + column.saturating_sub(1)) as u64
}

/// The layers of a parsed topology.
pub fn decode(
    topo: &mut Value,
    name: &str,
    options: &ReadOptions,
) -> Result<Vec<Layer>, FormatError> {
    let fail = |why: String| FormatError::file(name, why);
    if topo["type"] != "Topology" {
        return Err(fail(format!(
            "not a TopoJSON topology: its \"type\" is {}",
            topo.get("type").map_or("missing".into(), Value::to_string)
        )));
    }
    let transform = match topo.get("transform") {
        None | Some(Value::Null) => None,
        Some(t) => {
            let pair =
                |k: &str| -> Option<(f64, f64)> { Some((t[k][0].as_f64()?, t[k][1].as_f64()?)) };
            match (pair("scale"), pair("translate")) {
                (Some(s), Some(tr)) => Some((s, tr)),
                _ => {
                    return Err(fail(
                        "\"transform\" needs \"scale\" and \"translate\", two numbers each".into(),
                    ))
                }
            }
        }
    };
    let arcs_value = topo
        .get_mut("arcs")
        .map(Value::take)
        .ok_or_else(|| fail("the topology has no \"arcs\"".into()))?;
    let Value::Array(raw_arcs) = arcs_value else {
        return Err(fail("\"arcs\" is not an array".into()));
    };
    let mut arcs = Vec::with_capacity(raw_arcs.len());
    for (i, a) in raw_arcs.into_iter().enumerate() {
        arcs.push(decode_arc(&a, transform).map_err(|e| fail(format!("arc {i}: {e}")))?);
    }
    let Some(Value::Object(objects)) = topo.get_mut("objects").map(Value::take) else {
        return Err(fail("the topology has no \"objects\" object".into()));
    };
    let mut objects: Vec<(String, Value)> = objects.into_iter().collect();
    if let Some(l) = &options.layer {
        let names: Vec<String> = objects.iter().map(|(n, _)| n.clone()).collect();
        objects.retain(|(n, _)| n == l);
        if objects.is_empty() {
            return Err(fail(format!(
                "--layer {l:?}: the topology has no such object (it has {names:?})"
            )));
        }
    }
    let arcs = std::sync::Arc::new(arcs);
    Ok(objects
        .into_iter()
        .map(|(layer, object)| {
            let members = match object {
                Value::Object(mut o) if o.get("type") == Some(&json!("GeometryCollection")) => {
                    match o.remove("geometries") {
                        Some(Value::Array(g)) => g,
                        _ => Vec::new(),
                    }
                }
                other => vec![other],
            };
            let arcs = arcs.clone();
            let file = name.to_string();
            let layer_name = layer.clone();
            let features = members.into_iter().enumerate().map(move |(i, g)| {
                to_feature(g, &arcs, transform).map_err(|e| {
                    FormatError::file(&file, e)
                        .in_layer(&layer_name)
                        .at_record(i as u64 + 1)
                })
            });
            Layer {
                name: layer,
                crs: Crs::lonlat("CRS84 (TopoJSON)"),
                features: Box::new(features.collect::<Vec<FeatureResult>>().into_iter()),
            }
        })
        .collect())
}

type Transform = Option<((f64, f64), (f64, f64))>;

/// An arc's positions, absolute (delta-decoded and scaled when quantised).
fn decode_arc(a: &Value, transform: Transform) -> Result<Vec<Vec<f64>>, String> {
    let points = a.as_array().ok_or("not an array")?;
    let (mut x, mut y) = (0.0, 0.0);
    let mut out = Vec::with_capacity(points.len());
    for (j, p) in points.iter().enumerate() {
        let nums: Option<Vec<f64>> = p
            .as_array()
            .and_then(|p| p.iter().map(Value::as_f64).collect());
        let nums = nums
            .filter(|n| n.len() >= 2)
            .ok_or_else(|| format!("position {j} is not 2 or more numbers"))?;
        let mut q = nums.clone();
        if let Some(((sx, sy), (tx, ty))) = transform {
            x += nums[0];
            y += nums[1];
            q[0] = x * sx + tx;
            q[1] = y * sy + ty;
        }
        out.push(q);
    }
    Ok(out)
}

fn point(p: &Value, transform: Transform) -> Result<Value, String> {
    let nums: Vec<f64> = p
        .as_array()
        .map(|a| a.iter().filter_map(Value::as_f64).collect())
        .filter(|n: &Vec<f64>| n.len() >= 2)
        .ok_or("a position is not 2 or more numbers")?;
    let mut q = nums;
    if let Some(((sx, sy), (tx, ty))) = transform {
        q[0] = q[0] * sx + tx;
        q[1] = q[1] * sy + ty;
    }
    Ok(Value::Array(q.into_iter().map(number).collect()))
}

/// The positions of a line of arc indices.
fn line(indices: &Value, arcs: &[Vec<Vec<f64>>], ring: bool) -> Result<Value, String> {
    let idx = indices.as_array().ok_or("a list of arcs is not an array")?;
    let mut points: Vec<Vec<f64>> = Vec::new();
    for i in idx {
        let i = i.as_i64().ok_or("an arc index is not an integer")?;
        let (k, reversed) = if i < 0 { (!i, true) } else { (i, false) };
        let arc = usize::try_from(k)
            .ok()
            .and_then(|k| arcs.get(k))
            .ok_or_else(|| format!("arc index {i} is not one of the {} arcs", arcs.len()))?;
        if !points.is_empty() {
            points.pop();
        }
        if reversed {
            points.extend(arc.iter().rev().cloned());
        } else {
            points.extend(arc.iter().cloned());
        }
    }
    if ring && !points.is_empty() {
        while points.len() < 4 {
            points.push(points[0].clone());
        }
    }
    Ok(Value::Array(
        points
            .into_iter()
            .map(|p| Value::Array(p.into_iter().map(number).collect()))
            .collect(),
    ))
}

fn list(v: &Value, f: impl Fn(&Value) -> Result<Value, String>) -> Result<Value, String> {
    v.as_array()
        .ok_or("not an array")?
        .iter()
        .map(f)
        .collect::<Result<Vec<_>, _>>()
        .map(Value::Array)
}

/// The GeoJSON geometry of a TopoJSON geometry object.
fn geometry(
    g: &Value,
    arcs: &[Vec<Vec<f64>>],
    t: Transform,
    depth: usize,
) -> Result<Value, String> {
    if depth > 32 {
        return Err("geometry collections nested more than 32 deep".into());
    }
    let kind = match g.get("type") {
        None | Some(Value::Null) => return Ok(Value::Null),
        Some(k) => k.as_str().ok_or("\"type\" is not a string")?,
    };
    let a = &g["arcs"];
    let c = &g["coordinates"];
    let coordinates = match kind {
        "Point" => point(c, t)?,
        "MultiPoint" => list(c, |p| point(p, t))?,
        "LineString" => line(a, arcs, false)?,
        "MultiLineString" => list(a, |l| line(l, arcs, false))?,
        "Polygon" => list(a, |r| line(r, arcs, true))?,
        "MultiPolygon" => list(a, |p| list(p, |r| line(r, arcs, true)))?,
        "GeometryCollection" => {
            let members = list(&g["geometries"], |m| geometry(m, arcs, t, depth + 1))?;
            return Ok(json!({"type": "GeometryCollection", "geometries": members}));
        }
        other => return Err(format!("geometry type {other:?} is not a TopoJSON type")),
    };
    Ok(json!({"type": kind, "coordinates": coordinates}))
}

fn to_feature(g: Value, arcs: &[Vec<Vec<f64>>], t: Transform) -> Result<Value, String> {
    let geom = geometry(&g, arcs, t, 0)?;
    let properties = match g.get("properties") {
        Some(Value::Object(p)) => p.clone(),
        _ => Map::new(),
    };
    let id = g.get("id").cloned();
    Ok(feature(geom, properties, id))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decodes_quantised_arcs_and_reversal() {
        let mut topo = json!({
            "type": "Topology",
            "transform": {"scale": [0.5, 0.25], "translate": [10.0, 20.0]},
            "objects": {"shapes": {"type": "GeometryCollection", "geometries": [
                {"type": "Polygon", "arcs": [[0, 1]], "id": "sq", "properties": {"n": 1}},
                {"type": "LineString", "arcs": [-2]},
                {"type": "Point", "coordinates": [2, 4]},
                {"type": "LineString", "arcs": [7]}
            ]}},
            "arcs": [[[0, 0], [2, 0], [0, 4]], [[2, 4], [-2, 0], [0, -4]]]
        });
        let layers = decode(&mut topo, "t.topojson", &ReadOptions::default()).unwrap();
        let fs: Vec<FeatureResult> = layers.into_iter().next().unwrap().features.collect();
        let sq = fs[0].as_ref().unwrap();
        assert_eq!(sq["id"], "sq");
        assert_eq!(
            sq["geometry"]["coordinates"],
            json!([[
                [10.0, 20.0],
                [11.0, 20.0],
                [11.0, 21.0],
                [10.0, 21.0],
                [10.0, 20.0]
            ]])
        );
        assert_eq!(
            fs[1].as_ref().unwrap()["geometry"]["coordinates"],
            json!([[10.0, 20.0], [10.0, 21.0], [11.0, 21.0]])
        );
        assert_eq!(
            fs[2].as_ref().unwrap()["geometry"]["coordinates"],
            json!([11.0, 21.0])
        );
        let e = fs[3].as_ref().unwrap_err();
        assert_eq!((e.layer.as_deref(), e.record), (Some("shapes"), Some(4)));
        assert!(e.reason.contains("arc index 7"), "{e}");
    }
}
