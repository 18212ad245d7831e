//! The built-in spectral renderer: the booth scene, rendered once for every
//! colour coding, measured by a simulated radiometer.
//!
//! A layer of the workspace above `lightbooth-science`, the only crate of
//! lightbooth it uses; it knows nothing of the instruments, the store or HTTP,
//! and Cargo refuses a build where it would. `lightbooth` re-exports it as
//! `lightbooth::render`.
//!
//! - [`scene`]: the TOML scene format and its validation; [`ies`]: LM-63
//!   luminaires; [`geometry`]: analytic primitives; [`bvh`]: the bounding
//!   volume hierarchy that finds a ray's nearest primitive.
//! - [`coding`]: the channel layout that carries rgb, srgb, nstepN and
//!   spectral in one vector per path.
//! - [`integrator`]: path tracing with next-event estimation;
//!   [`lights`]: point and area lights behind one interface, in one
//!   collection with a light sampler, for it;
//!   [`bsdf`]: every material's reflection model, Lambertian included.
//! - [`pinhole`]: the one pinhole camera ([`pinhole::Pinhole`]), below
//!   both image sensors: [`camera`], the measuring camera (any coding, XYZ,
//!   LMS, per-pixel standard errors), and [`sensor`], the camera image for
//!   the dashboard.
//!
//! Every render entry point takes the job's cancellation token as its last
//! argument (`None`: it always finishes); there is no thread-local.
//!
//! The public entry points:
//!
//! ```no_run
//! use lightbooth_render::{load_scene, render, RenderSettings};
//! let scene = load_scene("scenes/cylinder.toml".as_ref()).unwrap();
//! let result = render(&scene, &RenderSettings::default(), None, None).unwrap();
//! println!("{}", serde_json::to_string_pretty(&result).unwrap());
//! ```
//!
//! Sampling and its error: sample i of target t draws its numbers from a
//! fixed source — an Owen-scrambled Sobol point of replicate i mod 16, or the
//! PCG32 stream (seed, t, i) — so it is the same path wherever it runs. The
//! standard error of Y is estimated from the 16 independent replicate means
//! (randomised QMC; with `SamplerKind::Independent`, from the paths). With a
//! `target_relative_se` goal, targets above it get more batches in rounds.
//!
//! Determinism: samples are grouped in fixed batches of [`BATCH_SAMPLES`],
//! batch sums are added in (target, batch) order after the parallel part, and
//! the adaptive decisions depend only on those sums, so the result is
//! bit-identical for any number of threads.
//!
//! Cost per coding: one pass serves every coding, so [`RenderResult`] reports
//! the total wall time only; the cost of a coding is measured by rendering it
//! alone ([`cost`]: `lightbooth render --time-each-coding`, the daemon's
//! `coding_cost`, the study's sweeps; `benches/render.rs`).

pub mod bsdf;
pub mod bundle;
pub mod bvh;
pub mod camera;
pub mod coding;
pub mod cost;
pub mod geometry;
mod huge_pages;
pub mod ies;
pub mod input_file;
pub mod integrator;
pub mod lights;
pub mod pinhole;
pub mod radiance;
pub mod sampling;
pub mod scene;
pub mod sensor;

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, OnceLock};
use std::time::Instant;

use rayon::prelude::*;
use serde::ser::{SerializeMap, Serializer};
use serde::{Deserialize, Serialize};
use tokio_util::sync::CancellationToken;

pub use coding::{coding_order, ChannelLayout, Coding};
pub use scene::{load_scene, Scene, SceneError};

pub use integrator::Transport;
use integrator::{radiometer_batch, BatchSums, Prepared};
pub use lights::LightSampling;

use lightbooth_science::colorimetry::Observer;
use lightbooth_science::spectrum::table::{write_csv, SpectraTable};
use lightbooth_science::spectrum::{Grid, SpectralUnit, Spectrum};

pub use sampling::{SamplerKind, BATCH_SAMPLES, REPLICATES};

/// Everything that can go wrong in a render.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RenderError {
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error("preparing the scene's spectra: {0}")]
    Prepare(String),
    #[error("no target `{0}` in the scene (targets: {1})")]
    UnknownTarget(String, String),
    #[error("{0}")]
    Settings(String),
    #[error("{0}")]
    Io(String),
    /// The [`CancellationToken`] the render was given was cancelled.
    #[error("the render was cancelled")]
    Cancelled,
}

