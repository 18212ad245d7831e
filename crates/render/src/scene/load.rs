//! Loading a scene file into the model of [`super`]: the TOML parsed
//! (no key unknown, no number non-finite or beyond
//! [`MAX_SCENE_NUMBER`]), every file it names read, every value checked,
//! each error naming the file, the line and the key.

use super::*;

/// What loading accumulates: the materials, the spectra tables read and
/// every file the scene depends on.
pub(super) struct Loader {
    pub(super) file: String,
    pub(super) dir: PathBuf,
    pub(super) files: Vec<PathBuf>,
    pub(super) tables: HashMap<PathBuf, SpectraTable>,
    pub(super) materials: Vec<Material>,
    pub(super) material_index: HashMap<String, usize>,
    /// The black material of emitting surfaces without one, once added.
    pub(super) black: Option<usize>,
    /// Which of the files the scene names errors may quote.
    pub(super) quoting: crate::input_file::Quoting,
}

impl Loader {
    pub(super) fn err(&self, key: impl Into<String>, message: impl Into<String>) -> SceneError {
        SceneError {
            file: self.file.clone(),
            key: key.into(),
            message: message.into(),
        }
    }

    pub(super) fn add_material(&mut self, name: &str, reflectance: Spectrum) -> usize {
        self.materials.push(Material::lambertian(name, reflectance));
        let i = self.materials.len() - 1;
        self.material_index.insert(name.to_string(), i);
        i
    }

    pub(super) fn material(&self, name: &str, key: &str) -> Result<usize, SceneError> {
        self.material_index.get(name).copied().ok_or_else(|| {
            self.err(
                key,
                format!(
                    "no material `{name}`; [materials] has: {}",
                    self.material_index.keys().cloned().collect::<Vec<_>>().join(", ")
                ),
            )
        })
    }

    /// The material of an emitting surface that names none: reflectance 0.
    pub(super) fn black(&mut self) -> usize {
        if let Some(i) = self.black {
            return i;
        }
        let zero = Spectrum::constant(Grid::analysis(), SpectralUnit::Reflectance, 0.0).expect("0 is a reflectance");
        self.materials.push(Material::lambertian("(black emitter)", zero));
        self.black = Some(self.materials.len() - 1);
        self.materials.len() - 1
    }
}

pub(super) fn unit(v: V3, loader: &Loader, key: &str) -> Result<DVec3, SceneError> {
    let d = DVec3::from(v);
    if !d.is_finite() || d.length() < 1e-12 {
        return Err(loader.err(key, "must be a non-zero direction"));
    }
    Ok(d.normalize())
}

pub(super) fn positive(v: f64, loader: &Loader, key: &str) -> Result<f64, SceneError> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(loader.err(key, format!("must be positive, is {v}")))
    }
}

/// Metres per unit of `units`.
pub(super) fn metres_per_unit(units: Option<&str>) -> Option<f64> {
    match units.unwrap_or("m") {
        "m" => Some(1.0),
        "cm" => Some(0.01),
        "mm" => Some(0.001),
        _ => None,
    }
}

