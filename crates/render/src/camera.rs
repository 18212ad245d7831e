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
//! mean and the sum of squared deviations, so no large sums are kept;
//! within a pass, each quantity's sums are shifted by the pass's first path
//! (Σ(v − v₀), Σ(v − v₀)²), which costs no division per path and loses no
//! digits when a quantity's spread is small against its mean (the paired
//! difference of two codings that agree).
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
use lightbooth_science::colorimetry::{ciede2000, Cmf, Lab, Observer, Xyz, KM_LM_PER_W};
use lightbooth_science::spectrum::Grid;

/// Largest storage a camera image may take (means and squared deviations
/// of every coding, and the paired moments): 4 GiB, so that CYLINDER's view
/// at 960 × 540 in all seven codings (2.5 GB) fits.
pub const MAX_IMAGE_BYTES: u64 = 4 << 30;

/// The name of [`CameraImages::to_bytes`]'s layout, in its header.
pub const IMAGE_SET_FORMAT: &str = "lightbooth-camera-images-1";

/// How to render a camera image.
#[derive(Clone, Debug)]
pub struct CameraSettings {
    /// The codings rendered, every one from the same paths (a coding named
    /// twice is rendered once, in its first place).
    pub codings: Vec<Coding>,
    /// The coding every other is compared with ([`CameraImages::difference`])
    /// and whose SE(Y) stops a pixel; `None`: the last of `codings`.
    pub reference: Option<Coding>,
    /// Stop a pixel only when every coding's SE(Y) meets
    /// `target_relative_se`, not only the reference's.
    pub se_every_coding: bool,
    pub observer: Observer,
    pub transport: Transport,
    pub seed: u64,
    /// Paths per pixel before a pixel may stop (and per pass).
    pub min_spp: u32,
    /// Paths per pixel at most.
    pub max_spp: u32,
    /// The index of every pixel's first path: paths `first_sample` …
    /// `first_sample + max_spp − 1` are traced, each from its own stream
    /// (see the module doc). 0 for a whole render; a render worker's batch
    /// starts where the batch before it ends, so batches merged with
    /// [`CameraImages::merge`] hold exactly the paths one render of them
    /// all would trace.
    pub first_sample: u32,
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
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
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
    /// Rays traced: camera, bounce and shadow rays (of every coding at once
    /// when the codings were rendered together).
    pub rays: u64,
    pub elapsed_seconds: f64,
    pub stop: StopReason,
}

/// Linear maps from a coding's channels to XYZ and to LMS.
struct Colorimetry {
    /// The six rows (X, Y, Z, L, M, S) packed by 8 channels: chunk c holds
    /// the weights of channels 8c … 8c + 7 of every row (zero past the
    /// last channel), so that [`Colorimetry::apply`] keeps 48 independent
    /// sums (its loop vectorises, and no sum waits for another).
    packed: Vec<[[f64; 8]; 6]>,
}

impl Colorimetry {
    /// The maps of the layout's coding number `index` (its channels only).
    fn new(layout: &ChannelLayout, index: usize) -> Colorimetry {
        let (coding, range) = layout.entries()[index].clone();
        let observer = layout.observer();
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
            unit[range.start + k] = 1.0;
            let d = layout.decode(index, &unit);
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
        let mut packed = vec![[[0.0; 8]; 6]; n.div_ceil(8)];
        for (j, row) in rows.iter().enumerate() {
            for (k, w) in row.iter().enumerate() {
                packed[k / 8][j][k % 8] = *w;
            }
        }
        Colorimetry { packed }
    }