/// The paths per target a request for `samples` traces: whole batches of
/// [`BATCH_SAMPLES`] (every replicate gets the same number of paths).
pub fn paths_traced(samples: u64) -> u64 {
    samples.max(1).div_ceil(BATCH_SAMPLES) * BATCH_SAMPLES
}

/// What a command prints when `flag samples` is not a whole number of
/// batches: the count it rounded to and why; `None` when used as given.
pub fn samples_rounding_note(flag: &str, samples: u64) -> Option<String> {
    let traced = paths_traced(samples);
    (traced != samples).then(|| {
        format!(
            "note: {flag} {samples} rounded up to {traced} paths per target: the renderer traces \
             in whole batches of {BATCH_SAMPLES} paths ({REPLICATES} replicates of {}), so give a multiple of {BATCH_SAMPLES}",
            BATCH_SAMPLES / REPLICATES as u64
        )
    })
}

/// What to render. Serialises to (and reads from) JSON with codings as
/// names (`["rgb", "nstep9", …]`); missing fields take the defaults.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RenderSettings {
    #[serde(serialize_with = "codings_as_names", deserialize_with = "codings_from_names")]
    pub codings: Vec<Coding>,
    /// Radiometer paths per target (the first round when
    /// `target_relative_se` is set), rounded up to whole batches of
    /// [`BATCH_SAMPLES`].
    pub samples: u64,
    /// Most indirect bounces (RADIANCE `-ab`). `None` (JSON `null`, the
    /// default): no cap, paths end by Russian roulette only, so the estimate
    /// has no truncation bias. A cap (`--bounces 5` emulates RADIANCE's
    /// `-ab 5`) leaves out the light of later bounces, a bias the standard
    /// error does not show: the result says so in `truncated_at_bounces`.
    pub max_bounces: Option<u32>,
    pub seed: u64,
    /// Unbiased Russian roulette from this bounce on (default
    /// [`DEFAULT_ROULETTE_FROM`]); `None` = never, which needs a bounce cap.
    pub russian_roulette_from: Option<u32>,
    /// Only these targets (ids); `None` = all.
    pub targets: Option<Vec<String>>,
    /// Worker threads; `None` = rayon's default (one per core).
    pub threads: Option<usize>,
    /// Random numbers: scrambled Sobol (default) or independent.
    pub sampler: SamplerKind,
    /// How the direct-light estimate chooses one light: `power` (the
    /// default, probability ∝ luminous flux) or `uniform` ([`lights::sampler`]).
    pub light_sampler: LightSampling,
    /// Keep sampling each target until the relative standard error of Y is
    /// below this in every coding (or `max_samples` is reached); the default
    /// is the performance goal, 0.3 %. `None`: exactly `samples` paths.
    pub target_relative_se: Option<f64>,
    /// Cap on paths per target when `target_relative_se` is set.
    pub max_samples: u64,
    /// The observer of every XYZ, x,y and Y of the result (`judd-vos-1978`,
    /// the study's, by default; `cie-1931`).
    pub observer: Observer,
}

fn codings_as_names<S: Serializer>(codings: &[Coding], s: S) -> Result<S::Ok, S::Error> {
    s.collect_seq(codings.iter().map(|c| c.to_string()))
}

fn codings_from_names<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec<Coding>, D::Error> {
    let names: Vec<String> = Deserialize::deserialize(d)?;
    names
        .iter()
        .map(|n| n.parse().map_err(serde::de::Error::custom))
        .collect()
}

/// Russian roulette starts at this bounce in a default render (as in the
/// simulated booth's truth, [`TRUTH_ROULETTE_FROM`]): before it every path
/// continues; with no bounce cap the estimate has no truncation bias.
pub const DEFAULT_ROULETTE_FROM: u32 = 3;

impl RenderSettings {
    /// The light transport of these settings, for the camera images too.
    pub fn transport(&self) -> Transport {
        Transport {
            max_bounces: self.max_bounces,
            russian_roulette_from: self.russian_roulette_from,
            light_sampler: self.light_sampler,
        }
    }
}

/// What a render capped at `bounces` says beside its standard errors.
pub fn truncation_note(bounces: u32) -> String {
    format!(
        "truncated at {bounces} bounces: the light of later bounces is missing from every value, \
         a bias (always darker) that the standard errors do not include; omit the cap for an unbiased render"
    )
}

