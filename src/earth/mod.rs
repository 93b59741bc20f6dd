//! S^2 as the Earth: lon/lat <-> unit vectors, metres, the antimeridian, and GeoJSON in and out.
//!
//! Built on [`crate::sphere`] (which knows nothing of degrees or metres); used by the HTTP
//! service and the command line alike, so both give the same output for the same options.
//!
//! * [`lonlat`]: degrees <-> unit vectors, radians <-> metres (mean radius 6,371,008.8 m).
//! * [`antimeridian`]: lon/lat output cut at ±180 degrees (RFC 7946 §3.1.9), poles.
//! * [`area`]: areas of polygons on the sphere (`area_m2`, `area_change` in reports).
//! * [`sampling`]: dense output of a curve (`samples`, `spacing_m`, or automatic).
//! * [`curve`]: one line or ring: positions parsed and checked, repeats dropped, fitted.
//! * [`check_fit_options`], [`check_tolerance`], [`Job::validate`]: the option checks that
//!   the service and the command line share; errors carry the data ([`Problem::CountOutOfRange`]
//!   names the limit) and each front end words them.
//! * [`features`]: GeoJSON documents walked feature by feature ([`process_feature`]).
//! * [`json_out`]: output JSON whose long number arrays are written straight from `f64`.
//! * [`time`]: tracks in time: times read from the properties or the 4th coordinate and
//!   checked, the map between times and the curve parameter, speed and heading.
//! * [`topology`]: the polygons of a document as one coverage (`topology=shared`): arcs between
//!   junctions, each fitted once, rings rebuilt from them; [`topojson`]: its TopoJSON output.
//!
//! # What happens to a GeoJSON document
//! * LineString and each part of a MultiLineString is fitted on its own; each Polygon and
//!   MultiPolygon ring is fitted as a closed curve (its end control points are pinned together,
//!   so the curve closes exactly at the ring's first vertex, with a possible corner there).
//!   Every other geometry (Point, MultiPoint, GeometryCollection, `null`) passes through
//!   unchanged, as do `properties`, `id`, foreign members and the order of features. A fitted
//!   feature gets `properties.fit` (overwriting one that is there) and loses a stale `bbox`.
//! * Positions are `[lon, lat]` or `[lon, lat, altitude]` (all of one kind per line). Longitude
//!   must be in [-180, 180] and latitude in [-90, 90]: values outside are rejected, never
//!   wrapped. The altitude is carried along the curve parameter: an output point at parameter t
//!   gets the altitude interpolated linearly between the input points around t.
//! * Repeated consecutive positions are dropped before fitting; their error (that of the kept
//!   copy) still counts in the metrics and in `input_points`. When fewer distinct positions
//!   remain than `degree + 1`, the degree is lowered to `distinct - 1`; one distinct position
//!   is an error.
//! * With [`TimeOptions::fit_in_time`] (`parameterization=time`) a line is fitted as position
//!   against time: each position's parameter is its time mapped to [0, 1] (never moved), so its
//!   error is the synchronized distance; only records repeated exactly (same time, same
//!   position) are dropped, a line ending where it starts stays open, and the dense output
//!   carries its times where the input had them ([`time`]).
//! * Errors are parametric geodesic distances in metres (METHOD.md): the distance from each
//!   input point to the curve at that point's parameter, measured with the spline as returned
//!   (control points rounded to `precision`).
//!
//! # Reuse (the batch CLI)
//! [`process_feature`] handles one Feature at a time and is all a streaming reader needs:
//! ```
//! use spherefit::earth::{process_feature, Job};
//! let feature = serde_json::json!({
//!     "type": "Feature", "id": 7, "properties": {"name": "wave"},
//!     "geometry": {"type": "LineString", "coordinates":
//!         (0..50).map(|i| [i as f64 * 0.1, (i as f64 * 0.05).sin()]).collect::<Vec<_>>()}
//! });
//! let out = process_feature(&feature, "/features/0", &Job::fit(Default::default())).unwrap();
//! assert_eq!(out.stats.curves, 1);
//! // Written as it is (its long number arrays straight from f64), or taken as a Value:
//! let text = serde_json::to_string(&out.feature).unwrap();
//! let value = out.feature.into_value();
//! assert_eq!(text, value.to_string());
//! assert_eq!(value["id"], 7);
//! assert!(value["properties"]["fit"]["max_error_m"].as_f64().unwrap() < 5_000.0);
//! ```

