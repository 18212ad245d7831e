//! The REST API's handlers. Paths that scripts depend on are fixed:
//! `/api/health`, `/api/openapi.json`, `/api/measurements`,
//! `/api/measurements/{id}`, `/api/events`.

use std::sync::Arc;

use axum::extract::{Path, State};
use axum::http::{header, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use axum::{Json, Router};
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::error::ApiError;
use super::input::{Input, Query};
use super::{events, AppState, Event, InstrumentStatus, MeasurementJob, RenderRequest, SceneInfo, StudyRequest};
use crate::charts;
use crate::comparison::{mean_sd, SceneSummary};
use crate::export::mat::MatFile;
use crate::store::{
    ComparisonRow, InstrumentRow, MeasurementDetail, MeasurementFilter, MeasurementPage, MeasurementState,
    NewMeasurement, RenderRow, SessionRow, StudyRow,
};

pub fn api_router() -> Router<AppState> {
    Router::new()
        .route("/health", get(health))
        .route("/openapi.json", get(super::openapi::document))
        .route("/instruments", get(instruments))
        .route("/sessions", get(list_sessions).post(create_session))
        .route("/measurements", get(list_measurements).post(start_measurement))
        .route("/measurements/{id}", get(get_measurement))
        .route("/measurements/{id}/spectrum.csv", get(measurement_csv))
        .route("/measurements/{id}/spectrum.mat", get(measurement_mat))
        .route("/measurements/{id}/spectrum.svg", get(measurement_svg))
        .route("/measurements/{id}/comparisons", get(measurement_comparisons))
        .route("/scenes", get(list_scenes))
        .route("/scenes/{scene}", get(get_scene))
        .route("/scenes/{scene}/targets", get(scene_targets))
        .route("/scenes/{scene}/renders", get(scene_renders).post(start_render))
        .route("/scenes/{scene}/comparisons", get(scene_comparisons))
        .route("/scenes/{scene}/comparisons.csv", get(scene_comparisons_csv))
        .route("/scenes/{scene}/comparisons.mat", get(scene_comparisons_mat))
        .route("/scenes/{scene}/charts/{chart}", get(scene_chart))
        .route("/studies", get(list_studies).post(start_study))
        .route("/studies/{id}", get(get_study))
        .route("/studies/{id}/files/{name}", get(study_file))
        .route("/renders/{id}", get(get_render))
        .route("/renders/{id}/preview.png", get(render_preview))
        .route("/events", get(events::stream))
        .route("/mock/faults", axum::routing::post(mock_faults))
}

// --- health and instruments ------------------------------------------------

#[derive(Serialize, ToSchema)]
pub struct Health {
    /// "ok" when the database answers.
    pub status: String,
    pub version: String,
    pub instrument: InstrumentStatus,
    pub queued_measurements: usize,
}

#[utoipa::path(get, path = "/api/health", tag = "service", responses((status = 200, body = Health)))]
pub async fn health(State(state): State<AppState>) -> Result<Json<Health>, ApiError> {
    sqlx::query("SELECT 1")
        .execute(state.store.pool())
        .await
        .map_err(|e| ApiError::Internal(e.to_string()))?;
    Ok(Json(Health {
        status: "ok".into(),
        version: env!("CARGO_PKG_VERSION").into(),
        instrument: state.status.borrow().clone(),
        queued_measurements: state.jobs.max_capacity() - state.jobs.capacity(),
    }))
}

#[derive(Serialize, ToSchema)]
pub struct Instruments {
    /// What the instrument task is doing now.
    pub status: InstrumentStatus,
    /// Every instrument this database has seen.
    pub known: Vec<InstrumentRow>,
}

#[utoipa::path(get, path = "/api/instruments", tag = "instruments", responses((status = 200, body = Instruments)))]
pub async fn instruments(State(state): State<AppState>) -> Result<Json<Instruments>, ApiError> {
    let status = state.status.borrow().clone();
    Ok(Json(Instruments {
        status,
        known: state.store.list_instruments().await?,
    }))
}

// --- sessions --------------------------------------------------------------

#[derive(Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct NewSession {
    pub operator: String,
    #[serde(default)]
    pub notes: String,
}

