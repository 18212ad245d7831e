//! From spectra to colour: CIE XYZ, chromaticity, CIELAB, colour differences
//! and RGB spaces.
//!
//! # The integration rule
//!
//! Every tristimulus value in lightbooth is a plain sum over the spectrum's own
//! grid, as CIE 15 computes at 5 nm:
//!
//! ```text
//! X = k · Σᵢ S(λᵢ) · x̄(λᵢ) · Δλ        (likewise Y with ȳ, Z with z̄)
//! ```
//!
//! - λᵢ are the spectrum's wavelengths and Δλ its (uniform) grid step; a
//!   non-uniform grid is an error, resample it first.
//! - x̄(λᵢ) is the matching-function table's own row where it has one, and a
//!   linear interpolation between its two neighbouring rows otherwise (a
//!   PR-650's 384 nm under the 5 nm Judd–Vos table). Outside the table
//!   the matching functions are zero. The tables cover 380–780 nm, except
//!   the CIE 2015 2° and 10° observers', which start at 390 nm as CVRL
//!   publishes them (x̄ there is below 0.4 % of its peak; what is left out
//!   below 390 nm is said in `reference_data/PROVENANCE.md`).
//! - No trapezoid end weights, no ASTM E308 weighting tables.
//! - The grid must cover what the sum needs: all of 380–780 nm
//!   ([`INTEGRATION_RANGE_NM`]) at a step of at most
//!   [`MAX_INTEGRATION_STEP_NM`]. Anything else is an error naming the grid
//!   found and the one needed ([`ColorError::Coverage`]) — there is no
//!   extrapolation: a 400–700 nm table is extended (or resampled) by the
//!   user, who then says how. A sum that overflows (values near `f64::MAX`)
//!   is an error too, never an infinite or NaN XYZ.
//! - Absolute: k = Km = 683 lm/W and S a spectral radiance in W/(sr·m²·nm),
//!   so Y is luminance in cd/m².
//! - Relative: k = 100 / Σ E(λᵢ)·ȳ(λᵢ)·Δλ for the illuminant E on the same
//!   grid, so a perfect white has Y = 100.
//!
//! The default observer is Judd–Vos (1978), as in the study.
//!
//! ```
//! use lightbooth_science::colorimetry::{xyz_relative, Observer};
//! use lightbooth_science::reference_data::{illuminant, Illuminant};
//! use lightbooth_science::spectrum::{Grid, Spectrum, SpectralUnit};
//! let white = Spectrum::constant(Grid::analysis(), SpectralUnit::Reflectance, 1.0).unwrap();
//! let xyz = xyz_relative(&white, &illuminant(Illuminant::D65), Observer::Cie1931).unwrap();
//! let xy = xyz.chromaticity();
//! assert!((xy.x - 0.3127).abs() < 1e-4 && (xy.y - 0.3290).abs() < 1e-4);
//! ```

pub mod cielab;
pub mod rgb;

use std::fmt;
use std::str::FromStr;
use std::sync::OnceLock;

use serde::Serialize;

use crate::reference_data;
use crate::spectrum::{interpolate_clamped, Grid, SpectralUnit, Spectrum, SpectrumError};

pub use cielab::{ciede2000, delta_e76, Lab};

/// The maximum luminous efficacy of radiation for photopic vision, lm/W.
pub const KM_LM_PER_W: f64 = 683.0;

/// The observer of every photometric *input*: a candela, a lumen, a cd/m²
/// and every IES file are defined by V(λ), the CIE 1924 photopic luminous
/// efficiency function, tabulated as CIE 1931's ȳ (CIE S 017, ISO 23539),
/// whatever observer the analysis uses. Turn a number given in cd, lm or
/// cd/m² into W with it ([`luminous_1nm`]); weight what is computed from
/// spectra with the analysis observer.
pub const PHOTOMETRIC_OBSERVER: Observer = Observer::Cie1931;

/// 683 lm/W · Σ S(λ)·V(λ)·1 nm of `values` on [`Grid::one_nm`], V(λ) the
/// [`PHOTOMETRIC_OBSERVER`]'s ȳ: the luminance (cd/m²) of a spectral
/// radiance, the candela of a spectral intensity, as photometric inputs
/// are stated. Values beyond the grid's length are ignored.
pub fn luminous_1nm(values: &[f64]) -> f64 {
    static V: OnceLock<Vec<f64>> = OnceLock::new();
    let v = V.get_or_init(|| {
        let [_, y, _] = Cmf::of(PHOTOMETRIC_OBSERVER).on_grid(&Grid::one_nm());
        y
    });
    KM_LM_PER_W * values.iter().zip(v).map(|(s, y)| s * y).sum::<f64>()
}

