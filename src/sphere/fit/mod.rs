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
pub mod options_check;
pub(crate) mod pass;
pub mod seam;

pub use gls_pia::*;
