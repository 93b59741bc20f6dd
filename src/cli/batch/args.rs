//! The flags of `spherefit fit | interpolate | evaluate` and the [`Job`] they make: each
//! command only fills a [`RawOptions`]; [`into_job`] checks it, as it does the service's query.

use crate::cli::batch::input::Format;
use crate::cli::batch::topology;
use crate::cli::Failure;
use crate::earth::into_job;
use crate::earth::job::{
    InterpolateSettings, Job, Limits, OperationKind, ParameterizationOption, RawOptions,
};
use crate::sphere::fit::knots::KnotPlacement;
use crate::sphere::fit::options::{FitOptions, Solver};
use clap::Args;
use std::path::PathBuf;

pub(super) const AFTER_HELP: &str = "\
Input:
  Each INPUT is read in turn (stdin when none is given or for `-`) and its format detected
  unless --format names it: a leading RS byte (0x1E) is a GeoJSON text sequence (RFC 8142);
  a first line that is a whole JSON text followed by more lines is newline-delimited GeoJSON;
  anything else is one GeoJSON document. A FeatureCollection is read feature by feature and
  never held in memory whole; a Feature, a geometry (or, for evaluate, a spline document with
  \"crs\": \"lonlat\") is one record. In a sequence, each record may be a Feature, a geometry
  or a FeatureCollection (whose features are written as separate records).

Output:
  The features, in input order, in the input's format unless --output-format (or --format)
  says otherwise: a FeatureCollection for geojson (keeping the input collections' foreign
  members except bbox), one RS-prefixed record per feature for seq, one line per feature for
  lines. Each feature is exactly what the service returns for it. Features without lines or
  rings pass through unchanged.

Memory and threads:
  Records are fitted in parallel (--threads) within a bounded window of records in flight,
  so memory stays flat however long the input; only the largest single record counts.

Errors and exit status:
  A record that cannot be processed is reported on stderr as
  `spherefit: INPUT: record N: POINTER: reason` (POINTER is a JSON pointer into the record)
  and left out of the output; the others are written. A closed output pipe ends the run
  quietly. Exit status: 0 all records succeeded, 1 some failed, 2 usage error or an input or
  output that cannot be read or written (a document that is not valid JSON, a missing file).

Progress and summary:
  On a terminal, stderr shows features done, points per second and the ETA (for files); at
  the end a summary gives features, points in, numbers stored, the compression ratio (2 x
  points in / numbers stored) and the worst max error. --quiet turns both off; --stats prints
  the summary as JSON.";

/// Inputs, outputs and how the run reports.
#[derive(Debug, Args)]
pub(crate) struct BatchArgs {
    /// Inputs, read in order: GeoJSON files (or `-` for stdin), Shapefiles (.shp or .zip),
    /// GeoPackages, FlatGeobuf, GPX or TopoJSON files [default: stdin]
    #[arg(value_name = "INPUT", help_heading = "Input and output")]
    pub(super) inputs: Vec<PathBuf>,
    /// Write the output to this file (`-` is stdout); a name ending .gpkg, .fgb, .shp or .gpx
    /// writes that format [default: stdout]
    #[arg(short, long, value_name = "OUTPUT", help_heading = "Input and output")]
    pub(super) output: Option<PathBuf>,
    /// Input format, and the output's unless --output-format is given
    #[arg(
        long,
        value_enum,
        value_name = "FORMAT",
        default_value_t = Format::Auto,
        help_heading = "Input and output"
    )]
    pub(super) format: Format,
    /// Output format; auto writes the input's format (that of the first input)
    #[arg(
        long,
        value_enum,
        value_name = "FORMAT",
        default_value_t = Format::Auto,
        hide_possible_values = true,
        help_heading = "Input and output"
    )]
    pub(super) output_format: Format,
    /// The layer to read of a GeoPackage (a table), zipped Shapefile (a .shp in it), GPX
    /// (waypoints, routes, tracks) or TopoJSON (an object) [default: every layer]
    #[arg(long, value_name = "NAME", help_heading = "Input and output")]
    pub(super) layer: Option<String>,
    /// Worker threads [default: RAYON_NUM_THREADS if set, else the number of CPUs]
    #[arg(short = 'j', long, value_name = "N", help_heading = "Run")]
    pub(super) threads: Option<usize>,
    /// No progress and no summary on stderr (record errors are still printed)
    #[arg(short, long, help_heading = "Run")]
    pub(super) quiet: bool,
    /// Print the summary as one JSON object on stderr, or into FILE with --stats=FILE
    #[arg(
        long,
        value_name = "FILE",
        num_args = 0..=1,
        require_equals = true,
        default_missing_value = "-",
        help_heading = "Run"
    )]
    pub(super) stats: Option<PathBuf>,
}

