//! The map page at `GET /` and the limits it checks files against (`GET /v1/limits`).
//!
//! The page (`web/`) is compiled into the binary: HTML, CSS, two JavaScript modules, the
//! Natural Earth 110m land basemap and two sample files from `fixtures/`, so it works with no
//! network at all (its Content-Security-Policy allows nothing but this server). It fits through
//! `POST /v1/fit` like any other client; the only thing it adds to the API is `/v1/limits`, so
//! that a client can refuse a file that is too large before sending it.

use crate::service::AppState;
use axum::extract::{Path, State};
use axum::http::{header, HeaderValue, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use axum::Router;
use serde_json::json;

/// The page's files: name under `/page/`, content type, bytes.
const ASSETS: &[(&str, &str, &str)] = &[
    (
        "app.js",
        "text/javascript; charset=utf-8",
        include_str!("../../web/app.js"),
    ),
    (
        "globe.js",
        "text/javascript; charset=utf-8",
        include_str!("../../web/globe.js"),
    ),
    (
        "style.css",
        "text/css; charset=utf-8",
        include_str!("../../web/style.css"),
    ),
    (
        "land-110m.geojson",
        "application/geo+json",
        include_str!("../../web/land-110m.geojson"),
    ),
    (
        "sample-border.geojson",
        "application/geo+json",
        include_str!("../../fixtures/us_mexico_border_natural_earth.geojson"),
    ),
    (
        "sample-tracks.geojson",
        "application/geo+json",
        include_str!("../../fixtures/gps_tracks_slovenia_gpxpy.geojson"),
    ),
];

const INDEX_HTML: &str = include_str!("../../web/index.html");

/// Only this server: no scripts, styles, fonts or fetches from anywhere else.
const CSP: &str = "default-src 'self'; img-src 'self' data: blob:; object-src 'none'; \
                   base-uri 'none'; form-action 'none'; frame-ancestors 'none'";

/// The routes of this module, merged into [`super::router`].
pub(super) fn routes() -> Router<AppState> {
    Router::new()
        .route("/", get(index))
        .route("/page/{asset}", get(asset))
        .route("/v1/limits", get(limits))
}

fn page_response(content_type: &'static str, body: &'static str) -> Response {
    let mut res = (StatusCode::OK, body).into_response();
    let h = res.headers_mut();
    h.insert(header::CONTENT_TYPE, HeaderValue::from_static(content_type));
    h.insert(
        header::CONTENT_SECURITY_POLICY,
        HeaderValue::from_static(CSP),
    );
    h.insert(
        header::X_CONTENT_TYPE_OPTIONS,
        HeaderValue::from_static("nosniff"),
    );
    // The page changes with the binary; revalidation is cheap on loopback.
    h.insert(header::CACHE_CONTROL, HeaderValue::from_static("no-cache"));
    res
}

/// `GET /`: the map page, or the OGC API landing page (JSON) for clients that ask for JSON
/// ([`super::ogc::wants_json`]). `Vary: Accept` tells caches that the answer depends on it.
async fn index(headers: axum::http::HeaderMap, uri: axum::http::Uri) -> Response {
    if let Err(e) = super::ogc::check_format(uri.query()) {
        return e.into_response();
    }
    let mut res = if super::ogc::wants_json(&headers, uri.query()) {
        super::ogc::landing(&headers)
    } else {
        page_response("text/html; charset=utf-8", INDEX_HTML)
    };
    res.headers_mut()
        .insert(header::VARY, HeaderValue::from_static("accept"));
    res
}

async fn asset(Path(name): Path<String>) -> Response {
    match ASSETS.iter().find(|(n, _, _)| *n == name) {
        Some((_, ct, body)) => page_response(ct, body),
        None => super::ApiError::not_found(&format!("/page/{name}")).into_response(),
    }
}

/// The limits of this server, so clients can check a file before sending it.
async fn limits(State(state): State<AppState>) -> Response {
    let c = &state.config;
    let body = json!({
        "max_body_bytes": c.max_body_bytes,
        "max_points": c.max_points,
        "max_output_points": c.max_output_points,
        "max_control_points": c.limits.max_control_points,
        "max_samples": c.limits.max_samples,
        "max_iterations": c.limits.max_iterations,
        "timeout_s": c.request_timeout.as_secs_f64(),
    });
    let mut res = (StatusCode::OK, body.to_string()).into_response();
    res.headers_mut().insert(
        header::CONTENT_TYPE,
        HeaderValue::from_static("application/json"),
    );
    res
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::service::{router, ServiceConfig};
    use axum::body::Body;
    use axum::http::Request;
    use tower::ServiceExt;

    async fn get(config: ServiceConfig, uri: &str) -> (u16, String, String, Vec<u8>) {
        let res = router(AppState::new(config))
            .oneshot(Request::get(uri).body(Body::empty()).unwrap())
            .await
            .unwrap();
        let h = |n: header::HeaderName| {
            res.headers()
                .get(n)
                .map_or(String::new(), |v| v.to_str().unwrap().to_string())
        };
        let (ct, csp) = (h(header::CONTENT_TYPE), h(header::CONTENT_SECURITY_POLICY));
        let status = res.status().as_u16();
        let body = axum::body::to_bytes(res.into_body(), usize::MAX)
            .await
            .unwrap()
            .to_vec();
        (status, ct, csp, body)
    }

    #[tokio::test]
    async fn the_page_and_its_files_are_served_with_a_strict_policy() {
        let (status, ct, csp, body) = get(ServiceConfig::default(), "/").await;
        assert_eq!((status, ct.as_str()), (200, "text/html; charset=utf-8"));
        assert!(csp.starts_with("default-src 'self';"), "{csp}");
        assert_eq!(body, INDEX_HTML.as_bytes());
        for (name, want_ct, want) in ASSETS {
            let (status, ct, csp, body) =
                get(ServiceConfig::default(), &format!("/page/{name}")).await;
            assert_eq!((status, ct.as_str()), (200, *want_ct), "{name}");
            assert!(!csp.is_empty());
            assert_eq!(body, want.as_bytes(), "{name}");
        }
        let (status, ct, _, body) = get(ServiceConfig::default(), "/page/../Cargo.toml").await;
        assert_eq!((status, ct.as_str()), (404, "application/problem+json"));
        assert!(String::from_utf8(body).unwrap().contains("not-found"));
        let (status, _, _, _) = get(ServiceConfig::default(), "/page/missing.js").await;
        assert_eq!(status, 404);
    }

    #[tokio::test]
    async fn limits_are_the_servers_own() {
        let config = ServiceConfig {
            max_body_bytes: 12_345,
            max_points: 678,
            request_timeout: std::time::Duration::from_millis(2500),
            ..ServiceConfig::default()
        };
        let (status, ct, _, body) = get(config.clone(), "/v1/limits").await;
        assert_eq!((status, ct.as_str()), (200, "application/json"));
        let v: serde_json::Value = serde_json::from_slice(&body).unwrap();
        assert_eq!(v["max_body_bytes"], 12_345);
        assert_eq!(v["max_points"], 678);
        assert_eq!(v["timeout_s"], 2.5);
        assert_eq!(v["max_control_points"], config.limits.max_control_points);
        assert_eq!(v["max_output_points"], config.max_output_points);
    }

    /// "No network at run time": nothing the page ships names another host.
    #[test]
    fn the_page_loads_nothing_from_elsewhere() {
        for (name, _, body) in ASSETS
            .iter()
            .filter(|(n, _, _)| n.ends_with(".js") || n.ends_with(".css"))
            .chain([&("index.html", "", INDEX_HTML)])
        {
            for bad in ["http://", "https://", "//cdn", "@import"] {
                assert!(!body.contains(bad), "{name} contains {bad:?}");
            }
        }
    }

    /// openapi.yaml lists exactly the files served.
    #[test]
    fn the_contract_lists_every_asset() {
        let spec = super::super::OPENAPI_YAML;
        let line = spec
            .lines()
            .find(|l| l.contains("enum: [app.js"))
            .expect("the /page/{asset} enum");
        let listed: Vec<&str> = line
            .split('[')
            .nth(1)
            .and_then(|r| r.split(']').next())
            .unwrap()
            .split(',')
            .map(str::trim)
            .collect();
        let served: Vec<&str> = ASSETS.iter().map(|(n, _, _)| *n).collect();
        assert_eq!(listed, served);
    }

    /// Every `/page/...` file the HTML and scripts refer to is one that is served.
    #[test]
    fn every_referenced_asset_is_served() {
        let mut seen = 0;
        for (_, _, body) in ASSETS.iter().chain([&("index.html", "", INDEX_HTML)]) {
            for part in body.split("/page/").skip(1) {
                let name: String = part
                    .chars()
                    .take_while(|c| c.is_ascii_alphanumeric() || "._-${}".contains(*c))
                    .collect();
                if name.contains("${") {
                    // `sample-${which}.geojson`: the <select> options name the samples.
                    for which in ["border", "tracks"] {
                        assert!(INDEX_HTML.contains(&format!("value=\"{which}\"")));
                        let n = format!("sample-{which}.geojson");
                        assert!(ASSETS.iter().any(|(a, _, _)| *a == n), "{n}");
                    }
                } else {
                    assert!(ASSETS.iter().any(|(a, _, _)| *a == name), "{name}");
                }
                seen += 1;
            }
            // Module imports are relative to /page/.
            for part in body.split("from './").skip(1) {
                let name = part.split('\'').next().unwrap();
                assert!(ASSETS.iter().any(|(a, _, _)| *a == name), "{name}");
                seen += 1;
            }
        }
        assert!(seen >= 5, "{seen}");
    }
}
