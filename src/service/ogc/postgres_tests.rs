//! The PostgreSQL job store against a real database: `SPHEREFIT_TEST_POSTGRES` holds the URL
//! of a server these tests may make databases in (`.ci/postgres.sh` starts one). Without it
//! the tests pass with a note, unless `SPHEREFIT_TEST_TOOLS=required` (CI), where they fail.
//! Each test makes its own database, so their workers do not take each other's jobs. Two
//! [`AppState`]s on one database are two replicas.

use crate::service::auth::{ApiKeys, Owner};
use crate::service::ogc::postgres::PgStore;
use crate::service::ogc::postgres::MAX_ATTEMPTS;
use crate::service::{router, AppState, ServiceConfig};
use axum::body::Body;
use axum::http::{Request, StatusCode};
use axum::Router;
use serde_json::{json, Value};
use sha2::{Digest, Sha256};
use std::sync::Arc;
use std::time::{Duration, Instant};
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::watch;
use tower::ServiceExt;

/// The server's URL, or none (after saying why) when the tests should pass without it.
fn server_url() -> Option<String> {
    match std::env::var("SPHEREFIT_TEST_POSTGRES") {
        Ok(u) if !u.trim().is_empty() => Some(u.trim().to_string()),
        _ => {
            assert!(
                std::env::var("SPHEREFIT_TEST_TOOLS").as_deref() != Ok("required"),
                "SPHEREFIT_TEST_POSTGRES is not set and SPHEREFIT_TEST_TOOLS=required: run .ci/postgres.sh (it starts PostgreSQL and prints the URL)"
            );
            eprintln!("SPHEREFIT_TEST_POSTGRES is not set: PostgreSQL store test not run");
            None
        }
    }
}

/// `url` with its database replaced by `db`.
fn with_database(url: &str, db: &str) -> String {
    let (base, query) = url
        .split_once('?')
        .map_or((url, None), |(b, q)| (b, Some(q)));
    let scheme_end = base.find("://").map_or(0, |i| i + 3);
    let path_at = base[scheme_end..].find('/').map(|i| i + scheme_end);
    let mut out = match path_at {
        Some(i) => format!("{}/{db}", &base[..i]),
        None => format!("{base}/{db}"),
    };
    if let Some(q) = query {
        out.push('?');
        out.push_str(q);
    }
    out
}

/// A database of one test, made on the server and dropped by [`TestDb::drop_now`].
struct TestDb {
    server: String,
    name: String,
    url: String,
}

async fn admin(server: &str) -> tokio_postgres::Client {
    let (client, conn) = tokio_postgres::connect(server, tokio_postgres::NoTls)
        .await
        .expect("the test PostgreSQL server answers");
    tokio::spawn(conn);
    client
}

impl TestDb {
    async fn new() -> Option<TestDb> {
        let server = server_url()?;
        let name = format!("spherefit_test_{}", super::new_id());
        admin(&server)
            .await
            .batch_execute(&format!("CREATE DATABASE {name}"))
            .await
            .unwrap();
        let url = with_database(&server, &name);
        Some(TestDb { server, name, url })
    }

    async fn drop_now(self) {
        let _ = admin(&self.server)
            .await
            .batch_execute(&format!(
                "DROP DATABASE IF EXISTS {} WITH (FORCE)",
                self.name
            ))
            .await;
    }

    async fn query_i32(&self, sql: &str, id: &str) -> i32 {
        admin(&self.url)
            .await
            .query_one(sql, &[&id])
            .await
            .unwrap()
            .get(0)
    }
}

