//! What the user gave: [`RawOptions`] (each option `None` when not given), filled from text
//! ([`RawOptions::set`], the service's query) or field by field (the command line, Python), and
//! the enumerations its options name.

use crate::sphere::fit::knots::{KnotPlacement, Parameterization};
use crate::sphere::fit::options::Solver;
use crate::sphere::fit::options_check::{concat_names, SPLINE_OPTIONS};
use std::str::FromStr;

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

/// `FromStr` for an enumeration of options by the names users write.
macro_rules! from_names {
    ($t:ty { $($name:literal => $value:expr),+ $(,)? }) => {
        impl FromStr for $t {
            type Err = ();
            fn from_str(s: &str) -> Result<Self, ()> {
                match s {
                    $($name => Ok($value),)+
                    _ => Err(()),
                }
            }
        }
    };
}

from_names!(Topology { "per-feature" => Topology::PerFeature, "shared" => Topology::Shared });

/// The document written.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum OutputFormat {
    /// A GeoJSON FeatureCollection (the default).
    #[default]
    GeoJson,
    /// A TopoJSON topology ([`crate::earth::coverage::topojson`]); only with [`Topology::Shared`].
    TopoJson,
}

from_names!(OutputFormat { "geojson" => OutputFormat::GeoJson, "topojson" => OutputFormat::TopoJson });

/// What each fitted feature carries (`carry`): the dense geometry a plain GeoJSON reader
/// draws, the spline a curve-aware reader evaluates, or both. Storing one of them is what makes
/// an output small: the spline alone is a few numbers per curve, the geometry alone is what
/// mapshaper would write.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Carry {
    /// The geometry and, in `properties.fit`, the spline (the default: what a plain GeoJSON
    /// reader needs, and what `evaluate` reads).
    #[default]
    Both,
    /// The geometry only: `properties.fit` keeps its report but no `spline` (a degree-1 fit's
    /// geometry is its curve; a higher degree's is the curve sampled).
    Geometry,
    /// The spline only: `geometry` is `null` and `evaluate` makes it again.
    Spline,
}

from_names!(Carry { "both" => Carry::Both, "geometry" => Carry::Geometry, "spline" => Carry::Spline });

/// The options of a fit on the Earth: the spline options every fit takes, then the Earth's.
const FIT_OPTIONS: [&str; 17] = concat_names(
    SPLINE_OPTIONS,
    [
        "tolerance_m",
        "time_property",
        "samples",
        "spacing_m",
        "spacing_s",
        "precision",
        "topology",
        "format",
        "drop_small_rings",
        "carry",
    ],
);

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
            OperationKind::Fit => &FIT_OPTIONS,
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
    /// Position as a function of time ([`TimeOptions::fit_in_time`](crate::earth::job::TimeOptions::fit_in_time)).
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
    pub(super) fn name(self) -> &'static str {
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
/// Python from its keywords; [`into_job`](crate::earth::job::into_job::into_job) checks it and makes the [`Job`](crate::earth::job::Job).
///
/// Adding an option: a field here, a line in [`RawOptions::set`] and
/// [`RawOptions::given`], its name in [`OperationKind::option_names`], and its rule in
/// [`into_job`](crate::earth::job::into_job::into_job) (README, "Adding an option", lists the other files).
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
    /// What each fitted feature carries: geometry, spline or both.
    pub carry: Option<Carry>,
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

pub(super) const INTEGER: &str = "a non-negative integer";
pub(super) const NUMBER: &str = "a number";

impl RawOptions {
    /// Sets the option `name` from its text (a query parameter's value): integers in plain
    /// decimal digits, numbers as JSON writes them ([`parse_json_number`]), `true`/`false`,
    /// names of the enumerations. Whether the value is in range is [`into_job`](crate::earth::job::into_job::into_job)'s business.
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
                self.knots = Some(named(
                    value,
                    &fail,
                    "adaptive, geodesic, euclidean or uniform",
                )?)
            }
            "parameterization" => {
                self.parameterization = Some(named(
                    value,
                    &fail,
                    "chord, centripetal, uniform or (GeoJSON) time",
                )?)
            }
            "solver" => self.solver = Some(named(value, &fail, "gls-pia or gauss-newton")?),
            "parameter_correction" => self.parameter_correction = Some(boolean(value, &fail)?),
            "drop_small_rings" => self.drop_small_rings = Some(boolean(value, &fail)?),
            "topology" => self.topology = Some(named(value, &fail, "per-feature or shared")?),
            "format" => self.format = Some(named(value, &fail, "geojson or topojson")?),
            "carry" => self.carry = Some(named(value, &fail, "geometry, spline or both")?),
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
            carry,
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
            ("carry", carry.is_some()),
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

/// The type of an option's value, for front ends that describe options before they read them
/// (the OGC API – Processes input schemas are generated from this, and their JSON values are
/// read back through [`RawOptions::set`], so the options keep one home).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OptionType {
    /// A non-negative integer.
    Integer,
    /// A number, as JSON writes it.
    Number,
    /// `true` or `false`.
    Boolean,
    /// Free text (a property name, a list of times).
    Text,
    /// One of these names.
    OneOf(&'static [&'static str]),
}

impl RawOptions {
    /// The type of the option `name` (one of [`OperationKind::option_names`]); `None` for a
    /// name that is no option. Kept beside [`RawOptions::set`], which it describes (a unit test
    /// checks that `set` takes a value of every type given here).
    pub fn option_type(name: &str) -> Option<OptionType> {
        Some(match name {
            "control_points" | "degree" | "iterations" | "samples" | "precision" => {
                OptionType::Integer
            }
            "tolerance_m" | "spacing_m" | "spacing_s" | "beta1" | "beta2" => OptionType::Number,
            "parameter_correction" | "drop_small_rings" => OptionType::Boolean,
            "time_property" | "at" => OptionType::Text,
            "knots" => OptionType::OneOf(&["adaptive", "geodesic", "euclidean", "uniform"]),
            "parameterization" => OptionType::OneOf(&["chord", "centripetal", "uniform", "time"]),
            "solver" => OptionType::OneOf(&["gls-pia-accelerated", "gls-pia", "gauss-newton"]),
            "topology" => OptionType::OneOf(&["per-feature", "shared"]),
            "format" => OptionType::OneOf(&["geojson", "topojson"]),
            "carry" => OptionType::OneOf(&["both", "geometry", "spline"]),
            _ => return None,
        })
    }
}

/// `value` as one of the names of `T`; else `expected` says what it should be.
fn named<T: FromStr>(
    value: &str,
    fail: &dyn Fn(&'static str) -> ParseError,
    expected: &'static str,
) -> Result<T, ParseError> {
    value.parse().map_err(|_| fail(expected))
}

fn boolean(value: &str, fail: &dyn Fn(&'static str) -> ParseError) -> Result<bool, ParseError> {
    match value {
        "true" => Ok(true),
        "false" => Ok(false),
        _ => Err(fail("true or false")),
    }
}
