//! The scene's light sources behind one interface, [`Light`], in one
//! collection, [`SceneLights`], from which the integrator's one
//! direct-light estimate takes one sample of one light chosen by the light
//! sampler ([`sampler`]).
//!
//! pbrt-v4's `Light` (`src/pbrt/base/light.h`) is the model: `SampleLi`
//! chooses incident light at a surface point, `PDF_Li` gives the density of
//! that choice for a direction a BSDF sample found, `L` is the radiance an
//! area light emits along a ray that hit it. Here:
//!
//! - [`PointLight`](super::scene::PointLight) (`[[light]]`: an IES table, or
//!   a plain intensity with an optional soft cone — pbrt's `PointLight`,
//!   `GoniometricLight` and `SpotLight` in one type) is a delta light: its
//!   sample is the one direction to it, with no density, and no ray can hit
//!   it;
//! - [`AreaLight`] (one emitter's triangles, RADIANCE `light`, `glow` and
//!   `spotlight`; [`area`]) chooses one point on them by power, with its
//!   solid-angle density, and weighs a RADIANCE spotlight's cone and focal
//!   falloff into the radiance ([`Spot`](super::scene::Spot)) in both
//!   strategies alike.
//!
//! [`SceneLights`] holds every light of a scene, point luminaires first (in
//! file order), then one area light per emitter (in emitter order), and the
//! two light samplers over them (power and uniform, [`sampler`]). Its
//! [`SceneLights::sample_ld`] is pbrt's light choice in `SampleLd`: one
//! light ℓ with probability P(ℓ), one sample of it, its density scaled by
//! P(ℓ) ([`LiSample::pmf`]); [`SceneLights::emission_pdf`] is the density
//! P(ℓ)·p_ℓ(y) of the same strategy for a point y a BSDF-sampled ray found,
//! which the integrator weighs against the BSDF's density by multiple
//! importance sampling ([`power_heuristic`]). A delta light takes no MIS
//! weight.
//!
//! Beside the estimator, the collection gives the closed form of its point
//! luminaires' irradiance at a point ([`SceneLights::point_source_irradiance`],
//! E = Σ I·cos θᵢ / d² per spectrum, unoccluded): the CIELAB white of a scene
//! that names "its lights on a perfect diffuser" is computed from it.
//!
//! A sample keeps the factors of its contribution apart ([`Arrival`]) so
//! that the integrator forms each product in one fixed order: with one light
//! (P = 1) the renderer's results are bit-identical to the ones before the
//! light sampler existed (`tests/render/fixed_seed_pins.rs`).

pub mod area;
pub mod point;
pub mod sampler;

use glam::DVec3;

pub use area::{AreaLight, EmittingTriangle};
pub use point::Luminaire;
pub use sampler::{LightSampler, LightSampling};

use crate::sampling::PathSampler;
use crate::scene::{PointLight, Scene};
use lightbooth_science::spectrum::{Grid, SpectralUnit, Spectrum};

/// The surface point light arrives at: the point itself and its unit
/// normal on the side the path came from. Distances and cosines are taken
/// from `p`, not from the shadow ray's offset origin.
#[derive(Clone, Copy, Debug)]
pub struct LightContext {
    pub p: DVec3,
    pub n: DVec3,
}

/// Whose spectrum a sample carries: the prepared channels of a point light
/// (`Scene::lights`) or of an area emitter (`Scene::emitters`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpectrumOf {
    Luminaire(usize),
    Emitter(usize),
}

/// The scalar factors of one light sample's contribution, kept apart so the
/// integrator multiplies them in one fixed order ([`LiSample::scale`]).
#[derive(Clone, Copy, Debug)]
pub enum Arrival {
    /// A delta light: intensity I in cd toward the point at distance² d²;
    /// irradiance I·cos θᵢ / d² times the spectrum per cd.
    Delta { candela: f64, distance2: f64 },
    /// A point on an area light chosen with solid-angle density `pdf`
    /// (1/sr); `spot` is a spotlight's factor on its radiance toward the
    /// point (1 for a plain emitter).
    Area { pdf: f64, spot: f64 },
}

/// Where a shadow ray must reach unblocked for a sample to count.
#[derive(Clone, Copy, Debug)]
pub enum ShadowRay {
    /// Along `wi` from the offset origin up to `t_max` (a point light has
    /// no surface to stop short of).
    Along { t_max: f64 },
    /// To a point on an emitting triangle, stopping just short of it (the
    /// triangle must not shadow itself).
    ToPoint(DVec3),
}

