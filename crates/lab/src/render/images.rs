//! Camera images of a render, as the daemon runs them: the scene's camera
//! view rendered by the measuring camera ([`lightbooth_render::camera`]) in one
//! coding or several, with every channel's mean and standard error plus XYZ
//! and LMS, for the dashboard's image viewer and for downloads.
//!
//! - A request names one `coding` or a list of `codings`: a list is one job
//!   that renders every coding **from the same paths** (a *set*), each
//!   coding an image with its own id, the last (or `reference`) the one the
//!   others are compared with. Their ΔE00 map then carries the paired
//!   difference's own noise ([`ImageRef::set`], `compare::image_map`).
//!
//! - An image belongs to a render: it uses the render's scene (the file
//!   must still hash to the render's `scene_hash`, else 409), its bounces,
//!   Russian roulette and seed, and the daemon's observer.
//! - Requests are bounded before any work: `width` up to the scene's
//!   camera width (height follows the camera's aspect; default
//!   [`DEFAULT_WIDTH`] px wide, small so an image takes seconds), `max_spp`
//!   up to [`MAX_IMAGE_SPP`], and the work width × height × max_spp ×
//!   quantities (the coding's channels + X, Y, Z, L, M, S) at most
//!   [`MAX_IMAGE_WORK`]; the time budget at most [`MAX_TIME_BUDGET_S`].
//!   A request beyond a limit is refused with 400 naming the field and the
//!   limit, and leaves nothing behind.
//! - At most [`IMAGE_QUEUE_CAPACITY`] images wait (more answer 409); one
//!   worker renders them in turn on the global rayon pool, each under its
//!   own [`CancellationToken`] (`POST /api/images/{id}/cancel`; shutdown cancels
//!   them) and inside `catch_unwind`, with an `image_progress` event after
//!   every pass and `image_finished` at the end.
//! - One image per (render, request): asking again for the same render
//!   and settings returns the image already queued, running or complete.
//! - Images are kept in memory, not in the database: the `f32` means and
//!   squared deviations of the newest complete images up to
//!   [`MAX_KEPT_BYTES`] in all (the oldest are forgotten first); a restart
//!   forgets them all. They are cheap to render again and large to store
//!   (a spectral image holds 401 + 6 quantities per pixel).
//! - Ids never repeat across restarts: an image's id is its daemon run's
//!   number (the daemon's lease id, stored in `daemons` and new at every
//!   start) × [`IDS_PER_RUN`] + its number in that run, so an id a script
//!   or the viewer still holds after a restart answers 404 saying the
//!   image was lost with the restart, and never points at another image.

use std::collections::BTreeMap;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use serde::{Deserialize, Serialize};
use tokio::sync::mpsc;

use super::image_views::{self, Probe};
use crate::download::{Download, FileFormat};
use crate::error::LabError;
use crate::events::{Event, EventSink};
use crate::jobs;
use lightbooth_render::camera::{
    render_camera_images, CameraImage, CameraImages, CameraProgress, CameraSettings, StopReason,
};
use lightbooth_render::integrator::Transport;
use lightbooth_render::scene::Camera;
use lightbooth_render::{Coding, RenderError, Scene};
use lightbooth_science::colorimetry::Observer;
use tokio_util::sync::CancellationToken;

/// Image width (pixels) when a request does not say: the scene camera's
/// aspect kept, 96 px wide (or the camera's width when smaller).
pub const DEFAULT_WIDTH: u32 = 96;
/// Paths per pixel at most when a request does not say, and at least per pass.
pub const DEFAULT_MAX_SPP: u32 = 32;
pub const DEFAULT_MIN_SPP: u32 = 8;
/// Paths per pixel a request may ask for.
pub const MAX_IMAGE_SPP: u32 = 65_536;
/// Width × height × max_spp × quantities per pixel a request may ask for
/// (2²⁸: a 96 × 72 spectral image at 32 paths per pixel is 9 × 10⁷).
pub const MAX_IMAGE_WORK: u64 = 1 << 28;
/// Seconds of time budget a request may ask for (and the default).
pub const MAX_TIME_BUDGET_S: f64 = 600.0;
/// Images that may wait for the worker; more get 409.
pub const IMAGE_QUEUE_CAPACITY: usize = 4;
/// Bytes of complete images kept in memory, in all.
pub const MAX_KEPT_BYTES: u64 = 1 << 30;
/// Image ids one daemon run may hand out: run r's ids are r × this + 1, + 2,
/// … (runs up to 9 × 10⁶ keep ids below 2⁵³, exact in JavaScript and MATLAB).
pub const IDS_PER_RUN: i64 = 1_000_000_000;

