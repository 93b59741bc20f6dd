//! The job store: where OGC API – Processes jobs, their status, progress and results live, kept
//! apart by owner ([`Owner`]). Two stores answer the same calls ([`JobStore`]):
//!
//! * on disk ([`DiskStore`], `disk.rs`): one process, one directory, the default;
//! * in PostgreSQL ([`PgStore`], `postgres.rs`): any number of replicas share the jobs, and any
//!   replica with a free fitting slot runs any waiting job (a queue).
//!
//! Every call that creates, reads, lists or dismisses a job takes the caller's owner: another
//! owner's job is absent (404), lists hold the caller's jobs only.

use crate::service::auth::{Owner, ANONYMOUS};
use crate::service::error::ApiError;
use crate::service::ogc::disk::DiskStore;
use crate::service::ogc::postgres::PgStore;
use axum::http::StatusCode;
use serde::{Deserialize, Serialize};
use std::hash::{BuildHasher, Hasher};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{SystemTime, UNIX_EPOCH};

/// Bytes counted for a job's `status.json` (a record is a few hundred bytes; the message of a
/// failure is cut to fit, [`MAX_MESSAGE`]).
pub(crate) const STATUS_RESERVE: u64 = 4096;

/// Longest failure message kept, bytes.
pub(crate) const MAX_MESSAGE: usize = 2048;

/// OGC API – Processes job status codes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub(crate) enum Status {
    Accepted,
    Running,
    Successful,
    Failed,
    Dismissed,
}

impl Status {
    /// Whether the job still has work to do (and counts against `max_jobs`).
    pub fn is_active(self) -> bool {
        matches!(self, Status::Accepted | Status::Running)
    }

    /// The status as the API and the database write it.
    pub fn as_str(self) -> &'static str {
        match self {
            Status::Accepted => "accepted",
            Status::Running => "running",
            Status::Successful => "successful",
            Status::Failed => "failed",
            Status::Dismissed => "dismissed",
        }
    }

    /// The status written as [`Status::as_str`] writes it.
    pub fn parse(s: &str) -> Option<Status> {
        [
            Status::Accepted,
            Status::Running,
            Status::Successful,
            Status::Failed,
            Status::Dismissed,
        ]
        .into_iter()
        .find(|x| x.as_str() == s)
    }
}

fn anonymous() -> String {
    ANONYMOUS.to_string()
}

/// What is known of a job; `status.json` on disk, a row in PostgreSQL.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub(crate) struct JobRecord {
    /// 32 hex digits.
    pub id: String,
    /// Who made it (records written before owners existed are the anonymous owner's).
    #[serde(default = "anonymous")]
    pub owner: String,
    /// `fit`, `interpolate` or `evaluate`.
    pub process: String,
    pub status: Status,
    /// Why it failed, or what it is doing.
    pub message: Option<String>,
    /// Unix seconds.
    pub created_s: f64,
    pub started_s: Option<f64>,
    pub finished_s: Option<f64>,
    /// Per cent done, 0 to 100.
    pub progress: u8,
    /// The result's media type (`application/geo+json`, or `application/json` for TopoJSON).
    pub media_type: Option<String>,
    /// The result's length, bytes.
    pub result_bytes: u64,
    /// Input positions fitted and curves made (from the work's counts).
    pub input_points: usize,
    pub curves: usize,
}

/// Why a job could not be admitted.
#[derive(Debug, PartialEq)]
pub(crate) enum Refusal {
    /// `max_jobs` jobs are unfinished.
    TooManyJobs(usize),
    /// `max_owner_jobs` jobs of the caller are unfinished.
    TooManyOwnerJobs(usize),
    /// The store has no room for another status file.
    Full { used: u64, budget: u64 },
    /// The data directory cannot be written, or the database cannot be reached.
    Unavailable(String),
}

/// Seconds since the Unix epoch, now.
pub(crate) fn now_s() -> f64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64())
}

/// A fresh job id: 128 bits from the standard library's randomly keyed hasher (seeded from the
/// OS), the time and a counter; ids are not secrets, only unique and hard to guess.
pub(crate) fn new_id() -> String {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let t = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos());
    let mut halves = [0u64; 2];
    for (k, h) in halves.iter_mut().enumerate() {
        let mut hasher = std::collections::hash_map::RandomState::new().build_hasher();
        hasher.write_u128(t);
        hasher.write_u64(n);
        hasher.write_usize(k);
        hasher.write_u32(std::process::id());
        *h = hasher.finish();
    }
    format!("{:016x}{:016x}", halves[0], halves[1])
}

/// Whether `id` has the shape of a job id (so that it can name a directory safely).
pub(crate) fn is_job_id(id: &str) -> bool {
    id.len() == 32
        && id
            .bytes()
            .all(|b| b.is_ascii_hexdigit() && !b.is_ascii_uppercase())
}

/// `s` cut to [`MAX_MESSAGE`] bytes (at a character boundary).
pub(crate) fn cut(mut s: String) -> String {
    if s.len() > MAX_MESSAGE {
        let mut end = MAX_MESSAGE;
        while !s.is_char_boundary(end) {
            end -= 1;
        }
        s.truncate(end);
    }
    s
}

/// The job store in use (module docs).
#[derive(Debug)]
pub(crate) enum JobStore {
    Disk(DiskStore),
    Postgres(PgStore),
}

