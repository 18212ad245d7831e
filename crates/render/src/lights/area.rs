//! Area lights: choosing a point on an emitter's triangles for next-event
//! estimation, and the density of that choice for multiple importance
//! sampling.
//!
//! Every primitive with an [`Emitter`](crate::scene::Emitter) is a triangle
//! (the scene loader only lets `[[polygon]]` and `[[mesh]]` emit). One
//! [`AreaLight`] is one emitter — every triangle of one `[[polygon]]` or
//! `[[mesh]]` with `emission`, or of one RADIANCE light source material —
//! and one light of the scene's collection ([`super::SceneLights`]), which
//! the light sampler ([`super::sampler`]) chooses among the others by its
//! flux Φ = π·L·A (a Lambertian emitter). Within it, a light sample picks
//! one triangle with probability proportional to its power (area ×
//! luminance × emitting sides, the same luminance and sides for all of one
//! emitter's triangles, so proportional to area), then a point uniform in
//! its area. The density of the chosen point y, seen from x in solid
//! angle, is
//!
//! ```text
//! p_ω(y) = P(triangle) / A(triangle) · |x − y|² / |cos θ_y|
//! ```
//!
//! (pbrt-v4 §4.2.3, converting area to solid-angle density), times the
//! light sampler's P(light) in the integrator, which compares it with the
//! BSDF's density to weight the two strategies (Veach & Guibas 1995, the
//! power heuristic with β = 2).
//!
//! Approximation stated: power uses the luminance of each emitter's
//! spectrum, not each coding's own channels, so it is the same choice (the
//! same paths) for every coding; any positive selection probability keeps
//! the estimator unbiased.

use glam::DVec3;

use super::{Arrival, EmitterHit, LiSample, Light, LightContext, ShadowRay, SpectrumOf};
use crate::coding::OBSERVER;
use crate::geometry::Shape;
use crate::scene::{Scene, Spot};
use lightbooth_science::colorimetry::{Cmf, KM_LM_PER_W};
use lightbooth_science::spectrum::Grid;

/// One emitting triangle: the vertex p0 and edges, its unit geometric normal
/// (the emitting side when one-sided) and area.
#[derive(Clone, Debug)]
pub struct EmittingTriangle {
    pub p0: DVec3,
    pub e1: DVec3,
    pub e2: DVec3,
    pub normal: DVec3,
    /// Area, m².
    pub area: f64,
    /// Index into `Scene::emitters`.
    pub emitter: usize,
    pub two_sided: bool,
}

/// A point chosen on an area light.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    pub point: DVec3,
    /// The emitting triangle's geometric normal.
    pub normal: DVec3,
    pub emitter: usize,
    pub two_sided: bool,
    /// Probability of the triangle divided by its area, 1/m².
    pub pdf_area: f64,
}

/// One area light: the emitting triangles of one emitter (`Scene::emitters`:
/// one `[[polygon]]` or `[[mesh]]` with `emission`, or one RADIANCE light
/// source material and every surface it modifies), and the distribution
/// over them by power.
#[derive(Clone, Debug)]
pub struct AreaLight {
    /// Index into `Scene::emitters`.
    pub emitter: usize,
    triangles: Vec<EmittingTriangle>,
    /// The scene primitive of each triangle, ascending (the triangles are
    /// in the scene's primitive order).
    primitives: Vec<usize>,
    /// Cumulative selection probabilities: `cdf[i]` = P(triangle < i); `cdf[n]` = 1.
    cdf: Vec<f64>,
    /// A RADIANCE spotlight's cone.
    spot: Option<Spot>,
    /// Luminous flux, lm, for the light sampler ([`super::sampler`]).
    phi: f64,
}

