//! OGC API – Processes 1.0 and OGC API – Features 1.0 over the service, so that GIS tools
//! (QGIS, GDAL's `OAPIF` driver, OWSLib) run fits and read their results with no script. The
//! `/v1` API is unchanged; this is a second front end on the same work
//! ([`super::handlers::geo_run`]), the same limits and the same options ([`crate::earth::job`]:
//! the process input schemas are generated from [`crate::earth::RawOptions::option_type`]).
//!
//! | file | routes |
//! |---|---|
//! | `mod.rs` | `GET /` (JSON landing page; HTML for browsers, `page.rs`), `GET /conformance` |
//! | `processes.rs` | `GET /processes`, `GET /processes/{id}` (`fit`, `interpolate`, `evaluate`) |
//! | `execute.rs` | `POST /processes/{id}/execution`: synchronous, or a job with `Prefer: respond-async` |
//! | `jobs.rs` | `GET /jobs`, `GET`/`DELETE /jobs/{id}`, `GET /jobs/{id}/results` |
//! | `store.rs` | the job store: owners, and the calls both stores answer |
//! | `disk.rs` | the job store on disk (size budget, expiry, restarts) |
//! | `postgres.rs` | the job store in PostgreSQL (a queue any replica takes jobs from, leases) |
//! | `features.rs` | `GET /collections…`: each successful GeoJSON job as a feature collection |
//!
//! Links are absolute, made from the request's `Host` header (GDAL and OWSLib follow them).

mod disk;
mod execute;
mod features;
mod jobs;
mod postgres;
mod processes;
mod store;

pub(crate) use disk::DiskStore;
pub(crate) use execute::start_worker;
pub(crate) use postgres::PgStore;
pub(crate) use store::JobStore;

