//! Monte Carlo path tracing with next-event estimation, carrying every
//! coding's channels at once.
//!
//! One loop ([`trace_path`]) serves every material and every light, as
//! pbrt-v4's `PathIntegrator` (`cpu/integrators.cpp`, `SampleLd`): at each
//! vertex xⱼ of a path x₀ (first hit), x₁, …, with throughput β per channel,
//!
//! 1. **emission**: a ray that hits an emitting triangle adds β ⊙ Le ·
//!    w_bsdf, w_bsdf = p_bsdf²/(p_bsdf² + p_light²) (Veach & Guibas 1995,
//!    the power heuristic), where p_light = P(light)·p_light(y) is the
//!    light strategy's density of that point: the light sampler's
//!    probability of that emitter times its density of the point
//!    ([`SceneLights::emission_pdf`]). The sensor's own ray and an ideal
//!    reflection have no BSDF density: the emitter counts fully;
//! 2. **the BSDF at the vertex** ([`VertexBsdf`], [`super::bsdf`]): f = ρ/π
//!    for a Lambertian surface, RADIANCE's `plastic`, `metal` and `mirror`
//!    otherwise, a·ρ + b per channel (scalars a, b per direction pair);
//! 3. **one direct-light estimate** (`estimate_direct`, pbrt's `SampleLd`):
//!    one light ℓ of the scene's one collection ([`SceneLights`]: point
//!    luminaires and area lights), chosen by the light sampler with
//!    probability P(ℓ) ([`super::lights::sampler`]: ∝ luminous flux by
//!    default, or 1/n; P = 1 and no random number for a scene with one
//!    light), and one sample of it, with an unblocked shadow ray: a delta
//!    light (no area) adds β ⊙ f ⊙ I(ω)·cos θᵢ / (d²·P), I the luminaire's
//!    spectral intensity in W/(sr·nm) toward xⱼ, with no MIS weight; a
//!    point y on an area light (density p_ℓ in solid angle) adds β ⊙ f ⊙
//!    Le·cos θᵢ / (P·p_ℓ) · w_light, w_light the power heuristic of P·p_ℓ
//!    against the BSDF's density. At the last vertex (no bounce follows) the
//!    light sample counts fully;
//! 4. **one Russian roulette** (`russian_roulette`) from the bounce the
//!    settings ask for (by default the third): survival q = max channel of
//!    β, at least 0.05, with β /= q — unbiased;
//! 5. **the bounce**: a direction sampled from the BSDF (cosine-weighted for
//!    a Lambertian surface, pdf = cos θ / π, so f·cos θ / pdf is exactly ρ;
//!    the Ward lobe or the cosine for a glossy one, their mixture density
//!    being p_bsdf for MIS; an ideal reflection for a mirror), β ← β ⊙
//!    f·cos θ / pdf.
//!
//! A RADIANCE `spotlight`'s Le is Le·s(ω, d) in both strategies alike
//! ([`super::scene::Spot`]: 0 outside its cone, d²/(d + flen)² inside, 1
//! for the sensor's own ray), so the weights and densities are unchanged
//! and the estimate stays unbiased (the bounce's d is measured from the
//! offset ray origin, `SPAWN_OFFSET_M` from the point the light sample
//! uses: a relative difference below 1e-6 at the booth's distances).
//!
//! Paths end by the roulette, when they leave the scene (open sides return
//! zero radiance), on a surface that reflects nothing, or — only when a cap
//! is asked for — after `max_bounces` indirect bounces (RADIANCE `-ab`: a
//! truncation bias).
//!
//! The order of every product is fixed: the renderer gives the same bits
//! for a fixed seed as before the materials and lights shared this one
//! loop in scenes with one light (`tests/render/fixed_seed_pins.rs`); in
//! scenes with several, choosing one light by probability replaced the
//! exact sum over the point lights, with the same expectation.
//!
//! The channel arithmetic works on contiguous `f32` slices whose length is a
//! multiple of 8, which the compiler vectorises; nothing is allocated per ray.
//!
//! A render can be stopped between batches of paths: the entry points
//! ([`render`](super::render), [`render_camera_image`](super::camera::render_camera_image),
//! [`render_camera`](super::sensor::render_camera), [`time_renders`](super::cost::time_renders))
//! take the job's `tokio_util::sync::CancellationToken` as a parameter (the
//! daemon's jobs give one, a child of its shutdown token; the command
//! line's renders give `None` and always finish).

