//! Can a display show an experiment's colours apart? Each colour through the
//! profile at the output method's resolution, said per colour in words.
//!
//! Ruppertsberg & Bloj (2006) found that on their 8-bit frame buffer the
//! 27- and 81-step renderings and the measured colour had identical codes,
//! so only N = 3 and N = 9 could be tested. [`check_colours`] makes that
//! finding for any experiment before an observer sits down: the original
//! and every approximation are converted together (one gamut policy, one
//! `scale` factor, as [`super::resolution`]), and each approximation is
//! compared with the original at 8 bits and with the chosen
//! [`OutputMethod`].
//!
//! # Output methods and their resolution
//!
//! - **8 bit**: codes = round(255·drive); two colours are distinct when a
//!   code differs.
//! - **10 bit** (a native 10-bit output path): the same at 1023 levels.
//! - **Noisy-bit dithering** (Allard & Faubert 2008, *Behavior Research
//!   Methods* 40(3), 735–743): every pixel in every frame shows the upper
//!   of the two 8-bit codes around the fractional code c = 255·drive with
//!   probability frac(c), the lower otherwise. The *mean* emitted light is
//!   then the transfer interpolated linearly between the two codes, exactly
//!   ([`mean_dithered_output`]; not t(drive): the transfer's curvature
//!   between two adjacent codes is the approximation, below 10⁻⁵ of full
//!   scale at 8 bits for γ ≤ 3). Averaged over the n pixels and frames of
//!   one presented pie piece, the mean code has a standard error of at most
//!   0.5/√n; two colours are called distinct when their fractional codes
//!   differ, in some channel, by at least three standard errors of the
//!   difference, 3·√2·0.5/√n codes ([`Resolution::code_step`]). For the
//!   study's pie (13 470 pixels a piece) over 18 frames that is 0.0043 of a
//!   code: about 16 bits of effective resolution for the mean.
//!
//! Every transfer here is the profile's fitted γ ([`TransferModel::Gamma`]):
//! the session page applies the same γ per pixel.

use serde::{Deserialize, Serialize};

use super::profile::{DisplayProfile, FrameBuffer, TransferModel};
use super::stimulus::{apply_gamut, delta_e00, excess, GamutPolicy, GamutReport, GAMUT_TOLERANCE};
use super::{Converter, DisplayError};

/// How frame-buffer values reach the screen (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub enum OutputMethod {
    /// 8 bits per gun, each colour rounded to its nearest code (the study's).
    #[serde(rename = "8bit")]
    EightBit,
    /// 8 bits per gun with noisy-bit dithering (Allard & Faubert 2008).
    #[serde(rename = "noisy_bit")]
    NoisyBit,
    /// A native 10-bit output path (where the browser and display offer one).
    #[serde(rename = "10bit")]
    TenBit,
}

impl OutputMethod {
    pub fn name(self) -> &'static str {
        match self {
            OutputMethod::EightBit => "8bit",
            OutputMethod::NoisyBit => "noisy_bit",
            OutputMethod::TenBit => "10bit",
        }
    }

    /// What the method resolves when a colour is averaged over `samples`
    /// pixels × frames (one pie piece for one presentation).
    pub fn resolution(self, samples: f64) -> Resolution {
        match self {
            OutputMethod::EightBit => Resolution {
                method: self,
                bits_per_gun: 8,
                code_step: 1.0,
                effective_bits: 8.0,
                how: "8-bit codes: two colours differ when a code differs".into(),
            },
            OutputMethod::TenBit => Resolution {
                method: self,
                bits_per_gun: 10,
                code_step: 1.0,
                effective_bits: 10.0,
                how: "10-bit codes: two colours differ when a code differs".into(),
            },
            OutputMethod::NoisyBit => {
                let n = samples.max(1.0);
                let step = 3.0 * std::f64::consts::SQRT_2 * 0.5 / n.sqrt();
                Resolution {
                    method: self,
                    bits_per_gun: 8,
                    code_step: step,
                    effective_bits: 8.0 + (1.0 / step).log2(),
                    how: format!(
                        "noisy-bit dithering of 8-bit codes: the mean over {n:.0} pixels × frames resolves \
                         {step:.4} of a code (three standard errors of a difference of two means)"
                    ),
                }
            }
        }
    }
}

