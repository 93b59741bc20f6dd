//! Route handlers. Each POST handler takes a [`PostRequest`] (the content type and the query
//! are checked before the body is read, the body is read within its bounds) and does all
//! parsing and CPU work on the blocking pool within the request's time budget
//! ([`super::request::Accepted::run`]), checking every output size before the work that would
//! make it.

use crate::document::beta::{curve_from_json, InterpolationDocument};
use crate::document::{pointer, tolerance_document, FitDocument, PointsInput, SamplesDocument};
use crate::earth::features::{Document, FeatureStats};
use crate::earth::job::{Job, Topology};
use crate::service::error::ApiError;
use crate::service::files;
use crate::service::query;
use crate::service::query::{fit_options, GeoEndpoint, Params};
use crate::service::request::PostRequest;
use crate::service::{AppState, ServiceConfig, OPENAPI_JSON, OPENAPI_JSON_TYPE, OPENAPI_YAML};
use crate::sphere::cancel::Cancel;
use crate::sphere::compare::{fit_with, CompareError, Method, MethodOptions};
use crate::sphere::compress::tolerance::{fit_to_tolerance, ToleranceOptions};
use crate::sphere::curve::SphericalCurve;
use crate::sphere::interpolate;
use crate::sphere::interpolate::beta::InterpolationOptions;
use crate::sphere::{InputSite, SphereError};
use axum::extract::State;
use axum::http::{header, HeaderValue, StatusCode, Uri};
use axum::response::{IntoResponse, Response};
use rayon::prelude::*;
use serde_json::{json, Value};
use std::sync::atomic::{AtomicUsize, Ordering};

pub(crate) const GEO_JSON: &str = "application/geo+json";
pub(crate) const JSON: &str = "application/json";

/// Parses JSON; a UTF-8 byte order mark in front is skipped (RFC 8259 §8.1 lets a parser
/// ignore it, and Windows tools write one).
pub(crate) fn parse_json(bytes: &[u8]) -> Result<Value, ApiError> {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    serde_json::from_slice(bytes)
        .map_err(|e| ApiError::malformed_json(format!("the body is not valid JSON: {e}")))
}

pub(crate) fn respond(content_type: &'static str, body: Vec<u8>) -> Response {
    let mut res = (StatusCode::OK, body).into_response();
    res.headers_mut()
        .insert(header::CONTENT_TYPE, HeaderValue::from_static(content_type));
    res
}

pub(super) async fn fit(req: PostRequest) -> Result<Response, ApiError> {
    geo(req, GeoEndpoint::Fit).await
}

pub(super) async fn interpolate_geo(req: PostRequest) -> Result<Response, ApiError> {
    geo(req, GeoEndpoint::Interpolate).await
}

pub(super) async fn evaluate(req: PostRequest) -> Result<Response, ApiError> {
    geo(req, GeoEndpoint::Evaluate).await
}

async fn geo(req: PostRequest, endpoint: GeoEndpoint) -> Result<Response, ApiError> {
    let config = req.state().config.clone();
    // `/v1/fit` also takes the files of `crate::formats` and answers a GeoPackage on request
    // (`super::files`).
    let fit = matches!(endpoint, GeoEndpoint::Fit);
    let upload = if fit {
        files::upload_kind(req.headers())
    } else {
        None
    };
    let geopackage = fit && files::wants_geopackage(req.headers());
    let types: &[&str] = if fit {
        &[
            GEO_JSON,
            JSON,
            files::ZIP,
            files::GEOPACKAGE,
            files::FLATGEOBUF,
            files::GPX,
        ]
    } else {
        &[GEO_JSON, JSON]
    };
    let (job, accepted) = req
        .accept(types, |mut pairs| {
            // A GPX track's times are its parameterisation unless the query says otherwise.
            let time_given = pairs
                .iter()
                .any(|(k, _)| k == "parameterization" || k == "time_property");
            if upload == Some(crate::formats::Kind::Gpx) && !time_given {
                pairs.push(("parameterization".into(), "time".into()));
            }
            query::geo_job(pairs, endpoint, &config.limits)
        })
        .await?;
    let format = job.format;
    if geopackage && format != crate::earth::job::OutputFormat::GeoJson {
        return Err(ApiError::unprocessable(
            "conflicting-options",
            "Accept: application/geopackage+sqlite3 writes features: leave out format=topojson",
        )
        .param("format"));
    }
    let out = accepted
        .run(endpoint.route(), move |bytes, cancel| {
            let value = match upload {
                Some(kind) => files::read_upload(bytes, kind)?,
                None if fit => files::decode_topology(parse_json(bytes)?)?,
                None => parse_json(bytes)?,
            };
            let (out, points, curves) =
                geo_run(value, endpoint, job, &config, cancel, &Progress::default())?;
            let out = if geopackage {
                files::to_geopackage(&out)?
            } else {
                out
            };
            Ok((out, points, curves))
        })
        .await?;
    if geopackage {
        return Ok(respond(files::GEOPACKAGE, out));
    }
    Ok(respond(output_media_type(format), out))
}

