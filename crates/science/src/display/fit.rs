//! Which colours a display calibration shows, and the profile fitted to
//! what the instrument measured while it showed them: spectra (a
//! spectroradiometer), XYZ (a colorimeter) or luminance (a luminance meter).
//!
//! The patches are classified by their drive alone: all channels at 0 is the
//! black level; one channel non-zero is a point of that channel's ramp (at 1,
//! its primary); all three at 1 is the white of the additivity check; any
//! other mixture (grey ramp, colours) is a validation colour, predicted by
//! the fitted profile and compared with its measurement.
//!
//! A ramp point's normalised output, from spectra, is the least-squares
//! scale of the primary's increment that best matches the point's increment
//! over black, `t = ⟨S − K, P⟩ / ⟨P, P⟩` over the whole spectrum — less
//! noisy than a luminance ratio, and the phosphor-constancy assumption made
//! explicit. From XYZ or luminance it is the luminance ratio
//! `t = (Y − Y_K) / Y_P`, the way labs calibrate with a colorimeter: γ per
//! gun from luminance, the primaries from XYZ. A luminance meter's profile
//! has γ only; its additivity and validation are checked in luminance.
//! γ is then the least-squares fit of `t = v^γ` over the levels strictly
//! between 0 and 1 (golden-section search on 0.2–8). The measured table is
//! made monotone (a running maximum) so that it can be inverted; the raw
//! values are what the fit sees.

use serde::{Deserialize, Serialize};

use super::profile::{
    Additivity, ChannelTransfer, Checks, DisplayProfile, Emission, LuminanceAdditivity, LuminanceValidation,
    TransferModel, Validation,
};
use super::DisplayError;
use crate::colorimetry::{xyz_from_radiance, Observer, Xyz};
use crate::spectrum::{Grid, SpectralUnit, Spectrum};

const CHANNELS: [&str; 3] = ["red", "green", "blue"];

/// One colour the calibration page shows.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct PlanPatch {
    /// What it is, for the operator: `black`, `red 50 %`, `grey 25 %`, ….
    pub label: String,
    /// Drive per channel, 0–1, on the 8-bit grid (k/255) a browser can show.
    pub drive: [f64; 3],
    /// `fit` (black, ramps, white) or `validation`.
    pub purpose: String,
}

/// The colours of a calibration, in the order shown.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct CalibrationPlan {
    pub patches: Vec<PlanPatch>,
}

/// A drive on the 8-bit grid a browser shows: the nearest k/255.
fn eight_bit(v: f64) -> f64 {
    (v.clamp(0.0, 1.0) * 255.0).round() / 255.0
}

impl CalibrationPlan {
    /// Black; each channel's ramp at `steps` equal levels up to full drive;
    /// white; then a grey ramp at quarters and four mixtures for validation.
    pub fn new(steps: usize) -> Result<CalibrationPlan, DisplayError> {
        if !(2..=32).contains(&steps) {
            return Err(DisplayError::Calibration(format!(
                "ramp steps {steps}: choose 2–32 (γ needs at least one level between 0 and full drive)"
            )));
        }
        let mut patches = vec![PlanPatch {
            label: "black".into(),
            drive: [0.0; 3],
            purpose: "fit".into(),
        }];
        for (c, name) in CHANNELS.iter().enumerate() {
            for k in 1..=steps {
                let v = eight_bit(k as f64 / steps as f64);
                let mut drive = [0.0; 3];
                drive[c] = v;
                patches.push(PlanPatch {
                    label: format!("{name} {:.0} %", v * 100.0),
                    drive,
                    purpose: "fit".into(),
                });
            }
        }
        patches.push(PlanPatch {
            label: "white".into(),
            drive: [1.0; 3],
            purpose: "fit".into(),
        });
        for g in [0.25, 0.5, 0.75] {
            let v = eight_bit(g);
            patches.push(PlanPatch {
                label: format!("grey {:.0} %", v * 100.0),
                drive: [v; 3],
                purpose: "validation".into(),
            });
        }
        for (label, d) in [
            ("orange", [0.9, 0.5, 0.1]),
            ("teal", [0.1, 0.6, 0.6]),
            ("violet", [0.5, 0.2, 0.8]),
            ("skin", [0.8, 0.6, 0.5]),
        ] {
            patches.push(PlanPatch {
                label: label.into(),
                drive: d.map(eight_bit),
                purpose: "validation".into(),
            });
        }
        Ok(CalibrationPlan { patches })
    }
}

