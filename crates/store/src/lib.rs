//! The store: the database (through `sqlx`) that keeps everything needed to
//! audit a number later — instruments, sessions, measurements with **every
//! raw sample**, renders, and comparisons. Two engines sit behind one
//! [`Store`]: an SQLite file (`sqlite://lab.sqlite`, the one-booth default)
//! and a PostgreSQL server (`postgres://user@host/db`, for a lab whose
//! booths share one database).
//!
//! How the two engines share the code: an engine enum ([`engine`]) holds
//! either a `SqlitePool` or a `PgPool`, and every query is written once, with
//! `$1, $2, …` placeholders (both engines accept them: SQLite reads `$N` as
//! the N-th argument) in SQL both dialects run, and passed through
//! `with_pool!`, which compiles the same statement for each engine's own
//! driver. Rows are mapped by `#[derive(sqlx::FromRow)]` records (`rows.rs`).
//! `sqlx::Any` was the alternative and was not taken: its values go through
//! a lowest common type set where a `bool` decodes only from a boolean
//! column (SQLite keeps flags as 0/1 INTEGER, so `usable` would not decode),
//! every row is copied into that set before it is read, and it gives no
//! typed SQLite connection options (WAL, `synchronous`, foreign keys).
//! With the enum each engine keeps its native types and options, and SQL
//! that genuinely differs (only the migrations, today) is written per
//! engine.
//!
//! - Migrations are embedded in the binary and applied when the store
//!   opens: `migrations/sqlite/` and `migrations/postgres/`, one file per
//!   version in each, kept in step (a test applies both sets and compares
//!   the tables and columns they make). SQLite runs in WAL mode with foreign
//!   keys on and `synchronous = FULL` (a committed sample survives power
//!   loss); PostgreSQL commits durably by default.
//! - A sample is written when it is taken, so a crash or a pulled cable keeps
//!   the samples taken; a measurement is `complete` only with its average
//!   (the schema enforces it), and measurements left `running` or `queued` by
//!   a crash are marked `interrupted` when a daemon next opens the store
//!   ([`Store::open_recovering`]), as are renders and studies left `queued`
//!   or `running`; any other command's open writes nothing.
//! - Reflectances and lamp spectra measured against a white standard keep
//!   their provenance (`calibrations`).
//! - Times are POSIX seconds (f64, UTC: DOUBLE PRECISION on PostgreSQL);
//!   spectra are JSON arrays of numbers (TEXT); flags are 0/1 INTEGER on
//!   SQLite and BOOLEAN on PostgreSQL.
//! - Recovery follows daemon leases (`leases.rs`, migration 0010): every
//!   daemon registers, heartbeats, and records itself on the work it creates
//!   or runs; at start and on every heartbeat a daemon marks interrupted only
//!   the unfinished work of daemons whose lease expired or that stopped (and,
//!   at start, rows naming no daemon) — never a live neighbour's. On SQLite
//!   one daemon owns the file (`lightbooth::daemon::db_lock`), so its opening
//!   recovers all unfinished work, as before leases.
//!
//! ```no_run
//! # async fn demo() -> anyhow::Result<()> {
//! let store = lightbooth_store::Store::open("sqlite://lightbooth.sqlite").await?;
//! let listing = store.list_measurements(&Default::default()).await?;
//! # Ok(()) }
//! ```

/// Runs `$body` once with `$pool` bound to the store's pool, whichever the
/// engine: the body is compiled for each engine's driver, so one statement
/// (with `$N` placeholders) serves both.
macro_rules! with_pool {
    ($store:expr, |$pool:ident| $body:expr) => {
        match &$store.engine {
            $crate::engine::Engine::Sqlite($pool) => $body,
            $crate::engine::Engine::Postgres($pool) => $body,
        }
    };
}

mod booth;
mod calibrations;
mod comparisons;
mod display_profiles;
pub mod engine;
mod experiments;
mod image_batches;
mod leases;
mod measurements;
pub use measurements::SIMULATED_TRUTH_KEY;
mod partial;
mod renders;
mod rows;
pub mod scene_bundles;
mod stimulus_sets;
mod studies;
pub mod worker_jobs;