/// The media type of a GeoJSON operation's output in `format`.
pub(super) fn output_media_type(format: crate::earth::coverage::OutputFormat) -> &'static str {
    match format {
        crate::earth::coverage::OutputFormat::TopoJson => JSON,
        crate::earth::coverage::OutputFormat::GeoJson => GEO_JSON,
    }
}

/// How far a computation is: curves (features) done out of a total, read by a job's status
/// while the work runs (`/jobs/{id}` progress); requests ignore it.
#[derive(Debug, Default)]
pub(crate) struct Progress {
    /// Features processed so far.
    pub done: AtomicUsize,
    /// Features to process (0 until the document has been parsed).
    pub total: AtomicUsize,
}

impl Progress {
    /// Per cent done, 0 to 100.
    pub fn percent(&self) -> u8 {
        let total = self.total.load(Ordering::Relaxed);
        if total == 0 {
            return 0;
        }
        let done = self.done.load(Ordering::Relaxed).min(total);
        u8::try_from(done * 100 / total).unwrap_or(100)
    }
}

/// The work of `/v1/fit`, `/v1/interpolate` and `/v1/evaluate` on a parsed document: the one
/// path every front end of the service takes (the OGC API – Processes execution calls it
/// too), with the options already checked into `job`.
pub(crate) fn geo_run(
    value: Value,
    endpoint: GeoEndpoint,
    job: Job,
    config: &ServiceConfig,
    cancel: &Cancel,
    progress: &Progress,
) -> Result<(Vec<u8>, usize, usize), ApiError> {
    let job = job.with_cancel(cancel.clone());
    match job.topology {
        Topology::Shared => coverage_work(value, &job, config),
        Topology::PerFeature => geo_work(value, endpoint, &job, config, cancel, progress),
    }
}

/// `topology=shared`: the whole document fitted as one coverage
/// ([`crate::earth::coverage::fit_coverage`]), written as GeoJSON or TopoJSON.
fn coverage_work(
    value: Value,
    job: &Job,
    config: &ServiceConfig,
) -> Result<(Vec<u8>, usize, usize), ApiError> {
    let doc = Document::parse(value, false)?;
    check_positions(&doc, config)?;
    let coverage = crate::earth::coverage::fit_coverage(doc, job)?;
    let stats = coverage.stats;
    if stats.curves == 0 {
        return Err(ApiError::unprocessable(
            "nothing-to-fit",
            "the input holds no LineString, MultiLineString, Polygon or MultiPolygon with coordinates (other geometries pass through, but there must be something to fit)",
        )
        .at(""));
    }
    if stats.output_points > config.max_output_points {
        return Err(output_too_large(
            stats.output_points.to_string(),
            config.max_output_points,
        ));
    }
    let bytes = match job.format {
        crate::earth::coverage::OutputFormat::TopoJson => {
            crate::earth::coverage::topojson::to_bytes(
                &crate::earth::coverage::topojson::to_topology(
                    coverage,
                    job.output.precision,
                    job.carry,
                ),
            )
        }
        crate::earth::coverage::OutputFormat::GeoJson => {
            serde_json::to_vec(&coverage.into_feature_collection(job.carry))
                .map_err(|_| ApiError::internal())?
        }
    };
    Ok((bytes, stats.input_points, stats.curves))
}

/// A 413 `too-many-points` for a document whose curves hold more positions than
/// the server takes, pointing at the first feature past the limit.
fn check_positions(doc: &Document, config: &ServiceConfig) -> Result<(), ApiError> {
    let (total, over) = doc.curve_positions(config.max_points);
    match over {
        Some(i) => Err(ApiError::too_many_points(
            total,
            config.max_points,
            doc.slots[i].pointer.clone(),
        )),
        None => Ok(()),
    }
}

