//! An experiment's results: per observer and approximation (and pooled
//! over observers), the percent correct with its exact interval and d′
//! under both oddity models, beside the ΔE00 the display was asked to show
//! and showed ([`lightbooth_science::psychophysics::oddity::estimate`]).
//!
//! Trials with a frame dropped during the pie are not counted: the pie was
//! shown for less or more time than the design says, and the trial was
//! shown again at the end of the block. Their number is reported on every
//! row, a row with none counted included (it says so, with no estimate),
//! and the analysis warns when over
//! [`MAX_EXCLUDED_SHARE`](super::session::MAX_EXCLUDED_SHARE) of an
//! observer's trials are excluded.
//!
//! Each observer's **threshold** (and the pooled one) is fitted over all
//! approximations' counted trials with the model d′ = ΔE00/σ and a lapse
//! rate λ ∈ [0, 0.06] under both oddity models
//! ([`lightbooth_science::psychophysics::threshold`]): σ, the ΔE00 at 2/3
//! correct with their profile-likelihood intervals, λ̂ with its interval
//! and bound, what the likelihood leaves at a bound in words, the deviance against
//! the saturated model, and the percent correct predicted for every
//! approximation at the ΔE00 it was meant to have (the ones the display
//! could not show apart included). The ΔE00 of each condition is the one
//! the display was *measured* to show (the newest passing verification:
//! ΔE00 between the emitted original and approximation, each the mean over
//! the geometries measured) or, without one, the one the display profile
//! predicts the output method shows; `delta_e00_basis` says which.

use crate::export::csv_table::csv_table;
use serde::Serialize;

use super::session::excluded_warning;
use super::{parts, Experiments};
use crate::error::LabError;
use lightbooth_science::colorimetry::{ciede2000, Lab, Xyz};
use lightbooth_science::psychophysics::oddity::{estimate, OddityEstimate, OddityModel, CHANCE};
use lightbooth_science::psychophysics::threshold::{self, Condition, Prediction, ThresholdFit};
use lightbooth_store::ObservedTrial;

/// The confidence of every interval of the analysis.
pub const CONFIDENCE: f64 = 0.95;

/// The observer id of rows pooled over every observer.
pub const ALL_OBSERVERS: &str = "all";

/// One observer (or all) and one approximation.
#[derive(Clone, Debug, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ConditionResult {
    /// An observer id, or `all` pooled over observers.
    pub observer: String,
    pub approximation: String,
    /// Trials counted.
    pub trials: u32,
    pub correct: u32,
    /// Trials not counted: a frame was dropped during the pie (shown again).
    pub excluded: u32,
    /// Percent correct under the differencing model's estimate, with both
    /// models' d′ ([`OddityEstimate`] names its model); none when no trial
    /// is counted.
    #[cfg_attr(feature = "openapi", schema(value_type = Option<Object>))]
    pub differencing: Option<OddityEstimate>,
    #[cfg_attr(feature = "openapi", schema(value_type = Option<Object>))]
    pub independent_observation: Option<OddityEstimate>,
    /// ΔE00 (display white) between original and approximation as intended
    /// and as shown with the output method (the experiment's check).
    pub delta_e00_intended: f64,
    pub delta_e00_shown: f64,
    /// Whether the display could show the two apart with the output method.
    pub distinct: bool,
    pub distinct_at_8bit: bool,
}

/// Every condition of an experiment.
#[derive(Clone, Debug, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Analysis {
    pub experiment_id: i64,
    pub name: String,
    pub scene: String,
    pub target: String,
    pub output_method: String,
    pub confidence: f64,
    /// Proportion correct by guessing.
    pub chance: f64,
    pub observers: Vec<String>,
    pub sessions: usize,
    pub complete_sessions: usize,
    /// Per approximation, each observer's row and then the pooled row.
    pub rows: Vec<ConditionResult>,
    /// What is counted, in words.
    pub notes: Vec<String>,
    /// For the operator: observers with over
    /// [`MAX_EXCLUDED_SHARE`](super::session::MAX_EXCLUDED_SHARE) of their
    /// trials excluded, approximations with none counted.
    pub warnings: Vec<String>,
    /// `verified` (ΔE00 as the display was measured to show them) or
    /// `predicted` (as its profile predicts the output method shows them,
    /// no passing verification yet): the ΔE00 of every threshold fit.
    pub delta_e00_basis: String,
    /// Each observer's (then the pooled) threshold under each model.
    pub thresholds: Vec<ObserverThreshold>,
}

/// One observer's (or the pool's) threshold under one oddity model.
#[derive(Clone, Debug, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ObserverThreshold {
    /// An observer id, or `all`.
    pub observer: String,
    /// The oddity model, as [`OddityModel::name`] names it.
    pub model: String,
    /// The fit (σ, threshold, intervals, deviance); none when the trials
    /// cannot fit one (`not_fitted` says why).
    #[cfg_attr(feature = "openapi", schema(value_type = Option<Object>))]
    pub fit: Option<ThresholdFit>,
    /// The fitter's own reason there is no fit (as the CSV has it).
    pub not_fitted: Option<String>,
    /// Why there is no fit, as a sentence for a person (the pages and the
    /// CLI show this; see [`no_fit_sentence`]).
    pub no_fit: Option<String>,
    /// The conditions fitted: (ΔE00 on `delta_e00_basis`, correct, trials).
    #[cfg_attr(feature = "openapi", schema(value_type = Vec<Object>))]
    pub conditions: Vec<Condition>,
    /// Percent correct predicted per approximation at its intended ΔE00.
    pub predictions: Vec<ThresholdPrediction>,
}

