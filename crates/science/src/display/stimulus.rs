//! Rendered colours as a display's frame-buffer codes, and what the display
//! will then show: the core of `lightbooth stimulus` and
//! `lightbooth display-resolution`.
//!
//! Per colour (pixel or target), with XYZ in cd/m² in the profile's observer:
//! 1. linear RGB = M⁻¹ (XYZ − K), with M the primaries' XYZ and K the
//!    black's ([`Converter`]); outside 0–1 in any channel is out of gamut;
//! 2. the gamut policy ([`GamutPolicy`]) makes it displayable;
//! 3. codes = round(drive(t) · (2^b − 1)) through the measured transfer
//!    (fitted γ or the measured table, [`TransferModel`]);
//! 4. shown XYZ = M · t(code / (2^b − 1)) + K — the same model forward.
//!
//! ΔE00 everywhere here is relative to **the display's white** (all
//! channels at full drive, black included): the brightest colour the
//! display can show, so the L* of every displayable colour is at most 100
//! and the same white serves every image shown on this display.
//!
//! Out-of-gamut distance: the largest channel excess `max(−t_c, t_c − 1)`
//! in units of the channel's full-scale output, and the ΔE00 between the
//! original colour and its clipped version.
//!
//! ## Quantisation bound
//! Rounding a drive to the nearest code errs by at most half a code,
//! h = 1 / (2 (2^b − 1)). Through `t = v^γ` that moves the channel's output
//! by at most `γ · t^(1 − 1/γ) · h ≤ γ h` of full scale (largest at full
//! drive for γ > 1). [`quantisation_bound_de00`] turns it into ΔE00: the
//! largest ΔE00 between a colour and the eight colours half a code away in
//! every combination of channel signs, over a grid of 33 drive levels per
//! channel (35 937 colours; a sampled supremum over the drive cube — the
//! linearised error is largest at the box's corners). For the simulated CRT
//! (γ 2.25/2.2/2.15, 100 cd/m² white, black 0.5 %, Judd–Vos) it is 1.09 at
//! 8 bits, 0.27 at 10 and 0.069 at 12: it falls 4× per two bits. It is a
//! worst case over the whole cube; mid-range colours stay under 0.5 at 8
//! bits (the round-trip test of `tests/study/display_calibration.rs`). The
//! worst round trips of 2000 colours spread over the drive cube were 0.75,
//! 0.15 and 0.047 at 8, 10 and 12 bits; `tests/study/stimulus.rs` checks that round trips
//! through the simulated display stay under it.

use serde::Serialize;

use super::profile::{DisplayProfile, FrameBuffer, TransferModel};
use super::{Converter, DisplayError};
use crate::colorimetry::{ciede2000, Lab, Xyz};

/// A linear value this far outside 0–1 is still in gamut: above the f32
/// rounding of an EXR's XYZ (~1e-7 relative) and of a fitted profile's
/// black and primaries, below what half a 16-bit code changes at full drive
/// (γ / (2 · 65535) ≈ 1.7e-5 for γ 2.2).
pub const GAMUT_TOLERANCE: f64 = 1e-5;

/// What to do with colours the display cannot show.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, serde::Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(rename_all = "snake_case")]
pub enum GamutPolicy {
    /// Clamp each channel of linear RGB to 0–1 (hue and lightness may shift).
    Clip,
    /// Scale all colours' linear RGB (XYZ minus black) by one factor so the
    /// brightest colour with no negative channel fits (its largest channel
    /// becomes 1); never scales up. Negative channels (chromaticities outside
    /// the primaries' triangle) are still clipped to 0 afterwards.
    Scale,
    /// Refuse: any out-of-gamut colour is an error.
    Fail,
}

impl std::str::FromStr for GamutPolicy {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "clip" => Ok(GamutPolicy::Clip),
            "scale" => Ok(GamutPolicy::Scale),
            "fail" => Ok(GamutPolicy::Fail),
            _ => Err(format!("unknown gamut policy `{s}`: clip, scale or fail")),
        }
    }
}

/// The worst out-of-gamut colour.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct WorstOutOfGamut {
    /// Index of the colour (a pixel's `y · width + x`).
    pub index: usize,
    /// Its linear RGB before the policy.
    pub linear: [f64; 3],
    /// Largest channel excess, `max(−t, t − 1)`, of full scale.
    pub excess: f64,
    /// ΔE00 between it and its clipped colour.
    pub delta_e00_clipped: f64,
}

