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
//!   a crash are marked `interrupted` when the store next opens, as are
//!   renders and studies left `queued` or `running`.
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
//!   one daemon owns the file ([`crate::daemon::db_lock`]), so opening it
//!   recovers all unfinished work, as before leases.
//!
//! ```no_run
//! # async fn demo() -> anyhow::Result<()> {
//! let store = lightbooth::store::Store::open("sqlite://lightbooth.sqlite").await?;
//! let listing = store.list_measurements(&Default::default()).await?;
//! # Ok(()) }
//! ```

/// Runs `$body` once with `$pool` bound to the store's pool, whichever the
/// engine: the body is compiled for each engine's driver, so one statement
/// (with `$N` placeholders) serves both.
macro_rules! with_pool {
    ($store:expr, |$pool:ident| $body:expr) => {
        match &$store.engine {
            $crate::store::engine::Engine::Sqlite($pool) => $body,
            $crate::store::engine::Engine::Postgres($pool) => $body,
        }
    };
}

mod booth;
mod calibrations;
mod display_profiles;
pub mod engine;
mod leases;
mod partial;
mod rows;
pub mod scene_bundles;
pub mod worker_jobs;

use std::str::FromStr;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use serde::{Deserialize, Serialize};
use sqlx::sqlite::{SqlitePool, SqliteSynchronous};

use engine::Engine;

use crate::colorimetry::Observer;

