//! d′ of the three-interval oddity task, the study's experiment: three
//! stimuli, two alike, and the observer picks the odd one. Chance is 1/3.
//!
//! Each stimulus gives the observer one noisy value on a decision axis,
//! unit variance, the two colours d′ apart. How the observer picks the odd
//! one is the model, and the same proportion correct means a different d′
//! under each, so every d′ here is reported with its [`OddityModel`]:
//!
//! - **Differencing** (Macmillan & Creelman 2005, *Detection Theory*, ch. 9;
//!   the `triangle` psychometric function of R's sensR): pick the stimulus
//!   whose two differences from the others are both large. Its proportion
//!   correct is
//!   Pc(d′) = 2∫₀^∞ [Φ(−√3·x + d′·√(2/3)) + Φ(−√3·x − d′·√(2/3))] φ(x) dx.
//! - **Independent observation** (Versfeld, Dai & Green 1996, *Perception &
//!   Psychophysics* 58(1)): the likelihood-ratio rule of an observer who
//!   knows both distributions. With values x₁, x₂, x₃ it picks the i that
//!   maximises |xᵢ − xⱼ − xₖ + d′/2| (the log likelihood ratio of "i is odd"
//!   against the mean, for either colour being the odd one, which are
//!   equally likely). Written with c = e₁ + d′/2, a = e₂ + e₃ and
//!   b = e₂ − e₃ (eᵢ the unit noises, a and b independent of variance 2),
//!   the odd stimulus wins when |c + d′ − a| > |b| + |c|, so
//!   Pc(d′) = E_{b,c}[Φ((c + d′ − t)/√2) + Φ((−c − d′ − t)/√2)], t = |b| + |c|,
//!   a two-dimensional integral done here numerically.
//!
//! Both integrals are evaluated by Simpson's rule on panels that end at the
//! integrands' kinks: the differencing one to about 10⁻¹⁰, the
//! independent-observation one (128 × 256 panels, about a millisecond) to
//! about 3·10⁻⁷ in Pc, far below what any count of trials resolves
//! (checked against chance, 1/3 at d′ = 0, published values and a
//! simulated observer in the tests). d′ from Pc is the root on
//! [0, [`MAX_D_PRIME`]], found by the Illinois method.

use std::f64::consts::SQRT_2;
use std::fmt;
use std::sync::OnceLock;

use super::binomial::{Count, CountError};
use super::{normal_cdf, normal_pdf, simpson};

/// The largest d′ reported: Pc is within 10⁻⁶ of 1 beyond it under both
/// models, so larger values cannot be told apart by any count of trials
/// this crate accepts.
pub const MAX_D_PRIME: f64 = 15.0;

/// Chance in a three-alternative task.
pub const CHANCE: f64 = 1.0 / 3.0;

/// How the observer is taken to decide which stimulus is the odd one.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum OddityModel {
    /// Differencing (sensR's `triangle`; Macmillan & Creelman).
    Differencing,
    /// Independent observation, the likelihood-ratio rule (Versfeld, Dai & Green 1996).
    IndependentObservation,
}

impl OddityModel {
    pub const ALL: [OddityModel; 2] = [OddityModel::Differencing, OddityModel::IndependentObservation];

