//! GLS-PIA: progressive iterative approximation on the geodesic least-squares loss (GLS-PIA
//! paper §5, Algorithm 1).
//!
//! Each iteration evaluates the curve at every data parameter, forms the error vector
//! `δ_j = (q_j − C(t_j)) / |q_j − C(t_j)| · θ_j` (chord direction, geodesic length), shares it
//! out to the control points by their contribution coefficients, `Δ_i = μ_i Σ_j D_i(t_j) δ_j`,
//! and moves every control point at once: `P_i ← (P_i + Δ_i) / |P_i + Δ_i|`.

use crate::sphere::curve::bspline::SphericalBSpline;

use crate::sphere::fit::metrics::ErrorMetrics;
use crate::sphere::fit::pass::{run_pass, PassMode};
use crate::sphere::geometry::point::{normalize, Dynamic, PointSet};

use crate::sphere::fit::options::{
    FitOptions, FitReport, IterationError, Solver, StepRule, CORRECTION_INTERVAL,
};

/// GLS-PIA with the parameters moved to their foot points every [`CORRECTION_INTERVAL`]
/// iterations. Returns the (curve, parameters) pair with the lowest RMS error measured.
pub(crate) fn gls_pia_corrected(
    spline: SphericalBSpline,
    points: &PointSet,
    params: Vec<f64>,
    options: &FitOptions,
) -> FitReport {
    gls_pia_loop(spline, points, params, options, Some(CORRECTION_INTERVAL))
}

/// Runs GLS-PIA from `spline` (its knots are kept) on points with known parameters.
pub fn gls_pia(
    spline: SphericalBSpline,
    points: &PointSet,
    params: Vec<f64>,
    options: &FitOptions,
) -> FitReport {
    gls_pia_loop(spline, points, params, options, None)
}

/// The GLS-PIA iterations: measure, keep the best curve by RMS error, stop on the target, on
/// stagnation, when cancelled or out of iterations, else move every control point. With
/// `correct_every`, the parameters move to their foot points every that many iterations (and
/// the best curve is kept with its parameters); without, they stay as given.
fn gls_pia_loop(
    mut spline: SphericalBSpline,
    points: &PointSet,
    mut params: Vec<f64>,
    options: &FitOptions,
    correct_every: Option<usize>,
) -> FitReport {
    let global_mu = global_step(options.step, &spline, &params);
    let mut history = Vec::with_capacity(options.iterations + 1);
    let mut best: Option<(SphericalBSpline, Option<Vec<f64>>, ErrorMetrics)> = None;
    let mut iterations = 0;
    let mut converged = false;
    let mut last_rms = f64::INFINITY;
    loop {
        let mode = if iterations < options.iterations {
            PassMode::Accumulate
        } else {
            PassMode::Measure
        };
        let pass = run_pass(&spline, points, &params, mode);
        let m = pass.errors.metrics();
        history.push(IterationError::of(&m));
        if best
            .as_ref()
            .is_none_or(|(_, _, b)| m.rms_error_rad < b.rms_error_rad)
        {
            // Parameters are copied only when they can change.
            best = Some((spline.clone(), correct_every.map(|_| params.clone()), m));
        }
        let target_met = options.target_met(m.max_error_rad);
        let stagnated =
            iterations > 0 && last_rms - m.rms_error_rad <= options.stagnation * last_rms;
        if target_met || stagnated || m.max_error_rad == 0.0 {
            converged = true;
            break;
        }
        if mode == PassMode::Measure || options.cancel.is_cancelled() {
            break;
        }
        last_rms = m.rms_error_rad;
        apply_moves(&mut spline, &pass.moves, &pass.weights, global_mu);
        iterations += 1;
        if correct_every.is_some_and(|k| iterations % k == 0) {
            super::footpoint::correct_parameters(&spline, points, &mut params);
            // The loss changed with the parameters: the next drop is not a stagnation test.
            last_rms = f64::INFINITY;
        }
    }
    let (spline, best_params, metrics) = best.expect("at least one pass ran");
    FitReport {
        spline,
        parameters: best_params.unwrap_or(params),
        metrics,
        point_errors_rad: Vec::new(),
        iterations,
        converged,
        history,
        solver: Solver::GlsPia,
    }
}

