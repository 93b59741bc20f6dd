//! Runs GLS-PIA iterations on the bench's S^2 input for profiling with callgrind:
//! `valgrind --tool=callgrind target/release/examples/profile_pass 100000 2000 3`.

use spherefit::sphere::fit::knots::{greville_control_points, parameters, place_knots};
use spherefit::sphere::{
    gls_pia_iteration, KnotPlacement, Parameterization, PointSet, SphericalBSpline, StepRule,
};

fn main() {
    let args: Vec<usize> = std::env::args()
        .skip(1)
        .map(|a| a.parse().unwrap())
        .collect();
    let (n, n_ctrl, iters) = (args[0], args[1], args[2]);
    let rows: Vec<Vec<f64>> = (0..n)
        .map(|i| {
            let a = i as f64 / (n - 1) as f64 * 2.5;
            let lat = 0.4 * (7.0 * a).sin() + 0.05 * (53.0 * a).sin();
            vec![lat.cos() * a.cos(), lat.cos() * a.sin(), lat.sin()]
        })
        .collect();
    let pts = PointSet::try_from_rows(&rows).unwrap();
    let t = parameters(&pts, Parameterization::Chord).unwrap();
    let knots = place_knots(&pts, &t, n_ctrl, 3, KnotPlacement::Geodesic).unwrap();
    let cp = greville_control_points(&pts, &t, &knots, 3).unwrap();
    let mut spline = SphericalBSpline::try_new(3, knots, cp).unwrap();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let start = std::time::Instant::now();
    for _ in 0..iters {
        let m = pool.install(|| gls_pia_iteration(&mut spline, &pts, &t, StepRule::DengLin));
        eprintln!("max {:e} mean {:e}", m.max_error_rad, m.mean_error_rad);
    }
    let per = start.elapsed().as_nanos() as f64 / (iters * n) as f64;
    eprintln!("{per:.1} ns per point-iteration");
}