    /// X, Y, Z, L, M, S of one path's channels of this coding, each
    /// Σₖ wₖ·rₖ in f64 summed in a fixed order (deterministic).
    #[inline(always)]
    fn apply(&self, radiance: &[f32], out: &mut [f64]) {
        let mut acc = [[0.0f64; 8]; 6];
        let (whole, tail) = radiance.split_at(radiance.len() / 8 * 8);
        for (w, r) in self.packed.iter().zip(whole.chunks_exact(8)) {
            let r: [f64; 8] = std::array::from_fn(|l| r[l] as f64);
            for j in 0..6 {
                for l in 0..8 {
                    acc[j][l] += w[j][l] * r[l];
                }
            }
        }
        if !tail.is_empty() {
            let w = &self.packed[whole.len() / 8];
            let r: [f64; 8] = std::array::from_fn(|l| tail.get(l).map_or(0.0, |v| *v as f64));
            for j in 0..6 {
                for l in 0..8 {
                    acc[j][l] += w[j][l] * r[l];
                }
            }
        }
        for (o, a) in out.iter_mut().zip(&acc) {
            *o = ((a[0] + a[1]) + (a[2] + a[3])) + ((a[4] + a[5]) + (a[6] + a[7]));
        }
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
/// module doc) in the reference coding of `settings` (its only coding, as
/// a rule): [`render_camera_images`]'s reference image.
pub fn render_camera_image(
    scene: &Scene,
    camera: &Camera,
    settings: &CameraSettings,
    progress: Option<&(dyn Fn(CameraProgress) + Sync)>,
    cancel: Option<&CancellationToken>,
) -> Result<CameraImage, RenderError> {
    render_camera_images(scene, camera, settings, progress, cancel).map(CameraImages::into_reference)
}

/// Per pixel and coding, the moments kept beside the image's own (f32):
/// the co-moments Σ(X−X̄)(Y−Ȳ), Σ(X−X̄)(Z−Z̄), Σ(Y−Ȳ)(Z−Z̄) of the coding's
/// own X, Y, Z (the image keeps their squared deviations), then the mean of
/// the paired difference d = XYZ(coding) − XYZ(reference) over the pixel's
/// paths and its co-moments dxx, dyy, dzz, dxy, dxz, dyz (all zero for the
/// reference itself).
const PAIRED: usize = 12;
/// Offsets in [`PAIRED`]'s block.
const OWN_CROSS: usize = 0;
const D_MEAN: usize = 3;
const D_COMOMENTS: usize = 6;

/// `n` zeros, written here (in huge pages where the kernel gives them).
/// `vec![0.0; n]` maps untouched memory to the kernel's shared zero page;
/// the first pass then reads a pixel before writing it, and every such
/// page's copy-on-write fault flushed the other cores' TLBs: for a
/// 2.5 GB seven-coding image at 960 × 540 the kernel's time exceeded the
/// render's own (17.7 s system against 16.3 s user, `/usr/bin/time`).
/// The zeros are written by every core (rayon's indexed collect writes each
/// chunk in place), so the kernel's clearing of the new pages is shared too.
fn zeroed(n: usize) -> Vec<f32> {
    let mut v = crate::huge_pages::vec_with_huge_pages(n);
    v.par_extend(rayon::iter::repeat_n(0.0f32, n));
    v
}

/// Chan et al.'s merge of the cross co-moments: Cₐ + C_b + δᵢδⱼ·nₐn_b/n, δ
/// the difference of the two means.
fn cross_merge(stored: &mut [f32], pass: &[f64], delta: [f64; 3], weight: f64) {
    let pairs = [(0, 1), (0, 2), (1, 2)];
    for (k, (i, j)) in pairs.into_iter().enumerate() {
        stored[k] = (stored[k] as f64 + pass[k] + delta[i] * delta[j] * weight) as f32;
    }
}

/// One coding's Y means and squared deviations, for the stopping rule.
struct YPlane<'a> {
    mean: &'a [f32],
    m2: &'a [f32],
    stride: usize,
    /// The index of Y among a pixel's quantities.
    y: usize,
}

/// The stopping rule of the module doc: pixel p is done at the path cap, or
/// with at least `min_spp` paths and SE(Y) ≤ target · max(Y, 1 % of the
/// image's mean Y) in every plane of `ys`.
fn mark_done(ys: &[YPlane], samples: &[u32], settings: &CameraSettings, done: &mut [bool]) {
    let pixels = samples.len();
    let floors: Vec<f64> = ys
        .iter()
        .map(|c| {
            0.01 * ((0..pixels).map(|p| c.mean[p * c.stride + c.y] as f64).sum::<f64>() / pixels.max(1) as f64).abs()
        })
        .collect();
    for (p, (&n, done)) in samples.iter().zip(done.iter_mut()).enumerate() {
        let reached_cap = n >= settings.max_spp;
        let quiet = settings.target_relative_se.is_some_and(|t| {
            n >= settings.min_spp
                && ys.iter().zip(&floors).all(|(c, floor)| {
                    let k = p * c.stride + c.y;
                    let yv = c.mean[k] as f64;
                    let se = (c.m2[k].max(0.0) as f64 / (n as f64 * (n as f64 - 1.0).max(1.0))).sqrt();
                    se <= t * yv.abs().max(*floor)
                })
        });
        *done = reached_cap || quiet;
    }
}

/// Chan et al.'s update of one pixel's [`PAIRED`] moments: `stored` (over
/// nₐ paths) with `block` (over n_b paths), `delta` the difference of the
/// two XYZ means (b − a), `weight` nₐn_b/n, `(nb, n)` n_b and n. The paired
/// difference's mean and co-moments are kept for every coding but the
/// reference (`is_reference`).
fn merge_paired(
    stored: &mut [f32],
    block: &[f64],
    delta: [f64; 3],
    weight: f64,
    (nb, n): (f64, f64),
    is_reference: bool,
) {
    cross_merge(
        &mut stored[OWN_CROSS..OWN_CROSS + 3],
        &block[OWN_CROSS..],
        delta,
        weight,
    );
    if is_reference {
        return;
    }
    let d_delta: [f64; 3] = std::array::from_fn(|k| block[D_MEAN + k] - stored[D_MEAN + k] as f64);
    for k in 0..3 {
        let ma = stored[D_MEAN + k] as f64;
        stored[D_MEAN + k] = (ma + d_delta[k] * nb / n) as f32;
        let s2 = stored[D_COMOMENTS + k] as f64;
        stored[D_COMOMENTS + k] = (s2 + block[D_COMOMENTS + k] + d_delta[k] * d_delta[k] * weight) as f32;
    }
    cross_merge(
        &mut stored[D_COMOMENTS + 3..D_COMOMENTS + 6],
        &block[D_COMOMENTS + 3..],
        d_delta,
        weight,
    );
}

/// One row's share of every coding's buffers, for one pass.
struct RowBuffers<'a> {
    mean: Vec<&'a mut [f32]>,
    m2: Vec<&'a mut [f32]>,
    paired: Vec<&'a mut [f32]>,
}

