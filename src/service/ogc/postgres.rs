//! The job store in PostgreSQL (`spherefit serve --job-store postgres://…`): every replica of
//! the service reads and writes the same jobs, so a job posted to one replica is run by
//! whichever has a free fitting slot, and its status, result, collection and dismissal answer
//! the same from all of them.
//!
//! # Tables
//! [`MIGRATIONS`] are applied at start, in one transaction under an advisory lock (two
//! replicas starting at once apply them once); `schema_version` records each one applied. A
//! job is one row of `jobs`: its owner, status, progress, the checked execute request while it
//! waits or runs (`input`), and its result (`result`), both compressed (zlib, flate2's
//! pure-Rust backend). Times are Unix seconds of the database's clock, so replicas agree.
//!
//! # Bounds
//! The same as the disk store's: `store_bytes` bounds the bytes held (per job
//! [`STATUS_RESERVE`] plus its compressed request while it waits or runs, plus its compressed
//! result once it succeeded), checked before each write; `max_jobs` bounds the unfinished jobs
//! of all replicas and `max_owner_jobs` those of one owner (admissions are serialised by an
//! advisory lock, so two replicas cannot both take the last place); finished jobs expire after
//! `job_expiry`.
//!
//! # The queue
//! A posted job is `accepted`. Each replica's worker, when it holds a free fitting slot, claims
//! the oldest job that is `accepted` or whose lease ran out (`SELECT … FOR UPDATE SKIP LOCKED`,
//! so two replicas never claim the same one) and marks it `running` under its own name with a
//! lease (`lease_until`), renewed by a heartbeat while the work runs. A replica that dies stops
//! renewing; once its lease has run out any replica claims the job again, up to
//! [`MAX_ATTEMPTS`] times, after which it is `failed` saying why. Every write of a running job
//! requires the claim to still be the writer's, so a replica that lost its claim cannot
//! overwrite the job, and a dismissed job's heartbeat finds it gone and cancels the work.
//!
//! # Failures
//! Every call is bounded in time (pool and connection timeouts, and [`OP_TIMEOUT`] around
//! each operation); a database that cannot be reached gives [`Refusal::Unavailable`] (503
//! `store-unavailable`) at once, and the pool reconnects when it is back.

use crate::service::auth::Owner;
use crate::service::ogc::store::{cut, new_id, JobRecord, Refusal, Status, STATUS_RESERVE};
use crate::service::ServiceConfig;
use deadpool_postgres::{Manager, ManagerConfig, Pool, RecyclingMethod, Runtime};
use flate2::read::ZlibDecoder;
use flate2::write::ZlibEncoder;
use flate2::Compression;
use std::io::{Read, Write};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};
use tokio::sync::Notify;
use tokio_postgres::Row;

/// How many times a job is started before it is failed for good: each start after the first
/// is because the replica running it stopped renewing its lease (killed, or cut off from the
/// database), and a job that takes every replica that runs it down should not go on doing so.
pub const MAX_ATTEMPTS: i32 = 3;

/// The schema, one migration per entry; `schema_version` holds how many were applied.
pub const MIGRATIONS: &[&str] = &[
    // 1: jobs and the queue's indexes.
    "CREATE TABLE jobs (
        id text PRIMARY KEY,
        owner text NOT NULL,
        process text NOT NULL,
        status text NOT NULL,
        message text,
        created double precision NOT NULL,
        started double precision,
        finished double precision,
        progress smallint NOT NULL DEFAULT 0,
        media_type text,
        result_bytes bigint NOT NULL DEFAULT 0,
        input_points bigint NOT NULL DEFAULT 0,
        curves bigint NOT NULL DEFAULT 0,
        input bytea,
        result bytea,
        stored_bytes bigint NOT NULL,
        attempts integer NOT NULL DEFAULT 0,
        worker text,
        lease_until double precision
     );
     CREATE INDEX jobs_owner ON jobs (owner, created DESC);
     CREATE INDEX jobs_queue ON jobs (created) WHERE status IN ('accepted', 'running');
     CREATE INDEX jobs_finished ON jobs (finished) WHERE finished IS NOT NULL;",
];

