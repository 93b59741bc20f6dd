//! Coverages fitted with shared topology (`topology=shared`): real coverages (US states from
//! us-atlas, the world-atlas 110m countries) and a synthetic one with a hole, an enclave, an
//! island, an antimeridian-crossing feature and a polar ring. Everything is checked on the
//! output geometry, recomputed independently of the fitter: neighbours' output borders made of
//! the same segments bit for bit, every input vertex within the tolerance of its feature's
//! output boundary, geo's validity checks, and GDAL reading the TopoJSON.

use crate::helpers::distance_to_arc as to_segment;
use crate::helpers::{fixture_path, read_fixture_json, run_spherefit, EARTH_RADIUS_M};
use geo::{Area, BooleanOps, Contains, Coord, LineString, MultiPolygon, Polygon, Validation};
use serde_json::{json, Value};
use spherefit::earth::coverage::{fit_coverage, Coverage};
use spherefit::earth::{Document, Job, Operation};
use spherefit::sphere::FitOptions;
use std::collections::{HashMap, HashSet};
use std::path::PathBuf;
use std::process::Command;

fn job(tolerance_m: f64) -> Job {
    Job {
        operation: Operation::FitToTolerance {
            options: FitOptions::faithful(),
            tolerance_m,
        },
        ..Job::fit(FitOptions::default())
    }
}

fn fit(doc: &Value, tolerance_m: f64) -> Coverage {
    fit_coverage(
        Document::parse(doc.clone(), false).unwrap(),
        &job(tolerance_m),
    )
    .unwrap()
}

type Ring = Vec<[f64; 2]>;

/// `b` is ring `a` (closed, last position = first) started elsewhere: the same positions in
/// the same cyclic order, each within `eps` degrees. A TopoJSON ring made of shared arcs
/// starts where its first arc does, not necessarily where the GeoJSON ring starts.
fn same_cycle(a: &Ring, b: &Ring, eps: f64) -> bool {
    if a.len() != b.len() || a.is_empty() {
        return a.len() == b.len();
    }
    let n = a.len() - 1;
    if n == 0 {
        return true;
    }
    let near =
        |p: &[f64; 2], q: &[f64; 2]| (p[0] - q[0]).abs() <= eps && (p[1] - q[1]).abs() <= eps;
    // ±180 and -180 are the same meridian: a ring cut there may show either sign at a start.
    let same = |p: &[f64; 2], q: &[f64; 2]| {
        near(p, q) || (p[0].abs() == 180.0 && q[0].abs() == 180.0 && (p[1] - q[1]).abs() <= eps)
    };
    (0..n).any(|k| (0..n).all(|j| same(&a[j], &b[(k + j) % n])))
}

/// The rings of a Polygon or MultiPolygon geometry, as polygons of rings.
fn polygons(g: &Value) -> Vec<Vec<Ring>> {
    let ring = |r: &Value| -> Ring {
        r.as_array()
            .unwrap()
            .iter()
            .map(|p| [p[0].as_f64().unwrap(), p[1].as_f64().unwrap()])
            .collect()
    };
    let poly = |p: &Value| -> Vec<Ring> { p.as_array().unwrap().iter().map(ring).collect() };
    match g["type"].as_str().unwrap() {
        "Polygon" => vec![poly(&g["coordinates"])],
        "MultiPolygon" => g["coordinates"]
            .as_array()
            .unwrap()
            .iter()
            .map(poly)
            .collect(),
        t => panic!("not a polygon: {t}"),
    }
}

fn unit(p: &[f64; 2]) -> [f64; 3] {
    let (lo, la) = (p[0].to_radians(), p[1].to_radians());
    [la.cos() * lo.cos(), la.cos() * lo.sin(), la.sin()]
}

/// Largest distance (metres) from any input vertex of a feature to that feature's output
/// boundary (all its rings), computed from scratch.
fn worst_vertex_distance_m(input: &Value, output: &Value) -> f64 {
    let segments: Vec<([f64; 3], [f64; 3])> = polygons(output)
        .iter()
        .flatten()
        .flat_map(|r| {
            r.windows(2)
                .map(|w| (unit(&w[0]), unit(&w[1])))
                .collect::<Vec<_>>()
        })
        .collect();
    let mut worst = 0.0f64;
    for v in polygons(input).iter().flatten().flatten() {
        let p = unit(v);
        let d = segments
            .iter()
            .map(|(a, b)| to_segment(&p, a, b))
            .fold(f64::INFINITY, f64::min);
        worst = worst.max(d * EARTH_RADIUS_M);
    }
    worst
}

/// A position's bits.
type Bits = (u64, u64);

/// A segment as an unordered pair of positions' bits.
type Segment = (Bits, Bits);

fn key(p: &[f64; 2]) -> Bits {
    (p[0].to_bits(), p[1].to_bits())
}

/// Every segment of a feature's output rings, as an unordered pair of bit patterns.
fn segment_set(g: &Value) -> HashSet<Segment> {
    let mut s = HashSet::new();
    for r in polygons(g).iter().flatten() {
        for w in r.windows(2) {
            let (a, b) = (key(&w[0]), key(&w[1]));
            s.insert(if a <= b { (a, b) } else { (b, a) });
        }
    }
    s
}

/// For every pair of features sharing an input border: each vertex inside that border is
/// within the tolerance of the output segments both features hold, bit for bit (so their
/// common border is one line, and it follows the input). Returns the number of neighbour
/// pairs and shared vertices checked.
fn assert_neighbours_share_output(
    input: &Value,
    output: &[Value],
    tolerance_m: f64,
) -> (usize, usize) {
    let feats = input["features"].as_array().unwrap();
    // Input edges -> features using them.
    let mut edges: HashMap<Segment, Vec<usize>> = HashMap::new();
    for (i, f) in feats.iter().enumerate() {
        if !f["geometry"]["type"].as_str().unwrap().ends_with("Polygon") {
            continue;
        }
        for r in polygons(&f["geometry"]).iter().flatten() {
            for w in r.windows(2) {
                let (a, b) = (key(&w[0]), key(&w[1]));
                let e = if a <= b { (a, b) } else { (b, a) };
                let users = edges.entry(e).or_default();
                if !users.contains(&i) {
                    users.push(i);
                }
            }
        }
    }
    // Vertices inside a border shared by two features: ends of two edges both shared by
    // exactly that pair (junctions, where the nearest output segment may be a third
    // feature's border, are left out).
    let mut ends: HashMap<((usize, usize), Bits), usize> = HashMap::new();
    for ((a, b), users) in &edges {
        if users.len() == 2 {
            let pair = (users[0].min(users[1]), users[0].max(users[1]));
            for k in [a, b] {
                *ends.entry((pair, *k)).or_default() += 1;
            }
        }
    }
    let mut shared: HashMap<(usize, usize), Vec<[f64; 2]>> = HashMap::new();
    for ((pair, k), count) in ends {
        if count >= 2 {
            shared
                .entry(pair)
                .or_default()
                .push([f64::from_bits(k.0), f64::from_bits(k.1)]);
        }
    }
    let mut vertices = 0;
    for ((i, j), pts) in &shared {
        let (gi, gj) = (&output[*i]["geometry"], &output[*j]["geometry"]);
        let si = segment_set(gi);
        let sj = segment_set(gj);
        // The output segments both features hold, bit for bit.
        let common: Vec<([f64; 3], [f64; 3])> = si
            .intersection(&sj)
            .map(|s| {
                (
                    unit(&[f64::from_bits(s.0 .0), f64::from_bits(s.0 .1)]),
                    unit(&[f64::from_bits(s.1 .0), f64::from_bits(s.1 .1)]),
                )
            })
            .collect();
        for v in pts {
            let p = unit(v);
            let d = common
                .iter()
                .map(|(a, b)| to_segment(&p, a, b))
                .fold(f64::INFINITY, f64::min)
                * EARTH_RADIUS_M;
            assert!(
                d <= tolerance_m,
                "features {i} and {j}: shared vertex {v:?} is {d} m from the output border they have in common"
            );
            vertices += 1;
        }
    }
    (shared.len(), vertices)
}

