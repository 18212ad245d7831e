//! Camera images on render workers: a daemon started with `--renders
//! workers` splits an image set's paths into batches that any `lightbooth
//! worker` on its PostgreSQL database renders, and merges them.
//!
//! - The plan ([`plan`]): the `max_spp` paths of every pixel are cut into
//!   at most [`MAX_BATCHES`] consecutive ranges of path indices, each a
//!   whole number of the request's passes (`min_spp`). Batch b traces the
//!   paths `first_sample` … `first_sample + spp − 1` of every pixel, each
//!   from its own stream (seed, pixel, path index), so the batches together
//!   are exactly the paths one machine's render of the set traces, and
//!   their merge (`CameraImages::merge`, Chan et al.) is that render up to
//!   the `f32` rounding of the stored moments.
//! - Each batch is a row of `image_batches` and a worker job of kind
//!   `image` about it ([`ImageBatch`] is the job's payload: the scene and
//!   its content hash, the size, codings, observer, transport, seed and
//!   the path range). The worker renders it with the daemon's published
//!   scenes ([`ImageBatch::render`]) and leaves its moments on the row.
//! - The daemon ([`render_on_workers`]) polls its batches' jobs, merges
//!   each batch as it ends (in any order: the merge is exact), reports
//!   progress after each, and stops early by the request's own rules:
//!   when every pixel meets the SE target (checked on the merged batches,
//!   so a pixel gets the paths of whole batches, not one pass at a time)
//!   or when the time budget has passed with at least one batch merged;
//!   the batches not yet rendered are then cancelled. A batch that fails
//!   fails the image, saying which paths it held.
//! - A cancelled image cancels its batches; every row is deleted once
//!   merged or given up, and rows of daemons that are gone are given up by
//!   the next daemon to start on workers
//!   (`Store::abandon_image_batches_of_gone_daemons`).

use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};
use tokio_util::sync::CancellationToken;

use crate::scenes::SceneCatalog;
use lightbooth_render::camera::{render_camera_images, CameraImages, CameraProgress, CameraSettings, StopReason};
use lightbooth_render::integrator::Transport;
use lightbooth_render::{Coding, Scene};
use lightbooth_science::colorimetry::Observer;
use lightbooth_store::{Store, WorkerJobKind};

/// Batches one image is cut into, at most.
pub const MAX_BATCHES: u32 = 16;

/// How often the daemon looks at its batches' jobs.
const POLL: Duration = Duration::from_millis(100);

/// One batch of an image's paths, as a worker job carries it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ImageBatch {
    /// The scene id and its render key: the worker renders only that content.
    pub scene: String,
    pub scene_hash: String,
    pub width: u32,
    pub height: u32,
    pub codings: Vec<String>,
    pub reference: String,
    pub observer: Observer,
    pub seed: u64,
    pub max_bounces: Option<u32>,
    pub russian_roulette_from: Option<u32>,
    /// The path indices of every pixel this batch traces: `first_sample` …
    /// `first_sample + spp − 1`, in passes of `pass_spp`.
    pub first_sample: u32,
    pub spp: u32,
    pub pass_spp: u32,
}

/// The path ranges (first path index, paths) of a set of `max_spp` paths
/// per pixel in passes of `min_spp`: at most [`MAX_BATCHES`] ranges, each a
/// whole number of passes but the last, together 0 … `max_spp` − 1.
pub fn plan(min_spp: u32, max_spp: u32) -> Vec<(u32, u32)> {
    let min_spp = min_spp.clamp(1, max_spp.max(1));
    let passes = max_spp.div_ceil(min_spp);
    let per_batch = passes.div_ceil(MAX_BATCHES) * min_spp;
    (0..max_spp)
        .step_by(per_batch as usize)
        .map(|first| (first, per_batch.min(max_spp - first)))
        .collect()
}

impl ImageBatch {
    /// The batches of a set rendered with `settings` of scene `scene`
    /// (content `scene_hash`) by `camera` size.
    pub fn plan_for(
        scene: &str,
        scene_hash: &str,
        width: u32,
        height: u32,
        settings: &CameraSettings,
    ) -> Vec<ImageBatch> {
        let codings: Vec<String> = settings.codings.iter().map(|c| c.to_string()).collect();
        let reference = settings
            .reference
            .map(|r| r.to_string())
            .unwrap_or_else(|| codings[codings.len() - 1].clone());
        plan(settings.min_spp, settings.max_spp)
            .into_iter()
            .map(|(first_sample, spp)| ImageBatch {
                scene: scene.to_string(),
                scene_hash: scene_hash.to_string(),
                width,
                height,
                codings: codings.clone(),
                reference: reference.clone(),
                observer: settings.observer,
                seed: settings.seed,
                max_bounces: settings.transport.max_bounces,
                russian_roulette_from: settings.transport.russian_roulette_from,
                first_sample,
                spp,
                pass_spp: settings.min_spp.min(spp),
            })
            .collect()
    }

