//! The simulated display of `serve --mock`: what the simulated PR-650 sees
//! while the calibration page shows a colour.
//!
//! Primaries: a typical CRT's (Brainard 1997, via colour-science; see
//! `crates/science/src/reference_data/PROVENANCE.md`), relative spectra resampled linearly
//! from 5 nm to 1 nm and scaled so that white (all channels at full drive,
//! black included) has a luminance of [`WHITE_CD_M2`] (CIE 1931 ȳ). Black:
//! [`BLACK_FRACTION`] of the primaries' sum (a CRT's glow and room
//! reflections, with the white's chromaticity). Transfer: a pure power of
//! the drive per channel, [`GAMMAS`], the model the fit assumes; the
//! simulated display is exactly additive.

use super::{fit_profile, CalibrationPlan, DisplayError, DisplayProfile, MeasuredPatch};
use crate::colorimetry::{xyz_from_radiance, Observer};
use crate::spectrum::table::SpectraTable;
use crate::spectrum::{Grid, SpectralUnit, Spectrum};

const PRIMARIES_CSV: &str = include_str!("../reference_data/display_crt_brainard1997.csv");

/// Luminance of the simulated white, cd/m².
pub const WHITE_CD_M2: f64 = 100.0;
/// Black level as a fraction of the primaries' sum at full drive.
pub const BLACK_FRACTION: f64 = 0.005;
/// γ of red, green, blue.
pub const GAMMAS: [f64; 3] = [2.25, 2.2, 2.15];

/// What one patch of the screen showed while it was measured: per channel,
/// how many pixels × frames had each code (`counts[c][k]`, codes
/// 0–`max_code`). A dithered patch is many codes; a plain one, one.
#[derive(Clone, Debug, PartialEq)]
pub struct CodeCounts {
    /// 255 (8 bits) or 1023 (10 bits).
    pub max_code: u32,
    /// Red, green, blue: `max_code + 1` counts each, the same total per channel.
    pub counts: [Vec<u64>; 3],
}

/// Pixels × frames a [`CodeCounts`] may hold per channel (a 4K screen for
/// two seconds at 120 Hz).
pub const MAX_COUNTED: u64 = 4096 * 2160 * 240;

/// How many of image pixel (`x`, `y`)'s screen pixels an instrument's
/// field sees: the image drawn with each image pixel as `magnification` ×
/// `magnification` screen pixels, the field a disc of `radius_px` screen
/// pixels around `centre` (image pixels, from the top-left corner); a
/// screen pixel is inside when its centre is. With magnification 1, 1 when
/// the image pixel's centre is inside, else 0.
pub fn field_weight(x: usize, y: usize, centre: (f64, f64), radius_px: f64, magnification: u32) -> u64 {
    let m = magnification.max(1) as f64;
    let r = radius_px / m;
    let (x, y) = (x as f64, y as f64);
    // Quick rejection of pixels wholly outside the disc.
    if x + 1.0 < centre.0 - r || x > centre.0 + r || y + 1.0 < centre.1 - r || y > centre.1 + r {
        return 0;
    }
    let mut n = 0;
    for b in 0..magnification.max(1) {
        for a in 0..magnification.max(1) {
            let (sx, sy) = (x + (a as f64 + 0.5) / m, y + (b as f64 + 0.5) / m);
            if (sx - centre.0).powi(2) + (sy - centre.1).powi(2) <= r * r {
                n += 1;
            }
        }
    }
    n
}

