//! The study's charts for one scene, from its stored comparisons: data
//! selection here, drawing (one palette and marker per coding, the
//! measurement black and last) in [`crate::charts`].

use super::summary::{coding_order, SceneComparisons as SceneComparison};
use crate::charts::{self, Bar, LineSeriesData, ScatterSeries};
use crate::requests::SceneInfo;
use lightbooth_science::colorimetry::{Observer, Xyz};

/// The cost on the speed chart's x axis: the wall time of each coding
/// rendered alone at the same fixed number of paths per target
/// (`coding_cost.CODING.wall_seconds` of a stored render, see
/// `lab::render::runner`), and the axis title. The rays traced are stored beside
/// it (`coding_cost.CODING.rays`) but do not separate the codings: the same
/// paths trace the same rays in every coding, which differ only in the
/// arithmetic per ray (channels), so rays cannot be this chart's axis. The
/// wall time is the median of rotated repeats after a warm-up
/// ([`lightbooth_render::cost`]), drawn with its fastest–slowest whisker.
const SPEED_COST: (&str, &str, &str) = (
    "coding_cost",
    "wall_seconds",
    "render time (s, log scale), each coding alone, same paths",
);

/// Measured points and each coding's results in the x,y diagram of the
/// daemon's `observer`; profiles (more than one target) are drawn as lines.
pub fn chromaticity(c: &SceneComparison, info: &SceneInfo, observer: Observer) -> Result<String, String> {
    let mut rows = c.rows.clone();
    rows.sort_by_key(|r| (coding_order(&r.coding), info.target_index(&r.target)));
    let profile = info.targets.len() > 1;
    let mut series = Vec::new();
    // The measurement, once per target (every coding row carries it).
    let mut measured: Vec<(usize, (f64, f64))> = Vec::new();
    for r in &rows {
        let i = info.target_index(&r.target);
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
    charts::chromaticity_chart(&format!("{}: chromaticity", c.scene), observer, &series)
}

/// Luminance at each target (in the scene's target order), measured and per coding.
pub fn profile(c: &SceneComparison, info: &SceneInfo) -> Result<String, String> {
    let mut series = Vec::new();
    let mut measured: Vec<(f64, f64)> = Vec::new();
    for r in &c.rows {
        let i = info.target_number(&r.target);
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
            .map(|r| (info.target_number(&r.target), r.rendered_Y))
            .collect();
        points.sort_by(|a, b| a.0.total_cmp(&b.0));
        let errors = Some(
            c.rows
                .iter()
                .filter(|r| r.coding == coding)
                .map(|r| (info.target_index(&r.target), r.rendered_Y_se))
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
    charts::profile_chart(
        &format!("{}: luminance along the targets (±1 SE of the render)", c.scene),
        &info.targets,
        if c.scene == "cylinder" {
            "target (scene order; hNN: NN cm above the card)"
        } else {
            "target (scene order)"
        },
        "luminance Y (cd/m²)",
        &series,
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
    charts::bar_chart(
        &format!("{}: relative RMS luminance error", c.scene),
        "rms_rel (relative, 0.01 = 1 %)",
        &bars,
    )
}

/// Mean ΔE*ab per coding with ±1 SD over the targets.
pub fn delta_e(c: &SceneComparison) -> Result<String, String> {
    let bars: Vec<Bar> = c
        .codings
        .iter()
        .map(|s| Bar {
            label: s.coding.clone(),
            value: s.summary.mean_de76,
            sd: s.summary.sd_de76,
        })
        .collect();
    charts::bar_chart(
        &format!("{}: mean ΔE*ab ± 1 SD over targets", c.scene),
        "mean ΔE*ab (CIELAB units)",
        &bars,
    )
}

/// Cost per coding (see [`SPEED_COST`]: render time of each coding alone at
/// the same fixed paths per target) against its mean ΔE*ab ± 1 SD over targets, each
/// point labelled with its coding; read from the newest render that has it.
pub async fn speed(lab: &crate::LabHandle, c: &SceneComparison) -> Result<String, String> {
    let renders = lab.renders_of_scene(&c.scene).await.map_err(|e| e.to_string())?;
    let (key, field, x_desc) = SPEED_COST;
    let mut series = Vec::new();
    let mut labels = Vec::new();
    let mut spreads = Vec::new();
    for s in &c.codings {
        let cost = renders.iter().find_map(|r| r.result.as_ref()?.get(key)?.get(&s.coding));
        if let Some(x) = cost.and_then(|c| c.get(field)?.as_f64()) {
            let bound = |k: &str| cost.and_then(|c| c.get(k)?.as_f64()).unwrap_or(x);
            spreads.push(vec![(bound("wall_seconds_min"), bound("wall_seconds_max"))]);
            series.push(ScatterSeries {
                name: s.coding.clone(),
                points: vec![(x, s.summary.mean_de76)],
                connect: false,
            });
            labels.push(vec![s.coding.clone()]);
        }
    }
    if series.is_empty() {
        return Err(format!(
            "no render of scene {} has per-coding costs (`{key}`) yet",
            c.scene
        ));
    }
    charts::scatter_chart_with_spread(
        &format!("{}: speed against accuracy", c.scene),
        &format!("{x_desc}: {}", lightbooth_render::cost::TIMING_AXIS),
        "mean ΔE*ab (CIELAB units, log scale)",
        &series,
        &labels,
        &spreads,
        (true, true),
    )
}

fn codings(c: &SceneComparison) -> Vec<String> {
    c.codings.iter().map(|s| s.coding.clone()).collect()
}
