//! A study run: every coding of every scene against the truth, with the
//! Monte Carlo spread over seeds, and (optionally) settings sweeps for the
//! speed-against-accuracy chart.
//!
//! # What is compared
//!
//! - The truth is either the measurements (the newest complete measurement
//!   of each target, from the store) or, with `--against reference`, the
//!   simulated booth's converged `spectral` solution: its own seed
//!   ([`render::TRUTH_SEED`], no rendering under test uses it), no bounce cap
//!   (Russian roulette from bounce [`render::TRUTH_ROULETTE_FROM`], unbiased),
//!   relative standard error of Y below [`REFERENCE_RELATIVE_SE`], so neither
//!   the noise nor the bounce limit of the renderings under test is in it.
//! - The truth may come from a *truth scene* distinct from the model scene
//!   ([`StudyOptions::truth_scene`]): the booth as it is (a lamp at 3150 K, a
//!   reflectance 2 % low, a target 5 mm off) while the codings render the
//!   model. Without one the truth is the model scene's own converged solution.
//! - Each seed renders all codings in one pass (same paths for every coding,
//!   so differences between codings are not noise); the figures of merit
//!   (rms_rel, mean ± SD of ΔE*ab and ΔE00 over the targets) are computed per
//!   seed and then summarised as mean ± SD over seeds.
//! - CIELAB white: the one each scene declares (`[cielab_white]`, see
//!   [`crate::compare::white`]); the same white for truth and renderings.
//! - Observer: [`StudyOptions::observer`] for every XYZ, x,y, CIELAB and ΔE
//!   (renders and measurements alike); the result names it.
//! - "Beyond noise": a rendered luminance differs from the truth beyond
//!   noise only when |Ȳ_render − Y_truth| > k·√(SE_render² + SE_truth²) with
//!   k = [`BEYOND_NOISE_K`] ([`beyond_noise`]): SE_render is the seed mean's
//!   (the larger of the renders' own SE estimate and their observed spread
//!   over seeds, over √seeds), SE_truth the measurement's (its samples'
//!   SD/√n) or the reference rendering's.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::Serialize;
use tokio_util::sync::CancellationToken;

use lightbooth_render::{self as render, Coding, RenderResult, RenderSettings, Scene};
use lightbooth_science::colorimetry::{Observer, Xyz};
use lightbooth_science::comparison::{
    beyond_noise, compare_point, mean_sd, summarize, PointDifference, BEYOND_NOISE_K,
};
use lightbooth_store::{Booth, MeasurementDetail, Store};

use super::auto::{
    candidate_set, choose_settings, reference_render, verify, AutoChoice, CandidateSet, Tolerance, Verification,
};
use super::failure_map::{failure_map, FailureMap, FailureMapSettings};
use crate::compare::white::{measured_in_booth, resolve_white, scene_id, scene_white, RenderedWhite};

/// Relative standard error of Y of the reference rendering.
pub const REFERENCE_RELATIVE_SE: f64 = 1e-3;

/// What the renderings are compared with.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Against {
    Measurements,
    Reference,
}

/// Settings of a study run.
#[derive(Clone, Debug, Serialize)]
pub struct StudyOptions {
    #[serde(serialize_with = "coding_names")]
    pub codings: Vec<Coding>,
    pub seeds: u32,
    /// First-round paths per target; rendering continues until the relative
    /// SE of Y is below `target_relative_se` (the renderer's adaptive mode).
    pub samples: u64,
    pub target_relative_se: Option<f64>,
    /// The bounce cap of the study's renders; `None` (the default): no cap,
    /// Russian roulette ends the paths (unbiased). A cap is stated beside
    /// every figure of the report ("truncated at N bounces").
    pub max_bounces: Option<u32>,
    pub against: Against,
    /// Also sweep samples, bounces and N for the speed-against-accuracy chart.
    pub sweeps: bool,
    /// Fixed paths per target of every sweep render (timings on equal work).
    pub sweep_samples: u64,
    /// Also compute the failure maps (needs the CYLINDER among the scenes).
    pub failure_map: bool,
    /// Also choose, per scene, the cheapest settings that meet this tolerance
    /// against the converged spectral answer, verify them, and place them
    /// among the alternatives on the speed-against-accuracy chart.
    pub auto: Option<Tolerance>,
    /// The observer of every XYZ, x,y, CIELAB and ΔE (`judd-vos-1978`, the
    /// study's, by default).
    pub observer: Observer,
    /// The booth as it is, when it differs from the model: a scene file
    /// (used for the scene whose id is its file stem) or a folder of scene
    /// files named like the model scenes. The reference truth and the
    /// simulated measurements come from it; the codings render the model.
    pub truth_scene: Option<PathBuf>,
    /// Against measurements: the booth whose measurements are the truth and
    /// whose measured white is the CIELAB white (never another booth's: the
    /// rule of [`crate::compare`], so a study and the dashboard give
    /// one measurement the same ΔE).
    pub booth: Booth,
}