impl CodeCounts {
    /// What an instrument's field sees of an image on the screen: the
    /// codes of the screen pixels whose centres lie within `radius_px`
    /// (screen pixels) of `centre` (image pixels, x right and y down from
    /// the top-left corner), the image drawn with each image pixel as
    /// `magnification` × `magnification` screen pixels, one frame
    /// ([`field_weight`] pixel by pixel). `codes` holds the image's rows
    /// top to bottom, `width` pixels each; an error when the disc holds no
    /// screen pixel centre or a code exceeds `max_code`.
    pub fn of_disc(
        codes: &[[u32; 3]],
        width: usize,
        max_code: u32,
        centre: (f64, f64),
        radius_px: f64,
        magnification: u32,
    ) -> Result<CodeCounts, String> {
        if width == 0 || !codes.len().is_multiple_of(width) {
            return Err(format!("{} codes are not whole rows of {width}", codes.len()));
        }
        let mut counts = [0, 1, 2].map(|_| vec![0u64; max_code as usize + 1]);
        let mut inside = 0;
        for (i, code) in codes.iter().enumerate() {
            let w = field_weight(i % width, i / width, centre, radius_px, magnification);
            if w == 0 {
                continue;
            }
            for c in 0..3 {
                let k = code[c] as usize;
                if k > max_code as usize {
                    return Err(format!("pixel {i}: code {} above {max_code}", code[c]));
                }
                counts[c][k] += w;
            }
            inside += w;
        }
        if inside == 0 {
            return Err(format!(
                "no pixel centre within {radius_px:.2} px of ({:.1}, {:.1}): aim the field at the image",
                centre.0, centre.1
            ));
        }
        Ok(CodeCounts { max_code, counts })
    }

    /// Checks the shape; says what is wrong with which channel.
    pub fn check(&self) -> Result<u64, String> {
        if !matches!(self.max_code, 255 | 1023) {
            return Err(format!(
                "max_code = {}: give 255 (8 bits) or 1023 (10 bits)",
                self.max_code
            ));
        }
        let mut total = None;
        for (c, counts) in self.counts.iter().enumerate() {
            let name = ["red", "green", "blue"][c];
            if counts.len() != self.max_code as usize + 1 {
                return Err(format!(
                    "{name}: {} counts; give one per code 0–{}",
                    counts.len(),
                    self.max_code
                ));
            }
            let sum = counts
                .iter()
                .try_fold(0u64, |a, &n| a.checked_add(n))
                .unwrap_or(u64::MAX);
            if sum == 0 || sum > MAX_COUNTED {
                return Err(format!("{name}: {sum} pixels × frames counted; give 1–{MAX_COUNTED}"));
            }
            match total {
                None => total = Some(sum),
                Some(t) if t != sum => {
                    return Err(format!(
                        "{name}: {sum} pixels × frames counted, but red has {t}: every channel counts the same pixels"
                    ));
                }
                _ => {}
            }
        }
        Ok(total.unwrap_or(0))
    }
}

/// A display whose truth is known: the one the simulated PR-650 looks at.
#[derive(Clone, Debug)]
pub struct SimulatedDisplay {
    grid: Grid,
    black: Vec<f64>,
    primaries: [Vec<f64>; 3],
    gammas: [f64; 3],
}

impl SimulatedDisplay {
    /// The shipped CRT (see the module doc).
    pub fn crt() -> Result<SimulatedDisplay, DisplayError> {
        let table = SpectraTable::parse(PRIMARIES_CSV, "display_crt_brainard1997.csv")
            .map_err(|e| DisplayError::Profile(e.to_string()))?;
        let grid = Grid::one_nm();
        let mut rel = Vec::new();
        for name in ["red", "green", "blue"] {
            let s = table
                .spectrum(name, SpectralUnit::RelativePower)
                .map_err(|e| DisplayError::Profile(e.to_string()))?;
            rel.push(s.resample(&grid)?.into_values());
        }
        let sum: Vec<f64> = (0..grid.len()).map(|i| rel[0][i] + rel[1][i] + rel[2][i]).collect();
        let y_sum = xyz_from_radiance(
            &Spectrum::new(grid.clone(), SpectralUnit::SpectralRadiance, sum.clone())?,
            Observer::Cie1931,
        )?
        .y;
        let k = WHITE_CD_M2 / (y_sum * (1.0 + BLACK_FRACTION));
        let scale = |v: &[f64]| v.iter().map(|x| x * k).collect::<Vec<f64>>();
        Ok(SimulatedDisplay {
            black: sum.iter().map(|x| x * k * BLACK_FRACTION).collect(),
            primaries: [scale(&rel[0]), scale(&rel[1]), scale(&rel[2])],
            grid,
            gammas: GAMMAS,
        })
    }

    /// The spectral radiance shown for drives 0–1 per channel (clamped), 1 nm grid.
    pub fn spectrum(&self, drive: [f64; 3]) -> Spectrum {
        let t = [0, 1, 2].map(|c| drive[c].clamp(0.0, 1.0).powf(self.gammas[c]));
        let values = (0..self.grid.len())
            .map(|i| self.black[i] + (0..3).map(|c| t[c] * self.primaries[c][i]).sum::<f64>())
            .collect();
        Spectrum::new(self.grid.clone(), SpectralUnit::SpectralRadiance, values).expect("finite by construction")
    }

