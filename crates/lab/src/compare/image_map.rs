//! The per-pixel CIELAB ΔE00 map between two codings of one render: both
//! camera images through CIELAB with the scene's white (the one the
//! measurement comparisons use, [`super::white`]), CIEDE2000 per pixel
//! ([`lightbooth_science::colorimetry::ciede2000`]), summarised (mean, 95th
//! percentile, maximum) and given a colour scale: viridis
//! ([`lightbooth_science::display::stimulus_files::viridis`], 11 stops) from 0
//! to the maximum rounded up to 1, 2, 2.5 or 5 × 10ᵏ. The HTTP layer only
//! encodes it as JSON or as a PNG.
//!
//! When the two images were rendered from the same paths and one is their
//! set's reference, the map also carries the noise of the paired
//! difference ([`PairedNoise`], `CameraImages::difference`): far below
//! either image's own noise where the codings agree. Otherwise each
//! image's own noise adds to ΔE00, and `noise` says so.

use lightbooth_render::camera::{CameraImage, X, Y, Z};
use lightbooth_science::colorimetry::{ciede2000, Lab, Xyz};
use lightbooth_science::display::stimulus_files::{viridis, VIRIDIS};

use crate::error::LabError;

/// The ΔE00 map between two images of one render.
#[derive(Clone, Debug, serde::Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct DeltaEMap {
    pub image_id: i64,
    pub against: i64,
    pub codings: [String; 2],
    pub width: u32,
    pub height: u32,
    pub observer: String,
    /// The CIELAB white (XYZ, Y in cd/m²) and where it came from.
    pub white: [f64; 3],
    pub white_source: String,
    pub mean: f64,
    pub p95: f64,
    pub max: f64,
    /// The colour map runs from 0 (its first stop) to this (its last).
    pub scale_max: f64,
    /// The colour map's stops, evenly spaced from 0 to `scale_max` (sRGB 0–255).
    pub colour_map: &'static str,
    pub stops: Vec<[u8; 3]>,
    /// ΔE00 per pixel, rows top to bottom.
    pub values: Vec<f32>,
    /// The paired difference's noise, when the two images are one set's
    /// coding and its reference (rendered from the same paths).
    pub paired: Option<PairedNoise>,
    /// What the noise of these numbers is, in words.
    pub noise: String,
}

/// The noise of a ΔE00 map between a coding and its set's reference,
/// rendered from the same paths (`lightbooth_render::camera::PairedDifference`).
#[derive(Clone, Debug, serde::Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct PairedNoise {
    /// The standard error of the mean ΔE00 from the paired paths.
    pub se_mean: f64,
    /// The RMS over pixels of the ΔE00 the paths' noise alone puts between
    /// the two images (paired), and what it would be from independent paths.
    pub noise_paired: f64,
    pub noise_independent: f64,
}

impl DeltaEMap {
    /// Adds the paired difference's noise (`d` of this map's two images).
    pub fn with_paired(mut self, d: &lightbooth_render::camera::PairedDifference) -> DeltaEMap {
        self.noise = format!(
            "rendered from the same paths: the paths' noise alone puts an RMS ΔE00 of {:.3} between them \
             ({:.3} had they been rendered from independent paths); the mean ΔE00's standard error is {:.3}",
            d.noise_paired, d.noise_independent, d.se_mean
        );
        self.paired = Some(PairedNoise {
            se_mean: d.se_mean,
            noise_paired: d.noise_paired,
            noise_independent: d.noise_independent,
        });
        self
    }
}

/// ΔE00 per pixel between `a` and `b` (same size) with the white `white`.
pub fn delta_e_map(
    a: &CameraImage,
    a_id: i64,
    b: &CameraImage,
    b_id: i64,
    white: Xyz,
    white_source: String,
) -> Result<DeltaEMap, LabError> {
    if (a.width, a.height) != (b.width, b.height) {
        return Err(LabError::Conflict(format!(
            "image {a_id} is {} × {} and image {b_id} is {} × {}: a ΔE map needs two images of one size",
            a.width, a.height, b.width, b.height
        )));
    }
    let (w, h) = (a.width as usize, a.height as usize);
    let lab = |img: &CameraImage, x: usize, y: usize| {
        let k = img.xyz_index();
        Lab::from_xyz(
            Xyz::new(img.mean(x, y, k + X), img.mean(x, y, k + Y), img.mean(x, y, k + Z)),
            white,
        )
    };
    let values: Vec<f32> = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| ciede2000(lab(a, x, y), lab(b, x, y)) as f32)
        .collect();
    let mut sorted: Vec<f64> = values.iter().map(|v| *v as f64).collect();
    sorted.sort_by(|p, q| p.total_cmp(q));
    let n = sorted.len().max(1);
    let max = sorted.last().copied().unwrap_or(0.0);
    Ok(DeltaEMap {
        image_id: a_id,
        against: b_id,
        codings: [a.coding.to_string(), b.coding.to_string()],
        width: a.width,
        height: a.height,
        observer: a.observer.to_string(),
        white: white.to_array(),
        white_source,
        mean: sorted.iter().sum::<f64>() / n as f64,
        p95: sorted[((0.95 * (n - 1) as f64).round() as usize).min(n - 1)],
        max,
        scale_max: nice_ceiling(max),
        colour_map: "viridis",
        stops: VIRIDIS.to_vec(),
        values,
        paired: None,
        noise: "rendered from independent paths: each image's own noise adds to ΔE00 \
                (ask for both codings in one request, `codings`, to render them from the same paths)"
            .into(),
    })
}

/// The map's pixels in viridis, 8-bit RGB, rows top to bottom (0 at the
/// dark end, `scale_max` and above at the yellow end).
pub fn false_colour_rgb(map: &DeltaEMap) -> Vec<u8> {
    map.values
        .iter()
        .flat_map(|v| viridis(f64::from(*v) / map.scale_max))
        .collect()
}

/// The smallest of 1, 2, 2.5, 5 × 10ᵏ at or above `v` (1 for v ≤ 0).
pub fn nice_ceiling(v: f64) -> f64 {
    if v <= 0.0 || !v.is_finite() {
        return 1.0;
    }
    let p = 10f64.powf(v.log10().floor());
    [1.0, 2.0, 2.5, 5.0, 10.0]
        .into_iter()
        .map(|m| m * p)
        .find(|c| *c >= v * (1.0 - 1e-12))
        .unwrap_or(10.0 * p)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nice_ceiling_rounds_up_to_1_2_2_5_5() {
        assert_eq!(nice_ceiling(0.0), 1.0);
        assert_eq!(nice_ceiling(0.7), 1.0);
        assert_eq!(nice_ceiling(1.0), 1.0);
        assert_eq!(nice_ceiling(1.3), 2.0);
        assert_eq!(nice_ceiling(2.2), 2.5);
        assert_eq!(nice_ceiling(3.1), 5.0);
        assert_eq!(nice_ceiling(7.0), 10.0);
        assert_eq!(nice_ceiling(0.031), 0.05);
        assert_eq!(nice_ceiling(f64::NAN), 1.0);
    }
}
