//! The trials of one block of the study's oddity experiment, in order.
//!
//! Ruppertsberg & Bloj (2006, section 4.B) showed the original colour O and
//! an approximation N in the six configurations of three pie pieces with
//! one odd piece, ⟨O,O,N⟩ ⟨O,N,O⟩ ⟨N,O,O⟩ ⟨N,N,O⟩ ⟨N,O,N⟩ ⟨O,N,N⟩, each six
//! times: 36 trials per observer and condition, in random order.
//!
//! The order comes from a seed that is stored with the experiment, so a
//! session can be resumed and re-analysed trial by trial years later. That
//! needs a generator whose output for a seed never changes: `rand`'s
//! `StdRng` says its algorithm may change between releases, so the order
//! is drawn here with SplitMix64 (Steele, Lea & Flood 2014, "Fast splittable
//! pseudorandom number generators", OOPSLA), five lines specified to the
//! bit, and a Fisher–Yates shuffle. A test pins its reference output.

use std::fmt;

/// Which of the two colours a pie piece shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum Stimulus {
    /// O: the original (a measurement, or the converged rendering).
    Original,
    /// N: the approximation under test.
    Approximation,
}

/// The three pieces of one trial, in screen order (left, top, right).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub struct Configuration(pub [Stimulus; 3]);

use Stimulus::{Approximation as N, Original as O};

/// The study's six configurations, in its order.
pub const CONFIGURATIONS: [Configuration; 6] = [
    Configuration([O, O, N]),
    Configuration([O, N, O]),
    Configuration([N, O, O]),
    Configuration([N, N, O]),
    Configuration([N, O, N]),
    Configuration([O, N, N]),
];

impl Configuration {
    /// The position (0 left, 1 top, 2 right) of the piece unlike the other two.
    pub fn odd_position(self) -> usize {
        let [a, b, c] = self.0;
        if a == b {
            2
        } else if a == c {
            1
        } else {
            0
        }
    }
}

impl fmt::Display for Configuration {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let letter = |s: Stimulus| if s == O { 'O' } else { 'N' };
        let [a, b, c] = self.0;
        write!(f, "⟨{},{},{}⟩", letter(a), letter(b), letter(c))
    }
}

/// More repeats than this per block are refused: a block is shown in one
/// sitting (the study's 6 repeats are 36 trials).
pub const MAX_REPEATS: u32 = 100;

/// The trials of one block: each configuration `repeats` times, shuffled
/// with `seed`.
pub fn block_order(seed: u64, repeats: u32) -> Result<Vec<Configuration>, String> {
    if repeats == 0 || repeats > MAX_REPEATS {
        return Err(format!(
            "repeats = {repeats}: give 1–{MAX_REPEATS} repeats of each configuration per block (the study used 6)"
        ));
    }
    let mut trials: Vec<Configuration> = (0..repeats).flat_map(|_| CONFIGURATIONS).collect();
    let mut rng = SplitMix64(seed);
    // Fisher–Yates, from the end.
    for i in (1..trials.len()).rev() {
        let j = rng.below(i as u64 + 1) as usize;
        trials.swap(i, j);
    }
    Ok(trials)
}

/// SplitMix64: a 64-bit state advanced by the golden-ratio increment, and
/// a mix of it as the output (Steele, Lea & Flood 2014, figure 16).
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
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

    #[test]
    fn each_configuration_has_its_one_odd_piece() {
        let odd: Vec<usize> = CONFIGURATIONS.iter().map(|c| c.odd_position()).collect();
        assert_eq!(odd, [2, 1, 0, 2, 1, 0]);
        assert_eq!(CONFIGURATIONS[3].to_string(), "⟨N,N,O⟩");
    }

    #[test]
    fn a_block_holds_every_configuration_equally_often_in_an_order_fixed_by_its_seed() {
        let block = block_order(42, 6).unwrap();
        assert_eq!(block.len(), 36);
        for c in CONFIGURATIONS {
            assert_eq!(block.iter().filter(|&&t| t == c).count(), 6, "{c}");
        }
        assert_eq!(block, block_order(42, 6).unwrap(), "the same seed, the same order");
        assert_ne!(block, block_order(43, 6).unwrap());
        assert!(block_order(42, 0).unwrap_err().contains("the study used 6"));
        assert!(block_order(42, MAX_REPEATS + 1).is_err());
    }

    /// Every position of the odd piece is equally likely at each trial of
    /// a block, over many seeds (a shuffle without bias).
    #[test]
    fn the_shuffle_is_unbiased() {
        let seeds = 6_000u64;
        let mut first_odd = [0u32; 3];
        for seed in 0..seeds {
            first_odd[block_order(seed, 6).unwrap()[0].odd_position()] += 1;
        }
        // Each count ~ Binomial(6000, 1/3): mean 2000, sd 36.5.
        for n in first_odd {
            assert!((f64::from(n) - 2000.0).abs() < 4.0 * 36.5, "{first_odd:?}");
        }
    }
}
