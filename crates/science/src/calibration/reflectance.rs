//! A material's spectral reflectance factor from two measurements in the
//! same geometry: the sample, and a white standard in its place,
//!
//! ρ(λ) = L_sample(λ) / L_standard(λ) · ρ_standard(λ),
//!
//! on the instrument's grid. With r = L_s/L_w and the standard errors
//! s_s, s_w of the two means and u_std of the standard's calibration,
//! taken as independent, to first order
//!
//! u(ρ)² = (ρ_std/L_w)²·s_s² + (ρ_std·L_s/L_w²)²·s_w² + r²·u_std².
//!
//! Values above 1 (a fluorescent sample, a standard dirtier than its
//! certificate, a geometry that was not the same) and below 0 (noise on a
//! black sample) are kept as computed and flagged, never clipped. Where the
//! standard's radiance is not clearly above zero the ratio is undefined and
//! the computation is refused ([`super::dark_wavelengths`]).
//!
//! Approximations: the instrument's slit (8 nm FWHM for the PR-650) averages
//! both radiances before the ratio, so ρ is the slit-weighted mean of the
//! true reflectance, weighted by the lamp's spectrum — exact for a flat
//! standard and a reflectance linear across the slit; the geometry must be
//! the same (the standard is measured in the sample's place).

use serde::Serialize;

use super::{dark_wavelengths, CalibrationError, MeanSpectrum};
use crate::spectrum::table::write_csv;
use crate::spectrum::Grid;

/// Where a reflectance leaves [0, 1].
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ReflectanceFlags {
    /// Wavelengths (nm) where ρ > 1.
    pub above_one_nm: Vec<f64>,
    /// Wavelengths (nm) where ρ < 0.
    pub below_zero_nm: Vec<f64>,
    /// The largest ρ and the smallest.
    pub max: f64,
    pub min: f64,
}

impl ReflectanceFlags {
    fn of(wavelength_nm: &[f64], rho: &[f64]) -> ReflectanceFlags {
        let pick = |f: &dyn Fn(f64) -> bool| {
            wavelength_nm
                .iter()
                .zip(rho)
                .filter(|(_, r)| f(**r))
                .map(|(nm, _)| *nm)
                .collect()
        };
        ReflectanceFlags {
            above_one_nm: pick(&|r| r > 1.0),
            below_zero_nm: pick(&|r| r < 0.0),
            max: rho.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            min: rho.iter().copied().fold(f64::INFINITY, f64::min),
        }
    }

    /// True when every value lies in [0, 1].
    pub fn is_clean(&self) -> bool {
        self.above_one_nm.is_empty() && self.below_zero_nm.is_empty()
    }
}

/// A measured reflectance with its standard uncertainty.
#[derive(Clone, Debug, PartialEq)]
pub struct Reflectance {
    pub wavelength_nm: Vec<f64>,
    pub reflectance: Vec<f64>,
    pub uncertainty: Vec<f64>,
    pub flags: ReflectanceFlags,
}

/// ρ(λ) and u(ρ) from the sample's and the standard's measurements and the
/// standard's reflectance (ρ_std, u_std) on the same grid.
pub fn reflectance(
    sample: &MeanSpectrum,
    standard: &MeanSpectrum,
    standard_reflectance: (&[f64], &[f64]),
) -> Result<Reflectance, CalibrationError> {
    if sample.wavelength_nm != standard.wavelength_nm {
        return Err(CalibrationError::GridMismatch {
            sample: grid_name(&sample.wavelength_nm),
            standard: grid_name(&standard.wavelength_nm),
        });
    }
    let (rho_std, u_std) = standard_reflectance;
    if rho_std.len() != sample.wavelength_nm.len() || u_std.len() != rho_std.len() {
        return Err(CalibrationError::Inconsistent(
            "the standard's reflectance is not on the instrument's grid".into(),
        ));
    }
    let dark = dark_wavelengths(standard);
    if !dark.is_empty() {
        return Err(CalibrationError::DarkStandard { nm: dark });
    }
    let n = sample.wavelength_nm.len();
    let mut rho = Vec::with_capacity(n);
    let mut u = Vec::with_capacity(n);
    for i in 0..n {
        let (ls, lw) = (sample.mean[i], standard.mean[i]);
        let (ss, sw) = (sample.standard_error[i], standard.standard_error[i]);
        let r = ls / lw;
        rho.push(r * rho_std[i]);
        let var = (rho_std[i] / lw * ss).powi(2) + (rho_std[i] * ls / (lw * lw) * sw).powi(2) + (r * u_std[i]).powi(2);
        u.push(var.sqrt());
    }
    let flags = ReflectanceFlags::of(&sample.wavelength_nm, &rho);
    Ok(Reflectance {
        wavelength_nm: sample.wavelength_nm.clone(),
        reflectance: rho,
        uncertainty: u,
        flags,
    })
}

