//! `/api/measurements`: start a measurement, list and fetch them, their spectra
//! as CSV/MAT/SVG, and their comparisons with the renderings.

use axum::extract::State;
use axum::http::{header, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::Json;
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use crate::http::error::ApiError;
use crate::http::input::{check_paging, Input, Path, Query};
use crate::http::kept;
use crate::http::AppState;
use crate::lab::measure::booth_instrument::{Cancelled, MeasurementRequest, Requested};
use crate::lab::FileFormat;
use crate::store::{
    ComparisonRow, LuminanceComparisonRow, MeasurementDetail, MeasurementFilter, MeasurementPage, MeasurementState,
    MeasurementSummary,
};

#[derive(Deserialize, ToSchema, Default)]
#[serde(deny_unknown_fields)]
pub struct StartMeasurement {
    /// Scene id (see `/api/scenes`); the daemon renders and compares when given with `target`.
    pub scene: Option<String>,
    pub target: Option<String>,
    /// Samples to average: at least 1, at most what the daemon's instrument model allows
    /// (its capabilities; the PR-650's driver: 99); default: the daemon's, 5 unless configured.
    #[schema(minimum = 1)]
    pub samples: Option<usize>,
    pub session_id: Option<i64>,
    /// Free text kept with the measurement and shown in the table (`notes` is accepted too).
    #[serde(alias = "notes")]
    pub note: Option<String>,
    /// The instrument hold this measurement belongs to (`POST
    /// /api/instrument/hold`): while the instrument is held, only
    /// measurements naming the hold are taken; others answer 409.
    pub hold: Option<i64>,
    /// `true`: queue it even if the same measurement (this booth, scene,
    /// target, samples, note, session and hold) is already queued or running —
    /// repeated measurements of one target, on purpose. Default `false`:
    /// such a request is answered with the one on its way (`duplicate`).
    #[serde(default)]
    pub repeat: bool,
}

#[derive(Serialize, ToSchema)]
pub struct Accepted {
    pub id: i64,
    pub state: MeasurementState,
    /// Poll this URL (or follow `/api/events`) until `state` is final.
    pub url: String,
    /// True (status 200) when nothing new was queued: the same measurement
    /// (this booth, scene, target, samples, note, session and hold) was already
    /// queued or running, and `id` is that one.
    pub duplicate: bool,
    /// Says so in words when `duplicate`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub message: Option<String>,
}

/// Queues a measurement (202). A request for a scene target whose
/// measurement with the same samples, note, session and hold is already queued
/// or running in this booth queues nothing: it answers 200 with that
/// measurement and `"duplicate": true` (a double click, or a retry whose
/// answer was lost, then waits for the one measurement it asked for).
#[utoipa::path(post, path = "/measurements", tag = "measurements", request_body = Option<StartMeasurement>,
    responses((status = 202, body = Accepted, description = "queued"),
              (status = 200, body = Accepted, description = "the same measurement is already queued or running: that one, nothing queued"),
              (status = 400, body = crate::http::error::ErrorBody),
              (status = 401, body = crate::http::error::ErrorBody), (status = 409, body = crate::http::error::ErrorBody),
              (status = 503, body = crate::http::error::ErrorBody)),
    security(("bearer" = [])))]
pub async fn start_measurement(
    State(state): State<AppState>,
    Input(body): Input<StartMeasurement>,
) -> Result<(StatusCode, Json<Accepted>), ApiError> {
    let request = MeasurementRequest {
        scene: body.scene,
        target: body.target,
        samples: body.samples,
        session_id: body.session_id,
        note: body.note.unwrap_or_default(),
        hold: body.hold,
        repeat: body.repeat,
    };
    match state
        .lab
        .instrument()
        .request(request, &state.lab.scenes_if_any())
        .await?
    {
        Requested::Queued(id) => Ok((
            StatusCode::ACCEPTED,
            Json(Accepted {
                id,
                state: MeasurementState::Queued,
                url: format!("/api/measurements/{id}"),
                duplicate: false,
                message: None,
            }),
        )),
        Requested::AlreadyOnItsWay(m) => Ok((
            StatusCode::OK,
            Json(Accepted {
                id: m.id,
                state: m.state,
                url: format!("/api/measurements/{}", m.id),
                duplicate: true,
                message: Some(format!(
                    "measurement {} of {}/{} with {} samples is already {}; nothing new was queued",
                    m.id,
                    m.scene.as_deref().unwrap_or_default(),
                    m.target.as_deref().unwrap_or_default(),
                    m.samples_requested,
                    m.state.as_str()
                )),
            }),
        )),
    }
}

