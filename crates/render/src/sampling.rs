//! The random numbers of the renderer's Monte Carlo estimates, and the
//! warps that turn them into directions: PCG32 streams (one per sample, so
//! results do not depend on how samples are split over threads),
//! shuffled Owen-scrambled Sobol points ([`SamplerKind::Sobol`], the
//! default) and the cosine and cone warps.
//!
//! Written here, not taken from a crate: each sample needs its own
//! reproducible stream, and the first two decisions Burley's hash-based
//! nested Owen scrambling with 4D padding, all without allocating per
//! path. The tests pin the reference sequences (PCG32's demo output, Joe &
//! Kuo's direction numbers) and the stratification.

use std::f64::consts::PI;

use glam::DVec3;

use super::geometry::basis;
use lightbooth_science::random::splitmix64;

/// PCG32 (O'Neill 2014, `pcg32_random_r`): a small, fast, statistically
/// good generator with 2⁶³ selectable streams. Each Monte Carlo sample gets
/// its own stream, so results do not depend on how samples are split over
/// threads.
#[derive(Clone, Debug)]
pub struct Pcg32 {
    state: u64,
    inc: u64,
}

impl Pcg32 {
    pub fn new(seed: u64, stream: u64) -> Pcg32 {
        let mut r = Pcg32 {
            state: 0,
            inc: (stream << 1) | 1,
        };
        r.next_u32();
        r.state = r.state.wrapping_add(seed);
        r.next_u32();
        r
    }

    /// The generator of sample `sample` of target `target` under `seed`:
    /// the initial state is a hash of all three, on one fixed stream.
    ///
    /// Not one stream per sample with a shared state (as before): PCG
    /// streams that start from the same state differ by a fixed additive
    /// offset at every step, so the samples' n-th numbers formed an
    /// arithmetic progression mod 2⁶⁴ — a rank-1 lattice, not independent
    /// draws — and standard errors computed as if they were independent
    /// were wrong by up to 2× (pinned by
    /// `tests/render/render_standard_errors.rs`).
    pub fn for_sample(seed: u64, target: u64, sample: u64) -> Pcg32 {
        let state = splitmix64(splitmix64(seed ^ splitmix64(target.wrapping_add(0x9e37_79b9))) ^ sample);
        Pcg32::new(state, 0x5851_f42d_4c95_7f2d)
    }

    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        xorshifted.rotate_right((old >> 59) as u32)
    }

    /// Uniform in [0, 1).
    #[inline]
    pub fn uniform(&mut self) -> f64 {
        self.next_u32() as f64 * (1.0 / 4_294_967_296.0)
    }
}

/// How a path draws its random numbers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SamplerKind {
    /// Randomised quasi-Monte Carlo with shuffled, Owen-scrambled Sobol
    /// points (Burley 2020, "Practical hash-based Owen scrambling", JCGT
    /// 9(4)): the field direction and the first bounce are dimensions 0–3 of
    /// one 4D point (their interaction decides the lower CYLINDER points);
    /// later bounces take padded (independently scrambled) 2D points, and
    /// after 8 decisions PCG32. Sample i belongs to replicate i mod [`REPLICATES`], and
    /// each replicate is an independent randomisation of the whole sequence,
    /// so the replicate means are i.i.d. and the standard error comes from
    /// them (R = 16 replicates: 15 degrees of freedom).
    #[default]
    Sobol,
    /// Independent PCG32 numbers; the standard error comes from the paths.
    Independent,
}

/// Samples per batch: the unit of parallel work and of deterministic
/// summation; a multiple of [`REPLICATES`], so each batch adds the same
/// number of points to every replicate.
pub const BATCH_SAMPLES: u64 = 1024;

/// Independent randomisations of the Sobol sequence per target.
pub const REPLICATES: usize = 16;

/// 2D decisions per path drawn from the Sobol sequence; later ones use PCG32.
const SOBOL_PAIRS: u32 = 8;

