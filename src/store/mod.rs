//! The store: an SQLite file (through `sqlx`) that keeps everything needed to
//! audit a number later — instruments, sessions, measurements with **every
//! raw sample**, renders, and comparisons.
//!
//! - Migrations (`migrations/`) are embedded in the binary and applied when
//!   the store opens; the database runs in WAL mode with foreign keys on
//!   and `synchronous = FULL` (a committed sample survives power loss).
//! - A sample is written when it is taken, so a crash or a pulled cable keeps
//!   the samples taken; a measurement is `complete` only with its average
//!   (the schema enforces it), and measurements left `running` or `queued` by
//!   a crash are marked `interrupted` when the store next opens, as are
//!   renders and studies left `queued` or `running`.
//! - Reflectances and lamp spectra measured against a white standard keep
//!   their provenance (`calibrations`).
//! - Times are POSIX seconds (f64, UTC); spectra are JSON arrays of numbers.
//!
//! ```no_run
//! # async fn demo() -> anyhow::Result<()> {
//! let store = lightbooth::store::Store::open("sqlite://lightbooth.sqlite").await?;
//! let listing = store.list_measurements(&Default::default()).await?;
//! # Ok(()) }
//! ```

mod calibrations;
mod display_profiles;
mod partial;
mod rows;

use std::str::FromStr;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use serde::{Deserialize, Serialize};
use sqlx::sqlite::{SqliteConnectOptions, SqliteJournalMode, SqlitePool, SqlitePoolOptions, SqliteSynchronous};
use sqlx::Row;

pub use calibrations::*;
pub use display_profiles::*;
pub use rows::*;

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
    pool: SqlitePool,
}

impl Store {
    /// Opens (creating if needed) the database at `url` (`sqlite://path` or
    /// `sqlite::memory:`), applies migrations, and marks measurements a crash
    /// left unfinished as interrupted.
    ///
    /// Durability: `synchronous = FULL`, so every committed write — each raw
    /// sample, each finished measurement — is on disk (WAL fsynced) before
    /// the call returns, and survives an OS crash or power loss, not only a
    /// crash of the daemon (NORMAL's promise in WAL mode, which can lose the
    /// last transactions on power loss). The cost is one fsync per commit;
    /// `cargo bench --bench sample_durability` measures it (see the README).
    pub async fn open(url: &str) -> Result<Store, StoreError> {
        Store::open_with_synchronous(url, SqliteSynchronous::Full).await
    }

    /// [`Store::open`] with another `synchronous` mode (the benchmark compares
    /// FULL with NORMAL).
    pub async fn open_with_synchronous(url: &str, synchronous: SqliteSynchronous) -> Result<Store, StoreError> {
        let options = SqliteConnectOptions::from_str(url)?
            .create_if_missing(true)
            .journal_mode(SqliteJournalMode::Wal)
            .synchronous(synchronous)
            .foreign_keys(true)
            .busy_timeout(Duration::from_secs(5));
        // An in-memory database lives per connection: keep exactly one.
        let max = if url.contains(":memory:") { 1 } else { 8 };
        let pool = SqlitePoolOptions::new()
            .max_connections(max)
            .connect_with(options)
            .await?;
        sqlx::migrate!("./migrations").run(&pool).await?;
        let store = Store { pool };
        let n = store
            .interrupt_unfinished("the daemon stopped before this measurement finished")
            .await?;
        if n > 0 {
            tracing::warn!(
                count = n,
                "marked measurements left unfinished by the last run as interrupted"
            );
        }
        for job in [Job::Render, Job::Study] {
            let n = store
                .interrupt_unfinished_jobs(
                    job,
                    &format!(
                        "the daemon stopped before this {} finished; retry it with POST /api/{}/{{id}}/retry",
                        job.noun(),
                        job.table()
                    ),
                )
                .await?;
            if n > 0 {
                tracing::warn!(
                    count = n,
                    "marked {} left unfinished by the last run as interrupted",
                    job.table()
                );
            }
        }
        Ok(store)
    }

