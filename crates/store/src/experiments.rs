//! Oddity experiments (`migrations/0015`): the experiment, its observers,
//! their sessions and every trial, stored as it ends.
//!
//! A session's trial order is not stored: it follows from the session's
//! seed ([`lightbooth_science::psychophysics::design::session_order`]) and the trials
//! recorded (each trial with a frame dropped during its pie is shown again
//! at the end). [`Store::insert_trial`] takes trials only in that order, one
//! position at a time, and only while the session runs, so two tabs of one
//! session cannot both record trial 12.

use crate::BoxFuture;
use serde::Serialize;

/// A stored verification of an experiment: (id, created_at, result).
pub type StoredVerification = (i64, f64, serde_json::Value);

use super::{now, Store, StoreError};

/// What [`Store::insert_experiment`] stores.
pub struct NewExperiment<'a> {
    pub name: &'a str,
    pub scene: &'a str,
    pub target: &'a str,
    pub booth: &'a str,
    pub measurement_id: i64,
    pub display_profile_id: i64,
    pub output_method: &'a str,
    pub seed: i64,
    pub request: &'a serde_json::Value,
    pub check: &'a serde_json::Value,
}

/// A stored experiment.
#[derive(Clone, Debug, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ExperimentRow {
    pub id: i64,
    pub name: String,
    /// POSIX seconds, UTC.
    pub created_at: f64,
    pub scene: String,
    pub target: String,
    pub booth: String,
    pub measurement_id: i64,
    pub display_profile_id: i64,
    pub output_method: String,
    /// The trial orders' seed: at most 2⁵³ − 1 for experiments made since
    /// issue 32 (exact as a JSON number in JavaScript and MATLAB).
    pub seed: i64,
    /// The seed as a decimal string: exact in every client, whatever its size.
    pub seed_text: String,
    /// The request with its defaults filled in.
    #[cfg_attr(feature = "openapi", schema(value_type = Object))]
    pub request: serde_json::Value,
    /// Every colour through the display profile at creation.
    #[cfg_attr(feature = "openapi", schema(value_type = Object))]
    pub check: serde_json::Value,
}

#[derive(sqlx::FromRow)]
struct ExperimentRecord {
    id: i64,
    name: String,
    created_at: f64,
    scene: String,
    target: String,
    booth: String,
    measurement_id: i64,
    display_profile_id: i64,
    output_method: String,
    seed: i64,
    request_json: String,
    check_json: String,
}

impl TryFrom<ExperimentRecord> for ExperimentRow {
    type Error = StoreError;
    fn try_from(r: ExperimentRecord) -> Result<Self, StoreError> {
        let parse = |column: &str, text: &str| {
            serde_json::from_str(text).map_err(|e| StoreError::Corrupt {
                what: format!("experiments.{column} of experiment {}", r.id),
                err: e.to_string(),
            })
        };
        Ok(ExperimentRow {
            request: parse("request_json", &r.request_json)?,
            check: parse("check_json", &r.check_json)?,
            id: r.id,
            name: r.name,
            created_at: r.created_at,
            scene: r.scene,
            target: r.target,
            booth: r.booth,
            measurement_id: r.measurement_id,
            display_profile_id: r.display_profile_id,
            output_method: r.output_method,
            seed: r.seed,
            seed_text: r.seed.to_string(),
        })
    }
}

/// One observer's session of an experiment.
#[derive(Clone, Debug, PartialEq, Serialize, sqlx::FromRow)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ExperimentSessionRow {
    pub id: i64,
    pub experiment_id: i64,
    pub observer_id: String,
    pub seed: i64,
    pub created_at: f64,
    /// `running` or `complete`.
    pub state: String,
    pub finished_at: Option<f64>,
    /// The display's frame interval as the page measured it (median, ms).
    pub frame_ms: Option<f64>,
    /// The page's browser and output path, as it reported them.
    pub client: String,
    /// A duplicate running session from before one running session per
    /// observer was enforced (`migrations/0016`): the session that holds
    /// the observer's run instead. Its trials are kept and counted.
    pub superseded_by: Option<i64>,
    /// When it was last started, resumed, told the display's refresh or
    /// given a trial (POSIX seconds, UTC).
    pub touched_at: Option<f64>,
    /// Trials recorded, counted or not.
    pub trials_recorded: i64,
}

