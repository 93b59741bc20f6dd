use super::*;
use crate::earth::coverage::fit_arc::refit_around;
use crate::earth::lonlat::{lonlat_to_unit, m_to_rad};
use crate::sphere::geometry::arc::distance_to_arc;
use crate::sphere::FitOptions;

fn job(tolerance_m: f64) -> Job {
    Job {
        operation: Operation::FitToTolerance {
            options: FitOptions::faithful(),
            tolerance_m,
        },
        ..Job::fit(FitOptions::default())
    }
}

/// A wavy border from (0, 0) to (0, 2) shared by a west and an east square-ish feature.
fn two_neighbours() -> Value {
    let border: Vec<[f64; 2]> = (0..=100)
        .map(|i| {
            let t = i as f64 / 100.0;
            [0.05 * (12.0 * t).sin(), 2.0 * t]
        })
        .collect();
    let mut west = border.clone();
    west.extend([[-2.0, 2.0], [-2.0, 0.0], border[0]]);
    let mut east: Vec<[f64; 2]> = border.iter().rev().copied().collect();
    east.extend([[2.0, 0.0], [2.0, 2.0], border[100]]);
    json!({"type": "FeatureCollection", "features": [
        {"type": "Feature", "id": "w", "properties": {"name": "west"}, "geometry": {"type": "Polygon", "coordinates": [west]}},
        {"type": "Feature", "properties": null, "geometry": {"type": "Polygon", "coordinates": [east]}},
        {"type": "Feature", "properties": {"p": 1}, "geometry": {"type": "Point", "coordinates": [5, 5]}}
    ]})
}

#[test]
fn neighbours_share_identical_coordinates_and_arcs_are_stored_once() {
    let doc = Document::parse(two_neighbours(), false).unwrap();
    let c = fit_coverage(doc, &job(500.0)).unwrap();
    assert_eq!(c.graph.arcs.len(), 3);
    assert_eq!(c.report["shared_arcs"], 1);
    assert_eq!(c.report["tolerance_met"], true);
    let w = &c.features[0]["geometry"]["coordinates"][0];
    let e = &c.features[1]["geometry"]["coordinates"][0];
    let as_set = |r: &Value| -> std::collections::BTreeSet<String> {
        r.as_array()
            .unwrap()
            .iter()
            .map(|p| p.to_string())
            .collect()
    };
    let (ws, es) = (as_set(w), as_set(e));
    let common = ws.intersection(&es).count();
    // Every output point of the shared arc is in both rings, bit for bit.
    let shared = c.graph.arcs.iter().position(|a| a.uses == 2).unwrap();
    assert_eq!(common, c.arcs[shared].dense_ll.len());
    assert!(common > 2);
    // Arcs counted once: the dataset stores less than the features' sum.
    let once = c.report["stored_numbers"].as_u64().unwrap();
    let sum = c.report["stored_numbers_per_feature_sum"].as_u64().unwrap();
    assert_eq!(sum - once, c.arcs[shared].stored_numbers as u64);
    // Properties, ids and other features pass through.
    assert_eq!(c.features[0]["id"], "w");
    assert_eq!(c.features[0]["properties"]["name"], "west");
    assert_eq!(c.features[2]["geometry"]["coordinates"], json!([5, 5]));
    assert!(
        c.features[0]["properties"]["fit"]["area_change"]
            .as_f64()
            .unwrap()
            .abs()
            < 1e-3
    );
}

