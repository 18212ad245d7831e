//! A displayed image checked at its targets (issue 48, part 3's core): the
//! scene's radiometer targets, projected into the image, are where the
//! instrument measures the screen, and its field covers a disc of pixels
//! around each.
//!
//! Per target, with the display's white as every ΔE00's white:
//! - **intended**: the mean XYZ of the disc's pixels as the display is
//!   asked to show them (after the gamut policy, unquantised);
//! - **predicted**: the mean XYZ the profile says the disc's codes show
//!   (its fitted γ, per pixel, then averaged: the display is additive);
//! - **emitted**: what the instrument measured there.
//!
//! ΔE00 intended → emitted is the whole error of the displayed image at
//! the target; intended → predicted is the quantisation's share; predicted
//! → emitted is the display's departure from its profile (drift, or an
//! error of the profile). Where the booth was measured at the target, ΔE00
//! booth → emitted is the complex scene's loop closed: the real scene's
//! light against the light the displayed image emits at the same point.
//!
//! The codes are the codes of the linear RGB through the profile's γ at
//! the output's depth (8, 10 or 12 bits), as the session page draws a
//! plain image; with noisy-bit dithering (`bits` `None`) `predicted` is
//! the profile's mean over frames of the dithered 8-bit codes
//! ([`mean_dithered_output`]), and `counts` are one undithered frame's
//! 8-bit codes (a page that dithers reports its own frames' codes).

use serde::Serialize;

use super::output::mean_dithered_output;
use super::profile::{DisplayProfile, FrameBuffer, TransferModel};
use super::simulated::{field_weight, CodeCounts};
use super::stimulus::delta_e00;
use super::{Converter, DisplayError};

/// Where a target falls on the screen, and the booth's measurement there.
#[derive(Clone, Debug, PartialEq)]
pub struct TargetOnScreen {
    pub id: String,
    /// The target's image point, pixels (x right, y down from the top-left corner).
    pub x: f64,
    pub y: f64,
    /// The booth's measured XYZ at the target (cd/m², the profile's observer), if any.
    pub booth_xyz: Option<[f64; 3]>,
}

/// What the instrument's field covers at one target, before it measures.
#[derive(Clone, Debug, PartialEq)]
pub struct TargetField {
    pub target: TargetOnScreen,
    /// The codes of the disc's pixels (what a simulated display emits from).
    pub counts: CodeCounts,
    pub pixels: u64,
    pub intended: [f64; 3],
    pub predicted: [f64; 3],
}

/// One target of a displayed image, measured.
#[derive(Clone, Debug, PartialEq, Serialize, serde::Deserialize)]
pub struct TargetVerification {
    pub id: String,
    pub x: f64,
    pub y: f64,
    /// Screen pixels under the field.
    pub pixels: u64,
    pub intended: [f64; 3],
    pub predicted: [f64; 3],
    pub emitted: [f64; 3],
    pub delta_e00_intended_emitted: f64,
    /// Intended → predicted: the quantisation's share.
    pub delta_e00_quantisation: f64,
    /// Predicted → emitted: the display against its profile.
    pub delta_e00_profile: f64,
    pub booth_xyz: Option<[f64; 3]>,
    /// The booth's light at the target against the displayed image's.
    pub delta_e00_booth_emitted: Option<f64>,
}