/// Parses, fits (features in parallel, first error in input order wins) and serialises.
fn geo_work(
    value: Value,
    endpoint: GeoEndpoint,
    job: &Job,
    config: &ServiceConfig,
    cancel: &Cancel,
    progress: &Progress,
) -> Result<(Vec<u8>, usize, usize), ApiError> {
    let doc = Document::parse(value, endpoint == GeoEndpoint::Evaluate)?;
    if endpoint != GeoEndpoint::Evaluate {
        check_positions(&doc, config)?;
    }
    // Output that is known before any work (`samples` per curve) is checked up front; the
    // rest (automatic sampling, spacing_m) is counted as features finish, and the work stops
    // as soon as the running total passes the limit.
    let per_curve = match job.output.sampling {
        crate::earth::Sampling::Samples(n)
        | crate::earth::Sampling::SpacingAndSamples { samples: n, .. } => n,
        _ => 2,
    };
    let evaluate = endpoint == GeoEndpoint::Evaluate;
    let curves: usize = doc.slots.iter().map(|s| s.curve_count(evaluate)).sum();
    let floor = curves.saturating_mul(per_curve);
    if floor > config.max_output_points {
        return Err(output_too_large(
            format!("{curves} curves x {per_curve} points = {floor}"),
            config.max_output_points,
        ));
    }
    progress.total.store(doc.slots.len(), Ordering::Relaxed);
    let lowest_failed = AtomicUsize::new(usize::MAX);
    let output_total = AtomicUsize::new(0);
    let results: Vec<Option<Result<crate::earth::ProcessedFeature, ApiError>>> = doc
        .slots
        .par_iter()
        .enumerate()
        .map(|(i, slot)| {
            if cancel.is_cancelled() || i > lowest_failed.load(Ordering::Relaxed) {
                return None;
            }
            let mut r = slot.process(job).map_err(ApiError::from);
            progress.done.fetch_add(1, Ordering::Relaxed);
            if let Ok(p) = &r {
                let total = output_total.fetch_add(p.stats.output_points, Ordering::Relaxed)
                    + p.stats.output_points;
                if total > config.max_output_points {
                    r = Err(output_too_large(
                        format!("more than {total}"),
                        config.max_output_points,
                    ));
                }
            }
            if r.is_err() {
                lowest_failed.fetch_min(i, Ordering::Relaxed);
            }
            Some(r)
        })
        .collect();
    let mut features = Vec::with_capacity(results.len());
    let mut stats = FeatureStats::default();
    for r in results {
        match r {
            Some(Ok(p)) => {
                stats.merge(&p.stats);
                features.push(p.feature);
            }
            Some(Err(e)) => return Err(e),
            None => return Err(ApiError::timeout(config.request_timeout.as_secs_f64())),
        }
    }
    if stats.curves == 0 {
        return Err(ApiError::unprocessable(
            "nothing-to-fit",
            match endpoint {
                GeoEndpoint::Evaluate => "no feature carries properties.fit or properties.interpolation (as written by /v1/fit and /v1/interpolate), and the body is not a spline document with \"crs\": \"lonlat\"",
                _ => "the input holds no LineString, MultiLineString, Polygon or MultiPolygon with coordinates (other geometries pass through, but there must be something to fit)",
            },
        )
        .at(""));
    }
    let out = doc.into_feature_collection(features, true);
    let bytes = serde_json::to_vec(&out).map_err(|_| ApiError::internal())?;
    Ok((bytes, stats.input_points, stats.curves))
}

/// 422 `output-too-large`: `what` says how many points the output would have.
fn output_too_large(what: String, limit: usize) -> ApiError {
    ApiError::unprocessable(
        "output-too-large",
        format!(
            "the output would have {what} points, more than the limit of {limit} per request: use fewer samples, a larger spacing_m or fewer curves per request"
        ),
    )
    .at("")
}