impl StudyOptions {
    /// The scene file the truth of `model` comes from: the truth scene of the
    /// same id when there is one, else the model itself.
    pub fn truth_path(&self, model: &Path) -> PathBuf {
        truth_path(self.truth_scene.as_deref(), model)
    }
}

/// The truth scene of `model` in `truth` (a file with the model's file
/// stem, or a folder holding one), else `model` itself.
pub fn truth_path(truth: Option<&Path>, model: &Path) -> PathBuf {
    let id = scene_id(model);
    match truth {
        Some(t) if t.is_dir() => {
            let p = t.join(format!("{id}.toml"));
            if p.exists() {
                p
            } else {
                model.to_path_buf()
            }
        }
        Some(t) if scene_id(t) == id => t.to_path_buf(),
        _ => model.to_path_buf(),
    }
}

impl Default for StudyOptions {
    fn default() -> Self {
        StudyOptions {
            codings: Coding::ALL.to_vec(),
            seeds: 8,
            samples: 4096,
            target_relative_se: Some(0.003),
            max_bounces: None,
            against: Against::Reference,
            sweeps: false,
            sweep_samples: 4096,
            failure_map: false,
            auto: None,
            observer: Observer::JuddVos,
            truth_scene: None,
            booth: Booth::default(),
        }
    }
}

fn coding_names<S: serde::Serializer>(c: &[Coding], s: S) -> Result<S::Ok, S::Error> {
    s.collect_seq(c.iter().map(|c| c.to_string()))
}

/// The study's figures of merit for one coding in one render.
#[derive(Clone, Copy, Debug, Default, Serialize)]
#[allow(non_snake_case)]
pub struct Figures {
    pub rms_rel: f64,
    pub mean_dE76: f64,
    /// SD over the targets (n − 1); 0 with one target.
    pub sd_dE76: f64,
    pub mean_dE00: f64,
    pub sd_dE00: f64,
}

/// Mean and SD over seeds of a figure.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct Spread {
    pub mean: f64,
    pub sd: f64,
}

impl Spread {
    fn of(values: &[f64]) -> Spread {
        let (mean, sd) = mean_sd(values.iter().copied());
        Spread {
            mean,
            sd: sd.unwrap_or(0.0),
        }
    }
}

/// One target of one coding: the rendering (mean ± SD over seeds) and its
/// difference from the truth.
#[derive(Clone, Debug, Serialize)]
#[allow(non_snake_case)]
pub struct TargetProfile {
    pub target: String,
    pub Y: Spread,
    pub x: Spread,
    pub y: Spread,
    /// Mean Monte Carlo standard error of Y reported by the renders.
    pub Y_se: f64,
    /// The truth's luminance, cd/m².
    pub truth_Y: f64,
    /// The combined standard error √(SE_render² + SE_truth²) of the
    /// difference, cd/m².
    pub combined_se: f64,
    /// |Ȳ_render − Y_truth| > k · combined_se with k = [`BEYOND_NOISE_K`].
    pub Y_differs_significantly: bool,
}

/// One coding in one scene.
#[derive(Clone, Debug, Serialize)]
#[allow(non_snake_case)]
pub struct CodingStudy {
    pub coding: String,
    pub per_seed: Vec<Figures>,
    pub rms_rel: Spread,
    pub mean_dE76: Spread,
    pub mean_dE00: Spread,
    /// Mean over seeds of the SD over targets (the study's ±1 SD).
    pub sd_dE76_over_targets: f64,
    pub sd_dE00_over_targets: f64,
    pub profile: Vec<TargetProfile>,
    /// Targets whose luminance differs from the truth by more than the noise.
    pub significant_targets: usize,
    /// Against measurements: rms_rel and ΔE00 against what the
    /// measurements' error alone gives ([`study_claims`]); none against
    /// the reference, or when it cannot be propagated
    /// (`uncertainty_not_propagated` then says why).
    pub uncertainty: Option<StudyClaims>,
    pub uncertainty_not_propagated: Option<String>,
}

