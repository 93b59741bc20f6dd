//! `spherefit sphere fit | interpolate | evaluate`: the math core on S^n, JSON in and out.

use crate::cli::{read_json, write_json, Failure};
use crate::document::beta::{curve_from_json, InterpolationDocument};
use crate::document::pointer;
use crate::document::{tolerance_document, FitDocument, PointsInput, SamplesDocument};
use crate::sphere::compare::{fit_with, CompareError, Method, MethodOptions};
use crate::sphere::compress::tolerance::{fit_to_tolerance, ToleranceOptions};
use crate::sphere::curve::SphericalCurve;
use crate::sphere::fit;
use crate::sphere::fit::knots::{KnotPlacement, Parameterization};
use crate::sphere::fit::options::{FitOptions, Solver, StepRule};
use crate::sphere::fit::options_check::{check_given_together, check_tolerance_fit};
use crate::sphere::interpolate::beta::{BetaSolver, InterpolationOptions};
use crate::sphere::{interpolate, InputSite, SphereError};
use clap::{Args, Subcommand};
use std::path::PathBuf;

/// Most points `evaluate --samples` writes: about 1 GB of JSON on S^2; beyond that the output
/// is no longer a document anyone can read, and a typo must not exhaust memory.
const MAX_SAMPLES: usize = 10_000_000;

/// Points `evaluate` writes without `--samples` or `--at`, as the service.
const DEFAULT_SAMPLES: usize = 101;

#[derive(Debug, Subcommand)]
pub(crate) enum SphereCommand {
    /// Fit a spherical B-spline to ordered points with GLS-PIA.
    ///
    /// Input: {"points": [[x, y, z, ...], ...], "parameters": [...]} (parameters optional, e.g.
    /// timestamps; one per point, non-decreasing) or a bare array of points. Points are unit
    /// vectors of any dimension >= 2 (S^1 and up). Output: {"spline", "parameters", "metrics",
    /// "history"}; errors are geodesic, in radians, at the data parameters.
    Fit(FitArgs),
    /// Interpolate ordered points with a spherical Beta-spline: a G1 curve through every point.
    ///
    /// Input: as for `fit`, without "parameters" (the curve is at point j at parameter j).
    /// Output: {"curve": {"type": "beta", "beta1", "beta2", "segments": [[q0, q1, q2, q3],
    /// ...]}, "residual_rad", "iterations"}: cubic spherical Bezier segments, segment i on
    /// parameters [i, i+1]; residual_rad is the largest angle between the curve and a point.
    /// Shape parameters that cannot be met fail with exit status 2, naming the point.
    Interpolate(InterpolateArgs),
    /// Evaluate a curve at parameters: a spline document or `fit` output, or a Beta-spline
    /// document or `interpolate` output.
    ///
    /// Output: {"parameters": [...], "points": [[...], ...]}.
    Evaluate(EvaluateArgs),
}

#[derive(Debug, Args)]
pub(crate) struct InterpolateArgs {
    /// Bias beta1 > 0, the ratio of outgoing to incoming speed at a point: one value for every
    /// point, or comma-separated values, one per point
    #[arg(
        long,
        value_delimiter = ',',
        allow_negative_numbers = true,
        default_value = "1"
    )]
    beta1: Vec<f64>,
    /// Tension beta2 >= 0 (higher pulls the curve towards the point polygon): one value for
    /// every point, or comma-separated values, one per point
    #[arg(
        long,
        value_delimiter = ',',
        allow_negative_numbers = true,
        default_value = "0"
    )]
    beta2: Vec<f64>,
    /// Solver for the auxiliary vertices: newton, or jacobi (the paper's eq. 19)
    #[arg(long, default_value = "newton")]
    solver: BetaSolver,
    /// Iteration limit [default: 50 for newton, 5000 for jacobi]
    #[arg(long)]
    max_iterations: Option<usize>,
    /// Input JSON file; `-` or absent reads stdin
    file: Option<PathBuf>,
}

