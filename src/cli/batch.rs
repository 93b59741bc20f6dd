//! `spherefit fit | interpolate | evaluate`: the GeoJSON endpoints of the service
//! (`POST /v1/fit`, `/v1/interpolate`, `/v1/evaluate`) as streaming batch commands.
//!
//! The options have the names, defaults and checks of the endpoints' query parameters (one
//! [`Job`], validated by [`Job::validate`]) and every feature goes through the same
//! [`crate::earth`] functions as in the service, so a file gives the same features from the
//! command line as from the service.
//!
//! * [`input`]: formats (one GeoJSON document, RFC 8142 text sequence, newline-delimited),
//!   detection, and reading records without holding the input whole.
//! * [`pipeline`]: records processed in parallel on the rayon pool within a bounded window and
//!   written in input order; per-record errors; a closed pipe ends quietly.
//!
//! Exit status: 0 when every record succeeded, 1 when some failed (each is reported on stderr
//! with its record number and the reason, and the others are written), 2 for usage errors and
//! inputs or outputs that cannot be read or written at all.

mod input;
mod pipeline;
mod topology;

use super::Failure;
use crate::earth::{
    into_job, InterpolateSettings, Job, Limits, OperationKind, ParameterizationOption, RawOptions,
    Topology,
};
use crate::sphere::{FitOptions, KnotPlacement, Solver};
use clap::Args;
use input::{Format, Input};
use pipeline::{Fatal, Progress, Settings, Sink, Totals};
use serde_json::json;
use std::io::{self, IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

const AFTER_HELP: &str = "\
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
    /// GeoJSON inputs, read in order: files, or `-` for stdin [default: stdin]
    #[arg(value_name = "INPUT", help_heading = "Input and output")]
    inputs: Vec<PathBuf>,
    /// Write the output to this file (`-` is stdout) [default: stdout]
    #[arg(short, long, value_name = "OUTPUT", help_heading = "Input and output")]
    output: Option<PathBuf>,
    /// Input format, and the output's unless --output-format is given
    #[arg(
        long,
        value_enum,
        value_name = "FORMAT",
        default_value_t = Format::Auto,
        help_heading = "Input and output"
    )]
    format: Format,
    /// Output format; auto writes the input's format (that of the first input)
    #[arg(
        long,
        value_enum,
        value_name = "FORMAT",
        default_value_t = Format::Auto,
        hide_possible_values = true,
        help_heading = "Input and output"
    )]
    output_format: Format,
    /// Worker threads [default: RAYON_NUM_THREADS if set, else the number of CPUs]
    #[arg(short = 'j', long, value_name = "N", help_heading = "Run")]
    threads: Option<usize>,
    /// No progress and no summary on stderr (record errors are still printed)
    #[arg(short, long, help_heading = "Run")]
    quiet: bool,
    /// Print the summary as one JSON object on stderr, or into FILE with --stats=FILE
    #[arg(
        long,
        value_name = "FILE",
        num_args = 0..=1,
        require_equals = true,
        default_missing_value = "-",
        help_heading = "Run"
    )]
    stats: Option<PathBuf>,
}

