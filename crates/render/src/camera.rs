//! The one pinhole camera ([`Pinhole`]) and the measuring camera: an image
//! through it in any colour coding — a spectral
//! cube (401 1 nm channels for `spectral`, N bands for `nstepN`, 3 for
//! `rgb`/`srgb`) plus XYZ and LMS cone excitations per pixel, each with its
//! standard error, rendered in passes until a per-pixel relative standard
//! error of Y, a time budget or a path cap is reached.
//!
//! Per pixel the stored quantities are the coding's channels, then X, Y, Z
//! (Y in cd/m², the layout's observer), then L, M, S:
//! - L, M from the Stockman & Sharpe 2° cone fundamentals scaled so that
//!   L + M is the luminance of the CIE 2006 2° physiological observer,
//!   V(λ) = 0.68990272 l̄(λ) + 0.34832189 m̄(λ) (CIE 170-1:2006; Sharpe et al.
//!   2005), in cd/m²; S = Km ∫ L_λ s̄ dλ with the peak-normalised s̄ (the
//!   scale of S is a convention; this one makes S of an equal-energy
//!   spectrum about a third of its L + M). Km = 683 lm/W as everywhere here.
//! - For `spectral` the integrals run on the 1 nm channels; for `nstepN` on
//!   the bands' piecewise-constant spectrum (the coding's own reconstruction);
//!   for `rgb`/`srgb`, which carry no spectrum, LMS is a 3 × 3 matrix on XYZ
//!   fitted by least squares to the fundamentals from the observer's
//!   matching functions at 1 nm — an approximation, stated as such.
//!
//! Error estimate: every path of a pixel draws its numbers from its own
//! independent PCG32 stream (seed, pixel, sample) — not the radiometer's
//! scrambled Sobol points — so a pixel's paths are independent and
//! identically distributed and the per-sample variance s²/n is an unbiased
//! estimate of the squared standard error of the pixel's mean (with Sobol
//! points the paths are correlated and s²/n would not be the error of the
//! mean). Passes are combined with Chan et al.'s pairwise update of the
//! mean and the sum of squared deviations, so no large sums are kept.
//!
//! Storage: means and sums of squared deviations are `f32` (per pixel and
//! quantity, 8 bytes: 320 × 240 × (401 + 6) is 250 MB for a spectral cube);
//! each pass is accumulated in `f64` before it is merged. Images whose
//! storage would exceed [`MAX_IMAGE_BYTES`] are refused before any work.
//!
//! Progressive stopping: a pixel is done when it has at least
//! [`CameraSettings::min_spp`] paths and SE(Y) ≤ target · max(Y, 1 % of the
//! image's mean Y) — the floor keeps black pixels from holding the render
//! forever — or when it has `max_spp` paths. Only unfinished pixels get
//! more paths. Stopping on the estimated error makes the mean very slightly
//! biased (a pixel that happened to look quiet stops early); with ≥ 16 paths
//! the effect is far below the SE. The time budget is checked between passes.

use std::time::{Duration, Instant};

use glam::{DMat3, DVec3};
use rayon::prelude::*;
use tokio_util::sync::CancellationToken;

use super::coding::{ChannelLayout, Coding};
use super::integrator::{trace_path, PathState, Prepared, Transport};
use super::sampling::{PathSampler, SamplerKind};
use super::scene::{Camera, Scene};
use super::sensor::Image;
use super::RenderError;
pub use crate::pinhole::Pinhole;
use lightbooth_science::colorimetry::rgb::{apply, RgbSpace};
use lightbooth_science::colorimetry::{Cmf, Observer, KM_LM_PER_W};
use lightbooth_science::spectrum::Grid;

/// Largest storage a camera image may take (means and squared deviations).
pub const MAX_IMAGE_BYTES: u64 = 2 << 30;