fn geo_polygons(g: &Value) -> MultiPolygon<f64> {
    let ls = |r: &Ring| LineString::new(r.iter().map(|p| Coord { x: p[0], y: p[1] }).collect());
    MultiPolygon::new(
        polygons(g)
            .iter()
            .map(|p| Polygon::new(ls(&p[0]), p[1..].iter().map(ls).collect()))
            .collect(),
    )
}

/// Checks a fitted real coverage: shared borders identical, the tolerance met by every input
/// vertex, rings valid where the input's are, neighbours not overlapping.
fn check_coverage(name: &str, tolerance_m: f64) -> Coverage {
    let input = read_fixture_json(name);
    let c = fit(&input, tolerance_m);
    assert_eq!(c.report["tolerance_met"], true, "{}", c.report);
    let (pairs, vertices) = assert_neighbours_share_output(&input, &c.features, tolerance_m);
    assert!(
        pairs > 5 && vertices > 100,
        "{pairs} pairs, {vertices} vertices"
    );
    let feats = input["features"].as_array().unwrap();
    for (i, (f, o)) in feats.iter().zip(&c.features).enumerate() {
        let d = worst_vertex_distance_m(&f["geometry"], &o["geometry"]);
        assert!(
            d <= tolerance_m,
            "{name} feature {i}: an input vertex {d} m from the output"
        );
        let fit = &o["properties"]["fit"];
        assert_eq!(fit["tolerance_met"], true, "feature {i}");
        if fit["antimeridian_split"] == false && geo_polygons(&f["geometry"]).is_valid() {
            let out = geo_polygons(&o["geometry"]);
            assert!(
                out.is_valid(),
                "{name} feature {i} ({}): {:?}",
                f["properties"],
                out.validation_errors()
            );
        }
    }
    // Neighbours do not overlap (beyond the boolean operations' rounding).
    let shapes: Vec<MultiPolygon<f64>> = c
        .features
        .iter()
        .map(|o| geo_polygons(&o["geometry"]))
        .collect();
    let inputs: Vec<MultiPolygon<f64>> =
        feats.iter().map(|f| geo_polygons(&f["geometry"])).collect();
    let mut users: HashMap<usize, Vec<usize>> = HashMap::new();
    for (fi, rings) in c.feature_rings.iter().enumerate() {
        for u in rings.iter().flatten().flatten().flatten() {
            users.entry(u.arc).or_default().push(fi);
        }
    }
    let mut pairs_checked = HashSet::new();
    for fs in users.values() {
        if let [a, b] = fs[..] {
            if a != b && pairs_checked.insert((a.min(b), a.max(b))) {
                let overlap = shapes[a].intersection(&shapes[b]).unsigned_area();
                let before = inputs[a].intersection(&inputs[b]).unsigned_area();
                let smaller = shapes[a].unsigned_area().min(shapes[b].unsigned_area());
                assert!(
                    overlap <= before + 1e-9 * smaller,
                    "features {a} and {b} overlap: {overlap} (input: {before})"
                );
            }
        }
    }
    c
}

#[test]
fn us_states_share_their_borders_exactly_at_1_km() {
    let c = check_coverage("coverage_us_states.geojson", 1000.0);
    // The Four Corners: one vertex where four states meet.
    assert!(c.report["junctions"].as_u64().unwrap() >= 10);
    let once = c.report["stored_numbers"].as_u64().unwrap();
    let sum = c.report["stored_numbers_per_feature_sum"].as_u64().unwrap();
    assert!(once < sum, "{once} vs {sum}");
}

#[test]
fn world_110m_countries_share_their_borders_exactly_at_1_km() {
    let c = check_coverage("coverage_world_110m.geojson", 1000.0);
    assert_eq!(c.features.len(), 177);
    // Lesotho is an enclave: the hole of South Africa, one closed arc used by both.
    let idx = |name: &str| {
        c.features
            .iter()
            .position(|f| f["properties"]["name"] == name)
            .unwrap()
    };
    // Areas on the sphere, across the antimeridian and around a pole: Russia about 17.1
    // million km² (16.9 at 1:110M), Antarctica about 12-14 million km², Fiji about 18,000 km².
    let area = |name: &str| {
        c.features[idx(name)]["properties"]["fit"]["area_m2"]
            .as_f64()
            .unwrap()
    };
    assert!(
        (1.6e13..1.8e13).contains(&area("Russia")),
        "{}",
        area("Russia")
    );
    assert!(
        (1.1e13..1.45e13).contains(&area("Antarctica")),
        "{}",
        area("Antarctica")
    );
    assert!((1.5e10..2.2e10).contains(&area("Fiji")), "{}", area("Fiji"));
    assert!(
        c.report["max_area_change"].as_f64().unwrap() < 0.01,
        "{}",
        c.report
    );
    assert_eq!(
        c.report["kept_rings"],
        json!(["/features/95/geometry/coordinates/0/0"])
    );
    assert_eq!(c.report["crossings_left"], json!([]));
    let (za, ls) = (idx("South Africa"), idx("Lesotho"));
    let lesotho = &c.feature_rings[ls].as_ref().unwrap()[0][0];
    assert_eq!(lesotho.len(), 1);
    assert!(c.graph.arcs[lesotho[0].arc].closed);
    let za_rings = c.feature_rings[za].as_ref().unwrap();
    assert!(za_rings.iter().flatten().any(|r| r.len() == 1
        && r[0].arc == lesotho[0].arc
        && r[0].reversed != lesotho[0].reversed));
    let hole = geo_polygons(&c.features[za]["geometry"]);
    let enclave = geo_polygons(&c.features[ls]["geometry"]);
    assert!(hole.0.iter().any(|p| p.interiors().len() == 1));
    assert_eq!(hole.intersection(&enclave).unsigned_area(), 0.0);
}

