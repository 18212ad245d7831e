//! `/api/illuminants`: the lamp's relative spectral power distribution from
//! one measurement of the white standard (see
//! [`crate::calibration::illuminant`]), stored with its provenance and
//! exported as a scene spectrum CSV for a light's `spd`.

use axum::extract::State;
use axum::http::StatusCode;
use axum::response::Response;
use axum::Json;
use serde::Deserialize;
use utoipa::ToSchema;

use super::reflectances::requested_standard;
use crate::http::error::{ApiError, ErrorBody};
use crate::http::input::{Input, Path};
use crate::http::kept;
use crate::http::AppState;
use crate::lab::{Download, FileFormat};
use crate::store::IlluminantRow;

#[derive(Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct NewIlluminant {
    /// The white standard's complete measurement.
    pub measurement_id: i64,
    /// A standard shipped with lightbooth (`spectralon_99`), or give `standard_csv`.
    pub standard: Option<String>,
    /// The standard's calibrated reflectance as CSV text.
    pub standard_csv: Option<String>,
    /// The calibration file's name, kept with `standard_csv` (default `standard.csv`).
    pub standard_file: Option<String>,
    /// The scene CSV's column name (default `lamp_<id>`).
    pub name: Option<String>,
    #[serde(default)]
    pub note: String,
}

#[utoipa::path(post, path = "/illuminants", tag = "illuminants", request_body = NewIlluminant,
    responses((status = 201, body = IlluminantRow), (status = 400, body = ErrorBody),
              (status = 401, body = ErrorBody), (status = 409, body = ErrorBody)),
    security(("bearer" = [])))]
pub async fn create_illuminant_route(
    State(state): State<AppState>,
    Input(body): Input<NewIlluminant>,
) -> Result<(StatusCode, Json<IlluminantRow>), ApiError> {
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
    let name = body.name.unwrap_or_else(|| format!("lamp_{}", body.measurement_id));
    let row = state
        .lab
        .create_illuminant(body.measurement_id, &standard, &name, &body.note)
        .await?;
    Ok((StatusCode::CREATED, Json(row)))
}

#[utoipa::path(get, path = "/illuminants", tag = "illuminants",
    responses((status = 200, body = Vec<IlluminantRow>)))]
pub async fn list_illuminants(State(state): State<AppState>) -> Result<Json<Vec<IlluminantRow>>, ApiError> {
    Ok(Json(state.lab.illuminants().await?))
}

async fn load(state: &AppState, id: i64) -> Result<IlluminantRow, ApiError> {
    Ok(state.lab.illuminant(id).await?)
}

#[utoipa::path(get, path = "/illuminants/{id}", tag = "illuminants", params(("id" = i64, Path)),
    responses((status = 200, body = IlluminantRow), (status = 404, body = ErrorBody)))]
pub async fn get_illuminant(
    State(state): State<AppState>,
    Path(id): Path<i64>,
) -> Result<Json<IlluminantRow>, ApiError> {
    Ok(Json(load(&state, id).await?))
}

/// The scene spectrum CSV (`spectra/NAME.csv`, a light's `spd = "spectra/NAME.csv:NAME"`).
#[utoipa::path(get, path = "/illuminants/{id}/csv", tag = "illuminants", params(("id" = i64, Path)),
    responses((status = 200, content_type = "text/csv"), (status = 404, body = ErrorBody)))]
pub async fn illuminant_csv(State(state): State<AppState>, Path(id): Path<i64>) -> Result<Response, ApiError> {
    let row = load(&state, id).await?;
    let text = state.lab.illuminant_csv(&row).await?;
    Ok(kept::download(Download::new(
        FileFormat::Csv,
        &row.name,
        text.into_bytes(),
    )))
}
