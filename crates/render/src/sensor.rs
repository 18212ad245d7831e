//! Sensors: the radiometer (see [`super::integrator::radiometer_batch`]) and
//! the dashboard's camera image through the scene's [`Pinhole`], with its
//! image files.
//!
//! The camera renders in one coding (sRGB by default: three channels, the
//! display's own primaries) with `spp` jittered paths per pixel. Pixels hold
//! linear sRGB scaled so that Y is luminance in cd/m². Files:
//! - PFM (Portable Float Map, little-endian "PF"): linear HDR, rows bottom to top;
//! - PNG: tone-mapped 8-bit sRGB — each pixel scaled by 0.18 / (the log-average
//!   luminance) (Reinhard et al. 2002 "key"), compressed by v / (1 + v), and
//!   sRGB-encoded.

use std::io::Write;
use std::path::Path;

use rayon::prelude::*;
use tokio_util::sync::CancellationToken;

use super::coding::{ChannelLayout, Coding};
use super::integrator::{trace_path, PathState, Prepared, Transport};
use super::pinhole::Pinhole;
use super::sampling::{PathSampler, SamplerKind};
use super::scene::{Camera, Scene};
use super::RenderError;
use lightbooth_science::colorimetry::rgb::{apply, srgb_encode, RgbSpace};

/// Camera paths a dashboard preview may trace in all, unless the daemon is
/// told otherwise (`preview_paths`): bounds its cost whatever the camera's
/// size (about 30 s for CYLINDER's 320 × 240 on two busy cores).
pub const PREVIEW_PATH_BUDGET: u64 = 20_000_000;

/// Paths per pixel of a dashboard preview: `budget` paths in all (the
/// default [`PREVIEW_PATH_BUDGET`]) spread over the camera's pixels, 16 to
/// 1024. At CYLINDER's 320 × 240 the default gives 260, where the dark
/// walls show no speckle at the dashboard's scale (16 paths, the earlier
/// preview, left them peppered with fireflies). No denoising.
pub fn preview_spp(camera: &Camera, budget: u64) -> u32 {
    let pixels = (camera.width as u64 * camera.height as u64).max(1);
    (budget / pixels).clamp(16, 1024) as u32
}

/// A linear image, pixels in linear sRGB with Y in cd/m², rows top to bottom.
#[derive(Clone, Debug)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub rgb: Vec<[f32; 3]>,
}

/// Renders the scene's camera view through its [`Pinhole`] with `spp`
/// paths per pixel in `coding`. `cancel` (a job's token) is checked before
/// each row; a cancelled render ends with [`RenderError::Cancelled`].
pub fn render_camera(
    scene: &Scene,
    camera: &Camera,
    coding: Coding,
    spp: u32,
    transport: &Transport,
    seed: u64,
    cancel: Option<&CancellationToken>,
) -> Result<Image, RenderError> {
    let layout = ChannelLayout::new(&[coding]);
    let prep = Prepared::new(scene, layout).map_err(RenderError::Prepare)?;
    let pinhole = Pinhole::new(camera);
    let to_srgb = RgbSpace::SRGB.xyz_to_rgb();
    let (w, h) = (camera.width as usize, camera.height as usize);
    let cancelled = || cancel.is_some_and(|c| c.is_cancelled());
    if cancelled() {
        return Err(RenderError::Cancelled);
    }
    let rows: Vec<Vec<[f32; 3]>> = (0..h)
        .into_par_iter()
        .map(|y| {
            if cancelled() {
                return Vec::new();
            }
            let mut state = PathState::new(&prep.layout);
            let mut row = Vec::with_capacity(w);
            let mut mean = vec![0.0f64; prep.layout.len()];
            for x in 0..w {
                mean.fill(0.0);
                for s in 0..spp {
                    let pixel = (y * w + x) as u64;
                    let mut rng = PathSampler::new(SamplerKind::Sobol, seed, u64::MAX - pixel, s as u64);
                    let ray = pinhole.ray(x, y, rng.next_2d());
                    trace_path(&prep, transport, ray, &mut rng, &mut state);
                    for (m, r) in mean.iter_mut().zip(&state.radiance) {
                        *m += *r as f64 / spp as f64;
                    }
                }
                let xyz = prep.layout.decode(0, &mean).xyz;
                let rgb = apply(&to_srgb, xyz.to_array());
                row.push(rgb.map(|v| v as f32));
            }
            row
        })
        .collect();
    if cancelled() {
        return Err(RenderError::Cancelled);
    }
    Ok(Image {
        width: camera.width,
        height: camera.height,
        rgb: rows.into_iter().flatten().collect(),
    })
}

