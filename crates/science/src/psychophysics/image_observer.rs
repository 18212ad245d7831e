//! What a simulated observer sees of an image trial (issue 48, part 4):
//! the three pieces are copies of one image region, two in the reference
//! coding and one in the approximation (or the reverse), and the observer
//! answers as the patch observer ([`super::observer::SimulatedObserver`])
//! does, with a d′ = ΔE / σ where ΔE is what a stated decision rule takes
//! from the two shown images.
//!
//! The rules ([`ImageDecisionRule`]):
//! - **`most_discriminable_pixel`** (the default): the largest ΔE00 between
//!   the two images at one pixel of the region. An observer who scans the
//!   region for the place where the two differ most; the study's σ was
//!   fitted on uniform patches, and a patch is exactly this rule's image
//!   with every pixel the same, so the rule carries the patch σ to images
//!   unchanged. It ignores that a difference spread over many pixels may
//!   be easier to see than one at a single pixel (spatial summation), so
//!   it predicts at most what a summing observer would see: a lower bound
//!   on discriminability, stated as such.
//! - **`region_mean`**: the ΔE00 between the region's mean colours in the
//!   two images. An observer who sees the region as one colour; it misses
//!   differences that cancel over the region (a gradient shifted up in
//!   one half and down in the other).
//!
//! For a uniform region both rules give the patch's ΔE00 exactly.
//! Colours are CIELAB of the shown XYZ with the display's white; ΔE is
//! CIEDE2000, as the experiments' shown differences are.

use serde::{Deserialize, Serialize};

use crate::colorimetry::{ciede2000, Lab, Xyz};

/// How the simulated observer turns two images into one colour difference.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ImageDecisionRule {
    #[default]
    MostDiscriminablePixel,
    RegionMean,
}

impl ImageDecisionRule {
    pub fn name(self) -> &'static str {
        match self {
            ImageDecisionRule::MostDiscriminablePixel => "most_discriminable_pixel",
            ImageDecisionRule::RegionMean => "region_mean",
        }
    }
}

/// What the rule takes from two images of a region.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ImageSignal {
    pub rule: ImageDecisionRule,
    /// The ΔE00 the observer's d′ is counted from (d′ = ΔE00 / σ).
    pub delta_e00: f64,
    /// For `most_discriminable_pixel`, the index (in the region) of the pixel.
    pub pixel: Option<usize>,
}

