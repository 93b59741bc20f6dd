//! OGC API – Processes and Features (`src/service/ogc/`) through `tower::ServiceExt::oneshot`:
//! the required paths and status codes of each declared conformance class, synchronous and
//! asynchronous execution on the same work as `/v1`, the job lifecycle, the job store's limits
//! (size budget, expiry, too many jobs, time budget, dismissal freeing space) and restarts.
//! The real clients (OWSLib, GDAL's `OAPIF` driver) run in `.ci/ogc.sh`.

use axum::body::Body;
use axum::http::{header, Request, StatusCode};
use axum::Router;
use serde_json::{json, Value};
use spherefit::service::{
    router, AppState, ServiceConfig, OPENAPI_JSON, OPENAPI_JSON_TYPE, OPENAPI_YAML,
};
use std::path::PathBuf;
use std::time::{Duration, Instant};
use tower::ServiceExt;

const HOST: &str = "127.0.0.1:9";

struct Reply {
    status: StatusCode,
    headers: axum::http::HeaderMap,
    body: Vec<u8>,
}

impl Reply {
    fn json(&self) -> Value {
        serde_json::from_slice(&self.body)
            .unwrap_or_else(|e| panic!("not JSON ({e}): {}", String::from_utf8_lossy(&self.body)))
    }
    fn header(&self, name: &str) -> &str {
        self.headers.get(name).map_or("", |v| v.to_str().unwrap())
    }
    /// Asserts a problem+json of `status` and `slug`; returns the body.
    fn problem(&self, status: u16, slug: &str) -> Value {
        assert_eq!(
            self.status.as_u16(),
            status,
            "{}",
            String::from_utf8_lossy(&self.body)
        );
        assert_eq!(self.header("content-type"), "application/problem+json");
        let v = self.json();
        assert_eq!(v["type"], format!("urn:spherefit:problem:{slug}"), "{v}");
        v
    }
}

/// A scratch data directory, removed on drop.
struct DataDir(PathBuf);

impl DataDir {
    fn new(name: &str) -> DataDir {
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .unwrap()
            .as_nanos();
        let d = std::env::temp_dir().join(format!(
            "spherefit-it-ogc-{name}-{}-{nanos}",
            std::process::id()
        ));
        DataDir(d)
    }
    fn config(&self) -> ServiceConfig {
        ServiceConfig {
            data_dir: Some(self.0.clone()),
            ..ServiceConfig::default()
        }
    }
}

impl Drop for DataDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

async fn send(
    app: &Router,
    method: &str,
    uri: &str,
    headers: &[(&str, &str)],
    body: Vec<u8>,
) -> Reply {
    let mut req = Request::builder()
        .method(method)
        .uri(uri)
        .header(header::HOST, HOST);
    for (k, v) in headers {
        req = req.header(*k, *v);
    }
    let res = app
        .clone()
        .oneshot(req.body(Body::from(body)).unwrap())
        .await
        .unwrap();
    let status = res.status();
    let headers = res.headers().clone();
    let body = axum::body::to_bytes(res.into_body(), usize::MAX)
        .await
        .unwrap()
        .to_vec();
    Reply {
        status,
        headers,
        body,
    }
}

async fn get(app: &Router, uri: &str) -> Reply {
    send(app, "GET", uri, &[], vec![]).await
}

async fn execute(app: &Router, process: &str, body: &Value, asynchronous: bool) -> Reply {
    let mut h = vec![("content-type", "application/json")];
    if asynchronous {
        h.push(("prefer", "respond-async"));
    }
    send(
        app,
        "POST",
        &format!("/processes/{process}/execution"),
        &h,
        serde_json::to_vec(body).unwrap(),
    )
    .await
}

/// Submits an async job; returns its id (checking the 201, `Location` and status).
async fn submit(app: &Router, process: &str, body: &Value) -> String {
    let r = execute(app, process, body, true).await;
    assert_eq!(r.status, 201, "{}", String::from_utf8_lossy(&r.body));
    let v = r.json();
    let id = v["jobID"].as_str().unwrap().to_string();
    assert_eq!(r.header("location"), format!("http://{HOST}/jobs/{id}"));
    assert_eq!(r.header("preference-applied"), "respond-async");
    assert!(
        matches!(v["status"].as_str(), Some("accepted" | "running")),
        "{v}"
    );
    assert_eq!(v["processID"], process);
    id
}

