//! What the instrument task and the rest of the lab share: the queue of
//! [`MeasurementJob`]s the task takes one at a time, its live
//! [`InstrumentStatus`], the two handles it lends out — stopping the
//! running measurement ([`CancelMeasurement`]) and, with a simulated
//! instrument, injecting faults ([`MockControl`]) — and the
//! [`InstrumentHold`] a display calibration takes.
//!
//! # Holding the instrument
//!
//! A display calibration (or a verification) measures the display patch by
//! patch; a scene measurement taken between its patches re-aims the
//! instrument (an operator re-aims the real one; the simulated one follows
//! the measurement's scene target), and a patch measured after it read the
//! scene, not the display: a calibration once stored a profile fitted to
//! the GREEN scene patch as "red 60 %". So a calibration first takes the
//! hold, which it gets only while nothing is measuring or queued; while it
//! is held, every measurement and every change of the (simulated) display
//! must name the hold, and anything else is refused with 409 saying who
//! holds the instrument, since when, and how to release a hold whose
//! calibration is gone. A measurement naming a hold that has ended is
//! refused too, so a calibration that lost its hold stops instead of
//! fitting patches it did not own. The hold ends when released; a daemon
//! restart ends every hold.

use std::sync::Mutex;

use serde::Serialize;

use crate::error::LabError;

/// A measurement for the instrument task to take.
#[derive(Clone, Debug)]
pub struct MeasurementJob {
    pub id: i64,
    pub samples: usize,
    pub scene: Option<String>,
    pub target: Option<String>,
}

/// What the instrument is doing, as the dashboard shows it.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(tag = "state", rename_all = "snake_case")]
pub enum InstrumentStatus {
    /// No port open; `reason` says why and what the daemon is doing about it.
    Disconnected { reason: String },
    Idle {
        model: String,
        serial: Option<String>,
        /// What a measurement gives: `spectrum`, `XYZ` or `luminance`.
        measures: String,
        port: String,
    },
    Measuring {
        measurement_id: i64,
        /// Samples taken so far (the one under way is `sample + 1`).
        sample: usize,
        of: usize,
        /// The scene target measured, if any.
        scene: Option<String>,
        target: Option<String>,
        /// POSIX seconds: when the instrument took this measurement up.
        started_at: f64,
        /// POSIX seconds: when it should end if the remaining samples take
        /// as long as those taken (before the first, as long as the
        /// previous measurement's); null when nothing is known yet. An
        /// extrapolation, not a promise.
        expected_finish_at: Option<f64>,
    },
    /// Last operation failed; the daemon will retry.
    Error { message: String },
}

/// Stopping a running measurement; the instrument task provides it.
pub trait CancelMeasurement: Send + Sync {
    /// Asks measurement `id` to stop at once: between instrument commands, or
    /// within a poll slice of a reply being read, so at most the sample in
    /// progress is lost. False when `id` is not the measurement the
    /// instrument has taken (it is still queued, or already finished).
    fn cancel(&self, id: i64) -> bool;
}

/// Fault injection into the simulated PR-650 (`serve --mock` only).
pub trait MockControl: Send + Sync {
    /// `KIND[@DELAY][:RATE]`, comma-separated (see `lightbooth serve --help`); empty clears.
    fn set_faults(&self, spec: &str) -> Result<(), String>;
    /// Shows drives 0–1 per channel on the simulated display
    /// ([`lightbooth_science::display::SimulatedDisplay`]) the simulated PR-650 is aimed
    /// at: what it measures until a measurement names a scene target.
    fn show_on_display(&self, drive: [f64; 3]) -> Result<(), String>;
    /// Shows a patch whose pixels and frames had the codes `codes` (what a
    /// page drew, dithered or not): the simulated PR-650 sees their mean.
    fn show_codes_on_display(&self, codes: &lightbooth_science::display::CodeCounts) -> Result<(), String>;
}

/// The longest description of what holds the instrument, in characters.
pub const MAX_HOLD_PURPOSE: usize = 200;

/// Who holds the instrument, as the API shows it.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct HoldInfo {
    /// Name it in every measurement and display change while it holds.
    pub id: i64,
    /// What holds it, e.g. `display calibration “lab-lcd”`.
    pub purpose: String,
    /// POSIX seconds: when it was taken.
    pub since: f64,
}

/// The one hold on the instrument (see the module doc).
#[derive(Debug, Default)]
pub struct InstrumentHold {
    state: Mutex<HoldState>,
}

#[derive(Debug, Default)]
struct HoldState {
    current: Option<HoldInfo>,
    last_id: i64,
}

impl InstrumentHold {
    fn lock(&self) -> std::sync::MutexGuard<'_, HoldState> {
        self.state.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// The current hold, if any.
    pub fn current(&self) -> Option<HoldInfo> {
        self.lock().current.clone()
    }

