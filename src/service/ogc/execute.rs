//! `POST /processes/{id}/execution`. The body is an OGC execute request,
//! `{"inputs": {"data": <GeoJSON or {"href": …}>, "<option>": <value>, …}, "response": "raw"}`,
//! read within the same body limits as `/v1` ([`super::super::request::PostRequest`]).
//!
//! * Synchronous (the default): the work runs as `/v1/fit` runs it, holding a fitting slot within
//!   the request's time budget; the answer is the output document (`"response": "raw"`, the
//!   default) or `{"result": <document>}` (`"response": "document"`).
//! * `Prefer: respond-async`: the request is checked (options, `data`) and answered at once with
//!   `201`, a `Location` and the job's status; the work runs in the background under the job
//!   time budget (`job_timeout`), taking a fitting slot like any request.
//!
//! Options are read as [`RawOptions::set`] reads the query (a JSON value of the type the process
//! description gives, or `{"value": …}`) and checked by [`into_job`], so a 422 names the same
//! option, with a pointer into the execute request.

use crate::earth::into_job;
use crate::earth::job::{Job, OptionType, RawOptions};
use crate::service::error::ApiError;
use crate::service::handlers::{geo_run, output_media_type, parse_json, respond, Progress, JSON};
use crate::service::ogc::jobs::status_info;
use crate::service::ogc::processes::process;
use crate::service::ogc::store::{is_job_id, JobStore, Refusal, Status};
use crate::service::ogc::{base_url, json_response};
use crate::service::query::{GeoEndpoint, Params};
use crate::service::request::PostRequest;
use crate::service::{AppState, ServiceConfig};
use crate::sphere::cancel::Cancel;
use axum::extract::{Path, State};
use axum::http::{header, HeaderMap, HeaderValue, StatusCode};
use axum::response::Response;
use serde_json::{json, Value};
use std::sync::Arc;
use std::time::Instant;

/// A checked execute request.
#[derive(Debug)]
pub(crate) struct Execution {
    pub job: Job,
    pub data: Value,
    /// `"response": "document"`: the output wrapped as `{"result": …}`.
    pub document: bool,
}

fn invalid(pointer: impl Into<String>, detail: impl Into<String>) -> ApiError {
    ApiError::new(StatusCode::BAD_REQUEST, "invalid-input", detail).at(pointer)
}

/// Whether the request asks for asynchronous execution (RFC 7240 `Prefer: respond-async`).
fn prefers_async(headers: &HeaderMap) -> bool {
    headers.get_all("prefer").iter().any(|v| {
        v.to_str().is_ok_and(|s| {
            s.split([',', ';'])
                .any(|t| t.trim().eq_ignore_ascii_case("respond-async"))
        })
    })
}

/// One option's JSON value as the text [`RawOptions::set`] reads.
fn option_text(name: &str, t: OptionType, v: &Value) -> Result<String, ApiError> {
    let at = format!("/inputs/{name}");
    let v = match v {
        Value::Object(o) if o.len() == 1 && o.contains_key("value") => &o["value"],
        v => v,
    };
    let text = match (t, v) {
        (OptionType::Integer, Value::Number(n)) if n.is_u64() => Some(n.to_string()),
        (OptionType::Number, Value::Number(n)) => Some(n.to_string()),
        (OptionType::Boolean, Value::Bool(b)) => Some(b.to_string()),
        (OptionType::Text | OptionType::OneOf(_), Value::String(s)) => Some(s.clone()),
        _ => None,
    };
    text.ok_or_else(|| {
        let expected = match t {
            OptionType::Integer => "a non-negative integer".to_string(),
            OptionType::Number => "a number".to_string(),
            OptionType::Boolean => "true or false".to_string(),
            OptionType::Text => "a string".to_string(),
            OptionType::OneOf(names) => format!("one of the strings {}", names.join(", ")),
        };
        invalid(at, format!("input {name} is {v}, not {expected}")).param(name.to_string())
    })
}