/// What to render: `POST /api/renders/{id}/images`.
#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(deny_unknown_fields)]
pub struct ImageRequest {
    /// `rgb`, `srgb`, `nstepN` or `spectral` (or give `codings`).
    pub coding: Option<String>,
    /// Several codings rendered from the same paths, an image each (up to
    /// [`MAX_SET_CODINGS`], no coding twice); give this or `coding`.
    pub codings: Option<Vec<String>>,
    /// The coding of `codings` the others are compared with, and whose
    /// SE(Y) stops a pixel; default the last.
    pub reference: Option<String>,
    /// Stop a pixel only when every coding's SE(Y) meets
    /// `target_relative_se`, not only the reference's (default false).
    pub se_every_coding: Option<bool>,
    /// Pixels across, 8 up to the scene camera's width (height keeps the
    /// camera's aspect); default 96 (or the camera's width when smaller).
    pub width: Option<u32>,
    /// Paths per pixel before a pixel may stop, and per pass (default 8).
    pub min_spp: Option<u32>,
    /// Paths per pixel at most, up to 65536 (default 32).
    pub max_spp: Option<u32>,
    /// Stop a pixel when SE(Y)/Y is below this (0 < t ≤ 1); default: every
    /// pixel gets `max_spp`.
    pub target_relative_se: Option<f64>,
    /// Stop starting passes after this many seconds (0 < t ≤ 600, default 600).
    pub time_budget_s: Option<f64>,
}

/// A request with every default filled in and checked: what keys reuse.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ImageSettings {
    /// This image's coding.
    pub coding: String,
    /// Every coding rendered from the same paths as this one (this one
    /// included), in the request's order, and their reference.
    pub codings: Vec<String>,
    pub reference: String,
    pub se_every_coding: bool,
    pub width: u32,
    pub height: u32,
    pub min_spp: u32,
    pub max_spp: u32,
    pub target_relative_se: Option<f64>,
    pub time_budget_s: f64,
    /// The render's seed, bounces and Russian roulette.
    pub seed: u64,
    /// The bounce cap; `null`: none (Russian roulette, unbiased).
    pub max_bounces: Option<u32>,
    pub russian_roulette_from: Option<u32>,
}

/// Where an image is and what it holds, as the API answers it.
#[derive(Clone, Debug, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ImageInfo {
    pub id: i64,
    pub render_id: i64,
    pub scene: String,
    /// `queued`, `running`, `complete`, `failed` or `cancelled`.
    pub state: String,
    pub error: Option<String>,
    pub settings: ImageSettings,
    /// The ids of the images rendered from the same paths (this one
    /// included), in `settings.codings`' order.
    pub set: Vec<i64>,
    /// The image of the set the others are compared with.
    pub reference_id: i64,
    /// The observer of its XYZ (and of every x,y, CIELAB and ΔE drawn from it).
    pub observer: String,
    /// The coding's colour in every chart and page (`charts::CODING_STYLES`), `#rrggbb`.
    pub colour: String,
    /// After each pass.
    #[cfg_attr(feature = "openapi", schema(value_type = Option<Object>))]
    pub progress: Option<CameraProgress>,
    /// Per pixel, once complete: the coding's channels (`S0.<λ>nm` bands,
    /// or R, G, B), then X, Y, Z, L, M, S.
    pub quantities: Vec<String>,
    /// Band centres of the coding's channels (nm); `null` for `rgb`/`srgb`.
    pub wavelengths_nm: Option<Vec<f64>>,
    /// Once complete.
    pub passes: Option<u32>,
    pub paths: Option<u64>,
    pub elapsed_seconds: Option<f64>,
    #[cfg_attr(feature = "openapi", schema(value_type = Option<String>))]
    pub stop: Option<StopReason>,
    /// Once complete: the log-average luminance (cd/m²) of its display
    /// PNG's tone map, for the page's cd/m² scale: a grey of Y cd/m² is
    /// shown at the linear display value d = Yk/(1 + Yk), k = 0.18 / this.
    pub display_log_average_cd_m2: Option<f64>,
}

struct Entry {
    info: ImageInfo,
    image: Option<ImageRef>,
    /// Shared by the images of a set: cancelling one cancels the set.
    cancel: CancellationToken,
    /// Finish order of complete images, for forgetting the oldest.
    finished_seq: u64,
}

/// One complete image: its coding's image in the set it was rendered
/// with. Dereferences to the [`CameraImage`].
#[derive(Clone)]
pub struct ImageRef {
    set: Arc<CameraImages>,
    index: usize,
}

impl ImageRef {
    /// Every coding rendered from the same paths, and the paired moments.
    pub fn set(&self) -> &CameraImages {
        &self.set
    }

