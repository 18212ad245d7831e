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
//! fitting patches it did not own.
//!
//! A hold ends when released, when a daemon restarts, or when its holder
//! stops renewing it: a hold lasts [`HOLD_LEASE_S`] from when it was taken
//! or last renewed (`POST /api/instrument/hold/{id}/renew`, or any
//! measurement or display change that names it), and its JSON says until
//! when (`expires_at`) and how often to renew (`renew_within_s`). A client
//! that vanished (a closed tab, a crashed script) so blocks measurements
//! for at most that long, not until an operator steps in. The lease is
//! longer than a browser's slowest timer in a background tab (once a
//! minute), so an open page keeps its hold.
//!
//! Hold ids are drawn from the store (one row per hold,
//! `Store::record_instrument_hold`), not counted in memory: they never
//! repeat, across daemon restarts (a calibration page left open across one
//! would otherwise post into another client's new hold 1) and across the
//! daemons of one PostgreSQL database (a measurement keeps its `hold_id`).
//! A database sequence gives small integers, which JavaScript and MATLAB
//! read exactly and MATLAB's `webwrite` sends in full (a random 63-bit id
//! would not survive a double; a string id would change the API's type).

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

/// How long a hold lasts without a renewal, in seconds (see the module doc).
pub const HOLD_LEASE_S: f64 = 120.0;

/// Who holds the instrument, as the API shows it.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct HoldInfo {
    /// Name it in every measurement and display change while it holds.
    /// Never repeats (drawn from the database).
    pub id: i64,
    /// What holds it, e.g. `display calibration “lab-lcd”`.
    pub purpose: String,
    /// POSIX seconds: when it was taken.
    pub since: f64,
    /// POSIX seconds: when it ends unless renewed before (by
    /// `POST /api/instrument/hold/{id}/renew`, or a measurement or display
    /// change naming it).
    pub expires_at: f64,
    /// Seconds each renewal gives: renew well within this.
    pub renew_within_s: f64,
}

/// The one hold on the instrument (see the module doc).
#[derive(Debug)]
pub struct InstrumentHold {
    state: Mutex<HoldState>,
    lease_s: f64,
}

impl Default for InstrumentHold {
    fn default() -> InstrumentHold {
        InstrumentHold::with_lease(HOLD_LEASE_S)
    }
}

#[derive(Debug, Default)]
struct HoldState {
    current: Option<HoldInfo>,
    /// The last hold that expired, to say so to whoever names it.
    expired: Option<HoldInfo>,
}

impl HoldState {
    /// Ends the current hold if it has expired by `now`.
    fn expire(&mut self, now: f64) {
        if self.current.as_ref().is_some_and(|h| now >= h.expires_at) {
            let h = self.current.take().expect("checked");
            tracing::warn!(
                hold = h.id,
                purpose = %h.purpose,
                "instrument hold expired: not renewed within {} s",
                h.renew_within_s
            );
            self.expired = Some(h);
        }
    }

    fn ended(&self, id: i64) -> String {
        match &self.expired {
            Some(h) if h.id == id => format!(
                "hold {id} expired at {:.0} POSIX s: not renewed within {:.0} s",
                h.expires_at, h.renew_within_s
            ),
            _ => format!("hold {id} has ended (released, expired, or the daemon restarted)"),
        }
    }
}

impl InstrumentHold {
    /// A hold lasting `lease_s` seconds past each renewal.
    pub fn with_lease(lease_s: f64) -> InstrumentHold {
        InstrumentHold {
            state: Mutex::default(),
            lease_s,
        }
    }