    pub fn pool(&self) -> &SqlitePool {
        &self.pool
    }

    /// Marks every queued or running measurement interrupted (start-up after a crash).
    pub async fn interrupt_unfinished(&self, why: &str) -> Result<u64, StoreError> {
        let r = sqlx::query(
            "UPDATE measurements SET state = 'interrupted', error = ?, finished_at = ? \
             WHERE state IN ('queued', 'running')",
        )
        .bind(why)
        .bind(now())
        .execute(&self.pool)
        .await?;
        Ok(r.rows_affected())
    }

    /// Marks every queued or running render (or study) interrupted, with
    /// `why` as its error: at start-up after a crash, and at shutdown.
    pub async fn interrupt_unfinished_jobs(&self, job: Job, why: &str) -> Result<u64, StoreError> {
        let r = sqlx::query(&format!(
            "UPDATE {} SET state = 'interrupted', error = ?, finished_at = ? WHERE state IN ('queued', 'running')",
            job.table()
        ))
        .bind(why)
        .bind(now())
        .execute(&self.pool)
        .await?;
        Ok(r.rows_affected())
    }

    /// `queued → running` for a render or study. False when it is no longer
    /// queued (cancelled while it waited): it must not run.
    pub async fn start_job(&self, job: Job, id: i64) -> Result<bool, StoreError> {
        let r = sqlx::query(&format!(
            "UPDATE {} SET state = 'running' WHERE id = ? AND state = 'queued'",
            job.table()
        ))
        .bind(id)
        .execute(&self.pool)
        .await?;
        Ok(r.rows_affected() == 1)
    }

    /// Ends an unfinished render or study as failed, interrupted or
    /// cancelled; false when it had already ended.
    pub async fn end_job(&self, job: Job, id: i64, state: JobEnd, error: &str) -> Result<bool, StoreError> {
        let r = sqlx::query(&format!(
            "UPDATE {} SET state = ?, error = ?, finished_at = ? WHERE id = ? AND state IN ('queued', 'running')",
            job.table()
        ))
        .bind(state.as_str())
        .bind(error)
        .bind(now())
        .bind(id)
        .execute(&self.pool)
        .await?;
        Ok(r.rows_affected() == 1)
    }

    /// The state of a render or study (`None`: no such id).
    pub async fn job_state(&self, job: Job, id: i64) -> Result<Option<String>, StoreError> {
        Ok(
            sqlx::query_scalar(&format!("SELECT state FROM {} WHERE id = ?", job.table()))
                .bind(id)
                .fetch_optional(&self.pool)
                .await?,
        )
    }

    // --- instruments and sessions ---------------------------------------

    /// The id of an instrument, recording it the first time it is seen.
    pub async fn upsert_instrument(&self, model: &str, serial: Option<&str>, port: &str) -> Result<i64, StoreError> {
        let t = now();
        let row = sqlx::query(
            "INSERT INTO instruments (model, serial, port, first_seen, last_seen) VALUES (?, ?, ?, ?, ?) \
             ON CONFLICT (model, serial) DO UPDATE SET port = excluded.port, last_seen = excluded.last_seen \
             RETURNING id",
        )
        .bind(model)
        .bind(serial.unwrap_or(""))
        .bind(port)
        .bind(t)
        .bind(t)
        .fetch_one(&self.pool)
        .await?;
        Ok(row.get(0))
    }

    pub async fn list_instruments(&self) -> Result<Vec<InstrumentRow>, StoreError> {
        let rows = sqlx::query("SELECT id, model, serial, port, first_seen, last_seen FROM instruments ORDER BY id")
            .fetch_all(&self.pool)
            .await?;
        Ok(rows
            .iter()
            .map(|r| InstrumentRow {
                id: r.get("id"),
                model: r.get("model"),
                serial: r.get("serial"),
                port: r.get("port"),
                first_seen: r.get("first_seen"),
                last_seen: r.get("last_seen"),
            })
            .collect())
    }

