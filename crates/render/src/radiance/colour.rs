//! Spectra for RADIANCE's RGB colours, synthesised at load time.
//!
//! A RADIANCE material or light gives its colour as RGB in RADIANCE's
//! primaries with an equal-energy white. The `rgb` coding uses those
//! numbers exactly (`Material::rgb`, `Emitter::rgb`); the spectral codings
//! need a spectrum, which RGB does not determine. The method here is
//! Jakob & Hanika's (2019), "A Low-Dimensional Function Space for
//! Efficient Spectral Upsampling", Computer Graphics Forum 38(2): the
//! reflectance is a sigmoid of a quadratic polynomial in wavelength,
//!
//! ```text
//! ρ(λ) = S(c₀t² + c₁t + c₂),  S(x) = ½ + x / (2√(1 + x²)),  t = (λ − 580 nm) / 200 nm,
//! ```
//!
//! smooth and inside (0, 1) by construction. Unlike the paper, which
//! precomputes a table, the three coefficients are fitted per colour here
//! by Levenberg–Marquardt (damped Gauss–Newton) so that the RGB of ρ under
//! the equal-energy illuminant — computed exactly as the `rgb` coding
//! computes a reflectance's RGB (81 samples, 380–780 nm, the renderer's
//! observer) — equals the given RGB. Greys (r = g = b) are flat spectra,
//! exactly. Colours no smooth reflectance reaches (a component at 0 or 1
//! with others not) keep the least-squares fit, and the fit's residual is
//! reported.
//!
//! A light's RGB radiance (r, g, b) in RADIANCE's W/(sr·m²) per channel
//! becomes L(λ) = m · s(λ) · 179 / (683 · Σ ȳ(λ)·1 nm) with m = max(r, g, b)
//! and s the sigmoid fitted to (r, g, b)/m: its `rgb` channels are then
//! 179·(r, g, b) and its luminance 179·(0.265 r + 0.670 g + 0.065 b) cd/m²,
//! RADIANCE's convention that a `light` of (1, 1, 1) has 179 cd/m².

use std::sync::OnceLock;

use glam::{DMat3, DVec3};

use crate::coding::{ChannelLayout, Coding, OBSERVER};
use lightbooth_science::colorimetry::xyz_from_radiance;
use lightbooth_science::spectrum::{Grid, SpectralUnit, Spectrum};

/// RADIANCE's luminous efficacy of its RGB radiance unit, lm/W: a `light`
/// of (1, 1, 1) has 179 cd/m².
pub const RADIANCE_EFFICACY: f64 = 179.0;

/// The sigmoid-polynomial coefficients of a reflectance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SmoothSpectrum {
    /// A flat spectrum (greys, exactly).
    Flat(f64),
    /// ρ(λ) = S(c₀t² + c₁t + c₂).
    Sigmoid([f64; 3]),
}

impl SmoothSpectrum {
    pub fn at(&self, nm: f64) -> f64 {
        match *self {
            SmoothSpectrum::Flat(v) => v,
            SmoothSpectrum::Sigmoid(c) => {
                let t = (nm - 580.0) / 200.0;
                sigmoid(c[0] * t * t + c[1] * t + c[2])
            }
        }
    }

    /// Sampled on the 1 nm grid, 380–780 nm, times `scale`; an error when
    /// a value is not a finite number (a `scale` that overflows).
    pub fn on_1nm(&self, unit: SpectralUnit, scale: f64) -> Result<Spectrum, String> {
        let grid = Grid::one_nm();
        let values = grid.wavelengths().iter().map(|&nm| scale * self.at(nm)).collect();
        Spectrum::new(grid, unit, values).map_err(|e| e.to_string())
    }
}

fn sigmoid(x: f64) -> f64 {
    0.5 + x / (2.0 * (1.0 + x * x).sqrt())
}

fn sigmoid_slope(x: f64) -> f64 {
    0.5 / (1.0 + x * x).powf(1.5)
}

/// The rgb coding's reflectance → RGB map as a 3 × 81 matrix: row k holds
/// channel k's response to a unit reflectance at each 5 nm sample (the map
/// is linear; it is taken from [`ChannelLayout::reflectance_channels`] itself).
fn rgb_weights() -> &'static [[f64; 81]; 3] {
    static W: OnceLock<[[f64; 81]; 3]> = OnceLock::new();
    W.get_or_init(|| {
        let layout = ChannelLayout::new(&[Coding::Rgb]);
        let mut w = [[0.0; 81]; 3];
        for i in 0..81 {
            let mut v = vec![0.0; 81];
            v[i] = 1.0;
            let s = Spectrum::new(Grid::analysis(), SpectralUnit::Reflectance, v).expect("impulse");
            let c = layout.reflectance_channels(&s).expect("analysis grid");
            for k in 0..3 {
                w[k][i] = c[k] as f64;
            }
        }
        w
    })
}

