//! The compression bench: numbers stored by [`fit_to_tolerance`] and by a spherical
//! Douglas–Peucker at the same max geodesic error, and the time of each, for the US–Mexico 10m
//! border, the GPS tracks in `fixtures/` and synthetic smooth tracks, at 1, 5, 25, 100 and 500 m.
//!
//! ```text
//! cargo run --release --example compression            # the markdown table
//! cargo run --release --example compression -- --ablation   # each idea switched off in turn
//! ```
//!
//! Numbers are counted as `fit_to_tolerance` documents: 2 per control point (lon/lat), one per
//! stored knot, one for the degree; Douglas–Peucker stores 2 per kept vertex. The spline's error
//! is the parametric one at its returned data parameters (never smaller than the closest-point
//! distance); Douglas–Peucker's is the cross-track distance to its own segment.

use spherefit::earth::{lonlat_to_unit, EARTH_RADIUS_M};
use spherefit::sphere::simplify::{douglas_peucker, max_deviation};
use spherefit::sphere::tolerance::polyline_numbers;
use spherefit::sphere::{fit_to_tolerance, PointSet, ToleranceOptions};
use std::time::Instant;

const TOLERANCES_M: [f64; 5] = [1.0, 5.0, 25.0, 100.0, 500.0];

/// One line of a data set, with optional timestamps.
struct Line {
    points: PointSet,
}

struct DataSet {
    name: String,
    lines: Vec<Line>,
}

fn read_lines(path: &str, filter: impl Fn(&serde_json::Value) -> bool) -> Vec<Line> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let doc: serde_json::Value = serde_json::from_str(&text).unwrap();
    let mut out = Vec::new();
    for f in doc["features"].as_array().unwrap() {
        if !filter(&f["properties"]) {
            continue;
        }
        let coords = f["geometry"]["coordinates"].as_array().unwrap();
        let mut rows: Vec<[f64; 3]> = Vec::with_capacity(coords.len());
        for c in coords {
            let v = lonlat_to_unit(c[0].as_f64().unwrap(), c[1].as_f64().unwrap());
            // Repeated positions carry no shape; drop them as the Earth layer does.
            if rows.last() != Some(&v) {
                rows.push(v);
            }
        }
        out.push(Line {
            points: PointSet::try_from_rows(&rows).unwrap(),
        });
    }
    out
}

/// A point `north_m` north and `east_m` east of (lon0, lat0), on the sphere (small offsets).
fn offset(lon0: f64, lat0: f64, east_m: f64, north_m: f64) -> [f64; 3] {
    let lat = lat0 + (north_m / EARTH_RADIUS_M).to_degrees();
    let lon = lon0 + (east_m / (EARTH_RADIUS_M * lat0.to_radians().cos())).to_degrees();
    lonlat_to_unit(lon, lat)
}

/// A smooth meandering 20 km track sampled every 5 m (4001 points): two sine waves across a
/// straight course, like a road or river, no noise.
fn smooth_track() -> Line {
    let rows: Vec<[f64; 3]> = (0..=4000)
        .map(|i| {
            let s = i as f64 * 5.0;
            let y = 400.0 * (s / 1500.0).sin() + 1500.0 * (s / 7000.0).sin();
            offset(14.0, 46.0, s, y)
        })
        .collect();
    Line {
        points: PointSet::try_from_rows(&rows).unwrap(),
    }
}