/// A coding's figures against the measurement's uncertainty: the
/// propagation of [`lightbooth_science::uncertainty`] with the seed-mean
/// rendering and its standard error, and the measurements of the truth.
#[derive(Clone, Debug, Serialize)]
#[allow(non_snake_case)]
pub struct StudyClaims {
    /// The model whose stated accuracy was propagated, and its source.
    pub instrument_model: String,
    pub accuracy: lightbooth_science::uncertainty::StatedAccuracy,
    pub draws: usize,
    /// rms_rel (of the seed-mean rendering) with its intervals and claims.
    pub rms_rel: lightbooth_science::uncertainty::PropagatedDifference,
    /// Targets whose ΔE00 is beyond the render's noise, the repeatability,
    /// and the stated accuracy (`None`: no accuracy on record).
    pub dE00_targets_beyond_noise: usize,
    pub dE00_targets_beyond_repeatability: usize,
    pub dE00_targets_beyond_stated_accuracy: Option<usize>,
}

impl StudyClaims {
    /// Whether the coding is told apart from the measurement beyond the
    /// instrument's stated accuracy, in words, in luminance (rms_rel) and in
    /// colour (any target's ΔE00): `yes in luminance`, `not in colour`, or
    /// `colour: no accuracy on record` where the figures it needs are not
    /// stated.
    pub fn distinguishable(&self) -> String {
        let luminance = match self.rms_rel.claims.beyond_stated_accuracy {
            Some(true) => "yes in luminance".to_string(),
            Some(false) => "not in luminance".to_string(),
            None => "luminance: no accuracy on record".to_string(),
        };
        let colour = match self.dE00_targets_beyond_stated_accuracy {
            Some(0) => "not in colour".to_string(),
            Some(n) => format!("yes in colour ({n} targets)"),
            None => "colour: no accuracy on record".to_string(),
        };
        format!("{luminance}; {colour}")
    }
}

/// The claims of one coding (see [`StudyClaims`]): the seed-mean rendering
/// of each target against its measurement.
fn study_claims(
    scene_id: &str,
    study: &CodingStudy,
    measurements: &[Option<MeasurementDetail>],
    white: Xyz,
    observer: Observer,
) -> Result<StudyClaims, String> {
    let mut points = Vec::with_capacity(study.profile.len());
    for (p, m) in study.profile.iter().zip(measurements) {
        let m = m.as_ref().ok_or("a target's truth is no measurement")?;
        let (x, y) = (p.x.mean, p.y.mean);
        if y.is_nan() || y <= 0.0 {
            return Err(format!("{}: the rendering has no chromaticity", p.target));
        }
        let big_y = p.Y.mean;
        let rendered = Xyz::new(x / y * big_y, big_y, (1.0 - x - y) / y * big_y);
        let mean_se = p.Y_se.max(p.Y.sd) / (study.per_seed.len().max(1) as f64).sqrt();
        points.push((m, rendered, mean_se));
    }
    let (instrument_model, u) = crate::compare::summary::propagate_measured(scene_id, observer, white, &points)?;
    let count =
        |f: fn(&lightbooth_science::uncertainty::Claims) -> bool| u.points.iter().filter(|p| f(&p.de00.claims)).count();
    Ok(StudyClaims {
        instrument_model,
        draws: u.monte_carlo.draws,
        dE00_targets_beyond_noise: count(|c| c.beyond_noise),
        dE00_targets_beyond_repeatability: count(|c| c.beyond_repeatability),
        dE00_targets_beyond_stated_accuracy: u
            .points
            .iter()
            .map(|p| p.de00.claims.beyond_stated_accuracy)
            .collect::<Option<Vec<bool>>>()
            .map(|v| v.into_iter().filter(|b| *b).count()),
        rms_rel: u.rms_rel,
        accuracy: u.accuracy,
    })
}

/// The truth at one target.
#[derive(Clone, Debug, Serialize)]
#[allow(non_snake_case)]
pub struct Truth {
    pub target: String,
    pub XYZ: [f64; 3],
    pub x: f64,
    pub y: f64,
    /// Standard error of Y: the measurement's (SD/√n of its samples) or the
    /// reference rendering's.
    pub Y_se: f64,
    /// Where it comes from: `measurement 12` or `reference render`.
    pub source: String,
    /// The scene file the truth was computed from (the model, or a truth scene).
    pub scene_file: String,
}