/// Out-of-gamut colours and what the policy did.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct GamutReport {
    pub policy: GamutPolicy,
    pub colours: usize,
    pub out_of_gamut: usize,
    pub fraction: f64,
    /// The factor the `scale` policy applied to linear RGB (1 otherwise).
    pub scale_factor: f64,
    /// Colours with a negative channel: clipped whatever the policy.
    pub negative_channel: usize,
    pub worst: Option<WorstOutOfGamut>,
    pub distance_metric: &'static str,
}

/// Largest channel excess outside 0–1 (0 when in gamut).
pub fn excess(linear: [f64; 3]) -> f64 {
    linear.iter().fold(0.0f64, |m, &t| m.max(-t).max(t - 1.0))
}

fn clip(linear: [f64; 3]) -> [f64; 3] {
    linear.map(|t| t.clamp(0.0, 1.0))
}

/// ΔE00 relative to `white`.
pub fn delta_e00(white: Xyz, a: [f64; 3], b: [f64; 3]) -> f64 {
    ciede2000(
        Lab::from_xyz(Xyz::from_array(a), white),
        Lab::from_xyz(Xyz::from_array(b), white),
    )
}

/// Applies `policy` to linear RGB colours in place; errors for `fail` when
/// any is out of gamut, naming the count and the worst.
pub fn apply_gamut(
    converter: &Converter,
    linear: &mut [[f64; 3]],
    policy: GamutPolicy,
) -> Result<GamutReport, DisplayError> {
    let white = converter.white();
    let mut out = 0;
    let mut negative = 0;
    let mut worst: Option<(usize, f64)> = None;
    let mut brightest_positive = 0.0f64;
    for (i, l) in linear.iter().enumerate() {
        let e = excess(*l);
        if l.iter().all(|&t| t >= -GAMUT_TOLERANCE) {
            brightest_positive = brightest_positive.max(l.iter().fold(0.0f64, |m, &t| m.max(t)));
        } else {
            negative += 1;
        }
        if e > GAMUT_TOLERANCE {
            out += 1;
            if worst.is_none_or(|(_, w)| e > w) {
                worst = Some((i, e));
            }
        }
    }
    let worst = worst.map(|(index, e)| {
        let l = linear[index];
        WorstOutOfGamut {
            index,
            linear: l,
            excess: e,
            delta_e00_clipped: delta_e00(white, converter.xyz(l), converter.xyz(clip(l))),
        }
    });
    let n = linear.len();
    let mut report = GamutReport {
        policy,
        colours: n,
        out_of_gamut: out,
        fraction: if n > 0 { out as f64 / n as f64 } else { 0.0 },
        scale_factor: 1.0,
        negative_channel: negative,
        worst,
        distance_metric: "largest channel excess max(-t, t - 1) of linear RGB, in full-scale units; \
                          and the CIEDE2000 (display white) between the colour and its clipped version",
    };
    match policy {
        GamutPolicy::Fail => {
            if let Some(w) = worst {
                return Err(DisplayError::Gamut(format!(
                    "{out} of {n} colours are outside the display's gamut; the worst, colour {}, has linear RGB \
                     [{:.4}, {:.4}, {:.4}] (excess {:.4} of full scale, ΔE00 {:.2} when clipped); \
                     use --gamut clip or scale",
                    w.index, w.linear[0], w.linear[1], w.linear[2], w.excess, w.delta_e00_clipped
                )));
            }
        }
        GamutPolicy::Clip => linear.iter_mut().for_each(|l| *l = clip(*l)),
        GamutPolicy::Scale => {
            let k = if brightest_positive > 1.0 {
                1.0 / brightest_positive
            } else {
                1.0
            };
            report.scale_factor = k;
            linear.iter_mut().for_each(|l| *l = clip(l.map(|t| t * k)));
        }
    }
    Ok(report)
}

/// The codes of displayable linear RGB and the XYZ the display shows for them.
pub fn quantise(
    profile: &DisplayProfile,
    converter: &Converter,
    linear: [f64; 3],
    fb: FrameBuffer,
    model: TransferModel,
) -> ([u32; 3], [f64; 3]) {
    let codes = profile.codes_of_linear(linear, fb, model);
    let shown = [0, 1, 2].map(|c| profile.transfer[c].output(fb.drive(codes[c]), model));
    (codes, converter.xyz(shown))
}

/// Mean, 95th percentile and maximum of a set of ΔE00.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Summary {
    pub mean: f64,
    /// Nearest-rank 95th percentile.
    pub p95: f64,
    pub max: f64,
}