/// Advisory lock key of the migrations.
const MIGRATION_LOCK: i64 = 0x5350_4846_0001;
/// Advisory lock key of admissions and result writes (the byte and job bounds).
const ADMISSION_LOCK: i64 = 0x5350_4846_0002;

/// Longest wait for a pooled connection, or to open one.
const POOL_TIMEOUT: Duration = Duration::from_secs(2);
/// Longest time any one store operation may take (results included).
pub const OP_TIMEOUT: Duration = Duration::from_secs(30);
/// Connections per replica.
const POOL_SIZE: usize = 16;
/// Finished jobs past their expiry are deleted at most this often per replica (they are
/// hidden from reads at once).
const SWEEP_EVERY_S: f64 = 1.0;

/// The database's clock, Unix seconds.
macro_rules! now {
    () => {
        "extract(epoch from clock_timestamp())::float8"
    };
}

/// The columns of a [`JobRecord`], in [`record`]'s order.
macro_rules! record_columns {
    () => {
        "id, owner, process, status, message, created, started, finished, progress, media_type, result_bytes, input_points, curves"
    };
}

/// A job this replica claimed: what it needs to run it.
#[derive(Debug)]
pub(crate) struct Claim {
    pub id: String,
    pub process: String,
    /// The checked execute request (decompressed).
    pub input: Vec<u8>,
}

/// The PostgreSQL job store (module docs); clones share the pool.
#[derive(Clone)]
pub(crate) struct PgStore(Arc<Pg>);

pub(crate) struct Pg {
    pool: Pool,
    /// This replica's name in `jobs.worker`.
    worker: String,
    budget: i64,
    expiry_s: f64,
    lease_s: f64,
    max_jobs: i64,
    max_owner_jobs: i64,
    /// Wakes this replica's worker when a job is posted here.
    posted: Notify,
    /// When expired jobs were last deleted (bits of an f64, Unix seconds).
    last_sweep: AtomicU64,
}

impl std::fmt::Debug for PgStore {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // Not the URL: it may hold a password.
        f.debug_struct("PgStore")
            .field("worker", &self.0.worker)
            .finish()
    }
}

/// A database error in a few words (the server's message when it sent one).
fn describe(e: &tokio_postgres::Error) -> String {
    if let Some(db) = e.as_db_error() {
        return format!("{} ({})", db.message(), db.code().code());
    }
    match std::error::Error::source(e) {
        Some(s) => format!("{e}: {s}"),
        None => e.to_string(),
    }
}

fn unavailable(e: impl std::fmt::Display) -> Refusal {
    Refusal::Unavailable(format!("PostgreSQL: {e}"))
}

/// `host:port/dbname` of a URL's configuration, for messages (never the password).
fn place(c: &tokio_postgres::Config) -> String {
    let host = c
        .get_hosts()
        .first()
        .map(|h| match h {
            tokio_postgres::config::Host::Tcp(s) => s.clone(),
            #[cfg(unix)]
            tokio_postgres::config::Host::Unix(p) => p.display().to_string(),
        })
        .unwrap_or_else(|| "localhost".into());
    let port = c.get_ports().first().copied().unwrap_or(5432);
    format!("{host}:{port}/{}", c.get_dbname().unwrap_or(""))
}

fn compress(bytes: &[u8]) -> Vec<u8> {
    let mut e = ZlibEncoder::new(Vec::with_capacity(bytes.len() / 4), Compression::fast());
    // Writing to a Vec cannot fail.
    let _ = e.write_all(bytes);
    e.finish().unwrap_or_default()
}

/// Decompresses `bytes`, expecting at most `limit` bytes out.
fn decompress(bytes: &[u8], limit: u64) -> Result<Vec<u8>, String> {
    let mut out = Vec::new();
    ZlibDecoder::new(bytes)
        .take(limit.saturating_add(1))
        .read_to_end(&mut out)
        .map_err(|e| format!("a stored job's data cannot be decompressed: {e}"))?;
    if out.len() as u64 > limit {
        return Err("a stored job's data is larger than recorded".into());
    }
    Ok(out)
}

