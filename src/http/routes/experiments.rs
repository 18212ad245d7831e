//! `/api/experiments` and `/api/experiment-sessions`: the study's oddity
//! experiment ([`crate::lab::experiments`]). An experiment is set up from a
//! complete measurement and its comparisons and checked on its display
//! profile when created (`POST /api/experiments/check` checks without
//! storing); observers' sessions take their trials one by one as each ends
//! (`POST /api/experiment-sessions/{id}/trials`), and the analysis gives
//! percent correct and d′ per observer and approximation.

use std::sync::Arc;

use axum::extract::State;
use axum::http::StatusCode;
use axum::response::{IntoResponse, Response};
use axum::Json;
use serde::Deserialize;
use utoipa::ToSchema;

use crate::display::output::ColourCheck;
use crate::http::error::{ApiError, ErrorBody};
use crate::http::input::{Input, Path, Query};
use crate::http::kept;
use crate::http::AppState;
use crate::lab::experiments::analysis::{figure, psychometric_figure, Analysis};
use crate::lab::experiments::session::{DisplayReport, SessionView, TrialReport};
use crate::lab::experiments::verification::{Verification, VerificationRequest};
use crate::lab::experiments::ExperimentRequest;
use crate::lab::AnalysisFile;
use crate::psychophysics::oddity::OddityModel;
use crate::store::{ExperimentRow, ExperimentSessionRow};

/// Every experiment, newest first.
#[utoipa::path(get, path = "/experiments", tag = "experiments",
    responses((status = 200, body = Vec<ExperimentRow>)))]
pub async fn list_experiments(State(state): State<AppState>) -> Result<Json<Vec<ExperimentRow>>, ApiError> {
    Ok(Json(state.lab.experiment_list().await?))
}

/// Sets up an experiment: every colour through the display profile, the
/// check stored with it (see `check`).
#[utoipa::path(post, path = "/experiments", tag = "experiments", request_body = ExperimentRequest,
    responses((status = 201, body = ExperimentRow), (status = 400, body = ErrorBody), (status = 401, body = ErrorBody),
              (status = 404, body = ErrorBody), (status = 409, body = ErrorBody)),
    security(("bearer" = [])))]
pub async fn create_experiment(
    State(state): State<AppState>,
    Input(body): Input<ExperimentRequest>,
) -> Result<(StatusCode, Json<ExperimentRow>), ApiError> {
    Ok((StatusCode::CREATED, Json(state.lab.experiments().create(body).await?)))
}

/// What an experiment's display would show: per colour the codes at 8 bits
/// and with the output method, out of gamut or not distinct, in words.
/// Stores nothing.
#[utoipa::path(post, path = "/experiments/check", tag = "experiments", request_body = ExperimentRequest,
    responses((status = 200, body = ColourCheck), (status = 400, body = ErrorBody), (status = 404, body = ErrorBody),
              (status = 409, body = ErrorBody)),
    security(("bearer" = [])))]
pub async fn check_experiment(
    State(state): State<AppState>,
    Input(body): Input<ExperimentRequest>,
) -> Result<Json<ColourCheck>, ApiError> {
    Ok(Json(state.lab.experiments().check(&body).await?.1))
}

#[utoipa::path(get, path = "/experiments/{id}", tag = "experiments", params(("id" = i64, Path)),
    responses((status = 200, body = ExperimentRow), (status = 404, body = ErrorBody)))]
pub async fn get_experiment(
    State(state): State<AppState>,
    Path(id): Path<i64>,
) -> Result<Json<ExperimentRow>, ApiError> {
    Ok(Json(state.lab.experiments().get(id).await?))
}

/// An experiment's sessions, oldest first.
#[utoipa::path(get, path = "/experiments/{id}/sessions", tag = "experiments", params(("id" = i64, Path)),
    responses((status = 200, body = Vec<ExperimentSessionRow>), (status = 404, body = ErrorBody)))]