/// The one step size of [`StepRule::Global`] (1/λmax of AᵀA) or a constant step; `None` for
/// Deng and Lin's step per control point.
fn global_step(step: StepRule, spline: &SphericalBSpline, params: &[f64]) -> Option<f64> {
    match step {
        StepRule::DengLin => None,
        StepRule::Global => Some(1.0 / largest_eigenvalue(spline, params)),
        StepRule::Constant(mu) => Some(mu),
    }
}

/// One GLS-PIA iteration in place: measures the current curve, moves every control point, and
/// returns the errors measured *before* the move. `step` as in [`FitOptions::step`]
/// (`StepRule::Global` is computed afresh here; [`gls_pia`] computes it once).
pub fn gls_pia_iteration(
    spline: &mut SphericalBSpline,
    points: &PointSet,
    params: &[f64],
    step: StepRule,
) -> ErrorMetrics {
    let global_mu = global_step(step, spline, params);
    let pass = run_pass(spline, points, params, PassMode::Accumulate);
    apply_moves(spline, &pass.moves, &pass.weights, global_mu);
    pass.errors.metrics()
}

/// [`gls_pia_iteration`] on a subset of the data that holds every point whose curve point
/// depends on a control point `moving(i)` says may move; the other control points stay put
/// (their data are only partly in the subset). Returns the subset's error sums before the move.
pub(crate) fn gls_pia_iteration_local(
    spline: &mut SphericalBSpline,
    points: &PointSet,
    params: &[f64],
    step: StepRule,
    moving: impl Fn(usize) -> bool,
) -> (super::metrics::ErrorSums, Vec<f64>) {
    let global_mu = global_step(step, spline, params);
    let mut pass = run_pass(spline, points, params, PassMode::Accumulate);
    for (i, w) in pass.weights.iter_mut().enumerate() {
        if !moving(i) {
            *w = 0.0;
        }
    }
    apply_moves(spline, &pass.moves, &pass.weights, global_mu);
    (pass.errors, pass.each)
}

/// `P_i ← (P_i + μ_i M_i) / |P_i + μ_i M_i|` with `M_i = Σ_j D_i(t_j) δ_j` and `μ_i = 1 / Σ_j
/// D_i(t_j)` (Deng–Lin) unless a global μ is given.
fn apply_moves(
    spline: &mut SphericalBSpline,
    moves: &[f64],
    weights: &[f64],
    global_mu: Option<f64>,
) {
    let dim = spline.dim();
    let control = spline.control_points_mut();
    for i in 0..control.len() {
        let w = weights[i];
        if w <= 0.0 {
            continue; // no data in this control point's support: nothing pulls it
        }
        let mu = global_mu.unwrap_or(1.0 / w);
        let pi = control.get_mut(i);
        for (x, mv) in pi.iter_mut().zip(&moves[i * dim..(i + 1) * dim]) {
            *x += mu * mv;
        }
        normalize(Dynamic(dim), pi);
    }
}

