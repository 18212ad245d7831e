//! Colour codings and the channel layout that carries all of them at once.
//!
//! A path carries one contiguous `[f32]` with every requested coding's
//! channels side by side (rgb 3, srgb 3, nstepN N, spectral 401). Every
//! multiplication of the transport (reflectance × reflectance × light) is an
//! element-wise product of such vectors, so each coding sees the same random
//! paths and differences between codings are not sampling noise.
//!
//! How each coding turns the scene's spectra into channels, and channels
//! back into XYZ (observer: Judd–Vos, the study's, unless the render settings
//! name another — [`ChannelLayout::with_observer`]):
//!
//! - `spectral` — the reference: every spectrum linearly resampled to 1 nm
//!   (380–780 nm, 401 channels); channels are spectral radiance in
//!   W/(sr·m²·nm); XYZ by [`xyz_from_radiance`] (the plain CIE sum at 1 nm).
//! - `nstepN` — every spectrum taken on the 81-sample 380–780 nm analysis grid
//!   (5 nm) and band-averaged into N bands ([`Bands`]); products are per band;
//!   XYZ with the approximated (band-averaged) matching functions
//!   ([`NStepObserver`]). The light's 5 nm samples are its 1 nm spectrum at
//!   380, 385, …, so `nstep81` equals `spectral` at those wavelengths.
//! - `rgb` (RADIANCE's primaries, equal-energy white) and `srgb` (Rec. 709
//!   primaries, D65 white) — what a RADIANCE user does:
//!   - a reflectance's RGB is M⁻¹ · XYZ of the reflectance under the space's
//!     white illuminant (E or D65, relative), divided per channel by the same
//!     for a perfect white, so ρ = 1 is exactly (1, 1, 1) and a flat ρ is
//!     (ρ, ρ, ρ);
//!   - a light's RGB is M⁻¹ · its absolute XYZ (from the 1 nm spectrum), so
//!     the light itself is reproduced exactly;
//!   - results go back to XYZ through M (the RGB → XYZ matrix derived from the
//!     primaries, [`RgbSpace::rgb_to_xyz`]).

use std::fmt;
use std::ops::Range;
use std::str::FromStr;

use lightbooth_science::colorimetry::rgb::{apply, RgbSpace};
use lightbooth_science::colorimetry::{xyz_from_radiance, xyz_relative, Cmf, Observer, Xyz, KM_LM_PER_W};
use lightbooth_science::nstep::{Bands, NStepObserver};
use lightbooth_science::reference_data::{illuminant, Illuminant};
use lightbooth_science::spectrum::{Grid, SpectralUnit, Spectrum};

/// The observer of every colorimetric conversion in the renderer.
pub const OBSERVER: Observer = Observer::JuddVos;

/// One colour coding.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Coding {
    /// RADIANCE's default primaries with an equal-energy white.
    Rgb,
    /// sRGB primaries, D65 white.
    Srgb,
    /// N equal bands on the 81-sample 380–780 nm grid.
    NStep(usize),
    /// 1 nm, 401 samples: the reference.
    Spectral,
}

impl Coding {
    /// The study's seven codings.
    pub const ALL: [Coding; 7] = [
        Coding::Rgb,
        Coding::Srgb,
        Coding::NStep(3),
        Coding::NStep(9),
        Coding::NStep(27),
        Coding::NStep(81),
        Coding::Spectral,
    ];

    /// The number of channels this coding carries.
    pub fn channels(self) -> usize {
        match self {
            Coding::Rgb | Coding::Srgb => 3,
            Coding::NStep(n) => n,
            Coding::Spectral => Grid::one_nm().len(),
        }
    }

    fn rgb_space(self) -> Option<(RgbSpace, Illuminant)> {
        match self {
            Coding::Rgb => Some((RgbSpace::RADIANCE, Illuminant::E)),
            Coding::Srgb => Some((RgbSpace::SRGB, Illuminant::D65)),
            _ => None,
        }
    }
}

/// The one order of codings wherever they are listed (API JSON, CSV and
/// MAT rows, tables on pages, chart legends): rgb, srgb, nstepN by N,
/// spectral — never text order, which puts nstep27 before nstep3. A name
/// that is no coding sorts after every N-step, before spectral.
pub fn coding_order(name: &str) -> (u32, u32) {
    match name {
        "rgb" => (0, 0),
        "srgb" => (1, 0),
        "spectral" => (3, 0),
        other => (
            2,
            other
                .strip_prefix("nstep")
                .and_then(|n| n.parse().ok())
                .unwrap_or(u32::MAX),
        ),
    }
}

