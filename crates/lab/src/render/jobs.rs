//! The daemon's renders, studies and camera images as the API asks for
//! them: one bounded queue ([`crate::jobs`]) and one worker that runs its
//! renders ([`RenderRunner`]) and studies ([`StudyRunner`]) in turn, camera
//! images on their own queue ([`crate::render::images`]), cancel and retry — or,
//! with `serve --renders workers`, the same rows handed to render workers
//! ([`WorkerQueue`]). [`RenderJobs`] is the [`RenderService`] the HTTP layer
//! calls.

use std::path::PathBuf;
use std::sync::Arc;

use crate::compare::Comparisons;
use crate::error::LabError;
use crate::jobs::{JobQueue, Queued};
use crate::progress::ProgressBoard;
use crate::render::images::{self as camera_images, ImageJobs, ImageRequest, ImageWork, ImagesAdmitted};
use crate::render::runner::RenderRunner;
use crate::render::worker_queue::WorkerQueue;
use crate::requests::{RenderRequest, SceneInfo, StudyRequest};
use crate::study::jobs::StudyRunner;
use crate::study::run::StudyOptions;
use lightbooth_render::RenderSettings;
use lightbooth_science::colorimetry::{Observer, Xyz};
use lightbooth_store::{already_retried_message, Booth, Job, JobEnd, Store};

/// A job's work, as the queue carries it.
pub enum Work {
    Render {
        scene_id: String,
        settings: RenderSettings,
    },
    Study {
        paths: Vec<PathBuf>,
        options: Box<StudyOptions>,
        /// Measurements queued for it (`measure_missing`), awaited first.
        measured_first: Vec<i64>,
    },
}

/// The daemon's render, study and image jobs.
pub struct RenderJobs {
    store: Store,
    runner: Arc<RenderRunner>,
    studies: Arc<StudyRunner>,
    /// For the CIELAB white of a scene (`GET /api/scenes/{scene}/white`).
    comparisons: Arc<Comparisons>,
    jobs: JobQueue<Work>,
    images: Arc<ImageJobs>,
    /// Set when renders and studies run on render workers.
    workers: Option<Arc<WorkerQueue>>,
    /// How far the running render and study have got (see [`Self::with_progress`]).
    progress: Option<Arc<ProgressBoard>>,
    /// Held by a retry from its look-up to its row: simultaneous retries in
    /// this daemon take turns, so the second finds the first's retry (and
    /// never meets a queue the others filled for a moment).
    retrying: tokio::sync::Mutex<()>,
}

impl RenderJobs {
    /// The jobs of a daemon whose renders `runner` runs, studies `studies`,
    /// camera images `images`; handed to `workers` when given.
    pub fn new(
        store: Store,
        runner: Arc<RenderRunner>,
        studies: Arc<StudyRunner>,
        comparisons: Arc<Comparisons>,
        images: Arc<ImageJobs>,
        workers: Option<Arc<WorkerQueue>>,
    ) -> RenderJobs {
        RenderJobs {
            jobs: JobQueue::new(store.clone(), runner.shutdown_flag()),
            store,
            runner,
            studies,
            comparisons,
            images,
            workers,
            progress: None,
            retrying: tokio::sync::Mutex::new(()),
        }
    }

    /// The same jobs, reporting their progress on `board` (the dashboard's
    /// queue reads it through [`RenderService::progress`]).
    pub fn with_progress(mut self, board: Arc<ProgressBoard>) -> RenderJobs {
        self.progress = Some(board);
        self
    }

    /// Starts the one worker that runs queued renders and studies in turn
    /// (and the camera images' own); it ends after [`RenderJobs::shutdown`],
    /// once the queue is drained.
    pub fn run(self: &Arc<Self>) -> tokio::task::JoinHandle<()> {
        drop(self.images.run());
        let this = Arc::clone(self);
        let receiver = self.jobs.take_receiver();
        tokio::spawn(async move {
            let Some(mut receiver) = receiver else { return };
            while let Some(queued) = receiver.recv().await {
                let (job, id) = (queued.job, queued.id);
                if let Err(e) = this.run_job(queued).await {
                    tracing::error!(job = job.noun(), id, error = %e, "cannot record the end of a job");
                }
                this.jobs.finished(job, id);
            }
        })
    }

    /// Refuses new jobs, stops the running one and the comparison renders;
    /// everything unfinished ends `interrupted`.
    pub fn shutdown(&self) {
        self.runner.shutdown();
        self.jobs.shutdown();
        self.images.shutdown();
    }