/// How output lines are drawn (query parameters `samples`, `spacing_m`, `precision`).
#[derive(Debug, Args)]
#[command(next_help_heading = "Output curves")]
pub(crate) struct OutputArgs {
    /// Output points per curve, evenly spaced in parameter, 2 to --max-samples (with
    /// --spacing-m: at least this many) [default: automatic, dense enough that the polyline
    /// stays within 5 % of the fit's max error of the curve and at least 5 cm]
    #[arg(long, value_name = "N")]
    pub(super) samples: Option<usize>,
    /// Distance between output points along the curve, in metres (with --samples: at most
    /// this far apart) [default: none, automatic sampling as for --samples]
    #[arg(
        long,
        value_name = "METRES",
        alias = "spacing_m",
        allow_negative_numbers = true
    )]
    pub(super) spacing_m: Option<f64>,
    /// For a curve in time (--parameterization time): an output point every this many
    /// seconds from the track's start, and its end (not with --samples or --spacing-m)
    #[arg(
        long,
        value_name = "SECONDS",
        alias = "spacing_s",
        allow_negative_numbers = true
    )]
    pub(super) spacing_s: Option<f64>,
    /// Decimals of output degrees, 0 to 15, control points included (7 decimals is 1.1 cm or
    /// less); altitudes are rounded to millimetres. With --tolerance-m: the fewest whose
    /// rounding stays within a tenth of the tolerance (100 m: 4, 1 km: 3), counted in the
    /// certified bound [default: 7]
    #[arg(long, value_name = "DECIMALS")]
    pub(super) precision: Option<u32>,
    /// Most output points per curve: --samples, or what --spacing-m or automatic sampling
    /// need (the service's SPHEREFIT_MAX_SAMPLES)
    #[arg(long, value_name = "N", default_value_t = Limits::default().max_samples, help_heading = "Limits")]
    pub(super) max_samples: usize,
}

/// GLS-PIA options (query parameters of `/v1/fit`).
#[derive(Debug, Args)]
#[command(next_help_heading = "Fit")]
pub(crate) struct FitOptionArgs {
    /// Control points per curve: at least degree + 1 and at most the curve's distinct
    /// positions [default: a quarter of the distinct positions, or half of them when a quarter
    /// leaves a position farther from the curve than a quarter of the median step; at least degree + 1]
    #[arg(short = 'n', long, value_name = "N", alias = "control_points")]
    pub(super) control_points: Option<usize>,
    /// Polynomial degree, 1 to 5 (lowered for a curve with fewer than degree + 1 distinct
    /// positions)
    #[arg(long, value_name = "DEGREE", default_value_t = FitOptions::default().degree)]
    pub(super) degree: usize,
    /// Knot placement: adaptive (the paper's geodesic feature function with corners as C0
    /// joints and a share of arc length), geodesic (the paper's), euclidean or uniform
    #[arg(long, value_name = "PLACEMENT", default_value = "adaptive")]
    pub(super) knots: KnotPlacement,
    /// Most GLS-PIA iterations, 0 to --max-iterations; a fit stops earlier when its error
    /// stagnates (the paper uses 30)
    #[arg(long, value_name = "N", default_value_t = crate::sphere::fit::DEFAULT_ITERATIONS)]
    pub(super) iterations: usize,
    /// Data parameters: chord (cumulative geodesic distance), centripetal, uniform, or time
    /// (position as a function of each position's time; with --tolerance-m the bound is the
    /// synchronized distance; implied by --time-property and --spacing-s) [default: chord]
    #[arg(long, value_name = "METHOD")]
    pub(super) parameterization: Option<ParameterizationOption>,
    /// With --parameterization time: the feature property holding one time per position
    /// (RFC 3339 strings or unix seconds) [default: the first of coordTimes, times, timestamps
    /// present, else the 4th coordinate of each position]
    #[arg(long, value_name = "NAME", alias = "time_property")]
    pub(super) time_property: Option<String>,
    /// Optimiser: gls-pia-accelerated (the paper's iteration preconditioned by the banded
    /// normal matrix: its fixed point in a few passes), gls-pia (the paper's 30 plain
    /// iterations) or gauss-newton (the exact geodesic least-squares optimum)
    #[arg(long, value_name = "SOLVER", default_value = "gls-pia-accelerated")]
    pub(super) solver: Solver,
    /// Move each position's parameter to its foot point on the curve between solver steps
    /// (false: chord-length parameters kept, as in the paper)
    #[arg(long, value_name = "BOOL", default_value_t = false, action = clap::ArgAction::Set)]
    pub(super) parameter_correction: bool,
    /// Fit each curve to this tolerance, in metres: every position within it of the curve as
    /// returned, with as few stored numbers as the fitter finds (not with --control-points;
    /// --degree caps the degrees tried, at most 3) [default: none, a fit with --control-points]
    #[arg(
        long,
        value_name = "METRES",
        alias = "tolerance_m",
        allow_negative_numbers = true
    )]
    pub(super) tolerance_m: Option<f64>,
    /// A polygon ring that collapses under the fit (an islet or a sliver narrower than the
    /// tolerance) is dropped and listed in properties.fit.dropped_rings, instead of kept as a
    /// small valid ring (listed in kept_rings); a polygon whose exterior ring is dropped is
    /// dropped with its holes, and a feature left with no polygon keeps its properties with an
    /// empty MultiPolygon
    #[arg(long, alias = "drop_small_rings", help_heading = "Fit")]
    pub(super) drop_small_rings: bool,
    /// What each fitted feature carries: both (the dense geometry, and the spline in
    /// properties.fit, which evaluate reads), geometry (no spline: the smallest file a plain
    /// GeoJSON reader draws) or spline (geometry null: evaluate draws it)
    #[arg(long, value_name = "WHAT", default_value = "both", value_parser = ["both", "geometry", "spline"], help_heading = "Input and output")]
    pub(super) carry: String,
    /// Most control points per curve (the service's SPHEREFIT_MAX_CONTROL_POINTS)
    #[arg(long, value_name = "N", default_value_t = Limits::default().max_control_points, help_heading = "Limits")]
    pub(super) max_control_points: usize,
    /// Most GLS-PIA iterations per fit (the service's SPHEREFIT_MAX_ITERATIONS)
    #[arg(long, value_name = "N", default_value_t = Limits::default().max_iterations, help_heading = "Limits")]
    pub(super) max_iterations: usize,
}