impl std::str::FromStr for OutputMethod {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "8bit" => Ok(OutputMethod::EightBit),
            "noisy_bit" | "noisy-bit" => Ok(OutputMethod::NoisyBit),
            "10bit" => Ok(OutputMethod::TenBit),
            _ => Err(format!("unknown output method `{s}`: 8bit, noisy_bit or 10bit")),
        }
    }
}

/// The smallest difference an output method shows (see the module doc).
#[derive(Clone, Debug, PartialEq, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Resolution {
    pub method: OutputMethod,
    /// Bits of the codes sent to the display.
    pub bits_per_gun: u32,
    /// Smallest difference of (mean) codes called distinct, in codes of `bits_per_gun`.
    pub code_step: f64,
    /// log2 of the levels that step gives per gun.
    pub effective_bits: f64,
    /// The rule, in words.
    pub how: String,
}

/// The mean normalised output of a channel dithered at drive `v`: the
/// transfer interpolated linearly between the two 8-bit codes around
/// 255·v, weighted by the probability of each (see the module doc).
pub fn mean_dithered_output(profile: &DisplayProfile, channel: usize, v: f64) -> f64 {
    let c = v.clamp(0.0, 1.0) * 255.0;
    let lo = c.floor().min(254.0);
    let f = c - lo;
    let t = |code: f64| profile.transfer[channel].output(code / 255.0, TransferModel::Gamma);
    (1.0 - f) * t(lo) + f * t(lo + 1.0)
}

/// One colour on the display.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ColourOnDisplay {
    /// `original`, or the approximation's coding.
    pub name: String,
    /// The colour asked for, XYZ cd/m² (the profile's observer).
    pub xyz: [f64; 3],
    /// Its linear RGB before the gamut policy; outside 0–1 is out of gamut.
    pub linear_requested: [f64; 3],
    pub out_of_gamut: bool,
    /// Largest channel excess outside 0–1, of full scale.
    pub gamut_excess: f64,
    /// Linear RGB after the gamut policy: what the page is asked to show.
    pub linear: [f64; 3],
    /// Drive 0–1 per gun through the fitted γ.
    pub drive: [f64; 3],
    /// 255 · drive, unrounded.
    pub fractional_code: [f64; 3],
    /// The nearest 8-bit codes.
    pub codes_8bit: [u32; 3],
    /// The nearest codes at the method's depth (the 8-bit ones for noisy-bit).
    pub codes: [u32; 3],
    /// What the display emits with the method, XYZ cd/m² (for noisy-bit, the mean).
    pub shown_xyz: [f64; 3],
    /// ΔE00 (display white) from the original as intended (after the gamut policy, unquantised).
    pub delta_e00_intended: f64,
    /// ΔE00 from the original as shown at 8 bits.
    pub delta_e00_shown_8bit: f64,
    /// ΔE00 from the original as shown with the method.
    pub delta_e00_shown: f64,
    pub distinct_at_8bit: bool,
    pub distinct: bool,
    /// The verdict in words, with the codes.
    pub verdict: String,
}

/// Every colour of an experiment on one display.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ColourCheck {
    pub resolution: Resolution,
    #[cfg_attr(feature = "openapi", schema(value_type = Object))]
    pub gamut: GamutReport,
    pub original: ColourOnDisplay,
    pub approximations: Vec<ColourOnDisplay>,
    /// The background: the display white's chromaticity at the colours' mean luminance.
    pub background: ColourOnDisplay,
    /// Approximations distinct from the original with the method.
    pub testable: Vec<String>,
    /// Approximations not distinct with the method (untestable as shown).
    pub untestable: Vec<String>,
    /// Approximations distinct with the method that are not at 8 bits.
    pub testable_only_with_method: Vec<String>,
    /// Plain words, one line per finding.
    pub summary: Vec<String>,
}