    async fn run_job(&self, queued: Queued<Work>) -> anyhow::Result<()> {
        let Queued { job, id, work, cancel } = queued;
        if self.jobs.is_shutting_down() {
            let why = format!(
                "the daemon shut down before this {} ran; retry it with POST /api/{}/{{id}}/retry",
                job.noun(),
                job.table()
            );
            self.store.end_job(job, id, JobEnd::Interrupted, &why).await?;
            return Ok(());
        }
        match work {
            Work::Render { scene_id, settings } => self.runner.execute(id, &scene_id, settings, cancel).await,
            Work::Study {
                paths,
                options,
                measured_first,
            } => self.studies.run(id, paths, *options, measured_first, cancel).await,
        }
    }

    /// Queues a render of a scene with checked settings; with `retry_of`,
    /// as the one retry of that render.
    async fn queue_render(
        &self,
        scene: String,
        settings: RenderSettings,
        retry_of: Option<i64>,
    ) -> Result<i64, LabError> {
        if self.runner.catalogue().get(&scene).is_none() {
            return Err(LabError::NotFound(format!("no scene `{scene}`")));
        }
        let record = self.runner.record_retrying(&scene, &settings, retry_of);
        if let Some(workers) = &self.workers {
            workers.check_share().await?;
            let id = record.await?;
            workers.hand_over(Job::Render, id, &scene).await?;
            return Ok(id);
        }
        let work = Work::Render {
            scene_id: scene.clone(),
            settings: settings.clone(),
        };
        // The caller polls /api/renders/{id} or follows the events.
        self.jobs.enqueue(Job::Render, record, work).await
    }

    /// Queues a study (its request checked field by field); with
    /// `retry_of`, as the one retry of that study.
    async fn queue_study(&self, request: StudyRequest, retry_of: Option<i64>) -> Result<i64, LabError> {
        let (paths, options) = self.studies.plan(&request)?;
        let create = async {
            self.store
                .create_study_retrying(&serde_json::to_value(&request).unwrap_or_default(), retry_of)
                .await
                .map_err(LabError::from)
        };
        if let Some(workers) = &self.workers {
            workers.check_share().await?;
            let id = create.await?;
            workers.hand_over(Job::Study, id, "").await?;
            tracing::info!(study_id = id, "study queued for the render workers");
            return Ok(id);
        }
        let work = Work::Study {
            paths,
            options: Box::new(options),
            measured_first: request.measured_first.clone(),
        };
        let id = self.jobs.enqueue(Job::Study, create, work).await?;
        tracing::info!(study_id = id, "study queued");
        Ok(id)
    }

    /// A new job with the request of an ended one (see the [jobs](crate::jobs)
    /// doc), once: a job already retried answers 409 naming its retry. The
    /// look-up first answers the usual case; the store's unique `retry_of`
    /// settles simultaneous retries (only one INSERT succeeds).
    async fn retry_job(&self, job: Job, id: i64) -> Result<i64, LabError> {
        let noun = job.noun();
        let not_found = || LabError::NotFound(format!("no {noun} {id}"));
        let _turn = self.retrying.lock().await;
        let retried = self.store.retried_as(job, id).await?;
        let retryable = |state: &str| -> Result<(), LabError> {
            if let Some(first) = retried {
                return Err(LabError::Conflict(already_retried_message(job, id, first)));
            }
            match state {
                "interrupted" | "failed" | "cancelled" => Ok(()),
                other => Err(LabError::Conflict(format!(
                    "{noun} {id} is {other}; only an interrupted, failed or cancelled {noun} can be retried"
                ))),
            }
        };
        match job {
            Job::Render => {
                let row = self.store.get_render(id).await?.ok_or_else(not_found)?;
                retryable(&row.state)?;
                let settings: RenderSettings = serde_json::from_value(row.settings.clone())
                    .map_err(|e| LabError::Internal(format!("render {id}'s stored settings: {e}")))?;
                let new = self.queue_render(row.scene.clone(), settings, Some(id)).await?;
                tracing::info!(render_id = new, retry_of = id, "render retried");
                Ok(new)
            }
            Job::Study => {
                let row = self.store.get_study(id).await?.ok_or_else(not_found)?;
                retryable(&row.state)?;
                // `measured_first` records what the first run queued for the
                // instrument; it is not part of a request (a retry uses the
                // measurements stored now).
                let mut stored = row.request.clone();
                if let Some(fields) = stored.as_object_mut() {
                    fields.remove("measured_first");
                }
                let request: StudyRequest = serde_json::from_value(stored)
                    .map_err(|e| LabError::Internal(format!("study {id}'s stored request: {e}")))?;
                let new = self.queue_study(request, Some(id)).await?;
                tracing::info!(study_id = new, retry_of = id, "study retried");
                Ok(new)
            }
        }
    }