/// One point of the speed-against-accuracy chart.
#[derive(Clone, Debug, Serialize)]
#[allow(non_snake_case)]
pub struct SweepPoint {
    /// `coding`, `samples`, `bounces` or `n`: what this sweep varies.
    pub sweep: String,
    pub coding: String,
    pub samples: u64,
    /// The bounce cap of this point's render (`null`: none, unbiased); the
    /// `bounces` sweep caps at 0…8 on purpose: truncated at N bounces.
    pub bounces: Option<u32>,
    /// The median wall time of the repeats, s ([`render::cost`]).
    pub wall_seconds: f64,
    /// The fastest and slowest repeat, s.
    pub wall_seconds_min: f64,
    pub wall_seconds_max: f64,
    /// Rays traced (primary, bounce and shadow): the cost that does not
    /// jitter with machine load; `wall_seconds` beside it.
    pub rays: u64,
    /// Paths traced, all targets (fixed: `samples` per target).
    pub paths: u64,
    pub rms_rel: f64,
    pub mean_dE00: f64,
    /// One of the study's own choices (RGB, sRGB, N = 3/9/27/81, 5 bounces).
    pub study_choice: bool,
}

/// One scene of a study.
#[derive(Clone, Debug, Serialize)]
#[allow(non_snake_case)]
pub struct SceneStudy {
    pub scene: String,
    pub title: String,
    /// The observer of every XYZ, x,y, CIELAB and ΔE of this scene.
    pub observer: Observer,
    pub targets: Vec<String>,
    /// The scene's CIELAB white (`[cielab_white]` in its file) and where its
    /// value came from.
    pub white_source: String,
    pub white_XYZ: [f64; 3],
    pub truth: Vec<Truth>,
    pub codings: Vec<CodingStudy>,
    /// Wall time of all seeds' renders of this scene.
    pub render_seconds: f64,
    /// The bounce cap of the seeds' renders (`options.max_bounces`), `null`
    /// when none: with a cap every figure misses the later bounces' light.
    pub truncated_at_bounces: Option<u32>,
    /// [`lightbooth_render::truncation_note`] when a cap is in force.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub truncation_note: Option<String>,
    pub sweeps: Vec<SweepPoint>,
    /// The automatic choice for this scene (with `auto`).
    pub auto: Option<AutoStudy>,
}

/// The automatic choice for a scene, its check against the converged
/// spectral reference, and the alternatives it is charted among.
#[derive(Clone, Debug, Serialize)]
pub struct AutoStudy {
    pub choice: AutoChoice,
    pub verification: Verification,
    pub candidates: CandidateSet,
    /// The speed-against-accuracy chart with the Pareto front and the choice.
    #[serde(skip)]
    pub svg: String,
}

/// A whole study run.
#[derive(Clone, Debug, Serialize)]
pub struct StudyResult {
    /// The observer of every XYZ, x,y, CIELAB and ΔE of the study.
    pub observer: Observer,
    /// The "beyond noise" test: k of |difference| > k·combined SE.
    pub beyond_noise_k: f64,
    /// How the sweeps' cost is defined.
    pub cost_definition: &'static str,
    pub options: StudyOptions,
    pub scenes: Vec<SceneStudy>,
    /// Where each coding fails (illuminant × patch, interreflection strength).
    pub failure_map: Option<FailureMap>,
    pub wall_seconds: f64,
}

