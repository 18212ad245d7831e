//! Triangles of the scene: `[[polygon]]` vertex lists and `[[mesh]]` files
//! (Wavefront OBJ through `tobj`, PLY through `ply-rs-bw`), placed by the
//! mesh's `scale`, `rotate_deg` and `translate` and converted to metres.
//!
//! Every polygon (a `[[polygon]]`, an OBJ face, a PLY face) is
//! fan-triangulated from its first vertex: (v0, v1, v2), (v0, v2, v3), …;
//! the vertex order gives each triangle's front side. A degenerate (zero
//! area) triangle is an error, not a silent hole.
//!
//! OBJ: positions and faces are read; `vt`, `vn`, smoothing groups and
//! `mtllib` files are ignored (materials come from the scene's
//! `[materials]`, named by `usemtl`); `l` polylines have no area and are
//! dropped; a face of one or two vertices is an error. PLY (ASCII or
//! binary): the `vertex` element's `x`, `y`, `z` and the `face` element's
//! `vertex_indices` (or `vertex_index`) list; other elements are skipped.

use std::collections::HashMap;
use std::io::{self, BufRead, Read};
use std::path::Path;

use glam::{DMat3, DVec3};
use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{Property, PropertyAccess, PropertyAccessResult};

use super::file::{Scale, V3};
use crate::geometry::Shape;
use crate::input_file::{read_bytes, unquoted};

/// The triangles of a fan over `points`: (0, i, i + 1).
pub(super) fn fan(n: usize) -> impl Iterator<Item = [usize; 3]> {
    (1..n.saturating_sub(1)).map(|i| [0, i, i + 1])
}

/// Polygons read from a mesh file, in groups of one material.
pub(super) struct FaceGroup {
    /// The OBJ object or group (`o`, `g`), for messages.
    pub object: String,
    /// The `usemtl` name, if any.
    pub material: Option<String>,
    pub positions: Vec<DVec3>,
    /// Vertex indices into `positions`, polygon after polygon.
    pub indices: Vec<u32>,
    /// The vertex count of each polygon; empty when all are triangles.
    pub arities: Vec<u32>,
}

impl FaceGroup {
    /// Each polygon's vertex indices.
    pub fn polygons(&self) -> Box<dyn Iterator<Item = &[u32]> + '_> {
        if self.arities.is_empty() {
            Box::new(self.indices.chunks_exact(3))
        } else {
            let mut start = 0;
            Box::new(self.arities.iter().map(move |&n| {
                let p = &self.indices[start..start + n as usize];
                start += n as usize;
                p
            }))
        }
    }
}

/// Where a mesh goes: p ↦ units · (R_z R_y R_x (scale ∘ p)) + translate.
pub(super) struct Placement {
    linear: DMat3,
    translate: DVec3,
    /// The linear map mirrors (det < 0): triangles are wound the other way
    /// round so that their front side stays the same surface side.
    pub mirrors: bool,
}

impl Placement {
    /// `translate` is already in metres; `units` converts the file's coordinates.
    pub fn new(scale: Option<Scale>, rotate_deg: Option<V3>, translate: Option<V3>, units: f64) -> Placement {
        let s = match scale {
            None => DVec3::ONE,
            Some(Scale::Uniform(k)) => DVec3::splat(k),
            Some(Scale::Axes(v)) => DVec3::from(v),
        };
        let r = rotate_deg.map(DVec3::from).unwrap_or(DVec3::ZERO);
        let rotation = DMat3::from_rotation_z(r.z.to_radians())
            * DMat3::from_rotation_y(r.y.to_radians())
            * DMat3::from_rotation_x(r.x.to_radians());
        let linear = rotation * DMat3::from_diagonal(s) * units;
        Placement {
            linear,
            translate: translate.map(DVec3::from).unwrap_or(DVec3::ZERO),
            mirrors: s.x * s.y * s.z < 0.0,
        }
    }

    pub fn apply(&self, p: DVec3) -> DVec3 {
        self.linear * p + self.translate
    }
}

/// A fan triangle of a polygon, wound for `mirrors`; `None` when degenerate.
pub(super) fn triangle(p: [DVec3; 3], mirrors: bool) -> Option<Shape> {
    if mirrors {
        Shape::triangle(p[0], p[2], p[1])
    } else {
        Shape::triangle(p[0], p[1], p[2])
    }
}

