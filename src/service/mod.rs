//! The HTTP service (axum): GeoJSON in, fitted curves out, and the S^n documents of the CLI.
//!
//! [`router`] builds everything (routes and layers); `main` and the tests both call it. The
//! contract is `openapi.yaml` (served at `/openapi.yaml`, and as JSON at `/openapi.json`, the
//! landing page's `service-desc`); errors are RFC 9457 problem+json (`error.rs`).
//!
//! | route | what |
//! |---|---|
//! | `POST /v1/fit` | GeoJSON lines and rings -> fitted spherical B-splines, dense GeoJSON |
//! | `POST /v1/interpolate` | GeoJSON -> Beta-splines through every vertex, dense GeoJSON |
//! | `POST /v1/evaluate` | `properties.fit` / `interpolation` (or a lon/lat spline) -> dense GeoJSON |
//! | `POST /v1/sphere/fit`, `/interpolate`, `/evaluate` | the CLI's S^n JSON documents |
//! | `GET /health`, `/openapi.yaml`, `/openapi.json`, `/metrics` | liveness, contract (YAML, JSON), Prometheus text |
//! | `GET /`, `/page/{asset}`, `/v1/limits` | the map page (`page.rs`, `web/`), its files, the limits |
//! | `GET /` (JSON), `/conformance`, `/processes…`, `/jobs…`, `/collections…` | OGC API – Processes and Features (`ogc/`) |
//!
//! # Runtime
//! CPU work runs on the blocking pool (the features of one request on rayon, in parallel),
//! never on the async workers. A request needs one of `fit_concurrency` slots to start; up to
//! `fit_queue` more wait for one; past that, 503 `overloaded` with `Retry-After`. Every request
//! has a time budget (503 `timeout`): the work itself is cancelled (checked every iteration of
//! the fitters and before every curve), so its slot is free again within about a second.
//!
//! # Connections and bodies
//! [`serve`] runs its own accept loop (hyper): at most `max_connections` connections (past that,
//! a canned 503 and close), a header read timeout that also closes idle keep-alive connections,
//! and a bounded graceful shutdown. Bodies are read within `body_timeout` (408 past it, 400 for a
//! body cut short) and count against a global byte budget for bodies in flight
//! (`max_body_bytes_in_flight`); a body over the limit is read and discarded for a bounded time before
//! the 413 is sent, so that clients that write the whole body before reading see it.

pub mod auth;
mod body;
pub(crate) mod error;
mod files;
mod handlers;
pub(crate) mod metrics;
mod ogc;
mod page;
pub(crate) mod query;
mod request;

pub(crate) use error::ApiError;

use crate::earth::job::Limits;
use axum::error_handling::HandleErrorLayer;
use axum::extract::{DefaultBodyLimit, MatchedPath, Request, State};
use axum::http::{header, HeaderValue, StatusCode};
use axum::middleware::{self, Next};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use axum::Router;
use metrics::Metrics;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};
use tokio::sync::{OwnedSemaphorePermit, Semaphore};
use tower::ServiceBuilder;
use tower_http::catch_panic::CatchPanicLayer;
use tower_http::timeout::TimeoutLayer;
use tower_http::trace::{DefaultMakeSpan, DefaultOnResponse, TraceLayer};

/// The contract, served at `/openapi.yaml`.
pub const OPENAPI_YAML: &str = include_str!("../../openapi.yaml");

/// The same contract as JSON, served at `/openapi.json` (the landing page's `service-desc`):
/// derived from `openapi.yaml` at build time by `build.rs`, keys in the file's order.
pub const OPENAPI_JSON: &str = include_str!(concat!(env!("OUT_DIR"), "/openapi.json"));

/// The media type of [`OPENAPI_JSON`]: the one QGIS 3.22 looks for among the landing page's
/// `service-desc` links (it ignores a YAML one and cannot open the layer). OGC API – Common
/// names this type for an OpenAPI 3.0 definition; the document is OpenAPI 3.1, which uses the
/// same structure for everything these clients read.
pub const OPENAPI_JSON_TYPE: &str = "application/vnd.oai.openapi+json;version=3.0";

