//! A proportion of correct trials and its exact interval.
//!
//! The Clopper–Pearson interval (Clopper & Pearson 1934, *Biometrika* 26)
//! inverts the binomial test itself: its lower end is the p at which
//! k or more successes in n have probability α/2, its upper end the p at
//! which k or fewer have probability α/2. It never covers less than the
//! stated confidence, and is what R's `binom.test` reports. Each end is
//! found by bisection on the binomial tail, summed exactly in log space
//! (no special function, no approximation beyond floating point).

use std::fmt;

/// More trials than this in one count are refused: a tail sum is O(n) and
/// a bisection takes a hundred of them. A block of the study has 36.
pub const MAX_TRIALS: u32 = 1_000_000;

/// Why a count has no interval.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CountError {
    #[error("no trials: a proportion needs at least one")]
    NoTrials,
    #[error("{correct} correct of {trials} trials: there cannot be more correct trials than trials")]
    MoreCorrectThanTrials { correct: u32, trials: u32 },
    #[error("{trials} trials: at most {MAX_TRIALS} are counted at once")]
    TooManyTrials { trials: u32 },
    #[error("confidence {0}: give a level strictly between 0 and 1 (0.95 for a 95 % interval)")]
    Confidence(f64),
}

/// k correct of n trials, checked.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Count {
    pub correct: u32,
    pub trials: u32,
}

impl Count {
    pub fn new(correct: u32, trials: u32) -> Result<Count, CountError> {
        if trials == 0 {
            return Err(CountError::NoTrials);
        }
        if correct > trials {
            return Err(CountError::MoreCorrectThanTrials { correct, trials });
        }
        if trials > MAX_TRIALS {
            return Err(CountError::TooManyTrials { trials });
        }
        Ok(Count { correct, trials })
    }

    /// k / n.
    pub fn proportion(self) -> f64 {
        f64::from(self.correct) / f64::from(self.trials)
    }

    /// The exact (Clopper–Pearson) interval of the proportion at
    /// `confidence` (0.95 for 95 %): 0 below when k = 0, 1 above when k = n.
    pub fn clopper_pearson(self, confidence: f64) -> Result<(f64, f64), CountError> {
        if !(confidence > 0.0 && confidence < 1.0) {
            return Err(CountError::Confidence(confidence));
        }
        let tail = (1.0 - confidence) / 2.0;
        let ln_factorial = ln_factorials(self.trials);
        let (k, n) = (self.correct, self.trials);
        let lower = if k == 0 {
            0.0
        } else {
            // P(X ≥ k; p) rises with p.
            bisect(|p| upper_tail(k, n, p, &ln_factorial) - tail)
        };
        let upper = if k == n {
            1.0
        } else {
            // P(X ≤ k; p) falls with p.
            bisect(|p| tail - lower_tail(k, n, p, &ln_factorial))
        };
        Ok((lower, upper))
    }
}

impl fmt::Display for Count {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} of {}", self.correct, self.trials)
    }
}

/// ln i! for i = 0..=n.
pub(super) fn ln_factorials(n: u32) -> Vec<f64> {
    let mut out = Vec::with_capacity(n as usize + 1);
    let mut acc = 0.0;
    out.push(0.0);
    for i in 1..=n {
        acc += f64::from(i).ln();
        out.push(acc);
    }
    out
}

/// ln P(X = i) for X ~ Binomial(n, p), 0 < p < 1.
fn ln_pmf(i: u32, n: u32, p: f64, ln_factorial: &[f64]) -> f64 {
    let (i_, n_) = (i as usize, n as usize);
    ln_factorial[n_] - ln_factorial[i_] - ln_factorial[n_ - i_]
        + f64::from(i) * p.ln()
        + f64::from(n - i) * (-p).ln_1p()
}

