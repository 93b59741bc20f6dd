//! The GLS-PIA paper's §6 on S², reproduced: Tables 1–2 (uniform, Euclidean-difference and
//! geodesic-difference knots, 30 GLS-PIA iterations) on a simple and a complex curve sampled
//! from spherical B-splines, Table 3 (GLS-PIA against Jupp–Kent, Samir et al., CBC and BCC) on
//! the complex curve, and the same comparison on a helix, a shock line and a curve with sharp
//! corners (the paper's Figures 10–12).
//!
//! `cargo run --release --example paper_tables -- OUT_DIR` writes `OUT_DIR/tables.md` (the
//! tables in Markdown) and `OUT_DIR/<example>.json` (data, ground truth and every method's
//! dense samples, for `scripts/paper_plot.py`). `scripts/paper_tables.sh` runs both and
//! splices the tables into `docs/paper.md`.
//!
//! Every example is a closed formula: no random numbers, no seed. Run times are wall-clock on
//! whatever machine runs this, the best of 3 runs.

use serde_json::json;
use spherefit::sphere::compare::{fit_with, Method, MethodFit, MethodOptions, Smoothing};
use spherefit::sphere::curve::bspline::clamped_uniform_knots;
use spherefit::sphere::geometry::point::{slerp, PointSet};
use spherefit::sphere::{FitOptions, KnotPlacement, SphericalBSpline};
use std::f64::consts::PI;
use std::fmt::Write as _;

/// A point at longitude and latitude in radians.
fn sph(lon: f64, lat: f64) -> Vec<f64> {
    vec![lat.cos() * lon.cos(), lat.cos() * lon.sin(), lat.sin()]
}

/// One example: its data, the curve the data came from (dense, for plots) and GLS-PIA's
/// number of control points.
struct Example {
    name: &'static str,
    title: &'static str,
    points: PointSet,
    truth: Vec<Vec<f64>>,
    control_points: usize,
    note: &'static str,
}

fn from_spline(s: &SphericalBSpline, ts: &[f64]) -> (PointSet, Vec<Vec<f64>>) {
    let points = s.evaluate_many(ts);
    let dense: Vec<f64> = (0..2001).map(|i| i as f64 / 2000.0).collect();
    (points, s.evaluate_many(&dense).to_rows())
}

/// Simple: a cubic spherical B-spline of 8 control points on a gentle wave (uniform knots),
/// 200 points evenly spaced in its parameter.
fn simple() -> Example {
    let control: Vec<Vec<f64>> = (0..8)
        .map(|i| sph(0.25 * i as f64, 0.3 * (1.3 * i as f64).sin()))
        .collect();
    let s = SphericalBSpline::try_new(
        3,
        clamped_uniform_knots(8, 3),
        PointSet::try_from_rows(&control).unwrap(),
    )
    .unwrap();
    let ts: Vec<f64> = (0..200).map(|j| j as f64 / 199.0).collect();
    let (points, truth) = from_spline(&s, &ts);
    Example {
        name: "simple",
        title: "Simple curve (Table 1, Figure 7)",
        points,
        truth,
        control_points: 10,
        note: "cubic B-spline, 8 control points, 200 points even in parameter",
    }
}

/// Complex: a cubic spherical B-spline of 24 control points, a long gentle sweep (the first
/// 10) followed by tight wiggles (the last 14), sampled at `s = 1 − (1 − u)²` for 400 evenly
/// spaced `u`: a step of 0.5 % of the parameter per point at the left end, shrinking towards
/// the right, so the detail-rich right part holds most of the points, as the paper describes.
fn complex() -> Example {
    let mut control = Vec::new();
    for i in 0..10 {
        control.push(sph(0.18 * i as f64, 0.25 * (0.6 * i as f64).sin()));
    }
    for i in 0..14 {
        let lon = 1.8 + 0.07 * i as f64;
        let lat = 0.25 * (5.4f64).sin() + if i % 2 == 0 { 0.12 } else { -0.12 };
        control.push(sph(lon, lat));
    }
    let s = SphericalBSpline::try_new(
        3,
        clamped_uniform_knots(24, 3),
        PointSet::try_from_rows(&control).unwrap(),
    )
    .unwrap();
    let ts: Vec<f64> = (0..400)
        .map(|j| {
            let u = j as f64 / 399.0;
            1.0 - (1.0 - u) * (1.0 - u)
        })
        .collect();
    let (points, truth) = from_spline(&s, &ts);
    Example {
        name: "complex",
        title: "Complex curve (Table 2, Table 3, Figures 8–9)",
        points,
        truth,
        control_points: 30,
        note: "cubic B-spline, 24 control points (10 sweeping, 14 wiggling), 400 points at s = 1 - (1 - u)^2",
    }
}

