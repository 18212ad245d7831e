//! An observer's session of an experiment: started (or resumed), shown
//! trial by trial, each trial stored as it ends.
//!
//! The server decides what each trial shows: the order follows from the
//! session's seed ([`session_order`]) and the trials recorded
//! ([`shown_order`]: a trial with a frame dropped during its pie is shown
//! again at the end and not counted). The page reports only what happened
//! (the key, its time, the frames), so a reloaded page, another browser or
//! a restarted daemon continues at the same trial; at most the trial on
//! screen is lost.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::{parts, Experiments, StoredColour};
use crate::display::output::OutputMethod;
use crate::lab::error::LabError;
use crate::psychophysics::design::{letters, session_order, shown_order, PlannedTrial};
use crate::psychophysics::presentation::{Presentation, MAX_REFRESH_HZ, MIN_REFRESH_HZ};
use crate::random::splitmix64;
use crate::store::{now, ExperimentSessionRow, TrialRow};

/// An observer id: 1–64 letters, digits, `.`, `_` or `-` (no names needed).
pub fn check_observer_id(id: &str) -> Result<(), LabError> {
    let ok = (1..=64).contains(&id.len())
        && id
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-'));
    if ok {
        Ok(())
    } else {
        Err(LabError::Invalid(format!(
            "observer = `{id}`: give an id of 1–64 letters, digits, `.`, `_` or `-` (e.g. `obs01`; no names needed)"
        )))
    }
}

/// Everything the session page needs to show the next trial.
#[derive(Clone, Debug, Serialize, ToSchema)]
pub struct SessionView {
    pub session: ExperimentSessionRow,
    pub experiment_id: i64,
    pub experiment_name: String,
    pub presentation: Presentation,
    #[schema(value_type = String)]
    pub output: OutputMethod,
    /// The display profile's fitted γ of red, green, blue: the page turns
    /// linear RGB into drive per pixel with them.
    pub gammas: [f64; 3],
    pub original: StoredColour,
    pub approximations: Vec<StoredColour>,
    pub background: StoredColour,
    pub trials_recorded: usize,
    /// Trials the session needs so far (the planned ones and the repeats).
    pub trials_total: usize,
    /// Trials shown again because a frame was dropped during their pie.
    pub repeats: usize,
    /// The trial to show now; none when the session is complete.
    pub next: Option<NextTrial>,
}

/// The trial to show.
#[derive(Clone, Debug, Serialize, ToSchema)]
pub struct NextTrial {
    pub position: usize,
    /// Index into the experiment's approximations.
    pub approximation_index: usize,
    pub approximation: String,
    /// Left, top, right: `O` the original, `N` the approximation.
    pub configuration: String,
}

/// What happened in one trial, as the page reports it.
#[derive(Clone, Debug, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct TrialReport {
    /// The trial's position (the `next.position` the page was given).
    pub position: usize,
    /// The key: 0 left, 1 top, 2 right.
    pub response: u8,
    /// The key event's `timeStamp` minus the pie's first frame, ms.
    pub reaction_ms: f64,
    /// Frames the pie was on screen.
    pub stimulus_frames: u32,
    /// Frame intervals over 1.5 frames during the trial.
    pub dropped_frames: u32,
    /// One of them while the pie was shown.
    pub dropped_in_stimulus: bool,
    /// Every frame interval of the trial, ms (at most [`MAX_FRAME_INTERVALS`]).
    pub frame_intervals_ms: Vec<f64>,
}

/// A trial reports at most this many frame intervals (a minute at 1000 Hz).
pub const MAX_FRAME_INTERVALS: usize = 60_000;

/// What the page measured of the display before the first trial.
#[derive(Clone, Debug, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct DisplayReport {
    /// Median `requestAnimationFrame` interval, ms.
    pub frame_ms: f64,
    /// The browser and output path, e.g. its user agent and "WebGL2, 8-bit canvas".
    #[serde(default)]
    pub client: String,
}

impl Experiments {
    /// Starts a session of `observer`, or resumes its running one.
    pub async fn start_session(&self, experiment_id: i64, observer: &str) -> Result<SessionView, LabError> {
        check_observer_id(observer)?;
        let e = self.get(experiment_id).await?;
        let sessions = self.store.sessions_of_experiment(experiment_id).await?;
        if let Some(s) = sessions
            .iter()
            .rev()
            .find(|s| s.observer_id == observer && s.state == "running")
        {
            return self.view(s.id).await;
        }
        let seed = (splitmix64((e.seed as u64).wrapping_add(sessions.len() as u64 + 1)) >> 1) as i64;
        let id = self
            .store
            .create_experiment_session(experiment_id, observer, seed)
            .await?;
        self.view(id).await
    }

    async fn session(&self, session_id: i64) -> Result<ExperimentSessionRow, LabError> {
        self.store
            .get_experiment_session(session_id)
            .await?
            .ok_or_else(|| LabError::NotFound(format!("there is no session {session_id}")))
    }