impl JobStore {
    /// Why a new job of `owner` would be refused now, if it would (checked before a request's
    /// body is read; creating the job checks again).
    pub async fn refusal(&self, owner: &Owner) -> Option<Refusal> {
        match self {
            JobStore::Disk(d) => d.refusal(owner),
            JobStore::Postgres(p) => p.refusal(owner).await,
        }
    }

    /// `owner`'s job `id` (none for another owner's).
    ///
    /// # Errors
    /// [`Refusal::Unavailable`] when the store cannot be read.
    pub async fn get(&self, owner: &Owner, id: &str) -> Result<Option<JobRecord>, Refusal> {
        match self {
            JobStore::Disk(d) => Ok(d.get(owner, id)),
            JobStore::Postgres(p) => p.get(owner, id).await,
        }
    }

    /// `owner`'s jobs, newest first.
    ///
    /// # Errors
    /// [`Refusal::Unavailable`] when the store cannot be read.
    pub async fn list(&self, owner: &Owner) -> Result<Vec<JobRecord>, Refusal> {
        match self {
            JobStore::Disk(d) => Ok(d.list(owner)),
            JobStore::Postgres(p) => p.list(owner).await,
        }
    }

    /// Dismisses `owner`'s job `id`: its work is cancelled (wherever it runs) and it is
    /// deleted with its result.
    ///
    /// # Errors
    /// [`Refusal::Unavailable`] when the store cannot be written.
    pub async fn dismiss(&self, owner: &Owner, id: &str) -> Result<Option<JobRecord>, Refusal> {
        match self {
            JobStore::Disk(d) => {
                let (d, owner, id) = (d.clone(), owner.clone(), id.to_string());
                // Deleting a large result is file-system work: off the async workers.
                tokio::task::spawn_blocking(move || d.dismiss(&owner, &id))
                    .await
                    .map_err(|e| Refusal::Unavailable(format!("dismissal failed: {e}")))
            }
            JobStore::Postgres(p) => p.dismiss(owner, id).await,
        }
    }

    /// The result bytes of `owner`'s job `id`, none when there are none (no such job, or not
    /// successful).
    ///
    /// # Errors
    /// [`Refusal::Unavailable`] when the store cannot be read.
    pub async fn result(&self, owner: &Owner, id: &str) -> Result<Option<Vec<u8>>, Refusal> {
        match self {
            JobStore::Disk(d) => {
                if d.get(owner, id).is_none() {
                    return Ok(None);
                }
                Ok(tokio::fs::read(d.result_path(id)).await.ok())
            }
            JobStore::Postgres(p) => p.result(owner, id).await,
        }
    }

    /// [`JobStore::get`] from blocking code (the parsing of an execute request on the blocking
    /// pool, which runs within the runtime).
    pub fn get_blocking(&self, owner: &Owner, id: &str) -> Result<Option<JobRecord>, Refusal> {
        match self {
            JobStore::Disk(d) => Ok(d.get(owner, id)),
            JobStore::Postgres(p) => tokio::runtime::Handle::current().block_on(p.get(owner, id)),
        }
    }

    /// [`JobStore::result`] from blocking code (as [`JobStore::get_blocking`]).
    pub fn result_blocking(&self, owner: &Owner, id: &str) -> Result<Option<Vec<u8>>, Refusal> {
        match self {
            JobStore::Disk(d) => {
                if d.get(owner, id).is_none() {
                    return Ok(None);
                }
                Ok(std::fs::read(d.result_path(id)).ok())
            }
            JobStore::Postgres(p) => {
                tokio::runtime::Handle::current().block_on(p.result(owner, id))
            }
        }
    }
}

impl From<Refusal> for ApiError {
    /// The `429`/`503` for a refused job, or a store that cannot be used.
    fn from(r: Refusal) -> ApiError {
        match r {
            Refusal::TooManyJobs(n) => {
                let mut e = ApiError::new(
                    StatusCode::TOO_MANY_REQUESTS,
                    "too-many-jobs",
                    format!("{n} jobs are waiting or running, as many as this server runs at once: retry after the time in Retry-After, or dismiss a job"),
                );
                e.retry_after_s = Some(5);
                e
            }
            Refusal::TooManyOwnerJobs(n) => {
                let mut e = ApiError::new(
                    StatusCode::TOO_MANY_REQUESTS,
                    "too-many-jobs",
                    format!("you have {n} jobs waiting or running, as many as one owner may have: retry after the time in Retry-After, or dismiss one of them"),
                );
                e.retry_after_s = Some(5);
                e
            }
            Refusal::Full { used, budget } => {
                let mut e = ApiError::new(
                    StatusCode::SERVICE_UNAVAILABLE,
                    "store-full",
                    format!("the job store holds {used} of its {budget} bytes: dismiss finished jobs, or retry once old ones expire"),
                );
                e.retry_after_s = Some(60);
                e
            }
            Refusal::Unavailable(why) => {
                tracing::error!(error = %why, "the job store cannot be used");
                let mut e = ApiError::new(
                    StatusCode::SERVICE_UNAVAILABLE,
                    "store-unavailable",
                    "the job store cannot be used at the moment (the server's log says why): retry after the time in Retry-After",
                );
                e.retry_after_s = Some(5);
                e
            }
        }
    }
}
