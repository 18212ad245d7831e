//! Failure maps: where each colour coding stops being good enough.
//!
//! The study's thresholds: a coding *fails* where its colour differs from the
//! `spectral` reference by more than ΔE*ab = 2 ([`DELTA_E_THRESHOLD`], the
//! discrimination threshold; ΔE00 is reported alongside) or where its
//! luminance along the targets differs by more than rms_rel = 5 %
//! ([`RMS_REL_THRESHOLD`]). Two sweeps:
//!
//! 1. **Illuminant × reflectance** ([`illuminant_patch_map`]): the 24
//!    ColorChecker patches under A (halogen), D65, F2 and F11 (spiky), in
//!    every coding. This map is *exact, not rendered*: the direct light a
//!    Lambertian patch reflects toward the radiometer is, in every coding,
//!    the element-wise product of the light's channels and the patch's
//!    reflectance channels ([`ChannelLayout::light_channels`] ×
//!    [`ChannelLayout::reflectance_channels`], see [`lightbooth_render::coding`])
//!    times a geometry factor I·cos θ/(π d²) that is the same scalar for all
//!    codings. CIELAB is invariant to that common scale (the white scales with
//!    it), so the product decoded by [`ChannelLayout::decode`] gives each
//!    coding's colour with no Monte Carlo noise. The CIELAB white is the
//!    illuminant's perfect white: the same light on a reflectance-1 patch in
//!    `spectral`. Saturation is the patch's chroma C*ab in `spectral` under
//!    that illuminant.
//!
//!    Illuminant spectra: A and D65 from the CIE 1 nm tables; F2 and F11 are
//!    published at 5 nm only and are **linearly resampled to 1 nm** here — an
//!    approximation of the true 1 nm lamp spectrum (the mercury lines are
//!    narrower than 5 nm), so `spectral` under F2/F11 is the reference *for
//!    that interpolated spectrum* (and `nstep81`, which samples it at the
//!    5 nm table's own wavelengths, differs from it only by the integration
//!    rule). Each light is normalised to 1 cd (V(λ), CIE
//!    1931 ȳ, as the scene loader does: a candela is defined by V(λ)); the scale cancels in CIELAB.
//!
//! 2. **Interreflection strength** ([`interreflection_map`]): the CYLINDER
//!    scene with its card's reflectance scaled by s ∈ {0.25, 0.5, 0.75, 1}
//!    (so the green light bounced onto the white cylinder grows with s),
//!    path traced for several seeds. Per seed and coding: rms_rel of
//!    luminance over the targets against `spectral` of the same render (the
//!    same paths, so the difference is the coding's, not sampling noise) and
//!    the mean ΔE*ab/ΔE00 against `spectral`, with `spectral` at the top
//!    target (h21) as the CIELAB white. Reported as mean ± SD over seeds
//!    (sample SD, n − 1). Where a coding crosses a threshold, the crossing
//!    scale is **linearly interpolated in s between the two sweep points**
//!    that bracket it (an approximation; the curve between them is not
//!    sampled).
//!
//! Units: XYZ relative to the light (1 cd normalisation, geometry factor
//! omitted) in map 1, cd/m² in map 2; rms_rel as a fraction (0.05 = 5 %);
//! ΔE in CIELAB units. Everything is deterministic for fixed seeds.

use std::path::{Path, PathBuf};

use serde::Serialize;
use tokio_util::sync::CancellationToken;

use crate::charts::{grid_chart, line_chart, LineSeriesData};
use lightbooth_render::coding::OBSERVER;
use lightbooth_render::{load_scene, render, ChannelLayout, Coding, RenderError, RenderSettings, SceneError};
use lightbooth_science::colorimetry::{luminous_1nm, Lab, Xyz};
use lightbooth_science::comparison::{compare_point, mean_sd, summarize};
use lightbooth_science::reference_data::{illuminant, illuminant_1nm, reflectances, Illuminant, ReflectanceSet};
use lightbooth_science::spectrum::{Grid, SpectralUnit, Spectrum};

/// ΔE*ab above which a coding's colour is discriminably wrong.
pub const DELTA_E_THRESHOLD: f64 = 2.0;
/// rms_rel (fraction) above which a coding's luminance profile is wrong.
pub const RMS_REL_THRESHOLD: f64 = 0.05;
/// The swept illuminants, from smooth to spiky.
pub const ILLUMINANTS: [Illuminant; 4] = [Illuminant::A, Illuminant::D65, Illuminant::F2, Illuminant::F11];
/// The swept card reflectance scales.
pub const CARD_SCALES: [f64; 4] = [0.25, 0.5, 0.75, 1.0];