    pub fn name(self) -> &'static str {
        match self {
            OddityModel::Differencing => "differencing",
            OddityModel::IndependentObservation => "independent-observation",
        }
    }

    /// The proportion correct of an observer of sensitivity `d_prime`
    /// (≥ 0; negative values are taken as their magnitude, the task being
    /// symmetric).
    pub fn proportion_correct(self, d_prime: f64) -> f64 {
        // `min` takes a NaN as PC_TABLE_END, as the quadrature did.
        self.pc_table().at(d_prime.abs().min(PC_TABLE_END))
    }

    /// The model's Pc(d′) interpolated from its quadrature (see
    /// [`PcTable`]), built once per process.
    fn pc_table(self) -> &'static PcTable {
        static TABLES: [OnceLock<PcTable>; 2] = [OnceLock::new(), OnceLock::new()];
        match self {
            OddityModel::Differencing => TABLES[0].get_or_init(|| PcTable::new(differencing_pc)),
            OddityModel::IndependentObservation => TABLES[1].get_or_init(|| PcTable::new(independent_observation_pc)),
        }
    }

    /// The d′ whose proportion correct is `pc`: 0 at or below chance,
    /// [`MAX_D_PRIME`] at or above that d′'s proportion correct.
    pub fn d_prime(self, pc: f64) -> f64 {
        if pc.is_nan() || pc <= CHANCE {
            return 0.0;
        }
        if pc >= self.proportion_correct(MAX_D_PRIME) {
            return MAX_D_PRIME;
        }
        // The Illinois variant of regula falsi (Dowell & Jarratt 1971):
        // bracketed like bisection, converging superlinearly, so the
        // independent-observation integral is evaluated a dozen times, not sixty.
        let f = |d: f64| self.proportion_correct(d) - pc;
        let (mut lo, mut hi) = (0.0f64, MAX_D_PRIME);
        let (mut f_lo, mut f_hi) = (f(lo), f(hi));
        let mut last_side = 0i8;
        for _ in 0..200 {
            let d = (lo * f_hi - hi * f_lo) / (f_hi - f_lo);
            let f_d = f(d);
            if f_d == 0.0 || hi - lo < 1e-12 {
                return d;
            }
            if f_d < 0.0 {
                lo = d;
                f_lo = f_d;
                if last_side == -1 {
                    f_hi /= 2.0;
                }
                last_side = -1;
            } else {
                hi = d;
                f_hi = f_d;
                if last_side == 1 {
                    f_lo /= 2.0;
                }
                last_side = 1;
            }
            if (hi - lo).abs() < 1e-12 || f_d.abs() < 1e-15 {
                return d;
            }
        }
        0.5 * (lo + hi)
    }
}