#[utoipa::path(get, path = "/api/sessions", tag = "sessions", responses((status = 200, body = Vec<SessionRow>)))]
pub async fn list_sessions(State(state): State<AppState>) -> Result<Json<Vec<SessionRow>>, ApiError> {
    Ok(Json(state.store.list_sessions().await?))
}

#[derive(Serialize, ToSchema)]
pub struct Created {
    pub id: i64,
}

#[utoipa::path(post, path = "/api/sessions", tag = "sessions", request_body = NewSession,
    responses((status = 201, body = Created), (status = 400, body = super::error::ErrorBody)),
    security(("bearer" = [])))]
pub async fn create_session(
    State(state): State<AppState>,
    Input(body): Input<NewSession>,
) -> Result<(StatusCode, Json<Created>), ApiError> {
    if body.operator.trim().is_empty() {
        return Err(ApiError::BadRequest("field `operator`: must not be empty".into()));
    }
    let id = state.store.create_session(body.operator.trim(), &body.notes).await?;
    Ok((StatusCode::CREATED, Json(Created { id })))
}

// --- measurements ----------------------------------------------------------

#[derive(Deserialize, ToSchema, Default)]
#[serde(deny_unknown_fields)]
pub struct StartMeasurement {
    /// Scene id (see `/api/scenes`); the daemon renders and compares when given with `target`.
    pub scene: Option<String>,
    pub target: Option<String>,
    /// Samples to average, 1–99 (default 5).
    pub samples: Option<usize>,
    pub session_id: Option<i64>,
    pub note: Option<String>,
}

#[derive(Serialize, ToSchema)]
pub struct Accepted {
    pub id: i64,
    pub state: MeasurementState,
    /// Poll this URL (or follow `/api/events`) until `state` is final.
    pub url: String,
}

#[utoipa::path(post, path = "/api/measurements", tag = "measurements", request_body = StartMeasurement,
    responses((status = 202, body = Accepted), (status = 400, body = super::error::ErrorBody),
              (status = 401, body = super::error::ErrorBody), (status = 409, body = super::error::ErrorBody),
              (status = 503, body = super::error::ErrorBody)),
    security(("bearer" = [])))]
pub async fn start_measurement(
    State(state): State<AppState>,
    Input(body): Input<StartMeasurement>,
) -> Result<(StatusCode, Json<Accepted>), ApiError> {
    let samples = body.samples.unwrap_or(state.config.default_samples);
    if !(1..=99).contains(&samples) {
        return Err(ApiError::BadRequest(format!(
            "field `samples`: {samples} is outside 1–99"
        )));
    }
    match (&body.scene, &body.target) {
        (Some(scene), target) => check_scene_target(&state, scene, target.as_deref())?,
        (None, Some(_)) => {
            return Err(ApiError::BadRequest(
                "field `target`: a target needs its `scene`".into(),
            ))
        }
        (None, None) => {}
    }
    match &*state.status.borrow() {
        InstrumentStatus::Disconnected { reason } => {
            return Err(ApiError::Unavailable(format!(
                "the instrument is unavailable: {reason}"
            )))
        }
        InstrumentStatus::Error { message } => {
            return Err(ApiError::Unavailable(format!("the instrument is in error: {message}")))
        }
        _ => {}
    }
    if let Some(session) = body.session_id {
        if !state.store.list_sessions().await?.iter().any(|s| s.id == session) {
            return Err(ApiError::BadRequest(format!(
                "field `session_id`: no session {session}; create one with POST /api/sessions"
            )));
        }
    }
    if state.jobs.capacity() == 0 {
        return Err(ApiError::Conflict(format!(
            "the instrument is busy: {} measurements are already queued; try again when one finishes",
            state.jobs.max_capacity()
        )));
    }
    let id = state
        .store
        .create_measurement(&NewMeasurement {
            session_id: body.session_id,
            scene: body.scene.clone(),
            target: body.target.clone(),
            samples,
            settings_json: serde_json::json!({ "samples": samples }),
            note: body.note.unwrap_or_default(),
        })
        .await?;
    let job = MeasurementJob {
        id,
        samples,
        scene: body.scene,
        target: body.target,
    };
    if let Err(e) = state.jobs.try_send(job) {
        state
            .store
            .end_measurement(id, MeasurementState::Cancelled, "the instrument queue was full")
            .await?;
        return Err(ApiError::Conflict(format!("the instrument is busy: {e}")));
    }
    tracing::info!(measurement_id = id, samples, "measurement queued");
    let _ = state.events.send(Event::MeasurementQueued { measurement_id: id });
    Ok((
        StatusCode::ACCEPTED,
        Json(Accepted {
            id,
            state: MeasurementState::Queued,
            url: format!("/api/measurements/{id}"),
        }),
    ))
}

