//! The renderer as the daemon runs it: scenes from `scenes/`, renders on the
//! rayon pool (never on the async runtime or the instrument thread), one
//! render per scene content and settings (reused from the store), and the
//! comparison of each measurement with every coding.
//!
//! Renders and studies requested through the API are [jobs](super::jobs):
//! bounded in size and number, cancellable, and a panic fails only its job.
//!
//! # The observer
//!
//! Every XYZ, x,y, CIELAB and ΔE the daemon computes uses its one configured
//! observer (`serve --observer`): the renders' settings, the measured XYZ
//! and the white; every comparison row names it.
//!
//! # The CIELAB reference white
//!
//! Both sides of a comparison go through CIELAB with the same white: the one
//! the scene declares in its file (`[cielab_white]`, resolved by
//! [`scene_white`]). WHITE, RED, GREEN and BLUE declare the WHITE scene's
//! Spectralon (`white/patch`), CYLINDER its top target (`h21`). A target
//! white is the newest complete *measurement* of that target in the booth
//! the compared measurement was taken in (booths have their own lamps: a
//! white measured in booth north never serves booth south); until one
//! exists, the `spectral` rendering of it stands in, and the row says so
//! (`white_source`, with the white's XYZ).
//!
//! When a booth's white changes — its target is measured there for the first
//! time or again — every comparison of that booth of every scene using it is
//! recomputed with the new white (ΔE from the stored XYZ; the measured and rendered XYZ do not
//! depend on the white), so no scene mixes whites. Comparisons and these
//! updates are serialised by one lock, so a comparison finishing late cannot
//! write an old white after the update.
//!
//! # The simulated booth
//!
//! With `--mock` the simulated PR-650 reads the converged truth of the scene
//! ([`render::converged_target_spectrum`]: its own seed, no bounce cap,
//! 1 nm), never the comparison render. With `--mock-world DIR` it reads the
//! scene of the same id in DIR instead (the booth as it is, when it differs
//! from the model the codings render).
//!
//! # Scene bundles
//!
//! Before a render is recorded, the scene's bundle (its TOML and every file
//! the loader reads, [`render::bundle`]) is stored unless the store has it,
//! with the render key (`scene_hash`) of the same bytes, so a machine
//! without `scenes/` can fetch the files a render row names.
//!
//! # Cost per coding
//!
//! After a render, each coding is rendered alone with a *fixed* number of
//! paths per target (the render's `samples`, no adaptive stop, as the CLI's
//! `--time-each-coding` and the study's sweeps), timed as
//! [`render::cost`] says (median of rotated repeats after a warm-up; the
//! codings trace the same rays, so rays cannot rank them): `coding_cost` in
//! the stored result gives its paths, rays, median wall time and its
//! fastest and slowest repeat; `coding_seconds` keeps the median alone.

use std::collections::HashMap;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use tokio::runtime::Handle;
use tokio::sync::broadcast;

use super::images::{self as camera_images, ImageJobs, ImageRequest, ImageWork};
use super::jobs::{self, JobQueue, Queued, MAX_RENDER_BOUNCES, MAX_RENDER_SAMPLES};
use super::study_measurements::wait_for_measurements;
use super::worker_queue::{PublishedScene, RenderConfig, WorkerQueue};
use crate::colorimetry::{xyz_from_radiance, Lab, Observer, Xyz};
use crate::comparison::{compare_point, delta_e_pair};
use crate::lab::error::LabError;
use crate::lab::events::Event;
use crate::lab::requests::RenderRequest;
use crate::lab::requests::SceneInfo;
use crate::lab::requests::StudyRequest;
use crate::lab::services::BoxFuture;
use crate::lab::services::RenderService;
use crate::render::integrator::{with_cancel, CancelFlag};
use crate::render::{self, Coding, RenderError, RenderSettings, Scene};
use crate::spectrum::{Grid, SpectralUnit, Spectrum};
use crate::store::{Booth, Job, JobEnd, NewComparison, NewRender, Store, WorkerJobKind};
use crate::study::report::report_files;
use crate::study::run::{run_study, Against, StudyOptions, COST_DEFINITION};
use crate::study::white::{scene_white, SceneWhite};

/// A scene found in `scenes/`.
struct SceneEntry {
    id: String,
    path: PathBuf,
    title: String,
    targets: Vec<String>,
}

pub struct Renderer {
    scenes: Vec<SceneEntry>,
    store: Store,
    events: broadcast::Sender<Event>,
    codings: Vec<Coding>,
    samples: u64,
    runtime: Handle,
    /// The observer of every XYZ, x,y, CIELAB and ΔE (`serve --observer`).
    observer: Observer,
    /// Scene files the simulated PR-650 measures instead of the model
    /// (`serve --mock-world DIR`), by scene id.
    mock_world: Option<PathBuf>,
    /// Serialises "resolve the white, store comparisons, refresh whites".
    compare_lock: tokio::sync::Mutex<()>,
    /// One lock per scene, so concurrent comparisons of one scene wait for a
    /// single render instead of each starting its own.
    scene_locks: std::sync::Mutex<HashMap<String, Arc<tokio::sync::Mutex<()>>>>,
    /// Renders and studies requested through the API.
    jobs: JobQueue<Work>,
    /// The simulated PR-650's converged spectra are rendered here, not on
    /// the global pool the jobs use: a job's batches fill the global pool's
    /// queues, and the instrument thread would wait behind all of them.
    converge_pool: rayon::ThreadPool,
    /// Set at shutdown: stops the comparison renders (jobs have their own flags).
    shutdown: CancelFlag,
    /// Camera images of renders, for the image viewer ([`super::images`]).
    images: Arc<ImageJobs>,
    /// Set when comparisons, renders and studies run on render workers
    /// (`serve --renders workers`, [`super::worker_queue`]).
    workers: Option<Arc<WorkerQueue>>,
}

/// A job's work, as the queue carries it.
pub enum Work {
    Render {
        scene_id: String,
        scene: Box<Scene>,
        settings: RenderSettings,
    },
    Study {
        paths: Vec<PathBuf>,
        options: Box<StudyOptions>,
        /// Measurements queued for it (`measure_missing`), awaited first.
        measured_first: Vec<i64>,
    },
}

