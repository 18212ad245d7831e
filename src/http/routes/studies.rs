//! `/api/studies`: start a study, follow it, and fetch its report files.

use axum::extract::State;
use axum::http::{header, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::Json;
use serde::Serialize;
use utoipa::ToSchema;

use crate::http::error::ApiError;
use crate::http::input::{Input, Path};
use crate::http::AppState;
use crate::lab::measure::booth_instrument::{describe_targets, TargetsRequested};
use crate::lab::requests::StudyRequest;
use crate::store::{Booth, Job, StudyRow};

#[utoipa::path(get, path = "/studies", tag = "studies", responses((status = 200, body = Vec<StudyRow>)))]
pub async fn list_studies(State(state): State<AppState>) -> Result<Json<Vec<StudyRow>>, ApiError> {
    Ok(Json(state.lab.studies().await?))
}

#[derive(Serialize, ToSchema)]
pub struct StudyAccepted {
    pub id: i64,
    pub url: String,
    /// With `measure_missing`: the measurements queued for the study now.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub measured_first: Vec<i64>,
    /// With `measure_missing`: the measurements of missing targets that
    /// were already queued or running, not queued again (the study waits
    /// for them too); `message` says how many.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub already_on_their_way: Vec<i64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub message: Option<String>,
}

/// Starts a study (every coding of the chosen scenes against the truth, over
/// seeds); poll the URL or follow `/api/events` until `state` is final.
/// Against measurements, every target of the chosen scenes needs a complete
/// measurement: with `"measure_missing": true` the missing ones are queued
/// for the instrument first (listed in the study's request as
/// `measured_first`, progress in `study_progress` events) — except those
/// with a measurement already queued or running, which the study waits for
/// instead (`already_on_their_way` in the answer); without it a
/// study missing measurements is refused with 409 naming them.
#[utoipa::path(post, path = "/studies", tag = "studies", request_body = Option<StudyRequest>,
    responses((status = 202, body = StudyAccepted), (status = 400, body = crate::http::error::ErrorBody),
              (status = 401, body = crate::http::error::ErrorBody),
              (status = 409, body = crate::http::error::ErrorBody,
               description = "measurements are missing, cannot give XYZ in the daemon's observer (a colorimeter's in another, a luminance meter's), the instrument queue cannot take them, or the render queue is full"),
              (status = 503, body = crate::http::error::ErrorBody, description = "measurements are missing and the instrument is unavailable")),
    security(("bearer" = [])))]
pub async fn start_study(
    State(state): State<AppState>,
    Input(mut body): Input<StudyRequest>,
) -> Result<(StatusCode, Json<StudyAccepted>), ApiError> {
    if let Some(list) = &body.scenes {
        check_scene_list(list)?;
    }
    let renders = state.lab.renders()?;
    // The study compares with one booth's measurements: this daemon's unless
    // the request names another; stored with the request (retries, workers).
    let booth: Booth = match body.booth.as_deref() {
        Some(b) => b
            .parse()
            .map_err(|e| ApiError::BadRequest(format!("field `booth`: {e}")))?,
        None => state.lab.booth().clone(),
    };
    body.booth = Some(booth.to_string());
    renders.check_study(&body)?;
    let mut requested = TargetsRequested::default();
    if body.against.as_deref().unwrap_or("measurements") == "measurements" {
        let chosen: Option<Vec<&str>> = body
            .scenes
            .as_deref()
            .map(|list| list.split(',').map(str::trim).filter(|s| !s.is_empty()).collect());
        let missing = state.lab.unmeasured_targets(chosen.as_deref(), &booth).await?;
        // A study that cannot run is refused now, not failed after the 202.
        let measures_missing = !missing.is_empty() && body.measure_missing == Some(true);
        state
            .lab
            .check_study_measurements(chosen.as_deref(), &booth, measures_missing)
            .await?;
        if !missing.is_empty() && body.measure_missing == Some(true) && &booth != state.lab.booth() {
            return Err(ApiError::BadRequest(format!(
                "field `booth`: this daemon measures in booth {}; it cannot measure the missing targets of booth \
                 {booth} ({}): start the study on that booth's daemon",
                state.lab.booth(),
                describe_targets(&missing)
            )));
        }
        if !missing.is_empty() {
            if body.measure_missing != Some(true) {
                return Err(ApiError::Conflict(format!(
                    "no complete measurement of {} in booth {booth}: measure {} first (POST /api/measurements, or the scene's \
                     \"Measure every target\" button), start the study with \"measure_missing\": true to have \
                     it measure them first, or compare against \"reference\"",
                    describe_targets(&missing),
                    if missing.len() == 1 { "it" } else { "them" }
                )));
            }
            requested = state
                .lab
                .instrument()
                .request_targets(&missing, "measured first for a study (measure_missing)")
                .await?;
            body.measured_first = requested
                .queued
                .iter()
                .chain(&requested.already_on_their_way)
                .copied()
                .collect();
            body.measured_first.sort_unstable();
        }
    }
    let id = renders.start_study(body).await?;
    let message = (!requested.already_on_their_way.is_empty()).then(|| {
        let skipped = &requested.already_on_their_way;
        format!(
            "{} of the missing targets already had a measurement queued or running ({}), not queued again; \
             the study waits for {} and for the {} queued now",
            skipped.len(),
            skipped
                .iter()
                .map(|i| format!("measurement {i}"))
                .collect::<Vec<_>>()
                .join(", "),
            if skipped.len() == 1 { "it" } else { "them" },
            requested.queued.len()
        )
    });
    Ok((
        StatusCode::ACCEPTED,
        Json(StudyAccepted {
            id,
            url: format!("/api/studies/{id}"),
            measured_first: requested.queued,
            already_on_their_way: requested.already_on_their_way,
            message,
        }),
    ))
}