/// How output lines are drawn (query parameters `samples`, `spacing_m`, `precision`).
#[derive(Debug, Args)]
#[command(next_help_heading = "Output curves")]
pub(crate) struct OutputArgs {
    /// Output points per curve, evenly spaced in parameter, 2 to --max-samples (with
    /// --spacing-m: at least this many) [default: automatic, dense enough that the polyline
    /// stays within 5 % of the fit's max error of the curve and at least 5 cm]
    #[arg(long, value_name = "N")]
    samples: Option<usize>,
    /// Distance between output points along the curve, in metres (with --samples: at most
    /// this far apart) [default: none, automatic sampling as for --samples]
    #[arg(
        long,
        value_name = "METRES",
        alias = "spacing_m",
        allow_negative_numbers = true
    )]
    spacing_m: Option<f64>,
    /// For a curve in time (--parameterization time): an output point every this many
    /// seconds from the track's start, and its end (not with --samples or --spacing-m)
    #[arg(
        long,
        value_name = "SECONDS",
        alias = "spacing_s",
        allow_negative_numbers = true
    )]
    spacing_s: Option<f64>,
    /// Decimals of output degrees, 0 to 15, control points included (7 decimals is 1.1 cm or
    /// less); altitudes are rounded to millimetres
    #[arg(long, value_name = "DECIMALS", default_value_t = crate::earth::DEFAULT_PRECISION)]
    precision: u32,
    /// Most output points per curve: --samples, or what --spacing-m or automatic sampling
    /// need (the service's SPHEREFIT_MAX_SAMPLES)
    #[arg(long, value_name = "N", default_value_t = Limits::default().max_samples, help_heading = "Limits")]
    max_samples: usize,
}

/// GLS-PIA options (query parameters of `/v1/fit`).
#[derive(Debug, Args)]
#[command(next_help_heading = "Fit")]
pub(crate) struct FitOptionArgs {
    /// Control points per curve: at least degree + 1 and at most the curve's distinct
    /// positions [default: a quarter of the distinct positions, or half of them when a quarter
    /// leaves a position farther from the curve than a quarter of the median step; at least degree + 1]
    #[arg(short = 'n', long, value_name = "N", alias = "control_points")]
    control_points: Option<usize>,
    /// Polynomial degree, 1 to 5 (lowered for a curve with fewer than degree + 1 distinct
    /// positions)
    #[arg(long, value_name = "DEGREE", default_value_t = FitOptions::default().degree)]
    degree: usize,
    /// Knot placement: adaptive (the paper's geodesic feature function with corners as C0
    /// joints and a share of arc length), geodesic (the paper's), euclidean or uniform
    #[arg(long, value_name = "PLACEMENT", default_value = "adaptive")]
    knots: KnotPlacement,
    /// Most GLS-PIA iterations, 0 to --max-iterations; a fit stops earlier when its error
    /// stagnates (the paper uses 30)
    #[arg(long, value_name = "N", default_value_t = crate::sphere::fit::DEFAULT_ITERATIONS)]
    iterations: usize,
    /// Data parameters: chord (cumulative geodesic distance), centripetal, uniform, or time
    /// (position as a function of each position's time; with --tolerance-m the bound is the
    /// synchronized distance; implied by --time-property and --spacing-s) [default: chord]
    #[arg(long, value_name = "METHOD")]
    parameterization: Option<ParameterizationOption>,
    /// With --parameterization time: the feature property holding one time per position
    /// (RFC 3339 strings or unix seconds) [default: the first of coordTimes, times, timestamps
    /// present, else the 4th coordinate of each position]
    #[arg(long, value_name = "NAME", alias = "time_property")]
    time_property: Option<String>,
    /// Optimiser: gls-pia-accelerated (the paper's iteration preconditioned by the banded
    /// normal matrix: its fixed point in a few passes), gls-pia (the paper's 30 plain
    /// iterations) or gauss-newton (the exact geodesic least-squares optimum)
    #[arg(long, value_name = "SOLVER", default_value = "gls-pia-accelerated")]
    solver: Solver,
    /// Move each position's parameter to its foot point on the curve between solver steps
    /// (false: chord-length parameters kept, as in the paper)
    #[arg(long, value_name = "BOOL", default_value_t = false, action = clap::ArgAction::Set)]
    parameter_correction: bool,
    /// Fit each curve to this tolerance, in metres: every position within it of the curve as
    /// returned, with as few stored numbers as the fitter finds (not with --control-points;
    /// --degree caps the degrees tried, at most 3) [default: none, a fit with --control-points]
    #[arg(
        long,
        value_name = "METRES",
        alias = "tolerance_m",
        allow_negative_numbers = true
    )]
    tolerance_m: Option<f64>,
    /// A polygon ring that collapses under the fit (an islet or a sliver narrower than the
    /// tolerance) is dropped and listed in properties.fit.dropped_rings, instead of kept as a
    /// small valid ring (listed in kept_rings); a polygon whose exterior ring is dropped is
    /// dropped with its holes, and a feature left with no polygon keeps its properties with an
    /// empty MultiPolygon
    #[arg(long, alias = "drop_small_rings", help_heading = "Fit")]
    drop_small_rings: bool,
    /// Most control points per curve (the service's SPHEREFIT_MAX_CONTROL_POINTS)
    #[arg(long, value_name = "N", default_value_t = Limits::default().max_control_points, help_heading = "Limits")]
    max_control_points: usize,
    /// Most GLS-PIA iterations per fit (the service's SPHEREFIT_MAX_ITERATIONS)
    #[arg(long, value_name = "N", default_value_t = Limits::default().max_iterations, help_heading = "Limits")]
    max_iterations: usize,
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
    fit: FitOptionArgs,
    #[command(flatten)]
    topology: topology::TopologyArgs,
    #[command(flatten)]
    output: OutputArgs,
    #[command(flatten)]
    batch: BatchArgs,
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
    shape: InterpolateOptionArgs,
    #[command(flatten)]
    output: OutputArgs,
    #[command(flatten)]
    batch: BatchArgs,
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
    at: Option<String>,
    #[command(flatten)]
    output: OutputArgs,
    #[command(flatten)]
    batch: BatchArgs,
}