/// How to render a camera image.
#[derive(Clone, Debug)]
pub struct CameraSettings {
    pub coding: Coding,
    pub observer: Observer,
    pub transport: Transport,
    pub seed: u64,
    /// Paths per pixel before a pixel may stop (and per pass).
    pub min_spp: u32,
    /// Paths per pixel at most.
    pub max_spp: u32,
    /// Stop a pixel when SE(Y)/Y is below this; `None`: every pixel gets `max_spp`.
    pub target_relative_se: Option<f64>,
    /// Stop starting passes after this long.
    pub time_budget: Option<Duration>,
}

/// Where a progressive render is, after each pass.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct CameraProgress {
    pub pass: u32,
    /// Pixels that reached their SE target or the path cap.
    pub pixels_done: u64,
    pub pixels: u64,
    /// Paths traced so far, and the most the render may trace.
    pub paths: u64,
    pub max_paths: u64,
    pub elapsed_seconds: f64,
}

/// Why the render stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum StopReason {
    /// Every pixel reached the SE target (or the path cap).
    Converged,
    /// Every pixel has `max_spp` paths (no SE target, or some pixels never reached it).
    MaxSamples,
    TimeBudget,
}

/// Which quantities the image holds, in per-pixel order.
#[derive(Clone, Debug)]
pub struct Quantities {
    /// The coding's channels: `S0.<λ>nm`-style spectral bands or R, G, B.
    pub coding_channels: usize,
    /// Band centres in nm, or `None` for the RGB codings.
    pub wavelengths_nm: Option<Vec<f64>>,
}

/// Index of X in a pixel's quantities is `coding_channels`; these offsets follow it.
pub const X: usize = 0;
pub const Y: usize = 1;
pub const Z: usize = 2;
pub const L: usize = 3;
pub const M: usize = 4;
pub const S: usize = 5;

/// A rendered camera image: means and standard errors of every quantity.
#[derive(Clone, Debug)]
pub struct CameraImage {
    pub width: u32,
    pub height: u32,
    pub coding: Coding,
    pub observer: Observer,
    pub quantities: Quantities,
    /// Per pixel (rows top to bottom), `stride()` means.
    mean: Vec<f32>,
    /// Per pixel, `stride()` sums of squared deviations from the mean.
    m2: Vec<f32>,
    /// Paths per pixel.
    pub samples: Vec<u32>,
    pub passes: u32,
    pub paths: u64,
    pub elapsed_seconds: f64,
    pub stop: StopReason,
}

/// Linear maps from a coding's channels to XYZ and to LMS.
struct Colorimetry {
    /// 6 rows (X, Y, Z, L, M, S) × channels.
    rows: Vec<Vec<f64>>,
}

impl Colorimetry {
    fn new(layout: &ChannelLayout, coding: Coding, observer: Observer) -> Colorimetry {
        let n = coding.channels();
        let mut rows = vec![vec![0.0; n]; 6];
        let mut unit = vec![0.0; layout.len()];
        // The cone fundamentals of the observer's field (2° or 10°), scaled
        // so that L + M is the CIE 2006 luminous efficiency of that field.
        let cones = observer.cone_fundamentals();
        let fundamentals = cones.on_1nm_grid();
        let [v_l, v_m] = cones.luminance_weights();
        let lms_scale = [KM_LM_PER_W * v_l, KM_LM_PER_W * v_m, KM_LM_PER_W];
        for k in 0..n {
            unit.fill(0.0);
            unit[k] = 1.0;
            let d = layout.decode(0, &unit);
            for (r, v) in d.xyz.to_array().iter().enumerate() {
                rows[r][k] = *v;
            }
            match coding {
                Coding::Spectral => {
                    for c in 0..3 {
                        rows[3 + c][k] = lms_scale[c] * fundamentals[c][k]; // Δλ = 1 nm
                    }
                }
                Coding::NStep(_) => {
                    // The band's piecewise-constant spectrum on the 5 nm grid,
                    // integrated with the fundamentals at 5 nm (Δλ = 5 nm).
                    let s81 = d.spectrum_81.expect("nstep spectrum");
                    for c in 0..3 {
                        rows[3 + c][k] = lms_scale[c]
                            * s81
                                .iter()
                                .enumerate()
                                .map(|(j, v)| v * fundamentals[c][5 * j] * 5.0)
                                .sum::<f64>();
                    }
                }
                Coding::Rgb | Coding::Srgb => {}
            }
        }
        if matches!(coding, Coding::Rgb | Coding::Srgb) {
            let fit = lms_from_xyz_fit(observer);
            #[allow(clippy::needless_range_loop)] // k indexes six rows at once
            for k in 0..n {
                let xyz = DVec3::new(rows[0][k], rows[1][k], rows[2][k]);
                let lms = fit * xyz;
                for c in 0..3 {
                    rows[3 + c][k] = lms_scale[c] * lms[c] / KM_LM_PER_W;
                }
            }
        }
        Colorimetry { rows }
    }
}

