//! What the image viewer reads from a camera image ([`CameraImage`]): the
//! display PNG, a pixel probe (a pixel's or a small box's channels ± SE,
//! XYZ, x,y, LMS) with its chart, and the per-pixel CIELAB ΔE00 map
//! between two codings of one render as a false-colour PNG.
//!
//! - Display: XYZ → linear sRGB → the global Reinhard et al. (2002) operator
//!   (each pixel scaled by 0.18 / the log-average luminance, compressed by
//!   v / (1 + v)) → sRGB encoding ([`crate::render::sensor::Image::png`]).
//!   For looking at, never for measuring.
//! - Probe of a box of pixels: the mean of the pixels' means, and its
//!   standard error √(Σ SEᵢ²) / n (the pixels' paths are independent).
//! - ΔE map: both images through CIELAB with the scene's white (the one the
//!   daemon's comparisons use, see `lab::comparisons`), CIEDE2000 per pixel,
//!   drawn with the viridis colour map from 0 to a rounded-up maximum.

use crate::charts::{self, LineSeriesData};
use crate::colorimetry::{ciede2000, Lab, Xyz};
use crate::http::error::ApiError;
use crate::render::camera::{CameraImage, L, M, S, X, Y, Z};

/// The tone-mapped display image as PNG bytes (see the module doc).
pub fn display_png(img: &CameraImage) -> Result<Vec<u8>, ApiError> {
    img.to_srgb().png().map_err(|e| ApiError::Internal(e.to_string()))
}

/// A mean and its standard error.
#[derive(Clone, Copy, Debug, serde::Serialize, utoipa::ToSchema)]
pub struct MeanSe {
    pub mean: f64,
    pub se: f64,
}

/// A probe of a box of pixels.
#[derive(Clone, Debug, serde::Serialize, utoipa::ToSchema)]
pub struct Probe {
    pub image_id: i64,
    pub coding: String,
    pub observer: String,
    /// The box: top-left pixel (x from the left, y from the top) and size.
    pub x: u32,
    pub y: u32,
    pub w: u32,
    pub h: u32,
    /// The coding's channel names (`S0.<λ>nm` bands, or R, G, B).
    pub channels: Vec<String>,
    /// Their band centres in nm; `null` for `rgb`/`srgb`.
    pub wavelengths_nm: Option<Vec<f64>>,
    /// Per channel: spectral radiance in W/(sr·m²·nm) for the spectral
    /// codings (the band mean for `nstepN`); linear RGB for `rgb`/`srgb`.
    pub mean: Vec<f64>,
    pub se: Vec<f64>,
    /// Y in cd/m².
    #[serde(rename = "X")]
    pub x_tristimulus: MeanSe,
    #[serde(rename = "Y")]
    pub y_tristimulus: MeanSe,
    #[serde(rename = "Z")]
    pub z_tristimulus: MeanSe,
    /// Chromaticity of the mean XYZ.
    pub chromaticity_x: f64,
    pub chromaticity_y: f64,
    #[serde(rename = "L")]
    pub l: MeanSe,
    #[serde(rename = "M")]
    pub m: MeanSe,
    #[serde(rename = "S")]
    pub s: MeanSe,
    /// Paths per pixel, averaged over the box.
    pub paths_per_pixel: f64,
}

/// The box's quantity `k`: mean of the means and √(Σ SE²)/n.
fn box_mean(img: &CameraImage, xs: std::ops::Range<usize>, ys: std::ops::Range<usize>, k: usize) -> MeanSe {
    let n = (xs.len() * ys.len()) as f64;
    let (mut sum, mut var) = (0.0, 0.0);
    for y in ys {
        for x in xs.clone() {
            sum += img.mean(x, y, k);
            var += img.standard_error(x, y, k).powi(2);
        }
    }
    MeanSe {
        mean: sum / n,
        se: var.sqrt() / n,
    }
}