impl Default for RenderSettings {
    fn default() -> RenderSettings {
        RenderSettings {
            codings: Coding::ALL.to_vec(),
            samples: 4096,
            max_bounces: None,
            seed: 1,
            russian_roulette_from: Some(DEFAULT_ROULETTE_FROM),
            targets: None,
            threads: None,
            sampler: SamplerKind::Sobol,
            light_sampler: LightSampling::Power,
            target_relative_se: Some(0.003),
            max_samples: 1 << 22,
            observer: Observer::JuddVos,
        }
    }
}

/// One coding's answer at one target.
#[derive(Clone, Debug, Serialize)]
pub struct CodingResult {
    /// Luminance, cd/m².
    #[serde(rename = "Y")]
    pub luminance_cd_m2: f64,
    /// Monte Carlo standard error of Y, cd/m².
    #[serde(rename = "Y_se")]
    pub luminance_se_cd_m2: f64,
    /// Chromaticity x.
    pub x: f64,
    /// Chromaticity y.
    pub y: f64,
    #[serde(rename = "XYZ")]
    pub xyz: [f64; 3],
    /// Spectral radiance on the 81-sample 380–780 nm grid, W/(sr·m²·nm)
    /// (piecewise-constant for N-step; absent for RGB codings).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub spectrum: Option<Vec<f64>>,
    /// The coding's own channel means (RGB, band means, or 1 nm radiance).
    pub bands: Vec<f64>,
}

/// Results at one target, codings in the order requested.
#[derive(Clone, Debug, Serialize)]
pub struct TargetResult {
    pub id: String,
    /// Paths traced for this target.
    pub paths: u64,
    #[serde(serialize_with = "ordered_map")]
    pub codings: Vec<(String, CodingResult)>,
}

impl TargetResult {
    pub fn coding(&self, name: &str) -> Option<&CodingResult> {
        self.codings.iter().find(|c| c.0 == name).map(|c| &c.1)
    }
}

fn ordered_map<S: Serializer, V: Serialize>(entries: &[(String, V)], s: S) -> Result<S::Ok, S::Error> {
    let mut m = s.serialize_map(Some(entries.len()))?;
    for (k, v) in entries {
        m.serialize_entry(k, v)?;
    }
    m.end()
}

/// How a coding's luminance departs from `spectral` along the targets.
#[derive(Clone, Debug, Serialize)]
pub struct Deviation {
    /// Per target, Y_coding / Y_spectral − 1.
    pub y_rel: Vec<f64>,
    /// The study's figure of merit: sqrt(mean((1 − Y_coding/Y_spectral)²)).
    pub rms_rel: f64,
    pub mean_rel: f64,
    /// Per target, the x,y distance from spectral.
    pub xy_distance: Vec<f64>,
}

/// A render's results (the JSON of `lightbooth render --json`).
#[derive(Clone, Debug, Serialize)]
pub struct RenderResult {
    /// The observer of every XYZ, x,y and Y below (as in `settings`).
    pub observer: Observer,
    pub scene: String,
    pub scene_file: String,
    pub settings: RenderSettings,
    pub wall_seconds: f64,
    /// Radiometer paths traced, all targets.
    pub paths: u64,
    /// Rays traced: primary, bounce and shadow rays.
    pub rays: u64,
    pub paths_per_second: f64,
    pub rays_per_second: f64,
    pub targets: Vec<TargetResult>,
    /// Every coding against `spectral` (when both were rendered).
    #[serde(serialize_with = "ordered_map")]
    pub deviation_from_spectral: Vec<(String, Deviation)>,
    /// The materials and emitters whose spectra were synthesised from
    /// RADIANCE RGB (the `rgb` coding uses their RGB exactly; the other
    /// codings the synthesised spectra, see `synthesis_method`). Empty for
    /// scenes with spectral colours only.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub synthesised_spectra: Vec<String>,
    /// How they were synthesised (`None` when nothing was).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub synthesis_method: Option<&'static str>,
    /// The bounce cap in force (`settings.max_bounces`), `null` when there is
    /// none: every Y above misses the light of later bounces.
    pub truncated_at_bounces: Option<u32>,
    /// [`truncation_note`] when a cap is in force.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub truncation_note: Option<String>,
}

impl RenderResult {
    pub fn target(&self, id: &str) -> Option<&TargetResult> {
        self.targets.iter().find(|t| t.id == id)
    }