#[derive(Debug, Args)]
pub(crate) struct FitArgs {
    /// Number of control points [default: a quarter of the points, at least degree + 1]
    #[arg(long, short = 'n')]
    control_points: Option<usize>,
    /// Polynomial degree, 1 to 5
    #[arg(long, default_value_t = 3)]
    degree: usize,
    /// Knot placement: geodesic (paper), euclidean or uniform [default: geodesic]
    #[arg(long)]
    knots: Option<KnotPlacement>,
    /// Maximum number of GLS-PIA iterations (the paper uses 30) [default: 30]
    #[arg(long)]
    iterations: Option<usize>,
    /// Data parameters when none are given: chord (geodesic length), centripetal or uniform
    #[arg(long, default_value = "chord")]
    parameterization: Parameterization,
    /// Step size: deng-lin (per control point), global (1/λmax of AᵀA) or a number
    /// [default: deng-lin]
    #[arg(long)]
    step: Option<StepRule>,
    /// Optimiser: gls-pia (the paper) or gauss-newton (the least-squares optimum in a few
    /// passes) [default: gls-pia]
    #[arg(long)]
    solver: Option<Solver>,
    /// Stop early once the max error is at or below this, in radians
    #[arg(long)]
    target_max_error_rad: Option<f64>,
    /// Fit to a tolerance instead, in radians: every point within it of the curve, with as few
    /// stored numbers as the fitter finds (degree 1 to 3 chosen per input, control points and
    /// knots found; not with --control-points, --knots, --iterations, --step, --solver or
    /// --target-max-error-rad). The output then has a "tolerance" object instead of "history"
    #[arg(long)]
    tolerance_rad: Option<f64>,
    /// Method: gls-pia (the paper's B-spline) or one it compares itself with: jupp-kent,
    /// samir, cbc or bcc, which write {"method", "parameters", "fitted_points", "metrics",
    /// "iterations", "converged", "free_points", "curve": {"type": "polyline", ...}}
    /// (docs/paper.md) [default: gls-pia]
    #[arg(long)]
    method: Option<Method>,
    /// Input JSON file; `-` or absent reads stdin
    file: Option<PathBuf>,
}

#[derive(Debug, Args)]
pub(crate) struct EvaluateArgs {
    /// Number of evenly spaced parameters over the curve's domain, ends included (not with
    /// --at) [default: 101]
    #[arg(long)]
    samples: Option<usize>,
    /// Comma-separated parameters to evaluate at (clamped to the domain; not with --samples)
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    at: Option<Vec<f64>>,
    /// Input JSON file; `-` or absent reads stdin
    file: Option<PathBuf>,
}

pub(crate) fn run(cmd: SphereCommand) -> Result<(), Failure> {
    match cmd {
        SphereCommand::Fit(a) => fit_cmd(a),
        SphereCommand::Interpolate(a) => interpolate_cmd(a),
        SphereCommand::Evaluate(a) => evaluate_cmd(a),
    }
}