/// A coverage with a hole, an enclave filling it, an island, a feature across the antimeridian
/// and a ring around the north pole.
fn synthetic() -> Value {
    let wavy = |a: [f64; 2], b: [f64; 2], n: usize, amp: f64| -> Vec<[f64; 2]> {
        (0..n)
            .map(|i| {
                let t = i as f64 / n as f64;
                let s = amp * (std::f64::consts::PI * 6.0 * t).sin();
                [a[0] + t * (b[0] - a[0]) + s, a[1] + t * (b[1] - a[1]) + s]
            })
            .collect()
    };
    let closed = |mut r: Vec<[f64; 2]>| {
        r.push(r[0]);
        r
    };
    let mut west = wavy([10.0, 0.0], [10.0, 10.0], 60, 0.1);
    let border = west.clone();
    west.extend([[10.0, 10.0], [0.0, 10.0], [0.0, 0.0]]);
    let hole: Vec<[f64; 2]> = (0..80)
        .map(|i| {
            let a = std::f64::consts::TAU * i as f64 / 80.0;
            [
                5.0 + 2.0 * a.cos(),
                5.0 + 2.0 * a.sin() + 0.2 * (4.0 * a).sin(),
            ]
        })
        .collect();
    let mut east: Vec<[f64; 2]> = vec![[10.0, 10.0]];
    east.extend(border.iter().rev());
    east.extend([[20.0, 0.0], [20.0, 10.0]]);
    let island: Vec<[f64; 2]> = (0..50)
        .map(|i| {
            let a = std::f64::consts::TAU * i as f64 / 50.0;
            [30.0 + a.cos(), 5.0 + 0.5 * a.sin()]
        })
        .collect();
    let across: Vec<[f64; 2]> = (0..100)
        .map(|i| {
            let a = std::f64::consts::TAU * i as f64 / 100.0;
            let lon = 178.0 + 5.0 * a.cos();
            [
                if lon > 180.0 { lon - 360.0 } else { lon },
                -20.0 + 3.0 * a.sin(),
            ]
        })
        .collect();
    let polar: Vec<[f64; 2]> = (0..120)
        .map(|i| {
            let lon = -180.0 + 3.0 * i as f64;
            let l = lon.to_radians();
            [
                lon,
                80.0 + 0.5 * (5.0 * l + 0.3).sin() + 0.1 * (11.0 * l).cos(),
            ]
        })
        .collect();
    let hole_rev: Vec<[f64; 2]> = hole.iter().rev().copied().collect();
    json!({"type": "FeatureCollection", "features": [
        {"type": "Feature", "id": "west", "properties": {}, "geometry": {"type": "Polygon", "coordinates": [closed(west), closed(hole_rev)]}},
        {"type": "Feature", "id": "enclave", "properties": {}, "geometry": {"type": "Polygon", "coordinates": [closed(hole)]}},
        {"type": "Feature", "id": "east", "properties": {}, "geometry": {"type": "MultiPolygon", "coordinates": [[closed(east)], [closed(island)]]}},
        {"type": "Feature", "id": "across", "properties": {}, "geometry": {"type": "Polygon", "coordinates": [closed(across)]}},
        {"type": "Feature", "id": "polar", "properties": {}, "geometry": {"type": "Polygon", "coordinates": [closed(polar)]}},
        {"type": "Feature", "id": "line", "properties": {"k": 1}, "geometry": {"type": "LineString", "coordinates": wavy([40.0, 0.0], [45.0, 5.0], 40, 0.05)}}
    ]})
}

#[test]
fn holes_enclaves_islands_the_antimeridian_and_a_pole() {
    let input = synthetic();
    let c = fit(&input, 500.0);
    assert_eq!(c.report["tolerance_met"], true, "{}", c.report);
    let feats = input["features"].as_array().unwrap();
    for (i, (f, o)) in feats.iter().zip(&c.features).enumerate().take(5) {
        let d = worst_vertex_distance_m(&f["geometry"], &o["geometry"]);
        assert!(
            d <= 500.0,
            "feature {i}: an input vertex {d} m from the output"
        );
    }
    let (pairs, _) = assert_neighbours_share_output(&input, &c.features, 500.0);
    assert_eq!(pairs, 2); // west and east, west (its hole) and the enclave
                          // The enclave's ring is the hole of `west`, bit for bit (the same positions, reversed).
    let west = polygons(&c.features[0]["geometry"]);
    let enclave = polygons(&c.features[1]["geometry"]);
    let as_set = |r: &Ring| r.iter().map(key).collect::<HashSet<_>>();
    assert_eq!(as_set(&west[0][1]), as_set(&enclave[0][0]));
    // The hole stays inside its shell; the island is one closed arc.
    let shell = Polygon::new(
        LineString::new(
            west[0][0]
                .iter()
                .map(|p| Coord { x: p[0], y: p[1] })
                .collect(),
        ),
        vec![],
    );
    let hole = LineString::new(
        west[0][1]
            .iter()
            .map(|p| Coord { x: p[0], y: p[1] })
            .collect(),
    );
    assert!(shell.contains(&hole));
    assert!(geo_polygons(&c.features[0]["geometry"]).is_valid());
    // Across the antimeridian: split into two polygons, no segment longer than 180 degrees.
    let across = &c.features[3];
    assert_eq!(across["geometry"]["type"], "MultiPolygon");
    assert_eq!(across["properties"]["fit"]["antimeridian_split"], true);
    for r in polygons(&across["geometry"]).iter().flatten() {
        assert!(r.windows(2).all(|w| (w[1][0] - w[0][0]).abs() <= 180.0));
    }
    // Around the pole: closed along it, and it still holds the pole's side.
    let polar = geo_polygons(&c.features[4]["geometry"]);
    assert!(polar.is_valid(), "{:?}", polar.validation_errors());
    assert!(polar.contains(&geo::Point::new(0.0, 89.0)));
    // The line is fitted on its own, properties kept.
    assert_eq!(c.features[5]["properties"]["k"], 1);
    assert_eq!(c.features[5]["geometry"]["type"], "LineString");
    assert!(c.features[5]["properties"]["fit"]["tolerance_met"] == true);
}

