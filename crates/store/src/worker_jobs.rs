//! Jobs for render workers (`migrations/0013`): the comparisons, renders and
//! studies a daemon started with `--renders workers` leaves to any
//! `lightbooth worker` sharing its database.
//!
//! - A daemon queues a job with [`Store::queue_worker_job`]; the job names
//!   its *subject* (the measurement a comparison compares, or the render or
//!   study row the job runs) and the daemon that asked (`requested_by`).
//! - A worker claims the oldest queued job with [`Store::claim_worker_job`]:
//!   one `UPDATE … WHERE id = (SELECT … LIMIT 1 FOR UPDATE SKIP LOCKED)` on
//!   PostgreSQL, so two workers polling at once never take the same job and
//!   neither waits for the other's lock; on SQLite, whose writers are
//!   serialised anyway, the same statement without the lock clause. The
//!   claim records the worker and counts the attempt.
//! - A worker holds its jobs under its lease in `daemons` (it registers and
//!   heartbeats like a daemon). A running job whose worker is gone is queued
//!   again by whoever notices ([`Store::requeue_abandoned_jobs`], on every
//!   daemon's and worker's heartbeat), with its render or study row put back
//!   to `queued`, so another worker retries it. After [`MAX_ATTEMPTS`]
//!   claims it fails instead: a job that kills every worker that takes it is
//!   a bug to report, not to retry forever.
//! - Lease recovery (`leases.rs`) never marks the subject of an unfinished
//!   job interrupted: the job's queue, not its last runner, owns it.
//! - Cancelling ([`Store::cancel_worker_job`]) ends a queued job at once and
//!   asks a running one to stop; the worker sees the request within a poll.

use crate::BoxFuture;
use serde::{Deserialize, Serialize};

use super::engine::Engine;
use super::{Store, StoreError};

/// Claims after which a job whose workers keep vanishing fails.
pub const MAX_ATTEMPTS: i64 = 3;

/// What a worker job does.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum WorkerJobKind {
    /// Compare a complete measurement (the subject) with every coding.
    Comparison,
    /// Run a queued render row (the subject).
    Render,
    /// Run a queued study row (the subject).
    Study,
    /// Render a batch of a camera image's paths; the subject is its
    /// `image_batches` row, where the worker leaves the batch's moments.
    Image,
}

impl WorkerJobKind {
    pub fn as_str(self) -> &'static str {
        match self {
            WorkerJobKind::Comparison => "comparison",
            WorkerJobKind::Render => "render",
            WorkerJobKind::Study => "study",
            WorkerJobKind::Image => "image",
        }
    }

    fn parse(s: &str) -> Result<WorkerJobKind, StoreError> {
        match s {
            "comparison" => Ok(WorkerJobKind::Comparison),
            "render" => Ok(WorkerJobKind::Render),
            "study" => Ok(WorkerJobKind::Study),
            "image" => Ok(WorkerJobKind::Image),
            other => Err(StoreError::Corrupt {
                what: "worker_jobs.kind".into(),
                err: format!("unknown kind `{other}`"),
            }),
        }
    }

    /// The table of a render or study job's subject row.
    fn subject_table(self) -> Option<&'static str> {
        match self {
            WorkerJobKind::Comparison | WorkerJobKind::Image => None,
            WorkerJobKind::Render => Some("renders"),
            WorkerJobKind::Study => Some("studies"),
        }
    }
}

/// A worker job row.
#[derive(Clone, Debug, PartialEq, sqlx::FromRow)]
pub struct WorkerJobRecord {
    pub id: i64,
    pub kind: String,
    pub subject_id: i64,
    pub requested_by: i64,
    pub payload_json: String,
    pub state: String,
    pub worker_id: Option<i64>,
    pub attempts: i64,
    pub error: Option<String>,
}

