//! Where a measurement's comparison with every coding is computed: the
//! render it is compared with (reused from the store, or rendered once),
//! the CIELAB white of its booth, the rows stored, the whites kept current,
//! and ([`summary`]) a scene's comparisons summarised per coding; their
//! charts ([`charts`]: what each shows, drawn by `lightbooth-report`), their
//! files ([`files`]: CSV and MAT), a camera image's ΔE map ([`image_map`])
//! and every scene at a glance ([`overview`]).
//!
//! The figures of merit themselves (ΔE, luminance ratio, x,y distance) are
//! the science's ([`lightbooth_science::comparison`]); this module decides what is
//! compared with what.
//!
//! # The observer
//!
//! A comparison is made in the observer of what was measured
//! ([`Comparable::observer`](crate::measure::recorder::Comparable::observer)): a
//! spectroradiometer's spectrum in the [`RenderRunner`]'s
//! (`serve --observer`), a colorimeter's XYZ or a luminance meter's Y in the
//! instrument's own (a render's spectra can be weighted with any observer,
//! a colorimeter's XYZ only with its own). The render compared with is one
//! at the comparison settings in that observer, the white is in it, and
//! every comparison row names it.
//!
//! # Measurements left uncompared
//!
//! [`Comparisons::compare_left_over`] (the daemon's start-up) compares
//! every complete measurement of a scene target in the booth that has no
//! comparison and none queued — one taken while the daemon was stopping,
//! or refused by an older daemon — and says so in the log.
//!
//! # The CIELAB reference white
//!
//! Both sides of a comparison go through CIELAB with the same white: the
//! one the scene declares in its file (`[cielab_white]`, resolved by the
//! [catalogue](super::scenes)). WHITE, RED, GREEN and BLUE declare the
//! WHITE scene's Spectralon (`white/patch`), CYLINDER its top target
//! (`h21`). A target white is the newest complete *measurement* of that
//! target in the booth the compared measurement was taken in (booths have
//! their own lamps: a white measured in booth north never serves booth
//! south); until one exists, the `spectral` rendering of it stands in, and
//! the row says so (`white_source`, with the white's XYZ).
//!
//! When a booth's white changes — its target is measured there for the first
//! time or again — every comparison of that booth of every scene using it is
//! recomputed with the new white (ΔE from the stored XYZ; the measured and
//! rendered XYZ do not depend on the white), so no scene mixes whites.
//! Comparisons and these updates are serialised by one lock, so a
//! comparison finishing late cannot write an old white after the update.
//!
//! No scene file is read here: the scenes, their render keys and whites
//! are the catalogue's.

pub mod charts;
pub mod files;
pub mod image_map;
pub mod overview;
pub mod summary;
pub mod white;

use std::collections::HashMap;
use std::path::Path;
use std::sync::Arc;

use tokio::runtime::Handle;

use super::error::LabError;
use super::events::{Event, EventSink};
use crate::measure::recorder::{stored_comparable, Comparable};
use crate::render::runner::{RenderRunner, StoredRenderResult};
use crate::render::worker_queue::WorkerQueue;
use lightbooth_science::colorimetry::{Lab, Observer, Xyz};
use lightbooth_science::comparison::{compare_point, delta_e_pair};
use lightbooth_store::{Booth, NewComparison, NewLuminanceComparison, Store};
use white::{resolve_white, RenderedWhite};

/// Compares measurements with every coding of their scene's render.
pub struct Comparisons {
    store: Store,
    runner: Arc<RenderRunner>,
    events: EventSink,
    /// Serialises "resolve the white, store comparisons, refresh whites".
    compare_lock: tokio::sync::Mutex<()>,
    /// One lock per scene, so concurrent comparisons of one scene wait for a
    /// single render instead of each starting its own.
    scene_locks: std::sync::Mutex<HashMap<String, Arc<tokio::sync::Mutex<()>>>>,
    /// Set when comparisons are left to render workers
    /// (`serve --renders workers`, [`super::handoff`]).
    workers: Option<Arc<WorkerQueue>>,
    runtime: Handle,
}

