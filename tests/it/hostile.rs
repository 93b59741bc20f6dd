//! Hostile clients against a spawned release server: each test reproduces one way a
//! small request used to crash, stall or starve the service, and asserts the fixed behaviour:
//! status and problem+json with a pointer, bounded time, bounded memory of the server, slots
//! freed after the budget, and `/health` answering fast throughout. Every server listens on
//! 127.0.0.1:0 and stops by itself (`--exit-after-s`); every socket has a read timeout.

use serde_json::{json, Value};
use std::io::{Read, Write};
use std::net::{Shutdown, SocketAddr, TcpStream};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// A `spherefit serve` child process, killed when dropped.
struct Server {
    child: Child,
    addr: SocketAddr,
}

impl Server {
    fn start(extra: &[&str]) -> Server {
        let (child, addr, lines) = crate::helpers::spawn_server(120, extra);
        // Keep reading the log so the server never blocks on a full pipe.
        std::thread::spawn(move || for _ in lines.map_while(Result::ok) {});
        Server { child, addr }
    }

    /// Peak resident memory of the server so far, MiB (VmHWM).
    fn peak_rss_mib(&self) -> f64 {
        let s = std::fs::read_to_string(format!("/proc/{}/status", self.child.id())).unwrap();
        let kb: f64 = s
            .lines()
            .find(|l| l.starts_with("VmHWM:"))
            .and_then(|l| l.split_whitespace().nth(1))
            .and_then(|x| x.parse().ok())
            .unwrap();
        kb / 1024.0
    }

    fn connect(&self) -> TcpStream {
        let s = TcpStream::connect(self.addr).unwrap();
        s.set_read_timeout(Some(Duration::from_secs(60))).unwrap();
        s.set_write_timeout(Some(Duration::from_secs(60))).unwrap();
        s
    }

    fn request(&self, method: &str, path: &str, ctype: &str, body: &[u8]) -> Reply {
        let mut s = self.connect();
        let head = format!(
            "{method} {path} HTTP/1.1\r\nhost: x\r\ncontent-type: {ctype}\r\ncontent-length: {}\r\nconnection: close\r\n\r\n",
            body.len()
        );
        s.write_all(head.as_bytes()).unwrap();
        s.write_all(body).unwrap();
        read_reply(&mut s)
    }

    fn post(&self, path: &str, body: &Value) -> Reply {
        let ctype = if path.starts_with("/v1/sphere") {
            "application/json"
        } else {
            "application/geo+json"
        };
        self.request("POST", path, ctype, body.to_string().as_bytes())
    }

    fn get(&self, path: &str) -> Reply {
        self.request("GET", path, "text/plain", b"")
    }

    /// `/health` answers 200, and within `within`.
    fn assert_healthy(&self, within: Duration) {
        let t = Instant::now();
        let r = self.get("/health");
        assert_eq!(r.status, 200);
        assert!(t.elapsed() < within, "/health took {:?}", t.elapsed());
    }

    /// The `spherefit_fits_in_progress` gauge.
    fn fits_in_progress(&self) -> u64 {
        let m = self.get("/metrics").text;
        m.lines()
            .find_map(|l| l.strip_prefix("spherefit_fits_in_progress "))
            .and_then(|x| x.trim().parse().ok())
            .expect("the gauge")
    }