use crate::service::handlers::JSON;
use crate::service::{AppState, OPENAPI_JSON_TYPE};
use axum::extract::State;
use axum::http::{header, HeaderMap, HeaderValue, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use axum::Router;
use serde_json::{json, Value};

/// The conformance classes this server declares; each one's required paths and status codes
/// are tested in `tests/it/ogc.rs`. Not declared: the HTML encodings, Processes callbacks, and
/// the `oas30` classes (`openapi.yaml` is OpenAPI 3.1, not 3.0).
pub(crate) const CONFORMANCE: &[&str] = &[
    "http://www.opengis.net/spec/ogcapi-common-1/1.0/conf/core",
    "http://www.opengis.net/spec/ogcapi-processes-1/1.0/conf/core",
    "http://www.opengis.net/spec/ogcapi-processes-1/1.0/conf/ogc-process-description",
    "http://www.opengis.net/spec/ogcapi-processes-1/1.0/conf/json",
    "http://www.opengis.net/spec/ogcapi-processes-1/1.0/conf/job-list",
    "http://www.opengis.net/spec/ogcapi-processes-1/1.0/conf/dismiss",
    "http://www.opengis.net/spec/ogcapi-features-1/1.0/conf/core",
    "http://www.opengis.net/spec/ogcapi-features-1/1.0/conf/geojson",
];

/// The routes of this module, merged into [`super::router`] (`/` is `page.rs`'s, which calls
/// [`landing`] for clients that ask for JSON).
pub(super) fn routes() -> Router<AppState> {
    Router::new()
        .route("/conformance", get(conformance))
        .route("/processes", get(processes::list))
        .route("/processes/{id}", get(processes::describe))
        .route("/processes/{id}/execution", post(execute::execute))
        .route("/jobs", get(jobs::list))
        .route("/jobs/{id}", get(jobs::status).delete(jobs::dismiss))
        .route("/jobs/{id}/results", get(jobs::results))
        .route("/collections", get(features::collections))
        .route("/collections/{id}", get(features::collection))
        .route("/collections/{id}/items", get(features::items))
        .route("/collections/{id}/items/{feature}", get(features::item))
}

/// Whether a `GET /` wants the OGC landing page (JSON) rather than the map page: `?f=json`, or
/// an `Accept` that does not name `text/html`. Browsers always name `text/html` and keep
/// getting the page; GDAL asks for `application/json`, and OWSLib (Python `requests`) sends
/// `Accept: */*` and cannot add a query to its first request, so `*/*` gets JSON. A request
/// with no `Accept` at all gets the page, as before this API existed.
pub(super) fn wants_json(headers: &HeaderMap, query: Option<&str>) -> bool {
    let f = query.and_then(|q| {
        q.split('&')
            .find_map(|kv| kv.strip_prefix("f="))
            .map(str::to_ascii_lowercase)
    });
    match f.as_deref() {
        Some("json") => return true,
        Some(_) => return false,
        None => {}
    }
    match headers
        .get(header::ACCEPT)
        .map(|v| v.to_str().unwrap_or(""))
    {
        None => false,
        Some(accept) => !accept.to_ascii_lowercase().contains("text/html"),
    }
}

/// Checks `f` of a `GET /`: `json` or `html` when given.
///
/// # Errors
/// 400 `invalid-query` for another value.
pub(super) fn check_format(query: Option<&str>) -> Result<(), super::ApiError> {
    let f = query.and_then(|q| q.split('&').find_map(|kv| kv.strip_prefix("f=")));
    match f {
        None | Some("json" | "html") => Ok(()),
        Some(other) => Err(super::ApiError::invalid_query(
            "f",
            format!("f={other:?}: use json (the OGC API landing page) or html (the map page)"),
        )),
    }
}

/// `http://host` of the request (links are absolute; see the module docs).
pub(crate) fn base_url(headers: &HeaderMap) -> String {
    let host = headers
        .get(header::HOST)
        .and_then(|v| v.to_str().ok())
        .filter(|h| {
            !h.is_empty()
                && h.bytes()
                    .all(|b| b.is_ascii_alphanumeric() || b".-:[]_".contains(&b))
        })
        .unwrap_or("localhost");
    format!("http://{host}")
}

/// A JSON response with `status`.
pub(crate) fn json_response(
    status: StatusCode,
    value: &Value,
    media_type: &'static str,
) -> Response {
    let body = serde_json::to_vec(value).expect("a JSON value serialises");
    let mut res = (status, body).into_response();
    res.headers_mut()
        .insert(header::CONTENT_TYPE, HeaderValue::from_static(media_type));
    res
}

fn link(href: String, rel: &str, media_type: &str, title: &str) -> Value {
    json!({"href": href, "rel": rel, "type": media_type, "title": title})
}

/// The landing page (OGC API – Common core): links to the API description, conformance,
/// processes, jobs and collections.
pub(super) fn landing(headers: &HeaderMap) -> Response {
    let b = base_url(headers);
    let body = json!({
        "title": "spherefit",
        "description": "Smooth spherical spline fits of GeoJSON lines and rings: OGC API – Processes (fit, interpolate, evaluate) and each job's result as an OGC API – Features collection",
        "links": [
            link(format!("{b}/?f=json"), "self", JSON, "this document"),
            link(format!("{b}/"), "alternate", "text/html", "the map page"),
            link(format!("{b}/openapi.json"), "service-desc", OPENAPI_JSON_TYPE, "the API definition (JSON)"),
            link(format!("{b}/openapi.yaml"), "service-desc", "application/vnd.oai.openapi;version=3.0", "the API definition (YAML, the hand-written source)"),
            link(format!("{b}/conformance"), "conformance", JSON, "conformance classes"),
            link(format!("{b}/conformance"), "http://www.opengis.net/def/rel/ogc/1.0/conformance", JSON, "conformance classes"),
            link(format!("{b}/processes"), "http://www.opengis.net/def/rel/ogc/1.0/processes", JSON, "processes"),
            link(format!("{b}/jobs"), "http://www.opengis.net/def/rel/ogc/1.0/job-list", JSON, "jobs"),
            link(format!("{b}/collections"), "data", JSON, "results of finished jobs"),
        ],
    });
    json_response(StatusCode::OK, &body, JSON)
}

async fn conformance(State(_): State<AppState>) -> Response {
    json_response(StatusCode::OK, &json!({"conformsTo": CONFORMANCE}), JSON)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn accept(v: &str) -> HeaderMap {
        let mut h = HeaderMap::new();
        h.insert(header::ACCEPT, HeaderValue::from_str(v).unwrap());
        h
    }

    #[test]
    fn browsers_get_the_page_and_json_clients_the_landing_page() {
        let chrome = "text/html,application/xhtml+xml,application/xml;q=0.9,*/*;q=0.8";
        assert!(!wants_json(&accept(chrome), None));
        assert!(wants_json(&accept("*/*"), None), "OWSLib");
        assert!(!wants_json(&HeaderMap::new(), None));
        assert!(wants_json(&accept("application/json"), None));
        assert!(wants_json(&accept("application/json, */*"), None));
        assert!(wants_json(&accept(chrome), Some("f=json")));
        assert!(!wants_json(&accept("application/json"), Some("f=html")));
        assert!(check_format(Some("f=json")).is_ok() && check_format(None).is_ok());
        assert_eq!(check_format(Some("f=AAA")).unwrap_err().status, 400);
    }

    #[test]
    fn links_use_the_host_but_not_junk_in_it() {
        let mut h = HeaderMap::new();
        h.insert(header::HOST, HeaderValue::from_static("127.0.0.1:8080"));
        assert_eq!(base_url(&h), "http://127.0.0.1:8080");
        h.insert(header::HOST, HeaderValue::from_static("a/b?c"));
        assert_eq!(base_url(&h), "http://localhost");
    }
}
