//! `openapi.yaml` is the contract: every documented path and method is routed, every documented
//! request example is accepted (200, with the documented content type), and so is every
//! documented parameter example.

use axum::body::Body;
use axum::http::{header, Request};
use serde_json::Value;
use spherefit::service::{router, AppState, ServiceConfig, OPENAPI_JSON, OPENAPI_YAML};
use tower::ServiceExt;
use yaml_rust2::{Yaml, YamlLoader};

fn to_json(y: &Yaml) -> Value {
    match y {
        Yaml::Real(s) => Value::from(s.parse::<f64>().expect("a YAML real")),
        Yaml::Integer(i) => Value::from(*i),
        Yaml::String(s) => Value::from(s.clone()),
        Yaml::Boolean(b) => Value::from(*b),
        Yaml::Array(a) => Value::Array(a.iter().map(to_json).collect()),
        Yaml::Hash(h) => Value::Object(
            h.iter()
                .map(|(k, v)| {
                    let key = match k {
                        Yaml::String(s) => s.clone(),
                        Yaml::Integer(i) => i.to_string(),
                        other => panic!("unexpected key {other:?}"),
                    };
                    (key, to_json(v))
                })
                .collect(),
        ),
        Yaml::Null => Value::Null,
        other => panic!("unexpected YAML {other:?}"),
    }
}

fn spec() -> Value {
    let docs = YamlLoader::load_from_str(OPENAPI_YAML).expect("openapi.yaml parses");
    to_json(&docs[0])
}

/// Follows a local `$ref` (`#/components/...`).
fn resolve<'a>(spec: &'a Value, v: &'a Value) -> &'a Value {
    match v.get("$ref").and_then(Value::as_str) {
        Some(r) => {
            let ptr = r.strip_prefix('#').expect("a local $ref");
            resolve(
                spec,
                spec.pointer(ptr).unwrap_or_else(|| panic!("dangling {r}")),
            )
        }
        None => v,
    }
}

struct Example {
    content_type: String,
    name: String,
    body: Vec<u8>,
}

fn examples_of(spec: &Value, op: &Value) -> Vec<Example> {
    let Some(rb) = op.get("requestBody") else {
        return Vec::new();
    };
    let rb = resolve(spec, rb);
    let mut out = Vec::new();
    for (ct, media) in rb["content"].as_object().expect("content") {
        let examples = media["examples"]
            .as_object()
            .unwrap_or_else(|| panic!("every request body documents examples ({ct})"));
        for (name, ex) in examples {
            let ex = resolve(spec, ex);
            out.push(Example {
                content_type: ct.clone(),
                name: name.clone(),
                body: serde_json::to_vec(&ex["value"]).unwrap(),
            });
        }
    }
    out
}

/// The job id of the path examples in `openapi.yaml` (`jobId`, `collectionId`): a call to such a
/// path is made on a server that has just run one job, with that job's id in its place.
const EXAMPLE_JOB: &str = "0123456789abcdef0123456789abcdef";

/// Runs a small fit job on `app` and waits for it; returns its id.
async fn run_job(app: &axum::Router) -> String {
    let body = br#"{"inputs": {"data": {"type": "LineString", "coordinates": [[0, 0], [1, 1], [2, 0], [3, 1]]}}}"#;
    let req = Request::post("/processes/fit/execution")
        .header(header::CONTENT_TYPE, "application/json")
        .header("prefer", "respond-async")
        .body(Body::from(&body[..]))
        .unwrap();
    let res = app.clone().oneshot(req).await.unwrap();
    assert_eq!(res.status(), 201);
    let v: Value = serde_json::from_slice(
        &axum::body::to_bytes(res.into_body(), usize::MAX)
            .await
            .unwrap(),
    )
    .unwrap();
    let id = v["jobID"].as_str().unwrap().to_string();
    for _ in 0..2000 {
        let res = app
            .clone()
            .oneshot(
                Request::get(format!("/jobs/{id}"))
                    .body(Body::empty())
                    .unwrap(),
            )
            .await
            .unwrap();
        let v: Value = serde_json::from_slice(
            &axum::body::to_bytes(res.into_body(), usize::MAX)
                .await
                .unwrap(),
        )
        .unwrap();
        if v["status"] == "successful" {
            return id;
        }
        tokio::time::sleep(std::time::Duration::from_millis(10)).await;
    }
    panic!("the example job did not finish");
}

async fn call(
    method: &str,
    uri: &str,
    ctype: Option<&str>,
    body: Vec<u8>,
) -> (u16, String, Vec<u8>) {
    static N: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let dir = std::env::temp_dir().join(format!(
        "spherefit-it-openapi-{}-{}",
        std::process::id(),
        N.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
    ));
    let app = router(AppState::new(ServiceConfig {
        data_dir: Some(dir.clone()),
        ..ServiceConfig::default()
    }));
    let mut uri = uri.to_string();
    if uri.contains(EXAMPLE_JOB) {
        uri = uri.replace(EXAMPLE_JOB, &run_job(&app).await);
    }
    let mut req = Request::builder().method(method).uri(uri);
    if let Some(c) = ctype {
        req = req.header(header::CONTENT_TYPE, c);
    }
    let res = app
        .oneshot(req.body(Body::from(body)).unwrap())
        .await
        .unwrap();
    let status = res.status().as_u16();
    let ct = res
        .headers()
        .get(header::CONTENT_TYPE)
        .map_or(String::new(), |v| v.to_str().unwrap().to_string());
    let body = axum::body::to_bytes(res.into_body(), usize::MAX)
        .await
        .unwrap()
        .to_vec();
    let _ = std::fs::remove_dir_all(&dir);
    (status, ct, body)
}

