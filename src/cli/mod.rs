//! The command line: clap definitions, input reading and exit codes. `main` only calls [`run`].
//!
//! Exit status: 0 success, 1 some records failed (batch commands), 2 usage error or invalid
//! input.

mod batch;
mod serve;
mod sphere_cmd;

use clap::{Parser, Subcommand};
use std::io::{Read, Write};
use std::path::PathBuf;
use std::process::ExitCode;

/// Fit smooth spline curves to ordered points on the sphere.
#[derive(Debug, Parser)]
#[command(name = "spherefit", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Curves on any S^n: JSON documents of unit vectors in, JSON out.
    #[command(subcommand)]
    Sphere(sphere_cmd::SphereCommand),
    /// Run the HTTP service (GeoJSON fitting API; contract at /openapi.yaml).
    Serve(serve::ServeArgs),
    // The batch commands take their help from their argument structs.
    Fit(batch::FitArgs),
    Interpolate(batch::InterpolateArgs),
    Evaluate(batch::EvaluateArgs),
}

/// A failure that ends the command, with the exit status it maps to.
#[derive(Debug)]
pub struct Failure {
    /// Process exit status (2 for usage and input errors).
    pub status: u8,
    /// The message printed on stderr.
    pub message: String,
}

impl Failure {
    /// Invalid input or usage: exit status 2.
    pub fn input(message: impl std::fmt::Display) -> Failure {
        Failure {
            status: 2,
            message: message.to_string(),
        }
    }

    /// An option the Earth layer refused, named as its flag (`--control-points: ...`), a
    /// count past its limit saying so: exit status 2.
    pub(crate) fn option(e: crate::earth::EarthError) -> Failure {
        match e.problem.option_message_named(&|name: &str| flag(name)) {
            Some((option, message)) => {
                let limit = if matches!(e.problem, crate::earth::Problem::CountOutOfRange { .. }) {
                    " (the limit)"
                } else {
                    ""
                };
                Failure::input(format!("{}: {message}{limit}", flag(option)))
            }
            None => Failure::input(e.problem),
        }
    }
}

/// The flag of an option the library names (`control_points` -> `--control-points`; the
/// output `format` is `--output-format`, `--format` being the input's).
pub(crate) fn flag(option: &str) -> String {
    match option {
        "format" => "--output-format".into(),
        _ => format!("--{}", option.replace('_', "-")),
    }
}

/// Parses the command line, runs the command and returns the exit status.
pub fn run() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Sphere(c) => sphere_cmd::run(c),
        Command::Serve(a) => serve::run(a),
        Command::Fit(a) => batch::fit(a),
        Command::Interpolate(a) => batch::interpolate(a),
        Command::Evaluate(a) => batch::evaluate(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(f) => {
            eprintln!("spherefit: {}", f.message);
            ExitCode::from(f.status)
        }
    }
}

/// Reads all of `path` (or stdin when `None` or `-`) as one JSON value.
pub(crate) fn read_json(path: Option<&PathBuf>) -> Result<serde_json::Value, Failure> {
    let (name, text) = match path {
        Some(p) if p.as_os_str() != "-" => (
            p.display().to_string(),
            std::fs::read_to_string(p)
                .map_err(|e| Failure::input(format!("{}: {e}", p.display())))?,
        ),
        _ => {
            let mut s = String::new();
            std::io::stdin()
                .read_to_string(&mut s)
                .map_err(|e| Failure::input(format!("stdin: {e}")))?;
            ("stdin".to_string(), s)
        }
    };
    serde_json::from_str(&text).map_err(|e| Failure::input(format!("{name}: invalid JSON: {e}")))
}

/// Writes `value` as one line of JSON to stdout. A closed pipe (`| head`) ends quietly with
/// status 0, as usual for filters; any other write error (a full disk) is exit status 2. (A
/// stdout closed with `>&-` is reopened on /dev/null by the Rust runtime before `main`.)
pub(crate) fn write_json<T: serde::Serialize>(value: &T) -> Result<(), Failure> {
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    let res = serde_json::to_writer(&mut out, value)
        .map_err(std::io::Error::from)
        .and_then(|_| out.write_all(b"\n"))
        .and_then(|_| out.flush());
    match res {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        Err(e) => Err(Failure {
            status: 2,
            message: format!("writing output: {e}"),
        }),
    }
}
