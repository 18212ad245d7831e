//! Running one recorded render: the settings a request asks for (checked
//! against the limits), the render row, the scene's bundle, and the render
//! itself on the rayon pool with progress events and each coding's cost.
//!
//! Every render the lab makes goes through [`RenderRunner`]: a render asked
//! for through the API ([`crate::render::jobs`]), the render a comparison
//! needs ([`crate::compare`]) and a render row a render worker claims
//! (`lightbooth::worker`). It never runs on the async runtime's workers or the
//! instrument thread, and a panic in the renderer fails only its render (a
//! panic on a `rayon::spawn` job would abort the whole process).
//!
//! # The observer
//!
//! The runner's one observer (`serve --observer`) is that of every render's
//! XYZ, x,y and Y.
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

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use crate::error::LabError;
use crate::events::{Event, EventSink};
use crate::jobs::{self, job_end, MAX_RENDER_BOUNCES, MAX_RENDER_SAMPLES};
use crate::requests::RenderRequest;
use crate::scenes::SceneCatalog;
use crate::study::run::COST_DEFINITION;
use lightbooth_render::{self as render, Coding, RenderError, RenderSettings, Scene};
use lightbooth_science::colorimetry::{Observer, Xyz};
use lightbooth_store::{Job, JobEnd, NewRender, Store};
use tokio_util::sync::CancellationToken;

/// Records and runs renders of the catalogue's scenes.
pub struct RenderRunner {
    store: Store,
    catalogue: Arc<SceneCatalog>,
    events: EventSink,
    /// The codings a render has when its request names none.
    codings: Vec<Coding>,
    /// Paths per target when a request does not say.
    samples: u64,
    /// Camera paths of a render's dashboard preview, in all
    /// ([`render::sensor::preview_spp`]).
    preview_paths: u64,
    observer: Observer,
    /// Set at shutdown: stops the renders comparisons run under it, and
    /// makes a stopped render `interrupted` rather than `cancelled`.
    shutdown: CancellationToken,
}

impl RenderRunner {
    /// A runner of `catalogue`'s scenes with the daemon's codings, paths
    /// per target and observer; `shutdown` is the daemon's shutdown flag.
    pub fn new(
        store: Store,
        catalogue: Arc<SceneCatalog>,
        events: EventSink,
        codings: Vec<Coding>,
        samples: u64,
        observer: Observer,
        shutdown: CancellationToken,
    ) -> RenderRunner {
        RenderRunner {
            store,
            catalogue,
            events,
            codings,
            samples,
            preview_paths: render::sensor::PREVIEW_PATH_BUDGET,
            observer,
            shutdown,
        }
    }

    /// The same runner with `paths` camera paths in all for each render's
    /// dashboard preview instead of [`render::sensor::PREVIEW_PATH_BUDGET`]
    /// (the daemon's `preview_paths`).
    pub fn with_preview_paths(mut self, paths: u64) -> RenderRunner {
        self.preview_paths = paths;
        self
    }

    /// The observer of every XYZ, x,y, CIELAB and ΔE.
    pub fn observer(&self) -> Observer {
        self.observer
    }

    /// The scenes it renders.
    pub fn catalogue(&self) -> &Arc<SceneCatalog> {
        &self.catalogue
    }

    /// The daemon's shutdown flag (set by [`RenderRunner::shutdown`]).
    pub fn shutdown_flag(&self) -> CancellationToken {
        self.shutdown.clone()
    }

    /// Stops every render running under the shutdown flag.
    pub fn shutdown(&self) {
        self.shutdown.cancel();
    }