#[test]
fn arcs_that_cross_their_neighbours_are_refitted_tighter() {
    // A corridor 445 to 890 m wide between two features, its borders wiggling by 5 km
    // together and sampled differently: at 1.5 km each border's fit may wander 1.5 km, so the
    // two cross; at an eighth of that (3 halvings) they cannot. (Which tolerances make them
    // cross depends on the fitter: at 2 km they did until polylines were fitted to their
    // whole target first, at 1.5 km they did not before that.)
    let wave = |n: usize, offset_deg: f64, extra: f64| -> Vec<[f64; 2]> {
        (0..=n)
            .map(|i| {
                let t = i as f64 / n as f64;
                [
                    3.0 * t,
                    offset_deg
                        + 0.045 * (9.0 * t).sin()
                        + 0.02 * (23.0 * t).sin()
                        + extra * (41.0 * t).sin(),
                ]
            })
            .collect()
    };
    // 445 to 890 m apart.
    let (low, high) = (wave(97, 0.0, 0.0), wave(61, 0.006, 0.002));
    let mut a = low.clone();
    a.extend([[3.0, -1.0], [0.0, -1.0], low[0]]);
    let mut corridor: Vec<[f64; 2]> = low.clone();
    corridor.extend(high.iter().rev());
    corridor.push(low[0]);
    let mut b: Vec<[f64; 2]> = high.iter().rev().copied().collect();
    b.extend([[0.0, 1.0], [3.0, 1.0], high[high.len() - 1]]);
    let doc = json!({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {}, "geometry": {"type": "Polygon", "coordinates": [a]}},
        {"type": "Feature", "properties": {}, "geometry": {"type": "Polygon", "coordinates": [corridor]}},
        {"type": "Feature", "properties": {}, "geometry": {"type": "Polygon", "coordinates": [b]}}
    ]});
    let c = fit_coverage(Document::parse(doc, false).unwrap(), &job(1500.0)).unwrap();
    assert!(
        c.report["tightened_arcs"].as_u64().unwrap() >= 1,
        "{}",
        c.report
    );
    assert_eq!(c.report["crossings_left"], json!([]));
    assert_eq!(c.report["tolerance_met"], true);
    let tightened: Vec<&FittedArc> = c
        .arcs
        .iter()
        .filter(|a| a.tolerance_rad < m_to_rad(1500.0))
        .collect();
    // Refitted around their meetings only: within the job's tolerance everywhere.
    assert!(tightened
        .iter()
        .all(|a| a.max_error_rad.max(a.two_way_rad) <= m_to_rad(1500.0)));
    assert_eq!(
        c.features[1]["properties"]["fit"]["tightened_arcs"]
            .as_u64()
            .unwrap() as usize,
        tightened.len()
    );
}

#[test]
fn an_arc_is_refitted_only_around_where_it_meets() {
    // A jagged coast 330 km long fitted at 300 m as a polyline, then refitted at 75 m around
    // two of its segments: its vertices outside the two windows stay where they were, the
    // windows' positions are within 75 m of the new arc, and the whole arc within 300 m.
    let coast: Vec<[f64; 3]> = (0..=600)
        .map(|i| {
            let t = i as f64 / 600.0;
            lonlat_to_unit(
                3.0 * t,
                0.03 * (11.0 * t).sin() + 0.004 * (i as f64 * 2.3).sin(),
            )
        })
        .collect();
    let j = job(300.0);
    let rule = ToleranceRule::new(300.0, j.output.precision);
    let parameterization = FitOptions::faithful().parameterization;
    let old = fit_arc(&coast, false, rule, 3, parameterization, &j).unwrap();
    assert_eq!(old.spline.degree(), 1);
    let m = old.control_ll.len();
    assert!(m > 40, "{m} vertices");
    let (s1, s2) = (m / 4, m / 2);
    let tight = ToleranceRule::new(75.0, j.output.precision);
    let new = refit_around(
        &coast,
        false,
        &old,
        (&[s1, s2], 1),
        tight,
        parameterization,
        &j,
    )
    .unwrap()
    .expect("a polyline written as its vertices is refitted around its segments");
    let n = new.control_ll.len();
    // The windows are old vertices s - 1 ..= s + 2, their ends kept.
    assert_eq!(new.control_ll[..s1], old.control_ll[..s1]);
    assert_eq!(new.control_ll[n - (m - s2 - 2)..], old.control_ll[s2 + 2..]);
    assert_ne!(new.control_ll, old.control_ll);
    assert!(new.max_error_rad.max(new.two_way_rad) <= m_to_rad(300.0));
    // The positions between the first window's ends are within 75 m of the new arc.
    let (lo, hi) = (old.control_ll[s1 - 1], old.control_ll[s1 + 2]);
    let dense: Vec<[f64; 3]> = new.dense.clone();
    let inside = coast.iter().filter(|p| {
        let (lon, _) = crate::earth::lonlat::unit_to_lonlat(*p);
        lon > lo[0] && lon < hi[0]
    });
    let mut count = 0;
    for p in inside {
        let d = dense
            .windows(2)
            .map(|w| distance_to_arc(p, &w[0], &w[1]))
            .fold(f64::INFINITY, f64::min);
        assert!(d <= m_to_rad(75.0) * 1.01, "{} m", d / m_to_rad(1.0));
        count += 1;
    }
    assert!(count >= 2, "{count} positions");
}

