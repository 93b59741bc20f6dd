//! Reading request bodies within bounds: the byte limit (413), a deadline for the whole body
//! (408), a global budget for the bytes of all bodies in flight, and a lingering read of what a
//! rejected request still sends (so that clients that write the whole body before reading the
//! answer, such as Python's urllib, see the error instead of a reset connection).

use crate::service::error::ApiError;
use crate::service::AppState;
use axum::body::{Body, Bytes};
use axum::http::{header, HeaderMap, StatusCode};
use http_body_util::BodyExt;
use std::time::{Duration, Instant};
use tokio::sync::OwnedSemaphorePermit;

/// Longest a rejected request's remaining body is read and discarded before the answer: as
/// nginx's `lingering_time`, a bound in time, not in bytes, so that a client that writes a body
/// of any size before reading (Python's urllib) gets the answer instead of a reset connection.
/// Reading costs no memory (nothing is kept) and little CPU; the connection is held at most
/// this long, within `max_connections`.
pub(crate) const DRAIN_TIMEOUT: Duration = Duration::from_secs(10);

/// A rejected body that sends nothing for this long is given up on (nginx's
/// `lingering_timeout`): a client that stopped sending is waiting for the answer.
pub(crate) const DRAIN_IDLE: Duration = Duration::from_secs(1);

/// A request body and its share of the global byte budget (returned when this is dropped).
pub(crate) struct HeldBody {
    pub bytes: Bytes,
    _budget: Option<OwnedSemaphorePermit>,
}

/// The `Content-Length` the client declared, if any.
fn declared_length(headers: &HeaderMap) -> Option<u64> {
    headers
        .get(header::CONTENT_LENGTH)
        .and_then(|v| v.to_str().ok())
        .and_then(|s| s.trim().parse().ok())
}

/// Reads and discards the rest of `body` until it ends, for at most [`DRAIN_TIMEOUT`], and
/// until nothing arrives for [`DRAIN_IDLE`].
pub(crate) async fn drain(body: Body) {
    let mut body = body;
    let until = tokio::time::Instant::now() + DRAIN_TIMEOUT;
    loop {
        let idle = (tokio::time::Instant::now() + DRAIN_IDLE).min(until);
        match tokio::time::timeout_at(idle, body.frame()).await {
            Ok(Some(Ok(_))) => {}
            _ => break,
        }
    }
}

/// `e`, after reading what is left of `body` (see the module docs).
pub(crate) async fn reject(_state: &AppState, body: Body, e: ApiError) -> ApiError {
    drain(body).await;
    e
}

fn body_timeout(budget: Duration) -> ApiError {
    ApiError::new(
        StatusCode::REQUEST_TIMEOUT,
        "body-timeout",
        format!(
            "the request body did not arrive within {} s: send it faster or send less",
            budget.as_secs_f64()
        ),
    )
    .at("")
}

fn no_room(budget: Duration) -> ApiError {
    let mut e = ApiError::overloaded();
    e.detail = format!(
        "the server holds as many request bodies as it may, and none finished within {} s: retry after the time in Retry-After",
        budget.as_secs_f64()
    );
    e
}

/// Reads the whole body of a request that arrived at `start`: at most `max_body_bytes` (413,
/// after a lingering read), within `body_timeout` of `start` (408), with room in the global
/// byte budget (waited for until the same deadline; then 503).
///
/// # Errors
/// As above; 400 `unreadable-body` when the body is cut short or the connection fails.
pub(crate) async fn read_body(
    state: &AppState,
    headers: &HeaderMap,
    body: Body,
    start: Instant,
) -> Result<HeldBody, ApiError> {
    let limit = state.config.max_body_bytes;
    let budget_time = state.config.body_timeout.min(state.config.request_timeout);
    let deadline = tokio::time::Instant::from_std(start + budget_time);
    let declared = declared_length(headers);
    if declared.is_some_and(|n| n > limit as u64) {
        return Err(reject(state, body, ApiError::body_too_large(limit)).await);
    }
    let mut held: Option<OwnedSemaphorePermit> = None;
    let mut reserved = 0usize;
    // Room for what the client announced, before any of it is buffered.
    let mut buf = Vec::new();
    if let Some(n) = declared {
        let n = n as usize;
        if n > 0 {
            held = Some(take(state, n, deadline, budget_time).await?);
            reserved = n;
            buf.reserve_exact(n);
        }
    }
    let mut body = body;
    loop {
        let frame = match tokio::time::timeout_at(deadline, body.frame()).await {
            Err(_) => return Err(body_timeout(budget_time)),
            Ok(None) => break,
            Ok(Some(Err(e))) => {
                return Err(ApiError::new(
                    StatusCode::BAD_REQUEST,
                    "unreadable-body",
                    format!("the request body could not be read (cut short?): {e}"),
                )
                .at(""))
            }
            Ok(Some(Ok(f))) => f,
        };
        let Ok(data) = frame.into_data() else {
            continue; // trailers
        };
        let total = buf.len() + data.len();
        if total > limit {
            return Err(reject(state, body, ApiError::body_too_large(limit)).await);
        }
        if total > reserved {
            let more = take(state, total - reserved, deadline, budget_time).await?;
            match &mut held {
                Some(h) => h.merge(more),
                None => held = Some(more),
            }
            reserved = total;
        }
        buf.extend_from_slice(&data);
    }
    Ok(HeldBody {
        bytes: Bytes::from(buf),
        _budget: held,
    })
}

/// `n` bytes of the global budget, waiting for room until `deadline`.
async fn take(
    state: &AppState,
    n: usize,
    deadline: tokio::time::Instant,
    budget_time: Duration,
) -> Result<OwnedSemaphorePermit, ApiError> {
    let n = u32::try_from(n).map_err(|_| ApiError::body_too_large(state.config.max_body_bytes))?;
    match tokio::time::timeout_at(deadline, state.body_bytes.clone().acquire_many_owned(n)).await {
        Ok(Ok(p)) => Ok(p),
        Ok(Err(_closed)) => Err(ApiError::internal()),
        Err(_) => Err(no_room(budget_time)),
    }
}
