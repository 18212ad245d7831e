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
//!   the fraction still to do ([`super::progress`]);
//! - a camera image: its paths traced against its cap, an upper bound (it
//!   stops earlier once every pixel reaches its noise target);
//! - an experiment session: trials recorded of those it needs (from
//!   counts); no time, an observer sets the pace. One untouched for
//!   [`PAUSED_AFTER_S`] is `paused`, not running.

use std::collections::HashMap;

use serde::Serialize;
use utoipa::ToSchema;

use super::experiments::session::{trials_needed, PAUSED_AFTER_S};
use super::experiments::ExperimentRequest;
use super::instrument_queue::InstrumentStatus;
use super::progress::{seconds_left, ProgressBoard};
use super::services::RenderService;
use crate::store::{Booth, Job, MeasurementFilter, MeasurementState, MeasurementSummary, Store, StoreError};

/// Complete measurements the instrument's recent pace is the median of.
const PACE_FROM_LAST: i64 = 10;

/// One job waiting or under way.
#[derive(Clone, Debug, Default, Serialize, ToSchema)]
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
#[derive(Clone, Debug, Serialize, ToSchema)]
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
    pub renders: Option<&'a dyn RenderService>,
    pub progress: Option<&'a ProgressBoard>,
}

/// The queue now.
pub async fn queue(src: &QueueSources<'_>) -> Result<Queue, StoreError> {
    let now = crate::store::now();
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
    for m in waiting {
        let remaining = match (src.status, pace) {
            (
                InstrumentStatus::Measuring {
                    measurement_id,
                    expected_finish_at: Some(end),
                    ..
                },
                _,
            ) if *measurement_id == m.id => Some((end - now).max(0.0)),
            (_, Some(pace)) => Some(pace * (m.samples_requested - m.samples_taken).max(0) as f64),
            _ => None,
        };
        let left = match remaining {
            Some(r) if known => {
                ahead += r;
                Some(ahead)
            }
            _ => {
                known = false;
                None
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
                format!("{target}, {} samples", m.samples_requested)
            } else {
                format!("{target}, {} samples: {}", m.samples_requested, m.note)
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
            estimate: left.map(|_| {
                format!(
                    "samples still to take × {:.2} s per sample ({}), after the measurements ahead",
                    pace.unwrap_or(0.0),
                    pace_source.as_deref().unwrap_or("this measurement's pace")
                )
            }),
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
    let recent = src
        .store
        .list_measurements(&MeasurementFilter {
            booth: Some(src.booth.clone()),
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
        return Ok((None, None));
    }
    paces.sort_by(f64::total_cmp);
    let median = paces[paces.len() / 2];
    Ok((
        Some(median),
        Some(format!(
            "median of the last {} complete measurement{}",
            paces.len(),
            if paces.len() == 1 { "" } else { "s" }
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
    renders: &dyn RenderService,
    now: f64,
    jobs: &mut Vec<QueuedJob>,
) -> Result<(), StoreError> {
    // (fraction, seconds left, the step under way) from the event board.
    let from_board = |job: Job, id: i64| match src.progress.and_then(|board| board.get(job, id)) {
        Some(p) => (Some(p.fraction.max(0.0)), p.seconds_left_at(now), p.message),
        None => (None, None, None),
    };
    for r in src.store.unfinished_renders().await? {
        let (fraction, left, _) = from_board(Job::Render, r.id);
        jobs.push(QueuedJob {
            kind: "render",
            id: r.id,
            state: r.state.clone(),
            what: format!("render of {} ({})", r.scene, r.codings.join(", ")),
            scene: Some(r.scene.clone()),
            created_at: Some(r.created_at),
            ..in_percent(
                fraction,
                "paths",
                left,
                "time so far × paths still to trace / paths traced",
            )
        });
    }
    for s in src.store.unfinished_studies().await? {
        let (fraction, left, step) = from_board(Job::Study, s.id);
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
    if let Some(images) = renders.images() {
        for i in images.unfinished() {
            let fraction = i.progress.as_ref().map(|p| p.paths as f64 / p.max_paths.max(1) as f64);
            let elapsed = i.progress.as_ref().map(|p| p.elapsed_seconds);
            // Its time budget bounds it too.
            let budget_left = elapsed.map(|e| (i.settings.time_budget_s - e).max(0.0));
            let left = match (fraction.zip(elapsed).and_then(|(f, e)| seconds_left(e, f)), budget_left) {
                (Some(l), Some(b)) => Some(l.min(b)),
                (l, _) => l,
            };
            jobs.push(QueuedJob {
                kind: "image",
                id: i.id,
                state: i.state.clone(),
                what: format!("camera image of {} ({})", i.scene, i.settings.coding),
                scene: Some(i.scene.clone()),
                parent_id: Some(i.render_id),
                ..in_percent(
                    fraction,
                    "its path cap",
                    left,
                    "at most: time so far × paths still allowed / paths traced, within its time budget",
                )
            });
        }
    }
    Ok(())
}

/// The running experiment sessions of this booth's experiments, from one
/// query of counts (no session's trials are read): a session untouched for
/// [`PAUSED_AFTER_S`] is listed as `paused` (resumable from where it
/// stopped, by starting the observer again).
async fn experiment_sessions(src: &QueueSources<'_>, jobs: &mut Vec<QueuedJob>) -> Result<(), StoreError> {
    let at = crate::store::now();
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
