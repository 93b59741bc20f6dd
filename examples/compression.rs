//! The compression bench: the spline of [`fit_to_tolerance`], spherical
//! Douglas–Peucker and the optimal subset polyline ([`optimal_subset`]) at the same tolerance T
//! (1, 5, 25, 100 and 500 m) on the three US–Mexico borders and the GPS tracks in `fixtures/`,
//! and synthetic lines (a smooth track, a transatlantic flight, a noisy 1 Hz track with jumps).
//!
//! ```text
//! scripts/compression_bench.sh                      # the markdown table (one thread)
//! scripts/compression_bench.sh --noisy-points 2000  # a shorter noisy track
//! scripts/compression_bench.sh --ablation           # each fitter idea switched off in turn
//! scripts/compression_bench.sh --time               # tracks in time: bytes per hour at an SED bound
//! target/release/examples/compression --write-flights F.geojson  # the synthetic flights as GeoJSON
//! ```
//!
//! `--time`: the fixture's timestamped GPS tracks and two synthetic 1 Hz tracks
//! fitted as position against time ([`fit_to_tolerance`] with the times as parameters, so the
//! vertex error is the synchronized distance, SED) at SED 5, 10, 25 and 100 m, against the
//! time-aware Douglas–Peucker ([`synchronized_douglas_peucker`], TD-TR) at the same bound.
//! Bytes per hour of track: the coding of [`spherefit::sphere::compress::coding`] (angles at T/10) plus
//! the times at 1 s — for the spline the start and the duration (two varints; its knots are
//! already in the stream), for TD-TR the start and each kept vertex's delta (varints).
//!
//! Per method: **numbers** as `fit_to_tolerance` counts them (2 per control point or vertex,
//! one per stored knot, one for the spline's degree); **bytes** in the one coding of
//! [`spherefit::sphere::compress::coding`] (angles at T/10, delta + zigzag varints; a polyline is a
//! degree-1 curve); the **certified two-way distance** to the input line with ordered matching
//! ([`two_way_distance`]; the spline's is the fitter's own, the polylines' are matched at the
//! feet of the input points, [`subset_curve`]), proven within T, proven over T, or undecided at
//! 10⁻⁶ T; and the time to compute each geometry. DP and the optimal subset keep every *vertex*
//! within T of its segment; the two-way distance also bounds the segments between and the
//! order, so it can exceed T for them (GPS points that step backwards).

use spherefit::earth::{lonlat_to_unit, EARTH_RADIUS_M};
use spherefit::sphere::certify::two_way::{two_way_distance, TwoWayOptions};
use spherefit::sphere::compress::coding::{encode_curve, encode_polyline, quantum_for_tolerance};
use spherefit::sphere::compress::optimal::{optimal_subset, subset_curve};
use spherefit::sphere::compress::simplify::{douglas_peucker, synchronized_douglas_peucker};
use spherefit::sphere::compress::tolerance::polyline_numbers;
use spherefit::sphere::{fit_to_tolerance, PointSet, SphericalBSpline, ToleranceOptions};
use std::time::Instant;

const TOLERANCES_M: [f64; 5] = [1.0, 5.0, 25.0, 100.0, 500.0];

/// One line of a data set, with optional timestamps.
struct Line {
    points: PointSet,
}