pub mod antimeridian;
pub mod area;
pub mod curve;
pub mod features;
pub mod json_out;
pub mod lonlat;
pub mod sampling;
pub mod small_rings;
pub mod time;
pub mod topojson;
pub mod topology;

pub use features::{
    evaluate_spline_document, process_feature, process_geometry, Document, FeatureSlot,
    FeatureStats, ProcessedFeature, Source,
};
pub use json_out::JsonOut;
pub use lonlat::{lonlat_to_unit, m_to_rad, rad_to_m, unit_to_lonlat, LonLat, EARTH_RADIUS_M};
pub use sampling::Sampling;
pub use time::{TimeFormat, TimeMap, TimeSource};

use crate::sphere::cancel::Cancel;
use crate::sphere::{FitOptions, SphereError};

/// Highest `precision` (decimals of output degrees): 1e-15 degrees is below f64 resolution.
pub const MAX_PRECISION: u32 = 15;

/// Default output precision: 7 decimals of a degree is 1.1 cm or less.
pub const DEFAULT_PRECISION: u32 = 7;

/// Bounds on the work one curve may ask for. Checked before fitting.
#[derive(Clone, Debug, PartialEq)]
pub struct Limits {
    /// Most control points per curve.
    pub max_control_points: usize,
    /// Most output points per curve (`samples`, or what `spacing_m` or automatic sampling need).
    pub max_samples: usize,
    /// Most GLS-PIA iterations.
    pub max_iterations: usize,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_control_points: 10_000,
            max_samples: 100_000,
            max_iterations: 1_000,
        }
    }
}

/// Shape parameters of Beta-spline interpolation.
#[derive(Clone, Debug, PartialEq)]
pub struct InterpolateSettings {
    /// Bias (1 = none), at every vertex.
    pub beta1: f64,
    /// Tension (0 = none), at every vertex.
    pub beta2: f64,
}

impl Default for InterpolateSettings {
    fn default() -> Self {
        InterpolateSettings {
            beta1: 1.0,
            beta2: 0.0,
        }
    }
}

/// What to do with each curve.
#[derive(Clone, Debug, PartialEq)]
pub enum Operation {
    /// Fit a spherical B-spline (GLS-PIA) to each line and ring.
    Fit(FitOptions),
    /// Fit each line and ring to a tolerance in metres with
    /// [`crate::sphere::tolerance::fit_to_tolerance`]: every position within `tolerance_m` of
    /// the curve as returned (control points rounded), with as few stored numbers as the fitter
    /// finds. Of `options`, `degree` caps the degrees tried (1 to 3) and `parameterization`
    /// gives the starting parameters; `control_points`, `knots`, `iterations` and `solver` are
    /// not used.
    FitToTolerance {
        /// Degree cap and starting parameterisation.
        options: FitOptions,
        /// Largest allowed distance from a position to the curve, metres.
        tolerance_m: f64,
    },
    /// Interpolate every vertex with a spherical Beta-spline.
    Interpolate(InterpolateSettings),
    /// Sample the splines stored in `properties.fit` (or a bare lon/lat spline document).
    Evaluate,
}

/// How output lines are made.
#[derive(Clone, Debug, PartialEq)]
pub struct OutputOptions {
    /// Density of output lines.
    pub sampling: Sampling,
    /// Decimals of output degrees (control points included).
    pub precision: u32,
}

impl Default for OutputOptions {
    fn default() -> Self {
        OutputOptions {
            sampling: Sampling::Auto,
            precision: DEFAULT_PRECISION,
        }
    }
}

/// Fitting and evaluating tracks in time ([`time`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TimeOptions {
    /// `parameterization=time`: fit position as a function of time, reading the times from
    /// here (lines only). The bound of a `tolerance_m` fit is then the synchronized distance:
    /// every position within the tolerance of the curve at its own time.
    pub fit_in_time: Option<TimeSource>,
    /// `at=`: evaluate stored fits in time at these unix times (positions, speed, heading)
    /// instead of sampling them densely. Evaluation only.
    pub at_unix_s: Option<Vec<f64>>,
}

