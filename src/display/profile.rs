//! The display profile and its two models: forward (frame-buffer values →
//! spectral radiance → XYZ) and inverse (XYZ → the display's linear RGB →
//! frame-buffer values at a bit depth).
//!
//! Transfer function, per channel: the normalised output
//! `t(v) = (L(v) − L_black) / (L_max − L_black)` of the drive `v ∈ [0, 1]`,
//! modelled as a pure power `t(v) = v^γ` — that is
//! `L = black + (max − black) · v^γ`, the black level carried separately by
//! [`DisplayProfile::black`] (Psychtoolbox's "simple power" with a measured
//! offset, not a gain-offset-gamma model). The measured table is kept beside
//! the fit and can be used instead ([`TransferModel::Table`]: linear
//! interpolation between the measured levels).

use glam::{DMat3, DVec3};
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::DisplayError;
use crate::colorimetry::{ciede2000, xyz_from_radiance, Lab, Observer, Xyz};
use crate::spectrum::{Grid, SpectralUnit, Spectrum};

/// The largest RMS residual of a channel's `v^γ` fit a usable profile may
/// have (normalised output; a good CRT or LCD fits within 0.01).
pub const MAX_TRANSFER_RMS_RESIDUAL: f64 = 0.03;
/// The largest CIEDE2000 between a validation colour measured and predicted
/// (and of the additivity check) a usable profile may have: a good
/// calibration predicts within 1.
pub const MAX_VALIDATION_DE00: f64 = 3.0;

/// Whether `value` is at most `limit`; a NaN is not (it fails the check).
fn within(value: f64, limit: f64) -> bool {
    value <= limit
}

/// One channel's transfer: the fitted exponent and the table it was fitted to.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct ChannelTransfer {
    /// γ of `t(v) = v^γ`, least squares over the measured levels.
    pub gamma: f64,
    /// Drive values measured, 0–1 (with 0 and 1).
    pub levels: Vec<f64>,
    /// Normalised output t at each level (0 at drive 0, 1 at full drive).
    pub measured: Vec<f64>,
    /// RMS of `measured − levels^γ`.
    pub rms_residual: f64,
}

/// Which transfer the models use.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TransferModel {
    /// The fitted power `v^γ` (smooth; the default).
    #[default]
    Gamma,
    /// The measured table, linearly interpolated.
    Table,
}

impl ChannelTransfer {
    /// Normalised output of drive `v` (clamped to 0–1).
    pub fn output(&self, v: f64, model: TransferModel) -> f64 {
        let v = v.clamp(0.0, 1.0);
        match model {
            TransferModel::Gamma => v.powf(self.gamma),
            TransferModel::Table => interpolate(&self.levels, &self.measured, v),
        }
    }

    /// The drive that gives normalised output `t` (clamped to 0–1).
    pub fn drive(&self, t: f64, model: TransferModel) -> f64 {
        let t = t.clamp(0.0, 1.0);
        match model {
            TransferModel::Gamma => t.powf(1.0 / self.gamma),
            // The table's inverse: monotone by construction of the fit.
            TransferModel::Table => interpolate(&self.measured, &self.levels, t),
        }
    }
}

/// Linear interpolation of `ys` over increasing `xs`, clamped at the ends.
fn interpolate(xs: &[f64], ys: &[f64], x: f64) -> f64 {
    if xs.is_empty() {
        return 0.0;
    }
    if x <= xs[0] {
        return ys[0];
    }
    for i in 1..xs.len() {
        if x <= xs[i] {
            let span = xs[i] - xs[i - 1];
            let f = if span > 0.0 { (x - xs[i - 1]) / span } else { 1.0 };
            return ys[i - 1] + f * (ys[i] - ys[i - 1]);
        }
    }
    ys[ys.len() - 1]
}

/// White against the sum of the three primaries: the additivity check.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct Additivity {
    /// XYZ of the measured white (all channels at full drive), cd/m².
    pub white_xyz: [f64; 3],
    /// XYZ predicted by the model: black + R + G + B, cd/m².
    pub sum_xyz: [f64; 3],
    /// CIEDE2000 between them, relative to the measured white.
    pub delta_e00: f64,
    /// The measured white's spectral radiance, W/(sr·m²·nm), on the profile's grid.
    pub white: Vec<f64>,
}

/// A validation colour: measured against what the profile predicts.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct Validation {
    /// The drive shown, 0–1 per channel.
    pub drive: [f64; 3],
    pub measured_xyz: [f64; 3],
    pub predicted_xyz: [f64; 3],
    /// CIEDE2000, relative to the profile's white.
    pub delta_e00: f64,
    pub measurement_id: Option<i64>,
}