fn scratch(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("topology-{name}"));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The arcs of a quantised topology as absolute `[lon, lat]` positions: the deltas summed and
/// the grid index `k` mapped to `(k − translate·10^p) / 10^p`, which is exactly the decimal a
/// GeoJSON output at `p` decimals writes (a reader's `k·scale + translate` is within 1e-12°).
fn absolute_arcs(t: &Value) -> Vec<Value> {
    let scale = t["transform"]["scale"][0]
        .as_f64()
        .expect("a quantised topology");
    assert_eq!(t["transform"]["scale"][1].as_f64(), Some(scale));
    let steps = (1.0 / scale).round();
    let decimals = steps.log10().round() as i32;
    assert_eq!(10f64.powi(decimals), steps, "a decimal grid");
    let tr = [
        t["transform"]["translate"][0].as_f64().unwrap(),
        t["transform"]["translate"][1].as_f64().unwrap(),
    ];
    assert_eq!(tr, [-180.0, -90.0]);
    t["arcs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|arc| {
            let mut k = [0i64; 2];
            Value::Array(
                arc.as_array()
                    .unwrap()
                    .iter()
                    .map(|p| {
                        k[0] += p[0].as_i64().expect("integer deltas");
                        k[1] += p[1].as_i64().expect("integer deltas");
                        let lon = (k[0] - (180.0 * steps) as i64) as f64 / steps;
                        let lat = (k[1] - (90.0 * steps) as i64) as f64 / steps;
                        serde_json::json!([lon, lat])
                    })
                    .collect(),
            )
        })
        .collect()
}

/// Decodes a TopoJSON polygon ring (arc indices) into positions, as a reader does.
fn decode_ring(arcs: &[Value], refs: &Value) -> Ring {
    let mut out: Ring = Vec::new();
    for r in refs.as_array().unwrap() {
        let i = r.as_i64().unwrap();
        let (idx, rev) = if i < 0 {
            ((-i - 1) as usize, true)
        } else {
            (i as usize, false)
        };
        let mut pts: Ring = arcs[idx]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| [p[0].as_f64().unwrap(), p[1].as_f64().unwrap()])
            .collect();
        if rev {
            pts.reverse();
        }
        if !out.is_empty() {
            assert_eq!(out.last(), pts.first(), "arcs of a ring meet end to start");
            pts.remove(0);
        }
        out.extend(pts);
    }
    out
}

#[test]
fn the_cli_writes_topojson_that_gdal_and_mapshaper_read() {
    let dir = scratch("cli");
    let topo = dir.join("states.topojson");
    let geo = dir.join("states.geojson");
    let input = fixture_path("coverage_us_states.geojson");
    for (path, format) in [(&topo, "topojson"), (&geo, "geojson")] {
        let o = run_spherefit(
            &[
                "fit",
                "--topology",
                "shared",
                "--tolerance-m",
                "1000",
                "--output-format",
                format,
                &input,
                "-o",
                path.to_str().unwrap(),
            ],
            None,
        );
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        assert!(String::from_utf8_lossy(&o.stderr).contains("shared"));
    }
    let t: Value = serde_json::from_slice(&std::fs::read(&topo).unwrap()).unwrap();
    let g: Value = serde_json::from_slice(&std::fs::read(&geo).unwrap()).unwrap();
    assert_eq!(t["type"], "Topology");
    let arcs = &absolute_arcs(&t);
    let arc_count = t["spherefit"]["arc_count"].as_u64().unwrap();
    assert!(arcs.len() as u64 >= arc_count);
    // One compact spline per shared arc: null where the arc is its own (degree-1) spline.
    let splines = t["spherefit"]["splines"].as_array().unwrap();
    assert_eq!(splines.len() as u64, arc_count);
    assert!(splines.iter().all(|s| s.is_null() || s["degree"].is_u64()));
    // Every ring decoded from the arcs is the GeoJSON output's ring.
    let geoms = t["objects"]["collection"]["geometries"].as_array().unwrap();
    let feats = g["features"].as_array().unwrap();
    assert_eq!(geoms.len(), feats.len());
    for (tg, f) in geoms.iter().zip(feats) {
        assert_eq!(tg["id"], f["id"]);
        let rings: Vec<Ring> = match tg["type"].as_str().unwrap() {
            "Polygon" => tg["arcs"]
                .as_array()
                .unwrap()
                .iter()
                .map(|r| decode_ring(arcs, r))
                .collect(),
            _ => tg["arcs"]
                .as_array()
                .unwrap()
                .iter()
                .flat_map(|p| p.as_array().unwrap().iter().map(|r| decode_ring(arcs, r)))
                .collect(),
        };
        let expected: Vec<Ring> = polygons(&f["geometry"]).into_iter().flatten().collect();
        assert_eq!(rings, expected, "feature {}", f["id"]);
    }
    // Without --topology shared there is no TopoJSON.
    let o = run_spherefit(
        &[
            "fit",
            "--tolerance-m",
            "1000",
            "--output-format",
            "topojson",
            &input,
        ],
        None,
    );
    assert_eq!(o.status.code(), Some(2));
    let o = run_spherefit(&["fit", "--topology", "shared", &input], None);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--tolerance-m"));
    mapshaper_reads(&topo, 11);
    let info = match Command::new("ogrinfo")
        .args(["-ro", "-al", "-so"])
        .arg(&topo)
        .output()
    {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            println!("NOTICE: ogrinfo (GDAL, Debian gdal-bin) is not installed: the GDAL half of this test was skipped");
            return;
        }
        Err(e) => panic!("ogrinfo: {e}"),
        Ok(o) => {
            let text = format!(
                "{}{}",
                String::from_utf8_lossy(&o.stderr),
                String::from_utf8_lossy(&o.stdout)
            );
            assert!(o.status.success(), "ogrinfo failed: {text}");
            text
        }
    };
    assert!(info.contains("TopoJSON"), "{info}");
    assert!(info.contains("Feature Count: 11"), "{info}");
    assert!(!info.contains("ERROR"), "{info}");
}

/// How many array levels sit above the arc indices of a TopoJSON geometry's `arcs`.
fn arc_depth(v: &Value) -> usize {
    match v {
        Value::Array(a) => 1 + a.iter().map(arc_depth).max().unwrap_or(0),
        _ => 0,
    }
}