/// Everything that can stop a failure map.
#[derive(Debug, thiserror::Error)]
pub enum FailureMapError {
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error(transparent)]
    Render(#[from] RenderError),
    #[error("{0}")]
    Spectrum(String),
    #[error("{0}")]
    Settings(String),
}

// ---- 1. illuminant × patch -------------------------------------------------

/// One coding's colour of one patch.
#[derive(Clone, Debug, Serialize)]
pub struct PatchCell {
    pub coding: String,
    /// XYZ relative to a 1 cd light (geometry factor omitted).
    pub xyz: Xyz,
    pub lab: Lab,
    /// ΔE*ab against `spectral`.
    #[serde(rename = "dE76")]
    pub de76: f64,
    /// ΔE00 against `spectral`.
    #[serde(rename = "dE00")]
    pub de00: f64,
    /// ΔE*ab > [`DELTA_E_THRESHOLD`].
    pub fails: bool,
}

/// One patch under one illuminant, in every coding.
#[derive(Clone, Debug, Serialize)]
pub struct PatchRow {
    /// Chart number, 1 = dark skin … 24 = black.
    pub patch: usize,
    pub name: String,
    /// C*ab in `spectral` under this illuminant: the patch's saturation.
    pub chroma: f64,
    pub cells: Vec<PatchCell>,
}

impl PatchRow {
    pub fn cell(&self, coding: &str) -> Option<&PatchCell> {
        self.cells.iter().find(|c| c.coding == coding)
    }
}

/// How one coding fares over the patches under one illuminant.
#[derive(Clone, Debug, Serialize)]
pub struct CodingFailures {
    pub coding: String,
    /// Patches with ΔE*ab > [`DELTA_E_THRESHOLD`].
    pub failing: usize,
    /// Patches with ΔE00 > [`DELTA_E_THRESHOLD`].
    pub failing_de00: usize,
    /// The failing patch with the lowest chroma: below its saturation, the coding holds.
    pub least_saturated_failing: Option<String>,
    pub least_saturated_failing_chroma: Option<f64>,
    #[serde(rename = "max_dE76")]
    pub max_de76: f64,
    #[serde(rename = "mean_dE76")]
    pub mean_de76: f64,
}

/// The 24 patches under one illuminant.
#[derive(Clone, Debug, Serialize)]
pub struct IlluminantMap {
    pub illuminant: String,
    /// True when the 1 nm spectrum is a linear interpolation of the 5 nm table (F2, F11).
    pub resampled_from_5nm: bool,
    /// The CIELAB white: the light on a reflectance-1 patch, `spectral`.
    pub white: Xyz,
    pub patches: Vec<PatchRow>,
    pub summary: Vec<CodingFailures>,
}

impl IlluminantMap {
    pub fn summary_for(&self, coding: &str) -> Option<&CodingFailures> {
        self.summary.iter().find(|s| s.coding == coding)
    }
}

/// Every illuminant's map.
#[derive(Clone, Debug, Serialize)]
pub struct IlluminantPatchMap {
    #[serde(rename = "threshold_dE76")]
    pub threshold_de: f64,
    pub codings: Vec<String>,
    pub illuminants: Vec<IlluminantMap>,
}

impl IlluminantPatchMap {
    pub fn illuminant(&self, name: &str) -> Option<&IlluminantMap> {
        self.illuminants.iter().find(|m| m.illuminant == name)
    }
}

/// The illuminant as a light of 1 cd on the 1 nm grid (W/(sr·nm) per cd) and
/// whether it was interpolated from 5 nm.
fn light_per_cd(which: Illuminant) -> Result<(Spectrum, bool), FailureMapError> {
    let spe = |e: lightbooth_science::spectrum::SpectrumError| {
        FailureMapError::Spectrum(format!("illuminant {}: {e}", which.name()))
    };
    let (spd, resampled) = match illuminant_1nm(which) {
        Some(s) => (s.resample(&Grid::one_nm()).map_err(spe)?, false),
        None => (illuminant(which).resample(&Grid::one_nm()).map_err(spe)?, true),
    };
    // "1 cd" is a photometric input: V(λ) (CIE 1931 ȳ), as the renderer
    // normalises a lamp, not the analysis observer (issue 46).
    let lum = luminous_1nm(spd.values());
    if lum.is_nan() || lum <= 0.0 {
        return Err(FailureMapError::Spectrum(format!(
            "illuminant {} has no luminous power",
            which.name()
        )));
    }
    Ok((spd.scaled(1.0 / lum).map_err(spe)?, resampled))
}

