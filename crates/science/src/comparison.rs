//! How far a rendering is from a measurement: the study's figures of merit.
//!
//! Per point: CIELAB ΔE*ab and ΔE00, the luminance ratio rendered/measured
//! and the distance in the x,y diagram. Per scene (over its points):
//! the relative RMS luminance error
//!
//! ```text
//! rms_rel = sqrt( mean_i (1 − S_i / M_i)² )      S simulated, M measured luminance
//! ```
//!
//! and the mean ΔE with its sample standard deviation (n − 1), as in
//! Ruppertsberg & Bloj (2006), Fig. 3. Both sides go through CIELAB with the
//! same reference white, which the caller states and which is stored with
//! every comparison, and every figure names the observer of its XYZ.
//!
//! # Beyond noise
//!
//! A rendered value differs from the measured (or reference) one *beyond
//! noise* when
//!
//! ```text
//! |S − M| > k · √(SE_S² + SE_M²)        k = 3 (BEYOND_NOISE_K)
//! ```
//!
//! with SE_S the rendering's Monte Carlo standard error and SE_M the
//! measurement's (its samples' SD/√n). For Gaussian errors a true difference
//! of zero passes this test with probability 0.27 %; k = 3 rather than 2
//! because a study tests some 150 targets × codings at once, and at k = 2
//! about 7 of them would be flagged by chance alone. A difference of zero is
//! never beyond noise, whatever the SEs.
//!
//! ```
//! use lightbooth_science::colorimetry::{Observer, Xyz};
//! use lightbooth_science::comparison::{compare_point, summarize};
//! let white = Xyz::new(32.5, 34.2, 37.2);
//! let m = Xyz::new(10.0, 11.0, 5.0);
//! let d = compare_point(m, m.scaled(1.1), white, Observer::JuddVos);
//! assert!((d.y_ratio - 1.1).abs() < 1e-12);
//! let s = summarize(&[d]);
//! assert!((s.rms_rel - 0.1).abs() < 1e-12);
//! ```

use serde::Serialize;

use crate::colorimetry::{ciede2000, delta_e76, Lab, Observer, Xyz};

/// k of the beyond-noise test: |difference| > k · combined standard error.
pub const BEYOND_NOISE_K: f64 = 3.0;

/// Whether `difference` exceeds [`BEYOND_NOISE_K`] times the combined
/// standard error √(se_a² + se_b²) of its two sides (see the module doc).
/// Zero is never beyond noise; a non-zero difference with both SEs zero is.
pub fn beyond_noise(difference: f64, se_a: f64, se_b: f64) -> bool {
    difference != 0.0 && difference.abs() > BEYOND_NOISE_K * se_a.hypot(se_b)
}

/// ΔE*ab and ΔE00 between two CIELAB colours.
pub fn delta_e_pair(p: Lab, q: Lab) -> (f64, f64) {
    (delta_e76(p, q), ciede2000(p, q))
}

/// The difference between one measured and one rendered colour.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct PointDifference {
    /// The observer of both XYZ and so of x,y, CIELAB and ΔE.
    pub observer: Observer,
    pub measured: Xyz,
    pub rendered: Xyz,
    /// Rendered luminance over measured luminance.
    pub y_ratio: f64,
    /// Euclidean distance between the two chromaticities in the x,y diagram
    /// of `observer`.
    pub xy_distance: f64,
    #[serde(rename = "dE76")]
    pub de76: f64,
    #[serde(rename = "dE00")]
    pub de00: f64,
}

/// Compares a rendered XYZ with a measured one through CIELAB with `white`
/// (all three on the same scale, e.g. cd/m², and all three XYZ of `observer`).
pub fn compare_point(measured: Xyz, rendered: Xyz, white: Xyz, observer: Observer) -> PointDifference {
    let lab_m = Lab::from_xyz(measured, white);
    let lab_r = Lab::from_xyz(rendered, white);
    PointDifference {
        observer,
        measured,
        rendered,
        y_ratio: rendered.y / measured.y,
        xy_distance: measured.chromaticity().distance(rendered.chromaticity()),
        de76: delta_e76(lab_m, lab_r),
        de00: ciede2000(lab_m, lab_r),
    }
}

/// A scene's figures of merit over its points.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SceneSummary {
    /// The observer of the points summarised.
    pub observer: Observer,
    pub points: usize,
    pub rms_rel: f64,
    #[serde(rename = "mean_dE76")]
    pub mean_de76: f64,
    /// Sample standard deviation (n − 1); `None` with a single point.
    #[serde(rename = "sd_dE76")]
    pub sd_de76: Option<f64>,
    #[serde(rename = "mean_dE00")]
    pub mean_de00: f64,
    #[serde(rename = "sd_dE00")]
    pub sd_de00: Option<f64>,
}