impl AreaLight {
    /// The area lights of `scene`, one per emitter with at least one
    /// triangle, in emitter order; an emitting primitive that is not a
    /// triangle, or an emitter without luminous power, is an error.
    pub fn of_scene(scene: &Scene) -> Result<Vec<AreaLight>, String> {
        // Computed from the emitters' spectra, for the light sampler's
        // weights only (any positive weight leaves the estimate unbiased):
        // the analysis observer, not an input's V(λ).
        let ybar = &Cmf::of(OBSERVER).on_grid(&Grid::one_nm())[1];
        let luminance: Vec<f64> = scene
            .emitters
            .iter()
            .map(|e| {
                let values = e.radiance.resample(&Grid::one_nm()).map(|s| s.into_values());
                values.map(|v| KM_LM_PER_W * v.iter().zip(ybar).map(|(l, y)| l * y).sum::<f64>())
            })
            .collect::<Result<_, _>>()
            .map_err(|e| e.to_string())?;
        let mut triangles: Vec<Vec<EmittingTriangle>> = vec![Vec::new(); scene.emitters.len()];
        let mut primitives: Vec<Vec<usize>> = vec![Vec::new(); scene.emitters.len()];
        let mut weights: Vec<Vec<f64>> = vec![Vec::new(); scene.emitters.len()];
        for (i, p) in scene.primitives.iter().enumerate() {
            let Some(e) = p.emitter else {
                continue;
            };
            let Shape::Triangle { p0, p1, p2, normal } = p.shape else {
                return Err(format!("primitive {i} emits light but is not a triangle"));
            };
            let emitter = &scene.emitters[e];
            if luminance[e].is_nan() || luminance[e] <= 0.0 {
                return Err(format!("emitter `{}` has no luminous power", emitter.name));
            }
            let (e1, e2) = (p1 - p0, p2 - p0);
            let area = 0.5 * e1.cross(e2).length();
            // The same weight for every triangle of one emitter up to its
            // area (one radiance, one number of sides): kept as the product
            // the collection of all emitting triangles used, so a scene with
            // one emitter chooses its triangles with the same bits.
            weights[e].push(area * luminance[e] * if emitter.two_sided { 2.0 } else { 1.0 });
            primitives[e].push(i);
            triangles[e].push(EmittingTriangle {
                p0,
                e1,
                e2,
                normal,
                area,
                emitter: e,
                two_sided: emitter.two_sided,
            });
        }
        let mut lights = Vec::new();
        for (e, ((triangles, primitives), weights)) in triangles.into_iter().zip(primitives).zip(weights).enumerate() {
            if triangles.is_empty() {
                continue;
            }
            let total: f64 = weights.iter().sum();
            let mut cdf = Vec::with_capacity(weights.len() + 1);
            let mut acc = 0.0;
            cdf.push(0.0);
            for w in &weights {
                acc += w / total;
                cdf.push(acc);
            }
            if let Some(last) = cdf.last_mut() {
                *last = 1.0;
            }
            let emitter = &scene.emitters[e];
            let area: f64 = triangles.iter().map(|t| t.area).sum();
            let sides = if emitter.two_sided { 2.0 } else { 1.0 };
            lights.push(AreaLight {
                emitter: e,
                triangles,
                primitives,
                cdf,
                spot: emitter.spot,
                phi: lambertian_flux(luminance[e], area, sides, emitter.spot.as_ref()),
            });
        }
        Ok(lights)
    }

    /// Selection probability of emitting triangle `i`.
    #[inline]
    fn pmf(&self, i: usize) -> f64 {
        self.cdf[i + 1] - self.cdf[i]
    }

    /// Luminous flux Φ, lm ([`lambertian_flux`]).
    pub fn phi(&self) -> f64 {
        self.phi
    }

    /// A point on the light from two uniform numbers: u1 chooses the
    /// triangle (and is then rescaled within its interval, so it stays
    /// stratified), (u1', u2) a point uniform in its area (the square-root
    /// map, pbrt-v4 `SampleUniformTriangle`).
    #[inline]
    pub fn sample(&self, u1: f64, u2: f64) -> LightSample {
        let n = self.triangles.len();
        let i = (self.cdf.partition_point(|&c| c <= u1) - 1).min(n - 1);
        let pmf = self.pmf(i);
        let u1 = ((u1 - self.cdf[i]) / pmf).clamp(0.0, 1.0);
        let t = &self.triangles[i];
        let su = u1.sqrt();
        let (b1, b2) = (1.0 - su, u2 * su);
        LightSample {
            point: t.p0 + t.e1 * b1 + t.e2 * b2,
            normal: t.normal,
            emitter: t.emitter,
            two_sided: t.two_sided,
            pdf_area: pmf / t.area,
        }
    }

    /// For primitive `primitive` (an emitter hit by a sampled direction), the
    /// density of choosing that point on this light, per m² of area; 0 when
    /// the primitive is not one of its triangles.
    #[inline]
    pub fn pdf_area_of_primitive(&self, primitive: usize) -> f64 {
        match self.primitives.binary_search(&primitive) {
            Ok(i) => self.pmf(i) / self.triangles[i].area,
            Err(_) => 0.0,
        }
    }
}

/// The luminous flux of a Lambertian emitter of luminance `luminance`
/// (cd/m²), area `area` (m²) and `sides` emitting sides: Φ = π·L·A·sides
/// (lm). A RADIANCE spotlight's cone keeps the fraction 1 − max(cos(angle/2), 0)²
/// of it: the share of a Lambertian emitter's flux inside a cone around its
/// normal. Approximation, used only for the light sampler's probabilities:
/// the cone's axis is taken to be the normal, and the focal-length falloff
/// d²/(d + flen)² (which depends on the receiver) is left out; at least
/// 10⁻⁶ of the flux stays, so a narrow cone is still chosen.
pub fn lambertian_flux(luminance: f64, area: f64, sides: f64, spot: Option<&Spot>) -> f64 {
    let cone = match spot {
        None => 1.0,
        Some(s) => {
            let c = s.cos_half_angle.clamp(0.0, 1.0);
            (1.0 - c * c).max(1e-6)
        }
    };
    std::f64::consts::PI * luminance * area * sides * cone
}

