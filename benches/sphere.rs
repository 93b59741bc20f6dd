//! Criterion benches for the S^n core: de Boor evaluation and one GLS-PIA iteration.
//!
//! `cargo bench --bench sphere`. The GLS-PIA groups run on one core (a one-thread rayon pool)
//! and report throughput in points, so criterion's "time per element" is the time per
//! point-iteration; the target is <= 150 ns on S^2 (cubic, 100k points, 2k controls).

// `criterion_group!` defines public functions without doc comments.
#![allow(missing_docs)]

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use spherefit::sphere::bench_hooks::accumulate_pass_dynamic;
use spherefit::sphere::fit::knots::{greville_control_points, parameters, place_knots};
use spherefit::sphere::{
    gls_pia_iteration, KnotPlacement, Parameterization, PointSet, SphericalBSpline, StepRule,
};

/// A wavy line around S^2 (dim 3) or its analogue on S^3 (dim 4), `n` points.
fn wavy(n: usize, dim: usize) -> PointSet {
    let rows: Vec<Vec<f64>> = (0..n)
        .map(|i| {
            let a = i as f64 / (n - 1) as f64 * 2.5;
            let lat = 0.4 * (7.0 * a).sin() + 0.05 * (53.0 * a).sin();
            let mut v = vec![lat.cos() * a.cos(), lat.cos() * a.sin(), lat.sin()];
            if dim == 4 {
                let w = 0.3 * (3.0 * a).cos();
                v = vec![v[0] * w.cos(), v[1] * w.cos(), v[2] * w.cos(), w.sin()];
            }
            v
        })
        .collect();
    PointSet::try_from_rows(&rows).unwrap()
}

fn setup(n: usize, n_ctrl: usize, dim: usize) -> (PointSet, Vec<f64>, SphericalBSpline) {
    let pts = wavy(n, dim);
    let t = parameters(&pts, Parameterization::Chord).unwrap();
    let knots = place_knots(&pts, &t, n_ctrl, 3, KnotPlacement::Geodesic).unwrap();
    let cp = greville_control_points(&pts, &t, &knots, 3).unwrap();
    let spline = SphericalBSpline::try_new(3, knots, cp).unwrap();
    (pts, t, spline)
}

fn one_thread() -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
}

fn de_boor(c: &mut Criterion) {
    let pool = one_thread();
    let mut g = c.benchmark_group("de_boor_evaluate");
    for dim in [3, 4] {
        let (_, t, spline) = setup(100_000, 2_000, dim);
        g.throughput(Throughput::Elements(t.len() as u64));
        g.bench_function(
            BenchmarkId::new("cubic_2k_ctrl_100k_params", format!("S{}", dim - 1)),
            |b| b.iter(|| pool.install(|| spline.evaluate_many(&t))),
        );
    }
    g.finish();
}

fn gls_pia(c: &mut Criterion) {
    let pool = one_thread();
    let mut g = c.benchmark_group("gls_pia_iteration");
    g.sample_size(20);
    for dim in [3, 4] {
        let (pts, t, spline) = setup(100_000, 2_000, dim);
        g.throughput(Throughput::Elements(pts.len() as u64));
        let id = BenchmarkId::new("cubic_2k_ctrl_100k_pts_1_core", format!("S{}", dim - 1));
        g.bench_function(id, |b| {
            b.iter_batched_ref(
                || spline.clone(),
                |s| pool.install(|| gls_pia_iteration(s, &pts, &t, StepRule::DengLin)),
                criterion::BatchSize::LargeInput,
            )
        });
    }
    // The same pass with the runtime-dimension kernel on S^2: what `Fixed<3>` saves.
    let (pts, t, spline) = setup(100_000, 2_000, 3);
    g.throughput(Throughput::Elements(pts.len() as u64));
    g.bench_function("accumulate_pass_dynamic_dim_S2", |b| {
        b.iter(|| pool.install(|| accumulate_pass_dynamic(&spline, &pts, &t)))
    });
    let pool2 = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    g.bench_function("cubic_2k_ctrl_100k_pts_2_cores/S2", |b| {
        b.iter_batched_ref(
            || spline.clone(),
            |s| pool2.install(|| gls_pia_iteration(s, &pts, &t, StepRule::DengLin)),
            criterion::BatchSize::LargeInput,
        )
    });
    g.finish();
}

criterion_group!(benches, de_boor, gls_pia);
criterion_main!(benches);