struct DataSet {
    name: String,
    lines: Vec<Line>,
    /// One of the four sets the fitter's ablation (`docs/tolerance-fitting.md`) measures.
    in_ablation: bool,
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
    let theta = spherefit::sphere::geometry::point::angle_between(&a, &b);
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
            let p = spherefit::sphere::geometry::point::slerp(&a, &b, s).unwrap();
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

/// A deterministic pseudo-random number in [-0.5, 0.5) (as in `tests/it/two_way.rs`).
fn noise(i: usize, salt: usize) -> f64 {
    let x = (i.wrapping_mul(2_654_435_761) ^ salt.wrapping_mul(40_503)) % 10_007;
    x as f64 / 10_007.0 - 0.5
}

/// A 1 Hz track at 60 m/s with 8 m noise and a 300-800 m position jump (and back) every 90 s,
/// like a low-level ADS-B flight: `n` points, the track of
/// `tests/it/two_way.rs` made longer.
fn noisy_track_with_jumps(n: usize) -> Line {
    let rows: Vec<[f64; 3]> = (0..n)
        .map(|i| {
            let s = 60.0 * i as f64;
            let (mut e, mut north) = (s, 3000.0 * (s / 20_000.0).sin());
            e += 8.0 * noise(i, 1);
            north += 8.0 * noise(i, 2);
            if i % 90 == 45 {
                north += 300.0 + 500.0 * (noise(i, 3) + 0.5);
            }
            offset(-100.0, 40.0, e, north)
        })
        .collect();
    Line {
        points: PointSet::try_from_rows(&rows).unwrap(),
    }
}

fn data_sets(noisy_points: usize) -> Vec<DataSet> {
    let dir = format!("{}/fixtures", env!("CARGO_MANIFEST_DIR"));
    let mut sets: Vec<DataSet> = ["110m", "50m", "10m"]
        .iter()
        .map(|res| DataSet {
            name: format!("US–Mexico border {res}"),
            lines: read_lines(
                &format!("{dir}/us_mexico_border_natural_earth.geojson"),
                |p| p["resolution"] == *res,
            ),
            in_ablation: *res == "10m",
        })
        .collect();
    sets.extend([
        DataSet {
            name: "GPS tracks (8 segments)".into(),
            lines: read_lines(&format!("{dir}/gps_tracks_slovenia_gpxpy.geojson"), |_| {
                true
            }),
            in_ablation: true,
        },
        DataSet {
            name: "smooth track 20 km / 5 m".into(),
            lines: vec![smooth_track()],
            in_ablation: true,
        },
        DataSet {
            name: "flight NYC–LHR 1 km".into(),
            lines: vec![flight()],
            in_ablation: true,
        },
        DataSet {
            name: format!("noisy 1 Hz track, jumps ({noisy_points} s)"),
            lines: vec![noisy_track_with_jumps(noisy_points)],
            in_ablation: false,
        },
    ]);
    sets
}

/// Points (seconds) of the noisy 1 Hz track by default: a flight of about 4.4 hours
/// (`--noisy-points N` for another).
const NOISY_POINTS: usize = 16_000;

/// One method's result on a data set at one tolerance (summed or maxed over its lines).
#[derive(Default)]
struct Method {
    numbers: usize,
    bytes: usize,
    /// Largest certified two-way distance over the lines, metres.
    two_way_m: f64,
    /// Every line's two-way distance proven within the tolerance.
    met: bool,
    /// Some line's two-way distance proven over the tolerance.
    over: bool,
    /// Time to compute the geometry (not the two-way check), milliseconds.
    ms: f64,
}

impl Method {
    fn add(&mut self, tw: TwoWay) {
        self.two_way_m = self.two_way_m.max(tw.upper_m);
        self.met &= tw.within == Some(true);
        self.over |= tw.within == Some(false);
    }
}

struct Row {
    spline: Method,
    dp: Method,
    optimal: Method,
    degrees: Vec<usize>,
    /// The fitter's own verdict (two-way and length ratio) on every line.
    spline_tolerance_met: bool,
    /// Time of the polylines' two-way checks, milliseconds.
    check_ms: f64,
}

/// A certified two-way distance, metres: the upper bound, and whether it is proven within the
/// tolerance (`Some(true)`), proven over it (`Some(false)`: the lower bound is over), or neither
/// at the finest precision tried (`None`: within 10⁻⁶ T of it).
#[derive(Clone, Copy)]
struct TwoWay {
    upper_m: f64,
    within: Option<bool>,
}

/// The certified two-way distance of a subset polyline of `line`.
fn polyline_two_way(line: &PointSet, kept: &[usize], tol: f64) -> TwoWay {
    let (curve, params) = subset_curve(line, kept).unwrap();
    decided(None, tol, &curve, line, &params)
}

/// Refines the two-way distance (from `first`, an upper bound already known, such as the
/// fitter's) at the precisions of [`PRECISIONS`] until it is proven within or over `tol`.
fn decided(
    first: Option<f64>,
    tol: f64,
    curve: &SphericalBSpline,
    line: &PointSet,
    params: &[f64],
) -> TwoWay {
    let mut upper = f64::INFINITY;
    for (k, share) in PRECISIONS.iter().enumerate() {
        // The fitter's bound, when given, stands for the first precision.
        let lower = match first {
            Some(f) if k == 0 => {
                upper = f;
                0.0
            }
            _ => {
                let options = TwoWayOptions::default().with_precision_rad(share * tol);
                let tw = two_way_distance(curve, line, params, &options).unwrap();
                assert!(!tw.budget_exhausted, "two-way budget ran out");
                upper = tw.upper_rad;
                tw.lower_rad
            }
        };
        let within = if upper <= tol {
            Some(true)
        } else if lower > tol {
            Some(false)
        } else {
            continue;
        };
        return TwoWay {
            upper_m: upper * EARTH_RADIUS_M,
            within,
        };
    }
    TwoWay {
        upper_m: upper * EARTH_RADIUS_M,
        within: None,
    }
}

/// Precisions of the two-way distances, as shares of the tolerance: the first is the one the
/// fitter decides by; the finer ones are used only while a bound straddles the tolerance.
const PRECISIONS: [f64; 3] = [0.02, 1e-4, 1e-6];

fn polyline_method(
    line: &PointSet,
    tol: f64,
    simplify: fn(&PointSet, f64) -> Vec<usize>,
    m: &mut Method,
) -> f64 {
    let t0 = Instant::now();
    let kept = simplify(line, tol);
    m.ms += t0.elapsed().as_secs_f64() * 1e3;
    m.numbers += polyline_numbers(kept.len(), line.dim());
    let vertices =
        PointSet::try_from_rows(&kept.iter().map(|&i| line.get(i)).collect::<Vec<_>>()).unwrap();
    m.bytes += encode_polyline(&vertices, quantum_for_tolerance(tol))
        .unwrap()
        .len();
    let t0 = Instant::now();
    m.add(polyline_two_way(line, &kept, tol));
    t0.elapsed().as_secs_f64() * 1e3
}

fn run(set: &DataSet, tol_m: f64, options: &ToleranceOptions, polylines: bool) -> Row {
    let tol = tol_m / EARTH_RADIUS_M;
    let fresh = || Method {
        met: true,
        ..Method::default()
    };
    let mut row = Row {
        spline: fresh(),
        dp: fresh(),
        optimal: fresh(),
        degrees: Vec::new(),
        spline_tolerance_met: true,
        check_ms: 0.0,
    };
    for line in &set.lines {
        let t0 = Instant::now();
        let fit = fit_to_tolerance(&line.points, None, tol, options).unwrap();
        row.spline.ms += t0.elapsed().as_secs_f64() * 1e3;
        row.spline.numbers += fit.stored_numbers;
        row.spline.bytes += encode_curve(&fit.spline, fit.knot_rule, quantum_for_tolerance(tol))
            .unwrap()
            .len();
        // The fitter's certified two-way distance of the returned curve at its parameters.
        let t0 = Instant::now();
        let tw = decided(
            Some(fit.two_way_rad),
            tol,
            &fit.spline,
            &line.points,
            &fit.parameters,
        );
        row.check_ms += t0.elapsed().as_secs_f64() * 1e3;
        row.spline.add(tw);
        row.spline_tolerance_met &= fit.tolerance_met;
        if !row.degrees.contains(&fit.degree) {
            row.degrees.push(fit.degree);
        }
        if polylines {
            row.check_ms += polyline_method(&line.points, tol, douglas_peucker, &mut row.dp);
            row.check_ms += polyline_method(&line.points, tol, optimal_subset, &mut row.optimal);
        } else {
            row.dp.numbers += polyline_numbers(douglas_peucker(&line.points, tol).len(), 3);
        }
    }
    row.degrees.sort_unstable();
    row
}

/// The two-way distance in metres: plain when proven within the tolerance, bold `> T` when
/// proven over it, bold `≈ T` when within 10⁻⁶ T of it either way.
fn two_way_cell(m: &Method, tol_m: f64) -> String {
    if m.met {
        format!("{:.2}", m.two_way_m)
    } else if m.over {
        format!("**{:.2} > {tol_m}**", m.two_way_m)
    } else {
        format!("**{:.2} ≈ {tol_m}**", m.two_way_m)
    }
}

/// Writes the two synthetic flights (the transatlantic flight and the noisy 1 Hz track with
/// jumps, `noisy_points` long) as a GeoJSON FeatureCollection of LineStrings at 7 decimals, for
/// `scripts/bytes_bench.sh`.
fn write_flights(path: &str, noisy_points: usize) {
    let feature = |name: &str, line: &Line| {
        let coords: Vec<[f64; 2]> = line
            .points
            .iter()
            .map(|p| {
                let (lon, lat) = spherefit::earth::unit_to_lonlat(&[p[0], p[1], p[2]]);
                [(lon * 1e7).round() / 1e7, (lat * 1e7).round() / 1e7]
            })
            .collect();
        serde_json::json!({"type": "Feature", "properties": {"name": name},
            "geometry": {"type": "LineString", "coordinates": coords}})
    };
    let doc = serde_json::json!({"type": "FeatureCollection", "features": [
        feature("flight NYC–LHR 1 km", &flight()),
        feature("noisy 1 Hz track, jumps", &noisy_track_with_jumps(noisy_points)),
    ]});
    std::fs::write(path, serde_json::to_vec(&doc).unwrap())
        .unwrap_or_else(|e| panic!("{path}: {e}"));
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |name: &str| {
        args.iter()
            .position(|a| a == name)
            .and_then(|i| args.get(i + 1))
            .cloned()
    };
    let noisy_points = arg("--noisy-points")
        .map(|n| n.parse().expect("--noisy-points N"))
        .unwrap_or(NOISY_POINTS);
    if let Some(path) = arg("--write-flights") {
        write_flights(&path, noisy_points);
        return;
    }
    let mut sets = data_sets(noisy_points);
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
                            "  degree {} {:?}: {} control points, {} numbers, max {:.2} m, two-way {:.2} m, length ratio {:.3}, met {}",
                            c.degree,
                            c.knot_rule,
                            c.control_points,
                            c.stored_numbers,
                            c.max_error_rad * EARTH_RADIUS_M,
                            c.two_way_rad * EARTH_RADIUS_M,
                            c.curve_length_ratio,
                            c.tolerance_met
                        );
                    }
                }
            }
        }
        return;
    }
    if args.iter().any(|a| a == "--time") {
        time_table(noisy_points);
        return;
    }
    if args.iter().any(|a| a == "--ablation") {
        sets.retain(|s| s.in_ablation);
        ablation(&sets);
        return;
    }
    let started = Instant::now();
    println!("| line | points | T | spline numbers / bytes | DP numbers / bytes | optimal numbers / bytes | spline bytes / DP, / optimal | two-way m: spline / DP / optimal | spline degree | time ms: spline / DP / optimal | two-way checks s |");
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    let mut check_ms = 0.0;
    for set in &sets {
        let points: usize = set.lines.iter().map(|l| l.points.len()).sum();
        for &tol_m in &tolerances {
            let r = run(set, tol_m, &ToleranceOptions::default(), true);
            check_ms += r.check_ms;
            // Bold where the spline needs more bytes.
            let ratio = |other: &Method| {
                let x = r.spline.bytes as f64 / other.bytes as f64;
                if r.spline.bytes > other.bytes {
                    format!("**{x:.3}**")
                } else {
                    format!("{x:.3}")
                }
            };
            let flag = if r.spline_tolerance_met {
                ""
            } else {
                " (fitter: not met)"
            };
            println!(
                "| {} | {points} | {tol_m} m | {} / {} | {} / {} | {} / {} | {}, {} | {} / {} / {}{flag} | {} | {:.0} / {:.2} / {:.1} | {:.1} |",
                set.name,
                r.spline.numbers,
                r.spline.bytes,
                r.dp.numbers,
                r.dp.bytes,
                r.optimal.numbers,
                r.optimal.bytes,
                ratio(&r.dp),
                ratio(&r.optimal),
                two_way_cell(&r.spline, tol_m),
                two_way_cell(&r.dp, tol_m),
                two_way_cell(&r.optimal, tol_m),
                r.degrees
                    .iter()
                    .map(|d| d.to_string())
                    .collect::<Vec<_>>()
                    .join(","),
                r.spline.ms,
                r.dp.ms,
                r.optimal.ms,
                r.check_ms / 1e3,
            );
        }
    }
    println!(
        "\nwhole run {:.1} s, of which two-way checks outside the fitter {:.1} s",
        started.elapsed().as_secs_f64(),
        check_ms / 1e3
    );
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
            "no greedy stabbing polyline",
            ToleranceOptions::default().with_stabbing(false),
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
            "no degree probe (degrees 2, 3 always tried)",
            ToleranceOptions::default().with_degree_probe(false),
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
                let r = run(s, tol_m, opts, false);
                numbers += r.spline.numbers;
                dp += r.dp.numbers;
                failed += usize::from(!r.spline_tolerance_met);
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