/// Reads an OBJ or PLY file (by extension; bounded, a regular file:
/// [`crate::input_file`]). `known` names the scene's materials, which OBJ
/// `usemtl` may use; `shown` is the path as the scene writes it, for
/// messages (which name the line where the format has one, and quote it
/// only when `quote`: the file is inside the scene's folder).
pub(super) fn read_mesh(
    path: &Path,
    shown: &str,
    known: &HashMap<String, usize>,
    quote: bool,
) -> Result<Vec<FaceGroup>, String> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .unwrap_or_default();
    if ext != "obj" && ext != "ply" {
        return Err(format!("{shown}: unknown mesh format (expected a .obj or .ply file)"));
    }
    let bytes = read_bytes(path).map_err(|e| format!("cannot read {shown}: {}", e.reason))?;
    if ext == "obj" {
        read_obj(&bytes, shown, known, quote)
    } else {
        read_ply(&bytes, shown, quote)
    }
}

/// `{shown} line {line} (`{text}`): {message}`, or without the text and
/// the message (which may quote it) when the file may not be quoted.
fn at_line(shown: &str, line: usize, text: &str, message: &str, quote: bool) -> String {
    if quote {
        format!("{shown} line {line} (`{text}`): {message}")
    } else {
        format!("{shown} line {line}: {}", unquoted("not a usable OBJ line"))
    }
}

/// tobj reads through this: it counts lines (so errors name them), checks
/// `usemtl` names against the scene's materials and positions for finite
/// numbers, drops `l` polylines, and first hands tobj a `mtllib` line so
/// that the scene's materials are the library `usemtl` resolves against.
struct ObjLines<'a, R> {
    inner: R,
    /// The line being read, 1-based (0 before the first).
    line: usize,
    started: bool,
    text: String,
    known: &'a HashMap<String, usize>,
    problem: Option<(usize, String, String)>,
}

impl<R: BufRead> Read for ObjLines<'_, R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        self.inner.read(buf)
    }
}

impl<R: BufRead> BufRead for ObjLines<'_, R> {
    fn fill_buf(&mut self) -> io::Result<&[u8]> {
        self.inner.fill_buf()
    }

    fn consume(&mut self, amt: usize) {
        self.inner.consume(amt)
    }

    fn read_line(&mut self, buf: &mut String) -> io::Result<usize> {
        if !self.started {
            self.started = true;
            const LIBRARY: &str = "mtllib lightbooth:scene-materials\n";
            buf.push_str(LIBRARY);
            return Ok(LIBRARY.len());
        }
        self.line += 1;
        self.text.clear();
        let start = buf.len();
        let n = self.inner.read_line(buf)?;
        let line = &buf[start..];
        self.text.push_str(line.trim_end());
        let mut words = line.split_whitespace();
        let problem = match words.next() {
            Some("l") => {
                // A polyline has no area: nothing to render.
                buf.truncate(start);
                buf.push_str("#\n");
                None
            }
            Some("usemtl") => {
                // tobj's reading of the name.
                let name = line.split_once(' ').unwrap_or_default().1.trim();
                (!name.is_empty() && !self.known.contains_key(name)).then(|| {
                    let mut have: Vec<&str> = self.known.keys().map(String::as_str).collect();
                    have.sort_unstable();
                    format!(
                        "usemtl `{name}` names no material of the scene's [materials] (it has: {})",
                        have.join(", ")
                    )
                })
            }
            Some("v") => {
                let coords: Vec<Option<f64>> = words.take(3).map(|w| w.parse::<f64>().ok()).collect();
                coords
                    .iter()
                    .any(|c| c.is_some_and(|c| !c.is_finite()))
                    .then(|| "a vertex coordinate is not a finite number".to_string())
            }
            _ => None,
        };
        if let Some(p) = problem {
            self.problem = Some((self.line, self.text.clone(), p));
            return Err(io::Error::other("refused"));
        }
        Ok(n)
    }
}

