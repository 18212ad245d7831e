//! `/api/scenes` and `/api/renders`: the scenes the daemon knows, their
//! targets, and renders of them (with a preview image).

use axum::extract::State;
use axum::http::{header, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::Json;
use serde::Serialize;
use utoipa::ToSchema;

use crate::http::error::ApiError;
use crate::http::input::{Input, Path};
use crate::http::AppState;
use crate::lab::compare::overview::ScenesOverview;
use crate::lab::requests::RenderRequest;
use crate::lab::requests::SceneInfo;
use crate::store::{Job, RenderRow};

#[utoipa::path(get, path = "/scenes", tag = "scenes", responses((status = 503, description = "this daemon runs without the renderer", body = crate::http::error::ErrorBody), (status = 200, body = Vec<SceneInfo>)))]
pub async fn list_scenes(State(state): State<AppState>) -> Result<Json<Vec<SceneInfo>>, ApiError> {
    Ok(Json(state.lab.scenes()?))
}

/// Every scene at a glance: targets measured in this booth of all, the
/// newest measurement's end, the render whose camera view is its
/// thumbnail, and each coding's mean ΔE00 and rms_rel (see
/// `lab::compare::overview`).
#[utoipa::path(get, path = "/scene-overview", tag = "scenes", responses((status = 503, description = "this daemon runs without the renderer", body = crate::http::error::ErrorBody), (status = 200, body = ScenesOverview)))]
pub async fn scene_overview(State(state): State<AppState>) -> Result<Response, ApiError> {
    let overview = state.lab.scenes_overview().await?;
    let body = state
        .lab
        .computed()
        .output(&overview, "json", |o| serde_json::to_vec(o).map_err(|e| e.to_string()))
        .await?;
    Ok(crate::http::kept::json(body))
}

#[utoipa::path(get, path = "/scenes/{scene}", tag = "scenes", params(("scene" = String, Path)),
    responses((status = 503, description = "this daemon runs without the renderer", body = crate::http::error::ErrorBody), (status = 200, body = SceneInfo), (status = 404, body = crate::http::error::ErrorBody)))]
pub async fn get_scene(State(state): State<AppState>, Path(scene): Path<String>) -> Result<Json<SceneInfo>, ApiError> {
    Ok(Json(state.lab.scene(&scene)?))
}

#[utoipa::path(get, path = "/scenes/{scene}/targets", tag = "scenes", params(("scene" = String, Path)),
    responses((status = 503, description = "this daemon runs without the renderer", body = crate::http::error::ErrorBody), (status = 200, body = Vec<String>)))]
pub async fn scene_targets(
    State(state): State<AppState>,
    Path(scene): Path<String>,
) -> Result<Json<Vec<String>>, ApiError> {
    Ok(Json(state.lab.scene(&scene)?.targets))
}

#[utoipa::path(get, path = "/scenes/{scene}/renders", tag = "renders", params(("scene" = String, Path)),
    responses((status = 503, description = "this daemon runs without the renderer", body = crate::http::error::ErrorBody), (status = 200, body = Vec<RenderRow>)))]
pub async fn scene_renders(
    State(state): State<AppState>,
    Path(scene): Path<String>,
) -> Result<Json<Vec<RenderRow>>, ApiError> {
    Ok(Json(state.lab.renders_of_scene(&scene).await?))
}

#[derive(Serialize, ToSchema)]
pub struct RenderAccepted {
    pub render_id: i64,
    pub url: String,
}

#[utoipa::path(post, path = "/scenes/{scene}/renders", tag = "renders", params(("scene" = String, Path)),
    request_body = Option<RenderRequest>,
    responses((status = 202, body = RenderAccepted), (status = 400, body = crate::http::error::ErrorBody),
              (status = 401, body = crate::http::error::ErrorBody), (status = 404, body = crate::http::error::ErrorBody),
              (status = 409, description = "the render queue is full", body = crate::http::error::ErrorBody),
              (status = 503, body = crate::http::error::ErrorBody)),
    security(("bearer" = [])))]
pub async fn start_render(
    State(state): State<AppState>,
    Path(scene): Path<String>,
    Input(body): Input<RenderRequest>,
) -> Result<(StatusCode, Json<RenderAccepted>), ApiError> {
    state.lab.scene(&scene)?;
    let render_id = state.lab.renders()?.start_render(&scene, body).await?;
    Ok((
        StatusCode::ACCEPTED,
        Json(RenderAccepted {
            render_id,
            url: format!("/api/renders/{render_id}"),
        }),
    ))
}

#[utoipa::path(get, path = "/renders/{id}", tag = "renders", params(("id" = i64, Path)),
    responses((status = 200, body = RenderRow), (status = 404, body = crate::http::error::ErrorBody)))]
pub async fn get_render(State(state): State<AppState>, Path(id): Path<i64>) -> Result<Json<RenderRow>, ApiError> {
    Ok(Json(state.lab.render(id).await?))
}

/// Cancels a queued render at once, or stops a running one within a batch
/// of paths (it then ends `cancelled`); answers with the render as it is now.
#[utoipa::path(post, path = "/renders/{id}/cancel", tag = "renders", params(("id" = i64, Path)),
    responses((status = 503, description = "this daemon runs without the renderer", body = crate::http::error::ErrorBody), (status = 202, body = RenderRow), (status = 401, body = crate::http::error::ErrorBody),
              (status = 404, body = crate::http::error::ErrorBody),
              (status = 409, description = "the render has already ended", body = crate::http::error::ErrorBody)),
    security(("bearer" = [])))]
pub async fn cancel_render(
    State(state): State<AppState>,
    Path(id): Path<i64>,
) -> Result<(StatusCode, Json<RenderRow>), ApiError> {
    state.lab.renders()?.cancel(Job::Render, id).await?;
    Ok((StatusCode::ACCEPTED, Json(state.lab.render(id).await?)))
}

/// Queues a new render (a new id) with the scene and settings of an
/// interrupted, failed or cancelled one; the old render stays as it ended.
#[utoipa::path(post, path = "/renders/{id}/retry", tag = "renders", params(("id" = i64, Path)),
    responses((status = 503, description = "this daemon runs without the renderer", body = crate::http::error::ErrorBody), (status = 202, body = RenderAccepted), (status = 401, body = crate::http::error::ErrorBody),
              (status = 404, body = crate::http::error::ErrorBody),
              (status = 409, description = "the render is not retryable, or the queue is full",
               body = crate::http::error::ErrorBody)),
    security(("bearer" = [])))]
pub async fn retry_render(
    State(state): State<AppState>,
    Path(id): Path<i64>,
) -> Result<(StatusCode, Json<RenderAccepted>), ApiError> {
    let render_id = state.lab.renders()?.retry(Job::Render, id).await?;
    Ok((
        StatusCode::ACCEPTED,
        Json(RenderAccepted {
            render_id,
            url: format!("/api/renders/{render_id}"),
        }),
    ))
}

/// The scene's camera view of a render (tone-mapped sRGB), once the render is complete.
#[utoipa::path(get, path = "/renders/{id}/preview.png", tag = "renders", params(("id" = i64, Path)),
    responses((status = 200, content_type = "image/png"), (status = 404, body = crate::http::error::ErrorBody)))]
pub async fn render_preview(State(state): State<AppState>, Path(id): Path<i64>) -> Result<Response, ApiError> {
    let png = state.lab.render_preview(id).await?;
    Ok(([(header::CONTENT_TYPE, "image/png")], png).into_response())
}
