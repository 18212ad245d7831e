//! N-step spectral approximation: the heart of the study.
//!
//! RADIANCE renders three channels at a time, so Ruppertsberg & Bloj rendered
//! a spectrum as N/3 three-channel images, each channel the average of the
//! spectrum over one waveband. Everything the renderer multiplies (light ×
//! reflectance × reflectance …) is then multiplied per band, and the result
//! is turned back into XYZ with matching functions averaged the same way.
//!
//! # Bands
//!
//! The K samples of a grid are split into N consecutive bands; band b holds
//! the samples i with ⌊b·K/N⌋ ≤ i < ⌊(b+1)·K/N⌋. When N divides K the bands
//! are equal: on the 81-sample analysis grid N = 3 gives 380–510, 515–645 and
//! 650–780 nm, N = 81 gives one sample per band (exact).
//!
//! ```
//! use lightbooth_science::nstep::Bands;
//! let b = Bands::new(81, 3).unwrap();
//! assert_eq!(b.range(1), 27..54);
//! let v: Vec<f64> = (0..81).map(|i| i as f64).collect();
//! assert_eq!(b.average(&v), vec![13.0, 40.0, 67.0]);
//! ```

use std::ops::Range;

use serde::Serialize;

use crate::colorimetry::{Cmf, Observer, Xyz, KM_LM_PER_W};
use crate::spectrum::{Grid, Spectrum, SpectrumError};

/// A partition of K grid samples into N consecutive bands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Bands {
    k: usize,
    n: usize,
}

impl Bands {
    /// N bands over K samples; 1 ≤ N ≤ K.
    pub fn new(k: usize, n: usize) -> Result<Bands, String> {
        if n == 0 || n > k {
            return Err(format!("N = {n} bands need 1 ≤ N ≤ {k} (the number of grid samples)"));
        }
        Ok(Bands { k, n })
    }

    pub fn samples(&self) -> usize {
        self.k
    }

    pub fn count(&self) -> usize {
        self.n
    }

    /// The sample indices of band `b`.
    pub fn range(&self, b: usize) -> Range<usize> {
        (b * self.k / self.n)..((b + 1) * self.k / self.n)
    }

    /// The band that holds sample `i`.
    pub fn band_of(&self, i: usize) -> usize {
        // The largest b with ⌊b·K/N⌋ ≤ i.
        let mut b = (i * self.n) / self.k;
        while b + 1 < self.n && self.range(b + 1).start <= i {
            b += 1;
        }
        while self.range(b).start > i {
            b -= 1;
        }
        b
    }

    /// The mean of `values` (K of them) over each band.
    pub fn average(&self, values: &[f64]) -> Vec<f64> {
        assert_eq!(values.len(), self.k, "band averaging needs one value per grid sample");
        (0..self.n)
            .map(|b| {
                let r = self.range(b);
                let len = r.len() as f64;
                values[r].iter().sum::<f64>() / len
            })
            .collect()
    }

    /// The piecewise-constant spectrum (K samples) of N band values.
    pub fn reconstruct(&self, band_values: &[f64]) -> Vec<f64> {
        assert_eq!(band_values.len(), self.n, "one value per band");
        let mut out = Vec::with_capacity(self.k);
        for (b, v) in band_values.iter().enumerate() {
            out.extend(std::iter::repeat_n(*v, self.range(b).len()));
        }
        out
    }
}

/// A spectrum band-averaged: N values in the spectrum's unit, on its grid's bands.
pub fn band_average(spectrum: &Spectrum, n: usize) -> Result<Vec<f64>, String> {
    Ok(Bands::new(spectrum.grid().len(), n)?.average(spectrum.values()))
}

/// The piecewise-constant reconstruction of a spectrum with N bands, on its own grid.
pub fn approximate(spectrum: &Spectrum, n: usize) -> Result<Spectrum, String> {
    let bands = Bands::new(spectrum.grid().len(), n)?;
    let values = bands.reconstruct(&bands.average(spectrum.values()));
    Spectrum::new(spectrum.grid().clone(), spectrum.unit(), values).map_err(|e| e.to_string())
}

/// The approximated matching functions x̄′, ȳ′, z̄′: the CMFs sampled on the
/// grid and band-averaged like every other quantity. With them, N band values
/// turn back into XYZ: X = Km · Δλ · Σ_b v_b · x̄′_b · (samples in b), which is
/// the plain CIE sum of the piecewise-constant reconstruction.
#[derive(Clone, Debug)]
pub struct NStepObserver {
    bands: Bands,
    step_nm: f64,
    /// Per band: x̄′, ȳ′, z̄′ times the number of samples in the band times
    /// Δλ, so a dot product with the band values is the CIE sum.
    weights: Vec<[f64; 3]>,
    bars: [Vec<f64>; 3],
}

