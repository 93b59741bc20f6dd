//! Rings too small for the tolerance come back as valid rings in both modes (per feature and
//! `topology=shared`), with their feature and everything else the user sent: Natural Earth-style
//! islets of one repeated position, slivers, the Dutch parcels of georust's fixtures. Checked on
//! the written output: every ring closed with at least 4 positions and 3 distinct ones (or as it
//! came), every input vertex within the tolerance of its output ring, nothing dropped.
//! With `drop_small_rings` those rings are dropped instead, listed, in both modes and through
//! both the service and the command line.

use crate::helpers::EARTH_RADIUS_M;
use crate::helpers::{
    distance_to_arc, fixture_path, post_geo_oneshot, read_fixture_json, run_spherefit, unit3,
};
use serde_json::{json, Value};

type Ring = Vec<[f64; 2]>;

/// A Polygon's or MultiPolygon's rings, as polygons of rings.
fn polygons(g: &Value) -> Vec<Vec<Ring>> {
    let c: Value = g["coordinates"].clone();
    let as_ring = |r: &Value| -> Ring {
        r.as_array()
            .unwrap()
            .iter()
            .map(|p| [p[0].as_f64().unwrap(), p[1].as_f64().unwrap()])
            .collect()
    };
    let as_poly = |p: &Value| -> Vec<Ring> { p.as_array().unwrap().iter().map(as_ring).collect() };
    match g["type"].as_str().unwrap() {
        "Polygon" => vec![as_poly(&c)],
        "MultiPolygon" => c.as_array().unwrap().iter().map(as_poly).collect(),
        other => panic!("not a polygon: {other}"),
    }
}

fn distinct(r: &Ring) -> usize {
    let mut seen: Vec<[f64; 2]> = Vec::new();
    for p in r {
        if !seen.contains(p) {
            seen.push(*p);
        }
    }
    seen.len()
}

