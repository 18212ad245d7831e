//! Model no more than the scene needs: `--auto TOLERANCE`.
//!
//! Given a tolerance against the converged `spectral` answer (ΔE00 of every
//! target and the study's rms_rel of luminance), [`choose_settings`] picks the
//! cheapest colour coding, bounce count and sample count for *this* scene and
//! says why, with the numbers behind each choice:
//!
//! - **N** (of `nstepN`) from the scene's own spectra, with no rendering: for
//!   every light, the colour signals that can reach the radiometer — each
//!   target material under the light (ρₜ·S, direct) and each target material
//!   lit by one bounce off any material (ρₜ·ρₘ·S, including ρₜ², the second
//!   bounce) — are computed exactly (1 nm, as `spectral`) and as N-step
//!   renders them (product of band means on the 81-sample 5 nm grid, XYZ with
//!   the band-averaged observer: exactly what the renderer does, the study's
//!   Fig. 7 quantity carried through to colour). The smallest N in 1…81 (all of
//!   them, not only divisors of 81; uneven bands are allowed, as in
//!   [`lightbooth_science::nstep::Bands`]) whose worst case meets [`SPECTRAL_SHARE`] of the
//!   tolerance is chosen; when none does, `spectral` is needed.
//!   ΔE00 is taken with the light's perfect white (ρ = 1 under S); for the
//!   direct signals also with the signal as its own white, and the larger
//!   kept: the verification's white is the brightest target, which can be
//!   the target itself (CIELAB differences grow as (Y/Yₙ)^⅓, so a sample as
//!   bright as its white shows the largest ΔE). Approximations: second-order
//!   terms are tested unweighted (as if a bounce carried all the light, which
//!   over-states their share — the safety margin for interreflection); third
//!   and later products are not enumerated, their share is bounded by the
//!   bounce analysis.
//! - **Bounces** by rendering (cheap: the chosen coding alone, a pilot of
//!   [`PILOT_SAMPLES`] paths per target, fixed seed: the path tracer draws
//!   the same random numbers whatever max_bounces is, so every render traces
//!   the same paths and the difference of two renders is exactly the added
//!   bounce on those paths) with max_bounces k = 0, 1, 2, …: bounce k adds
//!   aₜₖ = Yₜ(k) − Yₜ(k−1) at target t (aₜ₀ the direct light). Stopping
//!   after b bounces leaves Σ_{j>b} aₜⱼ, estimated as geometric with period
//!   two: (aₜ,b+1 + aₜ,b+2) / (1 − q), q = max(aₜ,b+1/aₜ,b−1, aₜ,b+2/aₜ,b).
//!   Period two because light trapped in a wedge (the CYLINDER touching its
//!   card) alternates between the lit card and the unlit underside, so odd
//!   bounces add far more than even ones and a one-step ratio would stop too
//!   early; for plain geometric decay r, q = r² and the estimate is exact. b
//!   is the smallest with tail / Y ≤ [`BOUNCE_SHARE`] · rms_rel at every
//!   target (Y of the render b + 2, a lower bound on the converged Y).
//! - **Samples** from the standard error: the pilot at b bounces has relative
//!   SE s₀ of Y (the worst target); SE ∝ 1/√n (plain Monte Carlo; the
//!   renderer's randomised QMC converges at least as fast, so this
//!   over-estimates), so n = n₀ · (s₀ / goal)² with goal = [`NOISE_SHARE`] ·
//!   rms_rel, rounded up to whole batches of [`BATCH_SAMPLES`].
//!
//! The three shares add to 1, so the three errors, each at its budget, add to
//! the luminance tolerance (a linear bound; independent errors add in
//! quadrature and do better). ΔE00 is budgeted to the spectral approximation;
//! the luminance errors of the other two move L* by ≈ 116/3 · δY/Y ≤ 0.2 at
//! rms_rel = 2 %, which the remaining half of the ΔE00 budget holds.
//!
//! Not considered: `rgb` and `srgb` (the choice is among nstepN and
//! `spectral`; at loose ΔE00 tolerances `rgb` can be as good and as fast),
//! and the measured cost of channels (the choice minimises N; tracing, not
//! the channel count, dominates the time, so nstep27 often costs about what
//! the chosen N does). The worst case over N is not monotone for bands that do
//! not divide 81 evenly, so the smallest passing N can sit next to failing ones.
//!
//! [`verify`] renders the choice and compares it with a converged `spectral`
//! reference ([`reference_render`]); [`candidate_set`] renders the
//! alternatives of the study's speed/accuracy chart and marks the
//! [`pareto_front`]. Units: luminance cd/m², times seconds of wall clock,
//! errors relative (rms_rel) or ΔE00 (CIEDE2000, Judd–Vos observer).