/// The codings with `spectral` (the reference) present exactly once.
fn with_spectral(codings: &[Coding]) -> Vec<Coding> {
    let mut out: Vec<Coding> = Vec::new();
    for &c in codings.iter().chain(std::iter::once(&Coding::Spectral)) {
        if !out.contains(&c) {
            out.push(c);
        }
    }
    out
}

/// Each coding's XYZ of `reflectance` lit directly by the light whose channels are `light`.
fn direct_xyz(layout: &ChannelLayout, light: &[f32], reflectance: &Spectrum) -> Result<Vec<Xyz>, FailureMapError> {
    let refl = layout
        .reflectance_channels(reflectance)
        .map_err(FailureMapError::Spectrum)?;
    let product: Vec<f64> = light.iter().zip(&refl).map(|(l, r)| *l as f64 * *r as f64).collect();
    Ok((0..layout.entries().len())
        .map(|i| layout.decode(i, &product).xyz)
        .collect())
}

/// The exact illuminant × ColorChecker map for `codings` (`spectral` is
/// added as the reference if absent) under each of `illuminants`.
pub fn illuminant_patch_map(
    codings: &[Coding],
    illuminants: &[Illuminant],
) -> Result<IlluminantPatchMap, FailureMapError> {
    let codings = with_spectral(codings);
    let layout = ChannelLayout::new(&codings);
    let names: Vec<String> = codings.iter().map(|c| c.to_string()).collect();
    let spectral = codings.iter().position(|c| *c == Coding::Spectral).expect("added");
    let patches = reflectances(ReflectanceSet::ColorChecker);
    let perfect = Spectrum::constant(Grid::analysis(), SpectralUnit::Reflectance, 1.0)
        .map_err(|e| FailureMapError::Spectrum(e.to_string()))?;
    let mut maps = Vec::new();
    for &which in illuminants {
        let (light, resampled_from_5nm) = light_per_cd(which)?;
        let light = layout.light_channels(&light).map_err(FailureMapError::Spectrum)?;
        let white = direct_xyz(&layout, &light, &perfect)?[spectral];
        let mut rows = Vec::new();
        for (k, (name, reflectance)) in patches.iter().enumerate() {
            let xyz = direct_xyz(&layout, &light, reflectance)?;
            let reference_xyz = xyz[spectral];
            let reference = Lab::from_xyz(reference_xyz, white);
            let cells = names
                .iter()
                .zip(&xyz)
                .map(|(coding, &xyz)| {
                    let d = compare_point(reference_xyz, xyz, white, OBSERVER);
                    PatchCell {
                        coding: coding.clone(),
                        xyz,
                        lab: Lab::from_xyz(xyz, white),
                        de76: d.de76,
                        de00: d.de00,
                        fails: d.de76 > DELTA_E_THRESHOLD,
                    }
                })
                .collect();
            rows.push(PatchRow {
                patch: k + 1,
                name: name.clone(),
                chroma: reference.chroma(),
                cells,
            });
        }
        let summary = names
            .iter()
            .enumerate()
            .map(|(i, coding)| {
                let failing: Vec<&PatchRow> = rows.iter().filter(|r| r.cells[i].fails).collect();
                let least = failing.iter().min_by(|a, b| a.chroma.total_cmp(&b.chroma));
                CodingFailures {
                    coding: coding.clone(),
                    failing: failing.len(),
                    failing_de00: rows.iter().filter(|r| r.cells[i].de00 > DELTA_E_THRESHOLD).count(),
                    least_saturated_failing: least.map(|r| r.name.clone()),
                    least_saturated_failing_chroma: least.map(|r| r.chroma),
                    max_de76: rows.iter().map(|r| r.cells[i].de76).fold(0.0, f64::max),
                    mean_de76: rows.iter().map(|r| r.cells[i].de76).sum::<f64>() / rows.len() as f64,
                }
            })
            .collect();
        maps.push(IlluminantMap {
            illuminant: which.name().to_string(),
            resampled_from_5nm,
            white,
            patches: rows,
            summary,
        });
    }
    Ok(IlluminantPatchMap {
        threshold_de: DELTA_E_THRESHOLD,
        codings: names,
        illuminants: maps,
    })
}

