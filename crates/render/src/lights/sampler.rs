//! Choosing one light for a direct-light estimate: the light sampler
//! (pbrt-v4's `LightSampler`, `src/pbrt/lightsamplers.h`).
//!
//! The integrator's direct-light estimate at a path vertex takes one sample
//! of ONE light of the scene's collection ([`super::SceneLights`]), chosen
//! with probability P(ℓ) (the pmf), and divides its contribution by P(ℓ):
//!
//! ```text
//! L_d ≈ f · L_e(ℓ, y) · cos θᵢ / (P(ℓ) · p_ℓ(y))        (an area light ℓ, point y)
//! L_d ≈ f · I_ℓ(ω) · cos θᵢ / (P(ℓ) · d²)               (a delta light ℓ)
//! ```
//!
//! which is unbiased whenever P(ℓ) > 0 for every light that can send light
//! to the vertex (pbrt-v4 §12.6, `PathIntegrator::SampleLd`). The emission a
//! BSDF-sampled ray finds on an area light is weighted against this strategy
//! with its density p_light = P(ℓ) · p_ℓ(y) (the power heuristic); a delta
//! light takes no MIS weight (no ray can hit it).
//!
//! Two choices, the render setting `light_sampler` ([`LightSampling`]):
//!
//! - **`power`** (the default, pbrt-v4's `PowerLightSampler`):
//!   P(ℓ) = Φ(ℓ) / Σₖ Φ(k), Φ the light's **luminous flux** in lumens — the
//!   same for every colour coding, so every coding follows the same paths
//!   (pbrt uses the spectral power at the path's wavelengths; a spectral
//!   choice per coding would give each coding other paths). When no light
//!   has positive flux, P is uniform (as pbrt does).
//! - **`uniform`** (pbrt's `UniformLightSampler`): P(ℓ) = 1/n for n lights.
//!
//! What Φ is for each kind of light ([`super::point`], [`super::area`]):
//!
//! - a point luminaire (`[[light]]`, a delta light) with intensity I(ω) in
//!   cd: Φ = ∫ I(ω) dω over the sphere. Isotropic: Φ = 4π·I. A cone of
//!   half-angle γₒ whose outer `falloff_deg` falls by a smoothstep in cos γ
//!   (from cos γᵢ to cos γₒ): Φ = 2π·I·[(1 − cos γᵢ) + (cos γᵢ − cos γₒ)/2],
//!   exact, since a smoothstep's mean over its interval is ½ and dω =
//!   2π·d(cos γ) (pbrt-v4 `SpotLight::Phi`). An IES table: the midpoint rule
//!   over 360 equal steps of cos γ (equal solid angles) and 72 of C (1 for a
//!   rotationally symmetric table) — an approximation of the flux, which
//!   changes only the probabilities, never the estimate's mean;
//! - an area light (one emitter: all triangles of one `[[polygon]]`,
//!   `[[mesh]]` or RADIANCE light source that share one emission) of
//!   luminance L_v (cd/m², as [`super::area`] computes it), area A and s
//!   emitting sides: Φ = π·L_v·A·s, the flux of a Lambertian emitter. A
//!   RADIANCE `spotlight` emits only into its cone: Φ = π·L_v·A·s·(1 −
//!   max(cos(angle/2), 0)²), the fraction of a Lambertian emitter's flux
//!   inside a cone around its normal — an approximation (the cone's axis need
//!   not be the normal, and the focal-length falloff d²/(d + flen)², which
//!   depends on the receiver, is left out); again only the probabilities
//!   depend on it.
//!
//! The choice draws no random number when the scene has one light (P = 1,
//! so a scene with one point light or one area emitter follows exactly the
//! paths it did when every point light was gathered at every vertex), and
//! none when it has no light. With n ≥ 2 lights it takes the first number
//! of the vertex's light-sample point, u₀, finds the light whose interval
//! [cdf(ℓ), cdf(ℓ + 1)) contains it, and rescales u₀ into that interval
//! for the light's own use (an area light's choice of triangle), so the
//! point stays stratified.
//!
//! Power-proportional is not automatically better: for two spotlights of
//! equal flux aimed at different parts of the booth, each vertex mostly
//! sees one of them, and choosing by flux wastes half the samples on the
//! light that sends nothing there, where gathering both (as before) cost two
//! shadow rays and no variance from the choice. Uniform is the other
//! option; the standard error per second of a render decides per scene.

