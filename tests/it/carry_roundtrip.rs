//! The carry outputs (#30) read back by the tools people read them with: TopoJSON of a shared
//! fit (`carry=geometry` and `carry=both`) by npm `topojson-client` and GDAL's TopoJSON driver,
//! GeoJSON (`carry=geometry` and `carry=spline`) by GDAL's GeoJSON driver, every feature and
//! every property present with its value; and the compact curve decoded by the CLI and the
//! service giving the points of the JSON spline of the same fit (Python's `evaluate` is
//! checked against the CLI in `python/tests/test_compact.py`).
//!
//! A missing tool skips its half with a notice, unless `SPHEREFIT_TEST_TOOLS=required` (set by
//! `.ci/run`), where it fails.

use crate::helpers::{fixture_path, lonlat_to_unit, run_spherefit, EARTH_RADIUS_M};
use crate::topology::topojson_client;
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::process::Command;

fn scratch(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("carry-{name}"));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn tools_required() -> bool {
    std::env::var("SPHEREFIT_TEST_TOOLS").as_deref() == Ok("required")
}

/// `spherefit fit ARGS INPUT -o OUT`, which must succeed.
fn fit_to(args: &[&str], input: &str, out: &std::path::Path) {
    let mut all = vec!["fit", "-q"];
    all.extend_from_slice(args);
    let out_s = out.to_str().unwrap();
    all.extend_from_slice(&[input, "-o", out_s]);
    let o = run_spherefit(&all, None);
    assert!(
        o.status.success(),
        "{all:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

fn read_json(p: &std::path::Path) -> Value {
    serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap()
}

/// A field of a feature as `ogrinfo -al` prints it: `  name (Type) = text`.
#[derive(Debug)]
struct OgrField {
    kind: String,
    text: String,
}

/// A feature as `ogrinfo -al` prints it: its fields and its geometry's WKT (if any).
#[derive(Debug, Default)]
struct OgrFeature {
    fields: BTreeMap<String, OgrField>,
    wkt: Option<String>,
}

/// Every feature of every layer of `path` as GDAL's `ogrinfo -ro -al` lists it; None (with a
/// notice) when GDAL is not installed and not required.
fn ogrinfo(path: &std::path::Path) -> Option<Vec<OgrFeature>> {
    let o = match Command::new("ogrinfo")
        .arg("-ro")
        .arg("-al")
        .arg(path)
        .output()
    {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            assert!(
                !tools_required(),
                "ogrinfo (Debian gdal-bin) is not installed"
            );
            println!("NOTICE: ogrinfo (GDAL) is not installed: the GDAL half was skipped");
            return None;
        }
        Err(e) => panic!("ogrinfo: {e}"),
        Ok(o) => o,
    };
    let text = String::from_utf8_lossy(&o.stdout);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "ogrinfo {}: {err}", path.display());
    assert!(
        !err.contains("ERROR") && !text.contains("FAILURE"),
        "ogrinfo {}: {err}",
        path.display()
    );
    let mut out: Vec<OgrFeature> = Vec::new();
    for line in text.lines() {
        if line.starts_with("OGRFeature(") {
            out.push(OgrFeature::default());
            continue;
        }
        let Some(f) = out.last_mut() else { continue };
        let Some(body) = line.strip_prefix("  ") else {
            continue;
        };
        // `name (Type) = value`; the type may hold parentheses: `String(JSON)`.
        if let Some((head, value)) = body.split_once(") = ") {
            if let Some((name, kind)) = head.split_once(" (") {
                f.fields.insert(
                    name.to_string(),
                    OgrField {
                        kind: kind.to_string(),
                        text: value.to_string(),
                    },
                );
                continue;
            }
        }
        if !body.starts_with(' ') && body.contains('(') && f.wkt.is_none() {
            f.wkt = Some(body.to_string());
        }
    }
    Some(out)
}

/// Whether two JSON values are equal, numbers within a relative 1e-12 (GDAL prints 17
/// significant digits, node writes `2.0` as `2`).
fn json_close(a: &Value, b: &Value) -> bool {
    match (a, b) {
        (Value::Number(x), Value::Number(y)) => {
            let (x, y) = (x.as_f64().unwrap(), y.as_f64().unwrap());
            (x - y).abs() <= 1e-12 * x.abs().max(y.abs()).max(1.0)
        }
        (Value::Array(x), Value::Array(y)) => {
            x.len() == y.len() && x.iter().zip(y).all(|(p, q)| json_close(p, q))
        }
        (Value::Object(x), Value::Object(y)) => {
            x.len() == y.len()
                && x.iter()
                    .all(|(k, v)| y.get(k).is_some_and(|w| json_close(v, w)))
        }
        _ => a == b,
    }
}