fn read_obj(bytes: &[u8], shown: &str, known: &HashMap<String, usize>, quote: bool) -> Result<Vec<FaceGroup>, String> {
    let mut lines = ObjLines {
        inner: bytes,
        line: 0,
        started: false,
        text: String::new(),
        known,
        problem: None,
    };
    // The scene's materials, as the library every `mtllib` line loads.
    let mut names: Vec<(&String, &usize)> = known.iter().collect();
    names.sort_by_key(|(_, i)| **i);
    let library: Vec<tobj::Material> = names
        .iter()
        .map(|(n, _)| tobj::Material {
            name: (*n).clone(),
            ..Default::default()
        })
        .collect();
    let map: HashMap<String, usize> = library.iter().enumerate().map(|(i, m)| (m.name.clone(), i)).collect();
    let options = tobj::LoadOptions {
        single_index: false,
        triangulate: false,
        ignore_points: false,
        ignore_lines: false,
    };
    let loaded = tobj::load_obj_buf(&mut lines, &options, |_| Ok((library.clone(), map.clone())));
    let (models, materials) = match loaded {
        Ok(m) => m,
        Err(e) => {
            if let Some((line, text, message)) = lines.problem {
                return Err(at_line(shown, line, &text, &message, quote));
            }
            let out_of_bounds = matches!(
                e,
                tobj::LoadError::FaceVertexOutOfBounds
                    | tobj::LoadError::FaceTexCoordOutOfBounds
                    | tobj::LoadError::FaceNormalOutOfBounds
            );
            // tobj finds bad indices when it closes an object, past the
            // face: find the face's line again.
            if out_of_bounds {
                if let Some((line, text)) = locate_bad_index(bytes) {
                    return Err(at_line(shown, line, &text, &e.to_string(), quote));
                }
                return Err(format!("{shown}: {e}"));
            }
            return Err(at_line(shown, lines.line, &lines.text, &e.to_string(), quote));
        }
    };
    let materials = materials.map_err(|e| format!("{shown}: {e}"))?;
    let mut groups = Vec::with_capacity(models.len());
    for m in models {
        let mesh = m.mesh;
        if let Some(n) = mesh.face_arities.iter().find(|n| **n < 3) {
            let object = if quote {
                format!("object `{}`", m.name)
            } else {
                "an object".into()
            };
            return Err(format!(
                "{shown}: {object} has a face of {n} vertices; a surface needs at least 3"
            ));
        }
        groups.push(FaceGroup {
            object: m.name,
            material: mesh.material_id.map(|id| materials[id].name.clone()),
            positions: mesh
                .positions
                .chunks_exact(3)
                .map(|p| DVec3::new(p[0], p[1], p[2]))
                .collect(),
            indices: mesh.indices,
            arities: mesh.face_arities,
        });
    }
    Ok(groups)
}

/// The first OBJ face line with a vertex, texture or normal index that
/// names no element read before it (tobj's rule: 1…n, or −n…−1 from the end).
fn locate_bad_index(bytes: &[u8]) -> Option<(usize, String)> {
    let text = String::from_utf8_lossy(bytes);
    let mut counts = [0isize; 3];
    for (n, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => counts[0] += 1,
            Some("vt") => counts[1] += 1,
            Some("vn") => counts[2] += 1,
            Some("f") => {
                for w in words {
                    for (k, part) in w.split('/').enumerate().take(3) {
                        let Ok(x) = part.parse::<isize>() else { continue };
                        let ok = if x < 0 {
                            counts[k] + x >= 0
                        } else {
                            x >= 1 && x <= counts[k]
                        };
                        if !ok {
                            return Some((n + 1, line.trim_end().to_string()));
                        }
                    }
                }
            }
            _ => {}
        }
    }
    None
}

/// A PLY vertex: its position.
struct PlyVertex([Option<f64>; 3]);

impl PropertyAccess for PlyVertex {
    fn new() -> Self {
        PlyVertex([None; 3])
    }

    fn set_property(&mut self, key: &str, property: Property) -> PropertyAccessResult {
        let i = match key {
            "x" => 0,
            "y" => 1,
            "z" => 2,
            _ => return PropertyAccessResult::Ignored,
        };
        self.0[i] = match property {
            Property::Float(v) => Some(f64::from(v)),
            Property::Double(v) => Some(v),
            Property::Char(v) => Some(f64::from(v)),
            Property::UChar(v) => Some(f64::from(v)),
            Property::Short(v) => Some(f64::from(v)),
            Property::UShort(v) => Some(f64::from(v)),
            Property::Int(v) => Some(f64::from(v)),
            Property::UInt(v) => Some(f64::from(v)),
            _ => return PropertyAccessResult::UnsupportedType,
        };
        PropertyAccessResult::Set
    }
}

/// A PLY face: its vertex indices.
struct PlyFace(Option<Vec<i64>>);

impl PropertyAccess for PlyFace {
    fn new() -> Self {
        PlyFace(None)
    }

