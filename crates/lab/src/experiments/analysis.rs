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

use serde::Serialize;

use super::session::excluded_warning;
use super::{parts, Experiments};
use crate::error::LabError;
use lightbooth_science::psychophysics::oddity::{estimate, OddityEstimate, OddityModel, CHANCE};
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
        Ok(Analysis {
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

/// `1 trial`, `2 trials`.
fn plural(n: usize, word: &str) -> String {
    format!("{n} {word}{}", if n == 1 { "" } else { "s" })
}

/// The analysis as CSV, one row per condition, every number labelled with its model.
pub fn analysis_csv(a: &Analysis) -> String {
    let mut out = String::from(
        "experiment,scene,target,output_method,observer,approximation,trials,correct,excluded,\
         proportion_correct,pc_low,pc_high,dprime_differencing,dprime_differencing_low,dprime_differencing_high,\
         dprime_independent_observation,dprime_io_low,dprime_io_high,upper_bounded,rule,dE00_intended,dE00_shown,distinct,distinct_at_8bit\n",
    );
    // A row with no trial counted has empty estimate cells.
    let num = |v: Option<f64>, digits: usize| v.map(|v| format!("{v:.digits$}")).unwrap_or_default();
    for r in &a.rows {
        let d = r.differencing.as_ref();
        let io = r.independent_observation.as_ref();
        out += &format!(
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{:.4},{:.4},{},{}\n",
            a.experiment_id,
            a.scene,
            a.target,
            a.output_method,
            r.observer,
            r.approximation,
            r.trials,
            r.correct,
            r.excluded,
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
            d.and_then(|d| d.rule).unwrap_or(""),
            r.delta_e00_intended,
            r.delta_e00_shown,
            r.distinct,
            r.distinct_at_8bit
        );
    }
    out
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
    Ok(mat.into_bytes())
}

/// The study's Fig. 5 (right) for experiments' analyses: per scene and
/// approximation the pooled row (or the only observer's), d′ under `model`.
/// A condition with no trial counted has no bar; the title counts the
/// observers whose counted trials the bars are made of.
pub fn figure(analyses: &[Analysis], model: OddityModel) -> Result<String, LabError> {
    let mut bars = Vec::new();
    let mut drawn: Vec<&str> = Vec::new();
    for a in analyses {
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
