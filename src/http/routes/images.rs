//! `/api/renders/{id}/images` and `/api/images`: camera images of a render
//! in any coding (queued, progressive, cancellable; see `lab::render::images`),
//! what the dashboard's image viewer shows of them (display PNG, pixel
//! probe and its chart, ΔE00 map between two codings) and their files
//! (OpenEXR, MATLAB) through [`crate::export::image`].

use axum::extract::State;
use axum::http::{header, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::Json;
use serde::{Deserialize, Serialize};
use utoipa::{IntoParams, ToSchema};

use crate::http::error::{ApiError, ErrorBody};
use crate::http::input::{Input, Path, Query};
use crate::http::kept;
use crate::http::AppState;
use crate::lab::compare::image_map::DeltaEMap;
use crate::lab::render::image_views::Probe;
use crate::lab::render::images::{ImageInfo, ImageJobs, ImageRequest};
use crate::lab::FileFormat;

fn images(state: &AppState) -> Result<&ImageJobs, ApiError> {
    Ok(state.lab.renders()?.images())
}

#[derive(Serialize, ToSchema)]
pub struct ImageAccepted {
    /// The image of `coding`, or of the reference of `codings`.
    pub image_id: i64,
    pub url: String,
    /// One per coding asked for, in the request's order.
    pub images: Vec<AcceptedImage>,
    /// True when images of this render with the same settings already
    /// existed (queued, running or complete) and are the ones answered.
    pub reused: bool,
}

#[derive(Serialize, ToSchema)]
pub struct AcceptedImage {
    pub coding: String,
    pub image_id: i64,
    pub url: String,
}

/// Queues camera images of a render (202): in one `coding`, or in several
/// `codings` rendered from the same paths (an image each, compared with
/// the `reference`); or answers the images already made with the same
/// settings. Limits: see `lab::render::images` (400 naming the field and
/// the limit).
#[utoipa::path(post, path = "/renders/{id}/images", tag = "images", params(("id" = i64, Path)),
    request_body = ImageRequest,
    responses((status = 202, body = ImageAccepted), (status = 400, body = ErrorBody),
              (status = 401, body = ErrorBody), (status = 404, body = ErrorBody),
              (status = 409, description = "the image queue is full, the scene changed since the render, or it has no camera", body = ErrorBody),
              (status = 503, body = ErrorBody)),
    security(("bearer" = [])))]
pub async fn start_image(
    State(state): State<AppState>,
    Path(id): Path<i64>,
    Input(body): Input<ImageRequest>,
) -> Result<(StatusCode, Json<ImageAccepted>), ApiError> {
    let admitted = state.lab.renders()?.start_image(id, body).await?;
    let image_id = admitted.reference_id;
    Ok((
        StatusCode::ACCEPTED,
        Json(ImageAccepted {
            image_id,
            url: format!("/api/images/{image_id}"),
            images: admitted
                .images
                .into_iter()
                .map(|(coding, image_id)| AcceptedImage {
                    coding,
                    image_id,
                    url: format!("/api/images/{image_id}"),
                })
                .collect(),
            reused: admitted.reused,
        }),
    ))
}

/// The camera images this daemon keeps of a render, oldest first (404 when
/// there is no such render).
#[utoipa::path(get, path = "/renders/{id}/images", tag = "images", params(("id" = i64, Path)),
    responses((status = 200, body = Vec<ImageInfo>), (status = 404, body = ErrorBody), (status = 503, body = ErrorBody)))]
pub async fn render_images(
    State(state): State<AppState>,
    Path(id): Path<i64>,
) -> Result<Json<Vec<ImageInfo>>, ApiError> {
    let jobs = images(&state)?;
    state.lab.render(id).await?;
    Ok(Json(jobs.of_render(id)))
}

#[utoipa::path(get, path = "/images/{id}", tag = "images", params(("id" = i64, Path)),
    responses((status = 200, body = ImageInfo), (status = 404, body = ErrorBody), (status = 503, body = ErrorBody)))]