impl Coding {
    /// This coding's place in [`coding_order`].
    pub fn order(&self) -> (u32, u32) {
        coding_order(&self.to_string())
    }
}

impl fmt::Display for Coding {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Coding::Rgb => f.write_str("rgb"),
            Coding::Srgb => f.write_str("srgb"),
            Coding::NStep(n) => write!(f, "nstep{n}"),
            Coding::Spectral => f.write_str("spectral"),
        }
    }
}

impl FromStr for Coding {
    type Err = String;
    fn from_str(s: &str) -> Result<Coding, String> {
        match s.trim().to_ascii_lowercase().as_str() {
            "rgb" => Ok(Coding::Rgb),
            "srgb" => Ok(Coding::Srgb),
            "spectral" => Ok(Coding::Spectral),
            other => {
                let n: usize = other
                    .strip_prefix("nstep")
                    .and_then(|n| n.parse().ok())
                    .ok_or_else(|| format!("unknown coding `{s}`: rgb, srgb, nstepN (1 ≤ N ≤ 81) or spectral"))?;
                Bands::new(Grid::analysis().len(), n).map_err(|e| format!("coding `{s}`: {e}"))?;
                Ok(Coding::NStep(n))
            }
        }
    }
}

/// What a coding's mean channels say about a target.
#[derive(Clone, Debug)]
pub struct Decoded {
    /// XYZ, Y in cd/m².
    pub xyz: Xyz,
    /// The spectrum on the 81-sample analysis grid in W/(sr·m²·nm); `None` for RGB.
    pub spectrum_81: Option<Vec<f64>>,
}

/// Where each coding's channels sit in the path vector, and how to convert.
#[derive(Clone, Debug)]
pub struct ChannelLayout {
    entries: Vec<(Coding, Range<usize>)>,
    /// Channels rounded up to a multiple of 8 (whole SIMD lanes); the tail is zero.
    padded: usize,
    /// Per channel, the weight that makes Σ wᵢ·cᵢ over a coding's range its Y
    /// in cd/m² (for the per-path variance of Y).
    y_weights: Vec<f32>,
    nstep_observers: Vec<Option<NStepObserver>>,
    /// The observer of every XYZ this layout converts to or from.
    observer: Observer,
}

impl ChannelLayout {
    /// The layout for these codings (duplicates removed, order kept), with
    /// the renderer's default observer [`OBSERVER`].
    pub fn new(codings: &[Coding]) -> ChannelLayout {
        ChannelLayout::with_observer(codings, OBSERVER)
    }

    /// The layout for these codings with `observer`'s matching functions for
    /// every spectrum ↔ XYZ conversion (RGB inputs, N-step and spectral XYZ).
    pub fn with_observer(codings: &[Coding], observer: Observer) -> ChannelLayout {
        let mut entries: Vec<(Coding, Range<usize>)> = Vec::new();
        let mut start = 0;
        for &c in codings {
            if entries.iter().any(|(e, _)| *e == c) {
                continue;
            }
            entries.push((c, start..start + c.channels()));
            start += c.channels();
        }
        let padded = start.div_ceil(8) * 8;
        let mut y_weights = vec![0.0f32; padded];
        let mut nstep_observers = Vec::new();
        for (c, r) in &entries {
            let w = &mut y_weights[r.clone()];
            let mut obs = None;
            match c {
                Coding::Spectral => {
                    let ybar = &Cmf::of(observer).on_grid(&Grid::one_nm())[1];
                    for (wi, y) in w.iter_mut().zip(ybar) {
                        *wi = (KM_LM_PER_W * y) as f32; // Δλ = 1 nm
                    }
                }
                Coding::NStep(n) => {
                    let o = NStepObserver::new(observer, &Grid::analysis(), *n).expect("validated N");
                    for (b, wi) in w.iter_mut().enumerate() {
                        let len = o.bands().range(b).len() as f64;
                        *wi = (KM_LM_PER_W * o.bars()[1][b] * len * o.step_nm()) as f32;
                    }
                    obs = Some(o);
                }
                Coding::Rgb | Coding::Srgb => {
                    let m = c.rgb_space().expect("rgb").0.rgb_to_xyz();
                    for (k, wi) in w.iter_mut().enumerate() {
                        *wi = m.row(1)[k] as f32;
                    }
                }
            }
            nstep_observers.push(obs);
        }
        ChannelLayout {
            entries,
            padded,
            y_weights,
            nstep_observers,
            observer,
        }
    }

