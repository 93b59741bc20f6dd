//! The curves of one geometry made in parallel, each by the job's operation; small rings kept.

use crate::earth::curve::fitting::{fit_line, fit_line_to_tolerance};
use crate::earth::curve::interpolation::interpolate_line;
use crate::earth::curve::line::OutputSpec;
use crate::earth::curve::output::CurveOutput;
use crate::earth::curve::stored::evaluate_curve;
use crate::earth::error::{EarthError, Problem};
use crate::earth::features::CurveJob;
use crate::earth::job::{Job, Operation};
use crate::earth::polygon::small_rings;
use rayon::prelude::{IntoParallelRefIterator, ParallelIterator};
use serde_json::Value;

/// Runs the curves of one geometry in parallel; the first error in order wins.
pub(super) fn run_curves(jobs: &[CurveJob<'_>], job: &Job) -> Result<Vec<CurveOutput>, EarthError> {
    let one = |c: &CurveJob<'_>| {
        if matches!(job.operation, Operation::Evaluate) {
            check_stored_size(c, &job.limits)?;
        }
        // The job's token, entered on whichever (rayon) thread runs this curve: the fitters
        // inside see it even where their options inherit.
        let _scope = job.cancel.enter();
        job.cancel
            .check()
            .map_err(|e| EarthError::new(c.pointer.clone(), Problem::Fit(e)))?;
        let made = one_curve(c, job);
        if !c.closed || matches!(job.operation, Operation::Evaluate) {
            return made;
        }
        // A ring too small to fit, or one whose fit collapsed, is kept (small_rings): a
        // feature is never refused for one of its rings being small.
        let tolerance_m = match &job.operation {
            Operation::FitToTolerance { tolerance_m, .. } => Some(*tolerance_m),
            _ => None,
        };
        match made {
            Err(e) if matches!(e.problem, Problem::TooFewPoints { .. }) => {
                small_rings::keep(c.value, &c.pointer, c.path.clone(), tolerance_m).map(|k| k.0)
            }
            Ok(out) if small_rings::collapsed(&out, job.output.precision) => {
                small_rings::keep(c.value, &c.pointer, c.path.clone(), tolerance_m).map(|k| k.0)
            }
            other => other,
        }
    };
    if jobs.len() == 1 {
        return Ok(vec![one(&jobs[0])?]);
    }
    jobs.par_iter()
        .map(one)
        .collect::<Vec<_>>()
        .into_iter()
        .collect()
}

/// A stored curve with more control points (or segments) than the limit is refused before it is
/// read.
pub(super) fn check_stored_size(
    c: &CurveJob<'_>,
    limits: &crate::earth::Limits,
) -> Result<(), EarthError> {
    for key in ["control_points", "segments"] {
        if let Some(n) = c.value.get(key).and_then(Value::as_array).map(Vec::len) {
            if n > limits.max_control_points {
                return Err(EarthError::new(
                    format!("{}/{key}", c.pointer),
                    Problem::InvalidSpline(format!(
                        "{n} {}, more than the limit of {} per curve",
                        key.replace('_', " "),
                        limits.max_control_points
                    )),
                ));
            }
        }
    }
    Ok(())
}

/// One curve of [`run_curves`].
pub(super) fn one_curve(c: &CurveJob<'_>, job: &Job) -> Result<CurveOutput, EarthError> {
    let out = output_spec(job);
    match &job.operation {
        Operation::Fit(o) => fit_line(c.line(), o, c.times.as_ref(), out),
        Operation::FitToTolerance {
            options,
            tolerance_m,
        } => fit_line_to_tolerance(c.line(), options, *tolerance_m, c.times.as_ref(), out),
        Operation::Interpolate(s) => interpolate_line(c.line(), s, out),
        Operation::Evaluate => evaluate_curve(
            c.line(),
            c.known_error_m,
            c.time_doc.as_ref().map(|(v, p)| (*v, p.as_str())),
            out,
        ),
    }
}

/// The output options and limits of `job`.
pub(super) fn output_spec(job: &Job) -> OutputSpec<'_> {
    OutputSpec {
        output: &job.output,
        limits: &job.limits,
    }
}
