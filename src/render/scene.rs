//! The scene format: human-edited TOML, spectra from CSV files, luminaires
//! from IES LM-63 files, all paths relative to the scene file.
//!
//! Loading validates everything a render would otherwise get silently wrong,
//! pbrt-style: an unused (unknown) key is an error, and so are a missing file
//! or column, a reflectance outside [0, 1], a target not on a surface and a
//! light inside a solid. Each error names the file and the key.
//!
//! ```toml
//! name = "example"
//! [radiometer]
//! position = [0.0, 1.0, 1.0]   # m
//! field_deg = 1.0               # full angle of the circular field
//! [[target]]
//! id = "centre"
//! point = [0.0, 0.0, 0.0]
//! [materials]
//! grey = { reflectance = 0.2 }                              # flat
//! green = { reflectance = "spectra/cc.csv:p14_green" }      # CSV column
//! [[light]]
//! id = "spot"
//! position = [0.0, 1.0, 0.0]
//! aim = [0.0, -1.0, 0.0]
//! ies = "luminaires/mr16_ctb.ies"   # candela
//! intensity_scale = 1.1            # × the file's candela
//! blackbody_k = 3200               # or spd = "FILE.csv:COLUMN"
//! filter = "spectra/ctb.csv:transmittance"
//! [[quad]]
//! corner = [-1.0, 0.0, -1.0]
//! edge_u = [2.0, 0.0, 0.0]
//! edge_v = [0.0, 0.0, 2.0]
//! material = "grey"
//! ```
//!
//! # The CIELAB reference white: `[cielab_white]`
//!
//! Every comparison of the scene goes through CIELAB with this white. Exactly
//! one of:
//!
//! ```toml
//! [cielab_white]
//! target = "patch"                  # a target of this scene …
//! # scene = "white"                 # … or of another scene in the same folder
//!
//! # light_on_perfect_diffuser = true   # the scene's lights on a perfect
//! # point = [0.0, 1.0, -0.6]           # (ρ = 1) Lambertian diffuser at point,
//! # normal = [0.0, 0.7071, 0.7071]     # facing normal: direct light, no occlusion
//!
//! # xyz = [32.5, 34.2, 12.0]           # an explicit absolute XYZ, cd/m²
//! ```
//!
//! A target white is the newest complete measurement of that target (until
//! there is one, its converged `spectral` rendering stands in, and the
//! comparison says so). The diffuser white is L(λ) = Σ_lights I(λ, toward
//! the point)·cos θ / (π d²), computed from the scene without shadows or
//! interreflections. A scene without the key has no declared white, and the
//! study refuses it.
//!
//! Other primitives: `[[disc]]` (centre, normal, radius), `[[cylinder]]`
//! (from, to, radius, caps), `[[sphere]]` (centre, radius, interior =
//! "solid" | "room"), `[[box]]` (min, max) and `[[chart]]`, a ColorChecker
//! laid out from its measured patch (see [`ChartFile`]). An optional
//! `[camera]` gives the dashboard view.
//!
//! Every number must be finite: `nan` or `inf` anywhere in the file is an
//! error naming its key (`light[0].position[1]`). A camera must look
//! somewhere (`look_at` ≠ `position`), with `up` not along the view
//! direction and 0 < `fov_deg` < 180.
//!
//! Limits (errors, not clamps): a camera image is at most
//! [`MAX_IMAGE_SIDE_PX`] pixels a side; a render traces at most
//! [`MAX_SAMPLES_PER_TARGET`] paths per target, [`MAX_PIXEL_SAMPLES`] paths
//! per pixel and [`MAX_BOUNCES`] bounces (`lightbooth render`, `study` and
//! the API refuse more).
//!
//! Light spectra: the SPD (a blackbody by Planck's law, or a CSV column, times
//! an optional filter transmittance) is resampled to 1 nm and scaled so that
//! 683 lm/W · Σ S(λ)·ȳ(λ)·1 nm = 1 cd, with the Judd–Vos ȳ (the renderer's
//! observer). The luminaire's intensity in W/(sr·nm) toward a direction is
//! then I_cd(direction) · S(λ), so the IES file's candela hold on the axis.

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