#[utoipa::path(get, path = "/studies/{id}", tag = "studies", params(("id" = i64, Path)),
    responses((status = 200, body = StudyRow), (status = 404, body = crate::http::error::ErrorBody)))]
pub async fn get_study(State(state): State<AppState>, Path(id): Path<i64>) -> Result<Json<StudyRow>, ApiError> {
    Ok(Json(state.lab.study(id).await?))
}

/// Cancels a queued study at once, or stops a running one at its next
/// batch of paths (it then ends `cancelled`); answers with the study as it is now.
#[utoipa::path(post, path = "/studies/{id}/cancel", tag = "studies", params(("id" = i64, Path)),
    responses((status = 503, description = "this daemon runs without the renderer", body = crate::http::error::ErrorBody), (status = 202, body = StudyRow), (status = 401, body = crate::http::error::ErrorBody),
              (status = 404, body = crate::http::error::ErrorBody),
              (status = 409, description = "the study has already ended", body = crate::http::error::ErrorBody)),
    security(("bearer" = [])))]
pub async fn cancel_study(
    State(state): State<AppState>,
    Path(id): Path<i64>,
) -> Result<(StatusCode, Json<StudyRow>), ApiError> {
    state.lab.renders()?.cancel(Job::Study, id).await?;
    Ok((StatusCode::ACCEPTED, Json(state.lab.study(id).await?)))
}

/// Queues a new study (a new id) with the request of an interrupted,
/// failed or cancelled one; the old study stays as it ended.
#[utoipa::path(post, path = "/studies/{id}/retry", tag = "studies", params(("id" = i64, Path)),
    responses((status = 503, description = "this daemon runs without the renderer", body = crate::http::error::ErrorBody), (status = 202, body = StudyAccepted), (status = 401, body = crate::http::error::ErrorBody),
              (status = 404, body = crate::http::error::ErrorBody),
              (status = 409, description = "the study is not retryable, or the queue is full",
               body = crate::http::error::ErrorBody)),
    security(("bearer" = [])))]
pub async fn retry_study(
    State(state): State<AppState>,
    Path(id): Path<i64>,
) -> Result<(StatusCode, Json<StudyAccepted>), ApiError> {
    let new = state.lab.renders()?.retry(Job::Study, id).await?;
    Ok((
        StatusCode::ACCEPTED,
        Json(StudyAccepted {
            id: new,
            url: format!("/api/studies/{new}"),
            measured_first: Vec::new(),
            already_on_their_way: Vec::new(),
            message: None,
        }),
    ))
}

/// A file of a study's report: `index.html` (the whole report), a chart
/// (`.svg`), a table (`.csv`) or `study.json`.
#[utoipa::path(get, path = "/studies/{id}/files/{name}", tag = "studies",
    params(("id" = i64, Path), ("name" = String, Path)),
    responses((status = 200, description = "the file"), (status = 404, body = crate::http::error::ErrorBody)))]
pub async fn study_file(
    State(state): State<AppState>,
    Path((id, name)): Path<(i64, String)>,
) -> Result<Response, ApiError> {
    let content = state.lab.study_file(id, &name).await?;
    let content_type = match name.rsplit('.').next() {
        Some("html") => "text/html; charset=utf-8",
        Some("svg") => "image/svg+xml",
        Some("csv") => "text/csv",
        Some("json") => "application/json",
        _ => "application/octet-stream",
    };
    Ok(([(header::CONTENT_TYPE, content_type)], content).into_response())
}

/// Most scenes one study may name: more than the scenes of any booth, and a
/// bound on the work one request can queue.
pub const MAX_STUDY_SCENES: usize = 64;

/// Refuses a scene list that names a scene twice (a study of the same scene
/// 5 000 times ran for minutes and failed on a UNIQUE constraint) or names
/// more than [`MAX_STUDY_SCENES`], as renders refuse repeated codings.
fn check_scene_list(list: &str) -> Result<(), ApiError> {
    let names: Vec<&str> = list.split(',').map(str::trim).filter(|s| !s.is_empty()).collect();
    if names.len() > MAX_STUDY_SCENES {
        return Err(ApiError::BadRequest(format!(
            "field `scenes`: {} scenes named; a study takes at most {MAX_STUDY_SCENES} (leave `scenes` out for every scene)",
            names.len()
        )));
    }
    for (i, name) in names.iter().enumerate() {
        if names[..i].contains(name) {
            return Err(ApiError::BadRequest(format!(
                "field `scenes`: `{name}` is named twice; name each scene once"
            )));
        }
    }
    Ok(())
}
