//! HTTP tests against a real bound port (127.0.0.1, ephemeral): the endpoints over TCP, 32
//! simultaneous requests, 503 with `Retry-After` when the fitting bound is taken, graceful
//! shutdown with a request in flight, and SIGTERM to the `spherefit serve` binary.

use serde_json::{json, Value};
use spherefit::service::{serve, AppState, ServiceConfig};
use std::net::SocketAddr;
use std::time::{Duration, Instant};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};

struct Reply {
    status: u16,
    headers: Vec<(String, String)>,
    body: Vec<u8>,
}

impl Reply {
    fn header(&self, name: &str) -> Option<&str> {
        self.headers
            .iter()
            .find(|(k, _)| k.eq_ignore_ascii_case(name))
            .map(|(_, v)| v.as_str())
    }
    fn json(&self) -> Value {
        serde_json::from_slice(&self.body)
            .unwrap_or_else(|e| panic!("{e}: {}", String::from_utf8_lossy(&self.body)))
    }
}

/// One HTTP/1.1 request on a fresh connection (`Connection: close`).
async fn request(addr: SocketAddr, method: &str, path: &str, ctype: &str, body: &[u8]) -> Reply {
    let mut s = TcpStream::connect(addr).await.expect("connect");
    let head = format!(
        "{method} {path} HTTP/1.1\r\nHost: {addr}\r\nContent-Type: {ctype}\r\nContent-Length: {}\r\nConnection: close\r\n\r\n",
        body.len()
    );
    s.write_all(head.as_bytes()).await.unwrap();
    s.write_all(body).await.unwrap();
    let mut raw = Vec::new();
    s.read_to_end(&mut raw).await.unwrap();
    let split = raw
        .windows(4)
        .position(|w| w == b"\r\n\r\n")
        .expect("a complete response head");
    let head = String::from_utf8_lossy(&raw[..split]).to_string();
    let mut lines = head.split("\r\n");
    let status: u16 = lines
        .next()
        .unwrap()
        .split(' ')
        .nth(1)
        .unwrap()
        .parse()
        .unwrap();
    let headers: Vec<(String, String)> = lines
        .filter_map(|l| l.split_once(':'))
        .map(|(k, v)| (k.trim().to_string(), v.trim().to_string()))
        .collect();
    Reply {
        status,
        headers,
        body: raw[split + 4..].to_vec(),
    }
}

async fn get(addr: SocketAddr, path: &str) -> Reply {
    request(addr, "GET", path, "text/plain", b"").await
}

async fn post(addr: SocketAddr, path: &str, v: &Value) -> Reply {
    request(
        addr,
        "POST",
        path,
        "application/geo+json",
        &serde_json::to_vec(v).unwrap(),
    )
    .await
}

/// Starts a server on an ephemeral port; returns its address, a shutdown trigger and the
/// task running it. The server also stops by itself after 120 s.
async fn start(
    config: ServiceConfig,
) -> (
    SocketAddr,
    tokio::sync::oneshot::Sender<()>,
    tokio::task::JoinHandle<std::io::Result<()>>,
) {
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = listener.local_addr().unwrap();
    let (tx, rx) = tokio::sync::oneshot::channel::<()>();
    let shutdown = async move {
        tokio::select! {
            _ = rx => {}
            _ = tokio::time::sleep(Duration::from_secs(120)) => {}
        }
    };
    let task = tokio::spawn(serve(listener, AppState::new(config), shutdown));
    (addr, tx, task)
}