/// rms_rel and mean ± SD of ΔE over a scene's points. Panics on no points
/// or on points of different observers: either is a caller bug.
pub fn summarize(points: &[PointDifference]) -> SceneSummary {
    assert!(!points.is_empty(), "a scene summary needs at least one point");
    let observer = points[0].observer;
    assert!(
        points.iter().all(|p| p.observer == observer),
        "a scene summary mixes observers"
    );
    let n = points.len() as f64;
    let rms_rel = (points.iter().map(|p| (1.0 - p.y_ratio).powi(2)).sum::<f64>() / n).sqrt();
    let (mean_de76, sd_de76) = mean_sd(points.iter().map(|p| p.de76));
    let (mean_de00, sd_de00) = mean_sd(points.iter().map(|p| p.de00));
    SceneSummary {
        observer,
        points: points.len(),
        rms_rel,
        mean_de76,
        sd_de76,
        mean_de00,
        sd_de00,
    }
}

/// Mean and sample standard deviation (n − 1; `None` for n = 1).
pub fn mean_sd(values: impl Iterator<Item = f64> + Clone) -> (f64, Option<f64>) {
    let n = values.clone().count();
    let mean = values.clone().sum::<f64>() / n as f64;
    let sd = (n > 1).then(|| (values.map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt());
    (mean, sd)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identical_colours_do_not_differ() {
        let white = Xyz::new(95.0, 100.0, 108.9);
        let c = Xyz::new(20.0, 18.0, 7.0);
        let d = compare_point(c, c, white, Observer::JuddVos);
        assert_eq!((d.de76, d.de00, d.xy_distance, d.y_ratio), (0.0, 0.0, 0.0, 1.0));
    }

    /// rms_rel by hand: ratios 0.9 and 1.2 → sqrt((0.01 + 0.04)/2) = 0.158114.
    #[test]
    fn rms_rel_is_the_studys_formula() {
        let white = Xyz::new(95.0, 100.0, 108.9);
        let m = Xyz::new(20.0, 20.0, 20.0);
        let s = summarize(&[
            compare_point(m, m.scaled(0.9), white, Observer::JuddVos),
            compare_point(m, m.scaled(1.2), white, Observer::JuddVos),
        ]);
        assert!((s.rms_rel - (0.05f64 / 2.0).sqrt()).abs() < 1e-12);
        assert!(s.sd_de76.is_some());
    }

    /// WHITE showed ΔE 0.000 and still "1 of 1 beyond noise". The test on
    /// cases whose answer is known: no difference is never significant (with
    /// or without noise), ten combined SEs always are, k SEs is the edge.
    #[test]
    fn zero_difference_is_never_beyond_noise() {
        for (se_a, se_b) in [(0.0, 0.0), (0.01, 0.0), (0.0, 0.02), (0.03, 0.04)] {
            assert!(!beyond_noise(0.0, se_a, se_b), "SE {se_a}, {se_b}");
        }
        let (se_a, se_b) = (0.03, 0.04); // combined 0.05
        assert!(beyond_noise(10.0 * 0.05, se_a, se_b));
        assert!(beyond_noise(-10.0 * 0.05, se_a, se_b));
        assert!(!beyond_noise(2.9 * 0.05, se_a, se_b));
        assert!(beyond_noise(3.1 * 0.05, se_a, se_b));
        // Noise-free sides: any real difference is beyond noise.
        assert!(beyond_noise(1e-9, 0.0, 0.0));
    }

    #[test]
    fn a_summary_names_its_observer() {
        let white = Xyz::new(95.0, 100.0, 108.9);
        let m = Xyz::new(20.0, 20.0, 20.0);
        let s = summarize(&[compare_point(m, m, white, Observer::Cie1931)]);
        assert_eq!(s.observer, Observer::Cie1931);
        let json = serde_json::to_value(s).unwrap();
        assert_eq!(json["observer"], "cie-1931");
    }

    #[test]
    fn mean_sd_uses_n_minus_one() {
        let (m, sd) = mean_sd([2.0, 4.0, 4.0, 4.0, 5.0, 5.0, 7.0, 9.0].into_iter());
        assert_eq!(m, 5.0);
        assert!((sd.unwrap() - (32.0f64 / 7.0).sqrt()).abs() < 1e-12);
        assert_eq!(mean_sd([3.0].into_iter()).1, None);
    }
}
