//! The daemon's side of render workers: where a daemon's comparisons,
//! renders and studies run (`serve --renders here|workers`), and, when they
//! run on workers, what the daemon publishes for them and how it hears
//! that they ended.
//!
//! - `here` (the default, and the only choice on SQLite): the daemon runs
//!   them itself, exactly as a one-booth lab always had it.
//! - `workers`: the daemon stores each of its scenes as a bundle (its files,
//!   by content hash; [`lightbooth_render::bundle`]) and publishes a
//!   [`RenderConfig`] — those bundles, its codings, samples and observer —
//!   on its row in `daemons`; then it queues every comparison, render and
//!   study as a row of `worker_jobs` (`store/worker_jobs.rs`) that any
//!   `lightbooth worker` on the same database claims (`lightbooth::worker`).
//!   The render and study rows are created by the daemon as before, so the
//!   API answers with their ids at once.
//! - The daemon keeps the jobs it queued in memory and polls their rows
//!   ([`WorkerQueue::watch`]); when one ends it sends the same event the
//!   in-process job would have sent (`comparison_ready`, `render_finished`,
//!   `study_finished`), so the dashboard cannot tell where a job ran.
//!   Progress events of a job on a worker are not relayed: the worker's log
//!   has them.

use std::collections::HashMap;
use std::str::FromStr;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use serde::{Deserialize, Serialize};

use crate::error::LabError;
use crate::events::{Event, EventSink};
use crate::jobs::JOB_QUEUE_CAPACITY;
use crate::scenes::SceneCatalog;
use lightbooth_render::Coding;
use lightbooth_science::colorimetry::{Observer, Xyz};
use lightbooth_store::{Job, JobEnd, Store, StoreError, WorkerJobKind};

/// Where a daemon's comparisons, renders and studies run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum RenderPlace {
    /// In the daemon itself.
    #[default]
    Here,
    /// On `lightbooth worker` processes sharing the database.
    Workers,
}

impl FromStr for RenderPlace {
    type Err = String;
    fn from_str(s: &str) -> Result<RenderPlace, String> {
        match s {
            "here" => Ok(RenderPlace::Here),
            "workers" => Ok(RenderPlace::Workers),
            other => Err(format!(
                "`{other}` is neither `here` (the daemon renders) nor `workers` (lightbooth worker processes render)"
            )),
        }
    }
}

/// One scene a daemon serves, as workers fetch it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PublishedScene {
    /// The scene id (its file name without `.toml`).
    pub id: String,
    /// The SHA-256 of its bundle in `scene_bundles`.
    pub bundle: String,
    /// Its render key (`render::scene_hash`), for checking what was unpacked.
    pub scene_hash: String,
}

/// What a worker needs to render, compare and study exactly as the daemon
/// would: published on the daemon's `daemons` row.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RenderConfig {
    pub codings: Vec<String>,
    pub samples: u64,
    /// Camera paths of a render's dashboard preview, in all (published
    /// since the daemon's `preview_paths`; a row without it has the default).
    #[serde(default = "default_preview_paths")]
    pub preview_paths: u64,
    pub observer: Observer,
    pub scenes: Vec<PublishedScene>,
}

fn default_preview_paths() -> u64 {
    lightbooth_render::sensor::PREVIEW_PATH_BUDGET
}

/// What a comparison job carries beyond its measurement's id.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ComparisonPayload {
    pub scene: String,
    pub target: String,
    /// The measured XYZ in `observer`.
    pub measured: [f64; 3],
    /// The standard error of the measured Y.
    pub measured_y_se: f64,
    /// The observer of `measured` and of the comparison (a colorimeter's
    /// own); absent in a job queued before it was stated: the asking
    /// daemon's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub observer: Option<Observer>,
}

impl ComparisonPayload {
    pub fn measured_xyz(&self) -> Xyz {
        Xyz::from_array(self.measured)
    }
}

/// What a render or study job carries: the scene (renders), for the event.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct JobPayload {
    #[serde(default)]
    pub scene: String,
}

/// A queued job the daemon waits to hear the end of.
#[derive(Clone, Debug)]
struct Pending {
    kind: WorkerJobKind,
    subject_id: i64,
    scene: String,
    target: String,
}

/// The jobs this daemon left to workers and has not yet heard the end of.
pub struct WorkerQueue {
    store: Store,
    events: EventSink,
    pending: Mutex<HashMap<i64, Pending>>,
}

impl WorkerQueue {
    pub fn new(store: Store, events: EventSink) -> WorkerQueue {
        WorkerQueue {
            store,
            events,
            pending: Mutex::default(),
        }
    }