/// A session's columns and its trial count.
const SESSION_SELECT: &str =
    "SELECT s.*, (SELECT COUNT(*) FROM trials t WHERE t.session_id = s.id) AS trials_recorded \
     FROM experiment_sessions s";

/// A running session with its counts, for `/api/jobs` and the start-up
/// repair: no trial is read.
#[derive(Clone, Debug, PartialEq, sqlx::FromRow)]
pub struct RunningSessionCounts {
    pub id: i64,
    pub experiment_id: i64,
    pub experiment_name: String,
    pub scene: String,
    pub observer_id: String,
    pub created_at: f64,
    pub touched_at: f64,
    /// The experiment's stored request (for its approximations and repeats).
    pub request_json: String,
    pub trials: i64,
    /// Trials with a frame dropped during the pie.
    pub dropped: i64,
}

/// A trial as it ended.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct TrialRow {
    pub session_id: i64,
    /// 0, 1, … in the order shown.
    pub position: i64,
    /// The coding tested against the original.
    pub approximation: String,
    /// Left, top, right: `O` the original, `N` the approximation, e.g. `OON`.
    pub configuration: String,
    /// 0 left, 1 top, 2 right.
    pub response: i64,
    pub correct: bool,
    pub reaction_ms: f64,
    pub stimulus_frames: i64,
    pub dropped_frames: i64,
    /// A frame was dropped while the pie was shown: the trial is shown again
    /// at the end of the block and not counted.
    pub dropped_in_stimulus: bool,
    pub frame_intervals_ms: Vec<f64>,
    pub created_at: f64,
}

#[derive(sqlx::FromRow)]
struct TrialRecord {
    session_id: i64,
    position: i64,
    approximation: String,
    configuration: String,
    response: i64,
    correct: bool,
    reaction_ms: f64,
    stimulus_frames: i64,
    dropped_frames: i64,
    dropped_in_stimulus: bool,
    frame_intervals_json: String,
    created_at: f64,
}

impl TryFrom<TrialRecord> for TrialRow {
    type Error = StoreError;
    fn try_from(r: TrialRecord) -> Result<Self, StoreError> {
        let frame_intervals_ms = serde_json::from_str(&r.frame_intervals_json).map_err(|e| StoreError::Corrupt {
            what: format!(
                "trials.frame_intervals_json of session {} trial {}",
                r.session_id, r.position
            ),
            err: e.to_string(),
        })?;
        Ok(TrialRow {
            session_id: r.session_id,
            position: r.position,
            approximation: r.approximation,
            configuration: r.configuration,
            response: r.response,
            correct: r.correct,
            reaction_ms: r.reaction_ms,
            stimulus_frames: r.stimulus_frames,
            dropped_frames: r.dropped_frames,
            dropped_in_stimulus: r.dropped_in_stimulus,
            frame_intervals_ms,
            created_at: r.created_at,
        })
    }
}

/// A trial of a session with its observer, for an experiment's analysis.
#[derive(Clone, Debug, PartialEq)]
pub struct ObservedTrial {
    pub observer_id: String,
    pub trial: TrialRow,
}

const TRIAL_COLUMNS: &str = "t.session_id, t.position, t.approximation, t.configuration, t.response, t.correct, \
     t.reaction_ms, t.stimulus_frames, t.dropped_frames, t.dropped_in_stimulus, t.frame_intervals_json, t.created_at";

