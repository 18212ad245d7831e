//! Spectrum references of the scene format, and the photometric
//! normalisation of light spectra.
//!
//! A reference is a flat number, `"FILE.csv:COLUMN"` (the column must
//! cover 380–780 nm: nothing extends silently), or
//! `{ csv = "FILE.csv:COLUMN", outside = "hold" | "zero" }`, which states
//! how the spectrum continues outside its measured range: `hold` keeps the
//! first sample's value below it and the last sample's value above it,
//! `zero` is 0 outside. Inside, values are linearly interpolated. The
//! extension adds samples at 380 and 780 nm (and, for `zero`, 0.001 nm
//! outside each end, so the step to 0 is sharp to 0.001 nm on any grid the
//! renderer resamples to).

use super::file::{ExtendedRef, Outside, SpectrumRef};
use super::{Loader, SceneError};
use crate::input_file::{read_text, unquoted};
use lightbooth_science::spectrum::table::{SpectraTable, TableError};
use lightbooth_science::spectrum::{Grid, SpectralUnit, Spectrum, SpectrumError};

/// Second radiation constant c₂ = hc/k in m·K (CODATA 2018, as CIE 15:2018).
const C2_M_K: f64 = 1.438_776_877e-2;

/// The range every spectrum must cover, nm.
const RANGE_NM: (f64, f64) = (380.0, 780.0);

/// Distance of the `zero` rule's extra sample from the measured end, nm.
const ZERO_STEP_NM: f64 = 1e-3;

impl Loader {
    /// The CSV `rel` (relative to the scene), read once.
    pub(super) fn table(&mut self, rel: &str, key: &str) -> Result<&SpectraTable, SceneError> {
        let path = self.dir.join(rel);
        if !self.tables.contains_key(&path) {
            let text = read_text(&path).map_err(|e| self.err(key, e.to_string()))?;
            let t =
                SpectraTable::parse(&text, &path.display().to_string()).map_err(|e| self.table_err(&path, key, e))?;
            self.files.push(path.clone());
            self.tables.insert(path.clone(), t);
        }
        Ok(&self.tables[&path])
    }

    /// The error `e` about the table at `path`: as it is for a file in the
    /// scene's folder; for one outside, its file and line only.
    fn table_err(&self, path: &std::path::Path, key: &str, e: TableError) -> SceneError {
        if self.quoting.may_quote(path) {
            return self.err(key, e.to_string());
        }
        let at = e.line.map(|l| format!(":{l}")).unwrap_or_default();
        self.err(
            key,
            format!(
                "{}{at}: {}",
                path.display(),
                unquoted("not a usable spectra CSV (`nm,<name>,…`) or not the column named")
            ),
        )
    }

    /// A spectrum reference in `unit`, covering 380–780 nm (extended by its
    /// `outside` rule where it does not).
    pub(super) fn spectrum(&mut self, r: &SpectrumRef, unit: SpectralUnit, key: &str) -> Result<Spectrum, SceneError> {
        let (spec, outside) = match r {
            SpectrumRef::Flat(v) => {
                return Spectrum::constant(Grid::analysis(), unit, *v).map_err(|e| self.err(key, e.to_string()))
            }
            SpectrumRef::File(spec) => (spec, None),
            SpectrumRef::Extended(ExtendedRef { csv, outside }) => (csv, Some(*outside)),
        };
        let (file, column) = spec.rsplit_once(':').ok_or_else(|| {
            self.err(
                key,
                format!(
                    "`{spec}`: expected FILE.csv:COLUMN (or a number, or {{ csv = \"FILE.csv:COLUMN\", outside = … }})"
                ),
            )
        })?;
        let s = match self.table(file, key)?.spectrum(column, unit) {
            Ok(s) => s,
            Err(e) => return Err(self.table_err(&self.dir.join(file), key, e)),
        };
        if s.grid().covers(RANGE_NM.0, RANGE_NM.1) {
            return Ok(s);
        }
        match outside {
            Some(rule) => extend(&s, rule).map_err(|e| self.err(key, e.to_string())),
            None => Err(self.err(key, short_spectrum_message(spec, &s))),
        }
    }