/// Renders the camera view in every coding of `settings` from the same
/// paths (each path traced once, all codings' channels carried along it, as
/// the radiometer's targets are), progressively (see the module doc):
/// then two codings' images differ by the codings alone, not by two noise
/// draws, and [`CameraImages::difference`] gives the paired difference's
/// own standard error. A pixel stops on the reference coding's SE(Y) (every
/// coding's with `se_every_coding`). `progress` is called after every
/// pass; `cancel` (a job's token) is checked before each row of each pass,
/// and a cancelled render ends with [`RenderError::Cancelled`].
pub fn render_camera_images(
    scene: &Scene,
    camera: &Camera,
    settings: &CameraSettings,
    progress: Option<&(dyn Fn(CameraProgress) + Sync)>,
    cancel: Option<&CancellationToken>,
) -> Result<CameraImages, RenderError> {
    if settings.min_spp == 0 || settings.max_spp < settings.min_spp {
        return Err(RenderError::Settings(format!(
            "camera paths per pixel: need 1 ≤ min_spp ({}) ≤ max_spp ({})",
            settings.min_spp, settings.max_spp
        )));
    }
    let layout = ChannelLayout::with_observer(&settings.codings, settings.observer);
    let codings: Vec<Coding> = layout.codings().collect();
    let names = || codings.iter().map(|c| c.to_string()).collect::<Vec<_>>().join(",");
    if codings.is_empty() {
        return Err(RenderError::Settings("a camera image needs at least one coding".into()));
    }
    let reference = match settings.reference {
        None => codings.len() - 1,
        Some(r) => codings.iter().position(|c| *c == r).ok_or_else(|| {
            RenderError::Settings(format!(
                "the reference coding {r} is not one of the codings rendered ({})",
                names()
            ))
        })?,
    };
    let nc = codings.len();
    let quantities: Vec<Quantities> = codings.iter().map(|c| Quantities::of(*c)).collect();
    let strides: Vec<usize> = quantities.iter().map(|q| q.coding_channels + 6).collect();
    // Each coding's quantities in one per-path vector: coding c at offsets[c].
    let offsets: Vec<usize> = strides
        .iter()
        .scan(0, |at, s| {
            let o = *at;
            *at += s;
            Some(o)
        })
        .collect();
    let total_stride: usize = strides.iter().sum();
    let (w, h) = (camera.width as usize, camera.height as usize);
    let pixels = w * h;
    let bytes = pixels as u64 * (total_stride as u64 * 8 + nc as u64 * PAIRED as u64 * 4);
    if bytes > MAX_IMAGE_BYTES {
        return Err(RenderError::Settings(format!(
            "a {w} × {h} camera image in {} needs {} MB (at most {} MB): use a smaller [camera], fewer codings or fewer bands",
            names(),
            bytes >> 20,
            MAX_IMAGE_BYTES >> 20
        )));
    }
    let colorimetry: Vec<Colorimetry> = (0..nc).map(|i| Colorimetry::new(&layout, i)).collect();
    let ranges: Vec<std::ops::Range<usize>> = layout.entries().iter().map(|e| e.1.clone()).collect();
    let prep = Prepared::new(scene, layout).map_err(RenderError::Prepare)?;
    let pinhole = Pinhole::new(camera);
    let cancelled = || cancel.is_some_and(|c| c.is_cancelled());
    if cancelled() {
        return Err(RenderError::Cancelled);
    }
    let start = Instant::now();

    let mut mean: Vec<Vec<f32>> = strides.iter().map(|s| zeroed(pixels * s)).collect();
    let mut m2: Vec<Vec<f32>> = strides.iter().map(|s| zeroed(pixels * s)).collect();
    let mut paired: Vec<Vec<f32>> = (0..nc).map(|_| zeroed(pixels * PAIRED)).collect();
    let mut samples = vec![0u32; pixels];
    let mut done = vec![false; pixels];
    let mut passes = 0u32;
    let mut paths = 0u64;
    let mut rays = 0u64;
    let max_paths = pixels as u64 * settings.max_spp as u64;
    let stop = loop {
        let pass_spp = settings.min_spp;
        let mut rows: Vec<RowBuffers> = (0..h)
            .map(|_| RowBuffers {
                mean: Vec::with_capacity(nc),
                m2: Vec::with_capacity(nc),
                paired: Vec::with_capacity(nc),
            })
            .collect();
        for (((mean_c, m2_c), paired_c), stride) in
            mean.iter_mut().zip(m2.iter_mut()).zip(paired.iter_mut()).zip(&strides)
        {
            for (row, chunk) in rows.iter_mut().zip(mean_c.chunks_mut(w * stride)) {
                row.mean.push(chunk);
            }
            for (row, chunk) in rows.iter_mut().zip(m2_c.chunks_mut(w * stride)) {
                row.m2.push(chunk);
            }
            for (row, chunk) in rows.iter_mut().zip(paired_c.chunks_mut(w * PAIRED)) {
                row.paired.push(chunk);
            }
        }
        let (traced, traced_rays): (u64, u64) = rows
            .into_par_iter()
            .zip(samples.par_chunks_mut(w))
            .zip(done.par_chunks(w))
            .enumerate()
            .map(|(y, ((mut row, n_row), done_row))| {
                if cancelled() {
                    return (0, 0);
                }
                let job = PassJob {
                    prep: &prep,
                    settings,
                    pinhole: &pinhole,
                    colorimetry: &colorimetry,
                    ranges: &ranges,
                    quantities: &quantities,
                    offsets: &offsets,
                    strides: &strides,
                    reference,
                    total_stride,
                    width: w,
                    pass_spp,
                };
                pass_row(&job, y, &mut row, n_row, done_row)
            })
            .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
        paths += traced;
        rays += traced_rays;
        passes += 1;
        if cancelled() {
            return Err(RenderError::Cancelled);
        }
        // Which pixels are done: the reference's SE(Y), or every coding's.
        let stopping: Vec<usize> = if settings.se_every_coding {
            (0..nc).collect()
        } else {
            vec![reference]
        };
        let ys: Vec<YPlane> = stopping
            .iter()
            .map(|&c| YPlane {
                mean: &mean[c],
                m2: &m2[c],
                stride: strides[c],
                y: quantities[c].coding_channels + Y,
            })
            .collect();
        mark_done(&ys, &samples, settings, &mut done);
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
    let elapsed_seconds = start.elapsed().as_secs_f64();
    let images = codings
        .iter()
        .zip(quantities)
        .zip(mean.into_iter().zip(m2))
        .map(|((coding, quantities), (mean, m2))| CameraImage {
            width: camera.width,
            height: camera.height,
            coding: *coding,
            observer: settings.observer,
            quantities,
            mean,
            m2,
            samples: samples.clone(),
            passes,
            paths,
            rays,
            elapsed_seconds,
            stop,
        })
        .collect();
    Ok(CameraImages {
        images,
        reference,
        paired,
    })
}

/// What every row of a pass shares.
#[derive(Clone, Copy)]
struct PassJob<'a> {
    prep: &'a Prepared<'a>,
    settings: &'a CameraSettings,
    pinhole: &'a Pinhole,
    colorimetry: &'a [Colorimetry],
    ranges: &'a [std::ops::Range<usize>],
    quantities: &'a [Quantities],
    offsets: &'a [usize],
    strides: &'a [usize],
    reference: usize,
    total_stride: usize,
    width: usize,
    pass_spp: u32,
}

