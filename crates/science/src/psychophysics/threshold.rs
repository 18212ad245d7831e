//! Each observer's threshold: the colour difference it tells from the
//! original at 2/3 correct, fitted to its oddity trials over all the
//! conditions it saw.
//!
//! **Model.** An observer's d′ for an approximation is proportional to the
//! approximation's colour difference from the original,
//! d′ = ΔE00 / σ, with one parameter σ > 0 (ΔE00 units) per observer, or
//! one for a pool (pass the pooled observers' conditions together). That d′
//! grows linearly with ΔE00 is an assumption of this fit, not a property of
//! CIEDE2000 (Luo, Cui & Rigg 2001, *Color Res. Appl.* 26(5)), whose
//! differences are only approximately uniform in perceived size.
//!
//! **Lapses.** Real observers now and then miss a difference far above
//! their threshold (a blink, a wrong key). Without a term for that, one
//! miss at a large ΔE00 can only be explained by a large σ or, where the
//! model's 1 − Pc is below what the fit resolves, leaves ℓ flat down to the
//! fit's floor. So a lapse rate λ is fitted with σ, as psignifit and
//! Palamedes do (Wichmann & Hill 2001a, *Perception & Psychophysics*
//! 63(8), 1293–1313): a condition i, shown n_i times with k_i correct, has
//! proportion correct p_i = 1/3 + (2/3 − λ)·F(ΔE_i / σ), with chance 1/3
//! and F(d′) = (Pc(d′) − 1/3)/(2/3) the caller's [`OddityModel`] scaled to
//! [0, 1]; the ceiling is 1 − λ. It is the same as an observer who guesses
//! on a fraction 3λ/2 of trials. λ is bounded to [0, [`LAPSE_MAX`]] = [0, 0.06].
//!
//! **Fit.** (σ̂, λ̂) maximise the binomial log-likelihood
//! ℓ(σ, λ) = Σ_i [ln C(n_i, k_i) + k_i ln p_i + (n_i − k_i) ln(1 − p_i)]
//! (the binomial coefficients included, so ℓ is the log of the data's
//! probability). At each σ, ℓ is concave in λ (p is affine in it), so λ is
//! profiled out exactly: λ̃(σ) is the root of ∂ℓ/∂λ in [0, 0.06] or an end,
//! and ℓ_p(σ) = ℓ(σ, λ̃(σ)) is what the search below maximises; λ̂ = λ̃(σ̂).
//! The search is over the sensitivity s = 1/σ, which
//! includes both ends: s = 0 (σ = ∞, every p_i at chance) and s → ∞
//! (σ → 0, every p_i → 1 − λ). ℓ is evaluated at s = 0 and on a grid of s
//! spaced 5 % apart, from where the largest d′ is 10⁻³ to where the
//! smallest positive one reaches [`MAX_D_PRIME`] (beyond it Pc is held at
//! its value there, so ℓ is flat); the best grid point is refined by
//! golden-section search (Press et al. 2007, *Numerical Recipes*, 3rd ed.,
//! §10.2) on the grid steps either side of it. A grid, not a bracket from
//! one start, because nothing guarantees that ℓ has a single maximum; a
//! second maximum within 5 % of the first would not be told apart.
//!
//! **The ends,** reported as they are ([`Maximum`]), with no number made up:
//! - every trial at a positive ΔE00 correct, or the misses there no more
//!   than lapses explain (ℓ_p within 10⁻⁶ of its value as σ → 0, which it
//!   keeps beyond the grid's flat end): the supremum is at σ → 0. σ̂ = 0 and
//!   the threshold 0, the interval's lower end 0 and its upper end finite:
//!   the trials bound the threshold above only.
//! - the data no better than chance (ℓ largest at s = 0, which is where
//!   every count at or below one third correct puts it): σ̂ is unbounded,
//!   there is no finite threshold, and the interval has a finite lower end
//!   and no upper one.
//!
//! **Interval.** The profile-likelihood interval (Pawitan 2001, *In All
//! Likelihood*, §2.6 and §3.4), λ profiled out:
//! {σ : 2(ℓ̂ − ℓ_p(σ)) ≤ χ²₁(c)}, χ²₁(0.95) = 3.841458820694124, whose
//! coverage tends to c as the trials grow (Wilks 1938, *Ann. Math. Stat.*
//! 9). Its ends are found by bisection on the grid step where ℓ crosses the
//! cut; if ℓ has several maxima the interval reported is the hull of the
//! set (from the lowest σ to the highest at which ℓ reaches the cut), which
//! can only be wider than the set. Where ℓ stays above the cut all the way
//! to s = 0 the interval has no upper end; where it stays above it up to
//! the flat end of the grid, its lower end is 0. The threshold ΔE00 at
//! 2/3 correct is σ · d′(2/3) under the same model, so its interval is σ's
//! scaled; it is the lapse-free observer's 2/3 (F = 1/2, as psignifit's
//! threshold is taken on the unscaled sigmoid), where the fitted curve,
//! lapses included, is at 2/3 − λ̂/2. λ's own interval is its profile
//! interval, σ profiled out (the largest ℓ over the same grid, refined),
//! within [0, 0.06]. An interval that reaches 0 or has no upper end, and a
//! λ̂ at its bound, are said in words ([`ThresholdFit::at_bounds`]): there
//! the likelihood is flat and a bound, not the trials, sets the number.
//! With a lapse rate, 1 000 simulated observers per model (σ = 1, the
//! study's six differences × 36 trials, no lapses) are covered 959 and 944
//! times; 400 per model and λ who lapse (λ = 0.02, 0.05; σ = 0.4) 950–958
//! times, with λ̂ biased low at 36 trials a condition (mean 0.043 for 0.05).
//!
//! **Goodness of fit.** The deviance against the saturated model (one p per
//! condition, p = k/n), D = 2 Σ [k ln(k/(n p̂)) + (n − k) ln((n − k)/(n(1 − p̂)))]
//! with 0 · ln 0 = 0, on df = (conditions with trials) − 2 (σ and λ), and its
//! p-value from the χ² distribution (McCullagh & Nelder 1989, *Generalized
//! Linear Models*, 2nd ed., §4.4.3). The χ² reference is asymptotic: with
//! few trials per condition, or p̂ near 1, the deviance's distribution
//! departs from it (Wichmann & Hill 2001, *Perception & Psychophysics*
//! 63(8), 1293–1313, who recommend Monte Carlo for the study's sizes), so
//! the p-value is a guide, not an exact test. It is also so when σ̂ is at
//! an end, or λ̂ at 0 (a bound: the reference then lies between χ² on df
//! and on df + 1). With one or two conditions, df = 0 and there is no
//! p-value: the fit has no degrees of freedom left.
//!
//! **Approximation.** Pc(d′) is an integral (see [`super::oddity`]); the
//! independent-observation one costs about a millisecond, and a fit
//! evaluates ℓ some hundreds of times. The fit therefore evaluates Pc from a
//! clamped cubic spline (Press et al. 2007, §3.3) through the model's
//! values at d′ = 0, 0.05, …, [`MAX_D_PRIME`], built once per model (about
//! 0.3 s for independent observation). Its slope is 0 at d′ = 0 (Pc is even
//! in d′) and at the top end is taken from a three-point difference. A
//! clamped spline's error is at most (5/384) h⁴ max|Pc⁗| (Hall & Meyer
//! 1976, *J. Approx. Theory* 16); measured against the integrals here it
//! is below 10⁻⁶ in Pc under both models (a test), far below what a count
//! resolves. ℓ̂ and the deviance are the spline's; the threshold (through
//! d′(2/3)) and the predictions use the model's integral itself.
//!
//! ```
//! use lightbooth_science::psychophysics::oddity::OddityModel;
//! use lightbooth_science::psychophysics::threshold::{fit, Condition, Maximum};
//!
//! // One observer: four approximations, 36 trials each.
//! let seen = [(0.6, 14), (1.2, 17), (2.4, 26), (4.8, 35)];
//! let conditions: Vec<Condition> = seen
//!     .iter()
//!     .map(|&(delta_e00, correct)| Condition { delta_e00, correct, trials: 36 })
//!     .collect();
//! let f = fit(&conditions, OddityModel::Differencing, 0.95).unwrap();
//! assert_eq!(f.maximum, Maximum::Interior);
//! let (threshold, (lo, hi)) = (f.threshold.unwrap(), f.threshold_interval);
//! assert!(lo < threshold && threshold < hi.unwrap());
//! // An approximation that could not be shown, at ΔE00 = 0.3:
//! let p = f.predict(0.3).unwrap();
//! assert!(p.interval.0 <= p.proportion_correct && p.proportion_correct <= p.interval.1);
//! ```

