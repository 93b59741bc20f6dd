//! The job store on disk: one directory per job under `<data dir>/jobs/`, holding `status.json` (the
//! [`JobRecord`]) and, once the job succeeded, `result` (the output document, as `/v1` would
//! have answered it). An index in memory mirrors the directory and counts the bytes on disk.
//!
//! # Bounds
//! Nothing a client sends is written here: request bodies stay in memory (bounded by the body
//! limits), only results and small status files are written, and each is counted against
//! `store_bytes` *before* it is written ([`Disk::create`] reserves [`STATUS_RESERVE`] for a
//! job's status; [`Disk::succeed`] checks the result's length). A result that does not fit
//! fails its job with a reason, a job that does not fit is refused (503 `store-full`). Finished
//! jobs expire after `job_expiry` (swept whenever the store is used); a dismissed job's files
//! are deleted and its bytes freed at once.
//!
//! # Restarts
//! [`DiskStore::open`] reads the directory back: finished jobs (and their results) stay readable;
//! jobs that were accepted or running are marked failed, since their work died with the process.

use crate::service::auth::Owner;
use crate::service::handlers::Progress;
use crate::service::ogc::store::{
    cut, is_job_id, new_id, now_s, JobRecord, Refusal, Status, STATUS_RESERVE,
};
use crate::service::ServiceConfig;
use crate::sphere::cancel::Cancel;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

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

/// The job store on disk (see the module docs); clones share it.
#[derive(Clone, Debug)]
pub(crate) struct DiskStore(Arc<Disk>);

impl std::ops::Deref for DiskStore {
    type Target = Disk;
    fn deref(&self) -> &Disk {
        &self.0
    }
}

/// What a [`DiskStore`] shares.
pub(crate) struct Disk {
    dir: PathBuf,
    budget: u64,
    expiry: Duration,
    max_jobs: usize,
    max_owner_jobs: usize,
    inner: Mutex<Inner>,
    /// Why the directory could not be written the last time it was tried (start-up probe or a
    /// failed write); cleared when a probe or a write succeeds.
    unwritable: Mutex<Option<String>>,
}

impl std::fmt::Debug for Disk {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DiskStore").field("dir", &self.dir).finish()
    }
}

impl DiskStore {
    /// Opens the store of `config` (see the module docs); a store that cannot be read is
    /// logged and starts empty (jobs are then refused if the directory cannot be written).
    pub fn open(config: &ServiceConfig) -> DiskStore {
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
        let store = Disk {
            dir,
            budget: config.store_bytes,
            expiry: config.job_expiry,
            max_jobs: config.max_jobs.max(1),
            max_owner_jobs: config.max_owner_jobs.max(1),
            inner: Mutex::new(Inner {
                jobs: HashMap::new(),
                used: 0,
            }),
            unwritable: Mutex::new(None),
        };
        store.load();
        if config.data_dir.is_some() {
            // Said at start-up, not at the first job: a read-only file system (a container's
            // root) is a deployment mistake the operator should see at once.
            if let Err(why) = store.probe() {
                tracing::error!(
                    error = %why,
                    "the job store cannot be written: asynchronous jobs will get 503 store-unavailable until it can (give --data-dir a writable directory, or --job-store a PostgreSQL URL)"
                );
            }
        }
        DiskStore(Arc::new(store))
    }
}