use std::str::FromStr;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use serde::{Deserialize, Serialize};
use sqlx::sqlite::{SqlitePool, SqliteSynchronous};

use engine::Engine;

use lightbooth_science::colorimetry::Observer;

pub use booth::{Booth, DEFAULT_BOOTH};

/// The future every public method of [`Store`] returns: its body boxed
/// here, so that it is compiled once, in this crate. An `async fn`'s body
/// is compiled in each crate that awaits it (the lab, the app, the binary
/// and every test binary: `get_measurement`'s body was in the binary ten
/// times over); behind a `Box<dyn Future>` the crates above call it
/// through one vtable. The price is one allocation per database call.
pub type BoxFuture<'a, T> = std::pin::Pin<Box<dyn std::future::Future<Output = T> + Send + 'a>>;
pub use calibrations::*;
pub use display_profiles::*;
pub use experiments::{
    ExperimentRow, ExperimentSessionRow, NewExperiment, ObservedTrial, RunningSessionCounts, TrialRow,
};
pub use leases::{DaemonRow, InterruptedWork, Recovered, RecoveryScope};
pub use rows::*;
pub use stimulus_sets::{NewStimulusSet, StimulusSetBlob, StimulusSetRow, StimulusSetVerificationRow};
pub use worker_jobs::{ClaimedJob, WorkerJobKind, WorkerJobRecord};

/// Errors of the store, with what to do about them.
#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    #[error("database error: {0}")]
    Sql(#[from] sqlx::Error),
    #[error("cannot apply the database migrations: {0} (is this database from a newer lightbooth?)")]
    Migrate(#[from] sqlx::migrate::MigrateError),
    #[error("stored JSON is corrupt in {what}: {err}")]
    Corrupt { what: String, err: String },
    #[error("{0}")]
    Conflict(String),
    #[error("{0}")]
    Url(String),
}

impl StoreError {
    /// The database could not be reached or is not answering for now (a
    /// server that stopped, restarts or refuses connections, a pool with no
    /// connection to give, a busy SQLite file): the same statement may
    /// succeed later, unlike a refused or conflicting one.
    pub fn is_unavailable(&self) -> bool {
        let StoreError::Sql(e) = self else { return false };
        match e {
            sqlx::Error::Io(_)
            | sqlx::Error::Tls(_)
            | sqlx::Error::PoolTimedOut
            | sqlx::Error::PoolClosed
            | sqlx::Error::WorkerCrashed => true,
            // An unexpected end of the server's stream is reported as a protocol error.
            sqlx::Error::Protocol(_) => true,
            sqlx::Error::Database(db) => db.code().is_some_and(|code| {
                // PostgreSQL: class 08 (connection exception), 57P01–57P03
                // (administrator shutdown, crash shutdown, cannot connect
                // now), 53300 (too many connections). SQLite: 5 and 6 (busy,
                // locked).
                code.starts_with("08") || matches!(code.as_ref(), "57P01" | "57P02" | "57P03" | "53300" | "5" | "6")
            }),
            _ => false,
        }
    }
}

/// Seconds since the Unix epoch, UTC.
pub fn unix_seconds(t: SystemTime) -> f64 {
    t.duration_since(UNIX_EPOCH).unwrap_or(Duration::ZERO).as_secs_f64()
}

pub fn now() -> f64 {
    unix_seconds(SystemTime::now())
}

/// The measurement lifecycle. Only `queued → running → complete|failed|
/// interrupted|cancelled` transitions happen.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(rename_all = "lowercase")]
pub enum MeasurementState {
    Queued,
    Running,
    Complete,
    Failed,
    Interrupted,
    Cancelled,
}

impl MeasurementState {
    pub fn as_str(self) -> &'static str {
        match self {
            MeasurementState::Queued => "queued",
            MeasurementState::Running => "running",
            MeasurementState::Complete => "complete",
            MeasurementState::Failed => "failed",
            MeasurementState::Interrupted => "interrupted",
            MeasurementState::Cancelled => "cancelled",
        }
    }

    /// True once nothing more will happen to the measurement.
    pub fn is_final(self) -> bool {
        !matches!(self, MeasurementState::Queued | MeasurementState::Running)
    }
}