/// SED bounds of the `--time` table, metres.
const SED_TOLERANCES_M: [f64; 4] = [5.0, 10.0, 25.0, 100.0];

/// A track in time: positions and unix seconds (strictly increasing).
struct TimedLine {
    points: PointSet,
    times: Vec<f64>,
}

/// The fixture's tracks whose times strictly increase (six of eight).
fn timed_fixture_tracks() -> Vec<TimedLine> {
    let path = format!(
        "{}/fixtures/gps_tracks_slovenia_gpxpy.geojson",
        env!("CARGO_MANIFEST_DIR")
    );
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    let mut out = Vec::new();
    for f in doc["features"].as_array().unwrap() {
        let Some(t) = f["properties"]["timestamps_unix_s"].as_array() else {
            continue;
        };
        let times: Vec<f64> = t.iter().map(|x| x.as_f64().unwrap()).collect();
        if !times.windows(2).all(|w| w[1] > w[0]) {
            continue;
        }
        let rows: Vec<[f64; 3]> = f["geometry"]["coordinates"]
            .as_array()
            .unwrap()
            .iter()
            .map(|c| lonlat_to_unit(c[0].as_f64().unwrap(), c[1].as_f64().unwrap()))
            .collect();
        out.push(TimedLine {
            points: PointSet::try_from_rows(&rows).unwrap(),
            times,
        });
    }
    out
}

