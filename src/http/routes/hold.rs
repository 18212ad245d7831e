//! `/api/instrument/hold`: a display calibration (or verification) holds
//! the instrument while it measures the display patch by patch, so no
//! other measurement is taken between its patches and nobody else changes
//! the display (see [`crate::lab::measure::queue::InstrumentHold`]). A
//! hold expires unless its holder renews it (`…/renew`, or by naming it).

use axum::extract::State;
use axum::http::StatusCode;
use axum::Json;
use serde::Deserialize;
use utoipa::ToSchema;

use crate::http::error::{ApiError, ErrorBody};
use crate::http::input::{Input, Path};
use crate::http::AppState;
use crate::lab::measure::queue::HoldInfo;

#[derive(Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct TakeHold {
    /// What holds the instrument, shown to anyone refused meanwhile
    /// (1–200 characters, not all white space, no control characters),
    /// e.g. `display calibration “lab-lcd”`.
    #[schema(
        min_length = 1,
        max_length = 200,
        pattern = "^[^\\u0000-\\u001f\\u007f-\\u009f]*[^\\s\\u0000-\\u001f\\u007f-\\u009f][^\\u0000-\\u001f\\u007f-\\u009f]*$"
    )]
    pub purpose: String,
}

/// Holds the instrument: granted only while nothing is measuring or
/// queued; then every measurement and display change must name the hold
/// (`"hold": id`) until it is released or expires, and everything else
/// answers 409. It expires at `expires_at` unless renewed before
/// (`POST /api/instrument/hold/{id}/renew`, or any measurement or display
/// change naming it): renew well within `renew_within_s`.
#[utoipa::path(post, path = "/instrument/hold", tag = "instruments", request_body = TakeHold,
    responses((status = 201, body = HoldInfo), (status = 400, body = ErrorBody), (status = 401, body = ErrorBody),
              (status = 409, body = ErrorBody, description = "held already, or a measurement is under way or queued")),
    security(("bearer" = [])))]
pub async fn take_instrument_hold(
    State(state): State<AppState>,
    Input(body): Input<TakeHold>,
) -> Result<(StatusCode, Json<HoldInfo>), ApiError> {
    let hold = state.lab.instrument().take_hold(&body.purpose).await?;
    Ok((StatusCode::CREATED, Json(hold)))
}

/// Who holds the instrument now (`null`: nobody).
#[utoipa::path(get, path = "/instrument/hold", tag = "instruments",
    responses((status = 200, body = Option<HoldInfo>)))]
pub async fn get_instrument_hold(State(state): State<AppState>) -> Json<Option<HoldInfo>> {
    Json(state.lab.instrument().hold().current(crate::store::now()))
}

/// Renews a hold: it lasts another `renew_within_s` from now. Its
/// calibration's page renews it while open; a hold nobody renews expires.
/// 404 once it has ended (released, expired, or the daemon restarted).
#[utoipa::path(post, path = "/instrument/hold/{id}/renew", tag = "instruments", params(("id" = i64, Path)),
    responses((status = 200, body = HoldInfo), (status = 401, body = ErrorBody), (status = 404, body = ErrorBody)),
    security(("bearer" = [])))]
pub async fn renew_instrument_hold(
    State(state): State<AppState>,
    Path(id): Path<i64>,
) -> Result<Json<HoldInfo>, ApiError> {
    Ok(Json(state.lab.instrument().hold().renew(id, crate::store::now())?))
}

/// Ends a hold: by its calibration at its end, or by the operator when the
/// calibration's page is gone.
#[utoipa::path(post, path = "/instrument/hold/{id}/release", tag = "instruments", params(("id" = i64, Path)),
    responses((status = 200, body = HoldInfo), (status = 401, body = ErrorBody), (status = 404, body = ErrorBody)),
    security(("bearer" = [])))]
pub async fn release_instrument_hold(
    State(state): State<AppState>,
    Path(id): Path<i64>,
) -> Result<Json<HoldInfo>, ApiError> {
    let hold = state.lab.instrument().hold().release(id, crate::store::now())?;
    tracing::info!(hold = hold.id, purpose = %hold.purpose, "instrument hold released");
    Ok(Json(hold))
}