/// One pass over row `y`: each unfinished pixel's paths, traced once for
/// every coding, summed and merged into the row's stored moments. Returns
/// the paths and rays traced.
///
/// On x86-64 CPUs with AVX2 and FMA the whole row runs in code compiled
/// for them (4 f64 or 8 f32 lanes instead of SSE2's 2 and 4), as the
/// radiometer's batches do (`integrator::radiometer_batch`); the arithmetic
/// and its order are the same, so are the numbers.
fn pass_row(job: &PassJob, y: usize, row: &mut RowBuffers, n_row: &mut [u32], done_row: &[bool]) -> (u64, u64) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
            // SAFETY: the CPU has AVX2 and FMA, checked just above.
            return unsafe { pass_row_avx2(job, y, row, n_row, done_row) };
        }
    }
    pass_row_inline(job, y, row, n_row, done_row)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn pass_row_avx2(
    job: &PassJob,
    y: usize,
    row: &mut RowBuffers,
    n_row: &mut [u32],
    done_row: &[bool],
) -> (u64, u64) {
    pass_row_inline(job, y, row, n_row, done_row)
}

#[inline(always)]
fn pass_row_inline(job: &PassJob, y: usize, row: &mut RowBuffers, n_row: &mut [u32], done_row: &[bool]) -> (u64, u64) {
    let PassJob {
        prep,
        settings,
        pinhole,
        colorimetry,
        ranges,
        quantities,
        offsets,
        strides,
        reference,
        total_stride,
        width: w,
        pass_spp,
    } = *job;
    let nc = colorimetry.len();
    let seed = settings.seed;
    let mut state = PathState::new(&prep.layout);
    let mut q = vec![0.0f64; total_stride];
    // A pass's sums, shifted by its first path's values (so no
    // division per path, and no cancellation when a quantity's
    // spread is small against its mean): Σ(v − v₀), Σ(v − v₀)².
    let mut shift = vec![0.0f64; total_stride];
    let mut pass_sum = vec![0.0f64; total_stride];
    let mut pass_sq = vec![0.0f64; total_stride];
    // Per coding: Σ of the shifted own-XYZ cross products (3),
    // then of the shifted paired difference d − d₀ (3), its
    // squares (3) and cross products (3).
    let mut pass_sums = vec![0.0f64; nc * PAIRED];
    let mut d_shift = vec![[0.0f64; 3]; nc];
    // The pass's means, squared deviations and PAIRED moments.
    let mut pass_mean = vec![0.0f64; total_stride];
    let mut pass_m2 = vec![0.0f64; total_stride];
    let mut pass_paired = vec![0.0f64; nc * PAIRED];
    let xyz_at = |c: usize| offsets[c] + quantities[c].coding_channels;
    let xyz_of = |v: &[f64], c: usize| [v[xyz_at(c)], v[xyz_at(c) + 1], v[xyz_at(c) + 2]];
    let mut traced = 0u64;
    for x in 0..w {
        if done_row[x] {
            continue;
        }
        let pixel = (y * w + x) as u64;
        let first = n_row[x];
        let nb = pass_spp.min(settings.max_spp - first);
        pass_sum.fill(0.0);
        pass_sq.fill(0.0);
        pass_sums.fill(0.0);
        for i in 0..nb {
            let s = settings.first_sample as u64 + (first + i) as u64;
            let mut rng = PathSampler::new(SamplerKind::Independent, seed, u64::MAX - pixel, s);
            let ray = pinhole.ray(x, y, rng.next_2d());
            trace_path(prep, &settings.transport, ray, &mut rng, &mut state);
            for c in 0..nc {
                let radiance = &state.radiance[ranges[c].clone()];
                let n_channels = radiance.len();
                let qc = &mut q[offsets[c]..offsets[c] + strides[c]];
                for (qk, r) in qc.iter_mut().zip(radiance) {
                    *qk = *r as f64;
                }
                colorimetry[c].apply(radiance, &mut qc[n_channels..n_channels + 6]);
            }
            let reference_xyz = xyz_of(&q, reference);
            if i == 0 {
                shift.copy_from_slice(&q);
                for (c, d0) in d_shift.iter_mut().enumerate() {
                    let v = xyz_of(&q, c);
                    *d0 = std::array::from_fn(|k| v[k] - reference_xyz[k]);
                }
            }
            for (((sum, sq), v), v0) in pass_sum.iter_mut().zip(pass_sq.iter_mut()).zip(&q).zip(&shift) {
                let dv = v - v0;
                *sum += dv;
                *sq += dv * dv;
            }
            for c in 0..nc {
                let sums = &mut pass_sums[c * PAIRED..(c + 1) * PAIRED];
                let (v, v0) = (xyz_of(&q, c), xyz_of(&shift, c));
                let o: [f64; 3] = std::array::from_fn(|k| v[k] - v0[k]);
                sums[0] += o[0] * o[1];
                sums[1] += o[0] * o[2];
                sums[2] += o[1] * o[2];
                if c == reference {
                    continue;
                }
                // The paired difference d = XYZ(c) − XYZ(reference) of this path.
                let dv: [f64; 3] = std::array::from_fn(|k| v[k] - reference_xyz[k] - d_shift[c][k]);
                for k in 0..3 {
                    sums[3 + k] += dv[k];
                    sums[6 + k] += dv[k] * dv[k];
                }
                sums[9] += dv[0] * dv[1];
                sums[10] += dv[0] * dv[2];
                sums[11] += dv[1] * dv[2];
            }
        }
        // The pass's means and (co-)moments from its shifted sums:
        // Σ(v − v̄)² = Σ(v − v₀)² − (Σ(v − v₀))²/n, and likewise
        // Σ(a − ā)(b − b̄) = Σ(a − a₀)(b − b₀) − Σ(a − a₀)·Σ(b − b₀)/n.
        let nbf = nb as f64;
        for k in 0..total_stride {
            pass_mean[k] = shift[k] + pass_sum[k] / nbf;
            pass_m2[k] = (pass_sq[k] - pass_sum[k] * pass_sum[k] / nbf).max(0.0);
        }
        for c in 0..nc {
            let sums = &pass_sums[c * PAIRED..(c + 1) * PAIRED];
            let moments = &mut pass_paired[c * PAIRED..(c + 1) * PAIRED];
            let x0 = xyz_at(c);
            let o = |k: usize| pass_sum[x0 + k];
            moments[OWN_CROSS] = sums[0] - o(0) * o(1) / nbf;
            moments[OWN_CROSS + 1] = sums[1] - o(0) * o(2) / nbf;
            moments[OWN_CROSS + 2] = sums[2] - o(1) * o(2) / nbf;
            let ds = |k: usize| sums[3 + k];
            for k in 0..3 {
                moments[D_MEAN + k] = if c == reference {
                    0.0
                } else {
                    d_shift[c][k] + ds(k) / nbf
                };
                moments[D_COMOMENTS + k] = (sums[6 + k] - ds(k) * ds(k) / nbf).max(0.0);
            }
            moments[D_COMOMENTS + 3] = sums[9] - ds(0) * ds(1) / nbf;
            moments[D_COMOMENTS + 4] = sums[10] - ds(0) * ds(2) / nbf;
            moments[D_COMOMENTS + 5] = sums[11] - ds(1) * ds(2) / nbf;
        }
        traced += nb as u64;
        // Chan et al.: merge the pass (nb paths) into the stored (na paths).
        let (na, nbf) = (first as f64, nb as f64);
        let n = na + nbf;
        let weight = na * nbf / n;
        for c in 0..nc {
            let range = x * strides[c]..(x + 1) * strides[c];
            let pass = offsets[c]..offsets[c] + strides[c];
            let xyz = quantities[c].coding_channels;
            let stored_xyz: [f64; 3] = std::array::from_fn(|k| row.mean[c][range.start + xyz + k] as f64);
            for ((m, s2), (pm, pm2)) in row.mean[c][range.clone()]
                .iter_mut()
                .zip(row.m2[c][range.clone()].iter_mut())
                .zip(pass_mean[pass.clone()].iter().zip(&pass_m2[pass.clone()]))
            {
                let ma = *m as f64;
                let delta = pm - ma;
                *m = (ma + delta * nbf / n) as f32;
                *s2 = (*s2 as f64 + pm2 + delta * delta * weight) as f32;
            }
            let block = &pass_paired[c * PAIRED..(c + 1) * PAIRED];
            let stored = &mut row.paired[c][x * PAIRED..(x + 1) * PAIRED];
            let delta: [f64; 3] = std::array::from_fn(|k| pass_mean[pass.start + xyz + k] - stored_xyz[k]);
            merge_paired(stored, block, delta, weight, (nbf, n), c == reference);
        }
        n_row[x] = first + nb;
    }
    (traced, state.rays)
}

