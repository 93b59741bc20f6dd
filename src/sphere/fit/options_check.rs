//! The options of an S^n fit that go together or not, checked once for every front end (the
//! service's `/v1/sphere/fit`, `spherefit sphere fit`, Python's `spherefit.sphere.fit`): those
//! only read the options and call [`check_tolerance_fit`].

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

/// A fit to `tolerance_rad`, if asked for: positive, and not with `control_points` (a
/// tolerance fit chooses its own).
///
/// # Errors
/// [`FitOptionError::Conflicting`] or [`FitOptionError::Invalid`] naming `tolerance_rad`.
pub fn check_tolerance_fit(
    tolerance_rad: Option<f64>,
    control_points: Option<usize>,
) -> Result<Option<f64>, FitOptionError> {
    let Some(t) = tolerance_rad else {
        return Ok(None);
    };
    if control_points.is_some() {
        return Err(FitOptionError::Conflicting {
            option: "tolerance_rad",
            other: "control_points",
            reason: "a tolerance fit chooses its own control points",
        });
    }
    check_positive_tolerance("tolerance_rad", t, "radians")?;
    Ok(Some(t))
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
    fn a_tolerance_is_positive_and_excludes_control_points() {
        assert_eq!(check_tolerance_fit(None, Some(5)), Ok(None));
        assert_eq!(check_tolerance_fit(Some(1e-3), None), Ok(Some(1e-3)));
        assert!(matches!(
            check_tolerance_fit(Some(1e-3), Some(5)),
            Err(FitOptionError::Conflicting {
                option: "tolerance_rad",
                other: "control_points",
                ..
            })
        ));
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let e = check_tolerance_fit(Some(bad), None).unwrap_err();
            assert!(
                e.to_string().starts_with("tolerance_rad: ")
                    && e.to_string().ends_with("positive number of radians"),
                "{e}"
            );
        }
    }
}