/// Errors of a study run.
#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    #[error(transparent)]
    Render(#[from] render::RenderError),
    #[error(transparent)]
    Scene(#[from] render::SceneError),
    #[error("{0}")]
    Truth(String),
    #[error(transparent)]
    Store(#[from] lightbooth_store::StoreError),
}

/// The converged reference rendering of a scene (all its targets, `spectral`
/// only), cached in memory for the run.
struct References<'c> {
    cache: HashMap<PathBuf, RenderResult>,
    observer: Observer,
    cancel: Option<&'c CancellationToken>,
}

impl References<'_> {
    /// The converged truth of the scene file `path` (a model or a truth
    /// scene): the simulated booth's settings ([`render::truth_settings`])
    /// for every target.
    fn get(&mut self, path: &Path) -> Result<&RenderResult, StudyError> {
        if !self.cache.contains_key(path) {
            let scene = render::load_scene(path)?;
            let settings = RenderSettings {
                targets: None,
                target_relative_se: Some(REFERENCE_RELATIVE_SE),
                observer: self.observer,
                ..render::truth_settings("")
            };
            let result = render::render(&scene, &settings, None, self.cancel)?;
            self.cache.insert(path.to_path_buf(), result);
        }
        Ok(&self.cache[path])
    }

    fn xyz(&mut self, path: &Path, target: &str) -> Result<(Xyz, f64), StudyError> {
        let r = self.get(path)?;
        let c = r
            .target(target)
            .and_then(|t| t.coding("spectral"))
            .ok_or_else(|| StudyError::Truth(format!("{}: no target {target}", path.display())))?;
        Ok((Xyz::from_array(c.xyz), c.luminance_se_cd_m2))
    }
}

/// The truth for one target from the store: the newest complete measurement
/// taken in `booth`.
async fn measured(
    store: &Store,
    booth: &Booth,
    scene_id: &str,
    target: &str,
    observer: Observer,
) -> Result<Option<(Xyz, f64, String, MeasurementDetail)>, StudyError> {
    let Some((m, xyz)) = measured_in_booth(store, booth, scene_id, target, observer)
        .await
        .map_err(|e| e.into_error(StudyError::Truth))?
    else {
        return Ok(None);
    };
    let usable = m.samples.iter().filter(|s| s.usable).count();
    let y_se = crate::measure::recorder::mean_y_standard_error(m.summary.luminance_cv.unwrap_or(0.0), xyz.y, usable);
    Ok(Some((xyz, y_se, format!("measurement {}", m.summary.id), m)))
}

/// How many times [`run_study`] calls its `progress` for `scenes` scenes:
/// per scene its truth, one render per seed, the sweeps and the automatic
/// settings (when asked for), then the failure maps.
pub fn progress_steps(scenes: usize, options: &StudyOptions) -> usize {
    let per_scene = 1 + options.seeds as usize + usize::from(options.sweeps) + usize::from(options.auto.is_some());
    scenes * per_scene + usize::from(options.failure_map)
}

/// The fraction of the study done when [`run_study`] calls its `progress`
/// for the k-th time (from 0), for scenes of `targets` targets each, in
/// order: one per call of [`progress_steps`]. **A rough measure of time,
/// stated**: each of a scene's steps weighs its number of targets (a
/// render traces the same paths per target, so a 21-target scene's steps
/// take about 21 times a one-target scene's), the failure maps as much as
/// the mean scene step. With every step counted as equal, a study of four
/// one-target scenes and CYLINDER (21 targets) was "5/6 done" when
/// CYLINDER began, and its time left said "about 0 s" at 14 s of a 31 s
/// run (issue 46).
pub fn progress_fractions(targets: &[usize], options: &StudyOptions) -> Vec<f64> {
    let per_scene = progress_steps(1, options) - usize::from(options.failure_map);
    let mut weights: Vec<f64> = targets
        .iter()
        .flat_map(|&n| std::iter::repeat_n(n.max(1) as f64, per_scene))
        .collect();
    if options.failure_map {
        let mean = if weights.is_empty() {
            1.0
        } else {
            weights.iter().sum::<f64>() / weights.len() as f64
        };
        weights.push(mean);
    }
    let total: f64 = weights.iter().sum();
    let mut done = 0.0;
    weights
        .iter()
        .map(|w| {
            let fraction = done / total;
            done += w;
            fraction
        })
        .collect()
}