/// Converts `original` and `approximations` (name, XYZ cd/m² in the
/// profile's observer) together through `profile` and says which the
/// `method` shows apart from the original, with `samples` pixels × frames
/// averaged per presentation (see the module doc).
pub fn check_colours(
    profile: &DisplayProfile,
    original: [f64; 3],
    approximations: &[(String, [f64; 3])],
    method: OutputMethod,
    samples: f64,
    policy: GamutPolicy,
) -> Result<ColourCheck, DisplayError> {
    let converter = Converter::new(profile)?;
    let white = converter.white();
    let resolution = method.resolution(samples);
    let mut xyz: Vec<[f64; 3]> = vec![original];
    xyz.extend(approximations.iter().map(|(_, x)| *x));
    let requested: Vec<[f64; 3]> = xyz.iter().map(|&x| converter.linear(x)).collect();
    let mut linear = requested.clone();
    let gamut = apply_gamut(&converter, &mut linear, policy)?;
    let on_display = |name: &str, xyz: [f64; 3], requested: [f64; 3], linear: [f64; 3]| {
        let drive = [0, 1, 2].map(|c| profile.transfer[c].drive(linear[c], TransferModel::Gamma));
        let fb8 = FrameBuffer { bits: 8 };
        let codes_8bit = drive.map(|v| fb8.quantise(v));
        let codes = match method {
            OutputMethod::TenBit => drive.map(|v| FrameBuffer { bits: 10 }.quantise(v)),
            _ => codes_8bit,
        };
        let shown_linear = match method {
            OutputMethod::NoisyBit => [0, 1, 2].map(|c| mean_dithered_output(profile, c, drive[c])),
            OutputMethod::EightBit => {
                [0, 1, 2].map(|c| profile.transfer[c].output(fb8.drive(codes[c]), TransferModel::Gamma))
            }
            OutputMethod::TenBit => {
                let fb = FrameBuffer { bits: 10 };
                [0, 1, 2].map(|c| profile.transfer[c].output(fb.drive(codes[c]), TransferModel::Gamma))
            }
        };
        let e = excess(requested);
        ColourOnDisplay {
            name: name.to_string(),
            xyz,
            linear_requested: requested,
            out_of_gamut: e > GAMUT_TOLERANCE,
            gamut_excess: e,
            linear,
            drive,
            fractional_code: drive.map(|v| v * 255.0),
            codes_8bit,
            codes,
            shown_xyz: converter.xyz(shown_linear),
            delta_e00_intended: 0.0,
            delta_e00_shown_8bit: 0.0,
            delta_e00_shown: 0.0,
            distinct_at_8bit: false,
            distinct: false,
            verdict: String::new(),
        }
    };
    let mut original_shown = on_display("original", original, requested[0], linear[0]);
    original_shown.verdict = format!(
        "the original is shown as 8-bit codes {}",
        codes(original_shown.codes_8bit)
    );
    if original_shown.out_of_gamut {
        original_shown.verdict += &format!(
            "; it is outside the display's gamut by {:.3} of full scale ({} policy)",
            original_shown.gamut_excess,
            policy_name(policy)
        );
    }
    let shown_8bit =
        |c: &ColourOnDisplay| {
            converter.xyz([0, 1, 2].map(|k| {
                profile.transfer[k].output(FrameBuffer { bits: 8 }.drive(c.codes_8bit[k]), TransferModel::Gamma)
            }))
        };
    let original_8bit = shown_8bit(&original_shown);
    let mut out = Vec::new();
    for (i, (name, x)) in approximations.iter().enumerate() {
        let mut c = on_display(name, *x, requested[i + 1], linear[i + 1]);
        c.delta_e00_intended = delta_e00(white, converter.xyz(linear[0]), converter.xyz(c.linear));
        c.delta_e00_shown_8bit = delta_e00(white, original_8bit, shown_8bit(&c));
        c.delta_e00_shown = delta_e00(white, original_shown.shown_xyz, c.shown_xyz);
        c.distinct_at_8bit = c.codes_8bit != original_shown.codes_8bit;
        c.distinct = match method {
            OutputMethod::NoisyBit => {
                (0..3).any(|k| (c.fractional_code[k] - original_shown.fractional_code[k]).abs() >= resolution.code_step)
            }
            _ => c.codes != original_shown.codes,
        };
        c.verdict = verdict(&c, &original_shown, method, &resolution, policy);
        out.push(c);
    }
    // The background: the white's chromaticity at the mean luminance of what is shown.
    let mean_y = std::iter::once(&original_shown)
        .chain(&out)
        .map(|c| c.shown_xyz[1])
        .sum::<f64>()
        / (out.len() + 1) as f64;
    let grey = white.scaled(mean_y / white.y).to_array();
    let grey_requested = converter.linear(grey);
    let mut background = on_display(
        "background",
        grey,
        grey_requested,
        grey_requested.map(|t| t.clamp(0.0, 1.0)),
    );
    background.verdict = format!(
        "a grey of the stimuli's mean luminance, {mean_y:.2} cd/m², at the display white's chromaticity: 8-bit codes {}",
        codes(background.codes_8bit)
    );
    let names =
        |f: &dyn Fn(&ColourOnDisplay) -> bool| out.iter().filter(|c| f(c)).map(|c| c.name.clone()).collect::<Vec<_>>();
    let testable = names(&|c| c.distinct);
    let untestable = names(&|c| !c.distinct);
    let testable_only_with_method = names(&|c| c.distinct && !c.distinct_at_8bit);
    let mut summary = Vec::new();
    if gamut.out_of_gamut > 0 {
        summary.push(format!(
            "{} of {} colours are outside the display's gamut; the {} policy {}",
            gamut.out_of_gamut,
            gamut.colours,
            policy_name(policy),
            if policy == GamutPolicy::Scale {
                format!("darkens every colour by the factor {:.4}", gamut.scale_factor)
            } else {
                "clips each channel to 0–1".into()
            }
        ));
    }
    let not_8bit: Vec<String> = names(&|c| !c.distinct_at_8bit);
    if !not_8bit.is_empty() {
        summary.push(format!(
            "at 8 bits {} {} the original's codes {}: not testable at 8 bits",
            list(&not_8bit),
            if not_8bit.len() == 1 { "has" } else { "have" },
            codes(original_shown.codes_8bit)
        ));
    }
    if method != OutputMethod::EightBit {
        if !testable_only_with_method.is_empty() {
            summary.push(format!(
                "with {} {} distinct from the original although not at 8 bits",
                method_words(method),
                list(&testable_only_with_method)
                    + if testable_only_with_method.len() == 1 {
                        " is"
                    } else {
                        " are"
                    }
            ));
        }
        if !untestable.is_empty() {
            summary.push(format!(
                "even with {} {} not distinct from the original",
                method_words(method),
                list(&untestable) + if untestable.len() == 1 { " is" } else { " are" }
            ));
        }
    }
    if untestable.is_empty() {
        summary.push(format!(
            "every approximation is distinct from the original with {}",
            method_words(method)
        ));
    }
    Ok(ColourCheck {
        resolution,
        gamut,
        original: original_shown,
        approximations: out,
        background,
        testable,
        untestable,
        testable_only_with_method,
        summary,
    })
}

