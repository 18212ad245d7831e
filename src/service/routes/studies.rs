//! `/api/studies`: start a study, follow it, and fetch its report files.

use std::sync::Arc;

use axum::extract::State;
use axum::http::{header, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::Json;
use serde::Serialize;
use utoipa::ToSchema;

use crate::service::error::ApiError;
use crate::service::input::{Input, Path};
use crate::service::{AppState, StudyRequest};
use crate::store::StudyRow;

#[utoipa::path(get, path = "/studies", tag = "studies", responses((status = 200, body = Vec<StudyRow>)))]
pub async fn list_studies(State(state): State<AppState>) -> Result<Json<Vec<StudyRow>>, ApiError> {
    Ok(Json(state.store.list_studies().await?))
}

#[derive(Serialize, ToSchema)]
pub struct StudyAccepted {
    pub id: i64,
    pub url: String,
}

/// Starts a study (every coding of the chosen scenes against the truth, over
/// seeds); poll the URL or follow `/api/events` until `state` is final.
#[utoipa::path(post, path = "/studies", tag = "studies", request_body = Option<StudyRequest>,
    responses((status = 503, description = "this daemon runs without the renderer", body = crate::service::error::ErrorBody), (status = 202, body = StudyAccepted), (status = 400, body = crate::service::error::ErrorBody)),
    security(("bearer" = [])))]
pub async fn start_study(
    State(state): State<AppState>,
    Input(body): Input<StudyRequest>,
) -> Result<(StatusCode, Json<StudyAccepted>), ApiError> {
    let service = state
        .renders
        .as_ref()
        .ok_or_else(|| ApiError::Unavailable("no renderer".into()))?;
    let id = Arc::clone(service).start_study(body).await?;
    Ok((
        StatusCode::ACCEPTED,
        Json(StudyAccepted {
            id,
            url: format!("/api/studies/{id}"),
        }),
    ))
}

#[utoipa::path(get, path = "/studies/{id}", tag = "studies", params(("id" = i64, Path)),
    responses((status = 200, body = StudyRow), (status = 404, body = crate::service::error::ErrorBody)))]
pub async fn get_study(State(state): State<AppState>, Path(id): Path<i64>) -> Result<Json<StudyRow>, ApiError> {
    state
        .store
        .get_study(id)
        .await?
        .map(Json)
        .ok_or_else(|| ApiError::NotFound(format!("no study {id}")))
}

/// A file of a study's report: `index.html` (the whole report), a chart
/// (`.svg`), a table (`.csv`) or `study.json`.
#[utoipa::path(get, path = "/studies/{id}/files/{name}", tag = "studies",
    params(("id" = i64, Path), ("name" = String, Path)),
    responses((status = 200, description = "the file"), (status = 404, body = crate::service::error::ErrorBody)))]
pub async fn study_file(
    State(state): State<AppState>,
    Path((id, name)): Path<(i64, String)>,
) -> Result<Response, ApiError> {
    let content = state
        .store
        .study_file(id, &name)
        .await?
        .ok_or_else(|| ApiError::NotFound(format!("study {id} has no file `{name}`")))?;
    let content_type = match name.rsplit('.').next() {
        Some("html") => "text/html; charset=utf-8",
        Some("svg") => "image/svg+xml",
        Some("csv") => "text/csv",
        Some("json") => "application/json",
        _ => "application/octet-stream",
    };
    Ok(([(header::CONTENT_TYPE, content_type)], content).into_response())
}