/// Everything [`process_feature`] needs: the operation, the output options, the limits and a
/// cancellation token (checked before each curve and inside the fitters).
#[derive(Clone, Debug, PartialEq)]
pub struct Job {
    /// What to do to each line.
    pub operation: Operation,
    /// How output lines are made.
    pub output: OutputOptions,
    /// Bounds checked before the work they bound.
    pub limits: Limits,
    /// Stops the work ([`Problem::Fit`] with [`SphereError::Cancelled`]) when cancelled or past
    /// its deadline; the default inherits the token entered on the calling thread.
    pub cancel: Cancel,
    /// Fits in time and evaluation at times.
    pub time: TimeOptions,
}

impl Operation {
    /// The fit options of a fit (with or without a tolerance).
    pub fn fit_options(&self) -> Option<&FitOptions> {
        match self {
            Operation::Fit(o) | Operation::FitToTolerance { options: o, .. } => Some(o),
            _ => None,
        }
    }
}

impl Job {
    /// A fit with default output options and limits.
    pub fn fit(options: FitOptions) -> Job {
        Job {
            operation: Operation::Fit(options),
            output: OutputOptions::default(),
            limits: Limits::default(),
            cancel: Cancel::inherit(),
            time: TimeOptions::default(),
        }
    }

    /// An evaluation with default output options and limits.
    pub fn evaluate() -> Job {
        Job {
            operation: Operation::Evaluate,
            output: OutputOptions::default(),
            limits: Limits::default(),
            cancel: Cancel::inherit(),
            time: TimeOptions::default(),
        }
    }

    /// An interpolation with default output options and limits.
    pub fn interpolate(settings: InterpolateSettings) -> Job {
        Job {
            operation: Operation::Interpolate(settings),
            output: OutputOptions::default(),
            limits: Limits::default(),
            cancel: Cancel::inherit(),
            time: TimeOptions::default(),
        }
    }

    /// Sets the sampling.
    pub fn with_sampling(mut self, s: Sampling) -> Job {
        self.output.sampling = s;
        self
    }

    /// Sets the precision.
    pub fn with_precision(mut self, decimals: u32) -> Job {
        self.output.precision = decimals;
        self
    }

    /// Sets the limits.
    pub fn with_limits(mut self, limits: Limits) -> Job {
        self.limits = limits;
        self
    }

    /// Fits position as a function of time, with times from `source` (`parameterization=time`).
    pub fn in_time(mut self, source: TimeSource) -> Job {
        self.time.fit_in_time = Some(source);
        self
    }

    /// Evaluates at these unix times (`at=`).
    pub fn at_times(mut self, unix_s: Vec<f64>) -> Job {
        self.time.at_unix_s = Some(unix_s);
        self
    }

    /// Sets the cancellation token.
    pub fn with_cancel(mut self, cancel: Cancel) -> Job {
        self.cancel = cancel;
        self
    }

