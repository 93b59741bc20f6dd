//! Output JSON whose long number arrays stay `f64` until written.
//!
//! A fitted feature's output is mostly numbers: its dense coordinates and its spline's knots
//! and control points. Built as [`serde_json::Value`], every position is a vector of its own,
//! allocated, walked and freed once more to write it; on the land outlines at 100 m that was
//! about a tenth of the whole run. [`JsonOut`] keeps those arrays flat and writes them
//! straight from `f64`, byte for byte as the same `Value` would be written (object members in
//! key order, numbers by serde_json's own formatter, non-finite numbers as `null`).
//! [`JsonOut::into_value`] gives the `Value` for callers that work on one (the service, the
//! coverage fit, Python).

use serde::ser::{SerializeMap, SerializeSeq};
use serde::{Serialize, Serializer};
use serde_json::{Map, Value};
use std::collections::BTreeMap;

/// A JSON value for output (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub enum JsonOut {
    /// Any value, written as it is.
    Value(Value),
    /// An object; members are written in key order, as [`Value::Object`] writes them.
    Object(BTreeMap<String, JsonOut>),
    /// An array of values.
    Array(Vec<JsonOut>),
    /// An array of numbers: `[x, y, ...]`.
    Numbers(Vec<f64>),
    /// An array of rows of `width` numbers each (positions): `[[x, y], [x, y], ...]`.
    Rows {
        /// The rows one after the other.
        numbers: Vec<f64>,
        /// Numbers per row.
        width: usize,
    },
}

impl JsonOut {
    /// An object of these members.
    pub fn object<K: Into<String>>(members: impl IntoIterator<Item = (K, JsonOut)>) -> JsonOut {
        JsonOut::Object(members.into_iter().map(|(k, v)| (k.into(), v)).collect())
    }

    /// Rows of `width` numbers from rows given as arrays.
    pub fn rows<const W: usize>(rows: &[[f64; W]]) -> JsonOut {
        JsonOut::Rows {
            numbers: rows.iter().flatten().copied().collect(),
            width: W,
        }
    }

    /// The same JSON as a [`Value`].
    pub fn into_value(self) -> Value {
        match self {
            JsonOut::Value(v) => v,
            JsonOut::Object(m) => {
                Value::Object(m.into_iter().map(|(k, v)| (k, v.into_value())).collect())
            }
            JsonOut::Array(a) => Value::Array(a.into_iter().map(JsonOut::into_value).collect()),
            JsonOut::Numbers(xs) => Value::Array(xs.into_iter().map(Value::from).collect()),
            JsonOut::Rows { numbers, width } => Value::Array(
                numbers
                    .chunks(width.max(1))
                    .map(|row| Value::Array(row.iter().map(|&x| Value::from(x)).collect()))
                    .collect(),
            ),
        }
    }
}

impl JsonOut {
    /// The compact JSON text, byte for byte what `serde_json::to_vec` writes, with the number
    /// arrays written straight from `f64` by serde_json's own formatter rather than through
    /// the `Serializer` (its per-element state and calls) into a buffer grown from 128 bytes.
    /// On the 10m land outlines at 10 m (12.7 MB of output) that cut serialising from 298 M to
    /// about half the instructions.
    ///
    /// # Errors
    /// As `serde_json::to_vec` of the [`Value`]s inside.
    pub fn to_json_vec(&self) -> serde_json::Result<Vec<u8>> {
        let mut out = Vec::with_capacity(self.size_hint());
        self.write_compact(&mut out)?;
        Ok(out)
    }

    /// About the length of the compact text: 14 bytes a number (a coordinate at 7 decimals
    /// with its separators), 64 a member or value otherwise.
    fn size_hint(&self) -> usize {
        match self {
            JsonOut::Value(_) => 64,
            JsonOut::Object(m) => m.values().map(|v| 16 + v.size_hint()).sum::<usize>() + 2,
            JsonOut::Array(a) => a.iter().map(JsonOut::size_hint).sum::<usize>() + 2,
            JsonOut::Numbers(xs) => 14 * xs.len() + 2,
            JsonOut::Rows { numbers, .. } => 14 * numbers.len() + 2,
        }
    }

