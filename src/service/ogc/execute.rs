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
use crate::service::auth::Owner;
use crate::service::error::ApiError;
use crate::service::handlers::{geo_run, output_media_type, parse_json, respond, Progress, JSON};
use crate::service::ogc::jobs::status_info;
use crate::service::ogc::postgres::{Claim, PgStore};
use crate::service::ogc::processes::process;
use crate::service::ogc::store::{is_job_id, JobStore, Status};
use crate::service::ogc::{base_url, json_response};
use crate::service::query::{GeoEndpoint, Params};
use crate::service::request::PostRequest;
use crate::service::{AppState, ServiceConfig, Slot};
use crate::sphere::cancel::Cancel;
use axum::extract::{Extension, Path, State};
use axum::http::{header, HeaderMap, HeaderValue, StatusCode};
use axum::response::Response;
use serde_json::{json, Value};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// A checked execute request.
#[derive(Debug)]
pub(crate) struct Execution {
    pub job: Job,
    pub data: Value,
    /// `"response": "document"`: the output wrapped as `{"result": …}`.
    pub document: bool,
    /// `data` was read from a job result (`{"href": …}`).
    pub from_reference: bool,
}

/// Where `{"href": …}` references are read: the caller's jobs in the store, or nowhere (a
/// stored job's request, whose references were resolved when it was posted).
pub(crate) struct References<'a> {
    pub store: Option<&'a JobStore>,
    pub owner: &'a Owner,
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
    refs: &References<'_>,
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
    let (data, from_reference) = resolve_data(data, config, refs, base)?;
    Ok(Execution {
        job,
        data,
        document,
        from_reference,
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
    refs: &References<'_>,
    base: &str,
) -> Result<(Value, bool), ApiError> {
    let Value::Object(mut o) = data else {
        return Err(invalid(
            "/inputs/data",
            "data must be a GeoJSON object or {\"href\": …}",
        ));
    };
    if !o.contains_key("type") {
        if let Some(v) = o.remove("value") {
            return Ok((v, false));
        }
        if let Some(href) = o.get("href") {
            let href = href
                .as_str()
                .ok_or_else(|| invalid("/inputs/data/href", "href must be a string"))?;
            return read_reference(href, config, refs, base).map(|v| (v, true));
        }
    }
    Ok((Value::Object(o), false))
}

fn bad_reference(detail: String) -> ApiError {
    ApiError::unprocessable("invalid-reference", detail).at("/inputs/data/href")
}

fn read_reference(
    href: &str,
    config: &ServiceConfig,
    refs: &References<'_>,
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
    let Some(store) = refs.store else {
        return Err(bad_reference(format!(
            "{href:?} was not resolved when the job was posted"
        )));
    };
    let gone = || {
        bad_reference(format!(
            "there is no job {id} (it may have expired or been dismissed)"
        ))
    };
    let record = store.get_blocking(refs.owner, id)?.ok_or_else(gone)?;
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
    let bytes = store.result_blocking(refs.owner, id)?.ok_or_else(|| {
        tracing::warn!(job = %id, "cannot read a job result");
        bad_reference(format!("the result of job {id} cannot be read"))
    })?;
    parse_json(&bytes).map_err(|_| bad_reference(format!("the result of job {id} is not JSON")))
}

/// The request stored for a PostgreSQL job: the execute request as posted, or, when its data
/// was a reference, with the data read in its place (as `{"value": …}`, so that it is read
/// back as it is), since the replica that runs it reads no references.
fn stored_request(bytes: &[u8], x: &Execution) -> Result<Vec<u8>, ApiError> {
    if !x.from_reference {
        return Ok(bytes.to_vec());
    }
    let mut v = parse_json(bytes)?;
    v["inputs"]["data"] = json!({ "value": x.data });
    serde_json::to_vec(&v).map_err(|_| ApiError::internal())
}

const ROUTE: &str = "/processes/{id}/execution";

pub(super) async fn execute(
    State(state): State<AppState>,
    Extension(owner): Extension<Owner>,
    Path(id): Path<String>,
    headers: HeaderMap,
    req: PostRequest,
) -> Result<Response, ApiError> {
    let asynchronous = prefers_async(&headers);
    let store = state.jobs.clone();
    // Asked before the body is read (and answered after the request's own checks).
    let refused = if asynchronous {
        store.refusal(&owner).await
    } else {
        None
    };
    let (endpoint, accepted) = req
        .accept(&[JSON], |pairs| {
            let endpoint = process(&id)?;
            Params::new(pairs, &[])?;
            if let Some(r) = refused {
                return Err(r.into());
            }
            Ok(endpoint)
        })
        .await?;
    let base = base_url(&headers);
    let config = state.config.clone();
    if !asynchronous {
        let (body, media_type) = accepted
            .run(ROUTE, move |bytes, cancel| {
                let refs = References {
                    store: Some(&store),
                    owner: &owner,
                };
                let x = read_execution(bytes, endpoint, &config, &refs, &base)?;
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
    let postgres = matches!(&*store, JobStore::Postgres(_));
    let (checked, stored) = {
        let (config, store, base, owner) =
            (config.clone(), store.clone(), base.clone(), owner.clone());
        tokio::task::spawn_blocking(move || {
            let refs = References {
                store: Some(&store),
                owner: &owner,
            };
            let x = read_execution(&held.bytes, endpoint, &config, &refs, &base)?;
            let stored = if postgres {
                Some(stored_request(&held.bytes, &x)?)
            } else {
                None
            };
            drop(held);
            Ok::<_, ApiError>((x, stored))
        })
        .await
        .map_err(|_| ApiError::internal())??
    };
    let record = match (&*store, stored) {
        (JobStore::Postgres(pg), Some(input)) => {
            drop(checked);
            pg.enqueue(&owner, endpoint.kind().name(), &input).await?
        }
        (JobStore::Disk(disk), _) => {
            let deadline = Instant::now() + config.job_timeout;
            let cancel = Cancel::with_deadline(deadline);
            let progress = Arc::new(Progress::default());
            let record = disk.create(
                &owner,
                endpoint.kind().name(),
                cancel.clone(),
                progress.clone(),
            )?;
            tokio::spawn(run_job(
                state.clone(),
                record.id.clone(),
                endpoint,
                checked,
                cancel,
                progress,
                deadline,
            ));
            record
        }
        (JobStore::Postgres(_), None) => return Err(ApiError::internal()),
    };
    let job_id = record.id.clone();
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

/// How a job's work ended.
enum Outcome {
    Done {
        bytes: Vec<u8>,
        media_type: &'static str,
        points: usize,
        curves: usize,
    },
    Failed(String),
}

/// The message of a job past its time budget.
fn over_budget(config: &ServiceConfig) -> String {
    format!(
        "the job ran past its time budget of {} s (--job-timeout-s): send less work or fit with a larger tolerance",
        config.job_timeout.as_secs_f64()
    )
}

/// Runs a job's work holding `slot`, on the blocking pool.
async fn work(
    state: &AppState,
    slot: Slot,
    endpoint: GeoEndpoint,
    x: Execution,
    cancel: Cancel,
    progress: Arc<Progress>,
) -> Outcome {
    let config = state.config.clone();
    let metrics = state.metrics.clone();
    let work = tokio::task::spawn_blocking(move || {
        let _slot = slot;
        let t0 = Instant::now();
        let media_type = output_media_type(x.job.format);
        match geo_run(x.data, endpoint, x.job, &config, &cancel, &progress) {
            Ok((bytes, points, curves)) => {
                metrics.record_fit(ROUTE, t0.elapsed().as_secs_f64(), points, curves);
                Outcome::Done {
                    bytes,
                    media_type,
                    points,
                    curves,
                }
            }
            Err(_) if cancel.is_cancelled() => Outcome::Failed(over_budget(&config)),
            Err(e) => {
                let at = e
                    .pointer
                    .as_deref()
                    .map(|p| format!(" (at {p:?} of the data)"))
                    .unwrap_or_default();
                Outcome::Failed(format!("{}: {}{at}", e.slug, e.detail))
            }
        }
    });
    work.await.unwrap_or_else(|e| {
        tracing::error!(error = %e, "job work failed");
        Outcome::Failed("internal: an unexpected error occurred; it has been logged".into())
    })
}

/// A disk-store job's work: waits for a fitting slot (sharing them with requests), runs, and
/// stores the result or the reason it failed.
async fn run_job(
    state: AppState,
    id: String,
    endpoint: GeoEndpoint,
    x: Execution,
    cancel: Cancel,
    progress: Arc<Progress>,
    deadline: Instant,
) {
    let JobStore::Disk(store) = &*state.jobs else {
        return;
    };
    let store = store.clone();
    // The fitting slots are shared with requests: a full queue means waiting, not failing.
    let slot = loop {
        if cancel.is_cancelled() {
            store.fail(&id, over_budget(&state.config));
            return;
        }
        match state.enter(deadline).await {
            Ok(s) => break s,
            Err(e) if e.slug == "overloaded" => {
                tokio::time::sleep(Duration::from_millis(200)).await
            }
            Err(_) => {
                store.fail(&id, over_budget(&state.config));
                return;
            }
        }
    };
    store.start(&id);
    let outcome = work(&state, slot, endpoint, x, cancel, progress).await;
    // Writing a result is file-system work: off the async workers.
    let _ = tokio::task::spawn_blocking(move || match outcome {
        Outcome::Done {
            bytes,
            media_type,
            points,
            curves,
        } => store.succeed(&id, &bytes, media_type, points, curves),
        Outcome::Failed(why) => store.fail(&id, why),
    })
    .await;
}

/// How long an idle PostgreSQL worker waits before it looks for work again (a job posted to
/// this replica wakes it at once; one posted to another replica, or a lease that ran out, is
/// seen within this time).
pub(crate) const POLL: Duration = Duration::from_millis(200);

/// Starts this replica's PostgreSQL worker (nothing for the disk store): whenever a fitting
/// slot is free it claims the oldest waiting job (or one whose lease ran out) and runs it
/// ([`run_claimed`]).
pub(crate) fn start_worker(state: &AppState) {
    if matches!(&*state.jobs, JobStore::Postgres(_)) {
        tokio::spawn(worker(state.clone()));
    }
}

async fn worker(state: AppState) {
    let JobStore::Postgres(pg) = &*state.jobs else {
        return;
    };
    let mut failing = false;
    loop {
        let Some(slot) = state.free_slot().await else {
            return;
        };
        match pg.claim().await {
            Ok(Some(claim)) => {
                if failing {
                    tracing::info!("the job store is reachable again");
                    failing = false;
                }
                tokio::spawn(run_claimed(state.clone(), slot, claim));
                continue;
            }
            Ok(None) => {
                drop(slot);
                failing = false;
            }
            Err(why) => {
                drop(slot);
                if !failing {
                    tracing::warn!(error = %why, "the job store cannot be reached: no job is taken until it can");
                    failing = true;
                }
            }
        }
        pg.wait_for_work(POLL).await;
    }
}

/// Runs a job this replica claimed: renews the claim while it runs (cancelling the work when
/// the job was dismissed or another replica took it), then stores the outcome (kept only while
/// the claim is this replica's).
async fn run_claimed(state: AppState, slot: Slot, claim: Claim) {
    let JobStore::Postgres(pg) = &*state.jobs else {
        return;
    };
    let config = state.config.clone();
    let deadline = Instant::now() + config.job_timeout;
    let cancel = Cancel::with_deadline(deadline);
    let progress = Arc::new(Progress::default());
    let outcome = match prepare(&config, &claim).await {
        Err(why) => {
            drop(slot);
            Outcome::Failed(why)
        }
        Ok((endpoint, x)) => {
            let beat = tokio::spawn(heartbeat(
                pg.clone(),
                claim.id.clone(),
                progress.clone(),
                cancel.clone(),
                config.job_lease,
            ));
            let outcome = work(&state, slot, endpoint, x, cancel, progress).await;
            beat.abort();
            outcome
        }
    };
    // The outcome is written even if the database is away for a moment: a few tries, then
    // the lease runs out and another replica runs the job again.
    for attempt in 0..5u32 {
        let written = match &outcome {
            Outcome::Done {
                bytes,
                media_type,
                points,
                curves,
            } => {
                pg.succeed(&claim.id, bytes, media_type, *points, *curves)
                    .await
            }
            Outcome::Failed(why) => pg.fail(&claim.id, why).await,
        };
        match written {
            Ok(()) => return,
            Err(why) => {
                tracing::warn!(job = %claim.id, attempt, error = %why, "cannot store a job's outcome");
                tokio::time::sleep(Duration::from_secs(1)).await;
            }
        }
    }
}

/// A claimed job's process and checked request.
async fn prepare(
    config: &Arc<ServiceConfig>,
    claim: &Claim,
) -> Result<(GeoEndpoint, Execution), String> {
    let endpoint = process(&claim.process).map_err(|e| e.detail)?;
    let (config, input) = (config.clone(), claim.input.clone());
    tokio::task::spawn_blocking(move || {
        let owner = Owner::anonymous();
        let refs = References {
            store: None,
            owner: &owner,
        };
        read_execution(&input, endpoint, &config, &refs, "")
            .map(|x| (endpoint, x))
            .map_err(|e| format!("{}: {}", e.slug, e.detail))
    })
    .await
    .map_err(|e| format!("internal: {e}"))?
}

/// Renews a running job's lease (and writes its progress) until aborted; cancels the work
/// when the job is no longer this replica's (dismissed, or taken over after a lapse).
async fn heartbeat(
    pg: PgStore,
    id: String,
    progress: Arc<Progress>,
    cancel: Cancel,
    lease: Duration,
) {
    let every = (lease / 4).clamp(Duration::from_millis(50), Duration::from_secs(2));
    loop {
        tokio::time::sleep(every).await;
        match pg.renew(&id, progress.percent().min(99)).await {
            Ok(true) => {}
            Ok(false) => {
                tracing::info!(job = %id, "job dismissed or taken over: its work is cancelled");
                cancel.cancel();
                return;
            }
            Err(why) => tracing::warn!(job = %id, error = %why, "cannot renew a job's lease"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(body: Value) -> Result<Execution, ApiError> {
        let config = ServiceConfig::default();
        let store = JobStore::Disk(super::super::DiskStore::open(&config));
        let owner = Owner::anonymous();
        let refs = References {
            store: Some(&store),
            owner: &owner,
        };
        read_execution(
            &serde_json::to_vec(&body).unwrap(),
            GeoEndpoint::Fit,
            &config,
            &refs,
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