    /// The observer of this layout's XYZ.
    pub fn observer(&self) -> Observer {
        self.observer
    }

    pub fn codings(&self) -> impl Iterator<Item = Coding> + '_ {
        self.entries.iter().map(|e| e.0)
    }

    pub fn entries(&self) -> &[(Coding, Range<usize>)] {
        &self.entries
    }

    /// The length of a channel vector (padded to whole SIMD lanes).
    pub fn len(&self) -> usize {
        self.padded
    }

    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    pub fn y_weights(&self) -> &[f32] {
        &self.y_weights
    }

    /// A reflectance (any grid covering 380–780 nm) as channels.
    pub fn reflectance_channels(&self, reflectance: &Spectrum) -> Result<Vec<f32>, String> {
        let on81 = reflectance.resample(&Grid::analysis()).map_err(|e| e.to_string())?;
        let mut out = vec![0.0f32; self.padded];
        for (c, r) in &self.entries {
            let dst = &mut out[r.clone()];
            match c {
                Coding::Spectral => {
                    let s = reflectance.resample(&Grid::one_nm()).map_err(|e| e.to_string())?;
                    fill(dst, s.values());
                }
                Coding::NStep(n) => fill(dst, &Bands::new(81, *n)?.average(on81.values())),
                Coding::Rgb | Coding::Srgb => {
                    let (space, white_illum) = c.rgb_space().expect("rgb");
                    let illum = illuminant(white_illum);
                    let to_rgb = space.xyz_to_rgb();
                    let perfect = Spectrum::constant(Grid::analysis(), SpectralUnit::Reflectance, 1.0)
                        .map_err(|e| e.to_string())?;
                    let xyz = xyz_relative(&on81, &illum, self.observer).map_err(|e| e.to_string())?;
                    let white = xyz_relative(&perfect, &illum, self.observer).map_err(|e| e.to_string())?;
                    let rgb = apply(&to_rgb, xyz.to_array());
                    let rgb_white = apply(&to_rgb, white.to_array());
                    let v: Vec<f64> = (0..3).map(|k| rgb[k] / rgb_white[k]).collect();
                    fill(dst, &v);
                }
            }
        }
        Ok(out)
    }

    /// Writes `rgb` into the `rgb` coding's channels of `channels` (a
    /// material's or emitter's channel vector), if the layout has that
    /// coding: colours given as RADIANCE RGB are exact in it.
    pub fn set_rgb(&self, channels: &mut [f32], rgb: [f64; 3]) {
        if let Some((_, r)) = self.entries.iter().find(|(c, _)| *c == Coding::Rgb) {
            fill(&mut channels[r.clone()], &rgb);
        }
    }

    /// A light's spectral intensity per candela (W/(sr·nm) per cd on the
    /// 1 nm grid, see [`super::scene`]) as channels.
    pub fn light_channels(&self, per_cd_1nm: &Spectrum) -> Result<Vec<f32>, String> {
        let s1 = per_cd_1nm.resample(&Grid::one_nm()).map_err(|e| e.to_string())?;
        let s81 = s1.resample(&Grid::analysis()).map_err(|e| e.to_string())?;
        let mut out = vec![0.0f32; self.padded];
        for (c, r) in &self.entries {
            let dst = &mut out[r.clone()];
            match c {
                Coding::Spectral => fill(dst, s1.values()),
                Coding::NStep(n) => fill(dst, &Bands::new(81, *n)?.average(s81.values())),
                Coding::Rgb | Coding::Srgb => {
                    // Absolute XYZ of the intensity spectrum (Y = cd per cd = 1
                    // for a normalised SPD): the same CIE sum as for radiance.
                    let as_radiance =
                        Spectrum::new(Grid::one_nm(), SpectralUnit::SpectralRadiance, s1.values().to_vec())
                            .map_err(|e| e.to_string())?;
                    let xyz = xyz_from_radiance(&as_radiance, self.observer).map_err(|e| e.to_string())?;
                    let space = c.rgb_space().expect("rgb").0;
                    fill(dst, &apply(&space.xyz_to_rgb(), xyz.to_array()));
                }
            }
        }
        Ok(out)
    }

    /// XYZ and the 81-grid spectrum of entry `index` from its mean channels
    /// (spectral radiance, or RGB in the coding's absolute units).
    pub fn decode(&self, index: usize, channels: &[f64]) -> Decoded {
        let (coding, range) = &self.entries[index];
        let v = &channels[range.clone()];
        match coding {
            Coding::Spectral => {
                let s = Spectrum::new(Grid::one_nm(), SpectralUnit::SpectralRadiance, v.to_vec())
                    .expect("finite radiance on the 1 nm grid");
                let xyz = xyz_from_radiance(&s, self.observer).expect("spectral radiance");
                Decoded {
                    xyz,
                    spectrum_81: Some(v.iter().step_by(5).copied().collect()),
                }
            }
            Coding::NStep(_) => {
                let o = self.nstep_observers[index].as_ref().expect("nstep observer");
                Decoded {
                    xyz: o.xyz_from_radiance(v),
                    spectrum_81: Some(o.bands().reconstruct(v)),
                }
            }
            Coding::Rgb | Coding::Srgb => {
                let m = coding.rgb_space().expect("rgb").0.rgb_to_xyz();
                Decoded {
                    xyz: Xyz::from_array(apply(&m, [v[0], v[1], v[2]])),
                    spectrum_81: None,
                }
            }
        }
    }
}