use std::sync::Arc;

use glam::DVec3;

use super::bsdf::{Bsdf, VertexBsdf};
use super::bvh::{Bvh, LINEAR_SCAN_BELOW};
use super::coding::ChannelLayout;
use super::geometry::Ray;
use super::lights::{
    power_heuristic, EmitterHit, LiSample, LightContext, LightSampling, SceneLights, ShadowRay, SpectrumOf,
};
use super::sampling::{cone_direction, PathSampler, SamplerKind, REPLICATES};
use super::scene::Scene;

/// Offset of spawned rays from their surface along the normal, m. Only the
/// rays start there: distances and cosines of next-event estimation are
/// taken from the surface point itself, so the offset does not bias
/// irradiance in small (millimetre) scenes.
const SPAWN_OFFSET_M: f64 = 1e-6;

/// Transport settings shared by every sensor.
#[derive(Clone, Copy, Debug)]
pub struct Transport {
    /// Most indirect bounces (RADIANCE `-ab`); `None`: no cap (then
    /// Russian roulette must end the paths).
    pub max_bounces: Option<u32>,
    /// Russian roulette from this bounce on; `None` = never.
    pub russian_roulette_from: Option<u32>,
    /// How the direct-light estimate chooses its one light
    /// ([`super::lights::sampler`]): by power (the default) or uniformly.
    pub light_sampler: LightSampling,
}

/// The scene with every material and light converted to channels once.
pub struct Prepared<'a> {
    pub scene: &'a Scene,
    pub layout: ChannelLayout,
    /// `materials[m * len .. (m + 1) * len]`: reflectance channels.
    material_channels: Vec<f32>,
    /// Spectral intensity per cd of each light, as channels.
    light_channels: Vec<f32>,
    /// Spectral radiance of each area light's emitter, as channels.
    emitter_channels: Vec<f32>,
    /// Per material: true when it reflects nothing in any channel (a path
    /// that reaches it ends there).
    material_black: Vec<bool>,
    /// Per material: its reflection model ([`super::bsdf`]).
    bsdfs: Vec<Bsdf>,
    /// Every light (point luminaires and area lights) and the light
    /// samplers over them, for next-event estimation and the MIS weight of
    /// emission.
    pub lights: SceneLights<'a>,
    /// The BVH over `scene.primitives`; `None` below
    /// [`LINEAR_SCAN_BELOW`] primitives, where a linear scan is faster.
    bvh: Option<Arc<Bvh>>,
}

