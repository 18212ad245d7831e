//! `/api/scenes/{scene}/comparisons[.csv|.mat]` and the scene's charts:
//! every coding against the measurements, summarised per coding.

use axum::extract::State;
use axum::http::header;
use axum::response::{IntoResponse, Response};
use axum::Json;
use serde::Serialize;
use utoipa::ToSchema;

use super::download;
use crate::comparison::SceneSummary;
use crate::export::mat::MatFile;
use crate::http::error::ApiError;
use crate::http::input::Path;
use crate::http::AppState;
use crate::lab::comparisons::summary::SceneComparisons;
use crate::store::ComparisonRow;

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
    /// The observer of the XYZ, x,y and ΔE summarised.
    #[schema(value_type = String)]
    pub observer: crate::colorimetry::Observer,
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
            observer: s.observer,
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
    /// The daemon's observer (`serve --observer`): the observer of every
    /// summary and chart; each row names its own.
    #[schema(value_type = String)]
    pub observer: crate::colorimetry::Observer,
    /// One row per coding: rms_rel and mean ± SD of ΔE over the scene's targets.
    pub codings: Vec<CodingSummary>,
    /// The newest comparison of every (target, coding).
    pub rows: Vec<ComparisonRow>,
}

/// The scene's newest comparisons with the daemon's observer, summarised
/// per coding ([`crate::lab::comparisons::summary`]).
async fn scene_comparison(state: &AppState, scene: &str) -> Result<SceneComparisons, ApiError> {
    Ok(state.lab.scene_comparisons(scene).await?)
}

impl From<SceneComparisons> for SceneComparison {
    fn from(c: SceneComparisons) -> Self {
        SceneComparison {
            scene: c.scene,
            observer: c.observer,
            codings: c
                .codings
                .into_iter()
                .map(|s| CodingSummary {
                    coding: s.coding,
                    summary: s.summary.into(),
                    mean_Y_ratio: s.mean_y_ratio,
                })
                .collect(),
            rows: c.rows,
        }
    }
}

#[utoipa::path(get, path = "/scenes/{scene}/comparisons", tag = "comparisons", params(("scene" = String, Path)),
    responses((status = 503, description = "this daemon runs without the renderer", body = crate::http::error::ErrorBody), (status = 200, body = SceneComparison), (status = 404, body = crate::http::error::ErrorBody)))]
pub async fn scene_comparisons(
    State(state): State<AppState>,
    Path(scene): Path<String>,
) -> Result<Json<SceneComparison>, ApiError> {
    Ok(Json(scene_comparison(&state, &scene).await?.into()))
}

#[utoipa::path(get, path = "/scenes/{scene}/comparisons.csv", tag = "comparisons", params(("scene" = String, Path)),
    responses((status = 503, description = "this daemon runs without the renderer", body = crate::http::error::ErrorBody), (status = 200, content_type = "text/csv")))]
pub async fn scene_comparisons_csv(
    State(state): State<AppState>,
    Path(scene): Path<String>,
) -> Result<Response, ApiError> {
    let c = scene_comparison(&state, &scene).await?;
    // Every row names its observer (the `observer` column).
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
#[utoipa::path(get, path = "/scenes/{scene}/comparisons.mat", tag = "comparisons", params(("scene" = String, Path)),
    responses((status = 503, description = "this daemon runs without the renderer", body = crate::http::error::ErrorBody), (status = 200, content_type = "application/x-matlab-data")))]
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
    // The observer of every XYZ and ΔE in the file.
    mat.text_rows("observer", &[c.observer.to_string()]).map_err(internal)?;
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
#[utoipa::path(get, path = "/scenes/{scene}/charts/{chart}", tag = "comparisons",
    params(("scene" = String, Path), ("chart" = String, Path, description = "chromaticity.svg, profile.svg, rms.svg, de.svg or speed.svg")),
    responses((status = 503, description = "this daemon runs without the renderer", body = crate::http::error::ErrorBody), (status = 200, content_type = "image/svg+xml"), (status = 404, body = crate::http::error::ErrorBody)))]
pub async fn scene_chart(
    State(state): State<AppState>,
    Path((scene, chart)): Path<(String, String)>,
) -> Result<Response, ApiError> {
    let c = scene_comparison(&state, &scene).await?;
    let info = state.lab.scene(&scene)?;
    if c.rows.is_empty() {
        return Err(ApiError::NotFound(format!(
            "scene `{scene}` has no comparisons yet: measure its targets first"
        )));
    }
    let svg = match chart.as_str() {
        "chromaticity.svg" => crate::http::scene_charts::chromaticity(&c, &info, state.lab.observer()),
        "profile.svg" => crate::http::scene_charts::profile(&c, &info),
        "rms.svg" => crate::http::scene_charts::rms(&c),
        "de.svg" => crate::http::scene_charts::delta_e(&c),
        "speed.svg" => crate::http::scene_charts::speed(&state, &c).await,
        other => {
            return Err(ApiError::NotFound(format!(
                "no chart `{other}`: choose chromaticity.svg, profile.svg, rms.svg, de.svg or speed.svg"
            )))
        }
    }
    .map_err(ApiError::Internal)?;
    Ok(([(header::CONTENT_TYPE, "image/svg+xml")], svg).into_response())
}