fn digest_hex(token: &str) -> String {
    Sha256::digest(token.as_bytes())
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

fn config() -> ServiceConfig {
    let keys = format!(
        "alice:{}\nbob:{}\n",
        digest_hex("alice-token"),
        digest_hex("bob-token")
    );
    ServiceConfig {
        api_keys: Some(ApiKeys::parse(&keys).unwrap()),
        job_lease: Duration::from_millis(800),
        ..ServiceConfig::default()
    }
}

async fn replica(url: &str, config: ServiceConfig) -> Router {
    let state = AppState::with_postgres(config, url, Duration::from_secs(10))
        .await
        .unwrap();
    router(state)
}

struct Reply {
    status: StatusCode,
    headers: axum::http::HeaderMap,
    body: Vec<u8>,
}

impl Reply {
    fn json(&self) -> Value {
        serde_json::from_slice(&self.body)
            .unwrap_or_else(|e| panic!("{e}: {}", String::from_utf8_lossy(&self.body)))
    }
}

async fn send(app: &Router, method: &str, uri: &str, token: &str, body: Option<&Value>) -> Reply {
    let mut req = Request::builder()
        .method(method)
        .uri(uri)
        .header("host", "127.0.0.1:9")
        .header("authorization", format!("Bearer {token}"));
    if body.is_some() {
        req = req
            .header("content-type", "application/json")
            .header("prefer", "respond-async");
    }
    let body = body.map_or_else(Body::empty, |v| Body::from(serde_json::to_vec(v).unwrap()));
    let res = app.clone().oneshot(req.body(body).unwrap()).await.unwrap();
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

fn lines(n: usize) -> Value {
    let features: Vec<Value> = (0..n)
        .map(|k| {
            let lon0 = -150.0 + 60.0 * k as f64;
            json!({"type": "Feature", "properties": {"name": format!("line {k}")}, "geometry": {"type": "LineString",
                "coordinates": (0..50).map(|i| { let x = f64::from(i) * 0.2; [lon0 + x, 10.0 * (x * 0.7).sin()] }).collect::<Vec<_>>()}})
        })
        .collect();
    json!({"type": "FeatureCollection", "features": features})
}

fn request(n: usize) -> Value {
    json!({"inputs": {"data": lines(n), "tolerance_m": 100}})
}

/// Polls job `id` on `app` until it is no longer accepted or running.
async fn wait(app: &Router, token: &str, id: &str, within: Duration) -> Value {
    let start = Instant::now();
    loop {
        let r = send(app, "GET", &format!("/jobs/{id}"), token, None).await;
        assert_eq!(r.status, 200, "{}", String::from_utf8_lossy(&r.body));
        let v = r.json();
        if !matches!(v["status"].as_str(), Some("accepted" | "running")) {
            return v;
        }
        assert!(start.elapsed() < within, "job {id} never finished: {v}");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

#[test]
fn database_names_are_replaced_in_urls() {
    assert_eq!(
        with_database("postgres://u@127.0.0.1:5432/spherefit", "t"),
        "postgres://u@127.0.0.1:5432/t"
    );
    assert_eq!(
        with_database("postgresql://h?connect_timeout=2", "t"),
        "postgresql://h/t?connect_timeout=2"
    );
}

/// A job posted to replica A is run by a replica's worker and answers the same from B: status,
/// results, collections, features; dismissed on B it is gone on A. Owners are kept apart
/// across replicas, and the per-owner bound holds across them.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn two_replicas_share_the_jobs_and_keep_owners_apart() {
    let Some(db) = TestDb::new().await else {
        return;
    };
    let a = replica(&db.url, config()).await;
    let b = replica(&db.url, config()).await;
    let r = send(
        &a,
        "POST",
        "/processes/fit/execution",
        "alice-token",
        Some(&request(3)),
    )
    .await;
    assert_eq!(r.status, 201, "{}", String::from_utf8_lossy(&r.body));
    let id = r.json()["jobID"].as_str().unwrap().to_string();
    let v = wait(&b, "alice-token", &id, Duration::from_secs(60)).await;
    assert_eq!(v["status"], "successful", "{v}");
    assert_eq!(v["progress"], 100);
    let from_a = send(
        &a,
        "GET",
        &format!("/jobs/{id}/results"),
        "alice-token",
        None,
    )
    .await;
    let from_b = send(
        &b,
        "GET",
        &format!("/jobs/{id}/results"),
        "alice-token",
        None,
    )
    .await;
    assert_eq!(
        (from_a.status, from_b.status),
        (StatusCode::OK, StatusCode::OK)
    );
    assert_eq!(from_a.body, from_b.body);
    assert_eq!(from_b.json()["features"].as_array().unwrap().len(), 3);
    assert_eq!(
        from_b.headers["content-type"].to_str().unwrap(),
        "application/geo+json"
    );
    let cols = send(&b, "GET", "/collections", "alice-token", None)
        .await
        .json();
    assert_eq!(cols["collections"][0]["id"], id.as_str());
    let items = send(
        &a,
        "GET",
        &format!("/collections/{id}/items?limit=2"),
        "alice-token",
        None,
    )
    .await;
    assert_eq!(items.json()["numberMatched"], 3);
    // Another owner sees nothing of it, on either replica.
    for app in [&a, &b] {
        for path in [
            format!("/jobs/{id}"),
            format!("/jobs/{id}/results"),
            format!("/collections/{id}"),
            format!("/collections/{id}/items"),
        ] {
            let r = send(app, "GET", &path, "bob-token", None).await;
            assert_eq!(r.status, 404, "{path}");
        }
        let jobs = send(app, "GET", "/jobs", "bob-token", None).await.json();
        assert_eq!(jobs["jobs"], json!([]));
        let cols = send(app, "GET", "/collections", "bob-token", None)
            .await
            .json();
        assert_eq!(cols["collections"], json!([]));
        let r = send(app, "DELETE", &format!("/jobs/{id}"), "bob-token", None).await;
        assert_eq!(r.status, 404);
    }
    // A reference to the result reads it from the database (resolved when posted, on A),
    // and is run by whichever replica.
    let href =
        json!({"inputs": {"data": {"href": format!("/jobs/{id}/results")}, "tolerance_m": 1000}});
    let r = send(
        &a,
        "POST",
        "/processes/fit/execution",
        "alice-token",
        Some(&href),
    )
    .await;
    assert_eq!(r.status, 201, "{}", String::from_utf8_lossy(&r.body));
    let second = r.json()["jobID"].as_str().unwrap().to_string();
    let r = send(
        &b,
        "POST",
        "/processes/fit/execution",
        "bob-token",
        Some(&href),
    )
    .await;
    assert_eq!(r.status, 422, "bob cannot read alice's result");
    assert_eq!(
        wait(&a, "alice-token", &second, Duration::from_secs(60)).await["status"],
        "successful"
    );
    // Dismissed on B, gone on A (result and all).
    let r = send(&b, "DELETE", &format!("/jobs/{id}"), "alice-token", None).await;
    assert_eq!(r.status, 200);
    assert_eq!(r.json()["status"], "dismissed");
    assert_eq!(
        send(&a, "GET", &format!("/jobs/{id}"), "alice-token", None)
            .await
            .status,
        404
    );
    assert_eq!(
        send(
            &a,
            "GET",
            &format!("/jobs/{id}/results"),
            "alice-token",
            None
        )
        .await
        .status,
        404
    );
    db.drop_now().await;
}

/// The per-owner bound on unfinished jobs counts the jobs of every replica: 429 with
/// Retry-After for that owner, while another owner still gets in.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_owner_bound_holds_across_replicas() {
    let Some(db) = TestDb::new().await else {
        return;
    };
    // No fitting slot ever frees on these replicas' workers: the jobs stay accepted.
    let cfg = ServiceConfig {
        max_owner_jobs: 2,
        max_jobs: 10,
        ..config()
    };
    let store = PgStore::open(&db.url, &cfg, Duration::from_secs(10))
        .await
        .unwrap();
    let alice = Owner::named("alice");
    let body = serde_json::to_vec(&request(1)).unwrap();
    store.enqueue(&alice, "fit", &body).await.unwrap();
    let other = PgStore::open(&db.url, &cfg, Duration::from_secs(10))
        .await
        .unwrap();
    other.enqueue(&alice, "fit", &body).await.unwrap();
    assert_eq!(
        store.enqueue(&alice, "fit", &body).await.unwrap_err(),
        super::Refusal::TooManyOwnerJobs(2)
    );
    // Through the API: 429 with Retry-After, and bob is not held back by alice's jobs.
    let state = AppState::with_jobs(cfg.clone(), super::super::JobStore::Postgres(other.clone()));
    let app = router(state);
    let r = send(
        &app,
        "POST",
        "/processes/fit/execution",
        "alice-token",
        Some(&request(1)),
    )
    .await;
    assert_eq!(r.status, 429, "{}", String::from_utf8_lossy(&r.body));
    assert!(r.headers.contains_key("retry-after"));
    assert_eq!(r.json()["type"], "urn:spherefit:problem:too-many-jobs");
    let r = send(
        &app,
        "POST",
        "/processes/fit/execution",
        "bob-token",
        Some(&request(1)),
    )
    .await;
    assert_eq!(r.status, 201, "{}", String::from_utf8_lossy(&r.body));
    assert_eq!(store.list(&alice).await.unwrap().len(), 2);
    db.drop_now().await;
}

/// A replica that claimed a job and stopped (it never renews its lease) loses it: replica B
/// takes it up once the lease has run out and finishes it; the first replica's late result is
/// not written over B's.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_lapsed_lease_is_taken_up_and_finished_by_another_replica() {
    let Some(db) = TestDb::new().await else {
        return;
    };
    let cfg = config();
    let dead = PgStore::open(&db.url, &cfg, Duration::from_secs(10))
        .await
        .unwrap();
    let alice = Owner::named("alice");
    let job = dead
        .enqueue(&alice, "fit", &serde_json::to_vec(&request(2)).unwrap())
        .await
        .unwrap();
    let claim = dead.claim().await.unwrap().expect("the waiting job");
    assert_eq!(claim.id, job.id);
    assert!(dead.claim().await.unwrap().is_none(), "claimed once");
    let t0 = Instant::now();
    let b = replica(&db.url, cfg.clone()).await;
    let v = wait(&b, "alice-token", &job.id, Duration::from_secs(60)).await;
    assert_eq!(v["status"], "successful", "{v}");
    assert!(
        t0.elapsed() >= cfg.job_lease / 2,
        "taken before the lease ran out: {:?}",
        t0.elapsed()
    );
    let attempts = db
        .query_i32("SELECT attempts FROM jobs WHERE id = $1", &job.id)
        .await;
    assert_eq!(attempts, 2);
    // The first replica wakes up late: its claim is gone, nothing it writes lands.
    assert!(!dead.renew(&job.id, 50).await.unwrap());
    dead.succeed(&job.id, b"{}", "application/geo+json", 1, 1)
        .await
        .unwrap();
    dead.fail(&job.id, "late").await.unwrap();
    let r = send(
        &b,
        "GET",
        &format!("/jobs/{}/results", job.id),
        "alice-token",
        None,
    )
    .await;
    assert_eq!(r.status, 200);
    assert_eq!(r.json()["features"].as_array().unwrap().len(), 2);
    db.drop_now().await;
}

/// A job whose every replica stops is started [`MAX_ATTEMPTS`] times, then failed with the
/// reason.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_job_is_failed_after_max_attempts() {
    let Some(db) = TestDb::new().await else {
        return;
    };
    let cfg = ServiceConfig {
        job_lease: Duration::from_millis(100),
        ..config()
    };
    let first = PgStore::open(&db.url, &cfg, Duration::from_secs(10))
        .await
        .unwrap();
    let alice = Owner::named("alice");
    let job = first
        .enqueue(&alice, "fit", &serde_json::to_vec(&request(1)).unwrap())
        .await
        .unwrap();
    for attempt in 1..=MAX_ATTEMPTS {
        // A fresh replica each time (each one "dies" holding the job).
        let replica = PgStore::open(&db.url, &cfg, Duration::from_secs(10))
            .await
            .unwrap();
        let c = replica.claim().await.unwrap();
        assert_eq!(c.map(|c| c.id), Some(job.id.clone()), "attempt {attempt}");
        let r = replica.get(&alice, &job.id).await.unwrap().unwrap();
        assert_eq!(r.status.as_str(), "running");
        tokio::time::sleep(Duration::from_millis(250)).await;
    }
    assert!(first.claim().await.unwrap().is_none(), "not started again");
    let r = first.get(&alice, &job.id).await.unwrap().unwrap();
    assert_eq!(r.status.as_str(), "failed");
    let m = r.message.unwrap();
    assert!(m.contains(&format!("started {MAX_ATTEMPTS} times")), "{m}");
    db.drop_now().await;
}