/// `spherefit fit`: per feature, or (`--topology shared`) the input as one coverage.
pub(crate) fn fit(a: FitArgs) -> Result<(), Failure> {
    let job = fit_job(&a)?;
    match job.topology {
        Topology::Shared => topology::fit(job, &a.batch),
        Topology::PerFeature => run("fit", job, a.batch),
    }
}

impl FitOptionArgs {
    /// The options as given (those with defaults always given).
    fn raw(&self) -> RawOptions {
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
            ..RawOptions::default()
        }
    }

    /// The limits set by the fit's flags (`--max-samples` is an output option).
    fn limits(&self) -> Limits {
        Limits {
            max_control_points: self.max_control_points,
            max_iterations: self.max_iterations,
            ..Limits::default()
        }
    }
}

impl OutputArgs {
    /// Adds the output options to `raw`.
    fn fill(&self, raw: &mut RawOptions) {
        raw.samples = self.samples;
        raw.spacing_m = self.spacing_m;
        raw.spacing_s = self.spacing_s;
        raw.precision = Some(self.precision as usize);
    }

    /// The default limits with `--max-samples`.
    fn limits(&self) -> Limits {
        Limits {
            max_samples: self.max_samples,
            ..Limits::default()
        }
    }
}

/// The job of `spherefit fit`.
fn fit_job(a: &FitArgs) -> Result<Job, Failure> {
    let mut raw = a.fit.raw();
    a.output.fill(&mut raw);
    raw.topology = Some(a.topology.topology);
    raw.format = a.batch.output_format.topology_format();
    let limits = Limits {
        max_samples: a.output.max_samples,
        ..a.fit.limits()
    };
    job(raw, OperationKind::Fit, &limits)
}

/// `spherefit interpolate`.
pub(crate) fn interpolate(a: InterpolateArgs) -> Result<(), Failure> {
    let job = interpolate_job(&a)?;
    run("interpolate", job, a.batch)
}

/// The job of `spherefit interpolate`.
fn interpolate_job(a: &InterpolateArgs) -> Result<Job, Failure> {
    let mut raw = RawOptions {
        beta1: Some(a.shape.beta1),
        beta2: Some(a.shape.beta2),
        format: a.batch.output_format.topology_format(),
        ..RawOptions::default()
    };
    a.output.fill(&mut raw);
    job(raw, OperationKind::Interpolate, &a.output.limits())
}

/// `spherefit evaluate`.
pub(crate) fn evaluate(a: EvaluateArgs) -> Result<(), Failure> {
    let job = evaluate_job(&a)?;
    run("evaluate", job, a.batch)
}