/// Polls a job until it is no longer accepted or running.
async fn wait(app: &Router, id: &str) -> Value {
    let start = Instant::now();
    loop {
        let r = get(app, &format!("/jobs/{id}")).await;
        assert_eq!(r.status, 200, "{}", String::from_utf8_lossy(&r.body));
        let v = r.json();
        let p = v["progress"].as_u64().unwrap();
        assert!(p <= 100);
        if !matches!(v["status"].as_str(), Some("accepted" | "running")) {
            return v;
        }
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "job {id} never finished"
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

fn lines(n: usize) -> Value {
    let features: Vec<Value> = (0..n)
        .map(|k| {
            let lon0 = -150.0 + 60.0 * k as f64;
            json!({"type": "Feature", "properties": {"name": format!("line {k}")}, "geometry": {"type": "LineString",
                "coordinates": (0..50).map(|i| { let x = i as f64 * 0.2; [lon0 + x, 10.0 * (x * 0.7).sin()] }).collect::<Vec<_>>()}})
        })
        .collect();
    json!({"type": "FeatureCollection", "features": features})
}

/// Work that outlasts any short budget (as `hostile.rs`'s budget test).
fn heavy() -> Value {
    let n = 300_000;
    let line = json!({"type": "LineString", "coordinates": (0..n).map(|i| {
        let f = i as f64 / n as f64;
        [((-170.0 + 340.0 * f) * 1e6).round() / 1e6, ((30.0 * (i as f64 * 0.001).sin() + (i % 7) as f64 * 0.01) * 1e6).round() / 1e6]
    }).collect::<Vec<_>>()});
    json!({"inputs": {"data": line, "control_points": 10000, "iterations": 1000,
        "solver": "gauss-newton", "parameter_correction": true}})
}

const CONFORMANCE: [&str; 7] = [
    "http://www.opengis.net/spec/ogcapi-processes-1/1.0/conf/core",
    "http://www.opengis.net/spec/ogcapi-processes-1/1.0/conf/json",
    "http://www.opengis.net/spec/ogcapi-processes-1/1.0/conf/ogc-process-description",
    "http://www.opengis.net/spec/ogcapi-processes-1/1.0/conf/job-list",
    "http://www.opengis.net/spec/ogcapi-processes-1/1.0/conf/dismiss",
    "http://www.opengis.net/spec/ogcapi-features-1/1.0/conf/core",
    "http://www.opengis.net/spec/ogcapi-features-1/1.0/conf/geojson",
];

/// Common core / Processes core / Features core: the landing page (JSON for API clients, the
/// map page for browsers), its links, `/conformance`.
#[tokio::test]
async fn landing_page_and_conformance() {
    let dir = DataDir::new("landing");
    let app = router(AppState::new(dir.config()));
    for accept in ["application/json", "*/*"] {
        let r = send(&app, "GET", "/", &[("accept", accept)], vec![]).await;
        assert_eq!(r.status, 200);
        assert_eq!(r.header("content-type"), "application/json", "{accept}");
        assert_eq!(r.header("vary"), "accept");
        let rels: Vec<String> = r.json()["links"]
            .as_array()
            .unwrap()
            .iter()
            .map(|l| l["rel"].as_str().unwrap().to_string())
            .collect();
        for rel in [
            "self",
            "service-desc",
            "conformance",
            "data",
            "http://www.opengis.net/def/rel/ogc/1.0/processes",
            "http://www.opengis.net/def/rel/ogc/1.0/job-list",
        ] {
            assert!(rels.iter().any(|r| r == rel), "{rel} in {rels:?}");
        }
    }
    let browser = "text/html,application/xhtml+xml,*/*;q=0.8";
    let r = send(&app, "GET", "/", &[("accept", browser)], vec![]).await;
    assert_eq!(r.header("content-type"), "text/html; charset=utf-8");
    assert_eq!(
        get(&app, "/").await.header("content-type"),
        "text/html; charset=utf-8"
    );
    let r = send(&app, "GET", "/?f=json", &[("accept", browser)], vec![]).await;
    assert_eq!(r.header("content-type"), "application/json");
    let r = get(&app, "/conformance").await;
    assert_eq!(r.status, 200);
    let classes = r.json()["conformsTo"].clone();
    for c in CONFORMANCE {
        assert!(classes.as_array().unwrap().iter().any(|x| x == c), "{c}");
    }
}

/// The landing page's `service-desc` is the API definition as JSON, of the media type QGIS 3.22
/// looks for (it cannot read YAML and the layer would be invalid), followed as QGIS follows it;
/// the hand-written YAML stays linked as the alternate. Both answer the same document.
#[tokio::test]
async fn service_desc_is_the_json_api_definition() {
    let dir = DataDir::new("service-desc");
    let app = router(AppState::new(dir.config()));
    let landing = send(&app, "GET", "/", &[("accept", "application/json")], vec![]).await;
    let links = landing.json()["links"].as_array().unwrap().clone();
    let descs: Vec<(&str, &str)> = links
        .iter()
        .filter(|l| l["rel"] == "service-desc")
        .map(|l| (l["type"].as_str().unwrap(), l["href"].as_str().unwrap()))
        .collect();
    assert_eq!(
        descs,
        [
            (
                "application/vnd.oai.openapi+json;version=3.0",
                "http://127.0.0.1:9/openapi.json"
            ),
            (
                "application/vnd.oai.openapi;version=3.0",
                "http://127.0.0.1:9/openapi.yaml"
            ),
        ]
    );
    assert_eq!(OPENAPI_JSON_TYPE, descs[0].0);
    let accept = [("accept", "application/vnd.oai.openapi+json;version=3.0")];
    let r = send(&app, "GET", "/openapi.json", &accept, vec![]).await;
    assert_eq!(r.status, 200);
    assert_eq!(r.header("content-type"), OPENAPI_JSON_TYPE);
    let served = r.json();
    assert_eq!(served["openapi"], "3.1.0");
    assert!(served["paths"]["/collections/{collectionId}/items"]["get"].is_object());
    assert_eq!(r.body, OPENAPI_JSON.as_bytes());
    let yaml = get(&app, "/openapi.yaml").await;
    assert_eq!(yaml.status, 200);
    assert_eq!(yaml.header("content-type"), "application/yaml");
    assert_eq!(yaml.body, OPENAPI_YAML.as_bytes());
}

/// Processes core and OGC process description: the list, each description (inputs generated
/// from the options), 404 for an unknown process.
#[tokio::test]
async fn process_list_and_descriptions() {
    let dir = DataDir::new("processes");
    let app = router(AppState::new(dir.config()));
    let r = get(&app, "/processes").await;
    assert_eq!(r.status, 200);
    let v = r.json();
    let ids: Vec<&str> = v["processes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["id"].as_str().unwrap())
        .collect();
    assert_eq!(ids, ["fit", "interpolate", "evaluate"]);
    for p in v["processes"].as_array().unwrap() {
        assert!(p["version"].is_string());
        assert!(p["links"]
            .as_array()
            .unwrap()
            .iter()
            .any(|l| l["rel"] == "self"));
        let d = get(&app, &format!("/processes/{}", p["id"].as_str().unwrap())).await;
        assert_eq!(d.status, 200);
        let d = d.json();
        assert_eq!(d["inputs"]["data"]["minOccurs"], 1);
        assert!(d["outputs"]["result"].is_object());
        assert_eq!(
            d["jobControlOptions"],
            json!(["sync-execute", "async-execute", "dismiss"])
        );
    }
    let fit = get(&app, "/processes/fit").await.json();
    assert_eq!(fit["inputs"]["tolerance_m"]["schema"]["type"], "number");
    assert_eq!(
        fit["inputs"]["solver"]["schema"]["enum"],
        json!(["gls-pia-accelerated", "gls-pia", "gauss-newton"])
    );
    get(&app, "/processes/nope").await.problem(404, "not-found");
    execute(&app, "nope", &json!({}), false)
        .await
        .problem(404, "not-found");
}

/// Synchronous execution gives what `/v1/fit` gives for the same options, byte for byte; bad
/// requests get problem+json pointing into the execute request.
#[tokio::test]
async fn synchronous_execution_is_the_v1_fit() {
    let dir = DataDir::new("sync");
    let app = router(AppState::new(dir.config()));
    let data = lines(3);
    let r = execute(
        &app,
        "fit",
        &json!({"inputs": {"data": data, "tolerance_m": 100, "samples": 20}}),
        false,
    )
    .await;
    assert_eq!(r.status, 200, "{}", String::from_utf8_lossy(&r.body));
    assert_eq!(r.header("content-type"), "application/geo+json");
    let v1 = send(
        &app,
        "POST",
        "/v1/fit?tolerance_m=100&samples=20",
        &[("content-type", "application/geo+json")],
        serde_json::to_vec(&data).unwrap(),
    )
    .await;
    assert_eq!(v1.status, 200);
    assert_eq!(r.body, v1.body, "the same work as /v1/fit");
    // response=document wraps the same document.
    let d = execute(
        &app,
        "fit",
        &json!({"inputs": {"data": data, "tolerance_m": 100, "samples": 20}, "response": "document"}),
        false,
    )
    .await;
    assert_eq!(d.json()["result"], v1.json());
    // Interpolate and evaluate run too; evaluate reads the fit's output.
    let r = execute(
        &app,
        "interpolate",
        &json!({"inputs": {"data": data, "samples": 10}}),
        false,
    )
    .await;
    assert_eq!(r.status, 200);
    let r = execute(
        &app,
        "evaluate",
        &json!({"inputs": {"data": v1.json(), "samples": 7}}),
        false,
    )
    .await;
    assert_eq!(r.status, 200, "{}", String::from_utf8_lossy(&r.body));
    let e = r.json();
    assert_eq!(
        e["features"][0]["geometry"]["coordinates"]
            .as_array()
            .unwrap()
            .len(),
        7
    );
    // Errors.
    let p = execute(
        &app,
        "fit",
        &json!({"inputs": {"data": data, "degree": 9}}),
        false,
    )
    .await
    .problem(422, "invalid-option");
    assert_eq!(
        (p["parameter"].as_str(), p["pointer"].as_str()),
        (Some("degree"), Some("/inputs/degree"))
    );
    let p = execute(
        &app,
        "fit",
        &json!({"inputs": {"data": data, "colour": 1}}),
        false,
    )
    .await
    .problem(400, "invalid-input");
    assert_eq!(p["pointer"], "/inputs/colour");
    execute(&app, "fit", &json!({"inputs": {"tolerance_m": 1}}), false)
        .await
        .problem(400, "invalid-input");
    let r = send(
        &app,
        "POST",
        "/processes/fit/execution",
        &[("content-type", "text/plain")],
        b"{}".to_vec(),
    )
    .await;
    r.problem(415, "unsupported-media-type");
    let r = send(
        &app,
        "POST",
        "/processes/fit/execution",
        &[("content-type", "application/json")],
        b"{".to_vec(),
    )
    .await;
    r.problem(400, "malformed-json");
    let r = send(&app, "GET", "/processes/fit/execution", &[], vec![]).await;
    r.problem(405, "method-not-allowed");
    let small = router(AppState::new(ServiceConfig {
        max_body_bytes: 1000,
        ..dir.config()
    }));
    execute(&small, "fit", &json!({"inputs": {"data": data}}), false)
        .await
        .problem(413, "body-too-large");
    execute(
        &app,
        "fit",
        &json!({"inputs": {"data": {"type": "Point", "coordinates": [0, 0]}}}),
        false,
    )
    .await
    .problem(422, "nothing-to-fit");
}

/// Job list and dismiss classes: 201 + Location, status and progress, the result (equal to the
/// synchronous one), a later execution reading it by reference, the list, dismissal (404 after).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn async_job_lifecycle() {
    let dir = DataDir::new("lifecycle");
    let app = router(AppState::new(dir.config()));
    let body = json!({"inputs": {"data": lines(3), "tolerance_m": 100}});
    let id = submit(&app, "fit", &body).await;
    let v = wait(&app, &id).await;
    assert_eq!(v["status"], "successful", "{v}");
    assert_eq!(v["progress"], 100);
    for key in ["created", "started", "finished"] {
        assert!(v[key].as_str().unwrap().ends_with('Z'), "{key}: {v}");
    }
    let results = get(&app, &format!("/jobs/{id}/results")).await;
    assert_eq!(results.status, 200);
    assert_eq!(results.header("content-type"), "application/geo+json");
    let sync = execute(&app, "fit", &body, false).await;
    assert_eq!(results.body, sync.body);
    // By reference: evaluate the job's result (a relative and an absolute href).
    for href in [
        format!("/jobs/{id}/results"),
        format!("http://{HOST}/jobs/{id}/results"),
    ] {
        let r = execute(
            &app,
            "evaluate",
            &json!({"inputs": {"data": {"href": href}, "samples": 5}}),
            false,
        )
        .await;
        assert_eq!(r.status, 200, "{}", String::from_utf8_lossy(&r.body));
        assert_eq!(r.json()["features"].as_array().unwrap().len(), 3);
    }
    execute(
        &app,
        "evaluate",
        &json!({"inputs": {"data": {"href": "http://example.org/x.geojson"}}}),
        false,
    )
    .await
    .problem(422, "invalid-reference");
    let list = get(&app, "/jobs").await.json();
    assert!(list["jobs"]
        .as_array()
        .unwrap()
        .iter()
        .any(|j| j["jobID"] == id));
    // A failed job says why, and has no result.
    let bad = submit(
        &app,
        "fit",
        &json!({"inputs": {"data": {"type": "Point", "coordinates": [0, 0]}}}),
    )
    .await;
    let v = wait(&app, &bad).await;
    assert_eq!(v["status"], "failed");
    assert!(
        v["message"].as_str().unwrap().starts_with("nothing-to-fit"),
        "{v}"
    );
    get(&app, &format!("/jobs/{bad}/results"))
        .await
        .problem(404, "result-not-ready");
    // Bad requests are refused before a job is made.
    execute(
        &app,
        "fit",
        &json!({"inputs": {"data": lines(1), "degree": 9}}),
        true,
    )
    .await
    .problem(422, "invalid-option");
    // Dismiss.
    let r = send(&app, "DELETE", &format!("/jobs/{id}"), &[], vec![]).await;
    assert_eq!(r.status, 200);
    assert_eq!(r.json()["status"], "dismissed");
    get(&app, &format!("/jobs/{id}"))
        .await
        .problem(404, "not-found");
    get(&app, &format!("/jobs/{id}/results"))
        .await
        .problem(404, "not-found");
    send(&app, "DELETE", &format!("/jobs/{id}"), &[], vec![])
        .await
        .problem(404, "not-found");
    get(&app, "/jobs/not-a-job").await.problem(404, "not-found");
}

/// Features core and GeoJSON: the collections, paging with next links, bbox, single features.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn job_results_are_feature_collections() {
    let dir = DataDir::new("features");
    let app = router(AppState::new(dir.config()));
    let id = submit(
        &app,
        "fit",
        &json!({"inputs": {"data": lines(3), "tolerance_m": 100}}),
    )
    .await;
    assert_eq!(wait(&app, &id).await["status"], "successful");
    let c = get(&app, "/collections").await;
    assert_eq!(c.status, 200);
    let c = c.json();
    let ours = c["collections"]
        .as_array()
        .unwrap()
        .iter()
        .find(|x| x["id"] == id)
        .unwrap()
        .clone();
    assert!(ours["links"]
        .as_array()
        .unwrap()
        .iter()
        .any(|l| l["rel"] == "items"));
    assert_eq!(
        get(&app, &format!("/collections/{id}")).await.json()["id"],
        id
    );
    let page = get(&app, &format!("/collections/{id}/items?limit=2")).await;
    assert_eq!(page.status, 200);
    assert_eq!(page.header("content-type"), "application/geo+json");
    let page = page.json();
    assert_eq!(
        (
            page["numberMatched"].as_u64(),
            page["numberReturned"].as_u64()
        ),
        (Some(3), Some(2))
    );
    assert_eq!(page["features"][1]["id"], 1);
    assert_eq!(page["features"][1]["properties"]["name"], "line 1");
    let next = page["links"]
        .as_array()
        .unwrap()
        .iter()
        .find(|l| l["rel"] == "next")
        .unwrap()["href"]
        .as_str()
        .unwrap()
        .to_string();
    let next = next.strip_prefix(&format!("http://{HOST}")).unwrap();
    let page2 = get(&app, next).await.json();
    assert_eq!(page2["numberReturned"], 1);
    assert_eq!(page2["features"][0]["properties"]["name"], "line 2");
    assert!(!page2["links"]
        .as_array()
        .unwrap()
        .iter()
        .any(|l| l["rel"] == "next"));
    // bbox: line 1 runs from -90 to -80 degrees of longitude.
    let b = get(
        &app,
        &format!("/collections/{id}/items?bbox=-95,-20,-85,20"),
    )
    .await
    .json();
    assert_eq!(b["numberMatched"], 1);
    assert_eq!(b["features"][0]["properties"]["name"], "line 1");
    let d = get(
        &app,
        &format!("/collections/{id}/items?datetime=2026-01-01T00:00:00Z"),
    )
    .await;
    assert_eq!(
        d.json()["numberMatched"],
        3,
        "datetime matches every feature"
    );
    let f = get(&app, &format!("/collections/{id}/items/2")).await;
    assert_eq!(f.status, 200);
    assert_eq!(f.json()["properties"]["name"], "line 2");
    get(&app, &format!("/collections/{id}/items/9"))
        .await
        .problem(404, "not-found");
    get(&app, &format!("/collections/{id}/items?limit=0"))
        .await
        .problem(400, "invalid-query");
    get(&app, &format!("/collections/{id}/items?bbox=1,2,3"))
        .await
        .problem(400, "invalid-query");
    get(&app, &format!("/collections/{id}/items?colour=red"))
        .await
        .problem(400, "invalid-query");
    get(&app, "/collections/0123456789abcdef0123456789abcdef")
        .await
        .problem(404, "not-found");
    get(&app, "/collections/0123456789abcdef0123456789abcdef/items")
        .await
        .problem(404, "not-found");
}

/// A restart: finished jobs stay readable, unfinished ones are marked failed.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn jobs_survive_a_restart() {
    let dir = DataDir::new("restart");
    let config = ServiceConfig {
        fit_concurrency: 1,
        ..dir.config()
    };
    let first = router(AppState::new(config.clone()));
    let done = submit(
        &first,
        "fit",
        &json!({"inputs": {"data": lines(2), "tolerance_m": 100}}),
    )
    .await;
    assert_eq!(wait(&first, &done).await["status"], "successful");
    let result = get(&first, &format!("/jobs/{done}/results")).await.body;
    let running = submit(&first, "fit", &heavy()).await;
    // The service "restarts" while the heavy job runs: a second state over the same directory.
    let second = router(AppState::new(config));
    let v = get(&second, &format!("/jobs/{done}")).await.json();
    assert_eq!(v["status"], "successful");
    assert_eq!(
        get(&second, &format!("/jobs/{done}/results")).await.body,
        result
    );
    assert_eq!(
        get(&second, &format!("/collections/{done}/items"))
            .await
            .json()["numberMatched"],
        2
    );
    let v = get(&second, &format!("/jobs/{running}")).await.json();
    assert_eq!(v["status"], "failed", "{v}");
    assert!(v["message"].as_str().unwrap().contains("stopped"), "{v}");
    send(&first, "DELETE", &format!("/jobs/{running}"), &[], vec![]).await;
}

