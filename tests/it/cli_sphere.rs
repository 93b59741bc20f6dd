//! `spherefit sphere fit | evaluate`, run as the built binary on `fixtures/` and on stdin:
//! the documented output shapes, options reaching the fitter, and invalid input exiting with
//! status 2 and a message naming the field and index.

use crate::helpers::{angle, clamped_uniform_knots, fixture_path, norm, run_spherefit};
use serde_json::{json, Value};
use spherefit::document::{spline_from_json, PointsInput};
use spherefit::sphere::{fit, FitOptions, KnotPlacement, Parameterization};
use std::collections::BTreeSet;
use std::process::Output;

const WAVY: &str = "fixtures/sphere_wavy_points.json";
const SPLINE: &str = "fixtures/sphere_cubic_spline.json";

/// Runs the binary from the package root with `args`, feeding `stdin` if given.
fn run(args: &[&str], stdin: Option<&str>) -> Output {
    run_spherefit(args, stdin.map(str::as_bytes))
}

/// Runs a command that must succeed and returns its stdout as JSON.
fn run_ok(args: &[&str], stdin: Option<&str>) -> Value {
    let out = run(args, stdin);
    assert!(
        out.status.success(),
        "{args:?} failed with {:?}: {}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("stdout is one JSON document")
}

/// Runs a command that must fail with status 2, print nothing on stdout, and mention every
/// string of `needles` on stderr. Returns stderr.
fn run_invalid(args: &[&str], stdin: Option<&str>, needles: &[&str]) -> String {
    let out = run(args, stdin);
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(
        out.status.code(),
        Some(2),
        "{args:?} must exit with status 2; stderr: {stderr}"
    );
    assert!(
        out.stdout.is_empty(),
        "nothing on stdout: {:?}",
        String::from_utf8_lossy(&out.stdout)
    );
    for n in needles {
        assert!(stderr.contains(n), "stderr must mention {n:?}: {stderr}");
    }
    stderr
}

fn keys(v: &Value) -> BTreeSet<&str> {
    v.as_object()
        .expect("an object")
        .keys()
        .map(String::as_str)
        .collect()
}

fn set<'a>(items: &[&'a str]) -> BTreeSet<&'a str> {
    items.iter().copied().collect()
}

fn f64s(v: &Value) -> Vec<f64> {
    v.as_array()
        .expect("an array")
        .iter()
        .map(|x| x.as_f64().expect("a number"))
        .collect()
}

fn rows(v: &Value) -> Vec<Vec<f64>> {
    v.as_array().expect("an array").iter().map(f64s).collect()
}

/// Checks the documented shape of a `sphere fit` output and returns (degree, knots, control).
fn check_fit_shape(out: &Value, n_points: usize) -> (usize, Vec<f64>, Vec<Vec<f64>>) {
    assert_eq!(
        keys(out),
        set(&["spline", "solver", "parameters", "metrics", "history"])
    );
    assert_eq!(
        keys(&out["spline"]),
        set(&["degree", "knots", "control_points"])
    );
    assert_eq!(
        keys(&out["metrics"]),
        set(&[
            "max_error_rad",
            "mean_error_rad",
            "rms_error_rad",
            "iterations",
            "converged"
        ])
    );
    let degree = out["spline"]["degree"].as_u64().unwrap() as usize;
    let knots = f64s(&out["spline"]["knots"]);
    let control = rows(&out["spline"]["control_points"]);
    assert_eq!(knots.len(), control.len() + degree + 1);
    for c in &control {
        assert!(
            (norm(c) - 1.0).abs() < 1e-12,
            "control points are unit vectors"
        );
    }
    let params = f64s(&out["parameters"]);
    assert_eq!(params.len(), n_points);
    assert_eq!((params[0], params[n_points - 1]), (0.0, 1.0));
    assert!(params.windows(2).all(|w| w[0] <= w[1]));
    let m = &out["metrics"];
    let (max, mean, rms) = (
        m["max_error_rad"].as_f64().unwrap(),
        m["mean_error_rad"].as_f64().unwrap(),
        m["rms_error_rad"].as_f64().unwrap(),
    );
    assert!(0.0 <= mean && mean <= rms && rms <= max, "{m}");
    assert!(m["converged"].is_boolean());
    let history = out["history"].as_array().unwrap();
    let iterations = m["iterations"].as_u64().unwrap() as usize;
    assert_eq!(
        history.len(),
        iterations + 1,
        "initial curve plus one per update"
    );
    for h in history {
        assert_eq!(keys(h), set(&["max_error_rad", "mean_error_rad"]));
    }
    assert!(max <= history[0]["max_error_rad"].as_f64().unwrap());
    (degree, knots, control)
}