/// The fit's percent correct for one approximation.
#[derive(Clone, Debug, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ThresholdPrediction {
    pub approximation: String,
    /// The ΔE00 the approximation was meant to have (before the display).
    pub delta_e00_intended: f64,
    /// Whether the display showed it apart from the original at 8 bits.
    pub distinct_at_8bit: bool,
    #[cfg_attr(feature = "openapi", schema(value_type = Object))]
    pub predicted: Prediction,
}

impl Experiments {
    /// The analysis of every trial stored so far.
    pub async fn analyze(&self, experiment_id: i64) -> Result<Analysis, LabError> {
        let e = self.get(experiment_id).await?;
        let (request, check) = parts(&e)?;
        let trials = self.store.trials_of_experiment(experiment_id).await?;
        let sessions = self.store.sessions_of_experiment(experiment_id).await?;
        let mut observers: Vec<String> = sessions.iter().map(|s| s.observer_id.clone()).collect();
        observers.sort();
        observers.dedup();
        let mut rows = Vec::new();
        for (i, approximation) in request.approximations.iter().enumerate() {
            let colour = &check.approximations[i];
            let groups = observers.iter().map(String::as_str).chain(
                // The pooled row only adds something with two observers or more.
                (observers.len() > 1).then_some(ALL_OBSERVERS),
            );
            for observer in groups {
                let of = |t: &&ObservedTrial| {
                    t.trial.approximation == *approximation && (observer == ALL_OBSERVERS || t.observer_id == observer)
                };
                let counted: Vec<&ObservedTrial> = trials
                    .iter()
                    .filter(of)
                    .filter(|t| !t.trial.dropped_in_stimulus)
                    .collect();
                let excluded = trials.iter().filter(of).filter(|t| t.trial.dropped_in_stimulus).count() as u32;
                let n = counted.len() as u32;
                if n == 0 && excluded == 0 {
                    continue;
                }
                let k = counted.iter().filter(|t| t.trial.correct).count() as u32;
                let est = |model| {
                    (n > 0)
                        .then(|| estimate(k, n, model, CONFIDENCE).map_err(|err| LabError::Internal(err.to_string())))
                        .transpose()
                };
                rows.push(ConditionResult {
                    observer: observer.to_string(),
                    approximation: approximation.clone(),
                    trials: n,
                    correct: k,
                    excluded,
                    differencing: est(OddityModel::Differencing)?,
                    independent_observation: est(OddityModel::IndependentObservation)?,
                    delta_e00_intended: colour.delta_e00_intended,
                    delta_e00_shown: colour.delta_e00_shown,
                    distinct: colour.distinct,
                    distinct_at_8bit: colour.distinct_at_8bit,
                });
            }
        }
        let excluded = trials.iter().filter(|t| t.trial.dropped_in_stimulus).count();
        let notes = vec![
            format!(
                "{} stored; {} had a frame dropped during the pie and {} not counted (each was shown again)",
                plural(trials.len(), "trial"),
                excluded,
                if excluded == 1 { "is" } else { "are" }
            ),
            format!(
                "intervals: exact (Clopper–Pearson) {:.0} % intervals of the proportion correct, mapped to d′ through each model",
                CONFIDENCE * 100.0
            ),
            "d′ models: differencing (sensR's triangle link) and independent observation (Versfeld, Dai & Green 1996)".into(),
        ];
        let mut warnings = Vec::new();
        for observer in &observers {
            let of: Vec<&ObservedTrial> = trials.iter().filter(|t| t.observer_id == *observer).collect();
            let excluded = of.iter().filter(|t| t.trial.dropped_in_stimulus).count();
            if let Some(w) = excluded_warning(excluded, of.len()) {
                warnings.push(format!("observer {observer}: {w}"));
            }
        }
        for r in rows.iter().filter(|r| r.trials == 0) {
            warnings.push(format!(
                "observer {}, {}: no trial counted ({} excluded for a dropped frame)",
                r.observer, r.approximation, r.excluded
            ));
        }
        let (delta_e00_basis, shown) = self
            .delta_e00_shown(experiment_id, &request.approximations, &check)
            .await?;
        let mut thresholds = Vec::new();
        let pools = observers
            .iter()
            .map(String::as_str)
            .chain((observers.len() > 1).then_some(ALL_OBSERVERS));
        for observer in pools {
            let conditions: Vec<Condition> = request
                .approximations
                .iter()
                .zip(&shown)
                .filter_map(|(approximation, &delta_e00)| {
                    let r = rows
                        .iter()
                        .find(|r| r.observer == observer && r.approximation == *approximation)?;
                    (r.trials > 0).then_some(Condition {
                        delta_e00,
                        correct: r.correct,
                        trials: r.trials,
                    })
                })
                .collect();
            for model in OddityModel::ALL {
                let fit = threshold::fit(&conditions, model, CONFIDENCE);
                let predictions = match &fit {
                    Ok(f) => request
                        .approximations
                        .iter()
                        .zip(&check.approximations)
                        .filter_map(|(name, c)| {
                            Some(ThresholdPrediction {
                                approximation: name.clone(),
                                delta_e00_intended: c.delta_e00_intended,
                                distinct_at_8bit: c.distinct_at_8bit,
                                predicted: f.predict(c.delta_e00_intended).ok()?,
                            })
                        })
                        .collect(),
                    Err(_) => Vec::new(),
                };
                let (fit, not_fitted, no_fit) = match fit {
                    Ok(f) => (Some(f), None, None),
                    Err(e) => (None, Some(e.to_string()), Some(no_fit_sentence(observer, &e))),
                };
                thresholds.push(ObserverThreshold {
                    observer: observer.to_string(),
                    model: model.name().to_string(),
                    fit,
                    not_fitted,
                    no_fit,
                    conditions: conditions.clone(),
                    predictions,
                });
            }
        }
        Ok(Analysis {
            delta_e00_basis,
            thresholds,
            experiment_id,
            name: e.name,
            scene: e.scene,
            target: e.target,
            output_method: e.output_method,
            confidence: CONFIDENCE,
            chance: CHANCE,
            observers,
            complete_sessions: sessions.iter().filter(|s| s.state == "complete").count(),
            sessions: sessions.len(),
            rows,
            notes,
            warnings,
        })
    }
}