fn check_scene_target(state: &AppState, scene: &str, target: Option<&str>) -> Result<(), ApiError> {
    let scenes = state.renders.as_ref().map(|r| r.scenes()).unwrap_or_default();
    let Some(info) = scenes.iter().find(|s| s.id == scene) else {
        let names: Vec<&str> = scenes.iter().map(|s| s.id.as_str()).collect();
        return Err(ApiError::BadRequest(format!(
            "field `scene`: no scene `{scene}`; available: {}",
            names.join(", ")
        )));
    };
    match target {
        None => Err(ApiError::BadRequest(format!(
            "field `target`: measuring scene `{scene}` needs a target; available: {}",
            info.targets.join(", ")
        ))),
        Some(t) if !info.targets.iter().any(|x| x == t) => Err(ApiError::BadRequest(format!(
            "field `target`: scene `{scene}` has no target `{t}`; available: {}",
            info.targets.join(", ")
        ))),
        Some(_) => Ok(()),
    }
}

#[utoipa::path(get, path = "/api/measurements", tag = "measurements", params(MeasurementFilter),
    responses((status = 200, body = MeasurementPage)))]
pub async fn list_measurements(
    State(state): State<AppState>,
    Query(filter): Query<MeasurementFilter>,
) -> Result<Json<MeasurementPage>, ApiError> {
    Ok(Json(state.store.list_measurements(&filter).await?))
}

async fn load_measurement(state: &AppState, id: i64) -> Result<MeasurementDetail, ApiError> {
    state
        .store
        .get_measurement(id)
        .await?
        .ok_or_else(|| ApiError::NotFound(format!("no measurement {id}")))
}

#[utoipa::path(get, path = "/api/measurements/{id}", tag = "measurements",
    params(("id" = i64, Path, description = "measurement id")),
    responses((status = 200, body = MeasurementDetail), (status = 404, body = super::error::ErrorBody)))]
pub async fn get_measurement(
    State(state): State<AppState>,
    Path(id): Path<i64>,
) -> Result<Json<MeasurementDetail>, ApiError> {
    Ok(Json(load_measurement(&state, id).await?))
}

/// Wavelength, mean, SD and every sample as columns (values as the instrument gave them, per nm).
#[utoipa::path(get, path = "/api/measurements/{id}/spectrum.csv", tag = "measurements",
    params(("id" = i64, Path)), responses((status = 200, content_type = "text/csv")))]
pub async fn measurement_csv(State(state): State<AppState>, Path(id): Path<i64>) -> Result<Response, ApiError> {
    let m = load_measurement(&state, id).await?;
    let wl = sample_grid(&m)?;
    let mut columns: Vec<(String, Vec<f64>)> = Vec::new();
    if let (Some(mean), Some(sd)) = (&m.radiance, &m.radiance_sd) {
        columns.push(("radiance".into(), mean.clone()));
        columns.push(("radiance_sd".into(), sd.clone()));
    }
    for s in &m.samples {
        if let Some(r) = &s.radiance {
            columns.push((format!("sample_{}_code_{}", s.index, s.code), r.clone()));
        }
    }
    let grid = crate::spectrum::Grid::from_wavelengths(wl).map_err(|e| ApiError::Internal(e.to_string()))?;
    let refs: Vec<(&str, &[f64])> = columns.iter().map(|(n, v)| (n.as_str(), v.as_slice())).collect();
    let mut out = Vec::new();
    crate::spectrum::table::write_csv(&mut out, &grid, &refs).map_err(|e| ApiError::Internal(e.to_string()))?;
    Ok(download("text/csv", &format!("measurement_{id}.csv"), out))
}