    fn write_compact(&self, out: &mut Vec<u8>) -> serde_json::Result<()> {
        match self {
            JsonOut::Value(v) => serde_json::to_writer(&mut *out, v)?,
            JsonOut::Object(m) => {
                out.push(b'{');
                for (i, (k, v)) in m.iter().enumerate() {
                    if i > 0 {
                        out.push(b',');
                    }
                    serde_json::to_writer(&mut *out, k)?;
                    out.push(b':');
                    v.write_compact(out)?;
                }
                out.push(b'}');
            }
            JsonOut::Array(a) => {
                out.push(b'[');
                for (i, v) in a.iter().enumerate() {
                    if i > 0 {
                        out.push(b',');
                    }
                    v.write_compact(out)?;
                }
                out.push(b']');
            }
            JsonOut::Numbers(xs) => write_numbers(out, xs),
            JsonOut::Rows { numbers, width } => {
                out.push(b'[');
                for (i, row) in numbers.chunks(*width.max(&1)).enumerate() {
                    if i > 0 {
                        out.push(b',');
                    }
                    write_numbers(out, row);
                }
                out.push(b']');
            }
        }
        Ok(())
    }

    /// Whether an object anywhere in the tree (the [`Value`]s included) has a member `key`:
    /// what finding `"key":` in the compact text finds (a key ending in `"key` aside), without
    /// scanning the text (on the land outlines at 10 m the scan for `"warnings":` cost
    /// 165 M instructions).
    pub fn has_key(&self, key: &str) -> bool {
        fn in_value(v: &Value, key: &str) -> bool {
            match v {
                Value::Object(m) => m.iter().any(|(k, v)| k == key || in_value(v, key)),
                Value::Array(a) => a.iter().any(|v| in_value(v, key)),
                _ => false,
            }
        }
        match self {
            JsonOut::Value(v) => in_value(v, key),
            JsonOut::Object(m) => m.iter().any(|(k, v)| k == key || v.has_key(key)),
            JsonOut::Array(a) => a.iter().any(|v| v.has_key(key)),
            JsonOut::Numbers(_) | JsonOut::Rows { .. } => false,
        }
    }
}

/// `[x,y,...]` as serde_json writes an array of `f64`: finite numbers by its formatter,
/// others as `null`.
fn write_numbers(out: &mut Vec<u8>, xs: &[f64]) {
    use serde_json::ser::{CompactFormatter, Formatter};
    out.push(b'[');
    for (i, &x) in xs.iter().enumerate() {
        if i > 0 {
            out.push(b',');
        }
        if x.is_finite() {
            CompactFormatter
                .write_f64(out, x)
                .expect("writing to a Vec cannot fail");
        } else {
            out.extend_from_slice(b"null");
        }
    }
    out.push(b']');
}

impl From<Value> for JsonOut {
    fn from(v: Value) -> JsonOut {
        JsonOut::Value(v)
    }
}

impl From<Map<String, Value>> for JsonOut {
    fn from(m: Map<String, Value>) -> JsonOut {
        JsonOut::Object(m.into_iter().map(|(k, v)| (k, JsonOut::Value(v))).collect())
    }
}

/// A number as [`Value::from`] keeps it: non-finite numbers are `null`.
struct Number(f64);

impl Serialize for Number {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        if self.0.is_finite() {
            s.serialize_f64(self.0)
        } else {
            s.serialize_unit()
        }
    }
}

/// One row of a [`JsonOut::Rows`].
struct Row<'a>(&'a [f64]);

impl Serialize for Row<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq(self.0.iter().map(|&x| Number(x)))
    }
}