impl Image {
    /// Writes PFM or PNG by the extension of `path`.
    pub fn write(&self, path: &Path) -> Result<(), RenderError> {
        let io = |e: std::io::Error| RenderError::Io(format!("{}: {e}", path.display()));
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .unwrap_or("")
            .to_ascii_lowercase();
        let mut out = std::io::BufWriter::new(std::fs::File::create(path).map_err(io)?);
        match ext.as_str() {
            "pfm" => {
                write!(out, "PF\n{} {}\n-1.0\n", self.width, self.height).map_err(io)?;
                for y in (0..self.height as usize).rev() {
                    for px in &self.rgb[y * self.width as usize..(y + 1) * self.width as usize] {
                        for v in px {
                            out.write_all(&v.to_le_bytes()).map_err(io)?;
                        }
                    }
                }
                Ok(())
            }
            "png" => out.write_all(&self.png()?).map_err(io),
            other => Err(RenderError::Io(format!(
                "{}: unknown image type `.{other}`: use .pfm (linear HDR) or .png (tone-mapped)",
                path.display()
            ))),
        }
    }

    /// The tone-mapped image as PNG file bytes.
    pub fn png(&self) -> Result<Vec<u8>, RenderError> {
        let png_err = |e: png::EncodingError| RenderError::Io(format!("PNG encoding: {e}"));
        let mut bytes = Vec::new();
        let mut enc = png::Encoder::new(&mut bytes, self.width, self.height);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut writer = enc.write_header().map_err(png_err)?;
        writer.write_image_data(&self.tone_mapped_srgb8()).map_err(png_err)?;
        writer.finish().map_err(png_err)?;
        Ok(bytes)
    }

    /// The image's log-average luminance (in its own units: cd/m² for a
    /// camera image), exp(mean ln(10⁻⁴ + Y)) over its pixels: the key of the
    /// tone map. A grey of luminance Y is shown at the linear display value
    /// d = Yk / (1 + Yk), k = 0.18 / this; so Y = d / (1 − d) / k, which is
    /// how a page draws the shown image's cd/m² scale.
    pub fn log_average_luminance(&self) -> f64 {
        let n = self.rgb.len().max(1) as f64;
        (self
            .rgb
            .iter()
            .map(|p| (1e-4 + luminance(p).max(0.0)).ln())
            .sum::<f64>()
            / n)
            .exp()
    }

    /// 8-bit sRGB after the global Reinhard operator.
    pub fn tone_mapped_srgb8(&self) -> Vec<u8> {
        let k = 0.18 / self.log_average_luminance();
        let mut out = Vec::with_capacity(self.rgb.len() * 3);
        for p in &self.rgb {
            let l = luminance(p).max(0.0) * k;
            let scale = if l > 0.0 { (l / (1.0 + l)) / l * k } else { 0.0 };
            for c in p {
                out.push((srgb_encode(*c as f64 * scale) * 255.0).round() as u8);
            }
        }
        out
    }
}

/// Rec. 709 luminance of a linear sRGB pixel.
fn luminance(p: &[f32; 3]) -> f64 {
    0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pfm_and_png_are_written_by_extension() {
        let img = Image {
            width: 2,
            height: 1,
            rgb: vec![[1.0, 0.5, 0.25], [0.0, 0.0, 0.0]],
        };
        let dir = tempfile::tempdir().unwrap();
        let pfm = dir.path().join("a.pfm");
        img.write(&pfm).unwrap();
        let bytes = std::fs::read(&pfm).unwrap();
        assert!(bytes.starts_with(b"PF\n2 1\n-1.0\n"));
        assert_eq!(bytes.len(), 12 + 2 * 3 * 4);
        assert_eq!(f32::from_le_bytes(bytes[12..16].try_into().unwrap()), 1.0);
        let png = dir.path().join("a.png");
        img.write(&png).unwrap();
        assert!(std::fs::read(&png).unwrap().starts_with(b"\x89PNG"));
        assert!(img.write(&dir.path().join("a.tif")).is_err());
    }
}