/// A transatlantic flight New York–London, a point every 1 km along the great circle with a
/// smooth lateral deviation of up to 60 km (about 5570 points).
fn flight() -> Line {
    let a = lonlat_to_unit(-73.78, 40.64);
    let b = lonlat_to_unit(-0.45, 51.47);
    let theta = spherefit::sphere::point::angle_between(&a, &b);
    let n = (theta * EARTH_RADIUS_M / 1000.0) as usize;
    // Unit normal of the great circle, for the lateral offset.
    let mut nrm = [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ];
    let l = (nrm.iter().map(|x| x * x).sum::<f64>()).sqrt();
    nrm.iter_mut().for_each(|x| *x /= l);
    let rows: Vec<[f64; 3]> = (0..=n)
        .map(|i| {
            let s = i as f64 / n as f64;
            let p = spherefit::sphere::point::slerp(&a, &b, s).unwrap();
            let dev = 60_000.0 / EARTH_RADIUS_M
                * (std::f64::consts::PI * s).sin().powi(2)
                * (3.0 * std::f64::consts::PI * s).sin();
            let v: Vec<f64> = (0..3)
                .map(|k| p[k] * dev.cos() + nrm[k] * dev.sin())
                .collect();
            [v[0], v[1], v[2]]
        })
        .collect();
    Line {
        points: PointSet::try_from_rows(&rows).unwrap(),
    }
}

fn data_sets() -> Vec<DataSet> {
    let dir = format!("{}/fixtures", env!("CARGO_MANIFEST_DIR"));
    vec![
        DataSet {
            name: "US–Mexico border 10m".into(),
            lines: read_lines(
                &format!("{dir}/us_mexico_border_natural_earth.geojson"),
                |p| p["resolution"] == "10m",
            ),
        },
        DataSet {
            name: "GPS tracks (8 segments)".into(),
            lines: read_lines(&format!("{dir}/gps_tracks_slovenia_gpxpy.geojson"), |_| {
                true
            }),
        },
        DataSet {
            name: "smooth track 20 km / 5 m".into(),
            lines: vec![smooth_track()],
        },
        DataSet {
            name: "flight NYC–LHR 1 km".into(),
            lines: vec![flight()],
        },
    ]
}

struct Row {
    dp_numbers: usize,
    dp_max_m: f64,
    dp_ms: f64,
    sp_numbers: usize,
    sp_max_m: f64,
    sp_ms: f64,
    met: bool,
    degrees: Vec<usize>,
}

fn run(set: &DataSet, tol_m: f64, options: &ToleranceOptions) -> Row {
    let tol = tol_m / EARTH_RADIUS_M;
    let mut row = Row {
        dp_numbers: 0,
        dp_max_m: 0.0,
        dp_ms: 0.0,
        sp_numbers: 0,
        sp_max_m: 0.0,
        sp_ms: 0.0,
        met: true,
        degrees: Vec::new(),
    };
    for line in &set.lines {
        let t0 = Instant::now();
        let kept = douglas_peucker(&line.points, tol);
        row.dp_ms += t0.elapsed().as_secs_f64() * 1e3;
        row.dp_numbers += polyline_numbers(kept.len(), 3);
        row.dp_max_m = row
            .dp_max_m
            .max(max_deviation(&line.points, &kept) * EARTH_RADIUS_M);
        let t0 = Instant::now();
        let fit = fit_to_tolerance(&line.points, None, tol, options).unwrap();
        row.sp_ms += t0.elapsed().as_secs_f64() * 1e3;
        row.sp_numbers += fit.stored_numbers;
        row.sp_max_m = row.sp_max_m.max(fit.metrics.max_error_rad * EARTH_RADIUS_M);
        row.met &= fit.tolerance_met;
        if !row.degrees.contains(&fit.degree) {
            row.degrees.push(fit.degree);
        }
    }
    row.degrees.sort_unstable();
    row
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |name: &str| {
        args.iter()
            .position(|a| a == name)
            .and_then(|i| args.get(i + 1))
            .cloned()
    };
    let mut sets = data_sets();
    if let Some(only) = arg("--only") {
        sets.retain(|s| s.name.contains(&only));
    }
    let tolerances: Vec<f64> = match arg("--tol") {
        Some(t) => vec![t.parse().expect("--tol metres")],
        None => TOLERANCES_M.to_vec(),
    };
    if args.iter().any(|a| a == "--candidates") {
        for set in &sets {
            for &tol_m in &tolerances {
                for line in &set.lines {
                    let fit = fit_to_tolerance(
                        &line.points,
                        None,
                        tol_m / EARTH_RADIUS_M,
                        &ToleranceOptions::default(),
                    )
                    .unwrap();
                    println!("{} {tol_m} m, {} points:", set.name, line.points.len());
                    for c in &fit.candidates {
                        println!(
                            "  degree {} {:?}: {} control points, {} numbers, max {:.2} m",
                            c.degree,
                            c.knot_rule,
                            c.control_points,
                            c.stored_numbers,
                            c.max_error_rad * EARTH_RADIUS_M
                        );
                    }
                }
            }
        }
        return;
    }
    if args.iter().any(|a| a == "--ablation") {
        ablation(&sets);
        return;
    }
    println!("| line | points | tolerance | DP numbers | DP max err | DP time | spline numbers | spline / DP | degree | spline max err | met | spline time |");
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|");
    for set in &sets {
        let points: usize = set.lines.iter().map(|l| l.points.len()).sum();
        for &tol_m in &tolerances {
            let r = run(set, tol_m, &ToleranceOptions::default());
            println!(
                "| {} | {points} | {tol_m} m | {} | {:.2} m | {:.2} ms | {} | {:.2} | {} | {:.2} m | {} | {:.1} ms |",
                set.name,
                r.dp_numbers,
                r.dp_max_m,
                r.dp_ms,
                r.sp_numbers,
                r.sp_numbers as f64 / r.dp_numbers as f64,
                r.degrees
                    .iter()
                    .map(|d| d.to_string())
                    .collect::<Vec<_>>()
                    .join(","),
                r.sp_max_m,
                if r.met { "yes" } else { "**no**" },
                r.sp_ms
            );
        }
    }
}