fn grid_name(nm: &[f64]) -> String {
    match Grid::from_wavelengths(nm.to_vec()) {
        Ok(g) => g.to_string(),
        Err(e) => e.to_string(),
    }
}

/// How the scene CSV treats values outside [0, 1] (the scene loader
/// accepts only reflectances in [0, 1]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OutOfRange {
    /// Refuse to export a flagged reflectance.
    Refuse,
    /// Clip to [0, 1], saying in the header where and from what.
    ClipAndSay,
}

/// The reflectance as a scene spectrum CSV: `#` provenance lines (each of
/// `provenance` is one), then `nm,<column>,<column>_u`. Refused with the
/// flags named when a value lies outside [0, 1] and `out_of_range` is
/// [`OutOfRange::Refuse`].
pub fn scene_csv(
    r: &Reflectance,
    column: &str,
    provenance: &[String],
    out_of_range: OutOfRange,
) -> Result<String, String> {
    let mut values = r.reflectance.clone();
    let mut header: Vec<String> = provenance.to_vec();
    if !r.flags.is_clean() {
        let what = describe_flags(&r.flags);
        match out_of_range {
            OutOfRange::Refuse => {
                return Err(format!(
                    "{what}; a scene reflectance must lie in [0, 1]: ask for the CSV with clipping \
                     (`?clip=true`, stated in its header), or measure again"
                ))
            }
            OutOfRange::ClipAndSay => {
                header.push(format!("CLIPPED to [0, 1] for the scene: {what}"));
                for v in &mut values {
                    *v = v.clamp(0.0, 1.0);
                }
            }
        }
    }
    let grid = Grid::from_wavelengths(r.wavelength_nm.clone()).map_err(|e| e.to_string())?;
    let mut out = String::new();
    for line in header {
        for l in line.lines() {
            out.push_str("# ");
            out.push_str(l);
            out.push('\n');
        }
    }
    let mut body = Vec::new();
    let u_name = format!("{column}_u");
    write_csv(&mut body, &grid, &[(column, &values), (&u_name, &r.uncertainty)]).map_err(|e| e.to_string())?;
    out.push_str(&String::from_utf8(body).map_err(|e| e.to_string())?);
    Ok(out)
}