/// `load('measurement_7.mat')` gives wavelength_nm, radiance, radiance_sd,
/// samples (one column per sample; NaN where a sample had no valid
/// spectrum), sample_code, sample_usable, Y, x, y.
#[utoipa::path(get, path = "/api/measurements/{id}/spectrum.mat", tag = "measurements",
    params(("id" = i64, Path)), responses((status = 200, content_type = "application/x-matlab-data")))]
pub async fn measurement_mat(State(state): State<AppState>, Path(id): Path<i64>) -> Result<Response, ApiError> {
    let m = load_measurement(&state, id).await?;
    let wl = sample_grid(&m)?;
    let mut mat = MatFile::new();
    let internal = |e: String| ApiError::Internal(e);
    mat.column("wavelength_nm", &wl).map_err(internal)?;
    if let (Some(mean), Some(sd)) = (&m.radiance, &m.radiance_sd) {
        mat.column("radiance", mean).map_err(internal)?;
        mat.column("radiance_sd", sd).map_err(internal)?;
    }
    let mut samples = Vec::with_capacity(wl.len() * m.samples.len());
    for s in &m.samples {
        match &s.radiance {
            Some(r) => samples.extend_from_slice(r),
            None => samples.extend(std::iter::repeat_n(f64::NAN, wl.len())),
        }
    }
    mat.matrix("samples", wl.len(), m.samples.len(), &samples)
        .map_err(internal)?;
    let codes: Vec<f64> = m.samples.iter().map(|s| s.code as f64).collect();
    let usable: Vec<f64> = m.samples.iter().map(|s| if s.usable { 1.0 } else { 0.0 }).collect();
    mat.matrix("sample_code", 1, codes.len(), &codes).map_err(internal)?;
    mat.matrix("sample_usable", 1, usable.len(), &usable)
        .map_err(internal)?;
    for (name, v) in [("Y", m.summary.luminance_cd_m2), ("x", m.summary.x), ("y", m.summary.y)] {
        mat.scalar(name, v.unwrap_or(f64::NAN)).map_err(internal)?;
    }
    mat.text("state", m.summary.state.as_str()).map_err(internal)?;
    Ok(download(
        "application/x-matlab-data",
        &format!("measurement_{id}.mat"),
        mat.into_bytes(),
    ))
}

#[utoipa::path(get, path = "/api/measurements/{id}/spectrum.svg", tag = "measurements",
    params(("id" = i64, Path)), responses((status = 200, content_type = "image/svg+xml")))]
pub async fn measurement_svg(State(state): State<AppState>, Path(id): Path<i64>) -> Result<Response, ApiError> {
    let m = load_measurement(&state, id).await?;
    let wl = sample_grid(&m).unwrap_or_default();
    let samples: Vec<Vec<f64>> = m.samples.iter().filter_map(|s| s.radiance.clone()).collect();
    let title = match (&m.summary.scene, &m.summary.target) {
        (Some(s), Some(t)) => format!("measurement {id}: {s} / {t}"),
        _ => format!("measurement {id}"),
    };
    let svg = charts::spectrum_chart(&title, &wl, m.radiance.as_deref(), m.radiance_sd.as_deref(), &samples)
        .map_err(ApiError::Internal)?;
    Ok(([(header::CONTENT_TYPE, "image/svg+xml")], svg).into_response())
}

