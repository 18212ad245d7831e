//! Spectra that carry their wavelength grid and their unit.
//!
//! Every number lightbooth computes starts as a spectrum: a PR-650 reading, a
//! reflectance from a data set, a luminaire's power distribution, a rendered
//! radiance. The classic mistakes of this field are silent factors: a per-band
//! value read as per-nm (PTB multiplies PR-650 values by the 4 nm step), a 4 nm
//! instrument grid read as 5 nm, an illuminant multiplied in twice. Here they
//! are errors instead:
//!
//! - a [`Spectrum`] always knows its [`Grid`] (the wavelengths of its samples,
//!   in nm), so two spectra on different grids cannot be combined sample by
//!   sample, and resampling is explicit;
//! - it always knows its [`SpectralUnit`], so per-band radiance must be
//!   converted to per-nm before colorimetry, and light × light is refused.
//!
//! ```
//! use lightbooth_science::spectrum::{Grid, Spectrum, SpectralUnit};
//! let grid = Grid::analysis();
//! let white = Spectrum::constant(grid.clone(), SpectralUnit::Reflectance, 0.9).unwrap();
//! let light = Spectrum::constant(grid, SpectralUnit::SpectralRadiance, 0.01).unwrap();
//! let signal = white.illuminated_by(&light).unwrap();
//! assert_eq!(signal.unit(), SpectralUnit::SpectralRadiance);
//! assert!(signal.illuminated_by(&light).is_err()); // light × light: an illuminant twice
//! ```
//!
//! CSV reading and writing lives in [`table`].

pub mod table;

use std::fmt;

/// Tolerance for comparing wavelengths in nm: grids built from decimal text
/// (380, 384, …) and from arithmetic (380 + 4·i) must compare equal.
const NM_EPS: f64 = 1e-6;

/// The wavelengths (nm) at which a spectrum is sampled: strictly increasing,
/// finite. Most grids are uniform; [`Grid::step_nm`] says whether this one is.
#[derive(Clone, PartialEq)]
pub struct Grid {
    nm: Vec<f64>,
}

impl Grid {
    /// `count` samples from `start_nm` in steps of `step_nm`.
    pub fn uniform(start_nm: f64, step_nm: f64, count: usize) -> Grid {
        assert!(
            step_nm > 0.0 && count > 0,
            "a grid needs a positive step and at least one sample"
        );
        Grid {
            nm: (0..count).map(|i| start_nm + step_nm * i as f64).collect(),
        }
    }

    /// The analysis grid of the study: 380–780 nm at 5 nm, 81 samples.
    pub fn analysis() -> Grid {
        Grid::uniform(380.0, 5.0, 81)
    }

    /// 380–780 nm at 1 nm, 401 samples: the renderer's reference resolution.
    pub fn one_nm() -> Grid {
        Grid::uniform(380.0, 1.0, 401)
    }

    /// The PR-650's native grid: 380–780 nm at 4 nm, 101 samples.
    pub fn pr650() -> Grid {
        Grid::uniform(380.0, 4.0, 101)
    }

    /// A grid from arbitrary wavelengths; they must be finite and strictly increasing.
    pub fn from_wavelengths(nm: Vec<f64>) -> Result<Grid, SpectrumError> {
        if nm.is_empty() {
            return Err(SpectrumError::EmptyGrid);
        }
        for (i, w) in nm.iter().enumerate() {
            if !w.is_finite() {
                return Err(SpectrumError::NonFiniteWavelength { index: i });
            }
            if i > 0 && *w <= nm[i - 1] {
                return Err(SpectrumError::NotIncreasing {
                    index: i,
                    prev_nm: nm[i - 1],
                    nm: *w,
                });
            }
        }
        Ok(Grid { nm })
    }

    pub fn wavelengths(&self) -> &[f64] {
        &self.nm
    }

    pub fn len(&self) -> usize {
        self.nm.len()
    }

    pub fn is_empty(&self) -> bool {
        self.nm.is_empty()
    }

    pub fn first_nm(&self) -> f64 {
        self.nm[0]
    }

    pub fn last_nm(&self) -> f64 {
        self.nm[self.nm.len() - 1]
    }

    /// The step in nm if the grid is uniform (and has at least two samples).
    pub fn step_nm(&self) -> Option<f64> {
        if self.nm.len() < 2 {
            return None;
        }
        let step = (self.last_nm() - self.first_nm()) / (self.nm.len() - 1) as f64;
        let uniform = self
            .nm
            .iter()
            .enumerate()
            .all(|(i, w)| (w - (self.first_nm() + step * i as f64)).abs() < NM_EPS);
        uniform.then_some(step)
    }