/// The 3 × 3 matrix A minimising Σλ |A·(x̄, ȳ, z̄)(λ) − (l̄, m̄, s̄)(λ)|² at 1 nm,
/// with the cone fundamentals of the observer's field.
pub fn lms_from_xyz_fit(observer: Observer) -> DMat3 {
    let cmf = Cmf::of(observer).on_grid(&Grid::one_nm());
    let f = observer.cone_fundamentals().on_1nm_grid();
    // Normal equations: A = (F Xᵀ)(X Xᵀ)⁻¹ with X the 3 × 401 CMF matrix.
    let mut xxt = DMat3::ZERO;
    let mut fxt = DMat3::ZERO;
    for i in 0..cmf[0].len() {
        let x = DVec3::new(cmf[0][i], cmf[1][i], cmf[2][i]);
        let l = DVec3::new(f[0][i], f[1][i], f[2][i]);
        // Outer products as columns: column j is v · u[j].
        xxt += DMat3::from_cols(x * x.x, x * x.y, x * x.z);
        fxt += DMat3::from_cols(l * x.x, l * x.y, l * x.z);
    }
    fxt * xxt.inverse()
}

impl Quantities {
    fn of(coding: Coding) -> Quantities {
        let wavelengths_nm = match coding {
            Coding::Spectral => Some(Grid::one_nm().wavelengths().to_vec()),
            Coding::NStep(n) => {
                let bands = lightbooth_science::nstep::Bands::new(Grid::analysis().len(), n).expect("validated N");
                let w = Grid::analysis().wavelengths().to_vec();
                Some(
                    (0..n)
                        .map(|b| {
                            let r = bands.range(b);
                            (w[r.start] + w[r.end - 1]) / 2.0
                        })
                        .collect(),
                )
            }
            Coding::Rgb | Coding::Srgb => None,
        };
        Quantities {
            coding_channels: coding.channels(),
            wavelengths_nm,
        }
    }
}

