//! The API definition as JSON, derived from the hand-written `openapi.yaml` at build time.
//!
//! GIS clients follow the landing page's `service-desc` link and expect JSON there: QGIS 3.22
//! only reads `application/vnd.oai.openapi+json;version=3.0` and gives up on YAML, and GDAL's
//! OAPIF driver documents a JSON API description too. `openapi.yaml` stays the one source; this
//! script writes `$OUT_DIR/openapi.json` (the same document, keys in the file's order) and the
//! service embeds it (`spherefit::service::OPENAPI_JSON`). A YAML error fails the build, naming
//! the line. `tests/it/http_openapi.rs` checks that the two served documents agree.

use std::fmt::Write as _;
use std::path::Path;
use yaml_rust2::{Yaml, YamlLoader};

fn main() {
    println!("cargo:rerun-if-changed=openapi.yaml");
    println!("cargo:rerun-if-changed=build.rs");
    let yaml = std::fs::read_to_string("openapi.yaml").expect("openapi.yaml is readable");
    let docs = YamlLoader::load_from_str(&yaml)
        .unwrap_or_else(|e| panic!("openapi.yaml is not valid YAML: {e}"));
    let [doc] = docs.as_slice() else {
        panic!("openapi.yaml holds {} YAML documents, not one", docs.len());
    };
    let mut json = String::with_capacity(yaml.len());
    write_json(doc, "", &mut json).unwrap_or_else(|e| panic!("openapi.yaml: {e}"));
    let out =
        Path::new(&std::env::var("OUT_DIR").expect("cargo sets OUT_DIR")).join("openapi.json");
    std::fs::write(&out, json).unwrap_or_else(|e| panic!("writing {}: {e}", out.display()));
}

/// Writes `y` as compact JSON; `at` is its path in the document (for errors).
fn write_json(y: &Yaml, at: &str, out: &mut String) -> Result<(), String> {
    match y {
        Yaml::Null => out.push_str("null"),
        Yaml::Boolean(b) => out.push_str(if *b { "true" } else { "false" }),
        Yaml::Integer(i) => write!(out, "{i}").expect("writing to a String"),
        Yaml::Real(s) => {
            let v: f64 = s
                .parse()
                .map_err(|_| format!("{at}: the number {s:?} is not a JSON number"))?;
            if !v.is_finite() {
                return Err(format!("{at}: {s} has no JSON form"));
            }
            let n = serde_json::Number::from_f64(v).expect("a finite number");
            out.push_str(&n.to_string());
        }
        Yaml::String(s) => out.push_str(&serde_json::to_string(s).expect("a string serialises")),
        Yaml::Array(items) => {
            out.push('[');
            for (i, item) in items.iter().enumerate() {
                if i > 0 {
                    out.push(',');
                }
                write_json(item, &format!("{at}/{i}"), out)?;
            }
            out.push(']');
        }
        Yaml::Hash(map) => {
            out.push('{');
            for (i, (k, v)) in map.iter().enumerate() {
                let key = match k {
                    Yaml::String(s) => s.clone(),
                    // Status codes written without quotes (`200:`) are keys all the same.
                    Yaml::Integer(n) => n.to_string(),
                    other => return Err(format!("{at}: the key {other:?} is not a string")),
                };
                if i > 0 {
                    out.push(',');
                }
                out.push_str(&serde_json::to_string(&key).expect("a string serialises"));
                out.push(':');
                write_json(v, &format!("{at}/{key}"), out)?;
            }
            out.push('}');
        }
        Yaml::Alias(_) | Yaml::BadValue => {
            return Err(format!("{at}: {y:?} has no JSON form (no anchors or tags)"));
        }
    }
    Ok(())
}