    pub async fn create_session(&self, operator: &str, notes: &str) -> Result<i64, StoreError> {
        let row = sqlx::query("INSERT INTO sessions (operator, notes, started_at) VALUES (?, ?, ?) RETURNING id")
            .bind(operator)
            .bind(notes)
            .bind(now())
            .fetch_one(&self.pool)
            .await?;
        Ok(row.get(0))
    }

    pub async fn list_sessions(&self) -> Result<Vec<SessionRow>, StoreError> {
        let rows = sqlx::query("SELECT id, operator, notes, started_at FROM sessions ORDER BY id DESC")
            .fetch_all(&self.pool)
            .await?;
        Ok(rows
            .iter()
            .map(|r| SessionRow {
                id: r.get("id"),
                operator: r.get("operator"),
                notes: r.get("notes"),
                started_at: r.get("started_at"),
            })
            .collect())
    }

    // --- measurements -----------------------------------------------------

    /// Records a requested measurement as `queued`.
    pub async fn create_measurement(&self, m: &NewMeasurement) -> Result<i64, StoreError> {
        let row = sqlx::query(
            "INSERT INTO measurements (session_id, scene, target, samples_requested, settings_json, state, note, created_at) \
             VALUES (?, ?, ?, ?, ?, 'queued', ?, ?) RETURNING id",
        )
        .bind(m.session_id)
        .bind(&m.scene)
        .bind(&m.target)
        .bind(m.samples as i64)
        .bind(m.settings_json.to_string())
        .bind(&m.note)
        .bind(now())
        .fetch_one(&self.pool)
        .await?;
        Ok(row.get(0))
    }

    /// `queued → running`, naming the instrument that takes it.
    pub async fn mark_running(&self, id: i64, instrument_id: Option<i64>) -> Result<(), StoreError> {
        let r = sqlx::query(
            "UPDATE measurements SET state = 'running', instrument_id = ?, started_at = ? WHERE id = ? AND state = 'queued'",
        )
        .bind(instrument_id)
        .bind(now())
        .bind(id)
        .execute(&self.pool)
        .await?;
        if r.rows_affected() != 1 {
            return Err(StoreError::Conflict(format!("measurement {id} is not queued")));
        }
        Ok(())
    }

    /// Writes one raw sample, as it is taken.
    pub async fn insert_sample(&self, measurement_id: i64, s: &NewSample) -> Result<(), StoreError> {
        sqlx::query(
            "INSERT INTO samples (measurement_id, idx, taken_at, code, message, usable, radiance_json, luminance_cd_m2) \
             VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
        )
        .bind(measurement_id)
        .bind(s.index as i64)
        .bind(s.taken_at)
        .bind(s.code)
        .bind(&s.message)
        .bind(s.usable)
        .bind(s.radiance.as_ref().map(|r| json_array(r)))
        .bind(s.luminance_cd_m2)
        .execute(&self.pool)
        .await?;
        Ok(())
    }