    /// Takes the hold for `purpose` at time `now`; `busy` says what the
    /// instrument is doing (a measurement under way or queued), which must
    /// end first. 409 when held or busy, 400 for an empty or long purpose.
    pub fn take(&self, purpose: &str, busy: Option<String>, now: f64) -> Result<HoldInfo, LabError> {
        // The length and characters as given (as the OpenAPI document
        // states them), then not only white space.
        let refused = purpose.chars().count() > MAX_HOLD_PURPOSE || purpose.chars().any(char::is_control);
        let purpose = purpose.trim();
        if purpose.is_empty() || refused {
            return Err(LabError::Invalid(format!(
                "field `purpose`: say what holds the instrument in 1–{MAX_HOLD_PURPOSE} characters, \
                 without control characters"
            )));
        }
        let mut state = self.lock();
        if let Some(held) = &state.current {
            return Err(held_by(held));
        }
        if let Some(busy) = busy {
            return Err(LabError::Conflict(format!(
                "the instrument is busy ({busy}): a calibration holds it only once nothing is measuring or \
                 queued; wait for it, or cancel it"
            )));
        }
        state.last_id += 1;
        let hold = HoldInfo {
            id: state.last_id,
            purpose: purpose.to_string(),
            since: now,
        };
        state.current = Some(hold.clone());
        Ok(hold)
    }

    /// Ends hold `id`. 404 when it is not the current hold.
    pub fn release(&self, id: i64) -> Result<HoldInfo, LabError> {
        let mut state = self.lock();
        match &state.current {
            Some(h) if h.id == id => Ok(state.current.take().expect("checked")),
            _ => Err(LabError::NotFound(format!(
                "no hold {id} on the instrument (it has ended)"
            ))),
        }
    }

    /// Whether `what` (a measurement, a display change) may use the
    /// instrument now, naming `hold` (or none): when nothing holds it,
    /// anything without a hold may; when held, only what names that hold.
    /// Admitted under a hold, the hold it is part of (its provenance, kept
    /// with a measurement).
    pub fn admit(&self, hold: Option<i64>, what: &str) -> Result<Option<HoldInfo>, LabError> {
        let state = self.lock();
        match (&state.current, hold) {
            (None, None) => Ok(None),
            (Some(held), Some(id)) if held.id == id => Ok(Some(held.clone())),
            (Some(held), _) => Err(LabError::Conflict(format!("{what} refused: {}", held_by(held)))),
            (None, Some(id)) => Err(LabError::Conflict(format!(
                "field `hold`: hold {id} has ended (released, or the daemon restarted): {what} would not be \
                 part of it; start the calibration again"
            ))),
        }
    }
}

fn held_by(held: &HoldInfo) -> LabError {
    LabError::Conflict(format!(
        "the instrument is held by {} (hold {}, since {:.0} POSIX s), and measures only for it until it ends; \
         wait for it to end, or, if that is gone (its page closed), release it with \
         POST /api/instrument/hold/{}/release",
        held.purpose, held.id, held.since, held.id
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_hold_admits_only_what_names_it_and_is_taken_only_when_idle() {
        let hold = InstrumentHold::default();
        assert!(hold.admit(None, "a measurement").is_ok());
        assert!(matches!(
            hold.take("display calibration", Some("measurement 3 under way".into()), 1.0),
            Err(LabError::Conflict(m)) if m.contains("measurement 3 under way")
        ));
        assert!(matches!(hold.take("  ", None, 1.0), Err(LabError::Invalid(_))));
        let h = hold.take("display calibration “lcd”", None, 2.0).unwrap();
        assert_eq!(
            hold.admit(Some(h.id), "a measurement")
                .unwrap()
                .map(|held| held.purpose),
            Some("display calibration “lcd”".to_string()),
            "what is admitted under a hold learns the hold's purpose, kept with a measurement"
        );
        match hold.admit(None, "a measurement of green/patch") {
            Err(LabError::Conflict(m)) => {
                assert!(
                    m.starts_with(
                        "a measurement of green/patch refused: the instrument is held by display calibration “lcd”"
                    ),
                    "{m}"
                );
                assert!(m.contains(&format!("/api/instrument/hold/{}/release", h.id)), "{m}");
            }
            other => panic!("{other:?}"),
        }
        assert!(matches!(hold.take("another", None, 3.0), Err(LabError::Conflict(_))));
        assert!(matches!(hold.release(h.id + 1), Err(LabError::NotFound(_))));
        assert_eq!(hold.release(h.id).unwrap().id, h.id);
        assert!(
            matches!(hold.admit(Some(h.id), "a measurement"), Err(LabError::Conflict(m)) if m.contains("has ended"))
        );
        assert!(hold.admit(None, "a measurement").is_ok());
        assert_eq!(
            hold.take("again", None, 4.0).unwrap().id,
            h.id + 1,
            "hold ids do not repeat"
        );
    }
}