    /// The mean spectral radiance of a patch whose pixels and frames showed
    /// `codes` (1 nm grid). The display is additive and each channel's
    /// output depends on its own code alone, so the mean over pixels is
    /// black plus each primary times its channel's mean output, exactly.
    pub fn mean_spectrum(&self, codes: &CodeCounts) -> Result<Spectrum, String> {
        let total = codes.check()? as f64;
        let max = f64::from(codes.max_code);
        let t = [0, 1, 2].map(|c| {
            codes.counts[c]
                .iter()
                .enumerate()
                .filter(|(_, &n)| n > 0)
                .map(|(k, &n)| n as f64 * (k as f64 / max).powf(self.gammas[c]))
                .sum::<f64>()
                / total
        });
        let values = (0..self.grid.len())
            .map(|i| self.black[i] + (0..3).map(|c| t[c] * self.primaries[c][i]).sum::<f64>())
            .collect();
        Ok(Spectrum::new(self.grid.clone(), SpectralUnit::SpectralRadiance, values).expect("finite by construction"))
    }

    /// The profile a calibration would fit to this display's exact 1 nm
    /// spectra (the eight-level plan of [`CalibrationPlan::new`]): for tests
    /// and for the simulated booth's experiments.
    pub fn exact_profile(&self, observer: Observer) -> Result<DisplayProfile, DisplayError> {
        let patches: Vec<MeasuredPatch> = CalibrationPlan::new(8)?
            .patches
            .iter()
            .enumerate()
            .map(|(i, p)| {
                MeasuredPatch::spectrum(
                    p.drive,
                    self.grid.wavelengths().to_vec(),
                    self.spectrum(p.drive).into_values(),
                    Some(i as i64 + 1),
                )
            })
            .collect();
        fit_profile(&patches, observer)
    }

    /// The true γ of each channel.
    pub fn gammas(&self) -> [f64; 3] {
        self.gammas
    }

    /// The true chromaticity x, y of each primary's increment over black.
    pub fn primary_chromaticities(&self, observer: Observer) -> Result<[[f64; 2]; 3], DisplayError> {
        let mut out = [[0.0; 2]; 3];
        for (o, p) in out.iter_mut().zip(&self.primaries) {
            let s = Spectrum::new(self.grid.clone(), SpectralUnit::SpectralRadiance, p.clone())?;
            let c = xyz_from_radiance(&s, observer)?.chromaticity();
            *o = [c.x, c.y];
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bug (issue 32): a scene measurement queued between a
    /// calibration's patches made patch "red 60 %" read the GREEN scene
    /// patch; the profile was stored (red γ 3.18, RMS residual 0.106, grey
    /// validation ΔE00 8–12) and offered like any other. Such a profile
    /// fails its checks, each named; the clean one passes.
    #[test]
    fn a_profile_fitted_to_a_corrupted_patch_was_stored_without_a_word() {
        let d = SimulatedDisplay::crt().unwrap();
        assert_eq!(
            d.exact_profile(Observer::JuddVos).unwrap().failures(),
            Vec::<String>::new()
        );
        let plan = CalibrationPlan::new(8).unwrap();
        let patches: Vec<MeasuredPatch> = plan
            .patches
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let red_mid = p.drive[1] == 0.0 && p.drive[2] == 0.0 && (0.5..0.7).contains(&p.drive[0]);
                // What the instrument saw instead: a green scene patch.
                let seen = if red_mid { [0.05, 0.55, 0.1] } else { p.drive };
                MeasuredPatch::spectrum(
                    p.drive,
                    d.grid.wavelengths().to_vec(),
                    d.spectrum(seen).into_values(),
                    Some(i as i64 + 1),
                )
            })
            .collect();
        assert!(
            plan.patches
                .iter()
                .any(|p| p.drive[1] == 0.0 && p.drive[2] == 0.0 && (0.5..0.7).contains(&p.drive[0])),
            "the plan has a red patch near 60 %"
        );
        let profile = fit_profile(&patches, Observer::JuddVos).unwrap();
        let failures = profile.failures();
        assert!(
            failures.iter().any(|f| f.starts_with("red transfer: RMS residual")),
            "{failures:?}"
        );
    }