    fn lock(&self, now: f64) -> std::sync::MutexGuard<'_, HoldState> {
        let mut state = self.state.lock().unwrap_or_else(|p| p.into_inner());
        state.expire(now);
        state
    }

    /// The current hold at time `now`, if any.
    pub fn current(&self, now: f64) -> Option<HoldInfo> {
        self.lock(now).current.clone()
    }

    /// Whether [`InstrumentHold::take`] would grant a hold now (see there),
    /// before an id is drawn for it.
    pub fn check_take(&self, purpose: &str, busy: Option<&str>, now: f64) -> Result<(), LabError> {
        // The length and characters as given (as the OpenAPI document
        // states them), then not only white space.
        let refused = purpose.chars().count() > MAX_HOLD_PURPOSE || purpose.chars().any(char::is_control);
        if purpose.trim().is_empty() || refused {
            return Err(LabError::Invalid(format!(
                "field `purpose`: say what holds the instrument in 1–{MAX_HOLD_PURPOSE} characters, \
                 without control characters"
            )));
        }
        if let Some(held) = &self.lock(now).current {
            return Err(held_by(held));
        }
        if let Some(busy) = busy {
            return Err(LabError::Conflict(format!(
                "the instrument is busy ({busy}): a calibration holds it only once nothing is measuring or \
                 queued; wait for it, or cancel it"
            )));
        }
        Ok(())
    }

    /// Takes the hold `id` (drawn from the store, never repeating) for
    /// `purpose` at time `now`; `busy` says what the instrument is doing (a
    /// measurement under way or queued), which must end first. 409 when
    /// held or busy, 400 for an empty or long purpose.
    pub fn take(&self, id: i64, purpose: &str, busy: Option<String>, now: f64) -> Result<HoldInfo, LabError> {
        self.check_take(purpose, busy.as_deref(), now)?;
        let mut state = self.lock(now);
        if let Some(held) = &state.current {
            return Err(held_by(held));
        }
        let hold = HoldInfo {
            id,
            purpose: purpose.trim().to_string(),
            since: now,
            expires_at: now + self.lease_s,
            renew_within_s: self.lease_s,
        };
        state.current = Some(hold.clone());
        Ok(hold)
    }

    /// Renews hold `id` at `now`: it lasts another `renew_within_s`.
    /// 404 when it is not the current hold (released, or expired).
    pub fn renew(&self, id: i64, now: f64) -> Result<HoldInfo, LabError> {
        let mut state = self.lock(now);
        match &mut state.current {
            Some(h) if h.id == id => {
                h.expires_at = now + self.lease_s;
                Ok(h.clone())
            }
            _ => Err(LabError::NotFound(format!(
                "no hold {id} on the instrument: {}; take a new one",
                state.ended(id)
            ))),
        }
    }

    /// Ends hold `id`. 404 when it is not the current hold.
    pub fn release(&self, id: i64, now: f64) -> Result<HoldInfo, LabError> {
        let mut state = self.lock(now);
        match &state.current {
            Some(h) if h.id == id => Ok(state.current.take().expect("checked")),
            _ => Err(LabError::NotFound(format!(
                "no hold {id} on the instrument: {}",
                state.ended(id)
            ))),
        }
    }

    /// Whether `what` (a measurement, a display change) may use the
    /// instrument at `now`, naming `hold` (or none): when nothing holds
    /// it, anything without a hold may; when held, only what names that
    /// hold, which renews it. Admitted under a hold, the hold it is part
    /// of (its provenance, kept with a measurement).
    pub fn admit(&self, hold: Option<i64>, what: &str, now: f64) -> Result<Option<HoldInfo>, LabError> {
        let mut state = self.lock(now);
        match (&mut state.current, hold) {
            (None, None) => Ok(None),
            (Some(held), Some(id)) if held.id == id => {
                held.expires_at = now + self.lease_s;
                Ok(Some(held.clone()))
            }
            (Some(held), _) => Err(LabError::Conflict(format!("{what} refused: {}", held_by(held)))),
            (None, Some(id)) => Err(LabError::Conflict(format!(
                "field `hold`: {}: {what} would not be part of it; start the calibration again",
                state.ended(id)
            ))),
        }
    }
}