/// Loads and validates a scene file.
pub fn load_scene(path: &Path) -> Result<Scene, SceneError> {
    let file = path.display().to_string();
    let text = crate::input_file::read_text(path).map_err(|e| SceneError {
        file: file.clone(),
        key: "(file)".into(),
        message: e.reason,
    })?;
    let syntax = |e: toml::de::Error| SceneError {
        file: file.clone(),
        key: "(syntax)".into(),
        message: e.to_string().trim_end().replace('\n', "\n  "),
    };
    let tree: toml::Table = toml::from_str(&text).map_err(syntax)?;
    if let Some((key, v)) = first_non_finite(&toml::Value::Table(tree), String::new()) {
        let message = if v.is_finite() {
            format!(
                "{v:e} is beyond ±{MAX_SCENE_NUMBER:e}, the largest magnitude a scene number may have \
                 (MAX_SCENE_NUMBER; larger numbers overflow once multiplied): check the number and its unit"
            )
        } else {
            format!("{v} is not a finite number")
        };
        return Err(SceneError {
            file: file.clone(),
            key,
            message,
        });
    }
    let de = toml::Deserializer::parse(&text).map_err(syntax)?;
    let mut raw: SceneFile = serde_path_to_error::deserialize(de).map_err(|e| {
        let key = e.path().to_string();
        SceneError {
            key: if key == "." { "(syntax)".into() } else { key },
            ..syntax(e.into_inner())
        }
    })?;
    let mut l = Loader {
        file,
        dir: path.parent().map(Path::to_path_buf).unwrap_or_default(),
        files: vec![path.to_path_buf()],
        tables: HashMap::new(),
        materials: Vec::new(),
        material_index: HashMap::new(),
        black: None,
        quoting: crate::input_file::Quoting::for_scene(path),
    };
    let units = metres_per_unit(raw.units.as_deref()).ok_or_else(|| {
        l.err(
            "units",
            format!(
                "`{}`: expected \"m\", \"cm\" or \"mm\"",
                raw.units.as_deref().unwrap_or_default()
            ),
        )
    })?;
    raw.convert_to_metres(units);

    for (name, m) in &raw.materials {
        let key = format!("materials.{name}.reflectance");
        let r = l.spectrum(&m.reflectance, SpectralUnit::Reflectance, &key)?;
        let surface = surface(m, name, &l)?;
        let i = l.add_material(name, r);
        l.materials[i].surface = surface;
    }
    // The names OBJ `usemtl` may use: [materials] only.
    let declared = l.material_index.clone();

    let mut primitives = Vec::new();
    let mut solids = Vec::new();
    let mut emitters = Vec::new();
    analytic::add_analytic(&mut l, &raw, &mut primitives, &mut solids)?;
    for (i, p) in raw.polygons.iter().enumerate() {
        triangles::add_polygon(&mut l, p, i, &mut primitives, &mut emitters)?;
    }
    for (i, m) in raw.meshes.iter().enumerate() {
        triangles::add_mesh(&mut l, m, i, units, &declared, &mut primitives, &mut emitters)?;
    }
    for (i, r) in raw.radiance.iter().enumerate() {
        rad_import::add_radiance(&mut l, r, i, units, &mut primitives, &mut emitters)?;
    }

    let mut lights = Vec::new();
    for (i, lf) in raw.lights.iter().enumerate() {
        lights.push(lights::load_light(&mut l, lf, i)?);
    }
    for (i, light) in lights.iter().enumerate() {
        if let Some(s) = solids.iter().find(|s| s.contains(light.position)) {
            return Err(l.err(
                format!("light[{i}].position"),
                format!("light `{}` is inside geometry ({s:?})", light.id),
            ));
        }
        if let Some(p) = primitives
            .iter()
            .find(|p| p.shape.distance_to(light.position) < TARGET_TOLERANCE_M)
        {
            return Err(l.err(
                format!("light[{i}].position"),
                format!("light `{}` lies on a surface ({:?})", light.id, p.shape),
            ));
        }
    }

    let radiometer = Radiometer {
        position: DVec3::from(raw.radiometer.position),
        field_deg: positive(raw.radiometer.field_deg, &l, "radiometer.field_deg")?,
    };
    if raw.targets.is_empty() {
        return Err(l.err("target", "the scene names no measurement target"));
    }
    let mut target_list: Vec<Target> = Vec::new();
    for (i, t) in raw.targets.iter().enumerate() {
        let key = format!("target[{i}] ({})", t.id);
        if target_list.iter().any(|o| o.id == t.id) {
            return Err(l.err(key, "duplicate target id"));
        }
        let point = DVec3::from(t.point);
        let nearest = primitives
            .iter()
            .map(|p| p.shape.distance_to(point))
            .fold(f64::INFINITY, f64::min);
        if nearest > TARGET_TOLERANCE_M {
            return Err(l.err(
                format!("{key}.point"),
                format!("{point} is not on a surface (nearest is {nearest:.6} m away)"),
            ));
        }
        target_list.push(Target {
            id: t.id.clone(),
            point,
        });
    }

    let camera = match &raw.camera {
        None => None,
        Some(c) => Some(load_camera(&l, c)?),
    };

    let cielab_white = raw
        .cielab_white
        .as_ref()
        .map(|w| cielab_white(w, &l, &target_list, &emitters))
        .transpose()?;
    // Made before the loader's files move into the scene.
    let white_not_finite = l.err(
        "cielab_white.point",
        "the lights' radiance on the diffuser here is not a finite number (a light is too close \
         to the point, or too intense): move the point away from the lights",
    );
    let scene = Scene {
        cielab_white,
        name: raw.name,
        path: path.to_path_buf(),
        materials: l.materials,
        primitives,
        solids,
        lights,
        emitters,
        radiometer,
        target_list,
        camera,
        files: l.files,
        bvh: Default::default(),
    };
    // The white the light collection gives (`crate::lights`), refused
    // where it is not a number.
    if let Some(CielabWhite::LightOnPerfectDiffuser { point, normal }) = &scene.cielab_white {
        if scene
            .perfect_diffuser_radiance(*point, *normal)
            .iter()
            .any(|v| !v.is_finite())
        {
            return Err(white_not_finite);
        }
    }
    Ok(scene)
}

