//! Math on S^n: unit vectors, spherical B-splines, knot placement, GLS-PIA fitting and metrics.
//!
//! Nothing here knows about GeoJSON, HTTP or metres; the Earth layer ([`crate::earth`]) builds
//! on it. Every public result is a unit vector (|norm - 1| < 1e-12).

pub mod compress;
pub mod curve;
pub mod fit;
pub mod geometry;
pub mod interpolate;
pub mod linalg;

// The flat module paths from before the folders, kept so code written against them compiles.
#[doc(hidden)]
pub use crate::document;
pub use compress::{simplify, tolerance};
pub use curve::{bezier, bspline};
pub use fit::{knots, metrics};
pub use geometry::point;
pub use interpolate::beta;
pub use linalg::banded;

#[doc(hidden)]
pub use crate::document::{BetaDocument, SplineDocument};
pub use beta::{interpolate, BetaInterpolation, BetaSolver, InterpolationOptions};
pub use bezier::SphericalBezier;
pub use bspline::SphericalBSpline;
pub use curve::beta::SphericalBetaSpline;
pub use curve::AnyCurve;
pub use curve::SphericalCurve;
pub use fit::{
    fit, gls_pia, gls_pia_iteration, FitOptions, FitReport, IterationError, Solver, StepRule,
};
pub use knots::{KnotPlacement, Parameterization};
pub use metrics::ErrorMetrics;
pub use point::PointSet;
pub use tolerance::{fit_to_tolerance, KnotRule, ToleranceFit, ToleranceOptions};

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
    #[error("{field} {index}: {value} is out of range: {rule}")]
    InvalidShapeParameter {
        field: &'static str,
        index: usize,
        value: f64,
        rule: &'static str,
    },
    #[error(
        "{field}: expected 1 value (used at every point) or {expected} (one per point), got {got}"
    )]
    ShapeParameterCount {
        field: &'static str,
        expected: usize,
        got: usize,
    },
    #[error("points {} and {index} are the same point ({angle_rad} rad apart): an interpolating curve cannot pass through one point at two consecutive parameters; remove the repeat", index.saturating_sub(1))]
    RepeatedPoint { index: usize, angle_rad: f64 },
    #[error("point {joint}: Beta-spline interpolation failed after {iterations} iterations: the curve misses this point by {residual_rad} rad (tolerance {tolerance_rad} rad); the shape parameters cannot be met near this point (move beta1 towards 1)")]
    NotInterpolated {
        joint: usize,
        residual_rad: f64,
        tolerance_rad: f64,
        iterations: usize,
    },
    #[error("point {joint}: the Beta-spline needs an arc of (nearly) half a great circle here ({angle_rad} rad), where the curve is undefined; the shape parameters cannot be met near this point (move beta1 towards 1)")]
    DegenerateArc { joint: usize, angle_rad: f64 },
}

/// Entry points that exist only so `benches/` can compare implementation choices.
#[doc(hidden)]
pub mod bench_hooks {
    use super::fit::pass::{run_pass_dim, PassMode};
    use super::geometry::point::Dynamic;
    use super::{ErrorMetrics, PointSet, SphericalBSpline};

    /// One accumulate pass with the runtime-dimension kernel, whatever the dimension: measures
    /// what the compile-time `Fixed<3>` path saves on S^2.
    pub fn accumulate_pass_dynamic(
        spline: &SphericalBSpline,
        points: &PointSet,
        params: &[f64],
    ) -> ErrorMetrics {
        run_pass_dim(
            Dynamic(spline.dim()),
            spline,
            points,
            params,
            PassMode::Accumulate,
        )
        .errors
        .metrics()
    }
}
