//! `/api/display-profiles`: display profiles measured with the PR-650 (see
//! [`crate::display`]). The calibration page (`/calibrate`) asks for the
//! plan, shows each colour while the instrument measures it (an ordinary
//! `POST /api/measurements`), then posts the measured patches here; the
//! profile is fitted server-side from the stored measurements and kept with
//! their ids. Charts: the primaries' spectra, the transfer curves with their
//! fit, and the additivity check (white against black + R + G + B).

use axum::extract::State;
use axum::http::{header, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::Json;
use serde::Deserialize;
use utoipa::{IntoParams, ToSchema};

use super::measurements::load_measurement;
use crate::charts::{self, LineSeriesData};
use crate::colorimetry::Observer;
use crate::display::fit::{CalibrationPlan, MeasuredPatch};
use crate::display::fit_profile;
use crate::http::error::{ApiError, ErrorBody};
use crate::http::input::{Input, Path, Query};
use crate::http::AppState;
use crate::store::{DisplayProfileRow, MeasurementState};

/// The most patches one profile may be fitted from (the plan at 32 steps has 108).
const MAX_PATCHES: usize = 256;

#[derive(Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
#[serde(deny_unknown_fields)]
pub struct PlanQuery {
    /// Levels per channel ramp, 2–32 (default 8).
    #[param(minimum = 2, maximum = 32, nullable = false)]
    pub steps: Option<usize>,
}

/// The colours a calibration shows, in order.
#[utoipa::path(get, path = "/display-profiles/plan", tag = "display", params(PlanQuery),
    responses((status = 200, body = CalibrationPlan), (status = 400, body = ErrorBody)))]
pub async fn display_calibration_plan(Query(q): Query<PlanQuery>) -> Result<Json<CalibrationPlan>, ApiError> {
    CalibrationPlan::new(q.steps.unwrap_or(8))
        .map(Json)
        .map_err(|e| ApiError::BadRequest(format!("query `steps`: {e}")))
}

/// A colour shown and the measurement taken of it.
#[derive(Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct ShownPatch {
    /// Drive of red, green, blue, 0–1.
    pub drive: [f64; 3],
    /// The complete measurement of it.
    pub measurement_id: i64,
}

#[derive(Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct NewDisplayProfile {
    /// Default `display`.
    pub name: Option<String>,
    #[serde(default)]
    pub note: String,
    /// `judd-vos-1978` (default) or `cie-1931`: the observer of every XYZ of the profile.
    pub observer: Option<String>,
    pub patches: Vec<ShownPatch>,
}

/// Fits a profile to measured patches and stores it with their ids.
#[utoipa::path(post, path = "/display-profiles", tag = "display", request_body = NewDisplayProfile,
    responses((status = 201, body = DisplayProfileRow), (status = 400, body = ErrorBody),
              (status = 401, body = ErrorBody), (status = 404, body = ErrorBody)),
    security(("bearer" = [])))]
pub async fn create_display_profile(
    State(state): State<AppState>,
    Input(body): Input<NewDisplayProfile>,
) -> Result<(StatusCode, Json<DisplayProfileRow>), ApiError> {
    if body.patches.len() > MAX_PATCHES {
        return Err(ApiError::BadRequest(format!(
            "field `patches`: {} patches; at most {MAX_PATCHES}",
            body.patches.len()
        )));
    }
    let observer: Observer = match &body.observer {
        Some(o) => o
            .parse()
            .map_err(|e| ApiError::BadRequest(format!("field `observer`: {e}")))?,
        None => Observer::default(),
    };
    let mut patches = Vec::with_capacity(body.patches.len());
    for (i, p) in body.patches.iter().enumerate() {
        let m = load_measurement(&state, p.measurement_id).await?;
        if m.summary.state != MeasurementState::Complete {
            return Err(ApiError::BadRequest(format!(
                "field `patches[{i}]`: measurement {} is {}, not complete",
                p.measurement_id,
                m.summary.state.as_str()
            )));
        }
        // A profile from a colorimeter's XYZ or a luminance meter's gamma is not built yet.
        let (wavelength_nm, radiance) =
            crate::lab::measurement::stored_spectrum(&m, "this display profile (fitted to spectra)")
                .map(|(wl, r)| (wl.to_vec(), r.to_vec()))
                .map_err(|e| ApiError::BadRequest(format!("field `patches[{i}]`: {e}")))?;
        patches.push(MeasuredPatch {
            drive: p.drive,
            wavelength_nm,
            radiance,
            measurement_id: Some(p.measurement_id),
        });
    }
    let profile = fit_profile(&patches, observer).map_err(|e| ApiError::BadRequest(e.to_string()))?;
    let name = body.name.unwrap_or_else(|| "display".into());
    let id = state.store.insert_display_profile(&name, &body.note, &profile).await?;
    let row = load(&state, id).await?;
    Ok((StatusCode::CREATED, Json(row)))
}