/// Renders the camera view through its [`Pinhole`] progressively (see the
/// module doc); `progress` is called after every pass. `cancel` (a job's
/// token) is checked before each row of each pass; a cancelled render ends
/// with [`RenderError::Cancelled`].
pub fn render_camera_image(
    scene: &Scene,
    camera: &Camera,
    settings: &CameraSettings,
    progress: Option<&(dyn Fn(CameraProgress) + Sync)>,
    cancel: Option<&CancellationToken>,
) -> Result<CameraImage, RenderError> {
    if settings.min_spp == 0 || settings.max_spp < settings.min_spp {
        return Err(RenderError::Settings(format!(
            "camera paths per pixel: need 1 ≤ min_spp ({}) ≤ max_spp ({})",
            settings.min_spp, settings.max_spp
        )));
    }
    let quantities = Quantities::of(settings.coding);
    let stride = quantities.coding_channels + 6;
    let (w, h) = (camera.width as usize, camera.height as usize);
    let pixels = w * h;
    let bytes = pixels as u64 * stride as u64 * 8;
    if bytes > MAX_IMAGE_BYTES {
        return Err(RenderError::Settings(format!(
            "a {w} × {h} camera image in {} needs {} MB (at most {} MB): use a smaller [camera] or fewer bands",
            settings.coding,
            bytes >> 20,
            MAX_IMAGE_BYTES >> 20
        )));
    }
    let layout = ChannelLayout::with_observer(&[settings.coding], settings.observer);
    let colorimetry = Colorimetry::new(&layout, settings.coding, settings.observer);
    let prep = Prepared::new(scene, layout).map_err(RenderError::Prepare)?;
    let pinhole = Pinhole::new(camera);
    let cancelled = || cancel.is_some_and(|c| c.is_cancelled());
    if cancelled() {
        return Err(RenderError::Cancelled);
    }
    let start = Instant::now();

    let mut mean = vec![0.0f32; pixels * stride];
    let mut m2 = vec![0.0f32; pixels * stride];
    let mut samples = vec![0u32; pixels];
    let mut done = vec![false; pixels];
    let mut passes = 0u32;
    let mut paths = 0u64;
    let max_paths = pixels as u64 * settings.max_spp as u64;
    let stop = loop {
        let pass_spp = settings.min_spp;
        let seed = settings.seed;
        let n_channels = quantities.coding_channels;
        let traced: u64 = mean
            .par_chunks_mut(w * stride)
            .zip(m2.par_chunks_mut(w * stride))
            .zip(samples.par_chunks_mut(w))
            .zip(done.par_chunks(w))
            .enumerate()
            .map(|(y, (((mean_row, m2_row), n_row), done_row))| {
                if cancelled() {
                    return 0;
                }
                let mut state = PathState::new(&prep.layout);
                let mut q = vec![0.0f64; stride];
                let mut pass_mean = vec![0.0f64; stride];
                let mut pass_m2 = vec![0.0f64; stride];
                let mut traced = 0u64;
                for x in 0..w {
                    if done_row[x] {
                        continue;
                    }
                    let pixel = (y * w + x) as u64;
                    let first = n_row[x];
                    let nb = pass_spp.min(settings.max_spp - first);
                    pass_mean.fill(0.0);
                    pass_m2.fill(0.0);
                    for i in 0..nb {
                        let s = (first + i) as u64;
                        let mut rng = PathSampler::new(SamplerKind::Independent, seed, u64::MAX - pixel, s);
                        let ray = pinhole.ray(x, y, rng.next_2d());
                        trace_path(&prep, &settings.transport, ray, &mut rng, &mut state);
                        let radiance = &state.radiance[..n_channels];
                        for (qk, r) in q.iter_mut().zip(radiance) {
                            *qk = *r as f64;
                        }
                        for (j, row) in colorimetry.rows.iter().enumerate() {
                            q[n_channels + j] = row.iter().zip(radiance).map(|(a, &b)| a * b as f64).sum();
                        }
                        // Welford within the pass.
                        let count = (i + 1) as f64;
                        for ((m, s2), v) in pass_mean.iter_mut().zip(pass_m2.iter_mut()).zip(&q) {
                            let delta = v - *m;
                            *m += delta / count;
                            *s2 += delta * (v - *m);
                        }
                    }
                    traced += nb as u64;
                    // Chan et al.: merge the pass (nb paths) into the stored (na paths).
                    let (na, nbf) = (first as f64, nb as f64);
                    let n = na + nbf;
                    let range = x * stride..(x + 1) * stride;
                    for ((m, s2), (pm, pm2)) in mean_row[range.clone()]
                        .iter_mut()
                        .zip(m2_row[range].iter_mut())
                        .zip(pass_mean.iter().zip(&pass_m2))
                    {
                        let ma = *m as f64;
                        let delta = pm - ma;
                        *m = (ma + delta * nbf / n) as f32;
                        *s2 = (*s2 as f64 + pm2 + delta * delta * na * nbf / n) as f32;
                    }
                    n_row[x] = first + nb;
                }
                traced
            })
            .sum();
        paths += traced;
        passes += 1;
        if cancelled() {
            return Err(RenderError::Cancelled);
        }
        // Which pixels are done.
        let y_index = quantities.coding_channels + Y;
        let mean_y = (0..pixels).map(|p| mean[p * stride + y_index] as f64).sum::<f64>() / pixels.max(1) as f64;
        let floor = 0.01 * mean_y.abs();
        for p in 0..pixels {
            let n = samples[p];
            let reached_cap = n >= settings.max_spp;
            let quiet = settings.target_relative_se.is_some_and(|t| {
                let yv = mean[p * stride + y_index] as f64;
                let se = (m2[p * stride + y_index].max(0.0) as f64 / (n as f64 * (n as f64 - 1.0).max(1.0))).sqrt();
                n >= settings.min_spp && se <= t * yv.abs().max(floor)
            });
            done[p] = reached_cap || quiet;
        }
        let pixels_done = done.iter().filter(|d| **d).count() as u64;
        if let Some(report) = progress {
            report(CameraProgress {
                pass: passes,
                pixels_done,
                pixels: pixels as u64,
                paths,
                max_paths,
                elapsed_seconds: start.elapsed().as_secs_f64(),
            });
        }
        if pixels_done == pixels as u64 {
            let all_at_cap = samples.iter().all(|&n| n >= settings.max_spp);
            break if settings.target_relative_se.is_none() || all_at_cap {
                StopReason::MaxSamples
            } else {
                StopReason::Converged
            };
        }
        if settings.time_budget.is_some_and(|b| start.elapsed() >= b) {
            break StopReason::TimeBudget;
        }
    };
    Ok(CameraImage {
        width: camera.width,
        height: camera.height,
        coding: settings.coding,
        observer: settings.observer,
        quantities,
        mean,
        m2,
        samples,
        passes,
        paths,
        elapsed_seconds: start.elapsed().as_secs_f64(),
        stop,
    })
}