/// Helix: a spherical spiral of 4 turns between z = −0.8 and z = 0.8, 300 points even in z.
fn helix() -> Example {
    let at = |z: f64| {
        let r = (1.0 - z * z).sqrt();
        vec![r * (5.0 * PI * z).cos(), r * (5.0 * PI * z).sin(), z]
    };
    let rows: Vec<Vec<f64>> = (0..300)
        .map(|j| at(-0.8 + 1.6 * j as f64 / 299.0))
        .collect();
    let truth = (0..4001)
        .map(|j| at(-0.8 + 1.6 * j as f64 / 4000.0))
        .collect();
    Example {
        name: "helix",
        title: "Helix (Figure 10)",
        points: PointSet::try_from_rows(&rows).unwrap(),
        truth,
        control_points: 40,
        note: "spherical spiral, 4 turns, 300 points even in z",
    }
}

/// Shock line: latitude jumps by 0.3 rad through a tanh step at longitude 0.6 rad; 300
/// points at longitude `1.2 u²` (dense on the left, 4× sparser than average on the right).
fn shock() -> Example {
    let at = |lon: f64| sph(lon, 0.15 * (40.0 * (lon - 0.6)).tanh());
    let rows: Vec<Vec<f64>> = (0..300)
        .map(|j| {
            let u = j as f64 / 299.0;
            at(1.2 * u * u)
        })
        .collect();
    let truth = (0..4001).map(|j| at(1.2 * j as f64 / 4000.0)).collect();
    Example {
        name: "shock",
        title: "Shock line (Figure 11)",
        points: PointSet::try_from_rows(&rows).unwrap(),
        truth,
        control_points: 20,
        note: "tanh step of 0.3 rad in latitude, 300 points at longitude 1.2 u^2",
    }
}

/// Corners: four great-circle arcs meeting at three sharp corners, 60 points per arc.
fn corners() -> Example {
    let v = [
        sph(0.0, 0.0),
        sph(0.5, 0.3),
        sph(0.9, -0.1),
        sph(1.4, 0.25),
        sph(1.8, 0.0),
    ];
    let mut rows = Vec::new();
    let mut truth = Vec::new();
    for w in v.windows(2) {
        rows.extend((0..60).map(|j| slerp(&w[0], &w[1], j as f64 / 60.0).unwrap()));
        truth.extend((0..500).map(|j| slerp(&w[0], &w[1], j as f64 / 500.0).unwrap()));
    }
    rows.push(v[4].clone());
    truth.push(v[4].clone());
    Example {
        name: "corners",
        title: "Sharp corners (Figure 12)",
        points: PointSet::try_from_rows(&rows).unwrap(),
        truth,
        control_points: 20,
        note: "four great-circle arcs, three corners, 60 points per arc",
    }
}

/// The best of three runs of `f` (the fit of the fastest run, its wall time).
fn best_of_3(f: impl Fn() -> MethodFit) -> MethodFit {
    (0..3)
        .map(|_| f())
        .min_by_key(|r| r.elapsed)
        .expect("three runs")
}

/// A row of a table: label, fit.
struct Row {
    label: String,
    fit: MethodFit,
}

fn table(out: &mut String, rows: &[Row]) {
    out.push_str("| method | Max_Error (rad) | Mean_Error (rad) | free points | iterations | converged | time (ms) |\n");
    out.push_str("|---|---:|---:|---:|---:|---|---:|\n");
    for r in rows {
        let f = &r.fit;
        let _ = writeln!(
            out,
            "| {} | {:.3e} | {:.3e} | {} | {} | {} | {:.1} |",
            r.label,
            f.metrics.max_error_rad,
            f.metrics.mean_error_rad,
            f.free_points,
            f.iterations,
            if f.converged { "yes" } else { "no" },
            f.elapsed.as_secs_f64() * 1e3
        );
    }
    out.push('\n');
}

