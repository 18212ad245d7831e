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
//!
//! What the display's light was measured as depends on the instrument
//! ([`Emission`]): a spectroradiometer gives the black level and each
//! primary as spectra (XYZ then computed in the profile's observer); a
//! colorimeter (ColorCAL MkII, CS-100A) gives them as XYZ, in the observer of
//! its filters, which the profile then has; a luminance meter (LS-100) gives
//! their luminance only: such a profile has each channel's γ and nothing of
//! the primaries' chromaticities, so it cannot turn a colour into codes
//! ([`DisplayProfile::primary_matrix`] refuses, saying why).

use glam::{DMat3, DVec3};
use serde::{Deserialize, Serialize};

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
/// The largest relative luminance difference between a validation colour
/// measured and predicted (and of the additivity check) a luminance-only
/// profile may have: a good calibration predicts within 1 %.
pub const MAX_VALIDATION_LUMINANCE: f64 = 0.05;

/// Whether `value` is at most `limit`; a NaN is not (it fails the check).
fn within(value: f64, limit: f64) -> bool {
    value <= limit
}

/// One channel's transfer: the fitted exponent and the table it was fitted to.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
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
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Additivity {
    /// XYZ of the measured white (all channels at full drive), cd/m².
    pub white_xyz: [f64; 3],
    /// XYZ predicted by the model: black + R + G + B, cd/m².
    pub sum_xyz: [f64; 3],
    /// CIEDE2000 between them, relative to the measured white.
    pub delta_e00: f64,
    /// The measured white's spectral radiance, W/(sr·m²·nm), on the
    /// profile's grid (empty when a colorimeter measured it).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub white: Vec<f64>,
}

/// A validation colour: measured against what the profile predicts.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Validation {
    /// The drive shown, 0–1 per channel.
    pub drive: [f64; 3],
    pub measured_xyz: [f64; 3],
    pub predicted_xyz: [f64; 3],
    /// CIEDE2000, relative to the profile's white.
    pub delta_e00: f64,
    pub measurement_id: Option<i64>,
}

/// The display's light as the calibration's instrument measured it.
///
/// Serialised without a tag: each kind has its own field names
/// (`wavelength_nm`, `black`, `primaries`; `black_xyz`, `primaries_xyz`;
/// `black_cd_m2`, `primaries_cd_m2`) beside the profile's other fields.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(untagged)]
pub enum Emission {
    /// A spectroradiometer's: spectra on its grid.
    Spectral {
        /// The instrument's grid, nm.
        wavelength_nm: Vec<f64>,
        /// Spectral radiance at drive (0, 0, 0), W/(sr·m²·nm).
        black: Vec<f64>,
        /// Each primary's increment over black at full drive, W/(sr·m²·nm): red, green, blue.
        primaries: [Vec<f64>; 3],
    },
    /// A colorimeter's: XYZ (cd/m²) in the profile's observer.
    Tristimulus {
        /// XYZ at drive (0, 0, 0).
        black_xyz: [f64; 3],
        /// Each primary's increment over black at full drive: red, green, blue.
        primaries_xyz: [[f64; 3]; 3],
    },
    /// A luminance meter's: luminance only (γ per channel, no chromaticity).
    Luminance {
        /// Luminance at drive (0, 0, 0), cd/m².
        black_cd_m2: f64,
        /// Each primary's luminance increment over black at full drive, cd/m².
        primaries_cd_m2: [f64; 3],
    },
}

impl Emission {
    /// What measured it, in words: `spectra`, `XYZ`, `luminance only`.
    pub fn measured_as(&self) -> &'static str {
        match self {
            Emission::Spectral { .. } => "spectra",
            Emission::Tristimulus { .. } => "XYZ",
            Emission::Luminance { .. } => "luminance only",
        }
    }
}

/// A luminance meter's additivity check: the white's luminance against
/// black + R + G + B.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct LuminanceAdditivity {
    /// Luminance of the measured white (all channels at full drive), cd/m².
    pub white_cd_m2: f64,
    /// Black + the three primaries' increments, cd/m².
    pub sum_cd_m2: f64,
    /// (sum − white) / white.
    pub relative_difference: f64,
}