    /// The largest relative standard error of Y over targets and codings.
    pub fn max_relative_se(&self) -> f64 {
        self.targets
            .iter()
            .flat_map(|t| t.codings.iter())
            .map(|(_, c)| c.luminance_se_cd_m2 / c.luminance_cd_m2.abs().max(f64::MIN_POSITIVE))
            .fold(0.0, f64::max)
    }
}

/// Renders every (selected) target of the scene with the radiometer, all
/// codings in one pass. `progress(done, total)` is called with samples done.
/// `cancel` (a job's token; `None`: the render always finishes) is checked
/// before each batch of [`BATCH_SAMPLES`] paths, so a cancelled render
/// stops within one batch per worker thread with [`RenderError::Cancelled`].
pub fn render(
    scene: &Scene,
    settings: &RenderSettings,
    progress: Option<&(dyn Fn(u64, u64) + Sync)>,
    cancel: Option<&CancellationToken>,
) -> Result<RenderResult, RenderError> {
    match settings.threads {
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .map_err(|e| RenderError::Settings(e.to_string()))?
            .install(|| render_in_pool(scene, settings, progress, cancel)),
        None => render_in_pool(scene, settings, progress, cancel),
    }
}

fn render_in_pool(
    scene: &Scene,
    settings: &RenderSettings,
    progress: Option<&(dyn Fn(u64, u64) + Sync)>,
    cancel: Option<&CancellationToken>,
) -> Result<RenderResult, RenderError> {
    let cancelled = || cancel.is_some_and(|c| c.is_cancelled());
    if cancelled() {
        return Err(RenderError::Cancelled);
    }
    let start = Instant::now();
    // One path asked for is one whole batch traced (the standard error
    // comes from the batch's 16 replicates), so any count from 1 is valid.
    if settings.codings.is_empty() || settings.samples == 0 {
        return Err(RenderError::Settings(
            "need at least one coding and at least one path per target".into(),
        ));
    }
    let target_indices: Vec<usize> = match &settings.targets {
        None => (0..scene.target_list.len()).collect(),
        Some(ids) => ids
            .iter()
            .map(|id| {
                scene
                    .target_list
                    .iter()
                    .position(|t| &t.id == id)
                    .ok_or_else(|| RenderError::UnknownTarget(id.clone(), scene.targets().join(", ")))
            })
            .collect::<Result<_, _>>()?,
    };
    let layout = ChannelLayout::with_observer(&settings.codings, settings.observer);
    let prep = Prepared::new(scene, layout).map_err(RenderError::Prepare)?;
    if settings.max_bounces.is_none() && settings.russian_roulette_from.is_none() {
        return Err(RenderError::Settings(
            "no bounce cap and no Russian roulette: a path in a closed scene would never end; \
             give a cap (`--bounces N`, the API's `bounces`) or Russian roulette"
                .into(),
        ));
    }
    let transport = settings.transport();
    // Whole batches only, so every replicate has the same number of paths.
    let first = settings.samples.div_ceil(BATCH_SAMPLES);
    let max_batches = settings.max_samples.div_ceil(BATCH_SAMPLES).max(first);
    let nt = target_indices.len();
    let mut sums: Vec<BatchSums> = (0..nt).map(|_| BatchSums::zero(&prep.layout)).collect();
    let mut done_batches = vec![0u64; nt];
    let mut want_batches = vec![first; nt];
    let done = AtomicU64::new(0);
    // Rounds: all targets get `samples`; with a relative-SE goal, targets
    // above it get the batches their SE says they need, up to `max_samples`. Every decision depends only on results, so the
    // outcome is the same on any number of threads.
    for _round in 0..16 {
        let tasks: Vec<(usize, u64)> = (0..nt)
            .flat_map(|k| (done_batches[k]..want_batches[k]).map(move |b| (k, b)))
            .collect();
        if tasks.is_empty() {
            break;
        }
        let total: u64 = want_batches.iter().sum::<u64>() * BATCH_SAMPLES;
        let partial: Vec<BatchSums> = tasks
            .par_iter()
            .map(|&(k, b)| {
                if cancelled() {
                    // Skipped; the whole render is refused below.
                    return BatchSums::zero(&prep.layout);
                }
                let range = b * BATCH_SAMPLES..(b + 1) * BATCH_SAMPLES;
                let t = target_indices[k];
                let out = radiometer_batch(&prep, &transport, settings.sampler, t, settings.seed, range);
                let now = done.fetch_add(BATCH_SAMPLES, Ordering::Relaxed) + BATCH_SAMPLES;
                if let Some(p) = progress {
                    p(now, total);
                }
                out
            })
            .collect();
        if cancelled() {
            return Err(RenderError::Cancelled);
        }
        // Deterministic reduction: each target's batches in batch order.
        for ((k, _), part) in tasks.iter().zip(&partial) {
            sums[*k].add(part);
        }
        done_batches.clone_from(&want_batches);
        let Some(goal) = settings.target_relative_se else {
            break;
        };
        for k in 0..nt {
            let rel = relative_se(&prep.layout, settings.sampler, &sums[k]);
            // At the cap the target is done, goal met or not.
            if rel > goal && done_batches[k] < max_batches {
                // SE ∝ 1/√n for plain Monte Carlo; randomised QMC converges
                // faster, so that estimate overshoots: grow at most 2× a round.
                let need = (done_batches[k] as f64 * (rel / goal).powi(2)).ceil() as u64;
                let need = need.min(2 * done_batches[k]);
                want_batches[k] = need.clamp(done_batches[k] + 1, max_batches);
            }
        }
    }
    let mut targets = Vec::new();
    let (mut paths, mut rays) = (0, 0);
    for (k, &t) in target_indices.iter().enumerate() {
        paths += sums[k].paths;
        rays += sums[k].rays;
        targets.push(target_result(
            &prep.layout,
            settings.sampler,
            &scene.target_list[t].id,
            &sums[k],
        ));
    }
    let wall_seconds = start.elapsed().as_secs_f64();
    let deviation_from_spectral = deviations(&settings.codings, &targets);
    Ok(RenderResult {
        observer: settings.observer,
        scene: scene.name.clone(),
        scene_file: scene.path.display().to_string(),
        settings: settings.clone(),
        wall_seconds,
        paths,
        rays,
        paths_per_second: paths as f64 / wall_seconds,
        rays_per_second: rays as f64 / wall_seconds,
        targets,
        deviation_from_spectral,
        synthesised_spectra: synthesised_spectra(scene),
        synthesis_method: synthesised_spectra(scene).first().map(|_| radiance::SYNTHESIS_METHOD),
        truncated_at_bounces: settings.max_bounces,
        truncation_note: settings.max_bounces.map(truncation_note),
    })
}