fn verdict(
    c: &ColourOnDisplay,
    o: &ColourOnDisplay,
    method: OutputMethod,
    r: &Resolution,
    policy: GamutPolicy,
) -> String {
    let mut v = if c.distinct_at_8bit {
        format!(
            "distinct at 8 bits: codes {} against the original's {} (ΔE00 {:.2} as shown)",
            codes(c.codes_8bit),
            codes(o.codes_8bit),
            c.delta_e00_shown_8bit
        )
    } else {
        format!(
            "not distinct at 8 bits: the same codes {} as the original (ΔE00 {:.3} as intended)",
            codes(c.codes_8bit),
            c.delta_e00_intended
        )
    };
    match method {
        OutputMethod::EightBit => {}
        OutputMethod::NoisyBit => {
            let d = (0..3)
                .map(|k| (c.fractional_code[k] - o.fractional_code[k]).abs())
                .fold(0.0, f64::max);
            v += &format!(
                "; with noisy-bit dithering {}: fractional codes [{:.3}, {:.3}, {:.3}] differ from the original's by up to {d:.4} of a code (step {:.4}), ΔE00 {:.3} in the mean",
                if c.distinct { "distinct" } else { "not distinct" },
                c.fractional_code[0],
                c.fractional_code[1],
                c.fractional_code[2],
                r.code_step,
                c.delta_e00_shown
            );
        }
        OutputMethod::TenBit => {
            v += &format!(
                "; at 10 bits {}: codes {} against the original's {}",
                if c.distinct { "distinct" } else { "not distinct" },
                codes(c.codes),
                codes(o.codes)
            );
        }
    }
    if c.out_of_gamut {
        v += &format!(
            "; outside the display's gamut by {:.3} of full scale ({} policy)",
            c.gamut_excess,
            policy_name(policy)
        );
    }
    v
}