    /// Which of the set's images this is.
    pub fn index(&self) -> usize {
        self.index
    }

    /// True when `other` was rendered from the same paths as this.
    pub fn same_set(&self, other: &ImageRef) -> bool {
        Arc::ptr_eq(&self.set, &other.set)
    }
}

impl std::ops::Deref for ImageRef {
    type Target = CameraImage;
    fn deref(&self) -> &CameraImage {
        &self.set.images[self.index]
    }
}

/// What `POST /api/renders/{id}/images` admitted.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ImagesAdmitted {
    /// (coding, image id) per coding, in the request's order.
    pub images: Vec<(String, i64)>,
    /// The image the others are compared with.
    pub reference_id: i64,
    /// True when images of this render with the same settings already
    /// existed (queued, running or complete) and are the ones answered.
    pub reused: bool,
}

/// Codings one request may render from the same paths.
pub const MAX_SET_CODINGS: usize = 8;

/// An admitted set of images, as the worker receives it.
pub struct ImageWork {
    /// One id per coding, in `settings.codings`' order.
    pub ids: Vec<i64>,
    pub scene: Arc<Scene>,
    /// The scene's id and render key, for render workers.
    pub scene_id: String,
    pub scene_hash: String,
    pub camera: Camera,
    pub settings: CameraSettings,
}

/// The images of this daemon, their queue and worker.
pub struct ImageJobs {
    entries: Mutex<BTreeMap<i64, Entry>>,
    sender: Mutex<Option<mpsc::Sender<ImageWork>>>,
    receiver: Mutex<Option<mpsc::Receiver<ImageWork>>>,
    events: EventSink,
    next_id: Mutex<(i64, u64)>,
    /// The daemon run these images belong to (see the module doc).
    run: i64,
    /// The database of the render workers, when they render the images
    /// ([`super::image_batches`]).
    workers: Option<lightbooth_store::Store>,
}

impl ImageJobs {
    /// The images of daemon run `run` (its lease id; 0 without one, as in
    /// tests): ids from `run` × [`IDS_PER_RUN`] + 1.
    pub fn new(events: EventSink, run: i64) -> ImageJobs {
        let (tx, rx) = mpsc::channel(IMAGE_QUEUE_CAPACITY);
        let run = run.clamp(0, i64::MAX / IDS_PER_RUN - 1);
        ImageJobs {
            entries: Mutex::default(),
            sender: Mutex::new(Some(tx)),
            receiver: Mutex::new(Some(rx)),
            events,
            next_id: Mutex::new((run * IDS_PER_RUN + 1, 1)),
            run,
            workers: None,
        }
    }

    /// Leaves the rendering to the render workers of `store` (a daemon
    /// started with `--renders workers`; see [`super::image_batches`]).
    pub fn on_workers(mut self, store: lightbooth_store::Store) -> ImageJobs {
        self.workers = Some(store);
        self
    }

