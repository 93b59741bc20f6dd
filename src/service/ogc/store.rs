//! The job store: one directory per job under `<data dir>/jobs/`, holding `status.json` (the
//! [`JobRecord`]) and, once the job succeeded, `result` (the output document, as `/v1` would
//! have answered it). An index in memory mirrors the directory and counts the bytes on disk.
//!
//! # Bounds
//! Nothing a client sends is written here: request bodies stay in memory (bounded by the body
//! limits), only results and small status files are written, and each is counted against
//! `store_bytes` *before* it is written ([`JobStore::create`] reserves [`STATUS_RESERVE`] for a
//! job's status; [`JobStore::succeed`] checks the result's length). A result that does not fit
//! fails its job with a reason, a job that does not fit is refused (503 `store-full`). Finished
//! jobs expire after `job_expiry` (swept whenever the store is used); a dismissed job's files
//! are deleted and its bytes freed at once.
//!
//! # Restarts
//! [`JobStore::open`] reads the directory back: finished jobs (and their results) stay readable;
//! jobs that were accepted or running are marked failed, since their work died with the process.

use crate::service::handlers::Progress;
use crate::service::ServiceConfig;
use crate::sphere::cancel::Cancel;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::hash::{BuildHasher, Hasher};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

/// Bytes counted for a job's `status.json` (a record is a few hundred bytes; the message of a
/// failure is cut to fit, [`MAX_MESSAGE`]).
pub(crate) const STATUS_RESERVE: u64 = 4096;

/// Longest failure message kept, bytes.
const MAX_MESSAGE: usize = 2048;

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
}

/// What is known of a job; `status.json` on disk.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub(crate) struct JobRecord {
    /// 32 hex digits.
    pub id: String,
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

struct Entry {
    record: JobRecord,
    /// The running work's cancel token and progress (none for jobs read back from disk).
    cancel: Option<Cancel>,
    progress: Option<Arc<Progress>>,
}

struct Inner {
    jobs: HashMap<String, Entry>,
    /// Bytes on disk counted against the budget (status reserves and results).
    used: u64,
}

/// Why a job could not be admitted.
#[derive(Debug, PartialEq)]
pub(crate) enum Refusal {
    /// `max_jobs` jobs are unfinished.
    TooManyJobs(usize),
    /// The store has no room for another status file.
    Full { used: u64, budget: u64 },
    /// The data directory cannot be written.
    Unavailable(String),
}

/// The job store (see the module docs).
pub(crate) struct JobStore {
    dir: PathBuf,
    budget: u64,
    expiry: Duration,
    max_jobs: usize,
    inner: Mutex<Inner>,
}

impl std::fmt::Debug for JobStore {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("JobStore").field("dir", &self.dir).finish()
    }
}

/// Seconds since the Unix epoch, now.
pub(crate) fn now_s() -> f64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64())
}