    /// A light spectrum's shape on the 1 nm grid: Planck's law at
    /// `blackbody_k`, or the `spd` reference; exactly one of the two.
    pub(super) fn spd_1nm(
        &mut self,
        blackbody_k: Option<f64>,
        spd: Option<&SpectrumRef>,
        key: &dyn Fn(&str) -> String,
    ) -> Result<Vec<f64>, SceneError> {
        match (blackbody_k, spd) {
            (Some(t), None) => {
                let t = super::positive(t, self, &key("blackbody_k"))?;
                Ok(blackbody_1nm(t))
            }
            (None, Some(r)) => {
                let s = self.spectrum(r, SpectralUnit::RelativePower, &key("spd"))?;
                Ok(s.resample(&Grid::one_nm())
                    .map_err(|e| self.err(key("spd"), e.to_string()))?
                    .into_values())
            }
            _ => Err(self.err(key("spd"), "give exactly one of `blackbody_k` and `spd`")),
        }
    }
}

/// Relative spectral power of a blackbody at `t` K on the 1 nm grid
/// (Planck's law without its constant factor): λ⁻⁵ / (exp(c₂/(λT)) − 1).
fn blackbody_1nm(t: f64) -> Vec<f64> {
    Grid::one_nm()
        .wavelengths()
        .iter()
        .map(|nm| {
            let m = nm * 1e-9;
            m.powi(-5) / ((C2_M_K / (m * t)).exp() - 1.0)
        })
        .collect()
}

/// 683 lm/W · Σ S(λ)·V(λ)·1 nm of a spectrum on the 1 nm grid: luminance
/// for a radiance, candela for an intensity. A photometric input (a lamp's
/// cd, an IES file, an emission's cd/m²) is in V(λ) (CIE 1931 ȳ,
/// [`PHOTOMETRIC_OBSERVER`](lightbooth_science::colorimetry::PHOTOMETRIC_OBSERVER)),
/// never in the renderer's analysis observer (issue 46: Judd–Vos ȳ here left
/// every booth lamp 0.44 % dim).
pub(super) fn luminous_1nm(values: &[f64]) -> f64 {
    lightbooth_science::colorimetry::luminous_1nm(values)
}

/// The error for a column that stops short of 380–780 nm: its range, and
/// exactly what to write instead.
fn short_spectrum_message(spec: &str, s: &Spectrum) -> String {
    format!(
        "`{spec}` covers {}–{} nm, not 380–780 nm, and nothing extends a spectrum silently: \
         write {{ csv = \"{spec}\", outside = \"hold\" }} to continue its end values, \
         or outside = \"zero\" for 0 outside its range",
        s.grid().first_nm(),
        s.grid().last_nm()
    )
}

/// `s` continued to 380–780 nm by `rule` (see the module doc).
fn extend(s: &Spectrum, rule: Outside) -> Result<Spectrum, SpectrumError> {
    let (nm, v) = (s.grid().wavelengths(), s.values());
    let (first, last) = (nm[0], nm[nm.len() - 1]);
    let (v_first, v_last) = match rule {
        Outside::Hold => (v[0], v[v.len() - 1]),
        Outside::Zero => (0.0, 0.0),
    };
    let mut grid = Vec::with_capacity(nm.len() + 4);
    let mut values = Vec::with_capacity(nm.len() + 4);
    if first > RANGE_NM.0 {
        grid.push(RANGE_NM.0);
        values.push(v_first);
        if rule == Outside::Zero && first - ZERO_STEP_NM > RANGE_NM.0 {
            grid.push(first - ZERO_STEP_NM);
            values.push(0.0);
        }
    }
    grid.extend_from_slice(nm);
    values.extend_from_slice(v);
    if last < RANGE_NM.1 {
        if rule == Outside::Zero && last + ZERO_STEP_NM < RANGE_NM.1 {
            grid.push(last + ZERO_STEP_NM);
            values.push(0.0);
        }
        grid.push(RANGE_NM.1);
        values.push(v_last);
    }
    Spectrum::new(Grid::from_wavelengths(grid)?, s.unit(), values)
}
