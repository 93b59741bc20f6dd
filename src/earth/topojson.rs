//! TopoJSON output of a coverage fitted with shared topology ([`super::topology`]).
//!
//! The topology's `arcs` are the dense fitted arcs, as rounded `[lon, lat]` positions (not
//! quantised: no `transform`, positions are absolute, to `precision` decimals): arc `i` is arc
//! `i` of the coverage, and its spline is `spherefit.arcs[i].spline` (degree, knots, control
//! points as `[lon, lat]`), so the compact curves are stored once per arc. Polygon features
//! rebuilt from arcs reference them (`~i` for an arc used reversed); anything else (lines,
//! polygons split at the antimeridian) gets arcs of its own after those, without a spline.
//! Every geometry carries the feature's `properties` (with `properties.fit`) and `id`; they
//! sit in one GeometryCollection object named `collection`. `spherefit` also holds the
//! dataset report (the GeoJSON output's `topology` member without its `arcs`).

use super::topology::{arc_json, Coverage};
use serde_json::{json, Map, Value};

/// The name of the one object of the topology.
pub const OBJECT_NAME: &str = "collection";

/// The TopoJSON topology of a fitted coverage.
pub fn to_topology(c: Coverage) -> Value {
    let mut arcs: Vec<Value> = c.arcs.iter().map(|a| json!(a.dense_ll)).collect();
    let mut geometries = Vec::with_capacity(c.features.len());
    for (f, rings) in c.features.iter().zip(&c.feature_rings) {
        let geometry = &f["geometry"];
        let mut g = match rings {
            Some(polys) => {
                let refs: Vec<Vec<Vec<i64>>> = polys
                    .iter()
                    .map(|p| {
                        p.iter()
                            .map(|r| r.iter().map(|u| u.topojson_index()).collect())
                            .collect()
                    })
                    .collect();
                if geometry["type"] == "Polygon" {
                    json!({"type": "Polygon", "arcs": refs[0]})
                } else {
                    json!({"type": "MultiPolygon", "arcs": refs})
                }
            }
            None => convert(geometry, &mut arcs),
        };
        if let Some(obj) = g.as_object_mut() {
            if let Some(id) = f.get("id") {
                obj.insert("id".into(), id.clone());
            }
            if let Some(p) = f.get("properties").filter(|p| !p.is_null()) {
                obj.insert("properties".into(), p.clone());
            }
        }
        geometries.push(g);
    }
    let mut report = c.report;
    report["arcs"] = Value::Array(c.arcs.iter().map(arc_json).collect());
    let mut out = Map::new();
    out.insert("type".into(), json!("Topology"));
    out.insert(
        "objects".into(),
        json!({ OBJECT_NAME: {"type": "GeometryCollection", "geometries": geometries} }),
    );
    out.insert("arcs".into(), Value::Array(arcs));
    out.insert("spherefit".into(), report);
    Value::Object(out)
}

/// A GeoJSON geometry as a TopoJSON one, its lines and rings appended to `arcs`.
fn convert(g: &Value, arcs: &mut Vec<Value>) -> Value {
    let mut new_arc = |line: &Value| -> i64 {
        arcs.push(line.clone());
        (arcs.len() - 1) as i64
    };
    let kind = g.get("type").and_then(Value::as_str).unwrap_or("");
    let c = &g["coordinates"];
    let list = |v: &Value| v.as_array().cloned().unwrap_or_default();
    match kind {
        "Point" | "MultiPoint" => json!({"type": kind, "coordinates": c}),
        // A LineString's `arcs` is one list of arc indices; a MultiLineString's and a Polygon's
        // one such list per line or ring; a MultiPolygon's one per ring of each polygon. Every
        // line and ring here is one arc of its own, so each list holds one index.
        "LineString" => json!({"type": kind, "arcs": [new_arc(c)]}),
        "MultiLineString" | "Polygon" => {
            let refs: Vec<[i64; 1]> = list(c).iter().map(|r| [new_arc(r)]).collect();
            json!({"type": kind, "arcs": refs})
        }
        "MultiPolygon" => {
            let refs: Vec<Vec<[i64; 1]>> = list(c)
                .iter()
                .map(|p| list(p).iter().map(|r| [new_arc(r)]).collect())
                .collect();
            json!({"type": kind, "arcs": refs})
        }
        "GeometryCollection" => {
            let gs: Vec<Value> = list(&g["geometries"])
                .iter()
                .map(|x| convert(x, arcs))
                .collect();
            json!({"type": kind, "geometries": gs})
        }
        _ => json!({"type": null}),
    }
}

/// The topology serialised with `"type": "Topology"` first (readers such as GDAL recognise a
/// TopoJSON file by its first bytes), then `objects`, `arcs` and the other members.
pub fn to_bytes(topology: &Value) -> Vec<u8> {
    let mut out = b"{\"type\":\"Topology\"".to_vec();
    let Some(map) = topology.as_object() else {
        return serde_json::to_vec(topology).expect("JSON values serialise");
    };
    let mut keys: Vec<&String> = map.keys().filter(|k| *k != "type").collect();
    let rank = |k: &str| match k {
        "objects" => 0,
        "arcs" => 1,
        _ => 2,
    };
    keys.sort_by_key(|k| rank(k));
    for k in keys {
        out.push(b',');
        out.extend(serde_json::to_vec(k).expect("a string serialises"));
        out.push(b':');
        out.extend(serde_json::to_vec(&map[k]).expect("JSON values serialise"));
    }
    out.push(b'}');
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// How many array levels sit above the arc indices (0 for an index itself).
    fn depth(v: &Value) -> usize {
        match v {
            Value::Array(a) => 1 + a.iter().map(depth).max().unwrap_or(0),
            _ => 0,
        }
    }

    #[test]
    fn geometries_with_arcs_of_their_own_nest_their_indices_as_topojson_says() {
        let line = json!([[0, 0], [1, 1]]);
        let ring = json!([[0, 0], [1, 0], [1, 1], [0, 0]]);
        let mut arcs = Vec::new();
        for (g, levels) in [
            (json!({"type": "LineString", "coordinates": line}), 1),
            (
                json!({"type": "MultiLineString", "coordinates": [line, line]}),
                2,
            ),
            (json!({"type": "Polygon", "coordinates": [ring]}), 2),
            (
                json!({"type": "MultiPolygon", "coordinates": [[ring], [ring, ring]]}),
                3,
            ),
        ] {
            let t = convert(&g, &mut arcs);
            assert_eq!(depth(&t["arcs"]), levels, "{g} -> {t}");
        }
        let t = convert(
            &json!({"type": "MultiPolygon", "coordinates": [[ring], [ring, ring]]}),
            &mut arcs,
        );
        // 7 arcs before: 1 + 2 (lines) + 1 + 3 (rings).
        assert_eq!(t["arcs"], json!([[[7]], [[8], [9]]]));
        assert_eq!(arcs.len(), 10);
    }
}