/// A math-core error on the points at `base` as a 422: the problem type by kind, the place
/// from [`SphereError::site`] (an option as the query parameter, else a JSON pointer).
fn sphere_error(e: SphereError, base: &str) -> ApiError {
    let kind = match e {
        SphereError::InvalidDegree { .. }
        | SphereError::InvalidControlPointCount { .. }
        | SphereError::InvalidShapeParameter { .. }
        | SphereError::ShapeParameterCount { .. } => "invalid-option",
        SphereError::InvalidParameters { .. } | SphereError::RepeatedPoint { .. } => {
            "invalid-points"
        }
        SphereError::TooFewPoints { .. } | SphereError::AllPointsEqual { .. } => "too-few-points",
        SphereError::Antipodal { .. } => "antipodal-points",
        SphereError::NotInterpolated { .. } | SphereError::DegenerateArc { .. } => {
            "not-interpolable"
        }
        SphereError::Cancelled => "cancelled",
        SphereError::NonFinite { .. } => "non-finite",
        _ => "unfittable",
    };
    let error = ApiError::unprocessable(kind, e.to_string());
    match e.site() {
        InputSite::Field { name, .. } => error.param(name),
        InputSite::Nothing => error,
        site => error.at(pointer(site, "", base)),
    }
}

fn check_point_count(n: usize, base: &str, config: &ServiceConfig) -> Result<(), ApiError> {
    if n > config.max_points {
        return Err(ApiError::too_many_points(
            n,
            config.max_points,
            base.to_string(),
        ));
    }
    Ok(())
}

/// The body of an S^n response made of one curve from `points` input points, with the counts
/// the metrics take (points, curves).
fn one_curve(
    doc: &impl serde::Serialize,
    points: usize,
) -> Result<(Vec<u8>, usize, usize), ApiError> {
    let body = serde_json::to_vec(doc).map_err(|_| ApiError::internal())?;
    Ok((body, points, 1))
}

/// The options of `/v1/sphere/fit` once checked: the B-spline fit's, the tolerance, and the
/// method with the `iterations` the caller gave (for the compared methods' cap).
type SphereFitOptions = (
    crate::sphere::FitOptions,
    Option<f64>,
    (Method, Option<usize>),
);

/// The options of `/v1/sphere/fit`, checked against the limits.
fn sphere_fit_options(
    config: &ServiceConfig,
    pairs: Vec<(String, String)>,
) -> Result<SphereFitOptions, ApiError> {
    let p = Params::new(pairs, query::SPHERE_FIT_PARAMS)?;
    let method = p
        .get::<Method>("method", "gls-pia, jupp-kent, samir, cbc or bcc")?
        .unwrap_or_default();
    if method != Method::GlsPia {
        let only_gls_pia = [
            "degree",
            "knots",
            "solver",
            "parameter_correction",
            "target_max_error_rad",
            "tolerance_rad",
        ];
        if let Some(other) = p.given().into_iter().find(|g| only_gls_pia.contains(g)) {
            return Err(ApiError::unprocessable(
                "conflicting-options",
                format!(
                    "{other} applies to method=gls-pia only, not method={}",
                    method.name()
                ),
            )
            .param(other));
        }
    }
    let mut options = fit_options(&p, crate::sphere::FitOptions::default())?;
    options.target_max_error_rad = p.num("target_max_error_rad")?;
    query::sphere_given_together(&p)?;
    let tolerance_rad = query::sphere_tolerance(&p)?;
    crate::earth::check_fit_options(&options, &config.limits)?;
    let iterations = p.int("iterations")?;
    Ok((options, tolerance_rad, (method, iterations)))
}

/// `/v1/sphere/fit?method=jupp-kent|samir|cbc|bcc` (`sphere::compare`): `control_points` is
/// the budget of free points (capped by the limit as GLS-PIA's), `iterations` caps the
/// iterative methods; the response is [`MethodFit::document`].
fn sphere_fit_method(
    input: &PointsInput,
    method: Method,
    fit: &crate::sphere::FitOptions,
    iterations: Option<usize>,
    cancel: &crate::sphere::cancel::Cancel,
    config: &ServiceConfig,
) -> Result<(Vec<u8>, usize, usize), ApiError> {
    let base = input.points_pointer;
    let n = input.points.len();
    let budget = fit
        .control_points
        .unwrap_or_else(|| crate::sphere::fit::default_control_points(n, 3))
        .min(config.limits.max_control_points);
    let options = MethodOptions {
        control_points: Some(budget),
        iterations,
        gls_pia: crate::sphere::FitOptions {
            parameterization: fit.parameterization,
            cancel: cancel.clone(),
            ..crate::sphere::FitOptions::default()
        },
        ..MethodOptions::default()
    };
    let r = fit_with(method, &input.points, input.parameters.as_deref(), &options).map_err(
        |e| match e {
            CompareError::Sphere(e) => sphere_error(e, base),
            CompareError::InvalidOption { option, .. } => {
                ApiError::unprocessable("invalid-option", e.to_string()).param(option)
            }
            CompareError::RepeatedParameter { index, .. } => {
                ApiError::unprocessable("invalid-points", e.to_string())
                    .at(format!("{base}/{index}"))
            }
            e => ApiError::unprocessable("unfittable", e.to_string()).at(base),
        },
    )?;
    one_curve(&r.document(), n)
}