/// A 1 Hz car track at 15 m/s on a gently curving road with 3 m noise, stopping for 60 s every
/// 10 minutes.
fn smooth_1hz_track(n: usize) -> TimedLine {
    let mut s: f64 = 0.0;
    let rows: Vec<[f64; 3]> = (0..n)
        .map(|i| {
            if i % 600 >= 60 {
                s += 15.0;
            }
            let (e, north) = (s, 2000.0 * (s / 5000.0).sin());
            offset(10.0, 50.0, e + 3.0 * noise(i, 4), north + 3.0 * noise(i, 5))
        })
        .collect();
    TimedLine {
        points: PointSet::try_from_rows(&rows).unwrap(),
        times: (0..n).map(|i| 1.7e9 + i as f64).collect(),
    }
}

fn varint_len(mut x: u64) -> usize {
    let mut n = 1;
    while x >= 0x80 {
        x >>= 7;
        n += 1;
    }
    n
}

/// Largest SED (radians) of a TD-TR polyline: each point against the SLERP between its kept
/// neighbours at its time, measured here afresh.
fn polyline_sed(line: &TimedLine, kept: &[usize]) -> f64 {
    let mut worst: f64 = 0.0;
    for w in kept.windows(2) {
        let (a, b) = (line.points.get(w[0]), line.points.get(w[1]));
        for j in w[0]..=w[1] {
            let f = (line.times[j] - line.times[w[0]]) / (line.times[w[1]] - line.times[w[0]]);
            let c = spherefit::sphere::geometry::point::slerp(a, b, f).unwrap();
            worst = worst.max(spherefit::sphere::geometry::point::angle_between(
                line.points.get(j),
                &c,
            ));
        }
    }
    worst
}