/// The rgb coding's RGB of a smooth reflectance.
#[cfg(test)]
pub fn rgb_of(s: &SmoothSpectrum) -> [f64; 3] {
    let w = rgb_weights();
    let grid = Grid::analysis();
    let mut rgb = [0.0; 3];
    for (i, &nm) in grid.wavelengths().iter().enumerate() {
        let r = s.at(nm);
        for k in 0..3 {
            rgb[k] += w[k][i] * r;
        }
    }
    rgb
}

/// A smooth reflectance whose RGB under E is `rgb` (each in [0, 1]), and
/// the largest |RGB difference| left (0 up to rounding when reachable).
pub fn fit_reflectance(rgb: [f64; 3]) -> (SmoothSpectrum, f64) {
    if rgb[0] == rgb[1] && rgb[1] == rgb[2] {
        return (SmoothSpectrum::Flat(rgb[0]), 0.0);
    }
    let w = rgb_weights();
    let t: Vec<f64> = Grid::analysis()
        .wavelengths()
        .iter()
        .map(|nm| (nm - 580.0) / 200.0)
        .collect();
    let target = DVec3::from(rgb);
    let eval = |c: DVec3| -> (DVec3, DMat3) {
        let mut f = DVec3::ZERO;
        let mut j = DMat3::ZERO;
        for (i, &ti) in t.iter().enumerate() {
            let x = c.x * ti * ti + c.y * ti + c.z;
            let (s, ds) = (sigmoid(x), sigmoid_slope(x));
            let phi = DVec3::new(ti * ti, ti, 1.0) * ds;
            for k in 0..3 {
                f[k] += w[k][i] * s;
                // Row k of the Jacobian, stored as column k of j (so j is Jᵀ).
                let col = j.col_mut(k);
                *col += phi * w[k][i];
            }
        }
        (f - target, j)
    };
    let mean = ((rgb[0] + rgb[1] + rgb[2]) / 3.0).clamp(0.02, 0.98);
    let mut c = DVec3::new(0.0, 0.0, (mean - 0.5) / (mean * (1.0 - mean)).sqrt());
    let (mut r, mut jt) = eval(c);
    let mut mu = 1e-3;
    for _ in 0..500 {
        if r.abs().max_element() < 1e-12 {
            break;
        }
        // (JᵀJ + μ·diag) δ = −Jᵀr, with J = jtᵀ.
        let jtj = jt * jt.transpose();
        let g = jt * r;
        let damped = jtj + DMat3::from_diagonal(DVec3::new(jtj.x_axis.x, jtj.y_axis.y, jtj.z_axis.z) * mu);
        if damped.determinant().abs() < 1e-300 {
            break;
        }
        let delta = -(damped.inverse() * g);
        let candidate = c + delta;
        let (r2, jt2) = eval(candidate);
        if candidate.is_finite() && r2.length_squared() < r.length_squared() {
            c = candidate;
            r = r2;
            jt = jt2;
            mu = (mu * 0.3).max(1e-12);
        } else {
            mu *= 10.0;
            if mu > 1e12 {
                break;
            }
        }
    }
    (SmoothSpectrum::Sigmoid(c.to_array()), r.abs().max_element())
}

/// Luminance of a flat 1 W/(sr·m²·nm) spectrum, cd/m² (683 · Σ ȳ · 1 nm),
/// in the renderer's analysis observer, not V(λ): a RADIANCE light is RGB
/// radiance, and its synthesised spectrum must give the `rgb` coding's
/// channels (computed in the analysis observer) 179·(r, g, b), so the
/// `spectral` and `rgb` codings of an imported scene agree. Its 179 cd/m²
/// per unit are therefore in the analysis observer (a RADIANCE file states
/// no observer); a lamp given in candela in a scene file is in V(λ).
fn flat_luminance() -> f64 {
    static Y: OnceLock<f64> = OnceLock::new();
    *Y.get_or_init(|| {
        let flat = Spectrum::constant(Grid::one_nm(), SpectralUnit::SpectralRadiance, 1.0).expect("flat");
        xyz_from_radiance(&flat, OBSERVER).expect("radiance").y
    })
}

/// The spectral radiance (W/(sr·m²·nm), 1 nm grid) synthesised for a
/// RADIANCE light of RGB radiance `rgb`, and the fit's residual (in the
/// RGB of `rgb`/max); an error when the radiance in lightbooth's units
/// (× 179 lm/W) is not a finite number.
pub fn emission_from_rgb(rgb: [f64; 3]) -> Result<(Spectrum, f64), String> {
    let m = rgb.iter().copied().fold(0.0, f64::max);
    if !(m * RADIANCE_EFFICACY).is_finite() {
        return Err(overflow(m));
    }
    if m <= 0.0 {
        return Ok((
            Spectrum::constant(Grid::one_nm(), SpectralUnit::SpectralRadiance, 0.0).expect("zero"),
            0.0,
        ));
    }
    let (shape, residual) = fit_reflectance(rgb.map(|v| v / m));
    let spectrum = shape
        .on_1nm(SpectralUnit::SpectralRadiance, m * RADIANCE_EFFICACY / flat_luminance())
        .map_err(|_| overflow(m))?;
    Ok((spectrum, residual))
}