/// The materials and emitters whose spectra were synthesised from RGB.
fn synthesised_spectra(scene: &Scene) -> Vec<String> {
    let materials = scene
        .materials
        .iter()
        .filter(|m| m.rgb.is_some())
        .map(|m| format!("material `{}`", m.name));
    let emitters = scene
        .emitters
        .iter()
        .filter(|e| e.rgb.is_some())
        .map(|e| format!("emitter `{}`", e.name));
    materials.chain(emitters).collect()
}

/// The standard error of Y for coding entry `k` of these sums: from the
/// paths (independent sampling) or from the batch means, each an independent
/// randomisation (Sobol).
fn luminance_se(sampler: SamplerKind, sums: &BatchSums, k: usize) -> f64 {
    let (sum, sum2, count) = match sampler {
        SamplerKind::Independent => (sums.y[k], sums.y2[k], sums.paths as f64),
        SamplerKind::Sobol => {
            // Replicate means (every replicate has paths / R paths).
            let codings = sums.y.len();
            let per = sums.paths as f64 / REPLICATES as f64;
            let means = (0..REPLICATES).map(|r| sums.replicate_y[r * codings + k] / per);
            let (s, s2) = means.fold((0.0, 0.0), |(s, s2), m| (s + m, s2 + m * m));
            (s, s2, REPLICATES as f64)
        }
    };
    if count < 2.0 {
        return f64::INFINITY;
    }
    let mean = sum / count;
    let var = ((sum2 / count - mean * mean) * count / (count - 1.0)).max(0.0);
    (var / count).sqrt()
}

/// The largest relative SE of Y over the codings.
fn relative_se(layout: &ChannelLayout, sampler: SamplerKind, sums: &BatchSums) -> f64 {
    (0..layout.entries().len())
        .map(|k| {
            let y = sums.y[k] / sums.paths as f64;
            luminance_se(sampler, sums, k) / y.abs().max(f64::MIN_POSITIVE)
        })
        .fold(0.0, f64::max)
}

