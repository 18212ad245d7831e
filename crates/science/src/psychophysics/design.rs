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
//! pseudorandom number generators", OOPSLA; [`crate::random`]), specified to
//! the bit, and a Fisher–Yates shuffle.

use std::fmt;

use crate::random::SplitMix64;

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

/// One trial of a session: which approximation (its index in the
/// experiment's list) and in which configuration.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct PlannedTrial {
    pub approximation: usize,
    pub configuration: Configuration,
}

/// More approximations than this in one block are refused (the study's
/// full set, N = 3, 9, 27, 81 with RGB and sRGB, is six).
pub const MAX_APPROXIMATIONS: usize = 16;

/// One block of a scene: every approximation in each configuration
/// `repeats` times, interleaved and shuffled with `seed` (Fisher–Yates, as
/// [`block_order`]).
pub fn session_order(seed: u64, approximations: usize, repeats: u32) -> Result<Vec<PlannedTrial>, String> {
    if approximations == 0 || approximations > MAX_APPROXIMATIONS {
        return Err(format!(
            "{approximations} approximations: give 1–{MAX_APPROXIMATIONS} to test against the original"
        ));
    }
    // Validates `repeats`; its order is not used.
    block_order(seed, repeats)?;
    let mut trials: Vec<PlannedTrial> = (0..approximations)
        .flat_map(|approximation| {
            (0..repeats).flat_map(move |_| {
                CONFIGURATIONS.map(|configuration| PlannedTrial {
                    approximation,
                    configuration,
                })
            })
        })
        .collect();
    let mut rng = SplitMix64(seed);
    for i in (1..trials.len()).rev() {
        let j = rng.below(i as u64 + 1) as usize;
        trials.swap(i, j);
    }
    Ok(trials)
}

/// The order trials are shown in: the planned trials, then again, at the
/// end, every trial that had a frame dropped while its pie was shown
/// (`dropped[i]` for the i-th trial recorded; a repeat that drops a frame
/// is repeated too), at most as many repeats as planned trials: a display
/// that drops frames in every trial ends its session after twice the
/// planned trials, with the dropped trials reported, rather than never.
/// Its length is the number of trials the session needs so far: the
/// session is complete when that many are recorded.
pub fn shown_order(planned: &[PlannedTrial], dropped: &[bool]) -> Vec<PlannedTrial> {
    let mut order = planned.to_vec();
    for (i, &d) in dropped.iter().enumerate() {
        if d && i < order.len() && order.len() < 2 * planned.len() {
            order.push(order[i]);
        }
    }
    order
}

/// A configuration as three letters, left top right: `O` the original, `N`
/// the approximation (`OON`), as stored with each trial.
pub fn letters(c: Configuration) -> String {
    c.0.iter().map(|&s| if s == O { 'O' } else { 'N' }).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

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

    #[test]
    fn a_session_interleaves_every_approximation_in_every_configuration() {
        let trials = session_order(7, 3, 6).unwrap();
        assert_eq!(trials.len(), 108);
        for a in 0..3 {
            for c in CONFIGURATIONS {
                let n = trials
                    .iter()
                    .filter(|t| t.approximation == a && t.configuration == c)
                    .count();
                assert_eq!(n, 6, "approximation {a}, {c}");
            }
        }
        // Interleaved, not in runs: the first 36 trials are not all one approximation.
        assert!(trials[..36].iter().any(|t| t.approximation != trials[0].approximation));
        assert_eq!(trials, session_order(7, 3, 6).unwrap());
        assert!(session_order(7, 0, 6).unwrap_err().contains("1–16"));
        assert!(session_order(7, 2, 0).unwrap_err().contains("the study used 6"));
    }

    #[test]
    fn a_trial_with_a_dropped_frame_is_shown_again_at_the_end() {
        let planned = session_order(1, 1, 1).unwrap();
        assert_eq!(shown_order(&planned, &[]), planned);
        let order = shown_order(&planned, &[false, true, false, false, false, false, true]);
        // Trial 1 dropped: repeated as trial 6; its repeat dropped again: trial 7.
        assert_eq!(order.len(), 8);
        assert_eq!(order[6], planned[1]);
        assert_eq!(order[7], planned[1]);
        assert_eq!(letters(CONFIGURATIONS[0]), "OON");
        // A display that drops a frame in every trial: at most as many repeats as planned.
        assert_eq!(shown_order(&planned, &[true; 100]).len(), 12);
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
