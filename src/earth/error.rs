//! What can be wrong with a GeoJSON input or the options for it: [`EarthError`] (a JSON
//! pointer and a [`Problem`]), with a stable slug per kind ([`Problem::slug`]) that the service's
//! problem types and the Python exception's `problem` use.

use crate::sphere::fit::options_check::FitOptionError;
use crate::sphere::SphereError;

/// A GeoJSON input that cannot be processed: a JSON pointer to the offending value
/// (`/features/3/geometry/coordinates/17`) and what is wrong with it.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{}: {problem}", if pointer.is_empty() { "(document)" } else { pointer.as_str() })]
pub struct EarthError {
    /// RFC 6901 pointer into the input document ("" for the whole document or an option).
    pub pointer: String,
    /// What is wrong there.
    pub problem: Problem,
}

/// An S^n fit's option error ([`crate::sphere::fit::options_check`]) as the options' problems
/// are written: with an empty pointer, naming the option.
impl From<FitOptionError> for EarthError {
    fn from(e: FitOptionError) -> EarthError {
        let problem = match e {
            FitOptionError::Invalid { option, message } => {
                Problem::InvalidOption { option, message }
            }
            FitOptionError::Conflicting {
                option,
                other,
                reason,
            } => Problem::ConflictingOptions {
                option,
                other: other.into(),
                reason: reason.into(),
            },
        };
        EarthError::new("", problem)
    }
}

impl EarthError {
    /// An error at `pointer`.
    pub fn new(pointer: impl Into<String>, problem: Problem) -> EarthError {
        EarthError {
            pointer: pointer.into(),
            problem,
        }
    }
}