/// A TCP forwarder on 127.0.0.1 in front of the database, that can be cut (every connection
/// closed, new ones refused) and restored on the same port: the database "going away" for one
/// test without stopping the server the others use.
struct Forwarder {
    port: u16,
    target: String,
    stop: Option<watch::Sender<bool>>,
}

impl Forwarder {
    async fn start(target: String, port: u16) -> Forwarder {
        let listener = TcpListener::bind(("127.0.0.1", port)).await.unwrap();
        let port = listener.local_addr().unwrap().port();
        let (tx, rx) = watch::channel(false);
        let to = target.clone();
        tokio::spawn(async move {
            let mut stop = rx.clone();
            loop {
                let (client, _) = tokio::select! {
                    _ = stop.wait_for(|&s| s) => return,
                    a = listener.accept() => match a { Ok(a) => a, Err(_) => return },
                };
                let (to, mut stop) = (to.clone(), rx.clone());
                tokio::spawn(async move {
                    let Ok(mut server) = TcpStream::connect(&to).await else {
                        return;
                    };
                    let mut client = client;
                    tokio::select! {
                        _ = tokio::io::copy_bidirectional(&mut client, &mut server) => {}
                        _ = stop.wait_for(|&s| s) => {}
                    }
                });
            }
        });
        Forwarder {
            port,
            target,
            stop: Some(tx),
        }
    }

