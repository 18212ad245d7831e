//! **Where the lab's object graph is built**: the one composition root of
//! the daemon ([`DaemonLab::start`]) and of a render worker
//! ([`RenderSide::new`], which the daemon's graph uses too), so both parse
//! the codings once and wire a render runner, the comparisons and the study
//! runner the same way.
//!
//! The daemon's graph, built in order:
//!
//! 1. the scene catalogue (every scene loaded once), the codings, the
//!    simulated truth (what `--mock` measures);
//! 2. with `--renders workers`, the queue that publishes the scenes and
//!    hands comparisons, renders and studies to render workers;
//! 3. the [`RenderSide`]: one render runner, the comparisons of each
//!    measurement with every coding, the study runner;
//! 4. the API's render, study and camera-image jobs, and the progress board;
//! 5. the [instrument task](crate::measure::task) on its own thread, and
//!    the [`BoothInstrument`] the HTTP layer asks it through;
//! 6. the [`LabHandle`] over all of it.
//!
//! [`DaemonLab`] keeps what must be stopped in order at shutdown: the jobs
//! first ([`DaemonLab::stop_jobs`]), then, once the HTTP server (which
//! holds the [`LabHandle`] and so the instrument queue's sender) is gone, the
//! instrument task, the job worker, and this daemon's unfinished rows
//! ([`DaemonLab::stop`]).

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use anyhow::Context;
use tokio::sync::{mpsc, watch};

use crate::compare::Comparisons;
use crate::events::EventSink;
use crate::measure::booth_instrument::BoothInstrument;
use crate::measure::queue::{InstrumentStatus, MockControl};
use crate::measure::simulated_truth::SimulatedTruth;
use crate::measure::task::{self, InstrumentTask, MockSettings};
use crate::render::images::ImageJobs;
use crate::render::jobs::RenderJobs;
use crate::render::runner::RenderRunner;
use crate::render::worker_queue::{RenderPlace, WorkerQueue};
use crate::scenes::SceneCatalog;
use crate::study::jobs::StudyRunner;
use crate::LabHandle;
use lightbooth_instrument::InstrumentSettings;
use lightbooth_render::Coding;
use lightbooth_science::colorimetry::Observer;
use lightbooth_store::{Booth, Job, Store};
use tokio_util::sync::CancellationToken;

/// How many measurements may wait for the instrument; more get 409. Enough
/// for every target of every booth scene (1 + 1 + 1 + 1 + 21) at once.
pub const QUEUE_CAPACITY: usize = 64;

/// How often a daemon leaving its work to render workers looks for the
/// jobs that ended, to send their events.
pub const WORKER_JOB_POLL: Duration = Duration::from_millis(250);

/// How long the render job may take to stop at shutdown (a render stops
/// within one batch of paths per thread).
const JOB_STOP: Duration = Duration::from_secs(30);

/// The codings named, parsed (`rgb`, `srgb`, `nstepN`, `spectral`), or the
/// first name that is not one.
pub fn parse_codings(names: &[String]) -> Result<Vec<Coding>, String> {
    names
        .iter()
        .map(|c| c.parse::<Coding>().map_err(|e| format!("coding `{c}`: {e}")))
        .collect()
}

/// What a render side is built from.
pub struct RenderSideSettings {
    pub store: Store,
    pub catalogue: Arc<SceneCatalog>,
    /// Where its workflows send events (a render worker's: nowhere; the
    /// daemon that asked reports the job's end when it sees it stored).
    pub events: EventSink,
    pub codings: Vec<Coding>,
    /// Radiometer samples per target of a comparison render.
    pub samples: u64,
    /// Camera paths in all of a render's preview.
    pub preview_paths: u64,
    pub observer: Observer,
    /// The study's scenes as the booth is, when they differ from the model
    /// (`serve --mock-world`).
    pub mock_world: Option<PathBuf>,
    /// The render workers comparisons are handed to (`--renders workers`).
    pub workers: Option<Arc<WorkerQueue>>,
    /// Cancelling it stops the running render and study.
    pub shutdown: CancellationToken,
}

/// One render runner and the workflows that render with it: the
/// comparisons of each measurement with every coding and the study.
pub struct RenderSide {
    pub runner: Arc<RenderRunner>,
    pub comparisons: Arc<Comparisons>,
    pub studies: Arc<StudyRunner>,
}