pub async fn list_experiment_sessions(
    State(state): State<AppState>,
    Path(id): Path<i64>,
) -> Result<Json<Vec<ExperimentSessionRow>>, ApiError> {
    Ok(Json(state.lab.sessions_of_experiment(id).await?))
}

#[derive(Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct NewExperimentSession {
    /// The observer's id: 1–64 letters, digits, `.`, `_`, `-` (no names needed).
    pub observer: String,
}

/// Starts a session of an observer, or resumes the observer's running one
/// where it stopped.
#[utoipa::path(post, path = "/experiments/{id}/sessions", tag = "experiments", params(("id" = i64, Path)),
    request_body = NewExperimentSession,
    responses((status = 200, body = SessionView), (status = 400, body = ErrorBody), (status = 401, body = ErrorBody),
              (status = 404, body = ErrorBody)),
    security(("bearer" = [])))]
pub async fn start_experiment_session(
    State(state): State<AppState>,
    Path(id): Path<i64>,
    Input(body): Input<NewExperimentSession>,
) -> Result<Json<SessionView>, ApiError> {
    Ok(Json(state.lab.experiments().start_session(id, &body.observer).await?))
}

/// A session's state and the trial to show next.
#[utoipa::path(get, path = "/experiment-sessions/{id}", tag = "experiments", params(("id" = i64, Path)),
    responses((status = 200, body = SessionView), (status = 404, body = ErrorBody)))]
pub async fn get_experiment_session(
    State(state): State<AppState>,
    Path(id): Path<i64>,
) -> Result<Json<SessionView>, ApiError> {
    Ok(Json(state.lab.experiments().view(id).await?))
}

/// The refresh the session page measured before its first trial; 409 once
/// the session has ended (a completed session is never rewritten).
#[utoipa::path(post, path = "/experiment-sessions/{id}/display", tag = "experiments", params(("id" = i64, Path)),
    request_body = DisplayReport,
    responses((status = 200, body = SessionView), (status = 400, body = ErrorBody), (status = 404, body = ErrorBody),
              (status = 409, body = ErrorBody)),
    security(("bearer" = [])))]
pub async fn report_session_display(
    State(state): State<AppState>,
    Path(id): Path<i64>,
    Input(body): Input<DisplayReport>,
) -> Result<Json<SessionView>, ApiError> {
    Ok(Json(state.lab.experiments().report_display(id, &body).await?))
}

/// Stores one trial as it ended; answers with the next. A trial that
/// contradicts its own frame intervals or the session's measured refresh is
/// refused (400, naming the field); one before the refresh is reported, or
/// for a position outside the session's order, is a 409.
#[utoipa::path(post, path = "/experiment-sessions/{id}/trials", tag = "experiments", params(("id" = i64, Path)),
    request_body = TrialReport,
    responses((status = 200, body = SessionView), (status = 400, body = ErrorBody), (status = 404, body = ErrorBody),
              (status = 409, body = ErrorBody)),
    security(("bearer" = [])))]
pub async fn record_experiment_trial(
    State(state): State<AppState>,
    Path(id): Path<i64>,
    Input(body): Input<TrialReport>,
) -> Result<Json<SessionView>, ApiError> {
    Ok(Json(state.lab.experiments().record_trial(id, &body).await?))
}

/// Stores a verification: the experiment's colours as the display emitted
/// them, each measured with the spectroradiometer, against what was
/// intended and against the real booth measurement (ΔE00, the display's
/// white), with a likely cause for each colour over the tolerance.
#[utoipa::path(post, path = "/experiments/{id}/verifications", tag = "experiments", params(("id" = i64, Path)),
    request_body = VerificationRequest,
    responses((status = 201, body = Verification), (status = 400, body = ErrorBody), (status = 401, body = ErrorBody),
              (status = 404, body = ErrorBody), (status = 409, body = ErrorBody)),
    security(("bearer" = [])))]
