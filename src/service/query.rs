//! Query parameters -> options. Every endpoint names the parameters it accepts; anything else,
//! a repeat, an empty value or a value that does not parse is a 400 `invalid-query` naming the
//! parameter. The GeoJSON endpoints only fill a [`RawOptions`]: whether values are in range and
//! go together is [`crate::earth::into_job`]'s business (a 422 naming the option).

use crate::earth::into_job;
use crate::earth::job::{Job, Limits, OperationKind, RawOptions};
use crate::service::error::ApiError;
use crate::sphere::fit::knots::{KnotPlacement, Parameterization};
use crate::sphere::fit::options::{FitOptions, Solver};
use std::collections::BTreeMap;
use std::str::FromStr;

/// Query pairs checked against an allowed list.
#[derive(Clone)]
pub struct Params {
    map: BTreeMap<String, String>,
}

impl Params {
    /// Checks names (allowed, no repeats, no empty values).
    ///
    /// # Errors
    /// 400 `invalid-query` naming the parameter.
    pub fn new(pairs: Vec<(String, String)>, allowed: &[&str]) -> Result<Params, ApiError> {
        let mut map = BTreeMap::new();
        for (k, v) in pairs {
            if !allowed.contains(&k.as_str()) {
                return Err(ApiError::invalid_query(
                    &k,
                    format!(
                        "unknown query parameter {k:?}: this endpoint accepts {}",
                        if allowed.is_empty() {
                            "none".to_string()
                        } else {
                            allowed.join(", ")
                        }
                    ),
                ));
            }
            if v.is_empty() {
                return Err(ApiError::invalid_query(
                    &k,
                    format!("{k} has no value: give one or leave the parameter out"),
                ));
            }
            if map.contains_key(&k) {
                return Err(ApiError::invalid_query(
                    &k,
                    format!("{k} is given more than once"),
                ));
            }
            map.insert(k, v);
        }
        Ok(Params { map })
    }

    /// The names of the parameters given, for
    /// [`crate::sphere::fit::options_check::check_given_together`].
    pub fn given(&self) -> Vec<&str> {
        self.map.keys().map(String::as_str).collect()
    }

    /// The parsed value of `name`, if given.
    ///
    /// # Errors
    /// 400 `invalid-query` when it does not parse as `what`.
    pub fn get<T: FromStr>(&self, name: &str, what: &str) -> Result<Option<T>, ApiError> {
        match self.map.get(name) {
            None => Ok(None),
            Some(v) => v
                .parse::<T>()
                .map(Some)
                .map_err(|_| ApiError::invalid_query(name, format!("{name}={v:?} is not {what}"))),
        }
    }

    /// A non-negative integer in plain decimal digits.
    ///
    /// # Errors
    /// 400 `invalid-query` for anything else (signs, spaces, exponents).
    pub fn int(&self, name: &str) -> Result<Option<usize>, ApiError> {
        match self.map.get(name) {
            None => Ok(None),
            Some(v) if is_decimal_integer(v) => v
                .parse()
                .map(Some)
                .map_err(|_| ApiError::invalid_query(name, format!("{name}={v:?} is too large"))),
            Some(v) => Err(ApiError::invalid_query(
                name,
                format!("{name}={v:?} is not {INTEGER}"),
            )),
        }
    }

    /// A number written as JSON writes numbers (`-1.5e-3`); no `inf`, `NaN`, `+` or spaces.
    ///
    /// # Errors
    /// 400 `invalid-query` for anything else.
    pub fn num(&self, name: &str) -> Result<Option<f64>, ApiError> {
        match self.map.get(name) {
            None => Ok(None),
            Some(v) => parse_number(v).map(Some).ok_or_else(|| {
                ApiError::invalid_query(name, format!("{name}={v:?} is not {NUMBER}"))
            }),
        }
    }
}

const INTEGER: &str = "a non-negative integer";
const NUMBER: &str = "a number";

fn is_decimal_integer(s: &str) -> bool {
    !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit())
}

/// Parses a number as JSON writes it ([`crate::earth::parse_json_number`]), the grammar the
/// OpenAPI `number` parameters promise; anything else is `None`.
pub fn parse_number(s: &str) -> Option<f64> {
    crate::earth::parse_json_number(s)
}

