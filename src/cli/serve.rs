//! `spherefit serve`: the HTTP service. Every flag has a `SPHEREFIT_*` environment variable;
//! a flag given on the command line wins.

use crate::cli::Failure;
use crate::earth::job::Limits;
use crate::service::{self, AppState, ServiceConfig};
use clap::{Args, ValueEnum};
use std::net::SocketAddr;
use std::time::Duration;

#[derive(Debug, Args)]
pub(crate) struct ServeArgs {
    /// Address to listen on (use 0.0.0.0:8080 to listen on every interface, e.g. in a container)
    #[arg(long, env = "SPHEREFIT_ADDR", default_value = "127.0.0.1:8080")]
    addr: SocketAddr,
    /// Largest request body, in bytes; larger bodies get 413
    #[arg(long, env = "SPHEREFIT_MAX_BODY_BYTES", default_value_t = ServiceConfig::default().max_body_bytes)]
    max_body_bytes: usize,
    /// Most input positions per request; more get 413
    #[arg(long, env = "SPHEREFIT_MAX_POINTS", default_value_t = ServiceConfig::default().max_points)]
    max_points: usize,
    /// Most output positions per request; more get 422
    #[arg(long, env = "SPHEREFIT_MAX_OUTPUT_POINTS", default_value_t = ServiceConfig::default().max_output_points)]
    max_output_points: usize,
    /// Most control points per curve; more get 422
    #[arg(long, env = "SPHEREFIT_MAX_CONTROL_POINTS", default_value_t = Limits::default().max_control_points)]
    max_control_points: usize,
    /// Most output points per curve (samples, or what spacing_m needs); more get 422
    #[arg(long, env = "SPHEREFIT_MAX_SAMPLES", default_value_t = Limits::default().max_samples)]
    max_samples: usize,
    /// Most GLS-PIA iterations per fit; more get 422
    #[arg(long, env = "SPHEREFIT_MAX_ITERATIONS", default_value_t = Limits::default().max_iterations)]
    max_iterations: usize,
    /// Time budget of one request, in seconds; past it the request gets 503 with Retry-After
    #[arg(long, env = "SPHEREFIT_TIMEOUT_S", default_value_t = ServiceConfig::default().request_timeout.as_secs_f64())]
    timeout_s: f64,
    /// Requests doing CPU work at once [default: twice the number of CPUs]
    #[arg(long, env = "SPHEREFIT_FIT_CONCURRENCY")]
    fit_concurrency: Option<usize>,
    /// Requests that may wait for a CPU slot; past that, 503 with Retry-After
    #[arg(long, env = "SPHEREFIT_FIT_QUEUE", default_value_t = ServiceConfig::default().fit_queue)]
    fit_queue: usize,
    /// Requests of any kind in flight at once; past that, 503 with Retry-After
    #[arg(long, env = "SPHEREFIT_MAX_IN_FLIGHT", default_value_t = ServiceConfig::default().max_in_flight)]
    max_in_flight: usize,
    /// Time for a whole request body to arrive, in seconds (at most --timeout-s); past it, 408
    #[arg(long, env = "SPHEREFIT_BODY_TIMEOUT_S", default_value_t = ServiceConfig::default().body_timeout.as_secs_f64())]
    body_timeout_s: f64,
    /// Bytes of request bodies held at once by all requests; a body waits for room (503 when
    /// none frees up within its body timeout)
    #[arg(long, env = "SPHEREFIT_MAX_BODY_BYTES_IN_FLIGHT", default_value_t = ServiceConfig::default().max_body_bytes_in_flight)]
    max_body_bytes_in_flight: usize,
    /// Time for a request header to arrive, in seconds; also how long an idle keep-alive
    /// connection stays open
    #[arg(long, env = "SPHEREFIT_HEADER_TIMEOUT_S", default_value_t = ServiceConfig::default().header_timeout.as_secs_f64())]
    header_timeout_s: f64,
    /// Open connections at once; past that, new connections get 503 and are closed
    #[arg(long, env = "SPHEREFIT_MAX_CONNECTIONS", default_value_t = ServiceConfig::default().max_connections)]
    max_connections: usize,
    /// Directory of the OGC API – Processes job store (job status and results; kept across
    /// restarts) [default: spherefit-data under the system's temporary directory]
    #[arg(long, env = "SPHEREFIT_DATA_DIR")]
    data_dir: Option<std::path::PathBuf>,
    /// Where jobs are kept: a postgres:// or postgresql:// URL keeps them in PostgreSQL, shared
    /// by every replica given the same URL (tables made at start); a path is the disk store's
    /// directory, as --data-dir [default: the disk store]
    #[arg(long, env = "SPHEREFIT_JOB_STORE")]
    job_store: Option<String>,
    /// File of API keys, one `OWNER:SHA256_HEX_OF_TOKEN` a line (`#` comments): every route
    /// but /health and the page's files then needs `Authorization: Bearer TOKEN`, and each
    /// owner sees only its own jobs [default: no keys, the service is open to anyone who can
    /// reach it]
    #[arg(long, env = "SPHEREFIT_API_KEYS_FILE")]
    api_keys: Option<std::path::PathBuf>,
    /// Jobs of one owner waiting or running at once; past that, 429 with Retry-After
    #[arg(long, env = "SPHEREFIT_MAX_OWNER_JOBS", default_value_t = ServiceConfig::default().max_owner_jobs)]
    max_owner_jobs: usize,
    /// With PostgreSQL: how long a replica's claim on a running job lasts without renewal, in
    /// seconds; a job whose replica died is taken up by another after this
    #[arg(long, env = "SPHEREFIT_JOB_LEASE_S", default_value_t = ServiceConfig::default().job_lease.as_secs_f64())]
    job_lease_s: f64,
    /// Time budget of one asynchronous job, in seconds; past it the job ends failed
    #[arg(long, env = "SPHEREFIT_JOB_TIMEOUT_S", default_value_t = ServiceConfig::default().job_timeout.as_secs_f64())]
    job_timeout_s: f64,
    /// Jobs waiting or running at once; past that, 429 with Retry-After
    #[arg(long, env = "SPHEREFIT_MAX_JOBS", default_value_t = ServiceConfig::default().max_jobs)]
    max_jobs: usize,
    /// Bytes the job store may hold on disk; past that, jobs fail or are refused (503)
    #[arg(long, env = "SPHEREFIT_STORE_BYTES", default_value_t = ServiceConfig::default().store_bytes)]
    store_bytes: u64,
    /// How long a finished job and its result are kept, in seconds
    #[arg(long, env = "SPHEREFIT_JOB_EXPIRY_S", default_value_t = ServiceConfig::default().job_expiry.as_secs_f64())]
    job_expiry_s: f64,
    /// Log format on stderr: auto (text on a terminal, JSON otherwise), text or json.
    /// The level comes from RUST_LOG (default info)
    #[arg(long, env = "SPHEREFIT_LOG_FORMAT", value_enum, default_value_t = LogFormat::Auto)]
    log_format: LogFormat,
    /// Stop by itself after this many seconds (for scripts and tests) [default: run until
    /// SIGINT or SIGTERM]
    #[arg(long, env = "SPHEREFIT_EXIT_AFTER_S")]
    exit_after_s: Option<f64>,
}

