//! A point luminaire ([`PointLight`]) as a delta [`Light`]: the one
//! direction to it, its candela toward the surface point, the
//! inverse-square law.

use super::{Arrival, EmitterHit, LiSample, Light, LightContext, ShadowRay, SpectrumOf};
use crate::scene::PointLight;

/// A scene's point light with its index in `Scene::lights` (whose prepared
/// spectrum its samples carry).
#[derive(Clone, Copy, Debug)]
pub struct Luminaire<'a> {
    pub index: usize,
    pub light: &'a PointLight,
}

impl Light for Luminaire<'_> {
    #[inline]
    fn sample_li(&self, ctx: &LightContext, _u: (f64, f64)) -> Option<LiSample> {
        let to_light = self.light.position - ctx.p;
        let distance2 = to_light.length_squared();
        let d = distance2.sqrt();
        let wi = to_light / d;
        let cos_i = ctx.n.dot(wi);
        if cos_i <= 0.0 {
            return None;
        }
        let candela = self.light.candela_toward(-wi);
        if candela <= 0.0 {
            return None;
        }
        Some(LiSample {
            wi,
            cos_i,
            arrival: Arrival::Delta { candela, distance2 },
            shadow: ShadowRay::Along { t_max: d },
            spectrum: SpectrumOf::Luminaire(self.index),
        })
    }

    fn pdf_li(&self, _hit: &EmitterHit) -> f64 {
        0.0
    }

    fn le_factor(&self, _hit: &EmitterHit) -> f64 {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;
    use crate::scene::LightDistribution;
    use lightbooth_science::spectrum::{Grid, SpectralUnit, Spectrum};

    fn lamp(at: DVec3) -> PointLight {
        PointLight {
            id: "lamp".into(),
            position: at,
            aim: -DVec3::Z,
            c0: DVec3::X,
            distribution: LightDistribution::Cone {
                intensity_cd: 100.0,
                cone_deg: 180.0,
                falloff_deg: 0.0,
            },
            intensity_scale: 1.0,
            spectrum_per_cd: Spectrum::constant(Grid::one_nm(), SpectralUnit::RelativePower, 1.0).unwrap(),
        }
    }

    /// A lamp 2 m above a floor point, 1.2 m to the side: cos θ = 2/√(2² + 1.2²).
    #[test]
    fn a_lamp_above_the_floor_gives_its_candela_at_the_inverse_square_distance() {
        let l = lamp(DVec3::new(1.2, 0.0, 2.0));
        let s = Luminaire { index: 3, light: &l }
            .sample_li(
                &LightContext {
                    p: DVec3::ZERO,
                    n: DVec3::Z,
                },
                (0.5, 0.5),
            )
            .unwrap();
        let d2 = 1.2f64 * 1.2 + 4.0;
        assert!((s.cos_i - 2.0 / d2.sqrt()).abs() < 1e-15);
        assert!((s.scale(1.0, 1.0) - 100.0 * 2.0 / d2.sqrt() / d2).abs() < 1e-12);
        assert_eq!(s.spectrum, SpectrumOf::Luminaire(3));
    }

    #[test]
    fn a_lamp_below_the_surface_gives_no_sample() {
        let l = lamp(DVec3::new(0.0, 0.0, -1.0));
        let s = Luminaire { index: 0, light: &l }.sample_li(
            &LightContext {
                p: DVec3::ZERO,
                n: DVec3::Z,
            },
            (0.5, 0.5),
        );
        assert!(s.is_none());
    }
}