    /// Queues a camera image of a render (see [`crate::render::images`]): the
    /// render's scene, which must be the content the render was of, with
    /// the render's transport and seed; the request checked against the
    /// limits first.
    async fn queue_image(&self, render_id: i64, request: ImageRequest) -> Result<ImagesAdmitted, LabError> {
        let row = self
            .store
            .get_render(render_id)
            .await?
            .ok_or_else(|| LabError::NotFound(format!("no render {render_id}")))?;
        let settings: RenderSettings = serde_json::from_value(row.settings.clone())
            .map_err(|e| LabError::Internal(format!("render {render_id}'s stored settings: {e}")))?;
        let entry = self
            .runner
            .catalogue()
            .get(&row.scene)
            .ok_or_else(|| LabError::NotFound(format!("render {render_id}'s scene `{}` is gone", row.scene)))?;
        if entry.hash != row.scene_hash {
            return Err(LabError::Conflict(format!(
                "the scene file of `{}` changed since render {render_id}: render the scene again, then ask for its images",
                row.scene
            )));
        }
        let camera =
            entry.scene.camera.clone().ok_or_else(|| {
                LabError::Conflict(format!("scene `{}` has no [camera]: no image to render", row.scene))
            })?;
        let transport = settings.transport();
        let (checked, codings) = camera_images::check_request(&request, &camera, &transport, settings.seed)?;
        let observer = self.runner.observer();
        let (scaled, camera_settings) = camera_images::camera_settings(&checked[0], codings, &camera, observer)?;
        let scene = Arc::clone(&entry.scene);
        let named: Vec<String> = checked.iter().map(|s| s.coding.clone()).collect();
        let reference = checked[0].reference.clone();
        let (ids, reused) = self
            .images
            .enqueue(render_id, &row.scene, observer, checked, |ids| ImageWork {
                ids,
                scene,
                scene_id: row.scene.clone(),
                scene_hash: row.scene_hash.clone(),
                camera: scaled,
                settings: camera_settings,
            })?;
        let reference_id = named
            .iter()
            .zip(&ids)
            .find(|(c, _)| **c == reference)
            .map_or(ids[ids.len() - 1], |(_, id)| *id);
        Ok(ImagesAdmitted {
            images: named.into_iter().zip(ids).collect(),
            reference_id,
            reused,
        })
    }
}

/// The renders, studies and camera images as the lab's handle asks for
/// them (see [`crate::handle::Lab`]).
impl RenderJobs {
    /// The scene catalogue renders are of.
    pub fn catalogue(&self) -> &Arc<crate::scenes::SceneCatalog> {
        self.runner.catalogue()
    }

    /// The scenes available under the daemon's `scenes_dir`, in the study's order.
    pub fn scenes(&self) -> Vec<SceneInfo> {
        self.runner.catalogue().infos()
    }

    /// Records a render of a scene and queues it; its id at once.
    pub async fn start_render(&self, scene: &str, request: RenderRequest) -> Result<i64, LabError> {
        if self.runner.catalogue().get(scene).is_none() {
            return Err(LabError::NotFound(format!("no scene `{scene}`")));
        }
        let settings = self.runner.settings(&request)?;
        self.queue_render(scene.to_string(), settings, None).await
    }

    /// Checks a study request field by field without starting anything.
    pub fn check_study(&self, request: &StudyRequest) -> Result<(), LabError> {
        self.studies.plan(request).map(|_| ())
    }

    /// Records a study and queues it; its id at once.
    pub async fn start_study(&self, request: StudyRequest) -> Result<i64, LabError> {
        self.queue_study(request, None).await
    }

    /// Cancels a queued or running render or study (a conflict once it has ended).
    pub async fn cancel(&self, job: Job, id: i64) -> Result<(), LabError> {
        if let Some(workers) = &self.workers {
            if workers.cancel(job, id).await? {
                return Ok(());
            }
        }
        self.jobs.cancel(job, id).await
    }

    /// Queues a new render or study with the request of an interrupted,
    /// failed or cancelled one; the new id.
    pub async fn retry(&self, job: Job, id: i64) -> Result<i64, LabError> {
        self.retry_job(job, id).await
    }

