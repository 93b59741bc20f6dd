//! What every POST handler does around its own work, in one extractor: [`PostRequest`] checks
//! the content type and the query before the body is read (a rejected request still has its
//! body read and discarded, so the client sees the answer), reads the body within its bounds
//! ([`super::body`]), and [`Accepted::run`] does the CPU work on the blocking pool holding a
//! fitting slot, within the request's time budget.

use crate::service::body::{read_body, reject, HeldBody};
use crate::service::error::ApiError;
use crate::service::{AppState, ServiceConfig};
use crate::sphere::cancel::Cancel;
use axum::body::Body;
use axum::extract::rejection::QueryRejection;
use axum::extract::{FromRequest, FromRequestParts, Query, Request};
use axum::http::{header, HeaderMap, StatusCode};
use std::convert::Infallible;
use std::time::Instant;

/// A POST request as it arrives: the query (parsed or not), the headers and the unread body,
/// with the time it arrived (the start of its time budget).
pub(super) struct PostRequest {
    state: AppState,
    headers: HeaderMap,
    query: QueryPairs,
    body: Body,
    start: Instant,
}

impl FromRequest<AppState> for PostRequest {
    type Rejection = Infallible;

    async fn from_request(req: Request, state: &AppState) -> Result<Self, Self::Rejection> {
        let start = Instant::now();
        let (mut parts, body) = req.into_parts();
        let query = Query::from_request_parts(&mut parts, state).await;
        Ok(PostRequest {
            state: state.clone(),
            headers: parts.headers,
            query,
            body,
            start,
        })
    }
}

impl PostRequest {
    /// The server's state.
    pub(super) fn state(&self) -> &AppState {
        &self.state
    }

    /// The request's headers.
    pub(super) fn headers(&self) -> &HeaderMap {
        &self.headers
    }

    /// Checks the content type (one of `accepted`) and the query pairs (`check`, which turns
    /// them into the options of the work) before the body is read, then reads the body.
    ///
    /// # Errors
    /// 415 for another content type, 400 for a query that cannot be read, what `check`
    /// returns, and the errors of reading the body (413, 408, 503, 400); on an error before the
    /// body is read, the body is drained first.
    pub(super) async fn accept<T>(
        self,
        accepted: &[&str],
        check: impl FnOnce(Vec<(String, String)>) -> Result<T, ApiError>,
    ) -> Result<(T, Accepted), ApiError> {
        let PostRequest {
            state,
            headers,
            query,
            body,
            start,
        } = self;
        let checked = check_content_type(&headers, accepted)
            .and_then(|()| pairs(query))
            .and_then(check);
        let t = match checked {
            Ok(t) => t,
            Err(e) => return Err(reject(&state, body, e).await),
        };
        let body = read_body(&state, &headers, body, start).await?;
        Ok((t, Accepted { state, body, start }))
    }
}

/// A request whose options passed and whose body has been read.
pub(super) struct Accepted {
    state: AppState,
    body: HeldBody,
    start: Instant,
}

impl Accepted {
    /// Runs `work` on the body ([`run_cpu`]); `route` names it in the metrics.
    ///
    /// # Errors
    /// What `work` returns; 503 when no fitting slot frees up or the time budget runs out.
    pub(super) async fn run<T: Send + 'static>(
        self,
        route: &'static str,
        work: impl FnOnce(&[u8], &Cancel) -> Result<(T, usize, usize), ApiError> + Send + 'static,
    ) -> Result<T, ApiError> {
        run_cpu(&self.state, route, self.start, self.body, work).await
    }

    /// The body, for work that runs later under its own budget (an OGC API – Processes job).
    pub(super) fn into_body(self) -> HeldBody {
        self.body
    }
}

type QueryPairs = Result<Query<Vec<(String, String)>>, QueryRejection>;

fn pairs(q: QueryPairs) -> Result<Vec<(String, String)>, ApiError> {
    q.map(|Query(p)| p).map_err(|e| {
        ApiError::new(
            StatusCode::BAD_REQUEST,
            "invalid-query",
            format!("the query string cannot be read: {}", e.body_text()),
        )
    })
}

/// Checks the `Content-Type` (parameters such as `charset` are ignored).
fn check_content_type(headers: &HeaderMap, accepted: &[&str]) -> Result<(), ApiError> {
    let expected = accepted.join(" or ");
    let Some(v) = headers.get(header::CONTENT_TYPE) else {
        return Err(ApiError::unsupported_media_type(&expected, None));
    };
    let text = v.to_str().unwrap_or("");
    let essence = text
        .split(';')
        .next()
        .unwrap_or("")
        .trim()
        .to_ascii_lowercase();
    if accepted.contains(&essence.as_str()) {
        Ok(())
    } else {
        Err(ApiError::unsupported_media_type(&expected, Some(text)))
    }
}

/// Cancels the work when the request is dropped (time budget, client gone).
struct CancelOnDrop(Cancel);

impl Drop for CancelOnDrop {
    fn drop(&mut self) {
        self.0.cancel();
    }
}

/// Maps a cancelled computation to 503 `timeout`; other errors stay as they are.
fn cancelled_is_timeout(e: ApiError, config: &ServiceConfig) -> ApiError {
    if e.slug == "cancelled" {
        ApiError::timeout(config.request_timeout.as_secs_f64())
    } else {
        e
    }
}

/// Runs `work` on the blocking pool holding a fitting slot, within the time budget. The work
/// gets a [`Cancel`] that fires at the deadline or when the request is dropped, and keeps the
/// body (and its share of the byte budget) until it ends.
async fn run_cpu<T: Send + 'static>(
    state: &AppState,
    route: &'static str,
    start: Instant,
    body: HeldBody,
    work: impl FnOnce(&[u8], &Cancel) -> Result<(T, usize, usize), ApiError> + Send + 'static,
) -> Result<T, ApiError> {
    let budget = state.config.request_timeout;
    let deadline = start + budget;
    let slot = state.enter(deadline).await?;
    let cancel = Cancel::with_deadline(deadline);
    let _guard = CancelOnDrop(cancel.clone());
    let metrics = state.metrics.clone();
    let config = state.config.clone();
    let handle = tokio::task::spawn_blocking(move || {
        let _slot = slot;
        let t0 = Instant::now();
        let r = work(&body.bytes, &cancel);
        drop(body);
        let r = r.map_err(|e| cancelled_is_timeout(e, &config));
        if let Ok((_, points, curves)) = &r {
            metrics.record_fit(route, t0.elapsed().as_secs_f64(), *points, *curves);
        }
        r
    });
    match tokio::time::timeout_at(deadline.into(), handle).await {
        Err(_) => Err(ApiError::timeout(budget.as_secs_f64())),
        Ok(Err(join)) => {
            tracing::error!(error = %join, route, "CPU work failed");
            Err(ApiError::internal())
        }
        Ok(Ok(r)) => r.map(|(t, _, _)| t),
    }
}