// ---- 2. interreflection ----------------------------------------------------

/// What to sweep: the interreflection scene and its sweep, and the codings of both maps.
#[derive(Clone, Debug, Serialize)]
pub struct FailureMapSettings {
    /// The scene (CYLINDER).
    pub scene: PathBuf,
    /// The material whose reflectance is scaled (`green_card`).
    pub card_material: String,
    /// Reflectance scales, each in (0, 1].
    pub scales: Vec<f64>,
    /// Monte Carlo seeds (at least two: the spread is part of the result).
    pub seeds: Vec<u64>,
    /// Radiometer paths per target per render (fixed; no SE-adaptive sampling).
    pub samples: u64,
    /// The bounce cap; `None`: none (Russian roulette, unbiased).
    pub max_bounces: Option<u32>,
    /// The target whose `spectral` XYZ is the CIELAB white.
    pub white_target: String,
    #[serde(serialize_with = "coding_names")]
    pub codings: Vec<Coding>,
}

fn coding_names<S: serde::Serializer>(codings: &[Coding], s: S) -> Result<S::Ok, S::Error> {
    s.collect_seq(codings.iter().map(|c| c.to_string()))
}

impl FailureMapSettings {
    /// The CYLINDER sweep of the study with the scene at `scene`: 4 seeds,
    /// 4096 paths per target, no bounce cap, all seven codings.
    pub fn cylinder(scene: &Path) -> FailureMapSettings {
        FailureMapSettings {
            scene: scene.to_path_buf(),
            card_material: "green_card".into(),
            scales: CARD_SCALES.to_vec(),
            seeds: vec![1, 2, 3, 4],
            samples: 4096,
            max_bounces: None,
            white_target: "h21".into(),
            codings: Coding::ALL.to_vec(),
        }
    }
}

/// A figure's mean and sample SD (n − 1) over seeds.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct MeanSd {
    pub mean: f64,
    pub sd: f64,
}

impl MeanSd {
    fn of(values: &[f64]) -> MeanSd {
        let (mean, sd) = mean_sd(values.iter().copied());
        MeanSd {
            mean,
            sd: sd.unwrap_or(0.0),
        }
    }

    /// The standard error of the mean, sd/√n, for `n` seeds.
    pub fn se(&self, n: usize) -> f64 {
        self.sd / (n as f64).sqrt()
    }
}

/// One seed's figures for one coding at one scale.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct SeedFigures {
    pub seed: u64,
    pub rms_rel: f64,
    #[serde(rename = "mean_dE76")]
    pub mean_de76: f64,
    #[serde(rename = "mean_dE00")]
    pub mean_de00: f64,
}

/// One coding at one card scale, over the seeds.
#[derive(Clone, Debug, Serialize)]
pub struct ScalePoint {
    pub scale: f64,
    pub rms_rel: MeanSd,
    #[serde(rename = "mean_dE76")]
    pub mean_de76: MeanSd,
    #[serde(rename = "mean_dE00")]
    pub mean_de00: MeanSd,
    pub per_seed: Vec<SeedFigures>,
}

/// Where a figure's mean first exceeds its threshold along the sweep.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Crossing {
    /// Below the threshold at every swept scale.
    Never,
    /// Already above it at the smallest swept scale.
    AtOrBelow { scale: f64 },
    /// Between two sweep points, linearly interpolated in s.
    At { scale: f64 },
}

impl Crossing {
    fn find(points: &[(f64, f64)], threshold: f64) -> Crossing {
        match points.iter().position(|p| p.1 > threshold) {
            None => Crossing::Never,
            Some(0) => Crossing::AtOrBelow { scale: points[0].0 },
            Some(i) => {
                let ((s0, v0), (s1, v1)) = (points[i - 1], points[i]);
                Crossing::At {
                    scale: s0 + (threshold - v0) / (v1 - v0) * (s1 - s0),
                }
            }
        }
    }

    pub fn fails(&self) -> bool {
        !matches!(self, Crossing::Never)
    }
}