/// A radiometer target as the camera sees it.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct TargetInView {
    pub id: String,
    /// The target's image point, pixels (x right, y down from the top-left corner).
    pub x: f64,
    pub y: f64,
    /// The point falls inside the image.
    pub inside: bool,
    /// The first surface along the camera's ray toward the target is the
    /// target's own (within 1 mm, or 10⁻⁴ of the distance): nothing hides it.
    pub visible: bool,
}

/// The scene's radiometer targets projected into `camera`'s view, each with
/// whether the camera sees it (issue 48: the points of an image where the
/// displayed image is measured, as the booth's targets were).
pub fn targets_in_view(scene: &Scene, camera: &Camera) -> Result<Vec<TargetInView>, RenderError> {
    let prep = Prepared::new(scene, ChannelLayout::new(&[Coding::Rgb])).map_err(RenderError::Prepare)?;
    let pinhole = Pinhole::new(camera);
    Ok(scene
        .target_list
        .iter()
        .map(|t| {
            let (x, y) = pinhole.project(t.point).unwrap_or((f64::NAN, f64::NAN));
            let inside = (0.0..camera.width as f64).contains(&x) && (0.0..camera.height as f64).contains(&y);
            let to = t.point - camera.position;
            let distance = to.length();
            let ray = crate::geometry::Ray {
                origin: camera.position,
                dir: to / distance,
            };
            let visible = !x.is_nan()
                && prep
                    .nearest_primitive(&ray)
                    .is_some_and(|(hit, _)| (hit.t - distance).abs() <= 1e-3f64.max(1e-4 * distance));
            TargetInView {
                id: t.id.clone(),
                x,
                y,
                inside,
                visible,
            }
        })
        .collect())
}

/// Every coding's image of one render, from the same paths, and the paired
/// moments that give the difference of two codings its own noise.
#[derive(Clone, Debug)]
pub struct CameraImages {
    /// One image per coding, in the settings' order (duplicates removed).
    pub images: Vec<CameraImage>,
    /// Which of `images` the others are compared with.
    pub reference: usize,
    /// Per image, per pixel, [`PAIRED`] moments.
    paired: Vec<Vec<f32>>,
}