/// A fresh job id: 128 bits from the standard library's randomly keyed hasher (seeded from the
/// OS), the time and a counter; ids are not secrets, only unique and hard to guess.
fn new_id() -> String {
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

fn cut(mut s: String) -> String {
    if s.len() > MAX_MESSAGE {
        let mut end = MAX_MESSAGE;
        while !s.is_char_boundary(end) {
            end -= 1;
        }
        s.truncate(end);
    }
    s
}

impl JobStore {
    /// Opens the store of `config` (see the module docs); a store that cannot be read is
    /// logged and starts empty (jobs are then refused if the directory cannot be written).
    pub fn open(config: &ServiceConfig) -> JobStore {
        let dir = match &config.data_dir {
            Some(d) => d.clone(),
            None => {
                static N: AtomicU64 = AtomicU64::new(0);
                std::env::temp_dir().join(format!(
                    "spherefit-jobs-{}-{}",
                    std::process::id(),
                    N.fetch_add(1, Ordering::Relaxed)
                ))
            }
        };
        let store = JobStore {
            dir,
            budget: config.store_bytes,
            expiry: config.job_expiry,
            max_jobs: config.max_jobs.max(1),
            inner: Mutex::new(Inner {
                jobs: HashMap::new(),
                used: 0,
            }),
        };
        store.load();
        store
    }

    fn jobs_dir(&self) -> PathBuf {
        self.dir.join("jobs")
    }

    fn job_dir(&self, id: &str) -> PathBuf {
        self.jobs_dir().join(id)
    }

    /// The path of a job's result file.
    pub fn result_path(&self, id: &str) -> PathBuf {
        self.job_dir(id).join("result")
    }

    fn lock(&self) -> MutexGuard<'_, Inner> {
        // A panic while holding the lock leaves a consistent map (every update is one
        // assignment), so a poisoned lock is used as it is.
        self.inner.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Reads the jobs back from disk (module docs, "Restarts").
    fn load(&self) {
        let Ok(entries) = std::fs::read_dir(self.jobs_dir()) else {
            return;
        };
        let mut inner = self.lock();
        for entry in entries.flatten() {
            let name = entry.file_name().to_string_lossy().into_owned();
            if !is_job_id(&name) {
                continue;
            }
            let path = entry.path().join("status.json");
            let record: Option<JobRecord> = std::fs::read(&path)
                .ok()
                .and_then(|b| serde_json::from_slice(&b).ok());
            let Some(mut record) = record.filter(|r| r.id == name) else {
                tracing::warn!(job = %name, "unreadable job status: removed");
                let _ = std::fs::remove_dir_all(entry.path());
                continue;
            };
            if record.status.is_active() {
                record.status = Status::Failed;
                record.message = Some(
                    "the service stopped while this job was waiting or running: submit it again"
                        .into(),
                );
                record.finished_s = Some(now_s());
                let _ = write_status(&entry.path(), &record);
            }
            let result_len = if record.status == Status::Successful {
                std::fs::metadata(entry.path().join("result")).map_or(0, |m| m.len())
            } else {
                0
            };
            inner.used += STATUS_RESERVE + result_len;
            inner.jobs.insert(
                name,
                Entry {
                    record,
                    cancel: None,
                    progress: None,
                },
            );
        }
        drop(inner);
        self.sweep();
    }

    /// Removes the finished jobs older than the expiry.
    pub fn sweep(&self) {
        let now = now_s();
        let expiry = self.expiry.as_secs_f64();
        let mut inner = self.lock();
        let old: Vec<String> = inner
            .jobs
            .values()
            .filter(|e| {
                !e.record.status.is_active()
                    && e.record.finished_s.unwrap_or(e.record.created_s) + expiry <= now
            })
            .map(|e| e.record.id.clone())
            .collect();
        for id in old {
            self.remove_locked(&mut inner, &id);
        }
    }

    fn remove_locked(&self, inner: &mut Inner, id: &str) -> Option<JobRecord> {
        let entry = inner.jobs.remove(id)?;
        let bytes = STATUS_RESERVE + entry.record.result_bytes;
        inner.used = inner.used.saturating_sub(bytes);
        if let Some(c) = &entry.cancel {
            c.cancel();
        }
        let _ = std::fs::remove_dir_all(self.job_dir(id));
        Some(entry.record)
    }

    /// Why a new job would be refused now, if it would (checked before a request's body is
    /// read; [`JobStore::create`] checks again).
    pub fn refusal(&self) -> Option<Refusal> {
        self.sweep();
        let inner = self.lock();
        let active = inner
            .jobs
            .values()
            .filter(|e| e.record.status.is_active())
            .count();
        if active >= self.max_jobs {
            return Some(Refusal::TooManyJobs(self.max_jobs));
        }
        (inner.used + STATUS_RESERVE > self.budget).then_some(Refusal::Full {
            used: inner.used,
            budget: self.budget,
        })
    }

    /// Admits a new job of `process` (status `accepted`), its status written to disk.
    ///
    /// # Errors
    /// [`Refusal`] when `max_jobs` are unfinished, the store is full, or the directory cannot
    /// be written.
    pub fn create(
        &self,
        process: &str,
        cancel: Cancel,
        progress: Arc<Progress>,
    ) -> Result<JobRecord, Refusal> {
        self.sweep();
        let mut inner = self.lock();
        let active = inner
            .jobs
            .values()
            .filter(|e| e.record.status.is_active())
            .count();
        if active >= self.max_jobs {
            return Err(Refusal::TooManyJobs(self.max_jobs));
        }
        if inner.used + STATUS_RESERVE > self.budget {
            return Err(Refusal::Full {
                used: inner.used,
                budget: self.budget,
            });
        }
        let record = JobRecord {
            id: new_id(),
            process: process.to_string(),
            status: Status::Accepted,
            message: None,
            created_s: now_s(),
            started_s: None,
            finished_s: None,
            progress: 0,
            media_type: None,
            result_bytes: 0,
            input_points: 0,
            curves: 0,
        };
        let dir = self.job_dir(&record.id);
        std::fs::create_dir_all(&dir)
            .and_then(|()| write_status(&dir, &record))
            .map_err(|e| Refusal::Unavailable(format!("{}: {e}", dir.display())))?;
        inner.used += STATUS_RESERVE;
        inner.jobs.insert(
            record.id.clone(),
            Entry {
                record: record.clone(),
                cancel: Some(cancel),
                progress: Some(progress),
            },
        );
        Ok(record)
    }

    /// Applies `f` to a live job's record and writes it; nothing for a job that is gone
    /// (dismissed or expired).
    fn update(&self, id: &str, f: impl FnOnce(&mut JobRecord)) {
        let mut inner = self.lock();
        let Some(entry) = inner.jobs.get_mut(id) else {
            return;
        };
        if !entry.record.status.is_active() {
            return;
        }
        f(&mut entry.record);
        if let Err(e) = write_status(&self.job_dir(id), &entry.record) {
            tracing::warn!(job = %id, error = %e, "cannot write job status");
        }
        if !entry.record.status.is_active() {
            entry.cancel = None;
            entry.progress = None;
        }
    }

    /// The job started its work.
    pub fn start(&self, id: &str) {
        self.update(id, |r| {
            r.status = Status::Running;
            r.started_s = Some(now_s());
        });
    }

    /// The job failed: `message` says why.
    pub fn fail(&self, id: &str, message: String) {
        self.update(id, |r| {
            r.status = Status::Failed;
            r.message = Some(cut(message));
            r.finished_s = Some(now_s());
        });
    }

    /// The job succeeded with `bytes` of `media_type`: written if the store has room (checked
    /// before writing), else the job fails saying so.
    pub fn succeed(
        &self,
        id: &str,
        bytes: &[u8],
        media_type: &str,
        input_points: usize,
        curves: usize,
    ) {
        let len = bytes.len() as u64;
        {
            let mut inner = self.lock();
            let Some(entry) = inner.jobs.get(id) else {
                return;
            };
            if !entry.record.status.is_active() {
                return;
            }
            if inner.used + len > self.budget {
                let (used, budget) = (inner.used, self.budget);
                drop(inner);
                self.fail(
                    id,
                    format!(
                        "the result ({len} bytes) does not fit in the job store ({used} of {budget} bytes used): dismiss finished jobs or ask for a smaller output"
                    ),
                );
                return;
            }
            // Reserved before the write, so two results finishing at once cannot both pass.
            inner.used += len;
        }
        let path = self.result_path(id);
        let written = write_atomically(&path, bytes);
        let mut inner = self.lock();
        if let Err(e) = written {
            inner.used = inner.used.saturating_sub(len);
            drop(inner);
            tracing::warn!(job = %id, error = %e, "cannot write job result");
            self.fail(id, format!("the result could not be stored: {e}"));
            return;
        }
        let live = inner
            .jobs
            .get(id)
            .is_some_and(|e| e.record.status.is_active());
        if !live {
            // Dismissed while the result was written: its directory is gone or going.
            inner.used = inner.used.saturating_sub(len);
            let _ = std::fs::remove_file(&path);
            return;
        }
        drop(inner);
        self.update(id, |r| {
            r.status = Status::Successful;
            r.progress = 100;
            r.finished_s = Some(now_s());
            r.media_type = Some(media_type.to_string());
            r.result_bytes = len;
            r.input_points = input_points;
            r.curves = curves;
        });
    }

    /// A job's record, with its live progress.
    pub fn get(&self, id: &str) -> Option<JobRecord> {
        self.sweep();
        let inner = self.lock();
        let entry = inner.jobs.get(id)?;
        let mut r = entry.record.clone();
        if let Some(p) = &entry.progress {
            r.progress = p.percent().min(99);
        }
        Some(r)
    }

    /// Every job, newest first.
    pub fn list(&self) -> Vec<JobRecord> {
        self.sweep();
        let inner = self.lock();
        let mut v: Vec<JobRecord> = inner
            .jobs
            .values()
            .map(|e| {
                let mut r = e.record.clone();
                if let Some(p) = &e.progress {
                    r.progress = p.percent().min(99);
                }
                r
            })
            .collect();
        v.sort_by(|a, b| b.created_s.total_cmp(&a.created_s).then(a.id.cmp(&b.id)));
        v
    }

    /// Dismisses a job: its work is cancelled, its files deleted and its bytes freed.
    pub fn dismiss(&self, id: &str) -> Option<JobRecord> {
        let mut inner = self.lock();
        let mut r = self.remove_locked(&mut inner, id)?;
        r.status = Status::Dismissed;
        r.message = Some("dismissed by a client".into());
        Some(r)
    }

    /// Bytes counted on disk.
    #[cfg(test)]
    pub fn used_bytes(&self) -> u64 {
        self.lock().used
    }
}

fn write_status(dir: &Path, record: &JobRecord) -> std::io::Result<()> {
    let bytes = serde_json::to_vec(record).map_err(std::io::Error::other)?;
    write_atomically(&dir.join("status.json"), &bytes)
}

/// Writes `bytes` to a temporary file beside `path`, then renames it over `path`, so a reader
/// (or a restart) sees the old file or the new one, never half of one.
fn write_atomically(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let tmp = path.with_extension("tmp");
    std::fs::write(&tmp, bytes)?;
    std::fs::rename(&tmp, path)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn config(dir: &Path, budget: u64) -> ServiceConfig {
        ServiceConfig {
            data_dir: Some(dir.to_path_buf()),
            store_bytes: budget,
            max_jobs: 2,
            ..ServiceConfig::default()
        }
    }

    fn scratch(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("spherefit-store-test-{name}-{}", new_id()));
        let _ = std::fs::remove_dir_all(&d);
        d
    }

    fn job(store: &JobStore) -> Result<JobRecord, Refusal> {
        store.create("fit", Cancel::default(), Arc::default())
    }

    #[test]
    fn ids_are_unique_and_shaped_for_paths() {
        let a = new_id();
        assert!(is_job_id(&a), "{a}");
        assert_ne!(a, new_id());
        assert!(!is_job_id("../etc"));
        assert!(!is_job_id(&a.to_uppercase()));
    }

    #[test]
    fn the_budget_is_checked_before_writing_and_freed_by_dismissal() {
        let dir = scratch("budget");
        let store = JobStore::open(&config(&dir, 3 * STATUS_RESERVE + 100));
        let a = job(&store).unwrap();
        store.start(&a.id);
        store.succeed(&a.id, &[b'x'; 200], "application/geo+json", 1, 1);
        let r = store.get(&a.id).unwrap();
        assert_eq!(r.status, Status::Successful);
        assert_eq!(store.used_bytes(), STATUS_RESERVE + 200);
        // A result over the room left fails its job and writes nothing.
        let b = job(&store).unwrap();
        store.succeed(&b.id, &[b'x'; 5000], "application/geo+json", 1, 1);
        let r = store.get(&b.id).unwrap();
        assert_eq!(r.status, Status::Failed);
        assert!(r.message.unwrap().contains("does not fit"));
        assert!(!store.result_path(&b.id).exists());
        // No room for a third status file.
        assert!(matches!(job(&store), Err(Refusal::Full { .. })));
        store.dismiss(&a.id).unwrap();
        assert!(!store.result_path(&a.id).exists());
        assert_eq!(store.used_bytes(), STATUS_RESERVE);
        assert!(job(&store).is_ok());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn unfinished_jobs_are_bounded() {
        let dir = scratch("bound");
        let store = JobStore::open(&config(&dir, 1 << 20));
        let a = job(&store).unwrap();
        job(&store).unwrap();
        assert_eq!(job(&store), Err(Refusal::TooManyJobs(2)));
        store.fail(&a.id, "x".repeat(10_000));
        assert_eq!(
            store.get(&a.id).unwrap().message.unwrap().len(),
            MAX_MESSAGE
        );
        assert!(job(&store).is_ok());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_restart_keeps_results_and_fails_unfinished_jobs() {
        let dir = scratch("restart");
        let store = JobStore::open(&config(&dir, 1 << 20));
        let done = job(&store).unwrap();
        store.succeed(&done.id, b"{}", "application/geo+json", 3, 1);
        let running = job(&store).unwrap();
        store.start(&running.id);
        drop(store);
        let store = JobStore::open(&config(&dir, 1 << 20));
        assert_eq!(store.get(&done.id).unwrap().status, Status::Successful);
        assert_eq!(std::fs::read(store.result_path(&done.id)).unwrap(), b"{}");
        let r = store.get(&running.id).unwrap();
        assert_eq!(r.status, Status::Failed);
        assert!(r.message.unwrap().contains("stopped"));
        assert_eq!(store.used_bytes(), 2 * STATUS_RESERVE + 2);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn finished_jobs_expire() {
        let dir = scratch("expiry");
        let mut c = config(&dir, 1 << 20);
        c.job_expiry = Duration::from_millis(50);
        let store = JobStore::open(&c);
        let a = job(&store).unwrap();
        store.succeed(&a.id, b"{}", "application/geo+json", 1, 1);
        let b = job(&store).unwrap();
        std::thread::sleep(Duration::from_millis(80));
        assert!(store.get(&a.id).is_none(), "expired");
        assert!(!store.result_path(&a.id).exists());
        assert!(store.get(&b.id).is_some(), "unfinished jobs do not expire");
        assert_eq!(store.used_bytes(), STATUS_RESERVE);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
