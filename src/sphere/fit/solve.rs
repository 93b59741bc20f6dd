//! The dispatch of a fit on S^n: parameters and knots set up, then the chosen [`Solver`]
//! run (GLS-PIA, its accelerated form or Gauss–Newton), with foot-point corrections between
//! rounds when asked.

use crate::sphere::curve::bspline::{check_degree, SphericalBSpline};
use crate::sphere::fit::knots::{
    greville_control_points, normalize_parameters, parameters, place_knots,
};

use crate::sphere::geometry::point::PointSet;
use crate::sphere::SphereError;

use crate::sphere::fit::gls_pia::{gls_pia, gls_pia_corrected};
use crate::sphere::fit::options::{
    default_control_points, FitOptions, FitReport, Solver, GAUSS_NEWTON_CORRECTION_ROUNDS,
};

/// Fits a spherical B-spline to ordered `points` with GLS-PIA (or, with
/// [`Solver::GaussNewton`], the fast solver).
///
/// `given_params` (timestamps, for example) are normalised to [0, 1]; without them the
/// parameters come from `options.parameterization`.
///
/// # Errors
/// Too few points for the degree, more control points than points, an invalid degree, knot
/// vector or parameter list, all points equal, or antipodal neighbours.
///
/// # Example
/// ```
/// use spherefit::sphere::{fit, FitOptions, PointSet};
/// let rows: Vec<Vec<f64>> = (0..50)
///     .map(|i| { let a = i as f64 * 0.02; vec![a.cos(), a.sin(), 0.1 * (3.0 * a).sin()] })
///     .map(|v| { let n = v.iter().map(|x| x * x).sum::<f64>().sqrt(); v.iter().map(|x| x / n).collect() })
///     .collect();
/// let points = PointSet::try_from_rows(&rows).unwrap();
/// let report = fit(&points, None, &FitOptions::default().with_control_points(8)).unwrap();
/// assert!(report.metrics.max_error_rad < 1e-3);
/// ```
pub fn fit(
    points: &PointSet,
    given_params: Option<&[f64]>,
    options: &FitOptions,
) -> Result<FitReport, SphereError> {
    let p = options.degree;
    check_degree(p)?;
    let n = points.len();
    if n < p + 1 {
        return Err(SphereError::TooFewPoints {
            got: n,
            need: p + 1,
        });
    }
    points.check_no_antipodal_neighbours()?;
    let params = match given_params {
        Some(t) => normalize_parameters(t, n)?,
        None => parameters(points, options.parameterization)?,
    };
    let knots = match &options.knot_vector {
        Some(k) => k.clone(),
        None => {
            let n_ctrl = options
                .control_points
                .unwrap_or_else(|| default_control_points(n, p));
            if n_ctrl < p + 1 || n_ctrl > n {
                return Err(SphereError::InvalidControlPointCount {
                    got: n_ctrl,
                    degree: p,
                    min: p + 1,
                    max: n,
                });
            }
            place_knots(points, &params, n_ctrl, p, options.knots)?
        }
    };
    if knots.len() < 2 * (p + 1) {
        return Err(SphereError::InvalidKnots {
            reason: format!(
                "{} knots cannot clamp a degree-{p} spline (need at least {})",
                knots.len(),
                2 * (p + 1)
            ),
        });
    }
    let initial = greville_control_points(points, &params, &knots, p)?;
    let spline = SphericalBSpline::try_new(p, knots, initial)?;
    let correct = options.parameter_correction && given_params.is_none();
    let r = match (options.solver, correct) {
        (Solver::GlsPia, false) => gls_pia(spline, points, params, options),
        (Solver::GlsPia, true) => gls_pia_corrected(spline, points, params, options),
        (Solver::GaussNewton, false) => {
            super::gauss_newton::gauss_newton(spline, points, params, options)
        }
        (Solver::GaussNewton, true) => solve_corrected(spline, points, params, options, |s, p| {
            super::gauss_newton::gauss_newton(s, points, p, options)
        }),
        (Solver::GlsPiaAccelerated, false) => {
            super::accelerated::gls_pia_accelerated(spline, points, params, options)
        }
        (Solver::GlsPiaAccelerated, true) => {
            solve_corrected(spline, points, params, options, |s, p| {
                super::accelerated::gls_pia_accelerated(s, points, p, options)
            })
        }
    };
    options.cancel.check()?;
    Ok(r)
}

/// Continues accelerated GLS-PIA (without parameter correction) from the curve of `report`
/// at its parameters with `options`, as if its iterations had not stopped: the adaptive-knot
/// refinement fits its intermediate rounds with one update (the accelerated update lands
/// within about 1e-9 of GLS-PIA's fixed point in one step at fixed knots and parameters, so
/// a second only confirms it) and resumes the round it keeps. Iterations and history add up.
/// Reports of other solvers are returned as they are.
///
/// # Errors
/// [`SphereError::Cancelled`] when `options.cancel` is cancelled.
pub fn resume_accelerated(
    report: FitReport,
    points: &PointSet,
    options: &FitOptions,
) -> Result<FitReport, SphereError> {
    if report.solver != Solver::GlsPiaAccelerated || report.converged {
        return Ok(report);
    }
    let FitReport {
        spline,
        parameters,
        mut history,
        iterations,
        ..
    } = report;
    let mut rest = options.clone();
    rest.iterations = rest.iterations.saturating_sub(iterations);
    let mut r = super::accelerated::gls_pia_accelerated(spline, points, parameters, &rest);
    options.cancel.check()?;
    history.extend_from_slice(&r.history[1..]);
    r.history = history;
    r.iterations += iterations;
    Ok(r)
}

/// A tolerance fit whose curve is longer than this times the data polyline does not count as
/// meeting its tolerance (`earth::curve::fitting`).
pub const MAX_LENGTH_RATIO: f64 = 1.25;

/// Solves (Gauss–Newton or accelerated GLS-PIA) alternated with foot-point corrections, until
/// a round lowers the RMS error by less than 1 % or [`GAUSS_NEWTON_CORRECTION_ROUNDS`] are
/// done.
fn solve_corrected(
    spline: SphericalBSpline,
    points: &PointSet,
    mut params: Vec<f64>,
    options: &FitOptions,
    solve: impl Fn(SphericalBSpline, Vec<f64>) -> FitReport,
) -> FitReport {
    let mut r = solve(spline, params.clone());
    let mut history = r.history.clone();
    let mut iterations = r.iterations;
    for _ in 1..GAUSS_NEWTON_CORRECTION_ROUNDS {
        if options.cancel.is_cancelled() {
            break;
        }
        if options.target_met(r.metrics.max_error_rad) {
            break;
        }
        params.clone_from(&r.parameters);
        if super::footpoint::correct_parameters(&r.spline, points, &mut params) == 0 {
            break;
        }
        let next = solve(r.spline.clone(), params.clone());
        history.extend_from_slice(&next.history[1..]);
        iterations += next.iterations;
        let gain = r.metrics.rms_error_rad - next.metrics.rms_error_rad;
        if gain <= 0.0 {
            break;
        }
        let small = gain < 0.01 * r.metrics.rms_error_rad;
        r = next;
        if small {
            break;
        }
    }
    r.history = history;
    r.iterations = iterations;
    r
}