fn overflow(m: f64) -> String {
    format!(
        "the radiance {m:e} × {RADIANCE_EFFICACY} lm/W is not a finite number in lightbooth's units \
         (W/(sr·m²·nm)): give a radiance below {:e}",
        f64::MAX / RADIANCE_EFFICACY / 1e3
    )
}

/// The spectral radiance of a light of grey level `k` modified by the
/// multiplier spectrum `s` (RADIANCE 6 `spectrum`/`specfile`): k·s(λ)·179 /
/// (683·Σȳ), so a spectrum averaging 1 against V(λ) keeps 179·k cd/m².
/// An error when the product is not a finite number.
pub fn emission_from_spectrum(k: f64, s: &Spectrum) -> Result<Spectrum, String> {
    let s1 = s.resample(&Grid::one_nm()).map_err(|e| e.to_string())?;
    let scale = k * RADIANCE_EFFICACY / flat_luminance();
    let values: Vec<f64> = s1.values().iter().map(|v| v * scale).collect();
    if let Some(v) = values.iter().find(|v| !v.is_finite()) {
        return Err(format!(
            "grey {k:e} × its spectrum × {RADIANCE_EFFICACY} lm/W gives {v}, not a finite number: the numbers \
             overflow; give a smaller grey or spectrum"
        ));
    }
    Spectrum::new(Grid::one_nm(), SpectralUnit::SpectralRadiance, values).map_err(|e| e.to_string())
}

/// How spectra were synthesised from RADIANCE RGB, for reports.
pub const SYNTHESIS_METHOD: &str = "spectra synthesised from RADIANCE RGB: reflectances as Jakob & Hanika (2019) \
     sigmoid polynomials fitted per colour (Levenberg–Marquardt) to reproduce the RGB under the equal-energy \
     illuminant, greys flat; light emission as the same shape scaled to RADIANCE's 179 lm/W; the rgb coding uses \
     the file's RGB exactly";

#[cfg(test)]
mod tests {
    use super::*;

    /// In-gamut colours are reproduced to 1e-6 by a spectrum inside (0, 1);
    /// greys are flat.
    #[test]
    fn fitted_reflectances_reproduce_their_rgb_and_stay_in_0_1() {
        for rgb in [
            [0.6, 0.2, 0.1],
            [0.2, 0.5, 0.3],
            [0.1, 0.2, 0.6],
            [0.9, 0.85, 0.3],
            [0.05, 0.05, 0.06],
        ] {
            let (s, residual) = fit_reflectance(rgb);
            let got = rgb_of(&s);
            for k in 0..3 {
                assert!(
                    (got[k] - rgb[k]).abs() < 1e-6,
                    "{rgb:?} → {got:?} (residual {residual})"
                );
            }
            for nm in (380..=780).step_by(5) {
                let v = s.at(nm as f64);
                assert!(v > 0.0 && v < 1.0, "{rgb:?} at {nm} nm: {v}");
            }
        }
        assert_eq!(fit_reflectance([0.5; 3]), (SmoothSpectrum::Flat(0.5), 0.0));
    }

    /// A colour no reflectance in [0, 1] has — red above the largest red any
    /// such reflectance reaches, Σ max(w_red, 0) — is not reached: the fit
    /// reports the miss it leaves, which is at least the gap to that bound.
    #[test]
    fn unreachable_colours_report_their_residual() {
        let red_max: f64 = rgb_weights()[0].iter().map(|w| w.max(0.0)).sum();
        let target = [1.05 * red_max, 0.5, 0.5];
        let (s, residual) = fit_reflectance(target);
        let got = rgb_of(&s);
        let miss = (0..3).map(|k| (got[k] - target[k]).abs()).fold(0.0, f64::max);
        assert!(residual >= 0.05 * red_max - 1e-9, "{residual} (red max {red_max})");
        assert!((residual - miss).abs() < 1e-9, "reported {residual}, actual {miss}");
    }

    /// RADIANCE's convention: a light of (1, 1, 1) has luminance 179 cd/m²,
    /// and a coloured light 179·(0.265 r + 0.670 g + 0.065 b) (RADIANCE's
    /// `luminance` from `rcalc`, with its primaries' Y row).
    #[test]
    fn a_white_light_of_one_has_179_cd_per_m2() {
        let (l, _) = emission_from_rgb([1.0, 1.0, 1.0]).unwrap();
        let y = xyz_from_radiance(&l, OBSERVER).unwrap().y;
        assert!((y - 179.0).abs() < 1e-9, "{y}");
        let (l, residual) = emission_from_rgb([2.0, 1.5, 1.0]).unwrap();
        let y = xyz_from_radiance(&l, OBSERVER).unwrap().y;
        let want = 179.0 * (0.2651 * 2.0 + 0.6701 * 1.5 + 0.0648 * 1.0);
        assert!(residual < 1e-6 && (y / want - 1.0).abs() < 1e-3, "{y} vs {want}");
    }
}
