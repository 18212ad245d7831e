//! `/api/stimulus-sets`: image stimulus sets (`lab::records::stimulus_sets`):
//! the codings of one rendered image converted through a stored display
//! profile, made from the camera images the daemon keeps (JSON) or from an
//! uploaded layered OpenEXR (the file as the body, up to
//! [`MAX_UPLOAD_BYTES`]); read back as the report, each coding's linear RGB
//! (f32) for the pages, and each coding's ΔE00 map against the reference;
//! and a coding verified on the display at the scene's targets
//! (`lab::records::image_verification`).

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
use crate::lab::records::image_verification::{ImageTargets, ImageVerificationRequest, ScreenGeometry};
use crate::lab::records::stimulus_sets::{ExrUpload, StimulusSetRequest};
use crate::store::{StimulusSetRow, StimulusSetVerificationRow};

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
    #[param(min_length = 1, max_length = 2000, pattern = "\\S")]
    pub provenance: String,
    pub display_profile_id: i64,
    /// `scale` (default), `clip` or `fail`.
    #[param(pattern = "^(scale|clip|fail)$")]
    pub gamut: Option<String>,
    /// `noisy_bit` (default), `8bit`, `10bit` or `12bit`.
    #[param(pattern = "^(8bit|noisy_bit|10bit|12bit)$")]
    pub output: Option<String>,
}

/// Makes a stimulus set from an uploaded layered OpenEXR (the body: a
/// layer per coding with `X`, `Y`, `Z` in the profile's observer, as
/// `lightbooth render --image-coding` and `GET /api/images/{id}/set.exr`
/// write it), kept with the file's SHA-256 and the stated provenance (201).
#[utoipa::path(post, path = "/stimulus-sets/exr", tag = "stimulus sets", params(UploadQuery),
    request_body(content = Vec<u8>, content_type = "application/octet-stream"),
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

#[derive(Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
#[serde(deny_unknown_fields)]
pub struct ScreenQuery {
    /// mm, 100–5000 (default 570).
    #[param(minimum = 100, maximum = 5000)]
    pub viewing_distance_mm: Option<f64>,
    /// mm, 0.05–2 (default 0.25).
    #[param(minimum = 0.05, maximum = 2)]
    pub pixel_pitch_mm: Option<f64>,
    /// The instrument's field, degrees, 0.1–10 (default: the scene's radiometer's).
    #[param(minimum = 0.1, maximum = 10)]
    pub field_deg: Option<f64>,
    /// Screen pixels per image pixel, each way, 1–16 (default 1).
    #[param(minimum = 1, maximum = 16)]
    pub magnification: Option<u32>,
}

/// Where the scene's targets fall in the set's image and how large the
/// instrument's field is there: what a verification aims at, with the
/// instrument hold to measure under.
#[utoipa::path(get, path = "/stimulus-sets/{id}/targets", tag = "stimulus sets", params(("id" = i64, Path), ScreenQuery),
    responses((status = 200, body = ImageTargets), (status = 400, body = ErrorBody), (status = 404, body = ErrorBody),
              (status = 409, description = "an uploaded set names no scene, or the scene changed", body = ErrorBody)))]
pub async fn stimulus_set_targets(
    State(state): State<AppState>,
    Path(id): Path<i64>,
    Query(q): Query<ScreenQuery>,
) -> Result<Json<ImageTargets>, ApiError> {
    let screen = ScreenGeometry {
        viewing_distance_mm: q.viewing_distance_mm,
        pixel_pitch_mm: q.pixel_pitch_mm,
        field_deg: q.field_deg,
        magnification: q.magnification,
    };
    Ok(Json(state.lab.image_targets(id, screen).await?))
}

/// Verifies a coding of the set on the display from the measurements taken
/// at its targets under the set's verification hold; stored (201).
#[utoipa::path(post, path = "/stimulus-sets/{id}/verifications", tag = "stimulus sets", params(("id" = i64, Path)),
    request_body = ImageVerificationRequest,
    responses((status = 201, body = StimulusSetVerificationRow), (status = 400, body = ErrorBody), (status = 401, body = ErrorBody),
              (status = 404, body = ErrorBody), (status = 409, body = ErrorBody)),
    security(("bearer" = [])))]
pub async fn create_stimulus_set_verification(
    State(state): State<AppState>,
    Path(id): Path<i64>,
    Input(body): Input<ImageVerificationRequest>,
) -> Result<(StatusCode, Json<StimulusSetVerificationRow>), ApiError> {
    Ok((StatusCode::CREATED, Json(state.lab.verify_image(id, body).await?)))
}

/// A set's verifications, oldest first.
#[utoipa::path(get, path = "/stimulus-sets/{id}/verifications", tag = "stimulus sets", params(("id" = i64, Path)),
    responses((status = 200, body = Vec<StimulusSetVerificationRow>), (status = 404, body = ErrorBody)))]
pub async fn list_stimulus_set_verifications(
    State(state): State<AppState>,
    Path(id): Path<i64>,
) -> Result<Json<Vec<StimulusSetVerificationRow>>, ApiError> {
    Ok(Json(state.lab.image_verifications(id).await?))
}

/// A verification's luminance profile along the targets: the booth
/// (through the set's gamut policy), the intended and the emitted Y.
#[utoipa::path(get, path = "/stimulus-sets/{id}/verifications/{verification}/profile.svg", tag = "stimulus sets",
    params(("id" = i64, Path), ("verification" = i64, Path)),
    responses((status = 200, content_type = "image/svg+xml"), (status = 404, body = ErrorBody)))]
pub async fn stimulus_set_verification_chart(
    State(state): State<AppState>,
    Path((id, verification)): Path<(i64, i64)>,
) -> Result<Response, ApiError> {
    let svg = state.lab.image_verification_chart(id, verification).await?;
    Ok(([(header::CONTENT_TYPE, "image/svg+xml")], svg).into_response())
}