/// The standard observer whose matching functions turn spectra into XYZ.
///
/// Serialised (JSON, CSV/MAT headers, store columns) by [`Observer::name`]:
/// `judd-vos-1978`, `cie-1931`, `cie-1964-10`, `cie-2015-2` or
/// `cie-2015-10`; parsing also accepts the older spellings `judd-vos`,
/// `juddvos`, `cie1931` and `1931`, and `cie-2012-2`/`cie-2012-10` (CVRL's
/// name for the 2015 observers).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Observer {
    /// CIE 1931 2° modified by Judd (1951) and Vos (1978): the study's observer.
    #[default]
    JuddVos,
    /// CIE 1931 2° standard observer.
    Cie1931,
    /// CIE 1964 10° supplementary standard observer.
    Cie1964Ten,
    /// CIE 170-2:2015 2° "physiologically relevant" observer (CVRL's "CIE
    /// 2012"), a linear transform of the Stockman & Sharpe 2° cone
    /// fundamentals. Its table starts at 390 nm.
    Cie2015Two,
    /// CIE 170-2:2015 10° observer, from the 10° cone fundamentals. Its
    /// table starts at 390 nm.
    Cie2015Ten,
}

impl FromStr for Observer {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "judd-vos" | "juddvos" | "judd-vos-1978" => Ok(Observer::JuddVos),
            "cie1931" | "cie-1931" | "1931" => Ok(Observer::Cie1931),
            "cie-1964-10" => Ok(Observer::Cie1964Ten),
            "cie-2015-2" | "cie-2012-2" => Ok(Observer::Cie2015Two),
            "cie-2015-10" | "cie-2012-10" => Ok(Observer::Cie2015Ten),
            _ => Err(format!(
                "unknown observer `{s}`: choose one of {}",
                Observer::ALL.map(Observer::name).join(", ")
            )),
        }
    }
}

impl Observer {
    /// Every observer lightbooth ships, the default first.
    pub const ALL: [Observer; 5] = [
        Observer::JuddVos,
        Observer::Cie1931,
        Observer::Cie1964Ten,
        Observer::Cie2015Two,
        Observer::Cie2015Ten,
    ];

    /// The name every output uses: `judd-vos-1978`, `cie-1931`,
    /// `cie-1964-10`, `cie-2015-2` or `cie-2015-10`.
    pub fn name(self) -> &'static str {
        match self {
            Observer::JuddVos => "judd-vos-1978",
            Observer::Cie1931 => "cie-1931",
            Observer::Cie1964Ten => "cie-1964-10",
            Observer::Cie2015Two => "cie-2015-2",
            Observer::Cie2015Ten => "cie-2015-10",
        }
    }

    /// The observer as a person reads it in a figure or a table:
    /// `Judd–Vos 1978 2°`, `CIE 1964 10°`…
    pub fn label(self) -> &'static str {
        match self {
            Observer::JuddVos => "Judd–Vos 1978 2°",
            Observer::Cie1931 => "CIE 1931 2°",
            Observer::Cie1964Ten => "CIE 1964 10°",
            Observer::Cie2015Two => "CIE 2015 2°",
            Observer::Cie2015Ten => "CIE 2015 10°",
        }
    }

    /// The visual field the observer's matching functions are for, in
    /// degrees: 2 or 10.
    pub fn field_degrees(self) -> u32 {
        match self {
            Observer::JuddVos | Observer::Cie1931 | Observer::Cie2015Two => 2,
            Observer::Cie1964Ten | Observer::Cie2015Ten => 10,
        }
    }

    /// The cone fundamentals of the observer's field (Stockman & Sharpe 2°
    /// or 10°): what an LMS beside this observer's XYZ is computed with.
    pub fn cone_fundamentals(self) -> ConeFundamentals {
        if self.field_degrees() == 10 {
            ConeFundamentals::StockmanSharpe10
        } else {
            ConeFundamentals::StockmanSharpe2
        }
    }
}

