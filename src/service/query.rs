//! Query parameters -> options. Every endpoint names the parameters it accepts; anything else,
//! a repeat, an empty value or a value that does not parse is a 400 `invalid-query` naming the
//! parameter. Values that parse but are out of range are checked later (422 `invalid-option`).

use super::error::ApiError;
use crate::earth::{
    InterpolateSettings, Job, Limits, Operation, OutputOptions, Sampling, TimeOptions, TimeSource,
};
use crate::sphere::{FitOptions, KnotPlacement, Parameterization, Solver};
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

    /// True when `name` was given.
    pub fn has(&self, name: &str) -> bool {
        self.map.contains_key(name)
    }

    /// The raw value of `name`, if given.
    pub fn raw(&self, name: &str) -> Option<&str> {
        self.map.get(name).map(String::as_str)
    }

    /// These parameters without `name`.
    fn without(&self, name: &str) -> Params {
        let mut map = self.map.clone();
        map.remove(name);
        Params { map }
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

/// Parameters of `/v1/fit`.
pub const FIT_PARAMS: &[&str] = &[
    "control_points",
    "degree",
    "knots",
    "iterations",
    "parameterization",
    "solver",
    "parameter_correction",
    "tolerance_m",
    "time_property",
    "samples",
    "spacing_m",
    "spacing_s",
    "precision",
    "topology",
    "format",
];
/// Parameters of `/v1/interpolate`.
pub const INTERPOLATE_PARAMS: &[&str] = &["beta1", "beta2", "samples", "spacing_m", "precision"];
/// Parameters of `/v1/evaluate`.
pub const EVALUATE_PARAMS: &[&str] = &["samples", "spacing_m", "spacing_s", "at", "precision"];
/// Parameters of `/v1/sphere/fit`.
pub const SPHERE_FIT_PARAMS: &[&str] = &[
    "control_points",
    "degree",
    "knots",
    "iterations",
    "parameterization",
    "solver",
    "parameter_correction",
    "target_max_error_rad",
    "tolerance_rad",
];
/// Parameters of `/v1/sphere/evaluate`.
pub const SPHERE_EVALUATE_PARAMS: &[&str] = &["samples", "at"];
/// Parameters of `/v1/sphere/interpolate`.
pub const SPHERE_INTERPOLATE_PARAMS: &[&str] = &["beta1", "beta2"];

fn output_options(p: &Params) -> Result<OutputOptions, ApiError> {
    let samples = p.int("samples")?;
    let spacing = p.num("spacing_m")?;
    let spacing_s = p.num("spacing_s")?;
    if let Some(s) = spacing_s {
        if samples.is_some() || spacing.is_some() {
            return Err(ApiError::unprocessable(
                "conflicting-options",
                "spacing_s excludes samples and spacing_m: give one way of sampling".to_string(),
            )
            .param("spacing_s"));
        }
        return Ok(OutputOptions {
            sampling: Sampling::SpacingS(s),
            precision: precision(p)?,
        });
    }
    Ok(OutputOptions {
        sampling: Sampling::from_samples_and_spacing(samples, spacing),
        precision: precision(p)?,
    })
}

fn precision(p: &Params) -> Result<u32, ApiError> {
    Ok(match p.int("precision")? {
        Some(n) => u32::try_from(n).unwrap_or(u32::MAX),
        None => crate::earth::DEFAULT_PRECISION,
    })
}

/// `parameterization=time` (with `time_property`; either of those or `spacing_s` on a fit
/// implies it) and `at`, and the parameters left for the fit options.
fn time_options(p: &Params, fit: bool) -> Result<(TimeOptions, Params), ApiError> {
    let mut t = TimeOptions::default();
    // `time_property` and (on /v1/fit) `spacing_s` mean a fit in time: they imply
    // parameterization=time, and conflict with any other.
    let implied = ["time_property", "spacing_s"]
        .into_iter()
        .find(|k| p.has(k) && (*k == "time_property" || fit));
    let in_time = match (p.raw("parameterization"), implied) {
        (Some("time"), _) | (None, Some(_)) => true,
        (Some(other), Some(k)) => {
            return Err(ApiError::unprocessable(
                "conflicting-options",
                format!("{k} is for a fit in time: it excludes parameterization={other}"),
            )
            .param(k))
        }
        _ => false,
    };
    if in_time {
        t.fit_in_time = Some(match p.raw("time_property") {
            Some(name) => TimeSource::Property(name.to_string()),
            None => TimeSource::Auto,
        });
    }
    if let Some(v) = p.raw("at") {
        // A string the schema allows but that holds no times: 422, like other unusable values.
        let at = crate::earth::time::parse_time_list(v).map_err(|m| {
            ApiError::from(crate::earth::EarthError::new(
                "",
                crate::earth::Problem::InvalidOption {
                    option: "at",
                    message: format!(
                        "at={v:?}: {m} (give RFC 3339 times or unix seconds, comma-separated)"
                    ),
                },
            ))
        })?;
        t.at_unix_s = Some(at);
    }
    let rest = if in_time {
        p.without("parameterization")
    } else {
        p.clone()
    };
    Ok((t, rest))
}

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

/// A tolerance (`tolerance_m` or `tolerance_rad`), if given: a 400 naming it when
/// `control_points` is given too, a 422 when it is not a positive finite number.
///
/// # Errors
/// As above, and 400 when it does not parse. Given together with `control_points` it is a 422
/// (`conflicting-options`): each is valid alone and the schema cannot forbid the pair, but a
/// tolerance fit chooses its own control points.
pub fn tolerance(p: &Params, name: &'static str) -> Result<Option<f64>, ApiError> {
    let Some(t) = p.num(name)? else {
        return Ok(None);
    };
    if p.has("control_points") {
        return Err(ApiError::unprocessable(
            "conflicting-options",
            format!(
                "{name} and control_points exclude each other: a tolerance fit chooses its own \
                 control points"
            ),
        )
        .param(name));
    }
    crate::earth::check_tolerance(name, t)?;
    Ok(Some(t))
}

/// The Earth job of a geo endpoint, validated against the limits.
///
/// # Errors
/// 400 for unparsable parameters, 422 `invalid-option` for values out of range.
pub fn geo_job(
    pairs: Vec<(String, String)>,
    endpoint: GeoEndpoint,
    limits: &Limits,
) -> Result<Job, ApiError> {
    let (allowed, operation) = match endpoint {
        GeoEndpoint::Fit => (FIT_PARAMS, None),
        GeoEndpoint::Interpolate => (INTERPOLATE_PARAMS, None),
        GeoEndpoint::Evaluate => (EVALUATE_PARAMS, Some(Operation::Evaluate)),
    };
    let p = Params::new(pairs, allowed)?;
    let (time, p) = time_options(&p, endpoint == GeoEndpoint::Fit)?;
    let operation = match (endpoint, operation) {
        (_, Some(op)) => op,
        (GeoEndpoint::Fit, None) => match tolerance(&p, "tolerance_m")? {
            Some(tolerance_m) => Operation::FitToTolerance {
                options: fit_options(&p, FitOptions::faithful())?,
                tolerance_m,
            },
            None => Operation::Fit(fit_options(&p, FitOptions::faithful())?),
        },
        _ => {
            let d = InterpolateSettings::default();
            Operation::Interpolate(InterpolateSettings {
                beta1: p.num("beta1")?.unwrap_or(d.beta1),
                beta2: p.num("beta2")?.unwrap_or(d.beta2),
            })
        }
    };
    let job = Job {
        operation,
        output: output_options(&p)?,
        limits: limits.clone(),
        cancel: Default::default(),
        time,
    };
    job.validate().map_err(ApiError::from)?;
    Ok(job)
}

/// `topology` (`per-feature`, `shared`) and `format` (`geojson`, `topojson`) of `/v1/fit`,
/// defaults when absent; names were checked by [`geo_job`]; whether they go with the other
/// options is checked by [`crate::earth::topology::validate`].
///
/// # Errors
/// 400 `invalid-query` for values that are not one of these.
pub fn fit_topology(
    pairs: &[(String, String)],
) -> Result<
    (
        crate::earth::topology::Topology,
        crate::earth::topology::OutputFormat,
    ),
    ApiError,
> {
    let value = |name: &str| pairs.iter().find(|(k, _)| k == name).map(|(_, v)| v);
    let topology = match value("topology") {
        None => Default::default(),
        Some(v) => v.parse().map_err(|_| {
            ApiError::invalid_query(
                "topology",
                format!("topology={v:?} is not per-feature or shared"),
            )
        })?,
    };
    let format = match value("format") {
        None => Default::default(),
        Some(v) => v.parse().map_err(|_| {
            ApiError::invalid_query("format", format!("format={v:?} is not geojson or topojson"))
        })?,
    };
    Ok((topology, format))
}

/// The three GeoJSON endpoints.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GeoEndpoint {
    Fit,
    Interpolate,
    Evaluate,
}