impl Comparisons {
    /// Comparisons rendered by `runner` (its catalogue, settings and
    /// observer), or queued for render workers when `workers` is given.
    /// Call it on the runtime the background comparisons should run on.
    pub fn new(
        store: Store,
        runner: Arc<RenderRunner>,
        events: EventSink,
        workers: Option<Arc<WorkerQueue>>,
    ) -> Comparisons {
        Comparisons {
            store,
            runner,
            events,
            compare_lock: tokio::sync::Mutex::new(()),
            scene_locks: Default::default(),
            workers,
            runtime: Handle::current(),
        }
    }

    /// After a measurement of a scene target completes: compares it as what
    /// it is ([`Comparable`]), in its observer, in the background: a colour
    /// ([`Self::compare_later`]) or a luminance alone
    /// ([`Self::compare_luminance_later`]).
    pub fn compare_measurement_later(
        self: &Arc<Self>,
        measurement_id: i64,
        scene: String,
        target: String,
        measured: Comparable,
    ) {
        match measured {
            Comparable::Colour { xyz, y_se, observer } => {
                self.compare_later(measurement_id, scene, target, xyz, y_se, observer)
            }
            Comparable::Luminance { y, y_se, observer } => {
                self.compare_luminance_later(measurement_id, scene, target, y, y_se, observer)
            }
        }
    }

    /// Compares, one after the other in the background, every complete
    /// measurement of a scene target taken in `booth` that has no
    /// comparison and none queued (see the module doc), logging each and
    /// how many; returns how many it took up. A measurement that cannot be
    /// compared (a scene this daemon does not have, no colour) is logged
    /// with the reason and left.
    pub async fn compare_left_over(self: &Arc<Self>, booth: &Booth) -> anyhow::Result<usize> {
        let mut left = Vec::new();
        for id in self.store.uncompared_measurements(booth).await? {
            let Some(m) = self.store.get_measurement(id).await? else {
                continue;
            };
            let (Some(scene), Some(target)) = (m.summary.scene.clone(), m.summary.target.clone()) else {
                continue;
            };
            if self.runner.catalogue().get(&scene).is_none() {
                tracing::warn!(
                    measurement_id = id,
                    scene,
                    "left uncompared: this daemon has no such scene"
                );
                continue;
            }
            match stored_comparable(&m, self.runner.observer()) {
                Ok(measured) => left.push((id, scene, target, measured)),
                Err(e) => tracing::warn!(measurement_id = id, error = %e, "left uncompared"),
            }
        }
        let n = left.len();
        if n == 0 {
            return Ok(0);
        }
        tracing::info!(
            measurements = n,
            %booth,
            "comparing the complete measurements left uncompared (taken while no comparison could be made)"
        );
        let this = Arc::clone(self);
        self.runtime.spawn(async move {
            for (id, scene, target, measured) in left {
                tracing::info!(measurement_id = id, scene, target, observer = %measured.observer(), "comparing a measurement left uncompared");
                let done = match measured {
                    Comparable::Colour { xyz, y_se, observer } => match &this.workers {
                        Some(workers) => workers
                            .queue_comparison(id, &scene, &target, xyz, y_se, observer)
                            .await
                            .map(drop)
                            .map_err(anyhow::Error::from),
                        None => this.compare(id, &scene, &target, xyz, y_se, observer).await,
                    },
                    Comparable::Luminance { y, y_se, observer } => {
                        this.compare_luminance(id, &scene, &target, y, y_se, observer).await
                    }
                };
                if let Err(e) = done {
                    tracing::error!(measurement_id = id, scene, target, error = %e, "comparison failed");
                }
            }
        });
        Ok(n)
    }

    /// After a measurement of a scene target completes: render (or reuse a
    /// render of) the scene and store the comparison, in the background —
    /// or queue it for the render workers. `measured` is XYZ in `observer`,
    /// `measured_y_se` the standard error of its Y.
    pub fn compare_later(
        self: &Arc<Self>,
        measurement_id: i64,
        scene: String,
        target: String,
        measured: Xyz,
        measured_y_se: f64,
        observer: Observer,
    ) {
        let this = Arc::clone(self);
        self.runtime.spawn(async move {
            if let Some(workers) = &this.workers {
                match workers
                    .queue_comparison(measurement_id, &scene, &target, measured, measured_y_se, observer)
                    .await
                {
                    Ok(_) => return,
                    // Nothing is lost: the daemon compares it itself.
                    Err(e) => tracing::error!(measurement_id, error = %e, "cannot queue the comparison for the render workers; comparing here"),
                }
            }
            if let Err(e) = this
                .compare(measurement_id, &scene, &target, measured, measured_y_se, observer)
                .await
            {
                tracing::error!(measurement_id, scene, target, error = %e, "comparison failed");
            }
        });
    }

