//! Rings that meet once fitted are refitted around where they meet only: the rest of the ring
//! comes back as it was fitted, vertex for vertex.

use crate::helpers::run_spherefit;
use serde_json::{json, Value};

/// A jagged coast around (10, 0), about 220 km across, with a bay 500 m deep and 900 m wide on
/// its west side (mouth along longitude 9).
fn coast() -> Vec<[f64; 2]> {
    let n = 720;
    let mut ring = Vec::new();
    for i in 0..n {
        let a = std::f64::consts::TAU * i as f64 / n as f64;
        let calm = 1.0 - (-((a - std::f64::consts::PI) / 0.3).powi(2)).exp();
        let r = 1.0 + calm * (0.01 * (37.0 * a).sin() + 0.004 * (i as f64 * 2.3).sin());
        if i == n / 2 {
            // The bay, counter-clockwise as the ring runs (southwards on this side).
            ring.extend([
                [9.0, 0.004],
                [9.0045, 0.001],
                [9.0045, -0.001],
                [9.0, -0.004],
            ]);
            continue;
        }
        ring.push([10.0 + r * a.cos(), r * a.sin()]);
    }
    ring.push(ring[0]);
    ring
}

/// An island 3 km wide and 6.7 km long off the bay, its east shore 55 to 165 m off the coast.
fn island() -> Vec<[f64; 2]> {
    let mut ring = vec![[8.97, 0.03], [8.97, -0.03]];
    ring.extend((0..=30).map(|k| {
        let y = -0.03 + 0.002 * k as f64;
        [8.9985 + 0.001 * (k % 2) as f64, y]
    }));
    ring.push([8.97, 0.03]);
    ring
}

fn fit(geometry: Value) -> Value {
    let doc = json!({"type": "Feature", "properties": {}, "geometry": geometry});
    let input = serde_json::to_vec(&doc).unwrap();
    let o = run_spherefit(&["fit", "--tolerance-m", "1000", "-q", "-"], Some(&input));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out: Value = serde_json::from_slice(&o.stdout).unwrap();
    out["features"][0].clone()
}

#[test]
fn a_ring_meeting_an_island_is_refitted_around_the_meeting_only() {
    let alone = fit(json!({"type": "Polygon", "coordinates": [coast()]}));
    let both = fit(json!({"type": "MultiPolygon", "coordinates": [[coast()], [island()]]}));
    let ring_alone = alone["geometry"]["coordinates"][0].as_array().unwrap();
    let parts = both["properties"]["fit"]["parts"].as_array().unwrap();
    let coast_part = &parts[0];
    assert_eq!(coast_part["path"], json!([0, 0]));
    // The fitted coast cut across the bay's mouth, through the island, and was refitted.
    let tightened = coast_part["tolerance_m"].as_f64().unwrap();
    assert!(tightened < 1000.0, "{coast_part}");
    assert_eq!(coast_part["tolerance_met"], json!(true));
    let geometry = &both["geometry"];
    assert_eq!(geometry["type"], "MultiPolygon");
    let ring_both = geometry["coordinates"][0][0].as_array().unwrap();
    // The two fits share every vertex but the few between the window's ends (the fit of the
    // coast alone has a 75 km chord along the calm shore there): a common start and end.
    let prefix = ring_alone
        .iter()
        .zip(ring_both)
        .take_while(|(a, b)| a == b)
        .count();
    let suffix = ring_alone
        .iter()
        .rev()
        .zip(ring_both.iter().rev())
        .take_while(|(a, b)| a == b)
        .count();
    assert!(ring_alone.len() > 50, "{} positions", ring_alone.len());
    assert!(
        prefix + suffix + 2 >= ring_alone.len(),
        "{prefix} + {suffix} of {} positions kept",
        ring_alone.len()
    );
    // Near the meeting the coast changed: it no longer cuts into the island.
    assert_ne!(ring_alone, ring_both);
    // Refitted whole at the tighter tolerance, every stretch would have more vertices.
    let whole = run_spherefit(
        &["fit", "--tolerance-m", &tightened.to_string(), "-q", "-"],
        Some(&serde_json::to_vec(&json!({"type": "Polygon", "coordinates": [coast()]})).unwrap()),
    );
    let whole: Value = serde_json::from_slice(&whole.stdout).unwrap();
    let n_whole = whole["features"][0]["geometry"]["coordinates"][0]
        .as_array()
        .unwrap()
        .len();
    assert!(
        ring_both.len() + 20 < n_whole,
        "{} positions spliced, {n_whole} refitted whole",
        ring_both.len()
    );
}