/// Beta-spline shape (query parameters of `/v1/interpolate`).
#[derive(Debug, Args)]
#[command(next_help_heading = "Interpolation")]
pub(crate) struct InterpolateOptionArgs {
    /// Bias at every vertex: the ratio of outgoing to incoming speed, 1e-6 to 1e6 (1 is none)
    #[arg(long, value_name = "RATIO", allow_negative_numbers = true, default_value_t = InterpolateSettings::default().beta1)]
    beta1: f64,
    /// Tension at every vertex, >= 0 (0 is none; more pulls the curve towards the polyline)
    #[arg(long, value_name = "TENSION", allow_negative_numbers = true, default_value_t = InterpolateSettings::default().beta2)]
    beta2: f64,
}

/// Fit spherical B-splines to GeoJSON lines and rings, as POST /v1/fit does.
///
/// Every LineString, each part of a MultiLineString and every Polygon and MultiPolygon ring
/// is fitted with a spherical B-spline (GLS-PIA) on the sphere, so lines crossing the
/// antimeridian or passing a pole fit like any other. Each fitted feature's geometry becomes
/// the dense fitted curve (cut at +-180 degrees) and `properties.fit` holds max_error_m,
/// mean_error_m, rms_error_m (parametric geodesic errors in metres of the spline as returned),
/// input_points, control_points, iterations, converged, knots, parameterization,
/// output_points, sampling_deviation_m and the spline itself (degree, knots, control points as
/// [lon, lat]), which `spherefit evaluate` turns back into the same curve.
#[derive(Debug, Args)]
#[command(after_long_help = AFTER_HELP)]
pub(crate) struct FitArgs {
    #[command(flatten)]
    pub(super) fit: FitOptionArgs,
    #[command(flatten)]
    pub(super) topology: topology::TopologyArgs,
    #[command(flatten)]
    pub(super) common: CommonArgs,
}

/// Smooth Beta-spline curves through every vertex, as POST /v1/interpolate does.
///
/// Every line and ring is interpolated with a spherical Beta-spline (G1, through every
/// distinct vertex). Each feature's geometry becomes the dense curve and
/// `properties.interpolation` holds max_error_m (distance of the vertices from the curve as
/// returned, after rounding), input_points, segments, output_points, sampling_deviation_m and
/// the curve document in lon/lat (type beta, beta1, beta2, segments).
#[derive(Debug, Args)]
#[command(after_long_help = AFTER_HELP)]
pub(crate) struct InterpolateArgs {
    #[command(flatten)]
    pub(super) shape: InterpolateOptionArgs,
    #[command(flatten)]
    pub(super) common: CommonArgs,
}

