//! The compression bench's baselines on the fixture lines (the three US–Mexico
//! borders and the GPS tracks) at T in 1, 5, 25, 100 and 500 m: the optimal subset polyline
//! meets T at every input point (recomputed here with a cross-track distance written apart
//! from the library's), keeps the ends, never has more vertices than Douglas–Peucker, and
//! cannot lose a vertex; the byte coding of it, of DP's polyline and of the fitted spline
//! decodes to within the quantum.

use crate::helpers::{angle as ang, distance_to_arc as dist_to_arc, read_fixture_json};
use crate::helpers::{unit3 as unit, EARTH_RADIUS_M};
use spherefit::sphere::compress::coding::{
    decode_curve, encode_curve, encode_polyline, quantum_for_tolerance,
};
use spherefit::sphere::compress::optimal::optimal_subset;
use spherefit::sphere::compress::simplify::douglas_peucker;
use spherefit::sphere::{fit_to_tolerance, KnotRule, PointSet, ToleranceOptions};

const TOLERANCES_M: [f64; 5] = [1.0, 5.0, 25.0, 100.0, 500.0];

/// The largest distance of a point from the segment of `kept` that spans it.
fn worst(points: &PointSet, kept: &[usize]) -> f64 {
    let mut w: f64 = 0.0;
    for s in kept.windows(2) {
        for k in s[0] + 1..s[1] {
            w = w.max(dist_to_arc(
                points.get(k),
                points.get(s[0]),
                points.get(s[1]),
            ));
        }
    }
    w
}

fn fixture_lines() -> Vec<(String, PointSet)> {
    let mut out = Vec::new();
    for file in [
        "us_mexico_border_natural_earth.geojson",
        "gps_tracks_slovenia_gpxpy.geojson",
    ] {
        let doc = read_fixture_json(file);
        for (i, f) in doc["features"].as_array().unwrap().iter().enumerate() {
            let mut rows: Vec<[f64; 3]> = Vec::new();
            for c in f["geometry"]["coordinates"].as_array().unwrap() {
                let v = unit(c[0].as_f64().unwrap(), c[1].as_f64().unwrap());
                if rows.last() != Some(&v) {
                    rows.push(v);
                }
            }
            out.push((
                format!("{file} feature {i}"),
                PointSet::try_from_rows(&rows).unwrap(),
            ));
        }
    }
    out
}

#[test]
fn the_optimal_subset_meets_t_and_never_loses_to_douglas_peucker() {
    let mut fewer_than_dp = 0;
    for (name, points) in fixture_lines() {
        let n = points.len();
        for tol_m in TOLERANCES_M {
            let tol = tol_m / EARTH_RADIUS_M;
            let kept = optimal_subset(&points, tol);
            let dp = douglas_peucker(&points, tol);
            assert_eq!((kept[0], kept[kept.len() - 1]), (0, n - 1), "{name}");
            assert!(kept.windows(2).all(|w| w[0] < w[1]), "{name}");
            // Independent check, with a hair for the two formulas' rounding (1e-12 rad = 6 µm).
            let w = worst(&points, &kept);
            assert!(
                w <= tol + 1e-12,
                "{name} at {tol_m} m: {} m",
                w * EARTH_RADIUS_M
            );
            assert!(
                kept.len() <= dp.len(),
                "{name} at {tol_m} m: {} > DP {}",
                kept.len(),
                dp.len()
            );
            fewer_than_dp += usize::from(kept.len() < dp.len());
            // Minimal: no single vertex can go (the subset would be shorter and still valid).
            // Checked where cheap: removing vertex v only changes the two segments around it.
            for v in 1..kept.len() - 1 {
                let (a, b) = (kept[v - 1], kept[v + 1]);
                let merged = (a + 1..b)
                    .map(|k| dist_to_arc(points.get(k), points.get(a), points.get(b)))
                    .fold(0.0, f64::max);
                assert!(
                    merged > tol - 1e-12,
                    "{name} at {tol_m} m: vertex {} is not needed",
                    kept[v]
                );
            }
        }
    }
    // It is a real improvement somewhere, not DP renamed.
    assert!(fewer_than_dp >= 10, "{fewer_than_dp}");
}

#[test]
fn stored_bytes_decode_within_the_quantum() {
    for (name, points) in fixture_lines().into_iter().step_by(3) {
        for tol_m in [5.0, 100.0] {
            let tol = tol_m / EARTH_RADIUS_M;
            let q = quantum_for_tolerance(tol);
            let bound = 0.5 * q * 2f64.sqrt() * (1.0 + 1e-9);
            for kept in [optimal_subset(&points, tol), douglas_peucker(&points, tol)] {
                let rows: Vec<&[f64]> = kept.iter().map(|&i| points.get(i)).collect();
                let vertices = PointSet::try_from_rows(&rows).unwrap();
                let bytes = encode_polyline(&vertices, q).unwrap();
                // Fewer than 3 bytes a lon/lat pair beyond the first: the deltas are small.
                assert!(
                    bytes.len() < 16 + 6 * kept.len(),
                    "{name}: {} bytes",
                    bytes.len()
                );
                let (back, rule) = decode_curve(&bytes, q).unwrap();
                assert_eq!((back.degree(), rule), (1, KnotRule::Uniform));
                for (v, row) in rows.iter().enumerate() {
                    let e = ang(back.control_points().get(v), row);
                    assert!(e <= bound, "{name}: vertex {v} off by {e}");
                }
            }
            let fit = fit_to_tolerance(&points, None, tol, &ToleranceOptions::default()).unwrap();
            let bytes = encode_curve(&fit.spline, fit.knot_rule, q).unwrap();
            let (back, rule) = decode_curve(&bytes, q).unwrap();
            assert_eq!(rule, fit.knot_rule, "{name}");
            assert_eq!(back.degree(), fit.spline.degree());
            let ctrl = fit.spline.control_points();
            assert_eq!(back.control_points().len(), ctrl.len());
            for v in 0..ctrl.len() {
                assert!(
                    ang(back.control_points().get(v), ctrl.get(v)) <= bound,
                    "{name}"
                );
            }
        }
    }
}