/// One sample of incident light at a surface point (pbrt's `LightLiSample`).
#[derive(Clone, Copy, Debug)]
pub struct LiSample {
    /// Unit direction from the surface point toward the light.
    pub wi: DVec3,
    /// n·wi, > 0 (a light behind the surface gives no sample).
    pub cos_i: f64,
    pub arrival: Arrival,
    pub shadow: ShadowRay,
    pub spectrum: SpectrumOf,
    /// The probability P(ℓ) with which the light sampler chose this light
    /// (1 from a [`Light`] itself, and when the scene has one light).
    pub pmf: f64,
}

impl LiSample {
    /// The scalar by which the light's spectrum (per cd, or radiance) and
    /// the path's throughput are multiplied: cos θᵢ·I/(k·d²·P) for a delta
    /// light, cos θᵢ/(k·P·p)·w·spot for an area light, with `k` the constant
    /// divisor of the BSDF (π for a Lambertian surface whose ρ is already in
    /// the throughput, 1 otherwise), P the light's choice probability
    /// ([`LiSample::pmf`]) and `w` the MIS weight (ignored by a delta light,
    /// which only one strategy can find).
    #[inline]
    pub fn scale(&self, k: f64, w: f64) -> f64 {
        match self.arrival {
            Arrival::Delta { candela, distance2 } => candela * self.cos_i / (k * distance2 * self.pmf),
            Arrival::Area { pdf, spot } => self.cos_i / (k * (pdf * self.pmf)) * w * spot,
        }
    }

    /// The density of this sample's strategy, P(ℓ)·p_ℓ, for the MIS weight;
    /// `None` for a delta light.
    #[inline]
    pub fn pdf(&self) -> Option<f64> {
        match self.arrival {
            Arrival::Delta { .. } => None,
            Arrival::Area { pdf, .. } => Some(pdf * self.pmf),
        }
    }
}

/// What a ray that hit an emitting surface saw: the primitive, the
/// distance along the ray, |cos| at the emitter, and the ray's direction.
#[derive(Clone, Copy, Debug)]
pub struct EmitterHit {
    pub primitive: usize,
    pub emitter: usize,
    pub distance: f64,
    pub cos_l: f64,
    pub dir: DVec3,
    /// True for the sensor's own ray (a spotlight shows its lamp's full
    /// radiance to the eye), false for a bounce from a surface.
    pub from_sensor: bool,
}

/// A light source as the integrator uses it (pbrt-v4's `Light`).
pub trait Light {
    /// Incident light at `ctx` from the uniform point `u` (ignored by delta
    /// lights); `None` when the light is behind the surface, faces away from
    /// it, or sends nothing toward it.
    fn sample_li(&self, ctx: &LightContext, u: (f64, f64)) -> Option<LiSample>;

    /// The solid-angle density with which [`Light::sample_li`] would have
    /// chosen the point a ray hit (0 for delta lights: no ray hits them).
    fn pdf_li(&self, hit: &EmitterHit) -> f64;

    /// The factor on the emitter's radiance along the ray that hit it (a
    /// spotlight's cone and falloff; 1 for a plain emitter, 0 for delta
    /// lights).
    fn le_factor(&self, hit: &EmitterHit) -> f64;

    /// True for a light no ray can hit (a point), whose sample needs no
    /// random numbers and takes no MIS weight.
    fn is_delta(&self) -> bool;

    /// Luminous flux Φ in lm, for the power light sampler ([`sampler`]).
    fn phi(&self) -> f64;
}

/// One light of the scene's collection.
#[derive(Clone, Debug)]
pub enum SceneLight<'a> {
    /// A point luminaire (`[[light]]`), a delta light.
    Point(Luminaire<'a>),
    /// One emitter's triangles.
    Area(AreaLight),
}

