//! A white reflectance standard's calibration: its spectral reflectance
//! factor (and, when the certificate gives it, the standard uncertainty) as
//! a spectra CSV, identified by its file name and the SHA-256 of its bytes,
//! so every reflectance computed from it can say exactly which calibration
//! it used.
//!
//! The CSV is the scene format's (`nm`, then columns; `#` comment lines):
//! the reflectance is the column named `reflectance`, else the first one;
//! the uncertainty the column named `uncertainty` (or `u`, or `<name>_u`).
//! Without one, the standard's uncertainty is taken as 0 and the result
//! says so ([`WhiteStandard::uncertainty_stated`]).
//!
//! Approximation: the certificate's reflectance factor (usually 8°/
//! hemispherical) is used in the booth's geometry, i.e. the standard is
//! taken as Lambertian. Spectralon is close to it at the booth's angles.

use sha2::{Digest, Sha256};

use super::CalibrationError;
use crate::spectrum::table::SpectraTable;
use crate::spectrum::{Grid, SpectralUnit, Spectrum};

/// Standards shipped with lightbooth: (name, file name, contents). The file
/// is also a scene spectrum (`scenes/spectra/`), so the simulated booth's
/// standard tile is made of exactly this calibration.
pub const SHIPPED: &[(&str, &str, &str)] = &[(
    "spectralon_99",
    "spectralon_99.csv",
    include_str!("../../../../scenes/spectra/spectralon_99.csv"),
)];

/// A parsed calibration.
#[derive(Clone, Debug)]
pub struct WhiteStandard {
    /// The file name as given (no directories are read through it).
    pub file_name: String,
    /// SHA-256 of the file's bytes, lower-case hex.
    pub sha256: String,
    reflectance: Spectrum,
    uncertainty: Option<Spectrum>,
}

/// Lower-case hex SHA-256 of `bytes`.
pub fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes).iter().map(|b| format!("{b:02x}")).collect()
}

impl WhiteStandard {
    /// Parses a calibration CSV; `file_name` names it in errors and in the
    /// provenance.
    pub fn parse(text: &str, file_name: &str) -> Result<WhiteStandard, CalibrationError> {
        let table = SpectraTable::parse(text, file_name)?;
        let names: Vec<String> = table.names().map(str::to_string).collect();
        let column = names
            .iter()
            .find(|n| n.eq_ignore_ascii_case("reflectance"))
            .unwrap_or(&names[0])
            .clone();
        let uncertainty_column = names.iter().find(|n| {
            n.eq_ignore_ascii_case("uncertainty") || n.eq_ignore_ascii_case("u") || **n == format!("{column}_u")
        });
        let reflectance = table.spectrum(&column, SpectralUnit::Reflectance)?;
        if let Some(i) = reflectance.values().iter().position(|v| *v <= 0.0) {
            return Err(CalibrationError::Standard(format!(
                "in {file_name} is {} at {} nm: a white standard reflects at every wavelength",
                reflectance.values()[i],
                reflectance.grid().wavelengths()[i]
            )));
        }
        let uncertainty = match uncertainty_column {
            Some(u) => Some(table.spectrum(u, SpectralUnit::Reflectance)?),
            None => None,
        };
        Ok(WhiteStandard {
            file_name: file_name.to_string(),
            sha256: sha256_hex(text.as_bytes()),
            reflectance,
            uncertainty,
        })
    }

    /// A standard shipped with lightbooth, by name (see [`SHIPPED`]).
    pub fn shipped(name: &str) -> Option<WhiteStandard> {
        SHIPPED
            .iter()
            .find(|(n, _, _)| *n == name)
            .map(|(_, file, text)| WhiteStandard::parse(text, file).expect("a shipped standard parses"))
    }

    /// True when the calibration states its uncertainty.
    pub fn uncertainty_stated(&self) -> bool {
        self.uncertainty.is_some()
    }

    /// Reflectance and its standard uncertainty linearly interpolated onto
    /// the instrument's grid, which the calibration must cover.
    pub fn on_grid(&self, wavelength_nm: &[f64]) -> Result<(Vec<f64>, Vec<f64>), CalibrationError> {
        let grid = Grid::from_wavelengths(wavelength_nm.to_vec())
            .map_err(|e| CalibrationError::Inconsistent(format!("the instrument's grid: {e}")))?;
        let cal = self.reflectance.grid();
        if !cal.covers(grid.first_nm(), grid.last_nm()) {
            return Err(CalibrationError::Standard(format!(
                "in {} covers {}–{} nm, but the instrument measured {}–{} nm: give a calibration \
                 that covers the instrument's range (nothing is extrapolated)",
                self.file_name,
                cal.first_nm(),
                cal.last_nm(),
                grid.first_nm(),
                grid.last_nm()
            )));
        }
        let resample = |s: &Spectrum| {
            s.resample(&grid)
                .map(Spectrum::into_values)
                .map_err(|e| CalibrationError::Standard(format!("in {}: {e}", self.file_name)))
        };
        let rho = resample(&self.reflectance)?;
        let u = match &self.uncertainty {
            Some(u) => resample(u)?,
            None => vec![0.0; rho.len()],
        };
        Ok((rho, u))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sha256_of_known_text() {
        // FIPS 180-2, appendix B.1.
        assert_eq!(
            sha256_hex(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
    }

    #[test]
    fn columns_are_found_by_name_and_interpolated_onto_the_grid() {
        let s = WhiteStandard::parse(
            "# cert 123\nnm,u,reflectance\n380,0.01,0.9\n400,0.03,0.98\n",
            "cert.csv",
        )
        .unwrap();
        assert!(s.uncertainty_stated());
        let (rho, u) = s.on_grid(&[380.0, 390.0, 400.0]).unwrap();
        assert_eq!(rho.len(), 3);
        assert!((rho[1] - 0.94).abs() < 1e-12 && (u[1] - 0.02).abs() < 1e-12);
        let e = s.on_grid(&[380.0, 404.0]).unwrap_err().to_string();
        assert!(
            e.contains("cert.csv covers 380–400 nm, but the instrument measured 380–404 nm"),
            "{e}"
        );
    }

    #[test]
    fn malformed_or_impossible_standards_name_file_and_line() {
        let e = WhiteStandard::parse("nm,reflectance\n380,0.99\n384,0.99x\n", "std.csv").unwrap_err();
        assert_eq!(
            e.to_string(),
            "std.csv:3: column 2 (reflectance): `0.99x` is not a number"
        );
        let e = WhiteStandard::parse("nm,reflectance\n380,0.99\n384,1.2\n", "std.csv").unwrap_err();
        assert!(e.to_string().starts_with("std.csv:3: column 2 (reflectance)"), "{e}");
        let e = WhiteStandard::parse("nm,reflectance\n380,0.99\n384,0\n", "std.csv").unwrap_err();
        assert!(e.to_string().contains("is 0 at 384 nm"), "{e}");
    }

    #[test]
    fn the_shipped_spectralon_is_0_99_with_its_stated_uncertainty() {
        let s = WhiteStandard::shipped("spectralon_99").unwrap();
        let (rho, u) = s.on_grid(Grid::pr650().wavelengths()).unwrap();
        assert!(rho.iter().all(|r| (r - 0.99).abs() < 1e-12));
        assert!(u.iter().all(|u| (u - 0.005).abs() < 1e-12));
        assert_eq!(s.sha256, sha256_hex(SHIPPED[0].2.as_bytes()));
    }
}