impl Serialize for JsonOut {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            JsonOut::Value(v) => v.serialize(s),
            JsonOut::Object(m) => {
                let mut map = s.serialize_map(Some(m.len()))?;
                for (k, v) in m {
                    map.serialize_entry(k, v)?;
                }
                map.end()
            }
            JsonOut::Array(a) => s.collect_seq(a),
            JsonOut::Numbers(xs) => s.collect_seq(xs.iter().map(|&x| Number(x))),
            JsonOut::Rows { numbers, width } => {
                let rows = numbers.chunks(*width.max(&1));
                let mut seq = s.serialize_seq(Some(rows.len()))?;
                for row in rows {
                    seq.serialize_element(&Row(row))?;
                }
                seq.end()
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    /// A tree with every variant and awkward numbers (integral, tiny, huge, negative zero,
    /// non-finite) and keys out of order.
    fn sample() -> JsonOut {
        JsonOut::object([
            ("z", JsonOut::Value(json!({"b": [1, 2.5, "x"], "a": null}))),
            (
                "a",
                JsonOut::Numbers(vec![0.0, 1.0, -0.0, 1e-7, 1.5e300, f64::NAN]),
            ),
            (
                "m",
                JsonOut::Array(vec![
                    JsonOut::rows(&[[120.0, -0.874126], [f64::INFINITY, 1e21]]),
                    JsonOut::Rows {
                        numbers: vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0],
                        width: 3,
                    },
                    JsonOut::Rows {
                        numbers: vec![],
                        width: 2,
                    },
                ]),
            ),
            (
                "k",
                JsonOut::from(json!({"q": 1}).as_object().unwrap().clone()),
            ),
        ])
    }

    #[test]
    fn writes_what_the_value_writes() {
        let out = sample();
        let direct = serde_json::to_string(&out).unwrap();
        let via_value = serde_json::to_string(&out.clone().into_value()).unwrap();
        assert_eq!(direct, via_value);
        assert_eq!(
            serde_json::to_string_pretty(&out).unwrap(),
            serde_json::to_string_pretty(&out.into_value()).unwrap()
        );
        assert!(direct.starts_with(r#"{"a":[0.0,1.0,-0.0,1e-7,1.5e+300,null],"k":{"q":1},"m":[[[120.0,-0.874126],[null,1e+21]],[[1.0,2.0,3.0],[4.0,5.0,6.0]],[]],"z""#), "{direct}");
    }

    #[test]
    fn the_compact_text_is_serde_json_s() {
        let out = sample();
        assert_eq!(
            out.to_json_vec().unwrap(),
            serde_json::to_vec(&out).unwrap()
        );
        let empty = JsonOut::object([
            ("o", JsonOut::object(Vec::<(String, JsonOut)>::new())),
            ("a", JsonOut::Array(vec![])),
            ("n", JsonOut::Numbers(vec![])),
        ]);
        assert_eq!(
            empty.to_json_vec().unwrap(),
            serde_json::to_vec(&empty).unwrap()
        );
    }

    #[test]
    fn keys_are_found_where_the_text_has_them() {
        let out = sample();
        for key in ["z", "b", "q", "m"] {
            let text = serde_json::to_string(&out).unwrap();
            assert_eq!(
                out.has_key(key),
                text.contains(&format!("\"{key}\":")),
                "{key}"
            );
        }
        assert!(!out.has_key("warnings"));
        assert!(JsonOut::Value(json!([{"x": {"warnings": []}}])).has_key("warnings"));
    }

    #[test]
    fn the_value_is_the_json_macro_s() {
        let v = JsonOut::rows(&[[1.5, 2.0], [3.0, f64::NAN]]).into_value();
        assert_eq!(v, json!([[1.5, 2.0], [3.0, null]]));
        assert_eq!(JsonOut::Numbers(vec![0.25]).into_value(), json!([0.25]));
    }
}