use std::sync::OnceLock;

use super::oddity::{OddityModel, CHANCE, MAX_D_PRIME};

/// The proportion correct at which the threshold is taken: halfway from
/// chance (1/3) to perfect.
pub const THRESHOLD_PROPORTION: f64 = 2.0 / 3.0;

/// The largest lapse rate λ the fit allows: Wichmann & Hill's (2001a,
/// *Perception & Psychophysics* 63(8), 1293–1313) constraint λ ∈ [0, 0.06],
/// also the range Palamedes' `PAL_PFML_Fit` is commonly given as
/// `lapseLimits` (Prins 2012, *J. Vision* 12(6):25). psignifit 4 (Schütt
/// et al. 2016, *Vision Res.* 122) instead puts a Beta(1, 10) prior on λ
/// (`getStandardPriors.m`), which gives λ > 0.06 a probability of 0.54:
/// a maximum-likelihood fit needs a hard bound, and 0.06 is the published one.
pub const LAPSE_MAX: f64 = 0.06;

/// ℓ differences below this are not told apart when deciding whether the
/// maximum is at σ → 0 (the 95 % interval's cut is 1.92).
const FLAT: f64 = 1e-6;

/// One condition of an observer: an approximation shown `trials` times,
/// `correct` of them right, at colour difference `delta_e00` (CIEDE2000)
/// from the original.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Condition {
    pub delta_e00: f64,
    pub correct: u32,
    pub trials: u32,
}

/// Why there is no fit.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ThresholdError {
    #[error("no conditions: give at least one (ΔE00, correct, trials)")]
    NoConditions,
    #[error("condition {index}: ΔE00 = {delta_e00}: give a finite colour difference, 0 or a positive normal number")]
    ColourDifference { index: usize, delta_e00: f64 },
    #[error(
        "condition {index}: {correct} correct of {trials} trials: there cannot be more correct trials than trials"
    )]
    MoreCorrectThanTrials { index: usize, correct: u32, trials: u32 },
    #[error("no trials in any condition: a threshold needs at least one")]
    NoTrials,
    #[error(
        "no trials at a colour difference above 0: d′ = ΔE00/σ is 0 whatever σ is, so the trials say nothing of σ"
    )]
    NoColourDifference,
    #[error("ΔE00 = {0}: give a finite colour difference ≥ 0 to predict at")]
    PredictAt(f64),
    #[error("confidence {0}: give a level strictly between 0 and 1 (0.95 for a 95 % interval)")]
    Confidence(f64),
}

/// Where the likelihood is largest.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Maximum {
    /// At a finite, positive σ̂.
    Interior,
    /// As σ → 0: every trial at a positive ΔE00 was right. σ̂ = 0; the
    /// interval's lower end is 0, its upper end finite.
    SigmaZero,
    /// As σ → ∞ (sensitivity 0): the data are no better than chance. No
    /// finite σ̂ or threshold; the interval has a finite lower end and no
    /// upper one.
    SigmaUnbounded,
}

/// The deviance of the fit against the saturated model.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct GoodnessOfFit {
    /// D = 2(ℓ_saturated − ℓ̂) ≥ 0.
    pub deviance: f64,
    /// Conditions with trials, less the two parameters fitted (σ and λ),
    /// at least 0.
    pub degrees_of_freedom: u32,
    /// P(χ²_df ≥ D); `None` when df = 0: the fit has no degrees of freedom
    /// left to test.
    pub p_value: Option<f64>,
}

/// σ of one observer (or a pool), its threshold, and how well d′ = ΔE00/σ fits.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ThresholdFit {
    pub model: OddityModel,
    /// The confidence of the intervals (0.95 for 95 %).
    pub confidence: f64,
    pub maximum: Maximum,
    /// σ̂ in ΔE00 units; 0 at [`Maximum::SigmaZero`], `None` (unbounded)
    /// at [`Maximum::SigmaUnbounded`].
    pub sigma: Option<f64>,
    /// The profile-likelihood interval of σ: (lower end ≥ 0, upper end),
    /// the upper end `None` when the data set no finite bound.
    pub sigma_interval: (f64, Option<f64>),
    /// d′ at [`THRESHOLD_PROPORTION`] under `model`.
    pub d_prime_at_threshold: f64,
    /// The ΔE00 at 2/3 correct, σ̂ · d′(2/3); `None` when σ̂ is unbounded.
    pub threshold: Option<f64>,
    /// σ's interval times d′(2/3).
    pub threshold_interval: (f64, Option<f64>),
    /// λ̂, the lapse rate fitted with σ: the fraction of trials missed at
    /// differences far above threshold (the curve's ceiling is 1 − λ̂).
    pub lapse: f64,
    /// λ's profile-likelihood interval (σ profiled out), within
    /// [0, `lapse_max`].
    pub lapse_interval: (f64, f64),
    /// The bound of λ, [`LAPSE_MAX`].
    pub lapse_max: f64,
    /// What the likelihood leaves at a bound, in words (σ's interval
    /// reaching 0 or without an upper end, λ̂ at its bound); empty when
    /// nothing is.
    pub at_bounds: Vec<String>,
    /// ℓ̂, the log-likelihood at (σ̂, λ̂) (its supremum at the ends).
    pub log_likelihood: f64,
    pub goodness_of_fit: GoodnessOfFit,
}

/// The proportion correct the fit predicts at a colour difference.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Prediction {
    pub delta_e00: f64,
    /// 1/3 + (2/3 − λ̂)·F(ΔE00 / σ̂), F = (Pc − 1/3)/(2/3) under the model
    /// (1/3 when σ̂ is unbounded, 1 − λ̂ when it is 0 and ΔE00 > 0).
    pub proportion_correct: f64,
    /// The same at the ends of σ's and λ's intervals: (σ_upper with
    /// λ_upper, σ_lower with λ_lower). Pc falls with σ and with λ, so this
    /// holds Pc over the box of the two intervals.
    pub interval: (f64, f64),
}

impl ThresholdFit {
    /// The proportion correct (percent = 100 ×) predicted at `delta_e00`,
    /// with the interval σ's interval induces, e.g. for an approximation
    /// that could not be shown.
    pub fn predict(&self, delta_e00: f64) -> Result<Prediction, ThresholdError> {
        if !(delta_e00.is_finite() && delta_e00 >= 0.0) {
            return Err(ThresholdError::PredictAt(delta_e00));
        }
        // No difference, or σ unbounded: chance; σ = 0: the limit, F = 1.
        let pc = |sigma: Option<f64>, lapse: f64| -> f64 {
            let f = match sigma {
                Some(s) if delta_e00 > 0.0 => {
                    if s == 0.0 {
                        1.0
                    } else {
                        (self.model.proportion_correct(delta_e00 / s) - CHANCE) / (1.0 - CHANCE)
                    }
                }
                _ => 0.0,
            };
            with_lapse(f, lapse)
        };
        Ok(Prediction {
            delta_e00,
            proportion_correct: pc(self.sigma, self.lapse),
            interval: (
                pc(self.sigma_interval.1, self.lapse_interval.1),
                pc(Some(self.sigma_interval.0), self.lapse_interval.0),
            ),
        })
    }
}

