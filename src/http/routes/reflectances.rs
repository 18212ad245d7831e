//! `/api/reflectances`: a material's reflectance from a sample measurement
//! and a white-standard measurement of the same geometry (see
//! [`crate::calibration::reflectance`]), stored with its provenance and
//! exported as a scene spectrum CSV.

use axum::extract::State;
use axum::http::StatusCode;
use axum::response::Response;
use axum::Json;
use serde::Deserialize;
use utoipa::ToSchema;

use crate::calibration::reflectance::OutOfRange;
use crate::calibration::standard::{WhiteStandard, SHIPPED};
use crate::http::error::{ApiError, ErrorBody};
use crate::http::input::{Input, Path, Query};
use crate::http::kept;
use crate::http::AppState;
use crate::lab::{Download, FileFormat};
use crate::store::ReflectanceRow;

#[derive(Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct NewReflectance {
    /// The sample's complete measurement.
    pub sample_measurement_id: i64,
    /// The white standard's complete measurement, in the sample's place.
    pub standard_measurement_id: i64,
    /// A standard shipped with lightbooth (`spectralon_99`), or give `standard_csv`.
    pub standard: Option<String>,
    /// The standard's calibrated reflectance as CSV text (`nm,reflectance[,uncertainty]`).
    pub standard_csv: Option<String>,
    /// The calibration file's name, kept as provenance with `standard_csv` (default `standard.csv`).
    pub standard_file: Option<String>,
    /// The scene CSV's column name (default `sample_<id>`).
    pub name: Option<String>,
    #[serde(default)]
    pub note: String,
}

/// The white standard a request names: a shipped one, or its CSV text.
pub(super) fn requested_standard(
    name: Option<&str>,
    csv: Option<&str>,
    file: Option<&str>,
) -> Result<WhiteStandard, ApiError> {
    match (name, csv) {
        (Some(n), None) => WhiteStandard::shipped(n).ok_or_else(|| {
            let names: Vec<&str> = SHIPPED.iter().map(|s| s.0).collect();
            ApiError::BadRequest(format!(
                "field `standard`: no shipped standard `{n}`; shipped: {} (or give `standard_csv`)",
                names.join(", ")
            ))
        }),
        (None, Some(text)) => {
            let file = file.unwrap_or("standard.csv");
            if file.is_empty() || file.len() > 128 || file.contains(['/', '\\']) || file.chars().any(char::is_control) {
                return Err(ApiError::BadRequest(format!(
                    "field `standard_file`: `{file}` is not a plain file name (no directories, at most 128 characters)"
                )));
            }
            WhiteStandard::parse(text, file).map_err(|e| ApiError::BadRequest(format!("field `standard_csv`: {e}")))
        }
        _ => Err(ApiError::BadRequest(
            "field `standard`: give exactly one of `standard` (a shipped standard, e.g. `spectralon_99`) \
             and `standard_csv` (its calibration as CSV text)"
                .into(),
        )),
    }
}

#[utoipa::path(post, path = "/reflectances", tag = "reflectances", request_body = NewReflectance,
    responses((status = 201, body = ReflectanceRow), (status = 400, body = ErrorBody),
              (status = 401, body = ErrorBody), (status = 409, body = ErrorBody)),
    security(("bearer" = [])))]
pub async fn create_reflectance_route(
    State(state): State<AppState>,
    Input(body): Input<NewReflectance>,
) -> Result<(StatusCode, Json<ReflectanceRow>), ApiError> {
    if body.standard_file.is_some() && body.standard_csv.is_none() {
        return Err(ApiError::BadRequest(
            "field `standard_file`: names the file of `standard_csv`, which is missing".into(),
        ));
    }
    let standard = requested_standard(
        body.standard.as_deref(),
        body.standard_csv.as_deref(),
        body.standard_file.as_deref(),
    )?;
    let name = body
        .name
        .unwrap_or_else(|| format!("sample_{}", body.sample_measurement_id));
    let row = state
        .lab
        .create_reflectance(
            body.sample_measurement_id,
            body.standard_measurement_id,
            &standard,
            &name,
            &body.note,
        )
        .await?;
    Ok((StatusCode::CREATED, Json(row)))
}

#[utoipa::path(get, path = "/reflectances", tag = "reflectances",
    responses((status = 200, body = Vec<ReflectanceRow>)))]
pub async fn list_reflectances(State(state): State<AppState>) -> Result<Json<Vec<ReflectanceRow>>, ApiError> {
    Ok(Json(state.lab.reflectances().await?))
}

async fn load(state: &AppState, id: i64) -> Result<ReflectanceRow, ApiError> {
    Ok(state.lab.reflectance(id).await?)
}

#[utoipa::path(get, path = "/reflectances/{id}", tag = "reflectances", params(("id" = i64, Path)),
    responses((status = 200, body = ReflectanceRow), (status = 404, body = ErrorBody)))]
pub async fn get_reflectance(
    State(state): State<AppState>,
    Path(id): Path<i64>,
) -> Result<Json<ReflectanceRow>, ApiError> {
    Ok(Json(load(&state, id).await?))
}

#[derive(Deserialize, ToSchema, utoipa::IntoParams, Default)]
#[into_params(parameter_in = Query)]
#[serde(deny_unknown_fields)]
pub struct CsvOptions {
    /// Clip values outside [0, 1] for the scene, saying so in the header;
    /// without it a flagged reflectance is refused (409).
    #[serde(default)]
    pub clip: bool,
}

/// The scene spectrum CSV (`spectra/NAME.csv`): `#` provenance lines, then
/// `nm,NAME,NAME_u`.
#[utoipa::path(get, path = "/reflectances/{id}/csv", tag = "reflectances", params(("id" = i64, Path), CsvOptions),
    responses((status = 200, content_type = "text/csv"), (status = 404, body = ErrorBody), (status = 409, body = ErrorBody)))]
pub async fn reflectance_csv(
    State(state): State<AppState>,
    Path(id): Path<i64>,
    Query(options): Query<CsvOptions>,
) -> Result<Response, ApiError> {
    let row = load(&state, id).await?;
    let rule = if options.clip {
        OutOfRange::ClipAndSay
    } else {
        OutOfRange::Refuse
    };
    let text = state.lab.reflectance_csv(&row, rule).await?;
    Ok(kept::download(Download::new(
        FileFormat::Csv,
        &row.name,
        text.into_bytes(),
    )))
}

/// ρ(λ) with its ±1 u and ±2 u bands; values outside [0, 1] marked.
#[utoipa::path(get, path = "/reflectances/{id}/chart.svg", tag = "reflectances", params(("id" = i64, Path)),
    responses((status = 200, content_type = "image/svg+xml"), (status = 404, body = ErrorBody)))]
pub async fn reflectance_svg(State(state): State<AppState>, Path(id): Path<i64>) -> Result<Response, ApiError> {
    use axum::response::IntoResponse;
    let row = load(&state, id).await?;
    let title = format!(
        "reflectance {id} `{}`: measurement {} against {}",
        row.name, row.sample_measurement_id, row.standard_measurement_id
    );
    let svg = crate::charts::reflectance_chart(&title, &row.wavelength_nm, &row.reflectance, &row.uncertainty)
        .map_err(ApiError::Internal)?;
    Ok(([(axum::http::header::CONTENT_TYPE, "image/svg+xml")], svg).into_response())
}
