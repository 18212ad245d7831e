//! The scene file as written: serde structs of the TOML, one per table,
//! every one refusing unknown keys. Numbers are still in the file's
//! `units`; [`SceneFile::convert_to_metres`] converts every length once, before
//! anything else reads them.

use std::collections::BTreeMap;

use serde::Deserialize;

pub(super) type V3 = [f64; 3];

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct SceneFile {
    pub name: String,
    #[serde(default)]
    #[allow(dead_code)]
    pub description: Option<String>,
    /// "m" (default), "cm" or "mm": the unit of every coordinate and length.
    pub units: Option<String>,
    pub radiometer: RadiometerFile,
    #[serde(default, rename = "target")]
    pub targets: Vec<TargetFile>,
    #[serde(default)]
    pub materials: BTreeMap<String, MaterialFile>,
    #[serde(default, rename = "light")]
    pub lights: Vec<LightFile>,
    #[serde(default, rename = "quad")]
    pub quads: Vec<QuadFile>,
    #[serde(default, rename = "disc")]
    pub discs: Vec<DiscFile>,
    #[serde(default, rename = "cylinder")]
    pub cylinders: Vec<CylinderFile>,
    #[serde(default, rename = "sphere")]
    pub spheres: Vec<SphereFile>,
    #[serde(default, rename = "box")]
    pub boxes: Vec<BoxFile>,
    #[serde(default, rename = "chart")]
    pub charts: Vec<ChartFile>,
    #[serde(default, rename = "polygon")]
    pub polygons: Vec<PolygonFile>,
    #[serde(default, rename = "mesh")]
    pub meshes: Vec<MeshFile>,
    #[serde(default, rename = "radiance")]
    pub radiance: Vec<RadianceFile>,
    pub camera: Option<CameraFile>,
    pub cielab_white: Option<CielabWhiteFile>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct CielabWhiteFile {
    pub target: Option<String>,
    pub scene: Option<String>,
    #[serde(default)]
    pub light_on_perfect_diffuser: bool,
    pub point: Option<V3>,
    pub normal: Option<V3>,
    pub xyz: Option<V3>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RadiometerFile {
    pub position: V3,
    #[serde(default = "one_degree")]
    pub field_deg: f64,
}

fn one_degree() -> f64 {
    1.0
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct TargetFile {
    pub id: String,
    pub point: V3,
}

/// A spectrum: a flat number, `FILE.csv:COLUMN` relative to the scene (it
/// must cover 380–780 nm), or a table naming how to continue it outside its
/// range.
#[derive(Deserialize, Clone, Debug)]
#[serde(
    untagged,
    expecting = "a spectrum: a number, \"FILE.csv:COLUMN\" or { csv = \"FILE.csv:COLUMN\", outside = \"hold\" | \"zero\" }"
)]
pub(super) enum SpectrumRef {
    Flat(f64),
    File(String),
    Extended(ExtendedRef),
}

/// `{ csv = "FILE.csv:COLUMN", outside = "hold" | "zero" }` (for a chart's
/// table, `csv` names the whole file).
#[derive(Deserialize, Clone, Debug)]
#[serde(deny_unknown_fields)]
pub(super) struct ExtendedRef {
    pub csv: String,
    pub outside: Outside,
}

/// How a spectrum continues outside its measured range.
#[derive(Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub(super) enum Outside {
    /// Below the first sample its value, above the last its value.
    Hold,
    /// Zero outside.
    Zero,
}

/// A material: `{ reflectance = … }` is Lambertian; `type` names one of
/// RADIANCE's glossy materials, which take `specularity` and `roughness`
/// (`plastic`, `metal`) or nothing more (`mirror`).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct MaterialFile {
    #[serde(rename = "type", default)]
    pub kind: MaterialKind,
    pub reflectance: SpectrumRef,
    pub specularity: Option<f64>,
    pub roughness: Option<f64>,
}

