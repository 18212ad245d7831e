//! What the image viewer reads from a camera image ([`CameraImage`]): the
//! display PNG, a pixel probe (a pixel's or a small box's channels ± SE,
//! XYZ, x,y, LMS) with its chart, and the per-pixel CIELAB ΔE00 map
//! between two codings of one render as a false-colour PNG.
//!
//! - Display: XYZ → linear sRGB → the global Reinhard et al. (2002) operator
//!   (each pixel scaled by 0.18 / the log-average luminance, compressed by
//!   v / (1 + v)) → sRGB encoding ([`lightbooth_render::sensor::Image::png`]).
//!   For looking at, never for measuring.
//! - Probe of a box of pixels: the mean of the pixels' means, and its
//!   standard error √(Σ SEᵢ²) / n (the pixels' paths are independent).
//! - ΔE map: computed by [`crate::compare::image_map`]; here encoded as a
//!   PNG.

use lightbooth_render::camera::{CameraImage, L, M, S, X, Y, Z};
use lightbooth_science::colorimetry::Xyz;

use crate::charts::{self, LineSeriesData};
use crate::compare::image_map::{self, DeltaEMap};
use crate::error::LabError;

/// The tone-mapped display image as PNG bytes (see the module doc).
pub fn display_png(img: &CameraImage) -> Result<Vec<u8>, LabError> {
    img.to_srgb().png().map_err(|e| LabError::Internal(e.to_string()))
}

/// A mean and its standard error.
#[derive(Clone, Copy, Debug, serde::Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct MeanSe {
    pub mean: f64,
    pub se: f64,
}

/// A probe of a box of pixels.
#[derive(Clone, Debug, serde::Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
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
pub fn check_box(x: u32, y: u32, w: u32, h: u32, width: u32, height: u32) -> Result<(), LabError> {
    for (name, size_name, v, size, max) in [("x", "w", x, w, width), ("y", "h", y, h, height)] {
        let (v64, size64, max64) = (u64::from(v), u64::from(size), u64::from(max));
        if v64 >= max64 {
            return Err(LabError::Invalid(format!(
                "query `{name}`: {v} is outside the image (0…{})",
                max64.saturating_sub(1)
            )));
        }
        if size == 0 || v64 + size64 > max64 {
            return Err(LabError::Invalid(format!(
                "query `{size_name}`: {size} pixels from {name}={v} leave the image (0…{}); give 1–{}",
                max64 - 1,
                max64 - v64
            )));
        }
    }
    Ok(())
}

/// Probes the box (x, y, w, h); 400 naming the field when it leaves the image.
pub fn probe(img: &CameraImage, image_id: i64, x: u32, y: u32, w: u32, h: u32) -> Result<Probe, LabError> {
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
pub fn probe_chart(p: &Probe) -> Result<String, LabError> {
    let (xs, x_desc, y_desc): (Vec<f64>, &str, String) = match &p.wavelengths_nm {
        Some(w) => (
            w.clone(),
            "wavelength (nm)",
            format!(
                "spectral radiance ({}), mean ± 1 SE",
                lightbooth_science::spectrum::SPECTRAL_RADIANCE_UNIT
            ),
        ),
        None => (
            (1..=p.mean.len()).map(|i| i as f64).collect(),
            "channel (1 = R, 2 = G, 3 = B)",
            "linear RGB (Y-scaled, cd/m²), mean ± 1 SE".to_string(),
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
    charts::line_chart(&title, x_desc, &y_desc, &[series], false).map_err(LabError::Internal)
}

/// The map as a false-colour PNG (viridis, 0 to `scale_max`).
pub fn delta_e_png(map: &DeltaEMap) -> Result<Vec<u8>, LabError> {
    rgb_png(map.width, map.height, &image_map::false_colour_rgb(map))
}

/// 8-bit RGB pixels (rows top to bottom) as a PNG.
pub fn rgb_png(width: u32, height: u32, rgb: &[u8]) -> Result<Vec<u8>, LabError> {
    let png_err = |e: png::EncodingError| LabError::Internal(format!("PNG encoding: {e}"));
    let mut bytes = Vec::new();
    let mut enc = png::Encoder::new(&mut bytes, width, height);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let mut writer = enc.write_header().map_err(png_err)?;
    writer.write_image_data(rgb).map_err(png_err)?;
    writer.finish().map_err(png_err)?;
    Ok(bytes)
}
