//! `GET /jobs`, `GET /jobs/{id}` (status and progress), `DELETE /jobs/{id}` (dismiss: the work
//! is cancelled and the files deleted), `GET /jobs/{id}/results` (the output document as it is,
//! with its media type, as pygeoapi answers a single output: so that `{"href": …/results}` of a
//! later execution and plain downloads read the same bytes).

use crate::service::auth::Owner;
use crate::service::error::ApiError;
use crate::service::handlers::{respond, GEO_JSON, JSON};
use crate::service::ogc::store::{is_job_id, JobRecord, Status};
use crate::service::ogc::{base_url, json_response, link};
use crate::service::AppState;
use axum::extract::{Extension, Path, State};
use axum::http::{HeaderMap, StatusCode};
use axum::response::Response;
use serde_json::{json, Value};

/// RFC 3339 of Unix seconds.
fn rfc3339(s: f64) -> String {
    jiff::Timestamp::from_microsecond((s * 1e6) as i64)
        .map(|t| t.to_string())
        .unwrap_or_default()
}

/// The OGC `statusInfo` of a job.
pub(crate) fn status_info(base: &str, r: &JobRecord) -> Value {
    let mut links = vec![link(
        format!("{base}/jobs/{}", r.id),
        "self",
        JSON,
        "job status",
    )];
    if r.status == Status::Successful {
        let media_type = r.media_type.as_deref().unwrap_or(GEO_JSON);
        links.push(link(
            format!("{base}/jobs/{}/results", r.id),
            "http://www.opengis.net/def/rel/ogc/1.0/results",
            media_type,
            "job result",
        ));
        if media_type == GEO_JSON {
            links.push(link(
                format!("{base}/collections/{}", r.id),
                "http://www.opengis.net/def/rel/ogc/1.0/data",
                JSON,
                "the result as an OGC API – Features collection",
            ));
        }
    }
    let mut v = json!({
        "jobID": r.id,
        "processID": r.process,
        "type": "process",
        "status": r.status,
        "progress": r.progress,
        "created": rfc3339(r.created_s),
        "links": links,
    });
    if let Some(m) = &r.message {
        v["message"] = json!(m);
    }
    if let Some(s) = r.started_s {
        v["started"] = json!(rfc3339(s));
    }
    if let Some(s) = r.finished_s {
        v["finished"] = json!(rfc3339(s));
        v["updated"] = json!(rfc3339(s));
    }
    v
}

fn no_such_job(id: &str) -> ApiError {
    let mut e = ApiError::not_found(&format!("/jobs/{id}"));
    e.detail = format!("no job {id:?} here (never created, expired or dismissed): see /jobs");
    e
}

/// `owner`'s job `id`.
///
/// # Errors
/// 404 when there is none (or it is another owner's); 503 `store-unavailable`.
pub(crate) async fn find(state: &AppState, owner: &Owner, id: &str) -> Result<JobRecord, ApiError> {
    if !is_job_id(id) {
        return Err(no_such_job(id));
    }
    state
        .jobs
        .get(owner, id)
        .await?
        .ok_or_else(|| no_such_job(id))
}

pub(super) async fn list(
    State(state): State<AppState>,
    Extension(owner): Extension<Owner>,
    headers: HeaderMap,
) -> Result<Response, ApiError> {
    let b = base_url(&headers);
    let jobs: Vec<Value> = state
        .jobs
        .list(&owner)
        .await?
        .iter()
        .map(|r| status_info(&b, r))
        .collect();
    let body = json!({
        "jobs": jobs,
        "links": [link(format!("{b}/jobs"), "self", JSON, "jobs")],
    });
    Ok(json_response(StatusCode::OK, &body, JSON))
}

pub(super) async fn status(
    State(state): State<AppState>,
    Extension(owner): Extension<Owner>,
    Path(id): Path<String>,
    headers: HeaderMap,
) -> Result<Response, ApiError> {
    let r = find(&state, &owner, &id).await?;
    Ok(json_response(
        StatusCode::OK,
        &status_info(&base_url(&headers), &r),
        JSON,
    ))
}

pub(super) async fn dismiss(
    State(state): State<AppState>,
    Extension(owner): Extension<Owner>,
    Path(id): Path<String>,
    headers: HeaderMap,
) -> Result<Response, ApiError> {
    if !is_job_id(&id) {
        return Err(no_such_job(&id));
    }
    let r = state
        .jobs
        .dismiss(&owner, &id)
        .await?
        .ok_or_else(|| no_such_job(&id))?;
    Ok(json_response(
        StatusCode::OK,
        &status_info(&base_url(&headers), &r),
        JSON,
    ))
}

/// A successful job's result bytes and media type.
///
/// # Errors
/// 404 `not-found` for no such job, 404 `result-not-ready` for a job that did not succeed
/// (saying why, for a failed one).
pub(crate) async fn result_bytes(
    state: &AppState,
    owner: &Owner,
    id: &str,
) -> Result<(Vec<u8>, &'static str), ApiError> {
    let r = find(state, owner, id).await?;
    match r.status {
        Status::Successful => {}
        Status::Failed => {
            return Err(ApiError::new(
                StatusCode::NOT_FOUND,
                "result-not-ready",
                format!(
                    "job {id} failed, so it has no result: {}",
                    r.message.unwrap_or_default()
                ),
            ))
        }
        s => {
            return Err(ApiError::new(
                StatusCode::NOT_FOUND,
                "result-not-ready",
                format!(
                    "job {id} is {s:?} ({} %): poll /jobs/{id} until it is successful",
                    r.progress
                ),
            ))
        }
    }
    let bytes = state
        .jobs
        .result(owner, id)
        .await?
        .ok_or_else(|| no_such_job(id))?;
    let media_type = if r.media_type.as_deref() == Some(GEO_JSON) {
        GEO_JSON
    } else {
        JSON
    };
    Ok((bytes, media_type))
}

pub(super) async fn results(
    State(state): State<AppState>,
    Extension(owner): Extension<Owner>,
    Path(id): Path<String>,
) -> Result<Response, ApiError> {
    let (bytes, media_type) = result_bytes(&state, &owner, &id).await?;
    Ok(respond(media_type, bytes))
}