/// σ of d′ = ΔE00/σ fitted to `conditions` under `model` by maximum
/// likelihood, with profile-likelihood intervals at `confidence` (0.95 for
/// 95 %).
pub fn fit(conditions: &[Condition], model: OddityModel, confidence: f64) -> Result<ThresholdFit, ThresholdError> {
    if !(confidence > 0.0 && confidence < 1.0) {
        return Err(ThresholdError::Confidence(confidence));
    }
    let data = Prepared::new(conditions, model)?;
    let cut = chi_square_1_quantile(confidence) / 2.0;
    let grid = data.grid();

    // The maximum, in u = ln s (u = −∞ is s = 0, σ = ∞; u = +∞ is σ → 0,
    // where ℓ has the value it keeps beyond the grid's flat end).
    let ell_zero = data.ell(f64::INFINITY);
    let mut best = 0;
    for (i, &(_, l)) in grid.iter().enumerate() {
        if l > grid[best].1 {
            best = i;
        }
    }
    let (u_hat, ell_hat, maximum) = if ell_zero >= grid[best].1 - FLAT {
        (f64::INFINITY, ell_zero, Maximum::SigmaZero)
    } else if best == 0 {
        (f64::NEG_INFINITY, grid[0].1, Maximum::SigmaUnbounded)
    } else {
        let (mut u, mut l) = grid[best];
        let sides = [(best - 1, best), (best, (best + 1).min(grid.len() - 1))];
        for (a, b) in sides {
            if a < b {
                let (u_side, l_side) = golden_section_max(|t| data.ell(along(grid[a].0, grid[b].0, t)));
                let u_side = along(grid[a].0, grid[b].0, u_side);
                if l_side > l {
                    (u, l) = (u_side, l_side);
                }
            }
        }
        (u, l, Maximum::Interior)
    };

    // The points in order, with the maximum among them.
    let mut points: Vec<(f64, f64)> = grid.iter().copied().filter(|&(u, _)| u != u_hat).collect();
    let at = points.partition_point(|&(u, _)| u < u_hat);
    points.insert(at, (u_hat, ell_hat));
    let target = ell_hat - cut;
    let crossing = |lo: usize, hi: usize, rising: bool| -> f64 {
        let (a, b) = (points[lo].0, points[hi].0);
        let t = bisect(|t| {
            let above = data.ell(along(a, b, t)) >= target;
            above == rising
        });
        along(a, b, t)
    };
    // Lower end of u (upper end of σ): the first point from below at the cut.
    let first = points.iter().position(|&(_, l)| l >= target).unwrap_or(at);
    let u_lower = if first == 0 {
        f64::NEG_INFINITY
    } else if points[first].0 == f64::INFINITY {
        points[first - 1].0
    } else {
        crossing(first - 1, first, true)
    };
    // Upper end of u (lower end of σ): the last point from above at the cut.
    let last = points.iter().rposition(|&(_, l)| l >= target).unwrap_or(at);
    let u_upper = if last == points.len() - 1 {
        f64::INFINITY
    } else {
        crossing(last, last + 1, false)
    };

    let sigma_of = |u: f64| (-u).exp();
    let sigma = (maximum != Maximum::SigmaUnbounded).then(|| sigma_of(u_hat));
    let sigma_interval = (
        sigma_of(u_upper),
        (u_lower > f64::NEG_INFINITY).then(|| sigma_of(u_lower)),
    );
    let d_thr = data.curve.d_prime_at_threshold;

    // λ̂ at σ̂, and λ's profile interval (σ profiled out), within [0, LAPSE_MAX].
    let lapse = data.profile(u_hat).1;
    let grid_u: Vec<f64> = grid
        .iter()
        .map(|&(u, _)| u)
        .chain(std::iter::once(f64::INFINITY))
        .collect();
    let grid_f: Vec<Vec<f64>> = grid_u.iter().map(|&u| data.sensory(u)).collect();
    let inside = |l: f64| data.ell_of_lapse(&grid_u, &grid_f, l) >= target;
    let lapse_end = |end: f64| -> f64 {
        if inside(end) {
            return end;
        }
        // Bisection to 2⁻²⁰ of the way (6·10⁻⁸ in λ at most), far below
        // what trials resolve.
        let (mut a, mut b) = (lapse, end);
        for _ in 0..20 {
            let mid = 0.5 * (a + b);
            if inside(mid) {
                a = mid;
            } else {
                b = mid;
            }
        }
        0.5 * (a + b)
    };
    let lapse_interval = (lapse_end(0.0), lapse_end(LAPSE_MAX));

    let threshold_interval = (sigma_interval.0 * d_thr, sigma_interval.1.map(|s| s * d_thr));
    let mut at_bounds = Vec::new();
    if sigma_interval.0 == 0.0 {
        at_bounds.push(format!(
            "σ's interval reaches 0: the likelihood is flat as σ → 0 (every condition at a visible ΔE00 as near its \
             ceiling as lapses allow), so the trials only bound the threshold above, ΔE00 ≤ {}; show smaller \
             differences to measure it",
            threshold_interval.1.map_or("∞".into(), |t| format!("{t:.3}"))
        ));
    }
    if sigma_interval.1.is_none() {
        at_bounds.push(format!(
            "σ's interval has no upper end: the likelihood is flat as σ → ∞ (no better than chance), so the trials \
             only bound the threshold below, ΔE00 ≥ {:.3}; show larger differences to measure it",
            threshold_interval.0
        ));
    }
    if lapse >= LAPSE_MAX {
        at_bounds.push(format!(
            "the lapse rate is at its bound, λ = {LAPSE_MAX}: the trials at the largest differences miss more often \
             than lapses allow, and σ takes up the rest"
        ));
    }
    Ok(ThresholdFit {
        model,
        confidence,
        maximum,
        sigma,
        sigma_interval,
        d_prime_at_threshold: d_thr,
        threshold: sigma.map(|s| s * d_thr),
        threshold_interval,
        lapse,
        lapse_interval,
        lapse_max: LAPSE_MAX,
        at_bounds,
        log_likelihood: ell_hat,
        goodness_of_fit: data.goodness_of_fit(u_hat, lapse),
    })
}

/// [`fit`] under both oddity models, in the order of [`OddityModel::ALL`].
pub fn fit_both(conditions: &[Condition], confidence: f64) -> Result<[ThresholdFit; 2], ThresholdError> {
    Ok([
        fit(conditions, OddityModel::ALL[0], confidence)?,
        fit(conditions, OddityModel::ALL[1], confidence)?,
    ])
}

/// A condition ready for ℓ: ln ΔE00 (−∞ at 0), the counts, ln C(n, k).
struct Row {
    ln_delta_e: f64,
    correct: f64,
    trials: f64,
    ln_choose: f64,
}

/// The checked conditions with trials, and the model's curve.
struct Prepared {
    curve: &'static Curve,
    rows: Vec<Row>,
    /// The smallest and largest positive ΔE00 with trials.
    delta_e_range: (f64, f64),
}

/// ln Γ(x + 1) = ln x!.
fn ln_factorial(x: f64) -> f64 {
    libm::lgamma(x + 1.0)
}

impl Prepared {
    fn new(conditions: &[Condition], model: OddityModel) -> Result<Prepared, ThresholdError> {
        if conditions.is_empty() {
            return Err(ThresholdError::NoConditions);
        }
        let mut rows = Vec::with_capacity(conditions.len());
        let mut range = (f64::INFINITY, 0.0f64);
        let mut any_trials = false;
        for (index, c) in conditions.iter().enumerate() {
            let d = c.delta_e00;
            // Subnormal differences are refused: 1/ΔE would overflow.
            if !(d == 0.0 || (d.is_normal() && d > 0.0)) {
                return Err(ThresholdError::ColourDifference { index, delta_e00: d });
            }
            if c.correct > c.trials {
                return Err(ThresholdError::MoreCorrectThanTrials {
                    index,
                    correct: c.correct,
                    trials: c.trials,
                });
            }
            if c.trials == 0 {
                continue;
            }
            any_trials = true;
            if d > 0.0 {
                range = (range.0.min(d), range.1.max(d));
            }
            let (k, n) = (f64::from(c.correct), f64::from(c.trials));
            rows.push(Row {
                ln_delta_e: d.ln(),
                correct: k,
                trials: n,
                ln_choose: ln_factorial(n) - ln_factorial(k) - ln_factorial(n - k),
            });
        }
        if !any_trials {
            return Err(ThresholdError::NoTrials);
        }
        if range.1 == 0.0 {
            return Err(ThresholdError::NoColourDifference);
        }
        Ok(Prepared {
            curve: Curve::of(model),
            rows,
            delta_e_range: range,
        })
    }

    /// d′ of a row at u = ln s: ΔE · s, 0 when either is 0.
    fn d_prime(row: &Row, u: f64) -> f64 {
        if row.ln_delta_e == f64::NEG_INFINITY || u == f64::NEG_INFINITY {
            0.0
        } else {
            (row.ln_delta_e + u).exp()
        }
    }