/// The grid of a measurement: stored with the average, or the PR-650's for
/// a measurement that never completed.
fn sample_grid(m: &MeasurementDetail) -> Result<Vec<f64>, ApiError> {
    if let Some(wl) = &m.wavelength_nm {
        return Ok(wl.clone());
    }
    let n = m.samples.iter().find_map(|s| s.radiance.as_ref().map(Vec::len));
    match n {
        Some(101) | None => Ok(crate::spectrum::Grid::pr650().wavelengths().to_vec()),
        Some(other) => Err(ApiError::Internal(format!(
            "measurement {} has {other}-point samples and no grid",
            m.summary.id
        ))),
    }
}

fn download(content_type: &'static str, filename: &str, body: Vec<u8>) -> Response {
    (
        [
            (header::CONTENT_TYPE, content_type.to_string()),
            (
                header::CONTENT_DISPOSITION,
                format!("attachment; filename=\"{filename}\""),
            ),
        ],
        body,
    )
        .into_response()
}

#[utoipa::path(get, path = "/api/measurements/{id}/comparisons", tag = "comparisons",
    params(("id" = i64, Path)), responses((status = 200, body = Vec<ComparisonRow>)))]
pub async fn measurement_comparisons(
    State(state): State<AppState>,
    Path(id): Path<i64>,
) -> Result<Json<Vec<ComparisonRow>>, ApiError> {
    load_measurement(&state, id).await?;
    Ok(Json(state.store.comparisons_for_measurement(id).await?))
}

// --- scenes and renders ----------------------------------------------------

fn scenes(state: &AppState) -> Result<Vec<SceneInfo>, ApiError> {
    Ok(state
        .renders
        .as_ref()
        .ok_or_else(|| ApiError::Unavailable("this daemon runs without the renderer".into()))?
        .scenes())
}

fn find_scene(state: &AppState, id: &str) -> Result<SceneInfo, ApiError> {
    let all = scenes(state)?;
    all.iter().find(|s| s.id == id).cloned().ok_or_else(|| {
        let names: Vec<&str> = all.iter().map(|s| s.id.as_str()).collect();
        ApiError::NotFound(format!("no scene `{id}`; available: {}", names.join(", ")))
    })
}

#[utoipa::path(get, path = "/api/scenes", tag = "scenes", responses((status = 200, body = Vec<SceneInfo>)))]
pub async fn list_scenes(State(state): State<AppState>) -> Result<Json<Vec<SceneInfo>>, ApiError> {
    Ok(Json(scenes(&state)?))
}

#[utoipa::path(get, path = "/api/scenes/{scene}", tag = "scenes", params(("scene" = String, Path)),
    responses((status = 200, body = SceneInfo), (status = 404, body = super::error::ErrorBody)))]
pub async fn get_scene(State(state): State<AppState>, Path(scene): Path<String>) -> Result<Json<SceneInfo>, ApiError> {
    Ok(Json(find_scene(&state, &scene)?))
}

#[utoipa::path(get, path = "/api/scenes/{scene}/targets", tag = "scenes", params(("scene" = String, Path)),
    responses((status = 200, body = Vec<String>)))]
pub async fn scene_targets(
    State(state): State<AppState>,
    Path(scene): Path<String>,
) -> Result<Json<Vec<String>>, ApiError> {
    Ok(Json(find_scene(&state, &scene)?.targets))
}

#[utoipa::path(get, path = "/api/scenes/{scene}/renders", tag = "renders", params(("scene" = String, Path)),
    responses((status = 200, body = Vec<RenderRow>)))]
pub async fn scene_renders(
    State(state): State<AppState>,
    Path(scene): Path<String>,
) -> Result<Json<Vec<RenderRow>>, ApiError> {
    find_scene(&state, &scene)?;
    Ok(Json(state.store.list_renders(Some(&scene)).await?))
}

#[derive(Serialize, ToSchema)]
pub struct RenderAccepted {
    pub render_id: i64,
    pub url: String,
}

#[utoipa::path(post, path = "/api/scenes/{scene}/renders", tag = "renders", params(("scene" = String, Path)),
    request_body = RenderRequest,
    responses((status = 202, body = RenderAccepted), (status = 404, body = super::error::ErrorBody)),
    security(("bearer" = [])))]
