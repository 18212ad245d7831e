//! The scene's light sources behind one interface, [`Light`], for the
//! integrator's one direct-light estimate.
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
//! - [`AreaLights`] (every emitting triangle, RADIANCE `light`, `glow` and
//!   `spotlight`; [`area`]) chooses one point on all of them by power, with
//!   its solid-angle density, and weighs a RADIANCE spotlight's cone and
//!   focal falloff into the radiance ([`Spot`](super::scene::Spot)) in both
//!   strategies alike.
//!
//! The integrator gathers every point light at every vertex (each is one
//! exact evaluation) and one sample of the area lights, which it weighs
//! against the BSDF's sampling of the same point by multiple importance
//! sampling ([`power_heuristic`]).
//!
//! A sample keeps the factors of its contribution apart ([`Arrival`]) so
//! that the integrator forms each product in one fixed order: the renderer's
//! results are bit-identical to the ones before this interface existed
//! (`tests/render/fixed_seed_pins.rs`).

pub mod area;
pub mod point;

use glam::DVec3;

pub use area::{AreaLights, EmittingTriangle};

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
}

impl LiSample {
    /// The scalar by which the light's spectrum (per cd, or radiance) and
    /// the path's throughput are multiplied: cos θᵢ·I/(k·d²) for a delta
    /// light, cos θᵢ/(k·p)·w·spot for an area light, with `k` the constant
    /// divisor of the BSDF (π for a Lambertian surface whose ρ is already in
    /// the throughput, 1 otherwise) and `w` the MIS weight (ignored by a
    /// delta light, which only one strategy can find).
    #[inline]
    pub fn scale(&self, k: f64, w: f64) -> f64 {
        match self.arrival {
            Arrival::Delta { candela, distance2 } => candela * self.cos_i / (k * distance2),
            Arrival::Area { pdf, spot } => self.cos_i / (k * pdf) * w * spot,
        }
    }

    /// The density of this sample's strategy, for the MIS weight; `None` for
    /// a delta light.
    #[inline]
    pub fn pdf(&self) -> Option<f64> {
        match self.arrival {
            Arrival::Delta { .. } => None,
            Arrival::Area { pdf, .. } => Some(pdf),
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn power_heuristic_weights_sum_to_one() {
        for (a, b) in [(1.0, 2.0), (0.3, 0.0), (5.0, 5.0)] {
            assert!((power_heuristic(a, b) + power_heuristic(b, a) - 1.0).abs() < 1e-15);
        }
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
        };
        assert_eq!(s.scale(1.0, 0.25), 12.5, "a delta light takes no MIS weight");
        assert_eq!(s.pdf(), None);
    }
}
