//! `/api/mock/faults`: fault injection into the simulated PR-650 (`--mock` only).

use axum::extract::State;
use axum::http::StatusCode;
use serde::Deserialize;
use utoipa::ToSchema;

use crate::service::error::ApiError;
use crate::service::input::Input;
use crate::service::AppState;

#[derive(Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct MockFaults {
    /// `KIND[@DELAY][:RATE]`, comma-separated, e.g. `cable-pull:once` or `slow@2500ms:once`
    /// (see `lightbooth serve --help`); empty clears all faults.
    pub faults: String,
}

/// Injects faults into the simulated PR-650 (only when the daemon runs with `--mock`).
#[utoipa::path(post, path = "/mock/faults", tag = "instruments", request_body = MockFaults,
    responses((status = 204), (status = 400, body = crate::service::error::ErrorBody), (status = 404, body = crate::service::error::ErrorBody)),
    security(("bearer" = [])))]
pub async fn mock_faults(
    State(state): State<AppState>,
    Input(body): Input<MockFaults>,
) -> Result<StatusCode, ApiError> {
    let mock = state
        .mock
        .as_ref()
        .ok_or_else(|| ApiError::NotFound("no simulated PR-650: the daemon runs a real one".into()))?;
    mock.set_faults(&body.faults)
        .map_err(|e| ApiError::BadRequest(format!("field `faults`: {e}")))?;
    Ok(StatusCode::NO_CONTENT)
}
