//! Live events for `/api/events` (server-sent events): instrument state,
//! measurement progress sample by sample, renders, camera images and
//! comparisons. The event
//! name is the `type` field; the data is the whole event as JSON.

use std::convert::Infallible;
use std::time::Duration;

use axum::extract::State;
use axum::response::sse::{self, KeepAlive, Sse};
use futures_util::stream::{Stream, StreamExt};
use serde::Serialize;
use tokio_stream::wrappers::{errors::BroadcastStreamRecvError, BroadcastStream};
use utoipa::ToSchema;

use super::{AppState, InstrumentStatus};
use crate::store::MeasurementState;

#[derive(Clone, Debug, Serialize, ToSchema)]
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
        done: u64,
        total: u64,
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
    },
    /// A camera image after each pass (see `daemon::images`).
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

/// `GET /api/events`: the current instrument status first, then every event.
#[utoipa::path(get, path = "/events", tag = "events",
    responses((status = 200, description = "text/event-stream of Event objects; the SSE event name is the `type` field")))]
pub async fn stream(State(state): State<AppState>) -> Sse<impl Stream<Item = Result<sse::Event, Infallible>>> {
    let first = Event::InstrumentStatus {
        status: state.status.borrow().clone(),
    };
    let rx = state.events.subscribe();
    let live = BroadcastStream::new(rx).map(|item| match item {
        Ok(event) => to_sse(&event),
        Err(BroadcastStreamRecvError::Lagged(n)) => Ok(sse::Event::default()
            .event("lagged")
            .data(format!("{{\"type\":\"lagged\",\"missed\":{n}}}"))),
    });
    let mut shutting_down = state.shutting_down.clone();
    let stream = futures_util::stream::once(async move { to_sse(&first) })
        .chain(live)
        .take_until(async move {
            let _ = shutting_down.wait_for(|down| *down).await;
        });
    Sse::new(stream).keep_alive(KeepAlive::new().interval(Duration::from_secs(15)))
}

fn to_sse(event: &Event) -> Result<sse::Event, Infallible> {
    let data = serde_json::to_string(event).unwrap_or_else(|e| format!("{{\"type\":\"error\",\"message\":\"{e}\"}}"));
    Ok(sse::Event::default().event(event.name()).data(data))
}