/// Refuses a probe box that is empty or leaves a `width` × `height` image,
/// naming the query field at fault. In u64, so `x + w` cannot wrap
/// (`x=1&w=4294967295` once passed as a box of 0 pixels and answered nulls).
pub fn check_box(x: u32, y: u32, w: u32, h: u32, width: u32, height: u32) -> Result<(), ApiError> {
    for (name, size_name, v, size, max) in [("x", "w", x, w, width), ("y", "h", y, h, height)] {
        let (v64, size64, max64) = (u64::from(v), u64::from(size), u64::from(max));
        if v64 >= max64 {
            return Err(ApiError::BadRequest(format!(
                "query `{name}`: {v} is outside the image (0…{})",
                max64.saturating_sub(1)
            )));
        }
        if size == 0 || v64 + size64 > max64 {
            return Err(ApiError::BadRequest(format!(
                "query `{size_name}`: {size} pixels from {name}={v} leave the image (0…{}); give 1–{}",
                max64 - 1,
                max64 - v64
            )));
        }
    }
    Ok(())
}

/// Probes the box (x, y, w, h); 400 naming the field when it leaves the image.
pub fn probe(img: &CameraImage, image_id: i64, x: u32, y: u32, w: u32, h: u32) -> Result<Probe, ApiError> {
    check_box(x, y, w, h, img.width, img.height)?;
    let (xs, ys) = (x as usize..(x + w) as usize, y as usize..(y + h) as usize);
    let n_ch = img.quantities.coding_channels;
    let coding: Vec<MeanSe> = (0..n_ch).map(|k| box_mean(img, xs.clone(), ys.clone(), k)).collect();
    let q = |k: usize| box_mean(img, xs.clone(), ys.clone(), n_ch + k);
    let (xt, yt, zt) = (q(X), q(Y), q(Z));
    let c = Xyz::new(xt.mean, yt.mean, zt.mean).chromaticity();
    let paths: u64 = ys
        .clone()
        .flat_map(|yy| xs.clone().map(move |xx| yy * img.width as usize + xx))
        .map(|i| img.samples[i] as u64)
        .sum();
    let names = crate::export::image::coding_channel_names(img);
    Ok(Probe {
        image_id,
        coding: img.coding.to_string(),
        observer: img.observer.to_string(),
        x,
        y,
        w,
        h,
        channels: names,
        wavelengths_nm: img.quantities.wavelengths_nm.clone(),
        mean: coding.iter().map(|c| c.mean).collect(),
        se: coding.iter().map(|c| c.se).collect(),
        x_tristimulus: xt,
        y_tristimulus: yt,
        z_tristimulus: zt,
        chromaticity_x: c.x,
        chromaticity_y: c.y,
        l: q(L),
        m: q(M),
        s: q(S),
        paths_per_pixel: paths as f64 / (w as f64 * h as f64),
    })
}

/// The probe's chart: the coding's channels ± 1 SE against wavelength (nm)
/// for the spectral codings, against channel number for `rgb`/`srgb`; the
/// series in the coding's own colour.
pub fn probe_chart(p: &Probe) -> Result<String, ApiError> {
    let (xs, x_desc, y_desc): (Vec<f64>, &str, &str) = match &p.wavelengths_nm {
        Some(w) => (
            w.clone(),
            "wavelength (nm)",
            "spectral radiance (W/(sr·m²·nm)), mean ± 1 SE",
        ),
        None => (
            (1..=p.mean.len()).map(|i| i as f64).collect(),
            "channel (1 = R, 2 = G, 3 = B)",
            "linear RGB (Y-scaled, cd/m²), mean ± 1 SE",
        ),
    };
    let series = LineSeriesData {
        name: p.coding.clone(),
        points: xs.into_iter().zip(p.mean.iter().copied()).collect(),
        errors: Some(p.se.clone()),
    };
    let title = format!(
        "image {} pixel ({}, {}){}: {} · Y = {:.4} ± {:.2} cd/m² · x,y = {:.4}, {:.4} ({})",
        p.image_id,
        p.x,
        p.y,
        if p.w * p.h > 1 {
            format!(" + {}×{} box", p.w, p.h)
        } else {
            String::new()
        },
        p.coding,
        p.y_tristimulus.mean,
        p.y_tristimulus.se,
        p.chromaticity_x,
        p.chromaticity_y,
        p.observer
    );
    charts::line_chart(&title, x_desc, y_desc, &[series], false).map_err(ApiError::Internal)
}

