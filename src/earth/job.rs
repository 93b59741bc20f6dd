//! The options of a GeoJSON operation, from what the user gave ([`RawOptions`]) to a checked
//! [`Job`] ([`into_job`]): every rule about options (ranges, limits, options that exclude or
//! imply each other, topology and output format) is written here once, and every front end (the
//! service's query, the command line's flags, Python's keywords) only fills a [`RawOptions`].

use super::error::{EarthError, Problem};
use super::sampling::Sampling;
use super::time::TimeSource;
use crate::sphere::cancel::Cancel;
use crate::sphere::{FitOptions, KnotPlacement, Parameterization, Solver};
use std::str::FromStr;

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
    /// [`crate::sphere::compress::tolerance::fit_to_tolerance`]: every position within `tolerance_m` of
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

/// Fitting and evaluating tracks in time ([`time`](super::time)).
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

/// Everything [`process_feature`](super::process_feature) needs: the operation, the output options, the limits and a
/// cancellation token (checked before each curve and inside the fitters).
#[derive(Clone, Debug, PartialEq)]
pub struct Job {
    /// What to do to each line.
    pub operation: Operation,
    /// How output lines are made.
    pub output: OutputOptions,
    /// Bounds checked before the work they bound.
    pub limits: Limits,
    /// Stops the work ([`Problem::Fit`] with [`SphereError::Cancelled`](crate::sphere::SphereError::Cancelled)) when cancelled or past
    /// its deadline; the default inherits the token entered on the calling thread.
    pub cancel: Cancel,
    /// Fits in time and evaluation at times.
    pub time: TimeOptions,
    /// Every feature on its own, or the polygons as one coverage (`topology=shared`).
    pub topology: Topology,
    /// The document written: GeoJSON, or TopoJSON (shared topology only).
    pub format: OutputFormat,
    /// `drop_small_rings`: a ring that collapses under the fit is dropped and listed in
    /// `properties.fit.dropped_rings`, instead of kept as a small valid ring
    /// ([`super::small_rings`]).
    pub drop_small_rings: bool,
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
            topology: Topology::PerFeature,
            format: OutputFormat::GeoJson,
            drop_small_rings: false,
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
            topology: Topology::PerFeature,
            format: OutputFormat::GeoJson,
            drop_small_rings: false,
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
            topology: Topology::PerFeature,
            format: OutputFormat::GeoJson,
            drop_small_rings: false,
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

    /// Sets the topology (and, for a coverage, the output format).
    pub fn with_topology(mut self, topology: Topology, format: OutputFormat) -> Job {
        self.topology = topology;
        self.format = format;
        self
    }