impl RenderSide {
    pub fn new(s: RenderSideSettings) -> RenderSide {
        let runner = Arc::new(
            RenderRunner::new(
                s.store.clone(),
                Arc::clone(&s.catalogue),
                s.events.clone(),
                s.codings.clone(),
                s.samples,
                s.observer,
                s.shutdown.clone(),
            )
            .with_preview_paths(s.preview_paths),
        );
        let comparisons = Arc::new(Comparisons::new(
            s.store.clone(),
            Arc::clone(&runner),
            s.events.clone(),
            s.workers,
        ));
        let studies = Arc::new(StudyRunner::new(
            s.store,
            s.catalogue,
            s.events,
            s.codings,
            s.observer,
            s.mock_world,
            s.shutdown,
        ));
        RenderSide {
            runner,
            comparisons,
            studies,
        }
    }
}

/// What the daemon's lab is built from (`serve`'s options that are the
/// lab's).
pub struct LabSettings {
    /// The booth this daemon and its instrument measure in.
    pub booth: Booth,
    /// The observer of every colour the lab computes.
    pub observer: Observer,
    pub scenes_dir: PathBuf,
    /// Codings rendered for each comparison, by name.
    pub codings: Vec<String>,
    pub render_samples: u64,
    pub preview_paths: u64,
    pub mock_world: Option<PathBuf>,
    /// Where comparisons, renders and studies run.
    pub renders: RenderPlace,
    /// The booth's instrument: its model and settings.
    pub instrument: InstrumentSettings,
    /// The simulated instrument (`--mock`), or the real one.
    pub mock: Option<MockSettings>,
}

/// The daemon's lab as it runs: what is stopped, in order, at shutdown
/// (see the module doc).
pub struct DaemonLab {
    store: Store,
    render_jobs: Arc<RenderJobs>,
    instrument: InstrumentTask,
    job_worker: tokio::task::JoinHandle<()>,
    _worker_watch: Option<AbortOnDrop>,
}

impl DaemonLab {
    /// Builds the daemon's lab on `store` (this daemon's, `daemon_id`),
    /// publishing on `events`; cancelling `shutdown` stops the running
    /// measurement, render and study. Returns the [`LabHandle`] (for the
    /// HTTP layer) and what runs under it.
    pub async fn start(
        store: Store,
        events: EventSink,
        daemon_id: i64,
        settings: LabSettings,
        shutdown: CancellationToken,
    ) -> anyhow::Result<(LabHandle, DaemonLab)> {
        let catalogue = Arc::new(SceneCatalog::from_folder(&settings.scenes_dir, settings.observer)?);
        let codings = parse_codings(&settings.codings).map_err(anyhow::Error::msg)?;
        let truth = Arc::new(SimulatedTruth::new(
            Arc::clone(&catalogue),
            settings.mock_world.clone(),
        )?);
        let workers = match settings.renders {
            RenderPlace::Here => None,
            RenderPlace::Workers => {
                anyhow::ensure!(
                    store.engine_name() == "postgres",
                    "--renders workers needs a database shared with the render workers: a PostgreSQL one \
                     (--db postgres://…); on an SQLite file the daemon renders itself (--renders here)"
                );
                anyhow::ensure!(
                    settings.mock_world.is_none(),
                    "--renders workers cannot be combined with --mock-world: the mock world's scenes are not published to workers"
                );
                let queue = WorkerQueue::publish(
                    store.clone(),
                    events.clone(),
                    &catalogue,
                    &codings,
                    settings.render_samples,
                    settings.preview_paths,
                    settings.observer,
                )
                .await?;
                Some(Arc::new(queue))
            }
        };
        let worker_watch = workers
            .as_ref()
            .map(|queue| AbortOnDrop(tokio::spawn(Arc::clone(queue).watch(WORKER_JOB_POLL))));
        let side = RenderSide::new(RenderSideSettings {
            store: store.clone(),
            catalogue,
            events: events.clone(),
            codings,
            samples: settings.render_samples,
            preview_paths: settings.preview_paths,
            observer: settings.observer,
            mock_world: settings.mock_world.clone(),
            workers: workers.clone(),
            shutdown: shutdown.clone(),
        });
        // Complete measurements left without a comparison (taken while the
        // daemon stopped, or refused by an older daemon: a colorimeter's in
        // another observer) are compared now, in the background.
        match side.comparisons.compare_left_over(&settings.booth).await {
            Ok(0) => {}
            Ok(n) => tracing::info!(
                measurements = n,
                "queued the comparisons of measurements left uncompared"
            ),
            Err(e) => tracing::error!(error = %e, "cannot look for measurements left uncompared"),
        }
        let render_jobs = Arc::new(
            RenderJobs::new(
                store.clone(),
                side.runner,
                side.studies,
                Arc::clone(&side.comparisons),
                Arc::new(match &workers {
                    Some(_) => ImageJobs::new(events.clone(), daemon_id).on_workers(store.clone()),
                    None => ImageJobs::new(events.clone(), daemon_id),
                }),
                workers,
            )
            .with_progress(crate::progress::ProgressBoard::follow(&events)),
        );
        let job_worker = render_jobs.run();
        let (jobs_tx, jobs_rx) = mpsc::channel(QUEUE_CAPACITY);
        let (status_tx, status_rx) = watch::channel(InstrumentStatus::Disconnected {
            reason: "starting".into(),
        });
        let instrument = task::spawn(task::TaskConfig {
            store: store.clone(),
            jobs: jobs_rx,
            status: status_tx,
            events: events.clone(),
            comparisons: side.comparisons,
            truth,
            observer: settings.observer,
            settings: settings.instrument.clone(),
            booth: settings.booth.clone(),
            mock: settings.mock,
            runtime: tokio::runtime::Handle::current(),
            shutdown,
        })
        .context("starting the instrument task")?;
        let booth_instrument = BoothInstrument::new(
            store.clone(),
            jobs_tx,
            status_rx,
            events,
            Some(Arc::new(instrument.canceller())),
            settings.instrument.capabilities(),
            settings.booth,
        );
        let lab = LabHandle::new(
            store.clone(),
            settings.observer,
            booth_instrument,
            Some(Arc::clone(&render_jobs)),
        );
        Ok((
            lab,
            DaemonLab {
                store,
                render_jobs,
                instrument,
                job_worker,
                _worker_watch: worker_watch,
            },
        ))
    }