/// One coding along the interreflection sweep.
#[derive(Clone, Debug, Serialize)]
pub struct CodingSweep {
    pub coding: String,
    pub points: Vec<ScalePoint>,
    /// Where mean rms_rel crosses [`RMS_REL_THRESHOLD`].
    pub rms_rel_crossing: Crossing,
    /// Where mean ΔE*ab crosses [`DELTA_E_THRESHOLD`].
    #[serde(rename = "dE76_crossing")]
    pub de_crossing: Crossing,
}

impl CodingSweep {
    pub fn at(&self, scale: f64) -> Option<&ScalePoint> {
        self.points.iter().find(|p| (p.scale - scale).abs() < 1e-12)
    }
}

/// The interreflection sweep's results.
#[derive(Clone, Debug, Serialize)]
pub struct InterreflectionMap {
    pub settings: FailureMapSettings,
    pub threshold_rms_rel: f64,
    #[serde(rename = "threshold_dE76")]
    pub threshold_de: f64,
    pub codings: Vec<CodingSweep>,
}

impl InterreflectionMap {
    pub fn coding(&self, name: &str) -> Option<&CodingSweep> {
        self.codings.iter().find(|c| c.coding == name)
    }
}

/// Renders the scene once per (scale, seed) with all codings in one pass and
/// measures every coding against `spectral` of the same render.
pub fn interreflection_map(
    settings: &FailureMapSettings,
    cancel: Option<&CancellationToken>,
) -> Result<InterreflectionMap, FailureMapError> {
    if settings.seeds.len() < 2 {
        return Err(FailureMapError::Settings(
            "the interreflection map needs at least two seeds: its spread over seeds is part of the result".into(),
        ));
    }
    if settings.scales.is_empty() || settings.scales.iter().any(|s| !(*s > 0.0 && *s <= 1.0)) {
        return Err(FailureMapError::Settings(format!(
            "card reflectance scales must be in (0, 1] (a reflectance stays ≤ 1): {:?}",
            settings.scales
        )));
    }
    let base = load_scene(&settings.scene)?;
    let card = base
        .materials
        .iter()
        .position(|m| m.name == settings.card_material)
        .ok_or_else(|| {
            let names: Vec<&str> = base.materials.iter().map(|m| m.name.as_str()).collect();
            FailureMapError::Settings(format!(
                "{}: no material `{}` (materials: {})",
                settings.scene.display(),
                settings.card_material,
                names.join(", ")
            ))
        })?;
    if base.target(&settings.white_target).is_none() {
        return Err(FailureMapError::Settings(format!(
            "{}: no target `{}` for the CIELAB white (targets: {})",
            settings.scene.display(),
            settings.white_target,
            base.targets().join(", ")
        )));
    }
    let codings = with_spectral(&settings.codings);
    let names: Vec<String> = codings.iter().map(|c| c.to_string()).collect();
    // figures[coding][scale][seed]
    let mut figures = vec![vec![Vec::new(); settings.scales.len()]; names.len()];
    for (si, &scale) in settings.scales.iter().enumerate() {
        let mut scene = base.clone();
        scene.materials[card].reflectance = base.materials[card]
            .reflectance
            .scaled(scale)
            .map_err(|e| FailureMapError::Spectrum(format!("scaling `{}`: {e}", settings.card_material)))?;
        for &seed in &settings.seeds {
            let render_settings = RenderSettings {
                codings: codings.clone(),
                samples: settings.samples,
                max_bounces: settings.max_bounces,
                seed,
                target_relative_se: None,
                ..RenderSettings::default()
            };
            let result = render(&scene, &render_settings, None, cancel)?;
            let white_xyz = result
                .target(&settings.white_target)
                .and_then(|t| t.coding("spectral"))
                .map(|c| Xyz::from_array(c.xyz))
                .expect("white target rendered in spectral");
            for (ci, name) in names.iter().enumerate() {
                let points: Vec<_> = result
                    .targets
                    .iter()
                    .map(|t| {
                        let reference = Xyz::from_array(t.coding("spectral").expect("rendered").xyz);
                        let coded = Xyz::from_array(t.coding(name).expect("rendered").xyz);
                        compare_point(reference, coded, white_xyz, OBSERVER)
                    })
                    .collect();
                let s = summarize(&points);
                figures[ci][si].push(SeedFigures {
                    seed,
                    rms_rel: s.rms_rel,
                    mean_de76: s.mean_de76,
                    mean_de00: s.mean_de00,
                });
            }
        }
    }
    let sweeps = names
        .iter()
        .zip(figures)
        .map(|(name, per_scale)| {
            let points: Vec<ScalePoint> = settings
                .scales
                .iter()
                .zip(per_scale)
                .map(|(&scale, per_seed)| {
                    let pick = |f: fn(&SeedFigures) -> f64| MeanSd::of(&per_seed.iter().map(f).collect::<Vec<_>>());
                    ScalePoint {
                        scale,
                        rms_rel: pick(|f| f.rms_rel),
                        mean_de76: pick(|f| f.mean_de76),
                        mean_de00: pick(|f| f.mean_de00),
                        per_seed,
                    }
                })
                .collect();
            let rms: Vec<(f64, f64)> = points.iter().map(|p| (p.scale, p.rms_rel.mean)).collect();
            let de: Vec<(f64, f64)> = points.iter().map(|p| (p.scale, p.mean_de76.mean)).collect();
            CodingSweep {
                coding: name.clone(),
                rms_rel_crossing: Crossing::find(&rms, RMS_REL_THRESHOLD),
                de_crossing: Crossing::find(&de, DELTA_E_THRESHOLD),
                points,
            }
        })
        .collect();
    Ok(InterreflectionMap {
        settings: settings.clone(),
        threshold_rms_rel: RMS_REL_THRESHOLD,
        threshold_de: DELTA_E_THRESHOLD,
        codings: sweeps,
    })
}