    /// Drops rings that collapse instead of keeping them (`drop_small_rings`).
    pub fn dropping_small_rings(mut self, drop: bool) -> Job {
        self.drop_small_rings = drop;
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
                let (lo, hi) = crate::sphere::interpolate::beta::BETA1_RANGE;
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
        if self.topology == Topology::Shared {
            if !matches!(self.operation, Operation::FitToTolerance { .. }) {
                return Err(EarthError::new(
                    "",
                    Problem::RequiresOption {
                        option: "topology",
                        requires: "tolerance_m",
                        reason: "shared topology fits every border to a tolerance",
                    },
                ));
            }
            if self.time.fit_in_time.is_some() {
                return bad(
                    "topology",
                    "shared topology fits polygon rings, which carry no times: drop parameterization time, time_property and spacing_s".into(),
                );
            }
        }
        if self.format == OutputFormat::TopoJson && self.topology != Topology::Shared {
            return bad(
                "format",
                "TopoJSON output is made of shared arcs: give topology shared too".into(),
            );
        }
        if self.drop_small_rings && self.operation.fit_options().is_none() {
            return bad(
                "drop_small_rings",
                "only a fit drops rings (fitted rings that collapse)".into(),
            );
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

/// The spline degree: 1 to [`crate::sphere::curve::bspline::MAX_DEGREE`].
///
/// # Errors
/// [`Problem::InvalidOption`] naming `degree`.
pub fn check_degree(degree: usize) -> Result<(), EarthError> {
    let max_degree = crate::sphere::curve::bspline::MAX_DEGREE;
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

/// How the features of a document relate when fitted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Topology {
    /// Every line and ring on its own (the default).
    #[default]
    PerFeature,
    /// Polygon rings share their common borders: each fitted once (this module).
    Shared,
}

impl FromStr for Topology {
    type Err = ();
    fn from_str(s: &str) -> Result<Self, ()> {
        match s {
            "per-feature" => Ok(Topology::PerFeature),
            "shared" => Ok(Topology::Shared),
            _ => Err(()),
        }
    }
}

/// The document written.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum OutputFormat {
    /// A GeoJSON FeatureCollection (the default).
    #[default]
    GeoJson,
    /// A TopoJSON topology ([`super::topojson`]); only with [`Topology::Shared`].
    TopoJson,
}

impl FromStr for OutputFormat {
    type Err = ();
    fn from_str(s: &str) -> Result<Self, ()> {
        match s {
            "geojson" => Ok(OutputFormat::GeoJson),
            "topojson" => Ok(OutputFormat::TopoJson),
            _ => Err(()),
        }
    }
}

/// The operations a [`RawOptions`] is assembled for, each with the options it takes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OperationKind {
    /// `POST /v1/fit`, `spherefit fit`, `spherefit.fit`.
    Fit,
    /// `POST /v1/interpolate`, `spherefit interpolate`, `spherefit.interpolate`.
    Interpolate,
    /// `POST /v1/evaluate`, `spherefit evaluate`, `spherefit.evaluate`.
    Evaluate,
}

impl OperationKind {
    /// The names of the options this operation takes (query parameters, Python keywords; the
    /// command line's flags are these with `-` for `_`).
    pub fn option_names(self) -> &'static [&'static str] {
        match self {
            OperationKind::Fit => &[
                "control_points",
                "degree",
                "knots",
                "iterations",
                "parameterization",
                "solver",
                "parameter_correction",
                "tolerance_m",
                "time_property",
                "samples",
                "spacing_m",
                "spacing_s",
                "precision",
                "topology",
                "format",
                "drop_small_rings",
            ],
            OperationKind::Interpolate => &["beta1", "beta2", "samples", "spacing_m", "precision"],
            OperationKind::Evaluate => &["samples", "spacing_m", "spacing_s", "at", "precision"],
        }
    }

    /// `fit`, `interpolate` or `evaluate`.
    pub fn name(self) -> &'static str {
        match self {
            OperationKind::Fit => "fit",
            OperationKind::Interpolate => "interpolate",
            OperationKind::Evaluate => "evaluate",
        }
    }
}

/// `parameterization`: one of the math core's, or `time` (position as a function of time).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParameterizationOption {
    /// Position as a function of time ([`TimeOptions::fit_in_time`]).
    Time,
    /// Chord, centripetal or uniform.
    Shape(Parameterization),
}

impl FromStr for ParameterizationOption {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        if s == "time" {
            return Ok(ParameterizationOption::Time);
        }
        s.parse::<Parameterization>()
            .map(ParameterizationOption::Shape)
            .map_err(|_| format!("{s:?}: use chord, centripetal, uniform or time"))
    }
}

impl ParameterizationOption {
    fn name(self) -> &'static str {
        match self {
            ParameterizationOption::Time => "time",
            ParameterizationOption::Shape(Parameterization::Chord) => "chord",
            ParameterizationOption::Shape(Parameterization::Centripetal) => "centripetal",
            ParameterizationOption::Shape(Parameterization::Uniform) => "uniform",
        }
    }
}

/// The options of a GeoJSON operation as the user gave them: each `None` when not given. The
/// service fills it from the query ([`RawOptions::set`]), the command line from its flags,
/// Python from its keywords; [`into_job`] checks it and makes the [`Job`].
///
/// Adding an option: a field here, a line in [`RawOptions::set`] and
/// [`RawOptions::given`], its name in [`OperationKind::option_names`], and its rule in
/// [`into_job`] (README, "Adding an option", lists the other files).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RawOptions {
    /// Control points per curve.
    pub control_points: Option<usize>,
    /// Spline degree.
    pub degree: Option<usize>,
    /// Knot placement.
    pub knots: Option<KnotPlacement>,
    /// Most solver iterations.
    pub iterations: Option<usize>,
    /// Data parameters, or time.
    pub parameterization: Option<ParameterizationOption>,
    /// The optimiser.
    pub solver: Option<Solver>,
    /// Foot-point parameter correction between solver steps.
    pub parameter_correction: Option<bool>,
    /// Fit to this tolerance, metres.
    pub tolerance_m: Option<f64>,
    /// The property holding a track's times (implies `parameterization=time`).
    pub time_property: Option<String>,
    /// Drop rings that collapse instead of keeping them.
    pub drop_small_rings: Option<bool>,
    /// Per feature or a shared coverage.
    pub topology: Option<Topology>,
    /// GeoJSON or TopoJSON output.
    pub format: Option<OutputFormat>,
    /// Beta-spline bias.
    pub beta1: Option<f64>,
    /// Beta-spline tension.
    pub beta2: Option<f64>,
    /// Output points per curve.
    pub samples: Option<usize>,
    /// Distance between output points, metres.
    pub spacing_m: Option<f64>,
    /// Time between output points, seconds (a curve in time).
    pub spacing_s: Option<f64>,
    /// Decimals of output degrees.
    pub precision: Option<usize>,
    /// Times to evaluate at: RFC 3339 times or unix seconds, comma-separated.
    pub at: Option<String>,
}