/// `value` (a property as written) is what GDAL read into `field`.
fn ogr_field_holds(field: &OgrField, value: &Value) -> bool {
    if field.text == "(null)" {
        return value.is_null();
    }
    match field.kind.as_str() {
        "String(JSON)" => {
            serde_json::from_str::<Value>(&field.text).is_ok_and(|v| json_close(&v, value))
        }
        "String" => match value {
            Value::String(s) => *s == field.text,
            other => serde_json::from_str::<Value>(&field.text).is_ok_and(|v| v == *other),
        },
        "Integer(Boolean)" => {
            value.as_bool().map(|b| if b { "1" } else { "0" }) == Some(&field.text)
        }
        "Integer" | "Integer64" | "Real" => field
            .text
            .parse::<f64>()
            .is_ok_and(|x| json_close(&serde_json::json!(x), value)),
        // `(2:USA,MEX)`, `(4:-117.1,25.8,-97.1,32.7)`.
        "StringList" | "RealList" | "IntegerList" | "Integer64List" => {
            let Some(items) = value.as_array() else {
                return false;
            };
            let inner = field
                .text
                .strip_prefix('(')
                .and_then(|t| t.strip_suffix(')'))
                .and_then(|t| t.split_once(':'));
            let Some((n, list)) = inner else { return false };
            let parts: Vec<&str> = list.split(',').collect();
            n == items.len().to_string()
                && parts.len() == items.len()
                && parts.iter().zip(items).all(|(p, v)| match v {
                    Value::String(s) => s == p,
                    _ => p
                        .parse::<f64>()
                        .is_ok_and(|x| json_close(&serde_json::json!(x), v)),
                })
        }
        other => panic!("a field type this test does not compare: {other}"),
    }
}

/// GDAL read every feature of `written` (the features as spherefit wrote them, in order) with
/// every property and its value, and a geometry exactly where one was written.
fn gdal_read_all(what: &str, read: &[OgrFeature], written: &[Value]) {
    assert_eq!(read.len(), written.len(), "{what}: feature count");
    for (i, (r, w)) in read.iter().zip(written).enumerate() {
        let props = w["properties"].as_object().expect("properties");
        assert!(!props.is_empty(), "{what}: feature {i} has properties");
        for (k, v) in props {
            let field = r
                .fields
                .get(k)
                .unwrap_or_else(|| panic!("{what}: feature {i}: GDAL lost property {k}"));
            assert!(
                ogr_field_holds(field, v),
                "{what}: feature {i}: {k} read as {field:?}, written {v}"
            );
        }
        assert_eq!(
            r.wkt.is_some(),
            !w["geometry"].is_null(),
            "{what}: feature {i}: geometry {:?}",
            r.wkt
        );
    }
}

/// The features of a TopoJSON's one object as spherefit wrote them: properties and whether
/// there is a geometry.
fn topojson_features(topo: &Value) -> Vec<Value> {
    let objects = topo["objects"].as_object().unwrap();
    assert_eq!(objects.len(), 1);
    let object = objects.values().next().unwrap();
    object["geometries"]
        .as_array()
        .unwrap()
        .iter()
        .map(|g| {
            serde_json::json!({
                "properties": g["properties"],
                "geometry": if g["type"].is_null() { Value::Null } else { g["type"].clone() },
            })
        })
        .collect()
}