    /// The camera settings of this batch: every pixel gets its `spp` paths
    /// (no stopping inside a batch; the daemon stops between batches).
    fn settings(&self) -> Result<CameraSettings, String> {
        let parse = |c: &String| {
            c.parse::<Coding>()
                .map_err(|e| format!("an image batch's coding `{c}`: {e}"))
        };
        Ok(CameraSettings {
            codings: self.codings.iter().map(parse).collect::<Result<_, _>>()?,
            reference: Some(parse(&self.reference)?),
            se_every_coding: false,
            observer: self.observer,
            transport: Transport {
                max_bounces: self.max_bounces,
                russian_roulette_from: self.russian_roulette_from,
                // As the daemon's own images (`images::camera_settings`).
                light_sampler: Default::default(),
            },
            seed: self.seed,
            min_spp: self.pass_spp.max(1),
            first_sample: self.first_sample,
            max_spp: self.spp,
            target_relative_se: None,
            time_budget: None,
        })
    }

    /// Renders the batch with the scene of `catalogue` (a worker's copy of
    /// the daemon's published scenes), which must have the batch's
    /// content: its moments as bytes (`CameraImages::to_bytes`). Blocks:
    /// run it off the async runtime.
    pub fn render(&self, catalogue: &SceneCatalog, cancel: &CancellationToken) -> Result<Vec<u8>, String> {
        let entry = catalogue
            .get(&self.scene)
            .ok_or_else(|| format!("no scene `{}` among the daemon's published scenes", self.scene))?;
        if entry.hash != self.scene_hash {
            return Err(format!(
                "scene `{}` here is not the content the image was asked of (render key {} here, {} asked)",
                self.scene, entry.hash, self.scene_hash
            ));
        }
        let camera = self.camera(&entry.scene)?;
        let images = render_camera_images(&entry.scene, &camera, &self.settings()?, None, Some(cancel))
            .map_err(|e| e.to_string())?;
        Ok(images.to_bytes())
    }

    fn camera(&self, scene: &Scene) -> Result<lightbooth_render::scene::Camera, String> {
        let mut camera = scene
            .camera
            .clone()
            .ok_or_else(|| format!("scene `{}` has no [camera]", self.scene))?;
        camera.width = self.width;
        camera.height = self.height;
        Ok(camera)
    }
}

/// A batch the daemon queued and waits for.
struct Pending {
    batch: ImageBatch,
    row: i64,
    job: i64,
}