use std::fmt;
use std::str::FromStr;

use serde::{Serialize, Serializer};
use tokio_util::sync::CancellationToken;

use crate::charts::{scatter_chart, ScatterSeries};
use lightbooth_render::coding::OBSERVER;
use lightbooth_render::scene::TARGET_TOLERANCE_M;
use lightbooth_render::{render, Coding, RenderError, RenderResult, RenderSettings, Scene, BATCH_SAMPLES};
use lightbooth_science::colorimetry::{Cmf, Xyz, KM_LM_PER_W};
use lightbooth_science::comparison::{compare_point, summarize, PointDifference};
use lightbooth_science::nstep::{Bands, NStepObserver};
use lightbooth_science::spectrum::Grid;

/// Share of the tolerance (both ΔE00 and rms_rel) given to the spectral
/// approximation (the choice of N).
pub const SPECTRAL_SHARE: f64 = 0.5;
/// Share of rms_rel given to stopping after a finite number of bounces.
pub const BOUNCE_SHARE: f64 = 0.25;
/// Share of rms_rel given to Monte Carlo noise (the relative SE goal).
pub const NOISE_SHARE: f64 = 0.25;
/// Paths per target of the pilot renders (bounces, SE).
pub const PILOT_SAMPLES: u64 = 2 * BATCH_SAMPLES;
/// The bounce search gives up after testing this many bounces (a scene
/// whose light does not die out).
pub const MAX_BOUNCES_SEARCHED: u32 = 24;

/// Everything that can go wrong choosing or checking settings.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AutoError {
    #[error("tolerance `{0}`: {1}")]
    Tolerance(String, String),
    #[error(transparent)]
    Render(#[from] RenderError),
    #[error("the scene's spectra: {0}")]
    Spectra(String),
    #[error("the scene has {0}")]
    Scene(String),
    #[error("the light has not died out after {MAX_BOUNCES_SEARCHED} bounces (added fraction {0:.3e} at target {1})")]
    Bounces(f64, String),
    #[error("{0}")]
    Chart(String),
}

/// The accuracy asked for, against the converged `spectral` answer.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, serde::Deserialize)]
pub struct Tolerance {
    /// Largest CIEDE2000 difference at any target.
    pub de00: f64,
    /// The study's rms_rel of luminance over the targets (0.02 = 2 %).
    pub rms_rel: f64,
}

impl Default for Tolerance {
    /// ΔE00 ≤ 1 and rms_rel ≤ 2 %.
    fn default() -> Tolerance {
        Tolerance {
            de00: 1.0,
            rms_rel: 0.02,
        }
    }
}

impl fmt::Display for Tolerance {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "de00={},rms={}", self.de00, self.rms_rel)
    }
}

/// Parses `de00=1,rms=0.02` (keys `de00`/`de`, `rms`/`rms_rel`, either
/// order, both required; rms also as a percentage, `rms=2%`), or the short
/// form `1,2%` / `1,0.02`: ΔE00 first, rms_rel second.
impl FromStr for Tolerance {
    type Err = AutoError;
    fn from_str(s: &str) -> Result<Tolerance, AutoError> {
        let bad = |m: &str| AutoError::Tolerance(s.to_string(), m.to_string());
        let number = |v: &str| -> Result<f64, AutoError> {
            let v = v.trim();
            let (v, scale) = match v.strip_suffix('%') {
                Some(p) => (p, 0.01),
                None => (v, 1.0),
            };
            let x: f64 = v.trim().parse().map_err(|_| bad(&format!("`{v}` is not a number")))?;
            if !(x.is_finite() && x > 0.0) {
                return Err(bad("every tolerance must be a positive number"));
            }
            Ok(x * scale)
        };
        let parts: Vec<&str> = s.split(',').map(str::trim).collect();
        if parts.len() != 2 {
            return Err(bad("expected `de00=1,rms=0.02` or the short form `1,2%`"));
        }
        let (mut de00, mut rms) = (None, None);
        if parts.iter().all(|p| !p.contains('=')) {
            de00 = Some(number(parts[0])?);
            rms = Some(number(parts[1])?);
        } else {
            for p in parts {
                let (k, v) = p
                    .split_once('=')
                    .ok_or_else(|| bad(&format!("`{p}`: expected key=value")))?;
                match k.trim().to_ascii_lowercase().as_str() {
                    "de00" | "de" => de00 = Some(number(v)?),
                    "rms" | "rms_rel" => rms = Some(number(v)?),
                    other => return Err(bad(&format!("unknown key `{other}` (de00, rms)"))),
                }
            }
        }
        match (de00, rms) {
            (Some(de00), Some(rms_rel)) => Ok(Tolerance { de00, rms_rel }),
            _ => Err(bad("give both de00 and rms")),
        }
    }
}