/// A validation colour measured by a luminance meter: its luminance against
/// the profile's prediction.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct LuminanceValidation {
    /// The drive shown, 0–1 per channel.
    pub drive: [f64; 3],
    pub measured_cd_m2: f64,
    pub predicted_cd_m2: f64,
    /// (predicted − measured) / measured.
    pub relative_difference: f64,
    pub measurement_id: Option<i64>,
}

/// The checks of a profile: in colour (CIEDE2000) where the instrument
/// measured colour, in luminance where it measured luminance only.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(untagged)]
pub enum Checks {
    Colour {
        additivity: Additivity,
        /// Validation colours (grey ramp and mixtures), when measured.
        #[serde(default)]
        validation: Vec<Validation>,
    },
    Luminance {
        luminance_additivity: LuminanceAdditivity,
        /// Validation colours, in luminance.
        #[serde(default)]
        luminance_validation: Vec<LuminanceValidation>,
    },
}

/// A display as measured: everything the forward and inverse models need,
/// with where it came from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct DisplayProfile {
    /// The observer of every XYZ in the profile and its models.
    #[cfg_attr(feature = "openapi", schema(value_type = String))]
    pub observer: Observer,
    /// The black level and the primaries, as the instrument measured them.
    #[serde(flatten)]
    pub emission: Emission,
    /// Transfer of red, green, blue.
    pub transfer: [ChannelTransfer; 3],
    /// Additivity and validation, in colour or in luminance.
    #[serde(flatten)]
    pub checks: Checks,
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
    /// Reads a profile from its JSON; a missing black level and primaries
    /// (or checks) are named by the fields each kind of profile has, not by
    /// serde's "no variant matched".
    pub fn from_json(value: serde_json::Value) -> Result<DisplayProfile, String> {
        serde_json::from_value(value).map_err(|e| {
            let e = e.to_string();
            if e.contains("untagged enum Emission") {
                "the black level and the primaries are missing: give `wavelength_nm`, `black` and `primaries` \
                 (spectra), `black_xyz` and `primaries_xyz` (XYZ), or `black_cd_m2` and `primaries_cd_m2` (luminance)"
                    .into()
            } else if e.contains("untagged enum Checks") {
                "the checks are missing: give `additivity` (and `validation`) or `luminance_additivity` (and \
                 `luminance_validation`)"
                    .into()
            } else {
                e
            }
        })
    }

    /// The instrument grid as a [`Grid`]; a profile measured as XYZ or
    /// luminance has none.
    pub fn grid(&self) -> Result<Grid, DisplayError> {
        match &self.emission {
            Emission::Spectral { wavelength_nm, .. } => Ok(Grid::from_wavelengths(wavelength_nm.clone())?),
            _ => Err(self.no_spectra()),
        }
    }

    /// Why a profile measured as XYZ or luminance has no spectra.
    fn no_spectra(&self) -> DisplayError {
        DisplayError::Profile(format!(
            "the profile was measured as {}: it has no spectra",
            self.emission.measured_as()
        ))
    }

    /// The additivity check in colour (none for a luminance meter's profile).
    pub fn additivity(&self) -> Option<&Additivity> {
        match &self.checks {
            Checks::Colour { additivity, .. } => Some(additivity),
            Checks::Luminance { .. } => None,
        }
    }

    /// The validation colours checked in colour (none for a luminance meter's profile).
    pub fn validation(&self) -> &[Validation] {
        match &self.checks {
            Checks::Colour { validation, .. } => validation,
            Checks::Luminance { .. } => &[],
        }
    }

    /// What makes this profile unfit for experiments, one line each: a
    /// channel's transfer fitted with an RMS residual over
    /// [`MAX_TRANSFER_RMS_RESIDUAL`], or a validation colour (or the
    /// additivity check) off by a CIEDE2000 over [`MAX_VALIDATION_DE00`]
    /// (by a relative luminance over [`MAX_VALIDATION_LUMINANCE`] for a
    /// luminance meter's profile): a patch measured while the instrument
    /// saw something else, a display that drifted or is not additive.
    /// Empty: it passed.
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
        let drive = |d: [f64; 3], id: Option<i64>| {
            format!(
                "validation drive ({:.2}, {:.2}, {:.2}){}",
                d[0],
                d[1],
                d[2],
                id.map(|id| format!(" (measurement {id})")).unwrap_or_default()
            )
        };
        match &self.checks {
            Checks::Colour { additivity, validation } => {
                if !within(additivity.delta_e00, MAX_VALIDATION_DE00) {
                    failures.push(format!(
                        "additivity: white differs from black + red + green + blue by ΔE00 {:.1}, over the limit {MAX_VALIDATION_DE00}",
                        additivity.delta_e00
                    ));
                }
                for v in validation {
                    if !within(v.delta_e00, MAX_VALIDATION_DE00) {
                        failures.push(format!(
                            "{}: ΔE00 {:.1} between measured and predicted, over the limit {MAX_VALIDATION_DE00}",
                            drive(v.drive, v.measurement_id),
                            v.delta_e00
                        ));
                    }
                }
            }
            Checks::Luminance {
                luminance_additivity: a,
                luminance_validation,
            } => {
                if !within(a.relative_difference.abs(), MAX_VALIDATION_LUMINANCE) {
                    failures.push(format!(
                        "additivity: white's luminance differs from black + red + green + blue by {:.1} %, over the limit {} %",
                        a.relative_difference * 100.0,
                        MAX_VALIDATION_LUMINANCE * 100.0
                    ));
                }
                for v in luminance_validation {
                    if !within(v.relative_difference.abs(), MAX_VALIDATION_LUMINANCE) {
                        failures.push(format!(
                            "{}: luminance {:.1} % off the prediction, over the limit {} %",
                            drive(v.drive, v.measurement_id),
                            v.relative_difference * 100.0,
                            MAX_VALIDATION_LUMINANCE * 100.0
                        ));
                    }
                }
            }
        }
        failures
    }

    /// Checks the shapes and values of a profile read from outside (a file, the store).
    pub fn validate(&self) -> Result<(), DisplayError> {
        let bad = |what: String| Err(DisplayError::Profile(what));
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
        match &self.emission {
            Emission::Spectral {
                wavelength_nm,
                black,
                primaries,
            } => {
                let n = wavelength_nm.len();
                if n < 2 {
                    return bad(format!("`wavelength_nm` has {n} values; a spectrum needs at least 2"));
                }
                if black.len() != n {
                    return bad(format!("`black` has {} values for {n} wavelengths", black.len()));
                }
                for (c, p) in ["red", "green", "blue"].iter().zip(primaries) {
                    if p.len() != n {
                        return bad(format!("`primaries` {c} has {} values for {n} wavelengths", p.len()));
                    }
                    if p.iter().any(|v| !v.is_finite()) {
                        return bad(format!("`primaries` {c} holds a non-finite value"));
                    }
                }
                if let Checks::Colour { additivity, .. } = &self.checks {
                    if additivity.white.len() != n {
                        return bad(format!(
                            "`additivity.white` has {} values for {n} wavelengths",
                            additivity.white.len()
                        ));
                    }
                }
                self.grid()?;
            }
            Emission::Tristimulus {
                black_xyz,
                primaries_xyz,
            } => {
                if black_xyz
                    .iter()
                    .chain(primaries_xyz.iter().flatten())
                    .any(|v| !v.is_finite())
                {
                    return bad("`black_xyz` or `primaries_xyz` holds a non-finite value".into());
                }
            }
            Emission::Luminance {
                black_cd_m2,
                primaries_cd_m2,
            } => {
                if !black_cd_m2.is_finite() || primaries_cd_m2.iter().any(|v| !(v.is_finite() && *v > 0.0)) {
                    return bad(
                        "`black_cd_m2` or `primaries_cd_m2` is not a finite luminance (each primary above 0)".into(),
                    );
                }
                return Ok(());
            }
        }
        self.primary_matrix()?;
        Ok(())
    }

    fn xyz_of(&self, values: &[f64]) -> Result<Xyz, DisplayError> {
        let s = Spectrum::new(self.grid()?, SpectralUnit::SpectralRadiance, values.to_vec())?;
        Ok(xyz_from_radiance(&s, self.observer)?)
    }

    /// Why a luminance meter's profile cannot do what needs colour.
    fn no_colour(&self) -> DisplayError {
        DisplayError::Profile(
            "the profile was calibrated with a luminance meter: it has each channel's γ but not the \
             primaries' colour, so it cannot turn a colour into codes; calibrate with a colorimeter \
             (ColorCAL MkII, CS-100A) or a spectroradiometer"
                .into(),
        )
    }

    /// XYZ of the black level, cd/m².
    pub fn black_xyz(&self) -> Result<Xyz, DisplayError> {
        match &self.emission {
            Emission::Spectral { black, .. } => self.xyz_of(black),
            Emission::Tristimulus { black_xyz, .. } => Ok(Xyz::from_array(*black_xyz)),
            Emission::Luminance { .. } => Err(self.no_colour()),
        }
    }

    /// Luminance of the black level and each primary's increment at full
    /// drive (red, green, blue), cd/m²: what every kind of profile has.
    pub fn luminances(&self) -> Result<(f64, [f64; 3]), DisplayError> {
        match &self.emission {
            Emission::Luminance {
                black_cd_m2,
                primaries_cd_m2,
            } => Ok((*black_cd_m2, *primaries_cd_m2)),
            _ => {
                let m = self.primary_matrix()?;
                Ok((self.black_xyz()?.y, [m.x_axis.y, m.y_axis.y, m.z_axis.y]))
            }
        }
    }

    /// Forward, in luminance: cd/m² shown for drives 0–1 (every kind of profile).
    pub fn luminance_of_drive(&self, drive: [f64; 3], model: TransferModel) -> Result<f64, DisplayError> {
        let (black, p) = self.luminances()?;
        Ok(black
            + (0..3)
                .map(|c| self.transfer[c].output(drive[c], model) * p[c])
                .sum::<f64>())
    }

    /// XYZ of each primary's increment at full drive (columns red, green, blue).
    pub fn primary_matrix(&self) -> Result<DMat3, DisplayError> {
        let cols: Vec<DVec3> = match &self.emission {
            Emission::Spectral { primaries, .. } => primaries
                .iter()
                .map(|p| self.xyz_of(p).map(|x| DVec3::from_array(x.to_array())))
                .collect::<Result<_, _>>()?,
            Emission::Tristimulus { primaries_xyz, .. } => {
                primaries_xyz.iter().map(|p| DVec3::from_array(*p)).collect()
            }
            Emission::Luminance { .. } => return Err(self.no_colour()),
        };
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
        let m = self.primary_matrix()?;
        let mut out = [[0.0; 2]; 3];
        for (c, o) in out.iter_mut().enumerate() {
            let xy = Xyz::from_array(m.col(c).to_array()).chromaticity();
            *o = [xy.x, xy.y];
        }
        Ok(out)
    }

    /// Forward: the spectral radiance shown for drives 0–1 per channel
    /// (a profile measured as XYZ or luminance has none).
    pub fn spectrum(&self, drive: [f64; 3], model: TransferModel) -> Result<Vec<f64>, DisplayError> {
        let Emission::Spectral { black, primaries, .. } = &self.emission else {
            return Err(self.no_spectra());
        };
        let t: Vec<f64> = (0..3).map(|c| self.transfer[c].output(drive[c], model)).collect();
        Ok((0..black.len())
            .map(|i| black[i] + (0..3).map(|c| t[c] * primaries[c][i]).sum::<f64>())
            .collect())
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