/// Every operation, its path with each `{name}` replaced by that path parameter's example.
fn operations(spec: &Value) -> Vec<(String, String, Value)> {
    let mut ops = Vec::new();
    for (path, item) in spec["paths"].as_object().unwrap() {
        for (method, op) in item.as_object().unwrap() {
            let mut concrete = path.clone();
            for p in op["parameters"].as_array().cloned().unwrap_or_default() {
                let p = resolve(spec, &p);
                if p["in"] == "path" {
                    let name = p["name"].as_str().unwrap();
                    let example = p["example"].as_str().expect("a path parameter example");
                    concrete = concrete.replace(&format!("{{{name}}}"), example);
                }
            }
            ops.push((concrete, method.to_uppercase(), op.clone()));
        }
    }
    ops
}

#[tokio::test]
async fn every_documented_operation_is_routed() {
    let spec = spec();
    assert_eq!(spec["openapi"], "3.1.0");
    let ops = operations(&spec);
    assert!(ops.len() >= 9, "{}", ops.len());
    for (path, method, op) in ops {
        let (ct, body) = match examples_of(&spec, &op).into_iter().next() {
            Some(e) => (Some(e.content_type), e.body),
            None => (None, Vec::new()),
        };
        let (status, _, body) = call(&method, &path, ct.as_deref(), body).await;
        assert!(
            status != 404 && status != 405,
            "{method} {path} is not routed: {status} {}",
            String::from_utf8_lossy(&body)
        );
    }
    // And something undocumented is not.
    assert_eq!(call("GET", "/v1/nothing", None, vec![]).await.0, 404);
}

#[tokio::test]
async fn every_documented_example_is_accepted() {
    let spec = spec();
    let mut checked = 0;
    for (path, method, op) in operations(&spec) {
        let documented_ok: Vec<String> = op["responses"]["200"]
            .get("$ref")
            .map_or(&op["responses"]["200"], |_| {
                resolve(&spec, &op["responses"]["200"])
            })["content"]
            .as_object()
            .map(|c| c.keys().cloned().collect())
            .unwrap_or_default();
        let examples = examples_of(&spec, &op);
        if examples.is_empty() {
            let (status, ct, _) = call(&method, &path, None, vec![]).await;
            assert_eq!(status, 200, "{method} {path}");
            assert!(
                documented_ok.iter().any(|d| ct.starts_with(d.as_str())),
                "{method} {path}: {ct}"
            );
            checked += 1;
        }
        for e in &examples {
            let (status, ct, body) =
                call(&method, &path, Some(&e.content_type), e.body.clone()).await;
            assert_eq!(
                status,
                200,
                "{method} {path} example {:?} ({}): {}",
                e.name,
                e.content_type,
                String::from_utf8_lossy(&body)
            );
            assert!(
                documented_ok.iter().any(|d| ct.starts_with(d.as_str())),
                "{method} {path}: {ct} not in {documented_ok:?}"
            );
            checked += 1;
        }
        // Every parameter example, alone, with the first body example.
        for p in op["parameters"].as_array().cloned().unwrap_or_default() {
            let p = resolve(&spec, &p).clone();
            if p["in"] == "path" {
                continue; // in the path already
            }
            let Some(example) = p.get("example") else {
                panic!("{method} {path}: parameter {} has no example", p["name"]);
            };
            let value = match example {
                Value::String(s) => s.clone(),
                other => other.to_string(),
            };
            let uri = format!("{path}?{}={value}", p["name"].as_str().unwrap());
            let (ct, body) = examples.first().map_or((None, Vec::new()), |e| {
                (Some(e.content_type.as_str()), e.body.clone())
            });
            let (status, _, reply) = call(&method, &uri, ct, body).await;
            assert_eq!(
                status,
                200,
                "{method} {uri}: {}",
                String::from_utf8_lossy(&reply)
            );
            checked += 1;
        }
    }
    assert!(checked >= 40, "{checked}");
}

#[tokio::test]
async fn the_served_contract_is_the_file() {
    let (status, ct, body) = call("GET", "/openapi.yaml", None, vec![]).await;
    assert_eq!(status, 200);
    assert_eq!(ct, "application/yaml");
    let file =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/openapi.yaml")).unwrap();
    assert_eq!(String::from_utf8(body).unwrap(), file);
}

/// `/openapi.json` (made by build.rs) is `openapi.yaml`, value for value: read here with this
/// test's own YAML-to-JSON reading, independent of the build script's writer.
#[tokio::test]
async fn the_json_contract_is_the_yaml_file() {
    let (status, ct, body) = call("GET", "/openapi.json", None, vec![]).await;
    assert_eq!(status, 200);
    assert_eq!(ct, "application/vnd.oai.openapi+json;version=3.0");
    assert_eq!(body, OPENAPI_JSON.as_bytes());
    let served: Value = serde_json::from_slice(&body).expect("/openapi.json is JSON");
    let file =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/openapi.yaml")).unwrap();
    let docs = YamlLoader::load_from_str(&file).expect("openapi.yaml parses");
    assert_eq!(served, to_json(&docs[0]));
    // The key order is the file's (paths read in the order they are written).
    let at = |p: &str| OPENAPI_JSON.find(&format!("\"{p}\":{{")).unwrap();
    assert!(at("/v1/fit") < at("/v1/interpolate") && at("/openapi.yaml") < at("/openapi.json"));
}