/// Runs the study over `scenes` (paths of scene files; the scene id is the
/// file stem, as in the daemon). `store` is needed with `Against::Measurements`.
/// `cancel` (the study job's token) stops every render of the study.
pub async fn run_study(
    scenes: &[PathBuf],
    options: &StudyOptions,
    store: Option<&Store>,
    progress: &(dyn Fn(&str) + Sync),
    cancel: Option<&CancellationToken>,
) -> Result<StudyResult, StudyError> {
    let start = Instant::now();
    let mut references = References {
        cache: HashMap::new(),
        observer: options.observer,
        cancel,
    };
    let mut out = Vec::new();
    for path in scenes {
        let scene = render::load_scene(path)?;
        let scene_id = path
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or_default()
            .to_string();
        let targets: Vec<String> = scene.targets().into_iter().map(str::to_string).collect();
        let white_spec = scene_white(path, &scene, options.observer).map_err(StudyError::Truth)?;
        let truth_file = options.truth_path(path);
        progress(&format!("{scene_id}: truth ({:?})", options.against));

        // The truth per target, and the CIELAB white.
        let mut truth = Vec::new();
        // The measurement behind each target's truth (against measurements).
        let mut truth_measurements = Vec::new();
        for t in &targets {
            let (xyz, y_se, source, measurement) = match options.against {
                Against::Reference => {
                    let (xyz, se) = references.xyz(&truth_file, t)?;
                    (xyz, se, "reference render".to_string(), None)
                }
                Against::Measurements => {
                    let store = store
                        .ok_or_else(|| StudyError::Truth("comparing with measurements needs the database".into()))?;
                    measured(store, &options.booth, &scene_id, t, options.observer)
                        .await?
                        .map(|(xyz, se, source, m)| (xyz, se, source, Some(m)))
                        .ok_or_else(|| {
                            StudyError::Truth(format!(
                                "no complete measurement of {scene_id}/{t} in booth {}: measure it there first \
                             (or use --against reference)",
                                options.booth
                            ))
                        })?
                }
            };
            truth_measurements.push(measurement);
            let xy = xyz.chromaticity();
            truth.push(Truth {
                target: t.clone(),
                XYZ: xyz.to_array(),
                x: xy.x,
                y: xy.y,
                Y_se: y_se,
                source,
                scene_file: truth_file.display().to_string(),
            });
        }
        // Measured in the booth first (against measurements), else the
        // converged reference render of the white target.
        let measured_in = match (options.against, store) {
            (Against::Measurements, Some(store)) => Some((store, &options.booth)),
            _ => None,
        };
        let reference_render = async |_: &str, white_path: &Path, white_target: &str| {
            let (xyz, _) = references.xyz(&options.truth_path(white_path), white_target)?;
            Ok::<_, StudyError>(RenderedWhite::Reference(xyz))
        };
        let (white, white_source) = resolve_white(&white_spec, measured_in, options.observer, reference_render)
            .await
            .map_err(|e| e.into_error(StudyError::Truth))?;

        // Every seed renders every coding in one pass.
        let render_start = Instant::now();
        let mut per_seed: Vec<RenderResult> = Vec::new();
        for seed in 1..=u64::from(options.seeds) {
            progress(&format!("{scene_id}: seed {seed} of {}", options.seeds));
            let settings = RenderSettings {
                codings: options.codings.clone(),
                samples: options.samples,
                max_bounces: options.max_bounces,
                seed,
                target_relative_se: options.target_relative_se,
                observer: options.observer,
                ..RenderSettings::default()
            };
            per_seed.push(render::render(&scene, &settings, None, cancel)?);
        }
        let render_seconds = render_start.elapsed().as_secs_f64();
        let codings = options
            .codings
            .iter()
            .map(|c| {
                let mut study = coding_study(&c.to_string(), &per_seed, &truth, white, options.observer);
                if options.against == Against::Measurements {
                    match study_claims(&scene_id, &study, &truth_measurements, white, options.observer) {
                        Ok(claims) => study.uncertainty = Some(claims),
                        Err(why) => study.uncertainty_not_propagated = Some(why),
                    }
                }
                study
            })
            .collect();

        let sweeps = if options.sweeps {
            progress(&format!("{scene_id}: sweeps"));
            sweeps(&scene, options, &truth, white, cancel)?
        } else {
            Vec::new()
        };
        let auto = match &options.auto {
            Some(tol) => {
                progress(&format!("{scene_id}: automatic settings for {tol}"));
                Some(auto_study(&scene, tol, cancel)?)
            }
            None => None,
        };
        out.push(SceneStudy {
            scene: scene_id,
            title: scene.name.clone(),
            observer: options.observer,
            targets,
            white_source,
            white_XYZ: white.to_array(),
            truth,
            codings,
            render_seconds,
            truncated_at_bounces: options.max_bounces,
            truncation_note: options.max_bounces.map(render::truncation_note),
            sweeps,
            auto,
        });
    }
    let failure_map = if options.failure_map {
        let cylinder = scenes
            .iter()
            .find(|p| p.file_stem().is_some_and(|s| s == "cylinder"))
            .ok_or_else(|| {
                StudyError::Truth("the failure maps need the CYLINDER scene (cylinder.toml) among the scenes".into())
            })?;
        progress("failure maps");
        let mut settings = FailureMapSettings::cylinder(cylinder);
        settings.codings = options.codings.clone();
        Some(failure_map(&settings, cancel).map_err(|e| StudyError::Truth(format!("failure maps: {e}")))?)
    } else {
        None
    };
    Ok(StudyResult {
        observer: options.observer,
        beyond_noise_k: BEYOND_NOISE_K,
        cost_definition: COST_DEFINITION,
        options: options.clone(),
        scenes: out,
        failure_map,
        wall_seconds: start.elapsed().as_secs_f64(),
    })
}