impl NStepObserver {
    /// The approximated observer for `n` bands on a uniform `grid`.
    pub fn new(observer: Observer, grid: &Grid, n: usize) -> Result<NStepObserver, String> {
        let step_nm = grid
            .step_nm()
            .ok_or_else(|| format!("N-step needs a uniform grid, not {grid}"))?;
        let bands = Bands::new(grid.len(), n)?;
        let sampled = Cmf::of(observer).on_grid(grid);
        let bars = [
            bands.average(&sampled[0]),
            bands.average(&sampled[1]),
            bands.average(&sampled[2]),
        ];
        let weights = (0..n)
            .map(|b| {
                let w = bands.range(b).len() as f64 * step_nm;
                [bars[0][b] * w, bars[1][b] * w, bars[2][b] * w]
            })
            .collect();
        Ok(NStepObserver {
            bands,
            step_nm,
            weights,
            bars,
        })
    }

    pub fn bands(&self) -> Bands {
        self.bands
    }

    pub fn step_nm(&self) -> f64 {
        self.step_nm
    }

    /// x̄′, ȳ′, z̄′ per band.
    pub fn bars(&self) -> &[Vec<f64>; 3] {
        &self.bars
    }

    /// Σ_b v_b · x̄′_b · n_b · Δλ (and ȳ, z̄) without any constant: multiply
    /// by Km for absolute radiance, by 100/Y_white for relative.
    pub fn tristimulus_sums(&self, band_values: &[f64]) -> [f64; 3] {
        assert_eq!(band_values.len(), self.weights.len(), "one value per band");
        let mut s = [0.0; 3];
        for (v, w) in band_values.iter().zip(&self.weights) {
            for c in 0..3 {
                s[c] += v * w[c];
            }
        }
        s
    }

    /// Absolute XYZ (Y in cd/m²) of N band values of spectral radiance
    /// (W/(sr·m²·nm), band means).
    pub fn xyz_from_radiance(&self, band_values: &[f64]) -> Xyz {
        Xyz::from_array(self.tristimulus_sums(band_values).map(|v| v * KM_LM_PER_W))
    }
}

/// The N-step reconstruction of a colour signal as N-step rendering computes
/// it: the product of the band means of reflectance and illuminant (not the
/// band mean of their product), reconstructed piecewise-constant.
pub fn nstep_colour_signal(reflectance: &Spectrum, illuminant: &Spectrum, n: usize) -> Result<Vec<f64>, String> {
    reflectance.require_same_grid(illuminant).map_err(|e| e.to_string())?;
    let bands = Bands::new(reflectance.grid().len(), n)?;
    let r = bands.average(reflectance.values());
    let e = bands.average(illuminant.values());
    let product: Vec<f64> = r.iter().zip(&e).map(|(a, b)| a * b).collect();
    Ok(bands.reconstruct(&product))
}

/// The study's Fig. 7 curve: for each N, the mean over reflectances of the
/// RMS difference between the colour signal and its N-step reconstruction,
/// divided by the N = 1 value.
#[derive(Clone, Debug, Serialize)]
pub struct NStepErrorCurve {
    pub n: Vec<usize>,
    pub error: Vec<f64>,
}