/// Σ exp(terms), without overflow or underflow of the largest term.
fn sum_exp(terms: impl Iterator<Item = f64> + Clone) -> f64 {
    let max = terms.clone().fold(f64::NEG_INFINITY, f64::max);
    if max == f64::NEG_INFINITY {
        return 0.0;
    }
    max.exp() * terms.map(|t| (t - max).exp()).sum::<f64>()
}

/// P(X ≥ k).
pub(super) fn upper_tail(k: u32, n: u32, p: f64, ln_factorial: &[f64]) -> f64 {
    sum_exp((k..=n).map(|i| ln_pmf(i, n, p, ln_factorial)))
}

/// P(X ≤ k).
fn lower_tail(k: u32, n: u32, p: f64, ln_factorial: &[f64]) -> f64 {
    sum_exp((0..=k).map(|i| ln_pmf(i, n, p, ln_factorial)))
}

/// The root in (0, 1) of `f`, rising from below zero to above it, to the
/// last bits of a double (a hundred halvings).
fn bisect(f: impl Fn(f64) -> f64) -> f64 {
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if f(mid) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// R 4.x, `binom.test(7, 10)$conf.int`: 0.3475471 0.9332605.
    #[test]
    fn seven_of_ten_has_the_interval_r_reports() {
        let (lo, hi) = Count::new(7, 10).unwrap().clopper_pearson(0.95).unwrap();
        assert!((lo - 0.347_547_1).abs() < 5e-8, "{lo}");
        assert!((hi - 0.933_260_5).abs() < 5e-8, "{hi}");
    }

    /// With k = 0 or k = n the tail is one term, and the ends are closed
    /// form: 1 − (α/2)^(1/n) and (α/2)^(1/n).
    #[test]
    fn all_or_none_correct_have_closed_form_ends() {
        for n in [1u32, 10, 36, 500] {
            let edge = 0.025f64.powf(1.0 / f64::from(n));
            let (lo, hi) = Count::new(n, n).unwrap().clopper_pearson(0.95).unwrap();
            assert!((lo - edge).abs() < 1e-12 && hi == 1.0, "{n}: {lo} {hi}");
            let (lo, hi) = Count::new(0, n).unwrap().clopper_pearson(0.95).unwrap();
            assert!(lo == 0.0 && (hi - (1.0 - edge)).abs() < 1e-12, "{n}: {lo} {hi}");
        }
    }

    /// A count far too large for direct products (0.6¹⁰⁰⁰⁰ underflows a
    /// double): the ends agree with the normal approximation
    /// p̂ ± z·√(p̂(1 − p̂)/n), z = 2.5758 for 99 %, which is within 10⁻⁴ of
    /// the exact interval at n = 10 000.
    #[test]
    fn a_large_count_has_the_normal_approximations_interval() {
        let c = Count::new(6_000, 10_000).unwrap();
        let (lo, hi) = c.clopper_pearson(0.99).unwrap();
        let half = 2.575_829_3 * (0.6f64 * 0.4 / 10_000.0).sqrt();
        assert!((lo - (0.6 - half)).abs() < 1e-4, "{lo} against {}", 0.6 - half);
        assert!((hi - (0.6 + half)).abs() < 1e-4, "{hi} against {}", 0.6 + half);
    }

    #[test]
    fn impossible_counts_and_levels_are_refused_with_what_to_do() {
        assert_eq!(Count::new(0, 0), Err(CountError::NoTrials));
        assert_eq!(
            Count::new(37, 36),
            Err(CountError::MoreCorrectThanTrials {
                correct: 37,
                trials: 36
            })
        );
        assert!(matches!(
            Count::new(1, MAX_TRIALS + 1),
            Err(CountError::TooManyTrials { .. })
        ));
        let c = Count::new(3, 4).unwrap();
        for bad in [0.0, 1.0, 95.0, f64::NAN] {
            let e = c.clopper_pearson(bad).unwrap_err();
            assert!(e.to_string().contains("0.95"), "{e}");
        }
    }
}