    fn counts_at(max_code: u32, code: [usize; 3], n: u64) -> CodeCounts {
        let mut counts = [0, 1, 2].map(|_| vec![0u64; max_code as usize + 1]);
        for c in 0..3 {
            counts[c][code[c]] = n;
        }
        CodeCounts { max_code, counts }
    }

    #[test]
    fn one_code_everywhere_is_that_codes_spectrum() {
        let d = SimulatedDisplay::crt().unwrap();
        let shown = d.mean_spectrum(&counts_at(255, [200, 10, 128], 64)).unwrap();
        let drive = [200.0 / 255.0, 10.0 / 255.0, 128.0 / 255.0];
        for (a, b) in shown.values().iter().zip(d.spectrum(drive).values()) {
            assert!((a - b).abs() <= 1e-12 * b.abs().max(1e-9), "{a} {b}");
        }
    }

    #[test]
    fn a_dithered_patch_is_the_count_weighted_mean_of_its_codes_spectra() {
        // 70 % of pixels at 127, 30 % at 128 on every gun: the mean radiance
        // is 0.7·S(127) + 0.3·S(128) (additivity), between the two levels.
        let d = SimulatedDisplay::crt().unwrap();
        let mut c = counts_at(255, [127; 3], 700);
        for ch in 0..3 {
            c.counts[ch][128] = 300;
        }
        let mean = d.mean_spectrum(&c).unwrap();
        let lo = d.spectrum([127.0 / 255.0; 3]);
        let hi = d.spectrum([128.0 / 255.0; 3]);
        for i in 0..lo.values().len() {
            let want = 0.7 * lo.values()[i] + 0.3 * hi.values()[i];
            assert!((mean.values()[i] - want).abs() <= 1e-12 * want.max(1e-9));
        }
    }

    #[test]
    fn counts_of_the_wrong_shape_are_refused_naming_the_channel() {
        let mut c = counts_at(255, [1; 3], 5);
        c.counts[2][1] = 4;
        assert!(c.check().unwrap_err().starts_with("blue: 4 pixels"));
        c.counts[1].pop();
        assert!(c.check().unwrap_err().starts_with("green: 255 counts"));
        assert!(counts_at(511, [0; 3], 1)
            .check()
            .unwrap_err()
            .contains("255 (8 bits) or 1023"));
        assert!(counts_at(255, [0; 3], 0).check().unwrap_err().contains("0 pixels"));
    }

    /// An instrument's field on an image: the mean spectrum of a disc over
    /// two halves of different colour is the mean of the two patches'
    /// spectra weighted by their pixels in the disc (the display is additive).
    #[test]
    fn a_field_over_an_image_sees_the_mean_spectrum_of_its_pixels() {
        let d = SimulatedDisplay::crt().unwrap();
        let (w, h) = (20usize, 10usize);
        let (left, right) = ([200u32, 40, 90], [30u32, 180, 60]);
        let codes: Vec<[u32; 3]> = (0..w * h).map(|i| if i % w < 10 { left } else { right }).collect();
        let counts = CodeCounts::of_disc(&codes, w, 255, (10.0, 5.0), 3.2, 1).unwrap();
        let n = counts.check().unwrap();
        let n_left = counts.counts[0][200];
        assert_eq!(n_left * 2, n, "the disc straddles the edge evenly");
        let seen = d.mean_spectrum(&counts).unwrap();
        let drive = |c: [u32; 3]| c.map(|v| f64::from(v) / 255.0);
        let (a, b) = (d.spectrum(drive(left)), d.spectrum(drive(right)));
        for ((s, x), y) in seen.values().iter().zip(a.values()).zip(b.values()) {
            assert!(
                (s - 0.5 * (x + y)).abs() <= 1e-12 * x.abs().max(y.abs()).max(1e-12),
                "{s} against {x}, {y}"
            );
        }
        let e = CodeCounts::of_disc(&codes, w, 255, (-50.0, 5.0), 3.0, 1).unwrap_err();
        assert!(e.contains("no pixel centre"), "{e}");
    }
}
