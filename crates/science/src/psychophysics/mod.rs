//! Whether an observer can tell: the statistics of the study's oddity
//! experiment, pure and without I/O.
//!
//! Ruppertsberg & Bloj (2006, section 4.B) showed three pie pieces, two of
//! one colour and one of another, and asked which was the odd one. What a
//! block of such trials says is here:
//!
//! - [`design`]: the trials of a block, the study's six configurations in
//!   an order fixed by a stored seed.
//! - [`binomial`]: the proportion correct with its exact (Clopper–Pearson)
//!   interval.
//! - [`oddity`]: the proportion correct of the three-interval oddity task
//!   as a function of d′, and back, under the two decision models the
//!   literature uses (the differencing model of sensR's `triangle` link, and
//!   the independent-observation model of Versfeld, Dai & Green 1996), and
//!   [`oddity::estimate`], which turns a count of correct trials into d′
//!   with its interval, naming the model and any rule applied.
//! - [`observer`]: a simulated observer whose true d′ is known (ΔE*ab over
//!   its stated noise), for tests and for planning.
//! - [`plan`]: how many trials tell one d′ from another with a given power.
//! - [`threshold`]: each observer's threshold from all its conditions:
//!   σ of d′ = ΔE00/σ by maximum likelihood, its profile-likelihood
//!   interval (unbounded ends reported as such), the ΔE00 at 2/3 correct,
//!   the deviance's goodness of fit, and the proportion correct predicted
//!   at any ΔE00, under either oddity model.
//! - [`presentation`]: the pie's size and the trial's timeline in frames.
//!
//! ```
//! use lightbooth_science::psychophysics::oddity::{estimate, OddityModel};
//!
//! // 30 of 36 trials right, as one observer and condition of the study.
//! let e = estimate(30, 36, OddityModel::Differencing, 0.95).unwrap();
//! assert!((e.proportion_correct - 30.0 / 36.0).abs() < 1e-12);
//! assert!(e.d_prime > 3.0 && e.d_prime < 3.6, "{}", e.d_prime);
//! assert!(e.d_prime_interval.0 < e.d_prime);
//! ```

pub mod binomial;
pub mod design;
pub mod image_observer;
pub mod observer;
pub mod oddity;
pub mod plan;
pub mod presentation;
pub mod threshold;

/// The standard normal distribution function Φ(x), from `libm`'s `erfc`
/// (a port of musl's, accurate to about one unit in the last place):
/// Φ(x) = erfc(−x/√2)/2, which keeps its precision far into both tails.
pub(crate) fn normal_cdf(x: f64) -> f64 {
    0.5 * libm::erfc(-x / std::f64::consts::SQRT_2)
}

/// The standard normal density φ(x).
pub(crate) fn normal_pdf(x: f64) -> f64 {
    (-0.5 * x * x).exp() / (2.0 * std::f64::consts::PI).sqrt()
}

/// ∫ f over [a, b] by composite Simpson's rule on `panels` (even) panels.
/// The integrands here are smooth on each interval they are given (kinks
/// are split off by the callers), so the error falls as h⁴.
pub(crate) fn simpson(f: impl Fn(f64) -> f64, a: f64, b: f64, panels: usize) -> f64 {
    debug_assert!(panels >= 2 && panels.is_multiple_of(2));
    let h = (b - a) / panels as f64;
    let inner: f64 = (1..panels)
        .map(|i| {
            let weight = if i % 2 == 1 { 4.0 } else { 2.0 };
            weight * f(a + h * i as f64)
        })
        .sum();
    (f(a) + inner + f(b)) * h / 3.0
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Published values of Φ (Abramowitz & Stegun 1964, Table 26.1).
    #[test]
    fn the_normal_distribution_function_matches_the_tables() {
        assert!((normal_cdf(0.0) - 0.5).abs() < 1e-15);
        assert!((normal_cdf(1.0) - 0.841_344_746_068_543).abs() < 1e-14);
        assert!((normal_cdf(-1.959_963_984_540_054) - 0.025).abs() < 1e-14);
        assert!((normal_cdf(-8.0) / 6.220_960_574_271_78e-16 - 1.0).abs() < 1e-10);
    }

    #[test]
    fn simpson_integrates_the_normal_density_to_one() {
        let total = simpson(normal_pdf, -12.0, 12.0, 400);
        assert!((total - 1.0).abs() < 1e-12, "{total}");
    }
}