    /// F of each row at u = ln s = −ln σ (u = −∞: σ = ∞, F = 0; u = +∞:
    /// σ → 0, F at its ceiling for ΔE00 > 0): the model's part of Pc,
    /// (Pc(d′) − 1/3)/(2/3), from the spline.
    fn sensory(&self, u: f64) -> Vec<f64> {
        self.rows
            .iter()
            .map(|r| (self.curve.pc(Self::d_prime(r, u)) - CHANCE) / (1.0 - CHANCE))
            .collect()
    }

    /// ℓ at the rows' F and lapse rate λ.
    fn ell_of(&self, f: &[f64], lapse: f64) -> f64 {
        self.rows
            .iter()
            .zip(f)
            .map(|(r, &f)| {
                let p = with_lapse(f, lapse);
                r.ln_choose + xlny(r.correct, p) + xlny(r.trials - r.correct, 1.0 - p)
            })
            .sum()
    }

    /// ℓ at u and a fixed λ.
    fn ell_at_lapse(&self, u: f64, lapse: f64) -> f64 {
        self.ell_of(&self.sensory(u), lapse)
    }

    /// λ̃(u), the λ in [0, [`LAPSE_MAX`]] that maximises ℓ at u. p is
    /// affine in λ, so ℓ is concave in λ: its slope
    /// ∂ℓ/∂λ = Σ F [(n − k)/(1 − p) − k/p] falls with λ, and
    /// ∂²ℓ/∂λ² = −Σ F² [k/p² + (n − k)/(1 − p)²]. The root of the slope by
    /// Newton's method kept inside a bisection bracket (Press et al. 2007,
    /// §9.4, `rtsafe`), or an end where the slope does not change sign.
    fn lapse_at(&self, f: &[f64]) -> f64 {
        let slopes = |lapse: f64| -> (f64, f64) {
            self.rows
                .iter()
                .zip(f)
                .filter(|&(_, &f)| f > 0.0)
                .fold((0.0, 0.0), |(d1, d2), (r, &f)| {
                    let p = with_lapse(f, lapse);
                    let (wrong, right) = (r.trials - r.correct, r.correct);
                    (
                        d1 + f * (wrong / (1.0 - p) - right / p),
                        d2 - f * f * (right / (p * p) + wrong / ((1.0 - p) * (1.0 - p))),
                    )
                })
        };
        if slopes(0.0).0 <= 0.0 {
            return 0.0;
        }
        if slopes(LAPSE_MAX).0 >= 0.0 {
            return LAPSE_MAX;
        }
        let (mut lo, mut hi) = (0.0, LAPSE_MAX);
        let mut lapse = 0.5 * LAPSE_MAX;
        for _ in 0..100 {
            let (d1, d2) = slopes(lapse);
            if d1 > 0.0 {
                lo = lapse;
            } else {
                hi = lapse;
            }
            let newton = lapse - d1 / d2;
            let next = if d2 < 0.0 && newton > lo && newton < hi {
                newton
            } else {
                0.5 * (lo + hi)
            };
            if (next - lapse).abs() <= 1e-15 || hi - lo <= 1e-15 {
                return next;
            }
            lapse = next;
        }
        lapse
    }

    /// The profile log-likelihood of σ at u = ln s = −ln σ, λ profiled
    /// out: (max over λ of ℓ(u, λ), that λ).
    fn profile(&self, u: f64) -> (f64, f64) {
        let f = self.sensory(u);
        let lapse = self.lapse_at(&f);
        (self.ell_of(&f, lapse), lapse)
    }

    /// The profile log-likelihood of σ at u (what the fit maximises).
    fn ell(&self, u: f64) -> f64 {
        self.profile(u).0
    }

    /// The profile log-likelihood of λ, σ profiled out: the largest ℓ at
    /// `lapse` over the grid's u (both ends included; `grid_f` is
    /// [`Self::sensory`] at each), refined by golden-section search on the
    /// grid steps either side of the best.
    fn ell_of_lapse(&self, grid_u: &[f64], grid_f: &[Vec<f64>], lapse: f64) -> f64 {
        let values: Vec<f64> = grid_f.iter().map(|f| self.ell_of(f, lapse)).collect();
        let mut best = 0;
        for (i, &l) in values.iter().enumerate() {
            if l > values[best] {
                best = i;
            }
        }
        let mut top = values[best];
        for (a, b) in [(best.saturating_sub(1), best), (best, (best + 1).min(grid_u.len() - 1))] {
            if a < b {
                // To 10⁻⁵ of a grid step: ℓ is flat at its maximum, so
                // its value there is found to far below the cut's precision.
                let (_, l) = golden_section_max_to(|t| self.ell_at_lapse(along(grid_u[a], grid_u[b], t), lapse), 1e-5);
                top = top.max(l);
            }
        }
        top
    }

    /// (u, ℓ(u)) at s = 0 and on the grid: s spaced 5 % (0.05 in ln s) from
    /// where the largest d′ is 10⁻³ to where the smallest is [`MAX_D_PRIME`].
    fn grid(&self) -> Vec<(f64, f64)> {
        const STEP: f64 = 0.05;
        let (lo, hi) = self.delta_e_range;
        let u_start = 1e-3f64.ln() - hi.ln();
        let u_end = MAX_D_PRIME.ln() - lo.ln();
        let steps = ((u_end - u_start) / STEP).ceil().max(1.0) as usize;
        let mut grid = Vec::with_capacity(steps + 2);
        grid.push((f64::NEG_INFINITY, self.ell(f64::NEG_INFINITY)));
        for i in 0..=steps {
            let u = u_start + (u_end - u_start) * i as f64 / steps as f64;
            grid.push((u, self.ell(u)));
        }
        grid
    }

    fn goodness_of_fit(&self, u_hat: f64, lapse: f64) -> GoodnessOfFit {
        let f = self.sensory(u_hat);
        let deviance: f64 = self
            .rows
            .iter()
            .zip(&f)
            .map(|(r, &f)| {
                // At σ → 0 the sensory part is 1 (the ceiling only keeps ℓ finite).
                let f = if u_hat == f64::INFINITY && f > 0.0 { 1.0 } else { f };
                let p = with_lapse(f, lapse);
                let (k, n) = (r.correct, r.trials);
                let failures = n - k;
                let term = |count: f64, expected: f64| {
                    if count == 0.0 {
                        0.0
                    } else {
                        count * (count / expected).ln()
                    }
                };
                2.0 * (term(k, n * p) + term(failures, n * (1.0 - p)))
            })
            .sum();
        // D ≥ 0 exactly; rounding can leave a few ulps below.
        let deviance = deviance.max(0.0);
        // Two parameters fitted, σ and λ.
        let degrees_of_freedom = self.rows.len().saturating_sub(2) as u32;
        GoodnessOfFit {
            deviance,
            degrees_of_freedom,
            p_value: (degrees_of_freedom > 0).then(|| chi_square_survival(deviance, degrees_of_freedom)),
        }
    }
}

/// Pc with a lapse rate: 1/3 + (1 − 1/3 − λ)·F, F the model's part
/// (Wichmann & Hill 2001a's ψ = γ + (1 − γ − λ)F, γ = 1/3).
fn with_lapse(f: f64, lapse: f64) -> f64 {
    CHANCE + (1.0 - CHANCE - lapse) * f
}

/// x ln y with 0 · ln 0 = 0.
fn xlny(x: f64, y: f64) -> f64 {
    if x == 0.0 {
        0.0
    } else {
        x * y.ln()
    }
}

/// The point at fraction t ∈ [0, 1] of the way from u = a to u = b. From
/// u = −∞ (s = 0) the way is linear in s, elsewhere in u = ln s. An
/// infinite b (σ → 0, whose ℓ is flat) stays at a.
fn along(a: f64, b: f64, t: f64) -> f64 {
    if b == f64::INFINITY {
        a
    } else if a == f64::NEG_INFINITY {
        (t * b.exp()).ln()
    } else {
        a + t * (b - a)
    }
}

/// The maximum of f on [0, 1] by golden-section search (Press et al. 2007,
/// §10.2), with the ends as candidates: (t, f(t)).
fn golden_section_max(f: impl Fn(f64) -> f64) -> (f64, f64) {
    golden_section_max_to(f, 1e-13)
}