/// Chooses, verifies and charts the automatic settings of one scene.
fn auto_study(scene: &Scene, tol: &Tolerance, cancel: Option<&CancellationToken>) -> Result<AutoStudy, StudyError> {
    let err = |e: super::auto::AutoError| StudyError::Truth(format!("automatic settings: {e}"));
    let choice = choose_settings(scene, tol, 1, cancel).map_err(err)?;
    let reference = reference_render(scene, &choice, cancel).map_err(err)?;
    let verification = verify(scene, &choice, &reference, cancel).map_err(err)?;
    let candidates = candidate_set(scene, &choice, &reference, &[choice.bounces], 2, cancel).map_err(err)?;
    let svg = candidates.svg.clone();
    Ok(AutoStudy {
        choice,
        verification,
        candidates,
        svg,
    })
}

/// The rendered XYZ and SE of Y of `coding` at each truth target.
fn rendered(result: &RenderResult, coding: &str, truth: &[Truth]) -> Vec<(Xyz, f64)> {
    truth
        .iter()
        .map(|t| {
            let c = result
                .target(&t.target)
                .and_then(|r| r.coding(coding))
                .expect("every target is rendered in every coding");
            (Xyz::from_array(c.xyz), c.luminance_se_cd_m2)
        })
        .collect()
}

fn figures(points: &[PointDifference]) -> Figures {
    let s = summarize(points);
    Figures {
        rms_rel: s.rms_rel,
        mean_dE76: s.mean_de76,
        sd_dE76: s.sd_de76.unwrap_or(0.0),
        mean_dE00: s.mean_de00,
        sd_dE00: s.sd_de00.unwrap_or(0.0),
    }
}

fn differences(rendered: &[(Xyz, f64)], truth: &[Truth], white: Xyz, observer: Observer) -> Vec<PointDifference> {
    rendered
        .iter()
        .zip(truth)
        .map(|((r, _), t)| compare_point(Xyz::from_array(t.XYZ), *r, white, observer))
        .collect()
}

fn coding_study(
    coding: &str,
    per_seed: &[RenderResult],
    truth: &[Truth],
    white: Xyz,
    observer: Observer,
) -> CodingStudy {
    let renders: Vec<Vec<(Xyz, f64)>> = per_seed.iter().map(|r| rendered(r, coding, truth)).collect();
    let figs: Vec<Figures> = renders
        .iter()
        .map(|r| figures(&differences(r, truth, white, observer)))
        .collect();
    let pick = |f: fn(&Figures) -> f64| Spread::of(&figs.iter().map(f).collect::<Vec<_>>());
    let profile: Vec<TargetProfile> = truth
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let ys: Vec<f64> = renders.iter().map(|r| r[i].0.y).collect();
            let xs: Vec<f64> = renders.iter().map(|r| r[i].0.chromaticity().x).collect();
            let yys: Vec<f64> = renders.iter().map(|r| r[i].0.chromaticity().y).collect();
            let se = renders.iter().map(|r| r[i].1).sum::<f64>() / renders.len() as f64;
            let y = Spread::of(&ys);
            // The seed mean's SE: the per-render spread (the larger of the
            // renders' own SE estimate and the observed SD over seeds) over
            // √seeds; the truth has its own SE.
            let per_render = se.max(y.sd);
            let mean_se = per_render / (renders.len() as f64).sqrt();
            TargetProfile {
                target: t.target.clone(),
                Y: y,
                x: Spread::of(&xs),
                y: Spread::of(&yys),
                Y_se: se,
                truth_Y: t.XYZ[1],
                combined_se: mean_se.hypot(t.Y_se),
                Y_differs_significantly: beyond_noise(y.mean - t.XYZ[1], mean_se, t.Y_se),
            }
        })
        .collect();
    CodingStudy {
        coding: coding.to_string(),
        rms_rel: pick(|f| f.rms_rel),
        mean_dE76: pick(|f| f.mean_dE76),
        mean_dE00: pick(|f| f.mean_dE00),
        sd_dE76_over_targets: figs.iter().map(|f| f.sd_dE76).sum::<f64>() / figs.len().max(1) as f64,
        sd_dE00_over_targets: figs.iter().map(|f| f.sd_dE00).sum::<f64>() / figs.len().max(1) as f64,
        significant_targets: profile.iter().filter(|p| p.Y_differs_significantly).count(),
        profile,
        per_seed: figs,
        uncertainty: None,
        uncertainty_not_propagated: None,
    }
}

