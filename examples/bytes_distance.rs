//! The distance between two GeoJSON files of the same features (same order), for
//! `scripts/bytes_bench.sh`: for each feature, every vertex of one and 3 points inside each
//! of its great-circle segments, measured to the nearest great-circle segment of the other,
//! both ways; the largest over all features, in metres.
//!
//! That is the Hausdorff distance between the two sets of lines, sampled (4 samples per
//! segment), not the *ordered* two-way distance spherefit certifies: it applies to any output
//! (mapshaper's, a TopoJSON read back) without knowing which stretch matches which, and is
//! never above the ordered distance. Segments along ±180° or from a pole (those of polygons
//! cut at the antimeridian or closed along a pole, which the other file may draw uncut) are
//! measured at their vertices only, and the poles themselves not at all. Each sample's nearest
//! segment is looked for near the previous sample's first (a window of 64 segments) and among
//! all of them whenever the window's nearest is farther than the largest distance so far (or
//! than the tolerance), so the maximum is exact: a window that holds only another ring's
//! segments can no longer inflate it (it did, by up to 209 m on the 50m countries, before
//! 2026-12-05).
//!
//! `cargo run --release --example bytes_distance -- A.geojson B.geojson TOLERANCE_M`

use serde_json::Value;

const R: f64 = 6_371_008.8;

/// Features farther apart than this many tolerances are counted, not measured.
const FAR: f64 = 10.0;

fn unit(lon: f64, lat: f64) -> [f64; 3] {
    let (lo, la) = (lon.to_radians(), lat.to_radians());
    [la.cos() * lo.cos(), la.cos() * lo.sin(), la.sin()]
}

fn dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn angle(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    let c = cross(a, b);
    dot(&c, &c).sqrt().atan2(dot(a, b))
}

fn normalise(a: [f64; 3]) -> [f64; 3] {
    let l = dot(&a, &a).sqrt();
    [a[0] / l, a[1] / l, a[2] / l]
}

/// Distance from `p` to the great-circle segment `a`–`b` (radians).
fn to_segment(p: &[f64; 3], a: &[f64; 3], b: &[f64; 3]) -> f64 {
    let n = cross(a, b);
    let nn = dot(&n, &n).sqrt();
    let ends = angle(p, a).min(angle(p, b));
    if nn < 1e-15 {
        return ends;
    }
    let n = [n[0] / nn, n[1] / nn, n[2] / nn];
    let s = dot(p, &n);
    let f = [p[0] - s * n[0], p[1] - s * n[1], p[2] - s * n[2]];
    if dot(&f, &f) < 1e-30 {
        return ends;
    }
    if dot(&cross(a, &f), &n) >= 0.0 && dot(&cross(&f, b), &n) >= 0.0 {
        s.abs().clamp(-1.0, 1.0).asin()
    } else {
        ends
    }
}

/// Every line and ring of a geometry as unit vectors.
fn lines(g: &Value, out: &mut Vec<Vec<[f64; 3]>>) {
    let pos = |v: &Value| -> Vec<[f64; 3]> {
        v.as_array()
            .map(|a| {
                a.iter()
                    .filter_map(|p| Some(unit(p[0].as_f64()?, p[1].as_f64()?)))
                    .collect()
            })
            .unwrap_or_default()
    };
    let c = &g["coordinates"];
    match g["type"].as_str().unwrap_or("") {
        "LineString" => out.push(pos(c)),
        "MultiLineString" | "Polygon" => out.extend(c.as_array().into_iter().flatten().map(pos)),
        "MultiPolygon" => {
            for p in c.as_array().into_iter().flatten() {
                out.extend(p.as_array().into_iter().flatten().map(pos));
            }
        }
        "GeometryCollection" => {
            for x in g["geometries"].as_array().into_iter().flatten() {
                lines(x, out);
            }
        }
        _ => {}
    }
}