use glam::DVec3;
use serde::Deserialize;

use super::geometry::{box_faces, Shape, Solid};
use super::ies::IesDistribution;
use crate::colorimetry::{Cmf, KM_LM_PER_W};
use crate::spectrum::table::SpectraTable;
use crate::spectrum::{Grid, SpectralUnit, Spectrum};

/// Targets farther than this from every surface are an error, m.
pub const TARGET_TOLERANCE_M: f64 = 1e-4;

/// Largest camera image side, pixels (`[camera] width`, `height`).
pub const MAX_IMAGE_SIDE_PX: u32 = 4096;
/// Most radiometer paths per target a render may trace (`--samples`,
/// `--max-samples`, the API's `samples`): 2²⁴, what the converged reference uses.
pub const MAX_SAMPLES_PER_TARGET: u64 = 1 << 24;
/// Most paths per pixel of a camera image (`--spp`).
pub const MAX_PIXEL_SAMPLES: u32 = 65_536;
/// Most indirect bounces (`--bounces`, the API's `bounces`); the study's
/// convergence checks go to 10.
pub const MAX_BOUNCES: u32 = 64;

/// Second radiation constant c₂ = hc/k in m·K (CODATA 2018, as CIE 15:2018).
const C2_M_K: f64 = 1.438_776_877e-2;

/// A problem in a scene, naming the file and the key.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{file}: {key}: {message}")]
pub struct SceneError {
    pub file: String,
    /// The TOML key path (`materials.green.reflectance`, `light[0].ies`, …).
    pub key: String,
    pub message: String,
}

/// A Lambertian material.
#[derive(Clone, Debug)]
pub struct Material {
    pub name: String,
    /// Reflectance on its source grid (covers 380–780 nm).
    pub reflectance: Spectrum,
}

/// A surface with its material index and, for an area light, its emitter.
#[derive(Clone, Debug)]
pub struct Primitive {
    pub shape: Shape,
    pub material: usize,
    /// Index into [`Scene::emitters`] when this surface emits light (only
    /// triangles do: `[[polygon]]` and `[[mesh]]` with `emission`).
    pub emitter: Option<usize>,
}

/// The emission of an area light: every primitive with this emitter emits
/// the same spectral radiance, uniformly in direction (a Lambertian emitter).
#[derive(Clone, Debug)]
pub struct Emitter {
    /// Where it was declared (`polygon[0]`, `mesh[1]`), for messages.
    pub name: String,
    /// Spectral radiance of the emitting side, W/(sr·m²·nm), 1 nm grid 380–780 nm.
    pub radiance: Spectrum,
    /// False: emits only on the front side, along the triangle's geometric
    /// normal (the vertex order); true: both sides.
    pub two_sided: bool,
}

/// How a point luminaire's intensity depends on direction.
#[derive(Clone, Debug)]
pub enum LightDistribution {
    /// An IES LM-63 table (candela), times `Light::intensity_scale`.
    Ies(IesDistribution),
    /// `intensity_cd` in every direction within `cone_deg` of the aim (all
    /// directions when `cone_deg` is 180), falling smoothly to zero over the
    /// outer `falloff_deg` of the cone (a smoothstep in cos γ, as pbrt-v4's
    /// spotlight): I = intensity_cd · smoothstep(cos cone, cos(cone − falloff), cos γ).
    Cone {
        intensity_cd: f64,
        cone_deg: f64,
        falloff_deg: f64,
    },
}

/// A point luminaire.
#[derive(Clone, Debug)]
pub struct Light {
    pub id: String,
    pub position: DVec3,
    /// Unit aim direction: the type C nadir (γ = 0).
    pub aim: DVec3,
    /// Unit direction of C = 0, perpendicular to the aim.
    pub c0: DVec3,
    pub distribution: LightDistribution,
    /// Multiplies the distribution's candela.
    pub intensity_scale: f64,
    /// Spectral intensity per candela on the 1 nm grid, W/(sr·nm) per cd.
    pub spectrum_per_cd: Spectrum,
}

