//! The optical and electronic model of the simulated PR-650: what it reads
//! when aimed at a radiance, how noisy, how long it takes, and when it
//! reports low light or overload. An instrument model, not a copy of the truth.
//!
//! - **Sampling**: 101 points, 380–780 nm at 4 nm.
//! - **Bandwidth**: a triangular slit of 8 nm FWHM (the `D120` example's
//!   bandwidth \[uncertain\]) centred on each sample, applied to the 1 nm truth;
//!   near 380/780 nm the part of the slit outside the truth is dropped and the
//!   weights renormalised.
//! - **Detector**: counts C = k·E·t for the slit-averaged radiance E over the
//!   integration time t, with photon (shot) noise √C and a Gaussian read noise,
//!   both in counts; the reading is C/(k·t). So σ(E) = √(k·E·t + r²)/(k·t).
//! - **Adaptive integration** (itime 0): t puts the brightest sample at 70 %
//!   of full scale, clamped to 10–6000 ms; dim sources take longer.
//! - **Limits**: overload (19) when even 10 ms saturates; at 6000 ms, a
//!   brightest sample under 2000 counts is low light (18), under 200 counts a
//!   weak signal (10). With the calibration below these fall near 14 000 cd/m²
//!   and 0.7 / 0.07 cd/m² for a flat spectrum. The real limits depend on the
//!   unit and its optics; these are chosen to sit where the PR-650 with an
//!   MS-75 is usually quoted (about 1 fL ≈ 3.4 cd/m² for a good spectrum).
//! - **Time**: a base time (shutter, dark reading, processing) plus twice the
//!   integration time (light and dark frames).

use lightbooth_science::spectrum::{Grid, Spectrum, SpectrumError};

/// Parameters of the simulated detector. Units in the names.
#[derive(Clone, Debug, PartialEq)]
pub struct InstrumentModel {
    pub grid: Grid,
    pub slit_fwhm_nm: f64,
    /// Counts per (W/(sr·m²·nm)) per second of integration.
    pub counts_per_radiance_s: f64,
    pub full_scale_counts: f64,
    /// Adaptive mode aims the brightest sample at this fraction of full scale.
    pub adaptive_target_fraction: f64,
    pub read_noise_counts: f64,
    pub min_integration_ms: f64,
    pub max_integration_ms: f64,
    /// Brightest sample at the longest integration below this: code 18.
    pub low_light_counts: f64,
    /// Below this: code 10.
    pub weak_signal_counts: f64,
    /// Shutter, dark frame handling and computation, ms.
    pub base_time_ms: f64,
}

impl Default for InstrumentModel {
    fn default() -> InstrumentModel {
        InstrumentModel {
            grid: Grid::pr650(),
            slit_fwhm_nm: 8.0,
            counts_per_radiance_s: 3.3e7,
            full_scale_counts: 65_535.0,
            adaptive_target_fraction: 0.7,
            read_noise_counts: 20.0,
            min_integration_ms: 10.0,
            max_integration_ms: 6000.0,
            low_light_counts: 2000.0,
            weak_signal_counts: 200.0,
            base_time_ms: 1500.0,
        }
    }
}

impl InstrumentModel {
    /// The PR-655 or PR-670: its native grid, and a slit of twice its step
    /// (8 nm, 4 nm: the PR-650's ratio; Photo Research quotes < 8 nm and
    /// < 5 nm, and report 120's bandwidth field is 0.00, 12.15). The detector is
    /// the PR-650's, with the shorter minimum exposure (3 or 6 ms).
    pub fn for_pr655(model: crate::pr655::Model) -> InstrumentModel {
        use crate::pr655::Model;
        let grid = model.grid();
        let (slit_fwhm_nm, min_integration_ms) = match model {
            Model::Pr655 => (8.0, 3.0),
            Model::Pr670 => (4.0, 6.0),
        };
        InstrumentModel {
            grid,
            slit_fwhm_nm,
            min_integration_ms,
            ..InstrumentModel::default()
        }
    }
}