    /// Queues the camera images of a render in one coding or several from
    /// the same paths (or finds those already made with the same settings):
    /// their ids and whether they were reused.
    pub async fn start_image(&self, render_id: i64, request: ImageRequest) -> Result<ImagesAdmitted, LabError> {
        self.queue_image(render_id, request).await
    }

    /// The camera images this daemon keeps (see [`crate::render::images`]).
    pub fn images(&self) -> &ImageJobs {
        &self.images
    }

    /// How far the running renders and studies have got, when followed.
    pub fn progress(&self) -> Option<&ProgressBoard> {
        self.progress.as_deref()
    }

    /// The CIELAB white of a scene in a booth in `observer` now, with its
    /// source (see [`crate::compare::white`]).
    pub async fn cielab_white(
        &self,
        scene: &str,
        booth: &Booth,
        observer: Observer,
    ) -> Result<(Xyz, String), LabError> {
        self.comparisons.white_xyz(scene, booth, observer).await
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::events::EventSink;
    use crate::testing::{runner, shipped_scenes, store_in};
    use lightbooth_render::Coding;
    use lightbooth_science::colorimetry::Observer;
    use tokio_util::sync::CancellationToken;

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_render_asked_for_runs_and_only_one_that_did_not_complete_may_be_retried() {
        let dir = tempfile::tempdir().unwrap();
        let store = store_in(dir.path()).await;
        let (runner, _) = runner(&store);
        let studies = Arc::new(StudyRunner::new(
            store.clone(),
            shipped_scenes(),
            EventSink::nowhere(),
            vec![Coding::Rgb],
            Observer::JuddVos,
            None,
            CancellationToken::new(),
        ));
        let comparisons = Arc::new(Comparisons::new(
            store.clone(),
            Arc::clone(&runner),
            EventSink::nowhere(),
            None,
        ));
        let bus = EventSink::bus(64);
        let jobs = Arc::new(RenderJobs::new(
            store.clone(),
            runner,
            studies,
            comparisons,
            Arc::new(ImageJobs::new(bus, 0)),
            None,
        ));
        let worker = jobs.run();

        let unknown = jobs.start_render("attic", RenderRequest::default()).await;
        assert_eq!(unknown, Err(LabError::NotFound("no scene `attic`".into())));
        let request = RenderRequest {
            samples: Some(16),
            ..RenderRequest::default()
        };
        let id = jobs.start_render("white", request).await.unwrap();
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs(300);
        loop {
            let row = store.get_render(id).await.unwrap().unwrap();
            if row.state == "complete" {
                break;
            }
            assert!(
                !["failed", "cancelled", "interrupted"].contains(&row.state.as_str()),
                "{row:?}"
            );
            assert!(std::time::Instant::now() < deadline, "render {id} still {}", row.state);
            tokio::time::sleep(std::time::Duration::from_millis(20)).await;
        }
        match jobs.retry(Job::Render, id).await {
            Err(LabError::Conflict(m)) => assert_eq!(
                m,
                format!("render {id} is complete; only an interrupted, failed or cancelled render can be retried")
            ),
            other => panic!("a complete render was retried: {other:?}"),
        }
        // Its camera image, once: the same request again is the same image.
        let image = ImageRequest {
            coding: Some("srgb".into()),
            width: Some(8),
            max_spp: Some(8),
            ..ImageRequest::default()
        };
        let first = jobs.start_image(id, image.clone()).await.unwrap();
        assert!(!first.reused);
        let again = jobs.start_image(id, image).await.unwrap();
        assert!(again.reused);
        assert_eq!(again.images, first.images);
        // A set of codings is a new job, an image per coding, the last the reference.
        let set = ImageRequest {
            codings: Some(vec!["srgb".into(), "nstep9".into()]),
            width: Some(8),
            max_spp: Some(8),
            ..ImageRequest::default()
        };
        let admitted = jobs.start_image(id, set).await.unwrap();
        assert!(!admitted.reused);
        assert_eq!(admitted.images.len(), 2);
        assert_ne!(admitted.images[0].1, first.images[0].1);
        assert_eq!(admitted.reference_id, admitted.images[1].1);

        jobs.shutdown();
        worker.await.unwrap();
        let refused = jobs.start_render("white", RenderRequest::default()).await.unwrap_err();
        assert_eq!(refused, LabError::Unavailable("the daemon is shutting down".into()));
        assert_eq!(
            store.list_renders(None).await.unwrap().len(),
            1,
            "nothing recorded for a refused render"
        );
    }
}