    fn cut(&mut self) {
        if let Some(tx) = self.stop.take() {
            let _ = tx.send(true);
        }
    }

    async fn restore(&mut self) {
        let f = Forwarder::start(self.target.clone(), self.port).await;
        self.stop = f.stop;
    }
}

/// The database going away gives 503 `store-unavailable` quickly (no hang, no panic) on the
/// job routes, while `/health` and synchronous fits go on; when it is back, so is the service.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_database_that_goes_away_gives_503_and_the_service_recovers() {
    let Some(db) = TestDb::new().await else {
        return;
    };
    let pg: tokio_postgres::Config = db.url.parse().unwrap();
    let host = match &pg.get_hosts()[0] {
        tokio_postgres::config::Host::Tcp(h) => h.clone(),
        #[cfg(unix)]
        tokio_postgres::config::Host::Unix(_) => panic!("give SPHEREFIT_TEST_POSTGRES a TCP host"),
    };
    let port = pg.get_ports().first().copied().unwrap_or(5432);
    let mut fwd = Forwarder::start(format!("{host}:{port}"), 0).await;
    let via = db.url.replacen(
        &format!("{host}:{port}"),
        &format!("127.0.0.1:{}", fwd.port),
        1,
    );
    assert_ne!(via, db.url, "the URL names host:port");
    let app = replica(&via, config()).await;
    let r = send(
        &app,
        "POST",
        "/processes/fit/execution",
        "alice-token",
        Some(&request(1)),
    )
    .await;
    assert_eq!(r.status, 201);
    let id = r.json()["jobID"].as_str().unwrap().to_string();
    wait(&app, "alice-token", &id, Duration::from_secs(60)).await;
    fwd.cut();
    for path in [
        "/jobs".to_string(),
        format!("/jobs/{id}"),
        format!("/jobs/{id}/results"),
        "/collections".into(),
    ] {
        let t0 = Instant::now();
        let r = send(&app, "GET", &path, "alice-token", None).await;
        assert_eq!(
            r.status,
            503,
            "{path}: {}",
            String::from_utf8_lossy(&r.body)
        );
        assert_eq!(r.json()["type"], "urn:spherefit:problem:store-unavailable");
        assert!(r.headers.contains_key("retry-after"));
        assert!(
            t0.elapsed() < Duration::from_secs(5),
            "{path}: {:?}",
            t0.elapsed()
        );
    }
    let r = send(
        &app,
        "POST",
        "/processes/fit/execution",
        "alice-token",
        Some(&request(1)),
    )
    .await;
    assert_eq!(r.status, 503);
    let r = app
        .clone()
        .oneshot(Request::get("/health").body(Body::empty()).unwrap())
        .await
        .unwrap();
    assert_eq!(r.status(), 200);
    fwd.restore().await;
    let t0 = Instant::now();
    loop {
        let r = send(&app, "GET", &format!("/jobs/{id}"), "alice-token", None).await;
        if r.status == 200 {
            assert_eq!(r.json()["status"], "successful");
            break;
        }
        assert!(
            t0.elapsed() < Duration::from_secs(10),
            "no recovery: {}",
            r.status
        );
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    let r = send(
        &app,
        "POST",
        "/processes/fit/execution",
        "alice-token",
        Some(&request(1)),
    )
    .await;
    assert_eq!(r.status, 201, "{}", String::from_utf8_lossy(&r.body));
    let id = r.json()["jobID"].as_str().unwrap().to_string();
    assert_eq!(
        wait(&app, "alice-token", &id, Duration::from_secs(60)).await["status"],
        "successful"
    );
    fwd.cut();
    db.drop_now().await;
}

/// Two replicas starting at once on an empty database apply the migrations once; a third,
/// later, finds them applied.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn migrations_run_once_with_replicas_starting_together() {
    let Some(db) = TestDb::new().await else {
        return;
    };
    let cfg = Arc::new(config());
    let (x, y) = tokio::join!(
        PgStore::open(&db.url, &cfg, Duration::from_secs(10)),
        PgStore::open(&db.url, &cfg, Duration::from_secs(10))
    );
    x.unwrap();
    y.unwrap();
    PgStore::open(&db.url, &cfg, Duration::from_secs(10))
        .await
        .unwrap();
    let client = admin(&db.url).await;
    let rows = client
        .query("SELECT version FROM schema_version ORDER BY version", &[])
        .await
        .unwrap();
    let versions: Vec<i32> = rows.iter().map(|r| r.get(0)).collect();
    assert_eq!(
        versions,
        (1..=super::MIGRATIONS.len() as i32).collect::<Vec<_>>()
    );
    db.drop_now().await;
}
