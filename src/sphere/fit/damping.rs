//! What the two banded solvers (accelerated GLS-PIA and Gauss–Newton) share: the state of a
//! run ([`Run`]) and Levenberg–Marquardt damping on the banded normal equations of a data pass
//! ([`Damping`]). They differ in the system their pass builds and in how a solution moves the
//! control points, not in how a step is damped or a run is recorded.

use crate::sphere::curve::bspline::SphericalBSpline;
use crate::sphere::fit::metrics::ErrorMetrics;
use crate::sphere::fit::options::{FitOptions, FitReport, IterationError, Solver};
use crate::sphere::fit::pass::{run_pass, PassMode, PassResult};
use crate::sphere::geometry::point::PointSet;

/// Tikhonov ridge relative to the largest diagonal of the normal matrix: keeps control points
/// whose support holds no data (their rows of A are zero) from making the system singular, and
/// is far below any entry that matters (diagonals are sums of squared coefficients of order 1).
const RIDGE_RELATIVE: f64 = 1e-12;

/// A trial curve, the pass run on it (which holds the next system) and its errors.
pub(super) type Trial = (SphericalBSpline, PassResult, ErrorMetrics);

/// One solver run: the current curve, the last pass on it (which holds the next system) and its
/// errors, the errors after every accepted step, how many were accepted, and whether the run
/// converged.
pub(super) struct Run {
    pub(super) spline: SphericalBSpline,
    pub(super) pass: PassResult,
    pub(super) m: ErrorMetrics,
    history: Vec<IterationError>,
    iterations: usize,
    pub(super) converged: bool,
}

impl Run {
    /// The run from `spline`, with `mode`'s pass on it.
    pub(super) fn start(
        spline: SphericalBSpline,
        points: &PointSet,
        params: &[f64],
        mode: PassMode,
    ) -> Run {
        let pass = run_pass(&spline, points, params, mode);
        let m = pass.errors.metrics();
        Run {
            spline,
            pass,
            history: vec![IterationError::of(&m)],
            m,
            iterations: 0,
            converged: false,
        }
    }

    /// Whether to take another step: iterations are left, the fit is not cancelled, and the
    /// curve neither passes through every point nor meets the options' error target (either
    /// of which converges the run).
    pub(super) fn step_again(&mut self, options: &FitOptions) -> bool {
        if self.iterations >= options.iterations || options.cancel.is_cancelled() {
            return false;
        }
        if self.m.max_error_rad == 0.0 || options.target_met(self.m.max_error_rad) {
            self.converged = true;
            return false;
        }
        true
    }

    /// Takes `trial` as the current curve; returns the relative gain in RMS error.
    pub(super) fn accept(&mut self, (spline, pass, m): Trial) -> f64 {
        self.iterations += 1;
        self.history.push(IterationError::of(&m));
        let relative = (self.m.rms_error_rad - m.rms_error_rad) / self.m.rms_error_rad;
        self.spline = spline;
        self.pass = pass;
        self.m = m;
        relative
    }

    /// The report of the run, at the data parameters `params`.
    pub(super) fn report(self, params: Vec<f64>, solver: Solver) -> FitReport {
        FitReport {
            spline: self.spline,
            parameters: params,
            metrics: self.m,
            point_errors_rad: self.pass.each,
            iterations: self.iterations,
            converged: self.converged,
            history: self.history,
            solver,
        }
    }
}

/// The damping `λ` of one solver run: 0 while undamped steps lower the error.
pub(super) struct Damping {
    pub(super) lambda: f64,
    /// `λ` after a failed undamped step.
    first: f64,
    /// Damping attempts per step before the solver declares it cannot improve further.
    max_tries: usize,
}

impl Damping {
    /// Undamped to begin with; `first` is `λ` after a failed undamped step.
    pub(super) fn new(first: f64, max_tries: usize) -> Damping {
        Damping {
            lambda: 0.0,
            first,
            max_tries,
        }
    }

    /// Solves the normal equations of `run`'s pass, `(band + λ diag(band)) V = moves` (`cols`
    /// right-hand sides per row of the band), for growing `λ`, moves a copy of the curve by V
    /// with `apply`, and returns the first trial whose `mode` pass lowers the RMS error; `None`
    /// when none of `max_tries` does. `λ` shrinks tenfold after a success (to 0 below 1e-9)
    /// and grows tenfold after a failure.
    pub(super) fn first_descent(
        &mut self,
        run: &Run,
        points: &PointSet,
        params: &[f64],
        mode: PassMode,
        cols: usize,
        apply: impl Fn(&mut SphericalBSpline, &[f64]),
    ) -> Option<Trial> {
        let band = run
            .pass
            .band
            .as_ref()
            .expect("a pass with normal equations");
        let ridge = RIDGE_RELATIVE * band.max_diagonal().max(f64::MIN_POSITIVE);
        for _ in 0..self.max_tries {
            let Some(chol) = band.cholesky(self.lambda, ridge) else {
                self.lambda = (self.lambda * 10.0).max(1e-6);
                continue;
            };
            let mut step = run.pass.moves.clone();
            chol.solve_in_place(&mut step, cols);
            let mut trial = run.spline.clone();
            apply(&mut trial, &step);
            let trial_pass = run_pass(&trial, points, params, mode);
            let tm = trial_pass.errors.metrics();
            let found = (trial, trial_pass, tm);
            if found.2.rms_error_rad < run.m.rms_error_rad {
                self.lambda = if self.lambda < 1e-9 {
                    0.0
                } else {
                    self.lambda / 10.0
                };
                return Some(found);
            }
            self.lambda = if self.lambda == 0.0 {
                self.first
            } else {
                self.lambda * 10.0
            };
        }
        None
    }
}
