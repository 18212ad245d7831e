//! The codings of one rendered image on one display (issue 48): every
//! coding's XYZ image converted together through the display profile, and
//! how far each coding is from the reference coding as rendered, as the
//! display is asked to show it, and as it shows it at each output depth.
//!
//! - **One gamut policy for the set.** The codings are converted as one
//!   list of colours ([`apply_gamut`] sees every pixel of every coding), so
//!   `scale` divides all codings by the same factor and a coding is never
//!   brighter or darker than another only because it was scaled alone.
//! - **Three ΔE00 per pixel against the reference**, all with the display's
//!   white (as [`super::stimulus`]): `rendered` (the two XYZ as rendered,
//!   before the display), `intended` (after the gamut policy, unquantised:
//!   what a display of unlimited depth would show) and `shown` at each
//!   output: 8, 10 and 12 bits per gun (codes rounded to the nearest level)
//!   and 8-bit noisy-bit dithering (its mean over frames,
//!   [`mean_dithered_output`]). The quantisation's share of a coding's
//!   difference at a depth is then `shown` against `intended`.
//! - **Each coding against its own intention**: ΔE00 intended → shown per
//!   pixel at each output (the quantisation alone), beside the sampled
//!   worst case [`quantisation_bound_de00`].
//! - The pages get each coding's linear RGB after the gamut policy
//!   ([`ImageSet::linear`], 0–1 per gun): they apply the profile's γ and the
//!   output method themselves, as they do for the pie.
//!
//! The transfer of every output here is the profile's fitted γ
//! ([`TransferModel::Gamma`]), as on the session page.

use serde::Serialize;

use super::output::mean_dithered_output;
use super::profile::{DisplayProfile, FrameBuffer, TransferModel};
use super::stimulus::{apply_gamut, delta_e00, quantisation_bound_de00, GamutPolicy, GamutReport, Summary};
use super::{Converter, DisplayError};

/// The outputs every coding is shown with: (name, bits per gun or `None`
/// for 8-bit noisy-bit dithering's mean).
pub const OUTPUTS: [(&str, Option<u32>); 4] = [
    ("8bit", Some(8)),
    ("noisy_bit", None),
    ("10bit", Some(10)),
    ("12bit", Some(12)),
];

/// ΔE00 over the image's pixels at one output.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AtOutput {
    /// `8bit`, `noisy_bit`, `10bit` or `12bit`.
    pub output: String,
    pub delta_e00: Summary,
}

/// One coding against the reference.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AgainstReference {
    /// The two images' XYZ as rendered.
    pub rendered: Summary,
    /// After the gamut policy, unquantised.
    pub intended: Summary,
    /// As shown at each of [`OUTPUTS`].
    pub shown: Vec<AtOutput>,
}

/// One coding of the set.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CodingOnDisplay {
    pub coding: String,
    /// Pixels outside the gamut before the policy (of this coding).
    pub out_of_gamut_pixels: usize,
    /// ΔE00 intended → shown at each of [`OUTPUTS`] (the quantisation alone).
    pub quantisation: Vec<AtOutput>,
    /// `None` for the reference itself.
    pub against_reference: Option<AgainstReference>,
}

/// The set: every coding converted, and the report.
#[derive(Clone, Debug, Serialize)]
pub struct ImageSet {
    pub pixels: usize,
    pub reference: String,
    /// The display's white (all guns full, black included), XYZ cd/m²: the
    /// white of every ΔE00 here.
    pub white: [f64; 3],
    pub policy: GamutPolicy,
    /// The gamut policy over all codings at once.
    pub gamut: GamutReport,
    pub codings: Vec<CodingOnDisplay>,
    /// The sampled worst ΔE00 half a code can cause, at 8, 10 and 12 bits.
    pub quantisation_bound: Vec<(u32, f64)>,
    /// Per coding, per pixel, linear RGB after the gamut policy (0–1).
    #[serde(skip)]
    pub linear: Vec<Vec<[f32; 3]>>,
    /// Per coding, per output of [`OUTPUTS`], per pixel: ΔE00 between what
    /// the display shows of the coding and of the reference (0 for the
    /// reference), the map the summaries `shown` are of.
    #[serde(skip)]
    pub shown_delta_e: Vec<Vec<Vec<f32>>>,
}