/// The record of a row selected with [`record_columns`].
fn record(row: &Row) -> Result<JobRecord, String> {
    let status: String = row.try_get(3).map_err(|e| describe(&e))?;
    let r = || -> Result<JobRecord, tokio_postgres::Error> {
        Ok(JobRecord {
            id: row.try_get(0)?,
            owner: row.try_get(1)?,
            process: row.try_get(2)?,
            status: Status::Failed,
            message: row.try_get(4)?,
            created_s: row.try_get(5)?,
            started_s: row.try_get(6)?,
            finished_s: row.try_get(7)?,
            progress: u8::try_from(row.try_get::<_, i16>(8)?.clamp(0, 100)).unwrap_or(0),
            media_type: row.try_get(9)?,
            result_bytes: u64::try_from(row.try_get::<_, i64>(10)?).unwrap_or(0),
            input_points: usize::try_from(row.try_get::<_, i64>(11)?).unwrap_or(0),
            curves: usize::try_from(row.try_get::<_, i64>(12)?).unwrap_or(0),
        })
    };
    let mut rec = r().map_err(|e| describe(&e))?;
    rec.status = Status::parse(&status).ok_or_else(|| format!("unknown job status {status:?}"))?;
    Ok(rec)
}

/// Runs `f` within [`OP_TIMEOUT`].
async fn bounded<T>(f: impl std::future::Future<Output = Result<T, String>>) -> Result<T, String> {
    tokio::time::timeout(OP_TIMEOUT, f)
        .await
        .unwrap_or_else(|_| Err(format!("no answer within {} s", OP_TIMEOUT.as_secs())))
}

impl PgStore {
    /// Connects to the database at `url`, applies the [`MIGRATIONS`] it lacks, and returns the
    /// store; retries for at most `wait` while the database cannot be reached.
    ///
    /// # Errors
    /// A URL that is not a PostgreSQL one, a database that stays unreachable for `wait`, or a
    /// schema newer than this program's.
    pub async fn open(
        url: &str,
        config: &ServiceConfig,
        wait: Duration,
    ) -> Result<PgStore, String> {
        let mut pg: tokio_postgres::Config = url.parse().map_err(|e| {
            format!("the job store URL is not a PostgreSQL URL (postgres://USER:PASSWORD@HOST:PORT/DATABASE): {e}")
        })?;
        pg.connect_timeout(POOL_TIMEOUT);
        pg.keepalives(true);
        pg.keepalives_idle(Duration::from_secs(30));
        if pg.get_application_name().is_none() {
            pg.application_name("spherefit");
        }
        let at = place(&pg);
        let manager = Manager::from_config(
            pg,
            tokio_postgres::NoTls,
            ManagerConfig {
                recycling_method: RecyclingMethod::Fast,
            },
        );
        let pool = Pool::builder(manager)
            .max_size(POOL_SIZE)
            .runtime(Runtime::Tokio1)
            .wait_timeout(Some(POOL_TIMEOUT))
            .create_timeout(Some(POOL_TIMEOUT))
            .recycle_timeout(Some(POOL_TIMEOUT))
            .build()
            .map_err(|e| format!("cannot make the PostgreSQL pool: {e}"))?;
        let store = PgStore(Arc::new(Pg {
            pool,
            worker: new_id(),
            budget: i64::try_from(config.store_bytes).unwrap_or(i64::MAX),
            expiry_s: config.job_expiry.as_secs_f64(),
            lease_s: config.job_lease.as_secs_f64(),
            max_jobs: config.max_jobs.max(1) as i64,
            max_owner_jobs: config.max_owner_jobs.max(1) as i64,
            posted: Notify::new(),
            last_sweep: AtomicU64::new(0),
        }));
        let start = Instant::now();
        loop {
            match bounded(store.migrate()).await {
                Ok(version) => {
                    tracing::info!(database = %at, schema_version = version, "job store in PostgreSQL");
                    return Ok(store);
                }
                Err(why) if why.starts_with("schema") => return Err(why),
                Err(why) if start.elapsed() >= wait => {
                    return Err(format!(
                        "cannot open the job store in PostgreSQL at {at} within {} s: {why}",
                        wait.as_secs_f64()
                    ))
                }
                Err(why) => {
                    tracing::warn!(database = %at, error = %why, "waiting for PostgreSQL");
                    tokio::time::sleep(Duration::from_millis(500)).await;
                }
            }
        }
    }