    /// Checks the options against their ranges and the limits, once, before any work.
    ///
    /// # Errors
    /// [`Problem::InvalidOption`] naming the option (`degree`, `control_points`, ...).
    pub fn validate(&self) -> Result<(), EarthError> {
        let bad = |option: &'static str, message: String| {
            Err(EarthError::new(
                "",
                Problem::InvalidOption { option, message },
            ))
        };
        if self.output.precision > MAX_PRECISION {
            return bad(
                "precision",
                format!(
                    "{} decimals: use 0 to {MAX_PRECISION}",
                    self.output.precision
                ),
            );
        }
        match self.output.sampling {
            Sampling::Auto => {}
            Sampling::Samples(n) => {
                check_count("samples", n, 2, self.limits.max_samples)?;
            }
            Sampling::SpacingM(s) | Sampling::SpacingAndSamples { spacing_m: s, .. } => {
                if let Sampling::SpacingAndSamples { samples: n, .. } = self.output.sampling {
                    check_count("samples", n, 2, self.limits.max_samples)?;
                }
                if !(s.is_finite() && s > 0.0) {
                    return bad(
                        "spacing_m",
                        format!("{s}: the spacing must be a positive number of metres"),
                    );
                }
            }
            Sampling::SpacingS(s) => {
                if !(s.is_finite() && s > 0.0) {
                    return bad(
                        "spacing_s",
                        format!("{s}: the spacing must be a positive number of seconds"),
                    );
                }
                let in_time = match &self.operation {
                    Operation::Evaluate => true,
                    Operation::Fit(_) | Operation::FitToTolerance { .. } => {
                        self.time.fit_in_time.is_some()
                    }
                    Operation::Interpolate(_) => false,
                };
                if !in_time {
                    return bad(
                        "spacing_s",
                        "spacing in seconds needs a curve in time: fit with parameterization time"
                            .into(),
                    );
                }
            }
        }
        if let Some(TimeSource::Property(name)) = &self.time.fit_in_time {
            if name.is_empty() {
                return bad("time_property", "the property name is empty".into());
            }
        }
        if self.time.fit_in_time.is_some() && self.operation.fit_options().is_none() {
            return bad(
                "parameterization",
                "only a fit can be in time (parameterization time)".into(),
            );
        }
        if let Some(at) = &self.time.at_unix_s {
            if !matches!(self.operation, Operation::Evaluate) {
                return bad("at", "times to evaluate at are for evaluation only".into());
            }
            check_count("at", at.len(), 1, self.limits.max_samples)?;
            if let Some(t) = at.iter().find(|t| !t.is_finite()) {
                return bad("at", format!("{t} is not a finite time"));
            }
            if self.output.sampling != Sampling::Auto {
                return bad(
                    "at",
                    "at gives the output positions itself: leave out samples, spacing_m and spacing_s"
                        .into(),
                );
            }
        }
        match &self.operation {
            Operation::Fit(o) => {
                check_fit_options(o, &self.limits)?;
                if o.knot_vector.is_some() {
                    return bad(
                        "knots",
                        "explicit knot vectors are not supported for GeoJSON".into(),
                    );
                }
            }
            Operation::FitToTolerance {
                options: o,
                tolerance_m,
            } => {
                check_degree(o.degree)?;
                check_tolerance("tolerance_m", *tolerance_m)?;
                if o.control_points.is_some() {
                    return bad(
                        "tolerance_m",
                        "a tolerance fit chooses its own control points: leave control_points out"
                            .into(),
                    );
                }
            }
            Operation::Interpolate(s) => {
                let (lo, hi) = crate::sphere::beta::BETA1_RANGE;
                if !(s.beta1.is_finite() && s.beta1 >= lo && s.beta1 <= hi) {
                    return bad(
                        "beta1",
                        format!("{}: beta1 must be a number from {lo:e} to {hi:e}", s.beta1),
                    );
                }
                if !(s.beta2.is_finite() && s.beta2 >= 0.0) {
                    return bad("beta2", format!("{}: beta2 must be a number >= 0", s.beta2));
                }
            }
            Operation::Evaluate => {}
        }
        Ok(())
    }
}

/// Checks fit options against their ranges and `limits`, before any data is read: the degree,
/// the number of control points (degree + 1 to the limit), the iterations (up to the limit)
/// and the target error. Shared by every front end that fits, on the Earth or on S^n.
///
/// # Errors
/// [`Problem::InvalidOption`] or [`Problem::CountOutOfRange`] naming the option.
pub fn check_fit_options(o: &FitOptions, limits: &Limits) -> Result<(), EarthError> {
    check_degree(o.degree)?;
    if let Some(n) = o.control_points {
        check_count("control_points", n, o.degree + 1, limits.max_control_points)?;
    }
    check_count("iterations", o.iterations, 0, limits.max_iterations)?;
    check_target_max_error_rad(o.target_max_error_rad)
}

/// The spline degree: 1 to [`crate::sphere::bspline::MAX_DEGREE`].
///
/// # Errors
/// [`Problem::InvalidOption`] naming `degree`.
pub fn check_degree(degree: usize) -> Result<(), EarthError> {
    let max_degree = crate::sphere::bspline::MAX_DEGREE;
    if degree == 0 || degree > max_degree {
        return Err(invalid_option(
            "degree",
            format!("degree {degree}: use 1 to {max_degree}"),
        ));
    }
    Ok(())
}

