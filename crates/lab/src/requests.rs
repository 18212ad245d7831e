//! The requests the lab's render and study workflows take, and what they
//! answer about scenes: the shapes the REST API, the CLI and render workers
//! share (deserialised from JSON by the HTTP layer, checked here).

use serde::Serialize;

/// Options of a study started through the API (see `lightbooth study`).
#[derive(Clone, Debug, Default, serde::Deserialize, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(deny_unknown_fields)]
pub struct StudyRequest {
    /// Comma-separated scene ids, each named once, at most 64
    /// (`routes::MAX_STUDY_SCENES`); default: every scene.
    pub scenes: Option<String>,
    /// `measurements` (default) or `reference` (a converged spectral rendering).
    pub against: Option<String>,
    /// Seeds, 1–64 (default 8).
    #[cfg_attr(feature = "openapi", schema(minimum = 1, maximum = 64))]
    pub seeds: Option<u32>,
    /// Also sweep samples, bounces and N for the speed-against-accuracy chart.
    pub sweeps: Option<bool>,
    /// Also compute the failure maps.
    pub failure_map: Option<bool>,
    /// Also choose per scene the cheapest settings meeting this tolerance, e.g. `de00=1,rms=0.02`.
    pub auto: Option<String>,
    /// Against measurements: first measure, through the instrument queue,
    /// every target of the chosen scenes that has no complete measurement;
    /// the study waits for them (reporting progress), then runs. Without it,
    /// a study missing measurements is refused with 409 naming them.
    pub measure_missing: Option<bool>,
    /// Against measurements: the booth whose measurements (and measured
    /// CIELAB whites) the study compares with; default: the daemon's own
    /// booth (`serve --booth`). Another booth's are never used (each booth
    /// has its own lamps). The daemon stores the booth it chose.
    pub booth: Option<String>,
    /// The measurements queued for this study by `measure_missing` (set by the daemon).
    #[serde(skip_deserializing, default, skip_serializing_if = "Vec::is_empty")]
    #[cfg_attr(feature = "openapi", schema(read_only))]
    pub measured_first: Vec<i64>,
}

/// A scene as the API lists it.
#[derive(Clone, Debug, Serialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct SceneInfo {
    pub id: String,
    pub title: String,
    pub targets: Vec<String>,
}

impl SceneInfo {
    /// The target's place in the scene's own order (the cylinder's 21
    /// heights bottom to top) from 0; `usize::MAX` for a target not in it,
    /// which sorts last.
    pub fn target_index(&self, target: &str) -> usize {
        self.targets.iter().position(|t| t == target).unwrap_or(usize::MAX)
    }

    /// A target's number on a profile's x axis: 1 for the scene's first
    /// target, where the axis prints the first target's id.
    pub fn target_number(&self, target: &str) -> f64 {
        self.target_index(target) as f64 + 1.0
    }
}

/// Options of a render request.
#[derive(Clone, Debug, Default, serde::Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(deny_unknown_fields)]
pub struct RenderRequest {
    /// Comma-separated codings, e.g. `rgb,srgb,nstep3,spectral`; default: the daemon's.
    pub codings: Option<String>,
    /// Radiometer paths per target, 2–4194304 (`lab::jobs::MAX_RENDER_SAMPLES`:
    /// two paths at least for a standard error; the renderer's own cap on
    /// adaptive sampling at most).
    #[cfg_attr(feature = "openapi", schema(minimum = 2, maximum = 4_194_304))]
    pub samples: Option<u32>,
    /// A cap on indirect bounces, 0–64 (`lab::jobs::MAX_RENDER_BOUNCES`;
    /// 5 emulates RADIANCE `-ab 5`). Absent: no cap, Russian roulette ends
    /// the paths (unbiased). A capped render's result says so:
    /// `truncated_at_bounces` (`null` when uncapped) and `truncation_note`.
    #[cfg_attr(feature = "openapi", schema(minimum = 0, maximum = 64))]
    pub bounces: Option<u32>,
    /// The sampler's seed, 0–9223372036854775807 (the store keeps it as a
    /// signed 64-bit integer); default: the daemon's.
    #[cfg_attr(feature = "openapi", schema(minimum = 0, maximum = 9_223_372_036_854_775_807_i64))]
    pub seed: Option<u64>,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The profile put the first target at x = 0 under an axis reading
    /// "height 1–21 cm": target numbers start at 1, where the axis prints
    /// the first target's id.
    #[test]
    fn profile_ticks_are_not_shifted_by_one() {
        let info = SceneInfo {
            id: "cylinder".into(),
            title: "CYLINDER".into(),
            targets: (1..=21).map(|h| format!("h{h:02}")).collect(),
        };
        assert_eq!(info.target_number("h01"), 1.0);
        assert_eq!(info.target_number("h21"), 21.0);
        assert_eq!(info.target_index("h99"), usize::MAX);
    }
}
