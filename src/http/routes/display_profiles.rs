//! `/api/display-profiles`: display profiles measured with a
//! spectroradiometer, a colorimeter or a luminance meter (see
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

use crate::charts::{self, Bar, LineSeriesData, ScatterSeries};
use crate::display::fit::CalibrationPlan;
use crate::display::{Checks, Emission};
use crate::http::error::{ApiError, ErrorBody};
use crate::http::input::{Input, Path, Query};
use crate::http::AppState;
use crate::lab::records::display_profiles::{self as lab_profiles, ProfileRequest};
use crate::store::DisplayProfileRow;

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
    /// `judd-vos-1978` (default), `cie-1931`, `cie-1964-10`, `cie-2015-2` or `cie-2015-10`: the observer of every XYZ of
    /// the profile. Patches measured by a colorimeter or a luminance meter
    /// are in their instrument's observer, which is then the profile's
    /// (another is refused).
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
    let request = ProfileRequest {
        name: body.name.unwrap_or_else(|| "display".into()),
        note: body.note,
        observer: body.observer,
        patches: body
            .patches
            .iter()
            .map(|p| lab_profiles::ShownPatch {
                drive: p.drive,
                measurement_id: p.measurement_id,
            })
            .collect(),
    };
    Ok((StatusCode::CREATED, Json(state.lab.fit_display_profile(request).await?)))
}

/// A spectrum as a chart's line.
fn spectrum(name: &str, wavelength_nm: &[f64], values: &[f64]) -> LineSeriesData {
    LineSeriesData {
        name: name.into(),
        points: wavelength_nm.iter().copied().zip(values.iter().copied()).collect(),
        errors: None,
    }
}

/// A bar without a spread.
fn bar(label: &str, value: f64) -> Bar {
    Bar {
        label: label.into(),
        value,
        sd: None,
    }
}

async fn load(state: &AppState, id: i64) -> Result<DisplayProfileRow, ApiError> {
    Ok(state.lab.display_profile(id).await?)
}

/// Every stored profile, newest first.
#[utoipa::path(get, path = "/display-profiles", tag = "display",
    responses((status = 200, body = Vec<DisplayProfileRow>)))]
pub async fn list_display_profiles(State(state): State<AppState>) -> Result<Json<Vec<DisplayProfileRow>>, ApiError> {
    Ok(Json(state.lab.display_profiles().await?))
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
    let names = ["red", "green", "blue"];
    let svg = match (chart.as_str(), &p.emission, &p.checks) {
        ("transfer.svg", _, _) => {
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
            let from = match p.emission {
                Emission::Spectral { .. } => "",
                _ => ", from luminance",
            };
            charts::line_chart(
                &format!("display profile {id}: transfer (normalised output against drive{from})"),
                "drive (fraction of the maximum code)",
                "normalised output t",
                &series,
                false,
            )
        }
        (
            "primaries.svg",
            Emission::Spectral {
                wavelength_nm,
                black,
                primaries,
            },
            _,
        ) => {
            let mut series: Vec<LineSeriesData> = names
                .iter()
                .zip(primaries)
                .map(|(n, v)| spectrum(n, wavelength_nm, v))
                .collect();
            series.push(spectrum("black", wavelength_nm, black));
            charts::line_chart(
                &format!("display profile {id}: primaries at full drive (increment over black)"),
                "wavelength (nm)",
                &format!("spectral radiance ({})", crate::spectrum::SPECTRAL_RADIANCE_UNIT),
                &series,
                false,
            )
        }
        ("primaries.svg", Emission::Tristimulus { .. }, _) => {
            let xy = p.primary_chromaticities().map_err(|e| ApiError::Internal(e.to_string()))?;
            let white = p.white_xyz().map_err(|e| ApiError::Internal(e.to_string()))?.chromaticity();
            let mut triangle: Vec<(f64, f64)> = xy.iter().map(|c| (c[0], c[1])).collect();
            triangle.push(triangle[0]);
            charts::chromaticity_chart(
                &format!("display profile {id}: primaries (red, green, blue) and white, measured as XYZ"),
                p.observer,
                &[
                    ScatterSeries {
                        name: "display gamut (measured red, green, blue)".into(),
                        points: triangle,
                        connect: true,
                    },
                    ScatterSeries {
                        name: "white (all channels at full drive)".into(),
                        points: vec![(white.x, white.y)],
                        connect: false,
                    },
                ],
            )
        }
        (
            "primaries.svg",
            Emission::Luminance {
                black_cd_m2,
                primaries_cd_m2,
            },
            _,
        ) => {
            let mut bars = vec![bar("black", *black_cd_m2)];
            bars.extend(names.iter().zip(primaries_cd_m2).map(|(n, y)| bar(n, *y)));
            charts::labelled_bar_chart(
                &format!(
                    "display profile {id}: luminance at full drive (increment over black); a luminance meter gives no colour"
                ),
                "channel at full drive",
                "luminance (cd/m²)",
                &bars,
            )
        }
        ("additivity.svg", Emission::Spectral { wavelength_nm, black, primaries }, Checks::Colour { additivity, .. }) => {
            let sum: Vec<f64> = (0..wavelength_nm.len())
                .map(|i| black[i] + primaries.iter().map(|c| c[i]).sum::<f64>())
                .collect();
            charts::line_chart(
                &format!(
                    "display profile {id}: additivity, white Y {:.2} cd/m² against R+G+B, ΔE00 {:.3} ({})",
                    additivity.white_xyz[1], additivity.delta_e00, p.observer
                ),
                "wavelength (nm)",
                &format!("spectral radiance ({})", crate::spectrum::SPECTRAL_RADIANCE_UNIT),
                &[
                    spectrum("white, measured", wavelength_nm, &additivity.white),
                    spectrum("black + R + G + B", wavelength_nm, &sum),
                ],
                false,
            )
        }
        ("additivity.svg", _, Checks::Colour { additivity, .. }) => {
            let mut bars = Vec::new();
            for (k, name) in ["X", "Y", "Z"].iter().enumerate() {
                bars.push(bar(&format!("{name}, white measured"), additivity.white_xyz[k]));
                bars.push(bar(&format!("{name}, black + R + G + B"), additivity.sum_xyz[k]));
            }
            charts::labelled_bar_chart(
                &format!(
                    "display profile {id}: additivity, ΔE00 {:.3} ({})",
                    additivity.delta_e00, p.observer
                ),
                "white measured, and black + R + G + B, per tristimulus value",
                "tristimulus value (cd/m² scale)",
                &bars,
            )
        }
        ("additivity.svg", _, Checks::Luminance { luminance_additivity: a, .. }) => charts::labelled_bar_chart(
            &format!(
                "display profile {id}: additivity in luminance, R+G+B {:+.2} % off the white",
                a.relative_difference * 100.0
            ),
            "",
            "luminance (cd/m²)",
            &[bar("white, measured", a.white_cd_m2), bar("black + R + G + B", a.sum_cd_m2)],
        ),
        (other, _, _) => {
            return Err(ApiError::NotFound(format!(
                "no chart `{other}`: choose primaries.svg, transfer.svg or additivity.svg"
            )))
        }
    }
    .map_err(ApiError::Internal)?;
    Ok(([(header::CONTENT_TYPE, "image/svg+xml")], svg).into_response())
}