impl Experiments {
    /// The ΔE00 each approximation was shown at, and on what basis: the
    /// newest passing verification's (emitted original against emitted
    /// approximation, each the mean XYZ over the geometries measured,
    /// relative to the verification's display white), else the display
    /// profile's prediction for the output method (the experiment's check).
    async fn delta_e00_shown(
        &self,
        experiment_id: i64,
        approximations: &[String],
        check: &super::StoredCheck,
    ) -> Result<(String, Vec<f64>), LabError> {
        let predicted = || {
            check
                .approximations
                .iter()
                .map(|c| c.delta_e00_shown)
                .collect::<Vec<f64>>()
        };
        let verifications = self.verifications(experiment_id).await?;
        let Some(v) = verifications
            .iter()
            .filter(|v| v.passed)
            .max_by(|a, b| a.created_at.total_cmp(&b.created_at))
        else {
            return Ok(("predicted".into(), predicted()));
        };
        let white = Xyz::from_array(v.white_xyz);
        let mean_emitted = |name: &str| -> Option<Xyz> {
            let of: Vec<[f64; 3]> = v
                .colours
                .iter()
                .filter(|c| c.colour == name)
                .map(|c| c.emitted_xyz)
                .collect();
            (!of.is_empty()).then(|| {
                let n = of.len() as f64;
                Xyz::from_array(std::array::from_fn(|k| of.iter().map(|x| x[k]).sum::<f64>() / n))
            })
        };
        let Some(original) = mean_emitted("original") else {
            return Ok(("predicted".into(), predicted()));
        };
        let mut shown = Vec::with_capacity(approximations.len());
        for name in approximations {
            match mean_emitted(name) {
                Some(xyz) => shown.push(ciede2000(Lab::from_xyz(original, white), Lab::from_xyz(xyz, white))),
                // A verification that did not measure every approximation
                // is not the basis of the fit.
                None => return Ok(("predicted".into(), predicted())),
            }
        }
        Ok(("verified".into(), shown))
    }
}

/// `1 trial`, `2 trials`.
fn plural(n: usize, word: &str) -> String {
    format!("{n} {word}{}", if n == 1 { "" } else { "s" })
}

/// The columns of [`analysis_csv`].
const ANALYSIS_COLUMNS: [&str; 24] = [
    "experiment",
    "scene",
    "target",
    "output_method",
    "observer",
    "approximation",
    "trials",
    "correct",
    "excluded",
    "proportion_correct",
    "pc_low",
    "pc_high",
    "dprime_differencing",
    "dprime_differencing_low",
    "dprime_differencing_high",
    "dprime_independent_observation",
    "dprime_io_low",
    "dprime_io_high",
    "upper_bounded",
    "rule",
    "dE00_intended",
    "dE00_shown",
    "distinct",
    "distinct_at_8bit",
];

/// The analysis as CSV, one row per condition, every number labelled with
/// its model (written by the `csv` crate: an observer named with a comma
/// keeps its columns).
pub fn analysis_csv(a: &Analysis) -> String {
    // A row with no trial counted has empty estimate cells.
    let num = |v: Option<f64>, digits: usize| v.map(|v| format!("{v:.digits$}")).unwrap_or_default();
    let rows = a.rows.iter().map(|r| {
        let d = r.differencing.as_ref();
        let io = r.independent_observation.as_ref();
        vec![
            a.experiment_id.to_string(),
            a.scene.clone(),
            a.target.clone(),
            a.output_method.clone(),
            r.observer.clone(),
            r.approximation.clone(),
            r.trials.to_string(),
            r.correct.to_string(),
            r.excluded.to_string(),
            num(d.map(|d| d.proportion_correct), 6),
            num(d.map(|d| d.proportion_interval.0), 6),
            num(d.map(|d| d.proportion_interval.1), 6),
            num(d.map(|d| d.d_prime), 4),
            num(d.map(|d| d.d_prime_interval.0), 4),
            num(d.map(|d| d.d_prime_interval.1), 4),
            num(io.map(|d| d.d_prime), 4),
            num(io.map(|d| d.d_prime_interval.0), 4),
            num(io.map(|d| d.d_prime_interval.1), 4),
            d.map(|d| d.upper_bounded.to_string()).unwrap_or_default(),
            d.and_then(|d| d.rule).unwrap_or("").to_string(),
            format!("{:.4}", r.delta_e00_intended),
            format!("{:.4}", r.delta_e00_shown),
            r.distinct.to_string(),
            r.distinct_at_8bit.to_string(),
        ]
    });
    csv_table(&ANALYSIS_COLUMNS, rows).expect("every row has the header's columns")
}

