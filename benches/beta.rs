//! Criterion benches for spherical Beta-spline interpolation.
//!
//! `cargo bench --bench beta`. Interpolates 10k points on S^2 (a track wrapping the globe
//! about five times, 3e-3 rad = 19 km between points) with beta1 = 1, beta2 = 0, to a residual
//! of at most 1e-15 rad: Newton (the default) on all cores and on one, and the paper's eq. 19
//! (Jacobi) run to the same criterion, for comparison. Also evaluates the result at 100k
//! parameters.

// `criterion_group!` defines public functions without doc comments.
#![allow(missing_docs)]

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use spherefit::sphere::{
    interpolate, BetaSolver, InterpolationOptions, PointSet, SphericalBetaSpline,
};

/// `n` points on S^2 along a wavy track that wraps the globe about five times.
fn track(n: usize) -> PointSet {
    let rows: Vec<Vec<f64>> = (0..n)
        .map(|i| {
            let a = i as f64 / (n - 1) as f64 * 30.0;
            let lat = 0.4 * (0.7 * a).sin() + 0.05 * (5.3 * a).sin();
            vec![lat.cos() * a.cos(), lat.cos() * a.sin(), lat.sin()]
        })
        .collect();
    PointSet::try_from_rows(&rows).unwrap()
}

fn one_thread() -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
}

fn interpolate_10k(c: &mut Criterion) {
    let points = track(10_000);
    let newton = InterpolationOptions::default();
    let jacobi = InterpolationOptions::default().with_solver(BetaSolver::Jacobi);
    let check = |o: &InterpolationOptions| {
        let r = interpolate(&points, o).unwrap();
        assert!(r.residual_rad <= 1e-12);
        eprintln!("{:?}: {} iterations", o.solver, r.iterations);
    };
    check(&newton);
    check(&jacobi);
    let pool = one_thread();
    let mut g = c.benchmark_group("beta_interpolate");
    g.sample_size(20);
    g.throughput(Throughput::Elements(points.len() as u64));
    g.bench_function(BenchmarkId::new("newton", "S2_10k"), |b| {
        b.iter(|| interpolate(&points, &newton).unwrap())
    });
    g.bench_function(BenchmarkId::new("newton_1_thread", "S2_10k"), |b| {
        b.iter(|| pool.install(|| interpolate(&points, &newton).unwrap()))
    });
    g.sample_size(10);
    g.bench_function(BenchmarkId::new("jacobi_eq19", "S2_10k"), |b| {
        b.iter(|| interpolate(&points, &jacobi).unwrap())
    });
    g.finish();
}

fn evaluate_100k(c: &mut Criterion) {
    let spline: SphericalBetaSpline = interpolate(&track(10_000), &InterpolationOptions::default())
        .unwrap()
        .spline;
    let ts: Vec<f64> = (0..100_000)
        .map(|i| i as f64 * 9_999.0 / 99_999.0)
        .collect();
    let mut g = c.benchmark_group("beta_evaluate");
    g.throughput(Throughput::Elements(ts.len() as u64));
    g.bench_function(BenchmarkId::new("cubic_segments", "S2_100k_params"), |b| {
        b.iter(|| spline.evaluate_many(&ts))
    });
    g.finish();
}

criterion_group!(benches, interpolate_10k, evaluate_100k);
criterion_main!(benches);