pub async fn start_render(
    State(state): State<AppState>,
    Path(scene): Path<String>,
    Input(body): Input<RenderRequest>,
) -> Result<(StatusCode, Json<RenderAccepted>), ApiError> {
    find_scene(&state, &scene)?;
    let service = state
        .renders
        .as_ref()
        .ok_or_else(|| ApiError::Unavailable("no renderer".into()))?;
    let render_id = Arc::clone(service).start_render(scene, body).await?;
    Ok((
        StatusCode::ACCEPTED,
        Json(RenderAccepted {
            render_id,
            url: format!("/api/renders/{render_id}"),
        }),
    ))
}

#[utoipa::path(get, path = "/api/renders/{id}", tag = "renders", params(("id" = i64, Path)),
    responses((status = 200, body = RenderRow), (status = 404, body = super::error::ErrorBody)))]
pub async fn get_render(State(state): State<AppState>, Path(id): Path<i64>) -> Result<Json<RenderRow>, ApiError> {
    state
        .store
        .get_render(id)
        .await?
        .map(Json)
        .ok_or_else(|| ApiError::NotFound(format!("no render {id}")))
}

/// The scene's camera view of a render (tone-mapped sRGB), once the render is complete.
#[utoipa::path(get, path = "/api/renders/{id}/preview.png", tag = "renders", params(("id" = i64, Path)),
    responses((status = 200, content_type = "image/png"), (status = 404, body = super::error::ErrorBody)))]
pub async fn render_preview(State(state): State<AppState>, Path(id): Path<i64>) -> Result<Response, ApiError> {
    let png = state.store.render_preview(id).await?.ok_or_else(|| {
        ApiError::NotFound(format!(
            "render {id} has no preview (not finished, or no [camera] in its scene)"
        ))
    })?;
    Ok(([(header::CONTENT_TYPE, "image/png")], png).into_response())
}

// --- comparisons -----------------------------------------------------------

/// A coding's figures of merit over a scene's targets.
#[allow(non_snake_case)]
#[derive(Serialize, ToSchema)]
pub struct CodingSummary {
    pub coding: String,
    #[serde(flatten)]
    #[schema(inline)]
    pub summary: SceneSummaryDto,
    /// Mean Y ratio rendered/measured.
    pub mean_Y_ratio: f64,
}

/// [`SceneSummary`] as the API gives it (MATLAB-friendly field names).
#[allow(non_snake_case)]
#[derive(Serialize, ToSchema)]
pub struct SceneSummaryDto {
    pub points: usize,
    pub rms_rel: f64,
    pub mean_dE76: f64,
    pub sd_dE76: Option<f64>,
    pub mean_dE00: f64,
    pub sd_dE00: Option<f64>,
}

impl From<SceneSummary> for SceneSummaryDto {
    fn from(s: SceneSummary) -> Self {
        SceneSummaryDto {
            points: s.points,
            rms_rel: s.rms_rel,
            mean_dE76: s.mean_de76,
            sd_dE76: s.sd_de76,
            mean_dE00: s.mean_de00,
            sd_dE00: s.sd_de00,
        }
    }
}

#[derive(Serialize, ToSchema)]
pub struct SceneComparison {
    pub scene: String,
    /// One row per coding: rms_rel and mean ± SD of ΔE over the scene's targets.
    pub codings: Vec<CodingSummary>,
    /// The newest comparison of every (target, coding).
    pub rows: Vec<ComparisonRow>,
}

