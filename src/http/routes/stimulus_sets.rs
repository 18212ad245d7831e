//! `/api/stimulus-sets`: image stimulus sets (`lab::records::stimulus_sets`):
//! the codings of one rendered image converted through a stored display
//! profile, made from the camera images the daemon keeps (JSON) or from an
//! uploaded layered OpenEXR (the file as the body, up to
//! [`MAX_UPLOAD_BYTES`]); read back as the report, each coding's linear RGB
//! (f32) for the pages, and each coding's ΔE00 map against the reference.

use axum::body::Bytes;
use axum::extract::State;
use axum::http::{header, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::Json;
use serde::Deserialize;
use utoipa::IntoParams;

use crate::http::error::{ApiError, ErrorBody};
use crate::http::input::{Input, Path, Query};
use crate::http::AppState;
use crate::lab::records::stimulus_sets::{ExrUpload, StimulusSetRequest};
use crate::store::StimulusSetRow;

/// The largest OpenEXR file `POST /api/stimulus-sets/exr` reads (every
/// other body is limited to `http::MAX_BODY_BYTES`).
pub const MAX_UPLOAD_BYTES: usize = 512 << 20;

/// Makes a stimulus set from a set of camera images this daemon keeps
/// (any image of codings rendered from the same paths), converted through
/// a stored display profile; stored with its report (201).
#[utoipa::path(post, path = "/stimulus-sets", tag = "stimulus sets", request_body = StimulusSetRequest,
    responses((status = 201, body = StimulusSetRow), (status = 400, body = ErrorBody), (status = 401, body = ErrorBody),
              (status = 404, body = ErrorBody), (status = 409, body = ErrorBody)),
    security(("bearer" = [])))]
pub async fn create_stimulus_set(
    State(state): State<AppState>,
    Input(body): Input<StimulusSetRequest>,
) -> Result<(StatusCode, Json<StimulusSetRow>), ApiError> {
    Ok((StatusCode::CREATED, Json(state.lab.create_stimulus_set(body).await?)))
}

#[derive(Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
#[serde(deny_unknown_fields)]
pub struct UploadQuery {
    /// What the file is (who rendered it, with what): stored with the set.
    pub provenance: String,
    pub display_profile_id: i64,
    /// `scale` (default), `clip` or `fail`.
    pub gamut: Option<String>,
    /// `noisy_bit` (default), `8bit`, `10bit` or `12bit`.
    pub output: Option<String>,
}

/// Makes a stimulus set from an uploaded layered OpenEXR (the body: a
/// layer per coding with `X`, `Y`, `Z` in the profile's observer, as
/// `lightbooth render --image-coding` and `GET /api/images/{id}/set.exr`
/// write it), kept with the file's SHA-256 and the stated provenance (201).
#[utoipa::path(post, path = "/stimulus-sets/exr", tag = "stimulus sets", params(UploadQuery),
    request_body(content = Vec<u8>, content_type = "image/x-exr"),
    responses((status = 201, body = StimulusSetRow), (status = 400, body = ErrorBody), (status = 401, body = ErrorBody),
              (status = 404, body = ErrorBody), (status = 409, body = ErrorBody), (status = 413, body = ErrorBody)),
    security(("bearer" = [])))]
pub async fn upload_stimulus_set(
    State(state): State<AppState>,
    Query(q): Query<UploadQuery>,
    body: Bytes,
) -> Result<(StatusCode, Json<StimulusSetRow>), ApiError> {
    let upload = ExrUpload {
        bytes: body.to_vec(),
        provenance: q.provenance,
        display_profile_id: q.display_profile_id,
        gamut: q.gamut,
        output: q.output,
    };
    Ok((
        StatusCode::CREATED,
        Json(state.lab.create_stimulus_set_from_exr(upload).await?),
    ))
}

/// Every stored set, newest first.
#[utoipa::path(get, path = "/stimulus-sets", tag = "stimulus sets",
    responses((status = 200, body = Vec<StimulusSetRow>)))]
pub async fn list_stimulus_sets(State(state): State<AppState>) -> Result<Json<Vec<StimulusSetRow>>, ApiError> {
    Ok(Json(state.lab.stimulus_sets().await?))
}

#[utoipa::path(get, path = "/stimulus-sets/{id}", tag = "stimulus sets", params(("id" = i64, Path)),
    responses((status = 200, body = StimulusSetRow), (status = 404, body = ErrorBody)))]
pub async fn get_stimulus_set(
    State(state): State<AppState>,
    Path(id): Path<i64>,
) -> Result<Json<StimulusSetRow>, ApiError> {
    Ok(Json(state.lab.stimulus_set(id).await?))
}

/// A coding's linear RGB after the gamut policy, what the display is asked
/// to show before the profile's γ and the output method: f32
/// little-endian, R, G, B per pixel, rows top to bottom.
#[utoipa::path(get, path = "/stimulus-sets/{id}/linear/{coding}", tag = "stimulus sets",
    params(("id" = i64, Path), ("coding" = String, Path)),
    responses((status = 200, content_type = "application/octet-stream"), (status = 404, body = ErrorBody)))]
pub async fn stimulus_set_linear(
    State(state): State<AppState>,
    Path((id, coding)): Path<(i64, String)>,
) -> Result<Response, ApiError> {
    let bytes = state.lab.stimulus_set_linear(id, &coding).await?;
    Ok(([(header::CONTENT_TYPE, "application/octet-stream")], bytes).into_response())
}

/// A coding's ΔE00 map against the reference, as the display shows both at
/// the set's output: viridis from 0 to the value in the `X-Scale-Max`
/// header (the same for every coding of the set).
#[utoipa::path(get, path = "/stimulus-sets/{id}/delta-e/{coding}", tag = "stimulus sets",
    params(("id" = i64, Path), ("coding" = String, Path)),
    responses((status = 200, content_type = "image/png"), (status = 404, body = ErrorBody)))]
pub async fn stimulus_set_delta_e(
    State(state): State<AppState>,
    Path((id, coding)): Path<(i64, String)>,
) -> Result<Response, ApiError> {
    let (png, top) = state.lab.stimulus_set_delta_e_png(id, &coding).await?;
    Ok((
        [
            (header::CONTENT_TYPE, "image/png".to_string()),
            (header::HeaderName::from_static("x-scale-max"), top.to_string()),
        ],
        png,
    )
        .into_response())
}