/// The analysis as the command line prints it (`lightbooth experiment
/// analyze`): a header, one line per condition with both models' d′ and
/// their intervals, the notes and warnings, and a footnote for each mark
/// the table shows (`*` the all-correct rule, `—` an unbounded upper end).
pub fn analysis_text(a: &Analysis) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "experiment {} ({}), {}/{}, {}: {}, {} ({} complete)",
        a.experiment_id,
        a.name,
        a.scene,
        a.target,
        a.output_method,
        plural(a.observers.len(), "observer"),
        plural(a.sessions, "session"),
        a.complete_sessions
    );
    let _ = writeln!(
        out,
        "{:<10} {:<14} {:>9} {:>7} {:>17} {:>17} {:>8}",
        "observer", "approximation", "correct", "%", "d′ differencing", "d′ indep. obs.", "ΔE00"
    );
    for row in &a.rows {
        let (Some(d), Some(io)) = (&row.differencing, &row.independent_observation) else {
            let _ = writeln!(
                out,
                "{:<10} {:<14} {:>4}/{:<4} none counted ({} excluded for a dropped frame) {:>8.3}",
                row.observer, row.approximation, row.correct, row.trials, row.excluded, row.delta_e00_shown
            );
            continue;
        };
        let interval = |e: &OddityEstimate| {
            format!(
                "{:.2} [{:.2}, {}]",
                e.d_prime,
                e.d_prime_interval.0,
                if e.upper_bounded {
                    format!("{:.2}", e.d_prime_interval.1)
                } else {
                    "—".into()
                }
            )
        };
        let _ = writeln!(
            out,
            "{:<10} {:<14} {:>4}/{:<4} {:>6.1} {:>17} {:>17} {:>8.3}{}",
            row.observer,
            row.approximation,
            row.correct,
            row.trials,
            100.0 * d.proportion_correct,
            interval(d),
            interval(io),
            row.delta_e00_shown,
            if d.rule.is_some() { "  *" } else { "" }
        );
    }
    let _ = writeln!(
        out,
        "thresholds (d′ = ΔE00/σ, ΔE00 {}; {:.0} % profile-likelihood intervals; ΔE00 at 2/3 correct):",
        a.delta_e00_basis,
        CONFIDENCE * 100.0
    );
    for t in &a.thresholds {
        let _ = writeln!(out, "  {}", threshold_line(t));
    }
    for n in &a.notes {
        let _ = writeln!(out, "{n}");
    }
    for w in &a.warnings {
        let _ = writeln!(out, "warning: {w}");
    }
    if a.rows
        .iter()
        .any(|row| row.differencing.as_ref().is_some_and(|d| d.rule.is_some()))
    {
        let _ = writeln!(out, "* {}", lightbooth_science::psychophysics::oddity::ALL_CORRECT_RULE);
    }
    // The footnote of the "—" only under a table that shows one.
    if a.rows
        .iter()
        .flat_map(|row| [&row.differencing, &row.independent_observation])
        .any(|e| e.as_ref().is_some_and(|e| !e.upper_bounded))
    {
        let _ = writeln!(
            out,
            "— an upper end of — : every trial or nearly correct, the data set no upper bound"
        );
    }
    out
}

/// Why `observer` (an observer id, or `all`) has no threshold, in words
/// for the person reading the thresholds table: the table once showed the
/// fitter's own text, "no fit: no conditions: give at least one (ΔE00,
/// correct, trials)", for an observer with no trials yet.
pub fn no_fit_sentence(observer: &str, error: &threshold::ThresholdError) -> String {
    use threshold::ThresholdError as E;
    let who = if observer == ALL_OBSERVERS {
        "the observers have".to_string()
    } else {
        format!("observer {observer} has")
    };
    match error {
        E::NoConditions | E::NoTrials => format!("no fit yet: {who} no trials recorded"),
        E::NoColourDifference => format!(
            "no fit yet: {who} trials only of approximations the display shows identical to the original \
             (ΔE00 0), which say nothing of σ; a fit needs trials at a visible difference"
        ),
        other => format!("no fit: the recorded trials cannot be fitted ({other})"),
    }
}

/// One threshold as a line: observer, model, σ and the threshold with
/// their intervals, the deviance and its p-value (or why there is no fit).
pub fn threshold_line(t: &ObserverThreshold) -> String {
    let Some(f) = &t.fit else {
        return format!(
            "{:<10} {:<24} {}",
            t.observer,
            t.model,
            t.no_fit.as_deref().unwrap_or("no fit")
        );
    };
    let end = |v: Option<f64>| v.map(|v| format!("{v:.3}")).unwrap_or_else(|| "∞".into());
    let gof = &f.goodness_of_fit;
    let mut line = format!(
        "{:<10} {:<24} σ = {} [{:.3}, {}], threshold ΔE00 = {} [{:.3}, {}], {}, deviance {:.2} on {} df{}",
        t.observer,
        f.model.name(),
        end(f.sigma),
        f.sigma_interval.0,
        end(f.sigma_interval.1),
        end(f.threshold),
        f.threshold_interval.0,
        end(f.threshold_interval.1),
        lapse_words(f),
        gof.deviance,
        gof.degrees_of_freedom,
        gof.p_value
            .map(|p| format!(", p = {p:.3}"))
            .unwrap_or_else(|| " (none left to test)".into())
    );
    for b in &f.at_bounds {
        line += &format!("\n{:<35} at a bound: {b}", "");
    }
    line
}

/// λ̂ with its interval and bound: `lapse λ = 0.006 [0.000, 0.024] (bound 0.06)`.
pub fn lapse_words(f: &ThresholdFit) -> String {
    format!(
        "lapse λ = {:.3} [{:.3}, {:.3}] (bound {})",
        f.lapse, f.lapse_interval.0, f.lapse_interval.1, f.lapse_max
    )
}