/// A display as measured: everything the forward and inverse models need,
/// with where it came from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct DisplayProfile {
    /// The observer of every XYZ in the profile and its models.
    #[schema(value_type = String)]
    pub observer: Observer,
    /// The instrument's grid, nm.
    pub wavelength_nm: Vec<f64>,
    /// Spectral radiance at drive (0, 0, 0), W/(sr·m²·nm).
    pub black: Vec<f64>,
    /// Each primary's increment over black at full drive, W/(sr·m²·nm): red, green, blue.
    pub primaries: [Vec<f64>; 3],
    /// Transfer of red, green, blue.
    pub transfer: [ChannelTransfer; 3],
    pub additivity: Additivity,
    /// Validation colours (grey ramp and mixtures), when measured.
    #[serde(default)]
    pub validation: Vec<Validation>,
    /// The measurements the profile was fitted to (provenance).
    pub measurement_ids: Vec<i64>,
}

/// Frame-buffer values at a bit depth.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameBuffer {
    pub bits: u32,
}

impl FrameBuffer {
    pub fn new(bits: u32) -> Result<FrameBuffer, DisplayError> {
        match bits {
            8 | 10 | 12 | 16 => Ok(FrameBuffer { bits }),
            _ => Err(DisplayError::Bits(bits)),
        }
    }

    /// The largest code, 2^bits − 1.
    pub fn max_code(self) -> u32 {
        (1u32 << self.bits) - 1
    }

    /// The nearest code of a drive 0–1 (clamped).
    pub fn quantise(self, drive: f64) -> u32 {
        (drive.clamp(0.0, 1.0) * f64::from(self.max_code())).round() as u32
    }

    /// The drive of a code.
    pub fn drive(self, code: u32) -> f64 {
        f64::from(code.min(self.max_code())) / f64::from(self.max_code())
    }
}

impl DisplayProfile {
    /// The instrument grid as a [`Grid`].
    pub fn grid(&self) -> Result<Grid, DisplayError> {
        Ok(Grid::from_wavelengths(self.wavelength_nm.clone())?)
    }

    /// What makes this profile unfit for experiments, one line each: a
    /// channel's transfer fitted with an RMS residual over
    /// [`MAX_TRANSFER_RMS_RESIDUAL`], or a validation colour (or the
    /// additivity check) off by a CIEDE2000 over [`MAX_VALIDATION_DE00`]
    /// (a patch measured while the instrument saw something else, a display
    /// that drifted or is not additive). Empty: it passed.
    pub fn failures(&self) -> Vec<String> {
        let mut failures = Vec::new();
        for (name, t) in ["red", "green", "blue"].iter().zip(&self.transfer) {
            if !within(t.rms_residual, MAX_TRANSFER_RMS_RESIDUAL) {
                failures.push(format!(
                    "{name} transfer: RMS residual {:.3} of the fit (γ {:.3}) is over the limit {MAX_TRANSFER_RMS_RESIDUAL}",
                    t.rms_residual, t.gamma
                ));
            }
        }
        if !within(self.additivity.delta_e00, MAX_VALIDATION_DE00) {
            failures.push(format!(
                "additivity: white differs from black + red + green + blue by ΔE00 {:.1}, over the limit {MAX_VALIDATION_DE00}",
                self.additivity.delta_e00
            ));
        }
        for v in &self.validation {
            if !within(v.delta_e00, MAX_VALIDATION_DE00) {
                failures.push(format!(
                    "validation drive ({:.2}, {:.2}, {:.2}){}: ΔE00 {:.1} between measured and predicted, over the limit {MAX_VALIDATION_DE00}",
                    v.drive[0],
                    v.drive[1],
                    v.drive[2],
                    v.measurement_id.map(|id| format!(" (measurement {id})")).unwrap_or_default(),
                    v.delta_e00
                ));
            }
        }
        failures
    }

    /// Checks the shapes and values of a profile read from outside (a file, the store).
    pub fn validate(&self) -> Result<(), DisplayError> {
        let n = self.wavelength_nm.len();
        let bad = |what: String| Err(DisplayError::Profile(what));
        if n < 2 {
            return bad(format!("`wavelength_nm` has {n} values; a spectrum needs at least 2"));
        }
        if self.black.len() != n {
            return bad(format!("`black` has {} values for {n} wavelengths", self.black.len()));
        }
        for (c, p) in ["red", "green", "blue"].iter().zip(&self.primaries) {
            if p.len() != n {
                return bad(format!("`primaries` {c} has {} values for {n} wavelengths", p.len()));
            }
            if p.iter().any(|v| !v.is_finite()) {
                return bad(format!("`primaries` {c} holds a non-finite value"));
            }
        }
        for (c, t) in ["red", "green", "blue"].iter().zip(&self.transfer) {
            if !(t.gamma.is_finite() && t.gamma > 0.0) {
                return bad(format!("`transfer` {c}: gamma {} is not a positive number", t.gamma));
            }
            if t.levels.len() != t.measured.len() {
                return bad(format!(
                    "`transfer` {c}: {} levels but {} measured values",
                    t.levels.len(),
                    t.measured.len()
                ));
            }
        }
        if self.additivity.white.len() != n {
            return bad(format!(
                "`additivity.white` has {} values for {n} wavelengths",
                self.additivity.white.len()
            ));
        }
        self.grid()?;
        self.primary_matrix()?;
        Ok(())
    }