impl fmt::Display for OddityModel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Where Pc(d′) is tabulated to: d′ beyond it is taken as this (Pc is
/// 1 to far below a double's resolution of 1 there under both models).
const PC_TABLE_END: f64 = MAX_D_PRIME * 4.0;

/// Pieces of [`PcTable`] of width 1 up to here, then one to [`PC_TABLE_END`]
/// (where Pc is flat).
const PC_TABLE_UNIT_PIECES: usize = 20;

/// Chebyshev coefficients per piece of [`PcTable`].
const PC_TABLE_TERMS: usize = 25;

/// **An approximation, stated**: Pc(d′) of one model as a Chebyshev series
/// of [`PC_TABLE_TERMS`] terms on each piece of [0, [`PC_TABLE_END`]]
/// (width 1 up to d′ = 20, then one piece), fitted at the Chebyshev nodes
/// to the quadrature ([`differencing_pc`], [`independent_observation_pc`]).
/// Pc is an entire function of d′, so the series converges faster than any
/// power: it reproduces the quadrature to about 10⁻¹⁴ (a test checks
/// 10⁻¹² at 4 000 points), far below the quadrature's own error. Why: an
/// analysis inverts Pc for every count and fits thresholds that evaluate
/// it thousands of times; the independent-observation integral costs about
/// a millisecond, so 200 observers took minutes (issue 46). Built once per
/// process, 525 quadratures per model (about half a second for both).
struct PcTable {
    /// Per piece: its start, half-width and coefficients.
    pieces: Vec<(f64, f64, [f64; PC_TABLE_TERMS])>,
}

impl PcTable {
    fn new(pc: fn(f64) -> f64) -> PcTable {
        let mut bounds: Vec<(f64, f64)> = (0..PC_TABLE_UNIT_PIECES).map(|i| (i as f64, i as f64 + 1.0)).collect();
        bounds.push((PC_TABLE_UNIT_PIECES as f64, PC_TABLE_END));
        let n = PC_TABLE_TERMS;
        let node = |k: usize| (std::f64::consts::PI * (k as f64 + 0.5) / n as f64).cos();
        let pieces = bounds
            .into_iter()
            .map(|(a, b)| {
                let (mid, half) = (0.5 * (a + b), 0.5 * (b - a));
                let values: Vec<f64> = (0..n).map(|k| pc(mid + half * node(k))).collect();
                let mut coefficients = [0.0; PC_TABLE_TERMS];
                for (j, c) in coefficients.iter_mut().enumerate() {
                    let sum: f64 = values
                        .iter()
                        .enumerate()
                        .map(|(k, v)| v * (std::f64::consts::PI * j as f64 * (k as f64 + 0.5) / n as f64).cos())
                        .sum();
                    *c = 2.0 * sum / n as f64;
                }
                coefficients[0] *= 0.5;
                (a, half, coefficients)
            })
            .collect();
        PcTable { pieces }
    }

    /// Pc at `d` in [0, [`PC_TABLE_END`]] (Clenshaw's recurrence).
    fn at(&self, d: f64) -> f64 {
        let i = (d.floor() as usize).min(self.pieces.len() - 1);
        let (a, half, c) = &self.pieces[i];
        let x = ((d - a) / half - 1.0).clamp(-1.0, 1.0);
        let (mut b1, mut b2) = (0.0, 0.0);
        for &cj in c.iter().skip(1).rev() {
            let b0 = 2.0 * x * b1 - b2 + cj;
            b2 = b1;
            b1 = b0;
        }
        x * b1 - b2 + c[0]
    }
}

fn differencing_pc(d: f64) -> f64 {
    let shift = d * (2.0f64 / 3.0).sqrt();
    let root3 = 3.0f64.sqrt();
    let integrand = |x: f64| (normal_cdf(-root3 * x + shift) + normal_cdf(-root3 * x - shift)) * normal_pdf(x);
    // φ(x) < 10⁻²⁷ beyond x = 11.
    2.0 * simpson(integrand, 0.0, 11.0, 2_000)
}

fn independent_observation_pc(d: f64) -> f64 {
    // b ~ N(0, 2), symmetric: twice the integral over b ≥ 0.
    // c ~ N(d/2, 1), with a kink at c = 0 (|c|): split there.
    // Both densities are below 10⁻¹³ beyond 8 sd.
    const PANELS: usize = 128;
    let sd_b = SQRT_2;
    let win = |b: f64, c: f64| {
        let t = b + c.abs();
        normal_cdf((c + d - t) / SQRT_2) + normal_cdf((-c - d - t) / SQRT_2)
    };
    let over_b = |c: f64| {
        let density_c = normal_pdf(c - d / 2.0);
        2.0 * simpson(|b| win(b, c) * normal_pdf(b / sd_b) / sd_b, 0.0, 8.0 * sd_b, PANELS) * density_c
    };
    let (c_lo, c_hi) = (d / 2.0 - 8.0, d / 2.0 + 8.0);
    let mut total = 0.0;
    if c_lo < 0.0 {
        total += simpson(over_b, c_lo, 0.0_f64.min(c_hi), PANELS);
    }
    if c_hi > 0.0 {
        total += simpson(over_b, 0.0_f64.max(c_lo), c_hi, PANELS);
    }
    total
}

/// The rule that makes a proportion of 0 or 1 usable: d′ is infinite at
/// Pc = 1, so k = n is counted as k = n − ½ (Pc = 1 − 1/(2n), Macmillan &
/// Creelman 2005, §1.2's correction). The interval is not corrected: its
/// upper end at k = n is 1, whose d′ is reported as [`MAX_D_PRIME`] and
/// flagged.
pub const ALL_CORRECT_RULE: &str = "all trials correct: d′ from Pc = 1 − 1/(2n)";

/// d′ and percent correct of one count of oddity trials.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct OddityEstimate {
    pub model: OddityModel,
    pub correct: u32,
    pub trials: u32,
    /// k / n.
    pub proportion_correct: f64,
    /// The exact (Clopper–Pearson) interval of the proportion correct.
    pub proportion_interval: (f64, f64),
    /// The confidence of both intervals (0.95 for 95 %).
    pub confidence: f64,
    /// d′ under `model`, from k / n (or from the corrected proportion, see `rule`).
    pub d_prime: f64,
    /// The proportion interval's ends mapped through the same model: 0
    /// where an end is at or below chance, [`MAX_D_PRIME`] where it is at or
    /// above that d′'s proportion correct (see `upper_bounded`).
    pub d_prime_interval: (f64, f64),
    /// False when the interval's upper end is only the reporting limit
    /// [`MAX_D_PRIME`] (every trial correct, or nearly): the data set no
    /// upper bound.
    pub upper_bounded: bool,
    /// A rule applied to the count before d′ was computed, said in words
    /// (today only [`ALL_CORRECT_RULE`]).
    pub rule: Option<&'static str>,
}