impl GeoEndpoint {
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

    fn pairs(q: &[(&str, &str)]) -> Vec<(String, String)> {
        q.iter()
            .map(|(a, b)| (a.to_string(), b.to_string()))
            .collect()
    }

    #[test]
    fn unknown_repeated_and_unparsable_parameters_are_400() {
        let l = Limits::default();
        let e = geo_job(pairs(&[("foo", "1")]), GeoEndpoint::Fit, &l).unwrap_err();
        assert_eq!(
            (e.status.as_u16(), e.parameter.as_deref()),
            (400, Some("foo"))
        );
        let e = geo_job(
            pairs(&[("degree", "2"), ("degree", "3")]),
            GeoEndpoint::Fit,
            &l,
        )
        .unwrap_err();
        assert_eq!(e.status.as_u16(), 400);
        let e = geo_job(pairs(&[("samples", "ten")]), GeoEndpoint::Fit, &l).unwrap_err();
        assert_eq!(e.parameter.as_deref(), Some("samples"));
        let both = geo_job(
            pairs(&[("samples", "10"), ("spacing_m", "5")]),
            GeoEndpoint::Evaluate,
            &l,
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

    #[test]
    fn out_of_range_values_are_422() {
        let l = Limits::default();
        for (k, v) in [
            ("degree", "9"),
            ("control_points", "2"),
            ("samples", "1"),
            ("precision", "16"),
            ("iterations", "100000"),
        ] {
            let e = geo_job(pairs(&[(k, v)]), GeoEndpoint::Fit, &l).unwrap_err();
            assert_eq!(e.status.as_u16(), 422, "{k}={v}");
            assert_eq!(e.parameter.as_deref(), Some(k));
        }
        let e = geo_job(pairs(&[("spacing_m", "0")]), GeoEndpoint::Fit, &l).unwrap_err();
        assert_eq!(e.status.as_u16(), 422);
        for bad in ["NaN", "inf", "+1", " 1", "1e", "--1", "."] {
            let e = geo_job(pairs(&[("spacing_m", bad)]), GeoEndpoint::Fit, &l).unwrap_err();
            assert_eq!(e.status.as_u16(), 400, "{bad}");
        }
        assert_eq!(parse_number("-1.5e-3"), Some(-1.5e-3));
        assert_eq!(parse_number("1e+20"), Some(1e20));
        assert_eq!(parse_number("5."), Some(5.0));
        let e = geo_job(pairs(&[("beta1", "0")]), GeoEndpoint::Interpolate, &l).unwrap_err();
        assert_eq!(e.parameter.as_deref(), Some("beta1"));
    }

    #[test]
    fn defaults_are_the_papers() {
        let job = geo_job(vec![], GeoEndpoint::Fit, &Limits::default()).unwrap();
        assert_eq!(job.operation, Operation::Fit(FitOptions::faithful()));
        assert_eq!(job.output, OutputOptions::default());
    }

    #[test]
    fn time_options_are_read_and_implied() {
        let l = Limits::default();
        let job = geo_job(pairs(&[("parameterization", "time")]), GeoEndpoint::Fit, &l).unwrap();
        assert_eq!(job.time.fit_in_time, Some(TimeSource::Auto));
        // parameterization=time is not a math-core parameterisation: the fit options keep theirs.
        assert_eq!(
            job.operation.fit_options().unwrap().parameterization,
            FitOptions::faithful().parameterization
        );
        let job = geo_job(pairs(&[("time_property", "when")]), GeoEndpoint::Fit, &l).unwrap();
        assert_eq!(
            job.time.fit_in_time,
            Some(TimeSource::Property("when".into()))
        );
        let job = geo_job(pairs(&[("spacing_s", "30")]), GeoEndpoint::Fit, &l).unwrap();
        assert_eq!(
            (job.time.fit_in_time, job.output.sampling),
            (Some(TimeSource::Auto), Sampling::SpacingS(30.0))
        );
        let e = geo_job(
            pairs(&[("parameterization", "chord"), ("spacing_s", "30")]),
            GeoEndpoint::Fit,
            &l,
        )
        .unwrap_err();
        assert_eq!(
            (e.status.as_u16(), e.parameter.as_deref()),
            (422, Some("spacing_s"))
        );
        let e = geo_job(
            pairs(&[("spacing_s", "30"), ("samples", "10")]),
            GeoEndpoint::Evaluate,
            &l,
        )
        .unwrap_err();
        assert_eq!(e.status.as_u16(), 422);
        let job = geo_job(
            pairs(&[("at", "1,2010-10-03T09:36:30Z")]),
            GeoEndpoint::Evaluate,
            &l,
        )
        .unwrap();
        assert_eq!(job.time.at_unix_s, Some(vec![1.0, 1286098590.0]));
        let e = geo_job(pairs(&[("at", "1,,2")]), GeoEndpoint::Evaluate, &l).unwrap_err();
        assert_eq!(
            (e.status.as_u16(), e.parameter.as_deref()),
            (422, Some("at"))
        );
        let e = geo_job(pairs(&[("spacing_s", "0")]), GeoEndpoint::Evaluate, &l).unwrap_err();
        assert_eq!(
            (e.status.as_u16(), e.parameter.as_deref()),
            (422, Some("spacing_s"))
        );
        let e = geo_job(pairs(&[("at", "1")]), GeoEndpoint::Fit, &l).unwrap_err();
        assert_eq!(e.status.as_u16(), 400, "at is not a fit parameter");
        // The S^n fit knows no time.
        let p = Params::new(pairs(&[("parameterization", "time")]), SPHERE_FIT_PARAMS).unwrap();
        assert!(fit_options(&p, FitOptions::default()).is_err());
    }
}