/// The store's size budget: a result that does not fit fails its job (nothing written), a job
/// with no room for its status is refused with 503 and Retry-After, and dismissing a job frees
/// its space for the next one.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_store_budget_holds_and_dismissal_frees_it() {
    let dir = DataDir::new("budget");
    // Room for two status files and a small result, not for the fit of 6 lines (about 8.6 KB:
    // degree-1 fits, whose splines refer to their geometry).
    let app = router(AppState::new(ServiceConfig {
        store_bytes: 2 * 4096 + 2000,
        ..dir.config()
    }));
    let body = json!({"inputs": {"data": lines(6), "tolerance_m": 100}});
    let a = submit(&app, "fit", &body).await;
    let v = wait(&app, &a).await;
    assert_eq!(v["status"], "failed");
    assert!(
        v["message"].as_str().unwrap().contains("does not fit"),
        "{v}"
    );
    let results = std::fs::read_dir(dir.0.join("jobs").join(&a))
        .unwrap()
        .count();
    assert_eq!(results, 1, "only status.json was written");
    let b = submit(&app, "fit", &body).await;
    wait(&app, &b).await;
    let r = execute(&app, "fit", &body, true).await;
    let p = r.problem(503, "store-full");
    assert!(r.header("retry-after").parse::<u32>().unwrap() > 0, "{p}");
    send(&app, "DELETE", &format!("/jobs/{a}"), &[], vec![]).await;
    assert!(
        !dir.0.join("jobs").join(&a).exists(),
        "the dismissed job's files are gone"
    );
    submit(&app, "fit", &body).await;
}

