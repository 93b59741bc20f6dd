//! The options of an S^n fit or evaluation that go together or not, checked once for every
//! front end (the service's `/v1/sphere/fit` and `/v1/sphere/evaluate`, `spherefit sphere fit`
//! and `sphere evaluate`, Python's `spherefit.sphere.fit`): those only read the options, say
//! which were given to [`check_given_together`] and check a tolerance with
//! [`check_tolerance_fit`].

/// The options every fit takes, on S^n or on the Earth, in the order the front ends list them.
pub const SPLINE_OPTIONS: [&str; 7] = [
    "control_points",
    "degree",
    "knots",
    "iterations",
    "parameterization",
    "solver",
    "parameter_correction",
];

/// The options of an S^n fit: [`SPLINE_OPTIONS`], a target error, or a tolerance.
pub const SPHERE_FIT_OPTIONS: [&str; 9] =
    concat_names(SPLINE_OPTIONS, ["target_max_error_rad", "tolerance_rad"]);

/// `a` then `b` (`C` = `A + B`), for lists of option names built from shared parts.
pub const fn concat_names<const A: usize, const B: usize, const C: usize>(
    a: [&'static str; A],
    b: [&'static str; B],
) -> [&'static str; C] {
    assert!(A + B == C, "C is A + B");
    let mut out = [""; C];
    let mut i = 0;
    while i < A {
        out[i] = a[i];
        i += 1;
    }
    let mut j = 0;
    while j < B {
        out[A + j] = b[j];
        j += 1;
    }
    out
}

/// An S^n fit's option that is out of range, or that excludes another one given.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum FitOptionError {
    /// An option out of range.
    #[error("{option}: {message}")]
    Invalid {
        /// The option's name.
        option: &'static str,
        /// What is wrong with its value.
        message: String,
    },
    /// Two options given together that exclude each other.
    #[error("{option}: {option} excludes {other}: {reason}")]
    Conflicting {
        /// The option reported.
        option: &'static str,
        /// The option it excludes.
        other: &'static str,
        /// Why.
        reason: &'static str,
    },
}

/// Options that exclude others: the option, those it excludes when both are given, and why.
/// Nothing a caller gives is dropped in silence, so an option the other one makes meaningless
/// is refused rather than ignored.
pub const EXCLUSIONS: [(&str, &[&str], &str); 2] = [
    (
        "tolerance_rad",
        &[
            "control_points",
            "knots",
            "iterations",
            "step",
            "solver",
            "target_max_error_rad",
            "parameter_correction",
        ],
        "a tolerance fit chooses its own control points, knots, solver and stopping rule",
    ),
    (
        "at",
        &["samples"],
        "give the parameters to evaluate at, or the number of evenly spaced ones",
    ),
];

/// Refuses options given together that [`EXCLUSIONS`] says exclude each other. `given` names
/// the options the caller gave (not the defaults it fills in), as the library names them
/// (`tolerance_rad`, not `--tolerance-rad`).
///
/// # Errors
/// [`FitOptionError::Conflicting`] naming the option that excludes (`tolerance_rad`, `at`)
/// and the first one given that it excludes.
pub fn check_given_together(given: &[&str]) -> Result<(), FitOptionError> {
    for (option, excludes, reason) in EXCLUSIONS {
        if !given.contains(&option) {
            continue;
        }
        if let Some(other) = excludes.iter().find(|o| given.contains(o)) {
            return Err(FitOptionError::Conflicting {
                option,
                other,
                reason,
            });
        }
    }
    Ok(())
}

/// A fit to `tolerance_rad`, if asked for: a positive number of radians. Which options it
/// excludes is [`check_given_together`]'s.
///
/// # Errors
/// [`FitOptionError::Invalid`] naming `tolerance_rad`.
pub fn check_tolerance_fit(tolerance_rad: Option<f64>) -> Result<Option<f64>, FitOptionError> {
    if let Some(t) = tolerance_rad {
        check_positive_tolerance("tolerance_rad", t, "radians")?;
    }
    Ok(tolerance_rad)
}

/// A tolerance: a positive, finite number of `unit`s.
///
/// # Errors
/// [`FitOptionError::Invalid`] naming `option`.
pub fn check_positive_tolerance(
    option: &'static str,
    tolerance: f64,
    unit: &str,
) -> Result<(), FitOptionError> {
    if tolerance.is_finite() && tolerance > 0.0 {
        return Ok(());
    }
    Err(FitOptionError::Invalid {
        option,
        message: format!("{tolerance}: the tolerance must be a positive number of {unit}"),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sphere_fit_options_are_the_spline_options_then_its_own() {
        assert_eq!(SPHERE_FIT_OPTIONS[..7], SPLINE_OPTIONS);
        assert_eq!(
            SPHERE_FIT_OPTIONS[7..],
            ["target_max_error_rad", "tolerance_rad"]
        );
    }

    #[test]
    fn a_tolerance_is_positive() {
        assert_eq!(check_tolerance_fit(None), Ok(None));
        assert_eq!(check_tolerance_fit(Some(1e-3)), Ok(Some(1e-3)));
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let e = check_tolerance_fit(Some(bad)).unwrap_err();
            assert!(
                e.to_string().starts_with("tolerance_rad: ")
                    && e.to_string().ends_with("positive number of radians"),
                "{e}"
            );
        }
    }

    /// The option named, and the one it excludes, of what `given` is refused for.
    fn refused(given: &[&str]) -> Option<(&'static str, &'static str)> {
        match check_given_together(given) {
            Ok(()) => None,
            Err(FitOptionError::Conflicting { option, other, .. }) => Some((option, other)),
            Err(e) => panic!("{e}"),
        }
    }

    #[test]
    fn a_tolerance_excludes_the_options_of_a_fit_it_chooses_itself() {
        let (_, excluded, _) = EXCLUSIONS[0];
        assert!(excluded.contains(&"knots") && excluded.contains(&"parameter_correction"));
        for &other in excluded {
            assert_eq!(
                refused(&[other, "degree", "tolerance_rad"]),
                Some(("tolerance_rad", other))
            );
            assert_eq!(refused(&[other, "degree"]), None, "{other} alone");
        }
        // Degree caps the degrees tried and parameterization places the points: both used.
        assert_eq!(
            refused(&["tolerance_rad", "degree", "parameterization"]),
            None
        );
        let e = check_given_together(&["tolerance_rad", "knots"]).unwrap_err();
        assert_eq!(
            e.to_string(),
            "tolerance_rad: tolerance_rad excludes knots: a tolerance fit chooses its own \
             control points, knots, solver and stopping rule"
        );
    }

    #[test]
    fn parameters_to_evaluate_at_exclude_a_number_of_samples() {
        assert_eq!(refused(&["samples", "at"]), Some(("at", "samples")));
        assert_eq!(refused(&["at"]), None);
        assert_eq!(refused(&["samples"]), None);
        assert_eq!(refused(&[]), None);
    }
}
