//! The renderer as the daemon runs it: scenes from `scenes/`, renders on the
//! rayon pool (never on the async runtime or the instrument thread), one
//! render per scene content and settings (reused from the store), and the
//! comparison of each measurement with every coding.
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
//! white is the newest complete *measurement* of that target; until one
//! exists, the `spectral` rendering of it stands in, and the row says so
//! (`white_source`, with the white's XYZ).
//!
//! When a white's source changes — its target is measured for the first time
//! or again — every comparison of every scene using it is recomputed with the
//! new white (ΔE from the stored XYZ; the measured and rendered XYZ do not
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
//! # Cost per coding
//!
//! After a render, each coding is rendered alone with a *fixed* number of
//! paths per target (the render's `samples`, no adaptive stop, as the CLI's
//! `--time-each-coding` and the study's sweeps): `coding_cost` in the stored
//! result gives its paths, rays traced (the cost that does not jitter with
//! machine load) and wall time; `coding_seconds` keeps the wall time alone.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use tokio::runtime::Handle;
use tokio::sync::broadcast;

use crate::colorimetry::{xyz_from_radiance, Lab, Observer, Xyz};
use crate::comparison::{compare_point, delta_e_pair};
use crate::render::{self, Coding, RenderSettings, Scene};
use crate::service::error::ApiError;
use crate::service::{BoxFuture, Event, RenderRequest, RenderService, SceneInfo, StudyRequest};
use crate::spectrum::{Grid, SpectralUnit, Spectrum};
use crate::store::{NewComparison, NewRender, Store};
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
        let mut scenes = Vec::new();
        let mut paths: Vec<PathBuf> = std::fs::read_dir(&scenes_dir)
            .map_err(|e| anyhow::anyhow!("cannot read the scenes folder {}: {e}", scenes_dir.display()))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|x| x == "toml"))
            .collect();
        paths.sort();
        for path in &paths {
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
        Ok(Renderer {
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
        })
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
        render::converged_target_spectrum(&self.world_path(entry), target, Some(cache_dir)).map_err(|e| e.to_string())
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
            if let Err(e) = this
                .compare(measurement_id, &scene, &target, measured, measured_y_se)
                .await
            {
                tracing::error!(measurement_id, scene, target, error = %e, "comparison failed");
            }
        });
    }

    async fn compare(
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
        let (white, white_source) = self.white_xyz(scene).await?;
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
        let dependent: Vec<String> = self
            .scenes
            .iter()
            .filter(|e| {
                e.id == scene
                    || render::load_scene(&e.path)
                        .ok()
                        .and_then(|s| scene_white(&e.path, &s, observer).ok())
                        .is_some_and(|w| w.is_target(scene, target))
            })
            .map(|e| e.id.clone())
            .collect();
        for other in dependent {
            self.refresh_white(&other).await?;
        }
        let _ = self.events.send(Event::ComparisonReady {
            measurement_id,
            scene: scene.to_string(),
            target: target.to_string(),
        });
        Ok(())
    }

    /// Recomputes every comparison of `scene` (of the daemon's observer)
    /// whose white is not the scene's current one: ΔE from the stored XYZ
    /// with the current white. The caller holds `compare_lock`.
    async fn refresh_white(&self, scene: &str) -> anyhow::Result<()> {
        let (white, source) = self.white_xyz(scene).await?;
        let updates: Vec<(i64, String, [f64; 3], f64, f64)> = self
            .store
            .comparisons_of_scene(scene)
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
            tracing::info!(scene, rows = updates.len(), white = %source, "comparisons recomputed with the scene's current white");
        }
        Ok(())
    }

    /// The CIELAB white of `scene` now, and where it came from (see the
    /// module doc).
    async fn white_xyz(&self, scene: &str) -> anyhow::Result<(Xyz, String)> {
        let entry = self.entry(scene).ok_or_else(|| anyhow::anyhow!("no scene `{scene}`"))?;
        let loaded = render::load_scene(&entry.path)?;
        let (white_scene, target) =
            match scene_white(&entry.path, &loaded, self.observer).map_err(anyhow::Error::msg)? {
                SceneWhite::Fixed { xyz, source } => return Ok((xyz, source)),
                SceneWhite::Target { scene_id, target, .. } => (scene_id, target),
            };
        if let Some(m) = self.store.latest_complete(&white_scene, &target).await? {
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

    fn settings(&self, request: &RenderRequest) -> Result<RenderSettings, String> {
        let codings = match &request.codings {
            Some(list) => list
                .split(',')
                .map(|c| c.parse::<Coding>())
                .collect::<Result<Vec<_>, _>>()?,
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
            s.samples = u64::from(n);
        }
        if let Some(b) = request.bounces {
            s.max_bounces = b;
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
        let settings = self.settings(&RenderRequest::default()).map_err(anyhow::Error::msg)?;
        let entry = self.entry(scene).ok_or_else(|| anyhow::anyhow!("no scene `{scene}`"))?;
        let loaded = render::load_scene(&entry.path)?;
        let hash = render::scene_hash(&loaded)?;
        if let Some(found) = self
            .store
            .find_render_result(&hash, &serde_json::to_value(&settings)?)
            .await?
        {
            return Ok(found);
        }
        let id = self.record(scene, &settings, hash).await?;
        self.execute(id, scene, loaded, settings).await?;
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

    /// Records a render about to run; returns its id.
    async fn record(&self, scene_id: &str, settings: &RenderSettings, hash: String) -> anyhow::Result<i64> {
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
        let _ = self.events.send(Event::RenderStarted {
            render_id: id,
            scene: scene_id.to_string(),
        });
        tracing::info!(render_id = id, scene = scene_id, "render started");
        Ok(id)
    }

    /// Runs a recorded render on the rayon pool with progress events, then
    /// times each coding alone (same settings) for the speed-against-accuracy
    /// chart (`coding_seconds` in the stored result), and stores the outcome.
    async fn execute(&self, id: i64, scene_id: &str, scene: Scene, settings: RenderSettings) -> anyhow::Result<()> {
        let events = self.events.clone();
        let (tx, rx) = tokio::sync::oneshot::channel();
        rayon::spawn(move || {
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
            let result = render::render(&scene, &settings, Some(&progress)).map(|full| {
                // Every coding alone at a fixed number of paths per target
                // (no adaptive stop): equal work, comparable costs.
                let mut coding_seconds = serde_json::Map::new();
                let mut coding_cost = serde_json::Map::new();
                for coding in &settings.codings {
                    let alone = RenderSettings {
                        codings: vec![*coding],
                        target_relative_se: None,
                        ..settings.clone()
                    };
                    let t = Instant::now();
                    if let Ok(r) = render::render(&scene, &alone, None) {
                        let wall = t.elapsed().as_secs_f64();
                        coding_seconds.insert(coding.to_string(), wall.into());
                        coding_cost.insert(
                            coding.to_string(),
                            serde_json::json!({
                                "paths": r.paths,
                                "paths_per_target": r.paths / r.targets.len().max(1) as u64,
                                "rays": r.rays,
                                "wall_seconds": wall,
                            }),
                        );
                    }
                }
                // The camera view for the dashboard: the sRGB coding, few paths per
                // pixel (a preview, not a measurement).
                let preview = scene.camera.as_ref().and_then(|camera| {
                    let transport = render::integrator::Transport {
                        max_bounces: settings.max_bounces,
                        russian_roulette_from: settings.russian_roulette_from,
                    };
                    render::sensor::render_camera(&scene, camera, Coding::Srgb, 16, &transport, settings.seed)
                        .and_then(|img| img.png())
                        .map_err(|e| tracing::warn!(render_id = id, error = %e, "no preview image"))
                        .ok()
                });
                (full, (coding_seconds, coding_cost), preview)
            });
            let _ = tx.send(result);
        });
        let outcome = rx.await?;
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
            Err(e) => {
                self.store.finish_render(id, Err(&e.to_string())).await?;
                tracing::error!(render_id = id, error = %e, "render failed");
                (false, Some(e.to_string()))
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
    fn study_plan(&self, request: &StudyRequest) -> Result<(Vec<PathBuf>, StudyOptions), ApiError> {
        let paths = match &request.scenes {
            None => self.scenes.iter().map(|s| s.path.clone()).collect(),
            Some(list) => list
                .split(',')
                .map(str::trim)
                .filter(|s| !s.is_empty())
                .map(|id| {
                    self.entry(id).map(|e| e.path.clone()).ok_or_else(|| {
                        let names: Vec<&str> = self.scenes.iter().map(|s| s.id.as_str()).collect();
                        ApiError::BadRequest(format!(
                            "field `scenes`: no scene `{id}`; available: {}",
                            names.join(", ")
                        ))
                    })
                })
                .collect::<Result<Vec<_>, _>>()?,
        };
        if paths.is_empty() {
            return Err(ApiError::BadRequest("field `scenes`: name at least one scene".into()));
        }
        let against = match request.against.as_deref().unwrap_or("measurements") {
            "measurements" => Against::Measurements,
            "reference" => Against::Reference,
            other => {
                return Err(ApiError::BadRequest(format!(
                    "field `against`: `{other}` is neither `measurements` nor `reference`"
                )))
            }
        };
        let seeds = request.seeds.unwrap_or(8);
        if !(1..=64).contains(&seeds) {
            return Err(ApiError::BadRequest(format!("field `seeds`: {seeds} is outside 1–64")));
        }
        let failure_map = request.failure_map.unwrap_or(false);
        if failure_map && !paths.iter().any(|p| p.file_stem().is_some_and(|s| s == "cylinder")) {
            return Err(ApiError::BadRequest(
                "field `failure_map`: the failure maps need the `cylinder` scene".into(),
            ));
        }
        let auto = request
            .auto
            .as_deref()
            .filter(|t| !t.trim().is_empty())
            .map(|t| t.parse::<crate::study::auto::Tolerance>())
            .transpose()
            .map_err(|e| ApiError::BadRequest(format!("field `auto`: {e}")))?;
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

    fn start_render(self: Arc<Self>, scene: String, request: RenderRequest) -> BoxFuture<Result<i64, ApiError>> {
        Box::pin(async move {
            let path = self
                .entry(&scene)
                .map(|e| e.path.clone())
                .ok_or_else(|| ApiError::NotFound(format!("no scene `{scene}`")))?;
            let settings = self
                .settings(&request)
                .map_err(|e| ApiError::BadRequest(format!("field `codings`: {e}")))?;
            let loaded = render::load_scene(&path).map_err(|e| ApiError::Internal(e.to_string()))?;
            let hash = render::scene_hash(&loaded).map_err(|e| ApiError::Internal(e.to_string()))?;
            let id = self
                .record(&scene, &settings, hash)
                .await
                .map_err(|e| ApiError::Internal(e.to_string()))?;
            // Run in the background; the caller polls /api/renders/{id} or follows the events.
            tokio::spawn(async move {
                if let Err(e) = self.execute(id, &scene, loaded, settings).await {
                    tracing::error!(render_id = id, error = %e, "render failed");
                }
            });
            Ok(id)
        })
    }

    fn start_study(self: Arc<Self>, request: StudyRequest) -> BoxFuture<Result<i64, ApiError>> {
        Box::pin(async move {
            let (paths, options) = self.study_plan(&request)?;
            let id = self
                .store
                .create_study(&serde_json::to_value(&request).unwrap_or_default())
                .await
                .map_err(|e| ApiError::Internal(e.to_string()))?;
            tracing::info!(study_id = id, scenes = paths.len(), "study started");
            let this = Arc::clone(&self);
            // Rendering is CPU-bound: run the study on a blocking thread (its
            // renders use the rayon pool), never on the async workers.
            tokio::task::spawn_blocking(move || {
                let runtime = this.runtime.clone();
                runtime.block_on(async {
                    let events = this.events.clone();
                    let progress = move |message: &str| {
                        let _ = events.send(Event::StudyProgress {
                            study_id: id,
                            message: message.to_string(),
                        });
                    };
                    let outcome = match run_study(&paths, &options, Some(&this.store), &progress).await {
                        Ok(result) => match (report_files(&result), serde_json::to_value(&result)) {
                            (Ok(files), Ok(json)) => this
                                .store
                                .complete_study(id, &json, result.wall_seconds, &files)
                                .await
                                .map_err(|e| e.to_string()),
                            (Err(e), _) => Err(e.to_string()),
                            (_, Err(e)) => Err(e.to_string()),
                        },
                        Err(e) => Err(e.to_string()),
                    };
                    if let Err(e) = &outcome {
                        tracing::error!(study_id = id, error = %e, "study failed");
                        let _ = this.store.fail_study(id, e).await;
                    } else {
                        tracing::info!(study_id = id, "study complete");
                    }
                    let _ = this.events.send(Event::StudyFinished {
                        study_id: id,
                        ok: outcome.is_ok(),
                        error: outcome.err(),
                    });
                });
            });
            Ok(id)
        })
    }
}