/// [`golden_section_max`] until the bracket is narrower than `tolerance`.
fn golden_section_max_to(f: impl Fn(f64) -> f64, tolerance: f64) -> (f64, f64) {
    let ratio = (5.0f64.sqrt() - 1.0) / 2.0;
    let (mut a, mut b) = (0.0f64, 1.0f64);
    let mut c = b - ratio * (b - a);
    let mut d = a + ratio * (b - a);
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..80 {
        if fc >= fd {
            b = d;
            d = c;
            fd = fc;
            c = b - ratio * (b - a);
            fc = f(c);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + ratio * (b - a);
            fd = f(d);
        }
        if b - a < tolerance {
            break;
        }
    }
    let mut best = if fc >= fd { (c, fc) } else { (d, fd) };
    for t in [0.0, 1.0] {
        let ft = f(t);
        if ft > best.1 {
            best = (t, ft);
        }
    }
    best
}

/// The t ∈ [0, 1] where `past(t)` turns from false to true (`past(0)`
/// false, `past(1)` true), by bisection to the last bits of a double.
fn bisect(past: impl Fn(f64) -> bool) -> f64 {
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if past(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    0.5 * (lo + hi)
}

/// Pc(d′) of one model as a clamped cubic spline (module doc,
/// "Approximation"), and d′ at the threshold.
struct Curve {
    values: Vec<f64>,
    /// The spline's second derivatives at the knots.
    second: Vec<f64>,
    d_prime_at_threshold: f64,
}

/// Knot spacing in d′.
const KNOT_SPACING: f64 = 0.05;

/// The largest p the fit uses. It keeps ln(1 − p) finite; 1 − Pc below it
/// is not resolved by the integrals (see [`super::oddity`]'s accuracy). A
/// failure where the model says 1 − Pc < 10⁻⁹ costs ln 10⁻⁹ ≈ −20.7 in ℓ,
/// ten times the 95 % interval's cut of 1.92, so no σ̂ or interval end can
/// lie where the ceiling acts unless the data allow it anyway.
const P_CEILING: f64 = 1.0 - 1e-9;

impl Curve {
    fn of(model: OddityModel) -> &'static Curve {
        static DIFFERENCING: OnceLock<Curve> = OnceLock::new();
        static INDEPENDENT: OnceLock<Curve> = OnceLock::new();
        let cell = match model {
            OddityModel::Differencing => &DIFFERENCING,
            OddityModel::IndependentObservation => &INDEPENDENT,
        };
        cell.get_or_init(|| Curve::build(model))
    }

    fn build(model: OddityModel) -> Curve {
        let n = (MAX_D_PRIME / KNOT_SPACING).round() as usize + 1;
        let h = KNOT_SPACING;
        // Pc(0) is chance exactly (the three stimuli are alike).
        let values: Vec<f64> = (0..n)
            .map(|i| {
                if i == 0 {
                    CHANCE
                } else {
                    model.proportion_correct(i as f64 * h)
                }
            })
            .collect();
        let slope_end = (3.0 * values[n - 1] - 4.0 * values[n - 2] + values[n - 3]) / (2.0 * h);
        // The clamped spline's equations (Press et al. 2007, §3.3) for the
        // second derivatives M, tridiagonal: diagonal 2, 4, …, 4, 2, off
        // diagonals 1; solved by the Thomas algorithm.
        let mut rhs = vec![0.0; n];
        rhs[0] = 6.0 / h * ((values[1] - values[0]) / h);
        for i in 1..n - 1 {
            rhs[i] = 6.0 * (values[i + 1] - 2.0 * values[i] + values[i - 1]) / (h * h);
        }
        rhs[n - 1] = 6.0 / h * (slope_end - (values[n - 1] - values[n - 2]) / h);
        let diagonal = |i: usize| if i == 0 || i == n - 1 { 2.0 } else { 4.0 };
        let mut upper = vec![0.0; n];
        let mut second = vec![0.0; n];
        upper[0] = 1.0 / diagonal(0);
        second[0] = rhs[0] / diagonal(0);
        for i in 1..n {
            let m = diagonal(i) - upper[i - 1];
            upper[i] = 1.0 / m;
            second[i] = (rhs[i] - second[i - 1]) / m;
        }
        for i in (0..n - 1).rev() {
            second[i] -= upper[i] * second[i + 1];
        }
        Curve {
            values,
            second,
            d_prime_at_threshold: model.d_prime(THRESHOLD_PROPORTION),
        }
    }

    /// Pc(d) (d ≥ 0), held at its value at [`MAX_D_PRIME`] beyond it, and
    /// within [1/3, [`P_CEILING`]].
    fn pc(&self, d: f64) -> f64 {
        let n = self.values.len();
        let h = KNOT_SPACING;
        let x = d.abs() / h;
        let p = if x.is_nan() || x >= (n - 1) as f64 {
            self.values[n - 1]
        } else {
            let j = (x.floor() as usize).min(n - 2);
            let t = x - j as f64;
            let a = 1.0 - t;
            a * self.values[j]
                + t * self.values[j + 1]
                + ((a * a * a - a) * self.second[j] + (t * t * t - t) * self.second[j + 1]) * h * h / 6.0
        };
        p.clamp(CHANCE, P_CEILING)
    }
}