    /// `running → complete` with the average; one transaction.
    pub async fn complete_measurement(&self, id: i64, a: &Average) -> Result<(), StoreError> {
        let r = sqlx::query(
            "UPDATE measurements SET state = 'complete', finished_at = ?, wavelength_json = ?, radiance_json = ?, \
             radiance_sd_json = ?, luminance_cd_m2 = ?, x = ?, y = ?, luminance_cv = ?, observer = ?, xyz_x = ?, \
             xyz_y = ?, xyz_z = ? WHERE id = ? AND state = 'running'",
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
        .execute(&self.pool)
        .await?;
        if r.rows_affected() != 1 {
            return Err(StoreError::Conflict(format!("measurement {id} is not running")));
        }
        Ok(())
    }

    /// Ends an unfinished measurement as failed, interrupted or cancelled.
    pub async fn end_measurement(&self, id: i64, state: MeasurementState, error: &str) -> Result<(), StoreError> {
        debug_assert!(state.is_final() && state != MeasurementState::Complete);
        sqlx::query(
            "UPDATE measurements SET state = ?, error = ?, finished_at = ? WHERE id = ? AND state IN ('queued', 'running')",
        )
        .bind(state.as_str())
        .bind(error)
        .bind(now())
        .bind(id)
        .execute(&self.pool)
        .await?;
        Ok(())
    }

    /// `queued → cancelled`, only while it is still queued (so a measurement
    /// the instrument has started is never ended here). True when it was.
    pub async fn cancel_queued(&self, id: i64, message: &str) -> Result<bool, StoreError> {
        let r = sqlx::query(
            "UPDATE measurements SET state = 'cancelled', error = ?, finished_at = ? WHERE id = ? AND state = 'queued'",
        )
        .bind(message)
        .bind(now())
        .bind(id)
        .execute(&self.pool)
        .await?;
        Ok(r.rows_affected() == 1)
    }

    /// Every (scene, target) with at least one complete measurement.
    pub async fn measured_targets(&self) -> Result<Vec<(String, String)>, StoreError> {
        let rows = sqlx::query(
            "SELECT DISTINCT scene, target FROM measurements \
             WHERE state = 'complete' AND scene IS NOT NULL AND target IS NOT NULL",
        )
        .fetch_all(&self.pool)
        .await?;
        Ok(rows.iter().map(|r| (r.get("scene"), r.get("target"))).collect())
    }

    /// One measurement with all its samples.
    pub async fn get_measurement(&self, id: i64) -> Result<Option<MeasurementDetail>, StoreError> {
        let Some(row) = sqlx::query(&format!(
            "SELECT {MEASUREMENT_COLUMNS}, wavelength_json, radiance_json, radiance_sd_json FROM measurements WHERE id = ?"
        ))
            .bind(id)
            .fetch_optional(&self.pool)
            .await?
        else {
            return Ok(None);
        };
        let mut summary = measurement_from_row(&row)?;
        self.fill_partial_averages(std::slice::from_mut(&mut summary)).await?;
        let sample_rows = sqlx::query(
            "SELECT idx, taken_at, code, message, usable, radiance_json, luminance_cd_m2 FROM samples \
             WHERE measurement_id = ? ORDER BY idx",
        )
        .bind(id)
        .fetch_all(&self.pool)
        .await?;
        let samples = sample_rows
            .iter()
            .map(|r| {
                Ok(SampleRow {
                    index: r.get::<i64, _>("idx") as usize,
                    time: r.get("taken_at"),
                    code: r.get("code"),
                    message: r.get("message"),
                    usable: r.get("usable"),
                    radiance: parse_opt_array(r.get("radiance_json"), "sample radiance")?,
                    luminance_cd_m2: r.get("luminance_cd_m2"),
                })
            })
            .collect::<Result<Vec<_>, StoreError>>()?;
        let wavelength_nm = parse_opt_array(row.get("wavelength_json"), "wavelengths")?;
        let radiance = parse_opt_array(row.get("radiance_json"), "mean radiance")?;
        let radiance_sd = parse_opt_array(row.get("radiance_sd_json"), "radiance SD")?;
        Ok(Some(MeasurementDetail {
            summary,
            wavelength_nm,
            radiance,
            radiance_sd,
            samples,
        }))
    }

    /// A page of measurements, newest first, with optional filters.
    pub async fn list_measurements(&self, f: &MeasurementFilter) -> Result<MeasurementPage, StoreError> {
        let mut conditions = Vec::new();
        if f.scene.is_some() {
            conditions.push("scene = ?");
        }
        if f.target.is_some() {
            conditions.push("target = ?");
        }
        if f.state.is_some() {
            conditions.push("state = ?");
        }
        // No `WHERE 1 = 1`: an unfiltered COUNT(*) then uses SQLite's fast path.
        let where_sql = if conditions.is_empty() {
            String::new()
        } else {
            format!(" WHERE {}", conditions.join(" AND "))
        };
        let count_sql = format!("SELECT COUNT(*) FROM measurements{where_sql}");
        let total: i64 = bind_filters(&count_sql, f).fetch_one(&self.pool).await?.get(0);
        let limit = f.limit.unwrap_or(50).clamp(1, 1000);
        let offset = f.offset.unwrap_or(0).max(0);
        // The page's ids come from the primary key alone; only those rows'
        // columns (and sample counts) are computed. With the columns in the
        // paging query itself, SQLite evaluates them for every skipped row.
        let list_sql = format!(
            "SELECT {MEASUREMENT_COLUMNS} FROM measurements WHERE id IN (\
             SELECT id FROM measurements{where_sql} ORDER BY id DESC LIMIT {limit} OFFSET {offset}) ORDER BY id DESC"
        );
        let rows = bind_filters(&list_sql, f).fetch_all(&self.pool).await?;
        let mut items = rows.iter().map(measurement_from_row).collect::<Result<Vec<_>, _>>()?;
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
        let id: Option<i64> = sqlx::query_scalar(
            "SELECT id FROM measurements WHERE scene = ? AND target = ? AND state = 'complete' ORDER BY id DESC LIMIT 1",
        )
        .bind(scene)
        .bind(target)
        .fetch_optional(&self.pool)
        .await?;
        match id {
            Some(id) => self.get_measurement(id).await,
            None => Ok(None),
        }
    }

    // --- renders ----------------------------------------------------------

    pub async fn create_render(&self, r: &NewRender) -> Result<i64, StoreError> {
        let row = sqlx::query(
            "INSERT INTO renders (scene, scene_hash, settings_json, codings, seed, state, created_at) \
             VALUES (?, ?, ?, ?, ?, 'queued', ?) RETURNING id",
        )
        .bind(&r.scene)
        .bind(&r.scene_hash)
        .bind(r.settings_json.to_string())
        .bind(r.codings.join(","))
        .bind(r.seed as i64)
        .bind(now())
        .fetch_one(&self.pool)
        .await?;
        Ok(row.get(0))
    }

    pub async fn finish_render(
        &self,
        id: i64,
        result: Result<(&serde_json::Value, f64), &str>,
    ) -> Result<(), StoreError> {
        match result {
            Ok((json, wall)) => {
                sqlx::query(
                    "UPDATE renders SET state = 'complete', result_json = ?, wall_seconds = ?, finished_at = ? \
                     WHERE id = ? AND state = 'running'",
                )
                .bind(json.to_string())
                .bind(wall)
                .bind(now())
                .bind(id)
                .execute(&self.pool)
                .await?
            }
            Err(e) => {
                sqlx::query(
                    "UPDATE renders SET state = 'failed', error = ?, finished_at = ? \
                     WHERE id = ? AND state IN ('queued', 'running')",
                )
                .bind(e)
                .bind(now())
                .bind(id)
                .execute(&self.pool)
                .await?
            }
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
        let row = sqlx::query(
            "SELECT id, result_json FROM renders WHERE scene_hash = ? AND settings_json = ? AND state = 'complete' \
             ORDER BY id DESC LIMIT 1",
        )
        .bind(scene_hash)
        .bind(settings.to_string())
        .fetch_optional(&self.pool)
        .await?;
        let Some(row) = row else { return Ok(None) };
        let text: String = row.get("result_json");
        let json = serde_json::from_str(&text).map_err(|e| StoreError::Corrupt {
            what: "renders.result_json".into(),
            err: e.to_string(),
        })?;
        Ok(Some((row.get("id"), json)))
    }

    /// Stores a render's preview image (PNG bytes).
    pub async fn set_render_preview(&self, id: i64, png: &[u8]) -> Result<(), StoreError> {
        sqlx::query("UPDATE renders SET preview_png = ? WHERE id = ?")
            .bind(png)
            .bind(id)
            .execute(&self.pool)
            .await?;
        Ok(())
    }

    /// A render's preview PNG, if it has one.
    pub async fn render_preview(&self, id: i64) -> Result<Option<Vec<u8>>, StoreError> {
        Ok(
            sqlx::query_scalar::<_, Option<Vec<u8>>>("SELECT preview_png FROM renders WHERE id = ?")
                .bind(id)
                .fetch_optional(&self.pool)
                .await?
                .flatten(),
        )
    }

    pub async fn get_render(&self, id: i64) -> Result<Option<RenderRow>, StoreError> {
        let row = sqlx::query(&format!("SELECT {RENDER_COLUMNS} FROM renders WHERE id = ?"))
            .bind(id)
            .fetch_optional(&self.pool)
            .await?;
        row.as_ref().map(render_from_row).transpose()
    }

    pub async fn list_renders(&self, scene: Option<&str>) -> Result<Vec<RenderRow>, StoreError> {
        let rows = match scene {
            Some(s) => {
                sqlx::query(&format!(
                    "SELECT {RENDER_COLUMNS} FROM renders WHERE scene = ? ORDER BY id DESC"
                ))
                .bind(s)
                .fetch_all(&self.pool)
                .await?
            }
            None => {
                sqlx::query(&format!(
                    "SELECT {RENDER_COLUMNS} FROM renders ORDER BY id DESC LIMIT 200"
                ))
                .fetch_all(&self.pool)
                .await?
            }
        };
        rows.iter().map(render_from_row).collect()
    }

    // --- studies ----------------------------------------------------------

    /// Records a study as `queued`.
    pub async fn create_study(&self, request: &serde_json::Value) -> Result<i64, StoreError> {
        let row =
            sqlx::query("INSERT INTO studies (request_json, state, created_at) VALUES (?, 'queued', ?) RETURNING id")
                .bind(request.to_string())
                .bind(now())
                .fetch_one(&self.pool)
                .await?;
        Ok(row.get(0))
    }

    /// Stores a finished study with its report files, in one transaction.
    pub async fn complete_study(
        &self,
        id: i64,
        result: &serde_json::Value,
        wall_seconds: f64,
        files: &[(String, Vec<u8>)],
    ) -> Result<(), StoreError> {
        let mut tx = self.pool.begin().await?;
        for (name, content) in files {
            sqlx::query("INSERT INTO study_files (study_id, name, content) VALUES (?, ?, ?)")
                .bind(id)
                .bind(name)
                .bind(content)
                .execute(&mut *tx)
                .await?;
        }
        let r = sqlx::query(
            "UPDATE studies SET state = 'complete', result_json = ?, wall_seconds = ?, finished_at = ? \
             WHERE id = ? AND state = 'running'",
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
        Ok(())
    }

    pub async fn fail_study(&self, id: i64, error: &str) -> Result<(), StoreError> {
        sqlx::query(
            "UPDATE studies SET state = 'failed', error = ?, finished_at = ? WHERE id = ? AND state = 'running'",
        )
        .bind(error)
        .bind(now())
        .bind(id)
        .execute(&self.pool)
        .await?;
        Ok(())
    }

    /// The stored studies, newest first, without their results.
    pub async fn list_studies(&self) -> Result<Vec<StudyRow>, StoreError> {
        let rows = sqlx::query(
            "SELECT id, request_json, state, error, created_at, finished_at, wall_seconds FROM studies ORDER BY id DESC",
        )
        .fetch_all(&self.pool)
        .await?;
        rows.iter().map(|r| study_from_row(r, false)).collect()
    }

    /// One study with its result and the names of its report files.
    pub async fn get_study(&self, id: i64) -> Result<Option<StudyRow>, StoreError> {
        let Some(row) = sqlx::query("SELECT * FROM studies WHERE id = ?")
            .bind(id)
            .fetch_optional(&self.pool)
            .await?
        else {
            return Ok(None);
        };
        let mut study = study_from_row(&row, true)?;
        study.files = sqlx::query_scalar("SELECT name FROM study_files WHERE study_id = ? ORDER BY name")
            .bind(id)
            .fetch_all(&self.pool)
            .await?;
        Ok(Some(study))
    }

    pub async fn study_file(&self, id: i64, name: &str) -> Result<Option<Vec<u8>>, StoreError> {
        Ok(
            sqlx::query_scalar("SELECT content FROM study_files WHERE study_id = ? AND name = ?")
                .bind(id)
                .bind(name)
                .fetch_optional(&self.pool)
                .await?,
        )
    }

    // --- comparisons ------------------------------------------------------

    /// Stores the comparisons of one measurement against one render, all
    /// codings in one transaction (all or nothing).
    pub async fn insert_comparisons(&self, rows: &[NewComparison]) -> Result<(), StoreError> {
        let mut tx = self.pool.begin().await?;
        for c in rows {
            sqlx::query(
                "INSERT INTO comparisons (measurement_id, render_id, scene, target, coding, white_source, \
                 white_x, white_y, white_z, measured_x, measured_y, measured_z, rendered_x, rendered_y, rendered_z, \
                 rendered_y_se, y_ratio, xy_distance, de76, de00, created_at, observer, measured_y_se) \
                 VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
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
        Ok(())
    }

    /// For each (target, coding) of a scene, the newest comparison.
    pub async fn latest_comparisons(&self, scene: &str) -> Result<Vec<ComparisonRow>, StoreError> {
        let rows = sqlx::query(
            "SELECT c.* FROM comparisons c JOIN ( \
                 SELECT target, coding, MAX(id) AS id FROM comparisons WHERE scene = ? GROUP BY target, coding \
             ) latest ON latest.id = c.id ORDER BY c.target, c.coding",
        )
        .bind(scene)
        .fetch_all(&self.pool)
        .await?;
        Ok(rows.iter().map(comparison_from_row).collect())
    }

    /// Every comparison of a scene, oldest first.
    pub async fn comparisons_of_scene(&self, scene: &str) -> Result<Vec<ComparisonRow>, StoreError> {
        let rows = sqlx::query("SELECT * FROM comparisons WHERE scene = ? ORDER BY id")
            .bind(scene)
            .fetch_all(&self.pool)
            .await?;
        Ok(rows.iter().map(comparison_from_row).collect())
    }

    /// Rewrites the CIELAB white of comparisons and the ΔE computed with it
    /// (`(id, white_source, white XYZ, ΔE*ab, ΔE00)`), all in one transaction.
    pub async fn update_comparison_whites(
        &self,
        updates: &[(i64, String, [f64; 3], f64, f64)],
    ) -> Result<(), StoreError> {
        let mut tx = self.pool.begin().await?;
        for (id, source, white, de76, de00) in updates {
            sqlx::query(
                "UPDATE comparisons SET white_source = ?, white_x = ?, white_y = ?, white_z = ?, de76 = ?, de00 = ? \
                 WHERE id = ?",
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
        Ok(())
    }

    pub async fn comparisons_for_measurement(&self, measurement_id: i64) -> Result<Vec<ComparisonRow>, StoreError> {
        let rows = sqlx::query("SELECT * FROM comparisons WHERE measurement_id = ? ORDER BY id")
            .bind(measurement_id)
            .fetch_all(&self.pool)
            .await?;
        Ok(rows.iter().map(comparison_from_row).collect())
    }
}

/// Binds the optional filters of [`Store::list_measurements`] in the order
/// its WHERE clause names them.
fn bind_filters<'q>(
    sql: &'q str,
    f: &MeasurementFilter,
) -> sqlx::query::Query<'q, sqlx::Sqlite, sqlx::sqlite::SqliteArguments<'q>> {
    let mut q = sqlx::query(sql);
    if let Some(s) = &f.scene {
        q = q.bind(s.clone());
    }
    if let Some(t) = &f.target {
        q = q.bind(t.clone());
    }
    if let Some(s) = f.state {
        q = q.bind(s.as_str());
    }
    q
}

fn json_array(v: &[f64]) -> String {
    serde_json::to_string(v).expect("finite numbers serialise")
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
mod tests;