/// What can be wrong with a GeoJSON input or the options for it. [`Problem::slug`] names each
/// kind in a stable, machine-readable way.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Problem {
    /// Not the GeoJSON structure expected (missing or unknown `type`, coordinates not arrays).
    #[error("{0}")]
    InvalidGeoJson(String),
    /// A position that is not 2 or 3 numbers, or whose numbers are not in range.
    #[error("{0}")]
    InvalidCoordinate(String),
    /// A Polygon ring whose last position differs from its first, or with under 4 positions.
    #[error("{0}")]
    InvalidRing(String),
    /// A compact curve (`carry=spline`) that does not decode: a wrong version, a count larger
    /// than its bytes, a varint that overflows, knots that decrease. Its own variant because
    /// such input is corrupt rather than merely unfit: the command line ends with exit status
    /// 2 for it (after writing every other feature).
    #[error("{0}")]
    CorruptCompactCurve(String),
    /// Fewer distinct positions than a curve needs.
    #[error(
        "{distinct} distinct position(s) after dropping repeats: a curve needs at least {need}"
    )]
    TooFewPoints {
        /// Distinct positions in the line.
        distinct: usize,
        /// Positions the curve needs.
        need: usize,
    },
    /// Two consecutive positions are (nearly) antipodal: the great circle between them is
    /// undefined.
    #[error("this position and the previous one are (nearly) antipodal ({angle_deg} degrees apart): the great circle between them is undefined; add a position in between")]
    Antipodal {
        /// Their distance, degrees of arc.
        angle_deg: f64,
    },
    /// More control points than distinct positions.
    #[error("{control_points} control points for a line with {distinct} distinct position(s): use at most as many control points as positions")]
    TooManyControlPoints {
        /// Control points asked for.
        control_points: usize,
        /// Distinct positions in the line.
        distinct: usize,
    },
    /// Output denser than the limit.
    #[error("{} output points needed, more than the limit of {max} per line: use a larger spacing_m or fewer samples", count_text(*needed))]
    TooManySamples {
        /// Output points the sampling asks for.
        needed: usize,
        /// The limit per line.
        max: usize,
    },
    /// A count option (`samples`, `at`, `control_points`, `iterations`) outside `min..=max`,
    /// where `max` is the limit of [`Limits`](super::Limits) that bounds it. The message does not say whose
    /// limit it is: the service and the command line add that.
    #[error("{option}: {}", count_out_of_range_text(option, *value, *min, *max))]
    CountOutOfRange {
        /// The option's name.
        option: &'static str,
        /// The count asked for.
        value: usize,
        /// The least that works.
        min: usize,
        /// The limit.
        max: usize,
    },
    /// An option that works only with another one, which is missing.
    #[error("{option}: {reason}: give {requires} too")]
    RequiresOption {
        /// The option given.
        option: &'static str,
        /// The option it needs.
        requires: &'static str,
        /// Why it needs it.
        reason: &'static str,
    },
    /// Two options given together that exclude each other (each is valid alone):
    /// `tolerance_m` and `control_points`, `spacing_s` and `samples`, ...
    #[error("{option}: {option} excludes {other}: {reason}")]
    ConflictingOptions {
        /// The option reported (the one that excludes the other).
        option: &'static str,
        /// The option it excludes (with its value where that matters: `parameterization=chord`).
        other: String,
        /// Why.
        reason: String,
    },
    /// An option out of range or not allowed.
    #[error("{option}: {message}")]
    InvalidOption {
        /// The option's name.
        option: &'static str,
        /// Why it is not allowed.
        message: String,
    },
    /// Times of a track that cannot be used: missing, not one per position, not RFC 3339 or
    /// unix seconds, or not increasing.
    #[error("{0}")]
    InvalidTime(String),
    /// A spline document (for `evaluate`) that does not describe a valid spline.
    #[error("{0}")]
    InvalidSpline(String),
    /// An interpolating curve whose control points, rounded to the output precision, no
    /// longer make a valid curve.
    #[error("rounding the curve: {0}")]
    RoundedCurve(#[source] crate::document::InputError),
    /// The math core refused the input for a reason not listed above.
    #[error("{0}")]
    Fit(#[source] SphereError),
    /// Beta-spline interpolation could not pass through every position.
    #[error("{0}")]
    Interpolation(#[source] SphereError),
}

/// `2 control points: use degree + 1 = 4 to 10000`, `0 samples: use 2 to 100000 per line`.
fn count_out_of_range_text(option: &str, value: usize, min: usize, max: usize) -> String {
    match option {
        "samples" => format!("{value} samples: use {min} to {max} per line"),
        "at" => format!("{value} times: give {min} to {max}"),
        "control_points" => {
            format!("{value} control points: use degree + 1 = {min} to {max}")
        }
        _ => format!("{value} {}: use {min} to {max}", option.replace('_', " ")),
    }
}

/// A count for a message: "more than 10^18" for counts that saturated.
fn count_text(n: usize) -> String {
    if n as u128 >= 1_000_000_000_000_000_000 {
        "more than 10^18".into()
    } else {
        n.to_string()
    }
}

/// The human title of a [`Problem::slug`] (problem+json `title`); "Cannot fit" for others.
pub fn title_of(slug: &str) -> &'static str {
    match slug {
        "invalid-geojson" => "Invalid GeoJSON",
        "invalid-coordinate" => "Invalid coordinate",
        "invalid-ring" => "Invalid polygon ring",
        "too-few-points" => "Too few points",
        "antipodal-points" => "Antipodal neighbours",
        "too-many-control-points" => "More control points than points",
        "too-many-samples" => "Too many output points",
        "invalid-option" => "Invalid option",
        "conflicting-options" => "Conflicting options",
        "invalid-spline" => "Invalid spline document",
        "non-finite" => "Result not finite",
        "not-interpolable" => "Cannot interpolate",
        _ => "Cannot fit",
    }
}

impl Problem {
    /// The option at fault and what is wrong with it (without the option's name), for an
    /// [`Problem::InvalidOption`] or a [`Problem::CountOutOfRange`]; each front end names the
    /// option its own way (a query parameter, a flag) and says whose limit a count passed.
    pub fn option_message(&self) -> Option<(&'static str, String)> {
        self.option_message_named(&|name: &str| name.to_string())
    }

    /// [`Problem::option_message`] with the other options a message names (the one excluded,
    /// the one required) written by `name`: `--control-points` on the command line.
    pub fn option_message_named(
        &self,
        name: &dyn Fn(&str) -> String,
    ) -> Option<(&'static str, String)> {
        match self {
            Problem::InvalidOption { option, message } => Some((option, message.clone())),
            Problem::ConflictingOptions {
                option,
                other,
                reason,
            } => {
                // `parameterization=chord`: the name is before the `=`.
                let other = match other.split_once('=') {
                    Some((n, v)) => format!("{} {v}", name(n)),
                    None => name(other),
                };
                Some((
                    option,
                    format!("{} excludes {other}: {reason}", name(option)),
                ))
            }
            Problem::RequiresOption {
                option,
                requires,
                reason,
            } => Some((option, format!("{reason}: give {} too", name(requires)))),
            Problem::CountOutOfRange {
                option,
                value,
                min,
                max,
            } => Some((option, count_out_of_range_text(option, *value, *min, *max))),
            _ => None,
        }
    }

    /// A stable, machine-readable name for the kind of problem (used in problem+json `type`).
    pub fn slug(&self) -> &'static str {
        match self {
            Problem::InvalidGeoJson(_) => "invalid-geojson",
            Problem::InvalidCoordinate(_) => "invalid-coordinate",
            Problem::InvalidRing(_) => "invalid-ring",
            Problem::TooFewPoints { .. } => "too-few-points",
            Problem::Antipodal { .. } => "antipodal-points",
            Problem::TooManyControlPoints { .. } => "too-many-control-points",
            Problem::TooManySamples { .. } => "too-many-samples",
            Problem::InvalidOption { .. }
            | Problem::CountOutOfRange { .. }
            | Problem::RequiresOption { .. } => "invalid-option",
            Problem::ConflictingOptions { .. } => "conflicting-options",
            Problem::InvalidSpline(_)
            | Problem::RoundedCurve(_)
            | Problem::CorruptCompactCurve(_) => "invalid-spline",
            Problem::InvalidTime(_) => "invalid-time",
            Problem::Fit(SphereError::Cancelled) => "cancelled",
            Problem::Fit(SphereError::NonFinite { .. }) => "non-finite",
            Problem::Fit(_) => "unfittable",
            Problem::Interpolation(_) => "not-interpolable",
        }
    }
}