pub use booth::{Booth, DEFAULT_BOOTH};
pub use calibrations::*;
pub use display_profiles::*;
pub use leases::{DaemonRow, InterruptedWork, Recovered, RecoveryScope};
pub use rows::*;
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
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, utoipa::ToSchema)]
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
    /// exist) — applies migrations, and marks measurements a crash left
    /// unfinished as interrupted.
    ///
    /// Durability on SQLite: `synchronous = FULL`, so every committed write —
    /// each raw sample, each finished measurement — is on disk (WAL fsynced)
    /// before the call returns, and survives an OS crash or power loss, not
    /// only a crash of the daemon (NORMAL's promise in WAL mode, which can
    /// lose the last transactions on power loss). The cost is one fsync per
    /// commit; `cargo bench --bench sample_durability` measures it (see the
    /// README). PostgreSQL's default (`synchronous_commit = on`) gives the
    /// same promise.
    pub async fn open(url: &str) -> Result<Store, StoreError> {
        Store::open_with_synchronous(url, SqliteSynchronous::Full).await
    }

    /// Opens the store for a one-shot command (`calibrate`, `study`) that
    /// may run beside daemons: on SQLite exactly [`Store::open`] (the command
    /// runs alone on the file or holds its lock); on PostgreSQL without
    /// start-up recovery, since daemons sharing the database may be running
    /// the work a recovery would mark interrupted.
    pub async fn open_as_tool(url: &str) -> Result<Store, StoreError> {
        match engine::EngineKind::of_url(url)? {
            engine::EngineKind::Sqlite => Store::open(url).await,
            engine::EngineKind::Postgres => Ok(Store {
                engine: Engine::connect(url, SqliteSynchronous::Full).await?,
                daemon_id: None,
                observer: Observer::default(),
            }),
        }
    }

    /// Opens the store to read from it beside a running daemon (`stimulus
    /// --display-db`): never start-up recovery, on either engine, since the
    /// daemon may be running the work a recovery would mark interrupted.
    pub async fn open_to_read(url: &str) -> Result<Store, StoreError> {
        Ok(Store {
            engine: Engine::connect(url, SqliteSynchronous::Full).await?,
            daemon_id: None,
            observer: Observer::default(),
        })
    }

    /// [`Store::open`] with another SQLite `synchronous` mode (the benchmark
    /// compares FULL with NORMAL); ignored for PostgreSQL.
    pub async fn open_with_synchronous(url: &str, synchronous: SqliteSynchronous) -> Result<Store, StoreError> {
        let store = Store {
            engine: Engine::connect(url, synchronous).await?,
            daemon_id: None,
            observer: Observer::default(),
        };
        // The work of daemons that are gone (leases, `leases.rs`) and rows
        // that name no daemon. On SQLite the caller holds the file alone, so
        // every daemon registered in it is gone.
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
    pub async fn ping(&self) -> Result<(), StoreError> {
        with_pool!(self, |pool| sqlx::query("SELECT 1")
            .execute(pool)
            .await?
            .rows_affected());
        Ok(())
    }

    /// Closes every connection (waits for those in use).
    pub async fn close(&self) {
        with_pool!(self, |pool| pool.close().await)
    }

    /// Marks every queued or running measurement interrupted (start-up after a crash).
    pub async fn interrupt_unfinished(&self, why: &str) -> Result<u64, StoreError> {
        Ok(with_pool!(self, |pool| sqlx::query(
            "UPDATE measurements SET state = 'interrupted', error = $1, finished_at = $2 \
             WHERE state IN ('queued', 'running')",
        )
        .bind(why)
        .bind(now())
        .execute(pool)
        .await?
        .rows_affected()))
    }

    /// Marks every queued or running render (or study) interrupted, with
    /// `why` as its error: at start-up after a crash, and at shutdown.
    pub async fn interrupt_unfinished_jobs(&self, job: Job, why: &str) -> Result<u64, StoreError> {
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
    }

    /// `queued → running` for a render or study. False when it is no longer
    /// queued (cancelled while it waited): it must not run.
    pub async fn start_job(&self, job: Job, id: i64) -> Result<bool, StoreError> {
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
    }

    /// Ends an unfinished render or study as failed, interrupted or
    /// cancelled; false when it had already ended.
    pub async fn end_job(&self, job: Job, id: i64, state: JobEnd, error: &str) -> Result<bool, StoreError> {
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
    }

    /// The state of a render or study (`None`: no such id).
    pub async fn job_state(&self, job: Job, id: i64) -> Result<Option<String>, StoreError> {
        let sql = format!("SELECT state FROM {} WHERE id = $1", job.table());
        Ok(with_pool!(self, |pool| sqlx::query_scalar(&sql)
            .bind(id)
            .fetch_optional(pool)
            .await?))
    }

    // --- instruments and sessions ---------------------------------------

    /// The id of an instrument, recording it the first time it is seen and
    /// the booth and port it is seen at now.
    pub async fn upsert_instrument(
        &self,
        booth: &Booth,
        model: &str,
        serial: Option<&str>,
        port: &str,
    ) -> Result<i64, StoreError> {
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
    }

    /// Every booth with a measurement or an instrument, by name. The counts
    /// and newest time come from `booth_measurement_counts` (kept by
    /// triggers, migration 0014), the unfinished ones from the state index:
    /// nothing here reads every measurement.
    pub async fn list_booths(&self) -> Result<Vec<BoothRow>, StoreError> {
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
    }

    pub async fn list_instruments(&self) -> Result<Vec<InstrumentRow>, StoreError> {
        Ok(with_pool!(self, |pool| sqlx::query_as(
            "SELECT id, model, booth, serial, port, first_seen, last_seen FROM instruments ORDER BY id"
        )
        .fetch_all(pool)
        .await?))
    }

    pub async fn create_session(&self, operator: &str, notes: &str) -> Result<i64, StoreError> {
        Ok(with_pool!(self, |pool| sqlx::query_scalar(
            "INSERT INTO sessions (operator, notes, started_at) VALUES ($1, $2, $3) RETURNING id"
        )
        .bind(operator)
        .bind(notes)
        .bind(now())
        .fetch_one(pool)
        .await?))
    }

    pub async fn list_sessions(&self) -> Result<Vec<SessionRow>, StoreError> {
        Ok(with_pool!(self, |pool| sqlx::query_as(
            "SELECT id, operator, notes, started_at FROM sessions ORDER BY id DESC"
        )
        .fetch_all(pool)
        .await?))
    }

    // --- measurements -----------------------------------------------------

    /// Records a requested measurement as `queued`.
    pub async fn create_measurement(&self, m: &NewMeasurement) -> Result<i64, StoreError> {
        Ok(with_pool!(self, |pool| {
            sqlx::query_scalar(
            "INSERT INTO measurements (booth, session_id, scene, target, samples_requested, settings_json, state, note, created_at, daemon_id) \
             VALUES ($1, $2, $3, $4, $5, $6, 'queued', $7, $8, $9) RETURNING id",
        )
        .bind(m.booth.as_str())
        .bind(m.session_id)
        .bind(&m.scene)
        .bind(&m.target)
        .bind(m.samples as i64)
        .bind(m.settings_json.to_string())
        .bind(&m.note)
        .bind(now())
        .bind(self.daemon_id)
        .fetch_one(pool)
        .await?
        }))
    }

    /// `queued → running`, naming the instrument that takes it.
    pub async fn mark_running(&self, id: i64, instrument_id: Option<i64>) -> Result<(), StoreError> {
        let n = with_pool!(self, |pool| {
            sqlx::query(
                "UPDATE measurements SET state = 'running', instrument_id = $1, started_at = $2, \
             daemon_id = COALESCE($4, daemon_id) WHERE id = $3 AND state = 'queued'",
            )
            .bind(instrument_id)
            .bind(now())
            .bind(id)
            .bind(self.daemon_id)
            .execute(pool)
            .await?
            .rows_affected()
        });
        if n != 1 {
            return Err(StoreError::Conflict(format!("measurement {id} is not queued")));
        }
        Ok(())
    }

    /// Writes one raw sample, as it is taken.
    pub async fn insert_sample(&self, measurement_id: i64, s: &NewSample) -> Result<(), StoreError> {
        with_pool!(self, |pool| {
            sqlx::query(
            "INSERT INTO samples (measurement_id, idx, taken_at, code, message, usable, radiance_json, luminance_cd_m2) \
             VALUES ($1, $2, $3, $4, $5, $6, $7, $8)",
        )
        .bind(measurement_id)
        .bind(s.index as i64)
        .bind(s.taken_at)
        .bind(s.code)
        .bind(&s.message)
        .bind(s.usable)
        .bind(s.radiance.as_ref().map(|r| json_array(r)))
        .bind(s.luminance_cd_m2)
        .execute(pool)
        .await?
        .rows_affected()
        });
        Ok(())
    }

    /// `running → complete` with the average; one transaction.
    pub async fn complete_measurement(&self, id: i64, a: &Average) -> Result<(), StoreError> {
        let n = with_pool!(self, |pool| {
            sqlx::query(
            "UPDATE measurements SET state = 'complete', finished_at = $1, wavelength_json = $2, radiance_json = $3, \
             radiance_sd_json = $4, luminance_cd_m2 = $5, x = $6, y = $7, luminance_cv = $8, observer = $9, xyz_x = $10, \
             xyz_y = $11, xyz_z = $12 WHERE id = $13 AND state = 'running'",
        )
        .bind(now())
        .bind(json_array(&a.wavelength_nm))
        .bind(json_array(&a.radiance))
        .bind(json_array(&a.radiance_sd))
        .bind(a.luminance_cd_m2)
        .bind(a.x)
        .bind(a.y)
        .bind(a.luminance_cv)
        .bind(a.observer.map(|o| o.name()))
        .bind(a.xyz.map(|v| v[0]))
        .bind(a.xyz.map(|v| v[1]))
        .bind(a.xyz.map(|v| v[2]))
        .bind(id)
        .execute(pool)
        .await?
        .rows_affected()
        });
        if n != 1 {
            return Err(StoreError::Conflict(format!("measurement {id} is not running")));
        }
        Ok(())
    }

    /// Ends an unfinished measurement as failed, interrupted or cancelled.
    pub async fn end_measurement(&self, id: i64, state: MeasurementState, error: &str) -> Result<(), StoreError> {
        debug_assert!(state.is_final() && state != MeasurementState::Complete);
        with_pool!(self, |pool| {
            sqlx::query(
            "UPDATE measurements SET state = $1, error = $2, finished_at = $3 WHERE id = $4 AND state IN ('queued', 'running')",
        )
        .bind(state.as_str())
        .bind(error)
        .bind(now())
        .bind(id)
        .execute(pool)
        .await?
        .rows_affected()
        });
        Ok(())
    }

    /// `queued → cancelled`, only while it is still queued (so a measurement
    /// the instrument has started is never ended here). True when it was.
    pub async fn cancel_queued(&self, id: i64, message: &str) -> Result<bool, StoreError> {
        let n = with_pool!(self, |pool| {
            sqlx::query(
            "UPDATE measurements SET state = 'cancelled', error = $1, finished_at = $2 WHERE id = $3 AND state = 'queued'",
        )
        .bind(message)
        .bind(now())
        .bind(id)
        .execute(pool)
        .await?
        .rows_affected()
        });
        Ok(n == 1)
    }

    /// Every (scene, target) with at least one complete measurement.
    pub async fn measured_targets(&self) -> Result<Vec<(String, String)>, StoreError> {
        Ok(with_pool!(self, |pool| sqlx::query_as(
            "SELECT DISTINCT scene, target FROM measurements \
             WHERE state = 'complete' AND scene IS NOT NULL AND target IS NOT NULL",
        )
        .fetch_all(pool)
        .await?))
    }

    /// One measurement with all its samples.
    pub async fn get_measurement(&self, id: i64) -> Result<Option<MeasurementDetail>, StoreError> {
        let sql = format!(
            "SELECT {MEASUREMENT_COLUMNS}, wavelength_json, radiance_json, radiance_sd_json FROM measurements WHERE id = $1"
        );
        let record: Option<MeasurementDetailRecord> =
            with_pool!(self, |pool| sqlx::query_as(&sql).bind(id).fetch_optional(pool).await?);
        let Some(record) = record else {
            return Ok(None);
        };
        let mut summary = MeasurementSummary::try_from(record.summary)?;
        self.fill_partial_averages(std::slice::from_mut(&mut summary)).await?;
        let sample_records: Vec<SampleRecord> = with_pool!(self, |pool| sqlx::query_as(
            "SELECT idx, taken_at, code, message, usable, radiance_json, luminance_cd_m2 FROM samples \
             WHERE measurement_id = $1 ORDER BY idx",
        )
        .bind(id)
        .fetch_all(pool)
        .await?);
        let mut samples = sample_records
            .into_iter()
            .map(SampleRow::try_from)
            .collect::<Result<Vec<_>, StoreError>>()?;
        // Each sample's Y from its spectrum with the measurement's observer,
        // the same one as the measurement's `Y` (never the instrument's own).
        let observer = summary.observer.unwrap_or(self.observer);
        for s in &mut samples {
            s.luminance_cd_m2 = s
                .radiance
                .as_deref()
                .and_then(|values| sample_luminance(values, observer));
        }
        Ok(Some(MeasurementDetail {
            summary,
            wavelength_nm: parse_opt_array(record.wavelength_json, "wavelengths")?,
            radiance: parse_opt_array(record.radiance_json, "mean radiance")?,
            radiance_sd: parse_opt_array(record.radiance_sd_json, "radiance SD")?,
            samples,
        }))
    }

    /// A page of measurements, newest first, with optional filters.
    pub async fn list_measurements(&self, f: &MeasurementFilter) -> Result<MeasurementPage, StoreError> {
        // The filters' values, in the order of their `$N` placeholders.
        let mut values: Vec<String> = Vec::new();
        let mut conditions = Vec::new();
        for (column, value) in [
            ("booth", f.booth.as_ref().map(|b| b.as_str().to_string())),
            ("scene", f.scene.clone()),
            ("target", f.target.clone()),
            ("state", f.state.map(|s| s.as_str().to_string())),
        ] {
            if let Some(v) = value {
                values.push(v);
                conditions.push(format!("{column} = ${}", values.len()));
            }
        }
        if let Some(model) = &f.instrument_model {
            values.push(model.clone());
            conditions.push(format!(
                "instrument_id IN (SELECT i.id FROM instruments i WHERE i.model = ${})",
                values.len()
            ));
        }
        // No `WHERE 1 = 1`: an unfiltered COUNT(*) then uses SQLite's fast path.
        let where_sql = if conditions.is_empty() {
            String::new()
        } else {
            format!(" WHERE {}", conditions.join(" AND "))
        };
        // Unfiltered or by booth alone, the total is the booths' counts
        // (migration 0014): counting the rows costs O(rows) per request.
        let count_sql = match (&f.booth, values.len()) {
            (_, 0) => "SELECT CAST(COALESCE(SUM(measurements), 0) AS BIGINT) FROM booth_measurement_counts".to_string(),
            (Some(_), 1) => {
                "SELECT CAST(COALESCE(SUM(measurements), 0) AS BIGINT) FROM booth_measurement_counts WHERE booth = $1"
                    .into()
            }
            _ => format!("SELECT COUNT(*) FROM measurements{where_sql}"),
        };
        let limit = f.limit.unwrap_or(50).clamp(1, 1000);
        let offset = f.offset.unwrap_or(0).max(0);
        // The page's ids come from the primary key alone; only those rows'
        // columns (and sample counts) are computed. With the columns in the
        // paging query itself, SQLite evaluates them for every skipped row.
        // `before_id` pages by the primary key (an index range, the same
        // cost at any depth); the total ignores it, as it ignores `offset`.
        let page_where = match (f.before_id, where_sql.is_empty()) {
            (None, _) => where_sql.clone(),
            (Some(before), true) => format!(" WHERE id < {before}"),
            (Some(before), false) => format!("{where_sql} AND id < {before}"),
        };
        let list_sql = format!(
            "SELECT {MEASUREMENT_COLUMNS} FROM measurements WHERE id IN (\
             SELECT id FROM measurements{page_where} ORDER BY id DESC LIMIT {limit} OFFSET {offset}) ORDER BY id DESC"
        );
        let (total, records): (i64, Vec<MeasurementRecord>) = with_pool!(self, |pool| {
            let mut count = sqlx::query_scalar(&count_sql);
            let mut list = sqlx::query_as(&list_sql);
            for v in &values {
                count = count.bind(v.as_str());
                list = list.bind(v.as_str());
            }
            (count.fetch_one(pool).await?, list.fetch_all(pool).await?)
        });
        let mut items = records
            .into_iter()
            .map(MeasurementSummary::try_from)
            .collect::<Result<Vec<_>, _>>()?;
        self.fill_partial_averages(&mut items).await?;
        Ok(MeasurementPage {
            total,
            limit,
            offset,
            items,
        })
    }

    /// The newest complete measurement of a scene target.
    pub async fn latest_complete(&self, scene: &str, target: &str) -> Result<Option<MeasurementDetail>, StoreError> {
        let id: Option<i64> = with_pool!(self, |pool| {
            sqlx::query_scalar(
            "SELECT id FROM measurements WHERE scene = $1 AND target = $2 AND state = 'complete' ORDER BY id DESC LIMIT 1",
        )
        .bind(scene)
        .bind(target)
        .fetch_optional(pool)
        .await?
        });
        match id {
            Some(id) => self.get_measurement(id).await,
            None => Ok(None),
        }
    }

    /// The newest complete measurement of a scene target taken in `booth`:
    /// the CIELAB white of that booth's comparisons (each booth has its own
    /// lamps, so another booth's white never stands in for it).
    pub async fn latest_complete_in_booth(
        &self,
        scene: &str,
        target: &str,
        booth: &Booth,
    ) -> Result<Option<MeasurementDetail>, StoreError> {
        let id: Option<i64> = with_pool!(self, |pool| {
            sqlx::query_scalar(
                "SELECT id FROM measurements WHERE scene = $1 AND target = $2 AND booth = $3 AND state = 'complete' \
                 ORDER BY id DESC LIMIT 1",
            )
            .bind(scene)
            .bind(target)
            .bind(booth.as_str())
            .fetch_optional(pool)
            .await?
        });
        match id {
            Some(id) => self.get_measurement(id).await,
            None => Ok(None),
        }
    }

    /// The booth a measurement was taken in; `None` when there is no such
    /// measurement.
    pub async fn measurement_booth(&self, id: i64) -> Result<Option<Booth>, StoreError> {
        let booth: Option<String> = with_pool!(self, |pool| {
            sqlx::query_scalar("SELECT booth FROM measurements WHERE id = $1")
                .bind(id)
                .fetch_optional(pool)
                .await?
        });
        booth
            .map(|b| {
                b.parse().map_err(|e: String| StoreError::Corrupt {
                    what: format!("measurement {id}'s booth"),
                    err: e,
                })
            })
            .transpose()
    }

    // --- renders ----------------------------------------------------------

    pub async fn create_render(&self, r: &NewRender) -> Result<i64, StoreError> {
        Ok(with_pool!(self, |pool| sqlx::query_scalar(
            "INSERT INTO renders (scene, scene_hash, settings_json, codings, seed, state, created_at, daemon_id) \
             VALUES ($1, $2, $3, $4, $5, 'queued', $6, $7) RETURNING id",
        )
        .bind(&r.scene)
        .bind(&r.scene_hash)
        .bind(r.settings_json.to_string())
        .bind(r.codings.join(","))
        .bind(r.seed as i64)
        .bind(now())
        .bind(self.daemon_id)
        .fetch_one(pool)
        .await?))
    }

    pub async fn finish_render(
        &self,
        id: i64,
        result: Result<(&serde_json::Value, f64), &str>,
    ) -> Result<(), StoreError> {
        match result {
            Ok((json, wall)) => with_pool!(self, |pool| sqlx::query(
                "UPDATE renders SET state = 'complete', result_json = $1, wall_seconds = $2, finished_at = $3 \
                 WHERE id = $4 AND state = 'running'",
            )
            .bind(json.to_string())
            .bind(wall)
            .bind(now())
            .bind(id)
            .execute(pool)
            .await?
            .rows_affected()),
            Err(e) => with_pool!(self, |pool| sqlx::query(
                "UPDATE renders SET state = 'failed', error = $1, finished_at = $2 \
                 WHERE id = $3 AND state IN ('queued', 'running')",
            )
            .bind(e)
            .bind(now())
            .bind(id)
            .execute(pool)
            .await?
            .rows_affected()),
        };
        Ok(())
    }

    /// The newest complete render of this scene content with these exact
    /// settings: its id and JSON result.
    pub async fn find_render_result(
        &self,
        scene_hash: &str,
        settings: &serde_json::Value,
    ) -> Result<Option<(i64, serde_json::Value)>, StoreError> {
        let row: Option<(i64, String)> = with_pool!(self, |pool| {
            sqlx::query_as(
            "SELECT id, result_json FROM renders WHERE scene_hash = $1 AND settings_json = $2 AND state = 'complete' \
             ORDER BY id DESC LIMIT 1",
        )
        .bind(scene_hash)
        .bind(settings.to_string())
        .fetch_optional(pool)
        .await?
        });
        let Some((id, text)) = row else { return Ok(None) };
        let json = serde_json::from_str(&text).map_err(|e| StoreError::Corrupt {
            what: "renders.result_json".into(),
            err: e.to_string(),
        })?;
        Ok(Some((id, json)))
    }

    /// A running render of this scene content with these exact settings,
    /// by any process: its id.
    pub async fn running_render_of(
        &self,
        scene_hash: &str,
        settings: &serde_json::Value,
    ) -> Result<Option<i64>, StoreError> {
        Ok(with_pool!(self, |pool| sqlx::query_scalar(
            "SELECT id FROM renders WHERE scene_hash = $1 AND settings_json = $2 AND state = 'running' \
             ORDER BY id DESC LIMIT 1"
        )
        .bind(scene_hash)
        .bind(settings.to_string())
        .fetch_optional(pool)
        .await?))
    }

    /// Stores a render's preview image (PNG bytes).
    pub async fn set_render_preview(&self, id: i64, png: &[u8]) -> Result<(), StoreError> {
        with_pool!(self, |pool| sqlx::query(
            "UPDATE renders SET preview_png = $1 WHERE id = $2"
        )
        .bind(png)
        .bind(id)
        .execute(pool)
        .await?
        .rows_affected());
        Ok(())
    }

    /// A render's preview PNG, if it has one.
    pub async fn render_preview(&self, id: i64) -> Result<Option<Vec<u8>>, StoreError> {
        Ok(with_pool!(self, |pool| sqlx::query_scalar::<_, Option<Vec<u8>>>(
            "SELECT preview_png FROM renders WHERE id = $1"
        )
        .bind(id)
        .fetch_optional(pool)
        .await?)
        .flatten())
    }

    pub async fn get_render(&self, id: i64) -> Result<Option<RenderRow>, StoreError> {
        let sql = format!("SELECT {RENDER_COLUMNS} FROM renders WHERE id = $1");
        let record: Option<RenderRecord> =
            with_pool!(self, |pool| sqlx::query_as(&sql).bind(id).fetch_optional(pool).await?);
        record.map(RenderRow::try_from).transpose()
    }

    pub async fn list_renders(&self, scene: Option<&str>) -> Result<Vec<RenderRow>, StoreError> {
        let records: Vec<RenderRecord> = match scene {
            Some(s) => {
                let sql = format!("SELECT {RENDER_COLUMNS} FROM renders WHERE scene = $1 ORDER BY id DESC");
                with_pool!(self, |pool| sqlx::query_as(&sql).bind(s).fetch_all(pool).await?)
            }
            None => {
                let sql = format!("SELECT {RENDER_COLUMNS} FROM renders ORDER BY id DESC LIMIT 200");
                with_pool!(self, |pool| sqlx::query_as(&sql).fetch_all(pool).await?)
            }
        };
        records.into_iter().map(RenderRow::try_from).collect()
    }

    // --- studies ----------------------------------------------------------

    /// Records a study as `queued`.
    pub async fn create_study(&self, request: &serde_json::Value) -> Result<i64, StoreError> {
        Ok(with_pool!(self, |pool| {
            sqlx::query_scalar(
            "INSERT INTO studies (request_json, state, created_at, daemon_id) VALUES ($1, 'queued', $2, $3) RETURNING id"
        )
        .bind(request.to_string())
        .bind(now())
        .bind(self.daemon_id)
        .fetch_one(pool)
        .await?
        }))
    }

    /// Stores a finished study with its report files, in one transaction.
    pub async fn complete_study(
        &self,
        id: i64,
        result: &serde_json::Value,
        wall_seconds: f64,
        files: &[(String, Vec<u8>)],
    ) -> Result<(), StoreError> {
        with_pool!(self, |pool| {
            let mut tx = pool.begin().await?;
            for (name, content) in files {
                sqlx::query("INSERT INTO study_files (study_id, name, content) VALUES ($1, $2, $3)")
                    .bind(id)
                    .bind(name)
                    .bind(content)
                    .execute(&mut *tx)
                    .await?;
            }
            let r = sqlx::query(
                "UPDATE studies SET state = 'complete', result_json = $1, wall_seconds = $2, finished_at = $3 \
                 WHERE id = $4 AND state = 'running'",
            )
            .bind(result.to_string())
            .bind(wall_seconds)
            .bind(now())
            .bind(id)
            .execute(&mut *tx)
            .await?;
            if r.rows_affected() != 1 {
                // Cancelled or interrupted meanwhile: keep nothing (the transaction rolls back).
                return Err(StoreError::Conflict(format!("study {id} is not running")));
            }
            tx.commit().await?;
        });
        Ok(())
    }

    pub async fn fail_study(&self, id: i64, error: &str) -> Result<(), StoreError> {
        with_pool!(self, |pool| sqlx::query(
            "UPDATE studies SET state = 'failed', error = $1, finished_at = $2 WHERE id = $3 AND state = 'running'",
        )
        .bind(error)
        .bind(now())
        .bind(id)
        .execute(pool)
        .await?
        .rows_affected());
        Ok(())
    }

    /// The stored studies, newest first, without their results.
    pub async fn list_studies(&self) -> Result<Vec<StudyRow>, StoreError> {
        let records: Vec<StudyRecord> = with_pool!(self, |pool| {
            sqlx::query_as(
            "SELECT id, request_json, state, error, created_at, finished_at, wall_seconds FROM studies ORDER BY id DESC",
        )
        .fetch_all(pool)
        .await?
        });
        records.into_iter().map(StudyRow::try_from).collect()
    }

    /// One study with its result and the names of its report files.
    pub async fn get_study(&self, id: i64) -> Result<Option<StudyRow>, StoreError> {
        let (record, files): (Option<StudyRecord>, Vec<String>) = with_pool!(self, |pool| (
            sqlx::query_as("SELECT * FROM studies WHERE id = $1")
                .bind(id)
                .fetch_optional(pool)
                .await?,
            sqlx::query_scalar("SELECT name FROM study_files WHERE study_id = $1 ORDER BY name")
                .bind(id)
                .fetch_all(pool)
                .await?
        ));
        let Some(record) = record else {
            return Ok(None);
        };
        let mut study = StudyRow::try_from(record)?;
        study.files = files;
        Ok(Some(study))
    }

    pub async fn study_file(&self, id: i64, name: &str) -> Result<Option<Vec<u8>>, StoreError> {
        Ok(with_pool!(self, |pool| sqlx::query_scalar(
            "SELECT content FROM study_files WHERE study_id = $1 AND name = $2"
        )
        .bind(id)
        .bind(name)
        .fetch_optional(pool)
        .await?))
    }

    // --- comparisons ------------------------------------------------------

    /// Stores the comparisons of one measurement against one render, all
    /// codings in one transaction (all or nothing).
    pub async fn insert_comparisons(&self, rows: &[NewComparison]) -> Result<(), StoreError> {
        with_pool!(self, |pool| {
            let mut tx = pool.begin().await?;
            for c in rows {
                sqlx::query(
                    "INSERT INTO comparisons (measurement_id, render_id, scene, target, coding, white_source, \
                     white_x, white_y, white_z, measured_x, measured_y, measured_z, rendered_x, rendered_y, rendered_z, \
                     rendered_y_se, y_ratio, xy_distance, de76, de00, created_at, observer, measured_y_se) \
                     VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13, $14, $15, $16, $17, $18, $19, $20, \
                     $21, $22, $23)",
                )
                .bind(c.measurement_id)
                .bind(c.render_id)
                .bind(&c.scene)
                .bind(&c.target)
                .bind(&c.coding)
                .bind(&c.white_source)
                .bind(c.white[0])
                .bind(c.white[1])
                .bind(c.white[2])
                .bind(c.measured[0])
                .bind(c.measured[1])
                .bind(c.measured[2])
                .bind(c.rendered[0])
                .bind(c.rendered[1])
                .bind(c.rendered[2])
                .bind(c.rendered_y_se)
                .bind(c.y_ratio)
                .bind(c.xy_distance)
                .bind(c.de76)
                .bind(c.de00)
                .bind(now())
                .bind(c.observer.name())
                .bind(c.measured_y_se)
                .execute(&mut *tx)
                .await?;
            }
            tx.commit().await?;
        });
        Ok(())
    }

    /// For each (target, coding) of a scene, the newest comparison.
    pub async fn latest_comparisons(&self, scene: &str) -> Result<Vec<ComparisonRow>, StoreError> {
        let records: Vec<ComparisonRecord> = with_pool!(self, |pool| sqlx::query_as(
            "SELECT c.* FROM comparisons c JOIN ( \
                 SELECT target, coding, MAX(id) AS id FROM comparisons WHERE scene = $1 GROUP BY target, coding \
             ) latest ON latest.id = c.id ORDER BY c.target, c.coding",
        )
        .bind(scene)
        .fetch_all(pool)
        .await?);
        Ok(records.into_iter().map(ComparisonRow::from).collect())
    }

    /// Every comparison of a scene, oldest first.
    pub async fn comparisons_of_scene(&self, scene: &str) -> Result<Vec<ComparisonRow>, StoreError> {
        let records: Vec<ComparisonRecord> = with_pool!(self, |pool| sqlx::query_as(
            "SELECT * FROM comparisons WHERE scene = $1 ORDER BY id"
        )
        .bind(scene)
        .fetch_all(pool)
        .await?);
        Ok(records.into_iter().map(ComparisonRow::from).collect())
    }

    /// Every comparison of a scene whose measurement was taken in `booth`,
    /// oldest first: the rows a new white of that booth applies to.
    pub async fn comparisons_of_scene_in_booth(
        &self,
        scene: &str,
        booth: &Booth,
    ) -> Result<Vec<ComparisonRow>, StoreError> {
        let records: Vec<ComparisonRecord> = with_pool!(self, |pool| sqlx::query_as(
            "SELECT c.* FROM comparisons c JOIN measurements m ON m.id = c.measurement_id \
             WHERE c.scene = $1 AND m.booth = $2 ORDER BY c.id"
        )
        .bind(scene)
        .bind(booth.as_str())
        .fetch_all(pool)
        .await?);
        Ok(records.into_iter().map(ComparisonRow::from).collect())
    }

    /// Rewrites the CIELAB white of comparisons and the ΔE computed with it
    /// (`(id, white_source, white XYZ, ΔE*ab, ΔE00)`), all in one transaction.
    pub async fn update_comparison_whites(
        &self,
        updates: &[(i64, String, [f64; 3], f64, f64)],
    ) -> Result<(), StoreError> {
        with_pool!(self, |pool| {
            let mut tx = pool.begin().await?;
            for (id, source, white, de76, de00) in updates {
                sqlx::query(
                    "UPDATE comparisons SET white_source = $1, white_x = $2, white_y = $3, white_z = $4, de76 = $5, \
                     de00 = $6 WHERE id = $7",
                )
                .bind(source)
                .bind(white[0])
                .bind(white[1])
                .bind(white[2])
                .bind(de76)
                .bind(de00)
                .bind(id)
                .execute(&mut *tx)
                .await?;
            }
            tx.commit().await?;
        });
        Ok(())
    }

    pub async fn comparisons_for_measurement(&self, measurement_id: i64) -> Result<Vec<ComparisonRow>, StoreError> {
        let records: Vec<ComparisonRecord> = with_pool!(self, |pool| sqlx::query_as(
            "SELECT * FROM comparisons WHERE measurement_id = $1 ORDER BY id"
        )
        .bind(measurement_id)
        .fetch_all(pool)
        .await?);
        Ok(records.into_iter().map(ComparisonRow::from).collect())
    }

    /// Runs one statement with one integer argument (`$1`), for tests that
    /// reach past the store's API (a schema constraint, a forced state).
    #[cfg(test)]
    pub(crate) async fn execute_for_test(&self, sql: &str, arg: i64) -> Result<u64, StoreError> {
        Ok(with_pool!(self, |pool| sqlx::query(sql)
            .bind(arg)
            .execute(pool)
            .await?
            .rows_affected()))
    }
}

fn json_array(v: &[f64]) -> String {
    serde_json::to_string(v).expect("finite numbers serialise")
}

/// Luminance (cd/m²) with `observer` of a stored sample spectrum, on the
/// native grid its length names; `None` for a length no instrument has.
fn sample_luminance(values: &[f64], observer: Observer) -> Option<f64> {
    let grid = crate::instrument::native_grid_of_length(values.len())?;
    let spectrum =
        crate::spectrum::Spectrum::new(grid, crate::spectrum::SpectralUnit::SpectralRadiance, values.to_vec()).ok()?;
    crate::colorimetry::xyz_from_radiance(&spectrum, observer)
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