/// Finished jobs expire: their status and files are gone after the expiry.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn finished_jobs_expire() {
    let dir = DataDir::new("expiry");
    let app = router(AppState::new(ServiceConfig {
        job_expiry: Duration::from_millis(300),
        ..dir.config()
    }));
    let id = submit(&app, "fit", &json!({"inputs": {"data": lines(1)}})).await;
    assert_eq!(wait(&app, &id).await["status"], "successful");
    assert!(dir.0.join("jobs").join(&id).join("result").exists());
    tokio::time::sleep(Duration::from_millis(400)).await;
    get(&app, &format!("/jobs/{id}"))
        .await
        .problem(404, "not-found");
    get(&app, &format!("/collections/{id}"))
        .await
        .problem(404, "not-found");
    assert!(!dir.0.join("jobs").join(&id).exists());
}

/// Too many unfinished jobs: 429 with Retry-After; a job over its time budget ends failed
/// saying so, and frees its place.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn too_many_jobs_and_the_job_time_budget() {
    let dir = DataDir::new("bounds");
    let app = router(AppState::new(ServiceConfig {
        max_jobs: 1,
        fit_concurrency: 1,
        job_timeout: Duration::from_millis(1500),
        ..dir.config()
    }));
    let t = Instant::now();
    let id = submit(&app, "fit", &heavy()).await;
    let r = execute(&app, "fit", &json!({"inputs": {"data": lines(1)}}), true).await;
    r.problem(429, "too-many-jobs");
    assert!(r.header("retry-after").parse::<u32>().unwrap() > 0);
    let v = wait(&app, &id).await;
    assert_eq!(v["status"], "failed", "{v}");
    assert!(
        v["message"]
            .as_str()
            .unwrap()
            .contains("time budget of 1.5 s"),
        "{v}"
    );
    assert!(t.elapsed() < Duration::from_secs(20), "{:?}", t.elapsed());
    // Its place is free again.
    let next = submit(&app, "fit", &json!({"inputs": {"data": lines(1)}})).await;
    assert_eq!(wait(&app, &next).await["status"], "successful");
}

