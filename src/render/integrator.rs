//! Monte Carlo path tracing with next-event estimation, carrying every
//! coding's channels at once.
//!
//! The estimator, for a path x₀ (first hit), x₁, … and Lambertian BRDFs
//! f = ρ/π:
//!
//! - at each vertex xⱼ, the point lights are sampled exactly (next-event
//!   estimation): a point light has no area, so its contribution is the
//!   deterministic L = β ⊙ ρ/π ⊙ I(ω)·cos θᵢ / d², with I(ω) the luminaire's
//!   spectral intensity in W/(sr·nm) toward xⱼ and an unoccluded shadow ray;
//! - area lights (emitting triangles) are reached by two strategies, combined
//!   by multiple importance sampling (Veach & Guibas 1995, power heuristic):
//!   at each vertex one point y is chosen on the lights ([`super::area_light`],
//!   density p_light in solid angle) and adds β ⊙ ρ/π ⊙ Le·cos θᵢ / p_light ·
//!   w_light; a bounce direction that hits an emitter adds β ⊙ Le · w_bsdf,
//!   with w = p²/(p_light² + p_bsdf²). The sensor's own ray has no BSDF
//!   density, so an emitter it sees directly counts fully; at the last
//!   vertex (no bounce follows) the light sample counts fully. A RADIANCE
//!   `spotlight`'s Le is Le·s(ω, d) in both strategies alike
//!   ([`super::scene::Spot`]: 0 outside its cone, d²/(d + flen)² inside, 1
//!   for the sensor's own ray), so the weights and densities are unchanged
//!   and the estimate stays unbiased (the bounce's d is measured from the
//!   offset ray origin, `SPAWN_OFFSET_M` from the point the light sample
//!   uses: a relative difference below 1e-6 at the booth's distances);
//! - the next direction is sampled cosine-weighted, pdf = cos θ / π, so the
//!   throughput update f·cos θ / pdf is exactly ρ (per channel);
//! - on a `plastic`, `metal` or `mirror` surface ([`super::bsdf`]) f is
//!   RADIANCE's model instead, a·ρ + b per channel (scalars a, b per
//!   direction pair), in every term above: next-event estimation uses f,
//!   the bounce samples the Ward lobe or the cosine (their mixture density
//!   is p_bsdf for MIS), and an ideal reflection (mirror, polished
//!   plastic) is a delta: the emitter it sees counts fully, as for the
//!   sensor's ray. Lambertian vertices keep the code above unchanged;
//! - paths end by unbiased Russian roulette (survival q = max channel of the
//!   throughput, at least 0.05, with β /= q) from the bounce the settings
//!   ask for (by default the third), or when they leave the scene (open
//!   sides return zero radiance), or — only when a cap is asked for — after
//!   `max_bounces` indirect bounces (RADIANCE `-ab`: a truncation bias).
//!
//! The channel arithmetic works on contiguous `f32` slices whose length is a
//! multiple of 8, which the compiler vectorises; nothing is allocated per ray.
//!
//! A render can be stopped between batches of paths: [`with_cancel`] gives
//! every render started on the calling thread a [`CancelFlag`] (the daemon's
//! jobs do; the command line's renders have none and always finish).

use std::cell::RefCell;
use std::f64::consts::PI;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use glam::DVec3;

use super::area_light::{power_heuristic, AreaLights};
use super::bsdf::Bsdf;
use super::bvh::{Bvh, LINEAR_SCAN_BELOW};
use super::coding::ChannelLayout;
use super::geometry::Ray;
use super::sampling::{cone_direction, cosine_direction, PathSampler, SamplerKind, REPLICATES};
use super::scene::{Light, Scene};

/// Asks the renders of one job to stop: checked before each batch of
/// [`BATCH_SAMPLES`](super::sampling::BATCH_SAMPLES) paths, so a cancelled render stops within one batch per
/// worker thread.
#[derive(Clone, Debug, Default)]
pub struct CancelFlag(Arc<AtomicBool>);

impl CancelFlag {
    pub fn cancel(&self) {
        self.0.store(true, Ordering::SeqCst);
    }

    pub fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }
}

thread_local! {
    static CANCEL: RefCell<Option<CancelFlag>> = const { RefCell::new(None) };
}