/// Russia, Fiji and Antarctica are split at ±180 in the output, so their polygons get arcs of
/// their own (one per ring): those were written one level short (`[594]` for a polygon instead
/// of `[[594]]`), which GDAL read as an empty MultiPolygon.
#[test]
fn topojson_of_polygons_split_at_the_antimeridian_nests_polygons_rings_and_arcs() {
    let dir = scratch("antimeridian");
    let topo = dir.join("world.topojson");
    let geo = dir.join("world.geojson");
    let input = fixture_path("coverage_world_110m.geojson");
    for (path, format) in [(&topo, "topojson"), (&geo, "geojson")] {
        let o = run_spherefit(
            &[
                "fit",
                "--topology",
                "shared",
                "--tolerance-m",
                "1000",
                "--output-format",
                format,
                &input,
                "-o",
                path.to_str().unwrap(),
            ],
            None,
        );
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let t: Value = serde_json::from_slice(&std::fs::read(&topo).unwrap()).unwrap();
    let g: Value = serde_json::from_slice(&std::fs::read(&geo).unwrap()).unwrap();
    let arcs = &absolute_arcs(&t);
    let geoms = t["objects"]["collection"]["geometries"].as_array().unwrap();
    let feats = g["features"].as_array().unwrap();
    assert_eq!(geoms.len(), 177);
    assert_eq!(geoms.len(), feats.len());
    let mut split = 0;
    for (tg, f) in geoms.iter().zip(feats) {
        let kind = tg["type"].as_str().unwrap();
        assert_eq!(kind, f["geometry"]["type"], "feature {}", f["id"]);
        let levels = match kind {
            "Polygon" => 2,
            "MultiPolygon" => 3,
            other => panic!("feature {}: {other}", f["id"]),
        };
        assert_eq!(
            arc_depth(&tg["arcs"]),
            levels,
            "feature {} {kind}: {}",
            f["id"],
            tg["arcs"]
        );
        let polys: Vec<&Value> = if kind == "Polygon" {
            vec![&tg["arcs"]]
        } else {
            tg["arcs"].as_array().unwrap().iter().collect()
        };
        let decoded: Vec<Vec<Ring>> = polys
            .iter()
            .map(|p| {
                p.as_array()
                    .unwrap()
                    .iter()
                    .map(|r| decode_ring(arcs, r))
                    .collect()
            })
            .collect();
        // The GeoJSON writes a few longitudes of rings cut at ±180 as `130.93499999999995`
        // (shifted by 360° and back); the quantised arcs hold them on the grid.
        let grid = |x: f64| (x * 1e7).round() / 1e7;
        let written: Vec<Vec<Ring>> = polygons(&f["geometry"])
            .into_iter()
            .map(|p| {
                p.into_iter()
                    .map(|r| r.into_iter().map(|q| [grid(q[0]), grid(q[1])]).collect())
                    .collect()
            })
            .collect();
        // The same polygons and rings, each ring possibly started elsewhere.
        assert_eq!(decoded.len(), written.len(), "feature {}", f["id"]);
        for (d, w) in decoded.iter().zip(&written) {
            assert_eq!(d.len(), w.len(), "feature {}", f["id"]);
            for (rd, rw) in d.iter().zip(w) {
                assert!(
                    same_cycle(rd, rw, 1e-12),
                    "feature {}: {rd:?} against {rw:?}",
                    f["id"]
                );
            }
        }
        if f["properties"]["fit"]["antimeridian_split"] == true {
            split += 1;
        }
    }
    // Fiji, Russia and Antarctica (the bug's three).
    assert!(split >= 3, "{split} features split at the antimeridian");
    mapshaper_reads(&topo, 177);
}

/// mapshaper (npm, `npm ci --prefix scripts/coverage`, which `.ci/run` does) reads the TopoJSON
/// and finds every feature. Skipped with a notice where it is not installed, unless
/// `SPHEREFIT_TEST_TOOLS=required` (set by `.ci/run`).
fn mapshaper_reads(topo: &std::path::Path, features: usize) {
    let bin = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scripts/coverage/node_modules/.bin/mapshaper");
    if !bin.exists() {
        assert!(
            std::env::var("SPHEREFIT_TEST_TOOLS").as_deref() != Ok("required"),
            "mapshaper is not installed: npm ci --prefix scripts/coverage"
        );
        println!("NOTICE: mapshaper (npm ci --prefix scripts/coverage) is not installed: the mapshaper half of this test was skipped");
        return;
    }
    let o = Command::new(&bin)
        .arg("-i")
        .arg(topo)
        .arg("-info")
        .output()
        .expect("mapshaper runs");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stderr),
        String::from_utf8_lossy(&o.stdout)
    );
    assert!(o.status.success(), "mapshaper failed: {text}");
    // Its -info table, with the padding collapsed: "Type: polygon", "Records: 11".
    let words = text.split_whitespace().collect::<Vec<_>>().join(" ");
    assert!(
        words.contains(&format!("Records: {features}")),
        "mapshaper: {text}"
    );
    assert!(words.contains("Type: polygon"), "mapshaper: {text}");
    assert!(!words.contains("[error]"), "mapshaper: {text}");
}

#[tokio::test]
async fn the_service_fits_coverages_on_request() {
    use axum::body::Body;
    use axum::http::{header, Request};
    use spherefit::service::{router, AppState, ServiceConfig};
    use tower::ServiceExt;
    let app = router(AppState::new(ServiceConfig::default()));
    let body = serde_json::to_vec(&synthetic()).unwrap();
    let send = |q: &str| {
        let req = Request::post(format!("/v1/fit?{q}"))
            .header(header::CONTENT_TYPE, "application/geo+json")
            .body(Body::from(body.clone()))
            .unwrap();
        let app = app.clone();
        async move {
            let res = app.oneshot(req).await.unwrap();
            let status = res.status().as_u16();
            let ct = res.headers()[header::CONTENT_TYPE]
                .to_str()
                .unwrap()
                .to_string();
            let b = axum::body::to_bytes(res.into_body(), usize::MAX)
                .await
                .unwrap();
            (status, ct, serde_json::from_slice::<Value>(&b).unwrap())
        }
    };
    let (s, ct, v) = send("topology=shared&tolerance_m=500").await;
    assert_eq!((s, ct.as_str()), (200, "application/geo+json"), "{v}");
    assert_eq!(v["topology"]["tolerance_met"], true);
    assert_eq!(v["features"][0]["properties"]["fit"]["topology"], "shared");
    let (s, ct, v) = send("topology=shared&tolerance_m=500&format=topojson").await;
    assert_eq!((s, ct.as_str()), (200, "application/json"), "{v}");
    assert_eq!(v["type"], "Topology");
    let (s, _, v) = send("topology=shared").await;
    assert_eq!((s, v["parameter"].as_str()), (422, Some("topology")), "{v}");
    let (s, _, v) = send("tolerance_m=500&format=topojson").await;
    assert_eq!((s, v["parameter"].as_str()), (422, Some("format")), "{v}");
    // Polygon rings carry no times.
    let (s, _, v) = send("topology=shared&tolerance_m=500&parameterization=time").await;
    assert_eq!((s, v["parameter"].as_str()), (422, Some("topology")), "{v}");
    let (s, _, v) = send("topology=maybe&tolerance_m=500").await;
    assert_eq!((s, v["parameter"].as_str()), (400, Some("topology")), "{v}");
}