/// A data directory that cannot be written (here: under a regular file, which even root cannot
/// make a directory in) answers 503 `store-unavailable`, not `store-full`, and `serve` says so
/// in its start-up log; synchronous execution still works.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_unwritable_data_dir_is_store_unavailable() {
    let dir = DataDir::new("unwritable");
    std::fs::create_dir_all(&dir.0).unwrap();
    let file = dir.0.join("a-file");
    std::fs::write(&file, b"x").unwrap();
    let bad = file.join("data");
    let app = router(AppState::new(ServiceConfig {
        data_dir: Some(bad.clone()),
        ..ServiceConfig::default()
    }));
    let body = json!({"inputs": {"data": lines(1), "tolerance_m": 100}});
    let r = execute(&app, "fit", &body, true).await;
    let p = r.problem(503, "store-unavailable");
    assert_eq!(p["title"], "Job store unavailable");
    assert!(r.header("retry-after").parse::<u32>().unwrap() > 0, "{p}");
    assert_eq!(execute(&app, "fit", &body, false).await.status, 200);
    // The binary, started on it, says so before any request.
    let out = super::helpers::run_spherefit(
        &[
            "serve",
            "--addr",
            "127.0.0.1:0",
            "--data-dir",
            bad.to_str().unwrap(),
            "--exit-after-s",
            "0.2",
            "--log-format",
            "text",
        ],
        None,
    );
    let log = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{log}");
    assert!(
        log.contains("the job store cannot be written") && log.contains("store-unavailable"),
        "{log}"
    );
}