/// Where `serve` keeps its jobs.
#[derive(Clone, Debug, PartialEq)]
enum Store {
    Disk,
    Postgres(String),
}

/// How long `serve` waits for PostgreSQL at start (a replica may start before the database).
const POSTGRES_WAIT: Duration = Duration::from_secs(30);

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum LogFormat {
    Auto,
    Text,
    Json,
}

impl ServeArgs {
    /// The job store asked for, and the disk store's directory.
    fn store(&self) -> Result<(Store, std::path::PathBuf), Failure> {
        let dir = self.data_dir.clone().unwrap_or_else(default_data_dir);
        match self.job_store.as_deref().map(str::trim) {
            None | Some("") => Ok((Store::Disk, dir)),
            Some(url)
                if url.starts_with("postgres://") || url.starts_with("postgresql://") =>
            {
                Ok((Store::Postgres(url.to_string()), dir))
            }
            Some(other) if other.contains("://") => Err(Failure::input(
                "--job-store: only postgres:// or postgresql:// URLs, or a directory, are job stores".to_string(),
            )),
            Some(path) => {
                let path = std::path::PathBuf::from(path);
                match &self.data_dir {
                    Some(d) if *d != path => Err(Failure::input(format!(
                        "--job-store {} and --data-dir {} name two different directories: give one",
                        path.display(),
                        d.display()
                    ))),
                    _ => Ok((Store::Disk, path)),
                }
            }
        }
    }

