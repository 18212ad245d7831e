//! `/api/scenes/{scene}/comparisons[.csv|.mat]` and the scene's charts:
//! every coding against the measurements, summarised per coding.

use std::sync::Arc;

use axum::extract::State;
use axum::response::Response;
use serde::Serialize;
use utoipa::ToSchema;

use crate::comparison::SceneSummary;
use crate::http::error::ApiError;
use crate::http::input::Path;
use crate::http::kept;
use crate::http::AppState;
use crate::lab::compare::summary::SceneComparisons;
use crate::lab::FileFormat;
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
    /// The figures' 95 % intervals and their three claims (beyond the
    /// render's noise, the measurement's repeatability, the instrument's
    /// stated accuracy); null when they could not be propagated, and then
    /// `uncertainty_not_propagated` says why.
    pub uncertainty: Option<CodingUncertaintyDto>,
    pub uncertainty_not_propagated: Option<String>,
}

/// A coding's propagated uncertainty (GUM Supplement 1 Monte Carlo,
/// [`crate::lab::compare::summary`]).
#[derive(Serialize, ToSchema)]
pub struct CodingUncertaintyDto {
    /// The model whose stated accuracy was propagated.
    pub instrument_model: String,
    /// Its stated accuracy as propagated, with the source of each figure;
    /// an unset figure added nothing, and with none set the stated-accuracy
    /// claims are null (not made).
    #[schema(value_type = Object)]
    pub stated_accuracy: crate::uncertainty::StatedAccuracy,
    pub draws: usize,
    pub seed: u64,
    /// When a simulated instrument took the measurements: the largest
    /// relative standard error of Y (0.001 = 0.1 %) of the converged render
    /// it measured as the truth, counted with the repeatability in every
    /// claim; null for a real instrument.
    pub simulated_truth_relative_se: Option<f64>,
    /// rms_rel with its intervals and claims.
    #[schema(value_type = Object)]
    pub rms_rel: crate::uncertainty::PropagatedDifference,
    /// One per target, in the order of the coding's rows.
    pub targets: Vec<TargetUncertaintyDto>,
}

/// One target's figures with their intervals and claims.
#[allow(non_snake_case)]
#[derive(Serialize, ToSchema)]
pub struct TargetUncertaintyDto {
    /// The comparison row (`rows[].id`).
    pub comparison_id: i64,
    pub target: String,
    pub measurement_id: i64,
    #[schema(value_type = Object)]
    pub measured_Y: crate::uncertainty::MeasuredLuminance,
    #[schema(value_type = Object)]
    pub dE00: crate::uncertainty::PropagatedDifference,
    #[schema(value_type = Object)]
    pub dE76: crate::uncertainty::PropagatedDifference,
    #[schema(value_type = Object)]
    pub dx: crate::uncertainty::PropagatedDifference,
    #[schema(value_type = Object)]
    pub dy: crate::uncertainty::PropagatedDifference,
    /// rendered Y / measured Y − 1.
    #[schema(value_type = Object)]
    pub relative_dY: crate::uncertainty::PropagatedDifference,
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
/// per coding ([`crate::lab::compare::summary`]).
async fn scene_comparison(state: &AppState, scene: &str) -> Result<Arc<SceneComparisons>, ApiError> {
    Ok(state.lab.scene_comparisons(scene).await?)
}

impl From<SceneComparisons> for SceneComparison {
    fn from(c: SceneComparisons) -> Self {
        let rows = c.rows;
        let row = |id: i64| rows.iter().find(|r| r.id == id);
        let codings = c
            .codings
            .into_iter()
            .map(|s| {
                let (uncertainty, uncertainty_not_propagated) = match s.uncertainty {
                    Ok(u) => {
                        let targets = u
                            .row_ids
                            .iter()
                            .zip(&u.propagated.points)
                            .map(|(&id, p)| TargetUncertaintyDto {
                                comparison_id: id,
                                target: row(id).map(|r| r.target.clone()).unwrap_or_default(),
                                measurement_id: row(id).map(|r| r.measurement_id).unwrap_or_default(),
                                measured_Y: p.measured_luminance,
                                dE00: p.de00,
                                dE76: p.de76,
                                dx: p.dx,
                                dy: p.dy,
                                relative_dY: p.relative_dy,
                            })
                            .collect();
                        let dto = CodingUncertaintyDto {
                            instrument_model: u.instrument_model,
                            stated_accuracy: u.propagated.accuracy,
                            draws: u.propagated.monte_carlo.draws,
                            seed: u.propagated.monte_carlo.seed,
                            simulated_truth_relative_se: u.propagated.simulated_truth_relative_se,
                            rms_rel: u.propagated.rms_rel,
                            targets,
                        };
                        (Some(dto), None)
                    }
                    Err(why) => (None, Some(why)),
                };
                CodingSummary {
                    coding: s.coding,
                    summary: s.summary.into(),
                    mean_Y_ratio: s.mean_y_ratio,
                    uncertainty,
                    uncertainty_not_propagated,
                }
            })
            .collect();
        SceneComparison {
            scene: c.scene,
            observer: c.observer,
            codings,
            rows,
        }
    }
}

#[utoipa::path(get, path = "/scenes/{scene}/comparisons", tag = "comparisons", params(("scene" = String, Path)),
    responses((status = 503, description = "this daemon runs without the renderer", body = crate::http::error::ErrorBody), (status = 200, body = SceneComparison), (status = 404, body = crate::http::error::ErrorBody)))]
pub async fn scene_comparisons(State(state): State<AppState>, Path(scene): Path<String>) -> Result<Response, ApiError> {
    let c = scene_comparison(&state, &scene).await?;
    let body = state
        .lab
        .computed()
        .output(&c, "json", |c| {
            serde_json::to_vec(&SceneComparison::from(c.clone())).map_err(|e| e.to_string())
        })
        .await?;
    Ok(kept::json(body))
}

#[utoipa::path(get, path = "/scenes/{scene}/comparisons.csv", tag = "comparisons", params(("scene" = String, Path)),
    responses((status = 503, description = "this daemon runs without the renderer", body = crate::http::error::ErrorBody), (status = 200, content_type = "text/csv")))]
pub async fn scene_comparisons_csv(
    State(state): State<AppState>,
    Path(scene): Path<String>,
) -> Result<Response, ApiError> {
    Ok(kept::download(
        state.lab.scene_comparisons_file(&scene, FileFormat::Csv).await?,
    ))
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
    Ok(kept::download(
        state.lab.scene_comparisons_file(&scene, FileFormat::Mat).await?,
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
    Ok(kept::served(
        "image/svg+xml",
        state.lab.scene_chart(&scene, &chart).await?,
    ))
}