fn wavy(n: usize, lon0: f64) -> Value {
    json!({"type": "LineString", "coordinates": (0..n)
        .map(|i| { let x = i as f64 / n as f64; [lon0 + 10.0 * x, 3.0 * (20.0 * x).sin()] })
        .collect::<Vec<_>>()})
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn endpoints_over_tcp() {
    let (addr, stop, task) = start(ServiceConfig::default()).await;
    let r = get(addr, "/health").await;
    assert_eq!(r.status, 200);
    assert_eq!(r.json()["status"], "ok");
    let r = get(addr, "/openapi.yaml").await;
    assert_eq!(r.status, 200);
    assert_eq!(r.header("content-type"), Some("application/yaml"));

    let r = post(addr, "/v1/fit?control_points=20", &wavy(500, 0.0)).await;
    assert_eq!(r.status, 200, "{}", String::from_utf8_lossy(&r.body));
    assert_eq!(r.header("content-type"), Some("application/geo+json"));
    let fitted = r.json();
    assert_eq!(
        fitted["features"][0]["properties"]["fit"]["control_points"],
        20
    );
    let r = post(addr, "/v1/evaluate?samples=50", &fitted).await;
    assert_eq!(r.status, 200);
    assert_eq!(
        r.json()["features"][0]["geometry"]["coordinates"]
            .as_array()
            .unwrap()
            .len(),
        50
    );
    let r = post(addr, "/v1/interpolate?samples=30", &wavy(10, 0.0)).await;
    assert_eq!(r.status, 200);

    let pts = json!([
        [1, 0, 0],
        [0.8, 0.6, 0],
        [0.6, 0.6, 0.52915],
        [0, 0.6, 0.8],
        [0, 0, 1]
    ]);
    let body = serde_json::to_vec(&pts).unwrap();
    let r = request(
        addr,
        "POST",
        "/v1/sphere/fit?degree=2",
        "application/json",
        &body,
    )
    .await;
    assert_eq!(r.status, 200);
    let doc = r.json();
    let r = request(
        addr,
        "POST",
        "/v1/sphere/evaluate?samples=3",
        "application/json",
        &serde_json::to_vec(&doc).unwrap(),
    )
    .await;
    assert_eq!(r.json()["points"].as_array().unwrap().len(), 3);
    let r = request(
        addr,
        "POST",
        "/v1/sphere/interpolate",
        "application/json",
        &body,
    )
    .await;
    assert_eq!(r.status, 200);

    let r = request(addr, "POST", "/v1/fit", "text/csv", b"lon,lat").await;
    assert_eq!(r.status, 415);
    assert_eq!(r.header("content-type"), Some("application/problem+json"));

    let r = get(addr, "/metrics").await;
    let text = String::from_utf8(r.body).unwrap();
    assert!(
        text.contains("route=\"/v1/fit\",method=\"POST\",status=\"415\"} 1"),
        "{text}"
    );
    stop.send(()).unwrap();
    task.await.unwrap().unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn thirty_two_simultaneous_requests_all_succeed() {
    let (addr, stop, task) = start(ServiceConfig::default()).await;
    let mut handles = Vec::new();
    for k in 0..32 {
        handles.push(tokio::spawn(async move {
            // 100 positions each: the point is 32 at once, not the work per request (which on
            // a loaded 2-core machine could otherwise reach the 30 s budget).
            let r = post(addr, "/v1/fit", &wavy(100, k as f64)).await;
            (r.status, r.json())
        }));
    }
    for (k, h) in handles.into_iter().enumerate() {
        let (status, body) = h.await.unwrap();
        assert_eq!(status, 200, "request {k}: {body}");
        // Every answer belongs to its own request.
        let first = &body["features"][0]["geometry"]["coordinates"][0];
        assert!(
            (first[0].as_f64().unwrap() - k as f64).abs() < 0.5,
            "{k}: {first}"
        );
    }
    stop.send(()).unwrap();
    task.await.unwrap().unwrap();
}

/// A request that keeps a fitting slot busy for a good while (a few hundred ms at least).
fn slow_body() -> Value {
    json!({"type": "LineString", "coordinates": (0..60_000)
        .map(|i| { let x = i as f64 * 1.5e-4; [x, (37.0 * x).sin() + 0.001 * (997.0 * x).sin()] })
        .collect::<Vec<_>>()})
}

async fn wait_for_metric(addr: SocketAddr, line: &str) {
    let start = Instant::now();
    loop {
        let text = String::from_utf8(get(addr, "/metrics").await.body).unwrap();
        if text.lines().any(|l| l == line) {
            return;
        }
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "never saw {line}"
        );
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn past_the_fitting_bound_requests_get_503_with_retry_after() {
    let config = ServiceConfig {
        fit_concurrency: 1,
        fit_queue: 0,
        request_timeout: Duration::from_secs(110),
        ..ServiceConfig::default()
    };
    let (addr, stop, task) = start(config).await;
    let slow = tokio::spawn(async move { post(addr, "/v1/fit", &slow_body()).await.status });
    wait_for_metric(addr, "spherefit_fits_in_progress 1").await;
    let r = post(addr, "/v1/fit", &wavy(100, 0.0)).await;
    assert_eq!(r.status, 503, "{}", String::from_utf8_lossy(&r.body));
    assert_eq!(r.header("retry-after"), Some("1"));
    assert_eq!(r.json()["type"], "urn:spherefit:problem:overloaded");
    // Light endpoints stay available, and the slow request completes.
    assert_eq!(get(addr, "/health").await.status, 200);
    assert_eq!(slow.await.unwrap(), 200);
    let r = post(addr, "/v1/fit", &wavy(100, 0.0)).await;
    assert_eq!(r.status, 200);
    let text = String::from_utf8(get(addr, "/metrics").await.body).unwrap();
    assert!(
        text.contains("spherefit_overload_rejections_total 1"),
        "{text}"
    );
    stop.send(()).unwrap();
    task.await.unwrap().unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn graceful_shutdown_finishes_the_request_in_flight() {
    let config = ServiceConfig {
        request_timeout: Duration::from_secs(110),
        ..ServiceConfig::default()
    };
    let (addr, stop, task) = start(config).await;
    let slow = tokio::spawn(async move { post(addr, "/v1/fit", &slow_body()).await.status });
    wait_for_metric(addr, "spherefit_fits_in_progress 1").await;
    stop.send(()).unwrap();
    assert_eq!(slow.await.unwrap(), 200);
    tokio::time::timeout(Duration::from_secs(60), task)
        .await
        .expect("the server stops after the request")
        .unwrap()
        .unwrap();
    assert!(
        TcpStream::connect(addr).await.is_err(),
        "no longer listening"
    );
}

#[test]
fn the_binary_stops_on_sigterm() {
    use std::process::Command;
    let (mut child, addr, lines) = crate::helpers::spawn_server(60, &[]);
    let rt = tokio::runtime::Runtime::new().unwrap();
    let r = rt.block_on(get(addr, "/health"));
    assert_eq!(r.status, 200);
    let killed = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        assert!(
            start.elapsed() < Duration::from_secs(20),
            "still running after SIGTERM"
        );
        std::thread::sleep(Duration::from_millis(20));
    };
    assert!(status.success(), "{status:?}");
    let rest: Vec<String> = lines.map_while(Result::ok).collect();
    assert!(rest.iter().any(|l| l.contains("SIGTERM")), "{rest:?}");
}
