//! One error type for every response that is not a success: RFC 9457
//! `application/problem+json` with a stable `type`, a `title`, the `status`, a human `detail`,
//! and where the fault is: `pointer` (RFC 6901, into the request body) or `parameter` (a query
//! parameter's name).
//!
//! | status | `type` (after `urn:spherefit:problem:`) | when |
//! |---|---|---|
//! | 400 | `malformed-json` | the body is not JSON (syntax, nesting deeper than 128) |
//! | 400 | `invalid-query` | unknown, repeated, empty or unparsable query parameter |
//! | 400 | `unreadable-body` | the body was cut short or the connection failed |
//! | 408 | `body-timeout` | the body did not arrive within the body timeout |
//! | 401 | `unauthorized` | a key file is in use and the bearer token is missing or wrong (`WWW-Authenticate`) |
//! | 404 | `not-found` | no such path |
//! | 405 | `method-not-allowed` | wrong method for the path |
//! | 413 | `body-too-large` | body over the byte limit |
//! | 413 | `too-many-points` | more input positions than the limit |
//! | 415 | `unsupported-media-type` | missing or wrong `Content-Type` |
//! | 422 | see [`Problem::slug`](crate::earth::Problem::slug) and below | valid JSON that cannot be used |
//! | 400 | `invalid-input` | an OGC API – Processes execute request that is not one (unknown input, wrong type) |
//! | 404 | `result-not-ready` | a job's result asked for before the job succeeded |
//! | 422 | `invalid-reference` | an input `href` that is not one of this server's successful jobs |
//! | 429 | `too-many-jobs` | as many jobs accepted and unfinished as the server runs (`Retry-After`) |
//! | 503 | `store-full` | the job store has no room for another job (`Retry-After`) |
//! | 503 | `store-unavailable` | the job store cannot be written or reached (`Retry-After`) |
//! | 503 | `overloaded` | the fitting slots and their queue are full (`Retry-After`) |
//! | 503 | `timeout` | the request ran past its time budget (`Retry-After`) |
//! | 500 | `internal` | a bug (logged; the detail says nothing more) |

use crate::document::InputError;
use crate::earth::error::{EarthError, Problem};
use axum::http::{header, HeaderValue, StatusCode};
use axum::response::{IntoResponse, Response};
use serde_json::json;

/// The media type of every error body.
pub const PROBLEM_JSON: &str = "application/problem+json";

/// Prefix of every problem `type`.
pub const PROBLEM_TYPE_PREFIX: &str = "urn:spherefit:problem:";

/// Seconds a client should wait after a 503.
pub const RETRY_AFTER_S: u16 = 1;

/// An error response (RFC 9457 problem details).
#[derive(Clone, Debug, PartialEq)]
pub struct ApiError {
    pub status: StatusCode,
    /// Stable machine-readable kind; the `type` is [`PROBLEM_TYPE_PREFIX`] + this (the `title`
    /// follows from it).
    pub slug: &'static str,
    /// What happened in this request.
    pub detail: String,
    /// RFC 6901 pointer into the request body.
    pub pointer: Option<String>,
    /// Name of the query parameter at fault.
    pub parameter: Option<String>,
    /// `Retry-After` seconds (503 only).
    pub retry_after_s: Option<u16>,
}

impl ApiError {
    /// An error without location.
    pub fn new(status: StatusCode, slug: &'static str, detail: impl Into<String>) -> ApiError {
        ApiError {
            status,
            slug,
            detail: detail.into(),
            pointer: None,
            parameter: None,
            retry_after_s: None,
        }
    }

    /// Adds a body pointer.
    pub fn at(mut self, pointer: impl Into<String>) -> ApiError {
        self.pointer = Some(pointer.into());
        self
    }

    /// Names the query parameter at fault.
    pub fn param(mut self, name: impl Into<String>) -> ApiError {
        self.parameter = Some(name.into());
        self
    }

    pub fn malformed_json(detail: impl Into<String>) -> ApiError {
        ApiError::new(StatusCode::BAD_REQUEST, "malformed-json", detail).at("")
    }

    pub fn invalid_query(name: &str, detail: impl Into<String>) -> ApiError {
        ApiError::new(StatusCode::BAD_REQUEST, "invalid-query", detail).param(name)
    }

    pub fn unsupported_media_type(expected: &str, got: Option<&str>) -> ApiError {
        ApiError::new(
            StatusCode::UNSUPPORTED_MEDIA_TYPE,
            "unsupported-media-type",
            match got {
                Some(g) => format!("Content-Type {g:?} is not accepted here: send {expected}"),
                None => format!("no Content-Type: send {expected}"),
            },
        )
    }

    pub fn body_too_large(limit: usize) -> ApiError {
        ApiError::new(
            StatusCode::PAYLOAD_TOO_LARGE,
            "body-too-large",
            format!("the body is larger than the limit of {limit} bytes"),
        )
        .at("")
    }

    pub fn too_many_points(got: usize, limit: usize, pointer: String) -> ApiError {
        ApiError::new(
            StatusCode::PAYLOAD_TOO_LARGE,
            "too-many-points",
            format!(
                "{got} input positions, more than the limit of {limit} per request: split the input"
            ),
        )
        .at(pointer)
    }

    pub fn unprocessable(slug: &'static str, detail: impl Into<String>) -> ApiError {
        ApiError::new(StatusCode::UNPROCESSABLE_ENTITY, slug, detail)
    }

    pub fn overloaded() -> ApiError {
        let mut e = ApiError::new(
            StatusCode::SERVICE_UNAVAILABLE,
            "overloaded",
            "all fitting slots and their queue are taken: retry after the time in Retry-After",
        );
        e.retry_after_s = Some(RETRY_AFTER_S);
        e
    }