/// Computes [`NStepErrorCurve`] for N = 1 … K on the common grid of the
/// reflectances and illuminant (normally the 81-sample analysis grid).
pub fn nstep_error(reflectances: &[Spectrum], illuminant: &Spectrum) -> Result<NStepErrorCurve, String> {
    if reflectances.is_empty() {
        return Err("no reflectances".into());
    }
    if !illuminant.unit().is_light() {
        return Err(format!("the illuminant must be light, not {}", illuminant.unit()));
    }
    let k = illuminant.grid().len();
    let signals: Vec<Spectrum> = reflectances
        .iter()
        .map(|r| r.illuminated_by(illuminant))
        .collect::<Result<_, SpectrumError>>()
        .map_err(|e| e.to_string())?;
    let mut raw = Vec::with_capacity(k);
    for n in 1..=k {
        let mut total = 0.0;
        for (r, signal) in reflectances.iter().zip(&signals) {
            let approx = nstep_colour_signal(r, illuminant, n)?;
            let mse = signal
                .values()
                .iter()
                .zip(&approx)
                .map(|(a, b)| (a - b).powi(2))
                .sum::<f64>()
                / k as f64;
            total += mse.sqrt();
        }
        raw.push(total / reflectances.len() as f64);
    }
    let norm = raw[0];
    if norm <= 0.0 {
        return Err("the N = 1 error is zero (all colour signals flat): nothing to normalise by".into());
    }
    Ok(NStepErrorCurve {
        n: (1..=k).collect(),
        error: raw.iter().map(|e| e / norm).collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::colorimetry::xyz_from_radiance;
    use crate::reference_data::{illuminant, reflectances, Illuminant, ReflectanceSet};
    use crate::spectrum::SpectralUnit;

    #[test]
    fn bands_partition_the_grid() {
        for n in 1..=81 {
            let b = Bands::new(81, n).unwrap();
            let mut next = 0;
            for band in 0..n {
                let r = b.range(band);
                assert_eq!(r.start, next);
                assert!(!r.is_empty());
                for i in r.clone() {
                    assert_eq!(b.band_of(i), band);
                }
                next = r.end;
            }
            assert_eq!(next, 81);
        }
        // The study's three bands.
        let g = Grid::analysis();
        let b = Bands::new(81, 3).unwrap();
        let nm = |i: usize| g.wavelengths()[i];
        assert_eq!((nm(b.range(0).start), nm(b.range(0).end - 1)), (380.0, 510.0));
        assert_eq!((nm(b.range(1).start), nm(b.range(1).end - 1)), (515.0, 645.0));
        assert_eq!((nm(b.range(2).start), nm(b.range(2).end - 1)), (650.0, 780.0));
        assert!(Bands::new(81, 0).is_err() && Bands::new(81, 82).is_err());
    }

    #[test]
    fn n81_reproduces_the_spectrum_exactly() {
        for (_, r) in reflectances(ReflectanceSet::ColorChecker) {
            assert_eq!(approximate(r, 81).unwrap(), *r);
        }
    }

    #[test]
    fn band_averaging_preserves_the_integral() {
        let d65 = illuminant(Illuminant::D65);
        for n in [1, 2, 3, 7, 9, 27, 40, 81] {
            let a = approximate(&d65, n).unwrap();
            let (x, y) = (a.integral().unwrap(), d65.integral().unwrap());
            assert!((x - y).abs() < 1e-9 * y, "N = {n}: {x} vs {y}");
        }
    }

    #[test]
    fn a_flat_spectrum_gives_the_same_xyz_for_every_n() {
        let flat = Spectrum::constant(Grid::analysis(), SpectralUnit::SpectralRadiance, 0.01).unwrap();
        for observer in [Observer::JuddVos, Observer::Cie1931] {
            let exact = xyz_from_radiance(&flat, observer).unwrap();
            for n in 1..=81 {
                let obs = NStepObserver::new(observer, &Grid::analysis(), n).unwrap();
                let xyz = obs.xyz_from_radiance(&band_average(&flat, n).unwrap());
                for (a, b) in xyz.to_array().iter().zip(exact.to_array()) {
                    assert!(
                        (a - b).abs() < 1e-12 * b.abs().max(1.0),
                        "N = {n}: {xyz:?} vs {exact:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn nstep_xyz_is_the_cie_sum_of_the_reconstruction() {
        let d65 = illuminant(Illuminant::D65).to_per_nm();
        let radiance = Spectrum::new(Grid::analysis(), SpectralUnit::SpectralRadiance, d65.values().to_vec()).unwrap();
        for n in [3, 9, 27] {
            let obs = NStepObserver::new(Observer::JuddVos, &Grid::analysis(), n).unwrap();
            let via_bands = obs.xyz_from_radiance(&band_average(&radiance, n).unwrap());
            // Σ recon·x̄′ = Σ_b v_b Σ_{i∈b} x̄′_b: the same as summing the reconstructions.
            let recon = approximate(&radiance, n).unwrap();
            let bars_recon: Vec<f64> = obs.bands().reconstruct(&obs.bars()[1]);
            let y: f64 = recon.values().iter().zip(&bars_recon).map(|(a, b)| a * b).sum::<f64>() * 5.0 * 683.0;
            assert!((via_bands.y - y).abs() < 1e-9 * y);
        }
    }

    #[test]
    fn spiky_f11_error_falls_more_slowly_than_d65() {
        let cc: Vec<Spectrum> = reflectances(ReflectanceSet::ColorChecker)
            .iter()
            .map(|(_, s)| s.clone())
            .collect();
        let d65 = nstep_error(&cc, &illuminant(Illuminant::D65)).unwrap();
        let f11 = nstep_error(&cc, &illuminant(Illuminant::F11)).unwrap();
        assert_eq!(d65.error[0], 1.0);
        assert!(
            d65.error[80].abs() < 1e-12 && f11.error[80].abs() < 1e-12,
            "N = 81 is exact"
        );
        for n in [3, 9, 27] {
            assert!(
                f11.error[n - 1] > d65.error[n - 1],
                "N = {n}: F11 {} vs D65 {}",
                f11.error[n - 1],
                d65.error[n - 1]
            );
        }
    }
}