impl Store {
    /// Stores an experiment; returns its id.
    pub fn insert_experiment<'a>(&'a self, e: &'a NewExperiment<'a>) -> BoxFuture<'a, Result<i64, StoreError>> {
        Box::pin(async move {
            Ok(with_pool!(self, |pool| sqlx::query_scalar(
                "INSERT INTO experiments (name, created_at, scene, target, booth, measurement_id, display_profile_id, \
                 output_method, seed, request_json, check_json) VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11) \
                 RETURNING id",
            )
            .bind(e.name)
            .bind(now())
            .bind(e.scene)
            .bind(e.target)
            .bind(e.booth)
            .bind(e.measurement_id)
            .bind(e.display_profile_id)
            .bind(e.output_method)
            .bind(e.seed)
            .bind(e.request.to_string())
            .bind(e.check.to_string())
            .fetch_one(pool)
            .await?))
        })
    }

    pub fn get_experiment<'a>(&'a self, id: i64) -> BoxFuture<'a, Result<Option<ExperimentRow>, StoreError>> {
        Box::pin(async move {
            with_pool!(self, |pool| sqlx::query_as::<_, ExperimentRecord>(
                "SELECT * FROM experiments WHERE id = $1"
            )
            .bind(id)
            .fetch_optional(pool)
            .await?)
            .map(ExperimentRow::try_from)
            .transpose()
        })
    }

    /// Every experiment, newest first.
    pub fn list_experiments<'a>(&'a self) -> BoxFuture<'a, Result<Vec<ExperimentRow>, StoreError>> {
        Box::pin(async move {
            with_pool!(self, |pool| sqlx::query_as::<_, ExperimentRecord>(
                "SELECT * FROM experiments ORDER BY id DESC"
            )
            .fetch_all(pool)
            .await?)
            .into_iter()
            .map(ExperimentRow::try_from)
            .collect()
        })
    }

    /// Starts a session of `observer` (recorded on first use), its seed
    /// `seed_of` its id; or, when the observer has a running session of
    /// the experiment, returns that one. One transaction, and a unique index
    /// (`migrations/0016`): two starts at once give one session.
    /// Returns the session's id and whether it was created.
    pub async fn create_experiment_session(
        &self,
        experiment_id: i64,
        observer: &str,
        seed_of: impl Fn(i64) -> i64,
    ) -> Result<(i64, bool), StoreError> {
        Ok(with_pool!(self, |pool| {
            let mut tx = pool.begin().await?;
            let at = now();
            // A write first: it takes SQLite's write lock before anything is read.
            sqlx::query("INSERT INTO observers (id, created_at) VALUES ($1, $2) ON CONFLICT (id) DO NOTHING")
                .bind(observer)
                .bind(at)
                .execute(&mut *tx)
                .await?;
            let created: Option<i64> = sqlx::query_scalar(
                "INSERT INTO experiment_sessions (experiment_id, observer_id, seed, created_at, touched_at, state) \
                 VALUES ($1, $2, 0, $3, $3, 'running') ON CONFLICT DO NOTHING RETURNING id",
            )
            .bind(experiment_id)
            .bind(observer)
            .bind(at)
            .fetch_optional(&mut *tx)
            .await?;
            let found = match created {
                Some(id) => {
                    sqlx::query("UPDATE experiment_sessions SET seed = $1 WHERE id = $2")
                        .bind(seed_of(id))
                        .bind(id)
                        .execute(&mut *tx)
                        .await?;
                    (id, true)
                }
                None => {
                    let id: i64 = sqlx::query_scalar(
                        "UPDATE experiment_sessions SET touched_at = $3 WHERE experiment_id = $1 AND observer_id = $2 \
                         AND state = 'running' AND superseded_by IS NULL RETURNING id",
                    )
                    .bind(experiment_id)
                    .bind(observer)
                    .bind(at)
                    .fetch_one(&mut *tx)
                    .await?;
                    (id, false)
                }
            };
            tx.commit().await?;
            self.wrote();
            found
        }))
    }

    /// The running session of `observer` in an experiment, if any.
    pub fn running_session_of<'a>(
        &'a self,
        experiment_id: i64,
        observer: &'a str,
    ) -> BoxFuture<'a, Result<Option<i64>, StoreError>> {
        Box::pin(async move {
            Ok(with_pool!(self, |pool| sqlx::query_scalar(
                "SELECT id FROM experiment_sessions WHERE experiment_id = $1 AND observer_id = $2 \
                 AND state = 'running' AND superseded_by IS NULL"
            )
            .bind(experiment_id)
            .bind(observer)
            .fetch_optional(pool)
            .await?))
        })
    }

    pub fn get_experiment_session<'a>(
        &'a self,
        id: i64,
    ) -> BoxFuture<'a, Result<Option<ExperimentSessionRow>, StoreError>> {
        Box::pin(async move {
            let sql = format!("{SESSION_SELECT} WHERE s.id = $1");
            Ok(with_pool!(self, |pool| sqlx::query_as::<_, ExperimentSessionRow>(&sql)
                .bind(id)
                .fetch_optional(pool)
                .await?))
        })
    }

    /// An experiment's sessions, oldest first.
    pub fn sessions_of_experiment<'a>(
        &'a self,
        experiment_id: i64,
    ) -> BoxFuture<'a, Result<Vec<ExperimentSessionRow>, StoreError>> {
        Box::pin(async move {
            let sql = format!("{SESSION_SELECT} WHERE s.experiment_id = $1 ORDER BY s.id");
            Ok(with_pool!(self, |pool| sqlx::query_as::<_, ExperimentSessionRow>(&sql)
                .bind(experiment_id)
                .fetch_all(pool)
                .await?))
        })
    }

    /// The running sessions of the experiments of `booth`, oldest first,
    /// with their counts (one query, no trial read).
    pub fn running_experiment_sessions<'a>(
        &'a self,
        booth: &'a str,
    ) -> BoxFuture<'a, Result<Vec<RunningSessionCounts>, StoreError>> {
        Box::pin(async move {
            const SQL: &str =
                "SELECT s.id, s.experiment_id, e.name AS experiment_name, e.scene, s.observer_id, s.created_at, \
                 COALESCE(s.touched_at, s.created_at) AS touched_at, e.request_json, \
                 (SELECT COUNT(*) FROM trials t WHERE t.session_id = s.id) AS trials, \
                 (SELECT COUNT(*) FROM trials t WHERE t.session_id = s.id AND t.dropped_in_stimulus) AS dropped \
                 FROM experiment_sessions s JOIN experiments e ON e.id = s.experiment_id \
                 WHERE s.state = 'running' AND s.superseded_by IS NULL AND e.booth = $1 ORDER BY s.id";
            Ok(with_pool!(self, |pool| sqlx::query_as::<_, RunningSessionCounts>(SQL)
                .bind(booth)
                .fetch_all(pool)
                .await?))
        })
    }

    /// The refresh the page measured and what it runs on, while the
    /// session runs; false (nothing written) once it has ended.
    pub fn set_session_display<'a>(
        &'a self,
        id: i64,
        frame_ms: f64,
        client: &'a str,
    ) -> BoxFuture<'a, Result<bool, StoreError>> {
        Box::pin(async move {
            let changed = with_pool!(self, |pool| sqlx::query(
                "UPDATE experiment_sessions SET frame_ms = $1, client = $2, touched_at = $3 \
                 WHERE id = $4 AND state = 'running'"
            )
            .bind(frame_ms)
            .bind(client)
            .bind(now())
            .bind(id)
            .execute(pool)
            .await?
            .rows_affected());
            Ok(changed == 1)
        })
    }

    /// Records a trial at `trial.position`, which must be the next one of a
    /// running session; otherwise a [`StoreError::Conflict`] says which is.
    /// With `last`, the same transaction marks the session complete: a
    /// session is never left running with all its trials (issue 32).
    pub fn insert_trial<'a>(&'a self, trial: &'a TrialRow, last: bool) -> BoxFuture<'a, Result<(), StoreError>> {
        Box::pin(async move {
            let session = trial.session_id;
            let intervals = serde_json::to_string(&trial.frame_intervals_ms).expect("finite numbers serialise");
            with_pool!(self, |pool| {
                let mut tx = pool.begin().await?;
                // A write first: it takes SQLite's write lock (waiting out a busy
                // database) and PostgreSQL's row lock before anything is read. A
                // read first would let another writer commit in between, and
                // SQLite would then refuse this transaction's write outright
                // (SQLITE_BUSY_SNAPSHOT, "database is locked", no retry).
                let state: Option<String> =
                    sqlx::query_scalar("UPDATE experiment_sessions SET state = state WHERE id = $1 RETURNING state")
                        .bind(session)
                        .fetch_optional(&mut *tx)
                        .await?;
                match state.as_deref() {
                    None => return Err(StoreError::Conflict(format!("there is no session {session}"))),
                    Some("running") => {}
                    Some(s) => {
                        return Err(StoreError::Conflict(format!(
                            "session {session} is {s}: it takes no more trials"
                        )))
                    }
                }
                let recorded: i64 = sqlx::query_scalar("SELECT COUNT(*) FROM trials WHERE session_id = $1")
                    .bind(session)
                    .fetch_one(&mut *tx)
                    .await?;
                if recorded != trial.position {
                    return Err(StoreError::Conflict(format!(
                        "session {session} has {recorded} trials recorded: the next is trial {recorded}, not {}",
                        trial.position
                    )));
                }
                let inserted = sqlx::query(
                    "INSERT INTO trials (session_id, position, approximation, configuration, response, correct, reaction_ms, \
                     stimulus_frames, dropped_frames, dropped_in_stimulus, frame_intervals_json, created_at) \
                     VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12)",
                )
                .bind(session)
                .bind(trial.position)
                .bind(&trial.approximation)
                .bind(&trial.configuration)
                .bind(trial.response)
                .bind(trial.correct)
                .bind(trial.reaction_ms)
                .bind(trial.stimulus_frames)
                .bind(trial.dropped_frames)
                .bind(trial.dropped_in_stimulus)
                .bind(&intervals)
                .bind(trial.created_at)
                .execute(&mut *tx)
                .await;
                match inserted {
                    Err(sqlx::Error::Database(db)) if db.is_unique_violation() => {
                        return Err(StoreError::Conflict(format!(
                            "trial {} of session {session} is already recorded",
                            trial.position
                        )))
                    }
                    other => other?,
                };
                sqlx::query(
                    "UPDATE experiment_sessions SET touched_at = $1, state = CASE WHEN $2 THEN 'complete' ELSE state END, \
                     finished_at = CASE WHEN $2 THEN $1 ELSE finished_at END WHERE id = $3",
                )
                .bind(trial.created_at)
                .bind(last)
                .bind(session)
                .execute(&mut *tx)
                .await?;
                tx.commit().await?;
            });
            self.wrote();
            Ok(())
        })
    }

    /// Marks a running session complete (the start-up repair of a session
    /// found with all its trials; a trial that ends a session completes it
    /// itself, [`Store::insert_trial`]).
    pub fn finish_experiment_session<'a>(&'a self, id: i64) -> BoxFuture<'a, Result<(), StoreError>> {
        Box::pin(async move {
            with_pool!(self, |pool| {
                sqlx::query(
                "UPDATE experiment_sessions SET state = 'complete', finished_at = $1 WHERE id = $2 AND state = 'running'"
            )
            .bind(now())
            .bind(id)
            .execute(pool)
            .await?
            .rows_affected()
            });
            self.wrote();
            Ok(())
        })
    }

    /// A session's trials in the order shown.
    pub fn trials_of_session<'a>(&'a self, session_id: i64) -> BoxFuture<'a, Result<Vec<TrialRow>, StoreError>> {
        Box::pin(async move {
            let sql = format!("SELECT {TRIAL_COLUMNS} FROM trials t WHERE t.session_id = $1 ORDER BY t.position");
            with_pool!(self, |pool| sqlx::query_as::<_, TrialRecord>(&sql)
                .bind(session_id)
                .fetch_all(pool)
                .await?)
            .into_iter()
            .map(TrialRow::try_from)
            .collect()
        })
    }

    /// Every trial of an experiment with its observer, by session and position.
    pub fn trials_of_experiment<'a>(
        &'a self,
        experiment_id: i64,
    ) -> BoxFuture<'a, Result<Vec<ObservedTrial>, StoreError>> {
        Box::pin(async move {
            #[derive(sqlx::FromRow)]
            struct Observed {
                observer_id: String,
                #[sqlx(flatten)]
                trial: TrialRecord,
            }
            let sql = format!(
                "SELECT s.observer_id, {TRIAL_COLUMNS} FROM trials t JOIN experiment_sessions s ON s.id = t.session_id \
                 WHERE s.experiment_id = $1 ORDER BY t.session_id, t.position"
            );
            let rows: Vec<Observed> = with_pool!(self, |pool| sqlx::query_as(&sql)
                .bind(experiment_id)
                .fetch_all(pool)
                .await?);
            rows.into_iter()
                .map(|o| {
                    Ok(ObservedTrial {
                        observer_id: o.observer_id,
                        trial: TrialRow::try_from(o.trial)?,
                    })
                })
                .collect()
        })
    }

    /// The version of everything an experiment's analysis reads: its
    /// sessions, complete sessions, trials, and newest verification (an
    /// experiment itself is never rewritten).
    pub fn experiment_inputs<'a>(
        &'a self,
        experiment_id: i64,
    ) -> BoxFuture<'a, Result<crate::InputsVersion, StoreError>> {
        Box::pin(async move {
            let (sessions, complete, trials, verification): (i64, i64, i64, i64) = with_pool!(self, |pool| {
                sqlx::query_as(
                    "SELECT (SELECT COUNT(*) FROM experiment_sessions WHERE experiment_id = $1), \
                     (SELECT COUNT(*) FROM experiment_sessions WHERE experiment_id = $1 AND state = 'complete'), \
                     (SELECT COUNT(*) FROM trials t JOIN experiment_sessions s ON s.id = t.session_id \
                      WHERE s.experiment_id = $1), \
                     (SELECT COALESCE(MAX(id), 0) FROM experiment_verifications WHERE experiment_id = $1)",
                )
                .bind(experiment_id)
                .fetch_one(pool)
                .await?
            });
            Ok(crate::InputsVersion([sessions, complete, trials, verification]))
        })
    }

    /// Stores a verification of an experiment's colours; returns its id.
    pub fn insert_verification<'a>(
        &'a self,
        experiment_id: i64,
        result: &'a serde_json::Value,
    ) -> BoxFuture<'a, Result<i64, StoreError>> {
        Box::pin(async move {
            let id = with_pool!(self, |pool| {
                sqlx::query_scalar(
                "INSERT INTO experiment_verifications (experiment_id, created_at, result_json) VALUES ($1, $2, $3) RETURNING id"
            )
            .bind(experiment_id)
            .bind(now())
            .bind(result.to_string())
            .fetch_one(pool)
            .await?
            });
            self.wrote();
            Ok(id)
        })
    }

    /// An experiment's verifications, newest first: (id, created_at, result).
    pub fn verifications_of_experiment<'a>(
        &'a self,
        experiment_id: i64,
    ) -> BoxFuture<'a, Result<Vec<StoredVerification>, StoreError>> {
        Box::pin(async move {
            let rows: Vec<(i64, f64, String)> = with_pool!(self, |pool| {
                sqlx::query_as(
                "SELECT id, created_at, result_json FROM experiment_verifications WHERE experiment_id = $1 ORDER BY id DESC"
            )
            .bind(experiment_id)
            .fetch_all(pool)
            .await?
            });
            rows.into_iter()
                .map(|(id, at, text)| {
                    let v = serde_json::from_str(&text).map_err(|e| StoreError::Corrupt {
                        what: format!("experiment_verifications.result_json of verification {id}"),
                        err: e.to_string(),
                    })?;
                    Ok((id, at, v))
                })
                .collect()
        })
    }
}

#[cfg(test)]
#[path = "experiments_tests.rs"]
mod tests;