    /// Compares measurement `measurement_id` of `scene`/`target` (XYZ
    /// `measured` in `observer`, `measured_y_se` the standard error of its
    /// Y) with every coding, rendering the scene if no render of it with the
    /// comparison settings in `observer` is stored, and stores the rows.
    pub async fn compare(
        &self,
        measurement_id: i64,
        scene: &str,
        target: &str,
        measured: Xyz,
        measured_y_se: f64,
        observer: Observer,
    ) -> anyhow::Result<()> {
        let (render_id, rendered) = self.rendered_target(scene, target, observer).await?;
        let _serial = self.compare_lock.lock().await;
        // The white is the one of the booth this measurement was taken in.
        let booth = self
            .store
            .measurement_booth(measurement_id)
            .await?
            .ok_or_else(|| anyhow::anyhow!("no measurement {measurement_id}"))?;
        let (white, white_source) = self.white_xyz(scene, &booth, observer).await?;
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
        tracing::info!(measurement_id, scene, target, codings = rows.len(), %observer, white = %white_source, "comparison stored");
        // This measurement may be the white of this and other scenes: bring
        // every comparison of those scenes to the current white.
        let dependent: Vec<String> = self
            .runner
            .catalogue()
            .whitened_by(scene, target)
            .into_iter()
            .map(str::to_string)
            .collect();
        for other in dependent {
            self.refresh_white(&other, &booth, observer).await?;
        }
        self.events.send(Event::ComparisonReady {
            measurement_id,
            scene: scene.to_string(),
            target: target.to_string(),
        });
        Ok(())
    }

    /// After a luminance meter's measurement of a scene target completes:
    /// compare its luminance with every coding, in the background.
    pub fn compare_luminance_later(
        self: &Arc<Self>,
        measurement_id: i64,
        scene: String,
        target: String,
        measured_y: f64,
        measured_y_se: f64,
        observer: Observer,
    ) {
        let this = Arc::clone(self);
        self.runtime.spawn(async move {
            if let Err(e) = this
                .compare_luminance(measurement_id, &scene, &target, measured_y, measured_y_se, observer)
                .await
            {
                tracing::error!(measurement_id, scene, target, error = %e, "luminance comparison failed");
            }
        });
    }

    /// Compares a luminance meter's measurement `measurement_id` of
    /// `scene`/`target` (luminance `measured_y`, cd/m², weighted by
    /// `observer`'s ȳ, the meter's V(λ); `measured_y_se` its standard error)
    /// with every coding of the scene's render in `observer`, in luminance
    /// alone, and stores
    /// the rows. No white is involved: the luminance ratio needs none, and
    /// x, y and ΔE need a colour the meter does not give. Render workers do
    /// not take these: the daemon renders, or reuses the stored render.
    pub async fn compare_luminance(
        &self,
        measurement_id: i64,
        scene: &str,
        target: &str,
        measured_y: f64,
        measured_y_se: f64,
        observer: Observer,
    ) -> anyhow::Result<()> {
        let (render_id, rendered) = self.rendered_target(scene, target, observer).await?;
        let rows: Vec<NewLuminanceComparison> = rendered
            .into_iter()
            .map(|(coding, rendered, y_se)| NewLuminanceComparison {
                measurement_id,
                render_id,
                scene: scene.to_string(),
                target: target.to_string(),
                coding,
                observer,
                measured_y,
                measured_y_se,
                rendered_y: rendered.y,
                rendered_y_se: y_se,
                y_ratio: rendered.y / measured_y,
            })
            .collect();
        self.store.insert_luminance_comparisons(&rows).await?;
        tracing::info!(
            measurement_id,
            scene,
            target,
            codings = rows.len(),
            %observer,
            "luminance comparison stored"
        );
        self.events.send(Event::ComparisonReady {
            measurement_id,
            scene: scene.to_string(),
            target: target.to_string(),
        });
        Ok(())
    }