    /// The settings of a render request, each field checked against its
    /// limit ([`LabError::Invalid`] naming the field and the limit).
    pub fn settings(&self, request: &RenderRequest) -> Result<RenderSettings, LabError> {
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
            // The store keeps the seed as a signed 64-bit integer.
            if seed > i64::MAX as u64 {
                return Err(LabError::Invalid(format!("field `seed`: {seed} is above {}", i64::MAX)));
            }
            s.seed = seed;
        }
        Ok(s)
    }

    /// The settings of the renders comparisons use: the daemon's codings
    /// (and `spectral`), paths per target and observer.
    pub fn comparison_settings(&self) -> RenderSettings {
        self.settings(&RenderRequest::default())
            .expect("an empty request names no field to refuse")
    }

    /// The settings of the renders comparisons in `observer` use: the
    /// comparison settings with the spectra weighted by `observer` (a
    /// colorimeter's own, which may not be the runner's).
    pub fn comparison_settings_in(&self, observer: Observer) -> RenderSettings {
        RenderSettings {
            observer,
            ..self.comparison_settings()
        }
    }

    /// How a render or study stopped without a result ends ([`job_end`]
    /// with this runner's shutdown).
    pub fn end_of(&self, job: Job, cancelled: bool, error: Option<String>) -> (JobEnd, String) {
        job_end(job, cancelled, self.shutdown.is_cancelled(), error)
    }

    /// Records a render of the catalogue's scene `scene_id` as queued, after
    /// storing its scene's bundle; returns its id.
    pub async fn record(&self, scene_id: &str, settings: &RenderSettings) -> anyhow::Result<i64> {
        self.record_retrying(scene_id, settings, None)
            .await
            .map_err(|e| anyhow::anyhow!(e))
    }

    /// [`RenderRunner::record`]; with `retry_of`, as the one retry of that
    /// render (a second is [`StoreError::Conflict`](lightbooth_store::StoreError::Conflict)
    /// naming the first, see [`Store::create_render_retrying`]).
    pub async fn record_retrying(
        &self,
        scene_id: &str,
        settings: &RenderSettings,
        retry_of: Option<i64>,
    ) -> Result<i64, LabError> {
        let hash = self
            .catalogue
            .get(scene_id)
            .ok_or_else(|| LabError::NotFound(format!("no scene `{scene_id}`")))?
            .hash
            .clone();
        self.store_bundle(scene_id, &hash).await;
        let settings_json = serde_json::to_value(settings).map_err(|e| LabError::Internal(e.to_string()))?;
        let id = self
            .store
            .create_render_retrying(
                &NewRender {
                    scene: scene_id.to_string(),
                    scene_hash: hash,
                    settings_json,
                    codings: settings.codings.iter().map(|c| c.to_string()).collect(),
                    seed: settings.seed,
                },
                retry_of,
            )
            .await?;
        tracing::info!(render_id = id, scene = scene_id, "render queued");
        Ok(id)
    }

    /// Stores the bundle of the scene `scene_id` (its files, for render
    /// workers without the scenes folder; [`render::bundle`]) unless the
    /// store has it. A scene that cannot be bundled (a reference outside
    /// the scenes folder) or whose files changed since the catalogue loaded
    /// it is logged and still rendered here: the daemon needs no bundle.
    async fn store_bundle(&self, scene_id: &str, hash: &str) {
        let Some(path) = self.catalogue.get(scene_id).map(|e| e.path.clone()) else {
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
                "its files changed since the daemon loaded it (render key {hash}, bundle's {})",
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

    /// Runs the recorded render `id` of the catalogue's scene `scene_id` on
    /// the rayon pool with progress events, then times each coding alone
    /// (same settings) for the speed-against-accuracy chart, and stores the
    /// outcome. `cancel` stops it between batches of paths; a panic fails
    /// it with the panic's message.
    pub async fn execute(
        &self,
        id: i64,
        scene_id: &str,
        settings: RenderSettings,
        cancel: CancellationToken,
    ) -> anyhow::Result<()> {
        let scene = Arc::clone(
            &self
                .catalogue
                .get(scene_id)
                .ok_or_else(|| anyhow::anyhow!("no scene `{scene_id}`"))?
                .scene,
        );
        if !self.store.start_job(Job::Render, id).await? {
            tracing::info!(render_id = id, "render no longer queued (cancelled); not run");
            return Ok(());
        }
        self.events.send(Event::RenderStarted {
            render_id: id,
            scene: scene_id.to_string(),
        });
        tracing::info!(render_id = id, scene = scene_id, "render started");
        let events = self.events.clone();
        let preview_paths = self.preview_paths;
        let (tx, rx) = tokio::sync::oneshot::channel();
        let flag = cancel.clone();
        let panic_scene = jobs::test_panic_requested(scene_id).then(|| scene_id.to_string());
        rayon::spawn(move || {
            let caught = catch_unwind(AssertUnwindSafe(|| {
                if let Some(scene) = &panic_scene {
                    jobs::panic_on_the_pool(scene);
                }
                render_with_timings(id, &scene, &settings, preview_paths, &events, &flag).and_then(|done| {
                    // Cancelled while the codings were timed: the timings are incomplete.
                    if flag.is_cancelled() {
                        Err(RenderError::Cancelled)
                    } else {
                        Ok(done)
                    }
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
            Ok(output) => {
                let mut json = serde_json::to_value(&output.result)?;
                json["coding_seconds"] = serde_json::Value::Object(output.coding_seconds);
                json["coding_cost"] = serde_json::Value::Object(output.coding_cost);
                json["cost_definition"] = COST_DEFINITION.into();
                if let Some((png, log_average)) = output.preview {
                    self.store.set_render_preview(id, &png).await?;
                    // What a page needs to put a cd/m² scale beside it.
                    json["preview"] = serde_json::json!({
                        "coding": "srgb",
                        "log_average_cd_m2": log_average,
                        "tone_map": PREVIEW_TONE_MAP,
                    });
                }
                let wall_seconds = output.result.wall_seconds;
                self.store.finish_render(id, Ok((&json, wall_seconds))).await?;
                tracing::info!(render_id = id, wall_seconds, "render complete");
                (true, None)
            }
            Err(error) => {
                let (end, message) = self.end_of(Job::Render, error.is_none(), error);
                self.store.end_job(Job::Render, id, end, &message).await?;
                tracing::warn!(render_id = id, state = end.as_str(), error = %message, "render did not complete");
                (false, Some(message))
            }
        };
        self.events.send(Event::RenderFinished {
            render_id: id,
            scene: scene_id.into(),
            ok,
            error,
        });
        Ok(())
    }

    /// Runs the queued render row `id` (another daemon's, for a render
    /// worker) under `cancel`. Its scene must be the content the row was
    /// recorded for (same render key), else the row fails saying so.
    pub async fn run_row(&self, id: i64, cancel: CancellationToken) -> anyhow::Result<()> {
        let row = self
            .store
            .get_render(id)
            .await?
            .ok_or_else(|| anyhow::anyhow!("no render {id}"))?;
        let settings: RenderSettings = serde_json::from_value(row.settings.clone())
            .map_err(|e| anyhow::anyhow!("render {id}'s stored settings: {e}"))?;
        let entry = self
            .catalogue
            .get(&row.scene)
            .ok_or_else(|| anyhow::anyhow!("render {id}'s scene `{}` is not among its daemon's scenes", row.scene))?;
        if entry.hash != row.scene_hash {
            let why = format!(
                "the scene `{}` this worker fetched has render key {}, not the render's {}: \
                 its daemon's scene files changed since; render it again",
                row.scene, entry.hash, row.scene_hash
            );
            self.store.end_job(Job::Render, id, JobEnd::Failed, &why).await?;
            anyhow::bail!(why);
        }
        self.execute(id, &row.scene, settings, cancel).await
    }
}

/// What a render stores besides its result: each coding's time alone and
/// the camera preview.
/// How the preview's pixels show luminance (see `render::sensor::Image`).
const PREVIEW_TONE_MAP: &str = "global Reinhard: a grey of Y cd/m² is shown at the linear display value \
     d = Yk/(1 + Yk), k = 0.18 / the log-average luminance, then sRGB-encoded";

struct RenderOutput {
    result: render::RenderResult,
    /// The median seconds of each coding rendered alone.
    coding_seconds: serde_json::Map<String, serde_json::Value>,
    /// Each coding's paths, rays, median and spread of its timed repeats.
    coding_cost: serde_json::Map<String, serde_json::Value>,
    /// The camera view as PNG, when the scene has a camera, and its
    /// log-average luminance (cd/m², the tone map's key).
    preview: Option<(Vec<u8>, f64)>,
}

/// What comparisons read of a stored render result: the JSON
/// [`RenderRunner::execute`] stores in the render row — a
/// [`render::RenderResult`] serialized (`targets[]`, each with its `id` and
/// its `codings` as a map of coding name to [`render::CodingResult`]), plus
/// `coding_seconds`, `coding_cost`, `cost_definition` and `preview` — of
/// which this reads every target's codings' `XYZ` and `Y_se` only.
/// `RenderResult` is written from lists and `&'static str`s and is never
/// read back, so this is a view of exactly the fields needed.
#[derive(Debug, serde::Deserialize)]
pub(crate) struct StoredRenderResult {
    targets: Vec<StoredTarget>,
}

#[derive(Debug, serde::Deserialize)]
struct StoredTarget {
    id: String,
    /// By coding name, in name order (as `serde_json::Map` gave them).
    codings: std::collections::BTreeMap<String, StoredCoding>,
}

#[derive(Debug, serde::Deserialize)]
struct StoredCoding {
    #[serde(rename = "XYZ")]
    xyz: [f64; 3],
    #[serde(rename = "Y_se")]
    y_se: f64,
}

impl StoredRenderResult {
    /// The stored result `json` of render `render_id`; an error naming the
    /// render when the JSON is not that of a render result.
    pub(crate) fn parse(render_id: i64, json: &serde_json::Value) -> Result<Self, String> {
        use serde::Deserialize;
        Self::deserialize(json)
            .map_err(|e| format!("render {render_id}: its stored result is not a render result's JSON: {e}"))
    }

    /// Every coding's XYZ and standard error of Y (cd/m²) at `target`, in
    /// the one coding order ([`lightbooth_render::coding_order`]); `None`
    /// when the render has no target `target`.
    pub(crate) fn codings(&self, target: &str) -> Option<Vec<(String, Xyz, f64)>> {
        let t = self.targets.iter().find(|t| t.id == target)?;
        let mut codings: Vec<(String, Xyz, f64)> = t
            .codings
            .iter()
            .map(|(name, c)| (name.clone(), Xyz::from_array(c.xyz), c.y_se))
            .collect();
        codings.sort_by_key(|(name, _, _)| lightbooth_render::coding_order(name));
        Some(codings)
    }
}

/// A render with progress events, then each coding timed alone (same
/// settings) and the camera preview, each stopped by `cancel`. Runs on the
/// rayon pool.
fn render_with_timings(
    id: i64,
    scene: &Scene,
    settings: &RenderSettings,
    preview_paths: u64,
    events: &EventSink,
    cancel: &CancellationToken,
) -> Result<RenderOutput, RenderError> {
    // Each step reports its own progress (`lab::progress::RENDER_STEPS`).
    let [tracing, timing, preview_step] = crate::progress::RENDER_STEPS.map(|(step, _)| step);
    let last = std::sync::Mutex::new(Instant::now());
    let report = |step: &str, done: u64, total: u64| {
        let mut last = last.lock().unwrap_or_else(|p| p.into_inner());
        if last.elapsed().as_millis() >= 200 || done == 0 || done == total {
            *last = Instant::now();
            events.send(Event::RenderProgress {
                render_id: id,
                done,
                total,
                step: step.to_string(),
            });
        }
    };
    let progress = |done: u64, total: u64| report(tracing, done, total);
    let result = render::render(scene, settings, Some(&progress), Some(cancel))?;
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
    let timing_progress = |done: u64, total: u64| report(timing, done, total);
    match render::cost::time_renders_reporting(
        scene,
        &alone,
        render::cost::TIMING_REPEATS,
        &timing_progress,
        Some(cancel),
    ) {
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
    if scene.camera.is_some() {
        report(preview_step, 0, 0);
    }
    let preview = scene.camera.as_ref().and_then(|camera| {
        let transport = settings.transport();
        render::sensor::render_camera(
            scene,
            camera,
            Coding::Srgb,
            render::sensor::preview_spp(camera, preview_paths),
            &transport,
            settings.seed,
            Some(cancel),
        )
        .and_then(|img| Ok((img.png()?, img.log_average_luminance())))
        .map_err(|e| tracing::warn!(render_id = id, error = %e, "no preview image"))
        .ok()
    });
    Ok(RenderOutput {
        result,
        coding_seconds,
        coding_cost,
        preview,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A stored result is read by its fields; one that is not a render
    /// result's JSON is an error naming the render, not "no such target".
    #[test]
    fn a_stored_result_is_read_typed_and_a_malformed_one_names_its_render() {
        let stored = serde_json::json!({
            "targets": [{"id": "patch", "paths": 4, "codings": {
                "spectral": {"XYZ": [1.0, 2.0, 3.0], "Y_se": 0.5, "Y": 2.0},
                "rgb": {"XYZ": [4.0, 5.0, 6.0], "Y_se": 0.25},
            }}],
            "coding_seconds": {},
        });
        let r = StoredRenderResult::parse(7, &stored).unwrap();
        assert_eq!(
            r.codings("patch").unwrap(),
            vec![
                ("rgb".to_string(), Xyz::new(4.0, 5.0, 6.0), 0.25),
                ("spectral".to_string(), Xyz::new(1.0, 2.0, 3.0), 0.5),
            ]
        );
        assert_eq!(r.codings("h21"), None);
        let malformed =
            serde_json::json!({"targets": [{"id": "patch", "codings": {"spectral": {"XYZ": [1.0, 2.0, 3.0]}}}]});
        let e = StoredRenderResult::parse(7, &malformed).unwrap_err();
        assert!(e.starts_with("render 7: ") && e.contains("Y_se"), "{e}");
    }
    use crate::testing::{drain, runner, store_in, TEST_SAMPLES};

    fn request(codings: Option<&str>, samples: Option<u32>, bounces: Option<u32>) -> RenderRequest {
        RenderRequest {
            codings: codings.map(str::to_string),
            samples,
            bounces,
            ..RenderRequest::default()
        }
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn each_render_setting_out_of_its_limit_is_refused_naming_the_field() {
        let dir = tempfile::tempdir().unwrap();
        let (runner, _) = runner(&store_in(dir.path()).await);
        let refused = |r: RenderRequest| match runner.settings(&r) {
            Err(LabError::Invalid(m)) => m,
            other => panic!("expected a refusal, got {other:?}"),
        };
        assert!(refused(request(Some("rgb,cmyk"), None, None)).starts_with("field `codings`"));
        assert!(refused(request(Some("rgb,rgb"), None, None)).contains("named twice"));
        assert!(refused(request(None, Some(1), None)).starts_with("field `samples`: 1 is outside"));
        assert!(refused(request(None, Some(MAX_RENDER_SAMPLES + 1), None)).starts_with("field `samples`"));
        assert!(refused(request(None, None, Some(MAX_RENDER_BOUNCES + 1))).starts_with("field `bounces`"));
        let seeded = |seed: u64| RenderRequest {
            seed: Some(seed),
            ..RenderRequest::default()
        };
        // Regression: a seed of 2^63 was accepted and stored as a negative number.
        assert!(refused(seeded(1 << 63)).starts_with("field `seed`"));
        assert_eq!(runner.settings(&seeded(i64::MAX as u64)).unwrap().seed, i64::MAX as u64);
        // No request: the daemon's codings and `spectral` (the white may
        // come from it), its paths, no bounce cap (unbiased).
        let default = runner.comparison_settings();
        assert_eq!(default.codings, [Coding::Rgb, Coding::Spectral]);
        assert_eq!(default.samples, TEST_SAMPLES);
        assert_eq!(default.max_bounces, None);
        let capped = runner.settings(&request(Some("srgb"), Some(10), Some(5))).unwrap();
        assert_eq!(
            (capped.codings.as_slice(), capped.samples, capped.max_bounces),
            (&[Coding::Srgb][..], 10, Some(5))
        );
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_recorded_render_completes_with_every_codings_cost_and_says_so_in_events() {
        let dir = tempfile::tempdir().unwrap();
        let store = store_in(dir.path()).await;
        let (runner, mut events) = runner(&store);
        let settings = runner.comparison_settings();
        let id = runner.record("white", &settings).await.unwrap();
        let row = store.get_render(id).await.unwrap().unwrap();
        assert_eq!(row.state, "queued");
        assert_eq!(row.scene_hash, runner.catalogue().get("white").unwrap().hash);
        runner
            .execute(id, "white", settings, CancellationToken::new())
            .await
            .unwrap();
        let row = store.get_render(id).await.unwrap().unwrap();
        assert_eq!(row.state, "complete", "{:?}", row.error);
        let result = row.result.unwrap();
        for coding in ["rgb", "spectral"] {
            let cost = &result["coding_cost"][coding];
            assert!(
                cost["wall_seconds"].as_f64().is_some_and(|s| s > 0.0),
                "{coding}: {cost}"
            );
            assert!(result["coding_seconds"][coding].as_f64().is_some(), "{coding}");
        }
        assert_eq!(result["cost_definition"], COST_DEFINITION);
        let names: Vec<&str> = drain(&mut events).iter().map(Event::name).collect::<Vec<_>>();
        assert_eq!(names.first(), Some(&"render_started"), "{names:?}");
        assert_eq!(names.last(), Some(&"render_finished"), "{names:?}");
        assert!(names.contains(&"render_progress"), "{names:?}");
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_render_stopped_by_a_client_is_cancelled_and_by_the_shutdown_interrupted() {
        let dir = tempfile::tempdir().unwrap();
        let store = store_in(dir.path()).await;
        let (runner, _) = runner(&store);
        let settings = runner.comparison_settings();
        let stopped = CancellationToken::new();
        stopped.cancel();
        let by_client = runner.record("white", &settings).await.unwrap();
        runner
            .execute(by_client, "white", settings.clone(), stopped.clone())
            .await
            .unwrap();
        let row = store.get_render(by_client).await.unwrap().unwrap();
        assert_eq!(
            (row.state.as_str(), row.error.as_deref()),
            ("cancelled", Some("cancelled by a client"))
        );
        runner.shutdown();
        let by_shutdown = runner.record("white", &settings).await.unwrap();
        runner.execute(by_shutdown, "white", settings, stopped).await.unwrap();
        let row = store.get_render(by_shutdown).await.unwrap().unwrap();
        assert_eq!(row.state, "interrupted");
        assert!(row
            .error
            .unwrap()
            .contains("retry it with POST /api/renders/{id}/retry"));
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_render_row_of_other_scene_content_fails_naming_both_render_keys() {
        let dir = tempfile::tempdir().unwrap();
        let store = store_in(dir.path()).await;
        let (runner, _) = runner(&store);
        let settings = runner.comparison_settings();
        let id = store
            .create_render(&NewRender {
                scene: "white".into(),
                scene_hash: "0123456789abcdef".into(),
                settings_json: serde_json::to_value(&settings).unwrap(),
                codings: settings.codings.iter().map(|c| c.to_string()).collect(),
                seed: settings.seed,
            })
            .await
            .unwrap();
        let err = runner
            .run_row(id, CancellationToken::new())
            .await
            .unwrap_err()
            .to_string();
        let ours = &runner.catalogue().get("white").unwrap().hash;
        assert!(err.contains("0123456789abcdef") && err.contains(ours.as_str()), "{err}");
        let row = store.get_render(id).await.unwrap().unwrap();
        assert_eq!(row.state, "failed");
        assert_eq!(row.error.as_deref(), Some(err.as_str()));
    }
}