    fn xyz_of(&self, values: &[f64]) -> Result<Xyz, DisplayError> {
        let s = Spectrum::new(self.grid()?, SpectralUnit::SpectralRadiance, values.to_vec())?;
        Ok(xyz_from_radiance(&s, self.observer)?)
    }

    /// XYZ of the black level, cd/m².
    pub fn black_xyz(&self) -> Result<Xyz, DisplayError> {
        self.xyz_of(&self.black)
    }

    /// XYZ of each primary's increment at full drive (columns red, green, blue).
    pub fn primary_matrix(&self) -> Result<DMat3, DisplayError> {
        let cols: Vec<DVec3> = self
            .primaries
            .iter()
            .map(|p| self.xyz_of(p).map(|x| DVec3::from_array(x.to_array())))
            .collect::<Result<_, _>>()?;
        let m = DMat3::from_cols(cols[0], cols[1], cols[2]);
        let det = m.determinant();
        if !(det.is_finite() && det.abs() > 1e-12) {
            return Err(DisplayError::Profile(
                "the primaries' XYZ are linearly dependent (a missing or duplicated primary)".into(),
            ));
        }
        Ok(m)
    }

    /// XYZ of the display's white (all channels at full drive, with black), cd/m².
    pub fn white_xyz(&self) -> Result<Xyz, DisplayError> {
        self.xyz_of_linear([1.0; 3])
    }

    /// Chromaticity x, y of each primary's increment.
    pub fn primary_chromaticities(&self) -> Result<[[f64; 2]; 3], DisplayError> {
        let mut out = [[0.0; 2]; 3];
        for (o, p) in out.iter_mut().zip(&self.primaries) {
            let c = self.xyz_of(p)?.chromaticity();
            *o = [c.x, c.y];
        }
        Ok(out)
    }

    /// Forward: the spectral radiance shown for drives 0–1 per channel.
    pub fn spectrum(&self, drive: [f64; 3], model: TransferModel) -> Vec<f64> {
        let t: Vec<f64> = (0..3).map(|c| self.transfer[c].output(drive[c], model)).collect();
        (0..self.black.len())
            .map(|i| self.black[i] + (0..3).map(|c| t[c] * self.primaries[c][i]).sum::<f64>())
            .collect()
    }

    /// Forward: XYZ for linear RGB (normalised outputs t, not drives), cd/m².
    pub fn xyz_of_linear(&self, linear: [f64; 3]) -> Result<Xyz, DisplayError> {
        let m = self.primary_matrix()?;
        let v = m * DVec3::from_array(linear) + DVec3::from_array(self.black_xyz()?.to_array());
        Ok(Xyz::from_array(v.to_array()))
    }

    /// Forward: XYZ for drives 0–1, cd/m².
    pub fn xyz_of_drive(&self, drive: [f64; 3], model: TransferModel) -> Result<Xyz, DisplayError> {
        let linear = [0, 1, 2].map(|c| self.transfer[c].output(drive[c], model));
        self.xyz_of_linear(linear)
    }

    /// Inverse: the linear RGB (normalised outputs) that shows `xyz`; values
    /// outside 0–1 are out of the display's gamut.
    pub fn linear_of_xyz(&self, xyz: Xyz) -> Result<[f64; 3], DisplayError> {
        let m = self.primary_matrix()?;
        let v = DVec3::from_array(xyz.to_array()) - DVec3::from_array(self.black_xyz()?.to_array());
        Ok((m.inverse() * v).to_array())
    }

    /// Inverse: the frame-buffer codes of in-gamut linear RGB (clamped to 0–1).
    pub fn codes_of_linear(&self, linear: [f64; 3], fb: FrameBuffer, model: TransferModel) -> [u32; 3] {
        [0, 1, 2].map(|c| fb.quantise(self.transfer[c].drive(linear[c], model)))
    }

    /// CIEDE2000 between two XYZ, relative to this display's white.
    pub fn delta_e00(&self, a: Xyz, b: Xyz) -> Result<f64, DisplayError> {
        let white = self.white_xyz()?;
        Ok(ciede2000(Lab::from_xyz(a, white), Lab::from_xyz(b, white)))
    }
}

/// Precomputed matrices for converting many pixels (no per-pixel spectra).
#[derive(Clone, Debug)]
pub struct Converter {
    to_xyz: DMat3,
    to_linear: DMat3,
    black: DVec3,
    white: Xyz,
}

impl Converter {
    pub fn new(profile: &DisplayProfile) -> Result<Converter, DisplayError> {
        let to_xyz = profile.primary_matrix()?;
        Ok(Converter {
            to_xyz,
            to_linear: to_xyz.inverse(),
            black: DVec3::from_array(profile.black_xyz()?.to_array()),
            white: profile.white_xyz()?,
        })
    }

    pub fn linear(&self, xyz: [f64; 3]) -> [f64; 3] {
        (self.to_linear * (DVec3::from_array(xyz) - self.black)).to_array()
    }

    pub fn xyz(&self, linear: [f64; 3]) -> [f64; 3] {
        (self.to_xyz * DVec3::from_array(linear) + self.black).to_array()
    }

    pub fn white(&self) -> Xyz {
        self.white
    }
}
