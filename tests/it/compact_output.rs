//! Outputs sized by the tolerance (#30): with `tolerance_m` and no `precision`, coordinates are
//! written at the decimals the tolerance needs and the certified bound is that of the rounded
//! curve; `carry` chooses geometry, spline or both.

use crate::helpers::{distance_to_arc, fixture_path, lonlat_to_unit, run_spherefit};
use serde_json::Value;

fn fit(args: &[&str]) -> Value {
    let mut all = vec!["fit", "-q"];
    all.extend_from_slice(args);
    let border = fixture_path("us_mexico_border_natural_earth.geojson");
    all.push(&border);
    let out = run_spherefit(&all, None);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("JSON out")
}

/// Most decimals of any coordinate of the geometries.
fn most_decimals(v: &Value) -> usize {
    match v {
        Value::Array(a) => a.iter().map(most_decimals).max().unwrap_or(0),
        Value::Number(n) => n.to_string().split('.').nth(1).map_or(0, str::len),
        _ => 0,
    }
}

#[test]
fn a_tolerance_writes_the_decimals_it_needs_and_the_bound_covers_them() {
    let sized = fit(&["--tolerance-m", "100", "--carry", "geometry"]);
    let full = fit(&[
        "--tolerance-m",
        "100",
        "--carry",
        "geometry",
        "--precision",
        "7",
    ]);
    for (f, g) in sized["features"]
        .as_array()
        .unwrap()
        .iter()
        .zip(full["features"].as_array().unwrap())
    {
        assert!(most_decimals(&f["geometry"]["coordinates"]) <= 4);
        assert!(most_decimals(&g["geometry"]["coordinates"]) > 4);
        let fit = &f["properties"]["fit"];
        assert_eq!(fit["tolerance_met"], true, "{fit}");
        assert!(fit["two_way_distance_m"].as_f64().unwrap() <= 100.0);
    }
    let bytes = |v: &Value| serde_json::to_vec(v).unwrap().len();
    assert!(bytes(&sized) < bytes(&full), "fewer decimals, fewer bytes");
}

