//! Everything this booth's daemon has waiting or under way, in one list:
//! measurements (the display calibration's patches among them), renders,
//! studies, camera images and experiment sessions — whoever started them
//! (a page, a MATLAB script, a study). The dashboard's home page and its
//! header read it (`GET /api/jobs`).
//!
//! Each job says how far it has got and, where its pace is known, the
//! seconds it still needs. Those estimates are extrapolations and say how
//! they were made ([`QueuedJob::estimate`]):
//!
//! - a measurement: its samples still to take times this measurement's
//!   seconds per sample so far (before its first sample, the instrument's
//!   recent pace: the median over its last complete measurements); a queued
//!   measurement waits for every measurement ahead of it, so its time left
//!   includes theirs;
//! - a render or study: the time its current phase has taken, scaled by
//!   the fraction still to do ([`super::progress`]); a render's phase is
//!   its step (tracing paths, timing each coding alone, the camera
//!   preview), which it names, and the estimate is that step's alone;
//! - a camera image: its paths traced against its cap, an upper bound (it
//!   stops earlier once every pixel reaches its noise target);
//! - an experiment session: trials recorded of those it needs (from
//!   counts); no time, an observer sets the pace. One untouched for
//!   [`PAUSED_AFTER_S`] is `paused`, not running.

use std::collections::HashMap;

use serde::Serialize;

use super::experiments::session::{trials_needed, PAUSED_AFTER_S};
use super::experiments::ExperimentRequest;
use super::progress::{image_time_left, ProgressBoard};
use crate::measure::queue::InstrumentStatus;
use crate::render::jobs::RenderJobs;
use lightbooth_store::{Booth, Job, MeasurementFilter, MeasurementState, MeasurementSummary, Store, StoreError};

/// Complete measurements the instrument's recent pace is the median of.
const PACE_FROM_LAST: i64 = 10;

/// One job waiting or under way.
#[derive(Clone, Debug, Default, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct QueuedJob {
    /// `measurement`, `render`, `study`, `image` or `experiment_session`.
    pub kind: &'static str,
    pub id: i64,
    /// `queued` or `running` (an experiment session: `paused` when
    /// untouched for a while, see the module doc).
    pub state: String,
    /// What it is, in words (`white/patch, 5 samples`).
    pub what: String,
    /// The scene it belongs to, if any.
    pub scene: Option<String>,
    /// The render of a camera image, the experiment of a session.
    pub parent_id: Option<i64>,
    /// POSIX seconds (null for a camera image: they are kept in memory
    /// only, without a time of request).
    pub created_at: Option<f64>,
    pub started_at: Option<f64>,
    /// Work done and to do, in `unit`s (samples, trials, steps, %).
    pub done: Option<f64>,
    pub total: Option<f64>,
    pub unit: Option<String>,
    /// What it is doing now, in words (a study's step).
    pub step: Option<String>,
    /// Seconds until it ends, extrapolated (see `estimate`); null when
    /// nothing to extrapolate from is known yet.
    pub seconds_left: Option<f64>,
    /// How `seconds_left` was made.
    pub estimate: Option<String>,
}

/// This booth's jobs, the instrument's first in queue order.
#[derive(Clone, Debug, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Queue {
    pub booth: String,
    /// POSIX seconds at which the list was made (the `seconds_left` are from then).
    pub at: f64,
    /// The instrument's seconds per sample the estimates use, and where
    /// that figure came from.
    pub seconds_per_sample: Option<f64>,
    pub pace_source: Option<String>,
    pub jobs: Vec<QueuedJob>,
}

/// Where the queue's parts come from.
pub struct QueueSources<'a> {
    pub store: &'a Store,
    pub booth: &'a Booth,
    pub status: &'a InstrumentStatus,
    pub renders: Option<&'a RenderJobs>,
    pub progress: Option<&'a ProgressBoard>,
}

