//! A GeoJSON document split into independent slots ([`Document`]), and the curves and
//! positions of its slots counted without validating them (for limits checked before the work).

use crate::earth::curve::positions::json_kind;
use crate::earth::error::EarthError;
use crate::earth::features::{check_bbox, invalid, FeatureSlot, Source, CURVE_TYPES, OTHER_TYPES};
use crate::earth::json_out::JsonOut;

use serde_json::{json, Map, Value};
use std::collections::BTreeMap;

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
    /// [`Problem::InvalidGeoJson`](crate::earth::error::Problem::InvalidGeoJson) for anything else.
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
pub(super) fn count_curves(geometry: &Value) -> usize {
    let kind = geometry.get("type").and_then(Value::as_str).unwrap_or("");
    let c = geometry.get("coordinates").and_then(Value::as_array);
    match (kind, c) {
        ("LineString", Some(_)) => 1,
        ("MultiLineString" | "Polygon", Some(a)) => a.len(),
        ("MultiPolygon", Some(a)) => a.iter().map(|p| p.as_array().map_or(0, Vec::len)).sum(),
        _ => 0,
    }
}

pub(super) fn count_positions(geometry: &Value) -> usize {
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

/// `bytes` as one JSON value, as [`serde_json::from_slice`] reads it; the items of a
/// top-level object's `features` array are parsed in parallel (a coverage is read whole this
/// way: on the 10m countries, 21 MB, one thread building the values was 5 % of the run), each
/// as soon as the scan of the document has found its end: the scan (12 ms on the 10m
/// countries) runs beside the parsing instead of before it.
///
/// # Errors
/// As [`serde_json::from_slice`]: input that is not one JSON value.
pub fn parse_json(bytes: &[u8]) -> Result<Value, serde_json::Error> {
    let in_parallel = || -> Option<Value> {
        let parsed: std::sync::Mutex<Vec<(usize, serde_json::Result<Value>)>> =
            std::sync::Mutex::new(Vec::new());
        let members = rayon::scope(|scope| -> Option<Vec<(String, RawMember<'_>)>> {
            let mut de = serde_json::Deserializer::from_slice(bytes);
            let members = serde::de::DeserializeSeed::deserialize(
                MembersSeed {
                    scope,
                    parsed: &parsed,
                },
                &mut de,
            )
            .ok()?;
            de.end().ok()?;
            Some(members)
        })?;
        let mut items = parsed.into_inner().ok()?;
        items.sort_unstable_by_key(|(i, _)| *i);
        let mut map = Map::new();
        for (key, raw) in members {
            let value = match raw {
                RawMember::Value(v) => serde_json::from_str(v.get()).ok()?,
                RawMember::Items(n) if n == items.len() => Value::Array(
                    std::mem::take(&mut items)
                        .into_iter()
                        .map(|(_, v)| v)
                        .collect::<Result<_, _>>()
                        .ok()?,
                ),
                RawMember::Items(_) => return None,
            };
            map.insert(key, value);
        }
        Some(Value::Object(map))
    };
    // Anything else (not an object with one array of features, or not JSON) is read whole,
    // and its error told as serde_json tells it.
    in_parallel().map_or_else(|| serde_json::from_slice(bytes), Ok)
}

/// The items of `features` parsed so far, by index.
type Parsed = std::sync::Mutex<Vec<(usize, serde_json::Result<Value>)>>;

/// A JSON object's members unparsed, its `features` as how many items it has: each item is
/// handed to `scope` to be parsed into `parsed` as soon as it is found.
struct MembersSeed<'s, 'scope> {
    scope: &'s rayon::Scope<'scope>,
    parsed: &'scope Parsed,
}

enum RawMember<'a> {
    Value(&'a serde_json::value::RawValue),
    /// The features array: its items are parsed apart.
    Items(usize),
}

impl<'de: 'scope, 'scope> serde::de::DeserializeSeed<'de> for MembersSeed<'_, 'scope> {
    type Value = Vec<(String, RawMember<'de>)>;

    fn deserialize<D: serde::Deserializer<'de>>(self, d: D) -> Result<Self::Value, D::Error> {
        d.deserialize_map(self)
    }
}

impl<'de: 'scope, 'scope> serde::de::Visitor<'de> for MembersSeed<'_, 'scope> {
    type Value = Vec<(String, RawMember<'de>)>;

    fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("a JSON object whose `features` is an array")
    }

    fn visit_map<A: serde::de::MapAccess<'de>>(self, mut map: A) -> Result<Self::Value, A::Error> {
        let mut members: BTreeMap<String, RawMember<'de>> = BTreeMap::new();
        while let Some(key) = map.next_key::<String>()? {
            let member = if key == "features" {
                if members.contains_key("features") {
                    // A later array would replace the earlier one: read whole instead.
                    return Err(serde::de::Error::custom("two arrays of features"));
                }
                RawMember::Items(map.next_value_seed(ItemsSeed {
                    scope: self.scope,
                    parsed: self.parsed,
                })?)
            } else {
                RawMember::Value(map.next_value()?)
            };
            members.insert(key, member);
        }
        if !matches!(members.get("features"), Some(RawMember::Items(_))) {
            return Err(serde::de::Error::custom("no array of features"));
        }
        Ok(members.into_iter().collect())
    }
}