/// The names of the options marked given (a flag on the command line), for
/// [`check_given_together`].
fn given<const N: usize>(options: [(&'static str, bool); N]) -> Vec<&'static str> {
    options
        .into_iter()
        .filter_map(|(name, given)| given.then_some(name))
        .collect()
}

fn fit_cmd(a: FitArgs) -> Result<(), Failure> {
    if let Some(method) = a.method.filter(|&m| m != Method::GlsPia) {
        return method_cmd(a, method);
    }
    check_given_together(&given([
        ("control_points", a.control_points.is_some()),
        ("knots", a.knots.is_some()),
        ("iterations", a.iterations.is_some()),
        ("step", a.step.is_some()),
        ("solver", a.solver.is_some()),
        ("target_max_error_rad", a.target_max_error_rad.is_some()),
        ("tolerance_rad", a.tolerance_rad.is_some()),
    ]))
    .map_err(|e| Failure::option(e.into()))?;
    crate::earth::check_target_max_error_rad(a.target_max_error_rad).map_err(Failure::option)?;
    check_tolerance_fit(a.tolerance_rad).map_err(|e| Failure::option(e.into()))?;
    let input = PointsInput::from_json(&read_json(a.file.as_ref())?).map_err(Failure::input)?;
    let d = FitOptions::default();
    let options = FitOptions {
        control_points: a.control_points,
        degree: a.degree,
        knots: a.knots.unwrap_or(d.knots),
        iterations: a.iterations.unwrap_or(d.iterations),
        parameterization: a.parameterization,
        step: a.step.unwrap_or(d.step),
        solver: a.solver.unwrap_or(d.solver),
        target_max_error_rad: a.target_max_error_rad,
        ..d
    };
    if let Some(tolerance_rad) = a.tolerance_rad {
        return tolerance_cmd(&input, tolerance_rad, a.degree, a.parameterization);
    }
    let report = fit(&input.points, input.parameters.as_deref(), &options)
        .map_err(|e| sphere_failure(&e, input.points_pointer))?;
    write_json(&FitDocument::from(&report))
}

/// `sphere fit --method jupp-kent|samir|cbc|bcc`: `sphere::compare`. `--control-points` is
/// the budget of free points, `--iterations` caps the iterative methods; the options of the
/// B-spline fit alone are refused.
fn method_cmd(a: FitArgs, method: Method) -> Result<(), Failure> {
    let only_gls_pia = [
        ("degree", a.degree != 3),
        ("knots", a.knots.is_some()),
        ("step", a.step.is_some()),
        ("solver", a.solver.is_some()),
        ("target_max_error_rad", a.target_max_error_rad.is_some()),
        ("tolerance_rad", a.tolerance_rad.is_some()),
    ];
    if let Some((name, _)) = only_gls_pia.iter().find(|(_, given)| *given) {
        return Err(Failure::input(format!(
            "{}: applies to --method gls-pia only, not {}",
            super::flag(name),
            method.name()
        )));
    }
    let input = PointsInput::from_json(&read_json(a.file.as_ref())?).map_err(Failure::input)?;
    let options = MethodOptions {
        control_points: a.control_points,
        iterations: a.iterations,
        gls_pia: FitOptions {
            parameterization: a.parameterization,
            ..FitOptions::default()
        },
        ..MethodOptions::default()
    };
    let r = fit_with(method, &input.points, input.parameters.as_deref(), &options).map_err(
        |e| match e {
            CompareError::Sphere(e) => sphere_failure(&e, input.points_pointer),
            CompareError::InvalidOption { option, .. } => {
                Failure::input(format!("{}: {e}", super::flag(option)))
            }
            e => Failure::input(format!("{}: {e}", input.points_pointer)),
        },
    )?;
    write_json(&r.document())
}

/// `sphere fit --tolerance-rad`: the tolerance fitter of `sphere::compress::tolerance`. `--degree` caps
/// the degrees tried (1 ..= degree, at most 3).
fn tolerance_cmd(
    input: &PointsInput,
    tolerance_rad: f64,
    degree: usize,
    parameterization: Parameterization,
) -> Result<(), Failure> {
    let mut options = ToleranceOptions {
        parameterization,
        ..ToleranceOptions::default()
    };
    options.degrees.retain(|&p| p <= degree.max(1));
    let r = fit_to_tolerance(
        &input.points,
        input.parameters.as_deref(),
        tolerance_rad,
        &options,
    )
    .map_err(|e| sphere_failure(&e, input.points_pointer))?;
    write_json(&tolerance_document(&r))
}

fn interpolate_cmd(a: InterpolateArgs) -> Result<(), Failure> {
    let v = read_json(a.file.as_ref())?;
    let input = PointsInput::from_json(&v).map_err(Failure::input)?;
    if input.parameters.is_some() {
        return Err(Failure::input(
            "/parameters: interpolate takes no parameters: the Beta-spline is at point j at \
             parameter j; shape it with --beta1 and --beta2",
        ));
    }
    let mut options = InterpolationOptions::default()
        .with_beta1_per_point(a.beta1)
        .with_beta2_per_point(a.beta2)
        .with_solver(a.solver);
    options.max_iterations = a.max_iterations;
    let result = interpolate(&input.points, &options)
        .map_err(|e| sphere_failure(&e, input.points_pointer))?;
    write_json(&InterpolationDocument::from(&result))
}

/// A math-core error as the command line words it: the place ([`SphereError::site`]) first,
/// an option as its flag (`--degree`, `--beta2, value 2`), anything in the input as a JSON
/// pointer (`/points/3`, `/parameters`) below the document whose points are at `points`.
fn sphere_failure(e: &SphereError, points: &str) -> Failure {
    let place = match e.site() {
        InputSite::Field { name, index } => {
            let flag = super::flag(name);
            match index {
                Some(i) => format!("{flag}, value {i}"),
                None => flag,
            }
        }
        site => match pointer(site, "", points) {
            p if p.is_empty() => "(document)".to_string(),
            p => p,
        },
    };
    let message = match e {
        // The place names the option and the value: say what is wrong with it.
        SphereError::InvalidShapeParameter { value, rule, .. } => {
            format!("{value} is out of range: {rule}")
        }
        _ => e.to_string(),
    };
    Failure::input(format!("{place}: {message}"))
}

fn evaluate_cmd(a: EvaluateArgs) -> Result<(), Failure> {
    check_given_together(&given([
        ("samples", a.samples.is_some()),
        ("at", a.at.is_some()),
    ]))
    .map_err(|e| Failure::option(e.into()))?;
    let v = read_json(a.file.as_ref())?;
    let curve = curve_from_json(&v).map_err(Failure::input)?;
    let samples = a.samples.unwrap_or(DEFAULT_SAMPLES);
    let ts = match a.at {
        Some(ts) => {
            if let Some(i) = ts.iter().position(|t| !t.is_finite()) {
                return Err(Failure::input(format!(
                    "--at: value {i} is not a finite number"
                )));
            }
            ts
        }
        None if samples == 0 => {
            return Err(Failure::input(
                "--samples: 0 points: give at least 1 (the service says the same)",
            ))
        }
        None if samples > MAX_SAMPLES => {
            return Err(Failure::input(format!(
                "--samples: {samples} is more than the {MAX_SAMPLES} points one document may hold"
            )))
        }
        None => crate::sphere::curve::even_parameters(curve.domain(), samples),
    };
    let pts = curve.evaluate_many(&ts);
    write_json(&SamplesDocument {
        parameters: ts,
        points: pts.to_rows(),
    })
}