fn fill(dst: &mut [f32], src: &[f64]) {
    for (d, s) in dst.iter_mut().zip(src) {
        *d = *s as f32;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layout_packs_the_seven_codings_into_527_channels() {
        let l = ChannelLayout::new(&Coding::ALL);
        let n: usize = l.entries().iter().map(|e| e.1.len()).sum();
        assert_eq!(n, 3 + 3 + 3 + 9 + 27 + 81 + 401);
        assert_eq!(l.len() % 8, 0);
        assert_eq!("nstep27".parse::<Coding>().unwrap(), Coding::NStep(27));
        assert!("nstep82".parse::<Coding>().is_err() && "cmyk".parse::<Coding>().is_err());
    }

    /// A flat reflectance is (ρ, ρ, ρ) in both RGB codings, by construction.
    #[test]
    fn flat_reflectance_is_grey_in_rgb() {
        let l = ChannelLayout::new(&[Coding::Rgb, Coding::Srgb]);
        let r = Spectrum::constant(Grid::analysis(), SpectralUnit::Reflectance, 0.4).unwrap();
        let c = l.reflectance_channels(&r).unwrap();
        for v in &c[0..6] {
            assert!((v - 0.4).abs() < 1e-6, "{c:?}");
        }
    }

    /// Decoding a light's own channels gives the light's XYZ exactly in the
    /// codings that reproduce it (spectral, RGB), and in N-step the XYZ of its
    /// band means with the approximated matching functions (the definition).
    #[test]
    fn decoding_a_light_gives_its_xyz() {
        let l = ChannelLayout::new(&Coding::ALL);
        let spd = illuminant(Illuminant::D65).resample(&Grid::one_nm()).unwrap();
        let s = Spectrum::new(Grid::one_nm(), SpectralUnit::SpectralRadiance, spd.values().to_vec()).unwrap();
        let s81 = s.resample(&Grid::analysis()).unwrap();
        let exact = xyz_from_radiance(&s, OBSERVER).unwrap();
        let c: Vec<f64> = l.light_channels(&s).unwrap().iter().map(|&v| v as f64).collect();
        for (i, (coding, _)) in l.entries().iter().enumerate() {
            let got = l.decode(i, &c).xyz;
            let want = match coding {
                Coding::NStep(n) => NStepObserver::new(OBSERVER, &Grid::analysis(), *n)
                    .unwrap()
                    .xyz_from_radiance(&lightbooth_science::nstep::band_average(&s81, *n).unwrap()),
                _ => exact,
            };
            // f32 channels: 1e-6 relative per value.
            for (g, w) in got.to_array().iter().zip(want.to_array()) {
                assert!((g / w - 1.0).abs() < 1e-5, "{coding}: {got:?} vs {want:?}");
            }
        }
    }
}
