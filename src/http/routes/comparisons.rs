//! `/api/scenes/{scene}/comparisons[.csv|.mat]` and the scene's charts:
//! every coding against the measurements, summarised per coding.

use std::sync::Arc;

use axum::extract::State;
use axum::response::Response;
use serde::Serialize;
use utoipa::ToSchema;

use super::download;
use crate::comparison::SceneSummary;
use crate::export::mat::MatFile;
use crate::http::error::ApiError;
use crate::http::input::Path;
use crate::http::kept;
use crate::http::AppState;
use crate::lab::comparisons::summary::SceneComparisons;
use crate::store::ComparisonRow;
use crate::uncertainty::{PointUncertainty, PropagatedDifference};

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
/// [`crate::lab::comparisons::summary`]).
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
/// per coding ([`crate::lab::comparisons::summary`]).
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
    let c = scene_comparison(&state, &scene).await?;
    let body = state.lab.computed().output(&c, "csv", comparisons_csv).await?;
    Ok(download(
        "text/csv",
        &format!("comparisons_{scene}.csv"),
        kept::body(body),
    ))
}

/// The CSV of a scene's comparisons: every row names its observer (the
/// `observer` column); the stored columns first, as serialised, then each
/// row's uncertainty columns.
fn comparisons_csv(c: &SceneComparisons) -> Result<Vec<u8>, String> {
    let e = |e: &dyn std::fmt::Display| e.to_string();
    let mut w = csv::Writer::from_writer(Vec::new());
    for row in &c.rows {
        w.serialize(row).map_err(|x| e(&x))?;
    }
    let stored = w.into_inner().map_err(|x| e(&x))?;
    let mut r = csv::Reader::from_reader(stored.as_slice());
    let by_row = uncertainty_by_row(c);
    let mut out = csv::Writer::from_writer(Vec::new());
    let mut header = r.headers().map_err(|x| e(&x))?.clone();
    let extra = uncertainty_columns(None);
    for (name, _) in &extra {
        header.push_field(name);
    }
    if !c.rows.is_empty() {
        out.write_record(&header).map_err(|x| e(&x))?;
    }
    for (record, row) in r.records().zip(&c.rows) {
        let mut record = record.map_err(|x| e(&x))?;
        for (_, value) in uncertainty_columns(by_row.get(&row.id).copied()) {
            record.push_field(&value);
        }
        out.write_record(&record).map_err(|x| e(&x))?;
    }
    out.into_inner().map_err(|x| e(&x))
}

/// Each comparison row's propagated figures, by the row's id.
fn uncertainty_by_row(c: &SceneComparisons) -> std::collections::HashMap<i64, (&PointUncertainty, &str)> {
    c.codings
        .iter()
        .filter_map(|s| s.uncertainty.as_ref().ok())
        .flat_map(|u| {
            u.row_ids
                .iter()
                .copied()
                .zip(u.propagated.points.iter().map(|p| (p, u.instrument_model.as_str())))
        })
        .collect()
}

/// A row's uncertainty columns, named as in the CSV and the MAT file
/// (empty, or NaN in the MAT file, where nothing was propagated): the
/// simulated truth's standard error of Y in the budget (`truth_se_Y`,
/// cd/m²; empty for a real instrument); for ΔE00 the 95th percentile of what the measurement's error alone gives
/// (repeatability; with the stated accuracy), for Δx, Δy and relative ΔY
/// the 95 % interval with the stated accuracy; and each figure's three
/// claims (`true`/`false`; empty where not made).
fn uncertainty_columns(p: Option<(&PointUncertainty, &str)>) -> Vec<(String, String)> {
    let num = |v: Option<f64>| v.map(|v| v.to_string()).unwrap_or_default();
    let flag = |v: Option<bool>| v.map(|v| v.to_string()).unwrap_or_default();
    let mut out = vec![(
        "accuracy_of".to_string(),
        p.map(|p| p.1.to_string()).unwrap_or_default(),
    )];
    out.push((
        "truth_se_Y".to_string(),
        num(p.and_then(|p| p.0.measured_luminance.truth_standard_error_cd_m2)),
    ));
    /// A figure's column prefix, where it is in a point, and whether it is signed.
    type Figure = (&'static str, fn(&PointUncertainty) -> &PropagatedDifference, bool);
    let figures: [Figure; 4] = [
        ("dE00", |p| &p.de00, false),
        ("relative_dY", |p| &p.relative_dy, true),
        ("dx", |p| &p.dx, true),
        ("dy", |p| &p.dy, true),
    ];
    for (name, figure, signed) in figures {
        let d = p.map(|p| figure(p.0));
        if signed {
            out.push((
                format!("{name}_low95"),
                num(d.map(|d| d.stated_accuracy.interval_95.low)),
            ));
            out.push((
                format!("{name}_high95"),
                num(d.map(|d| d.stated_accuracy.interval_95.high)),
            ));
        } else {
            out.push((
                format!("{name}_null95_repeatability"),
                num(d.and_then(|d| d.null_95th_repeatability)),
            ));
            out.push((
                format!("{name}_null95_stated_accuracy"),
                num(d.and_then(|d| d.null_95th_stated_accuracy)),
            ));
        }
        out.push((format!("{name}_beyond_noise"), flag(d.map(|d| d.claims.beyond_noise))));
        out.push((
            format!("{name}_beyond_repeatability"),
            flag(d.map(|d| d.claims.beyond_repeatability)),
        ));
        out.push((
            format!("{name}_beyond_stated_accuracy"),
            flag(d.and_then(|d| d.claims.beyond_stated_accuracy)),
        ));
    }
    out
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
    let body = state.lab.computed().output(&c, "mat", comparisons_mat).await?;
    Ok(download(
        "application/x-matlab-data",
        &format!("comparisons_{scene}.mat"),
        kept::body(body),
    ))
}

/// The MAT file of a scene's comparisons (see [`scene_comparisons_mat`]).
fn comparisons_mat(c: &SceneComparisons) -> Result<Vec<u8>, String> {
    let mut mat = MatFile::new();
    let internal = |e: String| e;
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
    // Each row's uncertainty columns (NaN where not propagated or not
    // made; claims 1 or 0), named as in the CSV.
    let by_row = uncertainty_by_row(c);
    let per_row: Vec<Vec<(String, String)>> = c
        .rows
        .iter()
        .map(|r| uncertainty_columns(by_row.get(&r.id).copied()))
        .collect();
    for (k, (name, _)) in uncertainty_columns(None).iter().enumerate() {
        if name == "accuracy_of" {
            mat.text_rows(name, &per_row.iter().map(|cols| cols[k].1.clone()).collect::<Vec<_>>())
                .map_err(internal)?;
            continue;
        }
        let values: Vec<f64> = per_row
            .iter()
            .map(|cols| match cols[k].1.as_str() {
                "true" => 1.0,
                "false" => 0.0,
                v => v.parse().unwrap_or(f64::NAN),
            })
            .collect();
        mat.column(name, &values).map_err(internal)?;
    }
    Ok(mat.into_bytes())
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