/// How N-step with N bands reproduces the scene's colour signals.
#[derive(Clone, Debug, Serialize)]
pub struct NCandidate {
    pub n: usize,
    /// Worst ΔE00 over the signals (the larger of the two whites).
    pub worst_de00: f64,
    /// Worst |Y_N / Y − 1| over the signals.
    pub worst_rel_y: f64,
    /// The signal with the worst ΔE00 (`light: material[×material]`).
    pub worst_signal: String,
    pub meets: bool,
}

/// One render of the bounce search.
#[derive(Clone, Debug, Serialize)]
pub struct BounceStep {
    /// max_bounces of this render.
    pub bounces: u32,
    pub wall_seconds: f64,
    /// Per target, Y at this bounce count, cd/m².
    pub luminance: Vec<f64>,
    /// Per target, what this bounce added over the render before (for 0, the
    /// direct light), cd/m².
    pub added: Vec<f64>,
}

/// Whether stopping after `stop_at` bounces leaves little enough.
#[derive(Clone, Debug, Serialize)]
pub struct BounceTest {
    pub stop_at: u32,
    /// Per target, q = max(a_{b+1}/a_{b−1}, a_{b+2}/a_b): the decay over two
    /// bounces (the pooled ratio of all targets where the target's own is
    /// undefined or ≥ 1; infinite when that is too).
    pub ratio: Vec<f64>,
    /// Per target, (a_{b+1} + a_{b+2}) / (1 − q) / Y_{b+2}: the estimated
    /// luminance left out, relative (Y of the latest render is a lower bound
    /// on the converged one, so this is not under-stated).
    pub tail_fraction: Vec<f64>,
    /// BOUNCE_SHARE · rms_rel.
    pub threshold: f64,
    pub accepted: bool,
}

fn argmax(v: &[f64]) -> (usize, f64) {
    v.iter()
        .copied()
        .enumerate()
        .fold((0, f64::NEG_INFINITY), |a, b| if b.1 > a.1 { b } else { a })
}

fn ratio(num: f64, den: f64) -> f64 {
    if num <= 0.0 {
        0.0
    } else if den <= 0.0 {
        f64::INFINITY
    } else {
        num / den
    }
}

/// The test of stopping after `b` bounces, from the renders 0 … b + 2.
/// Where a target's own ratio is undefined or ≥ 1 (its earlier bounce
/// added nothing in the pilot's paths, or a few late paths make it noise),
/// the ratio of the sums over all targets stands in: the decay is a property
/// of the scene's transport, and the numerator a_{b+1} + a_{b+2}, the
/// target's own, still has to be small.
pub fn bounce_test(steps: &[BounceStep], b: u32, threshold: f64) -> BounceTest {
    let b = b as usize;
    let last = &steps[b + 2];
    let sum = |k: usize| steps[k].added.iter().sum::<f64>();
    let q_of = |a: &dyn Fn(usize) -> f64| {
        let mut q = ratio(a(b + 2), a(b));
        if b >= 1 {
            q = q.max(ratio(a(b + 1), a(b - 1)));
        }
        q
    };
    let pooled = q_of(&sum);
    let mut q = Vec::new();
    let mut tail = Vec::new();
    for t in 0..last.luminance.len() {
        let a = |k: usize| steps[k].added[t];
        let mut qt = q_of(&a);
        if qt >= 1.0 {
            qt = pooled;
        }
        let left = a(b + 1) + a(b + 2);
        let y = last.luminance[t];
        tail.push(if left <= 0.0 {
            0.0
        } else if qt < 1.0 && y > 0.0 {
            left / (1.0 - qt) / y
        } else {
            f64::INFINITY
        });
        q.push(qt);
    }
    let accepted = tail.iter().all(|f| *f <= threshold);
    BounceTest {
        stop_at: b as u32,
        ratio: q,
        tail_fraction: tail,
        threshold,
        accepted,
    }
}