/// TopoJSON of a shared fit with `carry=geometry` and `carry=both` comes back through
/// topojson-client and GDAL with every feature, its id, every property (the fit report
/// included) and a geometry; `carry=both` also keeps every arc's spline in `spherefit.splines`.
#[test]
fn topojson_of_both_carries_is_read_whole_by_topojson_client_and_gdal() {
    let dir = scratch("topojson");
    let input = fixture_path("coverage_us_states.geojson");
    let n_in = crate::helpers::read_fixture_json("coverage_us_states.geojson")["features"]
        .as_array()
        .unwrap()
        .len();
    for carry in ["geometry", "both"] {
        let topo_path = dir.join(format!("{carry}.topojson"));
        let geo_path = dir.join(format!("{carry}.geojson"));
        let shared = [
            "--topology",
            "shared",
            "--tolerance-m",
            "1000",
            "--carry",
            carry,
        ];
        fit_to(
            &[&shared[..], &["--output-format", "topojson"]].concat(),
            &input,
            &topo_path,
        );
        fit_to(&shared, &input, &geo_path);
        let topo = read_json(&topo_path);
        let written = topojson_features(&topo);
        assert_eq!(written.len(), n_in, "{carry}");
        let splines = &topo["spherefit"]["splines"];
        if carry == "both" {
            let arcs = topo["arcs"].as_array().unwrap().len();
            assert_eq!(splines.as_array().map(Vec::len), Some(arcs), "{carry}");
            assert!(splines.as_array().unwrap().iter().any(Value::is_object));
        } else {
            assert!(splines.is_null(), "carry=geometry keeps no spline");
        }
        // topojson-client, as a d3 map reads it.
        let client_path = dir.join(format!("{carry}.client.geojson"));
        if topojson_client(&[
            "read",
            topo_path.to_str().unwrap(),
            client_path.to_str().unwrap(),
        ]) {
            let client = read_json(&client_path);
            let features = client["features"].as_array().unwrap();
            assert_eq!(features.len(), n_in, "topojson-client, {carry}");
            let geojson = read_json(&geo_path);
            for (i, (c, w)) in features.iter().zip(&written).enumerate() {
                assert!(
                    json_close(&c["properties"], &w["properties"]),
                    "topojson-client, {carry}, feature {i}: {} against {}",
                    c["properties"],
                    w["properties"]
                );
                let gtype = c["geometry"]["type"].as_str().unwrap_or("none");
                assert!(
                    gtype == "Polygon" || gtype == "MultiPolygon",
                    "topojson-client, {carry}, feature {i}: {gtype}"
                );
                // The name is that of spherefit's GeoJSON output of the same fit.
                assert_eq!(
                    c["properties"]["name"], geojson["features"][i]["properties"]["name"],
                    "{carry}"
                );
            }
        }
        // GDAL's TopoJSON driver (QGIS, ogr2ogr): it adds the geometry's id as a field.
        if let Some(read) = ogrinfo(&topo_path) {
            gdal_read_all(&format!("GDAL TopoJSON, carry={carry}"), &read, &written);
            let objects = topo["objects"]
                .as_object()
                .unwrap()
                .values()
                .next()
                .unwrap();
            for (i, (r, g)) in read
                .iter()
                .zip(objects["geometries"].as_array().unwrap())
                .enumerate()
            {
                if let Some(id) = g["id"].as_str() {
                    assert_eq!(r.fields["id"].text, id, "feature {i}");
                }
                let wkt = r.wkt.as_deref().unwrap();
                assert!(
                    wkt.starts_with("POLYGON") || wkt.starts_with("MULTIPOLYGON"),
                    "feature {i}: {}",
                    &wkt[..wkt.len().min(40)]
                );
            }
        }
    }
}

/// GeoJSON with `carry=geometry` (no spline in the report) and `carry=spline` (no geometry;
/// the compact curve in `fit.spline`) is read by GDAL with every feature and every property,
/// for lines (the US-Mexico border) and polygons (US states, per feature).
#[test]
fn geojson_of_geometry_and_spline_carries_is_read_whole_by_gdal() {
    let dir = scratch("geojson");
    for (name, tolerance) in [
        ("us_mexico_border_natural_earth.geojson", "100"),
        ("coverage_us_states.geojson", "1000"),
    ] {
        for carry in ["geometry", "spline"] {
            let out = dir.join(format!("{carry}-{name}"));
            fit_to(
                &["--tolerance-m", tolerance, "--carry", carry],
                &fixture_path(name),
                &out,
            );
            let written = read_json(&out);
            let features = written["features"].as_array().unwrap();
            for f in features {
                let spline = &f["properties"]["fit"]["spline"];
                let parts = f["properties"]["fit"]["parts"].as_array();
                match carry {
                    "geometry" => {
                        assert!(!f["geometry"].is_null());
                        assert!(spline.is_null());
                    }
                    _ => {
                        assert!(f["geometry"].is_null());
                        // Lines carry one compact curve, polygons one a ring (in `parts`).
                        let compact = spline.as_str().map(str::to_string).or_else(|| {
                            parts.and_then(|p| p[0]["spline"].as_str().map(str::to_string))
                        });
                        assert!(compact.is_some_and(|c| !c.is_empty()), "{name}: {f}");
                    }
                }
            }
            if let Some(read) = ogrinfo(&out) {
                gdal_read_all(
                    &format!("GDAL GeoJSON, {name}, carry={carry}"),
                    &read,
                    features,
                );
            }
        }
    }
}

fn lonlat_to_vec(lon_deg: f64, lat_deg: f64) -> [f64; 3] {
    let v = lonlat_to_unit(lon_deg, lat_deg);
    [v[0], v[1], v[2]]
}

