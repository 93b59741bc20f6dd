//! The options of a GeoJSON operation, from what the user gave ([`RawOptions`]) to a checked
//! [`Job`] ([`into_job`]): every rule about options (ranges, limits, options that exclude or
//! imply each other, topology and output format) is written here once, and every front end (the
//! service's query, the command line's flags, Python's keywords) only fills a [`RawOptions`].
//!
//! The files: this one ([`Job`] and what it holds, [`Job::validate`]), `raw` ([`RawOptions`]
//! and the enumerations of its options), `into_job` (the rules between options, the defaults)
//! and `checks` (one option's range and limit).

use crate::earth::error::{EarthError, Problem};
use crate::earth::sampling::Sampling;
use crate::earth::time::TimeSource;
use crate::sphere::cancel::Cancel;
use crate::sphere::fit::options::FitOptions;

mod checks;
mod grid;
mod into_job;
mod raw;
#[cfg(test)]
mod tests;

use checks::check_count;
pub use checks::{check_degree, check_fit_options, check_target_max_error_rad, check_tolerance};
pub use grid::{
    grid_neighbours, round_to_grid, topojson_grid_multiple, TOPOJSON_GRID_SHARE_OF_TOLERANCE,
};
pub use into_job::into_job;
pub use raw::{
    parse_json_number, Carry, OperationKind, OptionType, OutputFormat, ParameterizationOption,
    ParseError, RawOptions, Topology,
};

/// Highest `precision` (decimals of output degrees): 1e-15 degrees is below f64 resolution.
pub const MAX_PRECISION: u32 = 15;

/// Default output precision: 7 decimals of a degree is 1.1 cm or less.
pub const DEFAULT_PRECISION: u32 = 7;

/// The share of a tolerance that rounding the output to `precision` may take when the
/// precision is chosen from the tolerance ([`precision_for_tolerance`]): a tenth. Rounding moves
/// a control point by at most [`rounding_bound_rad`](crate::earth::curve::fitting::rounding_bound_rad), and the fitter aims
/// below the tolerance by 1.5 times that, so a tenth costs at most 15 % of the tolerance in the
/// fit's aim; decimals beyond it are bytes that carry no information the tolerance asks for.
pub const PRECISION_SHARE_OF_TOLERANCE: f64 = 0.1;

/// The fewest decimals of a degree whose rounding moves a position by at most
/// [`PRECISION_SHARE_OF_TOLERANCE`] of `tolerance_m` (at most [`DEFAULT_PRECISION`]: 7 decimals
/// are 1.1 cm, below any tolerance worth asking for; a tolerance that is not a positive number
/// gets the default, and is refused by [`Job::validate`]).
///
/// 100 m gives 4 decimals (rounding moves a position at most 7.9 m), 1 km gives 3, 25 m gives 5.
pub fn precision_for_tolerance(tolerance_m: f64) -> u32 {
    let allowed = PRECISION_SHARE_OF_TOLERANCE * crate::earth::lonlat::m_to_rad(tolerance_m);
    if !(allowed.is_finite() && allowed > 0.0) {
        return DEFAULT_PRECISION;
    }
    (0..DEFAULT_PRECISION)
        .find(|&p| crate::earth::curve::fitting::rounding_bound_rad(p) <= allowed)
        .unwrap_or(DEFAULT_PRECISION)
}

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
    /// Fits write their splines as compact curves (base64, [`encode_compact`](crate::earth::curve::compact::encode_compact))
    /// instead of JSON documents: set by `carry=spline`.
    pub compact_splines: bool,
    /// A degree-1 spline whose control points are exactly its geometry's positions refers to
    /// them (`"control_points": "geometry"`, [`CONTROL_POINTS_OF_GEOMETRY`](crate::earth::curve::stored::CONTROL_POINTS_OF_GEOMETRY))
    /// instead of repeating them. True by default; false where a spline is read back without
    /// its geometry (Python's `fit` column, which `evaluate` reads alone).
    pub splines_refer_to_geometry: bool,
    /// Decimal steps (of `precision`) in one step of the grid a coverage's positions are
    /// rounded to: 1 (the decimal grid) unless a tolerance chose the precision of a coverage
    /// written as TopoJSON ([`topojson_grid_multiple`]).
    pub grid_multiple: u32,
}

impl Default for OutputOptions {
    fn default() -> Self {
        OutputOptions {
            sampling: Sampling::Auto,
            precision: DEFAULT_PRECISION,
            compact_splines: false,
            splines_refer_to_geometry: true,
            grid_multiple: 1,
        }
    }
}

impl OutputOptions {
    /// Degrees rounded to the output grid ([`round_to_grid`]).
    pub fn round_deg(&self, x: f64) -> f64 {
        round_to_grid(x, self.precision, self.grid_multiple)
    }

    /// How far rounding to the output grid moves a position at most, radians.
    pub fn rounding_bound_rad(&self) -> f64 {
        f64::from(self.grid_multiple.max(1))
            * crate::earth::curve::fitting::rounding_bound_rad(self.precision)
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
    /// ([`crate::earth::polygon::small_rings`]).
    pub drop_small_rings: bool,
    /// What each fitted feature carries (`carry`): geometry, spline or both.
    pub carry: Carry,
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
    /// `operation` with default output options, limits, time options and topology.
    pub fn new(operation: Operation) -> Job {
        Job {
            operation,
            output: OutputOptions::default(),
            limits: Limits::default(),
            cancel: Cancel::inherit(),
            time: TimeOptions::default(),
            topology: Topology::PerFeature,
            format: OutputFormat::GeoJson,
            drop_small_rings: false,
            carry: Carry::Both,
        }
    }

    /// A fit with default output options and limits.
    pub fn fit(options: FitOptions) -> Job {
        Job::new(Operation::Fit(options))
    }

    /// An evaluation with default output options and limits.
    pub fn evaluate() -> Job {
        Job::new(Operation::Evaluate)
    }

    /// An interpolation with default output options and limits.
    pub fn interpolate(settings: InterpolateSettings) -> Job {
        Job::new(Operation::Interpolate(settings))
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

    /// Sets what each fitted feature carries (`carry`).
    pub fn carrying(mut self, carry: Carry) -> Job {
        self.carry = carry;
        self.output.compact_splines = carry == Carry::Spline;
        self
    }

    /// Whether degree-1 splines may refer to their geometry's positions
    /// ([`OutputOptions::splines_refer_to_geometry`]).
    pub fn splines_referring_to_geometry(mut self, refer: bool) -> Job {
        self.output.splines_refer_to_geometry = refer;
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
            if self.carry == Carry::Spline {
                return bad(
                    "carry",
                    "a coverage's geometry is its shared arcs, which its features need: use carry both (the splines are written with the arcs) or geometry".into(),
                );
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
        if self.carry != Carry::Both && self.operation.fit_options().is_none() {
            return bad(
                "carry",
                "only a fit chooses what its features carry (evaluate writes geometry)".into(),
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
