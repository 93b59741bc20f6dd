//! Checks of one option's value: its range, and the limit that bounds it.

use crate::earth::error::{EarthError, Problem};
use crate::earth::job::Limits;
use crate::sphere::fit::options::FitOptions;

/// Checks fit options against their ranges and `limits`, before any data is read: the degree,
/// the number of control points (degree + 1 to the limit), the iterations (up to the limit)
/// and the target error. Shared by every front end that fits, on the Earth or on S^n.
///
/// # Errors
/// [`Problem::InvalidOption`] or [`Problem::CountOutOfRange`] naming the option.
pub fn check_fit_options(o: &FitOptions, limits: &Limits) -> Result<(), EarthError> {
    check_degree(o.degree)?;
    if let Some(n) = o.control_points {
        check_count("control_points", n, o.degree + 1, limits.max_control_points)?;
    }
    check_count("iterations", o.iterations, 0, limits.max_iterations)?;
    check_target_max_error_rad(o.target_max_error_rad)
}

/// The spline degree: 1 to [`crate::sphere::curve::bspline::MAX_DEGREE`].
///
/// # Errors
/// [`Problem::InvalidOption`] naming `degree`.
pub fn check_degree(degree: usize) -> Result<(), EarthError> {
    let max_degree = crate::sphere::curve::bspline::MAX_DEGREE;
    if degree == 0 || degree > max_degree {
        return Err(invalid_option(
            "degree",
            format!("degree {degree}: use 1 to {max_degree}"),
        ));
    }
    Ok(())
}

/// The target maximum error of a fit, if given: a number of radians >= 0.
///
/// # Errors
/// [`Problem::InvalidOption`] naming `target_max_error_rad`.
pub fn check_target_max_error_rad(target: Option<f64>) -> Result<(), EarthError> {
    match target {
        Some(t) if !(t.is_finite() && t >= 0.0) => Err(invalid_option(
            "target_max_error_rad",
            format!("{t}: the target must be a number of radians >= 0"),
        )),
        _ => Ok(()),
    }
}

/// A tolerance: a positive, finite number, of metres (`tolerance_m`) or radians
/// (`tolerance_rad`, the S^n fit).
///
/// # Errors
/// [`Problem::InvalidOption`] naming the option.
pub fn check_tolerance(option: &'static str, tolerance: f64) -> Result<(), EarthError> {
    let unit = if option == "tolerance_m" {
        "metres"
    } else {
        "radians"
    };
    Ok(crate::sphere::fit::options_check::check_positive_tolerance(
        option, tolerance, unit,
    )?)
}

/// A count option in `min..=max`, `max` the limit that bounds it.
pub(super) fn check_count(
    option: &'static str,
    value: usize,
    min: usize,
    max: usize,
) -> Result<(), EarthError> {
    if value < min || value > max {
        return Err(EarthError::new(
            "",
            Problem::CountOutOfRange {
                option,
                value,
                min,
                max,
            },
        ));
    }
    Ok(())
}

pub(super) fn invalid_option(option: &'static str, message: String) -> EarthError {
    EarthError::new("", Problem::InvalidOption { option, message })
}