    /// Recomputes every comparison of `scene` in `booth` in `observer`
    /// whose white is not the booth's current one for the scene: ΔE from
    /// the stored XYZ with the current white. Other booths' comparisons
    /// keep their own booth's white. The caller holds `compare_lock`.
    async fn refresh_white(&self, scene: &str, booth: &Booth, observer: Observer) -> anyhow::Result<()> {
        let (white, source) = self.white_xyz(scene, booth, observer).await?;
        let updates: Vec<(i64, String, [f64; 3], f64, f64)> = self
            .store
            .comparisons_of_scene_in_booth(scene, booth)
            .await?
            .into_iter()
            .filter(|r| r.observer == observer)
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

    /// The CIELAB white of `scene` in `booth` in `observer` now, and where
    /// it came from (see the module doc): a white target's newest complete
    /// measurement taken in that booth, never another booth's; else the
    /// white target in a complete render at the comparison settings in
    /// `observer`. It never renders: it
    /// answers a GET (the viewer's ΔE00 map), and rendering CYLINDER for its
    /// white there once held a request for 45 s. With neither, it is a
    /// conflict that says what to measure or render.
    pub async fn white_xyz(&self, scene: &str, booth: &Booth, observer: Observer) -> Result<(Xyz, String), LabError> {
        let internal = |e: &dyn std::fmt::Display| LabError::Internal(format!("the CIELAB white of `{scene}`: {e}"));
        let entry = self
            .runner
            .catalogue()
            .get(scene)
            .ok_or_else(|| LabError::NotFound(format!("no scene `{scene}`")))?;
        // Not measured in the booth: the latest render at the comparison
        // settings, never one rendered for this.
        let latest_render = async |white_scene: &str, _: &Path, target: &str| {
            let hash = self
                .runner
                .catalogue()
                .get(white_scene)
                .ok_or_else(|| LabError::NotFound(format!("no scene `{white_scene}`")))?
                .hash
                .clone();
            let settings =
                serde_json::to_value(self.runner.comparison_settings_in(observer)).map_err(|e| internal(&e))?;
            let Some((render_id, result)) = self.store.find_render_result(&hash, &settings).await? else {
                return Err(LabError::Conflict(format!(
                    "the CIELAB white of `{scene}` is {white_scene}/{target}, which is not measured in booth {booth} \
                     and not yet rendered with the daemon's settings: measure it, or render `{white_scene}` with no \
                     options (POST /api/scenes/{white_scene}/renders with {{}}), then ask again"
                )));
            };
            let (_, xyz, _) = StoredRenderResult::parse(render_id, &result)
                .map_err(|e| internal(&e))?
                .codings(target)
                .and_then(|codings| codings.into_iter().find(|(c, _, _)| c == "spectral"))
                .ok_or_else(|| {
                    internal(&format!(
                        "render {render_id} has no spectral rendering of {white_scene}/{target}"
                    ))
                })?;
            Ok::<_, LabError>(RenderedWhite::Render { render_id, xyz })
        };
        // The catalogue's computed whites are in the runner's observer.
        let white = if observer == self.runner.observer() {
            entry.white.clone()
        } else {
            lightbooth_render::load_scene(&entry.path)
                .map_err(|e| e.to_string())
                .and_then(|scene| white::scene_white(&entry.path, &scene, observer))
                .map_err(|e| internal(&e))?
        };
        resolve_white(&white, Some((&self.store, booth)), observer, latest_render)
            .await
            .map_err(|e| e.into_error(|m| internal(&m)))
    }

    /// The render of `scene` comparisons in `observer` use
    /// ([`Self::render_for_comparison`]) and every coding's XYZ and standard
    /// error of Y at `target` in it.
    async fn rendered_target(
        &self,
        scene: &str,
        target: &str,
        observer: Observer,
    ) -> anyhow::Result<(i64, Vec<(String, Xyz, f64)>)> {
        let (render_id, result) = self.render_for_comparison(scene, observer).await?;
        let rendered = StoredRenderResult::parse(render_id, &result)
            .map_err(anyhow::Error::msg)?
            .codings(target)
            .ok_or_else(|| anyhow::anyhow!("the render of {scene} has no target {target}"))?;
        Ok((render_id, rendered))
    }

    /// The render comparisons in `observer` use: reused when the store has
    /// one of the same scene content and settings, rendered (once, even
    /// under concurrent requests) otherwise. Returns the render id and its
    /// stored JSON result.
    async fn render_for_comparison(&self, scene: &str, observer: Observer) -> anyhow::Result<(i64, serde_json::Value)> {
        let lock = {
            let mut locks = self.scene_locks.lock().unwrap_or_else(|p| p.into_inner());
            Arc::clone(locks.entry(scene.to_string()).or_default())
        };
        let _guard = lock.lock().await;
        let settings = self.runner.comparison_settings_in(observer);
        let hash = self
            .runner
            .catalogue()
            .get(scene)
            .ok_or_else(|| anyhow::anyhow!("no scene `{scene}`"))?
            .hash
            .clone();
        let settings_json = serde_json::to_value(&settings)?;
        let shutdown = self.runner.shutdown_flag();
        loop {
            if let Some(found) = self.store.find_render_result(&hash, &settings_json).await? {
                return Ok(found);
            }
            // Another process (a render worker, a neighbour daemon) is
            // rendering exactly this: wait for it rather than render twice.
            // A running render always ends — done, failed, or interrupted
            // by lease recovery when its process is gone.
            match self.store.running_render_of(&hash, &settings_json).await? {
                Some(other) if !shutdown.is_cancelled() => {
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
        let id = self.runner.record(scene, &settings).await?;
        self.runner.execute(id, scene, settings, shutdown).await?;
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
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{drain, queued_measurement, runner, store_in};
    use lightbooth_science::colorimetry::Observer;
    use tokio_util::sync::CancellationToken;

    /// WHITE rendered at the comparison settings (the render comparisons
    /// and the ΔE map's white reuse); its id.
    async fn render_white(runner: &RenderRunner) -> i64 {
        let settings = runner.comparison_settings();
        let render_id = runner.record("white", &settings).await.unwrap();
        runner
            .execute(render_id, "white", settings, CancellationToken::new())
            .await
            .unwrap();
        render_id
    }

    /// A measurement of `scene`/`target` in the default booth, as queued.
    async fn measurement_of(store: &Store, scene: &str, target: &str) -> i64 {
        queued_measurement(store, Some((scene, target))).await
    }

    /// Regression: the viewer's ΔE00 map (a GET) asked for the white of a
    /// scene whose white was neither measured nor rendered, and rendered the
    /// whole scene first (45 s for CYLINDER on a busy machine). Now it says
    /// what to do; once the scene is rendered at the comparison settings,
    /// that render's spectral white answers, and nothing new is rendered.
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn the_white_for_a_delta_e_map_is_never_rendered_on_the_request() {
        let dir = tempfile::tempdir().unwrap();
        let store = store_in(dir.path()).await;
        let (runner, _) = runner(&store);
        let comparisons = Comparisons::new(store.clone(), Arc::clone(&runner), EventSink::nowhere(), None);
        match comparisons
            .white_xyz("white", &Booth::default(), Observer::JuddVos)
            .await
        {
            Err(LabError::Conflict(m)) => assert!(
                m.contains("white/patch") && m.contains("POST /api/scenes/white/renders"),
                "{m}"
            ),
            other => panic!("expected a conflict naming what to do, got {other:?}"),
        }
        assert!(
            store.list_renders(Some("white")).await.unwrap().is_empty(),
            "nothing was rendered"
        );
        let render_id = render_white(&runner).await;
        let (_, source) = comparisons
            .white_xyz("white", &Booth::default(), Observer::JuddVos)
            .await
            .unwrap();
        assert_eq!(
            source,
            format!("render {render_id} spectral (white/patch; not yet measured)")
        );
        assert_eq!(store.list_renders(Some("white")).await.unwrap().len(), 1);
    }

    /// A measurement 10 % brighter than the spectral rendering of WHITE's
    /// Spectralon, of the same chromaticity, compared while the Spectralon
    /// is unmeasured: the white is that rendering, so CIELAB gives
    /// L* = 116·1.1^(1/3) − 16 against L* = 100, a* = b* = 0 for both
    /// (CIE 15:2004, §8.2.1), and ΔE*ab = 116·(1.1^(1/3) − 1) = 3.7445.
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_measurement_brighter_than_the_unmeasured_white_has_the_analytic_delta_e() {
        let dir = tempfile::tempdir().unwrap();
        let store = store_in(dir.path()).await;
        let (runner, mut events) = runner(&store);
        // The render the comparison will reuse (same scene content and settings).
        let render_id = render_white(&runner).await;
        let result = store.get_render(render_id).await.unwrap().unwrap().result.unwrap();
        let (_, spectral, _) = StoredRenderResult::parse(render_id, &result)
            .unwrap()
            .codings("patch")
            .unwrap()
            .into_iter()
            .find(|(c, _, _)| c == "spectral")
            .unwrap();
        let measured = Xyz::new(1.1 * spectral.x, 1.1 * spectral.y, 1.1 * spectral.z);
        let id = measurement_of(&store, "white", "patch").await;
        let comparisons = Comparisons::new(store.clone(), Arc::clone(&runner), EventSink::nowhere(), None);
        comparisons
            .compare(id, "white", "patch", measured, 0.01, Observer::JuddVos)
            .await
            .unwrap();

        assert_eq!(
            store.list_renders(Some("white")).await.unwrap().len(),
            1,
            "the render was reused"
        );
        let rows = store.latest_comparisons("white").await.unwrap();
        let codings: Vec<&str> = rows.iter().map(|r| r.coding.as_str()).collect();
        assert_eq!(codings.len(), 2, "{codings:?}");
        let row = rows.iter().find(|r| r.coding == "spectral").unwrap();
        assert_eq!(
            row.white_source,
            format!("render {render_id} spectral (white/patch; not yet measured)")
        );
        assert_eq!([row.white_X, row.white_Y, row.white_Z], spectral.to_array());
        assert!((row.Y_ratio - 1.0 / 1.1).abs() < 1e-12, "{}", row.Y_ratio);
        let expected = 116.0 * (1.1f64.cbrt() - 1.0);
        assert!(
            (row.dE76 - expected).abs() < 1e-9,
            "ΔE*ab {} against {expected}",
            row.dE76
        );
        assert!(row.xy_distance < 1e-12, "{}", row.xy_distance);
        assert_eq!(row.observer, Observer::JuddVos);
        // The render's own events; the comparison's went nowhere.
        assert!(!drain(&mut events).iter().any(|e| e.name() == "comparison_ready"));

        // Summarised: one point per coding, rms_rel = |1 − Y ratio|.
        let summary = summary::scene_comparisons(&store, "white", Observer::JuddVos)
            .await
            .unwrap();
        let spectral_summary = summary.codings.iter().find(|c| c.coding == "spectral").unwrap();
        assert_eq!(spectral_summary.summary.points, 1);
        assert!((spectral_summary.summary.rms_rel - (1.0 - 1.0 / 1.1)).abs() < 1e-12);
        assert!((spectral_summary.mean_y_ratio - 1.0 / 1.1).abs() < 1e-12);
        assert_eq!(summary.codings[0].coding, "rgb");
        // Another observer's summary has none of these rows.
        let other = summary::scene_comparisons(&store, "white", Observer::Cie1931)
            .await
            .unwrap();
        assert!(other.rows.is_empty() && other.codings.is_empty());
    }

    /// A luminance meter's measurement (issue 33): its Y is comparable in
    /// the observer whose ȳ is its V(λ) only, a colorimeter's is not a
    /// luminance-only one, and the rows are the luminance ratio alone.
    /// Truth: a measured Y 10 % above the spectral rendering's gives the
    /// ratio 1/1.1 exactly; with a standard error of 1 % of Y on the
    /// measurement the difference (9.1 % of the rendered Y) is beyond
    /// 3 · √(SE_S² + SE_M²) unless the render's own SE is larger.
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_luminance_meters_measurement_is_compared_in_luminance_alone() {
        use crate::measure::recorder::comparable_luminance;
        use lightbooth_instrument::{average_samples, InstrumentInfo, Reading, Sample};
        use lightbooth_science::spectrum::Grid;
        let info = InstrumentInfo {
            model: "LS-100".into(),
            serial: None,
            firmware: None,
            grid: Grid::pr650(),
        };
        let sample = |index: usize, y: f64, xyz: Option<[f64; 3]>| Sample {
            index,
            time: std::time::SystemTime::now(),
            code: lightbooth_instrument::pr650::codes::quality_code(0),
            radiance: None,
            luminance: Some(y),
            instrument_xyz: xyz,
        };
        let reading = Reading::Luminance {
            observer: Observer::Cie1931,
        };
        let avg = average_samples(
            info.clone(),
            reading,
            vec![sample(0, 30.0, None), sample(1, 32.0, None)],
        )
        .unwrap();
        assert_eq!(comparable_luminance(&avg), Some((31.0, Observer::Cie1931)));
        // What the daemon hands the comparisons, whatever its own observer:
        // Y = 31 in the meter's CIE 1931 and the standard error of the mean
        // of 30 and 32, s/√n = √2/√2 = 1 cd/m².
        for daemon in [Observer::Cie1931, Observer::JuddVos] {
            match crate::measure::recorder::comparable(&avg, daemon) {
                Ok(crate::measure::recorder::Comparable::Luminance { y, y_se, observer }) => {
                    assert_eq!(y, 31.0);
                    assert!((y_se - 1.0).abs() < 1e-12, "{y_se}");
                    assert_eq!(observer, Observer::Cie1931);
                }
                other => panic!("{other:?}"),
            }
        }
        let colorimeter = Reading::Tristimulus {
            observer: Observer::Cie1931,
        };
        let avg = average_samples(info, colorimeter, vec![sample(0, 30.0, Some([28.0, 30.0, 20.0]))]).unwrap();
        assert_eq!(comparable_luminance(&avg), None);

        let dir = tempfile::tempdir().unwrap();
        let store = store_in(dir.path()).await;
        let (runner, _) = runner(&store);
        let render_id = render_white(&runner).await;
        let result = store.get_render(render_id).await.unwrap().unwrap().result.unwrap();
        let (_, spectral, spectral_se) = StoredRenderResult::parse(render_id, &result)
            .unwrap()
            .codings("patch")
            .unwrap()
            .into_iter()
            .find(|(c, _, _)| c == "spectral")
            .unwrap();
        let id = measurement_of(&store, "white", "patch").await;
        let comparisons = Comparisons::new(store.clone(), Arc::clone(&runner), EventSink::nowhere(), None);
        let measured = 1.1 * spectral.y;
        comparisons
            .compare_luminance(id, "white", "patch", measured, 0.01 * measured, Observer::JuddVos)
            .await
            .unwrap();
        let rows = store.luminance_comparisons_for_measurement(id).await.unwrap();
        assert_eq!(rows.len(), 2, "every coding of the render: {rows:?}");
        let row = rows.iter().find(|r| r.coding == "spectral").unwrap();
        assert_eq!(row.render_id, render_id);
        assert_eq!(row.observer, Observer::JuddVos);
        assert!((row.Y_ratio - 1.0 / 1.1).abs() < 1e-12, "{}", row.Y_ratio);
        assert_eq!(row.measured_Y, measured);
        let combined = 3.0 * spectral_se.hypot(0.01 * measured);
        assert_eq!(row.Y_beyond_noise, measured - spectral.y > combined, "{row:?}");
        assert!(
            store.comparisons_for_measurement(id).await.unwrap().is_empty(),
            "no colour comparison"
        );
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_comparison_of_a_target_the_scene_lacks_stores_nothing_and_says_which() {
        let dir = tempfile::tempdir().unwrap();
        let store = store_in(dir.path()).await;
        let (runner, _) = runner(&store);
        let id = measurement_of(&store, "white", "no_such_target").await;
        let comparisons = Comparisons::new(store.clone(), runner, EventSink::nowhere(), None);
        let err = comparisons
            .compare(
                id,
                "white",
                "no_such_target",
                Xyz::new(1.0, 1.0, 1.0),
                0.01,
                Observer::JuddVos,
            )
            .await
            .unwrap_err()
            .to_string();
        assert_eq!(err, "the render of white has no target no_such_target");
        assert!(store.latest_comparisons("white").await.unwrap().is_empty());
    }
}