/// The job of `spherefit evaluate`.
fn evaluate_job(a: &EvaluateArgs) -> Result<Job, Failure> {
    let mut raw = RawOptions {
        at: a.at.clone(),
        format: a.batch.output_format.topology_format(),
        ..RawOptions::default()
    };
    a.output.fill(&mut raw);
    job(raw, OperationKind::Evaluate, &a.output.limits())
}

/// The job of a command: its options checked by [`into_job`], as the service's query is.
fn job(raw: RawOptions, kind: OperationKind, limits: &Limits) -> Result<Job, Failure> {
    into_job(raw, kind, limits).map_err(Failure::option)
}

/// `--threads`: the size of the global worker pool (without it: RAYON_NUM_THREADS if set, else
/// one thread per CPU).
fn set_threads(threads: Option<usize>) -> Result<(), Failure> {
    if let Some(n) = threads {
        if n == 0 {
            return Err(Failure::input("--threads: use 1 or more"));
        }
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
            .map_err(|e| Failure::input(format!("--threads: {e}")))?;
    }
    Ok(())
}

/// The inputs named on the command line, checked before anything is read.
fn inputs(paths: &[PathBuf]) -> Result<Vec<Input>, Failure> {
    if paths.is_empty() {
        return Ok(vec![Input {
            name: "stdin".into(),
            path: None,
            size: None,
        }]);
    }
    let mut out = Vec::with_capacity(paths.len());
    let mut stdin_seen = false;
    for p in paths {
        if p.as_os_str() == "-" {
            if stdin_seen {
                return Err(Failure::input("stdin (`-`) can be read only once"));
            }
            stdin_seen = true;
            out.push(Input {
                name: "stdin".into(),
                path: None,
                size: None,
            });
            continue;
        }
        let meta =
            std::fs::metadata(p).map_err(|e| Failure::input(format!("{}: {e}", p.display())))?;
        if meta.is_dir() {
            return Err(Failure::input(format!(
                "{}: is a directory, not a GeoJSON file",
                p.display()
            )));
        }
        out.push(Input {
            name: p.display().to_string(),
            path: Some(p.clone()),
            size: meta.is_file().then_some(meta.len()),
        });
    }
    Ok(out)
}

/// True when `a` and `b` name the same existing file.
/// A temporary name beside `path` (same directory, so the rename does not cross file
/// systems): `.NAME.spherefit-PID.tmp`.
fn temp_beside(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map_or_else(|| "output".into(), |n| n.to_string_lossy().into_owned());
    path.with_file_name(format!(".{name}.spherefit-{}.tmp", std::process::id()))
}

fn same_file(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(x), Ok(y)) => x == y,
        _ => false,
    }
}

fn stderr_line(text: &str) {
    let _ = writeln!(io::stderr(), "{text}");
}

