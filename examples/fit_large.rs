//! The large-fit benchmark of the fast solver: `n` points on a wavy track over S^2 with noise,
//! `n_ctrl` control points, cubic, Gauss–Newton (or GLS-PIA), all cores. Prints one JSON line
//! with the wall time; `--dump DIR` also writes the parameters, points and knots as
//! little-endian f64 files for `benches/scipy_lsq.py`, which fits the same data with scipy.
//!
//! `cargo run --release --example fit_large -- 1000000 2000 gauss-newton [--dump DIR]`

use spherefit::sphere::fit::knots::{parameters, place_knots};
use spherefit::sphere::{fit, FitOptions, KnotPlacement, Parameterization, PointSet, Solver};
use std::io::Write;
use std::time::Instant;

fn track(n: usize) -> PointSet {
    // Deterministic "noise": a hash of the index, ±1e-5 rad (about 60 m on the Earth).
    let noise = |i: usize, salt: u64| {
        let h = (i as u64 ^ salt).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        ((h >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 2e-5
    };
    let rows: Vec<[f64; 3]> = (0..n)
        .map(|i| {
            let a = i as f64 / (n - 1) as f64 * 2.5 + noise(i, 1);
            let lat = 0.4 * (7.0 * a).sin() + 0.05 * (53.0 * a).sin() + noise(i, 2);
            [lat.cos() * a.cos(), lat.cos() * a.sin(), lat.sin()]
        })
        .collect();
    PointSet::try_from_rows(&rows).unwrap()
}

fn write_f64s(path: &std::path::Path, xs: &[f64]) {
    let mut f = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    for x in xs {
        f.write_all(&x.to_le_bytes()).unwrap();
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let n: usize = args.first().map_or(1_000_000, |a| a.parse().unwrap());
    let n_ctrl: usize = args.get(1).map_or(2000, |a| a.parse().unwrap());
    let solver: Solver = args
        .get(2)
        .map_or(Solver::GaussNewton, |a| a.parse().unwrap());
    let dump = args
        .iter()
        .position(|a| a == "--dump")
        .map(|i| &args[i + 1]);
    let pts = track(n);
    let start = Instant::now();
    let opts = FitOptions::default()
        .with_control_points(n_ctrl)
        .with_solver(solver)
        .with_iterations(30);
    let report = fit(&pts, None, &opts).unwrap();
    let secs = start.elapsed().as_secs_f64();
    println!(
        "{{\"points\": {n}, \"control_points\": {n_ctrl}, \"solver\": \"{solver:?}\", \"seconds\": {secs:.3}, \"iterations\": {}, \"converged\": {}, \"rms_error_rad\": {:e}, \"max_error_rad\": {:e}, \"threads\": {}}}",
        report.iterations,
        report.converged,
        report.metrics.rms_error_rad,
        report.metrics.max_error_rad,
        rayon::current_num_threads()
    );
    if let Some(dir) = dump {
        let dir = std::path::Path::new(dir);
        std::fs::create_dir_all(dir).unwrap();
        let t = parameters(&pts, Parameterization::Chord).unwrap();
        let knots = place_knots(&pts, &t, n_ctrl, 3, KnotPlacement::Geodesic).unwrap();
        write_f64s(&dir.join("t.f64"), &t);
        write_f64s(&dir.join("xyz.f64"), pts.as_flat());
        write_f64s(&dir.join("knots.f64"), &knots);
    }
}