fn held_by(held: &HoldInfo) -> LabError {
    LabError::Conflict(format!(
        "the instrument is held by {} (hold {}, since {:.0} POSIX s, until {:.0} unless renewed), and measures \
         only for it until it ends; wait for it to end, or, if that is gone (its page closed), release it with \
         POST /api/instrument/hold/{}/release (or let it expire)",
        held.purpose, held.id, held.since, held.expires_at, held.id
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_hold_admits_only_what_names_it_and_is_taken_only_when_idle() {
        let hold = InstrumentHold::default();
        assert!(hold.admit(None, "a measurement", 1.0).is_ok());
        assert!(matches!(
            hold.take(7, "display calibration", Some("measurement 3 under way".into()), 1.0),
            Err(LabError::Conflict(m)) if m.contains("measurement 3 under way")
        ));
        assert!(matches!(hold.take(7, "  ", None, 1.0), Err(LabError::Invalid(_))));
        let h = hold.take(7, "display calibration “lcd”", None, 2.0).unwrap();
        assert_eq!(h.id, 7, "the id drawn from the store");
        assert_eq!(
            hold.admit(Some(h.id), "a measurement", 3.0)
                .unwrap()
                .map(|held| held.purpose),
            Some("display calibration “lcd”".to_string()),
            "what is admitted under a hold learns the hold's purpose, kept with a measurement"
        );
        match hold.admit(None, "a measurement of green/patch", 3.0) {
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
        assert!(matches!(hold.take(8, "another", None, 3.0), Err(LabError::Conflict(_))));
        assert!(matches!(hold.release(h.id + 1, 3.0), Err(LabError::NotFound(_))));
        assert_eq!(hold.release(h.id, 3.0).unwrap().id, h.id);
        assert!(
            matches!(hold.admit(Some(h.id), "a measurement", 3.0), Err(LabError::Conflict(m)) if m.contains("has ended"))
        );
        assert!(hold.admit(None, "a measurement", 3.0).is_ok());
    }

    /// Regression (issue 46): a hold lasted until released, so a client
    /// that vanished (a closed tab) blocked every measurement until an
    /// operator released it by hand. A hold not renewed expires and the
    /// queue moves on; one renewed (or used) does not.
    #[test]
    fn a_vanished_holder_blocked_every_measurement_until_an_operator_stepped_in() {
        let hold = InstrumentHold::default();
        let h = hold.take(11, "display calibration “lcd”", None, 100.0).unwrap();
        assert_eq!((h.expires_at, h.renew_within_s), (100.0 + HOLD_LEASE_S, HOLD_LEASE_S));
        // Renewed just before it would end, and used later: it holds on.
        let renewed = hold.renew(11, 100.0 + HOLD_LEASE_S - 1.0).unwrap();
        assert_eq!(renewed.expires_at, 99.0 + 2.0 * HOLD_LEASE_S);
        let used_at = 98.0 + 2.0 * HOLD_LEASE_S;
        assert!(hold.admit(Some(11), "a measurement", used_at).unwrap().is_some());
        let still = used_at + HOLD_LEASE_S - 1.0;
        assert!(
            matches!(hold.admit(None, "a measurement", still), Err(LabError::Conflict(_))),
            "a hold renewed by its use is still held"
        );
        assert_eq!(hold.current(still).map(|h| h.expires_at), Some(used_at + HOLD_LEASE_S));
        // Its holder gone, nothing renews it: at its expiry the queue moves on.
        let gone = used_at + HOLD_LEASE_S;
        assert_eq!(hold.current(gone), None);
        assert!(hold.admit(None, "a measurement", gone).unwrap().is_none());
        // The vanished holder, should it come back, is told its hold expired.
        for refused in [
            hold.admit(Some(11), "a measurement", gone).unwrap_err().to_string(),
            hold.renew(11, gone).unwrap_err().to_string(),
            hold.release(11, gone).unwrap_err().to_string(),
        ] {
            assert!(
                refused.contains("hold 11 expired") && refused.contains("not renewed within 120 s"),
                "{refused}"
            );
        }
        assert_eq!(
            hold.take(12, "another", None, gone).unwrap().id,
            12,
            "and a new hold can be taken"
        );
    }
}
