//! The study's charts for one scene, from its stored comparisons: data
//! selection here, drawing in [`crate::charts`].

use super::routes::{coding_order, SceneComparison};
use super::{AppState, SceneInfo};
use crate::charts::{self, Bar, LineSeriesData, ScatterSeries};
use crate::colorimetry::Xyz;

/// Targets in the scene's own order (the cylinder's 21 heights bottom to top).
fn target_index(info: &SceneInfo, target: &str) -> usize {
    info.targets.iter().position(|t| t == target).unwrap_or(usize::MAX)
}

/// Measured points and each coding's results in the x,y diagram; profiles
/// (more than one target) are drawn as lines, zoomed to the data.
pub fn chromaticity(c: &SceneComparison, info: &SceneInfo) -> Result<String, String> {
    let mut rows = c.rows.clone();
    rows.sort_by_key(|r| (coding_order(&r.coding), target_index(info, &r.target)));
    let profile = info.targets.len() > 1;
    let mut series = Vec::new();
    // The measurement, once per target (every coding row carries it).
    let mut measured: Vec<(usize, (f64, f64))> = Vec::new();
    for r in &rows {
        let i = target_index(info, &r.target);
        if !measured.iter().any(|(j, _)| *j == i) {
            let xy = Xyz::new(r.measured_X, r.measured_Y, r.measured_Z).chromaticity();
            measured.push((i, (xy.x, xy.y)));
        }
    }
    measured.sort_by_key(|(i, _)| *i);
    series.push(ScatterSeries {
        name: "measured".into(),
        points: measured.into_iter().map(|(_, p)| p).collect(),
        connect: profile,
    });
    for coding in codings(c) {
        let points = rows
            .iter()
            .filter(|r| r.coding == coding)
            .map(|r| {
                let xy = Xyz::new(r.rendered_X, r.rendered_Y, r.rendered_Z).chromaticity();
                (xy.x, xy.y)
            })
            .collect();
        series.push(ScatterSeries {
            name: coding,
            points,
            connect: profile,
        });
    }
    charts::chromaticity_chart(&format!("{}: chromaticity (CIE 1931)", c.scene), &series, true)
}

/// Luminance at each target (in the scene's target order), measured and per coding.
pub fn profile(c: &SceneComparison, info: &SceneInfo) -> Result<String, String> {
    let mut series = Vec::new();
    let mut measured: Vec<(f64, f64)> = Vec::new();
    for r in &c.rows {
        let i = target_index(info, &r.target) as f64;
        if !measured.iter().any(|(j, _)| *j == i) {
            measured.push((i, r.measured_Y));
        }
    }
    measured.sort_by(|a, b| a.0.total_cmp(&b.0));
    series.push(LineSeriesData {
        name: "measured".into(),
        points: measured,
        errors: None,
    });
    for coding in codings(c) {
        let mut points: Vec<(f64, f64)> = c
            .rows
            .iter()
            .filter(|r| r.coding == coding)
            .map(|r| (target_index(info, &r.target) as f64, r.rendered_Y))
            .collect();
        points.sort_by(|a, b| a.0.total_cmp(&b.0));
        let errors = Some(
            c.rows
                .iter()
                .filter(|r| r.coding == coding)
                .map(|r| (target_index(info, &r.target), r.rendered_Y_se))
                .collect::<std::collections::BTreeMap<_, _>>()
                .into_values()
                .collect(),
        );
        series.push(LineSeriesData {
            name: coding,
            points,
            errors,
        });
    }
    charts::line_chart(
        &format!("{}: luminance along the targets", c.scene),
        "target (scene order; CYLINDER: height 1–21 cm above the card)",
        "luminance (cd/m²)",
        &series,
        false,
    )
}

/// rms_rel per coding (no SD: it is one number per scene).
pub fn rms(c: &SceneComparison) -> Result<String, String> {
    let bars: Vec<Bar> = c
        .codings
        .iter()
        .map(|s| Bar {
            label: s.coding.clone(),
            value: s.summary.rms_rel,
            sd: None,
        })
        .collect();
    charts::bar_chart(&format!("{}: relative RMS luminance error", c.scene), "rms_rel", &bars)
}

/// Mean ΔE*ab per coding with ±1 SD over the targets.
pub fn delta_e(c: &SceneComparison) -> Result<String, String> {
    let bars: Vec<Bar> = c
        .codings
        .iter()
        .map(|s| Bar {
            label: s.coding.clone(),
            value: s.summary.mean_dE76,
            sd: s.summary.sd_dE76,
        })
        .collect();
    charts::bar_chart(&format!("{}: mean ΔE*ab ± 1 SD", c.scene), "ΔE*ab", &bars)
}

/// Render time per coding against its mean ΔE*ab: the chart the study never
/// drew. Time is each coding's own render time (the same settings with that
/// coding alone), read from the newest render's `result.coding_seconds`.
pub async fn speed(state: &AppState, c: &SceneComparison) -> Result<String, String> {
    let renders = state
        .store
        .list_renders(Some(&c.scene))
        .await
        .map_err(|e| e.to_string())?;
    let mut points = Vec::new();
    for s in &c.codings {
        let seconds = renders
            .iter()
            .find_map(|r| r.result.as_ref()?.get("coding_seconds")?.get(&s.coding)?.as_f64());
        if let Some(t) = seconds {
            points.push(LineSeriesData {
                name: s.coding.clone(),
                points: vec![(t, s.summary.mean_dE76)],
                errors: s.summary.sd_dE76.map(|v| vec![v]),
            });
        }
    }
    if points.is_empty() {
        return Err(format!("no render of scene {} has per-coding timings yet", c.scene));
    }
    charts::line_chart(
        &format!("{}: speed against accuracy", c.scene),
        "render time (s)",
        "mean ΔE*ab",
        &points,
        true,
    )
}

fn codings(c: &SceneComparison) -> Vec<String> {
    c.codings.iter().map(|s| s.coding.clone()).collect()
}
