//! A scene's CIELAB reference white, from its `[cielab_white]` declaration
//! (see [`crate::render::scene`]): the same rule for the study and the
//! daemon's comparisons, so a scene's comparisons never depend on
//! measurement order; and a stored measurement's XYZ, for both.
//!
//! - A target white (`target`, optionally `scene`) names a scene file and a
//!   target; the caller finds its newest complete measurement (or, until
//!   there is one, the converged rendering of it, and says so).
//! - A diffuser white (`light_on_perfect_diffuser`) and an explicit `xyz`
//!   are computed here from the scene alone.

use std::path::{Path, PathBuf};

use crate::colorimetry::{xyz_from_radiance, Observer, Xyz};
use crate::render::scene::CielabWhite;
use crate::render::{self, Scene};
use crate::spectrum::{Grid, SpectralUnit, Spectrum};
use crate::store::MeasurementDetail;

/// Where a scene's white comes from, resolved.
#[derive(Clone, Debug, PartialEq)]
pub enum SceneWhite {
    /// The newest measurement (else the converged rendering) of `target` in
    /// the scene file `scene_path` (scene id `scene_id`, its file stem).
    Target {
        scene_id: String,
        scene_path: PathBuf,
        target: String,
    },
    /// A white computed from the scene file alone; `source` says how.
    Fixed { xyz: Xyz, source: String },
}

impl SceneWhite {
    /// Whether a measurement of `scene_id`/`target` is this white's source.
    pub fn is_target(&self, scene_id: &str, target: &str) -> bool {
        matches!(self, SceneWhite::Target { scene_id: s, target: t, .. } if s == scene_id && t == target)
    }
}

/// The white `scene` (loaded from `scene_path`) declares, with `observer`
/// for a computed one. A scene without `[cielab_white]`, or one naming a
/// scene file or target that does not exist, is an error naming the file
/// and key.
pub fn scene_white(scene_path: &Path, scene: &Scene, observer: Observer) -> Result<SceneWhite, String> {
    let file = scene_path.display();
    let declared = scene.cielab_white.as_ref().ok_or_else(|| {
        format!(
            "{file}: cielab_white: the scene declares no CIELAB reference white; add a [cielab_white] table \
             (target = \"ID\", light_on_perfect_diffuser = true with point and normal, or xyz = [X, Y, Z])"
        )
    })?;
    match declared {
        CielabWhite::Target { scene: None, target } => Ok(SceneWhite::Target {
            scene_id: scene_id(scene_path),
            scene_path: scene_path.to_path_buf(),
            target: target.clone(),
        }),
        CielabWhite::Target {
            scene: Some(other),
            target,
        } => {
            let other_path = scene_path.with_file_name(format!("{other}.toml"));
            let other_scene = render::load_scene(&other_path)
                .map_err(|e| format!("{file}: cielab_white.scene: `{other}` ({}): {e}", other_path.display()))?;
            if other_scene.target(target).is_none() {
                return Err(format!(
                    "{file}: cielab_white.target: scene `{other}` has no target `{target}` (targets: {})",
                    other_scene.targets().join(", ")
                ));
            }
            Ok(SceneWhite::Target {
                scene_id: other.clone(),
                scene_path: other_path,
                target: target.clone(),
            })
        }
        CielabWhite::LightOnPerfectDiffuser { point, normal } => {
            let radiance = scene.light_on_perfect_diffuser(*point, *normal);
            let xyz = xyz_from_radiance(&radiance, observer).map_err(|e| format!("{file}: cielab_white: {e}"))?;
            Ok(SceneWhite::Fixed {
                xyz,
                source: format!(
                    "the scene's light on a perfect diffuser at ({:.4}, {:.4}, {:.4}) m ({})",
                    point.x,
                    point.y,
                    point.z,
                    scene_id(scene_path)
                ),
            })
        }
        CielabWhite::Xyz(xyz) => Ok(SceneWhite::Fixed {
            xyz: Xyz::from_array(*xyz),
            source: format!("XYZ stated in the scene file ({})", scene_id(scene_path)),
        }),
    }
}

/// A scene's id: its file stem (as the daemon names scenes).
pub fn scene_id(path: &Path) -> String {
    path.file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or_default()
        .to_string()
}

/// The XYZ of a stored measurement's mean spectral radiance with
/// `observer`; `None` when the row holds no spectrum (a measurement that
/// never completed). Used for the truth of a study against measurements and
/// for a comparison's white alike.
pub fn measured_xyz(m: &MeasurementDetail, observer: Observer) -> Result<Option<Xyz>, String> {
    let (Some(wl), Some(radiance)) = (&m.wavelength_nm, &m.radiance) else {
        return Ok(None);
    };
    let id = m.summary.id;
    let grid = Grid::from_wavelengths(wl.clone()).map_err(|e| format!("measurement {id}: {e}"))?;
    let s = Spectrum::new(grid, SpectralUnit::SpectralRadiance, radiance.clone())
        .map_err(|e| format!("measurement {id}: {e}"))?;
    xyz_from_radiance(&s, observer)
        .map(Some)
        .map_err(|e| format!("measurement {id}: {e}"))
}