fn run(command: &'static str, job: Job, batch: BatchArgs) -> Result<(), Failure> {
    let started = Instant::now();
    let allow_spline = matches!(job.operation, crate::earth::Operation::Evaluate);
    topology::check_input_format(&batch)?;
    set_threads(batch.threads)?;
    let inputs = inputs(&batch.inputs)?;
    let out_path = batch.output.as_ref().filter(|p| p.as_os_str() != "-");
    if let Some(o) = out_path {
        if let Some(i) = inputs
            .iter()
            .find(|i| i.path.as_deref().is_some_and(|p| same_file(p, o)))
        {
            return Err(Failure::input(format!(
                "{}: the output would overwrite this input",
                i.name
            )));
        }
    }
    let first = input::open(&inputs[0], 0, batch.format).map_err(Failure::input)?;
    let out_format = [batch.output_format, batch.format, first.format]
        .into_iter()
        .find(|f| *f != Format::Auto)
        .unwrap_or(Format::Geojson);
    // A file is written beside its name and renamed when the run did not fail, so a run cut
    // short by a fatal error leaves no complete-looking output (and an existing file as it was).
    let temp_path = out_path.map(|p| temp_beside(p));
    let writer: Box<dyn Write> = match (out_path, &temp_path) {
        (Some(p), Some(t)) => Box::new(
            std::fs::File::create(t)
                .map_err(|e| Failure::input(format!("{}: {e}", p.display())))?,
        ),
        _ => Box::new(io::stdout().lock()),
    };
    let mut sink = Sink::new(io::BufWriter::with_capacity(256 << 10, writer), out_format);
    let total_bytes = inputs.iter().map(|i| i.size).sum::<Option<u64>>();
    let names: Vec<String> = inputs.iter().map(|i| i.name.clone()).collect();
    let settings = Settings {
        job: Arc::new(job),
        allow_spline,
        names: Arc::new(names),
        input_format: batch.format,
    };
    let rest: Vec<(usize, Input)> = inputs.into_iter().enumerate().skip(1).collect();
    let mut progress = TerminalProgress::new(
        !batch.quiet && io::stderr().is_terminal(),
        total_bytes,
        started,
    );
    let (totals, fatal) =
        pipeline::run(first, rest, &mut sink, &settings, &mut progress, &mut |m| {
            stderr_line(&format!("spherefit: {m}"))
        });
    let fatal = match sink.flush() {
        Err(e) if fatal.is_none() && !totals.output_closed => Some(Fatal::Output(e)),
        _ => fatal,
    };
    drop(sink);
    if let (Some(p), Some(t)) = (out_path, &temp_path) {
        if fatal.is_none() {
            std::fs::rename(t, p).map_err(|e| {
                let _ = std::fs::remove_file(t);
                Failure::input(format!("{}: cannot write: {e}", p.display()))
            })?;
        } else {
            let _ = std::fs::remove_file(t);
        }
    }
    let seconds = started.elapsed().as_secs_f64();
    let summary = Summary {
        command,
        totals: &totals,
        seconds,
        threads: rayon::current_num_threads(),
    };
    if !batch.quiet && !totals.output_closed {
        stderr_line(&summary.text());
        if let Some(w) = summary.warning() {
            stderr_line(&format!("spherefit {command}: warning: {w}"));
        }
    }
    if let Some(p) = &batch.stats {
        let text = summary.json().to_string();
        if p.as_os_str() == "-" {
            stderr_line(&text);
        } else {
            std::fs::write(p, format!("{text}\n"))
                .map_err(|e| Failure::input(format!("--stats: {}: {e}", p.display())))?;
        }
    }
    match fatal {
        Some(Fatal::Input(m)) => return Err(Failure::input(m)),
        Some(Fatal::Output(e)) => {
            let name = out_path.map_or("stdout".to_string(), |p| p.display().to_string());
            return Err(Failure::input(format!("{name}: cannot write: {e}")));
        }
        None => {}
    }
    if totals.failed > 0 {
        return Err(Failure {
            status: 1,
            message: format!(
                "{} of {} features failed (reported above); the others were written",
                totals.failed,
                totals.failed + totals.features
            ),
        });
    }
    Ok(())
}

/// The end-of-run summary, as text and JSON.
struct Summary<'a> {
    command: &'static str,
    totals: &'a Totals,
    seconds: f64,
    threads: usize,
}