/// The signal of `rule` between two shown images of one region (XYZ cd/m²
/// per pixel, the same pixels in the same order) with CIELAB white `white`.
/// An error when the regions differ in size or are empty.
pub fn image_signal(
    rule: ImageDecisionRule,
    reference: &[[f64; 3]],
    approximation: &[[f64; 3]],
    white: Xyz,
) -> Result<ImageSignal, String> {
    if reference.len() != approximation.len() || reference.is_empty() {
        return Err(format!(
            "the two images of a region have {} and {} pixels: give the same, at least one",
            reference.len(),
            approximation.len()
        ));
    }
    let lab = |v: [f64; 3]| Lab::from_xyz(Xyz::from_array(v), white);
    Ok(match rule {
        ImageDecisionRule::MostDiscriminablePixel => {
            let (pixel, delta_e00) = reference
                .iter()
                .zip(approximation)
                .map(|(r, a)| ciede2000(lab(*r), lab(*a)))
                .enumerate()
                .fold(
                    (0, f64::NEG_INFINITY),
                    |best, (i, e)| if e > best.1 { (i, e) } else { best },
                );
            ImageSignal {
                rule,
                delta_e00,
                pixel: Some(pixel),
            }
        }
        ImageDecisionRule::RegionMean => {
            let mean = |v: &[[f64; 3]]| -> [f64; 3] {
                let n = v.len() as f64;
                std::array::from_fn(|k| v.iter().map(|p| p[k]).sum::<f64>() / n)
            };
            ImageSignal {
                rule,
                delta_e00: ciede2000(lab(mean(reference)), lab(mean(approximation))),
                pixel: None,
            }
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::psychophysics::design::{Configuration, Stimulus};
    use crate::psychophysics::observer::SimulatedObserver;
    use crate::psychophysics::oddity::OddityModel;
    use crate::random::SplitMix64;

    fn white() -> Xyz {
        Xyz::new(95.047, 100.0, 108.883)
    }

    /// A uniform region is a patch: both rules give the patch's ΔE00.
    #[test]
    fn a_uniform_region_gives_both_rules_the_patchs_difference() {
        let (a, b) = ([30.0, 32.0, 28.0], [31.0, 32.0, 27.0]);
        let patch = ciede2000(
            Lab::from_xyz(Xyz::from_array(a), white()),
            Lab::from_xyz(Xyz::from_array(b), white()),
        );
        for rule in [ImageDecisionRule::MostDiscriminablePixel, ImageDecisionRule::RegionMean] {
            let s = image_signal(rule, &[a; 50], &[b; 50], white()).unwrap();
            assert!(
                (s.delta_e00 - patch).abs() < 1e-12,
                "{rule:?}: {} against {patch}",
                s.delta_e00
            );
        }
    }

    /// A gradient shifted up in one half and down in the other: the mean
    /// rule sees (almost) nothing, the pixel rule finds the largest shift
    /// where it is.
    #[test]
    fn a_difference_that_cancels_over_the_region_is_seen_only_by_the_pixel_rule() {
        let reference: Vec<[f64; 3]> = (0..40)
            .map(|i| [20.0 + i as f64, 21.0 + i as f64, 22.0 + i as f64])
            .collect();
        let approximation: Vec<[f64; 3]> = reference
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let s = if i < 20 { 1.0 } else { -1.0 } * if i == 7 { 2.0 } else { 1.0 };
                [p[0] + s, p[1], p[2]]
            })
            .collect();
        let max = image_signal(
            ImageDecisionRule::MostDiscriminablePixel,
            &reference,
            &approximation,
            white(),
        )
        .unwrap();
        let mean = image_signal(ImageDecisionRule::RegionMean, &reference, &approximation, white()).unwrap();
        assert_eq!(max.pixel, Some(7));
        assert!(mean.delta_e00 < 0.1 * max.delta_e00, "{mean:?} against {max:?}");
        assert!(image_signal(ImageDecisionRule::RegionMean, &reference, &approximation[..3], white()).is_err());
    }

    /// The observer answers image trials from the rule's d′ as it does
    /// patches: over 6000 trials its proportion correct is the oddity
    /// model's Pc(ΔE00/σ) within 4 binomial standard errors.
    #[test]
    fn image_trials_are_answered_at_the_models_proportion_correct() {
        let reference = vec![[30.0, 32.0, 28.0]; 9];
        let approximation: Vec<[f64; 3]> = (0..9).map(|i| [30.0 + 0.2 * i as f64, 32.0, 28.0]).collect();
        let s = image_signal(
            ImageDecisionRule::MostDiscriminablePixel,
            &reference,
            &approximation,
            white(),
        )
        .unwrap();
        let observer = SimulatedObserver::new(0.6, OddityModel::Differencing).unwrap();
        let d = s.delta_e00 / observer.sigma();
        let configurations = [
            Configuration([Stimulus::Approximation, Stimulus::Original, Stimulus::Original]),
            Configuration([Stimulus::Original, Stimulus::Approximation, Stimulus::Original]),
            Configuration([Stimulus::Original, Stimulus::Original, Stimulus::Approximation]),
        ];
        let block: Vec<Configuration> = (0..6000).map(|i| configurations[i % 3]).collect();
        let correct = observer.run_block(&block, d, &mut SplitMix64(3)) as f64 / 6000.0;
        let pc = OddityModel::Differencing.proportion_correct(d);
        let se = (pc * (1.0 - pc) / 6000.0).sqrt();
        assert!((correct - pc).abs() < 4.0 * se, "d′ {d}: {correct} against Pc {pc}");
    }
}