impl Light {
    /// Luminous intensity in cd toward the unit direction `dir` (from the light).
    #[inline]
    pub fn candela_toward(&self, dir: DVec3) -> f64 {
        let cos_g = dir.dot(self.aim).clamp(-1.0, 1.0);
        match &self.distribution {
            LightDistribution::Ies(table) => {
                let gamma = cos_g.acos().to_degrees();
                let c = if table.is_rotationally_symmetric() {
                    0.0
                } else {
                    let b = self.aim.cross(self.c0);
                    dir.dot(b).atan2(dir.dot(self.c0)).to_degrees()
                };
                table.candela(gamma, c) * self.intensity_scale
            }
            LightDistribution::Cone {
                intensity_cd,
                cone_deg,
                falloff_deg,
            } => {
                if *cone_deg >= 180.0 {
                    return intensity_cd * self.intensity_scale;
                }
                let cos_outer = cone_deg.to_radians().cos();
                let cos_inner = (cone_deg - falloff_deg).max(0.0).to_radians().cos();
                let f = if cos_g >= cos_inner {
                    1.0
                } else if cos_g <= cos_outer {
                    0.0
                } else {
                    let x = (cos_g - cos_outer) / (cos_inner - cos_outer);
                    x * x * (3.0 - 2.0 * x)
                };
                intensity_cd * f * self.intensity_scale
            }
        }
    }
}

/// The spectroradiometer: its position and circular field.
#[derive(Clone, Debug)]
pub struct Radiometer {
    pub position: DVec3,
    /// Full angle of the measuring field, degrees (1° for the PR-650).
    pub field_deg: f64,
}

/// A named measurement point on a surface.
#[derive(Clone, Debug)]
pub struct Target {
    pub id: String,
    pub point: DVec3,
}

/// A pinhole camera for the dashboard image.
#[derive(Clone, Debug)]
pub struct Camera {
    pub position: DVec3,
    pub look_at: DVec3,
    pub up: DVec3,
    /// Vertical field of view, degrees.
    pub fov_deg: f64,
    pub width: u32,
    pub height: u32,
}

/// A loaded, validated scene.
#[derive(Clone, Debug)]
pub struct Scene {
    pub name: String,
    pub path: PathBuf,
    pub materials: Vec<Material>,
    pub primitives: Vec<Primitive>,
    pub solids: Vec<Solid>,
    /// Point luminaires.
    pub lights: Vec<Light>,
    /// Area lights' emission, referenced by [`Primitive::emitter`].
    pub emitters: Vec<Emitter>,
    pub radiometer: Radiometer,
    pub target_list: Vec<Target>,
    pub camera: Option<Camera>,
    /// The scene file and every file it references, for content hashing.
    pub files: Vec<PathBuf>,
    /// The CIELAB reference white the scene declares (`[cielab_white]`).
    pub cielab_white: Option<CielabWhite>,
    /// The bounding volume hierarchy over `primitives`, built by the first
    /// render that needs one and shared by later renders and clones (rebuilt
    /// if the primitives change; see [`super::bvh::BvhCache`]).
    pub bvh: super::bvh::BvhCache,
}

/// A scene's CIELAB reference white, as its file declares it.
#[derive(Clone, Debug, PartialEq)]
pub enum CielabWhite {
    /// A target of this scene (`scene` = `None`) or of the scene file
    /// `scene`.toml in the same folder.
    Target { scene: Option<String>, target: String },
    /// The scene's lights on a perfect Lambertian diffuser at `point` facing
    /// `normal` (direct light only, no occlusion).
    LightOnPerfectDiffuser { point: DVec3, normal: DVec3 },
    /// An explicit absolute XYZ (cd/m²).
    Xyz([f64; 3]),
}

impl Scene {
    /// The target ids, in file order.
    pub fn targets(&self) -> Vec<&str> {
        self.target_list.iter().map(|t| t.id.as_str()).collect()
    }

    pub fn target(&self, id: &str) -> Option<&Target> {
        self.target_list.iter().find(|t| t.id == id)
    }
}

// ---- the file format -------------------------------------------------------