/// A key file of two owners: `printf %s alice-token | sha256sum`, and bob's.
const KEYS: &str = "# owners of the tests\nalice:9c220f200955d76c0a38d308225e0ef10c5f971acaf2f8d1d8f732affa5bd1dc\nbob:97dd3707015dcf069cf73022ed7173b1165db6eff24b441cb57fd069a8c4e525\n";

fn keyed(dir: &DataDir) -> ServiceConfig {
    ServiceConfig {
        api_keys: Some(spherefit::service::auth::ApiKeys::parse(KEYS).unwrap()),
        ..dir.config()
    }
}

fn bearer(token: &str) -> String {
    format!("Bearer {token}")
}

/// With a key file every route but `/health` and the page's files needs a bearer token: none
/// gives 401 with `WWW-Authenticate: Bearer`, a wrong one 401 as well, saying no more.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn api_keys_guard_every_route_but_health_and_the_page_files() {
    let dir = DataDir::new("keys");
    let app = router(AppState::new(keyed(&dir)));
    assert_eq!(get(&app, "/health").await.status, 200);
    for asset in ["/page/app.js", "/page/style.css"] {
        assert_eq!(get(&app, asset).await.status, 200, "{asset} is open");
    }
    for path in [
        "/",
        "/?f=json",
        "/openapi.yaml",
        "/metrics",
        "/conformance",
        "/processes",
        "/jobs",
        "/collections",
        "/v1/limits",
        "/no-such-path",
    ] {
        let r = get(&app, path).await;
        let p = r.problem(401, "unauthorized");
        assert!(r.header("www-authenticate").starts_with("Bearer"), "{path}");
        assert!(p["detail"].as_str().unwrap().contains("Bearer"), "{p}");
        let wrong = send(
            &app,
            "GET",
            path,
            &[("authorization", "Bearer nope")],
            vec![],
        )
        .await;
        let pw = wrong.problem(401, "unauthorized");
        assert!(wrong.header("www-authenticate").starts_with("Bearer"));
        let basic = send(
            &app,
            "GET",
            path,
            &[("authorization", "Basic YWxpY2U6eA==")],
            vec![],
        )
        .await;
        assert_eq!(basic.problem(401, "unauthorized")["detail"], pw["detail"]);
        // A token of one owner with junk around it is wrong, and says so the same way.
        let junk = send(
            &app,
            "GET",
            path,
            &[("authorization", "Bearer alice-token2")],
            vec![],
        )
        .await;
        assert_eq!(junk.problem(401, "unauthorized")["detail"], pw["detail"]);
    }
    let h = bearer("alice-token");
    let r = send(&app, "GET", "/processes", &[("authorization", &h)], vec![]).await;
    assert_eq!(r.status, 200);
    let r = send(
        &app,
        "POST",
        "/v1/fit",
        &[
            ("authorization", "Bearer x"),
            ("content-type", "application/geo+json"),
        ],
        serde_json::to_vec(&lines(1)).unwrap(),
    )
    .await;
    r.problem(401, "unauthorized");
}