/// The fields of `targets` on an image of `width` pixels per row whose
/// pixels the display is asked to show as `linear` (RGB 0–1 after the
/// gamut policy), drawn as codes of `bits` (8, 10 or 12; `None`: 8-bit
/// noisy-bit dithering) through the profile's γ, each image pixel shown
/// as `magnification` × `magnification` screen pixels, with a field of
/// `radius_px` screen pixels: each image pixel weighs as many of its screen
/// pixels as the field sees ([`field_weight`]). An error names a target
/// whose field holds no pixel.
pub fn target_fields(
    profile: &DisplayProfile,
    linear: &[[f32; 3]],
    width: usize,
    bits: Option<u32>,
    targets: &[TargetOnScreen],
    radius_px: f64,
    magnification: u32,
) -> Result<Vec<TargetField>, DisplayError> {
    let converter = Converter::new(profile)?;
    let fb = FrameBuffer::new(bits.unwrap_or(8))?;
    let model = TransferModel::Gamma;
    let codes: Vec<[u32; 3]> = linear
        .iter()
        .map(|l| profile.codes_of_linear(l.map(f64::from), fb, model))
        .collect();
    targets
        .iter()
        .map(|t| {
            let counts = CodeCounts::of_disc(&codes, width, fb.max_code(), (t.x, t.y), radius_px, magnification)
                .map_err(|e| DisplayError::Profile(format!("target {}: {e}", t.id)))?;
            let mut intended = [0.0; 3];
            let mut predicted_linear = [0.0; 3];
            let mut pixels = 0u64;
            for (i, (l, c)) in linear.iter().zip(&codes).enumerate() {
                let w = field_weight(i % width, i / width, (t.x, t.y), radius_px, magnification);
                if w == 0 {
                    continue;
                }
                let wf = w as f64;
                let xyz = converter.xyz(l.map(f64::from));
                for k in 0..3 {
                    intended[k] += wf * xyz[k];
                    predicted_linear[k] += wf
                        * match bits {
                            Some(_) => profile.transfer[k].output(fb.drive(c[k]), model),
                            None => {
                                let drive = profile.transfer[k].drive(f64::from(l[k]).clamp(0.0, 1.0), model);
                                mean_dithered_output(profile, k, drive)
                            }
                        };
                }
                pixels += w;
            }
            let n = pixels as f64;
            Ok(TargetField {
                target: t.clone(),
                counts,
                pixels,
                intended: intended.map(|v| v / n),
                predicted: converter.xyz(predicted_linear.map(|v| v / n)),
            })
        })
        .collect()
}