/// The [`Surface`] of `[materials] name`: `specularity` in [0, 1] and
/// `roughness` ≥ 0 for `plastic` and `metal` (both required), neither for
/// a Lambertian material or a `mirror`.
pub(super) fn surface(m: &file::MaterialFile, name: &str, l: &Loader) -> Result<Surface, SceneError> {
    use file::MaterialKind;
    let key = |k: &str| format!("materials.{name}.{k}");
    if matches!(m.kind, MaterialKind::Lambertian | MaterialKind::Mirror) {
        for (k, v) in [("specularity", m.specularity), ("roughness", m.roughness)] {
            if v.is_some() {
                return Err(l.err(
                    key(k),
                    "only `plastic` and `metal` materials take it (set `type = \"plastic\"` or \"metal\")",
                ));
            }
        }
        return Ok(if m.kind == MaterialKind::Mirror {
            Surface::Mirror
        } else {
            Surface::Lambertian
        });
    }
    let specularity = m
        .specularity
        .ok_or_else(|| l.err(key("specularity"), "is required for plastic and metal (0–1)"))?;
    if !(0.0..=1.0).contains(&specularity) {
        return Err(l.err(key("specularity"), format!("must be in [0, 1], is {specularity}")));
    }
    let roughness = m.roughness.ok_or_else(|| {
        l.err(
            key("roughness"),
            "is required for plastic and metal (≥ 0; 0 is a polished surface)",
        )
    })?;
    if roughness < 0.0 {
        return Err(l.err(key("roughness"), format!("must be ≥ 0, is {roughness}")));
    }
    Ok(if m.kind == MaterialKind::Plastic {
        Surface::Plastic { specularity, roughness }
    } else {
        Surface::Metal { specularity, roughness }
    })
}