/// Stored numbers summed over all data sets and tolerances, with each idea switched off.
fn ablation(sets: &[DataSet]) {
    let variants: Vec<(&str, ToleranceOptions)> = vec![
        ("all ideas (default)", ToleranceOptions::default()),
        ("cubic only", ToleranceOptions::default().with_degrees(&[3])),
        (
            "degree 1 only",
            ToleranceOptions::default().with_degrees(&[1]),
        ),
        (
            "no knot removal",
            ToleranceOptions::default().with_reduce(false),
        ),
        (
            "no Lawson reweighting",
            ToleranceOptions::default().with_reweight(false),
        ),
        (
            "no parameter correction",
            ToleranceOptions::default().with_correct_parameters(false),
        ),
        (
            "no uniform (unstored) knots",
            ToleranceOptions::default().with_uniform_knots(false),
        ),
        (
            "plus stored-knot fits of degree >= 2 (free parameters)",
            ToleranceOptions::default().with_adaptive_knots(true),
        ),
        (
            "seed factor 1",
            ToleranceOptions::default().with_seed_factor(1.0),
        ),
        (
            "seed factor 16",
            ToleranceOptions::default().with_seed_factor(16.0),
        ),
    ];
    print!("| variant |");
    for s in sets {
        print!(" {} |", s.name);
    }
    println!(" time |");
    println!("|---|{}---:|", "---:|".repeat(sets.len()));
    for (name, opts) in &variants {
        print!("| {name} |");
        let t0 = Instant::now();
        for s in sets {
            let (mut numbers, mut dp, mut failed) = (0, 0, 0);
            for tol_m in TOLERANCES_M {
                let r = run(s, tol_m, opts);
                numbers += r.sp_numbers;
                dp += r.dp_numbers;
                failed += usize::from(!r.met);
            }
            let miss = if failed > 0 {
                format!(" ({failed} missed)")
            } else {
                String::new()
            };
            print!(
                " {numbers} ({:.2} of DP){miss} |",
                numbers as f64 / dp as f64
            );
        }
        println!(" {:.1} s |", t0.elapsed().as_secs_f64());
    }
}