impl CameraImage {
    /// Quantities per pixel: the coding's channels, then X, Y, Z, L, M, S.
    pub fn stride(&self) -> usize {
        self.quantities.coding_channels + 6
    }

    fn at(&self, x: usize, y: usize) -> usize {
        (y * self.width as usize + x) * self.stride()
    }

    /// Quantity `k` of pixel (x, y): its mean.
    pub fn mean(&self, x: usize, y: usize, k: usize) -> f64 {
        self.mean[self.at(x, y) + k] as f64
    }

    /// Quantity `k` of pixel (x, y): the standard error of its mean.
    pub fn standard_error(&self, x: usize, y: usize, k: usize) -> f64 {
        let n = self.samples[y * self.width as usize + x] as f64;
        if n < 2.0 {
            return f64::NAN;
        }
        (self.m2[self.at(x, y) + k].max(0.0) as f64 / (n * (n - 1.0))).sqrt()
    }

    /// One quantity over the image, rows top to bottom.
    pub fn plane(&self, k: usize) -> Vec<f32> {
        let s = self.stride();
        self.mean.iter().skip(k).step_by(s).copied().collect()
    }

    /// The standard error of one quantity over the image.
    pub fn se_plane(&self, k: usize) -> Vec<f32> {
        let w = self.width as usize;
        (0..self.height as usize)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .map(|(x, y)| self.standard_error(x, y, k) as f32)
            .collect()
    }

