//! Polygons across ±180 and around the poles, in both modes (per feature and
//! `topology=shared`): cut where the fitted curve crosses ±180, polar caps closed along the
//! pole, input already cut that way rejoined first. Checked on the written output against the
//! input as a region on the sphere (great-circle edges, the cut's own edges along ±180 and the
//! poles left out): every input vertex within T of the output outline, every output vertex
//! within T of the input outline, the area within 2 T x perimeter, every ring closed with at
//! least 4 positions and every polygon valid in the lon/lat plane (geo's `Validation`).

use crate::helpers::{distance_to_arc, fixture_path, run_spherefit, unit3, EARTH_RADIUS_M};
use geo::{Coord, LineString, Polygon, Validation};
use serde_json::{json, Value};

type Ring = Vec<[f64; 2]>;

fn polygons(g: &Value) -> Vec<Vec<Ring>> {
    let as_ring = |r: &Value| -> Ring {
        r.as_array()
            .unwrap()
            .iter()
            .map(|p| [p[0].as_f64().unwrap(), p[1].as_f64().unwrap()])
            .collect()
    };
    let as_poly = |p: &Value| -> Vec<Ring> { p.as_array().unwrap().iter().map(as_ring).collect() };
    match g["type"].as_str().unwrap() {
        "Polygon" => vec![as_poly(&g["coordinates"])],
        "MultiPolygon" => g["coordinates"]
            .as_array()
            .unwrap()
            .iter()
            .map(as_poly)
            .collect(),
        other => panic!("not a polygon: {other}"),
    }
}

fn on_cut(p: &[f64; 2]) -> bool {
    p[0].abs() == 180.0 || p[1].abs() == 90.0
}

/// An edge of the cut (along a ±180 meridian, or at a pole), not of the outline.
fn cut_edge(a: &[f64; 2], b: &[f64; 2]) -> bool {
    (a[0].abs() == 180.0 && a[0] == b[0]) || a[1].abs() == 90.0 || b[1].abs() == 90.0
}

/// The outline's edges as unit-vector pairs, cut edges left out.
fn outline(polys: &[Vec<Ring>]) -> Vec<([f64; 3], [f64; 3])> {
    polys
        .iter()
        .flatten()
        .flat_map(|r| r.windows(2))
        .filter(|w| !cut_edge(&w[0], &w[1]))
        .map(|w| (unit3(w[0][0], w[0][1]), unit3(w[1][0], w[1][1])))
        .collect()
}

/// Largest distance (m) from a vertex of `from` (off the cut) to the edges `to`.
fn max_to_outline_m(from: &[Vec<Ring>], to: &[([f64; 3], [f64; 3])]) -> f64 {
    from.iter()
        .flatten()
        .flatten()
        .filter(|p| !on_cut(p))
        .map(|p| {
            let q = unit3(p[0], p[1]);
            to.iter()
                .map(|(a, b)| distance_to_arc(&q, a, b))
                .fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max)
        * EARTH_RADIUS_M
}

/// Area (m^2) of a ring with great-circle edges, the smaller of the two regions it bounds
/// (d3-geo's sum of signed lunes; independent of how longitudes are written).
fn ring_area_m2(r: &Ring) -> f64 {
    let mut sum = 0.0;
    for w in r.windows(2) {
        let (l0, p0) = (
            w[0][0].to_radians(),
            w[0][1].to_radians() / 2.0 + std::f64::consts::FRAC_PI_4,
        );
        let (l1, p1) = (
            w[1][0].to_radians(),
            w[1][1].to_radians() / 2.0 + std::f64::consts::FRAC_PI_4,
        );
        let mut d = l1 - l0;
        d -= std::f64::consts::TAU * (d / std::f64::consts::TAU).round();
        let k = p0.sin() * p1.sin();
        let u = p0.cos() * p1.cos() + k * d.abs().cos();
        let v = k * d.signum() * d.abs().sin();
        sum += v.atan2(u);
    }
    let a = (2.0 * sum).rem_euclid(4.0 * std::f64::consts::PI);
    a.min(4.0 * std::f64::consts::PI - a) * EARTH_RADIUS_M * EARTH_RADIUS_M
}

fn area_m2(polys: &[Vec<Ring>]) -> f64 {
    polys
        .iter()
        .map(|p| ring_area_m2(&p[0]) - p[1..].iter().map(ring_area_m2).sum::<f64>())
        .sum()
}

fn perimeter_m(edges: &[([f64; 3], [f64; 3])]) -> f64 {
    edges
        .iter()
        .map(|(a, b)| crate::helpers::angle(a, b))
        .sum::<f64>()
        * EARTH_RADIUS_M
}

fn fit(geometry: &Value, tolerance_m: f64, topology: &str) -> Value {
    let doc = json!({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"name": "x"}, "geometry": geometry}]});
    let out = run_spherefit(
        &[
            "fit",
            "--tolerance-m",
            &tolerance_m.to_string(),
            "--topology",
            topology,
            "-",
        ],
        Some(doc.to_string().as_bytes()),
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{topology}: {stderr}");
    let out: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(out["features"][0]["properties"]["name"], "x");
    out["features"][0].clone()
}