// ---- both, and their outputs -----------------------------------------------

/// The study's failure map: both sweeps.
#[derive(Clone, Debug, Serialize)]
pub struct FailureMap {
    pub illuminant_patch: IlluminantPatchMap,
    pub interreflection: InterreflectionMap,
}

/// Both sweeps: the illuminant × patch map for [`ILLUMINANTS`] and the
/// interreflection map, with the same codings.
pub fn failure_map(
    settings: &FailureMapSettings,
    cancel: Option<&CancellationToken>,
) -> Result<FailureMap, FailureMapError> {
    Ok(FailureMap {
        illuminant_patch: illuminant_patch_map(&settings.codings, &ILLUMINANTS)?,
        interreflection: interreflection_map(settings, cancel)?,
    })
}

impl FailureMap {
    /// Every number in long ("tidy") form, one per line:
    /// `map,illuminant,patch,patch_name,coding,scale,seed,quantity,value`
    /// (fields that do not apply are empty; seed `mean`/`sd` rows are the
    /// summaries over seeds; `NaN` where there is no value: no failing patch,
    /// a threshold never crossed).
    pub fn to_csv(&self) -> String {
        let mut rows: Vec<Vec<String>> = Vec::new();
        let mut row =
            |map: &str, ill: &str, patch: &str, name: &str, coding: &str, scale: &str, seed: &str, q: &str, v: f64| {
                rows.push(
                    [map, ill, patch, name, coding, scale, seed, q, &v.to_string()]
                        .map(str::to_string)
                        .to_vec(),
                );
            };
        for m in &self.illuminant_patch.illuminants {
            let ill = m.illuminant.as_str();
            for (q, v) in [("white_X", m.white.x), ("white_Y", m.white.y), ("white_Z", m.white.z)] {
                row("illuminant_patch", ill, "", "", "", "", "", q, v);
            }
            for p in &m.patches {
                let n = p.patch.to_string();
                row("illuminant_patch", ill, &n, &p.name, "", "", "", "chroma", p.chroma);
                for c in &p.cells {
                    for (q, v) in [
                        ("X", c.xyz.x),
                        ("Y", c.xyz.y),
                        ("Z", c.xyz.z),
                        ("L", c.lab.l),
                        ("a", c.lab.a),
                        ("b", c.lab.b),
                        ("dE76", c.de76),
                        ("dE00", c.de00),
                        ("fails", c.fails as u8 as f64),
                    ] {
                        row("illuminant_patch", ill, &n, &p.name, &c.coding, "", "", q, v);
                    }
                }
            }
            for s in &m.summary {
                for (q, v) in [
                    ("failing", s.failing as f64),
                    ("failing_dE00", s.failing_de00 as f64),
                    (
                        "least_saturated_failing_chroma",
                        s.least_saturated_failing_chroma.unwrap_or(f64::NAN),
                    ),
                    ("max_dE76", s.max_de76),
                    ("mean_dE76", s.mean_de76),
                ] {
                    let name = s.least_saturated_failing.as_deref().unwrap_or("");
                    let patch_name = if q == "least_saturated_failing_chroma" {
                        name
                    } else {
                        ""
                    };
                    row("illuminant_patch", ill, "", patch_name, &s.coding, "", "", q, v);
                }
            }
        }
        for c in &self.interreflection.codings {
            for p in &c.points {
                let scale = p.scale.to_string();
                for f in &p.per_seed {
                    let seed = f.seed.to_string();
                    for (q, v) in [
                        ("rms_rel", f.rms_rel),
                        ("mean_dE76", f.mean_de76),
                        ("mean_dE00", f.mean_de00),
                    ] {
                        row("interreflection", "", "", "", &c.coding, &scale, &seed, q, v);
                    }
                }
                for (q, m) in [
                    ("rms_rel", p.rms_rel),
                    ("mean_dE76", p.mean_de76),
                    ("mean_dE00", p.mean_de00),
                ] {
                    row("interreflection", "", "", "", &c.coding, &scale, "mean", q, m.mean);
                    row("interreflection", "", "", "", &c.coding, &scale, "sd", q, m.sd);
                }
            }
            for (q, crossing) in [
                ("rms_rel_crossing_scale", c.rms_rel_crossing),
                ("dE76_crossing_scale", c.de_crossing),
            ] {
                let v = match crossing {
                    Crossing::Never => f64::NAN,
                    Crossing::AtOrBelow { scale } | Crossing::At { scale } => scale,
                };
                row("interreflection", "", "", "", &c.coding, "", "", q, v);
            }
        }
        crate::export::csv_table::csv_table(
            &[
                "map",
                "illuminant",
                "patch",
                "patch_name",
                "coding",
                "scale",
                "seed",
                "quantity",
                "value",
            ],
            rows,
        )
        .expect("every row has the header's nine columns")
    }