/// The random numbers of one path.
pub struct PathSampler {
    kind: SamplerKind,
    pcg: Pcg32,
    /// Index of this path within its replicate.
    index: u32,
    /// Seed of the replicate's randomisation.
    batch_seed: u32,
    pair: u32,
}

impl PathSampler {
    /// The sampler of sample `sample` of stream `stream` (a target or a pixel).
    pub fn new(kind: SamplerKind, seed: u64, stream: u64, sample: u64) -> PathSampler {
        let replicate = sample % REPLICATES as u64;
        PathSampler {
            kind,
            pcg: Pcg32::for_sample(seed, stream, sample),
            index: (sample / REPLICATES as u64) as u32,
            batch_seed: splitmix64(splitmix64(seed ^ splitmix64(stream)) ^ replicate) as u32,
            pair: 0,
        }
    }

    /// A uniform number in [0, 1).
    #[inline]
    pub fn next_1d(&mut self) -> f64 {
        self.pcg.uniform()
    }

    /// A uniform point in [0, 1)².
    #[inline]
    pub fn next_2d(&mut self) -> (f64, f64) {
        if self.kind == SamplerKind::Independent || self.pair >= SOBOL_PAIRS {
            return (self.pcg.uniform(), self.pcg.uniform());
        }
        // Decisions 0 and 1 (the field direction and the first bounce) are
        // dimensions 0–3 of one 4D Sobol point, so their interaction is
        // stratified too; later decisions are padded 2D points.
        let (group, dims) = if self.pair < 2 {
            (0, [2 * self.pair as usize, 2 * self.pair as usize + 1])
        } else {
            (self.pair, [0, 1])
        };
        let seed = hash_u32(self.batch_seed ^ group.wrapping_mul(0x9e37_79b9));
        let dim_seed = hash_u32(seed ^ self.pair.wrapping_mul(0x68bc_21eb));
        self.pair += 1;
        let i = nested_uniform_scramble(self.index, seed);
        let x = nested_uniform_scramble(sobol(i, dims[0]), hash_u32(dim_seed ^ 0x02e5_be93));
        let y = nested_uniform_scramble(sobol(i, dims[1]), hash_u32(dim_seed ^ 0x9670_c4f7));
        const SCALE: f64 = 1.0 / 4_294_967_296.0;
        (x as f64 * SCALE, y as f64 * SCALE)
    }
}

/// Direction numbers of the first four Sobol dimensions (Joe & Kuo 2008,
/// `new-joe-kuo-6.21201`: dimension 2 has s = 1, a = 0, m = 1; dimension 3
/// s = 2, a = 1, m = 1 3; dimension 4 s = 3, a = 1, m = 1 3 1; the first is
/// the van der Corput sequence), as 32-bit fractions vₖ = mₖ·2³²⁻ᵏ.
const SOBOL_V: [[u32; 32]; 4] = sobol_directions();

const fn sobol_directions() -> [[u32; 32]; 4] {
    // (s, a, initial m) per dimension after the first.
    let params: [(usize, u32, [u32; 3]); 3] = [(1, 0, [1, 0, 0]), (2, 1, [1, 3, 0]), (3, 1, [1, 3, 1])];
    let mut v = [[0u32; 32]; 4];
    let mut k = 0;
    while k < 32 {
        v[0][k] = 1 << (31 - k);
        k += 1;
    }
    let mut d = 0;
    while d < 3 {
        let (s, a, m0) = params[d];
        let mut m = [0u32; 32];
        let mut k = 0;
        while k < 32 {
            if k < s {
                m[k] = m0[k];
            } else {
                // mₖ = 2a₁mₖ₋₁ ⊕ 2²a₂mₖ₋₂ ⊕ … ⊕ 2ˢmₖ₋ₛ ⊕ mₖ₋ₛ (Bratley & Fox 1988).
                let mut x = (m[k - s] << s) ^ m[k - s];
                let mut j = 1;
                while j < s {
                    let a_j = (a >> (s - 1 - j)) & 1;
                    if a_j == 1 {
                        x ^= m[k - j] << j;
                    }
                    j += 1;
                }
                m[k] = x;
            }
            v[d + 1][k] = m[k] << (31 - k);
            k += 1;
        }
        d += 1;
    }
    v
}