/// Reads an execute request for `endpoint` (module docs); `base` is this server's URL, for
/// references.
///
/// # Errors
/// 400 `malformed-json` / `invalid-input` for a request that is not one; 422 from
/// [`into_job`] naming the option (and pointing at it); what [`resolve_data`] returns.
pub(crate) fn read_execution(
    bytes: &[u8],
    endpoint: GeoEndpoint,
    config: &ServiceConfig,
    store: &JobStore,
    base: &str,
) -> Result<Execution, ApiError> {
    let mut request = match parse_json(bytes)? {
        Value::Object(o) => o,
        _ => {
            return Err(invalid(
                "",
                "the body must be an execute request: {\"inputs\": {\"data\": …}}",
            ))
        }
    };
    for key in request.keys() {
        if !matches!(
            key.as_str(),
            "inputs" | "outputs" | "response" | "subscriber"
        ) {
            return Err(invalid(
                format!("/{key}"),
                format!(
                    "unknown member {key:?}: an execute request has inputs, outputs and response"
                ),
            ));
        }
    }
    let document = match request.get("response") {
        None => false,
        Some(Value::String(s)) if s == "raw" => false,
        Some(Value::String(s)) if s == "document" => true,
        Some(_) => return Err(invalid("/response", "response is \"raw\" or \"document\"")),
    };
    let mut inputs = match request.remove("inputs") {
        Some(Value::Object(o)) => o,
        _ => {
            return Err(invalid(
                "/inputs",
                "inputs must be an object holding data and the options",
            ))
        }
    };
    let kind = endpoint.kind();
    let data = inputs.remove("data").ok_or_else(|| {
        invalid(
            "/inputs/data",
            "the input data (a GeoJSON object, or {\"href\": …} to a job's result) is missing",
        )
    })?;
    let mut raw = RawOptions::default();
    for (name, value) in &inputs {
        if !kind.option_names().contains(&name.as_str()) {
            return Err(invalid(
                format!("/inputs/{name}"),
                format!(
                    "process {} has no input {name:?}: its inputs are data, {}",
                    kind.name(),
                    kind.option_names().join(", ")
                ),
            ));
        }
        let t = RawOptions::option_type(name).ok_or_else(ApiError::internal)?;
        let text = option_text(name, t, value)?;
        raw.set(name, &text)
            .map_err(|e| invalid(format!("/inputs/{name}"), e.to_string()).param(name.clone()))?;
    }
    let job = into_job(raw, kind, &config.limits).map_err(|e| {
        let e = ApiError::from(e);
        match e.parameter.clone() {
            Some(name) if e.pointer.is_none() => e.at(format!("/inputs/{name}")),
            _ => e,
        }
    })?;
    let data = resolve_data(data, config, store, base)?;
    Ok(Execution {
        job,
        data,
        document,
    })
}

/// The `data` input: a GeoJSON value as it is, `{"value": …}` unwrapped, or `{"href": …}` read
/// from this server's job store (never fetched: only `…/jobs/{id}/results` of this server).
///
/// # Errors
/// 400 for anything else; 422 `invalid-reference` for a reference to another server or to a
/// job that is not a successful GeoJSON one; 413 for a referenced result over the body limit.
fn resolve_data(
    data: Value,
    config: &ServiceConfig,
    store: &JobStore,
    base: &str,
) -> Result<Value, ApiError> {
    let Value::Object(mut o) = data else {
        return Err(invalid(
            "/inputs/data",
            "data must be a GeoJSON object or {\"href\": …}",
        ));
    };
    if !o.contains_key("type") {
        if let Some(v) = o.remove("value") {
            return Ok(v);
        }
        if let Some(href) = o.get("href") {
            let href = href
                .as_str()
                .ok_or_else(|| invalid("/inputs/data/href", "href must be a string"))?;
            return read_reference(href, config, store, base);
        }
    }
    Ok(Value::Object(o))
}

fn bad_reference(detail: String) -> ApiError {
    ApiError::unprocessable("invalid-reference", detail).at("/inputs/data/href")
}

fn read_reference(
    href: &str,
    config: &ServiceConfig,
    store: &JobStore,
    base: &str,
) -> Result<Value, ApiError> {
    let path = if let Some(rest) = href
        .strip_prefix("http://")
        .or_else(|| href.strip_prefix("https://"))
    {
        let (authority, path) = rest.split_at(rest.find('/').unwrap_or(rest.len()));
        let own = base.trim_start_matches("http://");
        if !authority.eq_ignore_ascii_case(own) {
            return Err(bad_reference(format!(
                "{href:?} is not on this server ({own}): only results of this server's jobs are read, no URL is fetched"
            )));
        }
        path
    } else {
        href
    };
    let id = path
        .strip_prefix("/jobs/")
        .and_then(|p| p.strip_suffix("/results"))
        .filter(|id| is_job_id(id))
        .ok_or_else(|| {
            bad_reference(format!(
                "{href:?} is not a job result here: give …/jobs/{{jobId}}/results"
            ))
        })?;
    let record = store.get(id).ok_or_else(|| {
        bad_reference(format!(
            "there is no job {id} (it may have expired or been dismissed)"
        ))
    })?;
    if record.status != Status::Successful
        || record.media_type.as_deref() != Some(super::super::handlers::GEO_JSON)
    {
        return Err(bad_reference(format!(
            "job {id} is {:?}, not a successful job with a GeoJSON result",
            record.status
        )));
    }
    if record.result_bytes > config.max_body_bytes as u64 {
        return Err(ApiError::body_too_large(config.max_body_bytes).at("/inputs/data/href"));
    }
    let bytes = std::fs::read(store.result_path(id)).map_err(|e| {
        tracing::warn!(job = %id, error = %e, "cannot read a job result");
        bad_reference(format!("the result of job {id} cannot be read"))
    })?;
    parse_json(&bytes).map_err(|_| bad_reference(format!("the result of job {id} is not JSON")))
}