/// How far one coding's image is from the reference's, from the same paths
/// (ΔE00 per pixel between the two images' means, with one CIELAB white).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PairedDifference {
    pub coding: String,
    pub reference: String,
    /// ΔE00 over the image's pixels: the mean, the 95th percentile, the largest.
    pub mean: f64,
    pub p95: f64,
    pub max: f64,
    /// The standard error of `mean` from the paired paths: √(Σₚ σₚ²)/N over
    /// the N pixels (each pixel's paths are its own), σₚ the paired noise
    /// of pixel p as in `noise_paired`. An upper bound: σₚ is the whole
    /// RMS noise, of which only the part along the difference moves ΔE00
    /// where the codings differ by more than the noise.
    pub se_mean: f64,
    /// The RMS over pixels of the ΔE00 the paths' noise alone puts between
    /// the two pixel means, from the paired difference's own covariance Σ_d
    /// (see [`CameraImages::difference`]).
    pub noise_paired: f64,
    /// The same had the two images been rendered from independent paths
    /// (Σ_a + Σ_r, each image's own covariance of its mean XYZ): the noise
    /// the paired render removes.
    pub noise_independent: f64,
    /// The CIELAB white of every ΔE00 (XYZ, Y in cd/m²).
    pub white: [f64; 3],
}

impl CameraImages {
    /// The reference coding's image alone.
    pub fn into_reference(mut self) -> CameraImage {
        self.images.swap_remove(self.reference)
    }

    pub fn reference_image(&self) -> &CameraImage {
        &self.images[self.reference]
    }

    /// [`CameraImage::every_nth_band`] on the `spectral` coding's image,
    /// the other codings as they are; `step` 1 changes nothing.
    pub fn every_nth_band(mut self, step: usize) -> Result<CameraImages, String> {
        if step == 1 {
            return Ok(self);
        }
        let spectral = self.images.iter().position(|i| i.coding == Coding::Spectral).ok_or_else(|| {
            let codings: Vec<String> = self.images.iter().map(|i| i.coding.to_string()).collect();
            format!(
                "a spectral step of {step} nm picks bands of the 1 nm `spectral` coding, which the image does not have ({})",
                codings.join(",")
            )
        })?;
        self.images[spectral] = self.images[spectral].every_nth_band(step)?;
        Ok(self)
    }

    /// Adds the paths of `other` to these: the same codings, size,
    /// observer and reference, traced from other path indices (its
    /// [`CameraSettings::first_sample`]), as a render worker's batch is.
    /// Per pixel, Chan et al.'s pairwise update of every quantity's mean
    /// and squared deviations and of the paired moments (the XYZ cross
    /// products, the paired difference's mean and co-moments): exact in real
    /// arithmetic, so merged batches equal one render of all their paths up
    /// to the `f32` rounding of the stored moments (the merges happen in
    /// another order than one render's passes). Counts (passes, paths,
    /// rays, seconds) add up; the stop reason is left to the caller.
    pub fn merge(&mut self, other: &CameraImages) -> Result<(), String> {
        let describe = |c: &CameraImages| {
            let first = &c.images[0];
            let codings: Vec<String> = c.images.iter().map(|i| i.coding.to_string()).collect();
            format!(
                "{} × {} in {} (reference {}, observer {})",
                first.width,
                first.height,
                codings.join(","),
                c.images[c.reference].coding,
                first.observer
            )
        };
        if self.images.is_empty() || other.images.is_empty() {
            return Err("an image set without images cannot be merged".into());
        }
        if describe(self) != describe(other) {
            return Err(format!(
                "cannot merge a batch of {} into an image of {}: the batches of one image share its size, codings and observer",
                describe(other),
                describe(self)
            ));
        }
        let reference = self.reference;
        let before: Vec<u32> = self.images[0].samples.clone();
        let added = &other.images[0].samples;
        for (c, (a, b)) in self.images.iter_mut().zip(&other.images).enumerate() {
            let stride = a.stride();
            let xyz = a.xyz_index();
            a.mean
                .par_chunks_mut(stride)
                .zip(a.m2.par_chunks_mut(stride))
                .zip(self.paired[c].par_chunks_mut(PAIRED))
                .zip(b.mean.par_chunks(stride).zip(b.m2.par_chunks(stride)))
                .zip(other.paired[c].par_chunks(PAIRED))
                .zip(before.par_iter().zip(added.par_iter()))
                .for_each(|(((((mean, m2), paired), (mean_b, m2_b)), paired_b), (&na, &nb))| {
                    if nb == 0 {
                        return;
                    }
                    let (na, nb) = (na as f64, nb as f64);
                    let n = na + nb;
                    let weight = na * nb / n;
                    let delta_xyz: [f64; 3] = std::array::from_fn(|k| mean_b[xyz + k] as f64 - mean[xyz + k] as f64);
                    for ((m, s2), (mb, m2b)) in mean.iter_mut().zip(m2.iter_mut()).zip(mean_b.iter().zip(m2_b)) {
                        let ma = *m as f64;
                        let delta = *mb as f64 - ma;
                        *m = (ma + delta * nb / n) as f32;
                        *s2 = (*s2 as f64 + *m2b as f64 + delta * delta * weight) as f32;
                    }
                    let block: [f64; PAIRED] = std::array::from_fn(|k| paired_b[k] as f64);
                    merge_paired(paired, &block, delta_xyz, weight, (nb, n), c == reference);
                });
            for (s, n) in a.samples.iter_mut().zip(added) {
                *s += n;
            }
            a.passes += b.passes;
            a.paths += b.paths;
            a.rays += b.rays;
            a.elapsed_seconds += b.elapsed_seconds;
        }
        Ok(())
    }

