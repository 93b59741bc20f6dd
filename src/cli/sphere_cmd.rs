//! `spherefit sphere fit | evaluate`: the math core on S^n, JSON in and out.

use super::{read_json, write_json, Failure};
use crate::sphere::document::{spline_from_json, FitDocument, PointsInput, SamplesDocument};
use crate::sphere::{fit, FitOptions, KnotPlacement, Parameterization, StepRule};
use crate::sphere::{SphericalBSpline, SphericalCurve};
use clap::{Args, Subcommand};
use std::path::PathBuf;

#[derive(Debug, Subcommand)]
pub(crate) enum SphereCommand {
    /// Fit a spherical B-spline to ordered points with GLS-PIA.
    ///
    /// Input: {"points": [[x, y, z, ...], ...], "parameters": [...]} (parameters optional, e.g.
    /// timestamps; one per point, non-decreasing) or a bare array of points. Points are unit
    /// vectors of any dimension >= 2 (S^1 and up). Output: {"spline", "parameters", "metrics",
    /// "history"}; errors are geodesic, in radians, at the data parameters.
    Fit(FitArgs),
    /// Evaluate a spline document (or a `sphere fit` output) at parameters.
    ///
    /// Output: {"parameters": [...], "points": [[...], ...]}.
    Evaluate(EvaluateArgs),
}

#[derive(Debug, Args)]
pub(crate) struct FitArgs {
    /// Number of control points [default: a quarter of the points, at least degree + 1]
    #[arg(long, short = 'n')]
    control_points: Option<usize>,
    /// Polynomial degree, 1 to 5
    #[arg(long, default_value_t = 3)]
    degree: usize,
    /// Knot placement: geodesic (paper), euclidean or uniform
    #[arg(long, default_value = "geodesic")]
    knots: KnotPlacement,
    /// Maximum number of GLS-PIA iterations (the paper uses 30)
    #[arg(long, default_value_t = 30)]
    iterations: usize,
    /// Data parameters when none are given: chord (geodesic length), centripetal or uniform
    #[arg(long, default_value = "chord")]
    parameterization: Parameterization,
    /// Step size: deng-lin (per control point), global (1/λmax of AᵀA) or a number
    #[arg(long, default_value = "deng-lin")]
    step: StepRule,
    /// Stop early once the max error is at or below this, in radians
    #[arg(long)]
    target_max_error_rad: Option<f64>,
    /// Input JSON file; `-` or absent reads stdin
    file: Option<PathBuf>,
}

#[derive(Debug, Args)]
pub(crate) struct EvaluateArgs {
    /// Number of evenly spaced parameters over the curve's domain, ends included
    #[arg(long, default_value_t = 101, conflicts_with = "at")]
    samples: usize,
    /// Comma-separated parameters to evaluate at (clamped to the domain)
    #[arg(long, value_delimiter = ',', allow_negative_numbers = true)]
    at: Option<Vec<f64>>,
    /// Input JSON file; `-` or absent reads stdin
    file: Option<PathBuf>,
}

pub(crate) fn run(cmd: SphereCommand) -> Result<(), Failure> {
    match cmd {
        SphereCommand::Fit(a) => fit_cmd(a),
        SphereCommand::Evaluate(a) => evaluate_cmd(a),
    }
}

fn fit_cmd(a: FitArgs) -> Result<(), Failure> {
    let input = PointsInput::from_json(&read_json(a.file.as_ref())?).map_err(Failure::input)?;
    let mut options = FitOptions::default()
        .with_degree(a.degree)
        .with_knots(a.knots)
        .with_iterations(a.iterations)
        .with_parameterization(a.parameterization)
        .with_step(a.step);
    options.control_points = a.control_points;
    options.target_max_error_rad = a.target_max_error_rad;
    let report = fit(&input.points, input.parameters.as_deref(), &options).map_err(|e| {
        let field = match e {
            crate::sphere::SphereError::InvalidDegree { .. } => "--degree",
            crate::sphere::SphereError::InvalidControlPointCount { .. } => "--control-points",
            crate::sphere::SphereError::InvalidParameters { .. } => "parameters",
            _ => "points",
        };
        Failure::input(format!("{field}: {e}"))
    })?;
    write_json(&FitDocument::from(&report))
}

fn evaluate_cmd(a: EvaluateArgs) -> Result<(), Failure> {
    let v = read_json(a.file.as_ref())?;
    let spline: SphericalBSpline = spline_from_json(&v).map_err(Failure::input)?;
    let ts = match a.at {
        Some(ts) => {
            if let Some(i) = ts.iter().position(|t| !t.is_finite()) {
                return Err(Failure::input(format!(
                    "--at: value {i} is not a finite number"
                )));
            }
            ts
        }
        None => crate::sphere::curve::even_parameters(spline.domain(), a.samples),
    };
    let pts = SphericalCurve::evaluate_many(&spline, &ts);
    write_json(&SamplesDocument {
        parameters: ts,
        points: pts.to_rows(),
    })
}