    /// The charts as (file name, SVG): the illuminant × patch grid and the
    /// interreflection rms_rel and ΔE curves.
    pub fn svgs(&self) -> Result<Vec<(String, String)>, String> {
        Ok(vec![
            (
                "failure_map_illuminant_patch.svg".into(),
                illuminant_patch_svg(&self.illuminant_patch)?,
            ),
            (
                "failure_map_interreflection_rms_rel.svg".into(),
                interreflection_rms_rel_svg(&self.interreflection)?,
            ),
            (
                "failure_map_interreflection_dE.svg".into(),
                interreflection_de_svg(&self.interreflection)?,
            ),
        ])
    }
}

/// The illuminant × patch map as one grid: a row per patch (most saturated
/// on top, by chroma averaged over the illuminants), a column per
/// (illuminant, coding), cells coloured by ΔE*ab with failures (> 2) marked.
pub fn illuminant_patch_svg(map: &IlluminantPatchMap) -> Result<String, String> {
    let Some(first) = map.illuminants.first() else {
        return Err("an empty illuminant × patch map has no chart".into());
    };
    let n = first.patches.len();
    let mean_chroma = |k: usize| map.illuminants.iter().map(|m| m.patches[k].chroma).sum::<f64>();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| mean_chroma(b).total_cmp(&mean_chroma(a)));
    let rows: Vec<String> = order
        .iter()
        .map(|&k| format!("{} {}", first.patches[k].patch, first.patches[k].name))
        .collect();
    let mut cols = Vec::new();
    let mut values = vec![Vec::new(); n];
    for m in &map.illuminants {
        for (ci, coding) in map.codings.iter().enumerate() {
            cols.push(format!("{} {coding}", m.illuminant));
            for (r, &k) in order.iter().enumerate() {
                values[r].push(m.patches[k].cells[ci].de76);
            }
        }
    }
    grid_chart(
        "Failure map: ΔE*ab against spectral, direct light (outlined: fails ΔE 2; rows by chroma)",
        &rows,
        &cols,
        &values,
        map.threshold_de,
    )
}

fn sweep_series(map: &InterreflectionMap, pick: fn(&ScalePoint) -> MeanSd, k: f64) -> Vec<LineSeriesData> {
    map.codings
        .iter()
        .map(|c| LineSeriesData {
            name: c.coding.clone(),
            points: c.points.iter().map(|p| (p.scale, k * pick(p).mean)).collect(),
            errors: Some(c.points.iter().map(|p| k * pick(p).sd).collect()),
        })
        .collect()
}

