//! A fast solver beside GLS-PIA: Gauss–Newton with Levenberg–Marquardt damping on the geodesic
//! least-squares loss `Σ_j θ_j²`, `θ_j = angle(q_j, C(t_j))`.
//!
//! The residual of point j is the log map `r_j = log_{C(t_j)}(q_j)` (length θ_j), and the
//! Jacobian of C(t_j) with respect to control point i is taken as `D_i(t_j)` times the identity
//! on the tangent plane: the contribution coefficients GLS-PIA already computes. This drops the
//! (second-order in the control spread) dependence of D on the control points, so each step
//! solves the banded normal equations `(AᵀA) V = Aᵀ R` with `A_ji = D_i(t_j)`, one banded
//! Cholesky factorisation for all coordinates, and moves each control point along the
//! exponential map of its (tangent-projected) row of V. Its fixed point `Σ_j D_i(t_j) r_j = 0`
//! is close to GLS-PIA's, reached in a handful of passes instead of thousands. Near it that
//! cheap Jacobian stops giving descent directions (it drops how D depends on the control
//! points), so the solver then switches to the exact Jacobian (`jacobian.rs`): block-banded
//! normal equations in tangent coordinates, quadratic convergence to the geodesic
//! least-squares optimum for the given knots.

use crate::sphere::curve::bspline::SphericalBSpline;
use crate::sphere::fit::damping::{Damping, Run, Trial};
use crate::sphere::fit::options::{FitOptions, FitReport, Solver};
use crate::sphere::fit::pass::{run_pass, PassMode};
use crate::sphere::geometry::point::{dot, exp_in_place, Dynamic, PointSet};

/// Damping attempts per iteration before the solver declares it cannot improve further.
const MAX_DAMPING_TRIES: usize = 10;

/// `λ` after a failed undamped step.
const FIRST_LAMBDA: f64 = 1e-4;

/// While cheap steps still gain more than this fraction of the RMS error per iteration the
/// solver keeps using them; below it, it switches to exact-Jacobian steps (several times the
/// cost per pass, but quadratic convergence) when the control polygon is coarse.
const SWITCH_TO_EXACT_GAIN: f64 = 1e-2;

/// The cheap Jacobian drops terms of order (control arc)², so its fixed point moves away from
/// the optimum only when neighbouring control points are far apart. Below this largest arc the
/// exact phase is skipped unless the cheap step stops descending: on 1M points with 2k control
/// points (arcs near 2e-3 rad) it changed the RMS error in the 12th digit at five times the
/// cost (`examples/fit_large.rs`); on the 8-control "simple" stand-in (0.3 rad) it lowers the
/// RMS error by 0.2%.
const EXACT_PHASE_MIN_ARC_RAD: f64 = 0.02;

fn largest_control_arc(spline: &SphericalBSpline) -> f64 {
    let c = spline.control_points();
    (1..c.len())
        .map(|i| crate::sphere::geometry::point::angle_between(c.get(i - 1), c.get(i)))
        .fold(0.0, f64::max)
}

pub(crate) fn gauss_newton(
    spline: SphericalBSpline,
    points: &PointSet,
    params: Vec<f64>,
    options: &FitOptions,
) -> FitReport {
    let mut mode = PassMode::Normal;
    let mut run = Run::start(spline, points, &params, mode);
    let mut damping = Damping::new(FIRST_LAMBDA, MAX_DAMPING_TRIES);
    while run.step_again(options) {
        let Some(trial) = damped_step(&run, points, &params, mode, &mut damping) else {
            if mode == PassMode::Normal {
                // The cheap Jacobian found no descent: continue with the exact one.
                mode = PassMode::Exact;
                damping.lambda = 0.0;
                run.pass = run_pass(&run.spline, points, &params, mode);
                continue;
            }
            run.converged = true; // no step lowers the loss: a (local) optimum to rounding
            break;
        };
        let relative = run.accept(trial);
        if mode == PassMode::Normal
            && relative < SWITCH_TO_EXACT_GAIN
            && largest_control_arc(&run.spline) > EXACT_PHASE_MIN_ARC_RAD
        {
            mode = PassMode::Exact;
            damping.lambda = 0.0;
            run.pass = run_pass(&run.spline, points, &params, mode);
        } else if relative <= options.stagnation {
            run.converged = true;
            break;
        }
    }
    run.report(params, Solver::GaussNewton)
}