impl<'a> Prepared<'a> {
    pub fn new(scene: &'a Scene, layout: ChannelLayout) -> Result<Prepared<'a>, String> {
        let mut material_channels = Vec::new();
        for m in &scene.materials {
            let mut c = layout
                .reflectance_channels(&m.reflectance)
                .map_err(|e| format!("material `{}`: {e}", m.name))?;
            // A RADIANCE RGB colour is exact in the rgb coding.
            if let Some(rgb) = m.rgb {
                layout.set_rgb(&mut c, rgb);
            }
            material_channels.extend(c);
        }
        let mut light_channels = Vec::new();
        for l in &scene.lights {
            light_channels.extend(
                layout
                    .light_channels(&l.spectrum_per_cd)
                    .map_err(|e| format!("light `{}`: {e}", l.id))?,
            );
        }
        let mut emitter_channels = Vec::new();
        for e in &scene.emitters {
            // The same conversion as a point light's spectrum (spectral: the
            // values; RGB: M⁻¹ · absolute XYZ), applied to radiance.
            let mut c = layout
                .light_channels(&e.radiance)
                .map_err(|err| format!("emitter `{}`: {err}", e.name))?;
            if let Some(rgb) = e.rgb {
                layout.set_rgb(&mut c, rgb);
            }
            emitter_channels.extend(c);
        }
        let n = layout.len();
        let ybar = &lightbooth_science::colorimetry::Cmf::of(super::coding::OBSERVER)
            .on_grid(&lightbooth_science::spectrum::Grid::one_nm())[1];
        let ybar_sum: f64 = ybar.iter().sum();
        let mut bsdfs = Vec::with_capacity(scene.materials.len());
        for m in &scene.materials {
            // The luminous reflectance (equal-energy white) sets only the
            // lobe's sampling probability, the same for every coding.
            let rho = m
                .reflectance
                .resample(&lightbooth_science::spectrum::Grid::one_nm())
                .map_err(|e| format!("material `{}`: {e}", m.name))?;
            let rho_mean = rho.values().iter().zip(ybar).map(|(r, y)| r * y).sum::<f64>() / ybar_sum;
            bsdfs.push(Bsdf::new(m.surface, rho_mean));
        }
        let material_black = material_channels
            .chunks(n.max(1))
            .zip(&bsdfs)
            .map(|(m, b)| !b.reflects_without_colour() && m.iter().all(|&r| r == 0.0))
            .collect();
        let bvh = (scene.primitives.len() >= LINEAR_SCAN_BELOW).then(|| scene.bvh.get_or_build(&scene.primitives[..]));
        Ok(Prepared {
            scene,
            layout,
            material_channels,
            light_channels,
            emitter_channels,
            material_black,
            bsdfs,
            lights: SceneLights::new(scene)?,
            bvh,
        })
    }

    #[inline]
    fn emitter(&self, e: usize) -> &[f32] {
        let n = self.layout.len();
        &self.emitter_channels[e * n..(e + 1) * n]
    }

    #[inline]
    fn material(&self, m: usize) -> &[f32] {
        let n = self.layout.len();
        &self.material_channels[m * n..(m + 1) * n]
    }

    #[inline]
    fn light(&self, i: usize) -> &[f32] {
        let n = self.layout.len();
        &self.light_channels[i * n..(i + 1) * n]
    }

    /// The prepared channels of a light sample's spectrum.
    #[inline]
    fn spectrum(&self, of: SpectrumOf) -> &[f32] {
        match of {
            SpectrumOf::Luminaire(i) => self.light(i),
            SpectrumOf::Emitter(e) => self.emitter(e),
        }
    }

    /// True when nothing blocks a light sample's shadow ray from the offset
    /// origin: along the direction up to a point light, or to a point on an
    /// emitting triangle, stopping just short of the light's own surface.
    #[inline]
    fn unoccluded(&self, origin: DVec3, sample: &LiSample) -> bool {
        match sample.shadow {
            ShadowRay::Along { t_max } => !self.occluded(&Ray { origin, dir: sample.wi }, t_max),
            ShadowRay::ToPoint(point) => {
                let to_point = point - origin;
                let reach = to_point.length();
                let shadow = Ray {
                    origin,
                    dir: to_point / reach,
                };
                !self.occluded(&shadow, reach * (1.0 - 1e-9) - 1e-9)
            }
        }
    }

    /// The nearest surface along the ray: (hit, index into
    /// `scene.primitives`); of equal distances, the smallest index.
    #[inline]
    pub fn nearest_primitive(&self, ray: &Ray) -> Option<(super::geometry::Hit, usize)> {
        let primitives = &self.scene.primitives[..];
        if let Some(bvh) = &self.bvh {
            return bvh.nearest(primitives, ray, f64::INFINITY);
        }
        let mut best = None;
        let mut t_max = f64::INFINITY;
        for (i, p) in primitives.iter().enumerate() {
            if let Some(h) = p.shape.intersect(ray, t_max) {
                t_max = h.t;
                best = Some((h, i));
            }
        }
        best
    }

    /// True when a surface lies on the ray with RAY_EPSILON_M < t < t_max.
    #[inline]
    fn occluded(&self, ray: &Ray, t_max: f64) -> bool {
        let primitives = &self.scene.primitives[..];
        if let Some(bvh) = &self.bvh {
            return bvh.occluded(primitives, ray, t_max);
        }
        primitives.iter().any(|p| p.shape.intersect(ray, t_max).is_some())
    }
}

/// Scratch vectors for one thread's paths, allocated once per batch.
pub struct PathState {
    /// Path throughput β per channel (dimensionless).
    pub beta: Vec<f32>,
    /// Radiance gathered by the path per channel (W/(sr·m²·nm), or RGB units).
    pub radiance: Vec<f32>,
    /// Rays traced (camera/radiometer, bounce and shadow rays).
    pub rays: u64,
    /// False while the path has gathered no light (its radiance is all zero).
    pub lit: bool,
}

impl PathState {
    pub fn new(layout: &ChannelLayout) -> PathState {
        PathState {
            beta: vec![0.0; layout.len()],
            radiance: vec![0.0; layout.len()],
            rays: 0,
            lit: false,
        }
    }
}

/// Traces one path from `ray` and leaves its radiance estimate in `state.radiance`.
#[inline(always)]
pub fn trace_path(prep: &Prepared, transport: &Transport, mut ray: Ray, rng: &mut PathSampler, state: &mut PathState) {
    if state.lit {
        state.radiance.fill(0.0);
        state.lit = false;
    }
    state.beta.fill(1.0);
    let mut depth = 0u32;
    // Solid-angle density of the direction that led here (for MIS); `None`
    // for the sensor's ray and an ideal reflection, which no light sample
    // could have produced.
    let mut bsdf_pdf: Option<f64> = None;
    loop {
        state.rays += 1;
        let Some((hit, primitive)) = prep.nearest_primitive(&ray) else {
            break; // left the booth: open sides return zero
        };
        let prim = &prep.scene.primitives[primitive];
        let front = hit.normal.dot(ray.dir) < 0.0;
        if let Some(emitter) = prim.emitter {
            if front || prep.scene.emitters[emitter].two_sided {
                let at = EmitterHit {
                    primitive,
                    emitter,
                    distance: hit.t,
                    cos_l: hit.normal.dot(ray.dir).abs(),
                    dir: ray.dir,
                    from_sensor: depth == 0,
                };
                add_emission(prep, transport.light_sampler, &at, bsdf_pdf, state);
            }
        }
        if prep.material_black[prim.material] {
            break; // reflects nothing: the path ends
        }
        let bsdf = prep.bsdfs[prim.material];
        if !front && !bsdf.reflects_on_back() {
            break; // RADIANCE m_mirror.c: "back is black"
        }
        let p = ray.origin + ray.dir * hit.t;
        // Two-sided: the normal on the side the ray came from.
        let n = if front { hit.normal } else { -hit.normal };
        let origin = p + n * SPAWN_OFFSET_M;
        let vertex = VertexBsdf::at(bsdf, n, -ray.dir, prep.material(prim.material), &mut state.beta);
        let last_vertex = transport.max_bounces.is_some_and(|m| depth >= m);
        let ctx = LightContext { p, n };
        estimate_direct(
            prep,
            transport.light_sampler,
            &vertex,
            ctx,
            origin,
            last_vertex,
            rng,
            state,
        );
        if last_vertex || !russian_roulette(transport, depth, rng, &mut state.beta) {
            break;
        }
        let (u1, u2) = rng.next_2d();
        let Some((dir, pdf)) = vertex.sample(u1, u2, &mut state.beta) else {
            break;
        };
        ray = Ray { origin, dir };
        bsdf_pdf = pdf;
        depth += 1;
    }
}

/// Le reached by a ray, weighted against the light strategy's density of
/// the same point, p_light = P(light)·p_light(y) (`bsdf_pdf`: the density of
/// the direction that led here; `None` counts it fully), times a
/// spotlight's factor.
#[inline(always)]
fn add_emission(
    prep: &Prepared,
    light_sampler: LightSampling,
    hit: &EmitterHit,
    bsdf_pdf: Option<f64>,
    state: &mut PathState,
) {
    let w = match bsdf_pdf {
        None => 1.0,
        Some(p_bsdf) => power_heuristic(p_bsdf, prep.lights.emission_pdf(light_sampler, hit)),
    } as f32;
    let w = w * prep.lights.le_factor(hit) as f32;
    state.lit = true;
    for ((l, b), le) in state
        .radiance
        .iter_mut()
        .zip(&state.beta)
        .zip(prep.emitter(hit.emitter))
    {
        *l += w * b * le;
    }
}

/// The one direct-light estimate at a vertex, for every material: one
/// sample of one light chosen by the light sampler
/// ([`SceneLights::sample_ld`]), divided by its probability; an area
/// light's sample MIS-weighted against the BSDF's density except at the
/// last vertex, where no bounce could find it; a delta light's unweighted.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn estimate_direct(
    prep: &Prepared,
    light_sampler: LightSampling,
    vertex: &VertexBsdf,
    ctx: LightContext,
    origin: DVec3,
    last_vertex: bool,
    rng: &mut PathSampler,
    state: &mut PathState,
) {
    if let Some(sample) = prep.lights.sample_ld(light_sampler, &ctx, rng) {
        add_light_sample(prep, vertex, &sample, origin, last_vertex, state);
    }
}