/// Largest distance (metres) from a vertex of `from` to the outline of `to` (great-circle edges).
fn max_to_outline_m(from: &Ring, to: &Ring) -> f64 {
    from.iter()
        .map(|q| {
            let q = unit3(q[0], q[1]);
            to.windows(2)
                .map(|w| distance_to_arc(&q, &unit3(w[0][0], w[0][1]), &unit3(w[1][0], w[1][1])))
                .fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max)
        * EARTH_RADIUS_M
}

fn fit(file: &str, tolerance_m: f64, topology: &str) -> (Value, String) {
    let out = run_spherefit(
        &[
            "fit",
            "--tolerance-m",
            &tolerance_m.to_string(),
            "--topology",
            topology,
            &fixture_path(file),
        ],
        None,
    );
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{topology}: {stderr}");
    (serde_json::from_slice(&out.stdout).unwrap(), stderr)
}

/// Checks every polygon feature of `output` against the same feature of `input`: the same
/// number of polygons and rings, each ring closed with at least 4 positions and 3 distinct ones
/// unless its input had fewer, and each input vertex within `tolerance_m` of its output ring.
/// Returns the number of rings checked.
fn check_rings(input: &Value, output: &Value, tolerance_m: f64, mode: &str) -> usize {
    let (fin, fout) = (
        input["features"].as_array().unwrap(),
        output["features"].as_array().unwrap(),
    );
    assert_eq!(fin.len(), fout.len(), "{mode}: every feature comes back");
    let mut rings = 0;
    for (i, (a, b)) in fin.iter().zip(fout).enumerate() {
        if !a["geometry"]["type"].as_str().unwrap().ends_with("Polygon") {
            assert_eq!(
                a["geometry"], b["geometry"],
                "{mode}: feature {i} passes through"
            );
            continue;
        }
        let (pa, pb) = (polygons(&a["geometry"]), polygons(&b["geometry"]));
        assert_eq!(pa.len(), pb.len(), "{mode}: feature {i}'s polygons");
        for (j, (ra, rb)) in pa.iter().zip(&pb).enumerate() {
            assert_eq!(
                ra.len(),
                rb.len(),
                "{mode}: feature {i} polygon {j}'s rings"
            );
            for (k, (x, y)) in ra.iter().zip(rb).enumerate() {
                rings += 1;
                let at = format!("{mode}: feature {i} polygon {j} ring {k}: {y:?}");
                assert!(y.len() >= 4, "{at}: fewer than 4 positions");
                assert_eq!(y.first(), y.last(), "{at}: not closed");
                assert!(distinct(y) >= distinct(x).min(3), "{at}: bounds no area");
                let d = max_to_outline_m(x, y);
                assert!(d <= tolerance_m, "{at}: an input vertex {d} m away");
            }
        }
    }
    rings
}

#[test]
fn islets_and_slivers_are_kept_with_their_feature_in_both_modes() {
    let input = read_fixture_json("small_rings.geojson");
    for mode in ["per-feature", "shared"] {
        let (out, _) = fit("small_rings.geojson", 1000.0, mode);
        assert_eq!(check_rings(&input, &out, 1000.0, mode), 6);
        let islands = &out["features"][0];
        assert_eq!(islands["id"], "islands");
        assert_eq!(islands["properties"]["name"], "islands");
        assert_eq!(
            islands["geometry"]["source"], "synthetic",
            "{mode}: a foreign member of the geometry comes back"
        );
        // The islet of one repeated position comes back as it came.
        assert_eq!(
            islands["geometry"]["coordinates"][1],
            json!([[[5.0, 40.0], [5.0, 40.0], [5.0, 40.0], [5.0, 40.0]]])
        );
        assert_eq!(
            islands["properties"]["fit"]["kept_rings"],
            json!([
                "/features/0/geometry/coordinates/1/0",
                "/features/0/geometry/coordinates/2/0",
                "/features/0/geometry/coordinates/3/0"
            ]),
            "{mode}"
        );
        assert_eq!(
            out["features"][1]["properties"]["fit"]["kept_rings"],
            json!(["/features/1/geometry/coordinates/1"]),
            "{mode}: the sliver hole"
        );
        assert_eq!(
            out["features"][2]["geometry"],
            json!({"type": "MultiPoint", "coordinates": [[1, 2], [3, 4, 5]]}),
            "{mode}: a geometry that is not fitted passes through whatever its dimensions"
        );
    }
}

#[test]
fn the_dutch_parcels_come_back_as_valid_rings_in_both_modes() {
    let input = read_fixture_json("nl_plots.geojson");
    let input = json!({"type": "FeatureCollection", "features": [input]});
    for mode in ["per-feature", "shared"] {
        for tolerance_m in [100.0, 1000.0] {
            let (out, _) = fit("nl_plots.geojson", tolerance_m, mode);
            assert_eq!(check_rings(&input, &out, tolerance_m, mode), 343);
            // Parcels a fit would push into each other are refitted tighter (down to 1 cm,
            // which rounding alone can exceed): the user's tolerance is still met, and said so.
            let fit = &out["features"][0]["properties"]["fit"];
            assert_eq!(fit["tolerance_met"], true, "{mode} {tolerance_m}");
            for part in fit["parts"].as_array().into_iter().flatten() {
                // Shared fits list each ring's arcs; their arcs' reports are the document's.
                if mode == "per-feature" {
                    assert_eq!(part["tolerance_met"], true, "{mode} {tolerance_m}: {part}");
                }
            }
        }
    }
}

#[test]
fn a_property_named_fit_is_refused_with_its_pointer_not_overwritten() {
    let doc = json!({"type": "Feature", "properties": {"fit": "good"},
        "geometry": {"type": "LineString", "coordinates": [[0, 0], [1, 1], [2, 0]]}});
    let out = run_spherefit(
        &["fit", "--tolerance-m", "100", "-"],
        Some(doc.to_string().as_bytes()),
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("/properties/fit"), "{stderr}");
    // A report spherefit wrote is replaced: a fitted output can be fitted again.
    let first = run_spherefit(
        &["fit", "--tolerance-m", "100", "-"],
        Some(
            json!({"type": "Feature", "properties": {},
            "geometry": doc["geometry"]})
            .to_string()
            .as_bytes(),
        ),
    );
    assert!(first.status.success());
    let again = run_spherefit(&["fit", "--tolerance-m", "100", "-"], Some(&first.stdout));
    assert!(
        again.status.success(),
        "{}",
        String::from_utf8_lossy(&again.stderr)
    );
}

/// The fixture fitted with `drop_small_rings`, through the command line and the service.
fn fit_dropping(doc: &Value, mode: &str) -> [Value; 2] {
    let out = run_spherefit(
        &[
            "fit",
            "--tolerance-m",
            "1000",
            "--topology",
            mode,
            "--drop-small-rings",
            "-",
        ],
        Some(doc.to_string().as_bytes()),
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{mode}: {stderr}");
    let cli: Value = serde_json::from_slice(&out.stdout).unwrap();
    let (status, _, http) = post_geo_oneshot(
        &format!("/v1/fit?tolerance_m=1000&topology={mode}&drop_small_rings=true"),
        doc,
    );
    assert_eq!(status, 200, "{mode}: {http}");
    [cli, http]
}

#[test]
fn drop_small_rings_drops_and_lists_them_in_both_modes_through_both_front_ends() {
    let input = read_fixture_json("small_rings.geojson");
    for mode in ["per-feature", "shared"] {
        for out in fit_dropping(&input, mode) {
            let islands = &out["features"][0];
            assert_eq!(islands["id"], "islands", "{mode}: the feature stays");
            assert_eq!(islands["properties"]["name"], "islands");
            // Only the 3-degree square is left; the islet, the triangle and the sliver went.
            assert_eq!(
                islands["geometry"]["coordinates"].as_array().unwrap().len(),
                1,
                "{mode}: {}",
                islands["geometry"]
            );
            let fit = &islands["properties"]["fit"];
            assert_eq!(
                fit["dropped_rings"],
                json!([
                    "/features/0/geometry/coordinates/1/0",
                    "/features/0/geometry/coordinates/2/0",
                    "/features/0/geometry/coordinates/3/0"
                ]),
                "{mode}"
            );
            assert_eq!(fit["kept_rings"], json!([]), "{mode}");
            let sliver = &out["features"][1];
            assert_eq!(
                sliver["properties"]["fit"]["dropped_rings"],
                json!(["/features/1/geometry/coordinates/1"]),
                "{mode}: the sliver hole"
            );
            let rings = polygons(&sliver["geometry"]);
            assert_eq!(
                (rings.len(), rings[0].len()),
                (1, 1),
                "{mode}: the exterior without its hole"
            );
            assert_eq!(
                out["features"][2]["geometry"]["type"], "MultiPoint",
                "{mode}: other geometries pass through"
            );
        }
    }
}

#[test]
fn a_dropped_exterior_takes_its_holes_and_an_emptied_feature_stays_with_an_empty_geometry() {
    // An islet 100 m across with a hole: at 1 km both go; the feature and its properties stay.
    let doc = json!({"type": "FeatureCollection", "features": [
        {"type": "Feature", "id": 1, "properties": {"name": "islet"}, "geometry": {
            "type": "Polygon", "coordinates": [
                [[20.0, 40.0], [20.001, 40.0], [20.001, 40.001], [20.0, 40.001], [20.0, 40.0]],
                [[20.0004, 40.0004], [20.0006, 40.0004], [20.0006, 40.0006], [20.0004, 40.0004]]
            ]}},
        {"type": "Feature", "id": 2, "properties": {}, "geometry": {
            "type": "Polygon", "coordinates": [[[30, 40], [33, 40], [33, 43], [30, 43], [30, 40]]]}}
    ]});
    for mode in ["per-feature", "shared"] {
        for out in fit_dropping(&doc, mode) {
            let islet = &out["features"][0];
            assert_eq!(
                (&islet["id"], &islet["properties"]["name"]),
                (&json!(1), &json!("islet"))
            );
            assert_eq!(
                islet["geometry"],
                json!({"type": "MultiPolygon", "coordinates": []}),
                "{mode}"
            );
            assert_eq!(
                islet["properties"]["fit"]["dropped_rings"],
                json!([
                    "/features/0/geometry/coordinates/0",
                    "/features/0/geometry/coordinates/1"
                ]),
                "{mode}"
            );
            assert_eq!(
                polygons(&out["features"][1]["geometry"]).len(),
                1,
                "{mode}: the large polygon is fitted as usual"
            );
        }
    }
    // Without the option the islet is kept (as a small valid ring) and nothing is dropped.
    let (status, _, kept) = post_geo_oneshot("/v1/fit?tolerance_m=1000", &doc);
    assert_eq!(status, 200);
    assert_eq!(polygons(&kept["features"][0]["geometry"]).len(), 1);
    assert!(kept["features"][0]["properties"]["fit"]
        .get("dropped_rings")
        .is_none());
}

#[test]
fn drop_small_rings_is_refused_where_it_means_nothing() {
    let line = json!({"type": "LineString", "coordinates": [[0, 0], [1, 1], [2, 0]]});
    let (status, _, problem) = post_geo_oneshot("/v1/fit?drop_small_rings=maybe", &line);
    assert_eq!(status, 400, "{problem}");
    assert_eq!(problem["parameter"], "drop_small_rings");
    let (status, _, problem) = post_geo_oneshot("/v1/interpolate?drop_small_rings=true", &line);
    assert_eq!(status, 400, "{problem}");
    let out = run_spherefit(&["interpolate", "--drop-small-rings", "-"], None);
    assert_eq!(out.status.code(), Some(2), "not a flag of interpolate");
}