/// λ_max(AᵀA) of the contribution matrix A (rows: data points, columns: control points) by
/// power iteration; A is banded, so each product costs O(n p).
fn largest_eigenvalue(spline: &SphericalBSpline, params: &[f64]) -> f64 {
    let n_ctrl = spline.control_points().len();
    let rows: Vec<_> = params.iter().map(|&t| spline.contributions(t)).collect();
    let mut v = vec![1.0 / (n_ctrl as f64).sqrt(); n_ctrl];
    let mut lambda = 1.0;
    for _ in 0..50 {
        let mut w = vec![0.0; n_ctrl];
        for r in &rows {
            let av: f64 = r
                .coefficients
                .iter()
                .enumerate()
                .map(|(m, c)| c * v[r.first + m])
                .sum();
            for (m, c) in r.coefficients.iter().enumerate() {
                w[r.first + m] += c * av;
            }
        }
        let norm = w.iter().map(|x| x * x).sum::<f64>().sqrt();
        if norm == 0.0 {
            return 1.0;
        }
        lambda = norm;
        v = w.into_iter().map(|x| x / norm).collect();
    }
    lambda
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sphere::fit::solve::{fit, resume_accelerated};
    use crate::sphere::SphereError;

    fn wavy(n: usize) -> PointSet {
        let rows: Vec<Vec<f64>> = (0..n)
            .map(|i| {
                let a = i as f64 / (n - 1) as f64 * 2.0;
                let lat = 0.3 * (4.0 * a).sin();
                vec![lat.cos() * a.cos(), lat.cos() * a.sin(), lat.sin()]
            })
            .collect();
        PointSet::try_from_rows(&rows).unwrap()
    }

    #[test]
    fn error_falls_over_the_iterations() {
        let pts = wavy(200);
        let r = fit(&pts, None, &FitOptions::default().with_control_points(12)).unwrap();
        assert_eq!(r.history.len(), 31);
        assert!(r.history[30].mean_error_rad < 0.5 * r.history[0].mean_error_rad);
        assert!(r.history[30].max_error_rad < r.history[0].max_error_rad);
        assert!((r.metrics.max_error_rad - r.history[30].max_error_rad).abs() < 1e-15);
    }

    #[test]
    fn target_error_stops_early() {
        let pts = wavy(200);
        let opts = FitOptions::default()
            .with_control_points(40)
            .with_target_max_error_rad(1e-3);
        let r = fit(&pts, None, &opts).unwrap();
        assert!(r.converged);
        assert!(r.iterations < 30);
        assert!(r.metrics.max_error_rad <= 1e-3);
    }

    #[test]
    fn step_rules_all_reduce_the_error() {
        let pts = wavy(100);
        for step in [
            StepRule::DengLin,
            StepRule::Global,
            StepRule::Constant(0.02),
        ] {
            let opts = FitOptions::default()
                .with_control_points(10)
                .with_step(step);
            let r = fit(&pts, None, &opts).unwrap();
            assert!(
                r.metrics.mean_error_rad < r.history[0].mean_error_rad,
                "{step:?}"
            );
        }
    }

    #[test]
    fn the_banded_solvers_report_every_point_error_of_the_curve_returned() {
        let pts = wavy(300);
        for solver in [Solver::GlsPiaAccelerated, Solver::GaussNewton] {
            let mut opts = FitOptions::default().with_control_points(20);
            opts.solver = solver;
            let r = fit(&pts, None, &opts).unwrap();
            let want = super::super::metrics::pointwise_errors(&r.spline, &pts, &r.parameters);
            assert_eq!(r.point_errors_rad.len(), want.len(), "{solver:?}");
            for (got, want) in r.point_errors_rad.iter().zip(&want) {
                assert!((got - want).abs() <= 1e-15, "{solver:?}: {got} vs {want}");
            }
            assert!(r.point_errors_rad.iter().any(|&e| e > 1e-6));
        }
    }

    #[test]
    fn a_one_update_fit_resumed_ends_where_the_full_fit_ends() {
        let pts = wavy(300);
        let mut opts = FitOptions::default().with_control_points(20);
        opts.solver = Solver::GlsPiaAccelerated;
        let full = fit(&pts, None, &opts).unwrap();
        let one = fit(&pts, None, &opts.clone().with_iterations(1)).unwrap();
        assert_eq!(one.iterations, 1);
        assert!(!one.converged);
        let resumed = resume_accelerated(one, &pts, &opts).unwrap();
        assert!(resumed.converged);
        assert_eq!(resumed.iterations, full.iterations);
        assert_eq!(resumed.history.len(), full.history.len());
        let (a, b) = (resumed.metrics.rms_error_rad, full.metrics.rms_error_rad);
        assert!((a - b).abs() <= 1e-9 * b, "{a} vs {b}");
        // A converged report is returned as it is.
        let again = resume_accelerated(resumed.clone(), &pts, &opts).unwrap();
        assert_eq!(again.iterations, resumed.iterations);
    }

    #[test]
    fn bad_requests_are_errors() {
        let pts = wavy(10);
        let e = fit(&pts, None, &FitOptions::default().with_control_points(11)).unwrap_err();
        assert!(matches!(
            e,
            SphereError::InvalidControlPointCount { got: 11, .. }
        ));
        let e = fit(&pts, None, &FitOptions::default().with_degree(9)).unwrap_err();
        assert!(matches!(e, SphereError::InvalidDegree { got: 9, .. }));
        let few = PointSet::try_from_rows(&[vec![1.0, 0.0, 0.0], vec![0.0, 1.0, 0.0]]).unwrap();
        let e = fit(&few, None, &FitOptions::default()).unwrap_err();
        assert!(matches!(e, SphereError::TooFewPoints { got: 2, need: 4 }));
    }
}