/// Parameters of `/v1/sphere/fit`.
pub const SPHERE_FIT_PARAMS: &[&str] = &crate::sphere::fit::options_check::concat_names::<9, 1, 10>(
    crate::sphere::fit::options_check::SPHERE_FIT_OPTIONS,
    ["method"],
);
/// Parameters of `/v1/sphere/evaluate`.
pub const SPHERE_EVALUATE_PARAMS: &[&str] = &["samples", "at"];
/// Parameters of `/v1/sphere/interpolate`.
pub const SPHERE_INTERPOLATE_PARAMS: &[&str] = &["beta1", "beta2"];

/// Fit options from the query over `base` (shared by `/v1/fit`, whose defaults are
/// [`FitOptions::faithful`], and `/v1/sphere/fit`, whose defaults are the paper's).
pub fn fit_options(p: &Params, base: FitOptions) -> Result<FitOptions, ApiError> {
    let mut o = FitOptions {
        control_points: p.int("control_points")?,
        ..base
    };
    if let Some(d) = p.int("degree")? {
        o.degree = d;
    }
    if let Some(k) = p.get::<KnotPlacement>("knots", "adaptive, geodesic, euclidean or uniform")? {
        o.knots = k;
    }
    if let Some(i) = p.int("iterations")? {
        o.iterations = i;
    }
    if let Some(x) = p.get::<Parameterization>(
        "parameterization",
        "chord, centripetal, uniform or (GeoJSON) time",
    )? {
        o.parameterization = x;
    }
    if let Some(s) = p.get::<Solver>("solver", "gls-pia-accelerated, gls-pia or gauss-newton")? {
        o.solver = s;
    }
    if let Some(c) = p.get::<bool>("parameter_correction", "true or false")? {
        o.parameter_correction = c;
    }
    Ok(o)
}

/// `tolerance_rad` of `/v1/sphere/fit`, if given, checked by
/// [`crate::sphere::fit::options_check::check_tolerance_fit`].
///
/// # Errors
/// 400 when it does not parse; 422 when it is not a positive number.
pub fn sphere_tolerance(p: &Params) -> Result<Option<f64>, ApiError> {
    let checked = crate::sphere::fit::options_check::check_tolerance_fit(p.num("tolerance_rad")?);
    Ok(checked.map_err(crate::earth::EarthError::from)?)
}

/// Refuses S^n options given together that exclude each other, as
/// [`crate::sphere::fit::options_check::check_given_together`] says.
///
/// # Errors
/// The sphere rule's error, as problem+json naming the option that excludes the other.
pub fn sphere_given_together(p: &Params) -> Result<(), ApiError> {
    let checked = crate::sphere::fit::options_check::check_given_together(&p.given());
    Ok(checked.map_err(crate::earth::EarthError::from)?)
}

/// The Earth job of a geo endpoint: the query read into [`RawOptions`] and checked by
/// [`into_job`].
///
/// # Errors
/// 400 `invalid-query` for unknown, repeated, empty or unparsable parameters; 422 from
/// [`into_job`] for values out of range or options that do not go together.
pub fn geo_job(
    pairs: Vec<(String, String)>,
    endpoint: GeoEndpoint,
    limits: &Limits,
) -> Result<Job, ApiError> {
    let kind = endpoint.kind();
    let p = Params::new(pairs, kind.option_names())?;
    let mut raw = RawOptions::default();
    for (name, value) in &p.map {
        raw.set(name, value)
            .map_err(|e| ApiError::invalid_query(name, e.to_string()))?;
    }
    Ok(into_job(raw, kind, limits)?)
}

/// The three GeoJSON endpoints.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GeoEndpoint {
    Fit,
    Interpolate,
    Evaluate,
}

impl GeoEndpoint {
    /// The operation, whose options the endpoint takes.
    pub fn kind(self) -> OperationKind {
        match self {
            GeoEndpoint::Fit => OperationKind::Fit,
            GeoEndpoint::Interpolate => OperationKind::Interpolate,
            GeoEndpoint::Evaluate => OperationKind::Evaluate,
        }
    }