/// The Stockman & Sharpe (2000) cone fundamentals l̄, m̄, s̄ (linear energy
/// units, each peaking at 1), the basis of the CIE 170-1:2006 and 170-2:2015
/// observers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ConeFundamentals {
    /// 2° field.
    StockmanSharpe2,
    /// 10° field.
    StockmanSharpe10,
}

impl ConeFundamentals {
    /// The weights a_L, a_M of CIE 170-1:2006's luminous efficiency
    /// V_F(λ) = a_L·l̄(λ) + a_M·m̄(λ) (S cones do not contribute), for
    /// fundamentals each peaking at 1. CIE 170-2:2015, table 4 (2°:
    /// 0.68990272, 0.34832189; 10°: 0.69283932, 0.34967567).
    pub fn luminance_weights(self) -> [f64; 2] {
        match self {
            ConeFundamentals::StockmanSharpe2 => [0.689_902_72, 0.348_321_89],
            ConeFundamentals::StockmanSharpe10 => [0.692_839_32, 0.349_675_67],
        }
    }

    /// l̄, m̄, s̄ on the 380–780 nm, 1 nm grid. The tables start at 390 nm;
    /// 380–389 nm are taken as 0 (an approximation: at 390 nm l̄ is 4·10⁻⁴
    /// of its peak and s̄ 1·10⁻² (2°) or 6·10⁻³ (10°)). CVRL leaves the 10°
    /// s̄ blank above 615 nm (below 3·10⁻⁶ of its peak): 0 here.
    pub fn on_1nm_grid(self) -> &'static [Vec<f64>; 3] {
        static CELLS: [OnceLock<[Vec<f64>; 3]>; 2] = [const { OnceLock::new() }; 2];
        let (cell, table) = match self {
            ConeFundamentals::StockmanSharpe2 => (&CELLS[0], "stockman_sharpe_2deg_cone_fundamentals"),
            ConeFundamentals::StockmanSharpe10 => (&CELLS[1], "stockman_sharpe_10deg_cone_fundamentals"),
        };
        cell.get_or_init(|| {
            let t = reference_data::builtin_table(table).expect("the fundamentals are embedded");
            ["l", "m", "s"].map(|name| {
                let s = t
                    .spectrum(name, SpectralUnit::RelativePower)
                    .unwrap_or_else(|e| panic!("embedded data is corrupt: {e}"));
                Grid::one_nm()
                    .wavelengths()
                    .iter()
                    .map(|&nm| s.value_at(nm).unwrap_or(0.0))
                    .collect()
            })
        })
    }
}

impl fmt::Display for Observer {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl Serialize for Observer {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

impl<'de> serde::Deserialize<'de> for Observer {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let name = String::deserialize(d)?;
        name.parse().map_err(serde::de::Error::custom)
    }
}

/// Colour-matching functions x̄, ȳ, z̄ as tabulated.
#[derive(Debug)]
pub struct Cmf {
    pub observer: Observer,
    grid: Grid,
    bars: [Vec<f64>; 3],
}

impl Cmf {
    /// The shipped table of an observer, parsed once.
    pub fn of(observer: Observer) -> &'static Cmf {
        static CELLS: [OnceLock<Cmf>; 5] = [const { OnceLock::new() }; 5];
        let index = Observer::ALL
            .iter()
            .position(|o| *o == observer)
            .expect("every observer is in ALL");
        CELLS[index].get_or_init(|| {
            let file = match observer {
                Observer::JuddVos => "judd_vos_1978_cmf",
                Observer::Cie1931 => "cie1931_2deg_cmf",
                Observer::Cie1964Ten => "cie1964_10deg_cmf",
                Observer::Cie2015Two => "cie2015_2deg_cmf",
                Observer::Cie2015Ten => "cie2015_10deg_cmf",
            };
            let table = reference_data::builtin_table(file).expect("every observer's table is embedded");
            let col = |name: &str| {
                table
                    .spectrum(name, SpectralUnit::RelativePower)
                    .expect("embedded CMF")
                    .into_values()
            };
            Cmf {
                observer,
                grid: table.grid().clone(),
                bars: [col("xbar"), col("ybar"), col("zbar")],
            }
        })
    }