pub(super) async fn sphere_fit(req: PostRequest) -> Result<Response, ApiError> {
    let config = req.state().config.clone();
    let ((options, tolerance_rad, method), accepted) = req
        .accept(&[JSON], |pairs| sphere_fit_options(&config, pairs))
        .await?;
    let out = accepted
        .run("/v1/sphere/fit", move |bytes, cancel| {
            let v = parse_json(bytes)?;
            let input = PointsInput::from_json(&v)?;
            let base = input.points_pointer;
            check_point_count(input.points.len(), base, &config)?;
            if method.0 != Method::GlsPia {
                return sphere_fit_method(&input, method.0, &options, method.1, cancel, &config);
            }
            if let Some(tolerance_rad) = tolerance_rad {
                // As `sphere fit --tolerance-rad`: degree caps the degrees tried.
                let mut t = ToleranceOptions {
                    parameterization: options.parameterization,
                    max_control_points: Some(config.limits.max_control_points),
                    cancel: cancel.clone(),
                    ..ToleranceOptions::default()
                };
                t.degrees.retain(|&d| d <= options.degree.max(1));
                let r = fit_to_tolerance(
                    &input.points,
                    input.parameters.as_deref(),
                    tolerance_rad,
                    &t,
                )
                .map_err(|e| sphere_error(e, base))?;
                return one_curve(&tolerance_document(&r), input.points.len());
            }
            let mut options = options;
            options.cancel = cancel.clone();
            if options.control_points.is_none() {
                let n =
                    crate::sphere::fit::default_control_points(input.points.len(), options.degree);
                options.control_points = Some(n.min(config.limits.max_control_points));
            }
            let report =
                crate::sphere::fit::fit(&input.points, input.parameters.as_deref(), &options)
                    .map_err(|e| sphere_error(e, base))?;
            one_curve(&FitDocument::from(&report), input.points.len())
        })
        .await?;
    Ok(respond(JSON, out))
}

pub(super) async fn sphere_interpolate(req: PostRequest) -> Result<Response, ApiError> {
    let config = req.state().config.clone();
    let (options, accepted) = req
        .accept(&[JSON], |pairs| {
            let p = Params::new(pairs, query::SPHERE_INTERPOLATE_PARAMS)?;
            let mut options = InterpolationOptions::default();
            if let Some(b) = p.num("beta1")? {
                options = options.with_beta1(b);
            }
            if let Some(b) = p.num("beta2")? {
                options = options.with_beta2(b);
            }
            let settings = crate::earth::InterpolateSettings {
                beta1: options.beta1[0],
                beta2: options.beta2[0],
            };
            crate::earth::Job::interpolate(settings)
                .validate()
                .map_err(ApiError::from)?;
            Ok(options)
        })
        .await?;
    let out = accepted
        .run("/v1/sphere/interpolate", move |bytes, cancel| {
            let mut options = options;
            options.cancel = cancel.clone();
            let v = parse_json(bytes)?;
            let input = PointsInput::from_json(&v)?;
            let base = input.points_pointer;
            if v.get("parameters").is_some() {
                return Err(ApiError::unprocessable(
                    "invalid-points",
                    "interpolation puts point j at parameter j; \"parameters\" are not used here",
                )
                .at("/parameters"));
            }
            check_point_count(input.points.len(), base, &config)?;
            let r = interpolate(&input.points, &options).map_err(|e| sphere_error(e, base))?;
            one_curve(&InterpolationDocument::from(&r), input.points.len())
        })
        .await?;
    Ok(respond(JSON, out))
}

