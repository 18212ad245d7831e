//! A scene's comparisons summarised per coding, as the API, its CSV and MAT
//! files and the scene's charts give them: the newest comparison of every
//! (target, coding) of one observer, and each coding's rms_rel and mean ± SD
//! of ΔE over the scene's targets ([`lightbooth_science::comparison::summarize`]).
//!
//! Only rows of the asked observer are summarised: rows of another (from a
//! run with another `--observer`) are never summarised or charted with them.

use lightbooth_science::colorimetry::{Observer, Xyz};
use lightbooth_science::comparison::{mean_sd, summarize, PointDifference, SceneSummary};
use lightbooth_store::{ComparisonRow, Store, StoreError};

/// One coding's figures of merit over a scene's targets.
pub struct CodingSummary {
    /// The coding, as the rows name it (`rgb`, `nstep9`, …).
    pub coding: String,
    pub summary: SceneSummary,
    /// Mean Y ratio rendered/measured.
    pub mean_y_ratio: f64,
}

/// A scene's newest comparisons and their summary per coding.
pub struct SceneComparisons {
    pub scene: String,
    /// The observer of every row and summary.
    pub observer: Observer,
    /// One per coding, in the study's order ([`coding_order`]).
    pub codings: Vec<CodingSummary>,
    /// The newest comparison of every (target, coding).
    pub rows: Vec<ComparisonRow>,
}

/// The newest comparisons of `scene` with `observer`, summarised per coding.
pub async fn scene_comparisons(store: &Store, scene: &str, observer: Observer) -> Result<SceneComparisons, StoreError> {
    let rows: Vec<ComparisonRow> = store
        .latest_comparisons(scene)
        .await?
        .into_iter()
        .filter(|r| r.observer == observer)
        .collect();
    Ok(summarise(scene, observer, rows))
}

/// The summary per coding of `rows` (all of `observer`).
fn summarise(scene: &str, observer: Observer, rows: Vec<ComparisonRow>) -> SceneComparisons {
    let mut codings: Vec<String> = rows.iter().map(|r| r.coding.clone()).collect();
    codings.sort_by_key(|c| coding_order(c));
    codings.dedup();
    let codings = codings
        .into_iter()
        .map(|coding| {
            let points: Vec<PointDifference> = rows.iter().filter(|r| r.coding == coding).map(point_of).collect();
            let (mean_y_ratio, _) = mean_sd(points.iter().map(|p| p.y_ratio));
            CodingSummary {
                coding,
                summary: summarize(&points),
                mean_y_ratio,
            }
        })
        .collect();
    SceneComparisons {
        scene: scene.to_string(),
        observer,
        codings,
        rows,
    }
}

/// A stored comparison row as the figures of merit it holds.
fn point_of(r: &ComparisonRow) -> PointDifference {
    PointDifference {
        observer: r.observer,
        measured: Xyz::new(r.measured_X, r.measured_Y, r.measured_Z),
        rendered: Xyz::new(r.rendered_X, r.rendered_Y, r.rendered_Z),
        y_ratio: r.Y_ratio,
        xy_distance: r.xy_distance,
        de76: r.dE76,
        de00: r.dE00,
    }
}

/// Sorts codings as the study lists them: rgb, srgb, nstepN by N, spectral
/// (an unknown name after every N-step).
pub fn coding_order(c: &str) -> (u32, u32) {
    match c {
        "rgb" => (0, 0),
        "srgb" => (1, 0),
        "spectral" => (3, 0),
        other => (
            2,
            other
                .strip_prefix("nstep")
                .and_then(|n| n.parse().ok())
                .unwrap_or(u32::MAX),
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codings_sort_as_the_study_lists_them_with_n_step_by_its_number() {
        let mut codings = vec!["spectral", "nstep16", "rgb", "nstep3", "srgb", "nstep9"];
        codings.sort_by_key(|c| coding_order(c));
        assert_eq!(codings, ["rgb", "srgb", "nstep3", "nstep9", "nstep16", "spectral"]);
    }
}