    /// The image with every `step`-th band of the 1 nm `spectral` coding
    /// (380, 380 + step, … nm, and 780 nm when step divides 400): the
    /// bands' own values and standard errors, not averaged, and X, Y, Z,
    /// L, M, S unchanged (from all 401 bands). A coarser grid for image
    /// files (`--image-step 5`); `step` 1 returns the image as it is.
    pub fn every_nth_band(&self, step: usize) -> Result<CameraImage, String> {
        if step == 1 {
            return Ok(self.clone());
        }
        if self.coding != Coding::Spectral || step == 0 {
            return Err(format!(
                "a spectral step of {step} nm needs the 1 nm `spectral` coding (the image is {}) and a step of 1 nm or more",
                self.coding
            ));
        }
        let n = self.quantities.coding_channels;
        let keep: Vec<usize> = (0..n).step_by(step).chain(n..n + 6).collect();
        let pick = |v: &[f32]| -> Vec<f32> {
            v.chunks_exact(self.stride())
                .flat_map(|px| keep.iter().map(move |&k| px[k]))
                .collect()
        };
        let wavelengths = self
            .quantities
            .wavelengths_nm
            .as_ref()
            .map(|w| w.iter().step_by(step).copied().collect::<Vec<f64>>());
        Ok(CameraImage {
            quantities: Quantities {
                coding_channels: keep.len() - 6,
                wavelengths_nm: wavelengths,
            },
            mean: pick(&self.mean),
            m2: pick(&self.m2),
            width: self.width,
            height: self.height,
            coding: self.coding,
            observer: self.observer,
            samples: self.samples.clone(),
            passes: self.passes,
            paths: self.paths,
            elapsed_seconds: self.elapsed_seconds,
            stop: self.stop,
        })
    }

    /// The index of X (Y, Z, L, M, S follow).
    pub fn xyz_index(&self) -> usize {
        self.quantities.coding_channels
    }

