//! [`into_job`]: the rules between options (what excludes or implies what), the defaults, and
//! the [`Job`] they make.

use crate::earth::error::{EarthError, Problem};
use crate::earth::job::checks::invalid_option;
use crate::earth::job::grid::topojson_grid_multiple;
use crate::earth::job::raw::{
    Carry, OperationKind, OutputFormat, ParameterizationOption, RawOptions, Topology,
};
use crate::earth::job::{
    precision_for_tolerance, InterpolateSettings, Job, Limits, Operation, OutputOptions,
    TimeOptions, DEFAULT_PRECISION,
};
use crate::earth::sampling::Sampling;
use crate::earth::time::TimeSource;
use crate::sphere::cancel::Cancel;
use crate::sphere::fit::options::FitOptions;

pub(super) fn conflict(option: &'static str, other: impl Into<String>, reason: &str) -> EarthError {
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
/// * Defaults: the fit's are [`FitOptions::faithful`], precision [`DEFAULT_PRECISION`] (with
///   `tolerance_m`, [`precision_for_tolerance`]: the output is sized by the tolerance),
///   per-feature topology, GeoJSON output, small rings kept, features carrying both geometry
///   and spline.
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
        Some(v) => Some(crate::earth::time::parse_time_list(v).map_err(|m| {
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
    let mut job = Job {
        operation,
        output: OutputOptions {
            sampling,
            // A tolerance sizes a compact output (carry geometry or spline) unless the
            // precision is given. Not the default output: refits of polygons that would
            // cross (tightened down to 1 cm) and rings kept whole when too small to fit need
            // finer than the tolerance's grid, which `carry=both` keeps as before.
            precision: match (raw.precision, raw.tolerance_m) {
                (Some(n), _) => u32::try_from(n).unwrap_or(u32::MAX),
                (None, Some(t))
                    if kind == OperationKind::Fit
                        && raw.carry.is_some_and(|c| c != Carry::Both) =>
                {
                    precision_for_tolerance(t)
                }
                (None, _) => DEFAULT_PRECISION,
            },
            compact_splines: raw.carry == Some(Carry::Spline),
            splines_refer_to_geometry: true,
            grid_multiple: 1,
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
        carry: raw.carry.unwrap_or_default(),
    };
    // A coverage written as TopoJSON, its precision chosen by the tolerance: a coarser grid
    // of those decimals (see `grid`).
    if let (None, Some(t)) = (raw.precision, raw.tolerance_m) {
        if job.format == OutputFormat::TopoJson
            && job.topology == Topology::Shared
            && job.output.precision == precision_for_tolerance(t)
            && kind == OperationKind::Fit
            && job.carry != Carry::Both
        {
            job.output.grid_multiple = topojson_grid_multiple(t, job.output.precision);
        }
    }
    job.validate()?;
    Ok(job)
}