/// The columns of [`thresholds_csv`].
const THRESHOLD_COLUMNS: [&str; 28] = [
    "experiment",
    "scene",
    "observer",
    "model",
    "kind",
    "dE00_basis",
    "sigma",
    "sigma_low",
    "sigma_high",
    "threshold_dE00",
    "threshold_low",
    "threshold_high",
    "deviance",
    "df",
    "p_value",
    "maximum",
    "lapse",
    "lapse_low",
    "lapse_high",
    "lapse_max",
    "at_bounds",
    "approximation",
    "dE00_intended",
    "distinct_at_8bit",
    "predicted_pc",
    "predicted_pc_low",
    "predicted_pc_high",
    "not_fitted",
];

/// The thresholds as CSV: one row per observer (then `all`) and model,
/// with the fit and, per approximation, the predicted percent correct in
/// its own rows (`kind` = `fit` or `prediction`).
pub fn thresholds_csv(a: &Analysis) -> String {
    let num = |v: Option<f64>| v.map(|v| format!("{v:.6}")).unwrap_or_default();
    let mut rows = Vec::new();
    for t in &a.thresholds {
        // The columns every row of this observer and model starts with.
        let row = |kind: &str| -> Vec<String> {
            let mut r = vec![String::new(); THRESHOLD_COLUMNS.len()];
            r[0] = a.experiment_id.to_string();
            r[1] = a.scene.clone();
            r[2] = t.observer.clone();
            r[3] = t.model.clone();
            r[4] = kind.to_string();
            r[5] = a.delta_e00_basis.to_string();
            r
        };
        let Some(f) = &t.fit else {
            let mut r = row("fit");
            r[27] = t.not_fitted.clone().unwrap_or_default();
            rows.push(r);
            continue;
        };
        let g = &f.goodness_of_fit;
        let mut r = row("fit");
        let fit = [
            num(f.sigma),
            num(Some(f.sigma_interval.0)),
            num(f.sigma_interval.1),
            num(f.threshold),
            num(Some(f.threshold_interval.0)),
            num(f.threshold_interval.1),
            format!("{:.6}", g.deviance),
            g.degrees_of_freedom.to_string(),
            num(g.p_value),
            serde_json::to_value(f.maximum)
                .ok()
                .and_then(|v| v.as_str().map(String::from))
                .unwrap_or_default(),
            format!("{:.6}", f.lapse),
            format!("{:.6}", f.lapse_interval.0),
            format!("{:.6}", f.lapse_interval.1),
            f.lapse_max.to_string(),
            f.at_bounds.join("; "),
        ];
        for (k, v) in fit.into_iter().enumerate() {
            r[6 + k] = v;
        }
        rows.push(r);
        for p in &t.predictions {
            let mut r = row("prediction");
            r[21] = p.approximation.clone();
            r[22] = format!("{:.4}", p.delta_e00_intended);
            r[23] = p.distinct_at_8bit.to_string();
            r[24] = format!("{:.6}", p.predicted.proportion_correct);
            r[25] = format!("{:.6}", p.predicted.interval.0);
            r[26] = format!("{:.6}", p.predicted.interval.1);
            rows.push(r);
        }
    }
    csv_table(&THRESHOLD_COLUMNS, rows).expect("every row has the header's columns")
}

/// The psychometric figure of an analysis under `model`: percent correct
/// against ΔE00 (on the analysis' basis) per observer, the fitted curve of
/// each (the pooled one when there are several), chance (1/3) as a line,
/// and the percent predicted for approximations the display could not
/// show apart at 8 bits (open markers, at their intended ΔE00).
pub fn psychometric_figure(a: &Analysis, model: OddityModel) -> Result<String, LabError> {
    use crate::charts::{psychometric_chart, Psychometric, PsychometricPoints};
    use lightbooth_science::psychophysics::binomial::Count;
    let of_model: Vec<&ObserverThreshold> = a.thresholds.iter().filter(|t| t.model == model.name()).collect();
    // The individual observers' points; the pooled curve (or the one
    // observer's) with its predictions.
    let pooled = a.observers.len() > 1;
    let observed = of_model
        .iter()
        .filter(|t| !pooled || t.observer != ALL_OBSERVERS)
        .map(|t| PsychometricPoints {
            name: format!("{}: observed, exact 95 %", t.observer),
            points: t
                .conditions
                .iter()
                .filter_map(|c| {
                    let (lo, hi) = Count::new(c.correct, c.trials).ok()?.clopper_pearson(CONFIDENCE).ok()?;
                    let pc = f64::from(c.correct) / f64::from(c.trials);
                    Some((c.delta_e00, 100.0 * pc, 100.0 * lo, 100.0 * hi))
                })
                .collect(),
        })
        .collect();
    let fitted = of_model
        .iter()
        .find(|t| !pooled || t.observer == ALL_OBSERVERS)
        .and_then(|t| t.fit.as_ref().map(|f| (*t, f)));
    let x_max = of_model
        .iter()
        .flat_map(|t| t.conditions.iter().map(|c| c.delta_e00))
        .chain(
            of_model
                .iter()
                .flat_map(|t| t.predictions.iter().map(|p| p.delta_e00_intended)),
        )
        .fold(0.5f64, f64::max);
    let curve = fitted.map(|(t, f)| {
        // A threshold at a bound is said as the bound the trials set.
        let threshold = match (f.threshold, f.threshold_interval) {
            (Some(_), (0.0, Some(hi))) => format!(", threshold ΔE00 ≤ {hi:.2}"),
            (Some(v), _) => format!(", threshold ΔE00 {v:.2}"),
            (None, (lo, _)) => format!(", threshold ΔE00 ≥ {lo:.2}"),
        };
        (
            format!(
                "{}: d′ = ΔE00/σ fitted{threshold}, lapse λ {:.3} (ceiling {:.1} %)",
                t.observer,
                f.lapse,
                100.0 * (1.0 - f.lapse)
            ),
            fitted_curve(f, x_max),
        )
    });
    let predicted = fitted
        .map(|(t, _)| {
            t.predictions
                .iter()
                .filter(|p| !p.distinct_at_8bit)
                .map(|p| {
                    (
                        p.delta_e00_intended,
                        100.0 * p.predicted.proportion_correct,
                        p.approximation.clone(),
                    )
                })
                .collect()
        })
        .unwrap_or_default();
    let figure = Psychometric {
        title: format!(
            "{} ({}): percent correct against ΔE00 ({}), {} model",
            a.name,
            a.scene,
            a.delta_e00_basis,
            model.name()
        ),
        observed,
        curve,
        predicted,
        chance_percent: 100.0 * CHANCE,
    };
    psychometric_chart(&figure).map_err(LabError::Internal)
}