/// L += β ⊙ f ⊙ S · scale, when f is not zero toward the light and its
/// shadow ray is unblocked.
#[inline(always)]
fn add_light_sample(
    prep: &Prepared,
    vertex: &VertexBsdf,
    sample: &LiSample,
    origin: DVec3,
    last_vertex: bool,
    state: &mut PathState,
) {
    let Some(f) = vertex.f(sample.wi) else {
        return;
    };
    state.rays += 1;
    if !prep.unoccluded(origin, sample) {
        return;
    }
    let w = match sample.pdf() {
        Some(p_light) if !last_vertex => power_heuristic(p_light, vertex.pdf(sample.wi, sample.cos_i)),
        _ => 1.0,
    };
    let k = sample.scale(f.divisor(), w) as f32;
    state.lit = true;
    vertex.add_light(f, k, &state.beta, prep.spectrum(sample.spectrum), &mut state.radiance);
}

/// The one Russian roulette, for every material: from bounce
/// `russian_roulette_from` on, a path survives with q = the largest channel
/// of β (at least 0.05, at most 1) and β /= q, which keeps it unbiased.
/// False when the path ends.
#[inline(always)]
fn russian_roulette(transport: &Transport, depth: u32, rng: &mut PathSampler, beta: &mut [f32]) -> bool {
    let Some(from) = transport.russian_roulette_from else {
        return true;
    };
    if depth < from {
        return true;
    }
    let q = beta.iter().fold(0.0f32, |m, &b| m.max(b)).clamp(0.05, 1.0);
    if rng.next_1d() >= q as f64 {
        return false;
    }
    let inv = 1.0 / q;
    beta.iter_mut().for_each(|b| *b *= inv);
    true
}

