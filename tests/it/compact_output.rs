//! Outputs sized by the tolerance (#30): with `tolerance_m` and no `precision`, coordinates are
//! written at the decimals the tolerance needs and the certified bound is that of the rounded
//! curve; `carry` chooses geometry, spline or both.

use crate::helpers::{fixture_path, run_spherefit};
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
    let sized = fit(&["--tolerance-m", "100"]);
    let full = fit(&["--tolerance-m", "100", "--precision", "7"]);
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
        assert!(most_decimals(&fit["spline"]["control_points"]) <= 4);
    }
    let bytes = |v: &Value| serde_json::to_vec(v).unwrap().len();
    assert!(bytes(&sized) < bytes(&full), "fewer decimals, fewer bytes");
}

#[test]
fn carry_writes_geometry_spline_or_both_and_evaluate_draws_the_spline() {
    let both = fit(&["--tolerance-m", "100"]);
    let geometry = fit(&["--tolerance-m", "100", "--carry", "geometry"]);
    let spline = fit(&["--tolerance-m", "100", "--carry", "spline"]);
    for i in 0..3 {
        let (b, g, s) = (
            &both["features"][i],
            &geometry["features"][i],
            &spline["features"][i],
        );
        assert_eq!(g["geometry"], b["geometry"]);
        assert!(g["properties"]["fit"].get("spline").is_none());
        assert_eq!(
            g["properties"]["fit"]["two_way_distance_m"],
            b["properties"]["fit"]["two_way_distance_m"]
        );
        assert!(s["geometry"].is_null());
        assert_eq!(
            s["properties"]["fit"]["spline"],
            b["properties"]["fit"]["spline"]
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