use std::fmt;
use std::str::FromStr;

/// How the direct-light estimate chooses its one light (the render setting
/// `light_sampler`; `lightbooth render --light-sampler`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LightSampling {
    /// P(ℓ) proportional to the light's luminous flux (pbrt-v4's default).
    #[default]
    Power,
    /// P(ℓ) = 1/n.
    Uniform,
}

impl LightSampling {
    /// Every value, in the order the messages list them.
    pub const ALL: [LightSampling; 2] = [LightSampling::Power, LightSampling::Uniform];

    pub fn name(self) -> &'static str {
        match self {
            LightSampling::Power => "power",
            LightSampling::Uniform => "uniform",
        }
    }
}

impl fmt::Display for LightSampling {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for LightSampling {
    type Err = String;

    /// `power` or `uniform`; anything else is an error naming the allowed values.
    fn from_str(s: &str) -> Result<LightSampling, String> {
        LightSampling::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| format!("unknown light sampler `{s}`: expected `power` or `uniform`"))
    }
}

/// A discrete distribution over the scene's lights: P(ℓ) and the cumulative
/// table the choice searches.
#[derive(Clone, Debug, Default)]
pub struct LightSampler {
    /// P(ℓ) per light; sums to 1 (empty for a scene without lights).
    pmf: Vec<f64>,
    /// `cdf[ℓ]` = Σ_{k<ℓ} P(k); `cdf[n]` = 1.
    cdf: Vec<f64>,
}

impl LightSampler {
    /// The sampler of `kind` over lights of luminous fluxes `phi` (lm).
    pub fn new(kind: LightSampling, phi: &[f64]) -> LightSampler {
        match kind {
            LightSampling::Power => LightSampler::power(phi),
            LightSampling::Uniform => LightSampler::uniform(phi.len()),
        }
    }

    /// P(ℓ) = Φ(ℓ)/ΣΦ; uniform when no flux is positive and finite.
    pub fn power(phi: &[f64]) -> LightSampler {
        let weight = |p: f64| if p.is_finite() && p > 0.0 { p } else { 0.0 };
        let total: f64 = phi.iter().map(|&p| weight(p)).sum();
        if !(total > 0.0 && total.is_finite()) {
            return LightSampler::uniform(phi.len());
        }
        LightSampler::from_pmf(phi.iter().map(|&p| weight(p) / total).collect())
    }

    /// P(ℓ) = 1/n.
    pub fn uniform(n: usize) -> LightSampler {
        LightSampler::from_pmf(vec![1.0 / n as f64; n])
    }

    fn from_pmf(pmf: Vec<f64>) -> LightSampler {
        let mut cdf = Vec::with_capacity(pmf.len() + 1);
        let mut acc = 0.0;
        cdf.push(0.0);
        for p in &pmf {
            acc += p;
            cdf.push(acc);
        }
        if let Some(last) = cdf.last_mut() {
            *last = 1.0;
        }
        LightSampler { pmf, cdf }
    }

    /// Number of lights.
    pub fn len(&self) -> usize {
        self.pmf.len()
    }

    pub fn is_empty(&self) -> bool {
        self.pmf.is_empty()
    }

    /// P(ℓ), the probability of choosing light `light`.
    #[inline]
    pub fn pmf(&self, light: usize) -> f64 {
        self.pmf[light]
    }

