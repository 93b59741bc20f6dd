//! Math on S^n: unit vectors, spherical B-splines, knot placement, GLS-PIA fitting and metrics.
//!
//! Nothing here knows about GeoJSON, HTTP or metres; the Earth layer ([`crate::earth`]) builds
//! on it. Every public result is a unit vector (|norm - 1| < 1e-12).

pub mod cancel;
pub mod certify;
pub mod compress;
pub mod curve;
pub mod fit;
pub mod geometry;
pub mod interpolate;
pub(crate) mod linalg;

// The flat module paths from before the folders, kept so code written against them compiles.
#[doc(hidden)]
pub use crate::document;
pub use certify::{bounds, dense, two_way};
pub use compress::{simplify, tolerance};
pub use curve::{bezier, bspline};
pub use fit::{knots, metrics};
pub use geometry::point;
pub use interpolate::beta;

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
/// needs to find and fix the offending value; indices are 0-based positions in the input.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SphereError {
    /// Fewer points than the operation needs (for a fit: more than the degree).
    #[error("too few points: got {got}, need at least {need}")]
    TooFewPoints {
        /// Points given.
        got: usize,
        /// Smallest count that works.
        need: usize,
    },
    /// A point with fewer than 2 coordinates (S^n needs n >= 1).
    #[error("point {index}: a point on S^n needs at least 2 coordinates, got {got}")]
    DimensionTooSmall {
        /// The point.
        index: usize,
        /// Its number of coordinates.
        got: usize,
    },
    /// A point whose dimension differs from that of point 0.
    #[error(
        "point {index}: expected {expected} coordinates (the dimension of point 0), got {got}"
    )]
    DimensionMismatch {
        /// The point.
        index: usize,
        /// Coordinates of point 0.
        expected: usize,
        /// Coordinates of this point.
        got: usize,
    },
    /// A NaN or infinite coordinate.
    #[error("point {index}, coordinate {coord}: not a finite number")]
    NotFinite {
        /// The point.
        index: usize,
        /// The coordinate within the point.
        coord: usize,
    },
    /// A point whose norm is not 1 within [`geometry::point::UNIT_NORM_TOLERANCE`].
    #[error("point {index}: not a unit vector (norm {norm}); points on S^n must have norm 1")]
    NotUnit {
        /// The point.
        index: usize,
        /// Its Euclidean norm.
        norm: f64,
    },
    /// Consecutive points (`index - 1`, `index`) so close to antipodal that the great circle
    /// through them is undefined.
    #[error("points {} and {index} are (nearly) antipodal ({angle_rad} rad apart): the great circle between them is undefined", index.saturating_sub(1))]
    Antipodal {
        /// The second point of the pair.
        index: usize,
        /// Their geodesic distance, radians.
        angle_rad: f64,
    },
    /// A spline degree outside `1..=max`.
    #[error("degree {got} is not supported: use 1 to {max}")]
    InvalidDegree {
        /// The degree asked for.
        got: usize,
        /// The largest supported degree.
        max: usize,
    },
    /// A knot vector that is not a clamped, non-decreasing vector of the right length.
    #[error("knots: {reason}")]
    InvalidKnots {
        /// What is wrong, naming the knot.
        reason: String,
    },
    /// A control-point count the degree and the data cannot support.
    #[error(
        "control_points: {got} control points for degree {degree}: need between {min} and {max}"
    )]
    InvalidControlPointCount {
        /// The count asked for.
        got: usize,
        /// The spline degree.
        degree: usize,
        /// Smallest count (degree + 1).
        min: usize,
        /// Largest count (when fitting: the number of points).
        max: usize,
    },
    /// Data parameters that are not finite, increasing, or one per point.
    #[error("parameters: {reason}")]
    InvalidParameters {
        /// What is wrong, naming the parameter.
        reason: String,
    },
    /// Every point is the same point, so there is no curve to fit.
    #[error("all {count} points are the same point: there is no curve to fit")]
    AllPointsEqual {
        /// The number of points.
        count: usize,
    },
    /// A Beta-spline shape parameter out of its range.
    #[error("{field} {index}: {value} is out of range: {rule}")]
    InvalidShapeParameter {
        /// `beta1` or `beta2`.
        field: &'static str,
        /// The point it belongs to.
        index: usize,
        /// The value given.
        value: f64,
        /// The range it must be in.
        rule: &'static str,
    },
    /// A list of shape parameters that is neither one value nor one per point.
    #[error(
        "{field}: expected 1 value (used at every point) or {expected} (one per point), got {got}"
    )]
    ShapeParameterCount {
        /// `beta1` or `beta2`.
        field: &'static str,
        /// The number of points.
        expected: usize,
        /// Values given.
        got: usize,
    },
    /// Consecutive points (`index - 1`, `index`) that coincide, which an interpolating curve
    /// cannot pass through at two parameters.
    #[error("points {} and {index} are the same point ({angle_rad} rad apart): an interpolating curve cannot pass through one point at two consecutive parameters; remove the repeat", index.saturating_sub(1))]
    RepeatedPoint {
        /// The second point of the pair.
        index: usize,
        /// Their geodesic distance, radians.
        angle_rad: f64,
    },
    /// Beta-spline interpolation that did not reach its tolerance at some point.
    #[error("point {joint}: Beta-spline interpolation failed after {iterations} iterations: the curve misses this point by {residual_rad} rad (tolerance {tolerance_rad} rad); the shape parameters cannot be met near this point (move beta1 towards 1)")]
    NotInterpolated {
        /// The worst point.
        joint: usize,
        /// How far the curve misses it, radians.
        residual_rad: f64,
        /// The tolerance asked for, radians.
        tolerance_rad: f64,
        /// Solver steps taken.
        iterations: usize,
    },
    /// A Beta-spline that would need an arc of half a great circle near a point.
    #[error("point {joint}: the Beta-spline needs an arc of (nearly) half a great circle here ({angle_rad} rad), where the curve is undefined; the shape parameters cannot be met near this point (move beta1 towards 1)")]
    DegenerateArc {
        /// The point.
        joint: usize,
        /// The arc's angle, radians.
        angle_rad: f64,
    },
    /// Every candidate of a tolerance fit had (nearly) antipodal neighbouring control points.
    #[error("no valid spline was found: every candidate had two neighbouring control points (nearly) antipodal (the points may lie on one great circle); add points in between or use a smaller tolerance")]
    NoValidFit,
    /// The work ran past its time budget or was cancelled.
    #[error("stopped: the time budget of the work ran out or it was cancelled")]
    Cancelled,
    /// A result that is not a finite number.
    #[error("{what}: the result is not finite ({why})")]
    NonFinite {
        /// What was computed.
        what: &'static str,
        /// Why it overflowed or underflowed.
        why: String,
    },
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