    /// True when the grid reaches from `lo_nm` to `hi_nm` (inclusive).
    pub fn covers(&self, lo_nm: f64, hi_nm: f64) -> bool {
        self.first_nm() <= lo_nm + NM_EPS && self.last_nm() >= hi_nm - NM_EPS
    }

    /// Same wavelengths, within `NM_EPS`.
    pub fn same_as(&self, other: &Grid) -> bool {
        self.nm.len() == other.nm.len() && self.nm.iter().zip(&other.nm).all(|(a, b)| (a - b).abs() < NM_EPS)
    }

    /// The index of a wavelength that is on the grid.
    pub fn index_of(&self, nm: f64) -> Option<usize> {
        self.nm.iter().position(|w| (w - nm).abs() < NM_EPS)
    }
}

impl fmt::Debug for Grid {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{self}")
    }
}

impl fmt::Display for Grid {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.step_nm() {
            Some(step) => write!(
                f,
                "{}–{} nm at {} nm ({} samples)",
                self.first_nm(),
                self.last_nm(),
                step,
                self.len()
            ),
            None => write!(
                f,
                "{}–{} nm, non-uniform ({} samples)",
                self.first_nm(),
                self.last_nm(),
                self.len()
            ),
        }
    }
}

/// What the numbers of a spectrum mean. Conversions between these are explicit
/// methods of [`Spectrum`]; combining incompatible ones is an error.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SpectralUnit {
    /// W/(sr·m²·nm): what the PR-650 reports, what the renderer computes.
    SpectralRadiance,
    /// W/(sr·m²) in each sample's band of `band_nm` width: the "power per
    /// wavelength band" some toolboxes produce by multiplying by the step.
    BandRadiance { band_nm: f64 },
    /// W/(m²·nm): the PR-650 with a cosine receptor (report unit flag 1).
    SpectralIrradiance,
    /// A reflectance factor in [0, 1].
    Reflectance,
    /// A transmittance factor in [0, 1] (filters).
    Transmittance,
    /// A relative spectral power distribution (illuminant shape), any scale.
    RelativePower,
}

impl SpectralUnit {
    /// Units of light (as opposed to factors that modulate light).
    pub fn is_light(self) -> bool {
        matches!(
            self,
            SpectralUnit::SpectralRadiance
                | SpectralUnit::BandRadiance { .. }
                | SpectralUnit::SpectralIrradiance
                | SpectralUnit::RelativePower
        )
    }

    /// Units bounded to [0, 1].
    pub fn is_factor(self) -> bool {
        matches!(self, SpectralUnit::Reflectance | SpectralUnit::Transmittance)
    }
}

/// The unit of spectral radiance as every chart, page and file header of
/// lightbooth writes it (one spelling; ASCII-only formats write
/// `W/(sr*m^2*nm)`).
pub const SPECTRAL_RADIANCE_UNIT: &str = "W/(sr·m²·nm)";

impl fmt::Display for SpectralUnit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SpectralUnit::SpectralRadiance => write!(f, "spectral radiance {SPECTRAL_RADIANCE_UNIT}"),
            SpectralUnit::BandRadiance { band_nm } => {
                write!(f, "band radiance W/(sr·m²) per {band_nm} nm band")
            }
            SpectralUnit::SpectralIrradiance => write!(f, "spectral irradiance W/(m²·nm)"),
            SpectralUnit::Reflectance => write!(f, "reflectance"),
            SpectralUnit::Transmittance => write!(f, "transmittance"),
            SpectralUnit::RelativePower => write!(f, "relative spectral power"),
        }
    }
}