/// Sums of one batch of radiometer samples: Σ radiance per channel, and per
/// coding Σ Y and Σ Y² (for the standard error).
#[derive(Clone, Debug)]
pub struct BatchSums {
    pub channels: Vec<f64>,
    pub y: Vec<f64>,
    pub y2: Vec<f64>,
    /// Σ Y per replicate and coding (`[replicate * codings + k]`): the
    /// standard error of randomised QMC comes from the replicate means.
    pub replicate_y: Vec<f64>,
    pub paths: u64,
    pub rays: u64,
}

impl BatchSums {
    pub fn zero(layout: &ChannelLayout) -> BatchSums {
        let k = layout.entries().len();
        BatchSums {
            channels: vec![0.0; layout.len()],
            y: vec![0.0; k],
            y2: vec![0.0; k],
            replicate_y: vec![0.0; k * REPLICATES],
            paths: 0,
            rays: 0,
        }
    }

    pub fn add(&mut self, other: &BatchSums) {
        for (a, b) in self.channels.iter_mut().zip(&other.channels) {
            *a += b;
        }
        for k in 0..self.y.len() {
            self.y[k] += other.y[k];
            self.y2[k] += other.y2[k];
        }
        for (a, b) in self.replicate_y.iter_mut().zip(&other.replicate_y) {
            *a += b;
        }
        self.paths += other.paths;
        self.rays += other.rays;
    }