/// The fitted curve the psychometric figure draws: (ΔE00, percent
/// correct) at 201 points from 0 to `x_max`, lapses included, so it rises
/// from chance to a ceiling of 100 (1 − λ̂) %.
pub fn fitted_curve(f: &ThresholdFit, x_max: f64) -> Vec<(f64, f64)> {
    (0..=200)
        .filter_map(|i| {
            let x = x_max * f64::from(i) / 200.0;
            f.predict(x).ok().map(|p| (x, 100.0 * p.proportion_correct))
        })
        .collect()
}

/// The analysis as a MAT-file (`load('experiment-1-analysis.mat')`): the
/// same columns as [`analysis_csv`], numbers as column vectors and text
/// (`observer`, `approximation`, `rule`) as char matrices of one row each,
/// so `table(cellstr(observer), cellstr(approximation), proportion_correct, ...)`
/// rebuilds it; `model_differencing` and `model_independent_observation`
/// name the models of the d′ columns. A row with no trial counted has NaN
/// estimates.
pub fn analysis_mat(a: &Analysis) -> Result<Vec<u8>, String> {
    let mut mat = crate::export::mat::MatFile::new();
    let text = |f: fn(&ConditionResult) -> String| a.rows.iter().map(f).collect::<Vec<_>>();
    mat.text_rows("observer", &text(|r| r.observer.clone()))?;
    mat.text_rows("approximation", &text(|r| r.approximation.clone()))?;
    mat.text_rows(
        "rule",
        &text(|r| r.differencing.as_ref().and_then(|d| d.rule).unwrap_or("").to_string()),
    )?;
    mat.text_rows("scene", std::slice::from_ref(&a.scene))?;
    mat.text_rows("target", std::slice::from_ref(&a.target))?;
    mat.text_rows("output_method", std::slice::from_ref(&a.output_method))?;
    mat.text_rows("model_differencing", &["differencing (sensR triangle)".to_string()])?;
    mat.text_rows(
        "model_independent_observation",
        &["independent observation (Versfeld, Dai & Green 1996)".to_string()],
    )?;
    mat.scalar("experiment_id", a.experiment_id as f64)?;
    mat.scalar("confidence", a.confidence)?;
    mat.scalar("chance", a.chance)?;
    type Field = (&'static str, fn(&ConditionResult) -> f64);
    fn d(r: &ConditionResult, f: fn(&OddityEstimate) -> f64) -> f64 {
        r.differencing.as_ref().map_or(f64::NAN, f)
    }
    fn io(r: &ConditionResult, f: fn(&OddityEstimate) -> f64) -> f64 {
        r.independent_observation.as_ref().map_or(f64::NAN, f)
    }
    let fields: [Field; 18] = [
        ("trials", |r| f64::from(r.trials)),
        ("correct", |r| f64::from(r.correct)),
        ("excluded", |r| f64::from(r.excluded)),
        ("proportion_correct", |r| d(r, |e| e.proportion_correct)),
        ("pc_low", |r| d(r, |e| e.proportion_interval.0)),
        ("pc_high", |r| d(r, |e| e.proportion_interval.1)),
        ("dprime_differencing", |r| d(r, |e| e.d_prime)),
        ("dprime_differencing_low", |r| d(r, |e| e.d_prime_interval.0)),
        ("dprime_differencing_high", |r| d(r, |e| e.d_prime_interval.1)),
        ("dprime_independent_observation", |r| io(r, |e| e.d_prime)),
        ("dprime_io_low", |r| io(r, |e| e.d_prime_interval.0)),
        ("dprime_io_high", |r| io(r, |e| e.d_prime_interval.1)),
        ("upper_bounded", |r| d(r, |e| f64::from(u8::from(e.upper_bounded)))),
        ("dE00_intended", |r| r.delta_e00_intended),
        ("dE00_shown", |r| r.delta_e00_shown),
        ("distinct", |r| f64::from(u8::from(r.distinct))),
        ("distinct_at_8bit", |r| f64::from(u8::from(r.distinct_at_8bit))),
        ("rule_applied", |r| d(r, |e| f64::from(u8::from(e.rule.is_some())))),
    ];
    for (name, f) in fields {
        mat.column(name, &a.rows.iter().map(f).collect::<Vec<_>>())?;
    }
    // The thresholds, one entry per observer and model (NaN where there is
    // no fit or no finite end), prefixed `threshold_`.
    let t = &a.thresholds;
    mat.text_rows(
        "threshold_observer",
        &t.iter().map(|t| t.observer.clone()).collect::<Vec<_>>(),
    )?;
    mat.text_rows(
        "threshold_model",
        &t.iter().map(|t| t.model.clone()).collect::<Vec<_>>(),
    )?;
    mat.text_rows("threshold_dE00_basis", std::slice::from_ref(&a.delta_e00_basis))?;
    type ThresholdField = (&'static str, fn(&ThresholdFit) -> Option<f64>);
    let threshold_fields: [ThresholdField; 13] = [
        ("threshold_sigma", |f| f.sigma),
        ("threshold_sigma_low", |f| Some(f.sigma_interval.0)),
        ("threshold_sigma_high", |f| f.sigma_interval.1),
        ("threshold_dE00", |f| f.threshold),
        ("threshold_dE00_low", |f| Some(f.threshold_interval.0)),
        ("threshold_dE00_high", |f| f.threshold_interval.1),
        ("threshold_deviance", |f| Some(f.goodness_of_fit.deviance)),
        ("threshold_df", |f| {
            Some(f64::from(f.goodness_of_fit.degrees_of_freedom))
        }),
        ("threshold_p_value", |f| f.goodness_of_fit.p_value),
        ("threshold_lapse", |f| Some(f.lapse)),
        ("threshold_lapse_low", |f| Some(f.lapse_interval.0)),
        ("threshold_lapse_high", |f| Some(f.lapse_interval.1)),
        ("threshold_lapse_max", |f| Some(f.lapse_max)),
    ];
    for (name, field) in threshold_fields {
        let values: Vec<f64> = t
            .iter()
            .map(|t| t.fit.as_ref().and_then(field).unwrap_or(f64::NAN))
            .collect();
        mat.column(name, &values)?;
    }
    mat.text_rows(
        "threshold_at_bounds",
        &t.iter()
            .map(|t| t.fit.as_ref().map(|f| f.at_bounds.join("; ")).unwrap_or_default())
            .collect::<Vec<_>>(),
    )?;
    Ok(mat.into_bytes())
}

/// The study's Fig. 5 (right) for experiments' analyses: per scene and
/// approximation the pooled row (or the only observer's), d′ under `model`.
/// A condition with no trial counted has no bar; the title counts the
/// observers whose counted trials the bars are made of.
pub fn figure(analyses: &[impl std::borrow::Borrow<Analysis>], model: OddityModel) -> Result<String, LabError> {
    let mut bars = Vec::new();
    let mut drawn: Vec<&str> = Vec::new();
    for a in analyses {
        let a: &Analysis = a.borrow();
        let mut approximations: Vec<&str> = a.rows.iter().map(|r| r.approximation.as_str()).collect();
        approximations.dedup();
        for name in approximations {
            let of: Vec<&ConditionResult> = a.rows.iter().filter(|r| r.approximation == name).collect();
            let Some(r) = of.iter().find(|r| r.observer == ALL_OBSERVERS).or(of.first()) else {
                continue;
            };
            let e = match model {
                OddityModel::Differencing => &r.differencing,
                OddityModel::IndependentObservation => &r.independent_observation,
            };
            let Some(e) = e else {
                continue;
            };
            if r.observer == ALL_OBSERVERS {
                // The observers with a counted trial of this condition.
                drawn.extend(
                    of.iter()
                        .filter(|o| o.observer != ALL_OBSERVERS && o.trials > 0)
                        .map(|o| o.observer.as_str()),
                );
            } else {
                drawn.push(&r.observer);
            }
            bars.push(crate::charts::DiscriminationBar {
                group: a.scene.clone(),
                coding: name.to_string(),
                d_prime: e.d_prime,
                interval: e.d_prime_interval,
                upper_bounded: e.upper_bounded,
                percent_correct: 100.0 * e.proportion_correct,
            });
        }
    }
    drawn.sort();
    drawn.dedup();
    let title = format!(
        "Can observers tell? d′ and percent correct, {}, {:.0} % intervals",
        plural(drawn.len(), "observer"),
        CONFIDENCE * 100.0
    );
    crate::charts::discrimination_chart(&title, model.name(), &bars).map_err(LabError::Internal)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The observer of issue 46 (one miss at ΔE00 2.151 of BLUE's visible
    /// approximations, near chance where the codes are the original's),
    /// as an analysis with its fits under both models.
    fn one_lapse() -> Analysis {
        let seen = [
            ("nstep3", 7.047, 36),
            ("nstep9", 2.151, 35),
            ("nstep27", 0.0, 12),
            ("nstep81", 0.326, 36),
            ("rgb", 0.689, 36),
            ("srgb", 0.324, 36),
        ];
        let conditions: Vec<Condition> = seen
            .iter()
            .map(|&(_, delta_e00, correct)| Condition {
                delta_e00,
                correct,
                trials: 36,
            })
            .collect();
        let thresholds = OddityModel::ALL
            .into_iter()
            .map(|model| {
                let f = threshold::fit(&conditions, model, CONFIDENCE).unwrap();
                ObserverThreshold {
                    observer: "sim1".into(),
                    model: model.name().into(),
                    predictions: seen
                        .iter()
                        .map(|&(name, delta_e00, _)| ThresholdPrediction {
                            approximation: name.into(),
                            delta_e00_intended: delta_e00,
                            distinct_at_8bit: delta_e00 > 0.0,
                            predicted: f.predict(delta_e00).unwrap(),
                        })
                        .collect(),
                    fit: Some(f),
                    not_fitted: None,
                    no_fit: None,
                    conditions: conditions.clone(),
                }
            })
            .collect();
        Analysis {
            experiment_id: 7,
            name: "blue".into(),
            scene: "blue".into(),
            target: "t".into(),
            output_method: "8bit".into(),
            confidence: CONFIDENCE,
            chance: CHANCE,
            observers: vec!["sim1".into()],
            sessions: 1,
            complete_sessions: 1,
            rows: Vec::new(),
            notes: Vec::new(),
            warnings: Vec::new(),
            delta_e00_basis: "verified".into(),
            thresholds,
        }
    }

    /// Fields of a CSV line, quotes respected.
    fn fields(line: &str) -> Vec<String> {
        let mut out = vec![String::new()];
        let mut quoted = false;
        for c in line.chars() {
            match c {
                '"' => quoted = !quoted,
                ',' if !quoted => out.push(String::new()),
                c => out.last_mut().unwrap().push(c),
            }
        }
        out
    }

    /// Issue 46: λ̂, its interval and bound, and what sits at a bound, in
    /// every output of the thresholds: the CLI's line, thresholds.csv
    /// (every row as wide as its header), the JSON, and the psychometric
    /// figure's curve, whose ceiling is 100 (1 − λ̂) %.
    #[test]
    fn the_lapse_rate_is_in_every_threshold_output() {
        let a = one_lapse();
        for t in &a.thresholds {
            let f = t.fit.as_ref().unwrap();
            assert!((f.lapse - 1.0 / 180.0).abs() < 1e-9, "{f:?}");
            let line = threshold_line(t);
            println!("{line}");
            assert!(
                line.contains("lapse λ = 0.006 [0.000, 0.024] (bound 0.06)")
                    && line.contains("at a bound: σ's interval reaches 0")
                    && line.contains("σ = 0.000 [0.000, 0.0"),
                "{line}"
            );
            let json = serde_json::to_value(f).unwrap();
            assert_eq!(json["lapse_max"], 0.06);
            assert!(json["lapse"].as_f64().unwrap() > 0.005 && json["at_bounds"].as_array().unwrap().len() == 1);
        }
        let csv = thresholds_csv(&a);
        let mut lines = csv.lines();
        let header = fields(lines.next().unwrap());
        let column = |name: &str| header.iter().position(|h| h == name).unwrap();
        for line in lines {
            let row = fields(line);
            assert_eq!(row.len(), header.len(), "{line}");
            if row[column("kind")] == "fit" {
                assert_eq!(row[column("lapse")], "0.005556", "{line}");
                assert_eq!(row[column("lapse_max")], "0.06", "{line}");
                assert_eq!(row[column("maximum")], "sigma-zero", "{line}");
                assert!(row[column("at_bounds")].contains("reaches 0"), "{line}");
            } else {
                assert!(!row[column("predicted_pc")].is_empty(), "{line}");
            }
        }
        for model in OddityModel::ALL {
            let t = a.thresholds.iter().find(|t| t.model == model.name()).unwrap();
            let f = t.fit.as_ref().unwrap();
            let curve = fitted_curve(f, 7.047);
            let top = curve.iter().map(|p| p.1).fold(0.0, f64::max);
            assert!((top - 100.0 * (1.0 - f.lapse)).abs() < 1e-9, "{model}: top {top}");
            assert!((curve[0].1 - 100.0 / 3.0).abs() < 1e-9);
            let svg = psychometric_figure(&a, model).unwrap();
            // The legend's words, however its lines wrap them.
            let words: Vec<&str> = svg
                .split("<text")
                .skip(1)
                .filter_map(|t| t.split_once('>').and_then(|(_, rest)| rest.split_once("</text>")))
                .flat_map(|(inside, _)| inside.split_whitespace())
                .collect();
            let words = words.join(" ");
            let bound = 100.0 * f.threshold_interval.1.unwrap();
            assert!(
                words.contains(&format!(
                    "sim1: d′ = ΔE00/σ fitted, threshold ΔE00 ≤ {:.2}, lapse λ 0.006 (ceiling 99.4 %)",
                    bound.round() / 100.0
                )),
                "{model}: {words}"
            );
        }
    }

    /// The thresholds table showed "no fit: no conditions: give at least
    /// one (ΔE00, correct, trials)" for an observer with no trials yet: a
    /// sentence for a person, the fitter's reason kept in `not_fitted`.
    #[test]
    fn the_thresholds_table_showed_the_fitters_raw_text() {
        use threshold::ThresholdError as E;
        let none = no_fit_sentence("sim3", &E::NoConditions);
        assert_eq!(none, "no fit yet: observer sim3 has no trials recorded");
        assert_eq!(no_fit_sentence("sim3", &E::NoTrials), none);
        assert_eq!(
            no_fit_sentence(ALL_OBSERVERS, &E::NoConditions),
            "no fit yet: the observers have no trials recorded"
        );
        let invisible = no_fit_sentence("sim3", &E::NoColourDifference);
        assert!(
            invisible.contains("visible difference") && !invisible.contains("d′ = ΔE00/σ is 0"),
            "{invisible}"
        );
        for e in [E::NoConditions, E::NoTrials, E::NoColourDifference] {
            let sentence = no_fit_sentence("sim3", &e);
            assert!(!sentence.contains(&e.to_string()), "{sentence}");
        }
    }
}