    /// The simulated instrument's faults and aim (`/api/mock`), with `--mock`.
    pub fn mock_control(&self) -> Option<Arc<dyn MockControl>> {
        self.instrument.mock_control()
    }

    /// Stops taking renders, studies and images (the first step of the
    /// shutdown; the running ones stop on the shutdown token).
    pub fn stop_jobs(&self) {
        self.render_jobs.shutdown();
    }

    /// Ends the lab once every [`LabHandle`] is gone (the HTTP server
    /// stopped): the instrument task finishes its current job and stops,
    /// the job worker marks the cancelled and queued jobs interrupted, and
    /// this daemon's own unfinished renders, studies and measurements are
    /// marked interrupted (a neighbour's on a shared database are its own
    /// business).
    pub async fn stop(self) -> anyhow::Result<()> {
        self.instrument.join().await;
        if tokio::time::timeout(JOB_STOP, self.job_worker).await.is_err() {
            tracing::warn!("the render job did not stop within {} s", JOB_STOP.as_secs());
        }
        for job in [Job::Render, Job::Study] {
            self.store
                .interrupt_own_unfinished(
                    job.table(),
                    &format!(
                        "the daemon shut down during this {}; retry it with POST /api/{}/{{id}}/retry",
                        job.noun(),
                        job.table()
                    ),
                )
                .await?;
        }
        let n = self
            .store
            .interrupt_own_unfinished("measurements", "the daemon shut down before this measurement ran")
            .await?;
        if n > 0 {
            tracing::info!(count = n, "queued measurements marked interrupted at shutdown");
        }
        Ok(())
    }
}

/// What a daemon starting on a booth repairs first: the work of this
/// booth's previous daemon on this host, killed (kill -9, a crash), marked
/// interrupted now, not a lease later; sessions left running with all
/// their trials completed (issue 32); camera-image export folders a killed
/// daemon left behind removed.
pub async fn recover_at_start(store: &Store, booth: &Booth) -> anyhow::Result<()> {
    let recovered = store
        .recover_dead_predecessors(booth)
        .await
        .context("recovering the work of this booth's previous daemon")?;
    if recovered.total() > 0 {
        tracing::warn!(
            measurements = recovered.measurements,
            renders = recovered.renders,
            studies = recovered.studies,
            "marked the work of this booth's dead previous daemon as interrupted"
        );
    }
    let completed = crate::experiments::Experiments::new(store.clone())
        .complete_finished_sessions(booth.as_str())
        .await
        .context("completing experiment sessions found with all their trials")?;
    if !completed.is_empty() {
        tracing::warn!(sessions = ?completed, "completed experiment sessions found running with all their trials");
    }
    for left in crate::export::image::remove_stale_export_folders(&std::env::temp_dir()) {
        tracing::info!(folder = %left.display(), "removed an image export folder left by a process that is gone");
    }
    Ok(())
}