/// The sample count and the pilot it was extrapolated from.
#[derive(Clone, Debug, Serialize)]
pub struct SampleChoice {
    pub pilot_samples: u64,
    /// The worst target's relative SE of Y in the pilot.
    pub pilot_relative_se: f64,
    pub pilot_target: String,
    /// The relative SE goal: NOISE_SHARE · rms_rel.
    pub goal_relative_se: f64,
    pub samples: u64,
    /// s₀ · √(n₀ / n): the relative SE expected at `samples`.
    pub predicted_relative_se: f64,
}

/// What the choice is expected to achieve, per source of error.
#[derive(Clone, Debug, Serialize)]
pub struct Predicted {
    /// Worst ΔE00 of the spectral approximation (N analysis).
    pub spectral_de00: f64,
    /// Worst relative luminance error of the spectral approximation.
    pub spectral_rel_y: f64,
    /// Largest estimated relative luminance left in the bounces not traced.
    pub bounce_tail_rel: f64,
    /// Relative SE of Y expected at the chosen sample count.
    pub relative_se: f64,
    /// The linear sum of the three: a bound on rms_rel.
    pub rms_rel_bound: f64,
}

/// The cheapest settings that meet the tolerance, with the reasons.
#[derive(Clone, Debug, Serialize)]
pub struct AutoChoice {
    pub scene: String,
    pub tolerance: Tolerance,
    /// N of `nstepN` (81 when even that is not enough and `needs_spectral`).
    pub n: usize,
    /// No N ≤ 81 meets the tolerance: render `spectral`.
    pub needs_spectral: bool,
    #[serde(serialize_with = "coding_name")]
    pub coding: Coding,
    pub bounces: u32,
    /// Paths per target.
    pub samples: u64,
    pub seed: u64,
    /// One sentence per choice with the numbers behind it.
    pub reasons: Vec<String>,
    pub predicted: Predicted,
    /// The target materials the N analysis started from.
    pub target_materials: Vec<String>,
    /// Every N = 1…81 with its worst case.
    pub n_analysis: Vec<NCandidate>,
    /// Per light (id), the study's Fig. 7 curve for the scene's materials:
    /// mean RMS N-step reconstruction error of the colour signals for
    /// N = 1…81, relative to N = 1 ([`lightbooth_science::nstep::nstep_error`]).
    pub fig7_error: Vec<(String, Vec<f64>)>,
    pub bounce_steps: Vec<BounceStep>,
    /// Each stopping point tested, the last one accepted.
    pub bounce_tests: Vec<BounceTest>,
    /// Bounces of the converged reference ([`reference_render`]).
    pub reference_bounces: u32,
    pub sample_choice: SampleChoice,
    /// Wall time of the pilot renders (the cost of choosing).
    pub choosing_seconds: f64,
}

fn coding_name<S: Serializer>(c: &Coding, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(&c.to_string())
}

impl AutoChoice {
    /// The render settings of the choice: the coding alone, exactly
    /// `samples` paths per target (no adaptive SE goal).
    pub fn settings(&self) -> RenderSettings {
        RenderSettings {
            codings: vec![self.coding],
            samples: self.samples,
            max_bounces: Some(self.bounces),
            // A chosen cap, its tail estimated: no roulette (the paths of the pilots).
            russian_roulette_from: None,
            seed: self.seed,
            target_relative_se: None,
            ..RenderSettings::default()
        }
    }
}

/// CIE XYZ of a 1 nm spectral radiance (the `spectral` coding's sum).
fn xyz_1nm(values: &[f64], cmf: &[Vec<f64>; 3]) -> Xyz {
    let mut s = [0.0; 3];
    for (i, v) in values.iter().enumerate() {
        for c in 0..3 {
            s[c] += v * cmf[c][i];
        }
    }
    Xyz::from_array(s.map(|v| v * KM_LM_PER_W))
}