impl Disk {
    /// Checks that the jobs directory can be made and written (a small file written and
    /// removed), remembering the outcome for [`Disk::refusal`].
    fn probe(&self) -> Result<(), String> {
        let dir = self.jobs_dir();
        let file = dir.join(".probe");
        let r = std::fs::create_dir_all(&dir)
            .and_then(|()| std::fs::write(&file, b"ok"))
            .and_then(|()| std::fs::remove_file(&file))
            .map_err(|e| format!("{}: {e}", dir.display()));
        *self.unwritable.lock().unwrap_or_else(|p| p.into_inner()) = r.clone().err();
        r
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
    /// read; [`Disk::create`] checks again).
    pub fn refusal(&self, owner: &Owner) -> Option<Refusal> {
        let known_bad = self
            .unwritable
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .is_some();
        if known_bad {
            // Tried again, so that a directory made writable is used without a restart.
            if let Err(why) = self.probe() {
                return Some(Refusal::Unavailable(why));
            }
        }
        self.sweep();
        let inner = self.lock();
        self.admission(&inner, owner).err()
    }

    /// Whether `owner` may add a job now: the bounds on unfinished jobs (all, the owner's) and
    /// on bytes.
    fn admission(&self, inner: &Inner, owner: &Owner) -> Result<(), Refusal> {
        let (mut active, mut own) = (0, 0);
        for e in inner.jobs.values() {
            if e.record.status.is_active() {
                active += 1;
                own += usize::from(e.record.owner == owner.name());
            }
        }
        if active >= self.max_jobs {
            return Err(Refusal::TooManyJobs(self.max_jobs));
        }
        if own >= self.max_owner_jobs {
            return Err(Refusal::TooManyOwnerJobs(self.max_owner_jobs));
        }
        if inner.used + STATUS_RESERVE > self.budget {
            return Err(Refusal::Full {
                used: inner.used,
                budget: self.budget,
            });
        }
        Ok(())
    }

    /// Admits a new job of `owner` running `process` (status `accepted`), its status written to
    /// disk.
    ///
    /// # Errors
    /// [`Refusal`] when `max_jobs` (or the owner's `max_owner_jobs`) are unfinished, the store
    /// is full, or the directory cannot be written.
    pub fn create(
        &self,
        owner: &Owner,
        process: &str,
        cancel: Cancel,
        progress: Arc<Progress>,
    ) -> Result<JobRecord, Refusal> {
        self.sweep();
        let mut inner = self.lock();
        self.admission(&inner, owner)?;
        let record = JobRecord {
            id: new_id(),
            owner: owner.name().to_string(),
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
            .map_err(|e| {
                let why = format!("{}: {e}", dir.display());
                *self.unwritable.lock().unwrap_or_else(|p| p.into_inner()) = Some(why.clone());
                Refusal::Unavailable(why)
            })?;
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

    /// `owner`'s job `id`, with its live progress (none for another owner's job).
    pub fn get(&self, owner: &Owner, id: &str) -> Option<JobRecord> {
        self.sweep();
        let inner = self.lock();
        let entry = inner
            .jobs
            .get(id)
            .filter(|e| e.record.owner == owner.name())?;
        let mut r = entry.record.clone();
        if let Some(p) = &entry.progress {
            r.progress = p.percent().min(99);
        }
        Some(r)
    }

    /// `owner`'s jobs, newest first.
    pub fn list(&self, owner: &Owner) -> Vec<JobRecord> {
        self.sweep();
        let inner = self.lock();
        let mut v: Vec<JobRecord> = inner
            .jobs
            .values()
            .filter(|e| e.record.owner == owner.name())
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

    /// Dismisses `owner`'s job `id`: its work is cancelled, its files deleted and its bytes
    /// freed (none for another owner's job).
    pub fn dismiss(&self, owner: &Owner, id: &str) -> Option<JobRecord> {
        let mut inner = self.lock();
        if inner
            .jobs
            .get(id)
            .is_none_or(|e| e.record.owner != owner.name())
        {
            return None;
        }
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
    use super::super::store::MAX_MESSAGE;
    use super::*;
    use crate::service::auth::Owner;

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

    fn job(store: &DiskStore) -> Result<JobRecord, Refusal> {
        store.create(
            &Owner::anonymous(),
            "fit",
            Cancel::default(),
            Arc::default(),
        )
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
        let store = DiskStore::open(&config(&dir, 3 * STATUS_RESERVE + 100));
        let a = job(&store).unwrap();
        store.start(&a.id);
        store.succeed(&a.id, &[b'x'; 200], "application/geo+json", 1, 1);
        let r = store.get(&Owner::anonymous(), &a.id).unwrap();
        assert_eq!(r.status, Status::Successful);
        assert_eq!(store.used_bytes(), STATUS_RESERVE + 200);
        // A result over the room left fails its job and writes nothing.
        let b = job(&store).unwrap();
        store.succeed(&b.id, &[b'x'; 5000], "application/geo+json", 1, 1);
        let r = store.get(&Owner::anonymous(), &b.id).unwrap();
        assert_eq!(r.status, Status::Failed);
        assert!(r.message.unwrap().contains("does not fit"));
        assert!(!store.result_path(&b.id).exists());
        // No room for a third status file.
        assert!(matches!(job(&store), Err(Refusal::Full { .. })));
        store.dismiss(&Owner::anonymous(), &a.id).unwrap();
        assert!(!store.result_path(&a.id).exists());
        assert_eq!(store.used_bytes(), STATUS_RESERVE);
        assert!(job(&store).is_ok());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn unfinished_jobs_are_bounded() {
        let dir = scratch("bound");
        let store = DiskStore::open(&config(&dir, 1 << 20));
        let a = job(&store).unwrap();
        job(&store).unwrap();
        assert_eq!(job(&store), Err(Refusal::TooManyJobs(2)));
        store.fail(&a.id, "x".repeat(10_000));
        assert_eq!(
            store
                .get(&Owner::anonymous(), &a.id)
                .unwrap()
                .message
                .unwrap()
                .len(),
            MAX_MESSAGE
        );
        assert!(job(&store).is_ok());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_restart_keeps_results_and_fails_unfinished_jobs() {
        let dir = scratch("restart");
        let store = DiskStore::open(&config(&dir, 1 << 20));
        let done = job(&store).unwrap();
        store.succeed(&done.id, b"{}", "application/geo+json", 3, 1);
        let running = job(&store).unwrap();
        store.start(&running.id);
        drop(store);
        let store = DiskStore::open(&config(&dir, 1 << 20));
        assert_eq!(
            store.get(&Owner::anonymous(), &done.id).unwrap().status,
            Status::Successful
        );
        assert_eq!(std::fs::read(store.result_path(&done.id)).unwrap(), b"{}");
        let r = store.get(&Owner::anonymous(), &running.id).unwrap();
        assert_eq!(r.status, Status::Failed);
        assert!(r.message.unwrap().contains("stopped"));
        assert_eq!(store.used_bytes(), 2 * STATUS_RESERVE + 2);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn an_unwritable_directory_refuses_jobs_until_it_can_be_written() {
        // Root ignores permissions: a data directory under a regular file cannot be made.
        let dir = scratch("unwritable");
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("file");
        std::fs::write(&file, b"x").unwrap();
        let store = DiskStore::open(&config(&file.join("data"), 1 << 20));
        match store.refusal(&Owner::anonymous()) {
            Some(Refusal::Unavailable(why)) => assert!(why.contains("file"), "{why}"),
            other => panic!("{other:?}"),
        }
        assert!(matches!(job(&store), Err(Refusal::Unavailable(_))));
        // Made writable: the next check finds out, without a restart.
        std::fs::remove_file(&file).unwrap();
        assert_eq!(store.refusal(&Owner::anonymous()), None);
        assert!(job(&store).is_ok());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn owners_see_their_own_jobs_only_and_have_their_own_bound() {
        let dir = scratch("owners");
        let mut c = config(&dir, 1 << 20);
        c.max_jobs = 3;
        c.max_owner_jobs = 2;
        let store = DiskStore::open(&c);
        let (alice, bob) = (Owner::named("alice"), Owner::named("bob"));
        let new = |o: &Owner| store.create(o, "fit", Cancel::default(), Arc::default());
        let a = new(&alice).unwrap();
        new(&alice).unwrap();
        assert_eq!(new(&alice), Err(Refusal::TooManyOwnerJobs(2)));
        assert_eq!(store.refusal(&alice), Some(Refusal::TooManyOwnerJobs(2)));
        assert_eq!(store.refusal(&bob), None);
        let b = new(&bob).unwrap();
        assert_eq!(new(&bob), Err(Refusal::TooManyJobs(3)), "all owners' bound");
        assert!(store.get(&bob, &a.id).is_none());
        assert!(store.dismiss(&bob, &a.id).is_none(), "not bob's to dismiss");
        assert_eq!(store.get(&alice, &a.id).unwrap().owner, "alice");
        assert_eq!(store.list(&alice).len(), 2);
        let bobs: Vec<String> = store.list(&bob).into_iter().map(|r| r.id).collect();
        assert_eq!(bobs, vec![b.id.clone()]);
        assert!(store.dismiss(&alice, &a.id).is_some());
        // A restart keeps the owners.
        drop(store);
        let store = DiskStore::open(&c);
        assert_eq!(store.get(&bob, &b.id).unwrap().owner, "bob");
        assert!(store.get(&alice, &b.id).is_none());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn finished_jobs_expire() {
        let dir = scratch("expiry");
        let mut c = config(&dir, 1 << 20);
        c.job_expiry = Duration::from_millis(50);
        let store = DiskStore::open(&c);
        let a = job(&store).unwrap();
        store.succeed(&a.id, b"{}", "application/geo+json", 1, 1);
        let b = job(&store).unwrap();
        std::thread::sleep(Duration::from_millis(80));
        assert!(store.get(&Owner::anonymous(), &a.id).is_none(), "expired");
        assert!(!store.result_path(&a.id).exists());
        assert!(
            store.get(&Owner::anonymous(), &b.id).is_some(),
            "unfinished jobs do not expire"
        );
        assert_eq!(store.used_bytes(), STATUS_RESERVE);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