    /// The light whose interval of the cumulative table holds `u` ∈ [0, 1),
    /// its P(ℓ), and `u` rescaled to [0, 1] within the interval (for the
    /// light's own choice of a point). A light with P = 0 is never chosen.
    #[inline]
    pub fn sample(&self, u: f64) -> (usize, f64, f64) {
        let n = self.pmf.len();
        let mut i = (self.cdf.partition_point(|&c| c <= u).max(1) - 1).min(n - 1);
        // Skip empty intervals (P = 0) that rounding could land on.
        while self.pmf[i] == 0.0 && i > 0 {
            i -= 1;
        }
        while self.pmf[i] == 0.0 && i + 1 < n {
            i += 1;
        }
        let p = self.pmf[i];
        let rescaled = ((u - self.cdf[i]) / p).clamp(0.0, 1.0);
        (i, p, rescaled)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Three lights of 100, 300 and 600 lm: P = 0.1, 0.3, 0.6, summing to 1.
    #[test]
    fn power_pmf_is_proportional_to_flux_and_sums_to_one() {
        let s = LightSampler::power(&[100.0, 300.0, 600.0]);
        for (i, want) in [0.1, 0.3, 0.6].into_iter().enumerate() {
            assert!((s.pmf(i) - want).abs() < 1e-15, "P({i}) = {}", s.pmf(i));
        }
        assert!(((0..3).map(|i| s.pmf(i)).sum::<f64>() - 1.0).abs() < 1e-15);
        // A unit flux at 4π·I: two isotropic lamps of 10 and 30 cd.
        let iso = LightSampler::power(&[4.0 * std::f64::consts::PI * 10.0, 4.0 * std::f64::consts::PI * 30.0]);
        assert!((iso.pmf(0) - 0.25).abs() < 1e-15 && (iso.pmf(1) - 0.75).abs() < 1e-15);
    }

    #[test]
    fn uniform_pmf_is_one_over_n() {
        for n in 1..=5 {
            let s = LightSampler::new(LightSampling::Uniform, &vec![7.0; n]);
            for i in 0..n {
                assert_eq!(s.pmf(i), 1.0 / n as f64);
            }
            assert!(((0..n).map(|i| s.pmf(i)).sum::<f64>() - 1.0).abs() < 1e-15);
        }
    }

    /// No positive flux at all: uniform (pbrt's fallback); a light of zero
    /// flux beside others is never chosen.
    #[test]
    fn zero_flux_falls_back_to_uniform_and_is_never_chosen_beside_others() {
        let s = LightSampler::power(&[0.0, 0.0]);
        assert_eq!((s.pmf(0), s.pmf(1)), (0.5, 0.5));
        let s = LightSampler::power(&[0.0, 5.0, 0.0]);
        for k in 0..1000 {
            let (i, p, _) = s.sample(k as f64 / 1000.0);
            assert_eq!((i, p), (1, 1.0));
        }
    }

    /// The choice follows the pmf: with u on a fine stratified grid, the
    /// fraction choosing each light is its P, and the rescaled u stays
    /// uniform within the light's interval.
    #[test]
    fn the_choice_follows_the_pmf_and_rescales_u_into_the_interval() {
        let s = LightSampler::power(&[1.0, 2.0, 5.0]);
        let n = 80_000;
        let mut count = [0usize; 3];
        let mut mean_rescaled = [0.0f64; 3];
        for k in 0..n {
            let (i, p, r) = s.sample((k as f64 + 0.5) / n as f64);
            assert_eq!(p, s.pmf(i));
            assert!((0.0..=1.0).contains(&r));
            count[i] += 1;
            mean_rescaled[i] += r;
        }
        for i in 0..3 {
            let frac = count[i] as f64 / n as f64;
            assert!((frac - s.pmf(i)).abs() < 1e-4, "light {i}: {frac} vs {}", s.pmf(i));
            assert!((mean_rescaled[i] / count[i] as f64 - 0.5).abs() < 1e-3);
        }
    }

    #[test]
    fn names_parse_and_an_unknown_one_lists_the_allowed_values() {
        assert_eq!("power".parse::<LightSampling>(), Ok(LightSampling::Power));
        assert_eq!("uniform".parse::<LightSampling>(), Ok(LightSampling::Uniform));
        assert_eq!(LightSampling::default(), LightSampling::Power);
        let e = "all".parse::<LightSampling>().unwrap_err();
        assert!(
            e.contains("`all`") && e.contains("`power`") && e.contains("`uniform`"),
            "{e}"
        );
        let json: LightSampling = serde_json::from_str("\"uniform\"").unwrap();
        assert_eq!(json, LightSampling::Uniform);
    }
}

/// The light sampler in the renderer against closed forms: a Lambertian
/// floor under two point lamps of different intensity and an emitting
/// panel, rendered with each sampler.
#[cfg(test)]
mod monte_carlo {
    use std::f64::consts::PI;
    use std::path::Path;