fn wavy_points() -> PointsInput {
    let text = std::fs::read_to_string(fixture_path("sphere_wavy_points.json")).unwrap();
    PointsInput::from_json(&serde_json::from_str(&text).unwrap()).unwrap()
}

#[test]
fn fit_from_a_file_writes_the_documented_document() {
    let out = run_ok(
        &[
            "sphere",
            "fit",
            "--control-points",
            "8",
            "--iterations",
            "20",
            WAVY,
        ],
        None,
    );
    let (degree, knots, control) = check_fit_shape(&out, 60);
    assert_eq!(degree, 3);
    assert_eq!(control.len(), 8);
    assert_eq!(knots.len(), 12);
    assert!(out["metrics"]["iterations"].as_u64().unwrap() <= 20);

    // The CLI computes exactly what the library does with the same options.
    let input = wavy_points();
    let lib = fit(
        &input.points,
        None,
        &FitOptions::default()
            .with_control_points(8)
            .with_iterations(20),
    )
    .unwrap();
    let cli_max = out["metrics"]["max_error_rad"].as_f64().unwrap();
    assert!((cli_max - lib.metrics.max_error_rad).abs() < 1e-15);
    // Equal up to how serde_json reads numbers back (see the ignored test below).
    for (a, b) in knots.iter().zip(lib.spline.knots()) {
        assert!((a - b).abs() <= 2.0 * f64::EPSILON, "{knots:?}");
    }
    eprintln!("cli fit of {WAVY}: max {cli_max:.3e} rad");
}

/// serde_json's `float_roundtrip` feature is on: without it some numbers read back 1 ULP off
/// (0.41495290790559003 became 0.41495290790559).
#[test]
fn fit_output_reads_back_exactly() {
    let out = run(
        &[
            "sphere",
            "fit",
            "--control-points",
            "8",
            "--iterations",
            "20",
            WAVY,
        ],
        None,
    );
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    let parsed: Value = serde_json::from_str(&text).unwrap();
    // Every number in the output, as written (Rust's own parser is correctly rounded) ...
    let knots_text = text.split("\"knots\":[").nth(1).unwrap();
    let knots_text = &knots_text[..knots_text.find(']').unwrap()];
    let written: Vec<f64> = knots_text
        .split(',')
        .map(|x| x.parse::<f64>().unwrap())
        .collect();
    // ... must be the number read back.
    assert_eq!(f64s(&parsed["spline"]["knots"]), written);
    // And so the CLI's spline equals the library's bit for bit.
    let lib = fit(
        &wavy_points().points,
        None,
        &FitOptions::default()
            .with_control_points(8)
            .with_iterations(20),
    )
    .unwrap();
    assert_eq!(written, lib.spline.knots());
    assert_eq!(
        rows(&parsed["spline"]["control_points"]),
        lib.spline.control_points().to_rows()
    );
}

#[test]
fn fit_defaults_to_a_quarter_of_the_points_and_30_iterations() {
    let out = run_ok(&["sphere", "fit", WAVY], None);
    let (degree, _, control) = check_fit_shape(&out, 60);
    assert_eq!(degree, 3);
    assert_eq!(control.len(), 15, "default: a quarter of the 60 points");
    let iterations = out["metrics"]["iterations"].as_u64().unwrap();
    assert!(iterations <= 30);
    if !out["metrics"]["converged"].as_bool().unwrap() {
        assert_eq!(iterations, 30);
    }
}

