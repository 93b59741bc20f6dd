use super::*;
use crate::sphere::fit::knots::KnotPlacement;
use crate::sphere::fit::knots::Parameterization;
use crate::sphere::fit::options::Solver;

fn job(kind: OperationKind, pairs: &[(&str, &str)]) -> Result<Job, EarthError> {
    let mut raw = RawOptions::default();
    for (k, v) in pairs {
        raw.set(k, v).unwrap();
    }
    into_job(raw, kind, &Limits::default())
}

fn fit(pairs: &[(&str, &str)]) -> Result<Job, EarthError> {
    job(OperationKind::Fit, pairs)
}

/// The option an error names and its kind.
fn refused(r: Result<Job, EarthError>) -> (&'static str, &'static str) {
    let e = r.unwrap_err();
    let (option, _) = e.problem.option_message().expect("an option's error");
    (option, e.problem.slug())
}

#[test]
fn defaults_are_the_faithful_fit_per_feature_with_small_rings_kept() {
    let j = fit(&[]).unwrap();
    assert_eq!(j.operation, Operation::Fit(FitOptions::faithful()));
    assert_eq!(j.output, OutputOptions::default());
    assert_eq!(
        (j.topology, j.format, j.drop_small_rings),
        (Topology::PerFeature, OutputFormat::GeoJson, false)
    );
    assert_eq!(j.time, TimeOptions::default());
    assert_eq!(
        job(OperationKind::Interpolate, &[]).unwrap().operation,
        Operation::Interpolate(InterpolateSettings::default())
    );
}

#[test]
fn every_option_lands_in_its_place() {
    let j = fit(&[
        ("control_points", "12"),
        ("degree", "2"),
        ("knots", "uniform"),
        ("iterations", "50"),
        ("parameterization", "centripetal"),
        ("solver", "gls-pia"),
        ("parameter_correction", "false"),
        ("samples", "20"),
        ("spacing_m", "250"),
        ("precision", "5"),
        ("drop_small_rings", "true"),
    ])
    .unwrap();
    let o = j.operation.fit_options().unwrap();
    assert_eq!(
        (o.control_points, o.degree, o.knots, o.iterations),
        (Some(12), 2, KnotPlacement::Uniform, 50)
    );
    assert_eq!(
        (o.parameterization, o.solver, o.parameter_correction),
        (Parameterization::Centripetal, Solver::GlsPia, false)
    );
    assert_eq!(
        j.output,
        OutputOptions {
            sampling: Sampling::SpacingAndSamples {
                spacing_m: 250.0,
                samples: 20
            },
            precision: 5,
            compact_splines: false,
            splines_refer_to_geometry: true,
            grid_multiple: 1,
        }
    );
    assert!(j.drop_small_rings);
    let j = fit(&[
        ("tolerance_m", "25"),
        ("topology", "shared"),
        ("format", "topojson"),
    ])
    .unwrap();
    assert!(matches!(
        j.operation,
        Operation::FitToTolerance { tolerance_m, .. } if tolerance_m == 25.0
    ));
    assert_eq!(
        (j.topology, j.format),
        (Topology::Shared, OutputFormat::TopoJson)
    );
}

#[test]
fn a_coverage_written_as_topojson_at_a_chosen_precision_gets_a_coarser_grid() {
    let grid = |pairs: &[(&str, &str)]| {
        let j = fit(pairs).unwrap();
        (j.output.precision, j.output.grid_multiple)
    };
    let base = [
        ("tolerance_m", "1000"),
        ("topology", "shared"),
        ("format", "topojson"),
        ("carry", "geometry"),
    ];
    assert_eq!(grid(&base), (3, 4));
    // GeoJSON, a given precision and carry=both keep the decimal grid (TopoJSON is only
    // written with shared topology).
    assert_eq!(
        grid(&[base[0], base[1], ("format", "geojson"), base[3]]),
        (3, 1)
    );
    assert_eq!(
        grid(&[base[0], base[1], base[2], base[3], ("precision", "3")]),
        (3, 1)
    );
    assert_eq!(grid(&[base[0], base[1], base[2], ("carry", "both")]).1, 1);
}

#[test]
fn time_is_asked_for_or_implied_and_conflicts_with_another_parameterization() {
    let t = |pairs| fit(pairs).unwrap().time.fit_in_time;
    assert_eq!(t(&[("parameterization", "time")]), Some(TimeSource::Auto));
    assert_eq!(
        t(&[("time_property", "when")]),
        Some(TimeSource::Property("when".into()))
    );
    assert_eq!(t(&[("spacing_s", "30")]), Some(TimeSource::Auto));
    // parameterization=time is not a math-core parameterisation: the fit keeps its own.
    assert_eq!(
        fit(&[("parameterization", "time")])
            .unwrap()
            .operation
            .fit_options()
            .unwrap()
            .parameterization,
        FitOptions::faithful().parameterization
    );
    assert_eq!(
        refused(fit(&[("parameterization", "chord"), ("spacing_s", "30")])),
        ("spacing_s", "conflicting-options")
    );
    assert_eq!(
        refused(fit(&[
            ("parameterization", "uniform"),
            ("time_property", "t")
        ])),
        ("time_property", "conflicting-options")
    );
    // On evaluation spacing_s is the spacing of a curve already in time.
    let e = job(OperationKind::Evaluate, &[("spacing_s", "60")]).unwrap();
    assert_eq!(e.time.fit_in_time, None);
    assert_eq!(e.output.sampling, Sampling::SpacingS(60.0));
    assert_eq!(
        refused(job(OperationKind::Interpolate, &[("spacing_s", "10")])),
        ("spacing_s", "invalid-option")
    );
}