async fn scene_comparison(state: &AppState, scene: &str) -> Result<SceneComparison, ApiError> {
    find_scene(state, scene)?;
    let rows = state.store.latest_comparisons(scene).await?;
    let mut codings: Vec<String> = rows.iter().map(|r| r.coding.clone()).collect();
    codings.sort_by_key(|c| coding_order(c));
    codings.dedup();
    let summaries = codings
        .into_iter()
        .map(|coding| {
            let points: Vec<crate::comparison::PointDifference> = rows
                .iter()
                .filter(|r| r.coding == coding)
                .map(|r| crate::comparison::PointDifference {
                    measured: crate::colorimetry::Xyz::new(r.measured_X, r.measured_Y, r.measured_Z),
                    rendered: crate::colorimetry::Xyz::new(r.rendered_X, r.rendered_Y, r.rendered_Z),
                    y_ratio: r.Y_ratio,
                    xy_distance: r.xy_distance,
                    de76: r.dE76,
                    de00: r.dE00,
                })
                .collect();
            let (mean_ratio, _) = mean_sd(points.iter().map(|p| p.y_ratio));
            CodingSummary {
                coding,
                summary: crate::comparison::summarize(&points).into(),
                mean_Y_ratio: mean_ratio,
            }
        })
        .collect();
    Ok(SceneComparison {
        scene: scene.to_string(),
        codings: summaries,
        rows,
    })
}

/// Sorts codings as the study lists them: rgb, srgb, nstepN by N, spectral.
pub fn coding_order(c: &str) -> (u32, u32) {
    match c {
        "rgb" => (0, 0),
        "srgb" => (1, 0),
        "spectral" => (3, 0),
        other => (
            2,
            other
                .strip_prefix("nstep")
                .and_then(|n| n.parse().ok())
                .unwrap_or(u32::MAX),
        ),
    }
}

#[utoipa::path(get, path = "/api/scenes/{scene}/comparisons", tag = "comparisons", params(("scene" = String, Path)),
    responses((status = 200, body = SceneComparison), (status = 404, body = super::error::ErrorBody)))]
pub async fn scene_comparisons(
    State(state): State<AppState>,
    Path(scene): Path<String>,
) -> Result<Json<SceneComparison>, ApiError> {
    Ok(Json(scene_comparison(&state, &scene).await?))
}

#[utoipa::path(get, path = "/api/scenes/{scene}/comparisons.csv", tag = "comparisons", params(("scene" = String, Path)),
    responses((status = 200, content_type = "text/csv")))]
pub async fn scene_comparisons_csv(
    State(state): State<AppState>,
    Path(scene): Path<String>,
) -> Result<Response, ApiError> {
    let c = scene_comparison(&state, &scene).await?;
    let mut w = csv::Writer::from_writer(Vec::new());
    for row in &c.rows {
        w.serialize(row).map_err(|e| ApiError::Internal(e.to_string()))?;
    }
    let bytes = w.into_inner().map_err(|e| ApiError::Internal(e.to_string()))?;
    Ok(download("text/csv", &format!("comparisons_{scene}.csv"), bytes))
}

/// `load('comparisons_cylinder.mat')`: one column vector per numeric field
/// and char matrices `target` and `coding` (one row each), so
/// `table(cellstr(target), cellstr(coding), dE00, ...)` rebuilds the table.
#[utoipa::path(get, path = "/api/scenes/{scene}/comparisons.mat", tag = "comparisons", params(("scene" = String, Path)),
    responses((status = 200, content_type = "application/x-matlab-data")))]