#[test]
fn fit_from_stdin_with_options() {
    let input = wavy_points();
    let bare = serde_json::to_string(&input.points.to_rows()).unwrap();
    let out = run_ok(
        &[
            "sphere",
            "fit",
            "--degree",
            "2",
            "-n",
            "6",
            "--knots",
            "uniform",
            "--parameterization",
            "uniform",
            "--iterations",
            "5",
            "--step",
            "global",
            "-",
        ],
        Some(&bare),
    );
    let (degree, knots, control) = check_fit_shape(&out, 60);
    assert_eq!(degree, 2);
    assert_eq!(control.len(), 6);
    for (a, b) in knots.iter().zip(clamped_uniform_knots(6, 2)) {
        assert!((a - b).abs() < 1e-15, "{knots:?}");
    }
    for (j, t) in f64s(&out["parameters"]).iter().enumerate() {
        assert!((t - j as f64 / 59.0).abs() < 1e-15, "uniform parameters");
    }
    assert!(out["metrics"]["iterations"].as_u64().unwrap() <= 5);

    // Same result without the `-`, and the options reach the fitter.
    let again = run_ok(
        &[
            "sphere",
            "fit",
            "--degree=2",
            "--control-points=6",
            "--knots=uniform",
            "--parameterization=uniform",
            "--iterations=5",
            "--step=global",
        ],
        Some(&bare),
    );
    assert_eq!(again, out);
    let lib = fit(
        &input.points,
        None,
        &FitOptions::default()
            .with_degree(2)
            .with_control_points(6)
            .with_knots(KnotPlacement::Uniform)
            .with_parameterization(Parameterization::Uniform)
            .with_iterations(5)
            .with_step(spherefit::sphere::StepRule::Global),
    )
    .unwrap();
    let cli_mean = out["metrics"]["mean_error_rad"].as_f64().unwrap();
    assert!((cli_mean - lib.metrics.mean_error_rad).abs() < 1e-15);
}

#[test]
fn fit_uses_given_parameters_and_the_error_target() {
    let input = wavy_points();
    // Timestamps every 2 s: not the chord-length parameters, and not already in [0, 1].
    let times: Vec<f64> = (0..60).map(|j| 100.0 + 2.0 * j as f64).collect();
    let doc = json!({"points": input.points.to_rows(), "parameters": times});
    let out = run_ok(
        &[
            "sphere",
            "fit",
            "-n",
            "20",
            "--iterations",
            "500",
            "--target-max-error-rad",
            "1e-3",
        ],
        Some(&doc.to_string()),
    );
    check_fit_shape(&out, 60);
    let params = f64s(&out["parameters"]);
    for (t, u) in times.iter().zip(&params) {
        assert!(((t - times[0]) / (times[59] - times[0]) - u).abs() < 1e-15);
    }
    let m = &out["metrics"];
    assert_eq!(m["converged"], true);
    assert!(m["max_error_rad"].as_f64().unwrap() <= 1e-3);
    // Measured: the target is met after 11 iterations (stagnation would take over 100).
    assert!(m["iterations"].as_u64().unwrap() < 50);
}

#[test]
fn evaluate_samples_a_spline_document() {
    let out = run_ok(&["sphere", "evaluate", "--samples", "5", SPLINE], None);
    assert_eq!(keys(&out), set(&["parameters", "points"]));
    assert_eq!(f64s(&out["parameters"]), vec![0.0, 0.25, 0.5, 0.75, 1.0]);
    let points = rows(&out["points"]);
    assert_eq!(points.len(), 5);
    let text = std::fs::read_to_string(fixture_path("sphere_cubic_spline.json")).unwrap();
    let doc: Value = serde_json::from_str(&text).unwrap();
    let control = rows(&doc["control_points"]);
    let spline = spline_from_json(&doc).unwrap();
    for (j, p) in points.iter().enumerate() {
        assert!((norm(p) - 1.0).abs() < 1e-12);
        assert!(angle(p, &spline.evaluate(j as f64 / 4.0)) < 1e-15);
    }
    // Clamped: the ends are the end control points.
    assert!(angle(&points[0], &control[0]) < 1e-15);
    assert!(angle(&points[4], &control[5]) < 1e-15);

    // Default sample count, from stdin.
    let out = run_ok(&["sphere", "evaluate"], Some(&text));
    assert_eq!(out["points"].as_array().unwrap().len(), 101);
}