    /// The image as linear sRGB with Y in cd/m² (for PFM/PNG), from its XYZ.
    pub fn to_srgb(&self) -> Image {
        let to_srgb = RgbSpace::SRGB.xyz_to_rgb();
        let (s, x0) = (self.stride(), self.xyz_index());
        Image {
            width: self.width,
            height: self.height,
            rgb: self
                .mean
                .chunks(s)
                .map(|p| apply(&to_srgb, [p[x0] as f64, p[x0 + 1] as f64, p[x0 + 2] as f64]).map(|v| v as f32))
                .collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lightbooth_science::colorimetry::ConeFundamentals;

    /// The least-squares fit reproduces the fundamentals' L and M closely
    /// (cones are nearly a linear transform of any 2° CMFs); S is worse with
    /// the 1931-based observers (their short-wavelength ȳ, z̄ error).
    #[test]
    fn lms_fit_from_xyz_matches_the_fundamentals() {
        let a = lms_from_xyz_fit(Observer::JuddVos);
        let cmf = Cmf::of(Observer::JuddVos).on_grid(&Grid::one_nm());
        let f = ConeFundamentals::StockmanSharpe2.on_1nm_grid();
        let mut worst = [0.0f64; 3];
        for i in 0..401 {
            let lms = a * DVec3::new(cmf[0][i], cmf[1][i], cmf[2][i]);
            for c in 0..3 {
                worst[c] = worst[c].max((lms[c] - f[c][i]).abs());
            }
        }
        println!("worst residual L, M, S: {worst:?}");
        assert!(worst[0] < 0.05 && worst[1] < 0.05 && worst[2] < 0.25, "{worst:?}");
    }

    /// A 4:3 camera 2 m from what it looks at, 40° vertical field of view,
    /// looking down −z from a point off the origin with y up.
    fn pinhole_4_3() -> (Camera, Pinhole) {
        let camera = Camera {
            position: DVec3::new(0.3, 1.2, 2.0),
            look_at: DVec3::new(0.3, 1.2, 0.0),
            up: DVec3::Y,
            fov_deg: 40.0,
            width: 320,
            height: 240,
        };
        let pinhole = Pinhole::new(&camera);
        (camera, pinhole)
    }

    fn angle_deg(a: DVec3, b: DVec3) -> f64 {
        a.dot(b).clamp(-1.0, 1.0).acos().to_degrees()
    }

    /// The image's centre looks at `look_at`, and a ray through a pixel
    /// starts at the pinhole and passes through its jittered point.
    #[test]
    fn the_pinholes_centre_ray_points_at_look_at() {
        let (camera, pinhole) = pinhole_4_3();
        let to_target = (camera.look_at - camera.position).normalize();
        assert!(angle_deg(pinhole.direction(160.0, 120.0), to_target) < 1e-12);
        // Pixel (159, 119) jittered by (1, 1) is the same image point.
        let ray = pinhole.ray(159, 119, (1.0, 1.0));
        assert_eq!(ray.origin, camera.position);
        assert!(angle_deg(ray.dir, to_target) < 1e-12);
        assert!((ray.dir.length() - 1.0).abs() < 1e-15);
        // The centre pixel's own centre is half a pixel off the axis.
        assert!(pinhole.off_axis_deg(160, 120) > 0.0);
        assert!(pinhole.off_axis_deg(160, 120) < 0.2);
    }

    /// `fov_deg` is the vertical field of view: the top and bottom edges
    /// of the image are fov/2 off the axis, above and below.
    #[test]
    fn the_pinholes_top_and_bottom_edges_are_half_the_field_of_view_off_axis() {
        let (camera, pinhole) = pinhole_4_3();
        let axis = (camera.look_at - camera.position).normalize();
        let top = pinhole.direction(160.0, 0.0);
        let bottom = pinhole.direction(160.0, 240.0);
        assert!((angle_deg(top, axis) - 20.0).abs() < 1e-12, "{}", angle_deg(top, axis));
        assert!((angle_deg(bottom, axis) - 20.0).abs() < 1e-12);
        assert!(top.y > 0.0 && bottom.y < 0.0, "row 0 is the top of the image");
        assert!(
            top.x.abs() < 1e-15 && bottom.x.abs() < 1e-15,
            "the centre column stays in its plane"
        );
    }

    /// The left and right edges are atan(aspect · tan(fov/2)) off the axis
    /// horizontally (aspect = width/height), left on the −x side for a
    /// camera looking down −z with y up; the image plane is flat, so the
    /// corners are at atan(tan(fov/2)·√(1 + aspect²)).
    #[test]
    fn the_pinholes_side_edges_follow_the_aspect_ratio() {
        let (camera, pinhole) = pinhole_4_3();
        let axis = (camera.look_at - camera.position).normalize();
        let tan_half = 20f64.to_radians().tan();
        let aspect = 320.0 / 240.0;
        let half_width = (aspect * tan_half).atan().to_degrees();
        let left = pinhole.direction(0.0, 120.0);
        let right = pinhole.direction(320.0, 120.0);
        assert!(
            (angle_deg(left, axis) - half_width).abs() < 1e-12,
            "{}",
            angle_deg(left, axis)
        );
        assert!((angle_deg(right, axis) - half_width).abs() < 1e-12);
        assert!(left.x < 0.0 && right.x > 0.0, "x grows to the right");
        assert!(left.y.abs() < 1e-15 && right.y.abs() < 1e-15);
        // The edges' tangents are in the ratio of the image's sides.
        let tan_of = |d: DVec3| d.dot(axis).acos().tan();
        assert!((tan_of(right) / tan_of(pinhole.direction(160.0, 0.0)) - aspect).abs() < 1e-12);
        let corner = (tan_half * (1.0 + aspect * aspect).sqrt()).atan().to_degrees();
        assert!((angle_deg(pinhole.direction(320.0, 0.0), axis) - corner).abs() < 1e-12);
    }

    /// The weights of V(λ) 2006: 0.68990272 l̄ + 0.34832189 m̄ (2°) and
    /// 0.69283932 l̄ + 0.34967567 m̄ (10°) peak at 1 near 555 nm (CIE
    /// 170-1:2006 normalises V to a peak of 1).
    #[test]
    fn v2006_from_the_fundamentals_peaks_at_one() {
        for cones in [ConeFundamentals::StockmanSharpe2, ConeFundamentals::StockmanSharpe10] {
            let f = cones.on_1nm_grid();
            let [v_l, v_m] = cones.luminance_weights();
            let (i, peak) = (0..401)
                .map(|i| (i, v_l * f[0][i] + v_m * f[1][i]))
                .fold((0, 0.0), |a, b| if b.1 > a.1 { b } else { a });
            assert!((peak - 1.0).abs() < 2e-3, "{cones:?}: {peak}");
            assert!((380 + i as i32 - 556).abs() <= 3, "{cones:?}: {i}");
        }
    }
}