/// The queue now.
pub async fn queue(src: &QueueSources<'_>) -> Result<Queue, StoreError> {
    let now = lightbooth_store::now();
    let mut jobs = Vec::new();
    let (pace, pace_source) = instrument_pace(src).await?;
    // The instrument's: running first, then the queue in the order it is taken.
    let mut waiting: Vec<MeasurementSummary> = Vec::new();
    for state in [MeasurementState::Running, MeasurementState::Queued] {
        let page = src
            .store
            .list_measurements(&MeasurementFilter {
                booth: Some(src.booth.clone()),
                state: Some(state),
                limit: Some(1000),
                ..MeasurementFilter::default()
            })
            .await?;
        let mut items = page.items;
        items.sort_by_key(|m| m.id);
        waiting.extend(items);
    }
    let mut ahead = 0.0; // seconds until the instrument is free of the jobs before this one
    let mut known = true;
    // Seconds per sample of each target, from its own past measurements.
    let mut target_paces: std::collections::HashMap<(String, String), Option<(f64, String)>> =
        std::collections::HashMap::new();
    for m in waiting {
        // The running measurement's own pace once it has taken a sample;
        // before that, and for those queued, the pace of the same target's
        // last complete measurements: a dim target's samples take several
        // times a bright one's (another target's pace said "about 6 s" of a
        // CYLINDER measurement that took 57 s); none known, no estimate. A
        // free measurement (no target) takes the instrument's recent pace.
        let own = match src.status {
            InstrumentStatus::Measuring {
                measurement_id,
                sample,
                expected_finish_at: Some(end),
                ..
            } if *measurement_id == m.id && *sample > 0 => {
                Some(((end - now).max(0.0), "this measurement's own pace so far".to_string()))
            }
            _ => None,
        };
        let basis = match (own, &m.scene, &m.target) {
            (Some(own), _, _) => Some(own),
            (None, Some(scene), Some(target)) => {
                let key = (scene.clone(), target.clone());
                if !target_paces.contains_key(&key) {
                    let pace = target_pace(src, scene, target).await?;
                    target_paces.insert(key.clone(), pace);
                }
                target_paces[&key].clone().map(|(pace, source)| {
                    let to_take = (m.samples_requested - m.samples_taken).max(0) as f64;
                    (
                        pace * to_take,
                        format!("samples still to take × {pace:.2} s per sample ({source})"),
                    )
                })
            }
            (None, _, _) => pace.map(|pace| {
                let to_take = (m.samples_requested - m.samples_taken).max(0) as f64;
                (
                    pace * to_take,
                    format!(
                        "samples still to take × {pace:.2} s per sample ({})",
                        pace_source.as_deref().unwrap_or("the instrument's recent pace")
                    ),
                )
            }),
        };
        let (left, estimate) = match basis {
            Some((r, how)) if known => {
                ahead += r;
                (Some(ahead), Some(format!("{how}, after the measurements ahead")))
            }
            _ => {
                known = false;
                (None, None)
            }
        };
        let target = match (&m.scene, &m.target) {
            (Some(s), Some(t)) => format!("{s}/{t}"),
            _ => "free measurement".to_string(),
        };
        jobs.push(QueuedJob {
            kind: "measurement",
            id: m.id,
            state: m.state.as_str().to_string(),
            what: if m.note.is_empty() {
                format!("{target}, {}", samples_text(m.samples_requested))
            } else {
                format!("{target}, {}: {}", samples_text(m.samples_requested), m.note)
            },
            scene: m.scene.clone(),
            parent_id: None,
            created_at: Some(m.created_at),
            started_at: m.started_at,
            done: Some(m.samples_taken as f64),
            total: Some(m.samples_requested as f64),
            unit: Some("samples".into()),
            step: None,
            seconds_left: left,
            estimate,
        });
    }
    if let Some(renders) = src.renders {
        render_and_study_jobs(src, renders, now, &mut jobs).await?;
    }
    experiment_sessions(src, &mut jobs).await?;
    Ok(Queue {
        booth: src.booth.to_string(),
        at: now,
        seconds_per_sample: pace,
        pace_source,
        jobs,
    })
}

/// Seconds per sample of `scene`/`target` in this booth: the median over
/// its last complete measurements, and where that figure comes from.
async fn target_pace(src: &QueueSources<'_>, scene: &str, target: &str) -> Result<Option<(f64, String)>, StoreError> {
    let Some((pace, n)) = median_pace(src, Some((scene, target))).await? else {
        return Ok(None);
    };
    let source = if n == 1 {
        format!("the last complete measurement of {scene}/{target}")
    } else {
        format!("median of the last {n} complete measurements of {scene}/{target}")
    };
    Ok(Some((pace, source)))
}

/// The median seconds per sample over this booth's last
/// [`PACE_FROM_LAST`] complete measurements (of one scene's target, or of
/// any), and how many it is the median of; `None` without one.
async fn median_pace(
    src: &QueueSources<'_>,
    scene_target: Option<(&str, &str)>,
) -> Result<Option<(f64, usize)>, StoreError> {
    let recent = src
        .store
        .list_measurements(&MeasurementFilter {
            booth: Some(src.booth.clone()),
            scene: scene_target.map(|(s, _)| s.to_string()),
            target: scene_target.map(|(_, t)| t.to_string()),
            state: Some(MeasurementState::Complete),
            limit: Some(PACE_FROM_LAST),
            ..MeasurementFilter::default()
        })
        .await?;
    let mut paces: Vec<f64> = recent
        .items
        .iter()
        .filter_map(|m| Some((m.finished_at? - m.started_at?) / m.samples_taken.max(1) as f64))
        .filter(|p| p.is_finite() && *p >= 0.0)
        .collect();
    if paces.is_empty() {
        return Ok(None);
    }
    paces.sort_by(f64::total_cmp);
    Ok(Some((paces[paces.len() / 2], paces.len())))
}