pub(super) async fn sphere_evaluate(req: PostRequest) -> Result<Response, ApiError> {
    let config = req.state().config.clone();
    let max_numbers = config.max_output_points.saturating_mul(3);
    let ((at, count), accepted) = req
        .accept(&[JSON], |pairs| sphere_evaluate_options(&config, pairs))
        .await?;
    let out = accepted.run("/v1/sphere/evaluate", move |bytes, _| {
        let v = parse_json(bytes)?;
        let curve = curve_from_json(&v)
            .map_err(|e| ApiError::unprocessable("invalid-spline", e.message).at(e.pointer))?;
        // Output numbers (points x ambient dimension), checked before they are made.
        let numbers = count.saturating_mul(curve.dim());
        if numbers > max_numbers {
            return Err(ApiError::unprocessable(
                "output-too-large",
                format!(
                    "the output would have {count} points of dimension {} = {numbers} numbers, more than the limit of {max_numbers} (3 x the output point limit) per request: use fewer samples",
                    curve.dim()
                ),
            )
            .param(if at.is_some() { "at" } else { "samples" }));
        }
        let ts = at.unwrap_or_else(|| crate::sphere::curve::even_parameters(curve.domain(), count));
        let pts = curve.evaluate_many(&ts);
        if let Some(i) = pts.to_rows().iter().position(|r| r.iter().any(|x| !x.is_finite())) {
            return Err(ApiError::unprocessable(
                "non-finite",
                format!("the curve at parameter {} is not a finite point: its knot spans under- or overflow in floating point; rescale the knots", ts[i]),
            )
            .at("/knots"));
        }
        let n = ts.len();
        let body = serde_json::to_vec(&SamplesDocument {
            parameters: ts,
            points: pts.to_rows(),
        })
        .map_err(|_| ApiError::internal())?;
        Ok((body, n, 1))
    })
    .await?;
    Ok(respond(JSON, out))
}

/// The query of `/v1/sphere/evaluate`: explicit parameters, or the number of samples (not
/// both).
#[allow(clippy::type_complexity)]
fn sphere_evaluate_options(
    config: &ServiceConfig,
    pairs: Vec<(String, String)>,
) -> Result<(Option<Vec<f64>>, usize), ApiError> {
    let p = Params::new(pairs, query::SPHERE_EVALUATE_PARAMS)?;
    let max = config.limits.max_samples;
    let samples = p.int("samples")?;
    let at: Option<Vec<f64>> = match p.get::<String>("at", "a list")? {
        None => None,
        Some(s) => {
            let mut ts = Vec::new();
            for (i, x) in s.split(',').enumerate() {
                let t: f64 = query::parse_number(x).ok_or_else(|| {
                    ApiError::invalid_query(
                        "at",
                        format!("value {i} ({x:?}) is not a number: give comma-separated numbers"),
                    )
                })?;
                if !t.is_finite() {
                    return Err(ApiError::unprocessable(
                        "invalid-option",
                        format!("value {i} of at is not a finite number"),
                    )
                    .param("at"));
                }
                ts.push(t);
            }
            Some(ts)
        }
    };
    query::sphere_given_together(&p)?;
    let count = at.as_ref().map_or(samples.unwrap_or(101), Vec::len);
    if count > max || (at.is_none() && count < 1) {
        let name = if at.is_some() { "at" } else { "samples" };
        return Err(ApiError::unprocessable(
            "invalid-option",
            format!("{count} parameters: use 1 to {max} (the server's limit)"),
        )
        .param(name));
    }
    Ok((at, count))
}

pub(super) async fn health() -> Response {
    let body = json!({"status": "ok", "version": env!("CARGO_PKG_VERSION")});
    respond(
        JSON,
        serde_json::to_vec(&body).expect("a JSON value serialises"),
    )
}

pub(super) async fn openapi() -> Response {
    respond("application/yaml", OPENAPI_YAML.as_bytes().to_vec())
}

pub(super) async fn openapi_json() -> Response {
    respond(OPENAPI_JSON_TYPE, OPENAPI_JSON.as_bytes().to_vec())
}

pub(super) async fn metrics(State(state): State<AppState>) -> Response {
    respond(
        "text/plain; version=0.0.4; charset=utf-8",
        state.metrics.render().into_bytes(),
    )
}

pub(super) async fn not_found(uri: Uri) -> ApiError {
    ApiError::not_found(uri.path())
}