impl Summary<'_> {
    /// Numbers in the input (lon and lat of each point) per number stored in the curves.
    fn compression_ratio(&self) -> Option<f64> {
        let s = &self.totals.stats;
        (s.stored_numbers > 0 && s.input_points > 0)
            .then(|| 2.0 * s.input_points as f64 / s.stored_numbers as f64)
    }

    fn points_per_second(&self) -> f64 {
        let s = &self.totals.stats;
        let points = if s.input_points > 0 {
            s.input_points
        } else {
            s.output_points
        };
        points as f64 / self.seconds.max(1e-9)
    }

    /// The largest max error of a curve and where (evaluation measures no error).
    fn worst(&self) -> Option<&(f64, String)> {
        self.totals
            .worst
            .as_ref()
            .filter(|_| self.command != "evaluate")
    }

    fn text(&self) -> String {
        let t = self.totals;
        let s = &t.stats;
        let mut line = format!(
            "spherefit {}: {} features written ({} with curves), {} failed, in {:.2} s ({:.0} points/s, {} threads)\n  {} points in, {} curves, {} numbers stored",
            self.command,
            t.features,
            t.with_curves,
            t.failed,
            self.seconds,
            self.points_per_second(),
            self.threads,
            s.input_points,
            s.curves,
            s.stored_numbers,
        );
        if let Some(r) = self.compression_ratio() {
            line.push_str(&format!(" (compression {r:.2}:1)"));
        }
        line.push_str(&format!(", {} points out", s.output_points));
        if let Some((e, at)) = self.worst() {
            line.push_str(&format!(", worst max error {e:.3} m ({at})"));
        }
        line
    }

    fn warning(&self) -> Option<String> {
        let t = self.totals;
        if t.failed > 0 || t.with_curves > 0 {
            return None;
        }
        Some(if t.records == 0 {
            "the input holds no records".into()
        } else if self.command == "evaluate" {
            "no feature carries properties.fit or properties.interpolation (as written by spherefit fit and interpolate): everything passed through unchanged".into()
        } else {
            "the input holds no LineString, MultiLineString, Polygon or MultiPolygon with coordinates: everything passed through unchanged".into()
        })
    }

    fn json(&self) -> serde_json::Value {
        let t = self.totals;
        let s = &t.stats;
        json!({
            "command": self.command,
            "records": t.records,
            "features": t.features,
            "features_with_curves": t.with_curves,
            "failed": t.failed,
            "curves": s.curves,
            "input_points": s.input_points,
            "output_points": s.output_points,
            "stored_numbers": s.stored_numbers,
            "compression_ratio": self.compression_ratio(),
            "max_error_m": self.worst().map(|w| w.0),
            "max_error_at": self.worst().map(|w| w.1.clone()),
            "seconds": self.seconds,
            "points_per_second": self.points_per_second(),
            "threads": self.threads,
            "output_closed": t.output_closed,
        })
    }
}

/// Progress on a terminal: one line, rewritten in place.
struct TerminalProgress {
    enabled: bool,
    shown: bool,
    total_bytes: Option<u64>,
    started: Instant,
}

impl TerminalProgress {
    fn new(enabled: bool, total_bytes: Option<u64>, started: Instant) -> TerminalProgress {
        TerminalProgress {
            enabled,
            shown: false,
            total_bytes,
            started,
        }
    }
}

/// `1:05` or `1:02:05`.
fn clock(seconds: f64) -> String {
    let s = seconds.max(0.0).round() as u64;
    if s >= 3600 {
        format!("{}:{:02}:{:02}", s / 3600, s / 60 % 60, s % 60)
    } else {
        format!("{}:{:02}", s / 60, s % 60)
    }
}

/// The progress line: features, points per second and, when the input size is known, the
/// share done and the ETA.
fn progress_line(totals: &Totals, bytes: u64, total_bytes: Option<u64>, elapsed_s: f64) -> String {
    let s = &totals.stats;
    let points = if s.input_points > 0 {
        s.input_points
    } else {
        s.output_points
    };
    let rate = points as f64 / elapsed_s.max(1e-9);
    let mut line = format!(
        "{} features, {} failed, {} points, {:.0} points/s",
        totals.features, totals.failed, points, rate
    );
    if let Some(total) = total_bytes.filter(|t| *t > 0) {
        let done = (bytes as f64 / total as f64).min(1.0);
        line.push_str(&format!(", {:.0} %", 100.0 * done));
        if done > 0.0 {
            let eta = elapsed_s * (1.0 - done) / done;
            line.push_str(&format!(", ETA {}", clock(eta)));
        }
    }
    line
}