/// "1 sample", "5 samples".
fn samples_text(n: i64) -> String {
    if n == 1 {
        "1 sample".into()
    } else {
        format!("{n} samples")
    }
}

/// Seconds per sample: the running measurement's own pace, else the median
/// over this booth's last complete measurements.
async fn instrument_pace(src: &QueueSources<'_>) -> Result<(Option<f64>, Option<String>), StoreError> {
    if let InstrumentStatus::Measuring {
        sample,
        started_at,
        expected_finish_at: Some(end),
        of,
        ..
    } = src.status
    {
        let pace = (end - started_at) / (*of).max(1) as f64;
        let source = if *sample > 0 {
            "the running measurement's pace so far"
        } else {
            "the previous measurement's pace"
        };
        return Ok((Some(pace), Some(source.into())));
    }
    let Some((median, n)) = median_pace(src, None).await? else {
        return Ok((None, None));
    };
    Ok((
        Some(median),
        Some(format!(
            "median of the last {n} complete measurement{}",
            if n == 1 { "" } else { "s" }
        )),
    ))
}

/// The progress fields of a job counted in percent of `unit` (renders,
/// studies, images); the caller fills in what the job is.
fn in_percent(fraction: Option<f64>, unit: &str, seconds_left: Option<f64>, estimate: &str) -> QueuedJob {
    QueuedJob {
        done: fraction.map(|f| (f * 100.0).round()),
        total: fraction.map(|_| 100.0),
        unit: fraction.map(|_| format!("% of {unit}")),
        seconds_left,
        estimate: seconds_left.map(|_| estimate.to_string()),
        ..QueuedJob::default()
    }
}

async fn render_and_study_jobs(
    src: &QueueSources<'_>,
    renders: &RenderJobs,
    now: f64,
    jobs: &mut Vec<QueuedJob>,
) -> Result<(), StoreError> {
    // (fraction, seconds left, the step under way, first report) from the
    // event board; a step with no count has no fraction.
    let from_board = |job: Job, id: i64| match src.progress.and_then(|board| board.get(job, id)) {
        Some(p) => (
            (p.fraction >= 0.0).then_some(p.fraction),
            p.seconds_left_at(now),
            p.message,
            Some(p.started_at),
        ),
        None => (None, None, None, None),
    };
    for r in src.store.unfinished_renders().await? {
        let (fraction, left, step, started_at) = from_board(Job::Render, r.id);
        let step = step.filter(|_| r.state == "running");
        let (unit, estimate) = render_step_estimate(step.as_deref());
        jobs.push(QueuedJob {
            kind: "render",
            id: r.id,
            state: r.state.clone(),
            what: format!("render of {} ({})", r.scene, r.codings.join(", ")),
            scene: Some(r.scene.clone()),
            created_at: Some(r.created_at),
            started_at: started_at.filter(|_| r.state == "running"),
            ..in_percent(fraction.filter(|_| !unit.is_empty()), &unit, left, &estimate)
        });
        if let Some(job) = jobs.last_mut() {
            job.step = step;
        }
    }
    for s in src.store.unfinished_studies().await? {
        let (fraction, left, step, _) = from_board(Job::Study, s.id);
        let scenes = s.request.get("scenes").and_then(|v| v.as_str()).unwrap_or("all scenes");
        jobs.push(QueuedJob {
            kind: "study",
            id: s.id,
            state: s.state.clone(),
            what: format!("study of {scenes}"),
            created_at: Some(s.created_at),
            step,
            ..in_percent(
                fraction,
                "steps",
                left,
                "time so far × steps still to do / steps done (steps counted as equal)",
            )
        });
    }
    {
        let images = renders.images();
        for i in images.unfinished() {
            let fraction = i.progress.as_ref().map(|p| p.paths as f64 / p.max_paths.max(1) as f64);
            // An upper bound under its path cap and its time budget, or none.
            let (left, estimate) = match &i.progress {
                Some(p) => image_time_left(p, i.settings.time_budget_s),
                None => (None, String::new()),
            };
            jobs.push(QueuedJob {
                kind: "image",
                id: i.id,
                state: i.state.clone(),
                what: format!("camera image of {} ({})", i.scene, i.settings.coding),
                scene: Some(i.scene.clone()),
                parent_id: Some(i.render_id),
                ..in_percent(fraction, "its path cap", left, &estimate)
            });
        }
    }
    Ok(())
}

