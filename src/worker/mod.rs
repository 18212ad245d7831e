//! `lightbooth worker`: a render worker. On any machine that reaches the
//! lab's PostgreSQL database, it claims the comparison, render and study
//! jobs that daemons started with `--renders workers` queue
//! (`store/worker_jobs.rs`), runs them, and stores the results where the
//! daemons and the dashboard read them.
//!
//! - It registers in `daemons` (role `worker`) and heartbeats like a daemon
//!   ([`crate::daemon`]'s heartbeat task, which also queues again the jobs
//!   of workers that are gone and recovers gone daemons' work), so a
//!   worker killed mid-job has its job retried by another.
//! - It needs no shared filesystem: for the daemon that asked for a job it
//!   reads the published [`RenderConfig`] (codings, samples, observer and
//!   the bundle of each scene), fetches each bundle from the database,
//!   unpacks it under its cache folder ([`crate::render::bundle`]) and
//!   renders, compares and studies with the same code the daemon would
//!   ([`RenderRunner`], [`Comparisons`], [`StudyRunner`]): one set per
//!   distinct configuration, kept for the next job. It builds no job queue,
//!   no camera images and no simulated instrument, and sends no events (the
//!   daemon that asked reports a job's end when it sees it in the store).
//! - An `image` job is a batch of a camera image's paths
//!   ([`ImageBatch`]): rendered with the daemon's published scenes, its
//!   moments left on its `image_batches` row for the daemon to merge.
//! - One job at a time, on the rayon pool (all cores). A job asked to stop
//!   (`POST /api/renders/{id}/cancel` on its daemon) is cancelled within a
//!   poll; at shutdown the running job is cancelled and marked stopped, and
//!   another worker takes it again.
//!
//! [`run`] takes a shutdown future, as the daemon's does, so tests run a
//! worker in-process too.

use std::collections::HashMap;
use std::future::Future;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use anyhow::Context;
use sha2::{Digest, Sha256};

use crate::lab::assemble::{parse_codings, RenderSide, RenderSideSettings};
use crate::lab::events::EventSink;
use crate::lab::lease::Lease;
use crate::lab::render::image_batches::ImageBatch;
use crate::lab::render::worker_queue::{ComparisonPayload, RenderConfig};
use crate::lab::scenes::SceneCatalog;
use crate::render::bundle::SceneBundle;
use crate::store::{Booth, ClaimedJob, Store, WorkerJobKind};
use tokio_util::sync::CancellationToken;

/// Everything `lightbooth worker` needs.
#[derive(Clone, Debug)]
pub struct WorkerOptions {
    /// `postgres://…`: the database the daemons share.
    pub db_url: String,
    /// Unpacked scene bundles and converged spectra are kept here.
    pub cache_dir: PathBuf,
    /// How often the worker renews its lease.
    pub heartbeat: Duration,
    /// How long after its last heartbeat the worker counts as gone.
    pub lease: Duration,
    /// How often an idle worker looks for a job, and a busy one for a
    /// request to stop its job.
    pub poll: Duration,
}

/// The booth name a worker registers under: workers serve every booth.
const WORKER_BOOTH: &str = "workers";

/// Runs a worker until `shutdown` resolves.
pub async fn run(options: WorkerOptions, shutdown: impl Future<Output = ()> + Send + 'static) -> anyhow::Result<()> {
    anyhow::ensure!(
        !options.heartbeat.is_zero() && options.lease > options.heartbeat,
        "the lease ({:?}) must be longer than the heartbeat interval ({:?}), which must not be zero",
        options.lease,
        options.heartbeat
    );
    let store = Store::open_as_tool(&options.db_url)
        .await
        .with_context(|| format!("opening the database {}", options.db_url))?;
    anyhow::ensure!(
        store.engine_name() == "postgres",
        "a render worker shares the daemons' PostgreSQL database (--db postgres://…); \
         a daemon on an SQLite file renders itself"
    );
    let booth: Booth = WORKER_BOOTH.parse().map_err(anyhow::Error::msg)?;
    // Nobody listens to a worker's events; its heartbeat still recovers the
    // work of gone daemons and workers, as a daemon's does.
    let events = EventSink::nowhere();
    let lease = Lease::take(&store, &booth, options.lease, options.heartbeat, Some(events))
        .await
        .context("registering this worker's lease")?;
    let id = lease.id();
    let store = lease.store().clone();
    store.set_daemon_role("worker", None).await?;
    tracing::info!(
        worker = id,
        "render worker registered; heartbeat every {:?}, lease {:?}",
        options.heartbeat,
        options.lease
    );
    println!(
        "lightbooth worker {id} claiming jobs from {}",
        redacted(&options.db_url)
    );
    let mut worker = Worker {
        store: store.clone(),
        options: options.clone(),
        renderers: HashMap::new(),
    };
    let mut shutdown = std::pin::pin!(shutdown);
    loop {
        let claimed = tokio::select! {
            _ = &mut shutdown => break,
            claimed = store.claim_worker_job() => claimed,
        };
        match claimed {
            Ok(Some(job)) => {
                let stopped = worker.run_job(job, &mut shutdown).await;
                if stopped {
                    break;
                }
            }
            Ok(None) => {
                tokio::select! {
                    _ = &mut shutdown => break,
                    _ = tokio::time::sleep(options.poll) => {}
                }
            }
            Err(e) => {
                tracing::warn!(worker = id, error = %e, "cannot claim a job; trying again");
                tokio::select! {
                    _ = &mut shutdown => break,
                    _ = tokio::time::sleep(options.poll * 4) => {}
                }
            }
        }
    }
    lease.release().await?;
    tracing::info!(worker = id, "render worker stopped");
    store.close().await;
    Ok(())
}