impl Progress for TerminalProgress {
    fn update(&mut self, totals: &Totals, bytes: u64) {
        if !self.enabled {
            return;
        }
        let line = progress_line(
            totals,
            bytes,
            self.total_bytes,
            self.started.elapsed().as_secs_f64(),
        );
        let _ = write!(io::stderr(), "\r\x1b[K{line}");
        self.shown = true;
    }

    fn clear(&mut self) {
        if self.shown {
            let _ = write!(io::stderr(), "\r\x1b[K");
            self.shown = false;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::earth::FeatureStats;
    use crate::earth::{Operation, Sampling, TimeSource};
    use crate::sphere::{KnotPlacement, Parameterization, Solver};
    use clap::Parser;

    /// The batch commands alone, to parse their arguments.
    #[derive(Debug, Parser)]
    enum Cmd {
        Fit(FitArgs),
        Interpolate(InterpolateArgs),
        Evaluate(EvaluateArgs),
    }

    /// The job a command line makes (as `fit`, `interpolate` and `evaluate` make it).
    fn cli_job(args: &[&str]) -> Result<Job, Failure> {
        let cmd = Cmd::try_parse_from(std::iter::once("x").chain(args.iter().copied()))
            .map_err(Failure::input)?;
        match cmd {
            Cmd::Fit(a) => fit_job(&a),
            Cmd::Interpolate(a) => interpolate_job(&a),
            Cmd::Evaluate(a) => evaluate_job(&a),
        }
    }

    fn library_job(kind: OperationKind, raw: RawOptions) -> Job {
        into_job(raw, kind, &Limits::default()).unwrap()
    }

    /// Each flag lands in its field of the raw options (the rules are `into_job`'s, tested
    /// there); the defaults of the flags are the library's.
    #[test]
    fn flags_fill_the_raw_options_and_defaults_are_the_librarys() {
        assert_eq!(
            cli_job(&["fit"]).unwrap(),
            library_job(OperationKind::Fit, RawOptions::default())
        );
        assert_eq!(
            cli_job(&["interpolate"]).unwrap(),
            library_job(OperationKind::Interpolate, RawOptions::default())
        );
        assert_eq!(
            cli_job(&["evaluate"]).unwrap(),
            library_job(OperationKind::Evaluate, RawOptions::default())
        );
        let cli = cli_job(&[
            "fit",
            "--control-points",
            "12",
            "--degree",
            "2",
            "--knots",
            "uniform",
            "--iterations",
            "50",
            "--parameterization",
            "centripetal",
            "--spacing-m",
            "250",
            "--samples",
            "20",
            "--precision",
            "5",
            "--solver",
            "gls-pia",
            "--parameter-correction",
            "false",
        ])
        .unwrap();
        let library = library_job(
            OperationKind::Fit,
            RawOptions {
                control_points: Some(12),
                degree: Some(2),
                knots: Some(KnotPlacement::Uniform),
                iterations: Some(50),
                parameterization: Some(ParameterizationOption::Shape(
                    Parameterization::Centripetal,
                )),
                spacing_m: Some(250.0),
                samples: Some(20),
                precision: Some(5),
                solver: Some(Solver::GlsPia),
                parameter_correction: Some(false),
                ..RawOptions::default()
            },
        );
        assert_eq!(cli, library);
        let cli = cli_job(&[
            "fit",
            "--tolerance-m",
            "25",
            "--topology",
            "shared",
            "--output-format",
            "topojson",
            "--drop-small-rings",
        ])
        .unwrap();
        assert_eq!(
            (cli.topology, cli.format, cli.drop_small_rings),
            (Topology::Shared, crate::earth::OutputFormat::TopoJson, true)
        );
        assert_eq!(
            cli_job(&["fit", "--time-property", "when", "--spacing-s", "30"])
                .unwrap()
                .time
                .fit_in_time,
            Some(TimeSource::Property("when".into()))
        );
        let at = cli_job(&["evaluate", "--at", "1,2010-10-03T09:36:30Z"]).unwrap();
        assert_eq!(at.time.at_unix_s, Some(vec![1.0, 1286098590.0]));
        assert_eq!(at.operation, Operation::Evaluate);
        assert_eq!(
            cli_job(&["interpolate", "--beta1", "2", "--samples", "40"])
                .unwrap()
                .output
                .sampling,
            Sampling::Samples(40)
        );
    }

    #[test]
    fn refused_options_name_the_flag() {
        for (args, flag) in [
            (&["fit", "--degree", "9"][..], "--degree"),
            (&["fit", "--control-points", "2"][..], "--control-points"),
            (&["fit", "--samples", "1"][..], "--samples"),
            (&["fit", "--precision", "16"][..], "--precision"),
            (&["fit", "--spacing-m", "-5"][..], "--spacing-m"),
            (&["fit", "--tolerance-m", "0"][..], "--tolerance-m"),
            (&["interpolate", "--beta1", "0"][..], "--beta1"),
            (&["interpolate", "--beta2", "-1"][..], "--beta2"),
            (&["fit", "--spacing-s", "0"][..], "--spacing-s"),
            (&["interpolate", "--spacing-s", "10"][..], "--spacing-s"),
            (&["evaluate", "--at", "1,2", "--samples", "5"][..], "--at"),
            (&["evaluate", "--at", "1,,2"][..], "--at"),
            (
                &["fit", "--tolerance-m", "10", "--control-points", "5"][..],
                "--tolerance-m: --tolerance-m excludes --control-points",
            ),
            (
                &["fit", "--spacing-s", "10", "--samples", "5"][..],
                "--spacing-s: --spacing-s excludes --samples",
            ),
            (
                &["fit", "--parameterization", "chord", "--time-property", "t"][..],
                "--time-property: --time-property excludes --parameterization chord",
            ),
            (
                &["fit", "--topology", "shared"][..],
                "--topology: shared topology fits every border to a tolerance: give --tolerance-m too",
            ),
            (
                &["fit", "--output-format", "topojson"][..],
                "--output-format: TopoJSON",
            ),
            (
                &["interpolate", "--output-format", "topojson"][..],
                "--output-format: not an option of interpolate",
            ),
        ] {
            let e = cli_job(args).unwrap_err();
            assert_eq!(e.status, 2, "{args:?}");
            assert!(e.message.starts_with(flag), "{args:?}: {}", e.message);
            assert!(!e.message.contains("server"), "{}", e.message);
        }
    }

    #[test]
    fn the_progress_line_has_rate_share_and_eta() {
        let t = Totals {
            features: 10,
            stats: FeatureStats {
                input_points: 1000,
                ..FeatureStats::default()
            },
            ..Totals::default()
        };
        let line = progress_line(&t, 250, Some(1000), 2.0);
        assert_eq!(
            line,
            "10 features, 0 failed, 1000 points, 500 points/s, 25 %, ETA 0:06"
        );
        assert_eq!(clock(3725.0), "1:02:05");
        assert!(!progress_line(&t, 250, None, 2.0).contains("ETA"));
    }

    #[test]
    fn the_summary_reports_the_compression_ratio() {
        let t = Totals {
            features: 3,
            with_curves: 2,
            stats: FeatureStats {
                input_points: 400,
                stored_numbers: 100,
                ..FeatureStats::default()
            },
            worst: Some((12.5, "a: record 2".into())),
            ..Totals::default()
        };
        let s = Summary {
            command: "fit",
            totals: &t,
            seconds: 1.0,
            threads: 2,
        };
        assert_eq!(s.compression_ratio(), Some(8.0));
        assert!(s.text().contains("compression 8.00:1"));
        assert!(s.text().contains("worst max error 12.500 m (a: record 2)"));
        assert_eq!(s.json()["max_error_at"], "a: record 2");
        assert!(s.warning().is_none());
    }
}
