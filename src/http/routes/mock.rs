//! `/api/mock/faults`: fault injection into the simulated PR-650, and
//! `/api/mock/display`: the colour the simulated display shows to it while
//! the calibration page shows that colour (`--mock` only).

use axum::extract::State;
use axum::http::StatusCode;
use serde::Deserialize;
use utoipa::ToSchema;

use crate::http::error::ApiError;
use crate::http::input::Input;
use crate::http::AppState;

#[derive(Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct MockFaults {
    /// `KIND[@DELAY][:RATE]`, comma-separated, e.g. `cable-pull:once` or `slow@2500ms:once`
    /// (see `lightbooth serve --help`); empty clears all faults.
    pub faults: String,
}

/// Injects faults into the simulated PR-650 (only when the daemon runs with `--mock`).
#[utoipa::path(post, path = "/mock/faults", tag = "instruments", request_body = MockFaults,
    responses((status = 204), (status = 400, body = crate::http::error::ErrorBody), (status = 404, body = crate::http::error::ErrorBody)),
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

#[derive(Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct MockDisplay {
    /// Drive of red, green, blue, 0–1 (frame-buffer value / maximum code):
    /// one colour on every pixel.
    #[serde(default)]
    pub drive: Option<[f64; 3]>,
    /// Or what a page drew in the measured patch: per channel (red, green,
    /// blue) the number of pixels × frames that had each code 0–`max_code`
    /// (a dithered patch has several codes).
    #[serde(default)]
    pub code_counts: Option<[Vec<u64>; 3]>,
    /// 255 (8 bits, the default) or 1023 (10 bits), with `code_counts`.
    #[serde(default)]
    pub max_code: Option<u32>,
    /// The instrument hold this change belongs to: while the instrument is
    /// held (`POST /api/instrument/hold`), only the holder changes the display.
    #[serde(default)]
    pub hold: Option<i64>,
}

/// Shows a colour on the simulated display the simulated PR-650 looks at
/// (only with `--mock`): the calibration page calls it with each patch it
/// shows (`drive`), the experiment's verification with the codes it drew
/// in the instrument's spot, dithered or not (`code_counts`).
#[utoipa::path(post, path = "/mock/display", tag = "instruments", request_body = MockDisplay,
    responses((status = 204), (status = 400, body = crate::http::error::ErrorBody), (status = 404, body = crate::http::error::ErrorBody),
              (status = 409, body = crate::http::error::ErrorBody, description = "the instrument is held by a calibration this change does not name")),
    security(("bearer" = [])))]
pub async fn mock_display(
    State(state): State<AppState>,
    Input(body): Input<MockDisplay>,
) -> Result<StatusCode, ApiError> {
    let mock = state
        .mock
        .as_ref()
        .ok_or_else(|| ApiError::NotFound("no simulated display: the daemon runs a real instrument".into()))?;
    state
        .lab
        .instrument()
        .hold()
        .admit(body.hold, "a change of the simulated display", crate::store::now())?;
    match (body.drive, body.code_counts) {
        (Some(drive), None) if body.max_code.is_none() => mock
            .show_on_display(drive)
            .map_err(|e| ApiError::BadRequest(format!("field `drive`: {e}")))?,
        (None, Some(counts)) => {
            let codes = crate::display::CodeCounts {
                max_code: body.max_code.unwrap_or(255),
                counts,
            };
            mock.show_codes_on_display(&codes)
                .map_err(|e| ApiError::BadRequest(format!("field `code_counts`: {e}")))?
        }
        _ => {
            return Err(ApiError::BadRequest(
                "give either `drive` (one colour, 0–1 per channel) or `code_counts` with an optional `max_code`".into(),
            ))
        }
    }
    Ok(StatusCode::NO_CONTENT)
}