    fn set_property(&mut self, key: &str, property: Property) -> PropertyAccessResult {
        if key != "vertex_indices" && key != "vertex_index" {
            return PropertyAccessResult::Ignored;
        }
        self.0 = Some(match property {
            Property::ListChar(v) => v.into_iter().map(i64::from).collect(),
            Property::ListUChar(v) => v.into_iter().map(i64::from).collect(),
            Property::ListShort(v) => v.into_iter().map(i64::from).collect(),
            Property::ListUShort(v) => v.into_iter().map(i64::from).collect(),
            Property::ListInt(v) => v.into_iter().map(i64::from).collect(),
            Property::ListUInt(v) => v.into_iter().map(i64::from).collect(),
            _ => return PropertyAccessResult::UnsupportedType,
        });
        PropertyAccessResult::Set
    }
}

/// An element this reader has no use for (its payload is read and dropped).
struct PlyIgnored;

impl PropertyAccess for PlyIgnored {
    fn new() -> Self {
        PlyIgnored
    }
}

fn read_ply(bytes: &[u8], shown: &str, quote: bool) -> Result<Vec<FaceGroup>, String> {
    let mut reader = Reader::new(bytes);
    let fail = |e: ply_rs_bw::parser::ParseError| {
        if quote {
            return format!("{shown}: {e}");
        }
        // ply-rs names the line as `Line N`; keep that, not the rest.
        let text = e.to_string();
        let line = text
            .split_once("Line ")
            .and_then(|(_, rest)| rest.split(|c: char| !c.is_ascii_digit()).next())
            .filter(|n| !n.is_empty())
            .map(|n| format!(" line {n}"))
            .unwrap_or_default();
        format!("{shown}{line}: {}", unquoted("not a usable PLY file"))
    };
    let header = Parser::<PlyIgnored>::new().read_header(&mut reader).map_err(fail)?;
    let mut vertices: Option<Vec<PlyVertex>> = None;
    let mut faces: Option<(Vec<PlyFace>, usize)> = None;
    for (name, element) in &header.elements {
        match name.as_str() {
            "vertex" => {
                for axis in ["x", "y", "z"] {
                    if !element.properties.contains_key(axis) {
                        return Err(format!("{shown}: the vertex element has no `{axis}` property"));
                    }
                }
                let v = Parser::<PlyVertex>::new()
                    .read_payload_for_element(&mut reader, element, &header)
                    .map_err(fail)?;
                vertices = Some(v);
            }
            "face" => {
                if !element.properties.contains_key("vertex_indices")
                    && !element.properties.contains_key("vertex_index")
                {
                    return Err(format!(
                        "{shown}: the face element has no `vertex_indices` (or `vertex_index`) list"
                    ));
                }
                // The reader stands on the line after the previous element.
                let first_line = reader.line();
                let f = Parser::<PlyFace>::new()
                    .read_payload_for_element(&mut reader, element, &header)
                    .map_err(fail)?;
                faces = Some((f, first_line));
            }
            _ => {
                Parser::<PlyIgnored>::new()
                    .read_payload_for_element(&mut reader, element, &header)
                    .map_err(fail)?;
            }
        }
    }
    let vertices = vertices.ok_or_else(|| format!("{shown}: no `vertex` element"))?;
    let (faces, first_line) = faces.ok_or_else(|| format!("{shown}: no `face` element"))?;
    let ascii = matches!(header.encoding, ply_rs_bw::ply::Encoding::Ascii);
    let face_at = |i: usize| {
        if ascii {
            format!("{shown} line {} (face {i})", first_line + i)
        } else {
            format!("{shown}: face {i}")
        }
    };
    let mut positions = Vec::with_capacity(vertices.len());
    for (i, v) in vertices.iter().enumerate() {
        match v.0 {
            [Some(x), Some(y), Some(z)] if x.is_finite() && y.is_finite() && z.is_finite() => {
                positions.push(DVec3::new(x, y, z))
            }
            _ => return Err(format!("{shown}: vertex {i} has no finite x, y, z")),
        }
    }
    let mut indices = Vec::with_capacity(faces.len() * 3);
    let mut arities = Vec::with_capacity(faces.len());
    for (i, f) in faces.iter().enumerate() {
        let list = f.0.as_deref().unwrap_or_default();
        if list.len() < 3 {
            return Err(format!(
                "{}: {} vertices; a surface needs at least 3",
                face_at(i),
                list.len()
            ));
        }
        for &k in list {
            if k < 0 || k as usize >= positions.len() {
                return Err(format!(
                    "{}: vertex index {k} is not one of the {} vertices",
                    face_at(i),
                    positions.len()
                ));
            }
            indices.push(k as u32);
        }
        arities.push(list.len() as u32);
    }
    Ok(vec![FaceGroup {
        object: shown.to_string(),
        material: None,
        positions,
        indices,
        arities,
    }])
}