    /// The table's own wavelengths.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// x̄, ȳ, z̄ at `nm`: the table's row, a linear interpolation between rows,
    /// or zero outside the table.
    pub fn at(&self, nm: f64) -> [f64; 3] {
        let w = self.grid.wavelengths();
        if nm < w[0] - 1e-6 || nm > w[w.len() - 1] + 1e-6 {
            return [0.0; 3];
        }
        std::array::from_fn(|c| interpolate_clamped(w, &self.bars[c], nm))
    }

    /// x̄, ȳ, z̄ sampled at every wavelength of `grid` (see [`Cmf::at`]).
    pub fn on_grid(&self, grid: &Grid) -> [Vec<f64>; 3] {
        let mut out: [Vec<f64>; 3] = Default::default();
        for &nm in grid.wavelengths() {
            let v = self.at(nm);
            for c in 0..3 {
                out[c].push(v[c]);
            }
        }
        out
    }

    /// Σ S·x̄·Δλ, Σ S·ȳ·Δλ, Σ S·z̄·Δλ over the spectrum's grid (no Km).
    pub fn integrate(&self, values: &[f64], grid: &Grid, step_nm: f64) -> [f64; 3] {
        let mut sums = [0.0; 3];
        for (&nm, &v) in grid.wavelengths().iter().zip(values) {
            let bar = self.at(nm);
            for c in 0..3 {
                sums[c] += v * bar[c];
            }
        }
        sums.map(|s| s * step_nm)
    }
}

/// CIE XYZ tristimulus values. Absolute ones (from radiance) have Y in cd/m²;
/// relative ones (from a reflectance) have Y = 100 for a perfect white.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Xyz {
    #[serde(rename = "X")]
    pub x: f64,
    #[serde(rename = "Y")]
    pub y: f64,
    #[serde(rename = "Z")]
    pub z: f64,
}

/// CIE 1931 chromaticity coordinates x, y.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Chromaticity {
    pub x: f64,
    pub y: f64,
}

/// CIE 1976 UCS chromaticity u′, v′.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct UvPrime {
    pub u: f64,
    pub v: f64,
}

impl Xyz {
    pub const fn new(x: f64, y: f64, z: f64) -> Xyz {
        Xyz { x, y, z }
    }

    pub fn to_array(self) -> [f64; 3] {
        [self.x, self.y, self.z]
    }

    pub fn from_array(a: [f64; 3]) -> Xyz {
        Xyz {
            x: a[0],
            y: a[1],
            z: a[2],
        }
    }

    /// x = X/(X+Y+Z), y = Y/(X+Y+Z); (0, 0) for black.
    pub fn chromaticity(self) -> Chromaticity {
        let sum = self.x + self.y + self.z;
        if sum == 0.0 {
            return Chromaticity { x: 0.0, y: 0.0 };
        }
        Chromaticity {
            x: self.x / sum,
            y: self.y / sum,
        }
    }

    /// u′ = 4X/(X+15Y+3Z), v′ = 9Y/(X+15Y+3Z); (0, 0) for black.
    pub fn uv_prime(self) -> UvPrime {
        let d = self.x + 15.0 * self.y + 3.0 * self.z;
        if d == 0.0 {
            return UvPrime { u: 0.0, v: 0.0 };
        }
        UvPrime {
            u: 4.0 * self.x / d,
            v: 9.0 * self.y / d,
        }
    }

    /// Every component times `k`.
    pub fn scaled(self, k: f64) -> Xyz {
        Xyz {
            x: self.x * k,
            y: self.y * k,
            z: self.z * k,
        }
    }
}

impl Chromaticity {
    /// XYZ of this chromaticity at luminance `y_lum`.
    pub fn to_xyz(self, y_lum: f64) -> Xyz {
        Xyz {
            x: self.x / self.y * y_lum,
            y: y_lum,
            z: (1.0 - self.x - self.y) / self.y * y_lum,
        }
    }

    /// Euclidean distance in the x,y diagram.
    pub fn distance(self, other: Chromaticity) -> f64 {
        (self.x - other.x).hypot(self.y - other.y)
    }
}

/// The wavelengths a tristimulus sum needs: the matching functions' table.
pub const INTEGRATION_RANGE_NM: (f64, f64) = (380.0, 780.0);

/// The coarsest grid step the plain sum is used with, nm. CIE 15 tabulates at
/// 5 nm; at 10 nm the sum still follows the matching functions' peaks, at
/// 20 nm and above it does not.
pub const MAX_INTEGRATION_STEP_NM: f64 = 10.0;

