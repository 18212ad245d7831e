//! Which colours a display calibration shows, and the profile fitted to the
//! spectra measured while it showed them.
//!
//! The patches are classified by their drive alone: all channels at 0 is the
//! black level; one channel non-zero is a point of that channel's ramp (at 1,
//! its primary); all three at 1 is the white of the additivity check; any
//! other mixture (grey ramp, colours) is a validation colour, predicted by
//! the fitted profile and compared with its measurement.
//!
//! A ramp point's normalised output is the least-squares scale of the
//! primary's increment that best matches the point's increment over black,
//! `t = ⟨S − K, P⟩ / ⟨P, P⟩` over the whole spectrum — less noisy than a
//! luminance ratio, and the phosphor-constancy assumption made explicit.
//! γ is then the least-squares fit of `t = v^γ` over the levels strictly
//! between 0 and 1 (golden-section search on 0.2–8). The measured table is
//! made monotone (a running maximum) so that it can be inverted; the raw
//! values are what the fit sees.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::profile::{Additivity, ChannelTransfer, DisplayProfile, TransferModel, Validation};
use super::DisplayError;
use crate::colorimetry::{xyz_from_radiance, Observer, Xyz};
use crate::spectrum::{Grid, SpectralUnit, Spectrum};

const CHANNELS: [&str; 3] = ["red", "green", "blue"];

/// One colour the calibration page shows.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct PlanPatch {
    /// What it is, for the operator: `black`, `red 50 %`, `grey 25 %`, ….
    pub label: String,
    /// Drive per channel, 0–1, on the 8-bit grid (k/255) a browser can show.
    pub drive: [f64; 3],
    /// `fit` (black, ramps, white) or `validation`.
    pub purpose: String,
}

/// The colours of a calibration, in the order shown.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
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

/// A colour as shown and measured.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct MeasuredPatch {
    /// Drive per channel, 0–1.
    pub drive: [f64; 3],
    /// The instrument's grid, nm.
    pub wavelength_nm: Vec<f64>,
    /// Mean spectral radiance, W/(sr·m²·nm).
    pub radiance: Vec<f64>,
    /// The measurement it came from (provenance).
    pub measurement_id: Option<i64>,
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
    let wavelength_nm = first.wavelength_nm.clone();
    let n = wavelength_nm.len();
    for (i, p) in patches.iter().enumerate() {
        if p.wavelength_nm.len() != n || p.wavelength_nm.iter().zip(&wavelength_nm).any(|(a, b)| !same(*a, *b)) {
            return Err(cal(format!(
                "patch {i} (drive {:?}) is on another wavelength grid than patch 0",
                p.drive
            )));
        }
        if p.radiance.len() != n {
            return Err(cal(format!(
                "patch {i} (drive {:?}) has {} radiance values for {n} wavelengths",
                p.drive,
                p.radiance.len()
            )));
        }
        if let Some(c) = p.drive.iter().position(|v| !(0.0..=1.0).contains(v)) {
            return Err(cal(format!(
                "patch {i}: {} drive {} is outside 0–1",
                CHANNELS[c], p.drive[c]
            )));
        }
    }
    let grid = Grid::from_wavelengths(wavelength_nm.clone())?;
    let mean_of = |sel: &[&MeasuredPatch]| -> Vec<f64> {
        (0..n)
            .map(|i| sel.iter().map(|p| p.radiance[i]).sum::<f64>() / sel.len() as f64)
            .collect()
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
        if !(norm.is_finite() && norm > 0.0) {
            return Err(cal(format!(
                "the {name} primary at full drive measured no more than black"
            )));
        }
        let mut ramp: Vec<(f64, f64)> = patches
            .iter()
            .filter(|p| single(p, c) && p.drive[c] < 1.0)
            .map(|p| {
                let inc: Vec<f64> = p.radiance.iter().zip(&black).map(|(s, k)| s - k).collect();
                (p.drive[c], dot(&inc, &primary) / norm)
            })
            .collect();
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
    let xyz = |v: Vec<f64>| -> Result<Xyz, DisplayError> {
        Ok(xyz_from_radiance(
            &Spectrum::new(grid.clone(), SpectralUnit::SpectralRadiance, v)?,
            observer,
        )?)
    };
    let white = mean_of(&whites);
    let white_xyz = xyz(white.clone())?;
    let primaries: [Vec<f64>; 3] = [primaries[0].clone(), primaries[1].clone(), primaries[2].clone()];
    let transfer: [ChannelTransfer; 3] = [transfer[0].clone(), transfer[1].clone(), transfer[2].clone()];
    let mut profile = DisplayProfile {
        observer,
        wavelength_nm,
        black,
        primaries,
        transfer,
        additivity: Additivity {
            white_xyz: white_xyz.to_array(),
            sum_xyz: [0.0; 3],
            delta_e00: 0.0,
            white,
        },
        validation: Vec::new(),
        measurement_ids: patches.iter().filter_map(|p| p.measurement_id).collect(),
    };
    let sum = profile.white_xyz()?;
    profile.additivity.sum_xyz = sum.to_array();
    profile.additivity.delta_e00 = profile.delta_e00(white_xyz, sum)?;

    for p in patches {
        let zeros = p.drive.iter().filter(|v| **v == 0.0).count();
        let is_white = p.drive.iter().all(|v| same(*v, 1.0));
        if zeros >= 2 || is_white {
            continue;
        }
        let measured = xyz(p.radiance.clone())?;
        let predicted = profile.xyz_of_drive(p.drive, TransferModel::Gamma)?;
        profile.validation.push(Validation {
            drive: p.drive,
            measured_xyz: measured.to_array(),
            predicted_xyz: predicted.to_array(),
            delta_e00: profile.delta_e00(measured, predicted)?,
            measurement_id: p.measurement_id,
        });
    }
    Ok(profile)
}