    fn config(&self) -> Result<ServiceConfig, Failure> {
        let request_timeout = seconds("--timeout-s", self.timeout_s)?;
        let body_timeout = seconds("--body-timeout-s", self.body_timeout_s)?.min(request_timeout);
        let header_timeout = seconds("--header-timeout-s", self.header_timeout_s)?;
        if let Some(s) = self.exit_after_s {
            seconds("--exit-after-s", s)?;
        }
        let d = ServiceConfig::default();
        let (_, data_dir) = self.store()?;
        let api_keys = match &self.api_keys {
            None => None,
            Some(path) => Some(service::auth::ApiKeys::read(path).map_err(Failure::input)?),
        };
        Ok(ServiceConfig {
            max_body_bytes: self.max_body_bytes,
            max_points: self.max_points,
            max_output_points: self.max_output_points,
            limits: Limits {
                max_control_points: self.max_control_points,
                max_samples: self.max_samples,
                max_iterations: self.max_iterations,
            },
            request_timeout,
            fit_concurrency: self.fit_concurrency.unwrap_or(d.fit_concurrency).max(1),
            fit_queue: self.fit_queue,
            max_in_flight: self.max_in_flight.max(1),
            body_timeout,
            max_body_bytes_in_flight: self.max_body_bytes_in_flight,
            header_timeout,
            max_connections: self.max_connections.max(1),
            data_dir: Some(data_dir),
            job_timeout: seconds("--job-timeout-s", self.job_timeout_s)?,
            max_jobs: self.max_jobs.max(1),
            max_owner_jobs: self.max_owner_jobs.max(1),
            api_keys,
            job_lease: seconds("--job-lease-s", self.job_lease_s)?,
            store_bytes: self.store_bytes,
            job_expiry: seconds("--job-expiry-s", self.job_expiry_s)?,
        })
    }
}

/// The job store of `spherefit serve` without `--data-dir`: one place per machine, so that
/// finished jobs survive a restart.
fn default_data_dir() -> std::path::PathBuf {
    std::env::temp_dir().join("spherefit-data")
}

/// Longest duration a flag takes: a year (longer is surely a typo, and would overflow timers).
const MAX_SECONDS: f64 = 366.0 * 86_400.0;

/// A positive, finite number of seconds up to [`MAX_SECONDS`].
fn seconds(flag: &str, s: f64) -> Result<Duration, Failure> {
    if !(s.is_finite() && s > 0.0 && s <= MAX_SECONDS) {
        return Err(Failure::input(format!(
            "{flag} {}: give a number of seconds greater than 0 and at most {MAX_SECONDS}",
            if s.abs() >= 1e9 {
                format!("{s:e}")
            } else {
                s.to_string()
            }
        )));
    }
    Ok(Duration::from_secs_f64(s))
}

fn init_logging(format: LogFormat) {
    use std::io::IsTerminal;
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info"));
    let json = match format {
        LogFormat::Json => true,
        LogFormat::Text => false,
        LogFormat::Auto => !std::io::stderr().is_terminal(),
    };
    let builder = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr);
    // `try_init`: a second call (tests) keeps the first subscriber.
    let _ = if json {
        builder.json().try_init()
    } else {
        builder.try_init()
    };
}

