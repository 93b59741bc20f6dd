//! GLS-PIA: progressive iterative approximation on the geodesic least-squares loss (GLS-PIA
//! paper §5, Algorithm 1).
//!
//! Each iteration evaluates the curve at every data parameter, forms the error vector
//! `δ_j = (q_j − C(t_j)) / |q_j − C(t_j)| · θ_j` (chord direction, geodesic length), shares it
//! out to the control points by their contribution coefficients, `Δ_i = μ_i Σ_j D_i(t_j) δ_j`,
//! and moves every control point at once: `P_i ← (P_i + Δ_i) / |P_i + Δ_i|`.

use crate::sphere::curve::bspline::{check_degree, SphericalBSpline};
use crate::sphere::fit::knots::{
    greville_control_points, normalize_parameters, parameters, place_knots, KnotPlacement,
    Parameterization,
};
use crate::sphere::fit::metrics::ErrorMetrics;
use crate::sphere::fit::pass::{run_pass, PassMode};
use crate::sphere::geometry::point::{normalize, Dynamic, PointSet};
use crate::sphere::SphereError;
use serde::{Deserialize, Serialize};

/// The paper's iteration count (§6).
pub const DEFAULT_ITERATIONS: usize = 30;

/// An iteration that lowers the RMS error by less than this fraction counts as stagnation: the
/// iteration has reached its fixed point to about 9 significant digits.
pub const DEFAULT_STAGNATION: f64 = 1e-9;

/// The step size μ of the update `Δ_i = μ_i Σ_j D_i(t_j) δ_j`; the paper only bounds it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum StepRule {
    /// Deng–Lin: `μ_i = 1 / Σ_j D_i(t_j)`, per control point, recomputed every iteration.
    /// Best or equal in almost every case measured (METHOD.md).
    #[default]
    DengLin,
    /// One global `μ = 1 / λ_max(AᵀA)` of the initial contribution matrix A, by power iteration:
    /// the step the paper's convergence argument uses.
    Global,
    /// A fixed global μ given by the caller.
    Constant(f64),
}

impl std::str::FromStr for StepRule {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "deng-lin" => Ok(StepRule::DengLin),
            "global" => Ok(StepRule::Global),
            _ => match s.parse::<f64>() {
                Ok(mu) if mu > 0.0 && mu.is_finite() => Ok(StepRule::Constant(mu)),
                _ => Err(format!(
                    "unknown step {s:?}: use deng-lin, global or a positive number"
                )),
            },
        }
    }
}

/// Which optimiser moves the control points.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Solver {
    /// GLS-PIA exactly as the paper describes (progressive iterative approximation).
    #[default]
    GlsPia,
    /// GLS-PIA with its update preconditioned by the banded normal matrix AᵀA (the paper's
    /// error allocation, Deng–Lin's diagonal replaced by the whole band): reaches GLS-PIA's
    /// fixed point in a few iterations (`accelerated.rs`). The default of the Earth fit.
    GlsPiaAccelerated,
    /// Gauss–Newton / Levenberg–Marquardt on the same loss with banded normal equations:
    /// reaches GLS-PIA's fixed point in a few passes (see `gauss_newton.rs`).
    GaussNewton,
}

impl Solver {
    /// The name used in options and reports.
    pub fn name(self) -> &'static str {
        match self {
            Solver::GlsPia => "gls-pia",
            Solver::GlsPiaAccelerated => "gls-pia-accelerated",
            Solver::GaussNewton => "gauss-newton",
        }
    }
}

from_names!(Solver, "solver", "gls-pia-accelerated, gls-pia or gauss-newton" {
    "gls-pia" => GlsPia,
    "gls-pia-accelerated" => GlsPiaAccelerated,
    "gauss-newton" => GaussNewton,
});

/// What to fit and how. `Default` is the paper's setting: cubic, geodesic-difference knots,
/// chord-length parameters, Deng–Lin steps, 30 iterations.
#[derive(Clone, Debug, PartialEq)]
pub struct FitOptions {
    /// Number of control points; `None` picks [`default_control_points`].
    pub control_points: Option<usize>,
    /// Degree 1 to 5.
    pub degree: usize,
    /// Knot placement (ignored when `knot_vector` is given).
    pub knots: KnotPlacement,
    /// An explicit clamped knot vector on [0, 1], e.g. to refit with known knots.
    pub knot_vector: Option<Vec<f64>>,
    /// How data points get parameters (ignored when parameters are given).
    pub parameterization: Parameterization,
    /// Maximum number of GLS-PIA updates.
    pub iterations: usize,
    /// Stop as soon as the max error is at or below this (radians).
    pub target_max_error_rad: Option<f64>,
    /// Stop when an iteration lowers the RMS error by less than this fraction.
    pub stagnation: f64,
    /// Step size rule (GLS-PIA only).
    pub step: StepRule,
    /// The optimiser.
    pub solver: Solver,
    /// Stops the fit (with [`SphereError::Cancelled`]) when cancelled or past its deadline.
    pub cancel: crate::sphere::cancel::Cancel,
    /// Move the data parameters to their foot points on the curve between updates
    /// ([`super::footpoint`]): every [`CORRECTION_INTERVAL`] GLS-PIA iterations, or after each
    /// Gauss–Newton solve. Off in the paper's method (parameters fixed); ignored for given
    /// parameters (timestamps are kept).
    pub parameter_correction: bool,
}