impl FromStr for MeasurementState {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Ok(match s {
            "queued" => MeasurementState::Queued,
            "running" => MeasurementState::Running,
            "complete" => MeasurementState::Complete,
            "failed" => MeasurementState::Failed,
            "interrupted" => MeasurementState::Interrupted,
            "cancelled" => MeasurementState::Cancelled,
            other => return Err(format!("unknown measurement state `{other}`")),
        })
    }
}

/// The two kinds of background job besides measurements: renders and
/// studies share the lifecycle `queued → running → complete | failed |
/// interrupted | cancelled`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Job {
    Render,
    Study,
}

impl Job {
    /// The table (and API collection) name.
    pub fn table(self) -> &'static str {
        match self {
            Job::Render => "renders",
            Job::Study => "studies",
        }
    }

    pub fn noun(self) -> &'static str {
        match self {
            Job::Render => "render",
            Job::Study => "study",
        }
    }
}

/// What a second retry of `job` `id` answers: it was retried as `first`
/// (one retry per job; retry `first` if it did not complete).
pub fn already_retried_message(job: Job, id: i64, first: i64) -> String {
    let noun = job.noun();
    format!(
        "{noun} {id} was already retried as {noun} {first} (/api/{}/{first}); one retry per {noun}: \
         retry {noun} {first} if it did not complete",
        job.table()
    )
}

/// How an unfinished render or study ends when it does not complete.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JobEnd {
    /// Its own error (a bad scene, a panic in the renderer).
    Failed,
    /// The daemon stopped under it; it can be retried.
    Interrupted,
    /// A client cancelled it.
    Cancelled,
}

impl JobEnd {
    pub fn as_str(self) -> &'static str {
        match self {
            JobEnd::Failed => "failed",
            JobEnd::Interrupted => "interrupted",
            JobEnd::Cancelled => "cancelled",
        }
    }
}

/// What a result computed from stored rows read, in a few numbers that
/// change whenever those rows do (counts, newest ids, a sum over a column
/// that is rewritten in place): the key under which the lab keeps the
/// result ([`Store::experiment_inputs`], [`Store::scene_comparison_inputs`]).
/// Read in one cheap query, so every daemon sharing the database sees
/// another's writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct InputsVersion(pub [i64; 4]);

/// A handle on the database; cheap to clone (a connection pool).
#[derive(Clone, Debug)]
pub struct Store {
    engine: Engine,
    /// The daemon this handle acts for ([`Store::as_daemon`]): recorded on
    /// the measurements, renders and studies it creates or starts.
    daemon_id: Option<i64>,
    /// The observer of what the store computes when it reads (a partial
    /// average, each sample's `Y`) for measurements that have none stored:
    /// the daemon's `--observer` ([`Store::with_observer`]).
    observer: Observer,
    /// Writes of what computed results read, by this handle and its clones
    /// ([`Store::writes`]).
    writes: std::sync::Arc<std::sync::atomic::AtomicU64>,
}

impl Store {
    /// This handle, computing with `observer` what it derives on read (a
    /// partial average's Y, x, y; a sample's Y) where the measurement stores
    /// no observer of its own. The daemon passes its `--observer`; the
    /// default is Judd–Vos 1978, the daemon's default.
    pub fn with_observer(mut self, observer: Observer) -> Store {
        self.observer = observer;
        self
    }

    /// The observer of [`Store::with_observer`].
    pub fn observer(&self) -> Observer {
        self.observer
    }