/// Checks `[cielab_white]`: exactly one kind, its keys complete and no key
/// of another kind.
pub(super) fn cielab_white(
    w: &CielabWhiteFile,
    l: &Loader,
    targets: &[Target],
    emitters: &[Emitter],
) -> Result<CielabWhite, SceneError> {
    let kinds = [w.target.is_some(), w.light_on_perfect_diffuser, w.xyz.is_some()];
    if kinds.iter().filter(|k| **k).count() != 1 {
        return Err(l.err(
            "cielab_white",
            "give exactly one of `target` (with optional `scene`), `light_on_perfect_diffuser = true` \
             (with `point` and `normal`) or `xyz`",
        ));
    }
    let stray = |key: &str, present: bool, kind: &str| {
        if present {
            Err(l.err(format!("cielab_white.{key}"), format!("only used with {kind}")))
        } else {
            Ok(())
        }
    };
    if let Some(target) = &w.target {
        stray("point", w.point.is_some(), "light_on_perfect_diffuser")?;
        stray("normal", w.normal.is_some(), "light_on_perfect_diffuser")?;
        if w.scene.is_none() && !targets.iter().any(|t| &t.id == target) {
            let ids: Vec<&str> = targets.iter().map(|t| t.id.as_str()).collect();
            return Err(l.err(
                "cielab_white.target",
                format!("no target `{target}` in this scene (targets: {})", ids.join(", ")),
            ));
        }
        return Ok(CielabWhite::Target {
            scene: w.scene.clone(),
            target: target.clone(),
        });
    }
    stray("scene", w.scene.is_some(), "target")?;
    if w.light_on_perfect_diffuser {
        if let Some(e) = emitters.first() {
            return Err(l.err(
                "cielab_white.light_on_perfect_diffuser",
                format!(
                    "knows only point luminaires, and this scene has area lights ({}): \
                     use `target = \"…\"` (a white target of the scene) instead",
                    e.name
                ),
            ));
        }
        let point = w
            .point
            .ok_or_else(|| l.err("cielab_white.point", "light_on_perfect_diffuser needs a point"))?;
        let normal = w
            .normal
            .ok_or_else(|| l.err("cielab_white.normal", "light_on_perfect_diffuser needs a normal"))?;
        return Ok(CielabWhite::LightOnPerfectDiffuser {
            point: DVec3::from(point),
            normal: unit(normal, l, "cielab_white.normal")?,
        });
    }
    stray("point", w.point.is_some(), "light_on_perfect_diffuser")?;
    stray("normal", w.normal.is_some(), "light_on_perfect_diffuser")?;
    let xyz = w.xyz.expect("checked above");
    if !xyz.iter().all(|v| v.is_finite() && *v >= 0.0) || xyz[1] <= 0.0 {
        return Err(l.err("cielab_white.xyz", "must be finite, non-negative, with Y > 0"));
    }
    Ok(CielabWhite::Xyz(xyz))
}

/// The first NaN, infinity or number beyond ±[`MAX_SCENE_NUMBER`] in a
/// parsed TOML tree, with its key path.
pub(super) fn first_non_finite(v: &toml::Value, key: String) -> Option<(String, f64)> {
    match v {
        toml::Value::Float(f) if !f.is_finite() || f.abs() > MAX_SCENE_NUMBER => Some((key, *f)),
        toml::Value::Integer(i) if (*i as f64).abs() > MAX_SCENE_NUMBER => Some((key, *i as f64)),
        toml::Value::Array(items) => items
            .iter()
            .enumerate()
            .find_map(|(i, item)| first_non_finite(item, format!("{key}[{i}]"))),
        toml::Value::Table(t) => t.iter().find_map(|(k, item)| {
            let key = if key.is_empty() {
                k.clone()
            } else {
                format!("{key}.{k}")
            };
            first_non_finite(item, key)
        }),
        _ => None,
    }
}

/// A camera that can form an image: it looks somewhere, `up` is not along
/// the view, the field of view is open, the image is 1–[`MAX_IMAGE_SIDE_PX`] a side.
pub(super) fn load_camera(l: &Loader, c: &CameraFile) -> Result<Camera, SceneError> {
    let (position, look_at) = (DVec3::from(c.position), DVec3::from(c.look_at));
    let view = unit((look_at - position).to_array(), l, "camera.look_at").map_err(|_| {
        l.err(
            "camera.look_at",
            "must differ from camera.position (the camera looks nowhere)",
        )
    })?;
    let up = unit(c.up, l, "camera.up")?;
    if view.cross(up).length() < 1e-6 {
        return Err(l.err("camera.up", "is along the view direction: the image has no vertical"));
    }
    let fov_deg = positive(c.fov_deg, l, "camera.fov_deg")?;
    if fov_deg >= 180.0 {
        return Err(l.err("camera.fov_deg", format!("must be below 180, is {fov_deg}")));
    }
    for (key, side) in [("camera.width", c.width), ("camera.height", c.height)] {
        if !(1..=MAX_IMAGE_SIDE_PX).contains(&side) {
            return Err(l.err(key, format!("must be 1–{MAX_IMAGE_SIDE_PX} pixels, is {side}")));
        }
    }
    Ok(Camera {
        position,
        look_at,
        up,
        fov_deg,
        width: c.width,
        height: c.height,
    })
}