/// GLS-PIA iterations between two foot-point corrections.
pub const CORRECTION_INTERVAL: usize = 3;

/// Most Gauss–Newton solves alternated with foot-point corrections.
pub const GAUSS_NEWTON_CORRECTION_ROUNDS: usize = 8;

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            control_points: None,
            degree: 3,
            knots: KnotPlacement::Geodesic,
            knot_vector: None,
            parameterization: Parameterization::Chord,
            iterations: DEFAULT_ITERATIONS,
            target_max_error_rad: None,
            stagnation: DEFAULT_STAGNATION,
            step: StepRule::DengLin,
            solver: Solver::GlsPia,
            cancel: crate::sphere::cancel::Cancel::inherit(),
            parameter_correction: false,
        }
    }
}

impl FitOptions {
    /// The default of `POST /v1/fit` and `spherefit fit`: the paper's loss and feature function
    /// made faithful on real lines: [`KnotPlacement::Adaptive`] knots, accelerated GLS-PIA
    /// ([`Solver::GlsPiaAccelerated`], the paper's fixed point in a few passes), chord-length
    /// parameters kept (foot-point correction let the curve loop between the positions: 1,086
    /// km two-way on the 10m US–Mexico border). Measured on the 10m borders in the README ("Default fit"); the
    /// paper's method is [`FitOptions::default`].
    pub fn faithful() -> Self {
        FitOptions {
            knots: KnotPlacement::Adaptive,
            solver: Solver::GlsPiaAccelerated,
            parameter_correction: false,
            ..FitOptions::default()
        }
    }
    /// Whether a fit whose largest error is `max_error_rad` meets
    /// [`FitOptions::target_max_error_rad`].
    pub(crate) fn target_met(&self, max_error_rad: f64) -> bool {
        self.target_max_error_rad
            .is_some_and(|e| max_error_rad <= e)
    }
    with_fields! {
        /// Sets the number of control points.
        with_control_points(control_points: usize) = Some;
        /// Sets the degree.
        with_degree(degree: usize);
        /// Sets the knot placement.
        with_knots(knots: KnotPlacement);
        /// Uses an explicit knot vector (its length fixes the number of control points).
        with_knot_vector(knot_vector: Vec<f64>) = Some;
        /// Sets the parameterisation.
        with_parameterization(parameterization: Parameterization);
        /// Sets the maximum number of iterations.
        with_iterations(iterations: usize);
        /// Stops once the max error reaches this many radians.
        with_target_max_error_rad(target_max_error_rad: f64) = Some;
        /// Sets the solver.
        with_solver(solver: Solver);
        /// Sets the step rule.
        with_step(step: StepRule);
        /// Turns foot-point parameter correction on or off.
        with_parameter_correction(parameter_correction: bool);
    }
}

/// The default number of control points for `n` data points and degree `p`: a quarter of the
/// points (at least p + 1, at most n): the curve then stores about a quarter of the numbers.
pub fn default_control_points(n: usize, p: usize) -> usize {
    n.div_ceil(4).max(p + 1).min(n)
}

/// Max and mean error of one iteration's curve (index 0 of a history is the initial curve).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct IterationError {
    /// Largest geodesic error, radians.
    pub max_error_rad: f64,
    /// Mean geodesic error, radians.
    pub mean_error_rad: f64,
}

impl IterationError {
    /// The max and mean of `m`.
    pub(crate) fn of(m: &ErrorMetrics) -> IterationError {
        IterationError {
            max_error_rad: m.max_error_rad,
            mean_error_rad: m.mean_error_rad,
        }
    }
}

/// The result of a fit.
#[derive(Clone, Debug)]
pub struct FitReport {
    /// The fitted curve.
    pub spline: SphericalBSpline,
    /// Data parameters used, in [0, 1].
    pub parameters: Vec<f64>,
    /// Errors of the returned curve at the data parameters.
    pub metrics: ErrorMetrics,
    /// The error of every point of the returned curve at its parameter (radians), when the
    /// solver's last pass measured that curve (the banded solvers); empty otherwise.
    pub point_errors_rad: Vec<f64>,
    /// Number of control point updates made (accepted steps for Gauss–Newton).
    pub iterations: usize,
    /// True when the iteration stopped because it met the error target or stagnated, false when
    /// it ran out of iterations.
    pub converged: bool,
    /// Max / mean error before the first update and after each one.
    pub history: Vec<IterationError>,
    /// The solver that made the curve.
    pub solver: Solver,
}

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

/// GLS-PIA with the parameters moved to their foot points every [`CORRECTION_INTERVAL`]
/// iterations. Returns the (curve, parameters) pair with the lowest RMS error measured.
fn gls_pia_corrected(
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
