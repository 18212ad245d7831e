//! Every scene at a glance, for the dashboard's Scenes page and its home
//! page's "what to measure next": per scene its targets measured in this
//! booth out of all, when the newest measurement ended, the render whose
//! camera view is its thumbnail, and each coding's mean ΔE00 and rms_rel
//! against the measurements (the same summary the scene's own page shows,
//! [`crate::compare::summary`], with the daemon's observer, as the
//! lab keeps it computed: [`crate::computed`]).

use std::sync::Arc;

use serde::Serialize;

use crate::compare::summary::SceneComparisons;
use crate::requests::SceneInfo;
use lightbooth_science::colorimetry::Observer;
use lightbooth_store::{Booth, MeasurementFilter, MeasurementState, Store, StoreError};

/// Complete measurements of one scene read to find its measured targets.
const MEASUREMENTS_READ: i64 = 1000;

/// One coding's figures over a scene's measured targets.
#[derive(Clone, Debug, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct CodingFigures {
    pub coding: String,
    /// The coding's colour in every chart and page (`charts::coding_style`), `#rrggbb`.
    pub colour: String,
    /// Targets compared.
    pub points: usize,
    /// Mean CIEDE2000 difference rendered → measured.
    #[serde(rename = "mean_dE00")]
    pub mean_de00: f64,
    /// sqrt(mean (1 − Y_render/Y_measured)²) over the targets.
    pub rms_rel: f64,
}

/// One scene's state.
#[derive(Clone, Debug, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct SceneStatus {
    pub scene: String,
    pub title: String,
    pub targets: Vec<String>,
    /// Targets with a complete measurement in this booth.
    pub measured: Vec<String>,
    /// POSIX seconds: when the newest complete measurement of the scene in
    /// this booth ended.
    pub last_measured_at: Option<f64>,
    /// The newest complete render with a camera view
    /// (`/api/renders/{id}/preview.png`); null before the scene is rendered.
    pub preview_render_id: Option<i64>,
    /// Each coding's figures, in the study's order; empty before a comparison.
    pub codings: Vec<CodingFigures>,
}

/// Every scene of `scenes`, in their order.
#[derive(Clone, Debug, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ScenesOverview {
    pub booth: String,
    /// The observer of every ΔE00 (`judd-vos-1978`, `cie-1931`, `cie-1964-10`, `cie-2015-2` or `cie-2015-10`).
    #[cfg_attr(feature = "openapi", schema(value_type = String))]
    pub observer: Observer,
    pub scenes: Vec<SceneStatus>,
}

/// The overview of `scenes` in `booth`, with `observer`, each scene's
/// codings from its summary in `comparisons` (one per scene, in order).
pub async fn scenes_overview(
    store: &Store,
    scenes: &[SceneInfo],
    comparisons: &[Arc<SceneComparisons>],
    booth: &Booth,
    observer: Observer,
) -> Result<ScenesOverview, StoreError> {
    let mut out = Vec::with_capacity(scenes.len());
    for (s, summary) in scenes.iter().zip(comparisons) {
        let complete = store
            .list_measurements(&MeasurementFilter {
                booth: Some(booth.clone()),
                scene: Some(s.id.clone()),
                state: Some(MeasurementState::Complete),
                limit: Some(MEASUREMENTS_READ),
                ..MeasurementFilter::default()
            })
            .await?;
        let measured: Vec<String> = s
            .targets
            .iter()
            .filter(|t| complete.items.iter().any(|m| m.target.as_deref() == Some(t.as_str())))
            .cloned()
            .collect();
        let last_measured_at = complete
            .items
            .iter()
            .filter_map(|m| m.finished_at)
            .fold(None, |a: Option<f64>, t| Some(a.map_or(t, |a| a.max(t))));
        let codings = summary
            .codings
            .iter()
            .map(|c| CodingFigures {
                colour: crate::charts::coding_colour_hex(&c.coding).unwrap_or_else(|| "#6e6e6e".into()),
                coding: c.coding.clone(),
                points: c.summary.points,
                mean_de00: c.summary.mean_de00,
                rms_rel: c.summary.rms_rel,
            })
            .collect();
        out.push(SceneStatus {
            scene: s.id.clone(),
            title: s.title.clone(),
            targets: s.targets.clone(),
            measured,
            last_measured_at,
            preview_render_id: store.latest_preview_render(&s.id).await?,
            codings,
        });
    }
    Ok(ScenesOverview {
        booth: booth.to_string(),
        observer,
        scenes: out,
    })
}