/// Limits and runtime settings; every field has a `spherefit serve` flag and a `SPHEREFIT_*`
/// environment variable.
#[derive(Clone, Debug, PartialEq)]
pub struct ServiceConfig {
    /// Largest request body, bytes (413).
    pub max_body_bytes: usize,
    /// Most input positions per request (413).
    pub max_points: usize,
    /// Most output positions per request (422 `output-too-large`).
    pub max_output_points: usize,
    /// Per-curve limits: control points, samples, iterations (422).
    pub limits: Limits,
    /// Time budget of one request (503 `timeout`).
    pub request_timeout: Duration,
    /// Requests doing CPU work at once.
    pub fit_concurrency: usize,
    /// Requests allowed to wait for a slot; past that, 503 `overloaded`.
    pub fit_queue: usize,
    /// Requests of any kind in flight at once; past that, 503 `overloaded`.
    pub max_in_flight: usize,
    /// Time for a whole request body to arrive (408 `body-timeout`); at most `request_timeout`.
    pub body_timeout: Duration,
    /// Bytes of request bodies held at once by all requests; a body waits for room until its
    /// `body_timeout` (then 503 `overloaded`).
    pub max_body_bytes_in_flight: usize,
    /// Time for a request's header to arrive, and the longest an idle keep-alive connection
    /// stays open.
    pub header_timeout: Duration,
    /// Open connections at once; past that, new connections get a canned 503 and are closed.
    pub max_connections: usize,
    /// Where OGC API – Processes jobs and their results are kept (`ogc::store`); `None`: a
    /// directory of this process's own under the system's temporary directory, made when the
    /// first job is stored.
    pub data_dir: Option<std::path::PathBuf>,
    /// Time budget of one asynchronous job (it ends `failed` past it).
    pub job_timeout: Duration,
    /// Jobs accepted and not finished at once (all owners; with PostgreSQL, all replicas);
    /// past that, 429 with `Retry-After`.
    pub max_jobs: usize,
    /// Jobs of one owner accepted and not finished at once; past that, 429 with `Retry-After`.
    pub max_owner_jobs: usize,
    /// API keys (`auth`): with them every route but `/health` and the page's files needs a
    /// bearer token, and each job belongs to its token's owner; without them the service is
    /// open and every caller is one anonymous owner.
    pub api_keys: Option<auth::ApiKeys>,
    /// How long a replica's claim on a PostgreSQL job lasts without a heartbeat (the running
    /// replica renews it several times per lease); past it, another replica takes the job up.
    pub job_lease: Duration,
    /// Bytes the job store may hold on disk (results and status files); a result that does not
    /// fit fails its job, a new job that does not fit is refused (503).
    pub store_bytes: u64,
    /// How long a finished job and its result are kept.
    pub job_expiry: Duration,
}

impl Default for ServiceConfig {
    fn default() -> Self {
        ServiceConfig {
            max_body_bytes: 16 * 1024 * 1024,
            max_points: 1_000_000,
            max_output_points: 5_000_000,
            limits: Limits::default(),
            request_timeout: Duration::from_secs(30),
            // Two per CPU: a fit's parallel loops hand work to rayon's pool and park the
            // request's thread, and between them it runs alone; with one slot per CPU the cores
            // idled between loops (the 10m US–Mexico border's default fit under `hey -c 4` on
            // 2 CPUs: 96-105 requests/s with 2 slots, 110-117 with 4, `scripts/border_load.sh`).
            fit_concurrency: std::thread::available_parallelism().map_or(2, |n| 2 * n.get()),
            fit_queue: 64,
            max_in_flight: 1024,
            body_timeout: Duration::from_secs(10),
            max_body_bytes_in_flight: 128 * 1024 * 1024,
            header_timeout: Duration::from_secs(10),
            max_connections: 1024,
            data_dir: None,
            job_timeout: Duration::from_secs(3600),
            max_jobs: 4,
            max_owner_jobs: 4,
            api_keys: None,
            job_lease: Duration::from_secs(30),
            store_bytes: 1 << 30,
            job_expiry: Duration::from_secs(24 * 3600),
        }
    }
}

/// Shared state of the handlers.
#[derive(Clone, Debug)]
pub struct AppState {
    pub(crate) config: Arc<ServiceConfig>,
    pub(crate) metrics: Arc<Metrics>,
    gate: Arc<FitGate>,
    /// Bytes of bodies in flight (one permit a byte).
    pub(crate) body_bytes: Arc<Semaphore>,
    /// OGC API – Processes jobs (`ogc::store`).
    pub(crate) jobs: Arc<ogc::JobStore>,
}