pub async fn scene_comparisons_mat(
    State(state): State<AppState>,
    Path(scene): Path<String>,
) -> Result<Response, ApiError> {
    let c = scene_comparison(&state, &scene).await?;
    let mut mat = MatFile::new();
    let internal = |e: String| ApiError::Internal(e);
    let col = |f: fn(&ComparisonRow) -> f64| c.rows.iter().map(f).collect::<Vec<f64>>();
    mat.text_rows("target", &c.rows.iter().map(|r| r.target.clone()).collect::<Vec<_>>())
        .map_err(internal)?;
    mat.text_rows("coding", &c.rows.iter().map(|r| r.coding.clone()).collect::<Vec<_>>())
        .map_err(internal)?;
    type Field = (&'static str, fn(&ComparisonRow) -> f64);
    let fields: [Field; 14] = [
        ("measurement_id", |r| r.measurement_id as f64),
        ("render_id", |r| r.render_id as f64),
        ("measured_X", |r| r.measured_X),
        ("measured_Y", |r| r.measured_Y),
        ("measured_Z", |r| r.measured_Z),
        ("rendered_X", |r| r.rendered_X),
        ("rendered_Y", |r| r.rendered_Y),
        ("rendered_Z", |r| r.rendered_Z),
        ("rendered_Y_se", |r| r.rendered_Y_se),
        ("Y_ratio", |r| r.Y_ratio),
        ("xy_distance", |r| r.xy_distance),
        ("dE76", |r| r.dE76),
        ("dE00", |r| r.dE00),
        ("white_Y", |r| r.white_Y),
    ];
    for (name, f) in fields {
        mat.column(name, &col(f)).map_err(internal)?;
    }
    Ok(download(
        "application/x-matlab-data",
        &format!("comparisons_{scene}.mat"),
        mat.into_bytes(),
    ))
}

/// The study's figures for a scene: `chromaticity.svg`, `profile.svg`
/// (luminance along the targets), `errors.svg` (rms_rel and mean ΔE per
/// coding with ±1 SD), `speed.svg` (render time against ΔE per coding).
#[utoipa::path(get, path = "/api/scenes/{scene}/charts/{chart}", tag = "comparisons",
    params(("scene" = String, Path), ("chart" = String, Path, description = "chromaticity.svg, profile.svg, rms.svg, de.svg or speed.svg")),
    responses((status = 200, content_type = "image/svg+xml"), (status = 404, body = super::error::ErrorBody)))]
pub async fn scene_chart(
    State(state): State<AppState>,
    Path((scene, chart)): Path<(String, String)>,
) -> Result<Response, ApiError> {
    let c = scene_comparison(&state, &scene).await?;
    let info = find_scene(&state, &scene)?;
    if c.rows.is_empty() {
        return Err(ApiError::NotFound(format!(
            "scene `{scene}` has no comparisons yet: measure its targets first"
        )));
    }
    let svg = match chart.as_str() {
        "chromaticity.svg" => super::scene_charts::chromaticity(&c, &info),
        "profile.svg" => super::scene_charts::profile(&c, &info),
        "rms.svg" => super::scene_charts::rms(&c),
        "de.svg" => super::scene_charts::delta_e(&c),
        "speed.svg" => super::scene_charts::speed(&state, &c).await,
        other => {
            return Err(ApiError::NotFound(format!(
                "no chart `{other}`: choose chromaticity.svg, profile.svg, rms.svg, de.svg or speed.svg"
            )))
        }
    }
    .map_err(ApiError::Internal)?;
    Ok(([(header::CONTENT_TYPE, "image/svg+xml")], svg).into_response())
}

// --- the simulated instrument ----------------------------------------------

#[derive(Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct MockFaults {
    /// `KIND[:RATE]`, comma-separated, e.g. `cable-pull:once`; empty clears all faults.
    pub faults: String,
}

/// Injects faults into the simulated PR-650 (only when the daemon runs with `--mock`).
#[utoipa::path(post, path = "/api/mock/faults", tag = "instruments", request_body = MockFaults,
    responses((status = 204), (status = 400, body = super::error::ErrorBody), (status = 404, body = super::error::ErrorBody)),
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

// --- studies ---------------------------------------------------------------

#[utoipa::path(get, path = "/api/studies", tag = "studies", responses((status = 200, body = Vec<StudyRow>)))]
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
#[utoipa::path(post, path = "/api/studies", tag = "studies", request_body = StudyRequest,
    responses((status = 202, body = StudyAccepted), (status = 400, body = super::error::ErrorBody)),
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

#[utoipa::path(get, path = "/api/studies/{id}", tag = "studies", params(("id" = i64, Path)),
    responses((status = 200, body = StudyRow), (status = 404, body = super::error::ErrorBody)))]
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
#[utoipa::path(get, path = "/api/studies/{id}/files/{name}", tag = "studies",
    params(("id" = i64, Path), ("name" = String, Path)),
    responses((status = 200, description = "the file"), (status = 404, body = super::error::ErrorBody)))]
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