/// The materials of the surfaces the targets lie on (indices into `scene.materials`).
pub fn target_materials(scene: &Scene) -> Result<Vec<usize>, AutoError> {
    let mut out: Vec<usize> = Vec::new();
    for t in &scene.target_list {
        let on: Vec<usize> = scene
            .primitives
            .iter()
            .filter(|p| p.shape.distance_to(t.point) < TARGET_TOLERANCE_M)
            .map(|p| p.material)
            .collect();
        if on.is_empty() {
            return Err(AutoError::Scene(format!("target `{}` on no surface", t.id)));
        }
        for m in on {
            if !out.contains(&m) {
                out.push(m);
            }
        }
    }
    if out.is_empty() {
        return Err(AutoError::Scene("no targets".into()));
    }
    Ok(out)
}

/// One colour signal: its name and its two forms.
struct Signal {
    name: String,
    /// On the 1 nm grid.
    exact: Vec<f64>,
    /// The factors on the 81-sample grid (light first), multiplied per band.
    factors_81: Vec<Vec<f64>>,
    white_exact: Xyz,
    /// A target material directly lit: it can be the verification's white.
    direct: bool,
}

/// Every light of the scene with its spectrum: the point luminaires'
/// spectral intensity per cd and the area lights' spectral radiance (only
/// the spectrum's shape matters to the N analysis).
fn light_spectra(scene: &Scene) -> Vec<(String, &lightbooth_science::spectrum::Spectrum)> {
    scene
        .lights
        .iter()
        .map(|l| (l.id.clone(), &l.spectrum_per_cd))
        .chain(scene.emitters.iter().map(|e| (e.name.clone(), &e.radiance)))
        .collect()
}

/// The N analysis: every N in 1…81 against the scene's colour signals.
pub fn n_analysis(scene: &Scene, tol: &Tolerance) -> Result<(Vec<NCandidate>, Vec<usize>), AutoError> {
    let spectra = |e: lightbooth_science::spectrum::SpectrumError| AutoError::Spectra(e.to_string());
    let lights = light_spectra(scene);
    if lights.is_empty() {
        return Err(AutoError::Scene("no lights".into()));
    }
    let targets = target_materials(scene)?;
    let (g1, g81) = (Grid::one_nm(), Grid::analysis());
    let cmf = Cmf::of(OBSERVER).on_grid(&g1);
    let refl: Vec<(Vec<f64>, Vec<f64>)> = scene
        .materials
        .iter()
        .map(|m| {
            Ok((
                m.reflectance.resample(&g1).map_err(spectra)?.into_values(),
                m.reflectance.resample(&g81).map_err(spectra)?.into_values(),
            ))
        })
        .collect::<Result<_, AutoError>>()?;
    let mut signals = Vec::new();
    for (light_id, light) in &lights {
        let s1 = light.resample(&g1).map_err(spectra)?.into_values();
        let s81 = light.resample(&g1).map_err(spectra)?;
        let s81 = s81.resample(&g81).map_err(spectra)?.into_values();
        let white_exact = xyz_1nm(&s1, &cmf);
        for &t in &targets {
            let (rt1, rt81) = &refl[t];
            let direct: Vec<f64> = s1.iter().zip(rt1).map(|(s, r)| s * r).collect();
            signals.push(Signal {
                name: format!("{light_id}: {}", scene.materials[t].name),
                exact: direct.clone(),
                factors_81: vec![s81.clone(), rt81.clone()],
                white_exact,
                direct: true,
            });
            for (m, (rm1, rm81)) in refl.iter().enumerate() {
                signals.push(Signal {
                    name: format!("{light_id}: {}×{}", scene.materials[t].name, scene.materials[m].name),
                    exact: direct.iter().zip(rm1).map(|(d, r)| d * r).collect(),
                    factors_81: vec![s81.clone(), rt81.clone(), rm81.clone()],
                    white_exact,
                    direct: false,
                });
            }
        }
    }
    let exact: Vec<Xyz> = signals.iter().map(|s| xyz_1nm(&s.exact, &cmf)).collect();
    let mut table = Vec::new();
    for n in 1..=g81.len() {
        let bands = Bands::new(g81.len(), n).map_err(AutoError::Spectra)?;
        let obs = NStepObserver::new(OBSERVER, &g81, n).map_err(AutoError::Spectra)?;
        let (mut worst_de00, mut worst_rel_y, mut worst_signal) = (0.0f64, 0.0f64, String::new());
        for (sig, xyz) in signals.iter().zip(&exact) {
            if xyz.y <= 0.0 {
                continue;
            }
            let mut product = vec![1.0; n];
            for f in &sig.factors_81 {
                for (p, v) in product.iter_mut().zip(bands.average(f)) {
                    *p *= v;
                }
            }
            let approx = obs.xyz_from_radiance(&product);
            let mut de = compare_point(*xyz, approx, sig.white_exact, OBSERVER).de00;
            if sig.direct {
                de = de.max(compare_point(*xyz, approx, *xyz, OBSERVER).de00);
            }
            let rel_y = (approx.y / xyz.y - 1.0).abs();
            if de > worst_de00 {
                worst_de00 = de;
                worst_signal = sig.name.clone();
            }
            worst_rel_y = worst_rel_y.max(rel_y);
        }
        table.push(NCandidate {
            n,
            worst_de00,
            worst_rel_y,
            worst_signal,
            meets: worst_de00 <= SPECTRAL_SHARE * tol.de00 && worst_rel_y <= SPECTRAL_SHARE * tol.rms_rel,
        });
    }
    Ok((table, targets))
}