    /// The route, for metrics.
    pub fn route(self) -> &'static str {
        match self {
            GeoEndpoint::Fit => "/v1/fit",
            GeoEndpoint::Interpolate => "/v1/interpolate",
            GeoEndpoint::Evaluate => "/v1/evaluate",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::earth::{Operation, OutputOptions, Sampling, TimeSource};

    fn pairs(q: &[(&str, &str)]) -> Vec<(String, String)> {
        q.iter()
            .map(|(a, b)| (a.to_string(), b.to_string()))
            .collect()
    }

    /// The status and the parameter named of a query `endpoint` refuses.
    fn refused(q: &[(&str, &str)], endpoint: GeoEndpoint) -> (u16, Option<String>) {
        let e = geo_job(pairs(q), endpoint, &Limits::default()).unwrap_err();
        (e.status.as_u16(), e.parameter)
    }

    fn named(status: u16, parameter: &str) -> (u16, Option<String>) {
        (status, Some(parameter.to_string()))
    }

    #[test]
    fn unknown_repeated_and_unparsable_parameters_are_400() {
        let fit = GeoEndpoint::Fit;
        assert_eq!(refused(&[("foo", "1")], fit), named(400, "foo"));
        assert_eq!(refused(&[("degree", "2"), ("degree", "3")], fit).0, 400);
        assert_eq!(refused(&[("samples", "ten")], fit), named(400, "samples"));
        for bad in ["NaN", "inf", "+1", " 1", "1e", "--1", "."] {
            assert_eq!(refused(&[("spacing_m", bad)], fit).0, 400, "{bad}");
        }
        assert_eq!(parse_number("-1.5e-3"), Some(-1.5e-3));
        assert_eq!(parse_number("1e+20"), Some(1e20));
        assert_eq!(parse_number("5."), Some(5.0));
        let both = geo_job(
            pairs(&[("samples", "10"), ("spacing_m", "5")]),
            GeoEndpoint::Evaluate,
            &Limits::default(),
        )
        .unwrap();
        assert_eq!(
            both.output.sampling,
            Sampling::SpacingAndSamples {
                spacing_m: 5.0,
                samples: 10
            }
        );
    }

    /// Ranges are `into_job`'s (tested there): the query answers them with a 422 naming the
    /// option.
    #[test]
    fn out_of_range_values_are_422() {
        assert_eq!(
            refused(&[("degree", "9")], GeoEndpoint::Fit),
            named(422, "degree")
        );
        assert_eq!(
            refused(&[("samples", "1")], GeoEndpoint::Fit),
            named(422, "samples")
        );
        assert_eq!(
            refused(&[("beta1", "0")], GeoEndpoint::Interpolate),
            named(422, "beta1")
        );
    }

    #[test]
    fn defaults_are_the_papers() {
        let job = geo_job(vec![], GeoEndpoint::Fit, &Limits::default()).unwrap();
        assert_eq!(job.operation, Operation::Fit(FitOptions::faithful()));
        assert_eq!(job.output, OutputOptions::default());
    }

    /// Which options go together is `into_job`'s business, tested there: the query only
    /// reads the parameters and answers its refusals with a 422 naming the option.
    #[test]
    fn rules_between_options_come_back_as_422_naming_the_option() {
        let job = geo_job(
            pairs(&[("time_property", "when")]),
            GeoEndpoint::Fit,
            &Limits::default(),
        )
        .unwrap();
        assert_eq!(
            job.time.fit_in_time,
            Some(TimeSource::Property("when".into()))
        );
        assert_eq!(
            refused(
                &[("parameterization", "chord"), ("spacing_s", "30")],
                GeoEndpoint::Fit
            ),
            named(422, "spacing_s")
        );
        assert_eq!(
            refused(&[("at", "1")], GeoEndpoint::Fit).0,
            400,
            "at is not a fit parameter"
        );
        // The S^n fit knows no time.
        let p = Params::new(pairs(&[("parameterization", "time")]), SPHERE_FIT_PARAMS).unwrap();
        assert!(fit_options(&p, FitOptions::default()).is_err());
    }
}