/// Aborts a task when dropped: a background task stops with its owner,
/// also when the owner returns early with an error.
struct AbortOnDrop(tokio::task::JoinHandle<()>);

impl Drop for AbortOnDrop {
    fn drop(&mut self) {
        self.0.abort();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::events::Event;
    use crate::measure::booth_instrument::{MeasurementRequest, Requested};
    use lightbooth_instrument::sim::Personality;
    use lightbooth_store::MeasurementState;
    use tokio::sync::broadcast;

    /// Measure → compare → event at the lab's boundary, without axum (issue
    /// 47): the daemon's lab built by `DaemonLab::start` with the simulated
    /// PR-650 on a pty takes a measurement of WHITE's patch asked for
    /// through its handle, publishes each sample and its end, compares it
    /// with every coding and says so; then stops in order, leaving nothing
    /// running.
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_target_asked_for_is_measured_compared_and_announced_without_http() {
        let dir = tempfile::tempdir().unwrap();
        let store = crate::testing::store_in(dir.path()).await;
        let events = EventSink::bus(4096);
        let mut heard = events.subscribe().unwrap();
        let booth = Booth::default();
        let lease = crate::lease::Lease::take(
            &store,
            &booth,
            Duration::from_secs(10),
            Duration::from_secs(2),
            Some(events.clone()),
        )
        .await
        .unwrap();
        let shutdown = CancellationToken::new();
        let settings = LabSettings {
            booth: booth.clone(),
            observer: Observer::JuddVos,
            scenes_dir: PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes"),
            codings: ["rgb", "nstep3", "spectral"].map(String::from).to_vec(),
            render_samples: 1024,
            preview_paths: 20_000,
            mock_world: None,
            renders: RenderPlace::Here,
            instrument: InstrumentSettings::default(),
            mock: Some(MockSettings {
                personality: Personality::Pr650,
                speed: 0.05,
                faults: Vec::new(),
                cache_dir: dir.path().join("cache"),
            }),
        };
        let (lab, running) = DaemonLab::start(
            lease.store().clone(),
            events.clone(),
            lease.id(),
            settings,
            shutdown.clone(),
        )
        .await
        .unwrap();
        let deadline = tokio::time::Instant::now() + Duration::from_secs(60);
        while lab.instrument().unavailable().is_some() {
            assert!(
                tokio::time::Instant::now() < deadline,
                "the simulated PR-650 never became ready"
            );
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
        let request = MeasurementRequest {
            scene: Some("white".into()),
            target: Some("patch".into()),
            samples: Some(2),
            ..MeasurementRequest::default()
        };
        let id = match lab.instrument().request(request, &lab.scenes_if_any()).await.unwrap() {
            Requested::Queued(id) => id,
            other => panic!("not queued: {other:?}"),
        };
        let (mut samples, mut finished) = (Vec::new(), None);
        let compared = tokio::time::timeout(Duration::from_secs(600), async {
            loop {
                match heard.recv().await {
                    Ok(Event::Sample {
                        measurement_id,
                        index,
                        of,
                        ..
                    }) if measurement_id == id => samples.push((index, of)),
                    Ok(Event::MeasurementFinished {
                        measurement_id, state, ..
                    }) if measurement_id == id => finished = Some(state),
                    Ok(Event::ComparisonReady {
                        measurement_id,
                        scene,
                        target,
                    }) if measurement_id == id => return (scene, target),
                    Ok(_) | Err(broadcast::error::RecvError::Lagged(_)) => {}
                    Err(e) => panic!("the event bus closed: {e}"),
                }
            }
        })
        .await
        .expect("no comparison_ready within 600 s");
        assert_eq!(compared, ("white".to_string(), "patch".to_string()));
        assert_eq!(samples, vec![(0, 2), (1, 2)], "each sample announced, in order");
        assert_eq!(finished, Some(MeasurementState::Complete));
        let rows = lab.comparisons_of_measurement(id).await.unwrap();
        let mut codings: Vec<&str> = rows.iter().map(|r| r.coding.as_str()).collect();
        codings.sort();
        assert_eq!(codings, ["nstep3", "rgb", "spectral"]);

        shutdown.cancel();
        running.stop_jobs();
        drop(lab);
        tokio::time::timeout(Duration::from_secs(60), running.stop())
            .await
            .expect("the lab stops once its handle is gone")
            .unwrap();
        lease.release().await.unwrap();
    }
}