impl Renderer {
    /// Loads every `*.toml` scene of `scenes_dir`; a scene that fails to load
    /// is an error naming the file and key (a broken booth must be fixed, not
    /// skipped).
    pub fn new(
        scenes_dir: PathBuf,
        store: Store,
        events: broadcast::Sender<Event>,
        codings: Vec<String>,
        samples: u64,
        observer: Observer,
        mock_world: Option<PathBuf>,
    ) -> anyhow::Result<Renderer> {
        let mut paths: Vec<PathBuf> = std::fs::read_dir(&scenes_dir)
            .map_err(|e| anyhow::anyhow!("cannot read the scenes folder {}: {e}", scenes_dir.display()))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|x| x == "toml"))
            .collect();
        paths.sort();
        Renderer::with_scene_files(&paths, store, events, codings, samples, observer, mock_world)
    }

    /// A renderer of the scene files `paths` (each scene's id is its file
    /// name without `.toml`): a render worker's, whose scenes are unpacked
    /// bundles in separate folders.
    pub fn with_scene_files(
        paths: &[PathBuf],
        store: Store,
        events: broadcast::Sender<Event>,
        codings: Vec<String>,
        samples: u64,
        observer: Observer,
        mock_world: Option<PathBuf>,
    ) -> anyhow::Result<Renderer> {
        let mut scenes = Vec::new();
        for path in paths {
            let scene = render::load_scene(path)?;
            // A scene must declare its CIELAB white: refuse it at start, not
            // at the first comparison.
            scene_white(path, &scene, observer).map_err(anyhow::Error::msg)?;
            let id = path
                .file_stem()
                .and_then(|s| s.to_str())
                .unwrap_or_default()
                .to_string();
            scenes.push(SceneEntry {
                title: scene.name.clone(),
                targets: scene.targets().into_iter().map(str::to_string).collect(),
                id,
                path: path.clone(),
            });
        }
        // The study's order: the simple scenes, then CYLINDER.
        let order = ["white", "red", "green", "blue", "cylinder"];
        scenes.sort_by_key(|s| order.iter().position(|o| *o == s.id).unwrap_or(order.len()));
        let codings = codings
            .iter()
            .map(|c| c.parse::<Coding>().map_err(|e| anyhow::anyhow!("coding `{c}`: {e}")))
            .collect::<anyhow::Result<Vec<_>>>()?;
        if let Some(world) = &mock_world {
            for s in &scenes {
                let p = world.join(format!("{}.toml", s.id));
                if p.exists() {
                    render::load_scene(&p)?;
                    tracing::info!(scene = s.id, world = %p.display(), "the simulated PR-650 measures the mock world's scene");
                } else {
                    tracing::info!(
                        scene = s.id,
                        "no scene in the mock world: the simulated PR-650 measures the model"
                    );
                }
            }
        }
        let converge_pool = rayon::ThreadPoolBuilder::new()
            .thread_name(|i| format!("converge-{i}"))
            .build()
            .map_err(|e| anyhow::anyhow!("cannot start the renderer's threads: {e}"))?;
        Ok(Renderer {
            images: Arc::new(ImageJobs::new(events.clone())),
            jobs: JobQueue::new(store.clone()),
            observer,
            mock_world,
            compare_lock: tokio::sync::Mutex::new(()),
            scenes,
            store,
            events,
            codings,
            samples,
            runtime: Handle::current(),
            scene_locks: Default::default(),
            converge_pool,
            shutdown: CancelFlag::default(),
            workers: None,
        })
    }

    /// Leaves this daemon's comparisons, renders and studies to render
    /// workers: stores every scene's bundle and publishes the
    /// [`RenderConfig`] workers render with (see [`super::worker_queue`]).
    /// Returns the queue, whose [`WorkerQueue::watch`] the daemon runs.
    pub async fn leave_to_workers(&mut self) -> anyhow::Result<Arc<WorkerQueue>> {
        anyhow::ensure!(
            self.mock_world.is_none(),
            "--renders workers cannot be combined with --mock-world: the mock world's scenes are not published to workers"
        );
        let mut scenes = Vec::new();
        for entry in &self.scenes {
            let path = entry.path.clone();
            let collected = tokio::task::spawn_blocking(move || {
                let root = path.parent().unwrap_or(Path::new("."));
                render::bundle::SceneBundle::collect(root, &path)
            })
            .await?
            .map_err(|e| anyhow::anyhow!("scene `{}` cannot be bundled for render workers: {e}", entry.id))?;
            self.store
                .put_scene_bundle(&entry.id, &collected.scene_hash, &collected.bundle)
                .await?;
            scenes.push(PublishedScene {
                id: entry.id.clone(),
                bundle: collected.bundle.hash(),
                scene_hash: collected.scene_hash,
            });
        }
        let config = RenderConfig {
            codings: self.codings.iter().map(|c| c.to_string()).collect(),
            samples: self.samples,
            observer: self.observer,
            scenes,
        };
        self.store
            .set_daemon_role("daemon", Some(&serde_json::to_value(&config)?))
            .await?;
        let queue = Arc::new(WorkerQueue::new(self.store.clone(), self.events.clone()));
        self.workers = Some(Arc::clone(&queue));
        tracing::info!(
            scenes = config.scenes.len(),
            "comparisons, renders and studies are left to render workers"
        );
        Ok(queue)
    }

    /// Starts the one worker that runs queued renders and studies in turn;
    /// it ends after [`Renderer::shutdown`], once the queue is drained.
    pub fn run_jobs(self: &Arc<Self>) -> tokio::task::JoinHandle<()> {
        // Camera images have their own queue and worker (see `images`).
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
        self.shutdown.cancel();
        self.jobs.shutdown();
        self.images.shutdown();
    }

    async fn run_job(self: &Arc<Self>, queued: Queued<Work>) -> anyhow::Result<()> {
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
            Work::Render {
                scene_id,
                scene,
                settings,
            } => self.execute(id, &scene_id, *scene, settings, cancel).await,
            Work::Study {
                paths,
                options,
                measured_first,
            } => self.run_study_job(id, paths, *options, measured_first, cancel).await,
        }
    }

    fn entry(&self, id: &str) -> Option<&SceneEntry> {
        self.scenes.iter().find(|s| s.id == id)
    }

    /// The observer of every XYZ, x,y, CIELAB and ΔE the daemon computes.
    pub fn observer(&self) -> Observer {
        self.observer
    }

    /// The scene file the simulated PR-650 measures for `scene`: the mock
    /// world's of the same id when there is one, else the model.
    fn world_path(&self, entry: &SceneEntry) -> PathBuf {
        crate::study::run::truth_path(self.mock_world.as_deref(), &entry.path)
    }

    /// The converged spectral radiance of a scene target on 1 nm (for the
    /// simulated PR-650: the booth's own solution, see the module doc),
    /// cached on disk by scene content and truth settings.
    pub fn converged_spectrum(&self, scene: &str, target: &str, cache_dir: &Path) -> Result<Spectrum, String> {
        let entry = self.entry(scene).ok_or_else(|| format!("no scene `{scene}`"))?;
        std::fs::create_dir_all(cache_dir).map_err(|e| format!("cache folder {}: {e}", cache_dir.display()))?;
        self.converge_pool.install(|| {
            if jobs::test_panic_requested(scene) {
                jobs::panic_on_the_pool(scene);
            }
            render::converged_target_spectrum(&self.world_path(entry), target, Some(cache_dir))
                .map_err(|e| e.to_string())
        })
    }

    /// After a measurement of a scene target completes: render (or reuse a
    /// render of) the scene and store the comparison, in the background.
    /// `measured` is XYZ with the daemon's observer, `measured_y_se` the
    /// standard error of its Y.
    pub fn compare_later(
        self: &Arc<Self>,
        measurement_id: i64,
        scene: String,
        target: String,
        measured: Xyz,
        measured_y_se: f64,
    ) {
        let this = Arc::clone(self);
        self.runtime.spawn(async move {
            if let Some(workers) = &this.workers {
                match workers
                    .queue_comparison(measurement_id, &scene, &target, measured, measured_y_se)
                    .await
                {
                    Ok(_) => return,
                    // Nothing is lost: the daemon compares it itself.
                    Err(e) => tracing::error!(measurement_id, error = %e, "cannot queue the comparison for the render workers; comparing here"),
                }
            }
            if let Err(e) = this
                .compare(measurement_id, &scene, &target, measured, measured_y_se)
                .await
            {
                tracing::error!(measurement_id, scene, target, error = %e, "comparison failed");
            }
        });
    }

    /// Compares measurement `measurement_id` of `scene`/`target` (XYZ
    /// `measured` with the daemon's observer, `measured_y_se` the standard
    /// error of its Y) with every coding, rendering the scene if no render
    /// of it with the comparison settings is stored, and stores the rows.
    pub(crate) async fn compare(
        &self,
        measurement_id: i64,
        scene: &str,
        target: &str,
        measured: Xyz,
        measured_y_se: f64,
    ) -> anyhow::Result<()> {
        let (render_id, result) = self.render_for_comparison(scene).await?;
        let rendered = rendered_codings(&result, target)
            .ok_or_else(|| anyhow::anyhow!("the render of {scene} has no target {target}"))?;
        let _serial = self.compare_lock.lock().await;
        // The white is the one of the booth this measurement was taken in.
        let booth = self
            .store
            .measurement_booth(measurement_id)
            .await?
            .ok_or_else(|| anyhow::anyhow!("no measurement {measurement_id}"))?;
        let (white, white_source) = self.white_xyz(scene, &booth).await?;
        let observer = self.observer;
        let rows: Vec<NewComparison> = rendered
            .into_iter()
            .map(|(coding, rendered, y_se)| {
                let d = compare_point(measured, rendered, white, observer);
                NewComparison {
                    measurement_id,
                    render_id,
                    scene: scene.to_string(),
                    target: target.to_string(),
                    coding,
                    observer,
                    white_source: white_source.clone(),
                    white: white.to_array(),
                    measured: measured.to_array(),
                    measured_y_se,
                    rendered: rendered.to_array(),
                    rendered_y_se: y_se,
                    y_ratio: d.y_ratio,
                    xy_distance: d.xy_distance,
                    de76: d.de76,
                    de00: d.de00,
                }
            })
            .collect();
        self.store.insert_comparisons(&rows).await?;
        tracing::info!(measurement_id, scene, target, codings = rows.len(), white = %white_source, "comparison stored");
        // This measurement may be the white of this and other scenes: bring
        // every comparison of those scenes to the current white.
        // (Scene files are read on the blocking pool, not the runtime's workers.)
        let candidates: Vec<(String, PathBuf)> = self.scenes.iter().map(|e| (e.id.clone(), e.path.clone())).collect();
        let (this_scene, this_target) = (scene.to_string(), target.to_string());
        let dependent: Vec<String> = tokio::task::spawn_blocking(move || {
            candidates
                .into_iter()
                .filter(|(id, path)| {
                    *id == this_scene
                        || render::load_scene(path)
                            .ok()
                            .and_then(|s| scene_white(path, &s, observer).ok())
                            .is_some_and(|w| w.is_target(&this_scene, &this_target))
                })
                .map(|(id, _)| id)
                .collect()
        })
        .await?;
        for other in dependent {
            self.refresh_white(&other, &booth).await?;
        }
        let _ = self.events.send(Event::ComparisonReady {
            measurement_id,
            scene: scene.to_string(),
            target: target.to_string(),
        });
        Ok(())
    }

    /// Recomputes every comparison of `scene` in `booth` (of the daemon's
    /// observer) whose white is not the booth's current one for the scene:
    /// ΔE from the stored XYZ with the current white. Other booths'
    /// comparisons keep their own booth's white. The caller holds
    /// `compare_lock`.
    async fn refresh_white(&self, scene: &str, booth: &Booth) -> anyhow::Result<()> {
        let (white, source) = self.white_xyz(scene, booth).await?;
        let updates: Vec<(i64, String, [f64; 3], f64, f64)> = self
            .store
            .comparisons_of_scene_in_booth(scene, booth)
            .await?
            .into_iter()
            .filter(|r| r.observer == self.observer)
            .filter(|r| r.white_source != source || [r.white_X, r.white_Y, r.white_Z] != white.to_array())
            .map(|r| {
                let m = Lab::from_xyz(Xyz::new(r.measured_X, r.measured_Y, r.measured_Z), white);
                let q = Lab::from_xyz(Xyz::new(r.rendered_X, r.rendered_Y, r.rendered_Z), white);
                let (de76, de00) = delta_e_pair(m, q);
                (r.id, source.clone(), white.to_array(), de76, de00)
            })
            .collect();
        if !updates.is_empty() {
            self.store.update_comparison_whites(&updates).await?;
            tracing::info!(scene, %booth, rows = updates.len(), white = %source, "comparisons recomputed with the scene's current white");
        }
        Ok(())
    }

    /// The CIELAB white of `scene` in `booth` now, and where it came from
    /// (see the module doc): a white target's newest complete measurement
    /// taken in that booth, never another booth's.
    async fn white_xyz(&self, scene: &str, booth: &Booth) -> anyhow::Result<(Xyz, String)> {
        let entry = self.entry(scene).ok_or_else(|| anyhow::anyhow!("no scene `{scene}`"))?;
        let (loaded, _) = load_scene_blocking(entry.path.clone()).await?;
        let (white_scene, target) =
            match scene_white(&entry.path, &loaded, self.observer).map_err(anyhow::Error::msg)? {
                SceneWhite::Fixed { xyz, source } => return Ok((xyz, source)),
                SceneWhite::Target { scene_id, target, .. } => (scene_id, target),
            };
        if let Some(m) = self
            .store
            .latest_complete_in_booth(&white_scene, &target, booth)
            .await?
        {
            if let (Some(wl), Some(radiance)) = (m.wavelength_nm, m.radiance) {
                let s = Spectrum::new(Grid::from_wavelengths(wl)?, SpectralUnit::SpectralRadiance, radiance)?;
                let xyz = xyz_from_radiance(&s, self.observer)?;
                return Ok((xyz, format!("measurement {} ({white_scene}/{target})", m.summary.id)));
            }
        }
        let (render_id, result) = self.render_for_comparison(&white_scene).await?;
        let (_, xyz, _) = rendered_codings(&result, &target)
            .and_then(|codings| codings.into_iter().find(|(c, _, _)| c == "spectral"))
            .ok_or_else(|| anyhow::anyhow!("no spectral rendering of the white {white_scene}/{target}"))?;
        Ok((
            xyz,
            format!("render {render_id} spectral ({white_scene}/{target}; not yet measured)"),
        ))
    }

    /// The settings of a render request, each field checked against its
    /// limit (400 naming the field and the limit).
    fn settings(&self, request: &RenderRequest) -> Result<RenderSettings, LabError> {
        let codings = match &request.codings {
            Some(list) => {
                let codings = list
                    .split(',')
                    .map(|c| c.parse::<Coding>())
                    .collect::<Result<Vec<_>, _>>()
                    .map_err(|e| LabError::Invalid(format!("field `codings`: {e}")))?;
                for (i, c) in codings.iter().enumerate() {
                    if codings[..i].contains(c) {
                        return Err(LabError::Invalid(format!("field `codings`: `{c}` is named twice")));
                    }
                }
                codings
            }
            None => {
                let mut c = self.codings.clone();
                // The comparison white may come from the spectral rendering.
                if !c.contains(&Coding::Spectral) {
                    c.push(Coding::Spectral);
                }
                c
            }
        };
        let mut s = RenderSettings {
            codings,
            samples: self.samples,
            observer: self.observer,
            ..RenderSettings::default()
        };
        if let Some(n) = request.samples {
            if !(2..=MAX_RENDER_SAMPLES).contains(&n) {
                return Err(LabError::Invalid(format!(
                    "field `samples`: {n} is outside 2–{MAX_RENDER_SAMPLES} (paths per target)"
                )));
            }
            s.samples = u64::from(n);
        }
        if let Some(b) = request.bounces {
            if b > MAX_RENDER_BOUNCES {
                return Err(LabError::Invalid(format!(
                    "field `bounces`: {b} is above the limit {MAX_RENDER_BOUNCES}"
                )));
            }
            // A cap (RADIANCE -ab); absent: none, Russian roulette (unbiased).
            s.max_bounces = Some(b);
        }
        if let Some(seed) = request.seed {
            s.seed = seed;
        }
        Ok(s)
    }

    /// The render comparisons use: reused when the store has one of the same
    /// scene content and settings, rendered (once, even under concurrent
    /// requests) otherwise. Returns the render id and its stored JSON result.
    async fn render_for_comparison(&self, scene: &str) -> anyhow::Result<(i64, serde_json::Value)> {
        let lock = {
            let mut locks = self.scene_locks.lock().unwrap_or_else(|p| p.into_inner());
            Arc::clone(locks.entry(scene.to_string()).or_default())
        };
        let _guard = lock.lock().await;
        let settings = self.settings(&RenderRequest::default())?;
        let entry = self.entry(scene).ok_or_else(|| anyhow::anyhow!("no scene `{scene}`"))?;
        let (loaded, hash) = load_scene_blocking(entry.path.clone()).await?;
        let settings_json = serde_json::to_value(&settings)?;
        loop {
            if let Some(found) = self.store.find_render_result(&hash, &settings_json).await? {
                return Ok(found);
            }
            // Another process (a render worker, a neighbour daemon) is
            // rendering exactly this: wait for it rather than render twice.
            // A running render always ends — done, failed, or interrupted
            // by lease recovery when its process is gone.
            match self.store.running_render_of(&hash, &settings_json).await? {
                Some(other) if !self.shutdown.is_cancelled() => {
                    tracing::debug!(
                        render_id = other,
                        scene,
                        "waiting for the same render running elsewhere"
                    );
                    tokio::time::sleep(std::time::Duration::from_millis(200)).await;
                }
                _ => break,
            }
        }
        let id = self.record(scene, &settings, hash).await?;
        self.execute(id, scene, loaded, settings, self.shutdown.clone()).await?;
        let row = self
            .store
            .get_render(id)
            .await?
            .ok_or_else(|| anyhow::anyhow!("render {id} vanished"))?;
        let result = row
            .result
            .ok_or_else(|| anyhow::anyhow!("render {id} failed: {}", row.error.unwrap_or_default()))?;
        Ok((id, result))
    }

    /// Records a render as queued, after storing its scene's bundle
    /// ([`Renderer::store_bundle`]); returns its id.
    async fn record(&self, scene_id: &str, settings: &RenderSettings, hash: String) -> anyhow::Result<i64> {
        self.store_bundle(scene_id, &hash).await;
        let id = self
            .store
            .create_render(&NewRender {
                scene: scene_id.to_string(),
                scene_hash: hash,
                settings_json: serde_json::to_value(settings)?,
                codings: settings.codings.iter().map(|c| c.to_string()).collect(),
                seed: settings.seed,
            })
            .await?;
        tracing::info!(render_id = id, scene = scene_id, "render queued");
        Ok(id)
    }

    /// Stores the bundle of the scene `scene_id` (its files, for render
    /// workers without the scenes folder; [`render::bundle`]) unless the
    /// store has it. A scene that cannot be bundled (a reference outside
    /// the scenes folder) or whose files changed since `hash` was taken is
    /// logged and still rendered here: the daemon needs no bundle itself.
    async fn store_bundle(&self, scene_id: &str, hash: &str) {
        let Some(path) = self.entry(scene_id).map(|e| e.path.clone()) else {
            return;
        };
        let collected = tokio::task::spawn_blocking(move || {
            let root = path.parent().unwrap_or(Path::new("."));
            render::bundle::SceneBundle::collect(root, &path).map_err(|e| e.to_string())
        })
        .await
        .map_err(|e| e.to_string())
        .and_then(|r| r);
        let stored = match collected {
            Ok(c) if c.scene_hash != hash => Err(format!(
                "its files changed while it was loaded (render key {hash}, bundle's {})",
                c.scene_hash
            )),
            Ok(c) => self
                .store
                .put_scene_bundle(scene_id, hash, &c.bundle)
                .await
                .map(|_| ())
                .map_err(|e| e.to_string()),
            Err(e) => Err(e),
        };
        if let Err(e) = stored {
            tracing::warn!(scene = scene_id, error = %e, "scene bundle not stored; render workers cannot render this scene");
        }
    }

    /// Runs a recorded render on the rayon pool with progress events, then
    /// times each coding alone (same settings) for the speed-against-accuracy
    /// chart (`coding_seconds` in the stored result), and stores the outcome.
    /// `cancel` stops it between batches of paths; a panic fails it with
    /// the panic's message (a panic on a `rayon::spawn` job would abort the
    /// whole daemon).
    async fn execute(
        &self,
        id: i64,
        scene_id: &str,
        scene: Scene,
        settings: RenderSettings,
        cancel: CancelFlag,
    ) -> anyhow::Result<()> {
        if !self.store.start_job(Job::Render, id).await? {
            tracing::info!(render_id = id, "render no longer queued (cancelled); not run");
            return Ok(());
        }
        let _ = self.events.send(Event::RenderStarted {
            render_id: id,
            scene: scene_id.to_string(),
        });
        tracing::info!(render_id = id, scene = scene_id, "render started");
        let events = self.events.clone();
        let (tx, rx) = tokio::sync::oneshot::channel();
        let flag = cancel.clone();
        let panic_scene = jobs::test_panic_requested(scene_id).then(|| scene_id.to_string());
        rayon::spawn(move || {
            let caught = catch_unwind(AssertUnwindSafe(|| {
                with_cancel(&flag, || {
                    if let Some(scene) = &panic_scene {
                        jobs::panic_on_the_pool(scene);
                    }
                    render_with_timings(id, &scene, &settings, &events).and_then(|done| {
                        // Cancelled while the codings were timed: the timings are incomplete.
                        if flag.is_cancelled() {
                            Err(RenderError::Cancelled)
                        } else {
                            Ok(done)
                        }
                    })
                })
            }))
            .map_err(|panic| format!("the renderer panicked: {}", jobs::panic_message(&*panic)));
            let _ = tx.send(caught);
        });
        let outcome = match rx.await? {
            Ok(outcome) => outcome.map_err(|e| match e {
                RenderError::Cancelled => None,
                other => Some(other.to_string()),
            }),
            Err(panic) => Err(Some(panic)),
        };
        let (ok, error) = match outcome {
            Ok((result, (coding_seconds, coding_cost), preview)) => {
                let mut json = serde_json::to_value(&result)?;
                json["coding_seconds"] = serde_json::Value::Object(coding_seconds);
                json["coding_cost"] = serde_json::Value::Object(coding_cost);
                json["cost_definition"] = COST_DEFINITION.into();
                if let Some(png) = preview {
                    self.store.set_render_preview(id, &png).await?;
                }
                self.store.finish_render(id, Ok((&json, result.wall_seconds))).await?;
                tracing::info!(render_id = id, wall_seconds = result.wall_seconds, "render complete");
                (true, None)
            }
            Err(error) => {
                let (end, message) = self.jobs.end_of(Job::Render, error.is_none(), error);
                self.store.end_job(Job::Render, id, end, &message).await?;
                tracing::warn!(render_id = id, state = end.as_str(), error = %message, "render did not complete");
                (false, Some(message))
            }
        };
        let _ = self.events.send(Event::RenderFinished {
            render_id: id,
            scene: scene_id.into(),
            ok,
            error,
        });
        Ok(())
    }
}

