//! Seeded random numbers specified to the bit, for what must give the same
//! numbers from the same seed in every version: SplitMix64 (Steele, Lea &
//! Flood 2014, "Fast splittable pseudorandom number generators", OOPSLA),
//! its output function as a hash that decorrelates nearby seeds (the
//! renderer's `lightbooth::render::sampling` seeds its streams with it) and as
//! a stream (the trial order of an experiment, [`crate::psychophysics`]).
//! `rand`'s `StdRng` says its algorithm may change between releases, which
//! a stored seed cannot allow; SplitMix64 is a few lines, pinned below to
//! its published reference output.

/// The increment of SplitMix64's state: 2⁶⁴ divided by the golden ratio.
const GOLDEN_GAMMA: u64 = 0x9E37_79B9_7F4A_7C15;

/// SplitMix64's output for state `z` (its finaliser): decorrelates nearby seeds.
pub fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(GOLDEN_GAMMA);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// SplitMix64: a 64-bit state advanced by the golden-ratio increment, and
/// a mix of it as the output (Steele, Lea & Flood 2014, figure 16).
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    pub fn next_u64(&mut self) -> u64 {
        let out = splitmix64(self.0);
        self.0 = self.0.wrapping_add(GOLDEN_GAMMA);
        out
    }

    /// Uniform in [0, 1), from the top 53 bits.
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in 0..n without modulo bias (Lemire's multiply-and-reject).
    pub fn below(&mut self, n: u64) -> u64 {
        debug_assert!(n > 0);
        let threshold = n.wrapping_neg() % n;
        loop {
            let m = u128::from(self.next_u64()) * u128::from(n);
            if (m as u64) >= threshold {
                return (m >> 64) as u64;
            }
        }
    }

    /// A standard normal deviate (Box–Muller, one of the pair).
    pub fn normal(&mut self) -> f64 {
        let (u, v) = (self.uniform(), self.uniform());
        (-2.0 * (1.0 - u).ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }

    /// Uniform in [−half_width, +half_width): the rectangular distribution
    /// GUM 4.3.7 assigns to a quantity known only to lie within ±half_width.
    pub fn rectangular(&mut self, half_width: f64) -> f64 {
        half_width * (2.0 * self.uniform() - 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The published first outputs of SplitMix64 from state 0 (Vigna's
    /// reference `splitmix64.c`, the values xoshiro's seeding starts from).
    #[test]
    fn splitmix64_gives_the_reference_stream() {
        let mut rng = SplitMix64(0);
        let first: Vec<u64> = (0..4).map(|_| rng.next_u64()).collect();
        assert_eq!(
            first,
            [
                0xE220_A839_7B1D_CDAF,
                0x6E78_9E6A_A1B9_65F4,
                0x06C4_5D18_8009_454F,
                0xF88B_B8A8_724C_81EC
            ]
        );
    }
}
