//! `/api/health` and `/api/instruments`: is the daemon alive, and what is the instrument doing.

use axum::extract::State;
use axum::Json;
use serde::Serialize;
use utoipa::ToSchema;

use crate::service::error::ApiError;
use crate::service::{AppState, InstrumentStatus};
use crate::store::InstrumentRow;

#[derive(Serialize, ToSchema)]
pub struct Health {
    /// "ok" when the database answers.
    pub status: String,
    pub version: String,
    pub instrument: InstrumentStatus,
    pub queued_measurements: usize,
}

#[utoipa::path(get, path = "/health", tag = "service", responses((status = 200, body = Health)))]
pub async fn health(State(state): State<AppState>) -> Result<Json<Health>, ApiError> {
    sqlx::query("SELECT 1")
        .execute(state.store.pool())
        .await
        .map_err(|e| ApiError::Internal(e.to_string()))?;
    Ok(Json(Health {
        status: "ok".into(),
        version: env!("CARGO_PKG_VERSION").into(),
        instrument: state.status.borrow().clone(),
        queued_measurements: state.jobs.max_capacity() - state.jobs.capacity(),
    }))
}

#[derive(Serialize, ToSchema)]
pub struct Instruments {
    /// What the instrument task is doing now.
    pub status: InstrumentStatus,
    /// Every instrument this database has seen.
    pub known: Vec<InstrumentRow>,
}

#[utoipa::path(get, path = "/instruments", tag = "instruments", responses((status = 200, body = Instruments)))]
pub async fn instruments(State(state): State<AppState>) -> Result<Json<Instruments>, ApiError> {
    let status = state.status.borrow().clone();
    Ok(Json(Instruments {
        status,
        known: state.store.list_instruments().await?,
    }))
}