/// A database URL without its password, for the terminal.
fn redacted(url: &str) -> String {
    match (url.find("://"), url.rfind('@')) {
        (Some(scheme), Some(at)) if at > scheme => {
            let userinfo = &url[scheme + 3..at];
            let user = userinfo.split(':').next().unwrap_or("");
            format!("{}{user}@{}", &url[..scheme + 3], &url[at + 1..])
        }
        _ => url.to_string(),
    }
}

struct Worker {
    store: Store,
    options: WorkerOptions,
    /// What it renders, compares and studies with for each daemon's
    /// published configuration (by its SHA-256), built as the daemon builds
    /// its own (`lab::assemble::RenderSide`).
    renderers: HashMap<String, Arc<RenderSide>>,
}

impl Worker {
    /// Runs a claimed job to its end and records it. True when `shutdown`
    /// resolved meanwhile (the job was cancelled and is left to others).
    async fn run_job(&mut self, job: ClaimedJob, shutdown: &mut (impl Future<Output = ()> + Unpin)) -> bool {
        let (id, kind, subject) = (job.id, job.kind.as_str(), job.subject_id);
        tracing::info!(
            job = id,
            kind,
            subject,
            attempt = job.attempts,
            requested_by = job.requested_by,
            "job claimed"
        );
        let cancel = CancellationToken::new();
        let (store, poll) = (self.store.clone(), self.options.poll);
        let renderers = self.renderers.clone();
        let mut stopping = false;
        let outcome = {
            let work = self.execute(&job, cancel.clone());
            let mut work = std::pin::pin!(work);
            let mut polls = tokio::time::interval(poll);
            polls.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
            loop {
                tokio::select! {
                    outcome = &mut work => break outcome,
                    _ = &mut *shutdown, if !stopping => {
                        tracing::info!(job = id, "shutting down: stopping the running job to hand it back");
                        cancel.cancel();
                        // A comparison's render stops with its renderer.
                        for r in renderers.values() {
                            r.runner.shutdown();
                        }
                        stopping = true;
                    }
                    _ = polls.tick() => {
                        if store.worker_job_cancel_requested(id).await.unwrap_or(false) {
                            cancel.cancel();
                        }
                    }
                }
            }
        };
        if stopping {
            // Not finished: back to the queue for another worker (or this
            // one's next start), its row `queued` again.
            match self.store.release_worker_job(id).await {
                Ok(true) => tracing::info!(job = id, "job handed back to the queue"),
                Ok(false) => {}
                Err(e) => {
                    tracing::warn!(job = id, error = %e, "cannot hand the job back; it is queued again once this worker counts as gone")
                }
            }
            return true;
        }
        let (state, error) = match &outcome {
            Ok(()) => ("done", None),
            Err(e) if cancel.is_cancelled() => ("cancelled", Some(e.as_str())),
            Err(e) => ("failed", Some(e.as_str())),
        };
        match self.store.finish_worker_job(job.id, state, error).await {
            Ok(true) => tracing::info!(job = id, kind, subject, state, error = error.unwrap_or(""), "job ended"),
            Ok(false) => tracing::warn!(
                job = id,
                "the job was no longer this worker's when it ended (queued again meanwhile)"
            ),
            Err(e) => tracing::error!(job = id, error = %e, "cannot record the end of the job"),
        }
        false
    }