/// What a render job stores: the result, each coding's time alone, and the preview PNG.
type RenderOutput = (
    render::RenderResult,
    (
        serde_json::Map<String, serde_json::Value>,
        serde_json::Map<String, serde_json::Value>,
    ),
    Option<Vec<u8>>,
);

/// A render with progress events, then each coding timed alone (same
/// settings) and the camera preview. Runs on the rayon pool.
fn render_with_timings(
    id: i64,
    scene: &Scene,
    settings: &RenderSettings,
    events: &broadcast::Sender<Event>,
) -> Result<RenderOutput, RenderError> {
    let last = std::sync::Mutex::new(Instant::now());
    let progress = |done: u64, total: u64| {
        let mut last = last.lock().unwrap_or_else(|p| p.into_inner());
        if last.elapsed().as_millis() >= 200 || done == total {
            *last = Instant::now();
            let _ = events.send(Event::RenderProgress {
                render_id: id,
                done,
                total,
            });
        }
    };
    render::render(scene, settings, Some(&progress)).map(|full| {
        // Every coding alone at a fixed number of paths per target (no
        // adaptive stop): equal work, comparable costs; timed in rotated
        // rounds after a warm-up (`render::cost`), so the first-timed coding
        // does not pay the warm-up.
        let mut coding_seconds = serde_json::Map::new();
        let mut coding_cost = serde_json::Map::new();
        let alone: Vec<RenderSettings> = settings
            .codings
            .iter()
            .map(|coding| RenderSettings {
                codings: vec![*coding],
                target_relative_se: None,
                ..settings.clone()
            })
            .collect();
        match render::cost::time_renders(scene, &alone, render::cost::TIMING_REPEATS) {
            Ok(timed) => {
                for (coding, t) in settings.codings.iter().zip(&timed) {
                    coding_seconds.insert(coding.to_string(), t.median_seconds().into());
                    coding_cost.insert(coding.to_string(), t.cost_json());
                }
            }
            Err(e) => tracing::warn!(render_id = id, error = %e, "codings not timed"),
        }
        // The camera view for the dashboard: the sRGB coding, few paths per
        // pixel from a fixed budget (a preview, not a measurement).
        let preview = scene.camera.as_ref().and_then(|camera| {
            let transport = settings.transport();
            render::sensor::render_camera(
                scene,
                camera,
                Coding::Srgb,
                render::sensor::preview_spp(camera),
                &transport,
                settings.seed,
            )
            .and_then(|img| img.png())
            .map_err(|e| tracing::warn!(render_id = id, error = %e, "no preview image"))
            .ok()
        });
        (full, (coding_seconds, coding_cost), preview)
    })
}