/// Great-circle distance in metres from `p` to the polyline `line` (unit vectors).
fn distance_to_polyline_m(p: [f64; 3], line: &[[f64; 3]]) -> f64 {
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let angle = |a: [f64; 3], b: [f64; 3]| {
        let c = cross(a, b);
        dot(c, c).sqrt().atan2(dot(a, b))
    };
    let mut best = f64::INFINITY;
    for w in line.windows(2) {
        let (a, b) = (w[0], w[1]);
        let mut d = angle(p, a).min(angle(p, b));
        let n = cross(a, b);
        let nn = dot(n, n).sqrt();
        if nn > 1e-15 {
            let n = [n[0] / nn, n[1] / nn, n[2] / nn];
            // The foot of p on the great circle lies within the arc a-b?
            let s = dot(p, n);
            let foot = [p[0] - s * n[0], p[1] - s * n[1], p[2] - s * n[2]];
            if dot(cross(a, foot), n) >= 0.0 && dot(cross(foot, b), n) >= 0.0 {
                d = d.min(s.abs().clamp(-1.0, 1.0).asin());
            }
        }
        best = best.min(d);
    }
    best * EARTH_RADIUS_M
}

fn positions(g: &Value) -> Vec<[f64; 2]> {
    g["coordinates"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| [p[0].as_f64().unwrap(), p[1].as_f64().unwrap()])
        .collect()
}

/// The compact curve (`carry=spline`) decoded by `spherefit evaluate` and by `POST
/// /v1/evaluate` gives the points of the JSON spline of the same fit (`carry=both`, the same
/// precision): the decoding is lossless, so they agree to the output's 1e-9°, far inside the
/// 10^-4° grid; and every point lies within the reported two-way distance of the input line.
#[tokio::test]
async fn cli_and_service_decode_compact_curves_to_the_json_splines_points() {
    use axum::body::Body;
    use axum::http::Request;
    use tower::ServiceExt;
    let dir = scratch("agree");
    let input = fixture_path("us_mexico_border_natural_earth.geojson");
    let common = ["--tolerance-m", "100", "--precision", "4"];
    let (json_path, compact_path) = (dir.join("both.geojson"), dir.join("spline.geojson"));
    fit_to(
        &[&common[..], &["--carry", "both"]].concat(),
        &input,
        &json_path,
    );
    fit_to(
        &[&common[..], &["--carry", "spline"]].concat(),
        &input,
        &compact_path,
    );
    let evaluate = |p: &std::path::Path| {
        let o = run_spherefit(
            &[
                "evaluate",
                "-q",
                "--samples",
                "400",
                "--precision",
                "9",
                p.to_str().unwrap(),
            ],
            None,
        );
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        serde_json::from_slice::<Value>(&o.stdout).unwrap()
    };
    let from_json = evaluate(&json_path);
    let from_compact = evaluate(&compact_path);
    let compact_doc = read_json(&compact_path);
    let app = spherefit::service::router(spherefit::service::AppState::new(
        spherefit::service::ServiceConfig::default(),
    ));
    let res = app
        .oneshot(
            Request::post("/v1/evaluate?samples=400&precision=9")
                .header("content-type", "application/geo+json")
                .body(Body::from(serde_json::to_vec(&compact_doc).unwrap()))
                .unwrap(),
        )
        .await
        .unwrap();
    assert_eq!(res.status().as_u16(), 200);
    let bytes = axum::body::to_bytes(res.into_body(), usize::MAX)
        .await
        .unwrap();
    let from_service: Value = serde_json::from_slice(&bytes).unwrap();
    let source = crate::helpers::read_fixture_json("us_mexico_border_natural_earth.geojson");
    let n = from_json["features"].as_array().unwrap().len();
    assert_eq!(n, 3);
    for i in 0..n {
        let want = positions(&from_json["features"][i]["geometry"]);
        assert_eq!(want.len(), 400);
        let two_way = compact_doc["features"][i]["properties"]["fit"]["two_way_distance_m"]
            .as_f64()
            .unwrap();
        let line: Vec<[f64; 3]> = positions(&source["features"][i]["geometry"])
            .iter()
            .map(|p| lonlat_to_vec(p[0], p[1]))
            .collect();
        for (who, got) in [("CLI", &from_compact), ("service", &from_service)] {
            let got = positions(&got["features"][i]["geometry"]);
            assert_eq!(got.len(), want.len(), "{who}, feature {i}");
            for (j, (g, w)) in got.iter().zip(&want).enumerate() {
                let d = (g[0] - w[0]).abs().max((g[1] - w[1]).abs());
                assert!(
                    d <= 1e-9,
                    "{who}, feature {i}, point {j}: {g:?} against {w:?}"
                );
                let off = distance_to_polyline_m(lonlat_to_vec(g[0], g[1]), &line);
                // The samples are points of the certified curve (a 1e-9° rounding aside).
                assert!(
                    off <= two_way + 0.01,
                    "{who}, feature {i}, point {j}: {off} m from the line, two-way {two_way} m"
                );
            }
        }
    }
}