    pub fn timeout(budget_s: f64) -> ApiError {
        let mut e = ApiError::new(StatusCode::SERVICE_UNAVAILABLE, "timeout",
            format!(
                "the request took longer than its time budget of {budget_s} s: send less work per request or retry later"
            ),
        );
        e.retry_after_s = Some(RETRY_AFTER_S);
        e
    }

    pub fn internal() -> ApiError {
        ApiError::new(
            StatusCode::INTERNAL_SERVER_ERROR,
            "internal",
            "an unexpected error occurred; it has been logged",
        )
    }

    pub fn not_found(path: &str) -> ApiError {
        ApiError::new(
            StatusCode::NOT_FOUND,
            "not-found",
            format!("no resource at {path}: see /openapi.yaml"),
        )
    }

    pub fn method_not_allowed() -> ApiError {
        ApiError::new(
            StatusCode::METHOD_NOT_ALLOWED,
            "method-not-allowed",
            "this path does not accept that method: see /openapi.yaml",
        )
    }

    /// The problem body as JSON.
    pub fn body(&self) -> serde_json::Value {
        let mut v = json!({
            "type": format!("{PROBLEM_TYPE_PREFIX}{}", self.slug),
            "title": title_of(self.slug),
            "status": self.status.as_u16(),
            "detail": self.detail,
        });
        if let Some(p) = &self.pointer {
            v["pointer"] = json!(p);
        }
        if let Some(p) = &self.parameter {
            v["parameter"] = json!(p);
        }
        v
    }
}

/// The `title` of each kind of problem: the service's own, then the library's
/// ([`crate::earth::error::title_of`]).
pub fn title_of(slug: &str) -> &'static str {
    match slug {
        "malformed-json" => "Malformed JSON",
        "invalid-query" => "Invalid query parameter",
        "unreadable-body" => "Unreadable body",
        "body-timeout" => "Request body too slow",
        "unsupported-media-type" => "Unsupported media type",
        "body-too-large" => "Request body too large",
        "too-many-points" => "Too many points",
        "overloaded" => "Server busy",
        "timeout" => "Time budget exceeded",
        "internal" => "Internal error",
        "not-found" => "Not found",
        "method-not-allowed" => "Method not allowed",
        "bad-request" => "Bad request",
        "invalid-points" => "Invalid points document",
        "nothing-to-fit" => "Nothing to fit",
        "output-too-large" => "Output too large",
        "invalid-input" => "Invalid process input",
        "invalid-reference" => "Invalid input reference",
        "too-many-jobs" => "Too many jobs",
        "store-full" => "Job store full",
        "store-unavailable" => "Job store unavailable",
        "result-not-ready" => "Result not ready",
        "unauthorized" => "Unauthorized",
        "unreadable-file" => "Unreadable file",
        "unsupported-crs" => "Unsupported coordinate reference system",
        "unwritable-output" => "Output cannot be written",
        other => crate::earth::error::title_of(other),
    }
}

impl std::fmt::Display for ApiError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} {}: {}", self.status.as_u16(), self.slug, self.detail)
    }
}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        let body = serde_json::to_vec(&self.body()).expect("a JSON value serialises");
        let mut res = (self.status, body).into_response();
        res.headers_mut()
            .insert(header::CONTENT_TYPE, HeaderValue::from_static(PROBLEM_JSON));
        if let Some(s) = self.retry_after_s {
            res.headers_mut()
                .insert(header::RETRY_AFTER, HeaderValue::from(s));
        }
        res.extensions_mut().insert(ProblemSlug(self.slug));
        res
    }
}

/// The problem kind of an error response, for metrics and logs.
#[derive(Clone, Copy, Debug)]
pub struct ProblemSlug(pub &'static str);

impl From<EarthError> for ApiError {
    fn from(e: EarthError) -> ApiError {
        let slug = e.problem.slug();
        let detail = e.problem.to_string();
        match e.problem {
            Problem::InvalidOption { option, .. }
            | Problem::RequiresOption { option, .. }
            | Problem::ConflictingOptions { option, .. } => {
                ApiError::unprocessable(slug, detail).param(option)
            }
            Problem::CountOutOfRange { option, .. } => {
                ApiError::unprocessable(slug, format!("{detail} (the server's limit)"))
                    .param(option)
            }
            // Only spacing_m can ask for more points than the limit once the options passed
            // validation; the pointer says which line.
            Problem::TooManySamples { .. } => ApiError::unprocessable(slug, detail)
                .at(e.pointer)
                .param("spacing_m"),
            _ => ApiError::unprocessable(slug, detail).at(e.pointer),
        }
    }
}

impl From<InputError> for ApiError {
    fn from(e: InputError) -> ApiError {
        ApiError::unprocessable("invalid-points", e.message).at(e.pointer)
    }
}

/// A generic problem for a status produced outside the handlers (router, layers).
pub fn problem_for_status(status: StatusCode, path: &str) -> ApiError {
    match status {
        StatusCode::NOT_FOUND => ApiError::not_found(path),
        StatusCode::METHOD_NOT_ALLOWED => ApiError::method_not_allowed(),
        StatusCode::PAYLOAD_TOO_LARGE => ApiError::new(
            status,
            "body-too-large",
            "the body is larger than the server's limit",
        ),
        StatusCode::SERVICE_UNAVAILABLE | StatusCode::REQUEST_TIMEOUT => {
            let mut e = ApiError::new(
                StatusCode::SERVICE_UNAVAILABLE,
                "timeout",
                "the request took longer than the server's time budget",
            );
            e.retry_after_s = Some(RETRY_AFTER_S);
            e
        }
        s if s.is_server_error() => ApiError::internal(),
        s => ApiError::new(
            s,
            "bad-request",
            s.canonical_reason().unwrap_or("bad request"),
        ),
    }
}