/// The `--time` table (module docs).
fn time_table(noisy_points: usize) {
    let noisy = noisy_track_with_jumps(noisy_points);
    let sets: Vec<(String, Vec<TimedLine>)> = vec![
        (
            "GPS tracks in time (6 segments)".into(),
            timed_fixture_tracks(),
        ),
        (
            format!("smooth 1 Hz car track, stops ({noisy_points} s)"),
            vec![smooth_1hz_track(noisy_points)],
        ),
        (
            format!("noisy 1 Hz track, jumps ({noisy_points} s)"),
            vec![TimedLine {
                times: (0..noisy.points.len()).map(|i| 1.7e9 + i as f64).collect(),
                points: noisy.points,
            }],
        ),
    ];
    println!("| track | points | hours | SED T | spline numbers / bytes | TD-TR numbers / bytes | spline bytes / TD-TR | bytes per hour: spline / TD-TR | max SED m: spline / TD-TR | spline two-way m | spline degrees | time ms: spline / TD-TR |");
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for (name, lines) in &sets {
        let points: usize = lines.iter().map(|l| l.points.len()).sum();
        let hours: f64 = lines
            .iter()
            .map(|l| (l.times[l.times.len() - 1] - l.times[0]) / 3600.0)
            .sum();
        for &tol_m in &SED_TOLERANCES_M {
            let tol = tol_m / EARTH_RADIUS_M;
            let q = quantum_for_tolerance(tol);
            let (mut sn, mut sb, mut tn, mut tb) = (0, 0, 0, 0);
            let (mut s_sed, mut t_sed, mut s_tw): (f64, f64, f64) = (0.0, 0.0, 0.0);
            let (mut s_ms, mut t_ms) = (0.0, 0.0);
            let mut met = true;
            let mut degrees = Vec::new();
            for l in lines {
                let t0 = Instant::now();
                let fit =
                    fit_to_tolerance(&l.points, Some(&l.times), tol, &ToleranceOptions::default())
                        .unwrap();
                s_ms += t0.elapsed().as_secs_f64() * 1e3;
                met &= fit.tolerance_met;
                let duration = (l.times[l.times.len() - 1] - l.times[0]).round() as u64;
                sn += fit.stored_numbers + 2;
                sb += encode_curve(&fit.spline, fit.knot_rule, q).unwrap().len()
                    + varint_len(l.times[0].round() as u64)
                    + varint_len(duration);
                // The SED of the returned spline: its error at the given parameters.
                s_sed = s_sed.max(fit.metrics.max_error_rad);
                s_tw = s_tw.max(fit.two_way_rad);
                if !degrees.contains(&fit.degree) {
                    degrees.push(fit.degree);
                }
                let t0 = Instant::now();
                let kept = synchronized_douglas_peucker(&l.points, &l.times, tol);
                t_ms += t0.elapsed().as_secs_f64() * 1e3;
                tn += 3 * kept.len();
                let vertices = PointSet::try_from_rows(
                    &kept.iter().map(|&i| l.points.get(i)).collect::<Vec<_>>(),
                )
                .unwrap();
                tb += encode_polyline(&vertices, q).unwrap().len()
                    + varint_len(l.times[0].round() as u64)
                    + kept
                        .windows(2)
                        .map(|w| varint_len((l.times[w[1]] - l.times[w[0]]).round() as u64))
                        .sum::<usize>();
                t_sed = t_sed.max(polyline_sed(l, &kept));
            }
            degrees.sort_unstable();
            let ratio = sb as f64 / tb as f64;
            let ratio = if sb > tb {
                format!("**{ratio:.3}**")
            } else {
                format!("{ratio:.3}")
            };
            println!(
                "| {name} | {points} | {hours:.2} | {tol_m} m | {sn} / {sb} | {tn} / {tb} | {ratio} | {:.0} / {:.0} | {:.2} / {:.2}{} | {:.2} | {} | {s_ms:.0} / {t_ms:.1} |",
                sb as f64 / hours,
                tb as f64 / hours,
                s_sed * EARTH_RADIUS_M,
                t_sed * EARTH_RADIUS_M,
                if met { "" } else { " (fitter: not met)" },
                s_tw * EARTH_RADIUS_M,
                degrees
                    .iter()
                    .map(|d| d.to_string())
                    .collect::<Vec<_>>()
                    .join(","),
            );
        }
    }
}