async fn load(state: &AppState, id: i64) -> Result<DisplayProfileRow, ApiError> {
    state
        .store
        .get_display_profile(id)
        .await?
        .ok_or_else(|| ApiError::NotFound(format!("no display profile {id}")))
}

/// Every stored profile, newest first.
#[utoipa::path(get, path = "/display-profiles", tag = "display",
    responses((status = 200, body = Vec<DisplayProfileRow>)))]
pub async fn list_display_profiles(State(state): State<AppState>) -> Result<Json<Vec<DisplayProfileRow>>, ApiError> {
    Ok(Json(state.store.list_display_profiles().await?))
}

#[utoipa::path(get, path = "/display-profiles/{id}", tag = "display", params(("id" = i64, Path)),
    responses((status = 200, body = DisplayProfileRow), (status = 404, body = ErrorBody)))]
pub async fn get_display_profile(
    State(state): State<AppState>,
    Path(id): Path<i64>,
) -> Result<Json<DisplayProfileRow>, ApiError> {
    Ok(Json(load(&state, id).await?))
}

/// A chart of a profile: `primaries`, `transfer` or `additivity`.
#[utoipa::path(get, path = "/display-profiles/{id}/{chart}", tag = "display",
    params(("id" = i64, Path), ("chart" = String, Path, description = "primaries.svg, transfer.svg or additivity.svg")),
    responses((status = 200, content_type = "image/svg+xml"), (status = 404, body = ErrorBody)))]
pub async fn display_profile_chart(
    State(state): State<AppState>,
    Path((id, chart)): Path<(i64, String)>,
) -> Result<Response, ApiError> {
    let row = load(&state, id).await?;
    let p = &row.profile;
    let wl = &p.wavelength_nm;
    let spectrum = |name: &str, v: &[f64]| LineSeriesData {
        name: name.into(),
        points: wl.iter().copied().zip(v.iter().copied()).collect(),
        errors: None,
    };
    let names = ["red", "green", "blue"];
    let svg = match chart.as_str() {
        "primaries.svg" => {
            let mut series: Vec<LineSeriesData> = names.iter().zip(&p.primaries).map(|(n, v)| spectrum(n, v)).collect();
            series.push(spectrum("black", &p.black));
            charts::line_chart(
                &format!("display profile {id}: primaries at full drive (increment over black)"),
                "wavelength (nm)",
                "spectral radiance (W/(sr·m²·nm))",
                &series,
                false,
            )
        }
        "transfer.svg" => {
            let mut series = Vec::new();
            for (n, t) in names.iter().zip(&p.transfer) {
                series.push(LineSeriesData {
                    name: format!("{n} measured"),
                    points: t.levels.iter().copied().zip(t.measured.iter().copied()).collect(),
                    errors: None,
                });
                series.push(LineSeriesData {
                    name: format!("{n} fit v^{:.3}", t.gamma),
                    points: (0..=50)
                        .map(|k| k as f64 / 50.0)
                        .map(|v| (v, v.powf(t.gamma)))
                        .collect(),
                    errors: None,
                });
            }
            charts::line_chart(
                &format!("display profile {id}: transfer (normalised output against drive)"),
                "drive (fraction of the maximum code)",
                "normalised output t",
                &series,
                false,
            )
        }
        "additivity.svg" => {
            let sum: Vec<f64> = (0..wl.len())
                .map(|i| p.black[i] + p.primaries.iter().map(|c| c[i]).sum::<f64>())
                .collect();
            let measured_white = p.additivity.white_xyz;
            charts::line_chart(
                &format!(
                    "display profile {id}: additivity, white Y {:.2} cd/m² against R+G+B, ΔE00 {:.3} ({})",
                    measured_white[1], p.additivity.delta_e00, p.observer
                ),
                "wavelength (nm)",
                "spectral radiance (W/(sr·m²·nm))",
                &[
                    spectrum("white, measured", &p.additivity.white),
                    spectrum("black + R + G + B", &sum),
                ],
                false,
            )
        }
        other => {
            return Err(ApiError::NotFound(format!(
                "no chart `{other}`: choose primaries.svg, transfer.svg or additivity.svg"
            )))
        }
    }
    .map_err(ApiError::Internal)?;
    Ok(([(header::CONTENT_TYPE, "image/svg+xml")], svg).into_response())
}
