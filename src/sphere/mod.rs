//! Math on S^n: unit vectors, spherical B-splines, knot placement, GLS-PIA fitting and metrics.
//!
//! Nothing here knows about GeoJSON, HTTP or metres; the Earth layer ([`crate::earth`]) builds
//! on it. Every public result is a unit vector (|norm - 1| < 1e-12).

/// `with_*` builder methods of an options struct, each setting the field it names and
/// returning the struct: `with_degree(degree: usize);` sets `self.degree = degree`, and
/// `with_max_control_points(max_control_points: usize) = Some;` wraps the value first.
macro_rules! with_fields {
    (@value $field:ident) => { $field };
    (@value $field:ident $wrap:ident) => { $wrap($field) };
    ($($(#[$doc:meta])* $method:ident($field:ident: $ty:ty) $(= $wrap:ident)?;)+) => {
        $(
            $(#[$doc])*
            pub fn $method(mut self, $field: $ty) -> Self {
                self.$field = with_fields!(@value $field $($wrap)?);
                self
            }
        )+
    };
}

/// `FromStr` for an enumeration of options by the names users write; any other name is
/// refused with `unknown <what> "<name>": use <the names>`.
macro_rules! from_names {
    ($t:ident, $what:literal, $names:literal { $($name:literal => $variant:ident),+ $(,)? }) => {
        impl std::str::FromStr for $t {
            type Err = String;
            fn from_str(s: &str) -> Result<Self, String> {
                match s {
                    $($name => Ok($t::$variant),)+
                    _ => Err(format!(concat!("unknown ", $what, " {:?}: use ", $names), s)),
                }
            }
        }
    };
}

pub mod cancel;
pub mod certify;
pub mod compare;
pub mod compress;
pub mod curve;
pub mod fit;
pub mod geometry;
pub mod interpolate;
pub(crate) mod linalg;

pub use compress::tolerance::{fit_to_tolerance, KnotRule, ToleranceFit, ToleranceOptions};
pub use curve::beta::SphericalBetaSpline;
pub use curve::bezier::SphericalBezier;
pub use curve::bspline::SphericalBSpline;
pub use curve::AnyCurve;
pub use curve::SphericalCurve;
pub use fit::knots::{KnotPlacement, Parameterization};
pub use fit::metrics::ErrorMetrics;
pub use fit::{
    fit, gls_pia, gls_pia_iteration, FitOptions, FitReport, IterationError, Solver, StepRule,
};
pub use geometry::point::PointSet;
pub use interpolate::beta::{interpolate, BetaInterpolation, BetaSolver, InterpolationOptions};

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

/// Why `values` (knots, parameters) cannot be used, if so: a value that is not finite, or one
/// smaller than the one before it (naming both). `name` is what one value is called ("knot").
pub(crate) fn finite_non_decreasing(values: &[f64], name: &str) -> Result<(), String> {
    if let Some(i) = values.iter().position(|u| !u.is_finite()) {
        return Err(format!("{name} {i} is not a finite number"));
    }
    if let Some(i) = (1..values.len()).find(|&i| values[i] < values[i - 1]) {
        return Err(format!(
            "{name} {i} ({}) is smaller than {name} {} ({}): {name}s must not decrease",
            values[i],
            i - 1,
            values[i - 1]
        ));
    }
    Ok(())
}

/// The input a [`SphereError`] is about ([`SphereError::site`]). Each front end words it its
/// own way: the documents as a JSON pointer (`document::pointer`), the service as a
/// pointer or a query parameter, the command line as a pointer or a flag.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum InputSite {
    /// A named option of the operation or field of a curve (`degree`, `knots`,
    /// `control_points`, `beta1`, `beta2`), and the value within it when it is a list.
    Field {
        /// The option's name, as the math core spells it.
        name: &'static str,
        /// The value within a list of them.
        index: Option<usize>,
    },
    /// The data parameters (one per point).
    Parameters,
    /// One input point (of a curve: one control point), and the coordinate within it.
    Point {
        /// The point.
        index: usize,
        /// The coordinate, when one coordinate is at fault.
        coord: Option<usize>,
    },
    /// The points as a whole: too few, all equal, or no curve found through them.
    Points,
    /// No input in particular: the work was cancelled.
    Nothing,
}

impl SphereError {
    /// The input this error is about: the one place that maps each variant to the value at
    /// fault.
    pub fn site(&self) -> InputSite {
        match *self {
            SphereError::DimensionTooSmall { index, .. }
            | SphereError::DimensionMismatch { index, .. }
            | SphereError::NotUnit { index, .. }
            | SphereError::Antipodal { index, .. }
            | SphereError::RepeatedPoint { index, .. } => InputSite::Point { index, coord: None },
            SphereError::NotFinite { index, coord } => InputSite::Point {
                index,
                coord: Some(coord),
            },
            SphereError::NotInterpolated { joint, .. }
            | SphereError::DegenerateArc { joint, .. } => InputSite::Point {
                index: joint,
                coord: None,
            },
            SphereError::InvalidDegree { .. } => InputSite::Field {
                name: "degree",
                index: None,
            },
            SphereError::InvalidKnots { .. } => InputSite::Field {
                name: "knots",
                index: None,
            },
            SphereError::InvalidControlPointCount { .. } => InputSite::Field {
                name: "control_points",
                index: None,
            },
            SphereError::InvalidShapeParameter { field, index, .. } => InputSite::Field {
                name: field,
                index: Some(index),
            },
            SphereError::ShapeParameterCount { field, .. } => InputSite::Field {
                name: field,
                index: None,
            },
            SphereError::InvalidParameters { .. } => InputSite::Parameters,
            SphereError::TooFewPoints { .. }
            | SphereError::AllPointsEqual { .. }
            | SphereError::NoValidFit
            | SphereError::NonFinite { .. } => InputSite::Points,
            SphereError::Cancelled => InputSite::Nothing,
        }
    }
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
