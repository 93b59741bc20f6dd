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
//! * [`args`]: the flags and the [`Job`] they make (through [`crate::earth::into_job`]).
//! * [`topology`]: `--topology shared`, the input fitted whole as one coverage.
//! * [`summary`], [`progress`]: what the run reports on stderr.
//!
//! Exit status: 0 when every record succeeded, 1 when some failed (each is reported on stderr
//! with its record number and the reason, and the others are written), 2 for usage errors,
//! inputs or outputs that cannot be read or written at all, and compact curves that do not
//! decode (corrupt input; the other records are still written).

mod input;
mod pipeline;
mod topology;

use crate::cli::Failure;

use crate::earth::job::{Job, ParameterizationOption, Topology};
use crate::formats::write::FeatureWriter;
use crate::formats::{Kind, ReadOptions};

use input::{Format, Input};
use pipeline::{Fatal, Settings, Sink};
use std::io::{self, IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

mod args;
mod progress;
mod summary;
#[cfg(test)]
mod tests;

use args::{evaluate_job, fit_job, interpolate_job, BatchArgs};
pub(crate) use args::{EvaluateArgs, FitArgs, InterpolateArgs};
use progress::TerminalProgress;
use summary::Summary;

/// `spherefit fit`: per feature, or (`--topology shared`) the input as one coverage.
pub(crate) fn fit(mut a: FitArgs) -> Result<(), Failure> {
    // A GPX track's times are its parameterisation unless the command says otherwise.
    if a.fit.parameterization.is_none()
        && a.fit.time_property.is_none()
        && first_is_gpx(&a.common.batch)
    {
        a.fit.parameterization = Some(ParameterizationOption::Time);
    }
    let job = fit_job(&a)?;
    match job.topology {
        Topology::Shared => topology::fit(job, &a.common.batch),
        Topology::PerFeature => run("fit", job, a.common.batch),
    }
}

/// True when the first input is a GPX file (by `--format`, its first bytes or its name).
fn first_is_gpx(batch: &BatchArgs) -> bool {
    if batch.format != Format::Auto {
        return batch.format == Format::Gpx;
    }
    let Some(p) = batch.inputs.first().filter(|p| p.as_os_str() != "-") else {
        return false;
    };
    let mut head = Vec::with_capacity(1024);
    let read = std::fs::File::open(p)
        .and_then(|f| std::io::Read::read_to_end(&mut std::io::Read::take(f, 1024), &mut head));
    read.is_ok() && Kind::detect(Some(p), &head) == Some(Kind::Gpx)
}

/// `spherefit interpolate`.
pub(crate) fn interpolate(a: InterpolateArgs) -> Result<(), Failure> {
    let job = interpolate_job(&a)?;
    run("interpolate", job, a.common.batch)
}

/// `spherefit evaluate`.
pub(crate) fn evaluate(a: EvaluateArgs) -> Result<(), Failure> {
    let job = evaluate_job(&a)?;
    run("evaluate", job, a.common.batch)
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

/// The output format: `--output-format`, else the format `-o`'s extension names (`.gpkg`,
/// `.fgb`, `.shp`, `.gpx`), else the input's (`--format`, else the first input's) when it is
/// GeoJSON or a GeoJSON sequence, else GeoJSON.
fn output_format(batch: &BatchArgs, first: Format, out: Option<&Path>) -> Result<Format, Failure> {
    let by_name = out
        .and_then(Kind::from_extension)
        .map(Format::of_kind)
        .filter(|f| f.is_file_output());
    let format = [batch.output_format]
        .into_iter()
        .chain(by_name)
        .chain(
            [batch.format, first]
                .into_iter()
                .filter(|f| !f.is_file_output() && *f != Format::Topojson),
        )
        .find(|f| *f != Format::Auto)
        .unwrap_or(Format::Geojson);
    if format.is_file_output() && out.is_none() {
        return Err(Failure::input(format!(
            "--output-format {}: this format is written to a file: add -o FILE",
            format.kind().map_or("?", Kind::name)
        )));
    }
    Ok(format)
}

/// A temporary name beside `path` (same directory, so the rename does not cross file
/// systems): `.NAME.spherefit-PID.tmp`.
fn temp_beside(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map_or_else(|| "output".into(), |n| n.to_string_lossy().into_owned());
    path.with_file_name(format!(".{name}.spherefit-{}.tmp", std::process::id()))
}

/// Whether `path` is written through a temporary file renamed into place: a new name or a
/// regular file. Anything else is written where it is: a device or a FIFO (`-o /dev/null`,
/// `-o /dev/stdout`), which a rename would replace with a plain file (run as root, that turned
/// the machine's `/dev/null` into a file), and a symbolic link, which a rename would replace
/// instead of writing the file it points to.
fn written_via_temp(path: &Path) -> bool {
    std::fs::symlink_metadata(path).map_or(true, |m| m.file_type().is_file())
}

/// True when `a` and `b` name the same existing file.
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
    let read_options = ReadOptions {
        layer: batch.layer.clone(),
    };
    let first = input::open(&inputs[0], 0, batch.format, &read_options).map_err(Failure::input)?;
    if !batch.quiet {
        for n in &first.notes {
            stderr_line(&format!("spherefit: {n}"));
        }
    }
    let out_format = output_format(&batch, first.format, out_path.map(PathBuf::as_path))?;
    // A file is written beside its name and renamed when the run did not fail, so a run cut
    // short by a fatal error leaves no complete-looking output (and an existing file as it was).
    // The formats of `crate::formats` do that themselves.
    let temp_path = out_path
        .filter(|p| written_via_temp(p) && !out_format.is_file_output())
        .map(|p| temp_beside(p));
    let mut sink = match (out_format.kind(), out_path) {
        (Some(kind), Some(p)) if out_format.is_file_output() => {
            let file = FeatureWriter::create(kind, p)
                .map_err(|e| Failure::input(format!("{}: cannot write: {e}", p.display())))?;
            let out: Box<dyn Write> = Box::new(io::sink());
            Sink::to_file(io::BufWriter::new(out), out_format, file)
        }
        _ => {
            let writer: Box<dyn Write> = match (out_path, &temp_path) {
                (Some(p), t) => Box::new(
                    std::fs::File::create(t.as_deref().unwrap_or(p))
                        .map_err(|e| Failure::input(format!("{}: {e}", p.display())))?,
                ),
                (None, _) => Box::new(io::stdout().lock()),
            };
            Sink::new(io::BufWriter::with_capacity(256 << 10, writer), out_format)
        }
    };
    let total_bytes = inputs.iter().map(|i| i.size).sum::<Option<u64>>();
    let names: Vec<String> = inputs.iter().map(|i| i.name.clone()).collect();
    let settings = Settings {
        job: Arc::new(job),
        allow_spline,
        names: Arc::new(names),
        input_format: batch.format,
        read_options,
        quiet: batch.quiet,
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
    let notes = std::mem::take(&mut sink.notes);
    drop(sink);
    if !batch.quiet {
        for n in notes {
            stderr_line(&format!("spherefit: {n}"));
        }
    }
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
        // Corrupt input (a compact curve that does not decode) is not a fit that failed: exit 2.
        let total = totals.failed + totals.features;
        let (status, corrupt) = if totals.corrupt > 0 {
            let n = totals.corrupt;
            (
                2,
                format!(", {n} of them with a compact curve that does not decode (corrupt input)"),
            )
        } else {
            (1, String::new())
        };
        return Err(Failure {
            status,
            message: format!(
                "{} of {total} features failed (reported above){corrupt}; the others were written",
                totals.failed
            ),
        });
    }
    Ok(())
}
