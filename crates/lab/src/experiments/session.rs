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

use super::{parts, Experiments, StoredColour};
use crate::error::LabError;
use lightbooth_science::display::output::OutputMethod;
use lightbooth_science::psychophysics::design::{letters, session_order, shown_order, PlannedTrial};
use lightbooth_science::psychophysics::presentation::{Presentation, MAX_REFRESH_HZ, MIN_REFRESH_HZ};
use lightbooth_store::{now, ExperimentSessionRow, TrialRow};

/// Every seed (an experiment's and a session's) is at most this, 2⁵³ − 1:
/// JavaScript and MATLAB read JSON numbers as doubles, which hold every
/// integer up to it exactly (issue 32: the page showed 9043539040596399000
/// for 9043539040596399293).
pub const MAX_SEED: u64 = (1 << 53) - 1;

/// A running session untouched (no start, display report or trial) for
/// this long is listed as paused: resumable, not running. Longer than the
/// longest adaptation (1800 s) and a trial.
pub const PAUSED_AFTER_S: f64 = 2700.0;

/// Over this share of a session's trials excluded (a frame dropped during
/// the pie), the session and the analysis warn the operator.
pub const MAX_EXCLUDED_SHARE: f64 = 0.2;

/// A session's seed: the experiment's seed and the session's id mixed by a
/// bijection of 53-bit numbers, so two sessions of one experiment never
/// share a seed (and with it a trial order) and every seed is at most
/// [`MAX_SEED`].
pub fn session_seed(experiment_seed: u64, session_id: i64) -> i64 {
    // xorshifts and multiplications by odd numbers, each a bijection modulo 2⁵³.
    let mut x = experiment_seed.wrapping_add(session_id as u64) & MAX_SEED;
    x ^= x >> 30;
    x = x.wrapping_mul(0xbf58_476d_1ce4_e5b9) & MAX_SEED;
    x ^= x >> 27;
    x = x.wrapping_mul(0x94d0_49bb_1331_11eb) & MAX_SEED;
    x ^= x >> 31;
    x as i64
}

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
#[derive(Clone, Debug, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct SessionView {
    pub session: ExperimentSessionRow,
    pub experiment_id: i64,
    pub experiment_name: String,
    pub presentation: Presentation,
    #[cfg_attr(feature = "openapi", schema(value_type = String))]
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
    /// Trials recorded with a frame dropped during their pie: not counted.
    pub excluded: usize,
    /// For the operator, when over [`MAX_EXCLUDED_SHARE`] of the trials
    /// are excluded: how many, and what to do.
    pub warning: Option<String>,
    /// The trial to show now; none when the session is complete.
    pub next: Option<NextTrial>,
}

/// The trial to show.
#[derive(Clone, Debug, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct NextTrial {
    pub position: usize,
    /// Index into the experiment's approximations.
    pub approximation_index: usize,
    pub approximation: String,
    /// Left, top, right: `O` the original, `N` the approximation.
    pub configuration: String,
}

/// What happened in one trial, as the page reports it.
#[derive(Clone, Debug, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
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
    /// Every frame interval of the trial, ms (at most
    /// [`MAX_FRAME_INTERVALS`]): interval `i` is from frame `i` to frame
    /// `i + 1`, the cross's frames first, then the pie's. The daemon checks
    /// the counts, the flag and the reaction time against them
    /// ([`check_trial`]).
    pub frame_intervals_ms: Vec<f64>,
}

/// An interval within this of 1.5 frames counts as dropped or not (the
/// page rounds intervals to the microsecond).
const INTERVAL_ROUNDING_MS: f64 = 0.001;