/// Solves the (damped) normal equations of `mode` and returns the first trial of
/// [`Damping::first_descent`] that lowers the RMS error.
fn damped_step(
    run: &Run,
    points: &PointSet,
    params: &[f64],
    mode: PassMode,
    damping: &mut Damping,
) -> Option<Trial> {
    // Normal: one column per coordinate; Exact: the unknowns are the tangent coordinates.
    let cols = if mode == PassMode::Exact {
        1
    } else {
        run.spline.dim()
    };
    let bases = &run.pass.bases;
    damping.first_descent(run, points, params, mode, cols, |trial, step| {
        move_along_geodesics(trial.control_points_mut(), step, mode, bases)
    })
}

/// `P_i ← exp_{P_i}(v_i)`. In [`PassMode::Normal`] row i of `step` holds ambient coordinates
/// (their tangent part is used); in [`PassMode::Exact`] it holds coordinates in the tangent
/// basis of P_i.
fn move_along_geodesics(control: &mut PointSet, step: &[f64], mode: PassMode, bases: &[f64]) {
    let dim = control.dim();
    let nb = dim - 1;
    let d = Dynamic(dim);
    let mut t = vec![0.0; dim];
    for i in 0..control.len() {
        let p = control.get_mut(i);
        if mode == PassMode::Exact {
            t.iter_mut().for_each(|x| *x = 0.0);
            for a in 0..nb {
                let c = step[i * nb + a];
                let e = &bases[(i * nb + a) * dim..(i * nb + a + 1) * dim];
                for x in 0..dim {
                    t[x] += c * e[x];
                }
            }
        } else {
            let v = &step[i * dim..(i + 1) * dim];
            let along = dot(d, p, v);
            for x in 0..dim {
                t[x] = v[x] - along * p[x];
            }
        }
        exp_in_place(d, p, &t);
    }
}

#[cfg(test)]
mod tests {
    use crate::sphere::fit::knots::{parameters, Parameterization};
    use crate::sphere::fit::{fit, FitOptions, Solver};
    use crate::sphere::geometry::point::PointSet;

    // Exact samples of a spline fitted with its own knots: tests/it/paper_reproduction.rs.

    #[test]
    fn reaches_the_gls_pia_fixed_point_on_noisy_data() {
        let rows: Vec<Vec<f64>> = (0..600)
            .map(|i| {
                let a = i as f64 / 599.0 * 2.0;
                let lat = 0.3 * (5.0 * a).sin() + 0.002 * ((i * 7919 % 101) as f64 / 50.0 - 1.0);
                vec![lat.cos() * a.cos(), lat.cos() * a.sin(), lat.sin()]
            })
            .collect();
        let pts = PointSet::try_from_rows(&rows).unwrap();
        let t = parameters(&pts, Parameterization::Chord).unwrap();
        let base = FitOptions::default().with_control_points(30);
        let pia30 = fit(&pts, Some(&t), &base).unwrap();
        let mut long = base.clone().with_iterations(2000);
        long.stagnation = 0.0;
        let pia2000 = fit(&pts, Some(&t), &long).unwrap();
        let gn = fit(
            &pts,
            Some(&t),
            &base.clone().with_solver(Solver::GaussNewton),
        )
        .unwrap();
        let (a, b, c) = (
            pia30.metrics.rms_error_rad,
            pia2000.metrics.rms_error_rad,
            gn.metrics.rms_error_rad,
        );
        eprintln!(
            "rms: gls-pia 30 {a:e}, gls-pia 2000 {b:e}, gauss-newton {c:e} in {} its",
            gn.iterations
        );
        assert!(c <= a);
        assert!((c - b).abs() <= 1e-3 * b, "{c:e} vs {b:e}");
        assert!(gn.converged);
    }
}