    /// Leaves a daemon's comparisons, renders and studies to render
    /// workers: stores every scene of `catalogue` as a bundle and publishes
    /// the [`RenderConfig`] workers render with (`codings`, `samples`,
    /// `preview_paths`, `observer`) on the daemon's row. Returns the queue, whose
    /// [`WorkerQueue::watch`] the daemon runs.
    pub async fn publish(
        store: Store,
        events: EventSink,
        catalogue: &SceneCatalog,
        codings: &[Coding],
        samples: u64,
        preview_paths: u64,
        observer: Observer,
    ) -> anyhow::Result<WorkerQueue> {
        let mut scenes = Vec::new();
        for entry in catalogue.iter() {
            let path = entry.path.clone();
            let collected = tokio::task::spawn_blocking(move || {
                let root = path.parent().unwrap_or(std::path::Path::new("."));
                lightbooth_render::bundle::SceneBundle::collect(root, &path)
            })
            .await?
            .map_err(|e| anyhow::anyhow!("scene `{}` cannot be bundled for render workers: {e}", entry.id))?;
            anyhow::ensure!(
                collected.scene_hash == entry.hash,
                "scene `{}`: its files changed since the daemon loaded them; start the daemon again",
                entry.id
            );
            store
                .put_scene_bundle(&entry.id, &collected.scene_hash, &collected.bundle)
                .await?;
            scenes.push(PublishedScene {
                id: entry.id.clone(),
                bundle: collected.bundle.hash(),
                scene_hash: collected.scene_hash,
            });
        }
        let config = RenderConfig {
            codings: codings.iter().map(|c| c.to_string()).collect(),
            samples,
            preview_paths,
            observer,
            scenes,
        };
        store
            .set_daemon_role("daemon", Some(&serde_json::to_value(&config)?))
            .await?;
        tracing::info!(
            scenes = config.scenes.len(),
            "comparisons, renders and studies are left to render workers"
        );
        Ok(WorkerQueue::new(store, events))
    }

    /// [`LabError::Conflict`] when this daemon already has
    /// [`JOB_QUEUE_CAPACITY`] renders and studies waiting for or running on
    /// workers: its share of the shared queue is bounded as its own queue is.
    pub async fn check_share(&self) -> Result<(), LabError> {
        let waiting = self.store.unfinished_worker_jobs_requested().await?;
        if waiting >= JOB_QUEUE_CAPACITY as i64 {
            return Err(LabError::Conflict(format!(
                "the render queue is full: {waiting} renders and studies of this daemon are waiting for \
                 or running on render workers; wait for one to finish (GET /api/renders, /api/studies)"
            )));
        }
        Ok(())
    }

    /// Queues a recorded render or study row for the workers; if that fails
    /// the row is failed with the reason (it would never run otherwise).
    pub async fn hand_over(&self, job: Job, id: i64, scene: &str) -> Result<(), LabError> {
        if let Err(e) = self.queue_row(worker_kind(job), id, scene).await {
            let why = format!("cannot queue this {} for the render workers: {e}", job.noun());
            self.store.end_job(job, id, JobEnd::Failed, &why).await?;
            return Err(LabError::Internal(why));
        }
        Ok(())
    }

    /// Cancels a render or study left to the workers: a queued one ends at
    /// once, a running one is flagged for its worker. False when no worker
    /// job has it (it runs in the daemon).
    pub async fn cancel(&self, job: Job, id: i64) -> Result<bool, LabError> {
        match self.store.cancel_worker_job(worker_kind(job), id).await? {
            Some(true) => {
                self.store
                    .end_job(
                        job,
                        id,
                        JobEnd::Cancelled,
                        "cancelled by a client before a render worker took it",
                    )
                    .await?;
                tracing::info!(job = job.noun(), id, "cancelled while queued for the render workers");
                Ok(true)
            }
            Some(false) => {
                tracing::info!(
                    job = job.noun(),
                    id,
                    "cancellation requested of the render worker running it"
                );
                Ok(true)
            }
            None => Ok(false),
        }
    }

    /// Queues the comparison of a complete measurement for the workers.
    pub async fn queue_comparison(
        &self,
        measurement_id: i64,
        scene: &str,
        target: &str,
        measured: Xyz,
        measured_y_se: f64,
        observer: Observer,
    ) -> Result<i64, StoreError> {
        let payload = ComparisonPayload {
            scene: scene.to_string(),
            target: target.to_string(),
            measured: measured.to_array(),
            measured_y_se,
            observer: Some(observer),
        };
        let payload = serde_json::to_value(&payload).expect("a comparison payload serialises");
        let id = self
            .store
            .queue_worker_job(WorkerJobKind::Comparison, measurement_id, &payload)
            .await?;
        self.wait_for(id, WorkerJobKind::Comparison, measurement_id, scene, target);
        tracing::info!(
            job = id,
            measurement_id,
            scene,
            target,
            "comparison queued for the render workers"
        );
        Ok(id)
    }