/// Every coding's XYZ and standard error of Y at `target` in a stored render result.
fn rendered_codings(result: &serde_json::Value, target: &str) -> Option<Vec<(String, Xyz, f64)>> {
    let t = result
        .get("targets")?
        .as_array()?
        .iter()
        .find(|t| t.get("id").and_then(|i| i.as_str()) == Some(target))?;
    let codings = t.get("codings")?.as_object()?;
    codings
        .iter()
        .map(|(name, c)| {
            let xyz: [f64; 3] = serde_json::from_value(c.get("XYZ")?.clone()).ok()?;
            Some((name.clone(), Xyz::from_array(xyz), c.get("Y_se")?.as_f64()?))
        })
        .collect()
}

impl Renderer {
    /// The study options of an API request, checked field by field.
    fn study_plan(&self, request: &StudyRequest) -> Result<(Vec<PathBuf>, StudyOptions), LabError> {
        let paths = match &request.scenes {
            None => self.scenes.iter().map(|s| s.path.clone()).collect(),
            Some(list) => list
                .split(',')
                .map(str::trim)
                .filter(|s| !s.is_empty())
                .map(|id| {
                    self.entry(id).map(|e| e.path.clone()).ok_or_else(|| {
                        let names: Vec<&str> = self.scenes.iter().map(|s| s.id.as_str()).collect();
                        LabError::Invalid(format!(
                            "field `scenes`: no scene `{id}`; available: {}",
                            names.join(", ")
                        ))
                    })
                })
                .collect::<Result<Vec<_>, _>>()?,
        };
        if paths.is_empty() {
            return Err(LabError::Invalid("field `scenes`: name at least one scene".into()));
        }
        let against = match request.against.as_deref().unwrap_or("measurements") {
            "measurements" => Against::Measurements,
            "reference" => Against::Reference,
            other => {
                return Err(LabError::Invalid(format!(
                    "field `against`: `{other}` is neither `measurements` nor `reference`"
                )))
            }
        };
        let seeds = request.seeds.unwrap_or(8);
        if !(1..=64).contains(&seeds) {
            return Err(LabError::Invalid(format!("field `seeds`: {seeds} is outside 1–64")));
        }
        let failure_map = request.failure_map.unwrap_or(false);
        if failure_map && !paths.iter().any(|p| p.file_stem().is_some_and(|s| s == "cylinder")) {
            return Err(LabError::Invalid(
                "field `failure_map`: the failure maps need the `cylinder` scene".into(),
            ));
        }
        let auto = request
            .auto
            .as_deref()
            .filter(|t| !t.trim().is_empty())
            .map(|t| t.parse::<crate::study::auto::Tolerance>())
            .transpose()
            .map_err(|e| LabError::Invalid(format!("field `auto`: {e}")))?;
        let options = StudyOptions {
            auto,
            codings: self.codings.clone(),
            seeds,
            against,
            sweeps: request.sweeps.unwrap_or(false),
            failure_map,
            observer: self.observer,
            truth_scene: self.mock_world.clone(),
            ..StudyOptions::default()
        };
        Ok((paths, options))
    }
}