/// What the instrument gave for a colour shown.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(rename_all = "snake_case")]
pub enum PatchLight {
    /// A spectroradiometer's mean spectral radiance, W/(sr·m²·nm).
    Spectrum {
        /// The instrument's grid, nm.
        wavelength_nm: Vec<f64>,
        radiance: Vec<f64>,
    },
    /// A colorimeter's mean XYZ, cd/m², in the profile's observer.
    Xyz([f64; 3]),
    /// A luminance meter's mean luminance, cd/m².
    Luminance(f64),
}

impl PatchLight {
    fn kind(&self) -> &'static str {
        match self {
            PatchLight::Spectrum { .. } => "a spectrum",
            PatchLight::Xyz(_) => "XYZ",
            PatchLight::Luminance(_) => "a luminance",
        }
    }

    /// The values the fit averages and subtracts: the spectrum, the XYZ or the luminance.
    fn values(&self) -> Vec<f64> {
        match self {
            PatchLight::Spectrum { radiance, .. } => radiance.clone(),
            PatchLight::Xyz(xyz) => xyz.to_vec(),
            PatchLight::Luminance(y) => vec![*y],
        }
    }
}

/// A colour as shown and measured.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct MeasuredPatch {
    /// Drive per channel, 0–1.
    pub drive: [f64; 3],
    /// What the instrument measured (the mean of the measurement's samples).
    pub light: PatchLight,
    /// The measurement it came from (provenance).
    pub measurement_id: Option<i64>,
}

impl MeasuredPatch {
    /// A patch measured by a spectroradiometer.
    pub fn spectrum(drive: [f64; 3], wavelength_nm: Vec<f64>, radiance: Vec<f64>, measurement_id: Option<i64>) -> Self {
        MeasuredPatch {
            drive,
            light: PatchLight::Spectrum {
                wavelength_nm,
                radiance,
            },
            measurement_id,
        }
    }
}

