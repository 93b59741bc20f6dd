use super::*;
use crate::cli::batch::pipeline::Totals;
use crate::cli::batch::progress::clock;
use crate::cli::batch::progress::progress_line;
use crate::earth::into_job;
use crate::earth::job::Limits;
use crate::earth::job::OperationKind;
use crate::earth::job::ParameterizationOption;
use crate::earth::job::RawOptions;
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
            parameterization: Some(ParameterizationOption::Shape(Parameterization::Centripetal)),
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

#[test]
fn only_new_names_and_regular_files_are_written_through_a_temporary_file() {
    let dir = std::env::temp_dir().join(format!("spherefit-out-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("out.geojson");
    assert!(written_via_temp(&file), "a new name");
    std::fs::write(&file, "{}").unwrap();
    assert!(written_via_temp(&file), "a regular file");
    let link = dir.join("link.geojson");
    let _ = std::fs::remove_file(&link);
    std::os::unix::fs::symlink(&file, &link).unwrap();
    assert!(!written_via_temp(&link), "a symbolic link");
    assert!(!written_via_temp(Path::new("/dev/null")), "a device");
    std::fs::remove_dir_all(&dir).unwrap();
}