/// `--scale METHOD N`: one fit of a wavy line of `N` points on S² by `METHOD` with the work of
/// `benches/compare.rs` (GLS-PIA 30 iterations, Jupp–Kent 2 rounds, Samir 30 steps), printing
/// its wall time; run under `/usr/bin/time -v` for the peak memory (docs/paper.md).
fn scale(method: &str, n: usize) {
    let m: Method = method.parse().unwrap_or_else(|e| panic!("{e}"));
    let rows: Vec<Vec<f64>> = (0..n)
        .map(|i| {
            let a = i as f64 / (n - 1) as f64 * 2.5;
            let lat = 0.4 * (7.0 * a).sin() + 0.05 * (53.0 * a).sin();
            vec![lat.cos() * a.cos(), lat.cos() * a.sin(), lat.sin()]
        })
        .collect();
    let points = PointSet::try_from_rows(&rows).expect("unit vectors");
    let o = MethodOptions::default().with_samples(100);
    let o = match m {
        Method::JuppKent => o.with_iterations(2),
        Method::Samir => o.with_iterations(30),
        _ => o,
    };
    let f = fit_with(m, &points, None, &o).expect("the line fits");
    println!(
        "{} {n} points: {:.3} s, max error {:.3e} rad, {} free points",
        m.name(),
        f.elapsed.as_secs_f64(),
        f.metrics.max_error_rad,
        f.free_points
    );
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.get(1).map(String::as_str) == Some("--scale") {
        let n = args
            .get(3)
            .and_then(|s| s.parse().ok())
            .expect("--scale METHOD N");
        return scale(&args[2], n);
    }
    let out_dir = args
        .get(1)
        .cloned()
        .unwrap_or_else(|| "target/paper".into());
    std::fs::create_dir_all(&out_dir).expect("the output directory can be made");
    let mut md = String::new();
    for ex in [simple(), complex(), helix(), shock(), corners()] {
        let n = ex.points.len();
        let base = MethodOptions::default().with_control_points(ex.control_points);
        let run = |m: Method, o: &MethodOptions| {
            best_of_3(|| fit_with(m, &ex.points, None, o).expect("the example fits"))
        };
        let gls = |k: KnotPlacement| {
            let o = MethodOptions {
                gls_pia: FitOptions::default().with_knots(k).with_iterations(30),
                ..base.clone()
            };
            run(Method::GlsPia, &o)
        };
        let _ = writeln!(md, "### {}\n", ex.title);
        let _ = writeln!(
            md,
            "{}; {n} points; GLS-PIA with {} control points, cubic, chord-length parameters, 30 iterations.\n",
            ex.note, ex.control_points
        );
        let knots = [
            ("GLS-PIA, uniform knots", KnotPlacement::Uniform),
            (
                "GLS-PIA, Euclidean-difference knots",
                KnotPlacement::Euclidean,
            ),
            (
                "GLS-PIA, geodesic-difference knots",
                KnotPlacement::Geodesic,
            ),
        ];
        let knot_rows: Vec<Row> = knots
            .iter()
            .map(|&(label, k)| Row {
                label: label.into(),
                fit: gls(k),
            })
            .collect();
        let t30 = knot_rows[2].fit.elapsed;
        let budget = |o: MethodOptions| MethodOptions {
            time_budget: Some(t30),
            ..o
        };
        let mut rows = vec![Row {
            label: "GLS-PIA (geodesic knots, 30 iterations)".into(),
            fit: knot_rows[2].fit.clone(),
        }];
        let compared: Vec<(String, Method, MethodOptions)> = vec![
            (
                "Jupp–Kent, GCV, stopped at GLS-PIA's time".into(),
                Method::JuppKent,
                budget(base.clone()),
            ),
            (
                "Jupp–Kent, GCV, converged".into(),
                Method::JuppKent,
                base.clone(),
            ),
            (
                format!(
                    "Jupp–Kent, {} degrees of freedom, converged",
                    ex.control_points
                ),
                Method::JuppKent,
                base.clone()
                    .with_smoothing(Smoothing::DegreesOfFreedom(ex.control_points as f64)),
            ),
            (
                format!("Samir, {n} nodes, stopped at GLS-PIA's time"),
                Method::Samir,
                budget(base.clone()),
            ),
            (
                format!("Samir, {n} nodes, converged (≤ 20,000 steps)"),
                Method::Samir,
                base.clone().with_iterations(20_000),
            ),
            (
                format!(
                    "Samir, {} nodes, converged (≤ 20,000 steps)",
                    ex.control_points
                ),
                Method::Samir,
                base.clone()
                    .with_nodes(ex.control_points)
                    .with_iterations(20_000),
            ),
            ("Gousenbourger CBC".into(), Method::Cbc, base.clone()),
            ("Gousenbourger BCC".into(), Method::Bcc, base.clone()),
        ];
        for (label, m, o) in &compared {
            rows.push(Row {
                label: label.clone(),
                fit: run(*m, o),
            });
        }
        let _ = writeln!(md, "Knot placements:\n");
        table(&mut md, &knot_rows);
        let _ = writeln!(
            md,
            "Methods (the time budget: {:.1} ms, GLS-PIA's 30 iterations):\n",
            t30.as_secs_f64() * 1e3
        );
        table(&mut md, &rows);
        // Plot data: the paper's panels — GLS-PIA with each knot placement, CBC, BCC, Samir and
        // Jupp–Kent as the paper ran them (stopped at GLS-PIA's time).
        let plotted = [
            ("GLS-PIA, uniform knots", &knot_rows[0].fit),
            ("GLS-PIA, Euclidean knots", &knot_rows[1].fit),
            ("GLS-PIA, geodesic knots", &knot_rows[2].fit),
            ("Gousenbourger CBC", &rows[7].fit),
            ("Gousenbourger BCC", &rows[8].fit),
            ("Samir (time of GLS-PIA)", &rows[4].fit),
            ("Jupp–Kent (time of GLS-PIA)", &rows[1].fit),
        ];
        let doc = json!({
            "name": ex.name,
            "title": ex.title,
            "points": ex.points.to_rows(),
            "truth": ex.truth,
            "fits": plotted.iter().map(|(label, f)| json!({
                "label": label,
                "max_error_rad": f.metrics.max_error_rad,
                "samples": f.samples.to_rows(),
            })).collect::<Vec<_>>(),
        });
        let path = format!("{out_dir}/{}.json", ex.name);
        std::fs::write(&path, serde_json::to_vec(&doc).expect("json")).expect("writable");
        let _ = writeln!(md, "![{}](paper/{}.png)\n", ex.title, ex.name);
        eprintln!("{}: done", ex.name);
    }
    std::fs::write(format!("{out_dir}/tables.md"), md).expect("writable");
}