/// Everything that can be wrong with a spectrum or an operation on spectra.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SpectrumError {
    #[error("a grid needs at least one wavelength")]
    EmptyGrid,
    #[error("wavelength #{index} is not a finite number")]
    NonFiniteWavelength { index: usize },
    #[error("wavelengths must increase: {nm} nm (#{index}) follows {prev_nm} nm")]
    NotIncreasing { index: usize, prev_nm: f64, nm: f64 },
    #[error("{values} values for a grid of {grid} wavelengths")]
    LengthMismatch { values: usize, grid: usize },
    #[error("value at {nm} nm is not a finite number")]
    NonFiniteValue { nm: f64 },
    #[error("{unit} at {nm} nm is {value}, outside [0, 1]")]
    FactorOutOfRange { unit: SpectralUnit, nm: f64, value: f64 },
    #[error("grids differ ({a} vs {b}): resample one onto the other first")]
    GridMismatch { a: Grid, b: Grid },
    #[error("{what} needs a uniform grid, but this one is {grid}")]
    NonUniformGrid { what: &'static str, grid: Grid },
    #[error("cannot resample from {from} to {to}: the target reaches outside the source (no extrapolation)")]
    OutOfRange { from: Grid, to: Grid },
    #[error("{op}: {unit} is not allowed here ({why})")]
    WrongUnit {
        op: &'static str,
        unit: SpectralUnit,
        why: &'static str,
    },
    #[error(
        "per-band values of {band_nm} nm bands on a grid with a {step_nm} nm step: \
         the band width must be the grid step (was a 4 nm grid read as 5 nm?)"
    )]
    BandMismatch { band_nm: f64, step_nm: f64 },
}

/// A sampled spectrum: values on a [`Grid`], in a [`SpectralUnit`].
#[derive(Clone, Debug, PartialEq)]
pub struct Spectrum {
    grid: Grid,
    unit: SpectralUnit,
    values: Vec<f64>,
}

impl Spectrum {
    /// Checks the length, that every value is finite, and that factors lie in
    /// [0, 1]. Negative light (instrument noise near zero) is accepted.
    pub fn new(grid: Grid, unit: SpectralUnit, values: Vec<f64>) -> Result<Spectrum, SpectrumError> {
        if values.len() != grid.len() {
            return Err(SpectrumError::LengthMismatch {
                values: values.len(),
                grid: grid.len(),
            });
        }
        for (nm, v) in grid.wavelengths().iter().zip(&values) {
            if !v.is_finite() {
                return Err(SpectrumError::NonFiniteValue { nm: *nm });
            }
            if unit.is_factor() && !(0.0..=1.0).contains(v) {
                return Err(SpectrumError::FactorOutOfRange {
                    unit,
                    nm: *nm,
                    value: *v,
                });
            }
        }
        if let SpectralUnit::BandRadiance { band_nm } = unit {
            match grid.step_nm() {
                Some(step) if (step - band_nm).abs() < NM_EPS => {}
                Some(step_nm) => return Err(SpectrumError::BandMismatch { band_nm, step_nm }),
                None => {
                    return Err(SpectrumError::NonUniformGrid {
                        what: "band radiance",
                        grid,
                    });
                }
            }
        }
        Ok(Spectrum { grid, unit, values })
    }

    /// The same value at every wavelength.
    pub fn constant(grid: Grid, unit: SpectralUnit, value: f64) -> Result<Spectrum, SpectrumError> {
        let values = vec![value; grid.len()];
        Spectrum::new(grid, unit, values)
    }

    /// A spectrum from (nm, value) knots, linearly interpolated onto `grid`
    /// and held constant beyond the first and last knot. This is how the scene
    /// sheet states its piecewise-linear reflectances.
    pub fn piecewise_linear(grid: Grid, unit: SpectralUnit, knots: &[(f64, f64)]) -> Result<Spectrum, SpectrumError> {
        let knot_grid = Grid::from_wavelengths(knots.iter().map(|k| k.0).collect())?;
        let knot_values: Vec<f64> = knots.iter().map(|k| k.1).collect();
        let values = grid
            .wavelengths()
            .iter()
            .map(|&nm| interpolate_clamped(knot_grid.wavelengths(), &knot_values, nm))
            .collect();
        Spectrum::new(grid, unit, values)
    }

    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    pub fn unit(&self) -> SpectralUnit {
        self.unit
    }

    pub fn values(&self) -> &[f64] {
        &self.values
    }

    pub fn into_values(self) -> Vec<f64> {
        self.values
    }

    /// The value at a wavelength, linearly interpolated; `None` outside the grid.
    pub fn value_at(&self, nm: f64) -> Option<f64> {
        let w = self.grid.wavelengths();
        if nm < w[0] - NM_EPS || nm > w[w.len() - 1] + NM_EPS {
            return None;
        }
        Some(interpolate_clamped(w, &self.values, nm))
    }