/// Per dimension and index byte, the XOR of the direction numbers selected by
/// each byte value: Sobol point i is four table look-ups instead of a loop
/// over its 32 bits (the shuffled indices use all 32). 16 KiB, fits L1.
static SOBOL_BYTES: [[[u32; 256]; 4]; 4] = sobol_byte_tables();

const fn sobol_byte_tables() -> [[[u32; 256]; 4]; 4] {
    let mut t = [[[0u32; 256]; 4]; 4];
    let mut d = 0;
    while d < 4 {
        let mut byte = 0;
        while byte < 4 {
            let mut value = 0;
            while value < 256 {
                let mut x = 0u32;
                let mut bit = 0;
                while bit < 8 {
                    if (value >> bit) & 1 == 1 {
                        x ^= SOBOL_V[d][8 * byte + bit];
                    }
                    bit += 1;
                }
                t[d][byte][value] = x;
                value += 1;
            }
            byte += 1;
        }
        d += 1;
    }
    t
}

/// Dimension `dim` (0–3) of Sobol point `i`, as a 32-bit fraction.
#[inline]
fn sobol(i: u32, dim: usize) -> u32 {
    let t = &SOBOL_BYTES[dim];
    t[0][(i & 0xff) as usize]
        ^ t[1][((i >> 8) & 0xff) as usize]
        ^ t[2][((i >> 16) & 0xff) as usize]
        ^ t[3][(i >> 24) as usize]
}

/// The same by the definition (a loop over the bits), for testing the tables.
#[cfg(test)]
fn sobol_by_bits(mut i: u32, dim: usize) -> u32 {
    let v = &SOBOL_V[dim];
    let mut r = 0;
    let mut k = 0;
    while i != 0 {
        if i & 1 != 0 {
            r ^= v[k];
        }
        i >>= 1;
        k += 1;
    }
    r
}

/// Laine–Karras permutation with Burley's constants: bit k of the result
/// depends only on bits ≤ k of the input.
#[inline]
fn laine_karras(mut x: u32, seed: u32) -> u32 {
    x = x.wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50_b47c);
    x ^= x.wrapping_mul(0xb82f_1e52);
    x ^= x.wrapping_mul(0xc7af_e638);
    x ^= x.wrapping_mul(0x8d22_f6e6);
    x
}

/// Owen scrambling of a 32-bit binary fraction (most significant digit first).
#[inline]
fn nested_uniform_scramble(x: u32, seed: u32) -> u32 {
    laine_karras(x.reverse_bits(), seed).reverse_bits()
}

#[inline]
fn hash_u32(x: u32) -> u32 {
    splitmix64(x as u64) as u32
}

/// A direction around the unit `n` with pdf cos θ / π (Malley's method).
#[inline]
pub fn cosine_direction(n: DVec3, u1: f64, u2: f64) -> DVec3 {
    let r = u1.sqrt();
    let phi = 2.0 * PI * u2;
    let (t, b) = basis(n);
    let z = (1.0 - u1).max(0.0).sqrt();
    t * (r * phi.cos()) + b * (r * phi.sin()) + n * z
}

