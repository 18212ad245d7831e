//! The daemon's side of render workers: where a daemon's comparisons,
//! renders and studies run (`serve --renders here|workers`), and, when they
//! run on workers, what the daemon publishes for them and how it hears
//! that they ended.
//!
//! - `here` (the default, and the only choice on SQLite): the daemon runs
//!   them itself, exactly as a one-booth lab always had it.
//! - `workers`: the daemon stores each of its scenes as a bundle (its files,
//!   by content hash; [`crate::render::bundle`]) and publishes a
//!   [`RenderConfig`] — those bundles, its codings, samples and observer —
//!   on its row in `daemons`; then it queues every comparison, render and
//!   study as a row of `worker_jobs` (`store/worker_jobs.rs`) that any
//!   `lightbooth worker` on the same database claims ([`crate::worker`]).
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
use tokio::sync::broadcast;

use crate::colorimetry::{Observer, Xyz};
use crate::lab::events::Event;
use crate::store::{Store, StoreError, WorkerJobKind};

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
    pub observer: Observer,
    pub scenes: Vec<PublishedScene>,
}

/// What a comparison job carries beyond its measurement's id.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ComparisonPayload {
    pub scene: String,
    pub target: String,
    /// The measured XYZ with the daemon's observer.
    pub measured: [f64; 3],
    /// The standard error of the measured Y.
    pub measured_y_se: f64,
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
    events: broadcast::Sender<Event>,
    pending: Mutex<HashMap<i64, Pending>>,
}

impl WorkerQueue {
    pub fn new(store: Store, events: broadcast::Sender<Event>) -> WorkerQueue {
        WorkerQueue {
            store,
            events,
            pending: Mutex::default(),
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
    ) -> Result<i64, StoreError> {
        let payload = ComparisonPayload {
            scene: scene.to_string(),
            target: target.to_string(),
            measured: measured.to_array(),
            measured_y_se,
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
        let _ = self.events.send(event);
    }
}