/// The target maximum error of a fit, if given: a number of radians >= 0.
///
/// # Errors
/// [`Problem::InvalidOption`] naming `target_max_error_rad`.
pub fn check_target_max_error_rad(target: Option<f64>) -> Result<(), EarthError> {
    match target {
        Some(t) if !(t.is_finite() && t >= 0.0) => Err(invalid_option(
            "target_max_error_rad",
            format!("{t}: the target must be a number of radians >= 0"),
        )),
        _ => Ok(()),
    }
}

/// A tolerance: a positive, finite number, of metres (`tolerance_m`) or radians
/// (`tolerance_rad`, the S^n fit).
///
/// # Errors
/// [`Problem::InvalidOption`] naming the option.
pub fn check_tolerance(option: &'static str, tolerance: f64) -> Result<(), EarthError> {
    if tolerance.is_finite() && tolerance > 0.0 {
        return Ok(());
    }
    let unit = if option == "tolerance_m" {
        "metres"
    } else {
        "radians"
    };
    Err(invalid_option(
        option,
        format!("{tolerance}: the tolerance must be a positive number of {unit}"),
    ))
}

/// A count option in `min..=max`, `max` the limit that bounds it.
fn check_count(
    option: &'static str,
    value: usize,
    min: usize,
    max: usize,
) -> Result<(), EarthError> {
    if value < min || value > max {
        return Err(EarthError::new(
            "",
            Problem::CountOutOfRange {
                option,
                value,
                min,
                max,
            },
        ));
    }
    Ok(())
}

fn invalid_option(option: &'static str, message: String) -> EarthError {
    EarthError::new("", Problem::InvalidOption { option, message })
}

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
    /// where `max` is the limit of [`Limits`] that bounds it. The message does not say whose
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
    /// The math core refused the input for a reason not listed above.
    #[error("{0}")]
    Fit(SphereError),
    /// Beta-spline interpolation could not pass through every position.
    #[error("{0}")]
    Interpolation(SphereError),
}

/// Parses `-?digits(.digits)?([eE][+-]?digits)?` (also `.5` and `5.`), a number as JSON
/// writes it; anything else (`inf`, `NaN`, `+1`, spaces) is `None`.
pub fn parse_json_number(s: &str) -> Option<f64> {
    let b = s.as_bytes();
    let mut i = 0;
    if b.first() == Some(&b'-') {
        i += 1;
    }
    let int_start = i;
    while i < b.len() && b[i].is_ascii_digit() {
        i += 1;
    }
    let mut digits = i - int_start;
    if i < b.len() && b[i] == b'.' {
        i += 1;
        let frac_start = i;
        while i < b.len() && b[i].is_ascii_digit() {
            i += 1;
        }
        digits += i - frac_start;
    }
    if digits == 0 {
        return None;
    }
    if i < b.len() && (b[i] == b'e' || b[i] == b'E') {
        i += 1;
        if i < b.len() && (b[i] == b'+' || b[i] == b'-') {
            i += 1;
        }
        let exp_start = i;
        while i < b.len() && b[i].is_ascii_digit() {
            i += 1;
        }
        if i == exp_start {
            return None;
        }
    }
    if i != b.len() {
        return None;
    }
    s.parse().ok()
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

impl Problem {
    /// The option at fault and what is wrong with it (without the option's name), for an
    /// [`Problem::InvalidOption`] or a [`Problem::CountOutOfRange`]; each front end names the
    /// option its own way (a query parameter, a flag) and says whose limit a count passed.
    pub fn option_message(&self) -> Option<(&'static str, String)> {
        match self {
            Problem::InvalidOption { option, message } => Some((option, message.clone())),
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
            Problem::InvalidSpline(_) => "invalid-spline",
            Problem::InvalidTime(_) => "invalid-time",
            Problem::Fit(SphereError::Cancelled) => "cancelled",
            Problem::Fit(SphereError::NonFinite { .. }) => "non-finite",
            Problem::Fit(_) => "unfittable",
            Problem::Interpolation(_) => "not-interpolable",
        }
    }
}
