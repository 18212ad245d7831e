//! `GET /api/events`: the lab's [`Event`]s as server-sent events, the
//! instrument's current status first. The SSE event name is the event's
//! `type`; a subscriber that falls behind gets a `lagged` event saying how
//! many it missed. Every stream ends when the daemon shuts down.

use std::convert::Infallible;
use std::time::Duration;

use axum::extract::State;
use axum::response::sse::{self, KeepAlive, Sse};
use futures_util::stream::{Stream, StreamExt};
use tokio_stream::wrappers::{errors::BroadcastStreamRecvError, BroadcastStream};

use super::AppState;
use crate::lab::events::Event;

/// `GET /api/events`: the current instrument status first, then every event.
#[utoipa::path(get, path = "/events", tag = "events",
    responses((status = 200, description = "text/event-stream of Event objects; the SSE event name is the `type` field")))]
pub async fn stream(State(state): State<AppState>) -> Sse<impl Stream<Item = Result<sse::Event, Infallible>>> {
    let first = Event::InstrumentStatus {
        status: state.lab.instrument().status(),
    };
    // A server without a bus (none is built so) streams the status alone.
    let rx = state.events.subscribe();
    let live = futures_util::stream::iter(rx)
        .flat_map(BroadcastStream::new)
        .map(|item| match item {
            Ok(event) => to_sse(&event),
            Err(BroadcastStreamRecvError::Lagged(n)) => Ok(sse::Event::default()
                .event("lagged")
                .data(format!("{{\"type\":\"lagged\",\"missed\":{n}}}"))),
        });
    let shutting_down = state.shutting_down.clone();
    let stream = futures_util::stream::once(async move { to_sse(&first) })
        .chain(live)
        .take_until(async move {
            shutting_down.cancelled().await;
        });
    Sse::new(stream).keep_alive(KeepAlive::new().interval(Duration::from_secs(15)))
}

fn to_sse(event: &Event) -> Result<sse::Event, Infallible> {
    let data = serde_json::to_string(event).unwrap_or_else(|e| format!("{{\"type\":\"error\",\"message\":\"{e}\"}}"));
    Ok(sse::Event::default().event(event.name()).data(data))
}