/// The items of an array, each handed to `scope` to be parsed into `parsed`; how many.
struct ItemsSeed<'s, 'scope> {
    scope: &'s rayon::Scope<'scope>,
    parsed: &'scope Parsed,
}

impl<'de: 'scope, 'scope> serde::de::DeserializeSeed<'de> for ItemsSeed<'_, 'scope> {
    type Value = usize;

    fn deserialize<D: serde::Deserializer<'de>>(self, d: D) -> Result<usize, D::Error> {
        d.deserialize_seq(self)
    }
}

impl<'de: 'scope, 'scope> serde::de::Visitor<'de> for ItemsSeed<'_, 'scope> {
    type Value = usize;

    fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("an array")
    }

    fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<usize, A::Error> {
        let mut n = 0;
        while let Some(raw) = seq.next_element::<&'de serde_json::value::RawValue>()? {
            let (i, parsed) = (n, self.parsed);
            self.scope.spawn(move |_| {
                let v = serde_json::from_str::<Value>(raw.get());
                parsed.lock().expect("no parse panics").push((i, v));
            });
            n += 1;
        }
        Ok(n)
    }
}

#[cfg(test)]
mod parse_tests {
    use super::*;

    #[test]
    fn features_parsed_in_parallel_are_the_document_read_whole() {
        let features: Vec<String> = (0..50)
            .map(|i| {
                format!(
                    r#"{{"type":"Feature","id":{i},"properties":{{"name":"f\u00e9{i}","x":[1e-7,0.1,{i}.25]}},"geometry":{{"type":"Polygon","coordinates":[[[0,0],[{i}.5,0],[1,1.0000000000000002],[0,0]]]}}}}"#
                )
            })
            .collect();
        let doc = format!(
            r#"{{"type":"FeatureCollection","name":"n","bbox":[0,0,1,1],"features":[{}],"name":"later wins"}}"#,
            features.join(",")
        );
        let whole: Value = serde_json::from_slice(doc.as_bytes()).unwrap();
        assert_eq!(parse_json(doc.as_bytes()).unwrap(), whole);
        assert_eq!(whole["name"], "later wins");
        assert_eq!(whole["features"].as_array().unwrap().len(), 50);
        // Other documents, and broken ones with serde_json's own error.
        for other in [
            r#"{"type":"Feature","geometry":null,"properties":{}}"#,
            "[1, 2]",
            r#"{"features": 3}"#,
        ] {
            let whole: Value = serde_json::from_str(other).unwrap();
            assert_eq!(parse_json(other.as_bytes()).unwrap(), whole);
        }
        let broken = r#"{"type":"FeatureCollection","features":[{"type":"Feature",}]}"#;
        assert_eq!(
            parse_json(broken.as_bytes()).unwrap_err().to_string(),
            serde_json::from_str::<Value>(broken)
                .unwrap_err()
                .to_string()
        );
    }
}