    use glam::DVec3;

    use super::LightSampling;
    use crate::{load_scene, render, Coding, RenderSettings};

    const RHO: f64 = 0.5;
    /// (position, intensity in cd) of the two isotropic lamps.
    const LAMPS: [([f64; 3], f64); 2] = [([0.5, 1.0, 0.0], 30.0), ([-0.8, 1.5, 0.4], 120.0)];
    /// The panel's corners (y = 1.2, emitting downward) and luminance, cd/m².
    const PANEL: [[f64; 3]; 4] = [[-0.2, 1.2, -0.2], [0.2, 1.2, -0.2], [0.2, 1.2, 0.2], [-0.2, 1.2, 0.2]];
    const PANEL_CD_M2: f64 = 2000.0;

    fn write_scene(dir: &Path, lamps: &[([f64; 3], f64)], panel: bool) -> std::path::PathBuf {
        std::fs::write(dir.join("flat.csv"), "nm,e\n380,1.0\n780,1.0\n").unwrap();
        let mut text = String::from(
            r#"name = "light sampler"
[radiometer]
position = [0.0, 2.0, 2.0]
field_deg = 0.01
[[target]]
id = "t"
point = [0.0, 0.0, 0.0]
[materials]
grey = { reflectance = 0.5 }
[[quad]]
corner = [-2.0, 0.0, -2.0]
edge_u = [4.0, 0.0, 0.0]
edge_v = [0.0, 0.0, 4.0]
material = "grey"
"#,
        );
        for (i, (p, cd)) in lamps.iter().enumerate() {
            text.push_str(&format!(
                "[[light]]\nid = \"lamp{i}\"\nposition = [{}, {}, {}]\nintensity_cd = {cd}\nspd = \"flat.csv:e\"\n",
                p[0], p[1], p[2]
            ));
        }
        if panel {
            let v: Vec<String> = PANEL
                .iter()
                .map(|p| format!("[{}, {}, {}]", p[0], p[1], p[2]))
                .collect();
            text.push_str(&format!(
                "[[polygon]]\nname = \"panel\"\nvertices = [{}]\nemission = {{ luminance_cd_m2 = {PANEL_CD_M2}, spd = \"flat.csv:e\" }}\n",
                v.join(", ")
            ));
        }
        let path = dir.join("scene.toml");
        std::fs::write(&path, text).unwrap();
        path
    }

    /// Illuminance at the origin (floor normal +y) from a Lambertian polygon
    /// of luminance L: Lambert's formula E = L/2 · |Σᵢ Θᵢ n·(vᵢ × vᵢ₊₁)/|vᵢ × vᵢ₊₁||,
    /// Θᵢ the angle between the corners' directions vᵢ and vᵢ₊₁.
    fn polygon_illuminance(corners: &[[f64; 3]], luminance: f64) -> f64 {
        let n = DVec3::Y;
        let v: Vec<DVec3> = corners.iter().map(|&c| DVec3::from(c).normalize()).collect();
        let mut sum = 0.0;
        for i in 0..v.len() {
            let (a, b) = (v[i], v[(i + 1) % v.len()]);
            let c = a.cross(b);
            sum += a.angle_between(b) * n.dot(c / c.length());
        }
        luminance / 2.0 * sum.abs()
    }