impl InstrumentModel {
    /// The CS-2000 family: 380–780 nm at 1 nm, a 5 nm slit (the catalogue's
    /// spectral bandwidth), a detector 10× as sensitive as the PR-650's
    /// (its range reaches 0.003 cd/m², the PR-650's about 3), integrations
    /// of 5 ms to 120 s (specio's manual-mode bounds, `konica_minolta.py`
    /// 131–140), and 1.5 s of shutter and computation per measurement.
    pub fn for_cs2000() -> InstrumentModel {
        InstrumentModel {
            grid: Grid::one_nm(),
            slit_fwhm_nm: 5.0,
            counts_per_radiance_s: 3.3e8,
            min_integration_ms: 5.0,
            max_integration_ms: 120_000.0,
            base_time_ms: 1500.0,
            ..InstrumentModel::default()
        }
    }
}

impl InstrumentModel {
    /// The CR-250 (4 nm) or CR-300 (1 nm): a slit of twice the step (the
    /// PR-650's ratio; a choice), a detector 10× as sensitive as the
    /// PR-650's, exposures from 1 ms (the longest is the speed's, set by
    /// the simulator), and 0.3 s of overhead per measurement.
    pub fn for_cr250(model: crate::cr250::Model) -> InstrumentModel {
        let grid = model.grid();
        let step = grid.step_nm().unwrap_or(1.0);
        InstrumentModel {
            grid,
            slit_fwhm_nm: 2.0 * step,
            counts_per_radiance_s: 3.3e8,
            min_integration_ms: 1.0,
            max_integration_ms: 2_500.0,
            base_time_ms: 300.0,
            ..InstrumentModel::default()
        }
    }
}

/// What the instrument will do for a given target.
#[derive(Clone, Debug, PartialEq)]
pub struct Reading {
    /// Noise-free slit-averaged radiance on the native grid, W/(sr·m²·nm).
    pub expected: Vec<f64>,
    /// Per-sample noise SD of one reading, same unit.
    pub sigma: Vec<f64>,
    pub integration_ms: f64,
    /// The quality code the measurement will carry (0, 10, 18 or 19).
    pub code: u8,
    /// Measurement time at speed 1, ms.
    pub duration_ms: f64,
}

impl InstrumentModel {
    /// The slit-averaged, noise-free reading of a radiance on any grid that
    /// covers 380–780 nm (resampled to 1 nm first).
    pub fn expected(&self, truth: &Spectrum) -> Result<Vec<f64>, SpectrumError> {
        let one_nm = truth.to_per_nm().resample(&Grid::one_nm())?;
        let truth_nm = Grid::one_nm();
        let half_base = self.slit_fwhm_nm; // a triangle of FWHM w has a base of 2w
        Ok(self
            .grid
            .wavelengths()
            .iter()
            .map(|&centre| {
                let mut sum = 0.0;
                let mut weights = 0.0;
                for (nm, v) in truth_nm.wavelengths().iter().zip(one_nm.values()) {
                    let w = 1.0 - (nm - centre).abs() / half_base;
                    if w > 0.0 {
                        sum += w * v;
                        weights += w;
                    }
                }
                if weights > 0.0 {
                    sum / weights
                } else {
                    0.0
                }
            })
            .collect())
    }

    /// Integration time, code, noise and duration for a target; `fixed_ms` is
    /// the `S` command's itime (0 = adaptive).
    pub fn reading(&self, truth: &Spectrum, fixed_ms: u32) -> Result<Reading, SpectrumError> {
        let expected = self.expected(truth)?;
        let peak = expected.iter().cloned().fold(0.0_f64, f64::max);
        let k = self.counts_per_radiance_s;
        let integration_ms = if fixed_ms > 0 {
            f64::from(fixed_ms)
        } else if peak > 0.0 {
            let t_s = self.adaptive_target_fraction * self.full_scale_counts / (k * peak);
            (t_s * 1000.0).clamp(self.min_integration_ms, self.max_integration_ms)
        } else {
            self.max_integration_ms
        };
        let peak_counts = k * peak * integration_ms / 1000.0;
        let code = if peak_counts > self.full_scale_counts {
            19
        } else if peak_counts < self.weak_signal_counts {
            10
        } else if peak_counts < self.low_light_counts {
            18
        } else {
            0
        };
        let sigma = self.sigma(&expected, integration_ms);
        Ok(Reading {
            expected,
            sigma,
            integration_ms,
            code,
            duration_ms: self.base_time_ms + 2.0 * integration_ms,
        })
    }

    /// σ of one reading at each sample, W/(sr·m²·nm).
    pub fn sigma(&self, expected: &[f64], integration_ms: f64) -> Vec<f64> {
        let kt = self.counts_per_radiance_s * integration_ms / 1000.0;
        expected
            .iter()
            .map(|e| (kt * e.max(0.0) + self.read_noise_counts.powi(2)).sqrt() / kt)
            .collect()
    }