pub async fn get_image(State(state): State<AppState>, Path(id): Path<i64>) -> Result<Json<ImageInfo>, ApiError> {
    let images = images(&state)?;
    images.info(id).map(Json).ok_or_else(|| images.missing(id).into())
}

/// Cancels a queued image at once, or stops a running one within a row of pixels.
#[utoipa::path(post, path = "/images/{id}/cancel", tag = "images", params(("id" = i64, Path)),
    responses((status = 202, body = ImageInfo), (status = 401, body = ErrorBody), (status = 404, body = ErrorBody),
              (status = 409, description = "the image has already ended", body = ErrorBody), (status = 503, body = ErrorBody)),
    security(("bearer" = [])))]
pub async fn cancel_image(
    State(state): State<AppState>,
    Path(id): Path<i64>,
) -> Result<(StatusCode, Json<ImageInfo>), ApiError> {
    Ok((StatusCode::ACCEPTED, Json(images(&state)?.cancel(id)?)))
}

/// The image for looking at: XYZ → sRGB, Reinhard global tone map, 8 bits.
#[utoipa::path(get, path = "/images/{id}/display.png", tag = "images", params(("id" = i64, Path)),
    responses((status = 200, content_type = "image/png"), (status = 404, body = ErrorBody),
              (status = 409, description = "the image is not complete", body = ErrorBody), (status = 503, body = ErrorBody)))]
pub async fn image_display_png(State(state): State<AppState>, Path(id): Path<i64>) -> Result<Response, ApiError> {
    let png = images(&state)?.display_png(id).await?;
    Ok(([(header::CONTENT_TYPE, "image/png")], png).into_response())
}

#[derive(Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
#[serde(deny_unknown_fields)]
pub struct ProbeQuery {
    /// Pixel column from the left (the box's left edge).
    pub x: u32,
    /// Pixel row from the top (the box's top edge).
    pub y: u32,
    /// Box width in pixels (default 1).
    #[param(minimum = 1, nullable = false)]
    pub w: Option<u32>,
    /// Box height in pixels (default 1).
    #[param(minimum = 1, nullable = false)]
    pub h: Option<u32>,
}

/// A pixel's (or a box's) channels ± SE, XYZ, x,y and LMS.
#[utoipa::path(get, path = "/images/{id}/pixel", tag = "images", params(("id" = i64, Path), ProbeQuery),
    responses((status = 200, body = Probe), (status = 400, description = "the box leaves the image", body = ErrorBody), (status = 404, body = ErrorBody), (status = 409, body = ErrorBody), (status = 503, body = ErrorBody)))]
pub async fn image_pixel(
    State(state): State<AppState>,
    Path(id): Path<i64>,
    Query(q): Query<ProbeQuery>,
) -> Result<Json<Probe>, ApiError> {
    Ok(Json(images(&state)?.probe(
        id,
        q.x,
        q.y,
        q.w.unwrap_or(1),
        q.h.unwrap_or(1),
    )?))
}

/// The probe as a chart: the spectrum (or the RGB channels) ± 1 SE.
#[utoipa::path(get, path = "/images/{id}/pixel.svg", tag = "images", params(("id" = i64, Path), ProbeQuery),
    responses((status = 200, content_type = "image/svg+xml"), (status = 400, description = "the box leaves the image", body = ErrorBody), (status = 404, body = ErrorBody), (status = 409, body = ErrorBody), (status = 503, body = ErrorBody)))]
pub async fn image_pixel_svg(
    State(state): State<AppState>,
    Path(id): Path<i64>,
    Query(q): Query<ProbeQuery>,
) -> Result<Response, ApiError> {
    let svg = images(&state)?
        .probe_chart(id, q.x, q.y, q.w.unwrap_or(1), q.h.unwrap_or(1))
        .await?;
    Ok(([(header::CONTENT_TYPE, "image/svg+xml")], svg).into_response())
}