impl Renderer {
    /// Runs a queued study on a blocking thread (its renders use the rayon
    /// pool; never the async workers) under its cancellation flag, with
    /// panics caught, and records how it ended.
    async fn run_study_job(
        self: &Arc<Self>,
        id: i64,
        paths: Vec<PathBuf>,
        options: StudyOptions,
        measured_first: Vec<i64>,
        cancel: CancelFlag,
    ) -> anyhow::Result<()> {
        if !self.store.start_job(Job::Study, id).await? {
            tracing::info!(study_id = id, "study no longer queued (cancelled); not run");
            return Ok(());
        }
        tracing::info!(study_id = id, scenes = paths.len(), "study started");
        // `measure_missing`: the measurements queued for it come first.
        if !measured_first.is_empty() {
            let events = self.events.clone();
            let progress = move |message: &str| {
                let _ = events.send(Event::StudyProgress {
                    study_id: id,
                    message: message.to_string(),
                });
            };
            if let Err(e) = wait_for_measurements(&self.store, &measured_first, &progress).await {
                self.store.end_job(Job::Study, id, JobEnd::Failed, &e).await?;
                tracing::warn!(study_id = id, error = %e, "study did not complete");
                let _ = self.events.send(Event::StudyFinished {
                    study_id: id,
                    ok: false,
                    error: Some(e),
                });
                return Ok(());
            }
        }
        let this = Arc::clone(self);
        let flag = cancel.clone();
        let outcome = tokio::task::spawn_blocking(move || {
            catch_unwind(AssertUnwindSafe(|| {
                with_cancel(&flag, || {
                    for p in &paths {
                        if let Some(scene) = p.file_stem().and_then(|s| s.to_str()) {
                            if jobs::test_panic_requested(scene) {
                                jobs::panic_on_the_pool(scene);
                            }
                        }
                    }
                    let events = this.events.clone();
                    let progress = move |message: &str| {
                        let _ = events.send(Event::StudyProgress {
                            study_id: id,
                            message: message.to_string(),
                        });
                    };
                    this.runtime
                        .block_on(run_study(&paths, &options, Some(&this.store), &progress))
                        .map_err(|e| e.to_string())
                        .and_then(|result| {
                            let files = report_files(&result).map_err(|e| e.to_string())?;
                            let json = serde_json::to_value(&result).map_err(|e| e.to_string())?;
                            Ok((json, result.wall_seconds, files))
                        })
                })
            }))
            .map_err(|panic| format!("the study panicked: {}", jobs::panic_message(&*panic)))
        })
        .await?;
        let outcome = match outcome {
            Ok(Ok((json, wall_seconds, files))) if !cancel.is_cancelled() => {
                match self.store.complete_study(id, &json, wall_seconds, &files).await {
                    Ok(()) => Ok(()),
                    Err(e) => Err(Some(e.to_string())),
                }
            }
            Ok(Ok(_)) => Err(None),
            // A render stopped by the flag fails the study with its error.
            Ok(Err(_)) if cancel.is_cancelled() => Err(None),
            Ok(Err(e)) | Err(e) => Err(Some(e)),
        };
        let error = match outcome {
            Ok(()) => {
                tracing::info!(study_id = id, "study complete");
                None
            }
            Err(error) => {
                let (end, message) = self.jobs.end_of(Job::Study, error.is_none(), error);
                self.store.end_job(Job::Study, id, end, &message).await?;
                tracing::warn!(study_id = id, state = end.as_str(), error = %message, "study did not complete");
                Some(message)
            }
        };
        let _ = self.events.send(Event::StudyFinished {
            study_id: id,
            ok: error.is_none(),
            error,
        });
        Ok(())
    }