/// Runs `scripts/coverage/topojson_read.mjs` (npm `topojson-client`, installed by
/// `npm ci --prefix scripts/coverage`). False, with a notice, where node or the package is
/// missing, unless `SPHEREFIT_TEST_TOOLS=required` (set by `.ci/run`).
pub(crate) fn topojson_client(args: &[&str]) -> bool {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let installed = root
        .join("scripts/coverage/node_modules/topojson-client")
        .exists();
    let required = std::env::var("SPHEREFIT_TEST_TOOLS").as_deref() == Ok("required");
    if !installed {
        assert!(
            !required,
            "topojson-client is not installed: npm ci --prefix scripts/coverage"
        );
        println!(
            "NOTICE: topojson-client (npm ci --prefix scripts/coverage) is not installed: skipped"
        );
        return false;
    }
    let o = Command::new("node")
        .arg(root.join("scripts/coverage/topojson_read.mjs"))
        .args(args)
        .output()
        .expect("node runs");
    assert!(
        o.status.success(),
        "topojson_read.mjs {args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    true
}

/// Every feature of `read` (a reader's GeoJSON of spherefit's TopoJSON) has the geometry and
/// the name of the same feature in `written` (spherefit's GeoJSON output of the same fit).
fn same_features(reader: &str, read: &Value, written: &Value) {
    let (r, w) = (
        read["features"].as_array().unwrap(),
        written["features"].as_array().unwrap(),
    );
    assert_eq!(r.len(), w.len(), "{reader}: feature count");
    for (i, (a, b)) in r.iter().zip(w).enumerate() {
        let name = &b["properties"]["name"];
        assert_eq!(&a["properties"]["name"], name, "{reader}: feature {i}");
        let (pa, pb) = (polygons(&a["geometry"]), polygons(&b["geometry"]));
        assert_eq!(pa.len(), pb.len(), "{reader}: {name}: polygons");
        for (qa, qb) in pa.iter().zip(&pb) {
            assert_eq!(qa.len(), qb.len(), "{reader}: {name}: rings");
            for (ra, rb) in qa.iter().zip(qb) {
                assert!(rb.len() >= 4, "{reader}: {name}: a ring of {}", rb.len());
                assert_eq!(ra.len(), rb.len(), "{reader}: {name}: positions");
                assert!(
                    same_cycle(ra, rb, 1e-9),
                    "{reader}: {name}: {ra:?} against {rb:?}"
                );
            }
        }
    }
}

/// The Natural Earth 50m and 10m countries of npm `world-atlas` (decoded with topojson-client),
/// fitted with shared topology at 1 km and written as TopoJSON, come back whole through the
/// readers people use: topojson-client (d3 maps) and GDAL's TopoJSON driver (QGIS, ogr2ogr)
/// find every feature with the rings of spherefit's GeoJSON output of the same fit, Russia,
/// Fiji and Antarctica (cut at ±180) included.
#[test]
fn world_atlas_countries_come_back_whole_through_topojson_client_and_gdal() {
    for name in ["countries-50m", "countries-10m"] {
        let dir = scratch(name);
        let p = |f: &str| dir.join(f).to_str().unwrap().to_string();
        if !topojson_client(&["world-atlas", name, &p("input.geojson")]) {
            return;
        }
        let input: Value =
            serde_json::from_slice(&std::fs::read(p("input.geojson")).unwrap()).unwrap();
        for (out, format) in [("fit.topojson", "topojson"), ("fit.geojson", "geojson")] {
            let o = run_spherefit(
                &[
                    "fit",
                    "--topology",
                    "shared",
                    "--tolerance-m",
                    "1000",
                    "--output-format",
                    format,
                    &p("input.geojson"),
                    "-o",
                    &p(out),
                ],
                None,
            );
            assert!(
                o.status.success(),
                "{name}: {}",
                String::from_utf8_lossy(&o.stderr)
            );
        }
        let written: Value =
            serde_json::from_slice(&std::fs::read(p("fit.geojson")).unwrap()).unwrap();
        let features = input["features"].as_array().unwrap();
        assert_eq!(
            written["features"].as_array().unwrap().len(),
            features.len()
        );
        let split = written["features"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|f| f["properties"]["fit"]["antimeridian_split"] == true)
            .count();
        // Antarctica at least (Russia and Fiji too at 50m; at 10m their parts meet ±180 at
        // latitudes a quantum apart, so they are fitted as they came and need no cut).
        assert!(split >= 1, "{name}: {split} features cut at ±180");
        assert!(topojson_client(&[
            "read",
            &p("fit.topojson"),
            &p("client.geojson")
        ]));
        let client: Value =
            serde_json::from_slice(&std::fs::read(p("client.geojson")).unwrap()).unwrap();
        same_features("topojson-client", &client, &written);
        let _ = std::fs::remove_file(p("gdal.geojson"));
        match Command::new("ogr2ogr")
            .args(["-f", "GeoJSON", &p("gdal.geojson"), &p("fit.topojson")])
            .output()
        {
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                assert!(
                    std::env::var("SPHEREFIT_TEST_TOOLS").as_deref() != Ok("required"),
                    "ogr2ogr (Debian gdal-bin) is not installed"
                );
                println!("NOTICE: ogr2ogr (GDAL) is not installed: the GDAL half was skipped");
            }
            Err(e) => panic!("ogr2ogr: {e}"),
            Ok(o) => {
                assert!(
                    o.status.success(),
                    "ogr2ogr: {}",
                    String::from_utf8_lossy(&o.stderr)
                );
                let gdal: Value =
                    serde_json::from_slice(&std::fs::read(p("gdal.geojson")).unwrap()).unwrap();
                same_features("GDAL", &gdal, &written);
            }
        }
    }
}

/// A segment of a feature's ring in the lon/lat plane, for geo's sweep.
#[derive(Clone, Debug)]
struct RingSegment {
    ring: usize,
    index: usize,
    last: usize,
    line: geo::Line<f64>,
}

impl geo::algorithm::sweep::Cross for RingSegment {
    type Scalar = f64;
    fn line(&self) -> geo::algorithm::sweep::LineOrPoint<f64> {
        self.line.into()
    }
}