/// How a material scatters (`type = "…"`).
#[derive(Deserialize, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub(super) enum MaterialKind {
    #[default]
    Lambertian,
    Plastic,
    Metal,
    Mirror,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct LightFile {
    pub id: String,
    pub position: V3,
    /// Required with `ies` and with `cone_deg`; an isotropic light has none.
    pub aim: Option<V3>,
    /// Direction of the C = 0 half-plane; only needed for IES tables that
    /// are not rotationally symmetric.
    pub c0: Option<V3>,
    pub ies: Option<String>,
    /// A plain luminaire: this many candela (instead of `ies`).
    pub intensity_cd: Option<f64>,
    pub cone_deg: Option<f64>,
    pub falloff_deg: Option<f64>,
    /// × the IES file's candela (default 1).
    pub intensity_scale: Option<f64>,
    pub blackbody_k: Option<f64>,
    pub spd: Option<SpectrumRef>,
    pub filter: Option<SpectrumRef>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct QuadFile {
    #[allow(dead_code)]
    pub name: Option<String>,
    pub corner: V3,
    pub edge_u: V3,
    pub edge_v: V3,
    pub material: String,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct DiscFile {
    #[allow(dead_code)]
    pub name: Option<String>,
    pub centre: V3,
    pub normal: V3,
    pub radius: f64,
    pub material: String,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct CylinderFile {
    #[allow(dead_code)]
    pub name: Option<String>,
    pub from: V3,
    pub to: V3,
    pub radius: f64,
    /// Close both ends with discs of the same material (then it is a solid).
    #[serde(default)]
    pub caps: bool,
    pub material: String,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct SphereFile {
    #[allow(dead_code)]
    pub name: Option<String>,
    pub centre: V3,
    pub radius: f64,
    /// "solid" (default: a light inside is an error) or "room" (an
    /// enclosure lit from inside, like an integrating sphere).
    #[serde(default = "solid")]
    pub interior: String,
    pub material: String,
}

fn solid() -> String {
    "solid".into()
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct BoxFile {
    #[allow(dead_code)]
    pub name: Option<String>,
    pub min: V3,
    pub max: V3,
    pub material: String,
}

/// A ColorChecker Classic: 4 rows × 6 columns of square patches in chart
/// order (row 1: patches 1–6 … row 4: 19–24), laid out so that the centre of
/// `measured_patch` is at `measured_point`. Patches lie in the plane of the
/// measured point; the card behind them is 0.5 mm further back along
/// −normal so the two never coincide.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct ChartFile {
    /// A CSV with the 24 patch reflectances as columns 1–24, in chart order.
    pub reflectances: TableRef,
    pub measured_patch: usize,
    pub measured_point: V3,
    /// Unit normal of the chart's face.
    pub normal: V3,
    /// Direction of the rows (left to right as seen from the front).
    pub right: V3,
    /// Card width × height.
    pub card_size: [f64; 2],
    pub card_reflectance: SpectrumRef,
    pub patch_size: f64,
    pub pitch: f64,
    /// Put a square standard of this size and reflectance in place of the measured patch.
    pub replace_measured: Option<ReplacementFile>,
}

/// A whole CSV of spectra: `"FILE.csv"` or `{ csv = "FILE.csv", outside = … }`.
#[derive(Deserialize, Clone, Debug)]
#[serde(
    untagged,
    expecting = "a spectra table: \"FILE.csv\" or { csv = \"FILE.csv\", outside = \"hold\" | \"zero\" }"
)]
pub(super) enum TableRef {
    File(String),
    Extended(ExtendedRef),
}

impl TableRef {
    pub fn file(&self) -> &str {
        match self {
            TableRef::File(f) => f,
            TableRef::Extended(e) => &e.csv,
        }
    }

    /// The reference to one column, with this table's rule for the outside.
    pub fn column(&self, column: &str) -> SpectrumRef {
        match self {
            TableRef::File(f) => SpectrumRef::File(format!("{f}:{column}")),
            TableRef::Extended(e) => SpectrumRef::Extended(ExtendedRef {
                csv: format!("{}:{column}", e.csv),
                outside: e.outside,
            }),
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct ReplacementFile {
    pub size: f64,
    pub reflectance: SpectrumRef,
}

/// A flat polygon, fan-triangulated from its first vertex.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct PolygonFile {
    pub name: Option<String>,
    pub vertices: Vec<V3>,
    /// Required unless the polygon emits (then it defaults to black).
    pub material: Option<String>,
    pub emission: Option<EmissionFile>,
    /// Emit on both sides (default: only along the normal of the vertex order).
    pub two_sided: Option<bool>,
}

/// A triangle mesh from an OBJ or PLY file.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct MeshFile {
    pub name: Option<String>,
    pub file: String,
    /// Material of faces without an OBJ `usemtl` (required for PLY).
    pub material: Option<String>,
    pub scale: Option<Scale>,
    pub rotate_deg: Option<V3>,
    pub translate: Option<V3>,
    pub emission: Option<EmissionFile>,
    pub two_sided: Option<bool>,
}

/// A RADIANCE scene file (`[[radiance]]`), read by [`crate::radiance`].
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RadianceFile {
    pub file: String,
    /// The unit of the file's coordinates: "m", "cm" or "mm" (default: the
    /// scene's `units`).
    pub units: Option<String>,
}

/// A mesh's scale: one factor or one per axis.
#[derive(Deserialize, Clone, Copy, Debug)]
#[serde(untagged, expecting = "a scale: a number or [x, y, z]")]
pub(super) enum Scale {
    Uniform(f64),
    Axes(V3),
}

/// An area light's emission: `radiance`, or `luminance_cd_m2` with the
/// spectrum's shape from `spd` or `blackbody_k`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct EmissionFile {
    pub radiance: Option<SpectrumRef>,
    pub luminance_cd_m2: Option<f64>,
    pub spd: Option<SpectrumRef>,
    pub blackbody_k: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct CameraFile {
    pub position: V3,
    pub look_at: V3,
    #[serde(default = "y_up")]
    pub up: V3,
    pub fov_deg: f64,
    pub width: u32,
    pub height: u32,
}

fn y_up() -> V3 {
    [0.0, 1.0, 0.0]
}

fn scaled(v: &mut V3, k: f64) {
    for c in v {
        *c *= k;
    }
}

impl SceneFile {
    /// Multiplies every coordinate and length by `k` (metres per file
    /// unit). Directions, angles, spectra and photometric quantities stay.
    /// Mesh vertices are converted where the mesh is read, after its own
    /// `scale` and rotation (`translate` is converted here).
    pub fn convert_to_metres(&mut self, k: f64) {
        if k == 1.0 {
            return;
        }
        scaled(&mut self.radiometer.position, k);
        for t in &mut self.targets {
            scaled(&mut t.point, k);
        }
        for l in &mut self.lights {
            scaled(&mut l.position, k);
        }
        for q in &mut self.quads {
            scaled(&mut q.corner, k);
            scaled(&mut q.edge_u, k);
            scaled(&mut q.edge_v, k);
        }
        for d in &mut self.discs {
            scaled(&mut d.centre, k);
            d.radius *= k;
        }
        for c in &mut self.cylinders {
            scaled(&mut c.from, k);
            scaled(&mut c.to, k);
            c.radius *= k;
        }
        for s in &mut self.spheres {
            scaled(&mut s.centre, k);
            s.radius *= k;
        }
        for b in &mut self.boxes {
            scaled(&mut b.min, k);
            scaled(&mut b.max, k);
        }
        for c in &mut self.charts {
            scaled(&mut c.measured_point, k);
            c.card_size[0] *= k;
            c.card_size[1] *= k;
            c.patch_size *= k;
            c.pitch *= k;
            if let Some(r) = &mut c.replace_measured {
                r.size *= k;
            }
        }
        for p in &mut self.polygons {
            for v in &mut p.vertices {
                scaled(v, k);
            }
        }
        for m in &mut self.meshes {
            if let Some(t) = &mut m.translate {
                scaled(t, k);
            }
        }
        if let Some(c) = &mut self.camera {
            scaled(&mut c.position, k);
            scaled(&mut c.look_at, k);
        }
        if let Some(w) = &mut self.cielab_white {
            if let Some(p) = &mut w.point {
                scaled(p, k);
            }
        }
    }
}