    /// The 404 of an image id not (or no longer) here: one of an earlier
    /// run was lost with the restart; one of this run was forgotten (the
    /// memory bound) or never existed.
    pub fn missing(&self, id: i64) -> LabError {
        let run = id.div_euclid(IDS_PER_RUN);
        if (0..self.run).contains(&run) && id.rem_euclid(IDS_PER_RUN) != 0 {
            return LabError::NotFound(format!(
                "image {id} was lost with the daemon's restart: it was made by run {run}, and this is run {} \
                 (images are kept in memory); ask for it again with POST /api/renders/{{render}}/images",
                self.run
            ));
        }
        not_found(id)
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, BTreeMap<i64, Entry>> {
        self.entries.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// One image's state.
    pub fn info(&self, id: i64) -> Option<ImageInfo> {
        self.lock().get(&id).map(|e| e.info.clone())
    }

    /// The images queued or being rendered, oldest first.
    pub fn unfinished(&self) -> Vec<ImageInfo> {
        self.lock()
            .values()
            .filter(|e| e.info.state == "queued" || e.info.state == "running")
            .map(|e| e.info.clone())
            .collect()
    }

    /// The images of a render, oldest first.
    pub fn of_render(&self, render_id: i64) -> Vec<ImageInfo> {
        self.lock()
            .values()
            .filter(|e| e.info.render_id == render_id)
            .map(|e| e.info.clone())
            .collect()
    }

    /// Image `id` tone-mapped for looking at, as PNG bytes
    /// ([`image_views::display_png`]), on the blocking pool.
    pub async fn display_png(&self, id: i64) -> Result<Vec<u8>, LabError> {
        let (_, img) = self.data(id)?;
        tokio::task::spawn_blocking(move || image_views::display_png(&img))
            .await
            .map_err(|e| LabError::Internal(e.to_string()))?
    }

    /// A probe of the box of `w` × `h` pixels at (`x`, `y`) of image `id`
    /// ([`image_views::probe`]); a box that leaves the image is
    /// [`LabError::Invalid`], naming the query field at fault.
    pub fn probe(&self, id: i64, x: u32, y: u32, w: u32, h: u32) -> Result<Probe, LabError> {
        let (_, img) = self.data(id)?;
        image_views::probe(&img, id, x, y, w, h)
    }

    /// That probe drawn as SVG ([`image_views::probe_chart`]), on the
    /// blocking pool.
    pub async fn probe_chart(&self, id: i64, x: u32, y: u32, w: u32, h: u32) -> Result<Vec<u8>, LabError> {
        let probe = self.probe(id, x, y, w, h)?;
        let svg = tokio::task::spawn_blocking(move || image_views::probe_chart(&probe))
            .await
            .map_err(|e| LabError::Internal(e.to_string()))??;
        Ok(svg.into_bytes())
    }

    /// Image `id` as a file to save: multi-channel OpenEXR (spectral
    /// channels `S0.<λ>nm`, Fichet et al. 2021, or R, G, B; then X, Y, Z,
    /// L, M, S, each with its `SE.` layer, and `paths`) or MATLAB `.mat`,
    /// named after its render and coding. With `whole_set`, every coding
    /// rendered from the same paths in one file: a layer per coding
    /// (`coding.X`, `coding.SE.X`, …; MAT variables prefixed by the coding),
    /// the reference named in the header. Written by
    /// [`write_camera_images`](crate::export::image::write_camera_images) to a
    /// private temporary folder (removed after) on the blocking pool.
    pub async fn file(&self, id: i64, format: FileFormat, whole_set: bool) -> Result<Download, LabError> {
        use crate::export::image::{create_private_folder, export_folder, write_camera_image, write_camera_images};
        let (info, img) = self.data(id)?;
        if format == FileFormat::Csv {
            return Err(LabError::NotFound(format!(
                "image {id} has no CSV file: ask for its exr or mat file"
            )));
        }
        let bytes = tokio::task::spawn_blocking(move || {
            let nanos = std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map(|d| d.as_nanos())
                .unwrap_or(0);
            let dir = export_folder(&std::env::temp_dir(), std::process::id(), id, nanos);
            create_private_folder(&dir).map_err(LabError::Internal)?;
            let path = dir.join(format!("image.{}", format.extension()));
            let written = if whole_set {
                write_camera_images(img.set(), &path)
            } else {
                write_camera_image(&img, &path)
            };
            let bytes = written
                .map_err(LabError::Internal)
                .and_then(|_| std::fs::read(&path).map_err(|e| LabError::Internal(format!("{}: {e}", path.display()))));
            let _ = std::fs::remove_dir_all(&dir);
            bytes
        })
        .await
        .map_err(|e| LabError::Internal(e.to_string()))??;
        let name = if whole_set {
            format!(
                "render_{}_{}_images_{id}",
                info.render_id,
                info.settings.codings.join("-")
            )
        } else {
            format!("render_{}_{}_image_{id}", info.render_id, info.settings.coding)
        };
        Ok(Download::new(format, &name, bytes))
    }

    /// A complete image's data; 404 for an unknown id, 409 before it is complete.
    pub fn data(&self, id: i64) -> Result<(ImageInfo, ImageRef), LabError> {
        let entries = self.lock();
        let e = entries.get(&id).ok_or_else(|| self.missing(id))?;
        match &e.image {
            Some(img) => Ok((e.info.clone(), img.clone())),
            None => Err(LabError::Conflict(format!(
                "image {id} is {}{}; its pixels exist once it is complete",
                e.info.state,
                e.info.error.as_deref().map(|m| format!(" ({m})")).unwrap_or_default()
            ))),
        }
    }

    /// Admits a set of images (one per coding of `settings`, rendered from
    /// the same paths): the same render and settings give the images
    /// already queued, running or complete (`reused` true); otherwise a
    /// slot is reserved (409 when full) and the set queued. The ids, in
    /// `settings`' order.
    pub fn enqueue(
        &self,
        render_id: i64,
        scene_id: &str,
        observer: Observer,
        settings: Vec<ImageSettings>,
        work: impl FnOnce(Vec<i64>) -> ImageWork,
    ) -> Result<(Vec<i64>, bool), LabError> {
        let mut entries = self.lock();
        let found: Vec<Option<&Entry>> = settings
            .iter()
            .map(|s| {
                entries.values().find(|e| {
                    e.info.render_id == render_id
                        && e.info.settings == *s
                        && matches!(e.info.state.as_str(), "queued" | "running" | "complete")
                })
            })
            .collect();
        if found.iter().all(Option::is_some) {
            return Ok((found.into_iter().flatten().map(|e| e.info.id).collect(), true));
        }
        let sender = self
            .sender
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .clone()
            .ok_or_else(|| LabError::Unavailable("the daemon is shutting down".into()))?;
        let permit = sender.try_reserve().map_err(|e| match e {
            mpsc::error::TrySendError::Full(()) => LabError::Conflict(format!(
                "the image queue is full: {IMAGE_QUEUE_CAPACITY} images are already waiting; \
                 try again when one finishes, or cancel one"
            )),
            mpsc::error::TrySendError::Closed(()) => LabError::Unavailable("the daemon is shutting down".into()),
        })?;
        let ids: Vec<i64> = {
            let mut next = self.next_id.lock().unwrap_or_else(|p| p.into_inner());
            let first = next.0;
            next.0 += settings.len() as i64;
            (first..next.0).collect()
        };
        let reference_id = settings
            .iter()
            .zip(&ids)
            .find(|(s, _)| s.coding == s.reference)
            .map_or(ids[ids.len() - 1], |(_, id)| *id);
        let cancel = CancellationToken::new();
        for (s, &id) in settings.into_iter().zip(&ids) {
            entries.insert(
                id,
                Entry {
                    info: ImageInfo {
                        id,
                        render_id,
                        scene: scene_id.to_string(),
                        state: "queued".into(),
                        error: None,
                        colour: crate::charts::coding_colour_hex(&s.coding).unwrap_or_else(|| "#000000".into()),
                        settings: s,
                        set: ids.clone(),
                        reference_id,
                        observer: observer.to_string(),
                        progress: None,
                        quantities: Vec::new(),
                        wavelengths_nm: None,
                        passes: None,
                        paths: None,
                        elapsed_seconds: None,
                        stop: None,
                        display_log_average_cd_m2: None,
                    },
                    image: None,
                    cancel: cancel.clone(),
                    finished_seq: 0,
                },
            );
        }
        let work = work(ids.clone());
        let codings: Vec<String> = work.settings.codings.iter().map(|c| c.to_string()).collect();
        permit.send(work);
        tracing::info!(image_ids = ?ids, render_id, codings = codings.join(","), "images queued");
        Ok((ids, false))
    }

    /// Cancels a queued or running image, and the images rendered with it
    /// from the same paths (409 once it has ended).
    pub fn cancel(&self, id: i64) -> Result<ImageInfo, LabError> {
        let mut entries = self.lock();
        let e = entries.get(&id).ok_or_else(|| self.missing(id))?;
        let (state, set) = (e.info.state.clone(), e.info.set.clone());
        match state.as_str() {
            "queued" => {
                e.cancel.cancel();
                for member in &set {
                    if let Some(m) = entries.get_mut(member) {
                        m.info.state = "cancelled".into();
                        m.info.error = Some("cancelled by a client before it started".into());
                    }
                }
            }
            "running" => e.cancel.cancel(),
            other => {
                return Err(LabError::Conflict(format!(
                    "image {id} is already {other}; nothing to cancel"
                )))
            }
        }
        Ok(entries[&id].info.clone())
    }

    /// Refuses new images and cancels every admitted one.
    pub fn shutdown(&self) {
        self.sender.lock().unwrap_or_else(|p| p.into_inner()).take();
        for e in self.lock().values() {
            e.cancel.cancel();
        }
    }

    /// Starts the one worker that renders queued images in turn.
    pub fn run(self: &Arc<Self>) -> tokio::task::JoinHandle<()> {
        let this = Arc::clone(self);
        let receiver = self.receiver.lock().unwrap_or_else(|p| p.into_inner()).take();
        tokio::spawn(async move {
            let Some(mut receiver) = receiver else { return };
            if let Some(store) = &this.workers {
                match store.abandon_image_batches_of_gone_daemons().await {
                    Ok(0) => {}
                    Ok(n) => tracing::info!(batches = n, "gave up the image batches of daemons that are gone"),
                    Err(e) => tracing::warn!(error = %e, "cannot give up the image batches of daemons that are gone"),
                }
            }
            while let Some(work) = receiver.recv().await {
                this.run_one(work).await;
            }
        })
    }

    async fn run_one(self: &Arc<Self>, work: ImageWork) {
        let ids = work.ids.clone();
        let (cancel, render_id) = {
            let mut entries = self.lock();
            let Some(e) = entries.get(&ids[0]) else { return };
            if e.info.state != "queued" {
                return; // cancelled while queued
            }
            let (cancel, render_id) = (e.cancel.clone(), e.info.render_id);
            let (state, error) = if cancel.is_cancelled() {
                (
                    "cancelled",
                    Some("the daemon shut down before this image ran".to_string()),
                )
            } else {
                ("running", None)
            };
            for id in &ids {
                if let Some(e) = entries.get_mut(id) {
                    e.info.state = state.into();
                    e.info.error = error.clone();
                }
            }
            if cancel.is_cancelled() {
                return;
            }
            (cancel, render_id)
        };
        tracing::info!(image_ids = ?ids, render_id, "images started");
        let outcome = match &self.workers {
            Some(store) => {
                let progress = |p: CameraProgress| self.progress(&ids, render_id, p);
                super::image_batches::render_on_workers(
                    store,
                    (&work.scene_id, &work.scene_hash),
                    &work.camera,
                    &work.settings,
                    progress,
                    &cancel,
                )
                .await
            }
            None => self.render_here(work, render_id, cancel.clone()).await,
        };
        let outcome = match outcome {
            Ok(images) if !cancel.is_cancelled() => Ok(images),
            Ok(_) | Err(None) => Err(None),
            Err(Some(e)) => Err(Some(e)),
        };
        // The display tone map's scale per image, off the async runtime.
        let outcome = match outcome {
            Ok(set) => tokio::task::spawn_blocking(move || {
                let scales: Vec<f64> = set.images.iter().map(|i| i.to_srgb().log_average_luminance()).collect();
                (Arc::new(set), scales)
            })
            .await
            .map_err(|e| Some(format!("the image's tone map: {e}"))),
            Err(e) => Err(e),
        };
        self.finish(&ids, render_id, outcome);
    }

    /// Renders a set in this daemon, on the global rayon pool; `Err(None)`
    /// when cancelled.
    async fn render_here(
        self: &Arc<Self>,
        work: ImageWork,
        render_id: i64,
        cancel: CancellationToken,
    ) -> Result<CameraImages, Option<String>> {
        let (tx, rx) = tokio::sync::oneshot::channel();
        let this = Arc::clone(self);
        rayon::spawn(move || {
            let id = work.ids[0];
            let caught = catch_unwind(AssertUnwindSafe(|| {
                if jobs::test_panic_requested(&this.scene_of(id)) {
                    jobs::panic_on_the_pool(&this.scene_of(id));
                }
                let progress = |p: CameraProgress| this.progress(&work.ids, render_id, p);
                render_camera_images(
                    &work.scene,
                    &work.camera,
                    &work.settings,
                    Some(&progress),
                    Some(&cancel),
                )
            }))
            .map_err(|panic| format!("the renderer panicked: {}", jobs::panic_message(&*panic)));
            let _ = tx.send(caught);
        });
        match rx.await {
            Ok(Ok(Ok(images))) => Ok(images),
            Ok(Ok(Err(RenderError::Cancelled))) => Err(None),
            Ok(Ok(Err(e))) => Err(Some(e.to_string())),
            Ok(Err(panic)) => Err(Some(panic)),
            Err(_) => Err(Some("the image's worker ended without an answer".into())),
        }
    }

    /// Records how a set ended (its images, or why not) and announces it.
    /// `outcome`: the set with each image's display tone-map scale.
    fn finish(&self, ids: &[i64], render_id: i64, outcome: Result<(Arc<CameraImages>, Vec<f64>), Option<String>>) {
        let ended = {
            let mut entries = self.lock();
            let seq = {
                let mut next = self.next_id.lock().unwrap_or_else(|p| p.into_inner());
                next.1 += 1;
                next.1
            };
            let mut ended = Vec::new();
            for (index, id) in ids.iter().enumerate() {
                let Some(e) = entries.get_mut(id) else { continue };
                match &outcome {
                    Ok((set, scales)) => {
                        let img = &set.images[index];
                        e.info.state = "complete".into();
                        e.info.passes = Some(img.passes);
                        e.info.paths = Some(img.paths);
                        e.info.elapsed_seconds = Some(img.elapsed_seconds);
                        e.info.stop = Some(img.stop);
                        e.info.display_log_average_cd_m2 = Some(scales[index]);
                        e.info.quantities = crate::export::image::quantity_names(img);
                        e.info.wavelengths_nm = img.quantities.wavelengths_nm.clone();
                        e.image = Some(ImageRef {
                            set: Arc::clone(set),
                            index,
                        });
                        e.finished_seq = seq;
                    }
                    Err(None) => {
                        e.info.state = "cancelled".into();
                        e.info.error = Some("cancelled".into());
                    }
                    Err(Some(message)) => {
                        e.info.state = "failed".into();
                        e.info.error = Some(message.clone());
                    }
                }
                ended.push((*id, e.info.state.clone(), e.info.error.clone()));
            }
            forget_oldest(&mut entries);
            ended
        };
        for (image_id, state, error) in ended {
            tracing::info!(image_id, render_id, state, "image ended");
            self.events.send(Event::ImageFinished {
                image_id,
                render_id,
                state,
                error,
            });
        }
    }

    fn scene_of(&self, id: i64) -> String {
        self.lock().get(&id).map(|e| e.info.scene.clone()).unwrap_or_default()
    }

    fn progress(&self, ids: &[i64], render_id: i64, p: CameraProgress) {
        let mut budget = None;
        {
            let mut entries = self.lock();
            for id in ids {
                if let Some(e) = entries.get_mut(id) {
                    e.info.progress = Some(p);
                    budget = Some(e.info.settings.time_budget_s);
                }
            }
        }
        let (seconds_left, estimate) = match budget {
            Some(b) => crate::progress::image_time_left(&p, b),
            None => (None, String::new()),
        };
        for &image_id in ids {
            self.events.send(Event::ImageProgress {
                seconds_left,
                estimate: estimate.clone(),
                image_id,
                render_id,
                pass: p.pass,
                pixels_done: p.pixels_done,
                pixels: p.pixels,
                paths: p.paths,
                max_paths: p.max_paths,
                elapsed_seconds: p.elapsed_seconds,
            });
        }
    }
}

/// Forgets the oldest complete sets until those kept fit [`MAX_KEPT_BYTES`]
/// (the images of a set share their storage, so they are forgotten together).
fn forget_oldest(entries: &mut BTreeMap<i64, Entry>) {
    // Means and squared deviations, f32 each, per pixel and quantity, and
    // the paired moments (12 f32 per pixel and coding), counted once per set.
    let bytes = |e: &Entry| {
        e.image.as_ref().map_or(0, |r| {
            let set = r.set();
            set.images
                .iter()
                .map(|i| i.width as u64 * i.height as u64 * (i.stride() as u64 * 8 + 48))
                .sum::<u64>()
        })
    };
    let set_of = |e: &Entry| e.info.set.first().copied().unwrap_or(e.info.id);
    let mut total: u64 = entries.values().filter(|e| e.info.id == set_of(e)).map(bytes).sum();
    while total > MAX_KEPT_BYTES {
        let Some(oldest) = entries
            .values()
            .filter(|e| e.image.is_some())
            .min_by_key(|e| e.finished_seq)
            .map(|e| (e.info.set.clone(), bytes(e)))
        else {
            break;
        };
        for id in &oldest.0 {
            if entries.remove(id).is_some() {
                tracing::info!(image_id = id, "image forgotten (images kept in memory are bounded)");
            }
        }
        total -= oldest.1;
    }
}

fn not_found(id: i64) -> LabError {
    LabError::NotFound(format!(
        "no image {id} (images are kept in memory: a restart, or newer images beyond {} MB, forget them)",
        MAX_KEPT_BYTES >> 20
    ))
}

/// The request checked field by field against the limits (see the module
/// doc) for a scene camera, with the render's transport and seed: the
/// settings of each image of the set, in the request's coding order, and
/// their codings.
pub fn check_request(
    request: &ImageRequest,
    camera: &Camera,
    transport: &Transport,
    seed: u64,
) -> Result<(Vec<ImageSettings>, Vec<Coding>), LabError> {
    let names: Vec<String> = match (&request.coding, &request.codings) {
        (Some(c), None) => vec![c.clone()],
        (None, Some(list)) if !list.is_empty() => list.clone(),
        (None, Some(_)) => return Err(LabError::Invalid("field `codings`: the list is empty".into())),
        (Some(_), Some(_)) => {
            return Err(LabError::Invalid(
                "fields `coding`, `codings`: give one coding or a list of them, not both".into(),
            ))
        }
        (None, None) => {
            return Err(LabError::Invalid(
                "field `coding`: missing (or give `codings`, a list of codings rendered from the same paths)".into(),
            ))
        }
    };
    let field = if request.codings.is_some() { "codings" } else { "coding" };
    if names.len() > MAX_SET_CODINGS {
        return Err(LabError::Invalid(format!(
            "field `codings`: {} codings; at most {MAX_SET_CODINGS} are rendered from one set of paths",
            names.len()
        )));
    }
    let mut codings: Vec<Coding> = Vec::with_capacity(names.len());
    for (i, name) in names.iter().enumerate() {
        let coding: Coding = name.parse().map_err(|e| {
            let at = if field == "codings" {
                format!("[{i}]")
            } else {
                String::new()
            };
            LabError::Invalid(format!("field `{field}`{at}: {e}"))
        })?;
        if codings.contains(&coding) {
            return Err(LabError::Invalid(format!(
                "field `codings`[{i}]: {coding} is listed twice"
            )));
        }
        codings.push(coding);
    }
    let reference = match &request.reference {
        None => codings[codings.len() - 1],
        Some(r) => {
            let coding: Coding = r
                .parse()
                .map_err(|e| LabError::Invalid(format!("field `reference`: {e}")))?;
            if !codings.contains(&coding) {
                return Err(LabError::Invalid(format!(
                    "field `reference`: {coding} is not one of the codings asked for ({})",
                    names.join(",")
                )));
            }
            coding
        }
    };
    let width = request.width.unwrap_or(DEFAULT_WIDTH.min(camera.width));
    if !(8..=camera.width).contains(&width) {
        return Err(LabError::Invalid(format!(
            "field `width`: {width} is outside 8–{} (the scene camera's width)",
            camera.width
        )));
    }
    let height = ((width as f64 * camera.height as f64 / camera.width as f64).round() as u32).max(1);
    let max_spp = request.max_spp.unwrap_or(DEFAULT_MAX_SPP);
    if !(1..=MAX_IMAGE_SPP).contains(&max_spp) {
        return Err(LabError::Invalid(format!(
            "field `max_spp`: {max_spp} is outside 1–{MAX_IMAGE_SPP} (paths per pixel)"
        )));
    }
    let min_spp = request.min_spp.unwrap_or(DEFAULT_MIN_SPP.min(max_spp));
    if !(1..=max_spp).contains(&min_spp) {
        return Err(LabError::Invalid(format!(
            "field `min_spp`: {min_spp} is outside 1–{max_spp} (`max_spp`)"
        )));
    }
    if let Some(t) = request.target_relative_se {
        if !(t > 0.0 && t <= 1.0) {
            return Err(LabError::Invalid(format!(
                "field `target_relative_se`: {t} is outside (0, 1]"
            )));
        }
    }
    let time_budget_s = request.time_budget_s.unwrap_or(MAX_TIME_BUDGET_S);
    if !(time_budget_s > 0.0 && time_budget_s <= MAX_TIME_BUDGET_S) {
        return Err(LabError::Invalid(format!(
            "field `time_budget_s`: {time_budget_s} is outside (0, {MAX_TIME_BUDGET_S}] seconds"
        )));
    }
    let quantities: u64 = codings.iter().map(|c| c.channels() as u64 + 6).sum();
    let work = width as u64 * height as u64 * max_spp as u64 * quantities;
    if work > MAX_IMAGE_WORK {
        return Err(LabError::Invalid(format!(
            "fields `width`, `max_spp`, `{field}`: width × height × max_spp × quantities = {width} × {height} × \
             {max_spp} × {quantities} = {work} is above the limit {MAX_IMAGE_WORK} (lab::render::images::MAX_IMAGE_WORK); \
             ask for fewer pixels, fewer paths per pixel, fewer codings or fewer bands"
        )));
    }
    let all: Vec<String> = codings.iter().map(|c| c.to_string()).collect();
    let settings = codings
        .iter()
        .map(|coding| ImageSettings {
            coding: coding.to_string(),
            codings: all.clone(),
            reference: reference.to_string(),
            se_every_coding: request.se_every_coding.unwrap_or(false),
            width,
            height,
            min_spp,
            max_spp,
            target_relative_se: request.target_relative_se,
            time_budget_s,
            seed,
            max_bounces: transport.max_bounces,
            russian_roulette_from: transport.russian_roulette_from,
        })
        .collect();
    Ok((settings, codings))
}

/// The camera settings and the scaled camera of checked settings (any
/// image's of the set).
pub fn camera_settings(
    s: &ImageSettings,
    codings: Vec<Coding>,
    camera: &Camera,
    observer: Observer,
) -> Result<(Camera, CameraSettings), LabError> {
    let mut scaled = camera.clone();
    scaled.width = s.width;
    scaled.height = s.height;
    let reference: Coding = s
        .reference
        .parse()
        .map_err(|e| LabError::Internal(format!("a checked reference coding: {e}")))?;
    Ok((
        scaled,
        CameraSettings {
            codings,
            reference: Some(reference),
            se_every_coding: s.se_every_coding,
            observer,
            transport: Transport {
                max_bounces: s.max_bounces,
                russian_roulette_from: s.russian_roulette_from,
                // The API's images take the renderer's default light sampler.
                light_sampler: Default::default(),
            },
            seed: s.seed,
            min_spp: s.min_spp,
            first_sample: 0,
            max_spp: s.max_spp,
            target_relative_se: s.target_relative_se,
            time_budget: Some(Duration::from_secs_f64(s.time_budget_s)),
        },
    ))
}