/// Errors of colorimetric computations.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ColorError {
    #[error(transparent)]
    Spectrum(#[from] SpectrumError),
    #[error("{0}")]
    Unit(String),
    #[error(
        "the grid {found} does not cover what the XYZ integration needs: {}–{} nm at a step of at most {} nm \
         (no extrapolation: extend or resample the data first)",
        INTEGRATION_RANGE_NM.0,
        INTEGRATION_RANGE_NM.1,
        MAX_INTEGRATION_STEP_NM
    )]
    Coverage { found: Grid },
    #[error("the XYZ sum overflows: the spectrum's values are too large to integrate (up to {max:e})")]
    Overflow { max: f64 },
}

/// Errors unless `grid` covers [`INTEGRATION_RANGE_NM`] at a step of at most
/// [`MAX_INTEGRATION_STEP_NM`] (no gap between neighbouring wavelengths wider).
pub fn require_integration_grid(grid: &Grid) -> Result<(), ColorError> {
    let (lo, hi) = INTEGRATION_RANGE_NM;
    let w = grid.wavelengths();
    let widest_gap = w.windows(2).map(|p| p[1] - p[0]).fold(0.0, f64::max);
    if !grid.covers(lo, hi) || widest_gap > MAX_INTEGRATION_STEP_NM + 1e-9 {
        return Err(ColorError::Coverage { found: grid.clone() });
    }
    Ok(())
}

/// The sums as XYZ, or [`ColorError::Overflow`] if any is not finite.
fn finite_xyz(sums: [f64; 3], values: &[f64]) -> Result<Xyz, ColorError> {
    if sums.iter().all(|v| v.is_finite()) {
        Ok(Xyz::from_array(sums))
    } else {
        Err(ColorError::Overflow {
            max: values.iter().fold(0.0, |m, v| m.max(v.abs())),
        })
    }
}

/// Absolute XYZ of a spectral radiance (W/(sr·m²·nm); per-band radiance is
/// converted to per nm first): Y is luminance in cd/m². A spectral
/// irradiance gives illuminance in lux the same way.
pub fn xyz_from_radiance(spectrum: &Spectrum, observer: Observer) -> Result<Xyz, ColorError> {
    let per_nm = spectrum.to_per_nm();
    match per_nm.unit() {
        SpectralUnit::SpectralRadiance | SpectralUnit::SpectralIrradiance => {}
        other => {
            return Err(ColorError::Unit(format!(
                "absolute XYZ needs a spectral radiance or irradiance, not {other}; \
                 for a reflectance use relative XYZ under an illuminant"
            )))
        }
    }
    require_integration_grid(per_nm.grid())?;
    let step = per_nm.uniform_step("XYZ")?;
    let s = Cmf::of(observer).integrate(per_nm.values(), per_nm.grid(), step);
    finite_xyz(s.map(|v| v * KM_LM_PER_W), per_nm.values())
}

/// Relative XYZ (perfect white Y = 100) of a reflectance under an
/// illuminant on the same grid.
pub fn xyz_relative(reflectance: &Spectrum, illuminant: &Spectrum, observer: Observer) -> Result<Xyz, ColorError> {
    let signal = reflectance.illuminated_by(illuminant)?;
    xyz_of_signal(&signal, illuminant, observer)
}