/// "ρ > 1 at 700, 704 nm (max 1.02)" and/or "ρ < 0 at …".
pub fn describe_flags(f: &ReflectanceFlags) -> String {
    let mut parts = Vec::new();
    if !f.above_one_nm.is_empty() {
        parts.push(format!(
            "ρ > 1 at {} (max {:.4})",
            super::nm_list(&f.above_one_nm),
            f.max
        ));
    }
    if !f.below_zero_nm.is_empty() {
        parts.push(format!(
            "ρ < 0 at {} (min {:.4})",
            super::nm_list(&f.below_zero_nm),
            f.min
        ));
    }
    parts.join("; ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectrum::table::SpectraTable;
    use crate::spectrum::SpectralUnit;

    fn mean(nm: &[f64], m: &[f64], se: &[f64]) -> MeanSpectrum {
        MeanSpectrum {
            wavelength_nm: nm.to_vec(),
            mean: m.to_vec(),
            standard_error: se.to_vec(),
            samples: 5,
        }
    }

    #[test]
    fn ratio_and_uncertainty_by_hand() {
        // L_s = 2 ± 0.1, L_w = 4 ± 0.2, ρ_std = 0.98 ± 0.01:
        // ρ = 0.49; u² = (0.98/4·0.1)² + (0.98·2/16·0.2)² + (0.5·0.01)²
        //            = 0.000600250 + 0.000600250 + 0.000025 = 0.0012255
        let nm = [500.0];
        let r = reflectance(
            &mean(&nm, &[2.0], &[0.1]),
            &mean(&nm, &[4.0], &[0.2]),
            (&[0.98], &[0.01]),
        )
        .unwrap();
        assert!((r.reflectance[0] - 0.49).abs() < 1e-15);
        assert!(
            (r.uncertainty[0] - 0.0012255f64.sqrt()).abs() < 1e-12,
            "{}",
            r.uncertainty[0]
        );
        assert!(r.flags.is_clean());
    }

    #[test]
    fn values_above_one_are_flagged_not_clipped() {
        let nm = [400.0, 404.0, 408.0];
        let r = reflectance(
            &mean(&nm, &[1.0, 5.2, 5.0], &[0.0; 3]),
            &mean(&nm, &[2.0, 5.0, 4.0], &[0.01; 3]),
            (&[0.9; 3], &[0.0; 3]),
        )
        .unwrap();
        assert_eq!(r.reflectance, [0.45, 5.2 / 5.0 * 0.9, 1.125]);
        assert_eq!(r.flags.above_one_nm, [408.0]);
        assert_eq!(r.flags.max, 1.125);
        // The scene CSV refuses it, or clips it saying so.
        let e = scene_csv(&r, "tile", &[], OutOfRange::Refuse).unwrap_err();
        assert!(e.contains("ρ > 1 at 408 nm (max 1.1250)"), "{e}");
        let csv = scene_csv(
            &r,
            "tile",
            &["from measurements 2 and 1".into()],
            OutOfRange::ClipAndSay,
        )
        .unwrap();
        assert!(csv.starts_with("# from measurements 2 and 1\n# CLIPPED to [0, 1] for the scene: ρ > 1 at 408 nm"));
        let t = SpectraTable::parse(&csv, "tile.csv").unwrap();
        assert_eq!(t.spectrum("tile", SpectralUnit::Reflectance).unwrap().values()[2], 1.0);
    }

    #[test]
    fn a_dark_standard_is_refused_with_its_wavelengths() {
        let nm = [380.0, 384.0, 388.0];
        let e = reflectance(
            &mean(&nm, &[0.0, 1.0, 1.0], &[0.1; 3]),
            &mean(&nm, &[0.0, 0.2, 5.0], &[0.1; 3]),
            (&[0.99; 3], &[0.0; 3]),
        )
        .unwrap_err();
        assert_eq!(e, CalibrationError::DarkStandard { nm: vec![380.0, 384.0] });
        assert!(e.to_string().contains("at 380, 384 nm"), "{e}");
    }

    #[test]
    fn the_scene_csv_reads_back_exactly() {
        let nm = [380.0, 384.0];
        let r = reflectance(
            &mean(&nm, &[0.3, 0.7], &[0.01, 0.02]),
            &mean(&nm, &[1.0, 1.0], &[0.01, 0.01]),
            (&[0.99, 0.99], &[0.005, 0.005]),
        )
        .unwrap();
        let csv = scene_csv(&r, "red", &["line one\nline two".into()], OutOfRange::Refuse).unwrap();
        assert!(csv.starts_with("# line one\n# line two\nnm,red,red_u\n"), "{csv}");
        let t = SpectraTable::parse(&csv, "red.csv").unwrap();
        assert_eq!(
            t.spectrum("red", SpectralUnit::Reflectance).unwrap().values(),
            r.reflectance
        );
        assert_eq!(
            t.spectrum("red_u", SpectralUnit::Reflectance).unwrap().values(),
            r.uncertainty
        );
    }
}
