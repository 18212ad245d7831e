//! RADIANCE scene files in scenes: `[[radiance]]` inside a TOML scene, and
//! a `.rad` file as a whole scene with the radiometer and targets given
//! separately (the command line's `--radiometer` and `--target`).

use std::path::Path;

use glam::DVec3;

use super::file::RadianceFile;
use super::{metres_per_unit, positive, Emitter, Loader, Primitive, Radiometer, Scene, SceneError, Target};
use crate::radiance::load_radiance;

/// Appends a RADIANCE file's materials, primitives and emitters.
pub(super) fn add_radiance(
    l: &mut Loader,
    r: &RadianceFile,
    i: usize,
    scene_units: f64,
    primitives: &mut Vec<Primitive>,
    emitters: &mut Vec<Emitter>,
) -> Result<(), SceneError> {
    let k = match &r.units {
        None => scene_units,
        Some(u) => metres_per_unit(Some(u)).ok_or_else(|| {
            l.err(
                format!("radiance[{i}].units"),
                format!("`{u}`: expected \"m\", \"cm\" or \"mm\""),
            )
        })?,
    };
    let path = l.dir.join(&r.file);
    let rad = load_radiance(&path, k, &l.quoting).map_err(|e| l.err(format!("radiance[{i}].file"), e.to_string()))?;
    let (m0, e0) = (l.materials.len(), emitters.len());
    l.materials.extend(rad.materials);
    emitters.extend(rad.emitters);
    primitives.extend(rad.primitives.into_iter().map(|p| Primitive {
        material: p.material + m0,
        emitter: p.emitter.map(|e| e + e0),
        ..p
    }));
    for f in rad.files {
        if !l.files.contains(&f) {
            l.files.push(f);
        }
    }
    Ok(())
}

/// Where the radiometer of a `.rad` scene stands and what it measures
/// (the `.rad` format has no such thing), in metres.
#[derive(Clone, Debug)]
pub struct RadianceView {
    pub radiometer: DVec3,
    /// Full angle of the measuring field, degrees.
    pub field_deg: f64,
    /// Named points on surfaces.
    pub targets: Vec<(String, DVec3)>,
}

/// A `.rad` file (coordinates in metres) as a scene measured as `view` says.
pub fn load_radiance_scene(path: &Path, view: &RadianceView) -> Result<Scene, SceneError> {
    let file = path.display().to_string();
    let err = |key: &str, message: String| SceneError {
        file: file.clone(),
        key: key.into(),
        message,
    };
    let quoting = crate::input_file::Quoting::for_scene(path);
    let rad = load_radiance(path, 1.0, &quoting).map_err(|e| err("(radiance)", e.to_string()))?;
    let l = Loader {
        file: file.clone(),
        dir: Default::default(),
        files: vec![],
        tables: Default::default(),
        materials: vec![],
        material_index: Default::default(),
        black: None,
        quoting,
    };
    if !view.radiometer.is_finite() {
        return Err(err(
            "--radiometer",
            format!("{} is not a finite position", view.radiometer),
        ));
    }
    let field_deg = positive(view.field_deg, &l, "--field-deg")?;
    if view.targets.is_empty() {
        return Err(err(
            "--target",
            "a .rad file names no measurement target: give at least one `--target NAME=X,Y,Z` (a point on a surface, m)"
                .into(),
        ));
    }
    let mut target_list: Vec<Target> = Vec::new();
    for (id, point) in &view.targets {
        let key = format!("--target {id}");
        if target_list.iter().any(|t| &t.id == id) {
            return Err(err(&key, "duplicate target id".into()));
        }
        let nearest = rad
            .primitives
            .iter()
            .map(|p| p.shape.distance_to(*point))
            .fold(f64::INFINITY, f64::min);
        if nearest.is_nan() || nearest > super::TARGET_TOLERANCE_M {
            return Err(err(
                &key,
                format!("{point} is not on a surface (nearest is {nearest:.6} m away)"),
            ));
        }
        target_list.push(Target {
            id: id.clone(),
            point: *point,
        });
    }
    Ok(Scene {
        name: path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| file.clone()),
        path: path.to_path_buf(),
        materials: rad.materials,
        primitives: rad.primitives,
        solids: vec![],
        lights: vec![],
        emitters: rad.emitters,
        radiometer: Radiometer {
            position: view.radiometer,
            field_deg,
        },
        target_list,
        camera: None,
        files: rad.files,
        cielab_white: None,
        bvh: Default::default(),
    })
}