#[test]
fn options_that_exclude_each_other_are_refused_once_naming_both() {
    let e = fit(&[("tolerance_m", "100"), ("control_points", "5")]).unwrap_err();
    assert_eq!(e.problem.slug(), "conflicting-options");
    assert_eq!(
        e.problem.option_message().unwrap(),
        (
            "tolerance_m",
            "tolerance_m excludes control_points: a tolerance fit chooses its own control points"
                .to_string()
        )
    );
    let flags = e
        .problem
        .option_message_named(&|n: &str| format!("--{}", n.replace('_', "-")))
        .unwrap();
    assert!(
        flags
            .1
            .starts_with("--tolerance-m excludes --control-points"),
        "{}",
        flags.1
    );
    for other in ["samples", "spacing_m"] {
        assert_eq!(
            refused(job(
                OperationKind::Evaluate,
                &[("spacing_s", "30"), (other, "10")]
            )),
            ("spacing_s", "conflicting-options")
        );
    }
    assert_eq!(
        refused(
            crate::sphere::fit::options_check::check_given_together(&[
                "tolerance_rad",
                "control_points"
            ])
            .map_err(EarthError::from)
            .map(|_| fit(&[]).unwrap())
        ),
        ("tolerance_rad", "conflicting-options")
    );
}

#[test]
fn topology_and_format_rules() {
    let e = fit(&[("topology", "shared")]).unwrap_err();
    assert!(matches!(
        e.problem,
        Problem::RequiresOption {
            option: "topology",
            requires: "tolerance_m",
            ..
        }
    ));
    assert_eq!(
        refused(fit(&[("format", "topojson"), ("tolerance_m", "10")])),
        ("format", "invalid-option")
    );
    assert_eq!(
        refused(fit(&[
            ("topology", "shared"),
            ("tolerance_m", "10"),
            ("parameterization", "time")
        ])),
        ("topology", "invalid-option")
    );
    assert!(fit(&[
        ("topology", "shared"),
        ("tolerance_m", "10"),
        ("format", "topojson")
    ])
    .is_ok());
}

#[test]
fn ranges_limits_and_foreign_options_are_refused_naming_the_option() {
    for (k, v) in [
        ("degree", "9"),
        ("control_points", "2"),
        ("samples", "1"),
        ("precision", "16"),
        ("iterations", "100000"),
        ("spacing_m", "0"),
        ("tolerance_m", "0"),
        ("spacing_s", "-1"),
    ] {
        assert_eq!(refused(fit(&[(k, v)])).0, k, "{k}={v}");
    }
    assert_eq!(
        refused(job(OperationKind::Interpolate, &[("beta1", "0")])).0,
        "beta1"
    );
    let e = job(OperationKind::Evaluate, &[("at", "1,,2")]).unwrap_err();
    assert_eq!(e.problem.option_message().unwrap().0, "at");
    assert_eq!(
        job(OperationKind::Evaluate, &[("at", "1,2010-10-03T09:36:30Z")])
            .unwrap()
            .time
            .at_unix_s,
        Some(vec![1.0, 1286098590.0])
    );
    assert_eq!(
        refused(job(
            OperationKind::Evaluate,
            &[("at", "1"), ("samples", "5")]
        ))
        .0,
        "at"
    );
    // An option of another operation (a front end that fills a field the operation does
    // not take) is refused, not ignored.
    assert_eq!(
        refused(job(
            OperationKind::Interpolate,
            &[("drop_small_rings", "true")]
        )),
        ("drop_small_rings", "invalid-option")
    );
    assert_eq!(refused(fit(&[("at", "1")])), ("at", "invalid-option"));
}

#[test]
fn set_parses_as_the_query_does() {
    let mut raw = RawOptions::default();
    for (k, bad) in [
        ("samples", "ten"),
        ("samples", "+5"),
        ("spacing_m", "NaN"),
        ("spacing_m", "inf"),
        ("spacing_m", " 1"),
        ("knots", "spline"),
        ("drop_small_rings", "yes"),
        ("topology", "merged"),
        ("nonsense", "1"),
    ] {
        let e = raw.set(k, bad).unwrap_err();
        assert_eq!(e.option, k);
    }
    assert_eq!(raw, RawOptions::default(), "nothing set by a failed parse");
    raw.set("spacing_m", "-1.5e-3").unwrap();
    assert_eq!(raw.spacing_m, Some(-1.5e-3));
    assert_eq!(raw.given(), ["spacing_m"]);
}