    async fn client(&self) -> Result<deadpool_postgres::Object, String> {
        self.0.pool.get().await.map_err(|e| match e {
            deadpool_postgres::PoolError::Backend(e) => describe(&e),
            e => e.to_string(),
        })
    }

    /// Applies the migrations the database lacks; returns the schema version.
    async fn migrate(&self) -> Result<usize, String> {
        let mut client = self.client().await?;
        let tx = client.transaction().await.map_err(|e| describe(&e))?;
        tx.batch_execute(&format!(
            "SELECT pg_advisory_xact_lock({MIGRATION_LOCK});
             CREATE TABLE IF NOT EXISTS schema_version (
                 version integer PRIMARY KEY,
                 applied double precision NOT NULL
             );"
        ))
        .await
        .map_err(|e| describe(&e))?;
        let row = tx
            .query_one("SELECT coalesce(max(version), 0) FROM schema_version", &[])
            .await
            .map_err(|e| describe(&e))?;
        let current = usize::try_from(row.get::<_, i32>(0)).unwrap_or(0);
        if current > MIGRATIONS.len() {
            return Err(format!(
                "schema version {current} of the database is newer than this program's ({}): run a newer spherefit",
                MIGRATIONS.len()
            ));
        }
        for (i, m) in MIGRATIONS.iter().enumerate().skip(current) {
            tx.batch_execute(m).await.map_err(|e| describe(&e))?;
            let version = i32::try_from(i + 1).unwrap_or(i32::MAX);
            tx.execute(
                concat!(
                    "INSERT INTO schema_version (version, applied) VALUES ($1, ",
                    now!(),
                    ")"
                ),
                &[&version],
            )
            .await
            .map_err(|e| describe(&e))?;
        }
        tx.commit().await.map_err(|e| describe(&e))?;
        Ok(MIGRATIONS.len())
    }

    /// Deletes the finished jobs past their expiry, at most every [`SWEEP_EVERY_S`].
    async fn sweep(&self, client: &deadpool_postgres::Object) -> Result<(), String> {
        let now = super::store::now_s();
        let last = f64::from_bits(self.0.last_sweep.load(Ordering::Relaxed));
        if now - last < SWEEP_EVERY_S {
            return Ok(());
        }
        self.0.last_sweep.store(now.to_bits(), Ordering::Relaxed);
        client
            .execute(
                concat!(
                    "DELETE FROM jobs WHERE finished IS NOT NULL AND finished + $1 <= ",
                    now!()
                ),
                &[&self.0.expiry_s],
            )
            .await
            .map_err(|e| describe(&e))?;
        Ok(())
    }

    /// Unfinished jobs of all owners and of `owner`, and bytes held.
    async fn counts(
        &self,
        client: &impl tokio_postgres::GenericClient,
        owner: &Owner,
    ) -> Result<(i64, i64, i64), String> {
        let row = client
            .query_one(
                "SELECT count(*) FILTER (WHERE status IN ('accepted', 'running')),
                        count(*) FILTER (WHERE status IN ('accepted', 'running') AND owner = $1),
                        coalesce(sum(stored_bytes), 0)::bigint
                 FROM jobs",
                &[&owner.name()],
            )
            .await
            .map_err(|e| describe(&e))?;
        Ok((row.get(0), row.get(1), row.get(2)))
    }

    fn admission(&self, (active, own, used): (i64, i64, i64), adding: i64) -> Result<(), Refusal> {
        let p = &self.0;
        if active >= p.max_jobs {
            return Err(Refusal::TooManyJobs(p.max_jobs as usize));
        }
        if own >= p.max_owner_jobs {
            return Err(Refusal::TooManyOwnerJobs(p.max_owner_jobs as usize));
        }
        if used.saturating_add(adding) > p.budget {
            return Err(Refusal::Full {
                used: used.max(0) as u64,
                budget: p.budget.max(0) as u64,
            });
        }
        Ok(())
    }

    /// Why a new job of `owner` would be refused now, if it would.
    pub async fn refusal(&self, owner: &Owner) -> Option<Refusal> {
        let r = bounded(async {
            let client = self.client().await?;
            self.sweep(&client).await?;
            self.counts(&**client, owner).await
        })
        .await;
        match r {
            Ok(c) => self.admission(c, STATUS_RESERVE as i64).err(),
            Err(why) => Some(unavailable(why)),
        }
    }