/// One field, with what the instrument measured there (`emitted`, XYZ cd/m²).
pub fn assess_target(
    profile: &DisplayProfile,
    field: &TargetField,
    emitted: [f64; 3],
) -> Result<TargetVerification, DisplayError> {
    let white = Converter::new(profile)?.white();
    let t = &field.target;
    Ok(TargetVerification {
        id: t.id.clone(),
        x: t.x,
        y: t.y,
        pixels: field.pixels,
        intended: field.intended,
        predicted: field.predicted,
        emitted,
        delta_e00_intended_emitted: delta_e00(white, field.intended, emitted),
        delta_e00_quantisation: delta_e00(white, field.intended, field.predicted),
        delta_e00_profile: delta_e00(white, field.predicted, emitted),
        booth_xyz: t.booth_xyz,
        delta_e00_booth_emitted: t.booth_xyz.map(|b| delta_e00(white, b, emitted)),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::colorimetry::{xyz_from_radiance, Observer};
    use crate::display::SimulatedDisplay;

    /// A 40 × 20 image: a red-green gradient left to right, constant blue.
    fn gradient() -> Vec<[f32; 3]> {
        (0..40 * 20)
            .map(|i| {
                let t = (i % 40) as f32 / 39.0;
                [0.1 + 0.8 * t, 0.9 - 0.8 * t, 0.3]
            })
            .collect()
    }

    fn targets() -> Vec<TargetOnScreen> {
        [("left", 6.0), ("middle", 20.0), ("right", 34.0)]
            .into_iter()
            .map(|(id, x)| TargetOnScreen {
                id: id.into(),
                x,
                y: 10.0,
                booth_xyz: None,
            })
            .collect()
    }

    /// What the simulated CRT emits for a field: its own spectra of the codes.
    fn emitted(display: &SimulatedDisplay, field: &TargetField) -> [f64; 3] {
        let s = display.mean_spectrum(&field.counts).unwrap();
        xyz_from_radiance(&s, Observer::JuddVos).unwrap().to_array()
    }

    /// With the display's exact profile, the emitted light is the predicted
    /// (the profile is the display), and the whole error at each target is
    /// the quantisation's, under half an 8-bit code's worst case.
    #[test]
    fn with_the_displays_own_profile_only_quantisation_remains() {
        let display = SimulatedDisplay::crt().unwrap();
        let profile = display.exact_profile(Observer::JuddVos).unwrap();
        let fields = target_fields(&profile, &gradient(), 40, Some(8), &targets(), 4.0, 1).unwrap();
        for f in &fields {
            assert!(
                (45..=53).contains(&f.pixels),
                "{}: {} pixels in a disc of radius 4",
                f.target.id,
                f.pixels
            );
            let v = assess_target(&profile, f, emitted(&display, f)).unwrap();
            assert!(v.delta_e00_profile < 0.01, "{v:?}");
            assert!(v.delta_e00_quantisation < 0.5, "{v:?}");
            assert!(
                (v.delta_e00_intended_emitted - v.delta_e00_quantisation).abs() < 0.01,
                "{v:?}"
            );
        }
    }

    /// A profile whose green γ is 0.2 too high predicts too little green
    /// where green is dim: the error shows at the right target (the right
    /// end, where green is lowest) and is larger there than where green is
    /// bright, while the quantisation stays small everywhere.
    #[test]
    fn a_profile_with_a_wrong_green_gamma_shows_at_the_targets_where_green_is_dim() {
        let display = SimulatedDisplay::crt().unwrap();
        let mut wrong = display.exact_profile(Observer::JuddVos).unwrap();
        wrong.transfer[1].gamma += 0.2;
        let fields = target_fields(&wrong, &gradient(), 40, Some(8), &targets(), 4.0, 1).unwrap();
        let v: Vec<TargetVerification> = fields
            .iter()
            .map(|f| assess_target(&wrong, f, emitted(&display, f)).unwrap())
            .collect();
        for t in &v {
            println!(
                "{}: profile ΔE00 {:.3}, quantisation {:.3}",
                t.id, t.delta_e00_profile, t.delta_e00_quantisation
            );
            assert!(t.delta_e00_quantisation < 0.5);
        }
        assert!(v[0].delta_e00_profile > 0.5, "{:?}", v[0]);
        assert!(
            v[2].delta_e00_profile > v[0].delta_e00_profile,
            "{:?} against {:?}",
            v[2],
            v[0]
        );
        // The size, in closed form: the page drives green at v = t^(1/γ′)
        // for the intended t, and the CRT emits v^γ = t^(γ/γ′); the emitted
        // green (read back through the display's own exact profile) is the
        // disc's mean of that, to the 8-bit rounding.
        let exact = display.exact_profile(Observer::JuddVos).unwrap();
        let (gamma, wrong_gamma) = (exact.transfer[1].gamma, wrong.transfer[1].gamma);
        let image = gradient();
        for (t, f) in v.iter().zip(&fields) {
            let inside = |i: usize| {
                let (x, y) = ((i % 40) as f64 + 0.5, (i / 40) as f64 + 0.5);
                (x - f.target.x).powi(2) + (y - f.target.y).powi(2) <= 16.0
            };
            let disc: Vec<f64> = (0..image.len())
                .filter(|&i| inside(i))
                .map(|i| f64::from(image[i][1]).powf(gamma / wrong_gamma))
                .collect();
            let expected = disc.iter().sum::<f64>() / disc.len() as f64;
            let green = Converter::new(&exact).unwrap().linear(t.emitted)[1];
            assert!(
                (green / expected - 1.0).abs() < 0.02,
                "{}: green {green} against {expected}",
                t.id
            );
        }
    }

    /// Magnified, the field sees more screen pixels of fewer image pixels:
    /// the screen pixels under the field are about π r² (the disc's area)
    /// at any magnification, the counts add up to them, and a magnification
    /// of 2 with twice the radius (the same disc in the image) gives the
    /// colours of magnification 1 to within the sampling of the disc's edge.
    #[test]
    fn a_magnified_image_weighs_each_pixel_by_its_screen_pixels_under_the_field() {
        let display = SimulatedDisplay::crt().unwrap();
        let profile = display.exact_profile(Observer::JuddVos).unwrap();
        let one = target_fields(&profile, &gradient(), 40, Some(8), &targets(), 4.0, 1).unwrap();
        let two = target_fields(&profile, &gradient(), 40, Some(8), &targets(), 8.0, 2).unwrap();
        for (a, b) in one.iter().zip(&two) {
            for k in 0..3 {
                assert!(
                    (a.intended[k] / b.intended[k] - 1.0).abs() < 0.01,
                    "{}: {:?} against {:?}",
                    a.target.id,
                    a.intended,
                    b.intended
                );
            }
        }
        for (m, r) in [(1u32, 9.0), (3, 12.0), (4, 30.0)] {
            let fields = target_fields(&profile, &gradient(), 40, Some(8), &targets(), r, m).unwrap();
            let area = std::f64::consts::PI * r * r;
            // The middle target's disc lies inside the 40 × 20 image.
            for f in fields.iter().filter(|f| f.target.id == "middle") {
                assert!(
                    (f.pixels as f64 / area - 1.0).abs() < 0.05,
                    "×{m}, r {r}: {}: {} screen pixels against π r² = {area:.0}",
                    f.target.id,
                    f.pixels
                );
                for c in 0..3 {
                    assert_eq!(f.counts.counts[c].iter().sum::<u64>(), f.pixels);
                }
            }
        }
    }
}