    /// Queues a render of a scene (validated settings, the scene file read
    /// off the async workers).
    async fn queue_render(&self, scene: String, settings: RenderSettings) -> Result<i64, LabError> {
        let path = self
            .entry(&scene)
            .map(|e| e.path.clone())
            .ok_or_else(|| LabError::NotFound(format!("no scene `{scene}`")))?;
        let (loaded, hash) = load_scene_blocking(path)
            .await
            .map_err(|e| LabError::Internal(e.to_string()))?;
        if let Some(workers) = &self.workers {
            self.check_worker_share().await?;
            let id = self
                .record(&scene, &settings, hash)
                .await
                .map_err(|e| LabError::Internal(e.to_string()))?;
            self.hand_to_workers(workers, Job::Render, id, &scene).await?;
            return Ok(id);
        }
        let create = async {
            self.record(&scene, &settings, hash)
                .await
                .map_err(|e| LabError::Internal(e.to_string()))
        };
        let work = Work::Render {
            scene_id: scene.clone(),
            scene: Box::new(loaded),
            settings: settings.clone(),
        };
        // The caller polls /api/renders/{id} or follows the events.
        self.jobs.enqueue(Job::Render, create, work).await
    }

    /// Queues a study (its request checked field by field).
    async fn queue_study(&self, request: StudyRequest) -> Result<i64, LabError> {
        let (paths, options) = self.study_plan(&request)?;
        let create = async {
            self.store
                .create_study(&serde_json::to_value(&request).unwrap_or_default())
                .await
                .map_err(LabError::from)
        };
        if let Some(workers) = &self.workers {
            self.check_worker_share().await?;
            let id = create.await?;
            self.hand_to_workers(workers, Job::Study, id, "").await?;
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

    /// 409 when this daemon already has [`jobs::JOB_QUEUE_CAPACITY`] renders
    /// and studies waiting for or running on workers: its share of the
    /// shared queue is bounded as its own queue is.
    async fn check_worker_share(&self) -> Result<(), LabError> {
        let waiting = self.store.unfinished_worker_jobs_requested().await?;
        if waiting >= jobs::JOB_QUEUE_CAPACITY as i64 {
            return Err(LabError::Conflict(format!(
                "the render queue is full: {waiting} renders and studies of this daemon are waiting for \
                 or running on render workers; wait for one to finish (GET /api/renders, /api/studies)"
            )));
        }
        Ok(())
    }

    /// Queues a recorded render or study row for the workers; if that fails
    /// the row is failed with the reason (it would never run otherwise).
    async fn hand_to_workers(&self, workers: &WorkerQueue, job: Job, id: i64, scene: &str) -> Result<(), LabError> {
        let kind = match job {
            Job::Render => WorkerJobKind::Render,
            Job::Study => WorkerJobKind::Study,
        };
        if let Err(e) = workers.queue_row(kind, id, scene).await {
            let why = format!("cannot queue this {} for the render workers: {e}", job.noun());
            self.store.end_job(job, id, JobEnd::Failed, &why).await?;
            return Err(LabError::Internal(why));
        }
        Ok(())
    }

    /// Cancels a render or study left to the workers: a queued one ends at
    /// once, a running one is flagged for its worker. False when no worker
    /// job has it (it runs here).
    async fn cancel_on_workers(&self, job: Job, id: i64) -> Result<bool, LabError> {
        let kind = match job {
            Job::Render => WorkerJobKind::Render,
            Job::Study => WorkerJobKind::Study,
        };
        match self.store.cancel_worker_job(kind, id).await? {
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

    /// A new job with the request of an ended one (see the [jobs](super::jobs) doc).
    async fn retry_job(&self, job: Job, id: i64) -> Result<i64, LabError> {
        let noun = job.noun();
        let not_found = || LabError::NotFound(format!("no {noun} {id}"));
        let retryable = |state: &str| -> Result<(), LabError> {
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
                let new = self.queue_render(row.scene.clone(), settings).await?;
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
                let new = self.queue_study(request).await?;
                tracing::info!(study_id = new, retry_of = id, "study retried");
                Ok(new)
            }
        }
    }
}

impl RenderService for Renderer {
    fn scenes(&self) -> Vec<SceneInfo> {
        self.scenes
            .iter()
            .map(|s| SceneInfo {
                id: s.id.clone(),
                title: s.title.clone(),
                targets: s.targets.clone(),
            })
            .collect()
    }

    fn start_render(self: Arc<Self>, scene: String, request: RenderRequest) -> BoxFuture<Result<i64, LabError>> {
        Box::pin(async move {
            if self.entry(&scene).is_none() {
                return Err(LabError::NotFound(format!("no scene `{scene}`")));
            }
            let settings = self.settings(&request)?;
            self.queue_render(scene, settings).await
        })
    }

    fn check_study(&self, request: &StudyRequest) -> Result<(), LabError> {
        self.study_plan(request).map(|_| ())
    }

    fn start_study(self: Arc<Self>, request: StudyRequest) -> BoxFuture<Result<i64, LabError>> {
        Box::pin(async move { self.queue_study(request).await })
    }

    fn cancel(self: Arc<Self>, job: Job, id: i64) -> BoxFuture<Result<(), LabError>> {
        Box::pin(async move {
            if self.workers.is_some() && self.cancel_on_workers(job, id).await? {
                return Ok(());
            }
            self.jobs.cancel(job, id).await
        })
    }

    fn retry(self: Arc<Self>, job: Job, id: i64) -> BoxFuture<Result<i64, LabError>> {
        Box::pin(async move { self.retry_job(job, id).await })
    }

    fn start_image(self: Arc<Self>, render_id: i64, request: ImageRequest) -> BoxFuture<Result<(i64, bool), LabError>> {
        Box::pin(async move { self.queue_image(render_id, request).await })
    }

    fn images(&self) -> Option<&ImageJobs> {
        Some(&self.images)
    }

    fn cielab_white(self: Arc<Self>, scene: String, booth: Booth) -> BoxFuture<Result<(Xyz, String), LabError>> {
        Box::pin(async move {
            self.white_xyz(&scene, &booth)
                .await
                .map_err(|e| LabError::Internal(format!("the CIELAB white of `{scene}`: {e}")))
        })
    }
}

impl Renderer {
    /// Queues a camera image of a render (see [`super::images`]): the
    /// render's scene, which must not have changed since, with the render's
    /// transport and seed; the request checked against the limits first.
    async fn queue_image(&self, render_id: i64, request: ImageRequest) -> Result<(i64, bool), LabError> {
        let row = self
            .store
            .get_render(render_id)
            .await?
            .ok_or_else(|| LabError::NotFound(format!("no render {render_id}")))?;
        let settings: RenderSettings = serde_json::from_value(row.settings.clone())
            .map_err(|e| LabError::Internal(format!("render {render_id}'s stored settings: {e}")))?;
        let entry = self
            .entry(&row.scene)
            .ok_or_else(|| LabError::NotFound(format!("render {render_id}'s scene `{}` is gone", row.scene)))?;
        let (scene, hash) = load_scene_blocking(entry.path.clone())
            .await
            .map_err(|e| LabError::Internal(e.to_string()))?;
        if hash != row.scene_hash {
            return Err(LabError::Conflict(format!(
                "the scene file of `{}` changed since render {render_id}: render the scene again, then ask for its images",
                row.scene
            )));
        }
        let camera = scene
            .camera
            .clone()
            .ok_or_else(|| LabError::Conflict(format!("scene `{}` has no [camera]: no image to render", row.scene)))?;
        let transport = settings.transport();
        let (checked, coding) = camera_images::check_request(&request, &camera, &transport, settings.seed)?;
        let (scaled, camera_settings) = camera_images::camera_settings(&checked, coding, &camera, self.observer);
        self.images
            .enqueue(render_id, &row.scene, self.observer, checked, |id| ImageWork {
                id,
                scene: Box::new(scene),
                camera: scaled,
                settings: camera_settings,
            })
    }
}

/// Loads a scene file and hashes its content on the blocking pool, so file
/// reads never hold up the async runtime's workers.
async fn load_scene_blocking(path: PathBuf) -> Result<(Scene, String), RenderError> {
    tokio::task::spawn_blocking(move || {
        let loaded = render::load_scene(&path)?;
        let hash = render::scene_hash(&loaded)?;
        Ok((loaded, hash))
    })
    .await
    .map_err(|e| RenderError::Io(format!("loading a scene: {e}")))?
}

/// The render worker's entry points ([`crate::worker`]): a render or study
/// row another daemon recorded, run here with that daemon's configuration.
impl Renderer {
    /// Runs the queued render row `id` under `cancel`. Its scene must be the
    /// content the row was recorded for (same render key).
    pub(crate) async fn run_render_row(&self, id: i64, cancel: CancelFlag) -> anyhow::Result<()> {
        let row = self
            .store
            .get_render(id)
            .await?
            .ok_or_else(|| anyhow::anyhow!("no render {id}"))?;
        let settings: RenderSettings = serde_json::from_value(row.settings.clone())
            .map_err(|e| anyhow::anyhow!("render {id}'s stored settings: {e}"))?;
        let entry = self
            .entry(&row.scene)
            .ok_or_else(|| anyhow::anyhow!("render {id}'s scene `{}` is not among its daemon's scenes", row.scene))?;
        let (scene, hash) = load_scene_blocking(entry.path.clone()).await?;
        if hash != row.scene_hash {
            let why = format!(
                "the scene `{}` this worker fetched has render key {hash}, not the render's {}: \
                 its daemon's scene files changed since; render it again",
                row.scene, row.scene_hash
            );
            self.store.end_job(Job::Render, id, JobEnd::Failed, &why).await?;
            anyhow::bail!(why);
        }
        self.execute(id, &row.scene, scene, settings, cancel).await
    }

    /// Runs the queued study row `id` under `cancel`, from its stored
    /// request (and the measurements its daemon queued for it first).
    pub(crate) async fn run_study_row(self: &Arc<Self>, id: i64, cancel: CancelFlag) -> anyhow::Result<()> {
        let row = self
            .store
            .get_study(id)
            .await?
            .ok_or_else(|| anyhow::anyhow!("no study {id}"))?;
        let measured_first: Vec<i64> = row
            .request
            .get("measured_first")
            .and_then(|m| serde_json::from_value(m.clone()).ok())
            .unwrap_or_default();
        let request: StudyRequest = serde_json::from_value(row.request.clone())
            .map_err(|e| anyhow::anyhow!("study {id}'s stored request: {e}"))?;
        let (paths, options) = match self.study_plan(&request) {
            Ok(plan) => plan,
            Err(e) => {
                let why = format!("study {id}'s request on this worker: {e}");
                self.store.end_job(Job::Study, id, JobEnd::Failed, &why).await?;
                anyhow::bail!(why);
            }
        };
        self.run_study_job(id, paths, options, measured_first, cancel).await
    }
}