    /// The job's work with the asking daemon's renderer.
    async fn execute(&mut self, job: &ClaimedJob, cancel: CancellationToken) -> Result<(), String> {
        let renderer = self.renderer_for(job.requested_by).await?;
        match job.kind {
            WorkerJobKind::Comparison => {
                let p: ComparisonPayload = serde_json::from_value(job.payload.clone())
                    .map_err(|e| format!("comparison job {}: its payload: {e}", job.id))?;
                renderer
                    .comparisons
                    .compare(
                        job.subject_id,
                        &p.scene,
                        &p.target,
                        p.measured_xyz(),
                        p.measured_y_se,
                        p.observer.unwrap_or(renderer.runner.observer()),
                    )
                    .await
                    .map_err(|e| e.to_string())
            }
            WorkerJobKind::Render => {
                renderer
                    .runner
                    .run_row(job.subject_id, cancel)
                    .await
                    .map_err(|e| e.to_string())?;
                self.subject_ended_well("renders", job.subject_id).await
            }
            WorkerJobKind::Image => {
                let batch: ImageBatch = serde_json::from_value(job.payload.clone())
                    .map_err(|e| format!("image job {}: its payload: {e}", job.id))?;
                let catalogue = Arc::clone(renderer.runner.catalogue());
                let flag = cancel.clone();
                let bytes = tokio::task::spawn_blocking(move || batch.render(&catalogue, &flag))
                    .await
                    .map_err(|e| format!("image job {}: {e}", job.id))??;
                if self
                    .store
                    .put_image_batch_moments(job.subject_id, &bytes)
                    .await
                    .map_err(|e| e.to_string())?
                {
                    Ok(())
                } else {
                    Err("the daemon that asked for this image gave it up (its batch row is gone)".into())
                }
            }
            WorkerJobKind::Study => {
                renderer
                    .studies
                    .run_row(job.subject_id, cancel)
                    .await
                    .map_err(|e| e.to_string())?;
                self.subject_ended_well("studies", job.subject_id).await
            }
        }
    }

    /// A render or study row runs to an end it records itself; the job
    /// failed unless that end is `complete`.
    async fn subject_ended_well(&self, table: &str, id: i64) -> Result<(), String> {
        let (state, error) = match table {
            "renders" => self
                .store
                .get_render(id)
                .await
                .map_err(|e| e.to_string())?
                .map(|r| (r.state, r.error)),
            _ => self
                .store
                .get_study(id)
                .await
                .map_err(|e| e.to_string())?
                .map(|r| (r.state, r.error)),
        }
        .ok_or_else(|| format!("{table} row {id} vanished"))?;
        if state == "complete" {
            Ok(())
        } else {
            Err(format!("{state}: {}", error.unwrap_or_default()))
        }
    }

    /// The renderer of daemon `daemon`'s published configuration: its
    /// scenes fetched from the database and unpacked, built once.
    async fn renderer_for(&mut self, daemon: i64) -> Result<Arc<RenderSide>, String> {
        let config_json = self
            .store
            .render_config(daemon)
            .await
            .map_err(|e| e.to_string())?
            .ok_or_else(|| {
                format!("daemon {daemon} published no render configuration (it was not started with --renders workers)")
            })?;
        let key = hex(&Sha256::digest(config_json.to_string().as_bytes()));
        if let Some(r) = self.renderers.get(&key) {
            return Ok(Arc::clone(r));
        }
        let config: RenderConfig =
            serde_json::from_value(config_json).map_err(|e| format!("daemon {daemon}'s render configuration: {e}"))?;
        // Every scene of the daemon in one folder, as in its scenes folder:
        // a scene's `[cielab_white]` may name a sibling scene.
        let mut bundles = Vec::new();
        for scene in &config.scenes {
            let stored = self
                .store
                .scene_bundle(&scene.bundle)
                .await
                .map_err(|e| e.to_string())?
                .ok_or_else(|| {
                    format!(
                        "scene `{}` of daemon {daemon}: its bundle {} is not in the database",
                        scene.id, scene.bundle
                    )
                })?;
            bundles.push(stored.bundle);
        }
        let cache = self.options.cache_dir.clone();
        let paths = tokio::task::spawn_blocking(move || {
            let merged = SceneBundle::merge(&bundles)?;
            let first = merged.unpack(&cache)?;
            let root = cache.join("bundles").join(merged.hash());
            debug_assert!(first.starts_with(&root));
            Ok::<_, crate::render::bundle::BundleError>(
                bundles
                    .iter()
                    .map(|b| root.join(b.scene_file()))
                    .collect::<Vec<PathBuf>>(),
            )
        })
        .await
        .map_err(|e| e.to_string())?
        .map_err(|e| format!("daemon {daemon}'s scenes: {e}"))?;
        let observer = config.observer;
        let catalogue = tokio::task::spawn_blocking(move || SceneCatalog::from_files(&paths, observer))
            .await
            .map_err(|e| e.to_string())?
            .map_err(|e| format!("daemon {daemon}'s scenes on this worker: {e}"))?;
        let catalogue = Arc::new(catalogue);
        let codings = parse_codings(&config.codings).map_err(|e| format!("daemon {daemon}'s {e}"))?;
        // The worker's own shutdown flag: set when it stops, so the render
        // a comparison runs stops too. Its workflows send no events: the
        // daemon that asked reports each job's end when it sees it stored.
        let renderer = RenderSide::new(RenderSideSettings {
            store: self.store.clone(),
            catalogue,
            events: EventSink::nowhere(),
            codings,
            samples: config.samples,
            preview_paths: config.preview_paths,
            observer,
            mock_world: None,
            workers: None,
            shutdown: CancellationToken::new(),
        });
        let renderer = Arc::new(renderer);
        tracing::info!(
            daemon,
            config = &key[..12],
            "renderer built from the daemon's published scenes"
        );
        self.renderers.insert(key, Arc::clone(&renderer));
        Ok(renderer)
    }
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}
