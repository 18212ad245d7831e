//! A simulated observer of the oddity task, for tests and for planning an
//! experiment: an observer whose true d′ is known, so what an analysis
//! estimates from its answers can be checked against it.
//!
//! The observer sees each pie piece's colour with Gaussian noise of
//! standard deviation σ on every CIELAB axis. It knows the two colours of
//! the block and judges each piece by its position on the line joining
//! them (the other two axes carry no information about which colour a
//! piece is, and it ignores them). Its d′ is therefore, in closed form,
//! d′ = ΔE*ab / σ, and it picks the odd piece by the decision rule of an
//! [`OddityModel`], so its proportion correct is that model's Pc(d′)
//! exactly. (σ is a stated assumption about an observer, not a property of
//! human vision; a ΔE*ab of 1 is roughly a just-noticeable difference,
//! CIE 15:2004 §8.2.1, so σ near 1/1.4 gives d′ ≈ 1.4 at ΔE*ab = 1.)

use crate::colorimetry::{delta_e76, Lab};

use super::design::{Configuration, Stimulus};
use super::oddity::OddityModel;
use crate::random::SplitMix64;

/// An observer with noise `noise_sd` (ΔE*ab units, per axis) deciding as `model`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimulatedObserver {
    noise_sd: f64,
    model: OddityModel,
}

impl SimulatedObserver {
    pub fn new(noise_sd: f64, model: OddityModel) -> Result<SimulatedObserver, String> {
        if !(noise_sd.is_finite() && noise_sd > 0.0) {
            return Err(format!(
                "noise_sd = {noise_sd}: give the observer's noise as a positive number of ΔE*ab units per CIELAB axis"
            ));
        }
        Ok(SimulatedObserver { noise_sd, model })
    }

    pub fn model(&self) -> OddityModel {
        self.model
    }

    /// The noise σ, in the colour-difference units its d′ are counted in.
    pub fn sigma(&self) -> f64 {
        self.noise_sd
    }

    /// The observer's true d′ for `original` against `approximation`: ΔE*ab / σ.
    pub fn d_prime(&self, original: Lab, approximation: Lab) -> f64 {
        delta_e76(original, approximation) / self.noise_sd
    }

    /// The position (0 left, 1 top, 2 right) the observer names as odd in
    /// one trial of `configuration`, for colours `d_prime` apart.
    pub fn respond(&self, configuration: Configuration, d_prime: f64, rng: &mut SplitMix64) -> usize {
        let seen: [f64; 3] = configuration.0.map(|s| {
            let mean = if s == Stimulus::Approximation { d_prime } else { 0.0 };
            mean + rng.normal()
        });
        let others = |i: usize| (seen[(i + 1) % 3], seen[(i + 2) % 3]);
        let score = |i: usize| {
            let (a, b) = others(i);
            match self.model {
                // The odd one is the piece outside the closest pair.
                OddityModel::Differencing => -(a - b).abs(),
                // The likelihood-ratio rule (see `oddity`'s module doc).
                OddityModel::IndependentObservation => (seen[i] - a - b + d_prime / 2.0).abs(),
            }
        };
        (0..3).max_by(|&i, &j| score(i).total_cmp(&score(j))).unwrap_or(0)
    }

    /// How many of the trials of `block` the observer gets right.
    pub fn run_block(&self, block: &[Configuration], d_prime: f64, rng: &mut SplitMix64) -> u32 {
        block
            .iter()
            .filter(|c| self.respond(**c, d_prime, rng) == c.odd_position())
            .count() as u32
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::psychophysics::design::block_order;
    use crate::psychophysics::oddity::{estimate, CHANCE};

    #[test]
    fn its_d_prime_is_the_colour_difference_over_its_noise() {
        let o = SimulatedObserver::new(0.5, OddityModel::Differencing).unwrap();
        let a = Lab {
            l: 50.0,
            a: 0.0,
            b: 0.0,
        };
        let b = Lab {
            l: 50.0,
            a: 3.0,
            b: 4.0,
        };
        assert!((o.d_prime(a, b) - 10.0).abs() < 1e-12);
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(SimulatedObserver::new(bad, OddityModel::Differencing).is_err());
        }
    }

    #[test]
    fn with_identical_colours_it_is_at_chance() {
        for model in OddityModel::ALL {
            let o = SimulatedObserver::new(1.0, model).unwrap();
            let mut rng = SplitMix64(5);
            let block = block_order(1, 100).unwrap();
            let correct: u32 = (0..50).map(|_| o.run_block(&block, 0.0, &mut rng)).sum();
            let pc = f64::from(correct) / 30_000.0;
            // sd of a proportion of 30 000 at 1/3: 0.0027.
            assert!((pc - CHANCE).abs() < 4.0 * 0.0027, "{model}: {pc}");
        }
    }

    /// The study's design, simulated: 400 observers' blocks of 36 trials at
    /// a true d′ of 2. Pooled, the estimate recovers the true d′; block by
    /// block, the 95 % intervals cover it at least 95 % of the time, less a
    /// binomial margin (the Clopper–Pearson interval is conservative, so
    /// its coverage is at or above the level).
    #[test]
    fn simulated_sessions_recover_the_true_d_prime_and_intervals_cover_it() {
        let true_d = 2.0;
        for model in OddityModel::ALL {
            let o = SimulatedObserver::new(1.0, model).unwrap();
            let mut rng = SplitMix64(2006);
            let blocks = 400u32;
            let (mut total, mut covered) = (0u32, 0u32);
            // A block has 37 possible counts: each count's estimate once.
            let mut estimates = std::collections::HashMap::new();
            for session in 0..blocks {
                let block = block_order(u64::from(session), 6).unwrap();
                let k = o.run_block(&block, true_d, &mut rng);
                total += k;
                let e = estimates
                    .entry(k)
                    .or_insert_with(|| estimate(k, 36, model, 0.95).unwrap());
                if e.d_prime_interval.0 <= true_d && true_d <= e.d_prime_interval.1 {
                    covered += 1;
                }
            }
            let pooled = estimate(total, 36 * blocks, model, 0.95).unwrap();
            assert!(
                (pooled.d_prime - true_d).abs() < 0.1,
                "{model}: pooled d′ {} from {total} of {}",
                pooled.d_prime,
                36 * blocks
            );
            assert!(
                pooled.d_prime_interval.0 <= true_d && true_d <= pooled.d_prime_interval.1,
                "{model}: {pooled:?}"
            );
            // 95 % of 400 is 380, sd 4.4: fail only below 380 − 3·4.4.
            assert!(
                covered >= 367,
                "{model}: {covered} of {blocks} intervals cover d′ = {true_d}"
            );
        }
    }
}