/// Checks a trial against its own frame intervals and the refresh its page
/// measured (`frame_ms`), with the page's rules (`web/trial.js`):
/// the cross for the fixation's frames, the pie for the stimulus's, an
/// interval over 1.5 frames dropped; the reaction time runs from the pie's
/// first frame on screen. What contradicts itself is refused, naming the
/// field.
pub fn check_trial(report: &TrialReport, frame_ms: f64, p: &Presentation) -> Result<(), String> {
    if report.response > 2 {
        return Err(format!(
            "response = {}: give 0 (left), 1 (top) or 2 (right)",
            report.response
        ));
    }
    let intervals = &report.frame_intervals_ms;
    if intervals.len() > MAX_FRAME_INTERVALS {
        return Err(format!(
            "frame_intervals_ms has {} intervals: at most {MAX_FRAME_INTERVALS}",
            intervals.len()
        ));
    }
    if let Some((i, v)) = intervals
        .iter()
        .enumerate()
        .find(|(_, v)| !v.is_finite() || **v < 0.0 || **v > 60_000.0)
    {
        return Err(format!("frame_intervals_ms[{i}] = {v}: give 0–60000 ms"));
    }
    // The page's `frames()`: the nearest whole number of frames, at least one.
    let frames = |ms: f64| {
        if ms <= 0.0 {
            0
        } else {
            ((ms / frame_ms).round() as usize).max(1)
        }
    };
    let (fixation, stimulus) = (frames(p.fixation_ms), frames(p.stimulus_ms));
    if report.stimulus_frames as usize != stimulus {
        return Err(format!(
            "stimulus_frames = {}: the pie is shown for {stimulus} frames ({} ms at the session's measured \
             frame of {frame_ms} ms)",
            report.stimulus_frames, p.stimulus_ms
        ));
    }
    if intervals.len() < fixation + stimulus {
        return Err(format!(
            "frame_intervals_ms has {} intervals: a trial is at least {} (the cross's {fixation} frames and the \
             pie's {stimulus}, each followed by an interval)",
            intervals.len(),
            fixation + stimulus
        ));
    }
    let threshold = 1.5 * frame_ms;
    let surely = |v: &f64| *v > threshold + INTERVAL_ROUNDING_MS;
    let maybe = |v: &f64| *v > threshold - INTERVAL_ROUNDING_MS;
    let (least, most) = (
        intervals.iter().filter(|v| surely(v)).count(),
        intervals.iter().filter(|v| maybe(v)).count(),
    );
    let dropped = report.dropped_frames as usize;
    if !(least..=most).contains(&dropped) {
        return Err(format!(
            "dropped_frames = {dropped}: frame_intervals_ms has {least} intervals over 1.5 frames \
             ({threshold:.3} ms at the session's measured frame of {frame_ms} ms)"
        ));
    }
    let pie = &intervals[fixation..fixation + stimulus];
    if report.dropped_in_stimulus && !pie.iter().any(maybe) {
        return Err(format!(
            "dropped_in_stimulus = true: no interval of the pie's frames (frame_intervals_ms[{fixation}..{}]) \
             is over 1.5 frames ({threshold:.3} ms)",
            fixation + stimulus
        ));
    }
    if !report.dropped_in_stimulus && pie.iter().any(surely) {
        let (i, v) = pie.iter().enumerate().find(|(_, v)| surely(v)).expect("found above");
        return Err(format!(
            "dropped_in_stimulus = false: frame_intervals_ms[{}] = {v} ms, during the pie, is over 1.5 frames \
             ({threshold:.3} ms): a frame was dropped while it was shown",
            fixation + i
        ));
    }
    // The pie's first frame is on screen at the frame after it was drawn;
    // the key comes before the frame that ends the trial (give a frame or two).
    let after_onset: f64 = intervals[fixation + 1..].iter().sum();
    let latest = after_onset + 2.0 * frame_ms;
    let r = report.reaction_ms;
    if !r.is_finite() || r <= 0.0 || r > latest {
        return Err(format!(
            "reaction_ms = {r}: the key must come after the pie's first frame reached the screen and before the \
             trial's last frame: above 0 and at most {latest:.1} ms by this trial's frame_intervals_ms"
        ));
    }
    Ok(())
}

/// A trial reports at most this many frame intervals (a minute at 1000 Hz).
pub const MAX_FRAME_INTERVALS: usize = 60_000;

/// What the page measured of the display before the first trial.
#[derive(Clone, Debug, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(deny_unknown_fields)]
pub struct DisplayReport {
    /// Median `requestAnimationFrame` interval, ms.
    pub frame_ms: f64,
    /// The browser and output path, e.g. its user agent and "WebGL2, 8-bit canvas".
    #[serde(default)]
    pub client: String,
}

