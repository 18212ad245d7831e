//! `/api/health` and `/api/instruments`: is the daemon alive, and what is
//! the instrument doing; `/api/openapi.json`: what the API offers.

use axum::extract::State;
use axum::http::StatusCode;
use axum::Json;
use serde::Serialize;
use utoipa::ToSchema;

use crate::http::error::ApiError;
use crate::http::openapi::served_document;
use crate::http::AppState;
use crate::lab::measure::queue::InstrumentStatus;
use crate::lab::measure::scan::InstrumentScan;
use crate::store::InstrumentRow;

/// How long `/api/health` waits for the database to answer its ping.
const DATABASE_ANSWER: std::time::Duration = std::time::Duration::from_secs(2);

#[derive(Serialize, ToSchema)]
pub struct Health {
    /// The booth this daemon measures in (`serve --booth`).
    pub booth: String,
    /// `ok`: measurements are taken; `degraded`: the daemon answers but
    /// refuses measurements with 503 for now (`measurements_refused` says
    /// why: the instrument is starting, disconnected, or in error while its
    /// task restarts); `down` (with 503) when the instrument task has
    /// stopped or the database does not answer, and no measurement can be
    /// recorded.
    pub status: String,
    /// `accepted` or `refused`: what `POST /api/measurements` answers now
    /// (202, or 503).
    pub measurements: String,
    /// Why a measurement would be refused now, in the words of that 503.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub measurements_refused: Option<String>,
    /// `ok`, or `unavailable` (with 503 and `down`) when the database does
    /// not answer; the daemon keeps retrying, and ends every measurement
    /// once it answers again.
    pub database: String,
    /// Why the database is unavailable, as the database driver says it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub database_error: Option<String>,
    pub version: String,
    /// The observer of every x, y, Y and ΔE this daemon computes
    /// (`serve --observer`): `judd-vos-1978`, `cie-1931`, `cie-1964-10`, `cie-2015-2` or `cie-2015-10`.
    pub observer: String,
    /// Samples per measurement when a request names none (a study's
    /// `measure_missing` queues that many per target).
    pub default_samples: usize,
    /// The model of this daemon's instrument (`PR-650`, `CS-2000`,
    /// `ColorCAL MkII`, `LS-100`, …), whatever it is doing now: the words of
    /// a page that asks the operator to aim it.
    pub instrument_model: String,
    /// What its measurement gives: `spectrum`, `XYZ` or `luminance`.
    pub instrument_measures: String,
    /// The observer this booth's comparisons are made in: the daemon's
    /// (`observer`) for a spectroradiometer, the instrument's own for a
    /// colorimeter or a luminance meter (its XYZ or Y cannot be recomputed
    /// in another).
    pub comparison_observer: String,
    pub instrument: InstrumentStatus,
    /// The thread that owns the instrument: `running`, `restarting` or `stopped`.
    pub instrument_task: String,
    pub queued_measurements: usize,
}

/// Is the daemon alive: the database answers and the instrument task runs;
/// and would a measurement be taken now (`status` `degraded` when it would
/// be refused, with why). 503 (with the same body, `down`) when the
/// instrument task is gone or the database does not answer.
#[utoipa::path(get, path = "/health", tag = "service",
    responses((status = 200, body = Health),
              (status = 503, description = "the instrument task has stopped, or the database does not answer",
               body = Health)))]
pub async fn health(State(state): State<AppState>) -> Result<(StatusCode, Json<Health>), ApiError> {
    // Bounded: a database that is away may hold a connection attempt for
    // its pool's whole acquire timeout.
    let database_error = match tokio::time::timeout(DATABASE_ANSWER, state.lab.database_error()).await {
        Ok(answer) => answer,
        Err(_) => Some(format!(
            "the database did not answer within {} s",
            DATABASE_ANSWER.as_secs()
        )),
    };
    let instrument = state.lab.instrument().status();
    // The task holds the receiving end of the queue for as long as it runs.
    let task_stopped = state.lab.instrument().task_stopped();
    // What a measurement POST would answer now (issue 46: health said `ok`
    // while the instrument was `starting` and measurements answered 503).
    let refused = state.lab.instrument().unavailable().or_else(|| {
        database_error
            .as_ref()
            .map(|e| format!("the database does not answer ({e}); nothing can be recorded"))
    });
    let task = if task_stopped {
        "stopped"
    } else if matches!(instrument, InstrumentStatus::Error { .. }) {
        "restarting"
    } else {
        "running"
    };
    let (code, status) = if task_stopped || database_error.is_some() {
        (StatusCode::SERVICE_UNAVAILABLE, "down")
    } else if refused.is_some() {
        (StatusCode::OK, "degraded")
    } else {
        (StatusCode::OK, "ok")
    };
    Ok((
        code,
        Json(Health {
            booth: state.lab.booth().to_string(),
            status: status.into(),
            measurements: if refused.is_some() { "refused" } else { "accepted" }.into(),
            measurements_refused: refused,
            database: if database_error.is_some() { "unavailable" } else { "ok" }.into(),
            database_error,
            version: env!("CARGO_PKG_VERSION").into(),
            observer: state.lab.observer().name().into(),
            default_samples: state.lab.instrument().capabilities().default_samples,
            instrument_model: state.lab.instrument().capabilities().model.into(),
            instrument_measures: state.lab.instrument().capabilities().reading.name().into(),
            comparison_observer: state.lab.comparison_observer().name().into(),
            instrument,
            instrument_task: task.into(),
            queued_measurements: state.lab.instrument().queued(),
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
    let status = state.lab.instrument().status();
    Ok(Json(Instruments {
        booth: state.lab.booth().to_string(),
        status,
        known: state.lab.instruments().await?,
    }))
}

/// The OpenAPI document of this API ([`crate::http::openapi`]).
#[utoipa::path(get, path = "/openapi.json", tag = "service",
    responses((status = 200, description = "the OpenAPI 3.1 document of this API", content_type = "application/json")))]
pub async fn document() -> Json<&'static serde_json::Value> {
    Json(served_document())
}

/// Looks for instruments again, as `lightbooth instruments --probe` does:
/// lists the serial ports and asks each its harmless identity command in
/// parallel, each within 2 s (never a measuring command or a settings
/// write). The port this daemon's instrument is on is not asked. Use it to
/// find which port a new instrument got; `serve --instrument auto` drives
/// the one that identifies itself.
#[utoipa::path(post, path = "/instruments/scan", tag = "instruments",
    responses((status = 200, body = InstrumentScan), (status = 401, body = crate::http::error::ErrorBody),
              (status = 409, body = crate::http::error::ErrorBody, description = "a scan is under way")),
    security(("bearer" = [])))]
pub async fn scan_instruments(State(state): State<AppState>) -> Result<Json<InstrumentScan>, ApiError> {
    Ok(Json(state.lab.scan_instruments().await?))
}