impl AppState {
    /// State for `config`, with the job store on disk (`data_dir`).
    pub fn new(config: ServiceConfig) -> AppState {
        let jobs = ogc::JobStore::Disk(ogc::DiskStore::open(&config));
        AppState::with_jobs(config, jobs)
    }

    /// State for `config` with the job store in the PostgreSQL database at `url`
    /// (`postgres://` or `postgresql://`): its tables are made or brought up to date, and this
    /// replica's worker starts taking waiting jobs (`ogc::postgres`). Waits for the database
    /// for at most `wait` (a replica may start before it).
    ///
    /// # Errors
    /// The URL cannot be read, or the database cannot be reached or migrated within `wait`.
    pub async fn with_postgres(
        config: ServiceConfig,
        url: &str,
        wait: Duration,
    ) -> Result<AppState, String> {
        let store = ogc::PgStore::open(url, &config, wait).await?;
        let state = AppState::with_jobs(config, ogc::JobStore::Postgres(store));
        ogc::start_worker(&state);
        Ok(state)
    }

    fn with_jobs(config: ServiceConfig, jobs: ogc::JobStore) -> AppState {
        let gate = FitGate {
            slots: Arc::new(Semaphore::new(config.fit_concurrency.max(1))),
            waiting: AtomicUsize::new(0),
            queue: config.fit_queue,
        };
        let body_bytes = Arc::new(Semaphore::new(
            config
                .max_body_bytes_in_flight
                .max(config.max_body_bytes)
                .min(Semaphore::MAX_PERMITS),
        ));
        let jobs = Arc::new(jobs);
        AppState {
            config: Arc::new(config),
            metrics: Arc::new(Metrics::default()),
            gate: Arc::new(gate),
            body_bytes,
            jobs,
        }
    }
}

/// The global bound on CPU work: slots, and a bounded queue in front of them.
#[derive(Debug)]
struct FitGate {
    slots: Arc<Semaphore>,
    waiting: AtomicUsize,
    queue: usize,
}

struct WaitingGuard<'a>(&'a AtomicUsize, &'a Metrics);

impl Drop for WaitingGuard<'_> {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::SeqCst);
        self.1.fits_waiting.fetch_sub(1, Ordering::Relaxed);
    }
}

/// A fitting slot; released when the CPU work ends (not when the request gives up).
pub(crate) struct Slot {
    _permit: OwnedSemaphorePermit,
    metrics: Arc<Metrics>,
}

impl Drop for Slot {
    fn drop(&mut self) {
        self.metrics
            .fits_in_progress
            .fetch_sub(1, Ordering::Relaxed);
    }
}

impl AppState {
    /// Waits for a free fitting slot and takes it (a PostgreSQL replica's worker takes a job
    /// only when it holds one; it waits outside the request queue).
    pub(crate) async fn free_slot(&self) -> Option<Slot> {
        let permit = self.gate.slots.clone().acquire_owned().await.ok()?;
        self.metrics
            .fits_in_progress
            .fetch_add(1, Ordering::Relaxed);
        Some(Slot {
            _permit: permit,
            metrics: self.metrics.clone(),
        })
    }

    /// Takes a fitting slot, waiting in the queue until `deadline` if there is room in it.
    ///
    /// # Errors
    /// 503 `overloaded` when the queue is full, 503 `timeout` at the deadline.
    pub(crate) async fn enter(&self, deadline: Instant) -> Result<Slot, ApiError> {
        let gate = &self.gate;
        let slot = |permit| {
            self.metrics
                .fits_in_progress
                .fetch_add(1, Ordering::Relaxed);
            Slot {
                _permit: permit,
                metrics: self.metrics.clone(),
            }
        };
        if let Ok(p) = gate.slots.clone().try_acquire_owned() {
            return Ok(slot(p));
        }
        if gate.waiting.fetch_add(1, Ordering::SeqCst) >= gate.queue {
            gate.waiting.fetch_sub(1, Ordering::SeqCst);
            return Err(ApiError::overloaded());
        }
        self.metrics.fits_waiting.fetch_add(1, Ordering::Relaxed);
        let _guard = WaitingGuard(&gate.waiting, &self.metrics);
        match tokio::time::timeout_at(deadline.into(), gate.slots.clone().acquire_owned()).await {
            Ok(Ok(p)) => Ok(slot(p)),
            Ok(Err(_closed)) => Err(ApiError::internal()),
            Err(_) => Err(ApiError::timeout(self.config.request_timeout.as_secs_f64())),
        }
    }
}

