//! `/api/health` and `/api/instruments`: is the daemon alive, and what is the instrument doing.

use axum::extract::State;
use axum::http::StatusCode;
use axum::Json;
use serde::Serialize;
use utoipa::ToSchema;

use crate::service::error::ApiError;
use crate::service::{AppState, InstrumentStatus};
use crate::store::InstrumentRow;

#[derive(Serialize, ToSchema)]
pub struct Health {
    /// The booth this daemon measures in (`serve --booth`).
    pub booth: String,
    /// `ok`; `degraded` while the instrument task restarts after a panic
    /// (measurements are refused meanwhile); `down` (with 503) when the
    /// instrument task has stopped and no measurement can run.
    pub status: String,
    pub version: String,
    pub instrument: InstrumentStatus,
    /// The thread that owns the instrument: `running`, `restarting` or `stopped`.
    pub instrument_task: String,
    pub queued_measurements: usize,
}

/// Is the daemon alive: the database answers and the instrument task runs.
/// 503 (with the same body) when the instrument task is gone.
#[utoipa::path(get, path = "/health", tag = "service",
    responses((status = 200, body = Health),
              (status = 503, description = "the instrument task has stopped", body = Health)))]
pub async fn health(State(state): State<AppState>) -> Result<(StatusCode, Json<Health>), ApiError> {
    state
        .store
        .ping()
        .await
        .map_err(|e| ApiError::Internal(e.to_string()))?;
    let instrument = state.status.borrow().clone();
    // The task holds the receiving end of the queue for as long as it runs.
    let (code, status, task) = if state.jobs.is_closed() {
        (StatusCode::SERVICE_UNAVAILABLE, "down", "stopped")
    } else if matches!(instrument, InstrumentStatus::Error { .. }) {
        (StatusCode::OK, "degraded", "restarting")
    } else {
        (StatusCode::OK, "ok", "running")
    };
    Ok((
        code,
        Json(Health {
            booth: state.config.booth.to_string(),
            status: status.into(),
            version: env!("CARGO_PKG_VERSION").into(),
            instrument,
            instrument_task: task.into(),
            queued_measurements: state.jobs.max_capacity() - state.jobs.capacity(),
        }),
    ))
}

#[derive(Serialize, ToSchema)]
pub struct Instruments {
    /// The booth of this daemon's instrument.
    pub booth: String,
    /// What the instrument task is doing now.
    pub status: InstrumentStatus,
    /// Every instrument this database has seen.
    pub known: Vec<InstrumentRow>,
}

#[utoipa::path(get, path = "/instruments", tag = "instruments", responses((status = 200, body = Instruments)))]
pub async fn instruments(State(state): State<AppState>) -> Result<Json<Instruments>, ApiError> {
    let status = state.status.borrow().clone();
    Ok(Json(Instruments {
        booth: state.config.booth.to_string(),
        status,
        known: state.store.list_instruments().await?,
    }))
}