fn threshold_line(map: &InterreflectionMap, name: String, y: f64) -> LineSeriesData {
    let scales = &map.settings.scales;
    let lo = scales.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = scales.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    LineSeriesData {
        name,
        points: vec![(lo, y), (hi, y)],
        errors: None,
    }
}

/// rms_rel (%) against the card scale per coding, ±1 SD over seeds, with the 5 % line.
pub fn interreflection_rms_rel_svg(map: &InterreflectionMap) -> Result<String, String> {
    let mut series = sweep_series(map, |p| p.rms_rel, 100.0);
    series.push(threshold_line(
        map,
        format!("threshold {} %", 100.0 * map.threshold_rms_rel),
        100.0 * map.threshold_rms_rel,
    ));
    line_chart(
        "Interreflection: luminance rms_rel vs spectral (±1 SD over seeds)",
        "card reflectance scale s",
        "rms_rel (%)",
        &series,
        false,
    )
}

/// Mean ΔE*ab against the card scale per coding, ±1 SD over seeds, with the ΔE 2 line.
pub fn interreflection_de_svg(map: &InterreflectionMap) -> Result<String, String> {
    let mut series = sweep_series(map, |p| p.mean_de76, 1.0);
    series.push(threshold_line(
        map,
        format!("threshold ΔE {}", map.threshold_de),
        map.threshold_de,
    ));
    line_chart(
        "Interreflection: mean ΔE*ab vs spectral (±1 SD over seeds)",
        "card reflectance scale s",
        "mean ΔE*ab",
        &series,
        false,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crossing_is_interpolated_between_sweep_points() {
        let pts = [(0.25, 1.0), (0.5, 1.5), (0.75, 2.5), (1.0, 3.0)];
        assert_eq!(Crossing::find(&pts, 2.0), Crossing::At { scale: 0.625 });
        assert_eq!(Crossing::find(&pts, 0.5), Crossing::AtOrBelow { scale: 0.25 });
        assert_eq!(Crossing::find(&pts, 5.0), Crossing::Never);
    }

    /// Spectral against itself is exactly zero, and the white is the light's
    /// own XYZ: a 1 cd light (V(λ), issue 46) on a perfect white has a
    /// V(λ)-weighted Y of exactly 1, and in the map's observer the ratio of
    /// its ȳ to V(λ) over the light (1.0057 for D65 in Judd–Vos).
    #[test]
    fn spectral_is_the_reference_and_the_white_is_one_candela() {
        let map = illuminant_patch_map(&[Coding::NStep(3)], &[Illuminant::D65]).unwrap();
        assert_eq!(map.codings, ["nstep3", "spectral"]);
        let m = &map.illuminants[0];
        let (light, _) = light_per_cd(Illuminant::D65).unwrap();
        assert!((luminous_1nm(light.values()) - 1.0).abs() < 1e-12, "1 cd in V(λ)");
        let ybar = &lightbooth_science::colorimetry::Cmf::of(OBSERVER).on_grid(&Grid::one_nm())[1];
        let y_obs = lightbooth_science::colorimetry::KM_LM_PER_W
            * light.values().iter().zip(ybar).map(|(s, y)| s * y).sum::<f64>();
        assert!(
            (m.white.y - y_obs).abs() < 1e-5 && (y_obs - 1.0).abs() < 0.01,
            "{:?} vs {y_obs}",
            m.white
        );
        assert!(!m.resampled_from_5nm);
        for p in &m.patches {
            assert_eq!(p.cell("spectral").unwrap().de76, 0.0);
        }
        assert_eq!(m.summary_for("spectral").unwrap().failing, 0);
    }

    #[test]
    fn interreflection_refuses_one_seed_and_bad_scales() {
        let mut s = FailureMapSettings::cylinder(Path::new("scenes/cylinder.toml"));
        s.seeds = vec![1];
        assert!(matches!(
            interreflection_map(&s, None),
            Err(FailureMapError::Settings(_))
        ));
        s.seeds = vec![1, 2];
        s.scales = vec![1.5];
        assert!(interreflection_map(&s, None)
            .unwrap_err()
            .to_string()
            .contains("(0, 1]"));
    }
}