#[test]
fn an_island_is_one_closed_arc_smooth_across_its_seam() {
    let ring: Vec<[f64; 2]> = (0..=1000)
        .map(|i| {
            let a = std::f64::consts::TAU * (i % 1000) as f64 / 1000.0;
            [
                10.0 + 2.0 * a.cos(),
                40.0 + 1.5 * a.sin() + 0.1 * (3.0 * a).sin(),
            ]
        })
        .collect();
    let doc = Document::parse(json!({"type": "Polygon", "coordinates": [ring]}), false).unwrap();
    let c = fit_coverage(doc, &job(50.0)).unwrap();
    assert_eq!(c.graph.arcs.len(), 1);
    let a = &c.arcs[0];
    assert!(a.tolerance_met);
    assert_eq!(a.dense_ll.first(), a.dense_ll.last());
    assert_eq!(a.seam, Some("smooth"), "degree {}", a.spline.degree());
}

#[test]
fn a_ring_that_bounds_no_area_is_kept() {
    // A ring that bounds no area is kept as it came and listed, as per-feature fitting
    // keeps it.
    let doc = Document::parse(
        json!({"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [0, 0], [1, 0], [0, 0]]]}),
        false,
    )
    .unwrap();
    let c = fit_coverage(doc, &job(10.0)).unwrap();
    assert_eq!(c.report["kept_rings"], json!(["/coordinates/0"]));
    assert_eq!(
        c.features[0]["geometry"]["coordinates"],
        json!([[[0.0, 0.0], [1.0, 0.0], [0.0, 0.0], [1.0, 0.0], [0.0, 0.0]]])
    );
    assert!(
        c.feature_rings[0].is_none(),
        "TopoJSON writes it as its own arcs"
    );
    // Bad positions are still errors, with their pointer.
    let doc = Document::parse(
        json!({"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 95], [0, 0]]]}),
        false,
    )
    .unwrap();
    let e = fit_coverage(doc, &job(10.0)).unwrap_err();
    assert_eq!(e.pointer, "/coordinates/0/2/1");
}

#[test]
fn a_ring_kept_small_counts_in_its_features_bound() {
    // An islet of the 10m countries (Croatia, ring 22) whose fitted outline bounds no area at
    // 1 km: it is kept as a triangle of its own positions, 981 m from its farthest one. The
    // feature's two-way distance (and max error) must cover that, not only its arcs'.
    let ring = [
        [14.614346143461432, 44.34090758282966],
        [14.643146431464316, 44.32571038740073],
        [14.661146611466108, 44.308824614701905],
        [14.657546575465773, 44.30544746016213],
        [14.639546395463952, 44.31220176924165],
        [14.599945999460004, 44.339219005559784],
        [14.59634596345964, 44.34766189190921],
        [14.614346143461432, 44.34090758282966],
    ];
    // GeoJSON writes the kept ring at 7 decimals; TopoJSON on its grid, here 10^-3 degrees
    // (up to 79 m off), which the kept positions and the bound must allow for.
    for (format, decimals) in [(OutputFormat::GeoJson, 7), (OutputFormat::TopoJson, 3)] {
        let doc =
            Document::parse(json!({"type": "Polygon", "coordinates": [ring]}), false).unwrap();
        let mut j = job(1000.0);
        j.format = format;
        j.output.precision = 3;
        let c = fit_coverage(doc, &j).unwrap();
        assert_eq!(c.report["kept_rings"], json!(["/coordinates/0"]));
        check_kept_bound(&ring, &c.features[0], decimals);
    }
}

/// The feature's bound covers its kept ring's distance as written at `decimals`.
fn check_kept_bound(ring: &[[f64; 2]], feature: &Value, decimals: u32) {
    let fit = &feature["properties"]["fit"];
    let written: Vec<[f64; 3]> = feature["geometry"]["coordinates"][0]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| {
            let r = |v: &Value| crate::earth::lonlat::round_to(v.as_f64().unwrap(), decimals);
            lonlat_to_unit(r(&p[0]), r(&p[1]))
        })
        .collect();
    // Every input position's distance to the written outline (vertex to great-circle edge).
    let farthest_m = ring
        .iter()
        .map(|p| {
            let q = lonlat_to_unit(p[0], p[1]);
            written
                .windows(2)
                .map(|e| distance_to_arc(&q, &e[0], &e[1]))
                .fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max)
        * crate::earth::lonlat::EARTH_RADIUS_M;
    assert!(farthest_m > 600.0, "{farthest_m}");
    let two_way = fit["two_way_distance_m"].as_f64().unwrap();
    assert!(two_way >= farthest_m, "{two_way} m < {farthest_m} m");
    assert!(fit["max_error_m"].as_f64().unwrap() >= farthest_m - 0.01);
    assert_eq!(fit["tolerance_met"], json!(true));
}

#[test]
fn a_polygon_coverage_written_as_topojson_lies_on_the_coarser_grid_within_the_tolerance() {
    let mut doc = two_neighbours();
    doc["features"].as_array_mut().unwrap().pop();
    let mut j = job(1000.0);
    j.format = OutputFormat::TopoJson;
    j.output.precision = 3;
    j.output.grid_multiple = 4;
    let c = fit_coverage(Document::parse(doc, false).unwrap(), &j).unwrap();
    assert_eq!(c.grid_multiple, 4);
    let on_grid = |x: f64| ((x * 250.0).round() - x * 250.0).abs() < 1e-9;
    for a in &c.arcs {
        assert!(
            a.dense_ll.iter().flatten().all(|&x| on_grid(x)),
            "{:?}",
            a.dense_ll
        );
        assert!(a.tolerance_met && a.two_way_rad <= m_to_rad(1000.0));
    }
    let t = crate::earth::coverage::topojson::to_topology(c, 3, crate::earth::Carry::Geometry);
    assert_eq!(t["transform"]["scale"], json!([0.004, 0.004]));
    // With a feature fitted on its own (a point), the coverage stays on the decimal grid.
    let c = fit_coverage(Document::parse(two_neighbours(), false).unwrap(), &j).unwrap();
    assert_eq!(c.grid_multiple, 1);
}

#[test]
fn a_coverage_read_and_rebuilt_on_many_threads_is_the_one_made_on_one() {
    // The world 110m fixture (177 countries, a line and a point added so some slots are
    // processed one by one), read with `parse_json` and fitted in pools of 1 and 4 threads:
    // the steps that run per feature in parallel (reading, rebuilding) give the same output.
    let text = std::fs::read(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/fixtures/coverage_world_110m.geojson"
    ))
    .unwrap();
    let mut value = crate::earth::features::parse_json(&text).unwrap();
    assert_eq!(value, serde_json::from_slice::<Value>(&text).unwrap());
    let features = value["features"].as_array_mut().unwrap();
    features.insert(
        3,
        json!({"type": "Feature", "properties": {}, "geometry": {"type": "LineString", "coordinates": [[0, 0], [1, 1], [2, 0]]}}),
    );
    features.push(json!({"type": "Feature", "properties": null, "geometry": {"type": "Point", "coordinates": [5, 5]}}));
    let fit_on = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let doc = Document::parse(value.clone(), false).unwrap();
        let c = pool.install(|| fit_coverage(doc, &job(1000.0))).unwrap();
        (c.features, c.report, c.feature_rings)
    };
    let one = fit_on(1);
    assert_eq!(one.0.len(), 179);
    assert_eq!(one.0[3]["geometry"]["type"], "LineString");
    assert_eq!(fit_on(4), one);
}