/// Each job belongs to its token's owner: another owner's job, result and collection answer
/// 404 as if absent, lists hold the caller's only, and each owner has its own bound on
/// unfinished jobs (429 with Retry-After).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn owners_see_only_their_own_jobs() {
    let dir = DataDir::new("owners");
    let app = router(AppState::new(ServiceConfig {
        max_owner_jobs: 1,
        ..keyed(&dir)
    }));
    let (alice, bob) = (bearer("alice-token"), bearer("bob-token"));
    let post = |who: &str, body: &Value| {
        let who = who.to_string();
        let body = serde_json::to_vec(body).unwrap();
        let app = app.clone();
        async move {
            send(
                &app,
                "POST",
                "/processes/fit/execution",
                &[
                    ("authorization", who.as_str()),
                    ("content-type", "application/json"),
                    ("prefer", "respond-async"),
                ],
                body,
            )
            .await
        }
    };
    let r = post(
        &alice,
        &json!({"inputs": {"data": lines(2), "tolerance_m": 100}}),
    )
    .await;
    assert_eq!(r.status, 201, "{}", String::from_utf8_lossy(&r.body));
    let id = r.json()["jobID"].as_str().unwrap().to_string();
    let as_of = |who: &str, path: String| {
        let (who, app) = (who.to_string(), app.clone());
        async move {
            send(
                &app,
                "GET",
                &path,
                &[("authorization", who.as_str())],
                vec![],
            )
            .await
        }
    };
    let start = Instant::now();
    loop {
        let v = as_of(&alice, format!("/jobs/{id}")).await.json();
        if v["status"] == "successful" {
            break;
        }
        assert!(v["status"] != "failed", "{v}");
        assert!(start.elapsed() < Duration::from_secs(60));
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    for path in [
        format!("/jobs/{id}"),
        format!("/jobs/{id}/results"),
        format!("/collections/{id}"),
        format!("/collections/{id}/items"),
        format!("/collections/{id}/items/0"),
    ] {
        as_of(&bob, path.clone()).await.problem(404, "not-found");
        assert_eq!(as_of(&alice, path.clone()).await.status, 200, "{path}");
    }
    assert_eq!(as_of(&bob, "/jobs".into()).await.json()["jobs"], json!([]));
    assert_eq!(
        as_of(&bob, "/collections".into()).await.json()["collections"],
        json!([])
    );
    assert_eq!(
        as_of(&alice, "/jobs".into()).await.json()["jobs"][0]["jobID"],
        id.as_str()
    );
    let r = send(
        &app,
        "DELETE",
        &format!("/jobs/{id}"),
        &[("authorization", &bob)],
        vec![],
    )
    .await;
    r.problem(404, "not-found");
    // Bob cannot use alice's result as his input either.
    let href = json!({"inputs": {"data": {"href": format!("/jobs/{id}/results")}}});
    post(&bob, &href).await.problem(422, "invalid-reference");
    // One unfinished job each: alice's second waits on a slow one; bob still gets in.
    let slow = post(&alice, &heavy()).await;
    assert_eq!(slow.status, 201, "{}", String::from_utf8_lossy(&slow.body));
    let slow_id = slow.json()["jobID"].as_str().unwrap().to_string();
    let r = post(&alice, &json!({"inputs": {"data": lines(1)}})).await;
    let p = r.problem(429, "too-many-jobs");
    assert!(r.header("retry-after").parse::<u32>().unwrap() > 0, "{p}");
    assert_eq!(
        post(&bob, &json!({"inputs": {"data": lines(1)}}))
            .await
            .status,
        201
    );
    let r = send(
        &app,
        "DELETE",
        &format!("/jobs/{slow_id}"),
        &[("authorization", &alice)],
        vec![],
    )
    .await;
    assert_eq!(r.status, 200);
    // Alice's job is there after a restart, still hers alone.
    drop(app);
    let app = router(AppState::new(keyed(&dir)));
    let r = send(
        &app,
        "GET",
        &format!("/jobs/{id}"),
        &[("authorization", &alice)],
        vec![],
    )
    .await;
    assert_eq!(r.json()["status"], "successful");
    let r = send(
        &app,
        "GET",
        &format!("/jobs/{id}"),
        &[("authorization", &bob)],
        vec![],
    )
    .await;
    assert_eq!(r.status, 404);
}
