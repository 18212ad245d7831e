//! A point luminaire ([`PointLight`]) as a delta [`Light`]: the one
//! direction to it, its candela toward the surface point, the
//! inverse-square law; and its luminous flux, for the light sampler.

use std::f64::consts::PI;

use glam::DVec3;

use super::{Arrival, EmitterHit, LiSample, Light, LightContext, ShadowRay, SpectrumOf};
use crate::scene::{LightDistribution, PointLight};

/// Steps of cos γ (equal solid angles) in the midpoint rule of an IES
/// table's flux ([`luminous_flux`]).
const FLUX_STEPS_COS_GAMMA: usize = 360;
/// Steps of C in that rule for a table that is not rotationally symmetric.
const FLUX_STEPS_C: usize = 72;

/// The luminous flux Φ = ∫ I(ω) dω of a point luminaire, lm, for the light
/// sampler's power-proportional choice ([`super::sampler`]).
///
/// - isotropic (`cone_deg` ≥ 180): Φ = 4π·I, exact;
/// - a cone of half-angle γₒ with a smoothstep falloff (in cos γ) from
///   γᵢ = γₒ − `falloff_deg`: Φ = 2π·I·[(1 − cos γᵢ) + (cos γᵢ − cos γₒ)/2],
///   exact (a smoothstep's mean over its interval is ½; dω = 2π d(cos γ));
/// - an IES table: the midpoint rule over [`FLUX_STEPS_COS_GAMMA`] equal
///   steps of cos γ and [`FLUX_STEPS_C`] of C (one for a rotationally
///   symmetric table) of the intensity the renderer uses
///   ([`PointLight::candela_toward`]), an approximation that moves only the
///   sampler's probabilities, never the estimate's mean; a beam the rule's
///   midpoints miss counts as its peak over one step's solid angle, so
///   that no emitting luminaire reads 0 lm.
pub fn luminous_flux(light: &PointLight) -> f64 {
    match &light.distribution {
        LightDistribution::Cone {
            intensity_cd,
            cone_deg,
            falloff_deg,
        } => {
            let i = intensity_cd * light.intensity_scale;
            if *cone_deg >= 180.0 {
                return 4.0 * PI * i;
            }
            let cos_outer = cone_deg.to_radians().cos();
            let cos_inner = (cone_deg - falloff_deg).max(0.0).to_radians().cos();
            2.0 * PI * i * ((1.0 - cos_inner) + 0.5 * (cos_inner - cos_outer))
        }
        LightDistribution::Ies(table) => {
            let n_c = if table.is_rotationally_symmetric() {
                1
            } else {
                FLUX_STEPS_C
            };
            let b = light.aim.cross(light.c0);
            let mut sum = 0.0;
            for j in 0..FLUX_STEPS_COS_GAMMA {
                let cos_g = 1.0 - 2.0 * (j as f64 + 0.5) / FLUX_STEPS_COS_GAMMA as f64;
                let sin_g = (1.0 - cos_g * cos_g).max(0.0).sqrt();
                for k in 0..n_c {
                    let c = 2.0 * PI * (k as f64 + 0.5) / n_c as f64;
                    let dir: DVec3 = light.aim * cos_g + (light.c0 * c.cos() + b * c.sin()) * sin_g;
                    sum += light.candela_toward(dir);
                }
            }
            // Each cell is 2/N of cos γ by 2π/M of C.
            let flux = sum * (2.0 / FLUX_STEPS_COS_GAMMA as f64) * (2.0 * PI / n_c as f64);
            // A beam narrower than one step of cos γ (under about 4.3° from
            // the aim) falls between the midpoints and would read 0 lm: a
            // light the sampler then never chose although it emits, a
            // biased estimate. Such a beam counts as its peak over one
            // cell's solid angle (4π/N sr), so every emitting table gets
            // P > 0.
            let peak = table.peak_cd() * light.intensity_scale;
            if flux > 0.0 || peak <= 0.0 {
                flux
            } else {
                peak * 4.0 * PI / FLUX_STEPS_COS_GAMMA as f64
            }
        }
    }
}

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
            pmf: 1.0,
        })
    }

    fn pdf_li(&self, _hit: &EmitterHit) -> f64 {
        0.0
    }

    fn le_factor(&self, _hit: &EmitterHit) -> f64 {
        0.0
    }

    fn is_delta(&self) -> bool {
        true
    }

    fn phi(&self) -> f64 {
        luminous_flux(self.light)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
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

    /// The flux of the closed forms: 4π·I isotropic, 2π·I·(1 − cos γ) for a
    /// hard cone, and the smoothstep edge counting half; an isotropic IES
    /// table integrates to 4π·I by the midpoint rule.
    #[test]
    fn the_flux_is_the_intensity_integrated_over_the_sphere() {
        let mut l = lamp(DVec3::ZERO);
        assert!((luminous_flux(&l) - 4.0 * PI * 100.0).abs() < 1e-9);
        l.distribution = LightDistribution::Cone {
            intensity_cd: 100.0,
            cone_deg: 60.0,
            falloff_deg: 0.0,
        };
        assert!((luminous_flux(&l) - 2.0 * PI * 100.0 * 0.5).abs() < 1e-9);
        l.distribution = LightDistribution::Cone {
            intensity_cd: 100.0,
            cone_deg: 60.0,
            falloff_deg: 60.0,
        };
        // From γᵢ = 0: ∫ smoothstep d(cos γ) over [cos 60°, 1] = ½·½.
        assert!((luminous_flux(&l) - 2.0 * PI * 100.0 * 0.25).abs() < 1e-9);
        // The same smooth cone, integrated numerically through candela_toward.
        let (mut sum, n) = (0.0, 200_000);
        for j in 0..n {
            let cos_g = 1.0 - 2.0 * (j as f64 + 0.5) / n as f64;
            let sin_g = (1.0 - cos_g * cos_g).sqrt();
            sum += l.candela_toward(-DVec3::Z * cos_g + DVec3::X * sin_g);
        }
        assert!((sum * 2.0 / n as f64 * 2.0 * PI - luminous_flux(&l)).abs() < 1e-6 * luminous_flux(&l));
        let iso = crate::ies::IesDistribution::parse(
            &crate::ies::write_symmetric_lm63(&[("TEST", "iso")], &[0.0, 90.0, 180.0], &[50.0; 3]),
            "iso.ies",
        )
        .unwrap();
        l.distribution = LightDistribution::Ies(iso);
        l.intensity_scale = 2.0;
        assert!((luminous_flux(&l) - 4.0 * PI * 100.0).abs() < 1e-9);
    }

    /// A 1° beam falls between the midpoint rule's first two midpoints
    /// (cos γ = 1 − 1/360 is γ ≈ 4.3°): its flux read 0 lm, and the power
    /// sampler would never have chosen a lamp that lights the scene.
    #[test]
    fn a_beam_narrower_than_the_flux_rule_step_still_has_flux() {
        let mut l = lamp(DVec3::ZERO);
        let narrow = crate::ies::IesDistribution::parse(
            &crate::ies::write_symmetric_lm63(
                &[("TEST", "narrow")],
                &[0.0, 1.0, 90.0, 180.0],
                &[1000.0, 0.0, 0.0, 0.0],
            ),
            "narrow.ies",
        )
        .unwrap();
        l.distribution = LightDistribution::Ies(narrow);
        let phi = luminous_flux(&l);
        assert!(phi > 0.0, "{phi}");
        let sampler = super::super::LightSampler::power(&[4.0 * PI * 100.0, phi]);
        assert!(sampler.pmf(1) > 0.0);
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