#[test]
fn evaluate_at_parameters_of_a_fit_output() {
    let fitted = run_ok(&["sphere", "fit", "-n", "10", WAVY], None);
    let text = fitted.to_string();
    let out = run_ok(&["sphere", "evaluate", "--at", "0,0.5,1"], Some(&text));
    assert_eq!(f64s(&out["parameters"]), vec![0.0, 0.5, 1.0]);
    assert_eq!(out["points"].as_array().unwrap().len(), 3);

    // At the data parameters, the curve is exactly as far from the data as the metrics say.
    let params = f64s(&fitted["parameters"]);
    let at = params
        .iter()
        .map(|t| format!("{t:?}"))
        .collect::<Vec<_>>()
        .join(",");
    let out = run_ok(&["sphere", "evaluate", "--at", &at], Some(&text));
    let curve = rows(&out["points"]);
    let data = wavy_points().points.to_rows();
    let errors: Vec<f64> = curve.iter().zip(&data).map(|(c, q)| angle(c, q)).collect();
    let max = errors.iter().copied().fold(0.0, f64::max);
    let mean = errors.iter().sum::<f64>() / errors.len() as f64;
    let m = &fitted["metrics"];
    assert!((max - m["max_error_rad"].as_f64().unwrap()).abs() < 1e-12);
    assert!((mean - m["mean_error_rad"].as_f64().unwrap()).abs() < 1e-12);

    // Parameters outside the domain clamp to its ends.
    let out = run_ok(&["sphere", "evaluate", "--at=-1,2"], Some(&text));
    let ends = run_ok(&["sphere", "evaluate", "--at", "0,1"], Some(&text));
    assert_eq!(out["points"], ends["points"]);
}

#[test]
fn evaluate_at_accepts_a_list_starting_with_a_negative_number() {
    let out = run_ok(&["sphere", "evaluate", "--at", "-1,0.5", SPLINE], None);
    assert_eq!(f64s(&out["parameters"]), vec![-1.0, 0.5]);
    let out = run_ok(&["sphere", "evaluate", "--at", "-0.5", SPLINE], None);
    assert_eq!(f64s(&out["parameters"]), vec![-0.5]);
}

/// Ten points on a small wave, as rows (valid input to edit into invalid input).
fn ten_points() -> Vec<Value> {
    wavy_points()
        .points
        .to_rows()
        .into_iter()
        .take(10)
        .map(|r| json!(r))
        .collect()
}

#[test]
fn a_point_that_is_not_a_unit_vector_is_named() {
    let mut pts = ten_points();
    pts[3] = json!([1.0, 1.0, 0.0]);
    let doc = json!({ "points": pts }).to_string();
    run_invalid(&["sphere", "fit"], Some(&doc), &["/points/3", "unit"]);
}

#[test]
fn a_string_for_a_number_is_named() {
    let mut pts = ten_points();
    pts[4] = json!([1.0, "0", 0.0]);
    let doc = Value::Array(pts).to_string();
    run_invalid(&["sphere", "fit"], Some(&doc), &["/4/1", "number"]);
    let mut pts = ten_points();
    pts[2] = json!([1.0, 0.0, null]);
    let doc = json!({ "points": pts }).to_string();
    run_invalid(&["sphere", "fit"], Some(&doc), &["/points/2/2", "number"]);
}

#[test]
fn a_point_of_the_wrong_dimension_is_named() {
    let mut pts = ten_points();
    pts[6] = json!([0.6, 0.8]);
    let doc = Value::Array(pts).to_string();
    run_invalid(&["sphere", "fit"], Some(&doc), &["/6"]);
}

#[test]
fn too_few_points_for_the_degree() {
    let pts = &ten_points()[..3];
    let doc = json!({ "points": pts }).to_string();
    let e = run_invalid(&["sphere", "fit"], Some(&doc), &["points", "too few"]);
    assert!(e.contains('3') && e.contains('4'), "got 3, need 4: {e}");
    // Degree 2 fits three points.
    run_ok(&["sphere", "fit", "--degree", "2"], Some(&doc));
}