impl Light for SceneLight<'_> {
    #[inline]
    fn sample_li(&self, ctx: &LightContext, u: (f64, f64)) -> Option<LiSample> {
        match self {
            SceneLight::Point(l) => l.sample_li(ctx, u),
            SceneLight::Area(l) => l.sample_li(ctx, u),
        }
    }

    #[inline]
    fn pdf_li(&self, hit: &EmitterHit) -> f64 {
        match self {
            SceneLight::Point(l) => l.pdf_li(hit),
            SceneLight::Area(l) => l.pdf_li(hit),
        }
    }

    #[inline]
    fn le_factor(&self, hit: &EmitterHit) -> f64 {
        match self {
            SceneLight::Point(l) => l.le_factor(hit),
            SceneLight::Area(l) => l.le_factor(hit),
        }
    }

    #[inline]
    fn is_delta(&self) -> bool {
        matches!(self, SceneLight::Point(_))
    }

    fn phi(&self) -> f64 {
        match self {
            SceneLight::Point(l) => l.phi(),
            SceneLight::Area(l) => l.phi(),
        }
    }
}

/// Every light of a scene, and the light samplers over them.
#[derive(Clone, Debug)]
pub struct SceneLights<'a> {
    lights: Vec<SceneLight<'a>>,
    /// P(ℓ) ∝ Φ(ℓ).
    power: LightSampler,
    /// P(ℓ) = 1/n.
    uniform: LightSampler,
    /// Per emitter (`Scene::emitters`), the index of its area light in
    /// `lights` (`u32::MAX`: an emitter without triangles).
    of_emitter: Vec<u32>,
}

