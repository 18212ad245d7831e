//! Area lights: choosing a point on the scene's emitting triangles for
//! next-event estimation, and the density of that choice for multiple
//! importance sampling.
//!
//! Every primitive with an [`Emitter`](super::scene::Emitter) is a triangle
//! (the scene loader only lets `[[polygon]]` and `[[mesh]]` emit). A light
//! sample picks one triangle with probability proportional to its power
//! (area × luminance of its radiance × emitting sides: bright small panels
//! and dim large ones each get samples in proportion to the light they send
//! out), then a point uniform in its area. The density of the chosen point
//! y, seen from x in solid angle, is
//!
//! ```text
//! p_ω(y) = P(triangle) / A(triangle) · |x − y|² / |cos θ_y|
//! ```
//!
//! (pbrt-v4 §4.2.3, converting area to solid-angle density), which the
//! integrator compares with the BSDF's density to weight the two strategies
//! (Veach & Guibas 1995, the power heuristic with β = 2).
//!
//! Approximation stated: selection by power uses the luminance of each
//! emitter's spectrum, not each coding's own channels, so it is the same
//! choice (the same paths) for every coding; any positive selection
//! probability keeps the estimator unbiased.

use glam::DVec3;

use super::coding::OBSERVER;
use super::geometry::Shape;
use super::scene::Scene;
use crate::colorimetry::{Cmf, KM_LM_PER_W};
use crate::spectrum::Grid;

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

/// The scene's emitting triangles and the power distribution over them.
#[derive(Clone, Debug, Default)]
pub struct AreaLights {
    triangles: Vec<EmittingTriangle>,
    /// Cumulative selection probabilities: `cdf[i]` = P(triangle < i); `cdf[n]` = 1.
    cdf: Vec<f64>,
    /// Per primitive of the scene, its index in `triangles` (`u32::MAX`: none).
    of_primitive: Vec<u32>,
}

impl AreaLights {
    /// Collects the emitting triangles of `scene`; an emitting primitive that
    /// is not a triangle, or an emitter without luminous power, is an error.
    pub fn new(scene: &Scene) -> Result<AreaLights, String> {
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
        let mut triangles = Vec::new();
        let mut weights = Vec::new();
        // Only scenes with emitters pay for the per-primitive table.
        let mut of_primitive = if scene.emitters.is_empty() {
            Vec::new()
        } else {
            vec![u32::MAX; scene.primitives.len()]
        };
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
            of_primitive[i] = triangles.len() as u32;
            weights.push(area * luminance[e] * if emitter.two_sided { 2.0 } else { 1.0 });
            triangles.push(EmittingTriangle {
                p0,
                e1,
                e2,
                normal,
                area,
                emitter: e,
                two_sided: emitter.two_sided,
            });
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
        Ok(AreaLights {
            triangles,
            cdf,
            of_primitive,
        })
    }

    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// Selection probability of emitting triangle `i`.
    #[inline]
    fn pmf(&self, i: usize) -> f64 {
        self.cdf[i + 1] - self.cdf[i]
    }

    /// A point on the lights from two uniform numbers: u1 chooses the
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
    /// light strategy's density of choosing that point, per m² of area.
    #[inline]
    pub fn pdf_area_of_primitive(&self, primitive: usize) -> f64 {
        match self.of_primitive.get(primitive) {
            Some(&i) if i != u32::MAX => self.pmf(i as usize) / self.triangles[i as usize].area,
            _ => 0.0,
        }
    }
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
}