#[test]
fn more_control_points_than_points() {
    let doc = Value::Array(ten_points()).to_string();
    run_invalid(
        &["sphere", "fit", "--control-points", "50"],
        Some(&doc),
        &["--control-points", "50"],
    );
    run_invalid(
        &["sphere", "fit", "--degree", "7"],
        Some(&doc),
        &["--degree", "7"],
    );
}

#[test]
fn antipodal_neighbours_are_named() {
    let mut pts = ten_points();
    pts[5] = json!([-1.0, 0.0, 0.0]);
    pts[4] = json!([1.0, 0.0, 0.0]);
    let doc = json!({ "points": pts }).to_string();
    run_invalid(
        &["sphere", "fit"],
        Some(&doc),
        &["points", "antipodal", "5"],
    );
}

#[test]
fn bad_parameters_are_named() {
    let pts = ten_points();
    let mut params: Vec<f64> = (0..10).map(f64::from).collect();
    params[6] = 1.5;
    let doc = json!({ "points": pts, "parameters": params }).to_string();
    run_invalid(
        &["sphere", "fit"],
        Some(&doc),
        &["parameters", "parameter 6"],
    );
    let doc = json!({ "points": pts, "parameters": [0, 1, 2] }).to_string();
    run_invalid(&["sphere", "fit"], Some(&doc), &["parameters", "3"]);
    let doc = json!({ "points": pts, "parameters": [0, 1, "2", 3, 4, 5, 6, 7, 8, 9] }).to_string();
    run_invalid(&["sphere", "fit"], Some(&doc), &["/parameters/2"]);
}

#[test]
fn bad_knots_are_named() {
    let text = std::fs::read_to_string(fixture_path("sphere_cubic_spline.json")).unwrap();
    let mut doc: Value = serde_json::from_str(&text).unwrap();
    doc["knots"] = json!([0, 0, 0, 0, 0.6, 0.3, 1, 1, 1, 1]);
    run_invalid(
        &["sphere", "evaluate"],
        Some(&doc.to_string()),
        &["knots", "knot 5"],
    );
    doc["knots"] = json!([0, 0, 0, 0, 0.5, 1, 1, 1, 1]);
    run_invalid(
        &["sphere", "evaluate"],
        Some(&doc.to_string()),
        &["knots", "expected 10 knots"],
    );
    // Inside a fit output the pointer says so.
    let mut fitted = run_ok(&["sphere", "fit", "-n", "6", WAVY], None);
    fitted["spline"]["control_points"][2] = json!([0.0, 0.0, 2.0]);
    run_invalid(
        &["sphere", "evaluate"],
        Some(&fitted.to_string()),
        &["/spline/control_points/2"],
    );
}

#[test]
fn malformed_json_and_unusable_documents() {
    run_invalid(
        &["sphere", "fit"],
        Some("{\"points\": [[1, 0, 0],"),
        &["invalid JSON", "line 1"],
    );
    run_invalid(&["sphere", "evaluate"], Some("[1, 2"), &["invalid JSON"]);
    run_invalid(&["sphere", "fit"], Some("{\"pts\": []}"), &["/pts"]);
    run_invalid(&["sphere", "fit"], Some("42"), &["points"]);
    run_invalid(
        &["sphere", "evaluate"],
        Some("{\"degree\": 3}"),
        &["spline document"],
    );
    run_invalid(
        &["sphere", "fit", "fixtures/no_such_file.json"],
        None,
        &["fixtures/no_such_file.json"],
    );
}

#[test]
fn bad_options_exit_with_status_2() {
    run_invalid(
        &["sphere", "fit", "--knots", "cubic", WAVY],
        None,
        &["--knots"],
    );
    run_invalid(
        &["sphere", "fit", "--parameterization", "arc", WAVY],
        None,
        &["--parameterization"],
    );
    run_invalid(&["sphere", "fit", "--step=0", WAVY], None, &["--step"]);
    run_invalid(
        &["sphere", "evaluate", "--at", "0,NaN", SPLINE],
        None,
        &["--at", "1"],
    );
    run_invalid(
        &["sphere", "evaluate", "--at", "0,x", SPLINE],
        None,
        &["--at"],
    );
}