pub async fn create_experiment_verification(
    State(state): State<AppState>,
    Path(id): Path<i64>,
    Input(body): Input<VerificationRequest>,
) -> Result<(StatusCode, Json<Verification>), ApiError> {
    Ok((
        StatusCode::CREATED,
        Json(state.lab.experiments().verify(id, &body).await?),
    ))
}

/// An experiment's verifications, newest first.
#[utoipa::path(get, path = "/experiments/{id}/verifications", tag = "experiments", params(("id" = i64, Path)),
    responses((status = 200, body = Vec<Verification>), (status = 404, body = ErrorBody)))]
pub async fn list_experiment_verifications(
    State(state): State<AppState>,
    Path(id): Path<i64>,
) -> Result<Json<Vec<Verification>>, ApiError> {
    Ok(Json(state.lab.experiments().verifications(id).await?))
}

/// Percent correct and d′ (both oddity models) per observer and approximation.
#[utoipa::path(get, path = "/experiments/{id}/analysis", tag = "experiments", params(("id" = i64, Path)),
    responses((status = 200, body = Analysis), (status = 404, body = ErrorBody)))]
pub async fn experiment_analysis(State(state): State<AppState>, Path(id): Path<i64>) -> Result<Response, ApiError> {
    let a = state.lab.experiment_analysis(id).await?;
    let body = state
        .lab
        .computed()
        .output(&a, "json", |a| serde_json::to_vec(a).map_err(|e| e.to_string()))
        .await?;
    Ok(kept::json(body))
}

/// The analysis as CSV, one row per observer and approximation.
#[utoipa::path(get, path = "/experiments/{id}/analysis.csv", tag = "experiments", params(("id" = i64, Path)),
    responses((status = 200, content_type = "text/csv"), (status = 404, body = ErrorBody)))]
pub async fn experiment_analysis_csv(
    State(state): State<AppState>,
    Path(id): Path<i64>,
) -> Result<impl IntoResponse, ApiError> {
    Ok(kept::download(
        state.lab.experiment_file(id, AnalysisFile::AnalysisCsv).await?,
    ))
}

/// The analysis as a MAT-file: the CSV's columns as column vectors, text as
/// char matrices (`table(cellstr(observer), cellstr(approximation), proportion_correct)`).
#[utoipa::path(get, path = "/experiments/{id}/analysis.mat", tag = "experiments", params(("id" = i64, Path)),
    responses((status = 200, content_type = "application/x-matlab-data"), (status = 404, body = ErrorBody)))]
pub async fn experiment_analysis_mat(
    State(state): State<AppState>,
    Path(id): Path<i64>,
) -> Result<impl IntoResponse, ApiError> {
    Ok(kept::download(
        state.lab.experiment_file(id, AnalysisFile::AnalysisMat).await?,
    ))
}

/// Each observer's (and the pooled) threshold as CSV: per observer and
/// oddity model a `fit` row (σ, the ΔE00 at 2/3 correct, their intervals,
/// the deviance and its p-value) and a `prediction` row per approximation.
#[utoipa::path(get, path = "/experiments/{id}/thresholds.csv", tag = "experiments", params(("id" = i64, Path)),
    responses((status = 200, content_type = "text/csv"), (status = 404, body = ErrorBody)))]
pub async fn experiment_thresholds_csv(
    State(state): State<AppState>,
    Path(id): Path<i64>,
) -> Result<impl IntoResponse, ApiError> {
    Ok(kept::download(
        state.lab.experiment_file(id, AnalysisFile::ThresholdsCsv).await?,
    ))
}

/// The oddity model a figure is drawn under.
#[derive(Deserialize, utoipa::IntoParams)]
#[into_params(parameter_in = Query)]
#[serde(deny_unknown_fields)]
pub struct ModelQuery {
    /// `differencing` (default) or `independent-observation`.
    #[param(nullable = false, pattern = "^(differencing|independent-observation)$")]
    pub model: Option<String>,
}