#[test]
fn every_option_name_is_one_that_set_reads_and_given_reports() {
    for kind in [
        OperationKind::Fit,
        OperationKind::Interpolate,
        OperationKind::Evaluate,
    ] {
        for name in kind.option_names() {
            let value = match *name {
                "knots" => "uniform",
                "parameterization" => "chord",
                "solver" => "gls-pia",
                "parameter_correction" | "drop_small_rings" => "true",
                "topology" => "shared",
                "format" => "topojson",
                "carry" => "geometry",
                "time_property" | "at" => "t",
                _ => "3",
            };
            let mut raw = RawOptions::default();
            raw.set(name, value).unwrap();
            assert_eq!(raw.given(), [*name]);
        }
    }
}

/// The types [`RawOptions::option_type`] gives (from which the OGC API – Processes input
/// schemas are made) are the ones `set` reads: every named value parses, and a value of
/// another type is refused.
#[test]
fn option_types_describe_what_set_reads() {
    for kind in [
        OperationKind::Fit,
        OperationKind::Interpolate,
        OperationKind::Evaluate,
    ] {
        for name in kind.option_names() {
            let t = RawOptions::option_type(name).unwrap_or_else(|| panic!("{name} has no type"));
            let (good, bad): (Vec<&str>, &str) = match t {
                OptionType::Integer => (vec!["3"], "1.5"),
                OptionType::Number => (vec!["1.5", "-2e3"], "x"),
                OptionType::Boolean => (vec!["true", "false"], "1"),
                OptionType::Text => (vec!["t"], ""),
                OptionType::OneOf(names) => (names.to_vec(), "no-such-name"),
            };
            for v in good {
                RawOptions::default()
                    .set(name, v)
                    .unwrap_or_else(|e| panic!("{name}={v}: {e}"));
            }
            if t != OptionType::Text {
                assert!(
                    RawOptions::default().set(name, bad).is_err(),
                    "{name}={bad}"
                );
            }
        }
    }
    assert_eq!(RawOptions::option_type("no_such_option"), None);
}

#[test]
fn a_tolerance_sizes_the_precision_unless_it_is_given() {
    // Rounding at p decimals moves a position at most 0.5e-p * sqrt(2) degrees: 7.9 m at 4.
    assert_eq!(precision_for_tolerance(100.0), 4);
    assert_eq!(precision_for_tolerance(1000.0), 3);
    assert_eq!(precision_for_tolerance(25.0), 5);
    assert_eq!(precision_for_tolerance(0.01), DEFAULT_PRECISION);
    assert_eq!(precision_for_tolerance(f64::NAN), DEFAULT_PRECISION);
    for t in [0.5, 3.0, 10.0, 100.0, 1000.0, 5e4] {
        let p = precision_for_tolerance(t);
        let bound_m = crate::earth::rad_to_m(crate::earth::curve::fitting::rounding_bound_rad(p));
        assert!(bound_m <= PRECISION_SHARE_OF_TOLERANCE * t, "{t} m: {p}");
        if p > 0 {
            // One decimal fewer would take more than the share.
            let coarser =
                crate::earth::rad_to_m(crate::earth::curve::fitting::rounding_bound_rad(p - 1));
            assert!(coarser > PRECISION_SHARE_OF_TOLERANCE * t, "{t} m: {p}");
        }
    }
    let job = |o: &[(&str, &str)], kind| {
        let mut raw = RawOptions::default();
        for (k, v) in o {
            raw.set(k, v).unwrap();
        }
        into_job(raw, kind, &Limits::default()).unwrap()
    };
    let fit = OperationKind::Fit;
    assert_eq!(
        job(&[("tolerance_m", "100"), ("carry", "geometry")], fit)
            .output
            .precision,
        4
    );
    // The default output (carry both) keeps 7 decimals.
    assert_eq!(job(&[("tolerance_m", "100")], fit).output.precision, 7);
    assert_eq!(
        job(
            &[
                ("tolerance_m", "100"),
                ("carry", "spline"),
                ("precision", "7")
            ],
            fit
        )
        .output
        .precision,
        7
    );
    assert_eq!(job(&[], fit).output.precision, DEFAULT_PRECISION);
    assert_eq!(job(&[("carry", "spline")], fit).carry, Carry::Spline);
    assert_eq!(job(&[], fit).carry, Carry::Both);
}

#[test]
fn only_a_fit_chooses_what_features_carry() {
    let mut raw = RawOptions::default();
    raw.set("carry", "geometry").unwrap();
    // Evaluate does not take the option at all.
    let e = into_job(raw, OperationKind::Evaluate, &Limits::default()).unwrap_err();
    assert!(
        matches!(
            e.problem,
            Problem::InvalidOption {
                option: "carry",
                ..
            }
        ),
        "{e:?}"
    );
    let e = Job::evaluate()
        .carrying(Carry::Geometry)
        .validate()
        .unwrap_err();
    assert!(
        matches!(
            e.problem,
            Problem::InvalidOption {
                option: "carry",
                ..
            }
        ),
        "{e:?}"
    );
    let mut raw = RawOptions::default();
    assert_eq!(raw.set("carry", "all").unwrap_err().option, "carry");
}
