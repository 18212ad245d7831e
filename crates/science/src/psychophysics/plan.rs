//! How many oddity trials an experiment needs: the power of telling a
//! larger d′ from a smaller one.
//!
//! The test is the exact one-sided binomial test of the count of correct
//! trials: with n trials, the observer is judged better than d′₀ when k
//! reaches the smallest k_c with P(X ≥ k_c | Pc(d′₀)) ≤ α. Its power
//! against d′₁ is P(X ≥ k_c | Pc(d′₁)), both tails summed exactly. Power is
//! not monotone in n (k_c moves in whole trials, so it saw-tooths), so
//! [`trials_for_power`] reports the smallest n that reaches the target and
//! says so.

use super::binomial::{ln_factorials, upper_tail};
use super::oddity::OddityModel;

/// Most trials a plan considers.
pub const MAX_PLANNED_TRIALS: u32 = 5_000;

/// The exact test of n trials against d′₀, and its power against d′₁.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Power {
    pub trials: u32,
    /// Correct trials needed to reject d′₀.
    pub critical_correct: u32,
    /// The test's actual size, P(X ≥ critical | d′₀) ≤ α.
    pub size: f64,
    /// P(X ≥ critical | d′₁).
    pub power: f64,
}

/// The power of `trials` trials to tell `d1` from `d0` (d1 > d0) at level
/// `alpha`, under `model`.
pub fn power(trials: u32, d0: f64, d1: f64, model: OddityModel, alpha: f64) -> Power {
    power_at(
        trials,
        model.proportion_correct(d0),
        model.proportion_correct(d1),
        alpha,
    )
}

/// [`power`] for proportions correct `p0` and `p1`.
fn power_at(trials: u32, p0: f64, p1: f64, alpha: f64) -> Power {
    let ln_f = ln_factorials(trials);
    // The smallest k whose upper tail under d′₀ is at most α; n + 1 if none.
    let critical = (0..=trials)
        .find(|&k| upper_tail(k, trials, p0, &ln_f) <= alpha)
        .unwrap_or(trials + 1);
    let tail = |p: f64| {
        if critical > trials {
            0.0
        } else {
            upper_tail(critical, trials, p, &ln_f)
        }
    };
    Power {
        trials,
        critical_correct: critical,
        size: tail(p0),
        power: tail(p1),
    }
}

/// The smallest number of trials whose test of `d0` against `d1` at level
/// `alpha` has at least `target` power, or why there is none.
pub fn trials_for_power(d0: f64, d1: f64, model: OddityModel, alpha: f64, target: f64) -> Result<Power, String> {
    if !(d0.is_finite() && d1.is_finite() && 0.0 <= d0 && d0 < d1) {
        return Err(format!("d′ {d0} against {d1}: give 0 ≤ d′₀ < d′₁"));
    }
    if !(alpha > 0.0 && alpha < 0.5 && target > 0.0 && target < 1.0) {
        return Err(format!(
            "alpha {alpha}, power {target}: give a level in (0, 0.5) and a power in (0, 1), such as 0.05 and 0.8"
        ));
    }
    let (p0, p1) = (model.proportion_correct(d0), model.proportion_correct(d1));
    (1..=MAX_PLANNED_TRIALS)
        .map(|n| power_at(n, p0, p1, alpha))
        .find(|p| p.power >= target)
        .ok_or_else(|| {
            format!("no plan of up to {MAX_PLANNED_TRIALS} trials tells d′ {d1} from {d0} with power {target}")
        })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::psychophysics::design::CONFIGURATIONS;
    use crate::psychophysics::observer::SimulatedObserver;
    use crate::random::SplitMix64;

    /// The plan for the question (d′ = 1 against 2, 80 % power,
    /// α = 0.05), checked by simulation: observers of true d′ 2 run the
    /// planned number of trials, and the share whose count reaches the
    /// critical one is the power, within 4 SE; observers of d′ 1 reach it at
    /// most α of the time.
    #[test]
    fn the_planned_trials_have_the_power_a_simulation_finds() {
        for model in OddityModel::ALL {
            let plan = trials_for_power(1.0, 2.0, model, 0.05, 0.8).unwrap();
            assert!(plan.power >= 0.8 && plan.size <= 0.05, "{model}: {plan:?}");
            // The same search in Python with exact integers (`math.comb`) on
            // these models' Pc(1) and Pc(2): 47 trials, 26 correct
            // (power 0.8093) and 29 trials, 18 correct (power 0.8048); one
            // trial fewer has power 0.760 and 0.729.
            let expected = match model {
                OddityModel::Differencing => (47, 26),
                OddityModel::IndependentObservation => (29, 18),
            };
            assert_eq!((plan.trials, plan.critical_correct), expected, "{model}: {plan:?}");
            let run = |d: f64, seed: u64| {
                let o = SimulatedObserver::new(1.0, model).unwrap();
                let mut rng = SplitMix64(seed);
                let sessions = 4_000;
                let rejected = (0..sessions)
                    .filter(|_| {
                        let block: Vec<_> = (0..plan.trials as usize).map(|i| CONFIGURATIONS[i % 6]).collect();
                        o.run_block(&block, d, &mut rng) >= plan.critical_correct
                    })
                    .count();
                rejected as f64 / f64::from(sessions)
            };
            let (power, size) = (run(2.0, 1), run(1.0, 2));
            let se = (plan.power * (1.0 - plan.power) / 4_000.0).sqrt();
            assert!(
                (power - plan.power).abs() < 4.0 * se,
                "{model}: simulated {power}, planned {}",
                plan.power
            );
            assert!(
                size <= 0.05 + 4.0 * (0.05f64 * 0.95 / 4_000.0).sqrt(),
                "{model}: size {size}"
            );
        }
    }

    #[test]
    fn impossible_plans_say_what_to_give() {
        assert!(trials_for_power(2.0, 1.0, OddityModel::Differencing, 0.05, 0.8)
            .unwrap_err()
            .contains("0 ≤ d′₀ < d′₁"));
        assert!(trials_for_power(1.0, 2.0, OddityModel::Differencing, 0.0, 0.8)
            .unwrap_err()
            .contains("0.05 and 0.8"));
    }
}