    fn lamp_illuminance(lamps: &[([f64; 3], f64)]) -> f64 {
        lamps
            .iter()
            .map(|(p, cd)| {
                let to = DVec3::from(*p);
                cd * (to.y / to.length()) / to.length_squared()
            })
            .sum()
    }

    fn luminance(scene: &Path, kind: LightSampling, seed: u64) -> (f64, f64) {
        let scene = load_scene(scene).unwrap();
        let s = RenderSettings {
            codings: vec![Coding::Spectral],
            samples: 16_384,
            target_relative_se: None,
            light_sampler: kind,
            seed,
            // The lamps' candela and the panel's cd/m² are in V(λ) (issue
            // 46): Y weighted with V(λ) is what the closed forms give.
            observer: lightbooth_science::colorimetry::PHOTOMETRIC_OBSERVER,
            ..RenderSettings::default()
        };
        let r = render(&scene, &s, None, None).unwrap();
        let c = &r.targets[0].codings[0].1;
        (c.luminance_cd_m2, c.luminance_se_cd_m2)
    }

    /// Y = ρ/π · E for the floor under both lamps and the panel: each
    /// sampler within 4 standard errors of the closed form (lamps: the
    /// inverse-square cosine law; panel: Lambert's polygon formula), with
    /// a standard error below 2 % (the estimate does converge).
    #[test]
    fn both_samplers_give_the_closed_form_illuminance_of_two_lamps_and_a_panel() {
        let dir = tempfile::tempdir().unwrap();
        let path = write_scene(dir.path(), &LAMPS, true);
        let e = lamp_illuminance(&LAMPS) + polygon_illuminance(&PANEL, PANEL_CD_M2);
        let truth = RHO / PI * e;
        for kind in LightSampling::ALL {
            let (y, se) = luminance(&path, kind, 5);
            assert!(se < 0.02 * truth, "{kind}: SE {se} of {truth}");
            assert!(
                (y - truth).abs() < 4.0 * se,
                "{kind}: Y = {y} ± {se}, closed form {truth}"
            );
        }
    }

    /// Two lamps alone (delta lights only: no MIS): the same check, each
    /// lamp's light divided by its probability.
    #[test]
    fn both_samplers_give_the_inverse_square_law_of_two_lamps_of_different_intensity() {
        let dir = tempfile::tempdir().unwrap();
        let path = write_scene(dir.path(), &LAMPS, false);
        let truth = RHO / PI * lamp_illuminance(&LAMPS);
        for kind in LightSampling::ALL {
            let (y, se) = luminance(&path, kind, 9);
            assert!(se > 0.0 && se < 0.05 * truth, "{kind}: SE {se} of {truth}");
            assert!(
                (y - truth).abs() < 4.0 * se,
                "{kind}: Y = {y} ± {se}, closed form {truth}"
            );
        }
    }

    /// One lamp: P = 1 and no random number spent on the choice, so both
    /// samplers give the exact inverse-square answer with no noise (the
    /// field is a point; the floor reflects to nothing), and a scene
    /// without any light renders black.
    #[test]
    fn one_lamp_is_exact_and_no_light_is_black() {
        let dir = tempfile::tempdir().unwrap();
        let path = write_scene(dir.path(), &LAMPS[..1], false);
        let truth = RHO / PI * lamp_illuminance(&LAMPS[..1]);
        for kind in LightSampling::ALL {
            let (y, _) = luminance(&path, kind, 3);
            assert!((y / truth - 1.0).abs() < 1e-5, "{kind}: {y} vs {truth}");
        }
        let dark = write_scene(dir.path(), &[], false);
        for kind in LightSampling::ALL {
            assert_eq!(luminance(&dark, kind, 3).0, 0.0);
        }
    }
}