    /// Linear interpolation onto `to`. The target must lie inside this grid
    /// (no extrapolation), and per-band values cannot be resampled (their
    /// meaning depends on the band width): convert with [`Self::to_per_nm`] first.
    pub fn resample(&self, to: &Grid) -> Result<Spectrum, SpectrumError> {
        if self.grid.same_as(to) {
            return Ok(self.clone());
        }
        if let SpectralUnit::BandRadiance { .. } = self.unit {
            return Err(SpectrumError::WrongUnit {
                op: "resample",
                unit: self.unit,
                why: "convert per-band values to per-nm first",
            });
        }
        if !self.grid.covers(to.first_nm(), to.last_nm()) {
            return Err(SpectrumError::OutOfRange {
                from: self.grid.clone(),
                to: to.clone(),
            });
        }
        let values = to
            .wavelengths()
            .iter()
            .map(|&nm| interpolate_clamped(self.grid.wavelengths(), &self.values, nm))
            .collect();
        Spectrum::new(to.clone(), self.unit, values)
    }

    /// Per-band radiance (W/(sr·m²) per band) to spectral radiance (per nm).
    /// Spectral units pass through unchanged.
    pub fn to_per_nm(&self) -> Spectrum {
        match self.unit {
            SpectralUnit::BandRadiance { band_nm } => Spectrum {
                grid: self.grid.clone(),
                unit: SpectralUnit::SpectralRadiance,
                values: self.values.iter().map(|v| v / band_nm).collect(),
            },
            _ => self.clone(),
        }
    }

    /// Spectral radiance to radiance per band of the grid's step.
    pub fn to_per_band(&self) -> Result<Spectrum, SpectrumError> {
        if self.unit != SpectralUnit::SpectralRadiance {
            return Err(SpectrumError::WrongUnit {
                op: "to_per_band",
                unit: self.unit,
                why: "only spectral radiance has a per-band form",
            });
        }
        let band_nm = self.uniform_step("per-band values")?;
        Ok(Spectrum {
            grid: self.grid.clone(),
            unit: SpectralUnit::BandRadiance { band_nm },
            values: self.values.iter().map(|v| v * band_nm).collect(),
        })
    }

    /// The light reflected (or transmitted) by this factor spectrum under
    /// `light`: the product per sample, in the light's unit. Both must share a
    /// grid. Light × light (an illuminant applied twice) is refused.
    pub fn illuminated_by(&self, light: &Spectrum) -> Result<Spectrum, SpectrumError> {
        if !self.unit.is_factor() {
            return Err(SpectrumError::WrongUnit {
                op: "illuminated_by",
                unit: self.unit,
                why: "only a reflectance or transmittance can be illuminated; \
                      is the illuminant already multiplied in?",
            });
        }
        if !light.unit.is_light() {
            return Err(SpectrumError::WrongUnit {
                op: "illuminated_by",
                unit: light.unit,
                why: "the light must be a radiance, irradiance or relative power",
            });
        }
        self.require_same_grid(light)?;
        let values = self.values.iter().zip(&light.values).map(|(r, l)| r * l).collect();
        Ok(Spectrum {
            grid: self.grid.clone(),
            unit: light.unit,
            values,
        })
    }

    /// Two factors in series (a filter in front of a filter, paint under a
    /// varnish): the product is still a factor.
    pub fn times_factor(&self, factor: &Spectrum) -> Result<Spectrum, SpectrumError> {
        if !factor.unit.is_factor() {
            return Err(SpectrumError::WrongUnit {
                op: "times_factor",
                unit: factor.unit,
                why: "the second operand must be a reflectance or transmittance",
            });
        }
        if self.unit.is_factor() {
            self.require_same_grid(factor)?;
            let values = self.values.iter().zip(&factor.values).map(|(a, b)| a * b).collect();
            return Ok(Spectrum {
                grid: self.grid.clone(),
                unit: self.unit,
                values,
            });
        }
        factor.illuminated_by(self)
    }

    /// Every value multiplied by `k`, same unit. Factors must stay in [0, 1].
    pub fn scaled(&self, k: f64) -> Result<Spectrum, SpectrumError> {
        Spectrum::new(
            self.grid.clone(),
            self.unit,
            self.values.iter().map(|v| v * k).collect(),
        )
    }

    /// Reinterprets the numbers in another unit: for reading files whose unit
    /// is known only to the caller (a CSV column of reflectances).
    pub fn with_unit(self, unit: SpectralUnit) -> Result<Spectrum, SpectrumError> {
        Spectrum::new(self.grid, unit, self.values)
    }

