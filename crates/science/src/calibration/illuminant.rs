//! The lamp's relative spectral power distribution from one measurement of
//! the white standard in the booth (the study took its illuminants from the
//! WHITE scene): S(λ) ∝ L_standard(λ) / ρ_standard(λ), the spectral
//! irradiance on the standard up to the constant π.
//!
//! Normalisation: S(560 nm) = 100, the convention of the CIE's illuminant
//! tables. The scene format reads a light's `spd` as a relative power and
//! scales it itself to the luminaire's candela (or an emitter's luminance),
//! so only the shape matters there; the measurement's own luminance is kept
//! beside it.
//!
//! Uncertainty (k = 1), first order, independent terms:
//! u(S)² = k²·[(s_w/ρ_std)² + (L_w·u_std/ρ_std²)²], with k the normalisation
//! factor. The normalisation's own uncertainty (the noise of L_w at 560 nm)
//! scales every value alike and is not included.
//!
//! Approximation: what reaches the standard is the lamp *in the booth* —
//! through its filter, plus the light the booth reflects onto the standard.
//! Used as a point luminaire's `spd`, the booth's interreflections are
//! then counted twice, a small effect in a booth with black walls.

use super::{CalibrationError, MeanSpectrum};
use crate::spectrum::table::write_csv;
use crate::spectrum::Grid;

/// The wavelength where S is 100.
pub const NORMALISATION_NM: f64 = 560.0;

/// A relative SPD with its standard uncertainty.
#[derive(Clone, Debug, PartialEq)]
pub struct Illuminant {
    pub wavelength_nm: Vec<f64>,
    /// Relative spectral power, 100 at [`NORMALISATION_NM`].
    pub spd: Vec<f64>,
    pub uncertainty: Vec<f64>,
}

/// S(λ) and u(S) from the white standard's measurement and its reflectance
/// (ρ_std, u_std) on the same grid.
pub fn illuminant(
    white: &MeanSpectrum,
    standard_reflectance: (&[f64], &[f64]),
) -> Result<Illuminant, CalibrationError> {
    let (rho, u_rho) = standard_reflectance;
    if rho.len() != white.wavelength_nm.len() || u_rho.len() != rho.len() {
        return Err(CalibrationError::Inconsistent(
            "the standard's reflectance is not on the instrument's grid".into(),
        ));
    }
    let raw: Vec<f64> = white.mean.iter().zip(rho).map(|(l, r)| l / r).collect();
    let grid = Grid::from_wavelengths(white.wavelength_nm.clone())
        .map_err(|e| CalibrationError::Inconsistent(format!("the instrument's grid: {e}")))?;
    let at_ref = crate::spectrum::Spectrum::new(grid, crate::spectrum::SpectralUnit::RelativePower, raw.clone())
        .ok()
        .and_then(|s| s.value_at(NORMALISATION_NM));
    let k = match at_ref {
        Some(v) if v > 0.0 => 100.0 / v,
        Some(v) => {
            return Err(CalibrationError::Inconsistent(format!(
                "the white standard's radiance at {NORMALISATION_NM} nm is {v}: no lamp to normalise there"
            )))
        }
        None => {
            return Err(CalibrationError::Inconsistent(format!(
                "the instrument's grid does not reach {NORMALISATION_NM} nm, where the SPD is normalised"
            )))
        }
    };
    let spd = raw.iter().map(|s| k * s).collect();
    let uncertainty = (0..rho.len())
        .map(|i| {
            let (l, s, r, u) = (white.mean[i], white.standard_error[i], rho[i], u_rho[i]);
            k * ((s / r).powi(2) + (l * u / (r * r)).powi(2)).sqrt()
        })
        .collect();
    Ok(Illuminant {
        wavelength_nm: white.wavelength_nm.clone(),
        spd,
        uncertainty,
    })
}

/// The SPD as a scene spectrum CSV: `#` provenance lines, then
/// `nm,<column>,<column>_u` (a light's `spd = "FILE.csv:<column>"`).
pub fn scene_csv(s: &Illuminant, column: &str, provenance: &[String]) -> Result<String, String> {
    let grid = Grid::from_wavelengths(s.wavelength_nm.clone()).map_err(|e| e.to_string())?;
    let mut out = String::new();
    for line in provenance.iter().flat_map(|p| p.lines()) {
        out.push_str("# ");
        out.push_str(line);
        out.push('\n');
    }
    let mut body = Vec::new();
    let u_name = format!("{column}_u");
    write_csv(&mut body, &grid, &[(column, &s.spd), (&u_name, &s.uncertainty)]).map_err(|e| e.to_string())?;
    out.push_str(&String::from_utf8(body).map_err(|e| e.to_string())?);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spd_and_uncertainty_by_hand() {
        // L = 1, 2, 3 (SE 0.1 each) at 540, 560, 580 nm; ρ = 0.5, 0.8, 1.0 (u 0.01):
        // raw L/ρ = 2, 2.5, 3 → k = 40 → S = 80, 100, 120;
        // u(540) = 40·√((0.1/0.5)² + (1·0.01/0.25)²) = 40·√(0.04 + 0.0016).
        let white = MeanSpectrum {
            wavelength_nm: vec![540.0, 560.0, 580.0],
            mean: vec![1.0, 2.0, 3.0],
            standard_error: vec![0.1; 3],
            samples: 5,
        };
        let s = illuminant(&white, (&[0.5, 0.8, 1.0], &[0.01; 3])).unwrap();
        for (got, want) in s.spd.iter().zip([80.0, 100.0, 120.0]) {
            assert!((got - want).abs() < 1e-12, "{got} vs {want}");
        }
        assert!((s.uncertainty[0] - 40.0 * 0.0416f64.sqrt()).abs() < 1e-12);
        let csv = scene_csv(&s, "lamp", &["from measurement 3".into()]).unwrap();
        assert!(csv.starts_with("# from measurement 3\nnm,lamp,lamp_u\n540,"), "{csv}");
    }
}