impl Summary {
    pub fn of(values: &[f64]) -> Summary {
        if values.is_empty() {
            return Summary {
                mean: 0.0,
                p95: 0.0,
                max: 0.0,
            };
        }
        let mut v = values.to_vec();
        v.sort_by(f64::total_cmp);
        let rank = ((0.95 * v.len() as f64).ceil() as usize).clamp(1, v.len());
        Summary {
            mean: v.iter().sum::<f64>() / v.len() as f64,
            p95: v[rank - 1],
            max: v[v.len() - 1],
        }
    }
}

/// Colours converted to codes, with what the display shows for them.
#[derive(Clone, Debug)]
pub struct Stimulus {
    pub codes: Vec<[u32; 3]>,
    /// XYZ after the gamut policy, before quantisation (what a display of
    /// unlimited depth would show), cd/m².
    pub intended: Vec<[f64; 3]>,
    /// XYZ shown after quantisation, cd/m².
    pub shown: Vec<[f64; 3]>,
    /// ΔE00 between the colour after the gamut policy (unquantised) and the shown one.
    pub delta_e00_intended: Vec<f64>,
    /// ΔE00 between the original colour and the shown one.
    pub delta_e00_original: Vec<f64>,
    pub gamut: GamutReport,
}

/// XYZ colours (cd/m², the profile's observer) → gamut policy → codes →
/// shown XYZ, with the ΔE00 of each (see the module doc).
pub fn convert(
    profile: &DisplayProfile,
    xyz: &[[f64; 3]],
    fb: FrameBuffer,
    policy: GamutPolicy,
    model: TransferModel,
) -> Result<Stimulus, DisplayError> {
    let converter = Converter::new(profile)?;
    let white = converter.white();
    let mut linear: Vec<[f64; 3]> = xyz.iter().map(|&x| converter.linear(x)).collect();
    let gamut = apply_gamut(&converter, &mut linear, policy)?;
    let mut out = Stimulus {
        codes: Vec::with_capacity(xyz.len()),
        intended: Vec::with_capacity(xyz.len()),
        shown: Vec::with_capacity(xyz.len()),
        delta_e00_intended: Vec::with_capacity(xyz.len()),
        delta_e00_original: Vec::with_capacity(xyz.len()),
        gamut,
    };
    for (l, original) in linear.iter().zip(xyz) {
        let (codes, shown) = quantise(profile, &converter, *l, fb, model);
        let intended = converter.xyz(*l);
        out.codes.push(codes);
        out.intended.push(intended);
        out.shown.push(shown);
        out.delta_e00_intended.push(delta_e00(white, intended, shown));
        out.delta_e00_original.push(delta_e00(white, *original, shown));
    }
    Ok(out)
}

/// The worst ΔE00 that half a code of error in every channel can cause at
/// `fb`'s depth: a sampled supremum over the drive cube (see the module doc).
pub fn quantisation_bound_de00(
    profile: &DisplayProfile,
    fb: FrameBuffer,
    model: TransferModel,
) -> Result<f64, DisplayError> {
    const LEVELS: usize = 33;
    let converter = Converter::new(profile)?;
    let white = converter.white();
    let h = 0.5 / f64::from(fb.max_code());
    let xyz_of = |v: [f64; 3]| converter.xyz([0, 1, 2].map(|c| profile.transfer[c].output(v[c], model)));
    let mut worst = 0.0f64;
    let level = |i: usize| i as f64 / (LEVELS - 1) as f64;
    for i in 0..LEVELS {
        for j in 0..LEVELS {
            for k in 0..LEVELS {
                let v = [level(i), level(j), level(k)];
                let centre = xyz_of(v);
                for corner in 0..8 {
                    let d = [0, 1, 2].map(|c| if (corner >> c) & 1 == 1 { h } else { -h });
                    let moved = [0, 1, 2].map(|c| (v[c] + d[c]).clamp(0.0, 1.0));
                    worst = worst.max(delta_e00(white, centre, xyz_of(moved)));
                }
            }
        }
    }
    Ok(worst)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_95th_percentile_is_the_nearest_rank() {
        let v: Vec<f64> = (1..=100).map(f64::from).collect();
        let s = Summary::of(&v);
        assert_eq!((s.mean, s.p95, s.max), (50.5, 95.0, 100.0));
        assert_eq!(Summary::of(&[3.0]).p95, 3.0);
    }

    #[test]
    fn excess_is_the_largest_distance_outside_the_unit_cube() {
        assert_eq!(excess([0.2, 0.5, 1.0]), 0.0);
        assert!((excess([-0.3, 0.5, 1.2]) - 0.3).abs() < 1e-12);
        assert!((excess([0.0, 1.5, -0.1]) - 0.5).abs() < 1e-12);
    }
}