/// Runs `f` with `flag` as the cancellation of every render `f` starts on
/// this thread (a thread-local, so the study's many renders need no extra
/// argument each); the previous flag is restored afterwards, even on panic.
pub fn with_cancel<R>(flag: &CancelFlag, f: impl FnOnce() -> R) -> R {
    struct Restore(Option<CancelFlag>);
    impl Drop for Restore {
        fn drop(&mut self) {
            let previous = self.0.take();
            CANCEL.with(|c| *c.borrow_mut() = previous);
        }
    }
    let _restore = Restore(CANCEL.with(|c| c.borrow_mut().replace(flag.clone())));
    f()
}

/// The cancellation flag of renders started on this thread, if any.
pub fn current_cancel() -> Option<CancelFlag> {
    CANCEL.with(|c| c.borrow().clone())
}

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
}

/// A point sampled on the area lights, as seen from a surface point.
struct AreaLightPoint {
    point: DVec3,
    /// Unit direction from the surface point to `point`.
    wi: DVec3,
    /// Cosine between the surface normal and `wi` (> 0).
    cos_i: f64,
    /// The sample's density in solid angle at the surface point, 1/sr.
    p_light: f64,
    emitter: usize,
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
    /// The emitting triangles, for next-event estimation.
    area_lights: AreaLights,
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
        let ybar = &crate::colorimetry::Cmf::of(super::coding::OBSERVER).on_grid(&crate::spectrum::Grid::one_nm())[1];
        let ybar_sum: f64 = ybar.iter().sum();
        let mut bsdfs = Vec::with_capacity(scene.materials.len());
        for m in &scene.materials {
            // The luminous reflectance (equal-energy white) sets only the
            // lobe's sampling probability, the same for every coding.
            let rho = m
                .reflectance
                .resample(&crate::spectrum::Grid::one_nm())
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
            area_lights: AreaLights::new(scene)?,
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

    /// A point on the area lights for next-event estimation from the
    /// surface point `p` (normal `n`), chosen by (u1, u2); `None` when the
    /// surface faces away from it or it faces away from the surface.
    /// Distances and cosines are taken from `p` itself, not from the offset
    /// ray origin.
    #[inline]
    fn sample_area_light(&self, p: DVec3, n: DVec3, u1: f64, u2: f64) -> Option<AreaLightPoint> {
        let s = self.area_lights.sample(u1, u2);
        let to_light = s.point - p;
        let d2 = to_light.length_squared();
        let wi = to_light / d2.sqrt();
        let cos_i = n.dot(wi);
        let cos_l_signed = -wi.dot(s.normal);
        let cos_l = if s.two_sided { cos_l_signed.abs() } else { cos_l_signed };
        (cos_i > 0.0 && cos_l > 0.0).then(|| AreaLightPoint {
            point: s.point,
            wi,
            cos_i,
            p_light: s.pdf_area * d2 / cos_l,
            emitter: s.emitter,
        })
    }

    /// A sampled light point's spotlight factor (`Spot::factor`) towards the
    /// surface point `p`; 1 for emitters that are not spotlights.
    #[inline]
    fn spot_factor(&self, ls: &AreaLightPoint, p: DVec3) -> f64 {
        match &self.scene.emitters[ls.emitter].spot {
            None => 1.0,
            Some(spot) => spot.factor(-ls.wi, Some(ls.point.distance(p))),
        }
    }

    /// True when nothing blocks the segment from the offset ray origin to a
    /// point on a light, stopping just short of the light's own surface.
    #[inline]
    fn light_point_visible(&self, origin: DVec3, point: DVec3) -> bool {
        let to_point = point - origin;
        let reach = to_point.length();
        let shadow = Ray {
            origin,
            dir: to_point / reach,
        };
        !self.occluded(&shadow, reach * (1.0 - 1e-9) - 1e-9)
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
    let lights: &[Light] = &prep.scene.lights;
    let mut depth = 0u32;
    // Solid-angle density of the direction that led here (for MIS); `None`
    // for the sensor's ray, which no light sample could have produced.
    let mut bsdf_pdf: Option<f64> = None;
    loop {
        state.rays += 1;
        let Some((hit, primitive)) = prep.nearest_primitive(&ray) else {
            break; // left the booth: open sides return zero
        };
        let prim = &prep.scene.primitives[primitive];
        let front = hit.normal.dot(ray.dir) < 0.0;
        if let Some(e) = prim.emitter {
            if front || prep.scene.emitters[e].two_sided {
                // Le reached by the bounce direction, weighted against the
                // light strategy's density of the same point.
                let w = match bsdf_pdf {
                    None => 1.0,
                    Some(p_bsdf) => {
                        let cos_l = hit.normal.dot(ray.dir).abs();
                        let p_light = prep.area_lights.pdf_area_of_primitive(primitive) * hit.t * hit.t / cos_l;
                        power_heuristic(p_bsdf, p_light)
                    }
                } as f32;
                // A spotlight's cone and focal falloff (`Spot`): the sensor's
                // own ray (depth 0) sees the lamp's radiance, a surface the
                // radiance scaled by d²/(d + flen)².
                let w = match &prep.scene.emitters[e].spot {
                    None => w,
                    Some(spot) => w * spot.factor(-ray.dir, (depth > 0).then_some(hit.t)) as f32,
                };
                state.lit = true;
                for ((l, b), le) in state.radiance.iter_mut().zip(&state.beta).zip(prep.emitter(e)) {
                    *l += w * b * le;
                }
            }
        }
        if prep.material_black[prim.material] {
            break; // reflects nothing: the path ends
        }
        let p = ray.origin + ray.dir * hit.t;
        // Two-sided: the normal on the side the ray came from.
        let n = if front { hit.normal } else { -hit.normal };
        let origin = p + n * SPAWN_OFFSET_M;
        let bsdf = prep.bsdfs[prim.material];
        if !matches!(bsdf, Bsdf::Lambertian) {
            let wo = -ray.dir;
            match glossy_vertex(prep, transport, bsdf, prim.material, front, p, n, wo, depth, rng, state) {
                Some((dir, pdf)) => {
                    ray = Ray { origin, dir };
                    bsdf_pdf = pdf;
                    depth += 1;
                    continue;
                }
                None => break,
            }
        }
        // β ← β ⊙ ρ: the throughput after this reflection (f·cos/pdf = ρ).
        let rho = prep.material(prim.material);
        for (b, r) in state.beta.iter_mut().zip(rho) {
            *b *= r;
        }
        for (li, light) in lights.iter().enumerate() {
            let to_light = light.position - p;
            let d2 = to_light.length_squared();
            let d = d2.sqrt();
            let wi = to_light / d;
            let cos_i = n.dot(wi);
            if cos_i <= 0.0 {
                continue;
            }
            let cd = light.candela_toward(-wi);
            if cd <= 0.0 {
                continue;
            }
            state.rays += 1;
            if prep.occluded(&Ray { origin, dir: wi }, d) {
                continue;
            }
            // L += β ⊙ (ρ/π) ⊙ I_cd·S(λ) · cos θᵢ / d²  (ρ already in β).
            let s = (cd * cos_i / (PI * d2)) as f32;
            let spd = prep.light(li);
            state.lit = true;
            for ((l, b), e) in state.radiance.iter_mut().zip(&state.beta).zip(spd) {
                *l += s * b * e;
            }
        }
        let last_vertex = transport.max_bounces.is_some_and(|m| depth >= m);
        if !prep.area_lights.is_empty() {
            let (u1, u2) = rng.next_2d();
            if let Some(ls) = prep.sample_area_light(p, n, u1, u2) {
                state.rays += 1;
                if prep.light_point_visible(origin, ls.point) {
                    let w = if last_vertex {
                        1.0
                    } else {
                        power_heuristic(ls.p_light, ls.cos_i / PI)
                    };
                    // L += β ⊙ (ρ/π) ⊙ Le · cos θᵢ / p_light · w  (ρ already in β).
                    let k = (ls.cos_i / (PI * ls.p_light) * w * prep.spot_factor(&ls, p)) as f32;
                    state.lit = true;
                    for ((l, b), le) in state.radiance.iter_mut().zip(&state.beta).zip(prep.emitter(ls.emitter)) {
                        *l += k * b * le;
                    }
                }
            }
        }
        if last_vertex {
            break;
        }
        if let Some(from) = transport.russian_roulette_from {
            if depth >= from {
                let q = state.beta.iter().fold(0.0f32, |m, &b| m.max(b)).clamp(0.05, 1.0);
                if rng.next_1d() >= q as f64 {
                    break;
                }
                let inv = 1.0 / q;
                state.beta.iter_mut().for_each(|b| *b *= inv);
            }
        }
        let (u1, u2) = rng.next_2d();
        let dir = cosine_direction(n, u1, u2);
        bsdf_pdf = Some(n.dot(dir).max(0.0) / PI);
        ray = Ray { origin, dir };
        depth += 1;
    }
}

/// One vertex on a surface that is not Lambertian (RADIANCE `plastic`,
/// `metal`, `mirror`; [`super::bsdf`]): next-event estimation with the
/// BSDF's value f = a·ρ + b per channel (point lights exactly; area lights
/// MIS-weighted against the BSDF's sampling density), then a sampled
/// bounce. The same random numbers as a Lambertian vertex: one 2D point for
/// the light sample, the roulette's number, one 2D point for the bounce.
/// Returns the next direction and its density (`None` for an ideal
/// reflection), or `None` when the path ends.
#[allow(clippy::too_many_arguments)]
#[inline]
fn glossy_vertex(
    prep: &Prepared,
    transport: &Transport,
    bsdf: Bsdf,
    material: usize,
    front: bool,
    p: DVec3,
    n: DVec3,
    wo: DVec3,
    depth: u32,
    rng: &mut PathSampler,
    state: &mut PathState,
) -> Option<(DVec3, Option<f64>)> {
    if matches!(bsdf, Bsdf::Mirror) && !front {
        return None; // RADIANCE m_mirror.c: "back is black"
    }
    let origin = p + n * SPAWN_OFFSET_M;
    let rho = prep.material(material);
    let last_vertex = transport.max_bounces.is_some_and(|m| depth >= m);
    for (li, light) in prep.scene.lights.iter().enumerate() {
        let to_light = light.position - p;
        let d2 = to_light.length_squared();
        let d = d2.sqrt();
        let wi = to_light / d;
        let cos_i = n.dot(wi);
        if cos_i <= 0.0 {
            continue;
        }
        let f = bsdf.eval(n, wo, wi);
        if f.is_zero() {
            continue;
        }
        let cd = light.candela_toward(-wi);
        if cd <= 0.0 {
            continue;
        }
        state.rays += 1;
        if prep.occluded(&Ray { origin, dir: wi }, d) {
            continue;
        }
        // L += β ⊙ f ⊙ I_cd·S(λ) · cos θᵢ / d², f = a·ρ + b.
        let s = (cd * cos_i / d2) as f32;
        let (a, b) = (f.a as f32, f.b as f32);
        state.lit = true;
        for (((l, bt), e), r) in state.radiance.iter_mut().zip(&state.beta).zip(prep.light(li)).zip(rho) {
            *l += s * bt * (a * r + b) * e;
        }
    }
    if !prep.area_lights.is_empty() {
        let (u1, u2) = rng.next_2d();
        if let Some(ls) = prep.sample_area_light(p, n, u1, u2) {
            let f = bsdf.eval(n, wo, ls.wi);
            if !f.is_zero() {
                state.rays += 1;
                if prep.light_point_visible(origin, ls.point) {
                    let w = if last_vertex {
                        1.0
                    } else {
                        power_heuristic(ls.p_light, bsdf.pdf(n, wo, ls.wi))
                    };
                    // L += β ⊙ f ⊙ Le · cos θᵢ / p_light · w.
                    let k = (ls.cos_i / ls.p_light * w * prep.spot_factor(&ls, p)) as f32;
                    let (a, b) = (f.a as f32, f.b as f32);
                    state.lit = true;
                    for (((l, bt), le), r) in state
                        .radiance
                        .iter_mut()
                        .zip(&state.beta)
                        .zip(prep.emitter(ls.emitter))
                        .zip(rho)
                    {
                        *l += k * bt * (a * r + b) * le;
                    }
                }
            }
        }
    }
    if last_vertex {
        return None;
    }
    if let Some(from) = transport.russian_roulette_from {
        if depth >= from {
            let q = state.beta.iter().fold(0.0f32, |m, &b| m.max(b)).clamp(0.05, 1.0);
            if rng.next_1d() >= q as f64 {
                return None;
            }
            let inv = 1.0 / q;
            state.beta.iter_mut().for_each(|b| *b *= inv);
        }
    }
    let (u1, u2) = rng.next_2d();
    let sample = bsdf.sample(n, wo, u1, u2)?;
    // β ← β ⊙ (a·ρ + b): f·cos θᵢ/pdf of the sampled direction.
    let (a, b) = (sample.weight.a as f32, sample.weight.b as f32);
    for (bt, r) in state.beta.iter_mut().zip(rho) {
        *bt *= a * r + b;
    }
    Some((sample.dir, sample.pdf))
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
