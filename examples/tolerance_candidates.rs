//! What the tolerance fitter tries on one ring of a GeoJSON FeatureCollection of LineStrings:
//! its time, every candidate (degree, knot rule, stored numbers, two-way distance) and the
//! vertex counts of Douglas–Peucker, the ordered Douglas–Peucker and the optimal subset at the
//! same tolerance. A diagnostic for the speed work of `docs/speed.md` ("Across tolerances").
//!
//! `cargo run --release --example tolerance_candidates -- FILE TOLERANCE_M [FEATURE_INDEX]`
//! (without an index: the feature with the most positions; `all`: one line per feature, the
//! slowest first, and the time by what the fit went through).

use spherefit::earth::lonlat::{lonlat_to_unit, EARTH_RADIUS_M};
use spherefit::sphere::certify::two_way::{two_way_distance, TwoWayOptions};
use spherefit::sphere::compress::optimal::{optimal_subset, subset_curve};
use spherefit::sphere::compress::simplify::{douglas_peucker, douglas_peucker_ordered};
use spherefit::sphere::{fit_to_tolerance, PointSet, ToleranceOptions};
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let doc: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&args[0]).expect("readable file")).unwrap();
    let tol_m: f64 = args[1].parse().unwrap();
    let features = doc["features"].as_array().expect("a FeatureCollection");
    let coords = |i: usize| features[i]["geometry"]["coordinates"].as_array().unwrap();
    if args.get(2).map(String::as_str) == Some("all") {
        return all(features, tol_m);
    }
    let index = args.get(2).map_or_else(
        || {
            (0..features.len())
                .max_by_key(|&i| coords(i).len())
                .unwrap()
        },
        |a| a.parse().unwrap(),
    );
    let points = unit_points(coords(index));
    let tol = tol_m / EARTH_RADIUS_M;
    let start = Instant::now();
    let fit = fit_to_tolerance(&points, None, tol, &ToleranceOptions::default()).unwrap();
    let secs = start.elapsed().as_secs_f64();
    println!(
        "feature {index}: {} points, T = {tol_m} m: {secs:.3} s, degree {}, {} stored, two-way {:.1} m, met {}",
        points.len(),
        fit.degree,
        fit.stored_numbers,
        fit.two_way_rad * EARTH_RADIUS_M,
        fit.tolerance_met
    );
    for c in &fit.candidates {
        println!(
            "  candidate degree {} {:?}: {} stored, two-way {:.1} m, met {}",
            c.degree,
            c.knot_rule,
            c.stored_numbers,
            c.two_way_rad * EARTH_RADIUS_M,
            c.tolerance_met
        );
    }
    for (name, kept) in [
        ("douglas_peucker", douglas_peucker(&points, tol)),
        (
            "douglas_peucker_ordered",
            douglas_peucker_ordered(&points, tol),
        ),
        ("optimal_subset", optimal_subset(&points, tol)),
    ] {
        let (spline, params) = subset_curve(&points, &kept).unwrap();
        let tw = two_way_distance(&spline, &points, &params, &TwoWayOptions::default()).unwrap();
        println!(
            "  {name}: {} vertices, two-way {:.1} m",
            kept.len(),
            tw.upper_rad * EARTH_RADIUS_M
        );
    }
}

/// The positions of a LineString as unit vectors, repeats dropped.
fn unit_points(coords: &[serde_json::Value]) -> PointSet {
    let mut rows: Vec<[f64; 3]> = Vec::new();
    for c in coords {
        let u = lonlat_to_unit(c[0].as_f64().unwrap(), c[1].as_f64().unwrap());
        if rows.last() != Some(&u) {
            rows.push(u);
        }
    }
    PointSet::try_from_rows(&rows).unwrap()
}

/// Every feature fitted on one thread: the slowest, and the time by what the fit went
/// through (the first candidate proven, a later one, degree 2 or 3 chosen).
fn all(features: &[serde_json::Value], tol_m: f64) {
    let tol = tol_m / EARTH_RADIUS_M;
    let mut rows = Vec::new();
    for (i, f) in features.iter().enumerate() {
        let points = unit_points(f["geometry"]["coordinates"].as_array().unwrap());
        if points.len() < 2 {
            continue;
        }
        let start = Instant::now();
        let Ok(fit) = fit_to_tolerance(&points, None, tol, &ToleranceOptions::default()) else {
            continue;
        };
        let secs = start.elapsed().as_secs_f64();
        let first_met = fit.candidates.first().is_some_and(|c| c.tolerance_met);
        let kind = match (first_met, fit.degree) {
            (true, 1) => "first candidate met, degree 1",
            (true, _) => "first candidate met, degree 2-3",
            (false, _) => "a later candidate",
        };
        rows.push((
            secs,
            i,
            points.len(),
            fit.candidates.len(),
            fit.stored_numbers,
            kind,
        ));
    }
    rows.sort_by(|a, b| b.0.total_cmp(&a.0));
    let total: f64 = rows.iter().map(|r| r.0).sum();
    println!("T = {tol_m} m: {} features, {total:.2} s", rows.len());
    for kind in [
        "first candidate met, degree 1",
        "first candidate met, degree 2-3",
        "a later candidate",
    ] {
        let (n, s) = rows
            .iter()
            .filter(|r| r.5 == kind)
            .fold((0, 0.0), |(n, s), r| (n + 1, s + r.0));
        println!("  {kind}: {n} features, {s:.2} s");
    }
    for (secs, i, n, c, stored, kind) in rows.iter().take(25) {
        println!(
            "  feature {i}: {n} points, {secs:.3} s, {c} candidates, {stored} stored ({kind})"
        );
    }
}