impl Experiments {
    /// Starts a session of `observer`, or resumes its running one (one
    /// running session per observer and experiment, however many tabs
    /// start it at once: the store's unique index decides).
    pub async fn start_session(&self, experiment_id: i64, observer: &str) -> Result<SessionView, LabError> {
        check_observer_id(observer)?;
        let e = self.get(experiment_id).await?;
        let base = e.seed as u64;
        let (id, _) = self
            .store
            .create_experiment_session(experiment_id, observer, |id| session_seed(base, id))
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
        let excluded = trials.iter().filter(|t| t.dropped_in_stimulus).count();
        let warning = excluded_warning(excluded, trials.len());
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
            excluded,
            warning,
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
        if !self
            .store
            .set_session_display(session_id, report.frame_ms, &client)
            .await?
        {
            return Err(LabError::Conflict(format!(
                "session {session_id} is {}: its display is no longer reported (start a new session to measure it again)",
                self.session(session_id).await?.state
            )));
        }
        self.view(session_id).await
    }

    /// Stores one trial as it ended, and completes the session with its
    /// last (one transaction, [`lightbooth_store::Store::insert_trial`]).
    pub async fn record_trial(&self, session_id: i64, report: &TrialReport) -> Result<SessionView, LabError> {
        let session = self.session(session_id).await?;
        let e = self.get(session.experiment_id).await?;
        let (request, _) = parts(&e)?;
        if session.state != "running" {
            return Err(LabError::Conflict(format!(
                "session {session_id} is complete: it takes no more trials"
            )));
        }
        let Some(frame_ms) = session.frame_ms else {
            return Err(LabError::Conflict(format!(
                "session {session_id} has no measured refresh: the page reports it before the first trial \
                 (POST /api/experiment-sessions/{session_id}/display)"
            )));
        };
        check_trial(report, frame_ms, &request.presentation).map_err(LabError::Invalid)?;
        let trials = self.store.trials_of_session(session_id).await?;
        let order = order_of(
            &session,
            request.approximations.len(),
            request.presentation.repeats,
            &trials,
        )?;
        if trials.len() >= order.len() || report.position >= order.len() {
            // All its trials are in (the trial that completes it is being
            // stored, or a daemon stopped before marking it): complete.
            return Err(LabError::Conflict(format!(
                "session {session_id} is complete: all {} trials are recorded; it takes no more \
                 (position = {} is outside its order)",
                order.len(),
                report.position
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
        // The store takes it only at `position` = the trials recorded, so the
        // order read above is the one it extends.
        self.store.insert_trial(&trial, trials.len() + 1 >= needed).await?;
        self.view(session_id).await
    }

    /// Completes the running sessions found with all their trials recorded
    /// (a daemon stopped between a session's last trial and its end before
    /// both were one transaction) of `booth`'s experiments; returns their
    /// ids. Run by the booth's daemon at start-up.
    pub async fn complete_finished_sessions(&self, booth: &str) -> Result<Vec<i64>, LabError> {
        let mut repaired = Vec::new();
        for s in self.store.running_experiment_sessions(booth).await? {
            let request: super::ExperimentRequest = serde_json::from_str(&s.request_json)
                .map_err(|err| LabError::Internal(format!("experiment {}: request: {err}", s.experiment_id)))?;
            let total = trials_needed(&request, s.dropped as usize);
            if s.trials as usize >= total {
                self.store.finish_experiment_session(s.id).await?;
                repaired.push(s.id);
            }
        }
        Ok(repaired)
    }
}

/// The trials a session of `request` needs with `dropped` trials excluded
/// so far: the planned ones and a repeat of each excluded one, at most as
/// many repeats as planned trials ([`shown_order`]), from counts alone.
pub fn trials_needed(request: &super::ExperimentRequest, dropped: usize) -> usize {
    let planned = request.approximations.len() * 6 * request.presentation.repeats as usize;
    planned + dropped.min(planned)
}

/// The operator's warning when over [`MAX_EXCLUDED_SHARE`] of `recorded`
/// trials are excluded.
pub fn excluded_warning(excluded: usize, recorded: usize) -> Option<String> {
    (recorded > 0 && excluded as f64 > MAX_EXCLUDED_SHARE * recorded as f64).then(|| {
        format!(
            "{excluded} of {recorded} trials ({:.0} %) had a frame dropped during the pie and are not counted \
             (more than {:.0} %): the display drops frames; close other programs and tabs, check the refresh, \
             and look at the results before relying on them",
            100.0 * excluded as f64 / recorded as f64,
            100.0 * MAX_EXCLUDED_SHARE
        )
    })
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
