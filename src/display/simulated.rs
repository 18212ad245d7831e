//! The simulated display of `serve --mock`: what the simulated PR-650 sees
//! while the calibration page shows a colour.
//!
//! Primaries: a typical CRT's (Brainard 1997, via colour-science; see
//! `src/reference_data/PROVENANCE.md`), relative spectra resampled linearly
//! from 5 nm to 1 nm and scaled so that white (all channels at full drive,
//! black included) has a luminance of [`WHITE_CD_M2`] (CIE 1931 ȳ). Black:
//! [`BLACK_FRACTION`] of the primaries' sum (a CRT's glow and room
//! reflections, with the white's chromaticity). Transfer: a pure power of
//! the drive per channel, [`GAMMAS`], the model the fit assumes; the
//! simulated display is exactly additive.

use super::{fit_profile, CalibrationPlan, DisplayError, DisplayProfile, MeasuredPatch};
use crate::colorimetry::{xyz_from_radiance, Observer};
use crate::spectrum::table::SpectraTable;
use crate::spectrum::{Grid, SpectralUnit, Spectrum};

const PRIMARIES_CSV: &str = include_str!("../reference_data/display_crt_brainard1997.csv");

/// Luminance of the simulated white, cd/m².
pub const WHITE_CD_M2: f64 = 100.0;
/// Black level as a fraction of the primaries' sum at full drive.
pub const BLACK_FRACTION: f64 = 0.005;
/// γ of red, green, blue.
pub const GAMMAS: [f64; 3] = [2.25, 2.2, 2.15];

/// A display whose truth is known: the one the simulated PR-650 looks at.
#[derive(Clone, Debug)]
pub struct SimulatedDisplay {
    grid: Grid,
    black: Vec<f64>,
    primaries: [Vec<f64>; 3],
    gammas: [f64; 3],
}

impl SimulatedDisplay {
    /// The shipped CRT (see the module doc).
    pub fn crt() -> Result<SimulatedDisplay, DisplayError> {
        let table = SpectraTable::parse(PRIMARIES_CSV, "display_crt_brainard1997.csv")
            .map_err(|e| DisplayError::Profile(e.to_string()))?;
        let grid = Grid::one_nm();
        let mut rel = Vec::new();
        for name in ["red", "green", "blue"] {
            let s = table
                .spectrum(name, SpectralUnit::RelativePower)
                .map_err(|e| DisplayError::Profile(e.to_string()))?;
            rel.push(s.resample(&grid)?.into_values());
        }
        let sum: Vec<f64> = (0..grid.len()).map(|i| rel[0][i] + rel[1][i] + rel[2][i]).collect();
        let y_sum = xyz_from_radiance(
            &Spectrum::new(grid.clone(), SpectralUnit::SpectralRadiance, sum.clone())?,
            Observer::Cie1931,
        )?
        .y;
        let k = WHITE_CD_M2 / (y_sum * (1.0 + BLACK_FRACTION));
        let scale = |v: &[f64]| v.iter().map(|x| x * k).collect::<Vec<f64>>();
        Ok(SimulatedDisplay {
            black: sum.iter().map(|x| x * k * BLACK_FRACTION).collect(),
            primaries: [scale(&rel[0]), scale(&rel[1]), scale(&rel[2])],
            grid,
            gammas: GAMMAS,
        })
    }

    /// The spectral radiance shown for drives 0–1 per channel (clamped), 1 nm grid.
    pub fn spectrum(&self, drive: [f64; 3]) -> Spectrum {
        let t = [0, 1, 2].map(|c| drive[c].clamp(0.0, 1.0).powf(self.gammas[c]));
        let values = (0..self.grid.len())
            .map(|i| self.black[i] + (0..3).map(|c| t[c] * self.primaries[c][i]).sum::<f64>())
            .collect();
        Spectrum::new(self.grid.clone(), SpectralUnit::SpectralRadiance, values).expect("finite by construction")
    }

    /// The profile a calibration would fit to this display's exact 1 nm
    /// spectra (the eight-level plan of [`CalibrationPlan::new`]): for tests
    /// and for the simulated booth's experiments.
    pub fn exact_profile(&self, observer: Observer) -> Result<DisplayProfile, DisplayError> {
        let patches: Vec<MeasuredPatch> = CalibrationPlan::new(8)?
            .patches
            .iter()
            .enumerate()
            .map(|(i, p)| MeasuredPatch {
                drive: p.drive,
                wavelength_nm: self.grid.wavelengths().to_vec(),
                radiance: self.spectrum(p.drive).into_values(),
                measurement_id: Some(i as i64 + 1),
            })
            .collect();
        fit_profile(&patches, observer)
    }

    /// The true γ of each channel.
    pub fn gammas(&self) -> [f64; 3] {
        self.gammas
    }

    /// The true chromaticity x, y of each primary's increment over black.
    pub fn primary_chromaticities(&self, observer: Observer) -> Result<[[f64; 2]; 3], DisplayError> {
        let mut out = [[0.0; 2]; 3];
        for (o, p) in out.iter_mut().zip(&self.primaries) {
            let s = Spectrum::new(self.grid.clone(), SpectralUnit::SpectralRadiance, p.clone())?;
            let c = xyz_from_radiance(&s, observer)?.chromaticity();
            *o = [c.x, c.y];
        }
        Ok(out)
    }
}