fn target_result(layout: &ChannelLayout, sampler: SamplerKind, id: &str, sums: &BatchSums) -> TargetResult {
    let n = sums.paths as f64;
    let mean: Vec<f64> = sums.channels.iter().map(|s| s / n).collect();
    let codings = layout
        .entries()
        .iter()
        .enumerate()
        .map(|(k, (coding, range))| {
            let d = layout.decode(k, &mean);
            let xy = d.xyz.chromaticity();
            (
                coding.to_string(),
                CodingResult {
                    luminance_cd_m2: d.xyz.y,
                    luminance_se_cd_m2: luminance_se(sampler, sums, k),
                    x: xy.x,
                    y: xy.y,
                    xyz: d.xyz.to_array(),
                    spectrum: d.spectrum_81,
                    bands: mean[range.clone()].to_vec(),
                },
            )
        })
        .collect();
    TargetResult {
        id: id.to_string(),
        paths: sums.paths,
        codings,
    }
}

fn deviations(codings: &[Coding], targets: &[TargetResult]) -> Vec<(String, Deviation)> {
    if !codings.contains(&Coding::Spectral) {
        return Vec::new();
    }
    codings
        .iter()
        .filter(|c| **c != Coding::Spectral)
        .map(|c| {
            let name = c.to_string();
            let (mut y_rel, mut xy_distance) = (Vec::new(), Vec::new());
            for t in targets {
                let (a, s) = (
                    t.coding(&name).expect("rendered"),
                    t.coding("spectral").expect("rendered"),
                );
                y_rel.push(a.luminance_cd_m2 / s.luminance_cd_m2 - 1.0);
                xy_distance.push((a.x - s.x).hypot(a.y - s.y));
            }
            let m = y_rel.len().max(1) as f64;
            let rms_rel = (y_rel.iter().map(|r| r * r).sum::<f64>() / m).sqrt();
            let mean_rel = y_rel.iter().sum::<f64>() / m;
            (
                name,
                Deviation {
                    y_rel,
                    rms_rel,
                    mean_rel,
                    xy_distance,
                },
            )
        })
        .collect()
}

// ---- the converged spectrum for the simulated PR-650 -------------------------
//
// The simulated booth's truth is its own converged solution, independent of
// every render it is compared with: its own seed (no comparison, study or
// reference render uses it), no bounce cap (Russian roulette ends the paths,
// unbiased), the 1 nm `spectral` coding, and a relative standard error of Y
// below 0.1 %. These settings are part of the cache key.

/// Relative standard error of Y at which [`converged_target_spectrum`] stops.
pub const CONVERGED_RELATIVE_SE: f64 = 1e-3;

/// The seed of the simulated booth's truth: "truth-v1" in ASCII, used by no
/// comparison render (seed 1), study seed (1…64) or reference (0xC0FFEE).
pub const TRUTH_SEED: u64 = 0x7472_7574_682d_7631;

/// Russian roulette starts at this bounce in the truth; before it every path
/// continues. With no bounce cap the estimate has no truncation bias.
pub const TRUTH_ROULETTE_FROM: u32 = 3;

/// The render settings of the simulated booth's truth for one target:
/// `spectral` (1 nm), [`TRUTH_SEED`], unbounded bounces with Russian roulette
/// from [`TRUTH_ROULETTE_FROM`], rendered until the relative SE of Y is
/// below [`CONVERGED_RELATIVE_SE`] (at most 2²⁴ paths).
pub fn truth_settings(target_id: &str) -> RenderSettings {
    RenderSettings {
        codings: vec![Coding::Spectral],
        targets: Some(vec![target_id.to_string()]),
        target_relative_se: Some(CONVERGED_RELATIVE_SE),
        max_samples: 1 << 24,
        seed: TRUTH_SEED,
        max_bounces: None,
        russian_roulette_from: Some(TRUTH_ROULETTE_FROM),
        ..RenderSettings::default()
    }
}

/// A stable content hash (FNV-1a, 64 bit) of the scene file and every file it
/// references (spectra CSVs, IES files), in load order, with the renderer's
/// cache version: the key under which converged spectra are cached.
///
/// It is not the [scene bundle](bundle)'s hash: see that module for how the
/// two relate.
pub fn scene_hash(scene: &Scene) -> Result<String, RenderError> {
    let mut contents = Vec::with_capacity(scene.files.len());
    for f in &scene.files {
        // Bounded as at load time: the files were regular files then, and
        // are read again the same way (a file swapped for a FIFO since is
        // refused, not waited on).
        contents.push(input_file::read_bytes(f).map_err(|e| RenderError::Io(e.to_string()))?);
    }
    Ok(scene_hash_of(contents.iter().map(Vec::as_slice)))
}