/// How many times the segments of a polygon feature's rings meet (cross, touch, overlap) in the
/// lon/lat plane, neighbouring segments of one ring at their shared vertex aside, after
/// rounding the positions to `decimals`: found by geo's Bentley–Ottmann sweep, independently of
/// the fitter's own check. Zero means no ring crosses or touches itself or another.
fn planar_meetings(geometry: &Value, decimals: i32) -> usize {
    use geo::algorithm::sweep::Intersections;
    use geo::LineIntersection;
    let scale = 10f64.powi(decimals);
    let round = |x: f64| (x * scale).round() / scale;
    let mut segments = Vec::new();
    for (ring, r) in polygons(geometry).iter().flatten().enumerate() {
        let pts: Vec<Coord> = r
            .iter()
            .map(|p| Coord {
                x: round(p[0]),
                y: round(p[1]),
            })
            .collect();
        let mut kept: Vec<geo::Line<f64>> = pts
            .windows(2)
            .filter(|w| w[0] != w[1])
            .map(|w| geo::Line::new(w[0], w[1]))
            .collect();
        kept.shrink_to_fit();
        let last = kept.len().saturating_sub(1);
        segments.extend(
            kept.into_iter()
                .enumerate()
                .map(|(index, line)| RingSegment {
                    ring,
                    index,
                    last,
                    line,
                }),
        );
    }
    Intersections::<RingSegment>::from_iter(segments)
        .filter(|(a, b, meeting)| {
            let neighbours = a.ring == b.ring
                && (a.index.abs_diff(b.index) == 1
                    || (a.index.min(b.index) == 0 && a.index.max(b.index) == a.last));
            !(neighbours && matches!(meeting, LineIntersection::SinglePoint { .. }))
        })
        .count()
}

/// The Natural Earth 10m countries of npm `world-atlas` at 100 m and 1 km, per feature and
/// shared, through the CLI (and the service at 1 km): every feature back, every ring of at least 4 positions, and no ring of the output
/// crossing or touching itself or another ring of its feature wherever the input's rings
/// (written at the output's 7 decimals) do not — islands off a coast (New Caledonia, the
/// Faroes), the Curonian Spit and Lithuania's coast, and the Cayman Islands' ring, whose
/// input passes 1e-14 degrees from its own edge, all once fitted across each other or touched.
/// 54 of the 255 input features are invalid as topojson-client decodes them (polygons
/// overlapping, rings touching, islets of one repeated position): those are not judged.
#[test]
fn world_atlas_10m_countries_come_back_valid_wherever_the_input_is() {
    let dir = scratch("valid-10m");
    let input_path = dir.join("input.geojson");
    let input_path = input_path.to_str().unwrap();
    if !topojson_client(&["world-atlas", "countries-10m", input_path]) {
        return;
    }
    let input: Value = serde_json::from_slice(&std::fs::read(input_path).unwrap()).unwrap();
    let features = input["features"].as_array().unwrap();
    let judged: Vec<bool> = features
        .iter()
        .map(|f| planar_meetings(&f["geometry"], 7) == 0)
        .collect();
    let n_judged = judged.iter().filter(|j| **j).count();
    assert!(n_judged >= 190, "{n_judged} of {} judged", features.len());
    let config = spherefit::service::ServiceConfig {
        max_body_bytes: 64 << 20,
        ..Default::default()
    };
    for tolerance in ["100", "1000"] {
        let mut outputs = Vec::new();
        for mode in ["per-feature", "shared"] {
            let o = run_spherefit(
                &[
                    "fit",
                    "--tolerance-m",
                    tolerance,
                    "--topology",
                    mode,
                    "-q",
                    input_path,
                ],
                None,
            );
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
            outputs.push((
                format!("CLI {mode}"),
                serde_json::from_slice(&o.stdout).unwrap(),
            ));
        }
        // The service, at 1 km (the same code; the whole dataset in one request).
        if tolerance == "1000" {
            for mode in ["per-feature", "shared"] {
                let uri = format!("/v1/fit?tolerance_m={tolerance}&topology={mode}");
                let (status, _, body) =
                    crate::helpers::post_geo_oneshot_with(config.clone(), &uri, &input);
                assert_eq!(status, 200, "{body}");
                outputs.push((format!("HTTP {mode}"), body));
            }
        }
        for (how, out) in &outputs {
            let out = out["features"].as_array().unwrap();
            assert_eq!(out.len(), features.len(), "{how} {tolerance} m");
            let mut bad = Vec::new();
            for (i, (f, o)) in features.iter().zip(out).enumerate() {
                assert_eq!(f["properties"]["name"], o["properties"]["name"], "{how}");
                for ring in polygons(&o["geometry"]).iter().flatten() {
                    assert!(
                        ring.len() >= 4,
                        "{how} {tolerance} m: feature {i}: {ring:?}"
                    );
                }
                if judged[i] && planar_meetings(&o["geometry"], 7) > 0 {
                    bad.push(f["properties"]["name"].to_string());
                }
            }
            assert!(
                bad.is_empty(),
                "{how} at {tolerance} m: rings meet in {bad:?}"
            );
        }
    }
}