    /// Queues a recorded render or study row for the workers.
    pub async fn queue_row(&self, kind: WorkerJobKind, subject_id: i64, scene: &str) -> Result<i64, StoreError> {
        let payload = serde_json::to_value(JobPayload {
            scene: scene.to_string(),
        })
        .expect("a job payload serialises");
        let id = self.store.queue_worker_job(kind, subject_id, &payload).await?;
        self.wait_for(id, kind, subject_id, scene, "");
        tracing::info!(
            job = id,
            kind = kind.as_str(),
            subject_id,
            "queued for the render workers"
        );
        Ok(id)
    }

    fn wait_for(&self, id: i64, kind: WorkerJobKind, subject_id: i64, scene: &str, target: &str) {
        self.pending.lock().unwrap_or_else(|p| p.into_inner()).insert(
            id,
            Pending {
                kind,
                subject_id,
                scene: scene.to_string(),
                target: target.to_string(),
            },
        );
    }

    /// Polls the pending jobs every `interval` and sends the event of each
    /// that ended; runs until aborted.
    pub async fn watch(self: Arc<Self>, interval: Duration) {
        let mut ticks = tokio::time::interval(interval);
        ticks.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        loop {
            ticks.tick().await;
            let ids: Vec<i64> = self
                .pending
                .lock()
                .unwrap_or_else(|p| p.into_inner())
                .keys()
                .copied()
                .collect();
            for id in ids {
                let row = match self.store.worker_job(id).await {
                    Ok(Some(row)) => row,
                    Ok(None) => continue,
                    Err(e) => {
                        tracing::warn!(job = id, error = %e, "cannot read a worker job's state");
                        break;
                    }
                };
                if !matches!(row.state.as_str(), "done" | "failed" | "cancelled") {
                    continue;
                }
                let Some(p) = self.pending.lock().unwrap_or_else(|p| p.into_inner()).remove(&id) else {
                    continue;
                };
                self.announce(&p, &row.state, row.error).await;
            }
        }
    }

    /// The event of an ended job, as the in-process job would send it.
    async fn announce(&self, p: &Pending, state: &str, error: Option<String>) {
        let ok = state == "done";
        let event = match p.kind {
            // An image's batches are watched by the image's own task
            // (`image_batches::render_on_workers`), never queued through here.
            WorkerJobKind::Image => return,
            WorkerJobKind::Comparison => {
                if !ok {
                    tracing::error!(
                        measurement_id = p.subject_id,
                        scene = p.scene,
                        target = p.target,
                        error = error.as_deref().unwrap_or(""),
                        "comparison failed on a render worker"
                    );
                    return;
                }
                Event::ComparisonReady {
                    measurement_id: p.subject_id,
                    scene: p.scene.clone(),
                    target: p.target.clone(),
                }
            }
            // The render and study rows say how they ended (the job's own
            // error is only set when its workers kept vanishing).
            WorkerJobKind::Render => {
                let row = self.store.get_render(p.subject_id).await.ok().flatten();
                let ok = row.as_ref().is_some_and(|r| r.state == "complete");
                Event::RenderFinished {
                    render_id: p.subject_id,
                    scene: p.scene.clone(),
                    ok,
                    error: if ok { None } else { row.and_then(|r| r.error).or(error) },
                }
            }
            WorkerJobKind::Study => {
                let row = self.store.get_study(p.subject_id).await.ok().flatten();
                let ok = row.as_ref().is_some_and(|r| r.state == "complete");
                Event::StudyFinished {
                    study_id: p.subject_id,
                    ok,
                    error: if ok { None } else { row.and_then(|r| r.error).or(error) },
                }
            }
        };
        self.events.send(event);
    }
}

/// The worker job kind of a render or study row.
fn worker_kind(job: Job) -> WorkerJobKind {
    match job {
        Job::Render => WorkerJobKind::Render,
        Job::Study => WorkerJobKind::Study,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A daemon started before `preview_paths` existed published a row
    /// without it: a worker reads it as the default budget, and a row that
    /// names a budget keeps it (the worker renders its previews with it).
    #[test]
    fn a_daemons_row_without_preview_paths_reads_as_the_default_budget() {
        let old = serde_json::json!({
            "codings": ["rgb", "spectral"],
            "samples": 1024,
            "observer": Observer::Cie1931,
            "scenes": [],
        });
        let config: RenderConfig = serde_json::from_value(old.clone()).unwrap();
        assert_eq!(config.preview_paths, 20_000_000);
        assert_eq!(config.preview_paths, lightbooth_render::sensor::PREVIEW_PATH_BUDGET);
        let mut new = old;
        new["preview_paths"] = serde_json::json!(7);
        let config: RenderConfig = serde_json::from_value(new).unwrap();
        assert_eq!(config.preview_paths, 7);
        let again: RenderConfig = serde_json::from_value(serde_json::to_value(&config).unwrap()).unwrap();
        assert_eq!(again, config);
    }
}