type V3 = [f64; 3];

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    name: String,
    #[serde(default)]
    #[allow(dead_code)]
    description: Option<String>,
    radiometer: RadiometerFile,
    #[serde(default, rename = "target")]
    targets: Vec<TargetFile>,
    #[serde(default)]
    materials: BTreeMap<String, MaterialFile>,
    #[serde(default, rename = "light")]
    lights: Vec<LightFile>,
    #[serde(default, rename = "quad")]
    quads: Vec<QuadFile>,
    #[serde(default, rename = "disc")]
    discs: Vec<DiscFile>,
    #[serde(default, rename = "cylinder")]
    cylinders: Vec<CylinderFile>,
    #[serde(default, rename = "sphere")]
    spheres: Vec<SphereFile>,
    #[serde(default, rename = "box")]
    boxes: Vec<BoxFile>,
    #[serde(default, rename = "chart")]
    charts: Vec<ChartFile>,
    camera: Option<CameraFile>,
    cielab_white: Option<CielabWhiteFile>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CielabWhiteFile {
    target: Option<String>,
    scene: Option<String>,
    #[serde(default)]
    light_on_perfect_diffuser: bool,
    point: Option<V3>,
    normal: Option<V3>,
    xyz: Option<V3>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RadiometerFile {
    position: V3,
    #[serde(default = "one_degree")]
    field_deg: f64,
}

fn one_degree() -> f64 {
    1.0
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TargetFile {
    id: String,
    point: V3,
}

/// A spectrum: a flat number or `FILE.csv:COLUMN` relative to the scene.
#[derive(Deserialize, Clone)]
#[serde(untagged)]
enum SpectrumRef {
    Flat(f64),
    File(String),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialFile {
    reflectance: SpectrumRef,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LightFile {
    id: String,
    position: V3,
    aim: V3,
    /// Direction of the C = 0 half-plane; only needed for tables that are
    /// not rotationally symmetric.
    c0: Option<V3>,
    ies: String,
    #[serde(default = "unit_scale")]
    intensity_scale: f64,
    blackbody_k: Option<f64>,
    spd: Option<String>,
    filter: Option<SpectrumRef>,
}

fn unit_scale() -> f64 {
    1.0
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct QuadFile {
    #[allow(dead_code)]
    name: Option<String>,
    corner: V3,
    edge_u: V3,
    edge_v: V3,
    material: String,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct DiscFile {
    #[allow(dead_code)]
    name: Option<String>,
    centre: V3,
    normal: V3,
    radius: f64,
    material: String,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CylinderFile {
    #[allow(dead_code)]
    name: Option<String>,
    from: V3,
    to: V3,
    radius: f64,
    /// Close both ends with discs of the same material (then it is a solid).
    #[serde(default)]
    caps: bool,
    material: String,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SphereFile {
    #[allow(dead_code)]
    name: Option<String>,
    centre: V3,
    radius: f64,
    /// "solid" (default: a light inside is an error) or "room" (an
    /// enclosure lit from inside, like an integrating sphere).
    #[serde(default = "solid")]
    interior: String,
    material: String,
}

fn solid() -> String {
    "solid".into()
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct BoxFile {
    #[allow(dead_code)]
    name: Option<String>,
    min: V3,
    max: V3,
    material: String,
}

/// A ColorChecker Classic: 4 rows × 6 columns of square patches in chart
/// order (row 1: patches 1–6 … row 4: 19–24), laid out so that the centre of
/// `measured_patch` is at `measured_point`. Patches lie in the plane of the
/// measured point; the card behind them is 0.5 mm further back along
/// −normal so the two never coincide.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ChartFile {
    /// A CSV with the 24 patch reflectances as columns 1–24, in chart order.
    reflectances: String,
    measured_patch: usize,
    measured_point: V3,
    /// Unit normal of the chart's face.
    normal: V3,
    /// Direction of the rows (left to right as seen from the front).
    right: V3,
    /// Card width × height, m.
    card_size: [f64; 2],
    card_reflectance: SpectrumRef,
    patch_size: f64,
    pitch: f64,
    /// Put a square standard of this size and reflectance in place of the measured patch.
    replace_measured: Option<ReplacementFile>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ReplacementFile {
    size: f64,
    reflectance: SpectrumRef,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraFile {
    position: V3,
    look_at: V3,
    #[serde(default = "y_up")]
    up: V3,
    fov_deg: f64,
    width: u32,
    height: u32,
}

fn y_up() -> V3 {
    [0.0, 1.0, 0.0]
}

// ---- loading ---------------------------------------------------------------

struct Loader {
    file: String,
    dir: PathBuf,
    files: Vec<PathBuf>,
    tables: HashMap<PathBuf, SpectraTable>,
    materials: Vec<Material>,
    material_index: HashMap<String, usize>,
}

impl Loader {
    fn err(&self, key: impl Into<String>, message: impl Into<String>) -> SceneError {
        SceneError {
            file: self.file.clone(),
            key: key.into(),
            message: message.into(),
        }
    }

    fn table(&mut self, rel: &str, key: &str) -> Result<&SpectraTable, SceneError> {
        let path = self.dir.join(rel);
        if !self.tables.contains_key(&path) {
            let t = SpectraTable::read(&path).map_err(|e| self.err(key, e.to_string()))?;
            self.files.push(path.clone());
            self.tables.insert(path.clone(), t);
        }
        Ok(&self.tables[&path])
    }

    /// A spectrum reference in `unit`, checked to cover 380–780 nm.
    fn spectrum(&mut self, r: &SpectrumRef, unit: SpectralUnit, key: &str) -> Result<Spectrum, SceneError> {
        let s = match r {
            SpectrumRef::Flat(v) => {
                Spectrum::constant(Grid::analysis(), unit, *v).map_err(|e| self.err(key, e.to_string()))?
            }
            SpectrumRef::File(spec) => {
                let (file, column) = spec
                    .rsplit_once(':')
                    .ok_or_else(|| self.err(key, format!("`{spec}`: expected FILE.csv:COLUMN or a number")))?;
                let (file, column) = (file.to_string(), column.to_string());
                let t = self.table(&file, key)?;
                let s = t.spectrum(&column, unit);
                s.map_err(|e| self.err(key, e.to_string()))?
            }
        };
        if !s.grid().covers(380.0, 780.0) {
            return Err(self.err(
                key,
                format!("the spectrum's grid {} does not cover 380–780 nm", s.grid()),
            ));
        }
        Ok(s)
    }

    fn add_material(&mut self, name: &str, reflectance: Spectrum) -> usize {
        self.materials.push(Material {
            name: name.to_string(),
            reflectance,
        });
        let i = self.materials.len() - 1;
        self.material_index.insert(name.to_string(), i);
        i
    }

    fn material(&self, name: &str, key: &str) -> Result<usize, SceneError> {
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
}

fn unit(v: V3, loader: &Loader, key: &str) -> Result<DVec3, SceneError> {
    let d = DVec3::from(v);
    if !d.is_finite() || d.length() < 1e-12 {
        return Err(loader.err(key, "must be a non-zero direction"));
    }
    Ok(d.normalize())
}

fn positive(v: f64, loader: &Loader, key: &str) -> Result<f64, SceneError> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(loader.err(key, format!("must be positive, is {v}")))
    }
}

/// Loads and validates a scene file.
pub fn load_scene(path: &Path) -> Result<Scene, SceneError> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| SceneError {
        file: file.clone(),
        key: "(file)".into(),
        message: format!("cannot read: {e}"),
    })?;
    let syntax = |e: toml::de::Error| SceneError {
        file: file.clone(),
        key: "(syntax)".into(),
        message: e.to_string().trim_end().replace('\n', "\n  "),
    };
    let tree: toml::Table = toml::from_str(&text).map_err(syntax)?;
    if let Some((key, v)) = first_non_finite(&toml::Value::Table(tree), String::new()) {
        return Err(SceneError {
            file: file.clone(),
            key,
            message: format!("{v} is not a finite number"),
        });
    }
    let raw: SceneFile = toml::from_str(&text).map_err(syntax)?;
    let mut l = Loader {
        file,
        dir: path.parent().map(Path::to_path_buf).unwrap_or_default(),
        files: vec![path.to_path_buf()],
        tables: HashMap::new(),
        materials: Vec::new(),
        material_index: HashMap::new(),
    };

    for (name, m) in &raw.materials {
        let key = format!("materials.{name}.reflectance");
        let r = l.spectrum(&m.reflectance, SpectralUnit::Reflectance, &key)?;
        l.add_material(name, r);
    }

    let mut primitives = Vec::new();
    let mut solids = Vec::new();
    for (i, q) in raw.quads.iter().enumerate() {
        let material = l.material(&q.material, &format!("quad[{i}].material"))?;
        let (u, v) = (DVec3::from(q.edge_u), DVec3::from(q.edge_v));
        if u.cross(v).length() < 1e-12 {
            return Err(l.err(format!("quad[{i}].edge_v"), "the edges are parallel or zero"));
        }
        primitives.push(Primitive {
            shape: Shape::quad(DVec3::from(q.corner), u, v),
            material,
            emitter: None,
        });
    }
    for (i, d) in raw.discs.iter().enumerate() {
        let material = l.material(&d.material, &format!("disc[{i}].material"))?;
        primitives.push(Primitive {
            shape: Shape::Disc {
                centre: DVec3::from(d.centre),
                normal: unit(d.normal, &l, &format!("disc[{i}].normal"))?,
                radius: positive(d.radius, &l, &format!("disc[{i}].radius"))?,
            },
            material,
            emitter: None,
        });
    }
    for (i, c) in raw.cylinders.iter().enumerate() {
        let material = l.material(&c.material, &format!("cylinder[{i}].material"))?;
        let (from, to) = (DVec3::from(c.from), DVec3::from(c.to));
        let axis = unit((to - from).to_array(), &l, &format!("cylinder[{i}].to"))?;
        let length = (to - from).length();
        let radius = positive(c.radius, &l, &format!("cylinder[{i}].radius"))?;
        primitives.push(Primitive {
            shape: Shape::Cylinder {
                base: from,
                axis,
                length,
                radius,
            },
            material,
            emitter: None,
        });
        if c.caps {
            for (centre, normal) in [(from, -axis), (to, axis)] {
                primitives.push(Primitive {
                    shape: Shape::Disc { centre, normal, radius },
                    material,
                    emitter: None,
                });
            }
            solids.push(Solid::Cylinder {
                base: from,
                axis,
                length,
                radius,
            });
        }
    }
    for (i, s) in raw.spheres.iter().enumerate() {
        let material = l.material(&s.material, &format!("sphere[{i}].material"))?;
        let centre = DVec3::from(s.centre);
        let radius = positive(s.radius, &l, &format!("sphere[{i}].radius"))?;
        primitives.push(Primitive {
            shape: Shape::Sphere { centre, radius },
            material,
            emitter: None,
        });
        match s.interior.as_str() {
            "solid" => solids.push(Solid::Sphere { centre, radius }),
            "room" => {}
            other => {
                return Err(l.err(
                    format!("sphere[{i}].interior"),
                    format!("`{other}`: expected \"solid\" or \"room\""),
                ))
            }
        }
    }
    for (i, b) in raw.boxes.iter().enumerate() {
        let material = l.material(&b.material, &format!("box[{i}].material"))?;
        let (min, max) = (DVec3::from(b.min), DVec3::from(b.max));
        if !(max.cmpgt(min).all()) {
            return Err(l.err(format!("box[{i}].max"), "must exceed min on every axis"));
        }
        for shape in box_faces(min, max) {
            primitives.push(Primitive { shape, material, emitter: None });
        }
        solids.push(Solid::Box { min, max });
    }
    for (i, c) in raw.charts.iter().enumerate() {
        add_chart(&mut l, &mut primitives, c, i)?;
    }

    let mut lights = Vec::new();
    for (i, lf) in raw.lights.iter().enumerate() {
        lights.push(load_light(&mut l, lf, i)?);
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
        .map(|w| cielab_white(w, &l, &target_list))
        .transpose()?;

    Ok(Scene {
        cielab_white,
        name: raw.name,
        path: path.to_path_buf(),
        materials: l.materials,
        primitives,
        solids,
        lights,
        emitters: Vec::new(),
        radiometer,
        target_list,
        camera,
        files: l.files,
        bvh: Default::default(),
    })
}

/// Checks `[cielab_white]`: exactly one kind, its keys complete and no key
/// of another kind.
fn cielab_white(w: &CielabWhiteFile, l: &Loader, targets: &[Target]) -> Result<CielabWhite, SceneError> {
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

impl Scene {
    /// The spectral radiance of a perfect (ρ = 1) Lambertian diffuser at
    /// `point` facing `normal` under the scene's lights, W/(sr·m²·nm) on the
    /// 1 nm grid: L(λ) = Σ I_cd(toward the point)·S(λ)·cos θ / (π d²). Direct
    /// light only: no shadows, no interreflections (an approximation the
    /// scene's author accepts by choosing this white).
    pub fn light_on_perfect_diffuser(&self, point: DVec3, normal: DVec3) -> Spectrum {
        let mut values = vec![0.0; Grid::one_nm().len()];
        for light in &self.lights {
            let to_point = point - light.position;
            let d2 = to_point.length_squared();
            let dir = to_point / d2.sqrt();
            let cos = (-dir).dot(normal);
            if cos <= 0.0 || d2 <= 0.0 {
                continue;
            }
            let k = light.candela_toward(dir) * cos / (std::f64::consts::PI * d2);
            for (v, s) in values.iter_mut().zip(light.spectrum_per_cd.values()) {
                *v += k * s;
            }
        }
        Spectrum::new(Grid::one_nm(), SpectralUnit::SpectralRadiance, values).expect("finite radiance")
    }
}

/// The first NaN or infinity in a parsed TOML tree, with its key path.
fn first_non_finite(v: &toml::Value, key: String) -> Option<(String, f64)> {
    match v {
        toml::Value::Float(f) if !f.is_finite() => Some((key, *f)),
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
fn load_camera(l: &Loader, c: &CameraFile) -> Result<Camera, SceneError> {
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

fn load_light(l: &mut Loader, lf: &LightFile, i: usize) -> Result<Light, SceneError> {
    let key = |k: &str| format!("light[{i}].{k}");
    let aim = unit(lf.aim, l, &key("aim"))?;
    let c0 = match lf.c0 {
        Some(c) => {
            let c = DVec3::from(c);
            let perp = c - aim * c.dot(aim);
            unit(perp.to_array(), l, &key("c0"))?
        }
        None => super::geometry::basis(aim).0,
    };
    let ies_path = l.dir.join(&lf.ies);
    let distribution = IesDistribution::read(&ies_path).map_err(|e| l.err(key("ies"), e.to_string()))?;
    l.files.push(ies_path);
    if !distribution.is_rotationally_symmetric() && lf.c0.is_none() {
        return Err(l.err(
            key("c0"),
            "the IES table is not rotationally symmetric: give the C = 0 direction",
        ));
    }
    let grid = Grid::one_nm();
    let mut spd: Vec<f64> = match (lf.blackbody_k, &lf.spd) {
        (Some(t), None) => {
            let t = positive(t, l, &key("blackbody_k"))?;
            // Planck's law, relative: λ⁻⁵ / (exp(c₂/(λT)) − 1).
            grid.wavelengths()
                .iter()
                .map(|nm| {
                    let m = nm * 1e-9;
                    m.powi(-5) / ((C2_M_K / (m * t)).exp() - 1.0)
                })
                .collect()
        }
        (None, Some(spec)) => {
            let s = l.spectrum(
                &SpectrumRef::File(spec.clone()),
                SpectralUnit::RelativePower,
                &key("spd"),
            )?;
            s.resample(&grid)
                .map_err(|e| l.err(key("spd"), e.to_string()))?
                .into_values()
        }
        _ => return Err(l.err(key("spd"), "give exactly one of `blackbody_k` and `spd`")),
    };
    if let Some(f) = &lf.filter {
        let t = l.spectrum(f, SpectralUnit::Transmittance, &key("filter"))?;
        let t = t.resample(&grid).map_err(|e| l.err(key("filter"), e.to_string()))?;
        for (s, f) in spd.iter_mut().zip(t.values()) {
            *s *= f;
        }
    }
    // Normalise to 1 cd: 683 · Σ S(λ) ȳ(λ) Δλ = 1, Δλ = 1 nm, Judd–Vos ȳ.
    let ybar = &Cmf::of(super::coding::OBSERVER).on_grid(&grid)[1];
    let lum: f64 = KM_LM_PER_W * spd.iter().zip(ybar).map(|(s, y)| s * y).sum::<f64>();
    if lum.is_nan() || lum <= 0.0 {
        return Err(l.err(key("spd"), "the spectrum has no luminous power"));
    }
    let spectrum_per_cd = Spectrum::new(grid, SpectralUnit::RelativePower, spd.iter().map(|s| s / lum).collect())
        .map_err(|e| l.err(key("spd"), e.to_string()))?;
    Ok(Light {
        id: lf.id.clone(),
        position: DVec3::from(lf.position),
        aim,
        c0,
        distribution: LightDistribution::Ies(distribution),
        intensity_scale: positive(lf.intensity_scale, l, &key("intensity_scale"))?,
        spectrum_per_cd,
    })
}

fn add_chart(l: &mut Loader, primitives: &mut Vec<Primitive>, c: &ChartFile, i: usize) -> Result<(), SceneError> {
    let key = |k: &str| format!("chart[{i}].{k}");
    if !(1..=24).contains(&c.measured_patch) {
        return Err(l.err(key("measured_patch"), "must be 1–24"));
    }
    let n = unit(c.normal, l, &key("normal"))?;
    let right = unit(c.right, l, &key("right"))?;
    if right.dot(n).abs() > 1e-6 {
        return Err(l.err(key("right"), "must be perpendicular to the normal"));
    }
    let up = n.cross(right);
    let table_key = key("reflectances");
    let columns: Vec<String> = l
        .table(&c.reflectances, &table_key)?
        .names()
        .map(String::from)
        .collect();
    if columns.len() != 24 {
        return Err(l.err(table_key, format!("{} columns; a ColorChecker has 24", columns.len())));
    }
    let offset = |patch: usize| {
        let (row, col) = ((patch - 1) / 6, (patch - 1) % 6);
        right * ((col as f64 - 2.5) * c.pitch) + up * ((1.5 - row as f64) * c.pitch)
    };
    let centre = DVec3::from(c.measured_point) - offset(c.measured_patch);
    let quad =
        |middle: DVec3, w: f64, h: f64| Shape::quad(middle - right * (w / 2.0) - up * (h / 2.0), right * w, up * h);
    let card_material = format!("chart{i}.card");
    let card = l.spectrum(&c.card_reflectance, SpectralUnit::Reflectance, &key("card_reflectance"))?;
    let card_index = l.add_material(&card_material, card);
    primitives.push(Primitive {
        shape: quad(centre - n * 0.0005, c.card_size[0], c.card_size[1]),
        material: card_index,
        emitter: None,
    });
    for patch in 1..=24 {
        let replacement = c.replace_measured.as_ref().filter(|_| patch == c.measured_patch);
        let (shape, material) = if let Some(r) = replacement {
            let s = l.spectrum(
                &r.reflectance,
                SpectralUnit::Reflectance,
                &key("replace_measured.reflectance"),
            )?;
            let m = l.add_material(&format!("chart{i}.standard"), s);
            (quad(centre + offset(patch), r.size, r.size), m)
        } else {
            let s = l.spectrum(
                &SpectrumRef::File(format!("{}:{}", c.reflectances, columns[patch - 1])),
                SpectralUnit::Reflectance,
                &table_key,
            )?;
            let m = l.add_material(&format!("chart{i}.{}", columns[patch - 1]), s);
            (quad(centre + offset(patch), c.patch_size, c.patch_size), m)
        };
        primitives.push(Primitive { shape, material, emitter: None });
    }
    Ok(())
}