/// The oddity model a query names (differencing by default).
fn model_of(name: Option<&str>) -> Result<OddityModel, ApiError> {
    match name {
        None | Some("differencing") => Ok(OddityModel::Differencing),
        Some("independent-observation") => Ok(OddityModel::IndependentObservation),
        Some(other) => Err(ApiError::BadRequest(format!(
            "query `model`: `{other}`; give differencing or independent-observation"
        ))),
    }
}

/// The psychometric figure: percent correct against ΔE00 per observer, the
/// fitted d′ = ΔE00/σ curve, chance marked, and the percent predicted for
/// the approximations the display could not show apart at 8 bits.
#[utoipa::path(get, path = "/experiments/{id}/psychometric.svg", tag = "experiments",
    params(("id" = i64, Path), ModelQuery),
    responses((status = 200, content_type = "image/svg+xml"), (status = 400, body = ErrorBody), (status = 404, body = ErrorBody)))]
pub async fn experiment_psychometric_figure(
    State(state): State<AppState>,
    Path(id): Path<i64>,
    Query(q): Query<ModelQuery>,
) -> Result<impl IntoResponse, ApiError> {
    let model = model_of(q.model.as_deref())?;
    let a = state.lab.experiment_analysis(id).await?;
    let what = format!("psychometric.svg {model:?}");
    let body = state
        .lab
        .computed()
        .output(&a, &what, move |a| {
            psychometric_figure(a, model)
                .map(String::into_bytes)
                .map_err(|e| e.to_string())
        })
        .await?;
    Ok(kept::served("image/svg+xml", body))
}

#[derive(Deserialize, utoipa::IntoParams)]
#[into_params(parameter_in = Query)]
#[serde(deny_unknown_fields)]
pub struct FigureQuery {
    /// Experiments (comma-separated ids, at most 24 distinct; a repeated id
    /// is drawn once), one group of bars each.
    pub ids: String,
    /// `differencing` (default) or `independent-observation`.
    pub model: Option<String>,
}

/// The study's Fig. 5 (right) for experiments: d′ bars per scene and
/// approximation (observers pooled), percent correct on a second axis,
/// chance marked.
#[utoipa::path(get, path = "/experiments/figure.svg", tag = "experiments", params(FigureQuery),
    responses((status = 200, content_type = "image/svg+xml"), (status = 400, body = ErrorBody), (status = 404, body = ErrorBody)))]
pub async fn experiments_figure(
    State(state): State<AppState>,
    Query(q): Query<FigureQuery>,
) -> Result<impl IntoResponse, ApiError> {
    let model = model_of(q.model.as_deref())?;
    let ids: Vec<i64> = q
        .ids
        .split(',')
        .map(|s| {
            crate::http::input::plain_id(s.trim()).ok_or_else(|| {
                ApiError::BadRequest(format!(
                    "query `ids`: `{}` is not an experiment id: give ids as plain digits, comma-separated, \
                     without a sign or leading zeros",
                    s.trim()
                ))
            })
        })
        .collect::<Result<_, _>>()?;
    let analyses = state.lab.experiment_analyses(&ids).await?;
    let svg = move |drawn: Result<String, crate::lab::error::LabError>| {
        drawn.map(String::into_bytes).map_err(|e| e.to_string())
    };
    // One experiment's figure is kept with its analysis; several are drawn
    // for the request (their analyses each kept).
    let computed = state.lab.computed();
    let body = match analyses.as_slice() {
        [one] => {
            let what = format!("figure.svg {model:?}");
            computed
                .output(one, &what, move |a| svg(figure(std::slice::from_ref(a), model)))
                .await?
        }
        _ => Arc::new(computed.output_not_kept(move || svg(figure(&analyses, model))).await?),
    };
    Ok(kept::served("image/svg+xml", body))
}
