//! Fitting a spherical B-spline to ordered points: parameters and knots ([`knots`]), GLS-PIA
//! ([`mod@gls_pia`]), the Gauss–Newton solver beside it, the shared data pass, and the geodesic
//! error metrics ([`metrics`]).

mod accelerated;
pub mod adaptive_knots;
mod damping;
pub mod footpoint;
mod gauss_newton;
pub mod gls_pia;
mod jacobian;
pub mod knots;
pub mod metrics;
pub mod options;
pub mod options_check;
pub(crate) mod pass;
pub mod seam;
pub mod solve;

// The public names of a fit, as `spherefit::sphere::fit::*` has always offered them (the crate's
// own files import them from the files that define them).
pub use gls_pia::{gls_pia, gls_pia_iteration};
pub use options::{
    default_control_points, FitOptions, FitReport, IterationError, Solver, StepRule,
    CORRECTION_INTERVAL, DEFAULT_ITERATIONS, DEFAULT_STAGNATION, GAUSS_NEWTON_CORRECTION_ROUNDS,
};
pub use solve::{fit, resume_accelerated, MAX_LENGTH_RATIO};