/// [`scene_hash`] of the files' contents, given in the loader's order
/// (`Scene::files`).
pub fn scene_hash_of<'a>(contents: impl IntoIterator<Item = &'a [u8]>) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut feed = |bytes: &[u8]| {
        for b in bytes {
            h ^= *b as u64;
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
    };
    feed(b"lightbooth-render-v1");
    for bytes in contents {
        feed(&(bytes.len() as u64).to_le_bytes());
        feed(bytes);
    }
    format!("{h:016x}")
}

fn memory_cache() -> &'static Mutex<HashMap<(String, String), ConvergedTruth>> {
    static C: OnceLock<Mutex<HashMap<(String, String), ConvergedTruth>>> = OnceLock::new();
    C.get_or_init(|| Mutex::new(HashMap::new()))
}

/// Where the converged spectrum of `target_id` is cached in `cache_dir`:
/// the scene hash and the target id's UTF-8 bytes in hex, so two ids never
/// share a file (`a.b` and `a_b` did when unsafe characters became `_`).
pub fn cache_file(cache_dir: &Path, hash: &str, target_id: &str) -> PathBuf {
    let hex: String = target_id.bytes().map(|b| format!("{b:02x}")).collect();
    cache_dir.join(format!("{hash}-{hex}.csv"))
}

/// A cached converged spectrum, or `None` (with the reason logged) when the
/// file is missing or unreadable: a torn or corrupt file is a cache miss,
/// recomputed and replaced, never an error.
fn read_cached(file: &Path) -> Option<ConvergedTruth> {
    if !file.exists() {
        return None;
    }
    let read = SpectraTable::read(file)
        .map_err(|e| e.to_string())
        .and_then(|t| {
            let s = t
                .spectrum("radiance", SpectralUnit::SpectralRadiance)
                .map_err(|e| e.to_string())?;
            let se = t
                .spectrum(SE_COLUMN, SpectralUnit::RelativePower)
                .map_err(|e| format!("{e} (a cache file from before the truth kept its standard error)"))?;
            Ok((s, se.values().first().copied().unwrap_or(f64::NAN)))
        })
        .and_then(|(s, relative_se_y)| {
            if !s.grid().same_as(&Grid::one_nm()) {
                Err("not on the 1 nm grid".to_string())
            } else if !s.values().iter().all(|v| v.is_finite()) {
                Err("a value is not a finite number".to_string())
            } else if !(relative_se_y.is_finite() && relative_se_y >= 0.0) {
                Err(format!(
                    "its standard error {relative_se_y} is not a finite, non-negative number"
                ))
            } else {
                Ok(ConvergedTruth {
                    spectrum: s,
                    relative_se_y,
                })
            }
        });
    match read {
        Ok(s) => Some(s),
        Err(e) => {
            tracing::warn!(file = %file.display(), error = %e, "unreadable converged-spectrum cache file; recomputing it");
            None
        }
    }
}