/// The study's Fig. 7 curve per light for all the scene's materials on the
/// 81-sample analysis grid.
pub fn fig7_curves(scene: &Scene) -> Result<Vec<(String, Vec<f64>)>, AutoError> {
    let g81 = Grid::analysis();
    let refl: Vec<lightbooth_science::spectrum::Spectrum> = scene
        .materials
        .iter()
        .map(|m| m.reflectance.resample(&g81))
        .collect::<Result<_, _>>()
        .map_err(|e| AutoError::Spectra(e.to_string()))?;
    light_spectra(scene)
        .into_iter()
        .map(|(id, l)| {
            let s = l.resample(&g81).map_err(|e| AutoError::Spectra(e.to_string()))?;
            let curve = lightbooth_science::nstep::nstep_error(&refl, &s).map_err(AutoError::Spectra)?;
            Ok((id, curve.error))
        })
        .collect()
}

fn luminances(r: &RenderResult) -> Vec<f64> {
    r.targets.iter().map(|t| t.codings[0].1.luminance_cd_m2).collect()
}

/// Chooses the cheapest coding, bounce count and sample count that meet
/// `tol` for this scene (see the module documentation for how and why).
pub fn choose_settings(
    scene: &Scene,
    tol: &Tolerance,
    seed: u64,
    cancel: Option<&CancellationToken>,
) -> Result<AutoChoice, AutoError> {
    let mut reasons = Vec::new();
    // ---- N
    let (table, targets) = n_analysis(scene, tol)?;
    let chosen = table.iter().find(|c| c.meets);
    let (n, needs_spectral, coding) = match chosen {
        Some(c) => (c.n, false, Coding::NStep(c.n)),
        None => (table.len(), true, Coding::Spectral),
    };
    let at_n = &table[n - 1];
    let fig7 = fig7_curves(scene)?;
    let fig7_at_n = fig7
        .iter()
        .map(|(light, curve)| format!("{light} {:.4}", curve[n - 1]))
        .collect::<Vec<_>>()
        .join(", ");
    let signals = light_spectra(scene).len() * targets.len() * (1 + scene.materials.len());
    reasons.push(if needs_spectral {
        format!(
            "coding spectral: even nstep81 leaves ΔE00 {:.3} (budget {:.3}) or a luminance error {:.2} % \
             (budget {:.2} %) on the worst of {signals} colour signals ({}), so N-step is not enough",
            at_n.worst_de00,
            SPECTRAL_SHARE * tol.de00,
            100.0 * at_n.worst_rel_y,
            100.0 * SPECTRAL_SHARE * tol.rms_rel,
            at_n.worst_signal
        )
    } else {
        let below = if n > 1 {
            let p = &table[n - 2];
            format!(
                "; N = {} gives ΔE00 {:.3} and {:.2} % ({})",
                n - 1,
                p.worst_de00,
                100.0 * p.worst_rel_y,
                p.worst_signal
            )
        } else {
            String::new()
        };
        format!(
            "N = {n}: the smallest N in 1…81 whose worst case over the scene's {signals} colour signals \
             (target materials {} directly and after one bounce off every material, each light) is within \
             {:.0} % of the tolerance: ΔE00 {:.3} ≤ {:.3} and luminance error {:.2} % ≤ {:.2} %{below}",
            targets
                .iter()
                .map(|&t| scene.materials[t].name.as_str())
                .collect::<Vec<_>>()
                .join(", "),
            100.0 * SPECTRAL_SHARE,
            at_n.worst_de00,
            SPECTRAL_SHARE * tol.de00,
            100.0 * at_n.worst_rel_y,
            100.0 * SPECTRAL_SHARE * tol.rms_rel
        ) + &format!(
            " (the study's Fig. 7 reconstruction error of the scene's reflectances at this N, relative to N = 1: \
             {fig7_at_n})"
        )
    });

    // ---- bounces
    let threshold = BOUNCE_SHARE * tol.rms_rel;
    let pilot = |k: u32| -> Result<RenderResult, AutoError> {
        Ok(render(
            scene,
            &RenderSettings {
                codings: vec![coding],
                samples: PILOT_SAMPLES,
                // Caps k = 0, 1, … on the same paths: no roulette.
                max_bounces: Some(k),
                russian_roulette_from: None,
                seed,
                target_relative_se: None,
                ..RenderSettings::default()
            },
            None,
            cancel,
        )?)
    };
    let ids: Vec<String> = scene.target_list.iter().map(|t| t.id.clone()).collect();
    let mut renders: Vec<RenderResult> = Vec::new();
    let mut steps: Vec<BounceStep> = Vec::new();
    let mut tests: Vec<BounceTest> = Vec::new();
    let bounces = loop {
        let k = renders.len() as u32;
        if k > MAX_BOUNCES_SEARCHED + 2 {
            let last = tests.last().expect("tests");
            let (i, f) = argmax(&last.tail_fraction);
            return Err(AutoError::Bounces(f, ids[i].clone()));
        }
        let r = pilot(k)?;
        let y = luminances(&r);
        // a_0 is the direct light, a_k (k ≥ 1) what bounce k adds.
        let added: Vec<f64> = match steps.last() {
            None => y.clone(),
            Some(prev) => y.iter().zip(&prev.luminance).map(|(a, b)| (a - b).max(0.0)).collect(),
        };
        steps.push(BounceStep {
            bounces: k,
            wall_seconds: r.wall_seconds,
            luminance: y,
            added,
        });
        renders.push(r);
        if k < 2 {
            continue;
        }
        let test = bounce_test(&steps, k - 2, threshold);
        let accepted = test.accepted;
        tests.push(test);
        if accepted {
            break k - 2;
        }
    };
    let test = tests.last().expect("the accepted test");
    let (worst_t, worst_tail) = argmax(&test.tail_fraction);
    let q_max = test.ratio.iter().copied().fold(0.0, f64::max);
    // Reference: the tail shrinks by q per two bounces; 2m more bounces make it 8× smaller.
    let m = if q_max <= 0.0 {
        1
    } else {
        ((8.0f64).ln() / (1.0 / q_max).ln()).ceil().clamp(1.0, 20.0) as u32
    };
    let reference_bounces = bounces + 2 * m;
    let refused = match tests.len() {
        1 => String::new(),
        n => {
            let t = &tests[n - 2];
            let (i, f) = argmax(&t.tail_fraction);
            format!(
                "; stopping at {} would leave {:.3} % at {}",
                t.stop_at,
                100.0 * f,
                ids[i]
            )
        }
    };
    reasons.push(format!(
        "{bounces} bounces: bounces {} and {} add {:.4} % and {:.4} % of the luminance at target {} (the worst), \
         and with q = {:.3}, the largest ratio of a bounce to the one two before (period two covers light \
         that alternates between a lit and an unlit surface), the tail (a₁ + a₂)/(1 − q) leaves {:.4} % ≤ \
         {:.3} % ({:.0} % of rms_rel){refused}; the reference traces {reference_bounces} (tail ÷ 8)",
        bounces + 1,
        bounces + 2,
        100.0 * steps[bounces as usize + 1].added[worst_t] / steps[bounces as usize + 2].luminance[worst_t],
        100.0 * steps[bounces as usize + 2].added[worst_t] / steps[bounces as usize + 2].luminance[worst_t],
        ids[worst_t],
        test.ratio[worst_t],
        100.0 * worst_tail,
        100.0 * threshold,
        100.0 * BOUNCE_SHARE
    ));

    // ---- samples
    let pilot_r = &renders[bounces as usize];
    let (mut s0, mut s0_target) = (0.0f64, String::new());
    for t in &pilot_r.targets {
        let c = &t.codings[0].1;
        let rel = c.luminance_se_cd_m2 / c.luminance_cd_m2.abs().max(f64::MIN_POSITIVE);
        if rel > s0 {
            s0 = rel;
            s0_target = t.id.clone();
        }
    }
    let goal = NOISE_SHARE * tol.rms_rel;
    let n0 = pilot_r.targets[0].paths;
    let wanted = (n0 as f64 * (s0 / goal).powi(2)).ceil() as u64;
    let samples = wanted.div_ceil(BATCH_SAMPLES).max(2) * BATCH_SAMPLES;
    let predicted_se = s0 * (n0 as f64 / samples as f64).sqrt();
    reasons.push(format!(
        "{samples} samples per target: the pilot's {n0} paths give a relative SE of Y of {:.3} % (worst, target \
         {s0_target}); SE ∝ 1/√n brings it to {:.3} % ≤ the goal {:.3} % ({:.0} % of rms_rel), rounded up to \
         whole batches of {BATCH_SAMPLES}",
        100.0 * s0,
        100.0 * predicted_se,
        100.0 * goal,
        100.0 * NOISE_SHARE
    ));
    let choosing_seconds = steps.iter().map(|s| s.wall_seconds).sum();
    let predicted = Predicted {
        spectral_de00: at_n.worst_de00,
        spectral_rel_y: at_n.worst_rel_y,
        bounce_tail_rel: worst_tail,
        relative_se: predicted_se,
        rms_rel_bound: at_n.worst_rel_y + worst_tail + predicted_se,
    };
    Ok(AutoChoice {
        scene: scene.name.clone(),
        tolerance: *tol,
        n,
        needs_spectral,
        coding,
        bounces,
        samples,
        seed,
        reasons,
        predicted,
        target_materials: targets.iter().map(|&t| scene.materials[t].name.clone()).collect(),
        n_analysis: table,
        fig7_error: fig7,
        bounce_steps: steps,
        bounce_tests: tests,
        reference_bounces,
        sample_choice: SampleChoice {
            pilot_samples: n0,
            pilot_relative_se: s0,
            pilot_target: s0_target,
            goal_relative_se: goal,
            samples,
            predicted_relative_se: predicted_se,
        },
        choosing_seconds,
    })
}

