//! What the instrument task and the rest of the lab share: the queue of
//! [`MeasurementJob`]s the task takes one at a time, its live
//! [`InstrumentStatus`], and the two handles it lends out — stopping the
//! running measurement ([`CancelMeasurement`]) and, with a simulated
//! instrument, injecting faults ([`MockControl`]).

use serde::Serialize;
use utoipa::ToSchema;

/// A measurement for the instrument task to take.
#[derive(Clone, Debug)]
pub struct MeasurementJob {
    pub id: i64,
    pub samples: usize,
    pub scene: Option<String>,
    pub target: Option<String>,
}

/// What the instrument is doing, as the dashboard shows it.
#[derive(Clone, Debug, PartialEq, Serialize, ToSchema)]
#[serde(tag = "state", rename_all = "snake_case")]
pub enum InstrumentStatus {
    /// No port open; `reason` says why and what the daemon is doing about it.
    Disconnected { reason: String },
    Idle {
        model: String,
        serial: Option<String>,
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
    /// ([`crate::display::SimulatedDisplay`]) the simulated PR-650 is aimed
    /// at: what it measures until a measurement names a scene target.
    fn show_on_display(&self, drive: [f64; 3]) -> Result<(), String>;
    /// Shows a patch whose pixels and frames had the codes `codes` (what a
    /// page drew, dithered or not): the simulated PR-650 sees their mean.
    fn show_codes_on_display(&self, codes: &crate::display::CodeCounts) -> Result<(), String>;
}