/// d′ of `correct` of `trials` oddity trials under `model`, with the exact
/// interval at `confidence` mapped through the same model.
pub fn estimate(correct: u32, trials: u32, model: OddityModel, confidence: f64) -> Result<OddityEstimate, CountError> {
    let count = Count::new(correct, trials)?;
    let (lo, hi) = count.clopper_pearson(confidence)?;
    let pc = count.proportion();
    let (pc_for_d, rule) = if correct == trials {
        (1.0 - 1.0 / (2.0 * f64::from(trials)), Some(ALL_CORRECT_RULE))
    } else {
        (pc, None)
    };
    let d_hi = model.d_prime(hi);
    Ok(OddityEstimate {
        model,
        correct,
        trials,
        proportion_correct: pc,
        proportion_interval: (lo, hi),
        confidence,
        d_prime: model.d_prime(pc_for_d),
        d_prime_interval: (model.d_prime(lo), d_hi),
        upper_bounded: d_hi < MAX_D_PRIME,
        rule,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The tabulated Pc (issue 46: an analysis of 200 observers took
    /// minutes in the quadrature) is the quadrature's, to 10⁻¹², at points
    /// between the nodes: 4 000 for differencing, 300 for independent
    /// observation (a millisecond each), over every piece and beyond.
    #[test]
    fn the_tabulated_proportion_correct_is_the_quadratures() {
        let mut rng = crate::random::SplitMix64(46);
        for (model, quadrature, points) in [
            (OddityModel::Differencing, differencing_pc as fn(f64) -> f64, 4_000),
            (OddityModel::IndependentObservation, independent_observation_pc, 300),
        ] {
            let mut worst: (f64, f64) = (0.0, 0.0);
            for k in 0..points {
                // Every piece, and the last one's far end.
                let d = if k % 10 == 9 {
                    20.0 + 40.0 * rng.uniform()
                } else {
                    21.0 * rng.uniform()
                };
                let err = (model.proportion_correct(d) - quadrature(d)).abs();
                if err > worst.0 {
                    worst = (err, d);
                }
            }
            assert!(
                worst.0 < 1e-12,
                "{model}: |table − quadrature| = {:e} at d′ = {}",
                worst.0,
                worst.1
            );
        }
    }

    #[test]
    fn chance_is_one_third_under_both_models() {
        for model in OddityModel::ALL {
            let pc = model.proportion_correct(0.0);
            let tolerance = match model {
                OddityModel::Differencing => 1e-10,
                OddityModel::IndependentObservation => 1e-6,
            };
            assert!((pc - CHANCE).abs() < tolerance, "{model}: {pc}");
            assert_eq!(model.d_prime(CHANCE), 0.0);
            assert_eq!(model.d_prime(0.2), 0.0, "below chance");
            let near_one = 1.0 - model.proportion_correct(MAX_D_PRIME);
            assert!(
                (0.0..1e-6).contains(&near_one),
                "{model}: 1 − Pc(MAX_D_PRIME) = {near_one}"
            );
        }
    }

    /// sensR's own tests of its `triangle` link (`psyinv` of Pc 0.4 … 0.9,
    /// five decimals; Christensen & Brockhoff, R package sensR).
    #[test]
    fn differencing_d_primes_match_sensr() {
        let published = [
            (0.4, 0.87911),
            (0.5, 1.46626),
            (0.6, 1.97560),
            (0.7, 2.50372),
            (0.8, 3.12859),
            (0.9, 4.02763),
        ];
        for (pc, d) in published {
            let ours = OddityModel::Differencing.d_prime(pc);
            assert!((ours - d).abs() < 5e-5, "Pc {pc}: d′ {ours}, sensR {d}");
        }
    }

    /// Macmillan & Creelman's tables of the three-interval oddity task
    /// (Detection Theory: A User's Guide, 2nd ed. 2005, appendix tables),
    /// for both models. The tables give three decimals and differ from a
    /// precise integral by up to 0.002 (at d′ = 3 the differencing table
    /// says 0.783 where the integral, whose inverse matches sensR's to
    /// 5·10⁻⁵ in d′ above, gives 0.7814), so they are met to 0.002.
    #[test]
    fn proportions_correct_match_macmillan_and_creelman() {
        let differencing = [0.418, 0.605, 0.783, 0.898, 0.959];
        let independent = [0.446, 0.677, 0.862, 0.953, 0.987];
        let ours =
            |model: OddityModel| -> Vec<f64> { (1..=5).map(|d| model.proportion_correct(f64::from(d))).collect() };
        let (ours_d, ours_i) = (
            ours(OddityModel::Differencing),
            ours(OddityModel::IndependentObservation),
        );
        for i in 0..5 {
            assert!(
                (ours_d[i] - differencing[i]).abs() < 2e-3 && (ours_i[i] - independent[i]).abs() < 2e-3,
                "d′ 1–5: differencing {ours_d:?}, table {differencing:?}; independent observation {ours_i:?}, table {independent:?}"
            );
        }
    }

    /// The independent-observation integral against a direct simulation of
    /// the likelihood-ratio observer (its own noise, its own rule), which
    /// shares nothing with the integral but the model; 2·10⁶ trials put the
    /// simulation's standard error near 3.5·10⁻⁴.
    #[test]
    fn the_independent_observation_integral_agrees_with_a_simulated_observer() {
        let d = 1.5;
        let mut rng = crate::random::SplitMix64(11);
        let trials = 2_000_000;
        let mut correct = 0u32;
        for _ in 0..trials {
            let x = [d + rng.normal(), rng.normal(), rng.normal()];
            let score = |i: usize| (x[i] - x[(i + 1) % 3] - x[(i + 2) % 3] + d / 2.0).abs();
            if score(0) > score(1) && score(0) > score(2) {
                correct += 1;
            }
        }
        let simulated = f64::from(correct) / f64::from(trials);
        let integral = OddityModel::IndependentObservation.proportion_correct(d);
        let se = (integral * (1.0 - integral) / f64::from(trials)).sqrt();
        assert!(
            (simulated - integral).abs() < 4.0 * se,
            "simulated {simulated}, integral {integral}"
        );
    }

    #[test]
    fn d_prime_inverts_the_proportion_correct() {
        for model in OddityModel::ALL {
            for d in [0.1, 0.5, 1.0, 2.5, 4.0, 6.0] {
                let back = model.d_prime(model.proportion_correct(d));
                assert!((back - d).abs() < 1e-6, "{model}: {d} → {back}");
            }
        }
    }

    #[test]
    fn all_correct_is_corrected_and_says_so_and_its_interval_is_unbounded_above() {
        let e = estimate(36, 36, OddityModel::Differencing, 0.95).unwrap();
        assert_eq!(e.rule, Some(ALL_CORRECT_RULE));
        let corrected = OddityModel::Differencing.d_prime(1.0 - 1.0 / 72.0);
        assert_eq!(e.d_prime, corrected);
        assert!(!e.upper_bounded && e.d_prime_interval.1 == MAX_D_PRIME);
        // The lower end: (0.025)^(1/36) = 0.90261 correct.
        let lower_pc = 0.025f64.powf(1.0 / 36.0);
        assert!((e.d_prime_interval.0 - OddityModel::Differencing.d_prime(lower_pc)).abs() < 1e-9);
    }

    #[test]
    fn a_count_at_chance_has_d_prime_zero_and_an_interval_from_zero() {
        let e = estimate(12, 36, OddityModel::IndependentObservation, 0.95).unwrap();
        assert_eq!(e.rule, None);
        assert_eq!(e.d_prime, 0.0);
        assert_eq!(e.d_prime_interval.0, 0.0);
        assert!(e.upper_bounded && e.d_prime_interval.1 > 0.5);
    }
}