    /// Pixels done by the stopping rule of `settings` (the module doc: the
    /// path cap, or the SE target on the reference's Y, or every coding's),
    /// as [`render_camera_images`] decides after each pass; for a daemon
    /// merging a worker's batches.
    pub fn pixels_done(&self, settings: &CameraSettings) -> u64 {
        let stopping: Vec<usize> = if settings.se_every_coding {
            (0..self.images.len()).collect()
        } else {
            vec![self.reference]
        };
        let ys: Vec<YPlane> = stopping
            .iter()
            .map(|&c| {
                let img = &self.images[c];
                YPlane {
                    mean: &img.mean,
                    m2: &img.m2,
                    stride: img.stride(),
                    y: img.xyz_index() + Y,
                }
            })
            .collect();
        let samples = &self.images[0].samples;
        let mut done = vec![false; samples.len()];
        mark_done(&ys, samples, settings, &mut done);
        done.iter().filter(|d| **d).count() as u64
    }

    /// The set as bytes, for a render worker to hand its batch to the
    /// daemon: a JSON header line (`IMAGE_SET_FORMAT`, size, codings,
    /// reference, observer, counts), then per image its means and squared
    /// deviations, per image its paired moments (`f32`, little-endian), and
    /// the paths per pixel (`u32`). [`CameraImages::from_bytes`] reads it.
    pub fn to_bytes(&self) -> Vec<u8> {
        let first = &self.images[0];
        let header = serde_json::json!({
            "format": IMAGE_SET_FORMAT,
            "width": first.width,
            "height": first.height,
            "codings": self.images.iter().map(|i| i.coding.to_string()).collect::<Vec<_>>(),
            "reference": self.reference,
            "observer": first.observer,
            "passes": first.passes,
            "paths": first.paths,
            "rays": first.rays,
            "elapsed_seconds": first.elapsed_seconds,
            "stop": first.stop,
        });
        let mut out = header.to_string().into_bytes();
        out.push(b'\n');
        let floats: usize = self.images.iter().map(|i| i.mean.len() * 2).sum::<usize>()
            + self.paired.iter().map(Vec::len).sum::<usize>();
        out.reserve(floats * 4 + first.samples.len() * 4);
        for img in &self.images {
            out.extend(img.mean.iter().chain(&img.m2).flat_map(|v| v.to_le_bytes()));
        }
        for p in &self.paired {
            out.extend(p.iter().flat_map(|v| v.to_le_bytes()));
        }
        out.extend(first.samples.iter().flat_map(|v| v.to_le_bytes()));
        out
    }