    /// Σ v(λ)·Δλ over the grid, the plain sum that CIE 15 uses (no end
    /// weights). Per-band values are summed without Δλ: they already hold it.
    pub fn integral(&self) -> Result<f64, SpectrumError> {
        let sum: f64 = self.values.iter().sum();
        match self.unit {
            SpectralUnit::BandRadiance { .. } => Ok(sum),
            _ => Ok(sum * self.uniform_step("an integral")?),
        }
    }

    /// The grid step, or an error naming `what` needed it.
    pub fn uniform_step(&self, what: &'static str) -> Result<f64, SpectrumError> {
        self.grid.step_nm().ok_or_else(|| SpectrumError::NonUniformGrid {
            what,
            grid: self.grid.clone(),
        })
    }

    pub fn require_same_grid(&self, other: &Spectrum) -> Result<(), SpectrumError> {
        if self.grid.same_as(&other.grid) {
            Ok(())
        } else {
            Err(SpectrumError::GridMismatch {
                a: self.grid.clone(),
                b: other.grid.clone(),
            })
        }
    }
}

/// Linear interpolation of (x, y) at `at`, holding the end values beyond the
/// ends. `x` is strictly increasing.
pub fn interpolate_clamped(x: &[f64], y: &[f64], at: f64) -> f64 {
    let n = x.len();
    if at <= x[0] {
        return y[0];
    }
    if at >= x[n - 1] {
        return y[n - 1];
    }
    // First index with x > at; at lies in [x[i-1], x[i]).
    let i = x.partition_point(|&w| w <= at);
    let (x0, x1, y0, y1) = (x[i - 1], x[i], y[i - 1], y[i]);
    if (at - x0).abs() < NM_EPS {
        return y0;
    }
    y0 + (y1 - y0) * (at - x0) / (x1 - x0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grids_know_their_step() {
        assert_eq!(Grid::analysis().step_nm(), Some(5.0));
        assert_eq!(Grid::pr650().len(), 101);
        assert_eq!(Grid::pr650().last_nm(), 780.0);
        assert_eq!(Grid::one_nm().len(), 401);
        let g = Grid::from_wavelengths(vec![380.0, 390.0, 395.0]).unwrap();
        assert_eq!(g.step_nm(), None);
    }

    #[test]
    fn a_4nm_grid_read_as_5nm_band_values_is_an_error() {
        let err = Spectrum::new(
            Grid::pr650(),
            SpectralUnit::BandRadiance { band_nm: 5.0 },
            vec![1.0; 101],
        )
        .unwrap_err();
        assert!(matches!(err, SpectrumError::BandMismatch { .. }), "{err}");
    }

    #[test]
    fn per_band_round_trip_preserves_the_integral() {
        let s = Spectrum::constant(Grid::pr650(), SpectralUnit::SpectralRadiance, 0.002).unwrap();
        let band = s.to_per_band().unwrap();
        assert_eq!(band.unit(), SpectralUnit::BandRadiance { band_nm: 4.0 });
        assert!((band.integral().unwrap() - s.integral().unwrap()).abs() < 1e-15);
        assert_eq!(band.to_per_nm(), s);
    }

    #[test]
    fn an_illuminant_cannot_be_applied_twice() {
        let g = Grid::analysis();
        let r = Spectrum::constant(g.clone(), SpectralUnit::Reflectance, 0.5).unwrap();
        let d65 = Spectrum::constant(g, SpectralUnit::RelativePower, 100.0).unwrap();
        let signal = r.illuminated_by(&d65).unwrap();
        assert_eq!(signal.unit(), SpectralUnit::RelativePower);
        assert!(signal.illuminated_by(&d65).is_err());
        assert!(d65.times_factor(&d65).is_err());
    }

    #[test]
    fn resampling_is_linear_and_refuses_extrapolation() {
        let g = Grid::from_wavelengths(vec![380.0, 780.0]).unwrap();
        let s = Spectrum::new(g, SpectralUnit::SpectralRadiance, vec![0.0, 400.0]).unwrap();
        let r = s.resample(&Grid::analysis()).unwrap();
        assert!((r.values()[1] - 5.0).abs() < 1e-12);
        assert!(s.resample(&Grid::uniform(370.0, 5.0, 10)).is_err());
    }

    #[test]
    fn negative_reflectance_is_an_error_but_negative_radiance_is_noise() {
        let g = Grid::uniform(380.0, 5.0, 2);
        assert!(Spectrum::new(g.clone(), SpectralUnit::Reflectance, vec![0.1, -0.01]).is_err());
        assert!(Spectrum::new(g, SpectralUnit::SpectralRadiance, vec![0.1, -0.01]).is_ok());
    }
}