/// A job a worker has claimed.
#[derive(Clone, Debug, PartialEq)]
pub struct ClaimedJob {
    pub id: i64,
    pub kind: WorkerJobKind,
    pub subject_id: i64,
    pub requested_by: i64,
    pub payload: serde_json::Value,
    /// 1 on the first claim.
    pub attempts: i64,
}

const JOB_COLUMNS: &str = "id, kind, subject_id, requested_by, payload_json, state, worker_id, attempts, error";

impl Store {
    /// The id the calling process registered with (daemon or worker).
    pub(super) fn registered_id(&self, what: &str) -> Result<i64, StoreError> {
        self.daemon_id.ok_or_else(|| {
            StoreError::Conflict(format!("{what} needs a registered daemon or worker (Store::as_daemon)"))
        })
    }

    /// Queues a job for the workers, asked by this handle's daemon; its id.
    /// A second job of the same kind and subject is refused by the schema.
    pub fn queue_worker_job<'a>(
        &'a self,
        kind: WorkerJobKind,
        subject_id: i64,
        payload: &'a serde_json::Value,
    ) -> BoxFuture<'a, Result<i64, StoreError>> {
        Box::pin(async move {
            let me = self.registered_id("queueing a worker job")?;
            let scene = payload.get("scene").and_then(|s| s.as_str()).unwrap_or_default();
            let sql = format!(
                "INSERT INTO worker_jobs (kind, subject_id, requested_by, payload_json, scene, state, created_at) \
                 VALUES ($1, $2, $3, $4, $5, 'queued', {}) RETURNING id",
                self.clock_sql()
            );
            Ok(with_pool!(self, |pool| sqlx::query_scalar(&sql)
                .bind(kind.as_str())
                .bind(subject_id)
                .bind(me)
                .bind(payload.to_string())
                .bind(scene)
                .fetch_one(pool)
                .await?))
        })
    }

    /// Claims a queued job for this handle's worker, if any: the oldest,
    /// except that a comparison of a scene another worker's comparison is
    /// rendering comes after the rest (it would only wait for that render),
    /// so a second worker renders another scene meanwhile.
    pub fn claim_worker_job<'a>(&'a self) -> BoxFuture<'a, Result<Option<ClaimedJob>, StoreError>> {
        Box::pin(async move {
            let me = self.registered_id("claiming a worker job")?;
            let lock = match self.engine {
                Engine::Postgres(_) => "FOR UPDATE SKIP LOCKED",
                Engine::Sqlite(_) => "",
            };
            let sql = format!(
                "UPDATE worker_jobs SET state = 'running', worker_id = $1, attempts = attempts + 1, started_at = {clock} \
                 WHERE state = 'queued' AND id = (SELECT j.id FROM worker_jobs j WHERE j.state = 'queued' \
                 ORDER BY (j.kind = 'comparison' AND j.scene <> '' AND EXISTS (SELECT 1 FROM worker_jobs r \
                 WHERE r.state = 'running' AND r.kind = 'comparison' AND r.scene = j.scene)), j.id LIMIT 1 {lock}) \
                 RETURNING {JOB_COLUMNS}",
                clock = self.clock_sql()
            );
            let row: Option<WorkerJobRecord> =
                with_pool!(self, |pool| sqlx::query_as(&sql).bind(me).fetch_optional(pool).await?);
            row.map(|r| {
                Ok(ClaimedJob {
                    kind: WorkerJobKind::parse(&r.kind)?,
                    payload: serde_json::from_str(&r.payload_json).map_err(|e| StoreError::Corrupt {
                        what: format!("worker_jobs.payload_json of job {}", r.id),
                        err: e.to_string(),
                    })?,
                    id: r.id,
                    subject_id: r.subject_id,
                    requested_by: r.requested_by,
                    attempts: r.attempts,
                })
            })
            .transpose()
        })
    }

    /// Ends a job this handle's worker holds: `state` is `done`, `failed`
    /// or `cancelled`, with the error of the last two. False when the job is
    /// no longer this worker's (it was queued again because the worker was
    /// counted gone).
    pub fn finish_worker_job<'a>(
        &'a self,
        id: i64,
        state: &'a str,
        error: Option<&'a str>,
    ) -> BoxFuture<'a, Result<bool, StoreError>> {
        Box::pin(async move {
            let me = self.registered_id("finishing a worker job")?;
            debug_assert!(matches!(state, "done" | "failed" | "cancelled"));
            let sql = format!(
                "UPDATE worker_jobs SET state = $1, error = $2, finished_at = {} \
                 WHERE id = $3 AND worker_id = $4 AND state = 'running'",
                self.clock_sql()
            );
            let n = with_pool!(self, |pool| sqlx::query(&sql)
                .bind(state)
                .bind(error)
                .bind(id)
                .bind(me)
                .execute(pool)
                .await?
                .rows_affected());
            Ok(n == 1)
        })
    }

    /// Hands job `id`, held by this handle's worker, back to the queue (the
    /// worker is stopping): its render or study row goes back to `queued`
    /// from wherever stopping it left it, and another worker takes it
    /// without waiting for a lease to run out. False when the job is no
    /// longer this worker's.
    pub fn release_worker_job<'a>(&'a self, id: i64) -> BoxFuture<'a, Result<bool, StoreError>> {
        Box::pin(async move {
            let me = self.registered_id("releasing a worker job")?;
            let Some(job) = self.worker_job(id).await? else {
                return Ok(false);
            };
            if job.state != "running" || job.worker_id != Some(me) {
                return Ok(false);
            }
            if let Some(table) = WorkerJobKind::parse(&job.kind)?.subject_table() {
                let sql = format!(
                    "UPDATE {table} SET state = 'queued', error = NULL, finished_at = NULL, daemon_id = $1 \
                     WHERE id = $2 AND daemon_id = $3 AND state IN ('running', 'cancelled', 'interrupted')"
                );
                with_pool!(self, |pool| sqlx::query(&sql)
                    .bind(job.requested_by)
                    .bind(job.subject_id)
                    .bind(me)
                    .execute(pool)
                    .await?
                    .rows_affected());
            }
            let n = with_pool!(self, |pool| sqlx::query(
                "UPDATE worker_jobs SET state = 'queued', worker_id = NULL, started_at = NULL \
                 WHERE id = $1 AND worker_id = $2 AND state = 'running'"
            )
            .bind(id)
            .bind(me)
            .execute(pool)
            .await?
            .rows_affected());
            Ok(n == 1)
        })
    }

    /// Job `id`'s row.
    pub fn worker_job<'a>(&'a self, id: i64) -> BoxFuture<'a, Result<Option<WorkerJobRecord>, StoreError>> {
        Box::pin(async move {
            let sql = format!("SELECT {JOB_COLUMNS} FROM worker_jobs WHERE id = $1");
            Ok(with_pool!(self, |pool| sqlx::query_as(&sql)
                .bind(id)
                .fetch_optional(pool)
                .await?))
        })
    }

    /// The job of `kind` about `subject_id`, if one was queued.
    pub fn worker_job_of<'a>(
        &'a self,
        kind: WorkerJobKind,
        subject_id: i64,
    ) -> BoxFuture<'a, Result<Option<WorkerJobRecord>, StoreError>> {
        Box::pin(async move {
            let sql = format!("SELECT {JOB_COLUMNS} FROM worker_jobs WHERE kind = $1 AND subject_id = $2");
            Ok(with_pool!(self, |pool| sqlx::query_as(&sql)
                .bind(kind.as_str())
                .bind(subject_id)
                .fetch_optional(pool)
                .await?))
        })
    }

    /// How many of this handle's daemon's render and study jobs wait or run
    /// (its share of the queue is bounded as its own queue is).
    pub fn unfinished_worker_jobs_requested<'a>(&'a self) -> BoxFuture<'a, Result<i64, StoreError>> {
        Box::pin(async move {
            let me = self.registered_id("counting worker jobs")?;
            Ok(with_pool!(self, |pool| sqlx::query_scalar(
                "SELECT COUNT(*) FROM worker_jobs WHERE requested_by = $1 AND kind IN ('render', 'study') \
                 AND state IN ('queued', 'running')"
            )
            .bind(me)
            .fetch_one(pool)
            .await?))
        })
    }

    /// Asks the job of `kind` about `subject_id` to stop: a queued job ends
    /// `cancelled` at once (true); a running one is flagged for its worker
    /// (false). `None` when there is no unfinished job.
    pub fn cancel_worker_job<'a>(
        &'a self,
        kind: WorkerJobKind,
        subject_id: i64,
    ) -> BoxFuture<'a, Result<Option<bool>, StoreError>> {
        Box::pin(async move {
            let sql = format!(
                "UPDATE worker_jobs SET state = 'cancelled', error = 'cancelled before a worker took it', \
                 finished_at = {} WHERE kind = $1 AND subject_id = $2 AND state = 'queued'",
                self.clock_sql()
            );
            let ended = with_pool!(self, |pool| sqlx::query(&sql)
                .bind(kind.as_str())
                .bind(subject_id)
                .execute(pool)
                .await?
                .rows_affected());
            if ended == 1 {
                return Ok(Some(true));
            }
            let flagged = with_pool!(self, |pool| {
                sqlx::query(
                "UPDATE worker_jobs SET cancel_requested = TRUE WHERE kind = $1 AND subject_id = $2 AND state = 'running'"
            )
            .bind(kind.as_str())
            .bind(subject_id)
            .execute(pool)
            .await?
            .rows_affected()
            });
            Ok((flagged == 1).then_some(false))
        })
    }

    /// True when job `id` was asked to stop (or is no longer running).
    pub fn worker_job_cancel_requested<'a>(&'a self, id: i64) -> BoxFuture<'a, Result<bool, StoreError>> {
        Box::pin(async move {
            let row: Option<(bool, String)> = with_pool!(self, |pool| sqlx::query_as(
                "SELECT cancel_requested, state FROM worker_jobs WHERE id = $1"
            )
            .bind(id)
            .fetch_optional(pool)
            .await?);
            Ok(row.is_none_or(|(flag, state)| flag || state != "running"))
        })
    }

    /// Queues again the running jobs of workers that are gone (lease
    /// expired or stopped), with their render or study rows back to
    /// `queued`; a job claimed [`MAX_ATTEMPTS`] times fails instead.
    /// Returns how many jobs were re-queued or failed.
    pub fn requeue_abandoned_jobs<'a>(&'a self) -> BoxFuture<'a, Result<u64, StoreError>> {
        Box::pin(async move {
            let clock = self.clock_sql();
            let gone = format!("(d.stopped_at IS NOT NULL OR d.heartbeat_at + d.lease_seconds < {clock})");
            let me = self.daemon_id.unwrap_or(-1);
            let find = format!(
                "SELECT {JOB_COLUMNS} FROM worker_jobs j WHERE j.state = 'running' AND j.worker_id <> $1 \
                 AND EXISTS (SELECT 1 FROM daemons d WHERE d.id = j.worker_id AND {gone}) ORDER BY j.id"
            );
            let abandoned: Vec<WorkerJobRecord> =
                with_pool!(self, |pool| sqlx::query_as(&find).bind(me).fetch_all(pool).await?);
            let mut count = 0;
            for job in abandoned {
                let kind = WorkerJobKind::parse(&job.kind)?;
                let worker = job.worker_id.unwrap_or(-1);
                let give_up = job.attempts >= MAX_ATTEMPTS;
                let why = format!(
                    "{} workers stopped while running this {} (the last: worker {worker}); \
                     see their logs before retrying it",
                    job.attempts,
                    kind.as_str()
                );
                // The subject first: once the job is queued again another worker
                // may claim it at once, and must find its row `queued`.
                if let Some(table) = kind.subject_table() {
                    if give_up {
                        let sql = format!(
                            "UPDATE {table} SET state = 'failed', error = $1, finished_at = {clock} \
                             WHERE id = $2 AND state IN ('queued', 'running')"
                        );
                        with_pool!(self, |pool| sqlx::query(&sql)
                            .bind(&why)
                            .bind(job.subject_id)
                            .execute(pool)
                            .await?
                            .rows_affected());
                    } else {
                        let sql = format!(
                            "UPDATE {table} SET state = 'queued', daemon_id = $1 WHERE id = $2 AND state = 'running' \
                             AND (daemon_id = $3 OR daemon_id IS NULL)"
                        );
                        with_pool!(self, |pool| sqlx::query(&sql)
                            .bind(job.requested_by)
                            .bind(job.subject_id)
                            .bind(worker)
                            .execute(pool)
                            .await?
                            .rows_affected());
                    }
                }
                let n = if give_up {
                    let sql = format!(
                        "UPDATE worker_jobs SET state = 'failed', error = $1, finished_at = {clock} \
                         WHERE id = $2 AND state = 'running' AND worker_id = $3"
                    );
                    with_pool!(self, |pool| sqlx::query(&sql)
                        .bind(&why)
                        .bind(job.id)
                        .bind(worker)
                        .execute(pool)
                        .await?
                        .rows_affected())
                } else {
                    with_pool!(self, |pool| sqlx::query(
                        "UPDATE worker_jobs SET state = 'queued', worker_id = NULL, started_at = NULL, \
                         cancel_requested = FALSE WHERE id = $1 AND state = 'running' AND worker_id = $2"
                    )
                    .bind(job.id)
                    .bind(worker)
                    .execute(pool)
                    .await?
                    .rows_affected())
                };
                if n == 1 {
                    tracing::warn!(
                        job = job.id,
                        kind = kind.as_str(),
                        subject = job.subject_id,
                        worker,
                        attempts = job.attempts,
                        "{}",
                        if give_up {
                            "a worker job's workers keep vanishing: failed"
                        } else {
                            "a gone worker's job queued again"
                        }
                    );
                    count += 1;
                }
            }
            Ok(count)
        })
    }

    /// Marks this handle's process as a render worker, or publishes (as a
    /// daemon leaving its renders to workers) what a worker needs to render
    /// for it.
    pub fn set_daemon_role<'a>(
        &'a self,
        role: &'a str,
        render_config: Option<&'a serde_json::Value>,
    ) -> BoxFuture<'a, Result<(), StoreError>> {
        Box::pin(async move {
            let me = self.registered_id("setting a role")?;
            with_pool!(self, |pool| sqlx::query(
                "UPDATE daemons SET role = $1, render_config_json = $2 WHERE id = $3"
            )
            .bind(role)
            .bind(render_config.map(|c| c.to_string()))
            .bind(me)
            .execute(pool)
            .await?
            .rows_affected());
            Ok(())
        })
    }

    /// The render configuration daemon `id` published for workers.
    pub fn render_config<'a>(&'a self, id: i64) -> BoxFuture<'a, Result<Option<serde_json::Value>, StoreError>> {
        Box::pin(async move {
            let text: Option<Option<String>> = with_pool!(self, |pool| sqlx::query_scalar(
                "SELECT render_config_json FROM daemons WHERE id = $1"
            )
            .bind(id)
            .fetch_optional(pool)
            .await?);
            text.flatten()
                .map(|t| {
                    serde_json::from_str(&t).map_err(|e| StoreError::Corrupt {
                        what: format!("daemons.render_config_json of daemon {id}"),
                        err: e.to_string(),
                    })
                })
                .transpose()
        })
    }
}

#[cfg(test)]
#[path = "worker_jobs_tests.rs"]
mod tests;