/// Fits `geometry` at `tolerance_m` in both modes and checks the output as the module docs
/// say; returns the output geometries (per feature, shared).
fn check(name: &str, geometry: &Value, tolerance_m: f64) -> Vec<Value> {
    check_in(name, geometry, tolerance_m, &["per-feature", "shared"])
}

/// [`check`] in the given modes only.
fn check_in(name: &str, geometry: &Value, tolerance_m: f64, modes: &[&str]) -> Vec<Value> {
    let mut outs = Vec::new();
    for &mode in modes {
        let at = format!("{name} ({mode}, {tolerance_m} m)");
        let feature = fit(geometry, tolerance_m, mode);
        check_output(&at, geometry, &feature["geometry"], tolerance_m, true);
        outs.push(feature["geometry"].clone());
    }
    outs
}

/// Checks one fitted polygon geometry against its input as the module docs say: every ring
/// closed with at least 4 positions in range, every polygon valid in the lon/lat plane (where
/// `valid_input` says the input was), every input vertex off the seam within the tolerance of
/// the output outline and back, the spherical area within 2 T x perimeter.
fn check_output(at: &str, geometry: &Value, output: &Value, tolerance_m: f64, valid_input: bool) {
    let input = polygons(geometry);
    let input_outline = outline(&input);
    let slack = tolerance_m * 1e-3 + 0.05;
    let output = polygons(output);
    for (i, poly) in output.iter().enumerate() {
        for r in poly {
            assert!(
                r.len() >= 4,
                "{at}: polygon {i}: a ring of {} positions",
                r.len()
            );
            assert_eq!(r.first(), r.last(), "{at}: polygon {i}: a ring not closed");
            assert!(
                r.iter()
                    .all(|p| (-180.0..=180.0).contains(&p[0]) && (-90.0..=90.0).contains(&p[1])),
                "{at}: polygon {i} out of range"
            );
        }
        let ls = |r: &Ring| LineString::new(r.iter().map(|p| Coord { x: p[0], y: p[1] }).collect());
        let g = Polygon::new(ls(&poly[0]), poly[1..].iter().map(ls).collect());
        assert!(
            !valid_input || g.is_valid(),
            "{at}: polygon {i} is not valid: {:?}",
            g.validation_errors()
        );
    }
    let output_outline = outline(&output);
    let d_in = max_to_outline_m(&input, &output_outline);
    assert!(
        d_in <= tolerance_m + slack,
        "{at}: an input vertex {d_in:.1} m from the output"
    );
    let d_out = max_to_outline_m(&output, &input_outline);
    assert!(
        d_out <= tolerance_m + slack,
        "{at}: an output vertex {d_out:.1} m from the input"
    );
    let (a_in, a_out) = (area_m2(&input), area_m2(&output));
    let bound = 2.0 * tolerance_m * perimeter_m(&input_outline);
    assert!(
        (a_out - a_in).abs() <= bound,
        "{at}: area {a_in:.4e} -> {a_out:.4e} m^2 (bound {bound:.3e})"
    );
}

fn load(name: &str) -> Value {
    let v: Value =
        serde_json::from_str(&std::fs::read_to_string(fixture_path(name)).unwrap()).unwrap();
    if v["type"] == "FeatureCollection" {
        v["features"][0]["geometry"].clone()
    } else {
        v
    }
}

/// Latitude where the great circle through two lon/lat points meets the meridian 180.
fn great_circle_lat_at_180(p: [f64; 2], q: [f64; 2]) -> f64 {
    let n = crate::helpers::cross3(&unit3(p[0], p[1]), &unit3(q[0], q[1]));
    (n[0] / n[2]).atan().to_degrees()
}

#[test]
fn a_long_edge_across_180_is_cut_where_its_great_circle_crosses() {
    let g = json!({"type": "Polygon", "coordinates": [[[170.0, 40.0], [-170.0, 40.0],
        [-170.0, 50.0], [170.0, 50.0], [170.0, 40.0]]]});
    let south = great_circle_lat_at_180([170.0, 40.0], [-170.0, 40.0]);
    assert!(south > 40.4, "{south}");
    for out in check("long edges", &g, 100.0) {
        let polys = polygons(&out);
        assert_eq!(polys.len(), 2, "{out}");
        let seam: Vec<f64> = polys[0][0]
            .iter()
            .filter(|p| p[0].abs() == 180.0)
            .map(|p| p[1])
            .collect();
        let lowest = seam.iter().copied().fold(f64::INFINITY, f64::min);
        // The cut lies on the fitted curve, within the tolerance of the great circle.
        let off_m = (lowest - south).abs().to_radians() * EARTH_RADIUS_M;
        assert!(off_m <= 100.0, "cut at {lowest}, great circle at {south}");
    }
}