#[test]
fn planar_meetings_counts_crossings_and_touches_not_neighbours() {
    let square =
        json!({"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]]]});
    assert_eq!(planar_meetings(&square, 7), 0);
    let bowtie =
        json!({"type": "Polygon", "coordinates": [[[0, 0], [1, 1], [1, 0], [0, 1], [0, 0]]]});
    assert_eq!(planar_meetings(&bowtie, 7), 1);
    // Two islands, the second's corner on the first's edge once rounded to 7 decimals.
    let touching = json!({"type": "MultiPolygon", "coordinates": [
        [[[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]]],
        [[[1.00000001, 0.5], [2, 0], [2, 1], [1.00000001, 0.5]]]]});
    assert_eq!(planar_meetings(&touching, 8), 0);
    assert_eq!(planar_meetings(&touching, 7), 2);
}

/// An islet whose fit bounds no area is kept as a triangle of its own positions, as an arc: it
/// is judged with its feature's other rings as any arc is. Bermuda (world-atlas 10m) at 5 km:
/// kept only once its feature was rebuilt, after the arcs were judged, the islet's triangle
/// crossed the main island's and GEOS found the feature invalid (as it did six more of the 10m
/// countries whose input is valid: South Korea, Oman, the UAE, the United Kingdom, Egypt and
/// the Faroes).
#[test]
fn an_islet_kept_small_is_judged_with_its_features_other_rings() {
    let input = read_fixture_json("world_atlas_10m_bermuda.geojson");
    assert!(geo_polygons(&input["features"][0]["geometry"]).is_valid());
    let mut kept_seen = false;
    for tolerance_m in [2000.0, 5000.0, 8000.0] {
        let c = fit(&input, tolerance_m);
        let o = &c.features[0];
        let out = geo_polygons(&o["geometry"]);
        assert!(
            out.is_valid() && planar_meetings(&o["geometry"], 7) == 0,
            "{tolerance_m} m: {:?} {}",
            out.validation_errors(),
            o["geometry"]
        );
        let fit = &o["properties"]["fit"];
        assert_eq!(fit["tolerance_met"], true, "{tolerance_m} m: {fit}");
        // Where the islet is kept small, it is listed, and written as an arc of the coverage.
        for part in fit["parts"].as_array().unwrap() {
            if part.get("small_ring").is_some() {
                kept_seen = true;
                assert_eq!(part["small_ring"], "kept_as_triangle", "{part}");
                assert_eq!(part["arcs"].as_array().unwrap().len(), 1, "{part}");
                assert!(!fit["kept_rings"].as_array().unwrap().is_empty(), "{fit}");
            }
        }
        // The feature's bound covers every input position.
        let d = worst_vertex_distance_m(&input["features"][0]["geometry"], &o["geometry"]);
        assert!(
            d <= tolerance_m,
            "{tolerance_m} m: an input vertex {d} m off"
        );
    }
    assert!(
        kept_seen,
        "the islet was kept small at none of the tolerances"
    );
}

/// A ring on the other side of another than its input was, with no edges meeting, is refitted
/// until it is not. Egypt and Azerbaijan (world-atlas 10m) at 20 km: Egypt's fitted coast
/// swallowed a Red Sea islet (GEOS: nested shells) and Azerbaijan's shell moved past its hole
/// (hole outside shell), per feature and shared; shared, a kept islet also crossed the coast.
#[test]
fn a_ring_swallowed_by_another_with_no_edges_meeting_is_refitted() {
    let path = fixture_path("world_atlas_10m_egypt_azerbaijan.geojson");
    let input = read_fixture_json("world_atlas_10m_egypt_azerbaijan.geojson");
    let features = input["features"].as_array().unwrap();
    for f in features {
        assert!(
            geo_polygons(&f["geometry"]).is_valid(),
            "{}",
            f["properties"]
        );
    }
    for mode in ["per-feature", "shared"] {
        let o = run_spherefit(
            &[
                "fit",
                "--tolerance-m",
                "20000",
                "--topology",
                mode,
                "-q",
                &path,
            ],
            None,
        );
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let out: Value = serde_json::from_slice(&o.stdout).unwrap();
        for (f, o) in features.iter().zip(out["features"].as_array().unwrap()) {
            let name = &f["properties"]["name"];
            let shape = geo_polygons(&o["geometry"]);
            assert!(
                shape.is_valid(),
                "{mode} {name}: {:?}",
                shape.validation_errors()
            );
            assert_eq!(planar_meetings(&o["geometry"], 7), 0, "{mode} {name}");
            assert_eq!(
                o["properties"]["fit"]["tolerance_met"], true,
                "{mode} {name}"
            );
            let d = worst_vertex_distance_m(&f["geometry"], &o["geometry"]);
            assert!(d <= 20_000.0, "{mode} {name}: an input vertex {d} m off");
        }
    }
}

/// A ring whose arcs fit to no area (an enclave touching its neighbour at one point, an
/// exclave whose border and coast fit as one straight segment) has its arcs refitted tighter
/// until it bounds an area: it stays made of the coverage's arcs. Cyprus and its neighbours
/// (world-atlas 10m) at 5 km: two such rings were kept apart as triangles of their own
/// positions and overlapped Dhekelia and the U.N. buffer zone.
#[test]
fn rings_that_collapse_in_a_coverage_stay_made_of_its_arcs() {
    let input = read_fixture_json("world_atlas_10m_cyprus.geojson");
    let feats = input["features"].as_array().unwrap();
    for tolerance_m in [2000.0, 5000.0, 10000.0] {
        let c = fit(&input, tolerance_m);
        assert_eq!(c.report["tolerance_met"], true, "{}", c.report);
        let shapes: Vec<MultiPolygon<f64>> = c
            .features
            .iter()
            .map(|o| geo_polygons(&o["geometry"]))
            .collect();
        for (i, o) in c.features.iter().enumerate() {
            for part in o["properties"]["fit"]["parts"].as_array().unwrap() {
                assert!(
                    !part["arcs"].as_array().unwrap().is_empty(),
                    "{tolerance_m} m: feature {i}'s ring {} kept apart from the arcs",
                    part["path"]
                );
            }
            if geo_polygons(&feats[i]["geometry"]).is_valid() {
                assert!(shapes[i].is_valid(), "{tolerance_m} m: feature {i}");
            }
        }
        for a in 0..shapes.len() {
            for b in a + 1..shapes.len() {
                let overlap = shapes[a].intersection(&shapes[b]).unsigned_area();
                let smaller = shapes[a].unsigned_area().min(shapes[b].unsigned_area());
                assert!(
                    overlap <= 1e-9 * smaller,
                    "{tolerance_m} m: features {a} and {b} overlap by {overlap} square degrees"
                );
            }
        }
    }
}

/// Arcs of different features are judged against each other too: in a coverage a line crossing
/// or swallowing another is an error whichever features they bound. A coast with an inlet 8.9
/// km wide and 3.3 km deep, and another feature's islet in it: at 5 km the coast's fit (a
/// smooth curve) cut across the inlet north of the islet and swallowed it, as Malaysia's coast
/// swallowed Singapore across the Johor Strait (world-atlas 10m), while only arcs of one
/// feature were paired.
#[test]
fn an_islet_of_one_feature_is_not_swallowed_by_anothers_coast() {
    let coast = json!([
        [0.0, 0.0],
        [0.2, 0.0],
        [0.2, 0.1],
        [0.14, 0.1],
        [0.1, 0.07],
        [0.06, 0.1],
        [0.0, 0.1],
        [0.0, 0.0]
    ]);
    let islet = json!([
        [0.099, 0.085],
        [0.101, 0.085],
        [0.101, 0.09],
        [0.099, 0.09],
        [0.099, 0.085]
    ]);
    let doc = json!({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"name": "coast"},
         "geometry": {"type": "Polygon", "coordinates": [coast]}},
        {"type": "Feature", "properties": {"name": "islet"},
         "geometry": {"type": "Polygon", "coordinates": [islet]}},
    ]});
    let c = fit(&doc, 5000.0);
    let land = geo_polygons(&c.features[0]["geometry"]);
    let isle = geo_polygons(&c.features[1]["geometry"]);
    assert!(isle.unsigned_area() > 0.0);
    let overlap = land.intersection(&isle).unsigned_area();
    assert!(
        overlap <= 1e-9 * isle.unsigned_area(),
        "the islet is {} % under the coast: {}",
        100.0 * overlap / isle.unsigned_area(),
        c.features[0]["geometry"]
    );
    assert_eq!(c.report["tolerance_met"], true, "{}", c.report);
}