mod candidates;
mod verify;

pub use candidates::*;
pub use verify::*;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tolerance_parses_both_forms() {
        let t: Tolerance = "de00=1,rms=0.02".parse().unwrap();
        assert_eq!(t, Tolerance::default());
        assert_eq!("rms=2%, de=1".parse::<Tolerance>().unwrap(), Tolerance::default());
        assert_eq!("1,2%".parse::<Tolerance>().unwrap(), Tolerance::default());
        assert_eq!("0.5,0.01".parse::<Tolerance>().unwrap().de00, 0.5);
        for bad in [
            "",
            "de00=1",
            "de00=1,rms=x",
            "de00=-1,rms=0.02",
            "de00=1,foo=2",
            "1,2,3",
        ] {
            assert!(bad.parse::<Tolerance>().is_err(), "{bad}");
        }
        let t = Tolerance::default();
        assert_eq!(t.to_string().parse::<Tolerance>().unwrap(), t);
    }

    #[test]
    fn pareto_front_keeps_the_non_dominated() {
        // (1, 5) and (3, 1) and (2, 2) are the front; (2, 6) is dominated by
        // (1, 5), (4, 1) by (3, 1) (equal error, slower); NaN never counts.
        let p = [
            (2.0, 6.0),
            (3.0, 1.0),
            (1.0, 5.0),
            (4.0, 1.0),
            (2.0, 2.0),
            (f64::NAN, 0.0),
        ];
        assert_eq!(pareto_front(&p), vec![2, 4, 1]);
        assert!(pareto_front(&[]).is_empty());
        assert_eq!(pareto_front(&[(1.0, 1.0)]), vec![0]);
        // Identical points do not dominate each other: both stay.
        assert_eq!(pareto_front(&[(1.0, 1.0), (1.0, 1.0)]), vec![0, 1]);
    }
}