    /// Opens the database at `url` — `sqlite://path` (created if needed),
    /// `sqlite::memory:`, or `postgres://user@host/db` (the database must
    /// exist) — and applies migrations. It never recovers, expires or
    /// otherwise writes work it did not make: a command that opens the
    /// store beside a running daemon (`lightbooth experiment list`) must
    /// leave the daemon's measurement under way alone. Only a daemon that
    /// owns the database or its booth recovers, through
    /// [`Store::open_recovering`].
    ///
    /// Durability on SQLite: `synchronous = FULL`, so every committed write —
    /// each raw sample, each finished measurement — is on disk (WAL fsynced)
    /// before the call returns, and survives an OS crash or power loss, not
    /// only a crash of the daemon (NORMAL's promise in WAL mode, which can
    /// lose the last transactions on power loss). The cost is one fsync per
    /// commit; `cargo bench --bench sample_durability` measures it (see the
    /// README). PostgreSQL's default (`synchronous_commit = on`) gives the
    /// same promise.
    pub fn open<'a>(url: &'a str) -> BoxFuture<'a, Result<Store, StoreError>> {
        Box::pin(async move { Store::open_with_synchronous(url, SqliteSynchronous::Full).await })
    }

    /// [`Store::open`], then marks the work left unfinished by daemons that
    /// are gone interrupted (leases, `leases.rs`), and rows that name no
    /// daemon. For the daemon's start only: on SQLite it must hold the
    /// file's lock (`lightbooth::daemon::db_lock`), which proves every daemon
    /// registered in the file gone; on PostgreSQL only daemons whose lease
    /// has expired or that stopped are gone.
    pub fn open_recovering<'a>(url: &'a str) -> BoxFuture<'a, Result<Store, StoreError>> {
        Box::pin(async move {
            let store = Store::open(url).await?;
            let recovered = store
                .recover_abandoned_work(RecoveryScope {
                    rows_without_daemon: true,
                    every_daemon_is_gone: matches!(store.engine, Engine::Sqlite(_)),
                })
                .await?;
            if recovered.total() > 0 {
                tracing::warn!(
                    measurements = recovered.measurements,
                    renders = recovered.renders,
                    studies = recovered.studies,
                    "marked work left unfinished by daemons that are gone as interrupted"
                );
            }
            Ok(store)
        })
    }

    /// Opens the store for a one-shot command (`calibrate`, `study`, a
    /// render worker) that may run beside daemons: [`Store::open`], which
    /// never recovers, on either engine.
    pub fn open_as_tool<'a>(url: &'a str) -> BoxFuture<'a, Result<Store, StoreError>> {
        Box::pin(async move { Store::open(url).await })
    }

    /// Opens the store to read from it beside a running daemon (`stimulus
    /// --display-db`): never start-up recovery, on either engine, since the
    /// daemon may be running the work a recovery would mark interrupted.
    pub fn open_to_read<'a>(url: &'a str) -> BoxFuture<'a, Result<Store, StoreError>> {
        Box::pin(async move { Store::open(url).await })
    }

    /// [`Store::open`] with another SQLite `synchronous` mode (the benchmark
    /// compares FULL with NORMAL); ignored for PostgreSQL.
    pub fn open_with_synchronous<'a>(
        url: &'a str,
        synchronous: SqliteSynchronous,
    ) -> BoxFuture<'a, Result<Store, StoreError>> {
        Box::pin(async move {
            Ok(Store {
                engine: Engine::connect(url, synchronous).await?,
                daemon_id: None,
                observer: Observer::default(),
                writes: Default::default(),
            })
        })
    }

    /// How many writes of what the lab's computed results read (a trial, a
    /// session begun or ended, a verification, a comparison or its white,
    /// a measurement ended, a render finished or its preview) this handle and
    /// its clones have made: a number that only grows, so a cache in this
    /// process knows at once that a result it keeps may be stale without
    /// asking the database. Writes by other processes sharing the database
    /// are not counted: a cache re-reads the stored version for those
    /// (`lightbooth_lab::computed`).
    pub fn writes(&self) -> u64 {
        self.writes.load(std::sync::atomic::Ordering::Acquire)
    }

    /// Counts one write of what computed results read ([`Store::writes`]);
    /// called after the write committed.
    fn wrote(&self) {
        self.writes.fetch_add(1, std::sync::atomic::Ordering::AcqRel);
    }

    /// `"sqlite"` or `"postgres"`.
    pub fn engine_name(&self) -> &'static str {
        self.engine.name()
    }

    /// The SQLite pool, for tools that write an SQLite store directly (the
    /// API load benchmark's fill); `None` on PostgreSQL.
    pub fn sqlite_pool(&self) -> Option<&SqlitePool> {
        match &self.engine {
            Engine::Sqlite(pool) => Some(pool),
            Engine::Postgres(_) => None,
        }
    }

    /// Does the database answer (`SELECT 1`).
    pub fn ping<'a>(&'a self) -> BoxFuture<'a, Result<(), StoreError>> {
        Box::pin(async move {
            with_pool!(self, |pool| sqlx::query("SELECT 1")
                .execute(pool)
                .await?
                .rows_affected());
            Ok(())
        })
    }

    /// Closes every connection (waits for those in use).
    pub fn close<'a>(&'a self) -> BoxFuture<'a, ()> {
        Box::pin(async move { with_pool!(self, |pool| pool.close().await) })
    }

    /// Marks every queued or running measurement interrupted (start-up after a crash).
    pub fn interrupt_unfinished<'a>(&'a self, why: &'a str) -> BoxFuture<'a, Result<u64, StoreError>> {
        Box::pin(async move {
            Ok(with_pool!(self, |pool| sqlx::query(
                "UPDATE measurements SET state = 'interrupted', error = $1, finished_at = $2 \
                 WHERE state IN ('queued', 'running')",
            )
            .bind(why)
            .bind(now())
            .execute(pool)
            .await?
            .rows_affected()))
        })
    }

    /// Marks every queued or running render (or study) interrupted, with
    /// `why` as its error: at start-up after a crash, and at shutdown.
    pub fn interrupt_unfinished_jobs<'a>(&'a self, job: Job, why: &'a str) -> BoxFuture<'a, Result<u64, StoreError>> {
        Box::pin(async move {
            let sql = format!(
                "UPDATE {} SET state = 'interrupted', error = $1, finished_at = $2 WHERE state IN ('queued', 'running')",
                job.table()
            );
            Ok(with_pool!(self, |pool| sqlx::query(&sql)
                .bind(why)
                .bind(now())
                .execute(pool)
                .await?
                .rows_affected()))
        })
    }

    /// `queued → running` for a render or study. False when it is no longer
    /// queued (cancelled while it waited): it must not run.
    pub fn start_job<'a>(&'a self, job: Job, id: i64) -> BoxFuture<'a, Result<bool, StoreError>> {
        Box::pin(async move {
            let sql = format!(
                "UPDATE {} SET state = 'running', daemon_id = COALESCE($2, daemon_id) WHERE id = $1 AND state = 'queued'",
                job.table()
            );
            let n = with_pool!(self, |pool| sqlx::query(&sql)
                .bind(id)
                .bind(self.daemon_id)
                .execute(pool)
                .await?
                .rows_affected());
            Ok(n == 1)
        })
    }

    /// Ends an unfinished render or study as failed, interrupted or
    /// cancelled; false when it had already ended.
    pub fn end_job<'a>(
        &'a self,
        job: Job,
        id: i64,
        state: JobEnd,
        error: &'a str,
    ) -> BoxFuture<'a, Result<bool, StoreError>> {
        Box::pin(async move {
            let sql = format!(
                "UPDATE {} SET state = $1, error = $2, finished_at = $3 WHERE id = $4 AND state IN ('queued', 'running')",
                job.table()
            );
            let n = with_pool!(self, |pool| sqlx::query(&sql)
                .bind(state.as_str())
                .bind(error)
                .bind(now())
                .bind(id)
                .execute(pool)
                .await?
                .rows_affected());
            Ok(n == 1)
        })
    }

    /// The state of a render or study (`None`: no such id).
    pub fn job_state<'a>(&'a self, job: Job, id: i64) -> BoxFuture<'a, Result<Option<String>, StoreError>> {
        Box::pin(async move {
            let sql = format!("SELECT state FROM {} WHERE id = $1", job.table());
            Ok(with_pool!(self, |pool| sqlx::query_scalar(&sql)
                .bind(id)
                .fetch_optional(pool)
                .await?))
        })
    }

    // --- instruments and sessions ---------------------------------------

    /// The id of an instrument, recording it the first time it is seen and
    /// the booth and port it is seen at now.
    pub fn upsert_instrument<'a>(
        &'a self,
        booth: &'a Booth,
        model: &'a str,
        serial: Option<&'a str>,
        port: &'a str,
    ) -> BoxFuture<'a, Result<i64, StoreError>> {
        Box::pin(async move {
            let t = now();
            Ok(with_pool!(self, |pool| {
                sqlx::query_scalar(
                "INSERT INTO instruments (booth, model, serial, port, first_seen, last_seen) VALUES ($1, $2, $3, $4, $5, $6) \
                 ON CONFLICT (model, serial) DO UPDATE SET booth = excluded.booth, port = excluded.port, \
                 last_seen = excluded.last_seen RETURNING id",
            )
            .bind(booth.as_str())
            .bind(model)
            .bind(serial.unwrap_or(""))
            .bind(port)
            .bind(t)
            .bind(t)
            .fetch_one(pool)
            .await?
            }))
        })
    }

    /// Every booth with a measurement or an instrument, by name. The counts
    /// and newest time come from `booth_measurement_counts` (kept by
    /// triggers, migration 0014), the unfinished ones from the state index:
    /// nothing here reads every measurement.
    pub fn list_booths<'a>(&'a self) -> BoxFuture<'a, Result<Vec<BoothRow>, StoreError>> {
        Box::pin(async move {
            Ok(with_pool!(self, |pool| sqlx::query_as(
                "SELECT b.booth, COALESCE(c.measurements, 0) AS measurements, \
                        (SELECT COUNT(*) FROM measurements m WHERE m.state IN ('queued', 'running') \
                           AND m.booth = b.booth) AS unfinished, \
                        c.last_measurement_at \
                 FROM (SELECT booth FROM booth_measurement_counts WHERE measurements > 0 \
                       UNION SELECT booth FROM instruments) b \
                 LEFT JOIN booth_measurement_counts c ON c.booth = b.booth ORDER BY b.booth"
            )
            .fetch_all(pool)
            .await?))
        })
    }

    pub fn list_instruments<'a>(&'a self) -> BoxFuture<'a, Result<Vec<InstrumentRow>, StoreError>> {
        Box::pin(async move {
            Ok(with_pool!(self, |pool| sqlx::query_as(
                "SELECT id, model, booth, serial, port, first_seen, last_seen FROM instruments ORDER BY id"
            )
            .fetch_all(pool)
            .await?))
        })
    }

    pub fn create_session<'a>(&'a self, operator: &'a str, notes: &'a str) -> BoxFuture<'a, Result<i64, StoreError>> {
        Box::pin(async move {
            Ok(with_pool!(self, |pool| sqlx::query_scalar(
                "INSERT INTO sessions (operator, notes, started_at) VALUES ($1, $2, $3) RETURNING id"
            )
            .bind(operator)
            .bind(notes)
            .bind(now())
            .fetch_one(pool)
            .await?))
        })
    }

    pub fn list_sessions<'a>(&'a self) -> BoxFuture<'a, Result<Vec<SessionRow>, StoreError>> {
        Box::pin(async move {
            Ok(with_pool!(self, |pool| sqlx::query_as(
                "SELECT id, operator, notes, started_at FROM sessions ORDER BY id DESC"
            )
            .fetch_all(pool)
            .await?))
        })
    }
}

fn json_array(v: &[f64]) -> String {
    serde_json::to_string(v).expect("finite numbers serialise")
}

/// Luminance (cd/m²) with `observer` of a stored sample spectrum, on the
/// native grid its length names; `None` for a length no instrument has.
fn sample_luminance(values: &[f64], observer: Observer) -> Option<f64> {
    let grid = lightbooth_instrument::native_grid_of_length(values.len())?;
    let spectrum = lightbooth_science::spectrum::Spectrum::new(
        grid,
        lightbooth_science::spectrum::SpectralUnit::SpectralRadiance,
        values.to_vec(),
    )
    .ok()?;
    lightbooth_science::colorimetry::xyz_from_radiance(&spectrum, observer)
        .ok()
        .map(|x| x.y)
}

fn parse_opt_array(text: Option<String>, what: &str) -> Result<Option<Vec<f64>>, StoreError> {
    text.map(|t| {
        serde_json::from_str(&t).map_err(|e| StoreError::Corrupt {
            what: what.into(),
            err: e.to_string(),
        })
    })
    .transpose()
}

#[cfg(test)]
pub(crate) mod test_db;
#[cfg(test)]
mod tests;