impl<'a> SceneLights<'a> {
    /// The point luminaires of `scene` (file order), then one area light per
    /// emitter with triangles (emitter order); errors as [`AreaLight::of_scene`].
    pub fn new(scene: &'a Scene) -> Result<SceneLights<'a>, String> {
        let mut lights = luminaires(&scene.lights);
        let mut of_emitter = vec![u32::MAX; scene.emitters.len()];
        for area in AreaLight::of_scene(scene)? {
            of_emitter[area.emitter] = lights.len() as u32;
            lights.push(SceneLight::Area(area));
        }
        Ok(SceneLights::of(lights, of_emitter))
    }

    /// A collection of point luminaires only (`Scene::lights`, in order),
    /// for a scene still being loaded or a question about them alone.
    pub fn of_luminaires(lights: &'a [PointLight]) -> SceneLights<'a> {
        SceneLights::of(luminaires(lights), Vec::new())
    }

    fn of(lights: Vec<SceneLight<'a>>, of_emitter: Vec<u32>) -> SceneLights<'a> {
        let phi: Vec<f64> = lights.iter().map(Light::phi).collect();
        SceneLights {
            power: LightSampler::power(&phi),
            uniform: LightSampler::uniform(lights.len()),
            lights,
            of_emitter,
        }
    }

    /// The spectral irradiance E(λ) = Σℓ Iℓ·cos θᵢ / d² · Sℓ(λ) that the
    /// collection's point luminaires deliver at `ctx`, W/(m²·nm) on the
    /// 1 nm grid: Iℓ the luminaire's candela toward the point, d its
    /// distance, θᵢ the incidence on `ctx.n`, Sℓ its spectral intensity per
    /// cd ([`PointLight::spectrum_per_cd`]). Each luminaire's arrival is its
    /// own [`Light::sample_li`] (the integrator's), every light counted
    /// fully (no light sampler). Approximations, stated: **unoccluded** (no
    /// shadow ray is traced, so a surface between a light and the point
    /// does not shade it) and **direct only** (nothing arrives by
    /// interreflection). Area lights are not included: their irradiance is
    /// an integral over their surface, not this closed form (a scene with
    /// area lights may not ask for it as its white; see
    /// [`Scene::light_on_perfect_diffuser`]). A luminaire at the point
    /// itself gives a non-finite value, which the caller must refuse.
    pub fn point_source_irradiance(&self, ctx: &LightContext) -> Vec<f64> {
        let mut irradiance = vec![0.0; Grid::one_nm().len()];
        for light in &self.lights {
            let SceneLight::Point(luminaire) = light else { continue };
            // `None`: the luminaire is behind the surface or dark toward it.
            let Some(arrival) = luminaire.sample_li(ctx, (0.0, 0.0)) else {
                continue;
            };
            // I·cos θᵢ / d² (k = 1, P = 1, a delta light takes no MIS weight).
            let e = arrival.scale(1.0, 1.0);
            for (v, s) in irradiance.iter_mut().zip(luminaire.light.spectrum_per_cd.values()) {
                *v += e * s;
            }
        }
        irradiance
    }

    pub fn len(&self) -> usize {
        self.lights.len()
    }

    pub fn is_empty(&self) -> bool {
        self.lights.is_empty()
    }

    /// The lights, point luminaires first.
    pub fn lights(&self) -> &[SceneLight<'a>] {
        &self.lights
    }

    /// The sampler of `kind` over these lights.
    #[inline]
    pub fn sampler(&self, kind: LightSampling) -> &LightSampler {
        match kind {
            LightSampling::Power => &self.power,
            LightSampling::Uniform => &self.uniform,
        }
    }

    /// One sample of one light at `ctx` (pbrt-v4 `SampleLd`'s light choice
    /// and `SampleLi`), its [`LiSample::pmf`] the probability of that light.
    /// No light: `None`, drawing nothing. One light: P = 1, and a 2D number
    /// only for an area light (a point light needs none). Several: one 2D
    /// number, whose first coordinate chooses the light and is rescaled for
    /// the light's own use ([`LightSampler::sample`]).
    #[inline]
    pub fn sample_ld(&self, kind: LightSampling, ctx: &LightContext, rng: &mut PathSampler) -> Option<LiSample> {
        match self.lights.len() {
            0 => None,
            1 => {
                let light = &self.lights[0];
                let u = if light.is_delta() { (0.0, 0.0) } else { rng.next_2d() };
                light.sample_li(ctx, u)
            }
            _ => {
                let (u0, u1) = rng.next_2d();
                let (i, pmf, u0) = self.sampler(kind).sample(u0);
                let mut sample = self.lights[i].sample_li(ctx, (u0, u1))?;
                sample.pmf = pmf;
                Some(sample)
            }
        }
    }

    /// The density P(ℓ)·p_ℓ(y) with which [`SceneLights::sample_ld`] would
    /// have chosen the point y on an emitter that a ray hit (p in solid
    /// angle at the ray's origin), for the MIS weight of its emission.
    #[inline]
    pub fn emission_pdf(&self, kind: LightSampling, hit: &EmitterHit) -> f64 {
        match self.of_emitter.get(hit.emitter) {
            Some(&l) if l != u32::MAX => {
                let l = l as usize;
                self.sampler(kind).pmf(l) * self.lights[l].pdf_li(hit)
            }
            _ => 0.0,
        }
    }

    /// The factor on the radiance of the emitter a ray hit
    /// ([`Light::le_factor`]: a spotlight's cone and falloff, else 1).
    #[inline]
    pub fn le_factor(&self, hit: &EmitterHit) -> f64 {
        match self.of_emitter.get(hit.emitter) {
            Some(&l) if l != u32::MAX => self.lights[l as usize].le_factor(hit),
            _ => 1.0,
        }
    }
}

/// The point luminaires of a scene as lights of the collection, in order.
fn luminaires(lights: &[PointLight]) -> Vec<SceneLight<'_>> {
    lights
        .iter()
        .enumerate()
        .map(|(index, light)| SceneLight::Point(Luminaire { index, light }))
        .collect()
}

/// The power heuristic with β = 2 (Veach & Guibas 1995): the weight of the
/// strategy with density `a` against one with density `b`.
#[inline]
pub fn power_heuristic(a: f64, b: f64) -> f64 {
    let (a2, b2) = (a * a, b * b);
    if a2 + b2 == 0.0 {
        0.0
    } else {
        a2 / (a2 + b2)
    }
}

/// The scene's white of `light_on_perfect_diffuser = true`, defined here,
/// beside the light collection that gives it (the scene's loader refuses
/// it where it is not finite).
impl Scene {
    /// The spectral radiance of a perfect (ρ = 1) Lambertian diffuser at
    /// `point` facing `normal` under the scene's point luminaires,
    /// W/(sr·m²·nm) on the 1 nm grid: L(λ) = ρ·E(λ)/π with E the
    /// irradiance the light collection gives
    /// ([`SceneLights::point_source_irradiance`],
    /// Σ I·cos θ·S(λ)/d²). Direct light only: no shadows, no
    /// interreflections (an approximation the scene's author accepts by
    /// choosing this white); area lights are not counted, and loading
    /// refuses this white in a scene that has them.
    pub fn light_on_perfect_diffuser(&self, point: DVec3, normal: DVec3) -> Spectrum {
        let values = self.perfect_diffuser_radiance(point, normal);
        // Loading refused a white whose radiance is not finite.
        Spectrum::new(Grid::one_nm(), SpectralUnit::SpectralRadiance, values).expect("finite radiance")
    }

    /// [`Self::light_on_perfect_diffuser`]'s values, W/(sr·m²·nm) on the
    /// 1 nm grid, unchecked (loading refuses a white where one is not
    /// finite).
    pub(crate) fn perfect_diffuser_radiance(&self, point: DVec3, normal: DVec3) -> Vec<f64> {
        let at = LightContext { p: point, n: normal };
        // A perfect Lambertian diffuser: L = ρE/π with ρ = 1.
        SceneLights::of_luminaires(&self.lights)
            .point_source_irradiance(&at)
            .into_iter()
            .map(|e| e / std::f64::consts::PI)
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn power_heuristic_weights_sum_to_one() {
        for (a, b) in [(1.0, 2.0), (0.3, 0.0), (5.0, 5.0)] {
            assert!((power_heuristic(a, b) + power_heuristic(b, a) - 1.0).abs() < 1e-15);
        }
    }

    fn lamp(position: DVec3, intensity_cd: f64, spectrum_per_cd: f64) -> PointLight {
        use crate::scene::LightDistribution;
        use lightbooth_science::spectrum::{SpectralUnit, Spectrum};
        PointLight {
            id: "lamp".into(),
            position,
            aim: -DVec3::Z,
            c0: DVec3::X,
            distribution: LightDistribution::Cone {
                intensity_cd,
                cone_deg: 180.0,
                falloff_deg: 0.0,
            },
            intensity_scale: 1.0,
            spectrum_per_cd: Spectrum::constant(Grid::one_nm(), SpectralUnit::RelativePower, spectrum_per_cd).unwrap(),
        }
    }

    /// A point source of I cd at distance d and incidence θ gives the
    /// irradiance E = I·cos θ / d² (per unit of its spectrum per cd); two
    /// add, and one behind the surface gives nothing.
    #[test]
    fn point_source_irradiance_is_i_cos_theta_over_d_squared() {
        let (i, d, theta) = (250.0, 1.7, 35f64.to_radians());
        // The lamp at distance d from the origin, θ from the normal +z.
        let at = DVec3::new(d * theta.sin(), 0.0, d * theta.cos());
        let lights = [
            lamp(at, i, 2.0e-3),
            lamp(DVec3::new(0.0, 0.0, 0.5), 10.0, 1.0e-3),
            lamp(DVec3::new(0.0, 0.3, -0.4), 1.0e6, 1.0),
        ];
        let ctx = LightContext {
            p: DVec3::ZERO,
            n: DVec3::Z,
        };
        let e = SceneLights::of_luminaires(&lights).point_source_irradiance(&ctx);
        assert_eq!(e.len(), Grid::one_nm().len());
        let truth = i * theta.cos() / (d * d) * 2.0e-3 + 10.0 / 0.25 * 1.0e-3;
        for v in &e {
            assert!((v / truth - 1.0).abs() < 1e-14, "{v} vs {truth}");
        }
        let alone = SceneLights::of_luminaires(&lights[..1]).point_source_irradiance(&ctx);
        assert!((alone[200] / (i * theta.cos() / (d * d) * 2.0e-3) - 1.0).abs() < 1e-14);
        let behind = SceneLights::of_luminaires(&lights[2..]).point_source_irradiance(&ctx);
        assert!(
            behind.iter().all(|v| *v == 0.0),
            "a lamp below the surface does not light it"
        );
    }

    /// A delta light's scale is the inverse-square law: I·cos θ / d².
    #[test]
    fn a_delta_sample_scales_by_the_inverse_square_law() {
        let s = LiSample {
            wi: DVec3::Z,
            cos_i: 0.5,
            arrival: Arrival::Delta {
                candela: 100.0,
                distance2: 4.0,
            },
            shadow: ShadowRay::Along { t_max: 2.0 },
            spectrum: SpectrumOf::Luminaire(0),
            pmf: 1.0,
        };
        assert_eq!(s.scale(1.0, 0.25), 12.5, "a delta light takes no MIS weight");
        assert_eq!(s.pdf(), None);
        let chosen = LiSample { pmf: 0.25, ..s };
        assert_eq!(chosen.scale(1.0, 0.25), 50.0, "divided by the light's probability");
    }
}