#[utoipa::path(get, path = "/measurements", tag = "measurements", params(MeasurementFilter),
    responses((status = 200, body = MeasurementPage)))]
pub async fn list_measurements(
    State(state): State<AppState>,
    Query(filter): Query<MeasurementFilter>,
) -> Result<Json<MeasurementPage>, ApiError> {
    check_paging(filter.limit, filter.offset)?;
    Ok(Json(state.lab.measurements(&filter).await?))
}

/// Cancels a queued or running measurement. A queued one never starts; a
/// running one stops at once (between instrument commands, or while a reply
/// is read), keeping every sample already taken; its `error` says how many,
/// and the average of its good samples is listed as `partial`. Answers 200
/// with the cancelled measurement, or 202 while it is still stopping
/// (follow `/api/events`: `measurement_finished` with state `cancelled`).
#[utoipa::path(post, path = "/measurements/{id}/cancel", tag = "measurements",
    params(("id" = i64, Path, description = "measurement id")),
    responses((status = 200, body = MeasurementSummary, description = "cancelled"),
              (status = 202, body = MeasurementSummary, description = "stopping"),
              (status = 401, body = crate::http::error::ErrorBody),
              (status = 404, body = crate::http::error::ErrorBody),
              (status = 409, body = crate::http::error::ErrorBody, description = "already finished")),
    security(("bearer" = [])))]
pub async fn cancel_measurement(
    State(state): State<AppState>,
    Path(id): Path<i64>,
) -> Result<(StatusCode, Json<MeasurementSummary>), ApiError> {
    match state.lab.instrument().cancel(id).await? {
        Cancelled::Done(m) => Ok((StatusCode::OK, Json(m))),
        Cancelled::Stopping(m) => Ok((StatusCode::ACCEPTED, Json(m))),
    }
}

pub(super) async fn load_measurement(state: &AppState, id: i64) -> Result<MeasurementDetail, ApiError> {
    Ok(state.lab.measurement(id).await?)
}

#[utoipa::path(get, path = "/measurements/{id}", tag = "measurements",
    params(("id" = i64, Path, description = "measurement id")),
    responses((status = 200, body = MeasurementDetail), (status = 404, body = crate::http::error::ErrorBody)))]
pub async fn get_measurement(
    State(state): State<AppState>,
    Path(id): Path<i64>,
) -> Result<Json<MeasurementDetail>, ApiError> {
    Ok(Json(load_measurement(&state, id).await?))
}

/// The observer a measurement's colorimetry is recomputed in.
#[derive(Deserialize, utoipa::IntoParams)]
#[into_params(parameter_in = Query)]
#[serde(deny_unknown_fields)]
pub struct ObserverQuery {
    /// `judd-vos-1978`, `cie-1931`, `cie-1964-10`, `cie-2015-2` or
    /// `cie-2015-10` (default: the daemon's `--observer`).
    #[param(
        value_type = Option<String>,
        nullable = false,
        pattern = "^(judd-vos-1978|cie-1931|cie-1964-10|cie-2015-2|cie-2015-10)$"
    )]
    pub observer: Option<crate::colorimetry::Observer>,
}

/// A measurement's XYZ and x, y in any observer, recomputed from its stored
/// mean spectrum. A colorimeter's XYZ stays in the observer it was made in:
/// asking for another is refused (409), as is a luminance meter's
/// measurement (it has no colour).
#[utoipa::path(get, path = "/measurements/{id}/colorimetry", tag = "measurements",
    params(("id" = i64, Path), ObserverQuery),
    responses((status = 200, body = crate::lab::MeasuredColorimetry),
        (status = 400, description = "an observer lightbooth does not know", body = crate::http::error::ErrorBody),
        (status = 404, body = crate::http::error::ErrorBody), (status = 409, body = crate::http::error::ErrorBody)))]