/// The index in [`OUTPUTS`] of an output's name (`8bit`, `noisy_bit`,
/// `10bit`, `12bit`).
pub fn output_index(name: &str) -> Result<usize, String> {
    OUTPUTS.iter().position(|(n, _)| *n == name).ok_or_else(|| {
        let names: Vec<&str> = OUTPUTS.iter().map(|o| o.0).collect();
        format!("unknown output `{name}`: {}", names.join(", "))
    })
}

/// What the display emits for displayable linear RGB at one output, XYZ.
fn shown(profile: &DisplayProfile, converter: &Converter, linear: [f64; 3], bits: Option<u32>) -> [f64; 3] {
    let model = TransferModel::Gamma;
    let out = match bits {
        Some(bits) => {
            let fb = FrameBuffer { bits };
            let codes = profile.codes_of_linear(linear, fb, model);
            [0, 1, 2].map(|c| profile.transfer[c].output(fb.drive(codes[c]), model))
        }
        None => [0, 1, 2].map(|c| mean_dithered_output(profile, c, profile.transfer[c].drive(linear[c], model))),
    };
    converter.xyz(out)
}

/// Converts `codings` (name, XYZ per pixel in cd/m² and the profile's
/// observer; every coding the same number of pixels) through `profile`
/// with one gamut `policy`, and compares each with `codings[reference]`
/// (see the module doc).
pub fn image_set(
    profile: &DisplayProfile,
    codings: &[(String, Vec<[f64; 3]>)],
    reference: usize,
    policy: GamutPolicy,
) -> Result<ImageSet, DisplayError> {
    let converter = Converter::new(profile)?;
    let white = converter.white();
    let pixels = codings.first().map_or(0, |c| c.1.len());
    if let Some((name, c)) = codings.iter().find(|c| c.1.len() != pixels) {
        return Err(DisplayError::Profile(format!(
            "coding {name} has {} pixels and {} has {pixels}: the codings of one image have one size",
            c.len(),
            codings[0].0
        )));
    }
    if pixels == 0 {
        return Err(DisplayError::Profile(
            "an image set needs at least one coding of at least one pixel".into(),
        ));
    }
    if reference >= codings.len() {
        return Err(DisplayError::Profile(format!(
            "the reference is coding {reference} of {}",
            codings.len()
        )));
    }
    let mut linear: Vec<[f64; 3]> = codings
        .iter()
        .flat_map(|(_, xyz)| xyz.iter().map(|&x| converter.linear(x)))
        .collect();
    let out_of_gamut: Vec<usize> = codings
        .iter()
        .enumerate()
        .map(|(i, _)| {
            linear[i * pixels..(i + 1) * pixels]
                .iter()
                .filter(|l| super::stimulus::excess(**l) > super::stimulus::GAMUT_TOLERANCE)
                .count()
        })
        .collect();
    let gamut = apply_gamut(&converter, &mut linear, policy)?;
    let linear: Vec<&[[f64; 3]]> = linear.chunks(pixels).collect();
    let intended: Vec<Vec<[f64; 3]>> = linear
        .iter()
        .map(|l| l.iter().map(|&v| converter.xyz(v)).collect())
        .collect();
    let shown_at: Vec<Vec<Vec<[f64; 3]>>> = linear
        .iter()
        .map(|l| {
            OUTPUTS
                .iter()
                .map(|(_, bits)| l.iter().map(|&v| shown(profile, &converter, v, *bits)).collect())
                .collect()
        })
        .collect();
    let summary = |a: &[[f64; 3]], b: &[[f64; 3]]| {
        let de: Vec<f64> = a.iter().zip(b).map(|(p, q)| delta_e00(white, *p, *q)).collect();
        Summary::of(&de)
    };
    let at_outputs = |f: &dyn Fn(usize) -> Summary| -> Vec<AtOutput> {
        OUTPUTS
            .iter()
            .enumerate()
            .map(|(o, (name, _))| AtOutput {
                output: name.to_string(),
                delta_e00: f(o),
            })
            .collect()
    };
    let mut out = Vec::with_capacity(codings.len());
    for (i, (name, xyz)) in codings.iter().enumerate() {
        let quantisation = at_outputs(&|o| summary(&intended[i], &shown_at[i][o]));
        let against_reference = (i != reference).then(|| AgainstReference {
            rendered: summary(xyz, &codings[reference].1),
            intended: summary(&intended[i], &intended[reference]),
            shown: at_outputs(&|o| summary(&shown_at[i][o], &shown_at[reference][o])),
        });
        out.push(CodingOnDisplay {
            coding: name.clone(),
            out_of_gamut_pixels: out_of_gamut[i],
            quantisation,
            against_reference,
        });
    }
    let shown_delta_e = (0..codings.len())
        .map(|i| {
            (0..OUTPUTS.len())
                .map(|o| {
                    shown_at[i][o]
                        .iter()
                        .zip(&shown_at[reference][o])
                        .map(|(p, q)| delta_e00(white, *p, *q) as f32)
                        .collect()
                })
                .collect()
        })
        .collect();
    let quantisation_bound = [8, 10, 12]
        .into_iter()
        .map(|bits| {
            Ok((
                bits,
                quantisation_bound_de00(profile, FrameBuffer { bits }, TransferModel::Gamma)?,
            ))
        })
        .collect::<Result<Vec<_>, DisplayError>>()?;
    Ok(ImageSet {
        pixels,
        reference: codings[reference].0.clone(),
        white: white.to_array(),
        policy,
        gamut,
        codings: out,
        quantisation_bound,
        linear: linear
            .iter()
            .map(|l| l.iter().map(|v| v.map(|c| c as f32)).collect())
            .collect(),
        shown_delta_e,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::display::SimulatedDisplay;

    fn profile() -> DisplayProfile {
        SimulatedDisplay::crt()
            .unwrap()
            .exact_profile(crate::colorimetry::Observer::JuddVos)
            .unwrap()
    }

    /// A gradient of greys and colours well inside the gamut, as XYZ.
    fn gradient(profile: &DisplayProfile, shift: f64) -> Vec<[f64; 3]> {
        let c = Converter::new(profile).unwrap();
        (0..64)
            .map(|i| {
                let t = 0.1 + 0.8 * i as f64 / 63.0;
                c.xyz([t, (t * 0.9 + shift).min(1.0), 0.5 * t])
            })
            .collect()
    }

    /// A coding identical to the reference differs by nothing at every
    /// output, and each coding's quantisation stays under the sampled bound.
    #[test]
    fn identical_codings_differ_by_nothing_and_quantisation_stays_under_its_bound() {
        let p = profile();
        let g = gradient(&p, 0.0);
        let set = image_set(&p, &[("a".into(), g.clone()), ("ref".into(), g)], 1, GamutPolicy::Clip).unwrap();
        let a = set.codings[0].against_reference.as_ref().unwrap();
        assert_eq!(a.rendered.max, 0.0);
        assert_eq!(a.intended.max, 0.0);
        for s in &a.shown {
            assert_eq!(s.delta_e00.max, 0.0, "{}", s.output);
        }
        for (bits, bound) in &set.quantisation_bound {
            let q = set.codings[0]
                .quantisation
                .iter()
                .find(|q| q.output == format!("{bits}bit"))
                .unwrap();
            assert!(
                q.delta_e00.max <= *bound,
                "{bits} bits: {} > bound {bound}",
                q.delta_e00.max
            );
        }
        assert!(set.codings[1].against_reference.is_none());
        assert_eq!(set.linear.len(), 2);
    }

    /// A shift of a tenth of an 8-bit step in linear green is invisible at
    /// 8 bits on most pixels (both round to the same code; the few that
    /// round apart jump a whole code, more than intended) but shown at
    /// 12 bits within the quantisation of the intended difference, and
    /// noisy-bit's mean shows it too (its mean is the intention, up to the
    /// linear interpolation of the transfer between two codes).
    #[test]
    fn a_sub_code_difference_is_lost_at_8_bits_and_kept_at_12_and_with_noisy_bit() {
        let p = profile();
        let step = 1.0 / 255.0;
        let reference = gradient(&p, 0.0);
        let shifted = gradient(&p, 0.1 * step);
        let set = image_set(
            &p,
            &[("near".into(), shifted), ("ref".into(), reference)],
            1,
            GamutPolicy::Clip,
        )
        .unwrap();
        let a = set.codings[0].against_reference.as_ref().unwrap();
        let at = |o: &str| a.shown.iter().find(|s| s.output == o).unwrap().delta_e00;
        assert!(a.intended.mean > 0.01, "{:?}", a.intended);
        // At 8 bits most pixels round to the reference's codes (ΔE00 0), and
        // the few that flip jump a whole code: hidden or exaggerated.
        assert!(
            at("8bit").p95 == 0.0 && a.intended.p95 > 0.05 && at("8bit").max > a.intended.max,
            "8 bits: {:?} against {:?}",
            at("8bit"),
            a.intended
        );
        assert!(
            (at("12bit").mean - a.intended.mean).abs() < 0.3 * a.intended.mean,
            "12 bits: {:?} against {:?}",
            at("12bit"),
            a.intended
        );
        assert!(
            (at("noisy_bit").mean - a.intended.mean).abs() < 0.3 * a.intended.mean,
            "noisy-bit: {:?} against {:?}",
            at("noisy_bit"),
            a.intended
        );
    }

    /// `scale` divides every coding by one factor: a set where only one
    /// coding is too bright keeps the other's ratio to it.
    #[test]
    fn the_scale_policy_scales_every_coding_by_one_factor() {
        let p = profile();
        let c = Converter::new(&p).unwrap();
        let dim = vec![c.xyz([0.4, 0.4, 0.4]); 4];
        let bright = vec![c.xyz([1.6, 1.6, 1.6]); 4];
        let set = image_set(
            &p,
            &[("dim".into(), dim), ("bright".into(), bright)],
            1,
            GamutPolicy::Scale,
        )
        .unwrap();
        let (d, b) = (set.linear[0][0], set.linear[1][0]);
        assert!((b[0] - 1.0).abs() < 1e-5, "the brightest fits: {b:?}");
        assert!((d[0] / b[0] - 0.25).abs() < 1e-5, "one factor: {d:?} against {b:?}");
        assert_eq!(set.codings[1].out_of_gamut_pixels, 4);
        assert_eq!(set.codings[0].out_of_gamut_pixels, 0);
    }

    /// Codings of different sizes are refused, naming both.
    #[test]
    fn codings_of_different_sizes_are_refused_naming_them() {
        let p = profile();
        let e = image_set(
            &p,
            &[("a".into(), gradient(&p, 0.0)), ("b".into(), vec![[1.0, 1.0, 1.0]])],
            1,
            GamutPolicy::Clip,
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("coding b has 1 pixels") && e.contains("64"), "{e}");
        let e = image_set(&p, &[("a".into(), Vec::new())], 0, GamutPolicy::Clip)
            .unwrap_err()
            .to_string();
        assert!(e.contains("at least one pixel"), "{e}");
    }
}