/// The `201`/`429`/`503` for a refused job.
fn refusal(r: Refusal) -> ApiError {
    match r {
        Refusal::TooManyJobs(n) => {
            let mut e = ApiError::new(
                StatusCode::TOO_MANY_REQUESTS,
                "too-many-jobs",
                format!("{n} jobs are waiting or running, as many as this server runs at once: retry after the time in Retry-After, or dismiss a job"),
            );
            e.retry_after_s = Some(5);
            e
        }
        Refusal::Full { used, budget } => {
            let mut e = ApiError::new(
                StatusCode::SERVICE_UNAVAILABLE,
                "store-full",
                format!("the job store holds {used} of its {budget} bytes: dismiss finished jobs, or retry once old ones expire"),
            );
            e.retry_after_s = Some(60);
            e
        }
        Refusal::Unavailable(why) => {
            tracing::error!(error = %why, "the job store cannot be written");
            let mut e = ApiError::new(
                StatusCode::SERVICE_UNAVAILABLE,
                "store-full",
                "the job store cannot be written at the moment",
            );
            e.retry_after_s = Some(60);
            e
        }
    }
}

const ROUTE: &str = "/processes/{id}/execution";

pub(super) async fn execute(
    State(state): State<AppState>,
    Path(id): Path<String>,
    headers: HeaderMap,
    req: PostRequest,
) -> Result<Response, ApiError> {
    let asynchronous = prefers_async(&headers);
    let store = state.jobs.clone();
    let (endpoint, accepted) = req
        .accept(&[JSON], |pairs| {
            let endpoint = process(&id)?;
            Params::new(pairs, &[])?;
            if asynchronous {
                if let Some(r) = store.refusal() {
                    return Err(refusal(r));
                }
            }
            Ok(endpoint)
        })
        .await?;
    let base = base_url(&headers);
    let config = state.config.clone();
    if !asynchronous {
        let (body, media_type) = accepted
            .run(ROUTE, move |bytes, cancel| {
                let x = read_execution(bytes, endpoint, &config, &store, &base)?;
                let media_type = output_media_type(x.job.format);
                let (out, points, curves) = geo_run(
                    x.data,
                    endpoint,
                    x.job,
                    &config,
                    cancel,
                    &Progress::default(),
                )?;
                if x.document {
                    let v: Box<serde_json::value::RawValue> =
                        serde_json::value::RawValue::from_string(
                            String::from_utf8(out).map_err(|_| ApiError::internal())?,
                        )
                        .map_err(|_| ApiError::internal())?;
                    let wrapped = serde_json::to_vec(&json!({ "result": v }))
                        .map_err(|_| ApiError::internal())?;
                    return Ok(((wrapped, JSON), points, curves));
                }
                Ok(((out, media_type), points, curves))
            })
            .await?;
        return Ok(respond(media_type, body));
    }
    // Asynchronous: check the request now (on the blocking pool, as all parsing), then answer.
    let held = accepted.into_body();
    let checked = {
        let (config, store, base) = (config.clone(), store.clone(), base.clone());
        tokio::task::spawn_blocking(move || {
            let r = read_execution(&held.bytes, endpoint, &config, &store, &base);
            drop(held);
            r
        })
        .await
        .map_err(|_| ApiError::internal())??
    };
    let deadline = Instant::now() + config.job_timeout;
    let cancel = Cancel::with_deadline(deadline);
    let progress = Arc::new(Progress::default());
    let record = store
        .create(endpoint.kind().name(), cancel.clone(), progress.clone())
        .map_err(refusal)?;
    let job_id = record.id.clone();
    tokio::spawn(run_job(
        state.clone(),
        job_id.clone(),
        endpoint,
        checked,
        cancel,
        progress,
        deadline,
    ));
    let mut res = json_response(StatusCode::CREATED, &status_info(&base, &record), JSON);
    let location = format!("{base}/jobs/{job_id}");
    if let Ok(v) = HeaderValue::from_str(&location) {
        res.headers_mut().insert(header::LOCATION, v);
    }
    res.headers_mut().insert(
        "preference-applied",
        HeaderValue::from_static("respond-async"),
    );
    Ok(res)
}