    /// The session's state and its next trial.
    pub async fn view(&self, session_id: i64) -> Result<SessionView, LabError> {
        let session = self.session(session_id).await?;
        let e = self.get(session.experiment_id).await?;
        let (request, check) = parts(&e)?;
        let profile = self
            .store
            .get_display_profile(e.display_profile_id)
            .await?
            .ok_or_else(|| LabError::Internal(format!("experiment {}: its display profile is gone", e.id)))?
            .profile;
        let trials = self.store.trials_of_session(session_id).await?;
        let order = order_of(
            &session,
            request.approximations.len(),
            request.presentation.repeats,
            &trials,
        )?;
        let next = order.get(trials.len()).map(|t| NextTrial {
            position: trials.len(),
            approximation_index: t.approximation,
            approximation: request.approximations[t.approximation].clone(),
            configuration: letters(t.configuration),
        });
        let planned = request.approximations.len() * 6 * request.presentation.repeats as usize;
        Ok(SessionView {
            experiment_id: e.id,
            experiment_name: e.name.clone(),
            presentation: request.presentation,
            output: request.output,
            gammas: [0, 1, 2].map(|c| profile.transfer[c].gamma),
            original: check.original,
            approximations: check.approximations,
            background: check.background,
            trials_recorded: trials.len(),
            trials_total: order.len(),
            repeats: order.len() - planned,
            next,
            session,
        })
    }

    /// Records the refresh the page measured.
    pub async fn report_display(&self, session_id: i64, report: &DisplayReport) -> Result<SessionView, LabError> {
        self.session(session_id).await?;
        let hz = 1000.0 / report.frame_ms;
        if !report.frame_ms.is_finite() || !(MIN_REFRESH_HZ..=MAX_REFRESH_HZ).contains(&hz) {
            return Err(LabError::Invalid(format!(
                "frame_ms = {}: a display refreshes at {MIN_REFRESH_HZ}–{MAX_REFRESH_HZ} Hz (1–50 ms a frame); \
                 close other tabs and measure again",
                report.frame_ms
            )));
        }
        let client: String = report.client.chars().take(500).collect();
        self.store
            .set_session_display(session_id, report.frame_ms, &client)
            .await?;
        self.view(session_id).await
    }

    /// Stores one trial as it ended, and completes the session after its last.
    pub async fn record_trial(&self, session_id: i64, report: &TrialReport) -> Result<SessionView, LabError> {
        let session = self.session(session_id).await?;
        let e = self.get(session.experiment_id).await?;
        let (request, _) = parts(&e)?;
        if report.response > 2 {
            return Err(LabError::Invalid(format!(
                "response = {}: give 0 (left), 1 (top) or 2 (right)",
                report.response
            )));
        }
        if !report.reaction_ms.is_finite() || !(0.0..=3_600_000.0).contains(&report.reaction_ms) {
            return Err(LabError::Invalid(format!(
                "reaction_ms = {}: give 0–3600000 ms from the pie's first frame",
                report.reaction_ms
            )));
        }
        if report.frame_intervals_ms.len() > MAX_FRAME_INTERVALS {
            return Err(LabError::Invalid(format!(
                "frame_intervals_ms has {} intervals: at most {MAX_FRAME_INTERVALS}",
                report.frame_intervals_ms.len()
            )));
        }
        if let Some((i, v)) = report
            .frame_intervals_ms
            .iter()
            .enumerate()
            .find(|(_, v)| !v.is_finite() || **v < 0.0 || **v > 60_000.0)
        {
            return Err(LabError::Invalid(format!(
                "frame_intervals_ms[{i}] = {v}: give 0–60000 ms"
            )));
        }
        if u64::from(report.dropped_frames) > report.frame_intervals_ms.len() as u64 {
            return Err(LabError::Invalid(format!(
                "dropped_frames = {} but only {} frame intervals are reported",
                report.dropped_frames,
                report.frame_intervals_ms.len()
            )));
        }
        let trials = self.store.trials_of_session(session_id).await?;
        let order = order_of(
            &session,
            request.approximations.len(),
            request.presentation.repeats,
            &trials,
        )?;
        if session.state != "running" {
            return Err(LabError::Conflict(format!(
                "session {session_id} is complete: it takes no more trials"
            )));
        }
        if report.position != trials.len() {
            return Err(LabError::Conflict(format!(
                "position = {}: session {session_id} has {} trials recorded, so the next is trial {}",
                report.position,
                trials.len(),
                trials.len()
            )));
        }
        let planned = order[report.position];
        let trial = TrialRow {
            session_id,
            position: report.position as i64,
            approximation: request.approximations[planned.approximation].clone(),
            configuration: letters(planned.configuration),
            response: i64::from(report.response),
            correct: usize::from(report.response) == planned.configuration.odd_position(),
            reaction_ms: report.reaction_ms,
            stimulus_frames: i64::from(report.stimulus_frames),
            dropped_frames: i64::from(report.dropped_frames),
            dropped_in_stimulus: report.dropped_in_stimulus,
            frame_intervals_ms: report.frame_intervals_ms.clone(),
            created_at: now(),
        };
        self.store.insert_trial(&trial).await?;
        // The order grows by a repeat when this trial dropped a frame (up to its cap).
        let mut dropped: Vec<bool> = trials.iter().map(|t| t.dropped_in_stimulus).collect();
        dropped.push(report.dropped_in_stimulus);
        let planned_trials = session_order(
            session.seed as u64,
            request.approximations.len(),
            request.presentation.repeats,
        )
        .map_err(LabError::Internal)?;
        let needed = shown_order(&planned_trials, &dropped).len();
        if trials.len() + 1 >= needed {
            self.store.finish_experiment_session(session_id).await?;
        }
        self.view(session_id).await
    }
}

/// The order of a session given its recorded trials (see the module doc).
fn order_of(
    session: &ExperimentSessionRow,
    approximations: usize,
    repeats: u32,
    trials: &[TrialRow],
) -> Result<Vec<PlannedTrial>, LabError> {
    let planned = session_order(session.seed as u64, approximations, repeats).map_err(LabError::Internal)?;
    let dropped: Vec<bool> = trials.iter().map(|t| t.dropped_in_stimulus).collect();
    Ok(shown_order(&planned, &dropped))
}