pub async fn measurement_colorimetry(
    State(state): State<AppState>,
    Path(id): Path<i64>,
    Query(q): Query<ObserverQuery>,
) -> Result<Json<crate::lab::MeasuredColorimetry>, ApiError> {
    let observer = q.observer.unwrap_or(state.lab.observer());
    Ok(Json(state.lab.measurement_colorimetry(id, observer).await?))
}

/// Wavelength, the mean and its SD, and every sample with a spectrum as
/// columns (`nm,radiance,radiance_sd,sample_0,…`; values as the instrument
/// gave them, per nm), the file `lightbooth measure --csv` prints.
/// A colorimeter's or a luminance meter's measurement has no spectrum: 409.
#[utoipa::path(get, path = "/measurements/{id}/spectrum.csv", tag = "measurements",
    params(("id" = i64, Path)), responses((status = 200, content_type = "text/csv"),
        (status = 409, body = crate::http::error::ErrorBody, description = "the instrument gives no spectrum (XYZ or luminance only)")))]
pub async fn measurement_csv(State(state): State<AppState>, Path(id): Path<i64>) -> Result<Response, ApiError> {
    Ok(kept::download(state.lab.measurement_file(id, FileFormat::Csv).await?))
}

/// `load('measurement_7.mat')` gives wavelength_nm, radiance, radiance_sd,
/// samples (one column per sample; NaN where a sample had no valid
/// spectrum), sample_code, sample_usable, Y, x, y (with `observer`), and
/// the instrument's own CIE 1931 instrument_Y, instrument_x, instrument_y.
/// A colorimeter's or a luminance meter's measurement has no spectrum: 409,
/// as the CSV and the chart (never a grid and NaN it did not measure).
#[utoipa::path(get, path = "/measurements/{id}/spectrum.mat", tag = "measurements",
    params(("id" = i64, Path)), responses((status = 200, content_type = "application/x-matlab-data"),
        (status = 409, body = crate::http::error::ErrorBody, description = "the instrument gives no spectrum (XYZ or luminance only)")))]
pub async fn measurement_mat(State(state): State<AppState>, Path(id): Path<i64>) -> Result<Response, ApiError> {
    Ok(kept::download(state.lab.measurement_file(id, FileFormat::Mat).await?))
}

#[utoipa::path(get, path = "/measurements/{id}/spectrum.svg", tag = "measurements",
    params(("id" = i64, Path)), responses((status = 200, content_type = "image/svg+xml")))]
pub async fn measurement_svg(State(state): State<AppState>, Path(id): Path<i64>) -> Result<Response, ApiError> {
    Ok((
        [(header::CONTENT_TYPE, "image/svg+xml")],
        state.lab.measurement_chart(id).await?,
    )
        .into_response())
}

#[utoipa::path(get, path = "/measurements/{id}/comparisons", tag = "comparisons",
    params(("id" = i64, Path)), responses((status = 200, body = Vec<ComparisonRow>)))]
pub async fn measurement_comparisons(
    State(state): State<AppState>,
    Path(id): Path<i64>,
) -> Result<Json<Vec<ComparisonRow>>, ApiError> {
    Ok(Json(state.lab.comparisons_of_measurement(id).await?))
}

/// A luminance meter's measurement compared with every coding in luminance
/// alone (it gives no colour): empty for any other measurement, whose
/// comparisons are at `/measurements/{id}/comparisons`.
#[utoipa::path(get, path = "/measurements/{id}/luminance-comparisons", tag = "comparisons",
    params(("id" = i64, Path)), responses((status = 200, body = Vec<LuminanceComparisonRow>)))]
pub async fn measurement_luminance_comparisons(
    State(state): State<AppState>,
    Path(id): Path<i64>,
) -> Result<Json<Vec<LuminanceComparisonRow>>, ApiError> {
    Ok(Json(state.lab.luminance_comparisons_of_measurement(id).await?))
}