fn same(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-9
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Least-squares γ of `t = v^γ` (golden-section search on 0.2–8).
pub fn fit_gamma(levels: &[f64], t: &[f64]) -> f64 {
    let cost = |g: f64| -> f64 { levels.iter().zip(t).map(|(v, t)| (t - v.powf(g)).powi(2)).sum() };
    let (mut a, mut b) = (0.2_f64, 8.0_f64);
    let r = (5.0_f64.sqrt() - 1.0) / 2.0;
    let mut c = b - r * (b - a);
    let mut d = a + r * (b - a);
    while b - a > 1e-9 {
        if cost(c) < cost(d) {
            b = d;
        } else {
            a = c;
        }
        c = b - r * (b - a);
        d = a + r * (b - a);
    }
    (a + b) / 2.0
}

/// Fits a profile to the measured patches (see the module doc for which
/// patch is what). Errors name the missing or inconsistent patch.
pub fn fit_profile(patches: &[MeasuredPatch], observer: Observer) -> Result<DisplayProfile, DisplayError> {
    let cal = |m: String| DisplayError::Calibration(m);
    let first = patches.first().ok_or_else(|| cal("no measured patches".into()))?;
    let grid = match &first.light {
        PatchLight::Spectrum { wavelength_nm, .. } => Some(Grid::from_wavelengths(wavelength_nm.clone())?),
        _ => None,
    };
    let n = first.light.values().len();
    for (i, p) in patches.iter().enumerate() {
        match (&first.light, &p.light) {
            (
                PatchLight::Spectrum { wavelength_nm: w0, .. },
                PatchLight::Spectrum {
                    wavelength_nm,
                    radiance,
                },
            ) => {
                if wavelength_nm.len() != w0.len() || wavelength_nm.iter().zip(w0).any(|(a, b)| !same(*a, *b)) {
                    return Err(cal(format!(
                        "patch {i} (drive {:?}) is on another wavelength grid than patch 0",
                        p.drive
                    )));
                }
                if radiance.len() != n {
                    return Err(cal(format!(
                        "patch {i} (drive {:?}) has {} radiance values for {n} wavelengths",
                        p.drive,
                        radiance.len()
                    )));
                }
            }
            (PatchLight::Xyz(_), PatchLight::Xyz(_)) | (PatchLight::Luminance(_), PatchLight::Luminance(_)) => {}
            (a, b) => {
                return Err(cal(format!(
                    "patch {i} (drive {:?}) was measured as {} but patch 0 as {}: calibrate with one instrument",
                    p.drive,
                    b.kind(),
                    a.kind()
                )))
            }
        }
        if p.light.values().iter().any(|v| !v.is_finite()) {
            return Err(cal(format!("patch {i} (drive {:?}) holds a non-finite value", p.drive)));
        }
        if let Some(c) = p.drive.iter().position(|v| !(0.0..=1.0).contains(v)) {
            return Err(cal(format!(
                "patch {i}: {} drive {} is outside 0–1",
                CHANNELS[c], p.drive[c]
            )));
        }
    }
    let mean_of = |sel: &[&MeasuredPatch]| -> Vec<f64> {
        let values: Vec<Vec<f64>> = sel.iter().map(|p| p.light.values()).collect();
        (0..n)
            .map(|i| values.iter().map(|v| v[i]).sum::<f64>() / sel.len() as f64)
            .collect()
    };
    // XYZ and luminance of averaged values of the patches' kind.
    let xyz = |v: &[f64]| -> Result<Xyz, DisplayError> {
        match &grid {
            Some(grid) => Ok(xyz_from_radiance(
                &Spectrum::new(grid.clone(), SpectralUnit::SpectralRadiance, v.to_vec())?,
                observer,
            )?),
            None => Ok(Xyz::from_array([v[0], v[1], v[2]])),
        }
    };
    let luminance = |v: &[f64]| -> Result<f64, DisplayError> {
        match (&grid, v.len()) {
            (None, 1) => Ok(v[0]),
            _ => Ok(xyz(v)?.y),
        }
    };

    let blacks: Vec<&MeasuredPatch> = patches.iter().filter(|p| p.drive.iter().all(|v| *v == 0.0)).collect();
    if blacks.is_empty() {
        return Err(cal("no black patch (drive 0, 0, 0): the black level is needed".into()));
    }
    let black = mean_of(&blacks);

    let single = |p: &MeasuredPatch, c: usize| p.drive[c] > 0.0 && (0..3).all(|o| o == c || p.drive[o] == 0.0);
    let mut primaries: Vec<Vec<f64>> = Vec::new();
    let mut transfer: Vec<ChannelTransfer> = Vec::new();
    for (c, name) in CHANNELS.iter().enumerate() {
        let full: Vec<&MeasuredPatch> = patches
            .iter()
            .filter(|p| single(p, c) && same(p.drive[c], 1.0))
            .collect();
        if full.is_empty() {
            return Err(cal(format!(
                "no {name} primary at full drive (drive 1 on {name}, 0 elsewhere)"
            )));
        }
        let primary: Vec<f64> = mean_of(&full).iter().zip(&black).map(|(s, k)| s - k).collect();
        let norm = dot(&primary, &primary);
        let primary_y = luminance(&primary)?;
        if !(norm.is_finite() && norm > 0.0 && primary_y > 0.0) {
            return Err(cal(format!(
                "the {name} primary at full drive measured no more than black"
            )));
        }
        let mut ramp: Vec<(f64, f64)> = Vec::new();
        for p in patches.iter().filter(|p| single(p, c) && p.drive[c] < 1.0) {
            let inc: Vec<f64> = p.light.values().iter().zip(&black).map(|(s, k)| s - k).collect();
            let t = match grid {
                Some(_) => dot(&inc, &primary) / norm,
                None => luminance(&inc)? / primary_y,
            };
            ramp.push((p.drive[c], t));
        }
        if ramp.is_empty() {
            return Err(cal(format!(
                "no {name} ramp level between 0 and full drive: γ cannot be fitted"
            )));
        }
        ramp.sort_by(|a, b| a.0.total_cmp(&b.0));
        let (lv, tv): (Vec<f64>, Vec<f64>) = ramp.iter().copied().unzip();
        let gamma = fit_gamma(&lv, &tv);
        let rms_residual = (lv
            .iter()
            .zip(&tv)
            .map(|(v, t)| (t - v.powf(gamma)).powi(2))
            .sum::<f64>()
            / lv.len() as f64)
            .sqrt();
        let mut levels = vec![0.0];
        let mut measured = vec![0.0];
        let mut running = 0.0_f64;
        for (v, t) in ramp {
            running = running.max(t.min(1.0));
            levels.push(v);
            measured.push(running);
        }
        levels.push(1.0);
        measured.push(1.0);
        primaries.push(primary);
        transfer.push(ChannelTransfer {
            gamma,
            levels,
            measured,
            rms_residual,
        });
    }

    let whites: Vec<&MeasuredPatch> = patches
        .iter()
        .filter(|p| p.drive.iter().all(|v| same(*v, 1.0)))
        .collect();
    if whites.is_empty() {
        return Err(cal(
            "no white patch (drive 1, 1, 1): additivity cannot be checked".into()
        ));
    }
    let white = mean_of(&whites);
    let primaries: [Vec<f64>; 3] = [primaries[0].clone(), primaries[1].clone(), primaries[2].clone()];
    let transfer: [ChannelTransfer; 3] = [transfer[0].clone(), transfer[1].clone(), transfer[2].clone()];
    let three = |v: &Vec<f64>| [v[0], v[1], v[2]];
    let (emission, checks) = match (&first.light, &grid) {
        (PatchLight::Spectrum { wavelength_nm, .. }, Some(_)) => (
            Emission::Spectral {
                wavelength_nm: wavelength_nm.clone(),
                black,
                primaries,
            },
            Checks::Colour {
                additivity: colour_additivity(xyz(&white)?, white),
                validation: Vec::new(),
            },
        ),
        (PatchLight::Xyz(_), _) => (
            Emission::Tristimulus {
                black_xyz: three(&black),
                primaries_xyz: [three(&primaries[0]), three(&primaries[1]), three(&primaries[2])],
            },
            Checks::Colour {
                additivity: colour_additivity(xyz(&white)?, Vec::new()),
                validation: Vec::new(),
            },
        ),
        _ => (
            Emission::Luminance {
                black_cd_m2: black[0],
                primaries_cd_m2: [primaries[0][0], primaries[1][0], primaries[2][0]],
            },
            Checks::Luminance {
                luminance_additivity: LuminanceAdditivity {
                    white_cd_m2: white[0],
                    sum_cd_m2: black[0] + primaries.iter().map(|p| p[0]).sum::<f64>(),
                    relative_difference: 0.0,
                },
                luminance_validation: Vec::new(),
            },
        ),
    };
    let mut profile = DisplayProfile {
        observer,
        emission,
        transfer,
        checks,
        measurement_ids: patches.iter().filter_map(|p| p.measurement_id).collect(),
    };
    let validation_patches = patches.iter().filter(|p| {
        let zeros = p.drive.iter().filter(|v| **v == 0.0).count();
        let is_white = p.drive.iter().all(|v| same(*v, 1.0));
        zeros < 2 && !is_white
    });
    match &profile.checks {
        Checks::Colour { additivity, .. } => {
            let white_xyz = Xyz::from_array(additivity.white_xyz);
            let sum = profile.white_xyz()?;
            let delta_e00 = profile.delta_e00(white_xyz, sum)?;
            let mut validation = Vec::new();
            for p in validation_patches {
                let measured = xyz(&p.light.values())?;
                let predicted = profile.xyz_of_drive(p.drive, TransferModel::Gamma)?;
                validation.push(Validation {
                    drive: p.drive,
                    measured_xyz: measured.to_array(),
                    predicted_xyz: predicted.to_array(),
                    delta_e00: profile.delta_e00(measured, predicted)?,
                    measurement_id: p.measurement_id,
                });
            }
            if let Checks::Colour {
                additivity,
                validation: v,
            } = &mut profile.checks
            {
                additivity.sum_xyz = sum.to_array();
                additivity.delta_e00 = delta_e00;
                *v = validation;
            }
        }
        Checks::Luminance { .. } => {
            let mut validation = Vec::new();
            for p in validation_patches {
                let measured = luminance(&p.light.values())?;
                let predicted = profile.luminance_of_drive(p.drive, TransferModel::Gamma)?;
                validation.push(LuminanceValidation {
                    drive: p.drive,
                    measured_cd_m2: measured,
                    predicted_cd_m2: predicted,
                    relative_difference: (predicted - measured) / measured,
                    measurement_id: p.measurement_id,
                });
            }
            if let Checks::Luminance {
                luminance_additivity: a,
                luminance_validation: v,
            } = &mut profile.checks
            {
                a.relative_difference = (a.sum_cd_m2 - a.white_cd_m2) / a.white_cd_m2;
                *v = validation;
            }
        }
    }
    Ok(profile)
}

/// The additivity check before the sum is known (filled in by the fit).
fn colour_additivity(white_xyz: Xyz, white: Vec<f64>) -> Additivity {
    Additivity {
        white_xyz: white_xyz.to_array(),
        sum_xyz: [0.0; 3],
        delta_e00: 0.0,
        white,
    }
}

#[cfg(test)]
mod tests {
    //! Truth: the simulated display's own primaries and γ
    //! ([`SimulatedDisplay`]), its XYZ integrated from its 1 nm spectra by
    //! the colour-matching functions — never the fit's code path.
    use super::*;
    use crate::display::SimulatedDisplay;

    /// The plan measured by a perfect instrument of kind `light`.
    fn measured(display: &SimulatedDisplay, light: impl Fn(&Spectrum) -> PatchLight) -> Vec<MeasuredPatch> {
        CalibrationPlan::new(8)
            .unwrap()
            .patches
            .iter()
            .enumerate()
            .map(|(i, p)| MeasuredPatch {
                drive: p.drive,
                light: light(&display.spectrum(p.drive)),
                measurement_id: Some(i as i64 + 1),
            })
            .collect()
    }

    fn cie1931(s: &Spectrum) -> Xyz {
        xyz_from_radiance(s, Observer::Cie1931).unwrap()
    }

    #[test]
    fn a_colorimeters_xyz_give_the_displays_primaries_and_gamma() {
        let d = SimulatedDisplay::crt().unwrap();
        let patches = measured(&d, |s| PatchLight::Xyz(cie1931(s).to_array()));
        let profile = fit_profile(&patches, Observer::Cie1931).unwrap();
        assert!(matches!(profile.emission, Emission::Tristimulus { .. }));
        let truth = d.primary_chromaticities(Observer::Cie1931).unwrap();
        let fitted = profile.primary_chromaticities().unwrap();
        for c in 0..3 {
            let dxy = (fitted[c][0] - truth[c][0]).hypot(fitted[c][1] - truth[c][1]);
            assert!(dxy < 1e-9, "primary {c}: {:?} against {:?}", fitted[c], truth[c]);
            let g = profile.transfer[c].gamma / d.gammas()[c];
            assert!((g - 1.0).abs() < 1e-6, "channel {c}: γ ratio {g}");
        }
        let white = profile.white_xyz().unwrap();
        assert!(
            (white.y - crate::display::simulated::WHITE_CD_M2).abs() < 1e-6,
            "{white:?}"
        );
        assert_eq!(profile.failures(), Vec::<String>::new());
        assert!(profile.additivity().unwrap().delta_e00 < 1e-6);
        assert_eq!(profile.validation().len(), 7, "three greys and four mixtures");
        assert!(profile.grid().is_err(), "no spectra from a colorimeter");
    }

    #[test]
    fn a_luminance_meter_gives_gamma_only_and_says_so_when_asked_for_colour() {
        let d = SimulatedDisplay::crt().unwrap();
        let patches = measured(&d, |s| PatchLight::Luminance(cie1931(s).y));
        let profile = fit_profile(&patches, Observer::Cie1931).unwrap();
        for c in 0..3 {
            let g = profile.transfer[c].gamma / d.gammas()[c];
            assert!((g - 1.0).abs() < 1e-6, "channel {c}: γ ratio {g}");
        }
        let Checks::Luminance {
            luminance_additivity,
            luminance_validation,
        } = &profile.checks
        else {
            panic!(
                "a luminance meter's profile is checked in luminance: {:?}",
                profile.checks
            )
        };
        assert!(luminance_additivity.relative_difference.abs() < 1e-9);
        assert_eq!(luminance_validation.len(), 7);
        assert!(luminance_validation.iter().all(|v| v.relative_difference.abs() < 1e-9));
        assert_eq!(profile.failures(), Vec::<String>::new());
        // Luminance of a grey: black + Σ t·ΔY, against the display's own.
        let grey = [0.5; 3];
        let want = cie1931(&d.spectrum(grey)).y;
        let got = profile.luminance_of_drive(grey, TransferModel::Gamma).unwrap();
        assert!((got / want - 1.0).abs() < 1e-9, "{got} against {want}");
        let e = profile.primary_matrix().unwrap_err().to_string();
        assert!(e.contains("luminance meter") && e.contains("colorimeter"), "{e}");
        assert!(profile.linear_of_xyz(Xyz::new(1.0, 1.0, 1.0)).is_err());
    }

    #[test]
    fn patches_of_two_kinds_of_instrument_are_refused_naming_the_patch() {
        let d = SimulatedDisplay::crt().unwrap();
        let mut patches = measured(&d, |s| PatchLight::Xyz(cie1931(s).to_array()));
        patches[3].light = PatchLight::Luminance(12.0);
        let e = fit_profile(&patches, Observer::Cie1931).unwrap_err().to_string();
        assert!(
            e.contains("patch 3") && e.contains("a luminance") && e.contains("one instrument"),
            "{e}"
        );
    }

    #[test]
    fn each_kind_of_profile_reads_back_as_itself() {
        let d = SimulatedDisplay::crt().unwrap();
        for patches in [
            measured(&d, |s| PatchLight::Spectrum {
                wavelength_nm: s.grid().wavelengths().to_vec(),
                radiance: s.values().to_vec(),
            }),
            measured(&d, |s| PatchLight::Xyz(cie1931(s).to_array())),
            measured(&d, |s| PatchLight::Luminance(cie1931(s).y)),
        ] {
            let profile = fit_profile(&patches, Observer::Cie1931).unwrap();
            let json = serde_json::to_string(&profile).unwrap();
            let back: DisplayProfile = serde_json::from_str(&json).unwrap();
            assert_eq!(
                std::mem::discriminant(&back.emission),
                std::mem::discriminant(&profile.emission)
            );
            back.validate().unwrap();
            // serde_json reads a float back to within its last bit.
            let (a, b) = (profile.luminances().unwrap(), back.luminances().unwrap());
            assert!((a.0 - b.0).abs() <= 1e-12 * a.0.abs(), "{a:?} {b:?}");
            for c in 0..3 {
                assert!((a.1[c] - b.1[c]).abs() <= 1e-12 * a.1[c], "{a:?} {b:?}");
                assert!((profile.transfer[c].gamma - back.transfer[c].gamma).abs() < 1e-12);
            }
            assert_eq!(profile.failures(), back.failures());
        }
    }

    /// A profile stored before profiles could be measured as XYZ or
    /// luminance (the JSON of migration 0008's rows, on a 10 nm grid) still
    /// reads as a spectral profile with its colour checks.
    #[test]
    fn a_profile_stored_before_colorimeters_reads_as_spectral() {
        let t = r#"{"gamma": 2.2, "levels": [0, 0.5, 1], "measured": [0, 0.21, 1], "rms_residual": 0.001}"#;
        let nm: Vec<String> = (0..41).map(|k| (380 + 10 * k).to_string()).collect();
        let flat = |v: f64| vec![v.to_string(); 41].join(", ");
        let json = format!(
            r#"{{"observer": "judd-vos-1978", "wavelength_nm": [{}], "black": [{}],
              "primaries": [[{}], [{}], [{}]], "transfer": [{t}, {t}, {t}],
              "additivity": {{"white_xyz": [95, 100, 108], "sum_xyz": [95, 100, 108], "delta_e00": 0.1,
                             "white": [{}]}},
              "validation": [], "measurement_ids": [1, 2]}}"#,
            nm.join(", "),
            flat(0.001),
            (0..41)
                .map(|k| if k > 25 { "0.01" } else { "0" })
                .collect::<Vec<_>>()
                .join(", "),
            (0..41)
                .map(|k| if (12..26).contains(&k) { "0.01" } else { "0" })
                .collect::<Vec<_>>()
                .join(", "),
            (0..41)
                .map(|k| if k < 12 { "0.01" } else { "0" })
                .collect::<Vec<_>>()
                .join(", "),
            flat(0.01)
        );
        let p: DisplayProfile = serde_json::from_str(&json).unwrap();
        assert!(matches!(p.emission, Emission::Spectral { .. }));
        assert_eq!(p.additivity().unwrap().delta_e00, 0.1);
        p.validate().unwrap();
    }
}