/// A job's work: waits for a fitting slot (sharing them with requests), runs, and stores the
/// result or the reason it failed.
async fn run_job(
    state: AppState,
    id: String,
    endpoint: GeoEndpoint,
    x: Execution,
    cancel: Cancel,
    progress: Arc<Progress>,
    deadline: Instant,
) {
    let store = state.jobs.clone();
    let budget_s = state.config.job_timeout.as_secs_f64();
    let over_budget = move || {
        format!("the job ran past its time budget of {budget_s} s (--job-timeout-s): send less work or fit with a larger tolerance")
    };
    // The fitting slots are shared with requests: a full queue means waiting, not failing.
    let slot = loop {
        if cancel.is_cancelled() {
            store.fail(&id, over_budget());
            return;
        }
        match state.enter(deadline).await {
            Ok(s) => break s,
            Err(e) if e.slug == "overloaded" => {
                tokio::time::sleep(std::time::Duration::from_millis(200)).await
            }
            Err(_) => {
                store.fail(&id, over_budget());
                return;
            }
        }
    };
    store.start(&id);
    let config = state.config.clone();
    let metrics = state.metrics.clone();
    let work_store = store.clone();
    let work_id = id.clone();
    let work = tokio::task::spawn_blocking(move || {
        let _slot = slot;
        let t0 = Instant::now();
        let media_type = output_media_type(x.job.format);
        let r = geo_run(x.data, endpoint, x.job, &config, &cancel, &progress);
        match r {
            Ok((bytes, points, curves)) => {
                metrics.record_fit(ROUTE, t0.elapsed().as_secs_f64(), points, curves);
                work_store.succeed(&work_id, &bytes, media_type, points, curves);
            }
            Err(_) if cancel.is_cancelled() => work_store.fail(&work_id, over_budget()),
            Err(e) => {
                let at = e
                    .pointer
                    .as_deref()
                    .map(|p| format!(" (at {p:?} of the data)"))
                    .unwrap_or_default();
                work_store.fail(&work_id, format!("{}: {}{at}", e.slug, e.detail));
            }
        }
    });
    if let Err(e) = work.await {
        tracing::error!(job = %id, error = %e, "job work failed");
        store.fail(
            &id,
            "internal: an unexpected error occurred; it has been logged".into(),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(body: Value) -> Result<Execution, ApiError> {
        let config = ServiceConfig::default();
        let store = JobStore::open(&config);
        read_execution(
            &serde_json::to_vec(&body).unwrap(),
            GeoEndpoint::Fit,
            &config,
            &store,
            "http://h:1",
        )
    }

    const LINE: &str = r#"{"type": "LineString", "coordinates": [[0, 0], [1, 1], [2, 0]]}"#;

    #[test]
    fn options_are_read_as_the_query_reads_them() {
        let data: Value = serde_json::from_str(LINE).unwrap();
        let x = read(json!({"inputs": {"data": data, "tolerance_m": 100, "degree": {"value": 3}, "topology": "per-feature"}})).unwrap();
        assert_eq!(x.job.topology, crate::earth::Topology::PerFeature);
        assert!(!x.document);
        // Wrong type: 400 at the input.
        let e = read(json!({"inputs": {"data": data, "degree": "3"}})).unwrap_err();
        assert_eq!(
            (e.status.as_u16(), e.pointer.as_deref()),
            (400, Some("/inputs/degree"))
        );
        // Out of range: into_job's 422, naming and pointing at the input.
        let e = read(json!({"inputs": {"data": data, "degree": 9}})).unwrap_err();
        assert_eq!(
            (
                e.status.as_u16(),
                e.parameter.as_deref(),
                e.pointer.as_deref()
            ),
            (422, Some("degree"), Some("/inputs/degree"))
        );
        let e = read(json!({"inputs": {"data": data, "beta1": 1}})).unwrap_err();
        assert_eq!(e.status.as_u16(), 400, "not an input of fit");
        let e = read(json!({"inputs": {}})).unwrap_err();
        assert_eq!(e.pointer.as_deref(), Some("/inputs/data"));
        assert_eq!(read(json!({"input": {}})).unwrap_err().status.as_u16(), 400);
        assert_eq!(crate::earth::OutputFormat::default(), x.job.format);
    }

    #[test]
    fn references_never_leave_this_server() {
        for href in [
            "http://example.com/jobs/0123456789abcdef0123456789abcdef/results",
            "/etc/passwd",
            "/jobs/../../results",
            "/jobs/0123456789abcdef0123456789abcdef/results",
        ] {
            let e = read(json!({"inputs": {"data": {"href": href}}})).unwrap_err();
            assert_eq!(
                (e.status.as_u16(), e.slug),
                (422, "invalid-reference"),
                "{href}"
            );
        }
    }

    #[test]
    fn prefer_is_read_as_rfc_7240_says() {
        let mut h = HeaderMap::new();
        assert!(!prefers_async(&h));
        h.insert(
            "prefer",
            HeaderValue::from_static("return=minimal, respond-async"),
        );
        assert!(prefers_async(&h));
        h.insert("prefer", HeaderValue::from_static("respond-async; wait=10"));
        assert!(prefers_async(&h));
    }
}