#[test]
fn polar_caps_uncut_come_back_closed_along_their_pole() {
    for (file, pole) in [
        ("antimeridian/south-pole.json", -90.0),
        ("antimeridian/north-pole.json", 90.0),
    ] {
        let g = load(file);
        for out in check(file, &g, 1000.0) {
            let polys = polygons(&out);
            assert_eq!(polys.len(), 1, "{file}: {out}");
            assert!(
                polys[0][0].iter().any(|p| p[1] == pole),
                "{file}: not closed along the pole"
            );
        }
    }
    // A cap at 72 S sampled every 5 degrees, as a coast might be.
    let ring: Vec<Value> = (0..=72)
        .map(|i| json!([-180.0 + 5.0 * (i % 72) as f64, -72.0]))
        .collect();
    let g = json!({"type": "Polygon", "coordinates": [ring]});
    check("72 S cap", &g, 100.0);
}

#[test]
fn polar_caps_already_cut_are_rejoined_and_keep_their_area() {
    let g = load("antimeridian/south-pole.cut.json");
    for out in check("south-pole.cut", &g, 1000.0) {
        assert_eq!(polygons(&out).len(), 1, "{out}");
    }
    // A north cap written cut, coast westward from +180.
    let mut ring: Vec<Value> = (0..=36)
        .map(|i| json!([180.0 - 10.0 * i as f64, 75.0]))
        .collect();
    ring.extend([
        json!([-180.0, 90.0]),
        json!([180.0, 90.0]),
        json!([180.0, 75.0]),
    ]);
    let g = json!({"type": "Polygon", "coordinates": [ring]});
    for out in check("north cap cut", &g, 1000.0) {
        assert_eq!(polygons(&out).len(), 1, "{out}");
    }
}

#[test]
fn antarctica_as_natural_earth_cuts_it_comes_back_whole() {
    // mapshaper's Antarctica: 140 parts, the mainland closed along the South Pole at ±180.
    let g = load("antarctica_cut_mapshaper.json");
    for tolerance_m in [1000.0, 10_000.0] {
        check("Antarctica", &g, tolerance_m);
    }
}

#[test]
fn rings_crossing_180_several_times_give_valid_pieces() {
    for file in [
        "antimeridian/complex-split.json",
        "antimeridian/complex-split.cut.json",
        "antimeridian/crossing-latitude.json",
    ] {
        check(file, &load(file), 1000.0);
    }
    // A Sentinel-3 swath crossing ±180 several times.
    check(
        "issues-124 swath",
        &load("antimeridian/issues-124.json"),
        1000.0,
    );
}

#[test]
fn a_vertex_on_180_is_written_on_the_side_of_its_edges() {
    // The antimeridian package's point-on-antimeridian: a vertex at +180 between vertices at
    // -176.9 and -176.8; written as +180 it would make edges 357 degrees wide.
    let file = "antimeridian/point-on-antimeridian.json";
    for out in check(file, &load(file), 100.0) {
        for poly in polygons(&out) {
            for r in &poly {
                for w in r.windows(2) {
                    assert!((w[0][0] - w[1][0]).abs() <= 180.0, "{file}: {w:?}");
                }
            }
        }
    }
}

#[test]
fn rings_round_a_pole_that_fold_back_across_180_lose_no_piece() {
    // extra-crossing turns once round the North Pole and crosses ±180 three times (a spike
    // west of 180 at 76 S); issues-164 is a real swath over the North Pole.
    check("issues-164", &load("antimeridian/issues-164.json"), 1000.0);
    // In shared mode extra-crossing is closed along the other pole (its area then differs by
    // 5 %): per feature only until the two agree.
    check_in(
        "extra-crossing",
        &load("antimeridian/extra-crossing.json"),
        1000.0,
        &["per-feature"],
    );
}

#[test]
fn a_band_from_minus_180_to_180_is_refused_where_it_is() {
    // On the sphere -180 and 180 are one meridian: the ring has 2 distinct points.
    let doc = std::fs::read(fixture_path("antimeridian/latitude-band.json")).unwrap();
    for mode in ["per-feature", "shared"] {
        let out = run_spherefit(
            &["fit", "--tolerance-m", "100", "--topology", mode, "-"],
            Some(&doc),
        );
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{mode}: {stderr}");
        assert!(
            stderr.contains("/coordinates/0") && stderr.contains("bounds no area"),
            "{mode}: {stderr}"
        );
    }
}

