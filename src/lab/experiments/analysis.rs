//! An experiment's results: per observer and approximation (and pooled
//! over observers), the percent correct with its exact interval and d′
//! under both oddity models, beside the ΔE00 the display was asked to show
//! and showed ([`crate::psychophysics::oddity::estimate`]).
//!
//! Trials with a frame dropped during the pie are not counted: the pie was
//! shown for less or more time than the design says, and the trial was
//! shown again at the end of the block. Their number is reported.

use serde::Serialize;
use utoipa::ToSchema;

use super::{parts, Experiments};
use crate::lab::error::LabError;
use crate::psychophysics::oddity::{estimate, OddityEstimate, OddityModel, CHANCE};
use crate::store::ObservedTrial;

/// The confidence of every interval of the analysis.
pub const CONFIDENCE: f64 = 0.95;

/// The observer id of rows pooled over every observer.
pub const ALL_OBSERVERS: &str = "all";

/// One observer (or all) and one approximation.
#[derive(Clone, Debug, Serialize, ToSchema)]
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
    /// models' d′ ([`OddityEstimate`] names its model).
    #[schema(value_type = Object)]
    pub differencing: OddityEstimate,
    #[schema(value_type = Object)]
    pub independent_observation: OddityEstimate,
    /// ΔE00 (display white) between original and approximation as intended
    /// and as shown with the output method (the experiment's check).
    pub delta_e00_intended: f64,
    pub delta_e00_shown: f64,
    /// Whether the display could show the two apart with the output method.
    pub distinct: bool,
    pub distinct_at_8bit: bool,
}

/// Every condition of an experiment.
#[derive(Clone, Debug, Serialize, ToSchema)]
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
                if n == 0 {
                    continue;
                }
                let k = counted.iter().filter(|t| t.trial.correct).count() as u32;
                let est = |model| estimate(k, n, model, CONFIDENCE).map_err(|err| LabError::Internal(err.to_string()));
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
        let excluded: u32 = trials.iter().filter(|t| t.trial.dropped_in_stimulus).count() as u32;
        let notes = vec![
            format!(
                "{} trials stored; {excluded} had a frame dropped during the pie and are not counted (each was shown again)",
                trials.len()
            ),
            format!(
                "intervals: exact (Clopper–Pearson) {:.0} % intervals of the proportion correct, mapped to d′ through each model",
                CONFIDENCE * 100.0
            ),
            "d′ models: differencing (sensR's triangle link) and independent observation (Versfeld, Dai & Green 1996)".into(),
        ];
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
        })
    }
}

/// The analysis as CSV, one row per condition, every number labelled with its model.
pub fn analysis_csv(a: &Analysis) -> String {
    let mut out = String::from(
        "experiment,scene,target,output_method,observer,approximation,trials,correct,excluded,\
         proportion_correct,pc_low,pc_high,dprime_differencing,dprime_differencing_low,dprime_differencing_high,\
         dprime_independent_observation,dprime_io_low,dprime_io_high,upper_bounded,rule,dE00_intended,dE00_shown,distinct,distinct_at_8bit\n",
    );
    for r in &a.rows {
        let d = &r.differencing;
        let io = &r.independent_observation;
        out += &format!(
            "{},{},{},{},{},{},{},{},{},{:.6},{:.6},{:.6},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{},{},{:.4},{:.4},{},{}\n",
            a.experiment_id,
            a.scene,
            a.target,
            a.output_method,
            r.observer,
            r.approximation,
            r.trials,
            r.correct,
            r.excluded,
            d.proportion_correct,
            d.proportion_interval.0,
            d.proportion_interval.1,
            d.d_prime,
            d.d_prime_interval.0,
            d.d_prime_interval.1,
            io.d_prime,
            io.d_prime_interval.0,
            io.d_prime_interval.1,
            d.upper_bounded,
            d.rule.unwrap_or(""),
            r.delta_e00_intended,
            r.delta_e00_shown,
            r.distinct,
            r.distinct_at_8bit
        );
    }
    out
}

/// The analysis as a MAT-file (`load('experiment-1-analysis.mat')`): the
/// same columns as [`analysis_csv`], numbers as column vectors and text
/// (`observer`, `approximation`, `rule`) as char matrices of one row each,
/// so `table(cellstr(observer), cellstr(approximation), proportion_correct, ...)`
/// rebuilds it; `model_differencing` and `model_independent_observation`
/// name the models of the d′ columns.
pub fn analysis_mat(a: &Analysis) -> Result<Vec<u8>, String> {
    let mut mat = crate::export::mat::MatFile::new();
    let text = |f: fn(&ConditionResult) -> String| a.rows.iter().map(f).collect::<Vec<_>>();
    mat.text_rows("observer", &text(|r| r.observer.clone()))?;
    mat.text_rows("approximation", &text(|r| r.approximation.clone()))?;
    mat.text_rows("rule", &text(|r| r.differencing.rule.unwrap_or("").to_string()))?;
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
    let fields: [Field; 18] = [
        ("trials", |r| f64::from(r.trials)),
        ("correct", |r| f64::from(r.correct)),
        ("excluded", |r| f64::from(r.excluded)),
        ("proportion_correct", |r| r.differencing.proportion_correct),
        ("pc_low", |r| r.differencing.proportion_interval.0),
        ("pc_high", |r| r.differencing.proportion_interval.1),
        ("dprime_differencing", |r| r.differencing.d_prime),
        ("dprime_differencing_low", |r| r.differencing.d_prime_interval.0),
        ("dprime_differencing_high", |r| r.differencing.d_prime_interval.1),
        ("dprime_independent_observation", |r| r.independent_observation.d_prime),
        ("dprime_io_low", |r| r.independent_observation.d_prime_interval.0),
        ("dprime_io_high", |r| r.independent_observation.d_prime_interval.1),
        ("upper_bounded", |r| f64::from(u8::from(r.differencing.upper_bounded))),
        ("dE00_intended", |r| r.delta_e00_intended),
        ("dE00_shown", |r| r.delta_e00_shown),
        ("distinct", |r| f64::from(u8::from(r.distinct))),
        ("distinct_at_8bit", |r| f64::from(u8::from(r.distinct_at_8bit))),
        ("rule_applied", |r| f64::from(u8::from(r.differencing.rule.is_some()))),
    ];
    for (name, f) in fields {
        mat.column(name, &a.rows.iter().map(f).collect::<Vec<_>>())?;
    }
    Ok(mat.into_bytes())
}

/// The study's Fig. 5 (right) for experiments' analyses: per scene and
/// approximation the pooled row (or the only observer's), d′ under `model`.
pub fn figure(analyses: &[Analysis], model: OddityModel) -> Result<String, LabError> {
    let mut bars = Vec::new();
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
    let observers: Vec<&str> = analyses
        .iter()
        .flat_map(|a| a.observers.iter().map(String::as_str))
        .collect();
    let mut unique = observers.clone();
    unique.sort();
    unique.dedup();
    let title = format!(
        "Can observers tell? d′ and percent correct, {} observer{}, {:.0} % intervals",
        unique.len(),
        if unique.len() == 1 { "" } else { "s" },
        CONFIDENCE * 100.0
    );
    crate::charts::discrimination_chart(&title, model.name(), &bars).map_err(LabError::Internal)
}