fn codes(c: [u32; 3]) -> String {
    format!("({}, {}, {})", c[0], c[1], c[2])
}

fn list(names: &[String]) -> String {
    names.join(", ")
}

fn policy_name(p: GamutPolicy) -> &'static str {
    match p {
        GamutPolicy::Clip => "clip",
        GamutPolicy::Scale => "scale",
        GamutPolicy::Fail => "fail",
    }
}

fn method_words(m: OutputMethod) -> &'static str {
    match m {
        OutputMethod::EightBit => "8 bits",
        OutputMethod::NoisyBit => "noisy-bit dithering",
        OutputMethod::TenBit => "10 bits",
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::colorimetry::{xyz_from_radiance, Observer};
    use crate::display::SimulatedDisplay;

    fn crt() -> (SimulatedDisplay, DisplayProfile) {
        let d = SimulatedDisplay::crt().unwrap();
        let p = d.exact_profile(Observer::JuddVos).unwrap();
        (d, p)
    }

    /// The XYZ of a drive on every gun, from the simulated display's own spectra.
    fn true_xyz(d: &SimulatedDisplay, drive: f64) -> [f64; 3] {
        xyz_from_radiance(&d.spectrum([drive; 3]), Observer::JuddVos)
            .unwrap()
            .to_array()
    }

    fn xyz_at_code(p: &DisplayProfile, code: f64) -> [f64; 3] {
        let c = Converter::new(p).unwrap();
        c.xyz([0, 1, 2].map(|k| p.transfer[k].output(code / 255.0, TransferModel::Gamma)))
    }

    #[test]
    fn noisy_bit_resolution_at_the_studys_pie_is_about_sixteen_bits() {
        let r = OutputMethod::NoisyBit.resolution(13_470.0 * 18.0);
        assert!((r.code_step - 0.0043).abs() < 1e-4, "{}", r.code_step);
        assert!(
            r.effective_bits > 15.5 && r.effective_bits < 16.0,
            "{}",
            r.effective_bits
        );
        assert_eq!(OutputMethod::EightBit.resolution(1e6).code_step, 1.0);
        assert_eq!("noisy-bit".parse::<OutputMethod>().unwrap(), OutputMethod::NoisyBit);
        assert!("12bit"
            .parse::<OutputMethod>()
            .unwrap_err()
            .contains("8bit, noisy_bit or 10bit"));
    }

    /// The dithered mean at code 127.30 is 70 % of the light at 127 and
    /// 30 % of that at 128, as the simulated display's spectra give it.
    #[test]
    fn the_dithered_mean_lies_between_two_codes_where_the_display_emits_it() {
        let (d, p) = crt();
        let expected: Vec<f64> = (0..3)
            .map(|k| 0.7 * true_xyz(&d, 127.0 / 255.0)[k] + 0.3 * true_xyz(&d, 128.0 / 255.0)[k])
            .collect();
        let original = xyz_at_code(&p, 127.30);
        let check = check_colours(&p, original, &[], OutputMethod::NoisyBit, 1e5, GamutPolicy::Fail).unwrap();
        let o = &check.original;
        for k in 0..3 {
            assert!((o.fractional_code[k] - 127.30).abs() < 1e-6, "{:?}", o.fractional_code);
            assert!(
                (o.shown_xyz[k] - expected[k]).abs() < 1e-4 * expected[k],
                "{:?} {expected:?}",
                o.shown_xyz
            );
        }
        assert_eq!(o.codes_8bit, [127; 3]);
    }

    /// Colours 0.4 of a code apart share their 8-bit codes: the study's
    /// "N = 27 and 81 cannot be shown at 8 bits"; dithering tells them apart.
    #[test]
    fn colours_sharing_an_8_bit_code_are_distinct_only_with_dithering() {
        let (_, p) = crt();
        let approximations = vec![
            ("nstep27".to_string(), xyz_at_code(&p, 127.45)),
            ("nstep3".to_string(), xyz_at_code(&p, 131.0)),
            ("nstep81".to_string(), xyz_at_code(&p, 127.051)),
        ];
        let check = check_colours(
            &p,
            xyz_at_code(&p, 127.05),
            &approximations,
            OutputMethod::NoisyBit,
            13_470.0 * 18.0,
            GamutPolicy::Fail,
        )
        .unwrap();
        let [n27, n3, n81] = [0, 1, 2].map(|i| &check.approximations[i]);
        assert!(!n27.distinct_at_8bit && n27.distinct, "{}", n27.verdict);
        assert!(
            n27.verdict
                .starts_with("not distinct at 8 bits: the same codes (127, 127, 127)"),
            "{}",
            n27.verdict
        );
        assert!(n3.distinct_at_8bit && n3.distinct, "{}", n3.verdict);
        assert!(!n81.distinct, "0.001 of a code is below the step: {}", n81.verdict);
        assert_eq!(check.testable, ["nstep27", "nstep3"]);
        assert_eq!(check.testable_only_with_method, ["nstep27"]);
        assert_eq!(check.untestable, ["nstep81"]);
        let words = check.summary.join("\n");
        assert!(
            words.contains("at 8 bits nstep27, nstep81 have the original's codes (127, 127, 127)"),
            "{words}"
        );
        assert!(
            words.contains("with noisy-bit dithering nstep27 is distinct"),
            "{words}"
        );
        assert!(
            words.contains("even with noisy-bit dithering nstep81 is not distinct"),
            "{words}"
        );
        // The same colours at 8 bits: only N = 3.
        let at8 = check_colours(
            &p,
            xyz_at_code(&p, 127.05),
            &approximations,
            OutputMethod::EightBit,
            1.0,
            GamutPolicy::Fail,
        )
        .unwrap();
        assert_eq!(at8.testable, ["nstep3"]);
        // Ten bits: 127.45/255 and 127.05/255 are 511.3 and 509.7 of 1023.
        let at10 = check_colours(
            &p,
            xyz_at_code(&p, 127.05),
            &approximations,
            OutputMethod::TenBit,
            1.0,
            GamutPolicy::Fail,
        )
        .unwrap();
        assert_eq!(at10.testable, ["nstep27", "nstep3"]);
    }

    #[test]
    fn a_colour_outside_the_gamut_is_named_with_its_excess() {
        let (_, p) = crt();
        let white = Converter::new(&p).unwrap().white().to_array();
        let too_bright = white.map(|v| v * 1.5);
        let check = check_colours(
            &p,
            xyz_at_code(&p, 200.0),
            &[("rgb".into(), too_bright)],
            OutputMethod::EightBit,
            1.0,
            GamutPolicy::Clip,
        )
        .unwrap();
        let c = &check.approximations[0];
        assert!(
            c.out_of_gamut && (c.gamut_excess - 0.5).abs() < 0.01,
            "{}",
            c.gamut_excess
        );
        assert!(
            c.verdict.contains("outside the display's gamut by 0.50"),
            "{}",
            c.verdict
        );
        assert!(
            check.summary[0].starts_with("1 of 2 colours are outside the display's gamut; the clip policy clips"),
            "{:?}",
            check.summary
        );
        // The background is a grey at the mean luminance of what is shown.
        let mean_y = (check.original.shown_xyz[1] + c.shown_xyz[1]) / 2.0;
        assert!(
            (check.background.shown_xyz[1] - mean_y).abs() < 0.02 * mean_y,
            "{:?}",
            check.background
        );
    }
}