    /// Adds a job of `owner` running `process` on the checked request `input` (status
    /// `accepted`) and wakes this replica's worker.
    ///
    /// # Errors
    /// The bounds ([`Refusal`]), or [`Refusal::Unavailable`].
    pub async fn enqueue(
        &self,
        owner: &Owner,
        process: &str,
        input: &[u8],
    ) -> Result<JobRecord, Refusal> {
        let raw = input.to_vec();
        let packed = tokio::task::spawn_blocking(move || compress(&raw))
            .await
            .map_err(unavailable)?;
        let stored = STATUS_RESERVE as i64 + packed.len() as i64;
        let id = new_id();
        let r = bounded(async {
            let mut client = self.client().await?;
            self.sweep(&client).await?;
            let tx = client.transaction().await.map_err(|e| describe(&e))?;
            tx.execute("SELECT pg_advisory_xact_lock($1)", &[&ADMISSION_LOCK])
                .await
                .map_err(|e| describe(&e))?;
            let counts = self.counts(&*tx, owner).await?;
            if let Err(refused) = self.admission(counts, stored) {
                return Ok(Err(refused));
            }
            let row = tx
                .query_one(
                    concat!(
                        "INSERT INTO jobs (id, owner, process, status, created, input, stored_bytes)
                         VALUES ($1, $2, $3, 'accepted', ",
                        now!(),
                        ", $4, $5) RETURNING ",
                        record_columns!()
                    ),
                    &[&id, &owner.name(), &process, &packed, &stored],
                )
                .await
                .map_err(|e| describe(&e))?;
            tx.commit().await.map_err(|e| describe(&e))?;
            Ok(Ok(record(&row)?))
        })
        .await;
        let rec = r.map_err(unavailable)??;
        self.0.posted.notify_one();
        Ok(rec)
    }

    /// `owner`'s job `id` (none for another owner's, or an expired one).
    ///
    /// # Errors
    /// [`Refusal::Unavailable`].
    pub async fn get(&self, owner: &Owner, id: &str) -> Result<Option<JobRecord>, Refusal> {
        bounded(async {
            let client = self.client().await?;
            let row = client
                .query_opt(
                    concat!(
                        "SELECT ",
                        record_columns!(),
                        " FROM jobs WHERE id = $1 AND owner = $2
                          AND (finished IS NULL OR finished + $3 > ",
                        now!(),
                        ")"
                    ),
                    &[&id, &owner.name(), &self.0.expiry_s],
                )
                .await
                .map_err(|e| describe(&e))?;
            row.as_ref().map(record).transpose()
        })
        .await
        .map_err(unavailable)
    }

    /// `owner`'s jobs, newest first.
    ///
    /// # Errors
    /// [`Refusal::Unavailable`].
    pub async fn list(&self, owner: &Owner) -> Result<Vec<JobRecord>, Refusal> {
        bounded(async {
            let client = self.client().await?;
            self.sweep(&client).await?;
            let rows = client
                .query(
                    concat!(
                        "SELECT ",
                        record_columns!(),
                        " FROM jobs WHERE owner = $1
                          AND (finished IS NULL OR finished + $2 > ",
                        now!(),
                        ") ORDER BY created DESC, id"
                    ),
                    &[&owner.name(), &self.0.expiry_s],
                )
                .await
                .map_err(|e| describe(&e))?;
            rows.iter().map(record).collect()
        })
        .await
        .map_err(unavailable)
    }

    /// Deletes `owner`'s job `id` and its result (a replica running it finds it gone at its
    /// next heartbeat and cancels the work).
    ///
    /// # Errors
    /// [`Refusal::Unavailable`].
    pub async fn dismiss(&self, owner: &Owner, id: &str) -> Result<Option<JobRecord>, Refusal> {
        bounded(async {
            let client = self.client().await?;
            let row = client
                .query_opt(
                    concat!(
                        "DELETE FROM jobs WHERE id = $1 AND owner = $2 RETURNING ",
                        record_columns!()
                    ),
                    &[&id, &owner.name()],
                )
                .await
                .map_err(|e| describe(&e))?;
            let Some(row) = row else { return Ok(None) };
            let mut r = record(&row)?;
            r.status = Status::Dismissed;
            r.message = Some("dismissed by a client".into());
            Ok(Some(r))
        })
        .await
        .map_err(unavailable)
    }

    /// The result of `owner`'s successful job `id`, decompressed.
    ///
    /// # Errors
    /// [`Refusal::Unavailable`].
    pub async fn result(&self, owner: &Owner, id: &str) -> Result<Option<Vec<u8>>, Refusal> {
        let row = bounded(async {
            let client = self.client().await?;
            client
                .query_opt(
                    "SELECT result, result_bytes FROM jobs
                     WHERE id = $1 AND owner = $2 AND status = 'successful' AND result IS NOT NULL",
                    &[&id, &owner.name()],
                )
                .await
                .map_err(|e| describe(&e))
        })
        .await
        .map_err(unavailable)?;
        let Some(row) = row else { return Ok(None) };
        let packed: Vec<u8> = row.get(0);
        let len = u64::try_from(row.get::<_, i64>(1)).unwrap_or(0);
        tokio::task::spawn_blocking(move || decompress(&packed, len))
            .await
            .map_err(unavailable)?
            .map(Some)
            .map_err(unavailable)
    }

    /// Waits until a job is posted to this replica, or for `poll`.
    pub async fn wait_for_work(&self, poll: Duration) {
        let _ = tokio::time::timeout(poll, self.0.posted.notified()).await;
    }

    /// Claims the oldest job that waits or whose lease ran out (failing first those that
    /// used up their [`MAX_ATTEMPTS`]); none when there is none.
    ///
    /// # Errors
    /// The database cannot be used.
    pub async fn claim(&self) -> Result<Option<Claim>, String> {
        let row = bounded(async {
            let client = self.client().await?;
            self.sweep(&client).await?;
            let given_up = cut(format!(
                "the job was started {MAX_ATTEMPTS} times and each time the replica running it stopped before it finished (it did not renew its lease): it is not started again"
            ));
            client
                .execute(
                    concat!(
                        "UPDATE jobs SET status = 'failed', message = $1, finished = ",
                        now!(),
                        ", input = NULL, stored_bytes = $3, worker = NULL, lease_until = NULL
                         WHERE status = 'running' AND lease_until < ",
                        now!(),
                        " AND attempts >= $2"
                    ),
                    &[&given_up, &MAX_ATTEMPTS, &(STATUS_RESERVE as i64)],
                )
                .await
                .map_err(|e| describe(&e))?;
            client
                .query_opt(
                    concat!(
                        "UPDATE jobs SET status = 'running', attempts = attempts + 1, worker = $1,
                             lease_until = ",
                        now!(),
                        " + $2, started = coalesce(started, ",
                        now!(),
                        "), progress = 0
                         WHERE id = (
                             SELECT id FROM jobs
                             WHERE (status = 'accepted' OR (status = 'running' AND lease_until < ",
                        now!(),
                        ")) AND attempts < $3
                             ORDER BY created LIMIT 1 FOR UPDATE SKIP LOCKED)
                         RETURNING id, process, input, attempts, stored_bytes"
                    ),
                    &[&self.0.worker, &self.0.lease_s, &MAX_ATTEMPTS],
                )
                .await
                .map_err(|e| describe(&e))
        })
        .await?;
        let Some(row) = row else { return Ok(None) };
        let id: String = row.get(0);
        let packed: Option<Vec<u8>> = row.get(2);
        let attempt: i32 = row.get(3);
        let stored: i64 = row.get(4);
        if attempt > 1 {
            tracing::warn!(job = %id, attempt, "taking up a job whose replica stopped renewing its lease");
        }
        // The request is at most the stored bytes' worth of compressed data; its
        // decompressed size is bounded by the body limit it passed when posted.
        let limit = u64::try_from(stored)
            .unwrap_or(0)
            .saturating_mul(1032)
            .max(1 << 20);
        let input = match packed {
            Some(p) => tokio::task::spawn_blocking(move || decompress(&p, limit))
                .await
                .map_err(|e| e.to_string())?,
            None => Err("the job's request is missing".into()),
        };
        match input {
            Ok(input) => Ok(Some(Claim {
                id,
                process: row.get(1),
                input,
            })),
            Err(why) => {
                self.fail(&id, &why).await?;
                Ok(None)
            }
        }
    }

    /// Renews this replica's lease on job `id` and writes its progress; false when the job is
    /// no longer this replica's (dismissed, or taken over).
    ///
    /// # Errors
    /// The database cannot be used.
    pub async fn renew(&self, id: &str, progress: u8) -> Result<bool, String> {
        bounded(async {
            let client = self.client().await?;
            let n = client
                .execute(
                    concat!(
                        "UPDATE jobs SET lease_until = ",
                        now!(),
                        " + $2, progress = $3
                         WHERE id = $1 AND worker = $4 AND status = 'running'"
                    ),
                    &[&id, &self.0.lease_s, &i16::from(progress), &self.0.worker],
                )
                .await
                .map_err(|e| describe(&e))?;
            Ok(n == 1)
        })
        .await
    }

    /// Job `id` failed: `why` says why (nothing when it is no longer this replica's).
    ///
    /// # Errors
    /// The database cannot be used.
    pub async fn fail(&self, id: &str, why: &str) -> Result<(), String> {
        let message = cut(why.to_string());
        bounded(async {
            let client = self.client().await?;
            client
                .execute(
                    concat!(
                        "UPDATE jobs SET status = 'failed', message = $2, finished = ",
                        now!(),
                        ", input = NULL, stored_bytes = $3, worker = NULL, lease_until = NULL
                         WHERE id = $1 AND worker = $4 AND status = 'running'"
                    ),
                    &[&id, &message, &(STATUS_RESERVE as i64), &self.0.worker],
                )
                .await
                .map_err(|e| describe(&e))?;
            Ok(())
        })
        .await
    }

    /// Job `id` succeeded with `bytes` of `media_type`: stored compressed if the store has
    /// room (checked before writing, under the admission lock), else the job fails saying so.
    ///
    /// # Errors
    /// The database cannot be used.
    pub async fn succeed(
        &self,
        id: &str,
        bytes: &[u8],
        media_type: &str,
        input_points: usize,
        curves: usize,
    ) -> Result<(), String> {
        let raw = bytes.to_vec();
        let len = raw.len() as i64;
        let packed = tokio::task::spawn_blocking(move || compress(&raw))
            .await
            .map_err(|e| e.to_string())?;
        let stored = STATUS_RESERVE as i64 + packed.len() as i64;
        let too_big = bounded(async {
            let mut client = self.client().await?;
            let tx = client.transaction().await.map_err(|e| describe(&e))?;
            tx.execute("SELECT pg_advisory_xact_lock($1)", &[&ADMISSION_LOCK])
                .await
                .map_err(|e| describe(&e))?;
            let used: i64 = tx
                .query_one(
                    "SELECT coalesce(sum(stored_bytes), 0)::bigint FROM jobs WHERE id <> $1",
                    &[&id],
                )
                .await
                .map_err(|e| describe(&e))?
                .get(0);
            if used.saturating_add(stored) > self.0.budget {
                return Ok(Some(format!(
                    "the result ({len} bytes, {} compressed) does not fit in the job store ({used} of {} bytes used): dismiss finished jobs or ask for a smaller output",
                    packed.len(),
                    self.0.budget
                )));
            }
            tx.execute(
                concat!(
                    "UPDATE jobs SET status = 'successful', progress = 100, finished = ",
                    now!(),
                    ", media_type = $2, result_bytes = $3, input_points = $4, curves = $5,
                       result = $6, input = NULL, stored_bytes = $7, worker = NULL, lease_until = NULL
                     WHERE id = $1 AND worker = $8 AND status = 'running'"
                ),
                &[
                    &id,
                    &media_type,
                    &len,
                    &(input_points as i64),
                    &(curves as i64),
                    &packed,
                    &stored,
                    &self.0.worker,
                ],
            )
            .await
            .map_err(|e| describe(&e))?;
            tx.commit().await.map_err(|e| describe(&e))?;
            Ok(None)
        })
        .await?;
        match too_big {
            Some(why) => self.fail(id, &why).await,
            None => Ok(()),
        }
    }
}

#[cfg(test)]
#[path = "postgres_tests.rs"]
mod tests;
