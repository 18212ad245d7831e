//! What happens in the lab, as it happens: instrument state, measurement
//! progress sample by sample, renders, camera images, comparisons and
//! studies. The workflows send [`Event`]s on one broadcast channel (the
//! bus); the HTTP layer streams them as server-sent events (`/api/events`,
//! `http::sse`), where the event name is [`Event::name`] (the `type` field)
//! and the data is the whole event as JSON.

use serde::Serialize;

use crate::measure::queue::InstrumentStatus;
use lightbooth_store::MeasurementState;

#[derive(Clone, Debug, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum Event {
    InstrumentStatus {
        status: InstrumentStatus,
    },
    MeasurementQueued {
        measurement_id: i64,
    },
    MeasurementStarted {
        measurement_id: i64,
        samples: usize,
    },
    /// One raw sample, stored before this event is sent.
    Sample {
        measurement_id: i64,
        index: usize,
        of: usize,
        code: i64,
        message: String,
        usable: bool,
        /// The sample's luminance with the daemon's observer, cd/m².
        #[serde(rename = "Y")]
        luminance_cd_m2: Option<f64>,
        /// The luminance the instrument itself reported (CIE 1931); never charted.
        #[serde(rename = "instrument_Y")]
        instrument_luminance_cd_m2: Option<f64>,
        wavelength_nm: Vec<f64>,
        radiance: Option<Vec<f64>>,
    },
    MeasurementFinished {
        measurement_id: i64,
        state: MeasurementState,
        error: Option<String>,
    },
    RenderStarted {
        render_id: i64,
        scene: String,
    },
    RenderProgress {
        render_id: i64,
        /// Work done and to do in this step (`total` 0: not counted).
        done: u64,
        total: u64,
        /// The render's step: `tracing paths`, `timing each coding alone`
        /// or `camera preview` (`lab::progress::RENDER_STEPS`).
        step: String,
    },
    RenderFinished {
        render_id: i64,
        scene: String,
        ok: bool,
        error: Option<String>,
    },
    ComparisonReady {
        measurement_id: i64,
        scene: String,
        target: String,
    },
    StudyProgress {
        study_id: i64,
        message: String,
        /// 0–1: the study's work before the step begun, each scene's
        /// steps weighed by its targets (see
        /// `lab::study::run::progress_fractions`); null while it waits for
        /// the measurements it asked for.
        fraction: Option<f64>,
    },
    /// A camera image after each pass (see `lab::render::images`).
    ImageProgress {
        image_id: i64,
        render_id: i64,
        pass: u32,
        /// Pixels that reached their SE target or the path cap.
        pixels_done: u64,
        pixels: u64,
        /// Paths traced so far, and the most the image may trace.
        paths: u64,
        max_paths: u64,
        elapsed_seconds: f64,
        /// The most seconds it still needs, if there is an honest bound,
        /// and how it was made or why there is none
        /// (`lab::progress::image_time_left`).
        seconds_left: Option<f64>,
        estimate: String,
    },
    /// A camera image ended: `complete`, `failed` or `cancelled`.
    ImageFinished {
        image_id: i64,
        render_id: i64,
        state: String,
        error: Option<String>,
    },
    StudyFinished {
        study_id: i64,
        ok: bool,
        error: Option<String>,
    },
}

impl Event {
    pub fn name(&self) -> &'static str {
        match self {
            Event::InstrumentStatus { .. } => "instrument_status",
            Event::MeasurementQueued { .. } => "measurement_queued",
            Event::MeasurementStarted { .. } => "measurement_started",
            Event::Sample { .. } => "sample",
            Event::MeasurementFinished { .. } => "measurement_finished",
            Event::RenderStarted { .. } => "render_started",
            Event::RenderProgress { .. } => "render_progress",
            Event::RenderFinished { .. } => "render_finished",
            Event::ComparisonReady { .. } => "comparison_ready",
            Event::StudyProgress { .. } => "study_progress",
            Event::ImageProgress { .. } => "image_progress",
            Event::ImageFinished { .. } => "image_finished",
            Event::StudyFinished { .. } => "study_finished",
        }
    }
}

/// The one way every workflow publishes its events: the daemon's bus, or
/// nowhere (a render worker's workflows: the daemon that asked reports the
/// job's end itself when it sees it in the store). Listeners
/// ([`subscribe`](Self::subscribe): `/api/events`, the progress board)
/// hear what is sent after they subscribe; one that lags misses events and
/// is told how many, and never slows a sender.
#[derive(Clone, Default)]
pub struct EventSink(Option<tokio::sync::broadcast::Sender<Event>>);

impl EventSink {
    /// A bus that keeps up to `capacity` events for its slowest listener.
    pub fn bus(capacity: usize) -> EventSink {
        EventSink(Some(tokio::sync::broadcast::channel(capacity).0))
    }

    /// A listener of every event sent from now on; `None` for a sink that
    /// sends nowhere.
    pub fn subscribe(&self) -> Option<tokio::sync::broadcast::Receiver<Event>> {
        self.0.as_ref().map(|bus| bus.subscribe())
    }

    /// Events dropped (nobody would listen).
    pub fn nowhere() -> EventSink {
        EventSink(None)
    }

    /// Sends `event` to whoever listens now (nobody listening is no error).
    pub fn send(&self, event: Event) {
        if let Some(bus) = &self.0 {
            let _ = bus.send(event);
        }
    }
}