    /// Reads [`CameraImages::to_bytes`]; what does not fit its header is an
    /// error saying what.
    pub fn from_bytes(bytes: &[u8]) -> Result<CameraImages, String> {
        #[derive(serde::Deserialize)]
        struct Header {
            format: String,
            width: u32,
            height: u32,
            codings: Vec<String>,
            reference: usize,
            observer: Observer,
            passes: u32,
            paths: u64,
            rays: u64,
            elapsed_seconds: f64,
            stop: StopReason,
        }
        let line = bytes
            .iter()
            .position(|b| *b == b'\n')
            .ok_or("an image batch without its header line")?;
        let h: Header = serde_json::from_slice(&bytes[..line]).map_err(|e| format!("an image batch's header: {e}"))?;
        if h.format != IMAGE_SET_FORMAT {
            return Err(format!(
                "an image batch in format `{}`; this build reads `{IMAGE_SET_FORMAT}`",
                h.format
            ));
        }
        let codings: Vec<Coding> = h
            .codings
            .iter()
            .map(|c| {
                c.parse::<Coding>()
                    .map_err(|e| format!("an image batch's coding `{c}`: {e}"))
            })
            .collect::<Result<_, _>>()?;
        if h.reference >= codings.len() {
            return Err(format!(
                "an image batch's reference {} is not one of its {} codings",
                h.reference,
                codings.len()
            ));
        }
        let pixels = h.width as usize * h.height as usize;
        let quantities: Vec<Quantities> = codings.iter().map(|c| Quantities::of(*c)).collect();
        let floats: usize = quantities
            .iter()
            .map(|q| pixels * (q.coding_channels + 6) * 2)
            .sum::<usize>()
            + codings.len() * pixels * PAIRED;
        let body = &bytes[line + 1..];
        let expected = floats * 4 + pixels * 4;
        if body.len() != expected {
            return Err(format!(
                "an image batch of {} × {} in {} holds {} bytes after its header, not {expected}",
                h.width,
                h.height,
                h.codings.join(","),
                body.len()
            ));
        }
        let mut at = 0usize;
        let mut take_f32 = |n: usize| -> Vec<f32> {
            let v = body[at..at + 4 * n]
                .chunks_exact(4)
                .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
                .collect();
            at += 4 * n;
            v
        };
        let mut planes = Vec::new();
        for q in &quantities {
            let n = pixels * (q.coding_channels + 6);
            planes.push((take_f32(n), take_f32(n)));
        }
        let paired: Vec<Vec<f32>> = (0..codings.len()).map(|_| take_f32(pixels * PAIRED)).collect();
        let samples: Vec<u32> = body[floats * 4..]
            .chunks_exact(4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect();
        let images = codings
            .into_iter()
            .zip(quantities)
            .zip(planes)
            .map(|((coding, quantities), (mean, m2))| CameraImage {
                width: h.width,
                height: h.height,
                coding,
                observer: h.observer,
                quantities,
                mean,
                m2,
                samples: samples.clone(),
                passes: h.passes,
                paths: h.paths,
                rays: h.rays,
                elapsed_seconds: h.elapsed_seconds,
                stop: h.stop,
            })
            .collect();
        Ok(CameraImages {
            images,
            reference: h.reference,
            paired,
        })
    }

    /// The covariance of pixel `p`'s mean XYZ in image `c`: the image's own
    /// squared deviations and the kept co-moments, over n(n − 1).
    fn own_covariance(&self, c: usize, p: usize) -> [[f64; 3]; 3] {
        let img = &self.images[c];
        let n = img.samples[p] as f64;
        let scale = 1.0 / (n * (n - 1.0)).max(1.0);
        let x0 = p * img.stride() + img.xyz_index();
        let d: [f64; 3] = std::array::from_fn(|k| img.m2[x0 + k].max(0.0) as f64 * scale);
        let block = &self.paired[c][p * PAIRED..];
        let o = |k: usize| block[OWN_CROSS + k] as f64 * scale;
        [[d[0], o(0), o(1)], [o(0), d[1], o(2)], [o(1), o(2), d[2]]]
    }

    /// The covariance of pixel `p`'s mean paired difference XYZ(c) − XYZ(reference).
    fn paired_covariance(&self, c: usize, p: usize) -> [[f64; 3]; 3] {
        let n = self.images[c].samples[p] as f64;
        let scale = 1.0 / (n * (n - 1.0)).max(1.0);
        let b = &self.paired[c][p * PAIRED + D_COMOMENTS..];
        let v = |k: usize| b[k] as f64 * scale;
        [[v(0), v(3), v(4)], [v(3), v(1), v(5)], [v(4), v(5), v(2)]]
    }

    /// Image `c` against the reference: ΔE00 per pixel with CIELAB white
    /// `white`, summarised, with its noise.
    ///
    /// The noise of a pixel's ΔE00 is σ² = Σᵢⱼ Qᵢⱼ Σᵢⱼ: Σ the covariance of
    /// the difference of the two mean XYZ (paired: the difference's own
    /// over the pixel's paths; independent: the sum of the two images'), Q
    /// the local quadratic form of ΔE00² in XYZ at the reference's mean
    /// (ΔE00² ≈ δᵀQδ for a small step δ), found by finite differences of
    /// ΔE00 with steps of 10⁻⁴ of the white — so σ is the RMS ΔE00 that
    /// noise of covariance Σ alone puts between two colours (E[δᵀQδ] =
    /// tr(QΣ)), a linearisation stated here.
    pub fn difference(&self, c: usize, white: Xyz) -> PairedDifference {
        let (a, r) = (&self.images[c], self.reference_image());
        let pixels = a.samples.len();
        let w = white.to_array();
        let step: [f64; 3] = std::array::from_fn(|k| 1e-4 * w[k].abs().max(1e-12));
        let per_pixel: Vec<(f64, f64, f64)> = (0..pixels)
            .into_par_iter()
            .map(|p| {
                let xyz = |img: &CameraImage| -> [f64; 3] {
                    let x0 = p * img.stride() + img.xyz_index();
                    std::array::from_fn(|k| img.mean[x0 + k] as f64)
                };
                let (xa, xr) = (xyz(a), xyz(r));
                let lab = |v: [f64; 3]| Lab::from_xyz(Xyz::from_array(v), white);
                let reference_lab = lab(xr);
                let delta_e = ciede2000(lab(xa), reference_lab);
                if c == self.reference {
                    return (0.0, 0.0, 0.0);
                }
                // Q by finite differences around the reference's mean.
                let f = |d: [f64; 3]| {
                    let e = ciede2000(lab([xr[0] + d[0], xr[1] + d[1], xr[2] + d[2]]), reference_lab);
                    e * e
                };
                let unit = |i: usize| -> [f64; 3] { std::array::from_fn(|k| if k == i { step[i] } else { 0.0 }) };
                let diag: [f64; 3] = std::array::from_fn(|i| f(unit(i)));
                let mut q = [[0.0; 3]; 3];
                for i in 0..3 {
                    q[i][i] = diag[i] / (step[i] * step[i]);
                    for j in 0..i {
                        let both: [f64; 3] = std::array::from_fn(|k| unit(i)[k] + unit(j)[k]);
                        let v = (f(both) - diag[i] - diag[j]) / (2.0 * step[i] * step[j]);
                        q[i][j] = v;
                        q[j][i] = v;
                    }
                }
                let trace = |s: [[f64; 3]; 3]| -> f64 {
                    (0..3)
                        .flat_map(|i| (0..3).map(move |j| (i, j)))
                        .map(|(i, j)| q[i][j] * s[i][j])
                        .sum::<f64>()
                        .max(0.0)
                };
                let paired = trace(self.paired_covariance(c, p));
                let (sa, sr) = (self.own_covariance(c, p), self.own_covariance(self.reference, p));
                let independent = trace(std::array::from_fn(|i| std::array::from_fn(|j| sa[i][j] + sr[i][j])));
                (delta_e, paired, independent)
            })
            .collect();
        let n = pixels.max(1) as f64;
        let mut sorted: Vec<f64> = per_pixel.iter().map(|v| v.0).collect();
        sorted.sort_by(|p, q| p.total_cmp(q));
        let paired_sum: f64 = per_pixel.iter().map(|v| v.1).sum();
        PairedDifference {
            coding: a.coding.to_string(),
            reference: r.coding.to_string(),
            mean: sorted.iter().sum::<f64>() / n,
            p95: sorted
                .get(((0.95 * (sorted.len().max(1) - 1) as f64).round() as usize).min(sorted.len().saturating_sub(1)))
                .copied()
                .unwrap_or(0.0),
            max: sorted.last().copied().unwrap_or(0.0),
            se_mean: paired_sum.sqrt() / n,
            noise_paired: (paired_sum / n).sqrt(),
            noise_independent: (per_pixel.iter().map(|v| v.2).sum::<f64>() / n).sqrt(),
            white: w,
        }
    }
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
            rays: self.rays,
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