/// Whether a lon/lat polygon geometry is valid in the plane (geo's OGC rules).
fn valid_in_plane(geometry: &Value) -> bool {
    polygons(geometry).iter().all(|poly| {
        let ls = |r: &Ring| LineString::new(r.iter().map(|p| Coord { x: p[0], y: p[1] }).collect());
        Polygon::new(ls(&poly[0]), poly[1..].iter().map(ls).collect()).is_valid()
    })
}

/// Natural Earth's 110m countries as GIS packages ship them (pyogrio's `naturalearth_lowres`
/// shapefile, converted by GDAL): Fiji and Russia cut at ±180, Antarctica closed along the
/// South Pole, a `crs` member. Through the CLI in both modes and the service, at 100 m and
/// 1 km: every feature back in order with its properties and the document's members, every
/// polygon checked as [`check_output`] does (valid wherever the input is: Sudan's input ring
/// touches itself).
#[test]
fn natural_earth_countries_as_gis_packages_ship_them_come_back_whole() {
    let path = fixture_path("naturalearth_lowres_gdal.geojson");
    let input: Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    let features = input["features"].as_array().unwrap();
    assert_eq!(features.len(), 177);
    let valid: Vec<bool> = features
        .iter()
        .map(|f| valid_in_plane(&f["geometry"]))
        .collect();
    assert_eq!(valid.iter().filter(|v| !**v).count(), 1, "Sudan only");
    for tolerance_m in [100.0, 1000.0] {
        let t = tolerance_m.to_string();
        let mut outputs = Vec::new();
        for mode in ["per-feature", "shared"] {
            let o = run_spherefit(
                &["fit", "--tolerance-m", &t, "--topology", mode, "-q", &path],
                None,
            );
            assert!(
                o.status.success(),
                "{mode}: {}",
                String::from_utf8_lossy(&o.stderr)
            );
            outputs.push((
                format!("CLI {mode}"),
                serde_json::from_slice::<Value>(&o.stdout).unwrap(),
            ));
        }
        let (status, _, body) = crate::helpers::post_geo_oneshot(
            &format!("/v1/fit?tolerance_m={t}&topology=shared"),
            &input,
        );
        assert_eq!(status, 200, "{body}");
        outputs.push(("HTTP shared".into(), body));
        for (how, out) in &outputs {
            assert_eq!(out["crs"], input["crs"], "{how}");
            assert_eq!(out["name"], input["name"], "{how}");
            let got = out["features"].as_array().unwrap();
            assert_eq!(got.len(), features.len(), "{how}");
            for (i, (f, g)) in features.iter().zip(got).enumerate() {
                let name = f["properties"]["name"].as_str().unwrap();
                for (k, v) in f["properties"].as_object().unwrap() {
                    assert_eq!(&g["properties"][k], v, "{how}: {name}: {k}");
                }
                assert_eq!(
                    g["properties"]["fit"]["tolerance_met"], true,
                    "{how}: {name}"
                );
                let at = format!("{name} ({how}, {tolerance_m} m, feature {i})");
                check_output(&at, &f["geometry"], &g["geometry"], tolerance_m, valid[i]);
            }
        }
    }
}

/// The `antimeridian` package's own cut output of three Sentinel-3 swaths: one forced onto the
/// North Pole (its larger side, 163 vertices were lost when it was closed along the smaller
/// one), one whose parts overlap across ±180 (an output edge spanned 360 degrees), one over
/// the North Pole that crosses ±180 three times (closed from a crossing below another, the
/// strips lost a piece, so it was closed along the South Pole instead). Each comes back with
/// every vertex within the tolerance both ways, in both modes.
#[test]
fn swaths_cut_onto_their_larger_side_or_overlapping_come_back_whole() {
    for name in ["force-north-pole", "overlap", "issues-164"] {
        let g = load(&format!("antimeridian/{name}.cut.json"));
        let valid = valid_in_plane(&g);
        for mode in ["per-feature", "shared"] {
            let out = fit(&g, 100.0, mode);
            check_output(
                &format!("{name} ({mode})"),
                &g,
                &out["geometry"],
                100.0,
                valid,
            );
            // No edge wider than 180 degrees but along a pole.
            for poly in polygons(&out["geometry"]) {
                for r in poly {
                    for w in r.windows(2) {
                        assert!(
                            (w[1][0] - w[0][0]).abs() <= 180.0
                                || (w[0][1].abs() == 90.0 && w[0][1] == w[1][1]),
                            "{name} ({mode}): edge {:?} -> {:?}",
                            w[0],
                            w[1]
                        );
                    }
                }
            }
        }
    }
}