/// All routes and layers. Layers, outermost first: metrics, problem+json for responses made
/// outside the handlers, trace, timeout (503), global concurrency limit with load shedding
/// (503), catch-panic (500). The body limit (413), body deadline (408) and body byte budget are
/// applied by the handlers as they read the body.
pub fn router(state: AppState) -> Router {
    let config = state.config.clone();
    // Two stacks because each `Router::layer` call turns response bodies back into `Body`,
    // which the timeout layer needs; the order is still the one documented above.
    let outer = ServiceBuilder::new()
        .layer(
            TraceLayer::new_for_http()
                .make_span_with(DefaultMakeSpan::new().level(tracing::Level::INFO))
                .on_response(DefaultOnResponse::new().level(tracing::Level::INFO)),
        )
        .layer(TimeoutLayer::with_status_code(
            StatusCode::SERVICE_UNAVAILABLE,
            // The handlers enforce the budget themselves (and say so); this is the backstop.
            config.request_timeout + Duration::from_secs(1),
        ));
    let inner = ServiceBuilder::new()
        .layer(HandleErrorLayer::new(|_: tower::BoxError| async {
            ApiError::overloaded()
        }))
        .layer(tower::load_shed::LoadShedLayer::new())
        .layer(tower::limit::GlobalConcurrencyLimitLayer::new(
            config.max_in_flight.max(1),
        ))
        .layer(CatchPanicLayer::custom(
            |_: Box<dyn std::any::Any + Send>| {
                tracing::error!("a handler panicked");
                ApiError::internal().into_response()
            },
        ));
    Router::new()
        .route("/v1/fit", post(handlers::fit))
        .route("/v1/interpolate", post(handlers::interpolate_geo))
        .route("/v1/evaluate", post(handlers::evaluate))
        .route("/v1/sphere/fit", post(handlers::sphere_fit))
        .route("/v1/sphere/interpolate", post(handlers::sphere_interpolate))
        .route("/v1/sphere/evaluate", post(handlers::sphere_evaluate))
        .route("/health", get(handlers::health))
        .route("/openapi.yaml", get(handlers::openapi))
        .route("/openapi.json", get(handlers::openapi_json))
        .route("/metrics", get(handlers::metrics))
        .merge(ogc::routes())
        .merge(page::routes())
        .fallback(handlers::not_found)
        .layer(DefaultBodyLimit::disable())
        .layer(inner)
        .layer(outer)
        .layer(middleware::from_fn_with_state(
            state.clone(),
            auth::authenticate,
        ))
        .layer(middleware::from_fn(problem_for_bare_errors))
        .layer(middleware::from_fn_with_state(state.clone(), track_metrics))
        .with_state(state)
}

/// Counts every response by route and status.
async fn track_metrics(State(state): State<AppState>, req: Request, next: Next) -> Response {
    let start = Instant::now();
    let route = req
        .extensions()
        .get::<MatchedPath>()
        .map_or_else(|| "unmatched".to_string(), |p| p.as_str().to_string());
    let method = req.method().to_string();
    let res = next.run(req).await;
    let problem = res.extensions().get::<error::ProblemSlug>().map(|s| s.0);
    state.metrics.record_request(
        &route,
        &method,
        res.status().as_u16(),
        problem,
        start.elapsed().as_secs_f64(),
    );
    res
}

/// Turns error responses made by the router or a layer (404, 405, 413, 503, 500) into
/// problem+json, keeping their headers (`Allow`).
async fn problem_for_bare_errors(req: Request, next: Next) -> Response {
    let path = req.uri().path().to_string();
    let res = next.run(req).await;
    let status = res.status();
    let is_problem = res
        .headers()
        .get(header::CONTENT_TYPE)
        .is_some_and(|v| v.as_bytes().starts_with(error::PROBLEM_JSON.as_bytes()));
    if !(status.is_client_error() || status.is_server_error()) || is_problem {
        return res;
    }
    let allow = res.headers().get(header::ALLOW).cloned();
    let mut out = error::problem_for_status(status, &path).into_response();
    if let Some(a) = allow {
        out.headers_mut().insert(header::ALLOW, a);
    }
    if status == StatusCode::SERVICE_UNAVAILABLE && !out.headers().contains_key(header::RETRY_AFTER)
    {
        out.headers_mut()
            .insert(header::RETRY_AFTER, HeaderValue::from(error::RETRY_AFTER_S));
    }
    out
}