/// Relative XYZ of a colour signal (reflectance × illuminant, already
/// multiplied) normalised by the illuminant, so the illuminant itself has Y = 100.
pub fn xyz_of_signal(signal: &Spectrum, illuminant: &Spectrum, observer: Observer) -> Result<Xyz, ColorError> {
    signal.require_same_grid(illuminant)?;
    if !illuminant.unit().is_light() || !signal.unit().is_light() {
        return Err(ColorError::Unit(format!(
            "relative XYZ needs light for the signal and the illuminant, got {} and {}",
            signal.unit(),
            illuminant.unit()
        )));
    }
    require_integration_grid(signal.grid())?;
    let step = signal.uniform_step("XYZ")?;
    let cmf = Cmf::of(observer);
    let white = finite_xyz(
        cmf.integrate(illuminant.values(), illuminant.grid(), step),
        illuminant.values(),
    )?;
    let white = white.to_array();
    if white[1] <= 0.0 {
        return Err(ColorError::Unit("the illuminant has no luminance on this grid".into()));
    }
    let k = 100.0 / white[1];
    let s = cmf.integrate(signal.values(), signal.grid(), step);
    finite_xyz(s.map(|v| v * k), signal.values())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::reference_data::{illuminant, illuminant_1nm, Illuminant};

    /// CIE 15:2004 Table T.3: D65 with the 1931 observer has x = 0.31272,
    /// y = 0.32903 (the 5 nm sum; 0.3127, 0.3290 to four decimals).
    #[test]
    fn d65_white_point_matches_cie_15() {
        let white = Spectrum::constant(Grid::analysis(), SpectralUnit::Reflectance, 1.0).unwrap();
        let xyz = xyz_relative(&white, &illuminant(Illuminant::D65), Observer::Cie1931).unwrap();
        let xy = xyz.chromaticity();
        assert!((xy.x - 0.3127).abs() < 1e-4, "x = {}", xy.x);
        assert!((xy.y - 0.3290).abs() < 1e-4, "y = {}", xy.y);
        assert!((xyz.y - 100.0).abs() < 1e-12);
        // CIE 15:2004 Table T.3 also gives X = 95.04, Z = 108.88 (5 nm, 1931).
        assert!((xyz.x - 95.04).abs() < 0.01, "X = {}", xyz.x);
        assert!((xyz.z - 108.88).abs() < 0.01, "Z = {}", xyz.z);
        // The 1 nm table gives the same white point.
        let white1 = Spectrum::constant(Grid::one_nm(), SpectralUnit::Reflectance, 1.0).unwrap();
        let xy1 = xyz_relative(&white1, &illuminant_1nm(Illuminant::D65).unwrap(), Observer::Cie1931)
            .unwrap()
            .chromaticity();
        assert!((xy1.x - 0.3127).abs() < 1e-4 && (xy1.y - 0.3290).abs() < 1e-4);
    }

    /// CIE 15:2004 Table T.3: illuminant A, 1931 observer: x = 0.44757, y = 0.40745.
    #[test]
    fn illuminant_a_white_point_matches_cie_15() {
        let white = Spectrum::constant(Grid::analysis(), SpectralUnit::Reflectance, 1.0).unwrap();
        let xy = xyz_relative(&white, &illuminant(Illuminant::A), Observer::Cie1931)
            .unwrap()
            .chromaticity();
        assert!((xy.x - 0.44757).abs() < 1e-4 && (xy.y - 0.40745).abs() < 1e-4, "{xy:?}");
    }

    /// An equal-energy spectrum of 1/683 W/(sr·m²·nm) has Y = Σ ȳ·Δλ, which for
    /// the CIE 1931 observer at 1 nm is 106.856… (the area under V(λ), 380–780).
    #[test]
    fn absolute_luminance_uses_683_lm_per_w() {
        let s = Spectrum::constant(Grid::one_nm(), SpectralUnit::SpectralRadiance, 1.0 / 683.0).unwrap();
        let y = xyz_from_radiance(&s, Observer::Cie1931).unwrap().y;
        let area: f64 = Cmf::of(Observer::Cie1931).on_grid(&Grid::one_nm())[1].iter().sum();
        assert!((y - area).abs() < 1e-9);
        assert!((area - 106.857).abs() < 0.01, "area under ybar = {area}");
        // The same light as per-band values gives the same luminance.
        let band = s.to_per_band().unwrap();
        assert!((xyz_from_radiance(&band, Observer::Cie1931).unwrap().y - y).abs() < 1e-9);
    }

    #[test]
    fn a_pr650_grid_takes_interpolated_judd_vos_rows() {
        let cmf = Cmf::of(Observer::JuddVos);
        let a = cmf.at(380.0);
        let b = cmf.at(385.0);
        let mid = cmf.at(384.0);
        for c in 0..3 {
            assert!((mid[c] - (a[c] + 0.8 * (b[c] - a[c]))).abs() < 1e-15);
        }
        assert_eq!(cmf.at(379.0), [0.0; 3]);
    }

    #[test]
    fn observer_is_named_with_its_year_and_reads_old_spellings() {
        assert_eq!(Observer::JuddVos.to_string(), "judd-vos-1978");
        assert_eq!(Observer::Cie1931.to_string(), "cie-1931");
        assert_eq!(serde_json::to_string(&Observer::Cie1931).unwrap(), "\"cie-1931\"");
        for (old, o) in [
            ("judd-vos", Observer::JuddVos),
            ("juddvos", Observer::JuddVos),
            ("judd-vos-1978", Observer::JuddVos),
            ("cie1931", Observer::Cie1931),
            ("cie-1931", Observer::Cie1931),
        ] {
            assert_eq!(old.parse::<Observer>().unwrap(), o);
            assert_eq!(serde_json::from_str::<Observer>(&format!("\"{old}\"")).unwrap(), o);
        }
        assert!("cie1964".parse::<Observer>().is_err());
        for o in Observer::ALL {
            assert_eq!(o.name().parse::<Observer>().unwrap(), o);
            assert_eq!(
                serde_json::from_str::<Observer>(&serde_json::to_string(&o).unwrap()).unwrap(),
                o
            );
        }
        assert_eq!("cie-2012-10".parse::<Observer>().unwrap(), Observer::Cie2015Ten);
        let e = "cie-2006".parse::<Observer>().unwrap_err();
        assert!(e.contains("cie-1964-10, cie-2015-2, cie-2015-10"), "{e}");
    }

    /// CIE 15:2018 Table 9.1 (also CIE 15:2004 Table T.3): D65 with the CIE
    /// 1964 10° observer has x₁₀ = 0.31382, y₁₀ = 0.33100.
    #[test]
    fn d65_white_point_in_the_1964_ten_degree_observer_matches_cie_15() {
        let white = Spectrum::constant(Grid::one_nm(), SpectralUnit::Reflectance, 1.0).unwrap();
        let d65 = illuminant_1nm(Illuminant::D65).unwrap();
        let xy = xyz_relative(&white, &d65, Observer::Cie1964Ten).unwrap().chromaticity();
        assert!((xy.x - 0.31382).abs() < 5e-5 && (xy.y - 0.33100).abs() < 5e-5, "{xy:?}");
    }

    /// CIE 170-2:2015 defines its 2° and 10° observers as a linear
    /// transform of the Stockman & Sharpe cone fundamentals, x̄ȳz̄_F = M·l̄m̄s̄
    /// (the matrices of CIE 170-2:2015, eq. 8.2 and 8.3; ȳ_F is the 2006
    /// V_F). The shipped 2015 tables (CVRL `lin2012xyz*e_1_7sf`, 7
    /// significant figures) and the shipped fundamentals (CVRL
    /// `linss*e_1`, 6 figures) are two tables: this checks one against the
    /// other through the standard's own definition.
    #[test]
    fn the_2015_observers_are_the_cie_170_2_transform_of_the_cone_fundamentals() {
        let cases = [
            (
                Observer::Cie2015Two,
                [
                    [1.947_354_69, -1.414_451_23, 0.364_763_27],
                    [0.689_902_72, 0.348_321_89, 0.0],
                    [0.0, 0.0, 1.934_853_43],
                ],
            ),
            (
                Observer::Cie2015Ten,
                [
                    [1.939_864_43, -1.346_643_59, 0.430_449_35],
                    [0.692_839_32, 0.349_675_67, 0.0],
                    [0.0, 0.0, 2.146_879_45],
                ],
            ),
        ];
        for (observer, m) in cases {
            let cones = observer.cone_fundamentals().on_1nm_grid();
            let cmf = Cmf::of(observer).on_grid(&Grid::one_nm());
            let mut worst = 0.0f64;
            for i in 10..401 {
                for r in 0..3 {
                    let from_cones: f64 = (0..3).map(|c| m[r][c] * cones[c][i]).sum();
                    worst = worst.max((from_cones - cmf[r][i]).abs());
                }
            }
            // The fundamentals' 6 figures: a rounding of 5·10⁻⁶ of values up
            // to 1, times matrix entries up to 2.
            assert!(worst < 3e-5, "{observer}: worst |M·lms − xyz| = {worst:e}");
            // Below 390 nm the 2015 tables have no rows: zero.
            assert_eq!(Cmf::of(observer).at(385.0), [0.0; 3]);
            assert!(Cmf::of(observer).at(390.0)[2] > 0.0);
        }
    }

    #[test]
    fn reflectance_is_refused_as_radiance() {
        let r = Spectrum::constant(Grid::analysis(), SpectralUnit::Reflectance, 0.5).unwrap();
        assert!(xyz_from_radiance(&r, Observer::JuddVos).is_err());
    }
}