#[test]
fn carry_writes_geometry_spline_or_both_and_evaluate_draws_the_spline() {
    let p4 = ["--tolerance-m", "100", "--precision", "4"];
    let both = fit(&p4);
    let geometry = fit(&[&p4[..], &["--carry", "geometry"]].concat());
    let spline = fit(&[&p4[..], &["--carry", "spline"]].concat());
    for i in 0..3 {
        let (b, g, s) = (
            &both["features"][i],
            &geometry["features"][i],
            &spline["features"][i],
        );
        assert_eq!(g["geometry"], b["geometry"]);
        assert!(g["properties"]["fit"].get("spline").is_none());
        // Without the curve, the bound is the geometry's: the curve's plus its samples'
        // deviation (rounding included).
        let (bf, gf) = (&b["properties"]["fit"], &g["properties"]["fit"]);
        let both_bound = bf["two_way_distance_m"].as_f64().unwrap()
            + bf["sampling_deviation_m"].as_f64().unwrap();
        let geometry_bound = gf["two_way_distance_m"].as_f64().unwrap();
        assert!(
            (geometry_bound - both_bound).abs() <= 0.0015,
            "{geometry_bound} against {both_bound}"
        );
        assert!(s["geometry"].is_null());
        // The spline as a compact curve: base64 text, a fraction of the JSON document.
        let compact = s["properties"]["fit"]["spline"]
            .as_str()
            .expect("base64 text");
        // A degree-1 spline's JSON refers to the geometry (written once); the geometry itself,
        // the same positions, takes several times the compact curve's bytes.
        assert_eq!(
            b["properties"]["fit"]["spline"]["control_points"],
            "geometry"
        );
        let positions = serde_json::to_string(&b["geometry"]["coordinates"]).unwrap();
        assert!(
            compact.len() * 2 < positions.len(),
            "{} vs {}",
            compact.len(),
            positions.len()
        );
    }
    // The spline alone is drawn again by evaluate: the same positions as `both` wrote (the
    // fits here are degree 1, whose curve is its geometry).
    let dir = std::env::temp_dir().join(format!("spherefit-carry-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("spline.geojson");
    std::fs::write(&path, serde_json::to_vec(&spline).unwrap()).unwrap();
    let out = run_spherefit(
        &["evaluate", "-q", "--precision", "4", path.to_str().unwrap()],
        None,
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let drawn: Value = serde_json::from_slice(&out.stdout).unwrap();
    for i in 0..3 {
        assert_eq!(drawn["features"][i]["properties"]["fit"]["degree"], 1);
        assert_eq!(
            drawn["features"][i]["geometry"], both["features"][i]["geometry"],
            "feature {i}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
    // Not an option of evaluate.
    let out = run_spherefit(&["evaluate", "--carry", "spline", "-"], Some(b"{}"));
    assert_eq!(out.status.code(), Some(2));
}

/// A corrupt compact curve is a clear error with where: a failed record with the message and
/// the pointer from the CLI, and exit status 2 (corrupt input, not a fit that failed).
#[test]
fn a_hostile_compact_curve_is_an_error_with_where() {
    let spline = fit(&["--tolerance-m", "100", "--carry", "spline"]);
    let mut bad = spline["features"][0].clone();
    let text = bad["properties"]["fit"]["spline"]
        .as_str()
        .unwrap()
        .to_string();
    // Version 2: the first byte's base64 digits ('A' 'Q' -> 'A' 'g').
    bad["properties"]["fit"]["spline"] = Value::String(format!("Ag{}", &text[2..]));
    let out = run_spherefit(&["evaluate", "-"], Some(&serde_json::to_vec(&bad).unwrap()));
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("version 2")
            && err.contains("/properties/fit/spline")
            && err.contains("does not decode"),
        "{err}"
    );
    // Truncated: the header promises more than the bytes hold.
    bad["properties"]["fit"]["spline"] = Value::String(text[..12].to_string());
    let out = run_spherefit(&["evaluate", "-"], Some(&serde_json::to_vec(&bad).unwrap()));
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("byte"), "{err}");
}

/// The service decodes a compact curve in `POST /v1/evaluate` and refuses a hostile one with
/// 422 and a pointer to it.
#[tokio::test]
async fn the_service_evaluates_compact_curves_and_points_at_bad_ones() {
    use axum::body::Body;
    use axum::http::Request;
    use tower::ServiceExt;
    let app = spherefit::service::router(spherefit::service::AppState::new(
        spherefit::service::ServiceConfig::default(),
    ));
    let post = |uri: &'static str, body: Value| {
        let app = app.clone();
        async move {
            let res = app
                .oneshot(
                    Request::post(uri)
                        .header("content-type", "application/geo+json")
                        .body(Body::from(serde_json::to_vec(&body).unwrap()))
                        .unwrap(),
                )
                .await
                .unwrap();
            let status = res.status().as_u16();
            let bytes = axum::body::to_bytes(res.into_body(), usize::MAX)
                .await
                .unwrap();
            (status, serde_json::from_slice::<Value>(&bytes).unwrap())
        }
    };
    let input = crate::helpers::read_fixture_json("us_mexico_border_natural_earth.geojson");
    let (s, fitted) = post("/v1/fit?tolerance_m=100&carry=spline", input.clone()).await;
    assert_eq!(s, 200, "{fitted}");
    assert!(fitted["features"][1]["geometry"].is_null());
    let (s, drawn) = post("/v1/evaluate", fitted.clone()).await;
    assert_eq!(s, 200, "{drawn}");
    let (_, both) = post("/v1/fit?tolerance_m=100&precision=4", input).await;
    assert_eq!(
        drawn["features"][1]["geometry"],
        both["features"][1]["geometry"]
    );
    let mut bad = fitted;
    bad["features"][1]["properties"]["fit"]["spline"] = Value::String("AQQBHAC/".into());
    let (s, problem) = post("/v1/evaluate", bad).await;
    assert_eq!(s, 422, "{problem}");
    assert_eq!(
        problem["pointer"], "/features/1/properties/fit/spline",
        "{problem}"
    );
    assert!(
        problem["detail"].as_str().unwrap().contains("byte"),
        "{problem}"
    );
}

/// LEB128, as the compact stream writes its integers.
fn varint(mut v: u64) -> Vec<u8> {
    let mut out = Vec::new();
    loop {
        let b = (v & 0x7f) as u8;
        v >>= 7;
        if v == 0 {
            out.push(b);
            return out;
        }
        out.push(b | 0x80);
    }
}

/// Every kind of hostile compact curve, in the second feature of a real `carry=spline` fit:
/// the service answers 422 problem+json (`invalid-spline`) with the pointer to the string and
/// the byte (or character) in `detail`; the CLI reports the record, the pointer and the same
/// detail on stderr, writes the other features and exits 1, as for any record that cannot be
/// processed (docs/cli.md: 2 is for usage and input that cannot be read at all).
#[tokio::test]
async fn every_kind_of_hostile_compact_curve_is_a_422_and_a_failed_record_naming_where() {
    use axum::body::Body;
    use axum::http::Request;
    use base64::engine::general_purpose::STANDARD;
    use base64::Engine as _;
    use tower::ServiceExt;
    let fitted = fit(&["--tolerance-m", "100", "--carry", "spline"]);
    let good = STANDARD
        .decode(
            fitted["features"][1]["properties"]["fit"]["spline"]
                .as_str()
                .unwrap(),
        )
        .unwrap();
    let half = 0.5f64.to_bits();
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        (
            "wrong version",
            [&[2u8][..], &good[1..]].concat(),
            "version 2 at byte 0",
        ),
        (
            "counts beyond the bytes",
            [&[1u8, 3, 1][..], &varint(5000), &[0]].concat(),
            "promises",
        ),
        ("truncated", good[..5].to_vec(), "bytes left"),
        (
            "varint over 64 bits",
            [&[1u8, 3, 1, 3, 0][..], &[0xff; 11], &[0; 6]].concat(),
            "longer than 64 bits",
        ),
        (
            "decreasing knots",
            [
                &[1u8, 3, 1, 3, 5][..],
                &varint(half),
                &varint(0x8000_0000_0000_0001 - half),
                &[0; 9],
            ]
            .concat(),
            "knot 1 at byte",
        ),
        (
            "trailing bytes",
            [&good[..], &[0]].concat(),
            "after the last control point",
        ),
    ];
    let app = spherefit::service::router(spherefit::service::AppState::new(
        spherefit::service::ServiceConfig::default(),
    ));
    let mut texts: Vec<(&str, String, &str)> = cases
        .into_iter()
        .map(|(what, b, msg)| (what, STANDARD.encode(b), msg))
        .collect();
    texts.push(("not base64", "AQ!=".into(), "not base64: character 2"));
    for (what, text, message) in texts {
        let mut bad = fitted.clone();
        bad["features"][1]["properties"]["fit"]["spline"] = Value::String(text);
        let body = serde_json::to_vec(&bad).unwrap();
        let res = app
            .clone()
            .oneshot(
                Request::post("/v1/evaluate")
                    .header("content-type", "application/geo+json")
                    .body(Body::from(body.clone()))
                    .unwrap(),
            )
            .await
            .unwrap();
        assert_eq!(res.status().as_u16(), 422, "{what}");
        assert_eq!(
            res.headers()["content-type"],
            "application/problem+json",
            "{what}"
        );
        let bytes = axum::body::to_bytes(res.into_body(), usize::MAX)
            .await
            .unwrap();
        let problem: Value = serde_json::from_slice(&bytes).unwrap();
        assert_eq!(
            problem["pointer"], "/features/1/properties/fit/spline",
            "{what}: {problem}"
        );
        assert!(
            problem["type"]
                .as_str()
                .unwrap()
                .ends_with("invalid-spline"),
            "{what}: {problem}"
        );
        let detail = problem["detail"].as_str().unwrap();
        assert!(detail.contains(message), "{what}: {detail}");
        let out = run_spherefit(&["evaluate", "-q", "-"], Some(&body));
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{what}: {err}");
        assert!(
            err.contains("record 2: /features/1/properties/fit/spline"),
            "{what}: {err}"
        );
        assert!(err.contains(message), "{what}: {err}");
        let written: Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(
            written["features"].as_array().unwrap().len(),
            2,
            "{what}: the other features are written"
        );
    }
}

/// With `carry=both`, a degree-1 spline's control points are its geometry's positions: the
/// spline says so (`"control_points": "geometry"`, uniform knots left out) instead of writing
/// them again, and `evaluate` reads them back from the geometry, for a LineString's own spline
/// and for the parts of a MultiLineString, giving the same geometry.
#[test]
fn a_degree_one_fit_is_written_once_and_evaluates_to_the_same_geometry() {
    let input = crate::helpers::read_fixture_json("us_mexico_border_natural_earth.geojson");
    let lines: Vec<Value> = input["features"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["geometry"]["coordinates"].clone())
        .collect();
    let multi = serde_json::json!({"type": "FeatureCollection", "features": [
        input["features"][2].clone(),
        {"type": "Feature", "properties": {},
         "geometry": {"type": "MultiLineString", "coordinates": [lines[0], lines[1]]}},
    ]});
    let run = |args: &[&str], stdin: &Value| -> Value {
        let out = run_spherefit(args, Some(&serde_json::to_vec(stdin).unwrap()));
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        serde_json::from_slice(&out.stdout).unwrap()
    };
    let both = run(&["fit", "-q", "--tolerance-m", "100", "-"], &multi);
    let geometry_only = run(
        &[
            "fit",
            "-q",
            "--tolerance-m",
            "100",
            "--carry",
            "geometry",
            "--precision",
            "7",
            "-",
        ],
        &multi,
    );
    let line = &both["features"][0]["properties"]["fit"];
    let parts = both["features"][1]["properties"]["fit"]["parts"]
        .as_array()
        .unwrap();
    let splines: Vec<&Value> = std::iter::once(&line["spline"])
        .chain(parts.iter().map(|p| &p["spline"]))
        .collect();
    for s in &splines {
        assert_eq!(s["degree"], 1, "{s}");
        assert_eq!(s["control_points"], "geometry", "{s}");
        assert!(s.get("knots").is_none(), "uniform knots left out: {s}");
    }
    // Written once: the spline adds a few bytes, not a second copy of the positions.
    let bytes = |v: &Value| serde_json::to_vec(v).unwrap().len();
    let positions = bytes(&both["features"][0]["geometry"]);
    assert!(
        bytes(&both["features"][0]) < bytes(&geometry_only["features"][0]) + positions / 4,
        "{} vs {} + {}",
        bytes(&both["features"][0]),
        bytes(&geometry_only["features"][0]),
        positions
    );
    let drawn = run(&["evaluate", "-q", "--precision", "7", "-"], &both);
    for i in 0..2 {
        assert_eq!(
            drawn["features"][i]["geometry"], both["features"][i]["geometry"],
            "feature {i}"
        );
    }
    // Without the geometry the marker stands for nothing: an invalid-spline error pointing at it.
    let mut orphan = both["features"][1].clone();
    orphan["geometry"] = Value::Null;
    let out = run_spherefit(
        &["evaluate", "-"],
        Some(&serde_json::to_vec(&orphan).unwrap()),
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("/properties/fit/parts/0/spline/control_points")
            && err.contains("no geometry"),
        "{err}"
    );
    // A bare spline document has no geometry to refer to.
    let bare = serde_json::json!({"crs": "lonlat", "degree": 1, "control_points": "geometry"});
    let out = run_spherefit(
        &["evaluate", "-"],
        Some(&serde_json::to_vec(&bare).unwrap()),
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_ne!(out.status.code(), Some(0), "{err}");
    assert!(err.contains("control_points"), "{err}");
}

/// The largest distance from a point of `a` (every vertex and 7 points inside each step) to the
/// polyline `b`, metres: a sampled directed Hausdorff distance, never above the true one.
fn sampled_directed_m(a: &[Vec<f64>], b: &[Vec<f64>]) -> f64 {
    let mut worst: f64 = 0.0;
    for w in a.windows(2) {
        for k in 0..8 {
            let f = k as f64 / 8.0;
            let q: Vec<f64> = (0..3).map(|i| w[0][i] * (1.0 - f) + w[1][i] * f).collect();
            let n = q.iter().map(|x| x * x).sum::<f64>().sqrt();
            let q: Vec<f64> = q.iter().map(|x| x / n).collect();
            let d = b
                .windows(2)
                .map(|s| distance_to_arc(&q, &s[0], &s[1]))
                .fold(f64::INFINITY, f64::min);
            worst = worst.max(d);
        }
    }
    worst * 6_371_008.8
}

/// With `carry=geometry` the report's two-way distance bounds the geometry as written: a
/// smooth curve's samples, rounded to the tolerance's 3 decimals, were written 762.8 m from
/// this land ring while its report said 715.5 m (the curve's distance alone).
#[test]
fn a_geometry_only_fit_reports_the_distance_of_the_geometry_it_writes() {
    let path = fixture_path("world_atlas_land_10m_ring_3441.geojson");
    let input: Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    let line: Vec<Vec<f64>> = input["features"][0]["geometry"]["coordinates"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| lonlat_to_unit(p[0].as_f64().unwrap(), p[1].as_f64().unwrap()))
        .collect();
    let out = run_spherefit(
        &[
            "fit",
            "-q",
            "--tolerance-m",
            "880",
            "--carry",
            "geometry",
            &path,
        ],
        None,
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let fitted: Value = serde_json::from_slice(&out.stdout).unwrap();
    let f = &fitted["features"][0];
    let written: Vec<Vec<f64>> = f["geometry"]["coordinates"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| lonlat_to_unit(p[0].as_f64().unwrap(), p[1].as_f64().unwrap()))
        .collect();
    let measured = sampled_directed_m(&written, &line).max(sampled_directed_m(&line, &written));
    let reported = f["properties"]["fit"]["two_way_distance_m"]
        .as_f64()
        .unwrap();
    assert!(
        measured > 750.0,
        "the case is still the one it was: {measured}"
    );
    assert!(
        measured <= reported,
        "written {measured} m from the line, reported {reported} m"
    );
    assert_eq!(f["properties"]["fit"]["tolerance_met"], reported <= 880.0);
}