/// A render's unit of progress and how its estimate is made, for its step
/// (`lab::progress::RENDER_STEPS`): each step's estimate is that step's
/// alone, and says which steps follow it.
fn render_step_estimate(step: Option<&str>) -> (String, String) {
    use super::progress::RENDER_STEPS;
    let k = step.and_then(|s| RENDER_STEPS.iter().position(|(name, _)| *name == s));
    let Some(k) = k else {
        return ("paths".into(), String::new());
    };
    let (name, unit) = RENDER_STEPS[k];
    let after: Vec<&str> = RENDER_STEPS[k + 1..].iter().map(|(n, _)| *n).collect();
    let then = if after.is_empty() {
        String::new()
    } else {
        format!("; then {}, not counted", after.join(", then "))
    };
    (
        unit.to_string(),
        format!("{name} only: time so far in it × {unit} still to do / {unit} done{then}"),
    )
}

/// The running experiment sessions of this booth's experiments, from one
/// query of counts (no session's trials are read): a session untouched for
/// [`PAUSED_AFTER_S`] is listed as `paused` (resumable from where it
/// stopped, by starting the observer again).
async fn experiment_sessions(src: &QueueSources<'_>, jobs: &mut Vec<QueuedJob>) -> Result<(), StoreError> {
    let at = lightbooth_store::now();
    let mut requests: HashMap<i64, Option<ExperimentRequest>> = HashMap::new();
    for s in src.store.running_experiment_sessions(src.booth.as_str()).await? {
        let request = requests
            .entry(s.experiment_id)
            .or_insert_with(|| serde_json::from_str(&s.request_json).ok());
        let total = request.as_ref().map(|r| trials_needed(r, s.dropped as usize) as f64);
        let paused = at - s.touched_at > PAUSED_AFTER_S;
        jobs.push(QueuedJob {
            kind: "experiment_session",
            id: s.id,
            state: if paused { "paused" } else { "running" }.into(),
            what: format!(
                "experiment {} ({}): observer {}",
                s.experiment_id, s.experiment_name, s.observer_id
            ),
            scene: Some(s.scene),
            parent_id: Some(s.experiment_id),
            created_at: Some(s.created_at),
            started_at: Some(s.created_at),
            done: Some(s.trials as f64),
            total,
            unit: Some("trials".into()),
            step: paused.then(|| {
                format!(
                    "paused: untouched for over {:.0} min; start the observer again to resume",
                    PAUSED_AFTER_S / 60.0
                )
            }),
            ..QueuedJob::default()
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{completed_measurement, queued_measurement, store_in};

    async fn measured(store: &Store, scene: &str, target: &str) {
        completed_measurement(store, Some((scene, target))).await;
    }

    async fn jobs(store: &Store) -> Vec<QueuedJob> {
        let status = InstrumentStatus::Disconnected { reason: "test".into() };
        queue(&QueueSources {
            store,
            booth: &Booth::default(),
            status: &status,
            renders: None,
            progress: None,
        })
        .await
        .unwrap()
        .jobs
    }

    /// A CYLINDER target estimated at "about 6 s left" took 57 s: its
    /// estimate came from the pace of other targets (a bright one's samples
    /// are several times faster). A target never measured has no estimate,
    /// nor has anything queued after it; a target measured before is
    /// estimated from its own measurements, and says so. Its description
    /// counts "1 sample", not "1 samples".
    #[tokio::test]
    async fn a_target_is_never_estimated_from_another_targets_pace() {
        let dir = tempfile::tempdir().unwrap();
        let store = store_in(dir.path()).await;
        measured(&store, "white", "patch").await;
        let dim = queued_measurement(&store, Some(("cylinder", "h01"))).await;
        let bright = queued_measurement(&store, Some(("white", "patch"))).await;
        let q = jobs(&store).await;
        let job = |id: i64| {
            q.iter()
                .find(|j| j.kind == "measurement" && j.id == id)
                .unwrap()
                .clone()
        };
        assert_eq!(job(dim).seconds_left, None, "{:?}", job(dim).estimate);
        assert_eq!(job(dim).estimate, None);
        assert_eq!(job(bright).seconds_left, None, "after a measurement of unknown length");
        assert_eq!(job(dim).what, "cylinder/h01, 1 sample");
        // With the dim one out of the way, the bright one is estimated from its own target.
        assert!(store.cancel_queued(dim, "test").await.unwrap());
        let q = jobs(&store).await;
        let job = q.iter().find(|j| j.id == bright).unwrap();
        assert!(job.seconds_left.is_some(), "{job:?}");
        let how = job.estimate.as_deref().unwrap();
        assert!(how.contains("last complete measurement of white/patch"), "{how}");
    }
}