/// Largest distance from samples of `from` to the segments of `to` (radians).
fn directed(from: &[Vec<[f64; 3]>], to: &[Vec<[f64; 3]>], tol: f64) -> f64 {
    let segs: Vec<([f64; 3], [f64; 3])> = to
        .iter()
        .flat_map(|l| l.windows(2).map(|w| (w[0], w[1])))
        .collect();
    let singles: Vec<[f64; 3]> = to.iter().filter(|l| l.len() == 1).map(|l| l[0]).collect();
    if segs.is_empty() && singles.is_empty() {
        return if from.iter().all(|l| l.is_empty()) {
            0.0
        } else {
            f64::INFINITY
        };
    }
    let nearest = |p: &[f64; 3], range: std::ops::Range<usize>| -> (f64, usize) {
        let mut best = (f64::INFINITY, range.start);
        for j in range {
            let d = to_segment(p, &segs[j].0, &segs[j].1);
            if d < best.0 {
                best = (d, j);
            }
        }
        best
    };
    let mut worst: f64 = 0.0;
    let mut at = 0usize;
    for l in from {
        let mut samples = Vec::new();
        for (i, p) in l.iter().enumerate() {
            // A polygon cut at ±180 (or closed along a pole) gains edges along the meridian
            // that the other side draws across it: their insides are not sampled, nor is a
            // pole itself (world-atlas's Antarctica runs along 84-85° S, and a writer closing
            // it along the South Pole puts two vertices 530 km from it).
            let on_cut =
                |v: &[f64; 3]| (v[1].abs() < 1e-9 && v[0] < 0.0) || v[2].abs() > 1.0 - 1e-12;
            if p[2].abs() <= 1.0 - 1e-12 {
                samples.push(*p);
            }
            if let Some(q) = l.get(i + 1).filter(|q| !(on_cut(p) && on_cut(q))) {
                for k in 1..4 {
                    let f = k as f64 / 4.0;
                    samples.push(normalise([
                        p[0] * (1.0 - f) + q[0] * f,
                        p[1] * (1.0 - f) + q[1] * f,
                        p[2] * (1.0 - f) + q[2] * f,
                    ]));
                }
            }
        }
        for p in &samples {
            let mut d = singles
                .iter()
                .map(|s| angle(p, s))
                .fold(f64::INFINITY, f64::min);
            if !segs.is_empty() {
                let lo = at.saturating_sub(64);
                let hi = (at + 64).min(segs.len());
                let (mut e, mut j) = nearest(p, lo..hi);
                // The window's nearest is an upper bound: look at every segment whenever it
                // could raise the maximum, so the maximum is exact.
                if e > worst.min(tol) {
                    (e, j) = nearest(p, 0..segs.len());
                }
                at = j;
                d = d.min(e);
            }
            worst = worst.max(d);
        }
    }
    worst
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() != 4 {
        eprintln!("usage: bytes_distance A.geojson B.geojson TOLERANCE_M");
        std::process::exit(2);
    }
    let read = |p: &str| -> Value {
        serde_json::from_slice(&std::fs::read(p).expect("readable")).expect("JSON")
    };
    let (a, b) = (read(&args[1]), read(&args[2]));
    let tol = args[3].parse::<f64>().expect("a tolerance in metres") / R;
    let (fa, fb) = (
        a["features"].as_array().expect("a FeatureCollection"),
        b["features"].as_array().expect("a FeatureCollection"),
    );
    assert_eq!(fa.len(), fb.len(), "the same features in the same order");
    let mut worst: f64 = 0.0;
    let mut dropped = 0;
    let mut far = 0;
    for (x, y) in fa.iter().zip(fb) {
        let (mut lx, mut ly) = (Vec::new(), Vec::new());
        lines(&x["geometry"], &mut lx);
        lines(&y["geometry"], &mut ly);
        // A feature one side lost whole (mapshaper drops lines that collapse) is counted
        // apart: its distance is that of the nearest other feature, not measured here.
        if lx.iter().all(Vec::is_empty) != ly.iter().all(Vec::is_empty) {
            dropped += 1;
            continue;
        }
        let d = directed(&lx, &ly, tol).max(directed(&ly, &lx, tol));
        // A feature drawn somewhere else entirely (mapshaper writes New Zealand of the 50m
        // countries thousands of kilometres off) is counted apart, not in the maximum.
        if d > FAR * tol {
            far += 1;
            if std::env::var_os("BYTES_DISTANCE_WHICH").is_some() {
                eprintln!("far: {:.2} m at {}", d * R, x["properties"]);
            }
            continue;
        }
        if d > worst {
            worst = d;
            if std::env::var_os("BYTES_DISTANCE_WHICH").is_some() {
                eprintln!("{:.2} m at {}", d * R, x["properties"]);
            }
        }
    }
    let mut notes = Vec::new();
    if dropped > 0 {
        notes.push(format!("{dropped} features lost"));
    }
    if far > 0 {
        notes.push(format!("{far} features over {FAR} T"));
    }
    if notes.is_empty() {
        println!("{:.2}", worst * R);
    } else {
        println!("{:.2} ({})", worst * R, notes.join(", "));
    }
}