/// Writes `spectrum` to `file` atomically: a temporary file in the same
/// folder, flushed to disk, then renamed over `file`, so a reader sees the
/// old file or the whole new one, never a torn one.
fn write_cached(file: &Path, truth: &ConvergedTruth) -> Result<(), RenderError> {
    use std::sync::atomic::AtomicUsize;
    static COUNTER: AtomicUsize = AtomicUsize::new(0);
    let io = |e: &dyn std::fmt::Display| RenderError::Io(format!("{}: {e}", file.display()));
    let mut tmp_name = file.as_os_str().to_os_string();
    tmp_name.push(format!(
        ".{}.{}.tmp",
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    let tmp = PathBuf::from(tmp_name);
    let written = (|| {
        let out = std::fs::File::create(&tmp).map_err(|e| io(&e))?;
        let se = vec![truth.relative_se_y; truth.spectrum.values().len()];
        write_csv(
            &out,
            truth.spectrum.grid(),
            &[("radiance", truth.spectrum.values()), (SE_COLUMN, &se)],
        )
        .map_err(|e| io(&e))?;
        out.sync_all().map_err(|e| io(&e))?;
        std::fs::rename(&tmp, file).map_err(|e| io(&e))
    })();
    if written.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    written
}

/// The cache file's column of the truth's relative standard error of Y (the
/// same number on every row).
const SE_COLUMN: &str = "y_relative_se";

/// The simulated booth's truth for one target: its converged spectral
/// radiance and the render's own relative standard error of Y (analysis
/// observer), which a comparison with a simulated measurement counts in its
/// error budget (the truth is an estimate too).
#[derive(Clone, Debug, PartialEq)]
pub struct ConvergedTruth {
    /// W/(sr·m²·nm) on [`Grid::one_nm`].
    pub spectrum: Spectrum,
    /// The truth render's standard error of Y over Y (≤ [`CONVERGED_RELATIVE_SE`]
    /// unless it stopped at its path cap).
    pub relative_se_y: f64,
}

/// The converged `spectral` radiance of a target, W/(sr·m²·nm) on
/// [`Grid::one_nm`] ([`converged_target_truth`] without its standard error).
pub fn converged_target_spectrum(
    scene_path: &Path,
    target_id: &str,
    cache_dir: Option<&Path>,
) -> Result<Spectrum, RenderError> {
    converged_target_truth(scene_path, target_id, cache_dir).map(|t| t.spectrum)
}

/// The converged `spectral` radiance of a target, W/(sr·m²·nm) on
/// [`Grid::one_nm`], with its relative standard error of Y: rendered until
/// that is below [`CONVERGED_RELATIVE_SE`], and cached by [`truth_hash`]
/// (the scene's content and the truth's settings) and the target id — as a
/// CSV in `cache_dir` (columns `radiance` and `y_relative_se`), or in
/// memory for this process when `cache_dir` is `None` — so it is computed
/// once per scene content.
pub fn converged_target_truth(
    scene_path: &Path,
    target_id: &str,
    cache_dir: Option<&Path>,
) -> Result<ConvergedTruth, RenderError> {
    let scene = load_scene(scene_path)?;
    if scene.target(target_id).is_none() {
        return Err(RenderError::UnknownTarget(target_id.into(), scene.targets().join(", ")));
    }
    let settings = truth_settings(target_id);
    let hash = truth_hash(&scene, &settings)?;
    let key = (hash.clone(), target_id.to_string());
    if let Some(dir) = cache_dir {
        if let Some(s) = read_cached(&cache_file(dir, &hash, target_id)) {
            return Ok(s);
        }
    } else if let Some(s) = memory_cache().lock().expect("cache lock").get(&key) {
        return Ok(s.clone());
    }
    let truth = converge(&scene, &settings)?;
    match cache_dir {
        Some(dir) => {
            std::fs::create_dir_all(dir).map_err(|e| RenderError::Io(format!("{}: {e}", dir.display())))?;
            write_cached(&cache_file(dir, &hash, target_id), &truth)?;
        }
        None => {
            memory_cache().lock().expect("cache lock").insert(key, truth.clone());
        }
    }
    Ok(truth)
}

/// The cache key of a truth spectrum: the scene's content hash and the
/// truth's render settings (seed, bounces, roulette, goal), so a change of
/// either is never served an old spectrum.
pub fn truth_hash(scene: &Scene, settings: &RenderSettings) -> Result<String, RenderError> {
    let settings_json = serde_json::to_string(settings).map_err(|e| RenderError::Settings(e.to_string()))?;
    let mut h: u64 = u64::from_str_radix(&scene_hash(scene)?, 16).expect("hex hash");
    for b in b"truth-settings:".iter().chain(settings_json.as_bytes()) {
        h ^= *b as u64;
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    Ok(format!("{h:016x}"))
}

fn converge(scene: &Scene, settings: &RenderSettings) -> Result<ConvergedTruth, RenderError> {
    // The simulator's truth runs to the end (no job's token: it is cached
    // by content and shared by every later measurement).
    let r = render(scene, settings, None, None)?;
    let c = &r.targets[0].codings[0].1;
    let spectrum = Spectrum::new(Grid::one_nm(), SpectralUnit::SpectralRadiance, c.bands.clone())
        .map_err(|e| RenderError::Prepare(e.to_string()))?;
    let relative_se_y = if c.luminance_cd_m2 > 0.0 {
        c.luminance_se_cd_m2 / c.luminance_cd_m2
    } else {
        0.0
    };
    Ok(ConvergedTruth {
        spectrum,
        relative_se_y,
    })
}
