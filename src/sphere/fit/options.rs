//! What a fit on S^n takes and gives back: [`FitOptions`] (with the [`Solver`] and [`StepRule`]
//! they name, and the defaults) and [`FitReport`]. Kept apart from the solvers so that each
//! solver (GLS-PIA, its accelerated form, Gauss–Newton) and the dispatch in
//! [`crate::sphere::fit::solve`] import them from one place, without importing each other.

use crate::sphere::curve::bspline::SphericalBSpline;
use crate::sphere::fit::knots::{KnotPlacement, Parameterization};
use crate::sphere::fit::metrics::ErrorMetrics;

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
    /// Stops the fit (with [`SphereError::Cancelled`](crate::sphere::SphereError::Cancelled)) when cancelled or past its deadline.
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