/// A direction uniform in solid angle within the cone of half-angle
/// `half_angle_rad` around the unit `axis`.
#[inline]
pub fn cone_direction(axis: DVec3, half_angle_rad: f64, u1: f64, u2: f64) -> DVec3 {
    let cos_max = half_angle_rad.cos();
    let cos_t = 1.0 - u1 * (1.0 - cos_max);
    let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
    let phi = 2.0 * PI * u2;
    let (t, b) = basis(axis);
    t * (sin_t * phi.cos()) + b * (sin_t * phi.sin()) + axis * cos_t
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pcg32_matches_the_reference_sequence() {
        // pcg32-global-demo: pcg32_srandom(42, 54) → 0xa15c02b7 0x7b47f409 0xba1d3330.
        let mut r = Pcg32::new(42, 54);
        assert_eq!(
            [r.next_u32(), r.next_u32(), r.next_u32()],
            [0xa15c02b7, 0x7b47f409, 0xba1d3330]
        );
    }

    /// The first 1024 points of a replicate of the scrambled Sobol sequence:
    /// dimensions 0–1 (the field) and padded later pairs are (0, 10, 2)-nets
    /// (each of the 32 × 32 elementary cells holds one point); dimensions
    /// 2–3 (the first bounce) are not (t > 0 there), but each coordinate is
    /// stratified into 1024 intervals.
    #[test]
    fn sobol_replicates_are_stratified() {
        for pair in 0..3 {
            let mut seen = vec![false; 1024];
            let mut seen_y = vec![false; 1024];
            for j in 0..1024 {
                let i = 5 + REPLICATES as u64 * j;
                let mut s = PathSampler::new(SamplerKind::Sobol, 7, 3, i);
                for _ in 0..pair {
                    s.next_2d();
                }
                let (x, y) = s.next_2d();
                if pair == 1 {
                    let (bx, by) = ((x * 1024.0) as usize, (y * 1024.0) as usize);
                    assert!(!seen[bx] && !seen_y[by], "pair 1: bin {bx} or {by} twice");
                    seen[bx] = true;
                    seen_y[by] = true;
                    continue;
                }
                let cell = (x * 32.0) as usize * 32 + (y * 32.0) as usize;
                assert!(!seen[cell], "pair {pair}: two points in cell {cell}");
                seen[cell] = true;
            }
        }
    }

    /// The direction numbers reproduce the known sequences: dimension 2's
    /// vₖ = vₖ₋₁ ⊕ (vₖ₋₁ >> 1), and dimension 3's first points in natural
    /// (not Gray-code) order, from v = 1/2, 3/4, 3/8.
    #[test]
    fn sobol_direction_numbers_match_the_tables() {
        let mut v = 1u32 << 31;
        for vk in SOBOL_V[1] {
            assert_eq!(vk, v);
            v ^= v >> 1;
        }
        let pts: Vec<f64> = (0..8).map(|i| sobol(i, 2) as f64 / 4_294_967_296.0).collect();
        assert_eq!(pts, vec![0.0, 0.5, 0.75, 0.25, 0.375, 0.875, 0.625, 0.125]);
        let mut r = Pcg32::new(9, 9);
        for _ in 0..10_000 {
            let i = r.next_u32();
            for d in 0..4 {
                assert_eq!(sobol(i, d), sobol_by_bits(i, d));
            }
        }
        assert_eq!(sobol(0x1234_5678, 0), 0x1234_5678u32.reverse_bits());
        // Every 1D projection of 1024 points is stratified into 1024 bins.
        for d in 0..4 {
            let mut seen = vec![false; 1024];
            for i in 0..1024 {
                let b = (sobol(i, d) >> 22) as usize;
                assert!(!seen[b], "dim {d}");
                seen[b] = true;
            }
        }
    }

    #[test]
    fn sampled_directions_are_unit_and_inside_their_domain() {
        let mut r = Pcg32::new(1, 2);
        let n = DVec3::new(0.0, 0.6, 0.8);
        let mut mean_cos = 0.0;
        for _ in 0..20_000 {
            let d = cosine_direction(n, r.uniform(), r.uniform());
            assert!((d.length() - 1.0).abs() < 1e-12 && d.dot(n) >= 0.0);
            mean_cos += d.dot(n);
            let c = cone_direction(n, 0.5f64.to_radians(), r.uniform(), r.uniform());
            assert!(c.dot(n) >= 0.5f64.to_radians().cos() - 1e-12);
        }
        // E[cos θ] under pdf cos θ/π is 2/3; the sample mean's SE is about 0.0017.
        assert!(
            (mean_cos / 20_000.0 - 2.0 / 3.0).abs() < 4.0 * 0.0017,
            "{}",
            mean_cos / 20_000.0
        );
    }
}