impl Light for AreaLight {
    /// One point on the light's triangles ([`AreaLight::sample`]), with
    /// its density in solid angle at the surface point.
    #[inline]
    fn sample_li(&self, ctx: &LightContext, u: (f64, f64)) -> Option<LiSample> {
        let s = self.sample(u.0, u.1);
        let to_light = s.point - ctx.p;
        let d2 = to_light.length_squared();
        let wi = to_light / d2.sqrt();
        let cos_i = ctx.n.dot(wi);
        let cos_l_signed = -wi.dot(s.normal);
        let cos_l = if s.two_sided { cos_l_signed.abs() } else { cos_l_signed };
        if !(cos_i > 0.0 && cos_l > 0.0) {
            return None;
        }
        let spot = match &self.spot {
            None => 1.0,
            Some(spot) => spot.factor(-wi, Some(s.point.distance(ctx.p))),
        };
        Some(LiSample {
            wi,
            cos_i,
            arrival: Arrival::Area {
                pdf: s.pdf_area * d2 / cos_l,
                spot,
            },
            shadow: ShadowRay::ToPoint(s.point),
            spectrum: SpectrumOf::Emitter(s.emitter),
            pmf: 1.0,
        })
    }

    /// p_ω = P(triangle)/A · d² / |cos θ_y| of the point a ray hit.
    #[inline]
    fn pdf_li(&self, hit: &EmitterHit) -> f64 {
        self.pdf_area_of_primitive(hit.primitive) * hit.distance * hit.distance / hit.cos_l
    }

    /// A spotlight's cone and focal falloff: the sensor's own ray sees the
    /// lamp's radiance, a surface the radiance scaled by d²/(d + flen)².
    #[inline]
    fn le_factor(&self, hit: &EmitterHit) -> f64 {
        match &self.spot {
            None => 1.0,
            Some(spot) => spot.factor(-hit.dir, (!hit.from_sensor).then_some(hit.distance)),
        }
    }

    fn is_delta(&self) -> bool {
        false
    }

    fn phi(&self) -> f64 {
        self.phi
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two triangles making the square [−½, ½]² at z = 1, emitting down.
    fn panel() -> AreaLight {
        let tri = |p0: DVec3, p1: DVec3, p2: DVec3| EmittingTriangle {
            p0,
            e1: p1 - p0,
            e2: p2 - p0,
            normal: -DVec3::Z,
            area: 0.5,
            emitter: 0,
            two_sided: false,
        };
        let (a, b, c, d) = (
            DVec3::new(-0.5, -0.5, 1.0),
            DVec3::new(-0.5, 0.5, 1.0),
            DVec3::new(0.5, 0.5, 1.0),
            DVec3::new(0.5, -0.5, 1.0),
        );
        AreaLight {
            emitter: 0,
            triangles: vec![tri(a, b, c), tri(a, c, d)],
            primitives: vec![0, 1],
            cdf: vec![0.0, 0.5, 1.0],
            spot: None,
            phi: lambertian_flux(1.0, 1.0, 1.0, None),
        }
    }

    /// A 1 m × 1 m one-sided panel 1 m above the surface point, facing it:
    /// the light sample's density is 1/A · d²/cos θ_y in solid angle
    /// (pbrt-v4 §4.2.3), and the density the ray strategy's `pdf_li` gives
    /// the same point is the same.
    #[test]
    fn a_panel_overhead_has_the_area_density_converted_to_solid_angle() {
        let lights = panel();
        let ctx = LightContext {
            p: DVec3::ZERO,
            n: DVec3::Z,
        };
        let mut checked = 0;
        for (u1, u2) in [(0.1, 0.2), (0.5, 0.5), (0.9, 0.3), (0.3, 0.8)] {
            let Some(s) = lights.sample_li(&ctx, (u1, u2)) else {
                panic!("the panel faces the point");
            };
            let ShadowRay::ToPoint(y) = s.shadow else {
                panic!("an area sample ends on the light")
            };
            let d2 = y.length_squared();
            let cos_y = s.wi.z; // the panel's normal is −z
            let pdf = s.pdf().unwrap();
            assert!((pdf - d2 / cos_y).abs() < 1e-12 * pdf, "{pdf} vs {}", d2 / cos_y);
            let hit = EmitterHit {
                primitive: usize::from(y.x > y.y),
                emitter: 0,
                distance: d2.sqrt(),
                cos_l: cos_y,
                dir: s.wi,
                from_sensor: false,
            };
            assert!((lights.pdf_li(&hit) - pdf).abs() < 1e-9 * pdf);
            assert_eq!(lights.le_factor(&hit), 1.0, "a plain emitter");
            checked += 1;
        }
        assert_eq!(checked, 4);
    }
}