/// `--solver gauss-newton` reaches at least what 30 GLS-PIA iterations reach, in fewer passes.
#[test]
fn fit_with_the_fast_solver() {
    let pia = run_ok(&["sphere", "fit", "-n", "12", WAVY], None);
    let gn = run_ok(
        &[
            "sphere",
            "fit",
            "-n",
            "12",
            "--solver",
            "gauss-newton",
            WAVY,
        ],
        None,
    );
    let rms = |v: &serde_json::Value| v["metrics"]["rms_error_rad"].as_f64().unwrap();
    assert!(rms(&gn) <= rms(&pia), "{} > {}", rms(&gn), rms(&pia));
    assert_eq!(gn["metrics"]["converged"], true);
    assert!(gn["metrics"]["iterations"].as_u64().unwrap() < 30);
}

/// `--tolerance-rad`: the reported max error, and a recomputation through
/// `sphere evaluate` at the returned parameters, are within the tolerance when it is met.
#[test]
fn fit_to_a_tolerance_reports_what_it_met() {
    let tol = 1e-3;
    let out = run_ok(&["sphere", "fit", "--tolerance-rad", "0.001", WAVY], None);
    let t = &out["tolerance"];
    assert_eq!(t["tolerance_met"], true, "{t}");
    let max = out["metrics"]["max_error_rad"].as_f64().unwrap();
    assert!(max <= tol);
    let stored = t["stored_numbers"].as_u64().unwrap();
    assert!(stored < t["input_numbers"].as_u64().unwrap(), "{t}");
    // Recompute independently: evaluate the curve at the returned parameters.
    let params: Vec<String> = f64s(&out["parameters"])
        .iter()
        .map(|x| format!("{x:e}"))
        .collect();
    let at = params.join(",");
    let curve = run_ok(&["sphere", "evaluate", "--at", &at], Some(&out.to_string()));
    let input: Value = serde_json::from_str(&std::fs::read_to_string(WAVY).unwrap()).unwrap();
    let pts = input
        .get("points")
        .unwrap_or(&input)
        .as_array()
        .unwrap()
        .clone();
    let worst = pts
        .iter()
        .zip(curve["points"].as_array().unwrap())
        .map(|(q, c)| {
            let (q, c) = (f64s(q), f64s(c));
            let (mut m, mut p) = (0.0, 0.0);
            for k in 0..q.len() {
                m += (q[k] - c[k]).powi(2);
                p += (q[k] + c[k]).powi(2);
            }
            2.0 * f64::atan2(m.sqrt(), p.sqrt())
        })
        .fold(0.0, f64::max);
    assert!(worst <= tol * (1.0 + 1e-9), "recomputed {worst:e}");
    assert!((worst - max).abs() <= 1e-12, "{worst:e} vs {max:e}");
    // A tolerance that is not positive is an input error.
    run_invalid(
        &["sphere", "fit", "--tolerance-rad", "0", WAVY],
        None,
        &["tolerance"],
    );
}

/// Options the other makes meaningless are refused, naming both, by the rule the service
/// keeps too (`sphere::fit::options_check::check_given_together`).
#[test]
fn options_that_exclude_each_other_are_named() {
    let e = run_invalid(
        &[
            "sphere",
            "fit",
            "--tolerance-rad",
            "0.001",
            "--solver",
            "gauss-newton",
            WAVY,
        ],
        None,
        &["--tolerance-rad excludes --solver"],
    );
    assert!(e.contains("spherefit: --tolerance-rad: "), "{e}");
    run_invalid(
        &[
            "sphere",
            "evaluate",
            "--samples",
            "5",
            "--at",
            "0.5",
            SPLINE,
        ],
        None,
        &["--at: --at excludes --samples"],
    );
    // Each alone is fine.
    run_ok(&["sphere", "fit", "--solver", "gauss-newton", WAVY], None);
    run_ok(&["sphere", "evaluate", "--at", "0.5", SPLINE], None);
}