/// A value that does not parse as its option's type (the service's 400 `invalid-query`).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{option}={value:?} is not {expected}")]
pub struct ParseError {
    /// The option's name.
    pub option: String,
    /// The value given.
    pub value: String,
    /// What it should be.
    pub expected: &'static str,
}

const INTEGER: &str = "a non-negative integer";
const NUMBER: &str = "a number";

impl RawOptions {
    /// Sets the option `name` from its text (a query parameter's value): integers in plain
    /// decimal digits, numbers as JSON writes them ([`parse_json_number`]), `true`/`false`,
    /// names of the enumerations. Whether the value is in range is [`into_job`]'s business.
    ///
    /// # Errors
    /// [`ParseError`] when `value` does not parse, or `name` is no option.
    pub fn set(&mut self, name: &str, value: &str) -> Result<(), ParseError> {
        let fail = |expected: &'static str| ParseError {
            option: name.to_string(),
            value: value.to_string(),
            expected,
        };
        let int = || -> Result<usize, ParseError> {
            if value.is_empty() || !value.bytes().all(|b| b.is_ascii_digit()) {
                return Err(fail(INTEGER));
            }
            value
                .parse()
                .map_err(|_| fail("a count this size (too large)"))
        };
        let num = || parse_json_number(value).ok_or_else(|| fail(NUMBER));
        let parse = |expected: &'static str| fail(expected);
        match name {
            "control_points" => self.control_points = Some(int()?),
            "degree" => self.degree = Some(int()?),
            "iterations" => self.iterations = Some(int()?),
            "samples" => self.samples = Some(int()?),
            "precision" => self.precision = Some(int()?),
            "tolerance_m" => self.tolerance_m = Some(num()?),
            "spacing_m" => self.spacing_m = Some(num()?),
            "spacing_s" => self.spacing_s = Some(num()?),
            "beta1" => self.beta1 = Some(num()?),
            "beta2" => self.beta2 = Some(num()?),
            "knots" => {
                self.knots = Some(match value.parse() {
                    Ok(k) => k,
                    Err(_) => return Err(parse("adaptive, geodesic, euclidean or uniform")),
                })
            }
            "parameterization" => {
                self.parameterization = Some(match value.parse() {
                    Ok(p) => p,
                    Err(_) => return Err(parse("chord, centripetal, uniform or (GeoJSON) time")),
                })
            }
            "solver" => {
                self.solver = Some(match value.parse() {
                    Ok(s) => s,
                    Err(_) => return Err(parse("gls-pia or gauss-newton")),
                })
            }
            "parameter_correction" => self.parameter_correction = Some(boolean(value, &fail)?),
            "drop_small_rings" => self.drop_small_rings = Some(boolean(value, &fail)?),
            "topology" => {
                self.topology = Some(match value.parse() {
                    Ok(t) => t,
                    Err(_) => return Err(parse("per-feature or shared")),
                })
            }
            "format" => {
                self.format = Some(match value.parse() {
                    Ok(f) => f,
                    Err(_) => return Err(parse("geojson or topojson")),
                })
            }
            "time_property" => self.time_property = Some(value.to_string()),
            "at" => self.at = Some(value.to_string()),
            _ => return Err(fail("an option of spherefit")),
        }
        Ok(())
    }

    /// The names of the options given.
    pub fn given(&self) -> Vec<&'static str> {
        let RawOptions {
            control_points,
            degree,
            knots,
            iterations,
            parameterization,
            solver,
            parameter_correction,
            tolerance_m,
            time_property,
            drop_small_rings,
            topology,
            format,
            beta1,
            beta2,
            samples,
            spacing_m,
            spacing_s,
            precision,
            at,
        } = self;
        [
            ("control_points", control_points.is_some()),
            ("degree", degree.is_some()),
            ("knots", knots.is_some()),
            ("iterations", iterations.is_some()),
            ("parameterization", parameterization.is_some()),
            ("solver", solver.is_some()),
            ("parameter_correction", parameter_correction.is_some()),
            ("tolerance_m", tolerance_m.is_some()),
            ("time_property", time_property.is_some()),
            ("drop_small_rings", drop_small_rings.is_some()),
            ("topology", topology.is_some()),
            ("format", format.is_some()),
            ("beta1", beta1.is_some()),
            ("beta2", beta2.is_some()),
            ("samples", samples.is_some()),
            ("spacing_m", spacing_m.is_some()),
            ("spacing_s", spacing_s.is_some()),
            ("precision", precision.is_some()),
            ("at", at.is_some()),
        ]
        .into_iter()
        .filter_map(|(name, given)| given.then_some(name))
        .collect()
    }
}