    /// Folds one path's radiance in.
    #[inline(always)]
    pub fn add_path(&mut self, layout: &ChannelLayout, radiance: &[f32], lit: bool, replicate: usize) {
        self.paths += 1;
        if !lit {
            return; // a dark path adds zeros
        }
        let codings = self.y.len();
        for (a, &b) in self.channels.iter_mut().zip(radiance) {
            *a += b as f64;
        }
        let w = layout.y_weights();
        for (k, (_, range)) in layout.entries().iter().enumerate() {
            let y = dot_lanes(&radiance[range.clone()], &w[range.clone()]) as f64;
            self.y[k] += y;
            self.y2[k] += y * y;
            self.replicate_y[replicate * codings + k] += y;
        }
    }
}

/// Σ aᵢ·bᵢ in 8 independent lanes (a fixed order, so deterministic), which
/// the compiler vectorises; a plain `.sum()` is one serial chain of adds.
#[inline(always)]
fn dot_lanes(a: &[f32], b: &[f32]) -> f32 {
    let mut acc = [0.0f32; 8];
    let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for l in 0..8 {
            acc[l] += x[l] * y[l];
        }
    }
    let mut tail = 0.0;
    for (x, y) in ra.iter().zip(rb) {
        tail += x * y;
    }
    acc.iter().sum::<f32>() + tail
}

/// Radiometer samples `samples` (a range of sample indices) of one target:
/// each a path from the instrument through a direction uniform in solid
/// angle within its circular field, so the mean is the field's mean radiance.
///
/// On x86-64 CPUs with AVX2 the whole batch loop runs in code compiled for
/// AVX2 (8 f32 lanes instead of SSE's 4); the arithmetic is the same.
pub fn radiometer_batch(
    prep: &Prepared,
    transport: &Transport,
    sampler: SamplerKind,
    target_index: usize,
    seed: u64,
    samples: std::ops::Range<u64>,
) -> BatchSums {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, checked just above.
            return unsafe { radiometer_batch_avx2(prep, transport, sampler, target_index, seed, samples) };
        }
    }
    radiometer_batch_inline(prep, transport, sampler, target_index, seed, samples)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn radiometer_batch_avx2(
    prep: &Prepared,
    transport: &Transport,
    sampler: SamplerKind,
    target_index: usize,
    seed: u64,
    samples: std::ops::Range<u64>,
) -> BatchSums {
    radiometer_batch_inline(prep, transport, sampler, target_index, seed, samples)
}

#[inline(always)]
fn radiometer_batch_inline(
    prep: &Prepared,
    transport: &Transport,
    sampler: SamplerKind,
    target_index: usize,
    seed: u64,
    samples: std::ops::Range<u64>,
) -> BatchSums {
    let scene = prep.scene;
    let position = scene.radiometer.position;
    let axis = (scene.target_list[target_index].point - position).normalize();
    let half_angle = scene.radiometer.field_deg.to_radians() / 2.0;
    let mut state = PathState::new(&prep.layout);
    let mut sums = BatchSums::zero(&prep.layout);
    for i in samples {
        let mut rng = PathSampler::new(sampler, seed, target_index as u64, i);
        let (u1, u2) = rng.next_2d();
        let dir = cone_direction(axis, half_angle, u1, u2);
        trace_path(prep, transport, Ray { origin: position, dir }, &mut rng, &mut state);
        sums.add_path(
            &prep.layout,
            &state.radiance,
            state.lit,
            (i % REPLICATES as u64) as usize,
        );
    }
    sums.rays += state.rays;
    sums
}