/// The image as multi-channel OpenEXR: spectral channels `S0.<λ>nm`
/// (Fichet et al. 2021) or R, G, B, then X, Y, Z, L, M, S, each with its
/// `SE.` layer, and `paths` (see `export::image`).
#[utoipa::path(get, path = "/images/{id}/image.exr", tag = "images", params(("id" = i64, Path)),
    responses((status = 200, content_type = "image/x-exr"), (status = 404, body = ErrorBody), (status = 409, body = ErrorBody), (status = 503, body = ErrorBody)))]
pub async fn image_exr(State(state): State<AppState>, Path(id): Path<i64>) -> Result<Response, ApiError> {
    Ok(kept::download(images(&state)?.file(id, FileFormat::Exr, false).await?))
}

/// The image as MATLAB `.mat`: `radiance` (H × W × N single),
/// `radiance_se`, `XYZ`, `LMS`, `paths`, `wavelength_nm`, `units`, `coding`.
#[utoipa::path(get, path = "/images/{id}/image.mat", tag = "images", params(("id" = i64, Path)),
    responses((status = 200, content_type = "application/x-matlab-data"), (status = 404, body = ErrorBody), (status = 409, body = ErrorBody), (status = 503, body = ErrorBody)))]
pub async fn image_mat(State(state): State<AppState>, Path(id): Path<i64>) -> Result<Response, ApiError> {
    Ok(kept::download(images(&state)?.file(id, FileFormat::Mat, false).await?))
}

/// Every coding rendered from the same paths as image `id`, in one
/// layered OpenEXR: a layer per coding (`nstep9.X`, `nstep9.SE.X`, …), the
/// codings and the reference in the header (`lightbooth.codings`,
/// `lightbooth.reference`). `POST /api/stimulus-sets/exr` reads it back.
#[utoipa::path(get, path = "/images/{id}/set.exr", tag = "images", params(("id" = i64, Path)),
    responses((status = 200, content_type = "image/x-exr"), (status = 404, body = ErrorBody), (status = 409, body = ErrorBody), (status = 503, body = ErrorBody)))]
pub async fn image_set_exr(State(state): State<AppState>, Path(id): Path<i64>) -> Result<Response, ApiError> {
    Ok(kept::download(images(&state)?.file(id, FileFormat::Exr, true).await?))
}

#[derive(Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
#[serde(deny_unknown_fields)]
pub struct DeltaEQuery {
    /// The other image: same render, same size.
    pub against: i64,
}

/// CIELAB ΔE00 per pixel between this image and `against` (two codings of
/// one render), with the scene's white: summary, colour scale and values.
#[utoipa::path(get, path = "/images/{id}/delta-e", tag = "images", params(("id" = i64, Path), DeltaEQuery),
    responses((status = 200, body = DeltaEMap), (status = 404, body = ErrorBody),
              (status = 409, description = "an image is not complete, or the two differ in render or size", body = ErrorBody), (status = 503, body = ErrorBody)))]
pub async fn image_delta_e(
    State(state): State<AppState>,
    Path(id): Path<i64>,
    Query(q): Query<DeltaEQuery>,
) -> Result<Json<DeltaEMap>, ApiError> {
    Ok(Json(state.lab.image_delta_e(id, q.against).await?))
}

/// The ΔE00 map as a false-colour PNG (viridis from 0 to `scale_max` of the JSON).
#[utoipa::path(get, path = "/images/{id}/delta-e.png", tag = "images", params(("id" = i64, Path), DeltaEQuery),
    responses((status = 200, content_type = "image/png"), (status = 404, body = ErrorBody), (status = 409, body = ErrorBody), (status = 503, body = ErrorBody)))]
pub async fn image_delta_e_png(
    State(state): State<AppState>,
    Path(id): Path<i64>,
    Query(q): Query<DeltaEQuery>,
) -> Result<Response, ApiError> {
    let png = state.lab.image_delta_e_png(id, q.against).await?;
    Ok(([(header::CONTENT_TYPE, "image/png")], png).into_response())
}