fn boolean(value: &str, fail: &dyn Fn(&'static str) -> ParseError) -> Result<bool, ParseError> {
    match value {
        "true" => Ok(true),
        "false" => Ok(false),
        _ => Err(fail("true or false")),
    }
}

fn conflict(option: &'static str, other: impl Into<String>, reason: &str) -> EarthError {
    EarthError::new(
        "",
        Problem::ConflictingOptions {
            option,
            other: other.into(),
            reason: reason.into(),
        },
    )
}

/// Checks `raw` for `kind` once and makes its [`Job`] (with `limits`, and a cancellation
/// token that inherits the caller's): every rule about options is here or in
/// [`Job::validate`], which this calls.
///
/// * An option `kind` does not take is refused.
/// * `parameterization=time`, or `time_property` (or on a fit `spacing_s`), which imply it,
///   make a fit in time; either of those with another parameterization conflicts.
/// * `spacing_s` excludes `samples` and `spacing_m`; `samples` and `spacing_m` together are
///   "at most that far apart and at least that many".
/// * `tolerance_m` excludes `control_points` (a tolerance fit chooses its own).
/// * Defaults: the fit's are [`FitOptions::faithful`], precision [`DEFAULT_PRECISION`],
///   per-feature topology, GeoJSON output, small rings kept.
///
/// # Errors
/// An [`EarthError`] with an empty pointer naming the option: [`Problem::ConflictingOptions`],
/// [`Problem::InvalidOption`], [`Problem::RequiresOption`], [`Problem::CountOutOfRange`].
pub fn into_job(raw: RawOptions, kind: OperationKind, limits: &Limits) -> Result<Job, EarthError> {
    if let Some(name) = raw
        .given()
        .into_iter()
        .find(|n| !kind.option_names().contains(n))
    {
        return Err(invalid_option(
            name,
            format!(
                "not an option of {}: it takes {}",
                kind.name(),
                kind.option_names().join(", ")
            ),
        ));
    }
    // A fit in time: asked for, or implied by time_property (and on a fit, spacing_s).
    let implied = if raw.time_property.is_some() {
        Some("time_property")
    } else if kind == OperationKind::Fit && raw.spacing_s.is_some() {
        Some("spacing_s")
    } else {
        None
    };
    let in_time = match (raw.parameterization, implied) {
        (Some(ParameterizationOption::Time), _) | (None, Some(_)) => true,
        (Some(p), Some(k)) => {
            return Err(conflict(
                k,
                format!("parameterization={}", p.name()),
                "it is for a fit in time",
            ))
        }
        (_, None) => false,
    };
    if raw.spacing_s.is_some() {
        if let Some(other) = [
            ("samples", raw.samples.is_some()),
            ("spacing_m", raw.spacing_m.is_some()),
        ]
        .into_iter()
        .find_map(|(n, g)| g.then_some(n))
        {
            return Err(conflict(
                "spacing_s",
                other,
                "give one way of sampling (spacing_s, or samples and spacing_m)",
            ));
        }
    }
    if raw.tolerance_m.is_some() && raw.control_points.is_some() {
        return Err(conflict(
            "tolerance_m",
            "control_points",
            "a tolerance fit chooses its own control points",
        ));
    }
    let at_unix_s = match &raw.at {
        None => None,
        Some(v) => Some(super::time::parse_time_list(v).map_err(|m| {
            invalid_option(
                "at",
                format!("at={v:?}: {m} (give RFC 3339 times or unix seconds, comma-separated)"),
            )
        })?),
    };
    let operation = match kind {
        OperationKind::Evaluate => Operation::Evaluate,
        OperationKind::Interpolate => {
            let d = InterpolateSettings::default();
            Operation::Interpolate(InterpolateSettings {
                beta1: raw.beta1.unwrap_or(d.beta1),
                beta2: raw.beta2.unwrap_or(d.beta2),
            })
        }
        OperationKind::Fit => {
            let base = FitOptions::faithful();
            let options = FitOptions {
                control_points: raw.control_points,
                degree: raw.degree.unwrap_or(base.degree),
                knots: raw.knots.unwrap_or(base.knots),
                iterations: raw.iterations.unwrap_or(base.iterations),
                parameterization: match raw.parameterization {
                    Some(ParameterizationOption::Shape(p)) => p,
                    _ => base.parameterization,
                },
                solver: raw.solver.unwrap_or(base.solver),
                parameter_correction: raw
                    .parameter_correction
                    .unwrap_or(base.parameter_correction),
                ..base
            };
            match raw.tolerance_m {
                Some(tolerance_m) => Operation::FitToTolerance {
                    options,
                    tolerance_m,
                },
                None => Operation::Fit(options),
            }
        }
    };
    let sampling = match raw.spacing_s {
        Some(s) => Sampling::SpacingS(s),
        None => Sampling::from_samples_and_spacing(raw.samples, raw.spacing_m),
    };
    let job = Job {
        operation,
        output: OutputOptions {
            sampling,
            precision: raw
                .precision
                .map_or(DEFAULT_PRECISION, |n| u32::try_from(n).unwrap_or(u32::MAX)),
        },
        limits: limits.clone(),
        cancel: Cancel::inherit(),
        time: TimeOptions {
            fit_in_time: in_time.then(|| match &raw.time_property {
                Some(name) => TimeSource::Property(name.clone()),
                None => TimeSource::Auto,
            }),
            at_unix_s,
        },
        topology: raw.topology.unwrap_or_default(),
        format: raw.format.unwrap_or_default(),
        drop_small_rings: raw.drop_small_rings.unwrap_or(false),
    };
    job.validate()?;
    Ok(job)
}

/// The tolerance of an S^n fit (`tolerance_rad`), checked: positive, and not with
/// `control_points` (a tolerance fit chooses its own), the rule [`into_job`] applies to
/// `tolerance_m`.
///
/// # Errors
/// [`Problem::ConflictingOptions`] or [`Problem::InvalidOption`] naming `tolerance_rad`.
pub fn check_sphere_tolerance(
    tolerance_rad: Option<f64>,
    control_points: Option<usize>,
) -> Result<Option<f64>, EarthError> {
    let Some(t) = tolerance_rad else {
        return Ok(None);
    };
    if control_points.is_some() {
        return Err(conflict(
            "tolerance_rad",
            "control_points",
            "a tolerance fit chooses its own control points",
        ));
    }
    check_tolerance("tolerance_rad", t)?;
    Ok(Some(t))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn job(kind: OperationKind, pairs: &[(&str, &str)]) -> Result<Job, EarthError> {
        let mut raw = RawOptions::default();
        for (k, v) in pairs {
            raw.set(k, v).unwrap();
        }
        into_job(raw, kind, &Limits::default())
    }

    fn fit(pairs: &[(&str, &str)]) -> Result<Job, EarthError> {
        job(OperationKind::Fit, pairs)
    }

    /// The option an error names and its kind.
    fn refused(r: Result<Job, EarthError>) -> (&'static str, &'static str) {
        let e = r.unwrap_err();
        let (option, _) = e.problem.option_message().expect("an option's error");
        (option, e.problem.slug())
    }

    #[test]
    fn defaults_are_the_faithful_fit_per_feature_with_small_rings_kept() {
        let j = fit(&[]).unwrap();
        assert_eq!(j.operation, Operation::Fit(FitOptions::faithful()));
        assert_eq!(j.output, OutputOptions::default());
        assert_eq!(
            (j.topology, j.format, j.drop_small_rings),
            (Topology::PerFeature, OutputFormat::GeoJson, false)
        );
        assert_eq!(j.time, TimeOptions::default());
        assert_eq!(
            job(OperationKind::Interpolate, &[]).unwrap().operation,
            Operation::Interpolate(InterpolateSettings::default())
        );
    }

    #[test]
    fn every_option_lands_in_its_place() {
        let j = fit(&[
            ("control_points", "12"),
            ("degree", "2"),
            ("knots", "uniform"),
            ("iterations", "50"),
            ("parameterization", "centripetal"),
            ("solver", "gls-pia"),
            ("parameter_correction", "false"),
            ("samples", "20"),
            ("spacing_m", "250"),
            ("precision", "5"),
            ("drop_small_rings", "true"),
        ])
        .unwrap();
        let o = j.operation.fit_options().unwrap();
        assert_eq!(
            (o.control_points, o.degree, o.knots, o.iterations),
            (Some(12), 2, KnotPlacement::Uniform, 50)
        );
        assert_eq!(
            (o.parameterization, o.solver, o.parameter_correction),
            (Parameterization::Centripetal, Solver::GlsPia, false)
        );
        assert_eq!(
            j.output,
            OutputOptions {
                sampling: Sampling::SpacingAndSamples {
                    spacing_m: 250.0,
                    samples: 20
                },
                precision: 5
            }
        );
        assert!(j.drop_small_rings);
        let j = fit(&[
            ("tolerance_m", "25"),
            ("topology", "shared"),
            ("format", "topojson"),
        ])
        .unwrap();
        assert!(matches!(
            j.operation,
            Operation::FitToTolerance { tolerance_m, .. } if tolerance_m == 25.0
        ));
        assert_eq!(
            (j.topology, j.format),
            (Topology::Shared, OutputFormat::TopoJson)
        );
    }

    #[test]
    fn time_is_asked_for_or_implied_and_conflicts_with_another_parameterization() {
        let t = |pairs| fit(pairs).unwrap().time.fit_in_time;
        assert_eq!(t(&[("parameterization", "time")]), Some(TimeSource::Auto));
        assert_eq!(
            t(&[("time_property", "when")]),
            Some(TimeSource::Property("when".into()))
        );
        assert_eq!(t(&[("spacing_s", "30")]), Some(TimeSource::Auto));
        // parameterization=time is not a math-core parameterisation: the fit keeps its own.
        assert_eq!(
            fit(&[("parameterization", "time")])
                .unwrap()
                .operation
                .fit_options()
                .unwrap()
                .parameterization,
            FitOptions::faithful().parameterization
        );
        assert_eq!(
            refused(fit(&[("parameterization", "chord"), ("spacing_s", "30")])),
            ("spacing_s", "conflicting-options")
        );
        assert_eq!(
            refused(fit(&[
                ("parameterization", "uniform"),
                ("time_property", "t")
            ])),
            ("time_property", "conflicting-options")
        );
        // On evaluation spacing_s is the spacing of a curve already in time.
        let e = job(OperationKind::Evaluate, &[("spacing_s", "60")]).unwrap();
        assert_eq!(e.time.fit_in_time, None);
        assert_eq!(e.output.sampling, Sampling::SpacingS(60.0));
        assert_eq!(
            refused(job(OperationKind::Interpolate, &[("spacing_s", "10")])),
            ("spacing_s", "invalid-option")
        );
    }

    #[test]
    fn options_that_exclude_each_other_are_refused_once_naming_both() {
        let e = fit(&[("tolerance_m", "100"), ("control_points", "5")]).unwrap_err();
        assert_eq!(e.problem.slug(), "conflicting-options");
        assert_eq!(
            e.problem.option_message().unwrap(),
            (
                "tolerance_m",
                "tolerance_m excludes control_points: a tolerance fit chooses its own control points"
                    .to_string()
            )
        );
        let flags = e
            .problem
            .option_message_named(&|n: &str| format!("--{}", n.replace('_', "-")))
            .unwrap();
        assert!(
            flags
                .1
                .starts_with("--tolerance-m excludes --control-points"),
            "{}",
            flags.1
        );
        for other in ["samples", "spacing_m"] {
            assert_eq!(
                refused(job(
                    OperationKind::Evaluate,
                    &[("spacing_s", "30"), (other, "10")]
                )),
                ("spacing_s", "conflicting-options")
            );
        }
        assert_eq!(
            refused(check_sphere_tolerance(Some(0.01), Some(5)).map(|_| fit(&[]).unwrap())),
            ("tolerance_rad", "conflicting-options")
        );
    }

    #[test]
    fn topology_and_format_rules() {
        let e = fit(&[("topology", "shared")]).unwrap_err();
        assert!(matches!(
            e.problem,
            Problem::RequiresOption {
                option: "topology",
                requires: "tolerance_m",
                ..
            }
        ));
        assert_eq!(
            refused(fit(&[("format", "topojson"), ("tolerance_m", "10")])),
            ("format", "invalid-option")
        );
        assert_eq!(
            refused(fit(&[
                ("topology", "shared"),
                ("tolerance_m", "10"),
                ("parameterization", "time")
            ])),
            ("topology", "invalid-option")
        );
        assert!(fit(&[
            ("topology", "shared"),
            ("tolerance_m", "10"),
            ("format", "topojson")
        ])
        .is_ok());
    }

    #[test]
    fn ranges_limits_and_foreign_options_are_refused_naming_the_option() {
        for (k, v) in [
            ("degree", "9"),
            ("control_points", "2"),
            ("samples", "1"),
            ("precision", "16"),
            ("iterations", "100000"),
            ("spacing_m", "0"),
            ("tolerance_m", "0"),
            ("spacing_s", "-1"),
        ] {
            assert_eq!(refused(fit(&[(k, v)])).0, k, "{k}={v}");
        }
        assert_eq!(
            refused(job(OperationKind::Interpolate, &[("beta1", "0")])).0,
            "beta1"
        );
        let e = job(OperationKind::Evaluate, &[("at", "1,,2")]).unwrap_err();
        assert_eq!(e.problem.option_message().unwrap().0, "at");
        assert_eq!(
            job(OperationKind::Evaluate, &[("at", "1,2010-10-03T09:36:30Z")])
                .unwrap()
                .time
                .at_unix_s,
            Some(vec![1.0, 1286098590.0])
        );
        assert_eq!(
            refused(job(
                OperationKind::Evaluate,
                &[("at", "1"), ("samples", "5")]
            ))
            .0,
            "at"
        );
        // An option of another operation (a front end that fills a field the operation does
        // not take) is refused, not ignored.
        assert_eq!(
            refused(job(
                OperationKind::Interpolate,
                &[("drop_small_rings", "true")]
            )),
            ("drop_small_rings", "invalid-option")
        );
        assert_eq!(refused(fit(&[("at", "1")])), ("at", "invalid-option"));
    }

    #[test]
    fn set_parses_as_the_query_does() {
        let mut raw = RawOptions::default();
        for (k, bad) in [
            ("samples", "ten"),
            ("samples", "+5"),
            ("spacing_m", "NaN"),
            ("spacing_m", "inf"),
            ("spacing_m", " 1"),
            ("knots", "spline"),
            ("drop_small_rings", "yes"),
            ("topology", "merged"),
            ("nonsense", "1"),
        ] {
            let e = raw.set(k, bad).unwrap_err();
            assert_eq!(e.option, k);
        }
        assert_eq!(raw, RawOptions::default(), "nothing set by a failed parse");
        raw.set("spacing_m", "-1.5e-3").unwrap();
        assert_eq!(raw.spacing_m, Some(-1.5e-3));
        assert_eq!(raw.given(), ["spacing_m"]);
    }

    #[test]
    fn every_option_name_is_one_that_set_reads_and_given_reports() {
        for kind in [
            OperationKind::Fit,
            OperationKind::Interpolate,
            OperationKind::Evaluate,
        ] {
            for name in kind.option_names() {
                let value = match *name {
                    "knots" => "uniform",
                    "parameterization" => "chord",
                    "solver" => "gls-pia",
                    "parameter_correction" | "drop_small_rings" => "true",
                    "topology" => "shared",
                    "format" => "topojson",
                    "time_property" | "at" => "t",
                    _ => "3",
                };
                let mut raw = RawOptions::default();
                raw.set(name, value).unwrap();
                assert_eq!(raw.given(), [*name]);
            }
        }
    }
}