/// Dense GeoJSON from stored curves, as POST /v1/evaluate does.
///
/// Features carrying `properties.fit` (from `spherefit fit`) or `properties.interpolation`
/// (from `spherefit interpolate`) get their geometry rebuilt from the stored curves and
/// `properties.evaluation` (output_points, sampling_deviation_m); other features pass through.
/// A bare spline document with "crs": "lonlat" becomes one Feature. Altitudes are not stored
/// in splines, so evaluated lines are 2D.
#[derive(Debug, Args)]
#[command(after_long_help = AFTER_HELP)]
pub(crate) struct EvaluateArgs {
    /// Positions at these times instead of a dense line, with speed (m/s) and heading
    /// (degrees from north) from the curve's derivative: RFC 3339 times or unix seconds,
    /// comma-separated (fits made with --parameterization time only)
    #[arg(long, value_name = "TIMES", help_heading = "Output curves")]
    pub(super) at: Option<String>,
    #[command(flatten)]
    pub(super) common: CommonArgs,
}

/// The output and batch options of every command.
#[derive(Debug, Args)]
pub(crate) struct CommonArgs {
    #[command(flatten)]
    pub(super) output: OutputArgs,
    #[command(flatten)]
    pub(super) batch: BatchArgs,
}

impl FitOptionArgs {
    /// The options as given (those with defaults always given).
    pub(super) fn raw(&self) -> RawOptions {
        RawOptions {
            control_points: self.control_points,
            degree: Some(self.degree),
            knots: Some(self.knots),
            iterations: Some(self.iterations),
            parameterization: self.parameterization,
            solver: Some(self.solver),
            parameter_correction: Some(self.parameter_correction),
            tolerance_m: self.tolerance_m,
            time_property: self.time_property.clone(),
            drop_small_rings: self.drop_small_rings.then_some(true),
            carry: self.carry.parse().ok(),
            ..RawOptions::default()
        }
    }

    /// The limits set by the fit's flags (`--max-samples` is an output option).
    pub(super) fn limits(&self) -> Limits {
        Limits {
            max_control_points: self.max_control_points,
            max_iterations: self.max_iterations,
            ..Limits::default()
        }
    }
}

impl OutputArgs {
    /// Adds the output options to `raw`.
    pub(super) fn fill(&self, raw: &mut RawOptions) {
        raw.samples = self.samples;
        raw.spacing_m = self.spacing_m;
        raw.spacing_s = self.spacing_s;
        raw.precision = self.precision.map(|p| p as usize);
    }
}

impl CommonArgs {
    /// The job of `kind` (its options checked by [`into_job`], as the service's query is):
    /// `raw` with the output options and the output format added, `limits` with
    /// `--max-samples`.
    pub(super) fn job(
        &self,
        mut raw: RawOptions,
        kind: OperationKind,
        limits: Limits,
    ) -> Result<Job, Failure> {
        self.output.fill(&mut raw);
        raw.format = self.batch.output_format.topology_format();
        let limits = Limits {
            max_samples: self.output.max_samples,
            ..limits
        };
        into_job(raw, kind, &limits).map_err(Failure::option)
    }
}

/// The job of `spherefit fit`.
pub(super) fn fit_job(a: &FitArgs) -> Result<Job, Failure> {
    let raw = RawOptions {
        topology: Some(a.topology.topology),
        ..a.fit.raw()
    };
    a.common.job(raw, OperationKind::Fit, a.fit.limits())
}

/// The job of `spherefit interpolate`.
pub(super) fn interpolate_job(a: &InterpolateArgs) -> Result<Job, Failure> {
    let raw = RawOptions {
        beta1: Some(a.shape.beta1),
        beta2: Some(a.shape.beta2),
        ..RawOptions::default()
    };
    a.common
        .job(raw, OperationKind::Interpolate, Limits::default())
}

/// The job of `spherefit evaluate`.
pub(super) fn evaluate_job(a: &EvaluateArgs) -> Result<Job, Failure> {
    let raw = RawOptions {
        at: a.at.clone(),
        ..RawOptions::default()
    };
    a.common
        .job(raw, OperationKind::Evaluate, Limits::default())
}
