//! Calibrations computed from booth measurements: a material's spectral
//! reflectance measured against a white standard ([`reflectance`]), and the
//! lamp's spectral power distribution from the white standard alone
//! ([`illuminant`]), as the study took its materials and illuminants from its
//! own booth. Pure functions of the stored samples and the standard's
//! calibration ([`standard`]): no I/O, no database (`lightbooth::lab::records::calibration`
//! reads the measurements from the store and stores the results).
//!
//! Uncertainties are standard uncertainties (k = 1), propagated to first
//! order from the standard errors of the measurements' means (the sample
//! standard deviation of the good samples over √n) and the standard's
//! calibration uncertainty, taken as independent.

pub mod illuminant;

pub mod reflectance;
pub mod standard;

use crate::spectrum::table::TableError;

/// A measurement reduced to what the calibrations need: per wavelength, the
/// mean of its good samples and the standard error of that mean.
#[derive(Clone, Debug, PartialEq)]
pub struct MeanSpectrum {
    /// The instrument's grid, nm.
    pub wavelength_nm: Vec<f64>,
    /// Mean spectral radiance of the good samples, W/(sr·m²·nm).
    pub mean: Vec<f64>,
    /// Standard error of `mean`: the samples' SD (n − 1) over √n.
    pub standard_error: Vec<f64>,
    /// Good samples averaged.
    pub samples: usize,
}

/// Fewest good samples from which a spread, hence an uncertainty, exists.
pub const MIN_SAMPLES: usize = 2;

impl MeanSpectrum {
    /// The mean and its standard error from the raw samples (each on
    /// `wavelength_nm`). `what` names the measurement in errors.
    pub fn from_samples(
        what: &str,
        wavelength_nm: &[f64],
        samples: &[&[f64]],
    ) -> Result<MeanSpectrum, CalibrationError> {
        if samples.len() < MIN_SAMPLES {
            return Err(CalibrationError::TooFewSamples {
                what: what.to_string(),
                samples: samples.len(),
            });
        }
        if let Some(bad) = samples.iter().position(|s| s.len() != wavelength_nm.len()) {
            return Err(CalibrationError::Inconsistent(format!(
                "{what}: sample {bad} has {} values for a grid of {}",
                samples[bad].len(),
                wavelength_nm.len()
            )));
        }
        let n = samples.len() as f64;
        let mut mean = Vec::with_capacity(wavelength_nm.len());
        let mut standard_error = Vec::with_capacity(wavelength_nm.len());
        for i in 0..wavelength_nm.len() {
            let m = samples.iter().map(|s| s[i]).sum::<f64>() / n;
            let var = samples.iter().map(|s| (s[i] - m).powi(2)).sum::<f64>() / (n - 1.0);
            mean.push(m);
            standard_error.push((var / n).sqrt());
        }
        Ok(MeanSpectrum {
            wavelength_nm: wavelength_nm.to_vec(),
            mean,
            standard_error,
            samples: samples.len(),
        })
    }
}

/// The white standard's radiance must exceed this many standard errors for
/// a ratio to it to mean anything.
pub const DARK_STANDARD_ERRORS: f64 = 3.0;

/// Wavelengths where the white standard's mean radiance is not clearly
/// above zero (≤ 0, or below [`DARK_STANDARD_ERRORS`] standard errors).
pub fn dark_wavelengths(white: &MeanSpectrum) -> Vec<f64> {
    white
        .wavelength_nm
        .iter()
        .zip(white.mean.iter().zip(&white.standard_error))
        .filter(|(_, (m, se))| **m <= 0.0 || **m < DARK_STANDARD_ERRORS * **se)
        .map(|(nm, _)| *nm)
        .collect()
}

/// What can make a calibration impossible; each names what to do.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CalibrationError {
    #[error(
        "{what} has {samples} good sample(s): at least {MIN_SAMPLES} are needed to estimate its uncertainty; \
         measure it again with more samples"
    )]
    TooFewSamples { what: String, samples: usize },
    #[error("the sample and the white standard were measured on different grids ({sample} vs {standard})")]
    GridMismatch { sample: String, standard: String },
    #[error(
        "the white standard's radiance is not above zero by {DARK_STANDARD_ERRORS} standard errors at {}: \
         a ratio to it is undefined there; measure with more light (or a longer integration)",
        nm_list(.nm)
    )]
    DarkStandard { nm: Vec<f64> },
    #[error("the standard's reflectance {0}")]
    Standard(String),
    #[error("{0}")]
    StandardTable(#[from] TableError),
    #[error("{0}")]
    Inconsistent(String),
}

/// `380, 384, 388 nm` (the first 12, then how many more).
pub fn nm_list(nm: &[f64]) -> String {
    let shown: Vec<String> = nm.iter().take(12).map(|v| format!("{v}")).collect();
    let more = nm.len().saturating_sub(12);
    if more > 0 {
        format!("{} … ({more} more) nm", shown.join(", "))
    } else {
        format!("{} nm", shown.join(", "))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mean_and_standard_error_by_hand() {
        // Samples 1, 2, 3 → mean 2, SD 1, SE 1/√3; 10, 10, 10 → SE 0.
        let s = MeanSpectrum::from_samples("m", &[380.0, 384.0], &[&[1.0, 10.0], &[2.0, 10.0], &[3.0, 10.0]]).unwrap();
        assert_eq!(s.mean, [2.0, 10.0]);
        assert!((s.standard_error[0] - 1.0 / 3f64.sqrt()).abs() < 1e-15);
        assert_eq!(s.standard_error[1], 0.0);
        let e = MeanSpectrum::from_samples("measurement 7", &[380.0], &[&[1.0]]).unwrap_err();
        assert!(e.to_string().starts_with("measurement 7 has 1 good sample(s)"), "{e}");
    }
}