/// The canned answer to a connection over `max_connections` (written without waiting).
const OVER_CONNECTIONS: &[u8] = b"HTTP/1.1 503 Service Unavailable\r\ncontent-type: application/problem+json\r\nretry-after: 1\r\nconnection: close\r\ncontent-length: 151\r\n\r\n{\"type\":\"urn:spherefit:problem:overloaded\",\"title\":\"Overloaded\",\"status\":503,\"detail\":\"too many open connections: retry after the time in Retry-After\"}";

/// Serves `router(state)` on `listener` until `shutdown` completes; then stops accepting, lets
/// the requests in flight finish for at most `request_timeout` + 1 s, and closes the rest.
///
/// Each connection is HTTP/1.1 with keep-alive; its header must arrive within
/// `header_timeout`, which also closes idle keep-alive connections. At most `max_connections`
/// are open at once.
///
/// # Errors
/// I/O errors of the listener (other than per-connection accept errors, which are skipped).
pub async fn serve(
    listener: tokio::net::TcpListener,
    state: AppState,
    shutdown: impl std::future::Future<Output = ()> + Send + 'static,
) -> std::io::Result<()> {
    use hyper_util::rt::{TokioIo, TokioTimer};
    let config = state.config.clone();
    let app = router(state);
    let connections = Arc::new(Semaphore::new(config.max_connections.max(1)));
    let (close_tx, close_rx) = tokio::sync::watch::channel(false);
    let mut tasks = tokio::task::JoinSet::new();
    tokio::pin!(shutdown);
    loop {
        let (stream, _peer) = tokio::select! {
            _ = &mut shutdown => break,
            // Reap finished connection tasks as we go.
            Some(_) = tasks.join_next(), if !tasks.is_empty() => continue,
            accepted = listener.accept() => match accepted {
                Ok(s) => s,
                Err(e) => {
                    // Per-connection errors (reset before accept, out of descriptors): keep
                    // serving, after a breath when the process is out of descriptors.
                    tracing::warn!(error = %e, "accept failed");
                    tokio::time::sleep(Duration::from_millis(20)).await;
                    continue;
                }
            },
        };
        let Ok(permit) = connections.clone().try_acquire_owned() else {
            let _ = stream.try_write(OVER_CONNECTIONS);
            continue;
        };
        let _ = stream.set_nodelay(true);
        let service = hyper_util::service::TowerToHyperService::new(app.clone());
        let mut close = close_rx.clone();
        let header_timeout = config.header_timeout;
        tasks.spawn(async move {
            let _permit = permit;
            let mut builder = hyper::server::conn::http1::Builder::new();
            builder
                .timer(TokioTimer::new())
                .header_read_timeout(header_timeout)
                .keep_alive(true);
            let conn = builder.serve_connection(TokioIo::new(stream), service);
            tokio::pin!(conn);
            tokio::select! {
                _ = conn.as_mut() => {}
                _ = async { close.wait_for(|&c| c).await.map(|_| ()) } => {
                    conn.as_mut().graceful_shutdown();
                    let _ = conn.await;
                }
            }
        });
    }
    drop(listener);
    let _ = close_tx.send(true);
    let grace = config.request_timeout + Duration::from_secs(1);
    let drained =
        tokio::time::timeout(grace, async { while tasks.join_next().await.is_some() {} }).await;
    if drained.is_err() {
        tracing::warn!(
            open = tasks.len(),
            "closing the connections still open after the shutdown grace period"
        );
        tasks.shutdown().await;
    }
    Ok(())
}

/// Completes on SIGINT (Ctrl-C) or SIGTERM.
pub async fn shutdown_signal() {
    let ctrl_c = async {
        if tokio::signal::ctrl_c().await.is_err() {
            std::future::pending::<()>().await;
        }
    };
    #[cfg(unix)]
    let term = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(_) => std::future::pending::<()>().await,
        }
    };
    #[cfg(not(unix))]
    let term = std::future::pending::<()>();
    tokio::select! {
        _ = ctrl_c => tracing::info!("SIGINT received, shutting down"),
        _ = term => tracing::info!("SIGTERM received, shutting down"),
    }
}
