//! Math on S^n: unit vectors, spherical B-splines, knot placement, GLS-PIA fitting and metrics.
//!
//! Nothing here knows about GeoJSON, HTTP or metres; the Earth layer ([`crate::earth`]) builds
//! on it. Every public result is a unit vector (|norm - 1| < 1e-12).

pub mod bspline;
pub mod curve;
pub mod document;
pub mod fit;
pub mod knots;
pub mod metrics;
mod pass;
pub mod point;

pub use bspline::SphericalBSpline;
pub use curve::SphericalCurve;
pub use document::SplineDocument;
pub use fit::{fit, FitOptions, FitReport, IterationError, StepRule};
pub use knots::{KnotPlacement, Parameterization};
pub use metrics::ErrorMetrics;
pub use point::PointSet;

/// Everything that can be wrong with input to the math core. Each variant carries what a user
/// needs to find and fix the offending value.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SphereError {
    #[error("too few points: got {got}, need at least {need}")]
    TooFewPoints { got: usize, need: usize },
    #[error("point {index}: a point on S^n needs at least 2 coordinates, got {got}")]
    DimensionTooSmall { index: usize, got: usize },
    #[error(
        "point {index}: expected {expected} coordinates (the dimension of point 0), got {got}"
    )]
    DimensionMismatch {
        index: usize,
        expected: usize,
        got: usize,
    },
    #[error("point {index}, coordinate {coord}: not a finite number")]
    NotFinite { index: usize, coord: usize },
    #[error("point {index}: not a unit vector (norm {norm}); points on S^n must have norm 1")]
    NotUnit { index: usize, norm: f64 },
    #[error("points {} and {index} are (nearly) antipodal ({angle_rad} rad apart): the great circle between them is undefined", index.saturating_sub(1))]
    Antipodal { index: usize, angle_rad: f64 },
    #[error("degree {got} is not supported: use 1 to {max}")]
    InvalidDegree { got: usize, max: usize },
    #[error("knots: {reason}")]
    InvalidKnots { reason: String },
    #[error(
        "control_points: {got} control points for degree {degree}: need between {min} and {max}"
    )]
    InvalidControlPointCount {
        got: usize,
        degree: usize,
        min: usize,
        max: usize,
    },
    #[error("parameters: {reason}")]
    InvalidParameters { reason: String },
    #[error("all {count} points are the same point: there is no curve to fit")]
    AllPointsEqual { count: usize },
}