pub(crate) fn run(args: ServeArgs) -> Result<(), Failure> {
    let config = args.config()?;
    let (store, _) = args.store()?;
    init_logging(args.log_format);
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .map_err(|e| Failure::input(format!("cannot start the async runtime: {e}")))?;
    let exit_after = args.exit_after_s.map(Duration::from_secs_f64);
    let result = runtime.block_on(async move {
        let listener = tokio::net::TcpListener::bind(args.addr)
            .await
            .map_err(|e| Failure::input(format!("cannot listen on {}: {e}", args.addr)))?;
        let local = listener.local_addr().map_err(|e| Failure::input(e.to_string()))?;
        let owners = config
            .api_keys
            .as_ref()
            .map_or_else(|| "none (open service)".to_string(), |k| k.owners().join(","));
        let state = match &store {
            Store::Disk => AppState::new(config.clone()),
            Store::Postgres(url) => AppState::with_postgres(config.clone(), url, POSTGRES_WAIT)
                .await
                .map_err(Failure::input)?,
        };
        tracing::info!(
            addr = %local,
            fit_concurrency = config.fit_concurrency,
            fit_queue = config.fit_queue,
            max_body_bytes = config.max_body_bytes,
            max_points = config.max_points,
            timeout_s = config.request_timeout.as_secs_f64(),
            job_store = if store == Store::Disk { "disk" } else { "postgresql" },
            api_key_owners = %owners,
            "spherefit listening"
        );
        let shutdown = async move {
            match exit_after {
                Some(d) => {
                    tokio::select! {
                        _ = service::shutdown_signal() => {}
                        _ = tokio::time::sleep(d) => tracing::info!("exit-after-s reached, shutting down"),
                    }
                }
                None => service::shutdown_signal().await,
            }
        };
        service::serve(listener, state, shutdown)
            .await
            .map_err(|e| Failure::input(format!("server error: {e}")))?;
        tracing::info!("stopped");
        Ok(())
    });
    // Work abandoned past its budget stops at its next cancellation check; do not wait for it.
    runtime.shutdown_timeout(Duration::from_millis(500));
    result
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Debug, Parser)]
    struct Serve {
        #[command(flatten)]
        args: ServeArgs,
    }

    #[test]
    fn no_flags_give_the_service_defaults() {
        // The flags' defaults are read from `ServiceConfig::default()`; the durations go
        // through seconds as f64 and must come back unchanged.
        let args = Serve::try_parse_from(["serve"]).unwrap().args;
        let expected = ServiceConfig {
            data_dir: Some(default_data_dir()),
            ..ServiceConfig::default()
        };
        assert_eq!(args.config().unwrap(), expected);
        assert_eq!(args.store().unwrap().0, Store::Disk);
    }

    #[test]
    fn the_job_store_is_a_postgres_url_or_a_directory() {
        let parse = |a: &[&str]| {
            let mut v = vec!["serve"];
            v.extend_from_slice(a);
            Serve::try_parse_from(v).unwrap().args
        };
        let a = parse(&["--job-store", "postgres://u:p@db:5432/jobs"]);
        assert_eq!(
            a.store().unwrap().0,
            Store::Postgres("postgres://u:p@db:5432/jobs".into())
        );
        let a = parse(&["--job-store", "postgresql://db/jobs"]);
        assert!(matches!(a.store().unwrap().0, Store::Postgres(_)));
        let a = parse(&["--job-store", "/srv/jobs"]);
        assert_eq!(
            a.config().unwrap().data_dir,
            Some(std::path::PathBuf::from("/srv/jobs"))
        );
        let e = parse(&["--job-store", "/a", "--data-dir", "/b"])
            .config()
            .unwrap_err();
        assert!(
            e.message.contains("two different directories"),
            "{}",
            e.message
        );
        let e = parse(&["--job-store", "mysql://db/x"]).store().unwrap_err();
        assert!(e.message.contains("postgres://"), "{}", e.message);
        let e = parse(&["--api-keys", "/nonexistent/keys"])
            .config()
            .unwrap_err();
        assert!(e.message.contains("/nonexistent/keys"), "{}", e.message);
        let e = parse(&["--job-lease-s", "0"]).config().unwrap_err();
        assert!(e.message.contains("--job-lease-s"), "{}", e.message);
    }
}