/// χ²₁'s quantile at `confidence`: the q with P(χ²₁ > q) = 1 − confidence,
/// using P(χ²₁ > q) = erfc(√(q/2)) (Abramowitz & Stegun 1964, 26.4.4), by
/// bisection.
fn chi_square_1_quantile(confidence: f64) -> f64 {
    let alpha = 1.0 - confidence;
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    while libm::erfc((hi / 2.0).sqrt()) > alpha && hi < 1e4 {
        hi *= 2.0;
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if libm::erfc((mid / 2.0).sqrt()) > alpha {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// P(χ²_df ≥ x) = Q(df/2, x/2), the regularised upper incomplete gamma
/// function, by Numerical Recipes' series (x < a + 1, for P = 1 − Q) and
/// continued fraction (x ≥ a + 1, modified Lentz) (Press et al. 2007, §6.2),
/// with ln Γ from `libm`. 1 at x ≤ 0, NaN for NaN or df = 0.
fn chi_square_survival(x: f64, df: u32) -> f64 {
    if x.is_nan() || df == 0 {
        return f64::NAN;
    }
    if x <= 0.0 {
        return 1.0;
    }
    if x == f64::INFINITY {
        return 0.0;
    }
    let (a, x) = (f64::from(df) / 2.0, x / 2.0);
    let prefactor = (a * x.ln() - x - libm::lgamma(a)).exp();
    const MAX_ITERATIONS: usize = 100_000;
    if x < a + 1.0 {
        // P(a, x) = e^{−x} x^a / Γ(a + 1) · Σ x^j / ((a + 1)…(a + j)).
        let mut term = 1.0 / a;
        let mut sum = term;
        let mut ap = a;
        for _ in 0..MAX_ITERATIONS {
            ap += 1.0;
            term *= x / ap;
            sum += term;
            if term.abs() < sum.abs() * f64::EPSILON {
                break;
            }
        }
        (1.0 - sum * prefactor).clamp(0.0, 1.0)
    } else {
        let tiny = f64::MIN_POSITIVE / f64::EPSILON;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..MAX_ITERATIONS {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let delta = d * c;
            h *= delta;
            if (delta - 1.0).abs() < f64::EPSILON {
                break;
            }
        }
        (prefactor * h).clamp(0.0, 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::random::SplitMix64;

    fn condition(delta_e00: f64, correct: u32, trials: u32) -> Condition {
        Condition {
            delta_e00,
            correct,
            trials,
        }
    }

    /// The study's design: six colour differences, 36 trials each.
    const STUDY_LEVELS: [f64; 6] = [0.5, 1.0, 1.5, 2.0, 3.0, 4.0];

    /// Counts drawn at `levels`, each trial correct with probability
    /// `pc[i]` (the model's Pc(ΔE_i/σ), computed once by the caller), from a
    /// uniform draw.
    fn simulate(levels: &[f64], pc: &[f64], trials: u32, rng: &mut SplitMix64) -> Vec<Condition> {
        levels
            .iter()
            .zip(pc)
            .map(|(&de, &p)| {
                let correct = (0..trials).filter(|_| rng.uniform() < p).count() as u32;
                condition(de, correct, trials)
            })
            .collect()
    }

    /// The profile ℓ at σ (λ profiled out), from the fit's own objective.
    fn ell_at(conditions: &[Condition], model: OddityModel, sigma: f64) -> f64 {
        Prepared::new(conditions, model).unwrap().ell(-sigma.ln())
    }

    /// ℓ at σ and a fixed lapse rate λ, from the fit's own objective.
    fn ell_at_lapse(conditions: &[Condition], model: OddityModel, sigma: f64, lapse: f64) -> f64 {
        Prepared::new(conditions, model)
            .unwrap()
            .ell_at_lapse(-sigma.ln(), lapse)
    }

    /// Two conditions and one at ΔE = 0, the probability of the data
    /// written out: C(3,2) p₁²(1 − p₁) · C(5,4) p₂⁴(1 − p₂) · C(3,1)(1/3)(2/3)²,
    /// with p = 1/3 + (2/3 − λ)(Pc − 1/3)/(2/3) and Pc from the model's
    /// integral, against the fit's ℓ (which uses the spline) with and
    /// without a lapse; and the fit's ℓ̂ against the same product at (σ̂, λ̂).
    #[test]
    fn the_log_likelihood_is_the_binomial_probability_of_the_data() {
        let data = [condition(1.0, 2, 3), condition(2.0, 4, 5), condition(0.0, 1, 3)];
        for model in OddityModel::ALL {
            let direct_lapse = |sigma: f64, lapse: f64| {
                let p = |d: f64| 1.0 / 3.0 + (2.0 / 3.0 - lapse) * (model.proportion_correct(d) - 1.0 / 3.0) * 1.5;
                let p1 = p(1.0 / sigma);
                let p2 = p(2.0 / sigma);
                let chance_part = 3.0 * (1.0 / 3.0) * (2.0 / 3.0) * (2.0 / 3.0);
                assert!((chance_part - 4.0 / 9.0f64).abs() < 1e-15);
                (3.0 * p1 * p1 * (1.0 - p1) * 5.0 * p2 * p2 * p2 * p2 * (1.0 - p2) * chance_part).ln()
            };
            for sigma in [0.4, 0.8, 2.0] {
                for lapse in [0.0, 0.03, LAPSE_MAX] {
                    let ours = ell_at_lapse(&data, model, sigma, lapse);
                    let direct = direct_lapse(sigma, lapse);
                    assert!(
                        (ours - direct).abs() < 1e-6,
                        "{model} σ {sigma} λ {lapse}: {ours} against {direct}"
                    );
                }
            }
            let f = fit(&data, model, 0.95).unwrap();
            let (s, lapse) = (f.sigma.unwrap(), f.lapse);
            assert!(
                (f.log_likelihood - direct_lapse(s, lapse)).abs() < 1e-6,
                "{model}: {f:?}"
            );
            // A maximum: 1 % either side in σ, and a step in λ within its bounds, are lower.
            assert!(
                direct_lapse(s * 1.01, lapse) < f.log_likelihood && direct_lapse(s / 1.01, lapse) < f.log_likelihood
            );
            for other in [lapse - 0.005, lapse + 0.005] {
                if (0.0..=LAPSE_MAX).contains(&other) {
                    assert!(direct_lapse(s, other) < f.log_likelihood, "{model}: λ {other}");
                }
            }
        }
    }

    #[test]
    fn the_spline_follows_the_integrals_to_a_millionth() {
        for model in OddityModel::ALL {
            let curve = Curve::of(model);
            let mut worst = 0.0f64;
            // Midway between knots, where a spline errs most, across [0, 15].
            for i in (0..300).step_by(7) {
                let d = (i as f64 + 0.5) * KNOT_SPACING;
                worst = worst.max((curve.pc(d) - model.proportion_correct(d)).abs());
            }
            println!("{model}: largest spline error {worst:e}");
            assert!(worst < 1e-6, "{model}: {worst}");
            assert!(
                (curve.d_prime_at_threshold - model.d_prime(THRESHOLD_PROPORTION)).abs() < 1e-12
                    && (model.proportion_correct(curve.d_prime_at_threshold) - 2.0 / 3.0).abs() < 1e-9
            );
        }
    }

    /// Published χ² table values (upper-tail 5 % and 1 % points, e.g.
    /// Abramowitz & Stegun 1964, Table 26.8), the lower 5 % point of 10 df
    /// (3.94030, the series branch), and df = 2, where Q = e^{−x/2} exactly.
    #[test]
    fn chi_square_survival_matches_the_tables() {
        let table = [
            (3.841_459, 1, 0.05, 1e-7),
            (11.0705, 5, 0.05, 1e-6),
            (20.0902, 8, 0.01, 1e-6),
            (6.634_897, 1, 0.01, 1e-7),
            (3.940_299, 10, 0.95, 1e-6),
        ];
        for (x, df, q, tolerance) in table {
            let ours = chi_square_survival(x, df);
            println!("Q(χ² = {x}, df = {df}) = {ours:.8} (table {q})");
            assert!((ours - q).abs() < tolerance, "χ² {x}, df {df}: {ours}, table {q}");
        }
        for x in [0.1, 1.0, 3.0, 10.0, 100.0] {
            let ours = chi_square_survival(x, 2);
            let exact = (-x / 2.0f64).exp();
            assert!((ours / exact - 1.0).abs() < 1e-12, "x {x}: {ours} against {exact}");
        }
        assert_eq!(chi_square_survival(0.0, 3), 1.0);
        assert_eq!(chi_square_survival(f64::INFINITY, 3), 0.0);
        assert!(chi_square_survival(f64::NAN, 3).is_nan());
        let q95 = chi_square_1_quantile(0.95);
        assert!((q95 - 3.841_458_820_694_124).abs() < 1e-12, "{q95}");
        assert!((chi_square_1_quantile(0.99) - 6.634_896_601_021_214).abs() < 1e-11);
    }

    /// Simulated observers of known σ, through the simulated observer's own
    /// decision rule (not the integral), 3 600 trials at each of six
    /// differences: σ̂ within 4 % of the truth, the truth inside the interval,
    /// and the interval's ends where ℓ has fallen by χ²₁(0.95)/2.
    #[test]
    fn simulated_observers_of_known_sigma_are_recovered() {
        use super::super::design::block_order;
        use super::super::observer::SimulatedObserver;
        let sigma = 0.8;
        for (model, seed) in OddityModel::ALL.into_iter().zip([61u64, 62]) {
            let observer = SimulatedObserver::new(sigma, model).unwrap();
            let mut rng = SplitMix64(seed);
            let conditions: Vec<Condition> = STUDY_LEVELS
                .iter()
                .enumerate()
                .map(|(i, &de)| {
                    let correct = (0..6)
                        .map(|b| {
                            let block = block_order(seed * 100 + (i * 6 + b) as u64, 100).unwrap();
                            observer.run_block(&block, de / observer.sigma(), &mut rng)
                        })
                        .sum();
                    condition(de, correct, 3_600)
                })
                .collect();
            let f = fit(&conditions, model, 0.95).unwrap();
            let s = f.sigma.unwrap();
            let (lo, hi) = (f.sigma_interval.0, f.sigma_interval.1.unwrap());
            println!(
                "{model}: σ̂ = {s:.4} ({lo:.4}–{hi:.4}), threshold {:.4} ΔE00, D = {:.2} on {} df, p = {:.3}",
                f.threshold.unwrap(),
                f.goodness_of_fit.deviance,
                f.goodness_of_fit.degrees_of_freedom,
                f.goodness_of_fit.p_value.unwrap()
            );
            assert_eq!(f.maximum, Maximum::Interior);
            assert!(f.at_bounds.is_empty(), "{model}: {:?}", f.at_bounds);
            assert!(f.lapse < 0.01, "{model}: λ̂ {} of an observer who never lapses", f.lapse);
            assert!((s / sigma - 1.0).abs() < 0.04, "{model}: σ̂ {s}");
            assert!(lo < sigma && sigma < hi && hi / lo < 1.1, "{model}: {lo}–{hi}");
            for end in [lo, hi] {
                let drop = 2.0 * (f.log_likelihood - ell_at(&conditions, model, end));
                assert!((drop - 3.841_458_820_694_124).abs() < 1e-6, "{model}: {drop}");
            }
            let thr = f.threshold.unwrap();
            assert!((thr - s * model.d_prime(2.0 / 3.0)).abs() < 1e-9);
            assert!((f.threshold_interval.0 - lo * f.d_prime_at_threshold).abs() < 1e-12);
            // At the threshold the sensory part is halfway, so the
            // prediction is 2/3 less half the lapses, its interval around it.
            let at = f.predict(thr).unwrap();
            let expected = 2.0 / 3.0 - f.lapse / 2.0;
            assert!((at.proportion_correct - expected).abs() < 1e-7, "{at:?}, λ̂ {}", f.lapse);
            assert!(at.interval.0 < expected && expected < at.interval.1);
        }
    }

    /// Coverage of the 95 % profile interval: 1 000 simulated observers per
    /// model, the study's six differences × 36 trials, σ = 1 (d′ 0.5–4).
    /// The fraction whose interval holds the true σ is near 0.95 (binomial
    /// sd of the fraction: 0.007).
    #[test]
    fn profile_intervals_cover_the_true_sigma_at_their_level() {
        let sigma = 1.0;
        let observers = 1_000;
        for (model, seed) in OddityModel::ALL.into_iter().zip([2006u64, 2007]) {
            let mut rng = SplitMix64(seed);
            let pc: Vec<f64> = STUDY_LEVELS
                .iter()
                .map(|de| model.proportion_correct(de / sigma))
                .collect();
            let mut covered = 0;
            let mut unbounded = 0;
            for _ in 0..observers {
                let data = simulate(&STUDY_LEVELS, &pc, 36, &mut rng);
                let f = fit(&data, model, 0.95).unwrap();
                let (lo, hi) = f.sigma_interval;
                if hi.is_none() {
                    unbounded += 1;
                }
                if lo <= sigma && hi.is_none_or(|hi| sigma <= hi) {
                    covered += 1;
                }
            }
            let coverage = f64::from(covered) / f64::from(observers);
            println!(
                "{model}: {covered} of {observers} intervals cover σ = {sigma} ({coverage:.3}); {unbounded} unbounded"
            );
            assert!((0.92..=0.975).contains(&coverage), "{model}: coverage {coverage}");
        }
    }

    /// Issue 46: an observer right on every trial but one at every
    /// visible ΔE00 of the study's BLUE scene (8 bits; 35 of 36 at 2.151,
    /// 36 of 36 at 0.324, 0.326, 0.689 and 7.047) and near chance where the
    /// display shows the original's codes (ΔE00 0). Without a lapse rate
    /// the one miss must be a sensory one, Pc is held below 1 − 10⁻⁹ beyond
    /// d′ = 15, and ℓ is flat for every σ below 0.324/15 = 0.0216: the
    /// fit called that floor an interior σ̂ = 0.0216 [0, 0.060], a
    /// threshold of 0.050 ΔE00 set by the floor, not by the trials. With
    /// the lapse fitted the miss is a lapse (λ̂ = 1/180), σ's likelihood is
    /// flat as σ → 0, and the fit says so: σ̂ = 0, the threshold bounded
    /// above only, where the profile has fallen by χ²₁(0.95)/2.
    #[test]
    fn one_lapse_does_not_set_the_threshold() {
        let data = [
            condition(7.047, 36, 36),
            condition(2.151, 35, 36),
            condition(0.0, 12, 36),
            condition(0.326, 36, 36),
            condition(0.689, 36, 36),
            condition(0.324, 36, 36),
        ];
        for model in OddityModel::ALL {
            let f = fit(&data, model, 0.95).unwrap();
            println!(
                "{model}: {:?}, σ̂ {:?} [{}, {:?}], threshold {:?} [{}, {:?}]",
                f.maximum,
                f.sigma,
                f.sigma_interval.0,
                f.sigma_interval.1,
                f.threshold,
                f.threshold_interval.0,
                f.threshold_interval.1
            );
            assert_eq!(f.maximum, Maximum::SigmaZero, "{model}: {f:?}");
            assert_eq!((f.sigma, f.threshold, f.sigma_interval.0), (Some(0.0), Some(0.0), 0.0));
            let hi = f.sigma_interval.1.unwrap();
            // The upper end is where the trials put it, far above the floor.
            assert!(hi > 2.0 * 0.324 / MAX_D_PRIME, "{model}: σ ≤ {hi}");
            let drop = 2.0 * (f.log_likelihood - ell_at(&data, model, hi));
            assert!((drop - 3.841_458_820_694_124).abs() < 1e-6, "{model}: {drop}");
            // The miss is a lapse: one of the 180 trials at a visible ΔE00.
            assert!((f.lapse - 1.0 / 180.0).abs() < 1e-9, "{model}: λ̂ {}", f.lapse);
            // λ's interval, where ln λ − 180 λ (its profile, near enough)
            // has fallen by 1.92 from λ̂: about [0.0003, 0.024].
            let (lo, hi) = f.lapse_interval;
            assert!(0.0002 < lo && lo < 0.0004 && 0.023 < hi && hi < 0.025, "{model}: {f:?}");
            assert_eq!(f.lapse_max, LAPSE_MAX);
            // And the fit says, in words, that the trials only bound the threshold.
            assert_eq!(f.at_bounds.len(), 1, "{model}: {:?}", f.at_bounds);
            assert!(
                f.at_bounds[0].contains("reaches 0")
                    && f.at_bounds[0].contains(&format!("ΔE00 ≤ {:.3}", f.threshold_interval.1.unwrap())),
                "{model}: {:?}",
                f.at_bounds
            );
            // The curve's ceiling is 1 − λ̂.
            assert!((f.predict(7.047).unwrap().proportion_correct - (1.0 - f.lapse)).abs() < 1e-12);
        }
    }

    /// Counts of an observer who lapses: on a fraction 3λ/2 of trials it
    /// guesses (right one time in three), on the others it decides as
    /// `model` says, so P(correct) = (1 − 3λ/2)·Pc + λ/2 = 1/3 + (2/3 − λ)F,
    /// whose ceiling is 1 − λ. Drawn trial by trial: the lapse, then the guess
    /// or the model's own decision (from a uniform draw against Pc).
    fn simulate_lapsing(levels: &[f64], pc: &[f64], lapse: f64, trials: u32, rng: &mut SplitMix64) -> Vec<Condition> {
        levels
            .iter()
            .zip(pc)
            .map(|(&de, &p)| {
                let correct = (0..trials)
                    .filter(|_| {
                        if rng.uniform() < 1.5 * lapse {
                            rng.uniform() < 1.0 / 3.0
                        } else {
                            rng.uniform() < p
                        }
                    })
                    .count() as u32;
                condition(de, correct, trials)
            })
            .collect()
    }

    /// Observers who lapse at a known rate: 400 simulated observers per
    /// model and λ (0.02, 0.05), σ = 0.4 at the study's six differences
    /// × 36 trials (d′ 1.25–10, so the largest differences show the
    /// ceiling). σ's 95 % profile interval, λ profiled out, covers the
    /// true σ near 95 % of the time (binomial sd of the fraction: 0.011).
    #[test]
    fn lapsing_observers_sigma_intervals_cover_the_truth() {
        let sigma = 0.4;
        let observers = 400;
        for (model, seed) in OddityModel::ALL.into_iter().zip([4602u64, 4603]) {
            let pc: Vec<f64> = STUDY_LEVELS
                .iter()
                .map(|de| model.proportion_correct(de / sigma))
                .collect();
            for lapse in [0.02, 0.05] {
                let mut rng = SplitMix64(seed + (lapse * 1000.0) as u64);
                let mut covered = 0;
                let mut lapse_covered = 0;
                let mut lapse_sum = 0.0;
                for _ in 0..observers {
                    let data = simulate_lapsing(&STUDY_LEVELS, &pc, lapse, 36, &mut rng);
                    let f = fit(&data, model, 0.95).unwrap();
                    let (lo, hi) = f.sigma_interval;
                    if lo <= sigma && hi.is_none_or(|hi| sigma <= hi) {
                        covered += 1;
                    }
                    lapse_sum += f.lapse;
                    if f.lapse_interval.0 <= lapse && lapse <= f.lapse_interval.1 {
                        lapse_covered += 1;
                    }
                }
                let coverage = f64::from(covered) / f64::from(observers);
                let mean_lapse = lapse_sum / f64::from(observers);
                println!(
                    "{model}, λ = {lapse}: {covered} of {observers} intervals cover σ = {sigma} ({coverage:.3}); \
                     mean λ̂ {mean_lapse:.4}, λ's interval covers it {lapse_covered} times"
                );
                assert!(
                    (0.92..=0.98).contains(&coverage),
                    "{model}, λ {lapse}: coverage {coverage}"
                );
                // λ̂ on average near the truth, within 0.01: with 36 trials
                // a condition it is biased low (0.043 for 0.05, 0.019 for
                // 0.02 under differencing), as Wichmann & Hill (2001a) found
                // of fitted lapse rates; the bound at 0.06 cuts off the
                // high estimates, and a larger σ takes up some misses.
                assert!(
                    (mean_lapse - lapse).abs() < 0.01,
                    "{model}, λ {lapse}: mean λ̂ {mean_lapse}"
                );
            }
        }
    }

    #[test]
    fn at_chance_sigma_is_unbounded_and_so_is_the_threshold() {
        for model in OddityModel::ALL {
            for data in [
                vec![condition(1.0, 12, 36), condition(2.0, 12, 36), condition(4.0, 12, 36)],
                vec![condition(1.0, 5, 36), condition(3.0, 10, 36)],
            ] {
                let f = fit(&data, model, 0.95).unwrap();
                assert_eq!(f.maximum, Maximum::SigmaUnbounded, "{model}: {f:?}");
                assert_eq!((f.sigma, f.threshold), (None, None));
                assert_eq!((f.sigma_interval.1, f.threshold_interval.1), (None, None));
                assert!(
                    f.at_bounds.len() == 1 && f.at_bounds[0].contains("no upper end"),
                    "{model}: {:?}",
                    f.at_bounds
                );
                // At chance λ says nothing: ℓ at σ = ∞ does not depend on it.
                assert_eq!((f.lapse, f.lapse_interval), (0.0, (0.0, LAPSE_MAX)));
                let lower = f.sigma_interval.0;
                assert!(lower > 0.0 && lower.is_finite(), "{model}: {f:?}");
                let drop = 2.0 * (f.log_likelihood - ell_at(&data, model, lower));
                assert!((drop - 3.841_458_820_694_124).abs() < 1e-6, "{model}: {drop}");
                let p = f.predict(2.0).unwrap();
                assert_eq!(p.proportion_correct, CHANCE);
                assert!(
                    p.interval.0 == CHANCE && p.interval.1 > CHANCE && p.interval.1 < 1.0,
                    "{p:?}"
                );
            }
        }
    }

    /// Every trial right: σ̂ = 0, the interval from 0 to where
    /// Σ n ln Pc(ΔE/σ) = −χ²₁(0.95)/2, checked with the integral.
    #[test]
    fn all_correct_puts_sigma_at_zero_with_a_finite_upper_end() {
        let data = [condition(1.0, 36, 36), condition(2.0, 36, 36), condition(0.0, 12, 36)];
        for model in OddityModel::ALL {
            let f = fit(&data, model, 0.95).unwrap();
            assert_eq!(f.maximum, Maximum::SigmaZero, "{model}: {f:?}");
            assert_eq!((f.sigma, f.threshold), (Some(0.0), Some(0.0)));
            assert_eq!(f.sigma_interval.0, 0.0);
            let hi = f.sigma_interval.1.unwrap();
            let fall = 36.0 * (model.proportion_correct(1.0 / hi).ln() + model.proportion_correct(2.0 / hi).ln());
            assert!(
                (fall + 3.841_458_820_694_124 / 2.0).abs() < 1e-5,
                "{model}: σ ≤ {hi}, fall {fall}"
            );
            let p = f.predict(1.0).unwrap();
            assert_eq!((p.proportion_correct, p.interval.1), (1.0, 1.0));
            assert!(p.interval.0 > 0.9 && p.interval.0 < 1.0, "{p:?}");
        }
    }

    #[test]
    fn impossible_inputs_are_refused_with_what_to_do() {
        let m = OddityModel::Differencing;
        assert_eq!(fit(&[], m, 0.95), Err(ThresholdError::NoConditions));
        assert_eq!(fit(&[condition(1.0, 0, 0)], m, 0.95), Err(ThresholdError::NoTrials));
        assert_eq!(
            fit(&[condition(0.0, 10, 30), condition(2.0, 0, 0)], m, 0.95),
            Err(ThresholdError::NoColourDifference)
        );
        for bad in [f64::NAN, f64::INFINITY, -1.0, 1e-310] {
            let e = fit(&[condition(1.0, 20, 36), condition(bad, 20, 36)], m, 0.95).unwrap_err();
            assert!(matches!(e, ThresholdError::ColourDifference { index: 1, .. }), "{e}");
        }
        assert!(matches!(
            fit(&[condition(1.0, 37, 36)], m, 0.95),
            Err(ThresholdError::MoreCorrectThanTrials { index: 0, .. })
        ));
        for bad in [0.0, 1.0, 95.0, f64::NAN] {
            let e = fit(&[condition(1.0, 20, 36)], m, bad).unwrap_err();
            assert!(e.to_string().contains("0.95"), "{e}");
        }
        let f = fit(&[condition(1.0, 20, 36)], m, 0.95).unwrap();
        for bad in [f64::NAN, -0.5, f64::INFINITY] {
            assert!(f.predict(bad).is_err());
        }
        // One condition: nothing left to test the fit with.
        assert_eq!(f.goodness_of_fit.degrees_of_freedom, 0);
        assert_eq!(f.goodness_of_fit.p_value, None);
        assert!(f.goodness_of_fit.deviance < 1e-9, "{:?}", f.goodness_of_fit);
    }

    /// Counts at their expectation under σ = 1.25 (10⁶ trials each, the
    /// expected counts rounded to whole trials): D ≈ 0, p ≈ 1, σ̂ ≈ 1.25.
    #[test]
    fn expected_counts_fit_perfectly() {
        for model in OddityModel::ALL {
            let n = 1_000_000u32;
            let data: Vec<Condition> = STUDY_LEVELS
                .iter()
                .map(|&de| {
                    let k = (f64::from(n) * model.proportion_correct(de / 1.25)).round() as u32;
                    condition(de, k, n)
                })
                .collect();
            let f = fit(&data, model, 0.95).unwrap();
            let g = f.goodness_of_fit;
            println!(
                "{model}: σ̂ {:?}, D = {:e}, df {}, p = {:?}",
                f.sigma, g.deviance, g.degrees_of_freedom, g.p_value
            );
            assert!(g.deviance < 1e-4 && g.degrees_of_freedom == 4, "{model}: {g:?}");
            assert!(g.p_value.unwrap() > 0.999_999, "{model}: {g:?}");
            assert!((f.sigma.unwrap() - 1.25).abs() < 1e-4, "{model}: {f:?}");
        }
    }

    /// The study's N = 27 and 81 approximations could not be shown at
    /// 8 bits; their percent correct is predicted from the others.
    #[test]
    fn predictions_rise_with_the_colour_difference_and_hold_the_fit() {
        let data = [
            condition(0.6, 14, 36),
            condition(1.2, 17, 36),
            condition(2.4, 26, 36),
            condition(4.8, 35, 36),
        ];
        let both = fit_both(&data, 0.95).unwrap();
        assert_eq!(both.each_ref().map(|f| f.model), OddityModel::ALL);
        assert_eq!(both[1], fit(&data, OddityModel::IndependentObservation, 0.95).unwrap());
        for f in both {
            let mut last = CHANCE;
            for de in [0.0, 0.2, 0.6, 1.2, 2.4, 4.8] {
                let p = f.predict(de).unwrap();
                assert!(p.interval.0 <= p.proportion_correct && p.proportion_correct <= p.interval.1);
                assert!(p.proportion_correct >= last, "{}: {p:?}", f.model);
                last = p.proportion_correct;
            }
            assert_eq!(f.predict(0.0).unwrap().interval, (CHANCE, CHANCE));
            // A higher confidence, a wider interval around the same σ̂.
            let wider = fit(&data, f.model, 0.99).unwrap();
            let (lo, hi) = (f.sigma_interval.0, f.sigma_interval.1.unwrap());
            assert_eq!(wider.sigma, f.sigma);
            assert!(
                wider.sigma_interval.0 < lo && hi < wider.sigma_interval.1.unwrap(),
                "{wider:?}"
            );
            let drop = 2.0 * (wider.log_likelihood - ell_at(&data, f.model, wider.sigma_interval.0));
            assert!((drop - 6.634_896_601_021_214).abs() < 1e-6, "{drop}");
        }
    }
}
