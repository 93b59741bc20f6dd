//! Criterion benches for the GLS-PIA paper's comparison (`sphere::compare`): each method's
//! wall time on 10⁴ and 10⁵ points of a wavy line on S², the budget a quarter of the points
//! (GLS-PIA's default control points).
//!
//! `cargo bench --bench compare`. Fixed amounts of work, so times compare across sizes:
//! GLS-PIA 30 iterations; Jupp–Kent 2 rounds (each: unwrap, a GCV search of 98 smoothing
//! spline solves, wrap); Samir 30 gradient steps on one node per point; CBC and BCC one
//! solve each. 100 dense samples. Memory and complexity: `docs/paper.md`.

// `criterion_group!` defines public functions without doc comments.
#![allow(missing_docs)]

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use spherefit::sphere::compare::{fit_with, Method, MethodOptions};
use spherefit::sphere::PointSet;
use std::time::Duration;

/// A wavy line on S², `n` points.
fn wavy(n: usize) -> PointSet {
    let rows: Vec<Vec<f64>> = (0..n)
        .map(|i| {
            let a = i as f64 / (n - 1) as f64 * 2.5;
            let lat = 0.4 * (7.0 * a).sin() + 0.05 * (53.0 * a).sin();
            vec![lat.cos() * a.cos(), lat.cos() * a.sin(), lat.sin()]
        })
        .collect();
    PointSet::try_from_rows(&rows).unwrap()
}

fn options(method: Method) -> MethodOptions {
    let o = MethodOptions::default().with_samples(100);
    match method {
        Method::JuppKent => o.with_iterations(2),
        Method::Samir => o.with_iterations(30),
        _ => o,
    }
}

fn bench_methods(c: &mut Criterion) {
    let mut g = c.benchmark_group("compare");
    g.sample_size(10);
    g.warm_up_time(Duration::from_millis(500));
    g.measurement_time(Duration::from_secs(3));
    for n in [10_000usize, 100_000] {
        let pts = wavy(n);
        g.throughput(Throughput::Elements(n as u64));
        for m in Method::ALL {
            let o = options(m);
            g.bench_with_input(BenchmarkId::new(m.name(), n), &pts, |b, pts| {
                b.iter(|| fit_with(m, pts, None, &o).unwrap())
            });
        }
    }
    g.finish();
}

criterion_group!(benches, bench_methods);
criterion_main!(benches);