/// The ΔE00 map between two images of one render.
#[derive(Clone, Debug, serde::Serialize, utoipa::ToSchema)]
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
}

/// Viridis (matplotlib, van der Walt & Smith 2015) at nine even stops.
const VIRIDIS: [[u8; 3]; 9] = [
    [68, 1, 84],
    [71, 44, 122],
    [59, 81, 139],
    [44, 113, 142],
    [33, 144, 141],
    [39, 173, 129],
    [92, 200, 99],
    [170, 220, 50],
    [253, 231, 37],
];

fn viridis(t: f64) -> [u8; 3] {
    let t = t.clamp(0.0, 1.0) * (VIRIDIS.len() - 1) as f64;
    let i = (t.floor() as usize).min(VIRIDIS.len() - 2);
    let f = t - i as f64;
    let (a, b) = (VIRIDIS[i], VIRIDIS[i + 1]);
    [0, 1, 2].map(|c| (a[c] as f64 + (b[c] as f64 - a[c] as f64) * f).round() as u8)
}

/// The smallest of 1, 2, 2.5, 5 × 10ᵏ at or above `v` (1 for v ≤ 0).
fn nice_ceiling(v: f64) -> f64 {
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

/// ΔE00 per pixel between `a` and `b` (same size) with the white `white`.
#[allow(clippy::too_many_arguments)]
pub fn delta_e_map(
    a: &CameraImage,
    a_id: i64,
    b: &CameraImage,
    b_id: i64,
    white: Xyz,
    white_source: String,
) -> Result<DeltaEMap, ApiError> {
    if (a.width, a.height) != (b.width, b.height) {
        return Err(ApiError::Conflict(format!(
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
    })
}

/// The map as a false-colour PNG (viridis, 0 to `scale_max`).
pub fn delta_e_png(map: &DeltaEMap) -> Result<Vec<u8>, ApiError> {
    let rgb: Vec<u8> = map
        .values
        .iter()
        .flat_map(|v| viridis(*v as f64 / map.scale_max))
        .collect();
    let png_err = |e: png::EncodingError| ApiError::Internal(format!("PNG encoding: {e}"));
    let mut bytes = Vec::new();
    let mut enc = png::Encoder::new(&mut bytes, map.width, map.height);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let mut writer = enc.write_header().map_err(png_err)?;
    writer.write_image_data(&rgb).map_err(png_err)?;
    writer.finish().map_err(png_err)?;
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Regression: `?x=1&y=0&w=4294967295` wrapped in u32 and was answered
    /// 200 with nulls.
    #[test]
    fn pixel_box_width_that_wraps_u32_is_refused_naming_w() {
        for (x, y, w, h, field) in [
            (1, 0, u32::MAX, 1, "`w`"),
            (0, 1, 1, u32::MAX, "`h`"),
            (2, 0, u32::MAX - 1, 1, "`w`"),
            (0, 0, 0, 1, "`w`"),
            (u32::MAX, 0, 1, 1, "`x`"),
            (0, 40, 1, 1, "`y`"),
        ] {
            let e = check_box(x, y, w, h, 64, 40).unwrap_err();
            assert!(matches!(e, ApiError::BadRequest(_)), "{e}");
            assert!(e.to_string().contains(field), "{x},{y},{w},{h}: {e}");
        }
        assert!(check_box(0, 0, 64, 40, 64, 40).is_ok());
        assert!(check_box(63, 39, 1, 1, 64, 40).is_ok());
    }

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
    }

    #[test]
    fn viridis_ends_are_its_first_and_last_stops() {
        assert_eq!(viridis(0.0), VIRIDIS[0]);
        assert_eq!(viridis(1.0), VIRIDIS[8]);
        assert_eq!(viridis(2.0), VIRIDIS[8]);
        assert_eq!(viridis(0.5), VIRIDIS[4]);
    }
}