/// Renders a set on the render workers (see the module doc): `settings`
/// and the scaled `camera` as the daemon would render it itself. `Err(None)`
/// when cancelled; `progress` after each merged batch.
pub async fn render_on_workers(
    store: &Store,
    scene: (&str, &str),
    camera: &lightbooth_render::scene::Camera,
    settings: &CameraSettings,
    progress: impl Fn(CameraProgress),
    cancel: &CancellationToken,
) -> Result<CameraImages, Option<String>> {
    let start = Instant::now();
    let batches = ImageBatch::plan_for(scene.0, scene.1, camera.width, camera.height, settings);
    let mut pending = Vec::new();
    let failed = |why: String| Some(why);
    for batch in batches {
        let queued = async {
            let row = store.new_image_batch().await?;
            let payload = serde_json::to_value(&batch).expect("an image batch serialises");
            let job = store.queue_worker_job(WorkerJobKind::Image, row, &payload).await?;
            Ok::<_, lightbooth_store::StoreError>(Pending { batch, row, job })
        }
        .await;
        match queued {
            Ok(p) => pending.push(p),
            Err(e) => {
                give_up(store, &pending).await;
                return Err(failed(format!(
                    "cannot queue the image's batches for the render workers: {e}"
                )));
            }
        }
    }
    tracing::info!(
        batches = pending.len(),
        scene = scene.0,
        "image batches queued for the render workers"
    );
    let pixels = camera.width as u64 * camera.height as u64;
    let max_paths = pixels * settings.max_spp as u64;
    let mut merged: Option<CameraImages> = None;
    let mut batches_merged = 0u32;
    let stop = loop {
        if cancel.is_cancelled() {
            give_up(store, &pending).await;
            return Err(None);
        }
        let mut ended = None;
        for (i, p) in pending.iter().enumerate() {
            match store.worker_job(p.job).await {
                Ok(Some(row)) if matches!(row.state.as_str(), "done" | "failed" | "cancelled") => {
                    ended = Some((i, row.state, row.error));
                    break;
                }
                Ok(_) => {}
                Err(e) => tracing::warn!(job = p.job, error = %e, "cannot read an image batch's job"),
            }
        }
        if let Some((i, state, error)) = ended {
            let p = pending.swap_remove(i);
            let range = format!(
                "paths {}–{} of every pixel",
                p.batch.first_sample,
                p.batch.first_sample + p.batch.spp - 1
            );
            if state != "done" {
                give_up(store, &pending).await;
                let _ = store.delete_image_batches(&[p.row]).await;
                return Err(failed(format!(
                    "the render worker's batch of {range} {state}: {}",
                    error.unwrap_or_default()
                )));
            }
            let bytes = match store.image_batch_moments(p.row).await {
                Ok(Some(Some(bytes))) => bytes,
                other => {
                    give_up(store, &pending).await;
                    let _ = store.delete_image_batches(&[p.row]).await;
                    return Err(failed(format!(
                        "the render worker's batch of {range} left no moments ({other:?})"
                    )));
                }
            };
            let _ = store.delete_image_batches(&[p.row]).await;
            let so_far = merged.take();
            let joined = tokio::task::spawn_blocking(move || {
                let batch = CameraImages::from_bytes(&bytes)?;
                match so_far {
                    None => Ok(batch),
                    Some(mut so_far) => so_far.merge(&batch).map(|()| so_far),
                }
            })
            .await
            .map_err(|e| e.to_string())
            .and_then(|r| r);
            let joined = match joined {
                Ok(j) => j,
                Err(e) => {
                    give_up(store, &pending).await;
                    return Err(failed(format!("the render worker's batch of {range}: {e}")));
                }
            };
            batches_merged += 1;
            let done = joined.pixels_done(settings);
            progress(CameraProgress {
                pass: batches_merged,
                pixels_done: done,
                pixels,
                paths: joined.images[0].paths,
                max_paths,
                elapsed_seconds: start.elapsed().as_secs_f64(),
            });
            merged = Some(joined);
            if pending.is_empty() {
                break if settings.target_relative_se.is_some() && done == pixels {
                    StopReason::Converged
                } else {
                    StopReason::MaxSamples
                };
            }
            if settings.target_relative_se.is_some() && done == pixels {
                break StopReason::Converged;
            }
        }
        if merged.is_some() && settings.time_budget.is_some_and(|b| start.elapsed() >= b) {
            break StopReason::TimeBudget;
        }
        tokio::select! {
            _ = tokio::time::sleep(POLL) => {}
            _ = cancel.cancelled() => {}
        }
    };
    give_up(store, &pending).await;
    let mut images = merged.expect("a batch was merged before stopping");
    let elapsed = start.elapsed().as_secs_f64();
    for img in &mut images.images {
        img.stop = stop;
        img.elapsed_seconds = elapsed;
    }
    Ok(images)
}

/// Cancels the batches not merged and deletes their rows.
async fn give_up(store: &Store, pending: &[Pending]) {
    for p in pending {
        if let Err(e) = store.cancel_worker_job(WorkerJobKind::Image, p.row).await {
            tracing::warn!(job = p.job, error = %e, "cannot cancel an image batch");
        }
    }
    let rows: Vec<i64> = pending.iter().map(|p| p.row).collect();
    if let Err(e) = store.delete_image_batches(&rows).await {
        tracing::warn!(error = %e, "cannot delete image batches");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_plan_covers_every_path_once_in_whole_passes() {
        for (min, max) in [(8, 32), (8, 4096), (1, 1), (3, 10), (16, 16), (7, 1000), (64, 65_536)] {
            let batches = plan(min, max);
            assert!(batches.len() as u32 <= MAX_BATCHES, "{min}, {max}: {batches:?}");
            let mut next = 0;
            for (i, &(first, spp)) in batches.iter().enumerate() {
                assert_eq!(first, next, "{min}, {max}: {batches:?}");
                assert!(spp > 0);
                if i + 1 < batches.len() {
                    assert_eq!(spp % min, 0, "a whole number of passes: {batches:?}");
                }
                next += spp;
            }
            assert_eq!(next, max, "{min}, {max}: {batches:?}");
        }
        assert_eq!(plan(8, 32), vec![(0, 8), (8, 8), (16, 8), (24, 8)]);
    }
}