/// How the cost of a coding is measured everywhere (study sweeps, daemon
/// renders): a fixed number of paths per target, the same for every coding,
/// timed as [`render::cost`] says.
pub const COST_DEFINITION: &str = "fixed paths per target (no adaptive stop), every coding rendered alone; \
     cost = wall time, the median of 3 repeats in rotated order after a warm-up render, with the fastest and \
     slowest beside it; rays traced beside it (the same for every coding of the same paths, so not a cost that \
     ranks codings)";

/// The sweeps of the speed-against-accuracy chart, each a render with a
/// fixed number of paths (so wall times compare equal work): every coding
/// alone at the study's settings; `spectral` at 256…16384 paths per target;
/// `spectral` with 0…8 bounces; and nstepN for N = 1…81.
fn sweeps(
    scene: &Scene,
    options: &StudyOptions,
    truth: &[Truth],
    white: Xyz,
    cancel: Option<&CancellationToken>,
) -> Result<Vec<SweepPoint>, StudyError> {
    let base = RenderSettings {
        samples: options.sweep_samples,
        max_bounces: options.max_bounces,
        seed: 1,
        target_relative_se: None,
        observer: options.observer,
        ..RenderSettings::default()
    };
    // (sweep, coding, samples, bounces, study choice) of every point, then
    // all timed together in rotated rounds (`render::cost`).
    let mut plan: Vec<(&str, Coding, u64, Option<u32>, bool)> = Vec::new();
    for c in &options.codings {
        let study = matches!(c, Coding::Rgb | Coding::Srgb) || matches!(c, Coding::NStep(3 | 9 | 27 | 81));
        plan.push(("coding", *c, options.sweep_samples, options.max_bounces, study));
    }
    for samples in [256, 1024, 4096, 16384] {
        plan.push(("samples", Coding::Spectral, samples, options.max_bounces, false));
    }
    for bounces in 0..=8 {
        plan.push((
            "bounces",
            Coding::Spectral,
            options.sweep_samples,
            Some(bounces),
            bounces == 5,
        ));
    }
    for n in [1, 2, 3, 5, 7, 9, 15, 20, 27, 40, 54, 81] {
        plan.push((
            "n",
            Coding::NStep(n),
            options.sweep_samples,
            options.max_bounces,
            matches!(n, 3 | 9 | 27 | 81),
        ));
    }
    let settings: Vec<RenderSettings> = plan
        .iter()
        .map(|&(_, coding, samples, bounces, _)| RenderSettings {
            codings: vec![coding],
            samples,
            max_bounces: bounces,
            // A capped point traces the same paths as the next cap up to its
            // last bounce: no roulette on the caps.
            russian_roulette_from: if bounces.is_some() {
                None
            } else {
                base.russian_roulette_from
            },
            ..base.clone()
        })
        .collect();
    let timed = render::cost::time_renders(scene, &settings, render::cost::TIMING_REPEATS, cancel)?;
    let mut points = Vec::new();
    for ((sweep, coding, samples, bounces, study_choice), t) in plan.into_iter().zip(timed) {
        let r = &t.result;
        let f = figures(&differences(
            &rendered(r, &coding.to_string(), truth),
            truth,
            white,
            options.observer,
        ));
        points.push(SweepPoint {
            sweep: sweep.into(),
            coding: coding.to_string(),
            samples,
            bounces,
            wall_seconds: t.median_seconds(),
            wall_seconds_min: t.fastest_seconds(),
            wall_seconds_max: t.slowest_seconds(),
            rays: r.rays,
            paths: r.paths,
            rms_rel: f.rms_rel,
            mean_dE00: f.mean_dE00,
            study_choice,
        });
    }
    Ok(points)
}