    /// One noisy reading. Shot noise is Gaussian with variance C (the
    /// Poisson limit at these counts), read noise Gaussian.
    pub fn sample(&self, reading: &Reading, rng: &mut Rng) -> Vec<f64> {
        reading
            .expected
            .iter()
            .zip(&reading.sigma)
            .map(|(e, s)| e + s * rng.gaussian())
            .collect()
    }
}

/// A small seedable generator for reproducible noise: PCG-XSH-RR 32 (O'Neill
/// 2014) with a Box–Muller transform. Hand-rolled so the simulator needs no
/// extra dependency and the same seed gives the same samples on every platform.
#[derive(Clone, Debug)]
pub struct Rng {
    state: u64,
    spare: Option<f64>,
}

impl Rng {
    const MULTIPLIER: u64 = 6_364_136_223_846_793_005;
    const INCREMENT: u64 = 1_442_695_040_888_963_407;

    pub fn new(seed: u64) -> Rng {
        let mut rng = Rng { state: 0, spare: None };
        rng.next_u32();
        rng.state = rng.state.wrapping_add(seed);
        rng.next_u32();
        rng
    }

    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(Self::MULTIPLIER).wrapping_add(Self::INCREMENT);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        let hi = u64::from(self.next_u32()) << 21;
        let lo = u64::from(self.next_u32()) >> 11;
        ((hi | lo) as f64) / (1u64 << 53) as f64
    }

    /// Standard normal.
    pub fn gaussian(&mut self) -> f64 {
        if let Some(z) = self.spare.take() {
            return z;
        }
        let u1 = self.uniform().max(f64::MIN_POSITIVE);
        let u2 = self.uniform();
        let r = (-2.0 * u1.ln()).sqrt();
        let theta = 2.0 * std::f64::consts::PI * u2;
        self.spare = Some(r * theta.sin());
        r * theta.cos()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lightbooth_science::spectrum::SpectralUnit;

    fn flat(value: f64) -> Spectrum {
        Spectrum::constant(Grid::one_nm(), SpectralUnit::SpectralRadiance, value).unwrap()
    }

    #[test]
    fn a_flat_spectrum_reads_flat_and_the_slit_smooths_a_line() {
        let m = InstrumentModel::default();
        let e = m.expected(&flat(1e-3)).unwrap();
        assert!(e.iter().all(|v| (v - 1e-3).abs() < 1e-12));
        let mut line = vec![0.0; 401];
        line[180] = 1.0; // 560 nm
        let s = Spectrum::new(Grid::one_nm(), SpectralUnit::SpectralRadiance, line).unwrap();
        let e = m.expected(&s).unwrap();
        let i560 = (560 - 380) / 4;
        assert!(
            e[i560] > 0.0 && e[i560 - 1] > 0.0 && e[i560 + 1] > 0.0,
            "an 8 nm slit spreads a line"
        );
        assert_eq!(e[i560 - 2], 0.0);
    }

    #[test]
    fn codes_follow_the_light_level() {
        let m = InstrumentModel::default();
        assert_eq!(m.reading(&flat(1e-3), 0).unwrap().code, 0);
        assert_eq!(m.reading(&flat(5e-6), 0).unwrap().code, 18);
        assert_eq!(m.reading(&flat(5e-7), 0).unwrap().code, 10);
        assert_eq!(m.reading(&flat(1.0), 0).unwrap().code, 19);
        let dim = m.reading(&flat(1e-4), 0).unwrap();
        let bright = m.reading(&flat(1e-2), 0).unwrap();
        assert!(dim.duration_ms > bright.duration_ms);
    }

    #[test]
    fn noise_has_the_modelled_spread() {
        let m = InstrumentModel::default();
        let r = m.reading(&flat(1e-3), 0).unwrap();
        let mut rng = Rng::new(7);
        let n = 400;
        let mut ss = 0.0;
        for _ in 0..n {
            let s = m.sample(&r, &mut rng);
            ss += (s[50] - r.expected[50]).powi(2);
        }
        let sd = (ss / n as f64).sqrt();
        assert!((sd / r.sigma[50] - 1.0).abs() < 0.15, "{sd} vs {}", r.sigma[50]);
    }
}