    /// Waits until no request holds a fitting slot; the time it took.
    fn wait_slots_free(&self, at_most: Duration) -> Duration {
        let t = Instant::now();
        while self.fits_in_progress() > 0 {
            assert!(
                t.elapsed() < at_most,
                "a slot is still held after {at_most:?}"
            );
            std::thread::sleep(Duration::from_millis(50));
        }
        t.elapsed()
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

struct Reply {
    status: u16,
    head: String,
    text: String,
}

impl Reply {
    fn json(&self) -> Value {
        serde_json::from_str(&self.text).unwrap_or_else(|_| panic!("not JSON: {}", self.text))
    }

    /// A problem+json body of `status` with this `type` suffix.
    fn problem(&self, status: u16, slug: &str) -> Value {
        assert_eq!(self.status, status, "{} {}", self.head, self.text);
        assert!(
            self.head
                .to_ascii_lowercase()
                .contains("content-type: application/problem+json"),
            "{}",
            self.head
        );
        let p = self.json();
        assert_eq!(p["type"], format!("urn:spherefit:problem:{slug}"), "{p}");
        p
    }
}

fn read_reply(s: &mut TcpStream) -> Reply {
    let mut buf = Vec::new();
    let _ = s.read_to_end(&mut buf);
    let text = String::from_utf8_lossy(&buf).to_string();
    let (head, body) = text.split_once("\r\n\r\n").unwrap_or((&text, ""));
    let status = head
        .split_whitespace()
        .nth(1)
        .and_then(|x| x.parse().ok())
        .unwrap_or(0);
    Reply {
        status,
        head: head.to_string(),
        text: body.to_string(),
    }
}

fn line(n: usize, lon0: f64) -> Value {
    json!((0..n)
        .map(|i| [lon0 + i as f64 * 0.01, (i as f64 * 0.1).sin()])
        .collect::<Vec<_>>())
}

/// A fit that runs for many seconds: 300,000 positions, 10,000 control points, 1,000
/// iterations (about 7 MB of body).
fn heavy_line() -> Value {
    let n = 300_000;
    json!({"type": "LineString", "coordinates": (0..n).map(|i| {
        let f = i as f64 / n as f64;
        [((-170.0 + 340.0 * f) * 1e6).round() / 1e6, ((30.0 * (i as f64 * 0.001).sin() + (i % 7) as f64 * 0.01) * 1e6).round() / 1e6]
    }).collect::<Vec<_>>()})
}

#[test]
fn output_is_bounded_before_it_is_made() {
    let srv = Server::start(&[]);
    // A dimension-3000 spline (18 KB) sampled 100,000 times used to abort the process.
    let dim = 3000;
    let mut a = vec![0.0; dim];
    a[0] = 1.0;
    let mut b = vec![0.0; dim];
    b[1] = 1.0;
    let doc = json!({"degree": 1, "knots": [0, 0, 1, 1], "control_points": [a, b]});
    let t = Instant::now();
    let r = srv.post("/v1/sphere/evaluate?samples=100000", &doc);
    let p = r.problem(422, "output-too-large");
    assert_eq!(p["parameter"], "samples");
    // 400 two-point lines with samples=100000 (47 KB): refused before any is sampled.
    let lines: Vec<Value> = (0..400).map(|i| line(2, i as f64 * 0.1)).collect();
    let r = srv.post(
        "/v1/fit?samples=100000",
        &json!({"type": "MultiLineString", "coordinates": lines}),
    );
    let p = r.problem(422, "output-too-large");
    assert_eq!(p["pointer"], "");
    assert!(p["detail"].as_str().unwrap().contains("400 curves"), "{p}");
    assert!(t.elapsed() < Duration::from_secs(5), "{:?}", t.elapsed());
    assert!(srv.peak_rss_mib() < 300.0, "{} MiB", srv.peak_rss_mib());
    srv.assert_healthy(Duration::from_millis(500));
}

#[test]
fn evaluate_applies_the_control_point_limit() {
    let srv = Server::start(&["--max-control-points", "100"]);
    let n = 200;
    let cps: Vec<[f64; 2]> = (0..n).map(|i| [i as f64 * 0.1, 0.0]).collect();
    let mut knots = vec![0.0; 2];
    knots.extend((1..n - 1).map(|i| i as f64 / (n - 1) as f64));
    knots.extend([1.0, 1.0]);
    let doc = json!({"crs": "lonlat", "degree": 1, "knots": knots, "control_points": cps});
    let p = srv
        .post("/v1/evaluate?samples=10", &doc)
        .problem(422, "invalid-spline");
    assert_eq!(p["pointer"], "/control_points");
    assert!(
        p["detail"].as_str().unwrap().contains("limit of 100"),
        "{p}"
    );
}

#[test]
fn non_finite_results_are_422_never_null() {
    let srv = Server::start(&[]);
    // Knot spans that underflow.
    let doc = json!({"crs": "lonlat", "degree": 1, "knots": [0, 0, 5e-324, 5e-324], "control_points": [[0, 0], [10, 0]]});
    let r = srv.post("/v1/evaluate?samples=5", &doc);
    let p = r.problem(422, "invalid-spline");
    assert!(p["detail"].as_str().unwrap().contains("knot"), "{p}");
    // Parameters spanning ±1e308 overflow.
    let pts =
        json!({"points": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "parameters": [-1e308, 0, 1e308]});
    let p = srv
        .post("/v1/sphere/fit?degree=1&control_points=2", &pts)
        .problem(422, "invalid-points");
    assert_eq!(p["pointer"], "/parameters");
    // The same knots on the S^n route.
    let doc = json!({"degree": 1, "knots": [0, 0, 5e-324, 5e-324], "control_points": [[1, 0, 0], [0, 1, 0]]});
    let r = srv.post("/v1/sphere/evaluate?samples=5", &doc);
    assert_eq!(r.status, 422, "{}", r.text);
    assert!(!r.text.contains("null"));
}

#[test]
fn tolerance_fits_along_a_great_circle_do_not_panic() {
    let srv = Server::start(&[]);
    let pts = json!({"points": [[-1, -1.2246467991473532e-16, 0], [6.1e-17, -1, 0], [1, 0, 0], [6.1e-17, 1, 0]]});
    let r = srv.post("/v1/sphere/fit?degree=2&tolerance_rad=1e-6", &pts);
    assert_eq!(r.status, 200, "{}", r.text);
    assert_eq!(r.json()["tolerance"]["tolerance_met"], true);
    let mut ring: Vec<[f64; 2]> = (0..100).map(|i| [-180.0 + i as f64 * 3.6, 0.0]).collect();
    ring.push(ring[0]);
    let r = srv.post(
        "/v1/fit?tolerance_m=1e7",
        &json!({"type": "Polygon", "coordinates": [ring]}),
    );
    assert_eq!(r.status, 200, "{}", r.text);
}

#[test]
fn past_the_budget_the_work_stops_and_its_slot_is_freed() {
    // A 0.5 s budget: on an idle machine the 0.01 m tolerance fit of the heavy line finished
    // inside a 2 s one (CI at 27dafbb), and inside 1 s once the fitter got faster (CI at
    // 4ce7d38: a 200), so the budget is what this test sets, not the work (about 0.9 s on
    // one core at 4ce7d38).
    let srv = Server::start(&["--timeout-s", "0.5", "--fit-concurrency", "1"]);
    let heavy = heavy_line();
    for query in [
        // Gauss–Newton with foot-point correction (the default before accelerated GLS-PIA, which
        // finishes this within the budget on an idle machine): work that outlasts the budget.
        "/v1/fit?control_points=10000&iterations=1000&solver=gauss-newton&parameter_correction=true",
        "/v1/fit?tolerance_m=0.01",
    ] {
        let t = Instant::now();
        let health = {
            let addr = srv.addr;
            std::thread::spawn(move || {
                // While the work runs (it is stopped at 0.5 s).
                std::thread::sleep(Duration::from_millis(300));
                let t = Instant::now();
                let mut s = TcpStream::connect(addr).unwrap();
                s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
                s.write_all(b"GET /health HTTP/1.1\r\nhost: x\r\nconnection: close\r\n\r\n")
                    .unwrap();
                let r = read_reply(&mut s);
                (r.status, t.elapsed())
            })
        };
        let r = srv.post(query, &heavy);
        r.problem(503, "timeout");
        assert!(t.elapsed() < Duration::from_secs(4), "{:?}", t.elapsed());
        let (status, took) = health.join().unwrap();
        assert_eq!(status, 200);
        assert!(took < Duration::from_millis(500), "/health took {took:?}");
        // About a second on an idle machine; the other tests share the two cores.
        let freed = srv.wait_slots_free(Duration::from_secs(4));
        eprintln!("{query}: slot free {freed:?} after the 503");
        // The slot is usable again at once.
        let r = srv.post(
            "/v1/fit?samples=10",
            &json!({"type": "LineString", "coordinates": line(20, 0.0)}),
        );
        assert_eq!(r.status, 200, "{}", r.text);
    }
}

#[test]
fn the_sphere_routes_honour_the_budget() {
    // The work must outlast the budget on a fast idle machine too: 150,000 points at a 2 s budget
    // finished in time there (a 200), so the work is doubled and the budget halved.
    let srv = Server::start(&[
        "--timeout-s",
        "1",
        "--fit-concurrency",
        "1",
        "--max-body-bytes",
        "33554432",
    ]);
    let n = 300_000;
    let pts: Vec<[f64; 3]> = (0..n)
        .map(|i| {
            let lon = (-170.0 + 340.0 * i as f64 / n as f64).to_radians();
            let lat = (30.0 * (i as f64 * 0.001).sin() + (i % 7) as f64 * 0.01).to_radians();
            [lat.cos() * lon.cos(), lat.cos() * lon.sin(), lat.sin()]
        })
        .collect();
    let doc = json!({ "points": pts });
    for query in [
        "/v1/sphere/fit?tolerance_rad=1e-9",
        "/v1/sphere/fit?control_points=10000&iterations=1000",
    ] {
        let t = Instant::now();
        srv.post(query, &doc).problem(503, "timeout");
        assert!(t.elapsed() < Duration::from_secs(4));
        srv.wait_slots_free(Duration::from_millis(2500));
    }
}

#[test]
fn antimeridian_cutting_is_linear() {
    let srv = Server::start(&[]);
    // A line along the antimeridian, sampled densely: 4.8 s before (quadratic), now fast.
    let meridian: Vec<[f64; 2]> = (0..5).map(|i| [180.0, 80.0 - i as f64 * 10.0]).collect();
    let parts: Vec<Value> = (0..20).map(|_| json!(meridian)).collect();
    let t = Instant::now();
    let r = srv.post(
        "/v1/fit?samples=100000",
        &json!({"type": "MultiLineString", "coordinates": parts}),
    );
    assert_eq!(r.status, 200, "{}", &r.text[..r.text.len().min(300)]);
    assert!(t.elapsed() < Duration::from_secs(10), "{:?}", t.elapsed());
}

#[test]
fn slow_and_idle_connections_are_closed_and_capped() {
    let srv = Server::start(&["--header-timeout-s", "1", "--max-connections", "4"]);
    // Slowloris: half a header, then nothing.
    let mut slow = srv.connect();
    slow.write_all(b"POST /v1/fit HTTP/1.1\r\nhost: x\r\n")
        .unwrap();
    // Idle keep-alive after one request.
    let mut idle = srv.connect();
    idle.write_all(b"GET /health HTTP/1.1\r\nhost: x\r\n\r\n")
        .unwrap();
    let t = Instant::now();
    let mut buf = vec![0u8; 4096];
    let n = idle.read(&mut buf).unwrap();
    assert!(String::from_utf8_lossy(&buf[..n]).starts_with("HTTP/1.1 200"));
    // Both are closed by the server within the header timeout (plus slack).
    for s in [&mut slow, &mut idle] {
        let mut rest = Vec::new();
        let _ = s.read_to_end(&mut rest);
    }
    assert!(t.elapsed() < Duration::from_secs(4), "{:?}", t.elapsed());
    drop(srv);
    // The connection cap, on a server that keeps idle connections (a 30 s header timeout):
    // four open, and a connection past them gets a 503 at once. On a loaded machine the
    // server may not have taken all four when the next one arrives; a connection it serves
    // within the cap (no reply within half a second) is kept open too, so the count only
    // grows until one is refused.
    let srv = Server::start(&["--header-timeout-s", "30", "--max-connections", "4"]);
    let mut held: Vec<TcpStream> = (0..4).map(|_| srv.connect()).collect();
    let mut refused = None;
    for _ in 0..20 {
        std::thread::sleep(Duration::from_millis(200));
        let mut next = srv.connect();
        next.set_read_timeout(Some(Duration::from_millis(500)))
            .unwrap();
        let r = read_reply(&mut next);
        if r.status == 503 {
            refused = Some(r);
            break;
        }
        assert_eq!(r.status, 0, "{} {}", r.head, r.text);
        held.push(next);
    }
    let r = refused.expect("a connection past the cap is refused");
    r.problem(503, "overloaded");
    assert!(r.head.to_ascii_lowercase().contains("retry-after: 1"));
    assert!(
        held.len() <= 8,
        "{} connections held before one was refused",
        held.len()
    );
    drop(held);
    std::thread::sleep(Duration::from_millis(200));
    srv.assert_healthy(Duration::from_millis(500));
}

#[test]
fn sigterm_finishes_with_a_half_sent_header() {
    let mut srv = Server::start(&["--timeout-s", "2", "--header-timeout-s", "30"]);
    let mut half = srv.connect();
    half.write_all(b"POST /v1/fit HTTP/1.1\r\nhost: x\r\ncontent-le")
        .unwrap();
    std::thread::sleep(Duration::from_millis(200));
    let killed = Command::new("kill")
        .args(["-TERM", &srv.child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let t = Instant::now();
    loop {
        if let Some(status) = srv.child.try_wait().unwrap() {
            assert!(status.success(), "{status:?}");
            break;
        }
        assert!(
            t.elapsed() < Duration::from_secs(6),
            "still running after SIGTERM"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

#[test]
fn stalled_and_short_bodies_are_the_clients_fault() {
    let srv = Server::start(&["--body-timeout-s", "1"]);
    let head = "POST /v1/fit HTTP/1.1\r\nhost: x\r\ncontent-type: application/geo+json\r\ncontent-length: 1000\r\n\r\n";
    // Stalled: 408 at the body deadline.
    let mut s = srv.connect();
    s.write_all(head.as_bytes()).unwrap();
    s.write_all(b"{\"type\":").unwrap();
    let t = Instant::now();
    let r = read_reply(&mut s);
    let p = r.problem(408, "body-timeout");
    assert_eq!(p["pointer"], "");
    assert!(t.elapsed() < Duration::from_secs(3), "{:?}", t.elapsed());
    // Short: the client stops sending and closes its side.
    let mut s = srv.connect();
    s.write_all(head.as_bytes()).unwrap();
    s.write_all(b"{\"type\":").unwrap();
    s.shutdown(Shutdown::Write).unwrap();
    let r = read_reply(&mut s);
    r.problem(400, "unreadable-body");
}

#[test]
fn bodies_in_flight_share_a_byte_budget() {
    let srv = Server::start(&[
        "--max-body-bytes",
        "1000000",
        "--max-body-bytes-in-flight",
        "4000000",
        "--body-timeout-s",
        "3",
    ]);
    let before = srv.peak_rss_mib();
    // 40 uploads of 1 MB less one byte, all stalled before the end.
    let chunk = vec![b' '; 999_999 - 1];
    let mut conns = Vec::new();
    for _ in 0..40 {
        let mut s = srv.connect();
        s.write_all(b"POST /v1/fit HTTP/1.1\r\nhost: x\r\ncontent-type: application/geo+json\r\ncontent-length: 999999\r\n\r\n").unwrap();
        s.set_nonblocking(true).unwrap();
        let _ = s.write(&chunk);
        conns.push(s);
    }
    srv.assert_healthy(Duration::from_millis(500));
    std::thread::sleep(Duration::from_millis(500));
    let grew = srv.peak_rss_mib() - before;
    assert!(
        grew < 40.0,
        "the server grew by {grew} MiB for 40 stalled 1 MB bodies"
    );
    // Every one ends with 408 (stalled with room) or 503 (no room within the deadline).
    let t = Instant::now();
    for mut s in conns {
        s.set_nonblocking(false).unwrap();
        let r = read_reply(&mut s);
        assert!([408, 503].contains(&r.status), "{}", r.head);
    }
    assert!(t.elapsed() < Duration::from_secs(8), "{:?}", t.elapsed());
    srv.assert_healthy(Duration::from_millis(500));
}

#[test]
fn write_then_read_clients_see_the_413() {
    let srv = Server::start(&["--max-body-bytes", "100000"]);
    for declared in [true, false] {
        let mut s = srv.connect();
        let body = vec![b' '; 1_000_000];
        let head = if declared {
            format!("POST /v1/fit HTTP/1.1\r\nhost: x\r\ncontent-type: application/geo+json\r\ncontent-length: {}\r\n\r\n", body.len())
        } else {
            "POST /v1/fit HTTP/1.1\r\nhost: x\r\ncontent-type: application/geo+json\r\ntransfer-encoding: chunked\r\n\r\n".to_string()
        };
        s.write_all(head.as_bytes()).unwrap();
        if declared {
            s.write_all(&body).expect("the server reads the whole body");
        } else {
            for c in body.chunks(65536) {
                s.write_all(format!("{:x}\r\n", c.len()).as_bytes())
                    .unwrap();
                s.write_all(c).expect("the server reads the whole body");
                s.write_all(b"\r\n").unwrap();
            }
            s.write_all(b"0\r\n\r\n").unwrap();
        }
        let r = read_reply(&mut s);
        let p = r.problem(413, "body-too-large");
        assert_eq!(p["pointer"], "");
    }
    // Also for a request refused before its body is read (wrong content type).
    let mut s = srv.connect();
    s.write_all(b"POST /v1/fit HTTP/1.1\r\nhost: x\r\ncontent-type: text/plain\r\ncontent-length: 90000\r\n\r\n").unwrap();
    s.write_all(&vec![b' '; 90_000]).unwrap();
    read_reply(&mut s).problem(415, "unsupported-media-type");
}

#[test]
fn metric_labels_stay_bounded() {
    let srv = Server::start(&[]);
    for m in ["FOO", "BAR", "BAZ"] {
        srv.request(m, "/health", "text/plain", b"");
    }
    let text = srv.get("/metrics").text;
    assert!(!text.contains("FOO") && !text.contains("BAZ"), "{text}");
    assert!(text.contains("method=\"other\""), "{text}");
}

#[test]
fn dense_spacing_and_byte_order_marks() {
    let srv = Server::start(&[]);
    let doc = json!({"type": "LineString", "coordinates": [[0, 0], [1, 1], [2, 0]]});
    let p = srv
        .post("/v1/fit?spacing_m=1e-300", &doc)
        .problem(422, "too-many-samples");
    assert_eq!(p["parameter"], "spacing_m");
    let detail = p["detail"].as_str().unwrap();
    assert!(!detail.contains("18446744073709551615"), "{detail}");
    let mut body = b"\xEF\xBB\xBF".to_vec();
    body.extend_from_slice(doc.to_string().as_bytes());
    let r = srv.request("POST", "/v1/fit?samples=3", "application/geo+json", &body);
    assert_eq!(r.status, 200, "{}", r.text);
}

fn spherefit(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_spherefit"))
        .args(args)
        .stdin(Stdio::null())
        .output()
        .unwrap()
}

#[test]
fn cli_option_values_are_checked() {
    for args in [
        &["serve", "--timeout-s", "1e300"][..],
        &["serve", "--exit-after-s", "NaN"],
        &["serve", "--exit-after-s", "1e300"],
        &["serve", "--exit-after-s=-1"],
        &["serve", "--body-timeout-s", "0"],
        &["serve", "--header-timeout-s", "inf"],
    ] {
        let out = spherefit(args);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains("seconds") && !err.contains("panicked"),
            "{args:?}: {err}"
        );
    }
    let dir = std::env::temp_dir().join(format!("spherefit-hostile-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let spline = dir.join("s.json");
    std::fs::write(
        &spline,
        r#"{"degree":1,"knots":[0,0,1,1],"control_points":[[1,0,0],[0,1,0]]}"#,
    )
    .unwrap();
    let pts = dir.join("p.json");
    std::fs::write(
        &pts,
        r#"{"points":[[1,0,0],[0.8,0.6,0],[0,1,0],[0,0.6,0.8]]}"#,
    )
    .unwrap();
    let s = spline.to_str().unwrap();
    let p = pts.to_str().unwrap();
    let out = spherefit(&["sphere", "evaluate", "--samples", "0", s]);
    assert_eq!(out.status.code(), Some(2));
    let out = spherefit(&["sphere", "fit", "--target-max-error-rad", "NaN", p]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("target-max-error-rad"));
    // Output that cannot be written is an error, not a silent exit 0. (A closed stdout, `>&-`,
    // is reopened on /dev/null by the Rust runtime before main, so it reads as /dev/null.)
    let bin = env!("CARGO_BIN_EXE_spherefit");
    let st = Command::new("sh")
        .arg("-c")
        .arg(format!(
            "'{bin}' sphere evaluate --samples 5 '{s}' >/dev/full"
        ))
        .status()
        .unwrap();
    assert_eq!(st.code(), Some(2));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_batch_keeps_the_records_after_a_failing_one() {
    let mut ring: Vec<[f64; 2]> = (0..100).map(|i| [-180.0 + i as f64 * 3.6, 0.0]).collect();
    ring.push(ring[0]);
    let records = [
        json!({"type": "Feature", "id": 1, "properties": {}, "geometry": {"type": "LineString", "coordinates": line(20, 0.0)}}),
        json!({"type": "Feature", "id": 2, "properties": {}, "geometry": {"type": "Polygon", "coordinates": [ring]}}),
        json!({"type": "Feature", "id": 3, "properties": {}, "geometry": {"type": "LineString", "coordinates": [[0, 0], [1, 95]]}}),
        json!({"type": "Feature", "id": 4, "properties": {}, "geometry": {"type": "LineString", "coordinates": line(20, 5.0)}}),
    ];
    let input: String = records.iter().map(|r| format!("{r}\n")).collect();
    let out = crate::helpers::run_spherefit(
        &["fit", "--tolerance-m", "1e7", "--format", "geojsonl", "-"],
        Some(input.as_bytes()),
    );
    assert_eq!(
        out.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let ids: Vec<i64> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| serde_json::from_str::<Value>(l.trim_start_matches('\u{1e}')).ok())
        .filter_map(|v| v["id"].as_i64())
        .collect();
    assert_eq!(ids, [1, 2, 4]);
}

/// Python's urllib writes the whole body before it reads the answer: posting 300 MB to a server
/// whose limit is 1 MB, it still gets the 413 (problem+json), because a rejected body is read
/// and discarded for a bounded time, not up to a byte cap (a cap at 4x the limit reset this
/// connection after 5 MB).
#[test]
fn python_urllib_posting_300_mb_gets_the_413() {
    let srv = Server::start(&["--max-body-bytes", "1000000"]);
    let script = r#"
import sys, urllib.request, urllib.error
req = urllib.request.Request(sys.argv[1], data=b" " * (300 << 20), method="POST",
                             headers={"Content-Type": "application/geo+json"})
try:
    urllib.request.urlopen(req, timeout=60)
    print("200")
except urllib.error.HTTPError as e:
    print(e.code, e.headers.get("Content-Type"))
"#;
    let t = Instant::now();
    let out = Command::new("python3")
        .args(["-c", script, &format!("http://{}/v1/fit", srv.addr)])
        .output()
        .expect("python3 runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        stdout.trim(),
        "413 application/problem+json",
        "{stdout} {}",
        String::from_utf8_lossy(&out.stderr)
    );
    eprintln!("300 MB refused with a 413 in {:?}", t.elapsed());
    srv.assert_healthy(Duration::from_millis(500));
}
