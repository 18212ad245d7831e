//! `[[polygon]]` and `[[mesh]]` tables become triangle primitives, with
//! their materials and, for area lights, their emitters.
//!
//! A polygon's `material` is required unless it emits; an emitting surface
//! without a material is black (reflects nothing, as the Cornell box's
//! light). A mesh's faces take the material of their OBJ `usemtl`, else the
//! mesh's `material` (black if it emits and has none); a face with neither
//! is an error, and so is a `material` no face uses.

use std::collections::HashMap;

use glam::DVec3;

use super::file::{EmissionFile, MeshFile, PolygonFile, Scale};
use super::lights::load_emitter;
use super::mesh::{fan, read_mesh, triangle, Placement};
use super::{Emitter, Loader, Primitive, SceneError};
use crate::input_file::unquoted;

/// `polygon[i]` or `mesh[i]`, and its label for messages (with its name).
fn labels(kind: &str, i: usize, name: Option<&str>) -> (String, String) {
    let at = format!("{kind}[{i}]");
    let label = match name {
        Some(n) => format!("{at} (`{n}`)"),
        None => at.clone(),
    };
    (at, label)
}

/// The emitter index of a surface with `emission` (pushed to `emitters`);
/// `two_sided` without `emission` is an unused key.
fn emitter_of(
    l: &mut Loader,
    emission: Option<&EmissionFile>,
    two_sided: Option<bool>,
    at: &str,
    label: &str,
    emitters: &mut Vec<Emitter>,
) -> Result<Option<usize>, SceneError> {
    match emission {
        Some(e) => {
            let emitter = load_emitter(l, e, at, label.to_string(), two_sided.unwrap_or(false))?;
            emitters.push(emitter);
            Ok(Some(emitters.len() - 1))
        }
        None if two_sided.is_some() => Err(l.err(
            format!("{at}.two_sided"),
            "only used with `emission` (which sides of an area light emit)",
        )),
        None => Ok(None),
    }
}

pub(super) fn add_polygon(
    l: &mut Loader,
    p: &PolygonFile,
    i: usize,
    primitives: &mut Vec<Primitive>,
    emitters: &mut Vec<Emitter>,
) -> Result<(), SceneError> {
    let (at, label) = labels("polygon", i, p.name.as_deref());
    if p.vertices.len() < 3 {
        return Err(l.err(
            format!("{at}.vertices"),
            format!("{label} has {} vertices; a polygon needs at least 3", p.vertices.len()),
        ));
    }
    let emitter = emitter_of(l, p.emission.as_ref(), p.two_sided, &at, &label, emitters)?;
    let material = match (&p.material, emitter) {
        (Some(name), _) => l.material(name, &format!("{at}.material"))?,
        (None, Some(_)) => l.black(),
        (None, None) => {
            return Err(l.err(
                format!("{at}.material"),
                format!("{label} needs a material (only an emitting polygon may omit it: it is then black)"),
            ))
        }
    };
    let v: Vec<DVec3> = p.vertices.iter().map(|v| DVec3::from(*v)).collect();
    for [a, b, c] in fan(v.len()) {
        let shape = triangle([v[a], v[b], v[c]], false).ok_or_else(|| {
            l.err(
                format!("{at}.vertices[{c}]"),
                format!(
                    "{label}: triangle (v{a}, v{b}, v{c}) of the fan from vertex 0 has zero area \
                     (vertex {c} = {} lies on the line through v{a} = {} and v{b} = {}, or repeats one)",
                    v[c], v[a], v[b]
                ),
            )
        })?;
        primitives.push(Primitive {
            shape,
            material,
            emitter,
        });
    }
    Ok(())
}

pub(super) fn add_mesh(
    l: &mut Loader,
    m: &MeshFile,
    i: usize,
    units: f64,
    declared: &HashMap<String, usize>,
    primitives: &mut Vec<Primitive>,
    emitters: &mut Vec<Emitter>,
) -> Result<(), SceneError> {
    let (at, label) = labels("mesh", i, m.name.as_deref());
    let scale_ok = match m.scale {
        None => true,
        Some(Scale::Uniform(k)) => k != 0.0,
        Some(Scale::Axes(s)) => s.iter().all(|k| *k != 0.0),
    };
    if !scale_ok {
        return Err(l.err(format!("{at}.scale"), "must be non-zero on every axis"));
    }
    let path = l.dir.join(&m.file);
    let quote = l.quoting.may_quote(&path);
    let groups = read_mesh(&path, &m.file, declared, quote).map_err(|e| l.err(format!("{at}.file"), e))?;
    l.files.push(path);
    let emitter = emitter_of(l, m.emission.as_ref(), m.two_sided, &at, &label, emitters)?;
    let fallback = match (&m.material, emitter) {
        (Some(name), _) => Some(l.material(name, &format!("{at}.material"))?),
        (None, Some(_)) => Some(l.black()),
        (None, None) => None,
    };
    let placement = Placement::new(m.scale, m.rotate_deg, m.translate, units);
    let mut fallback_used = false;
    let mut count = 0usize;
    for g in &groups {
        let material = match &g.material {
            Some(name) => declared[name],
            None => {
                fallback_used = true;
                fallback.ok_or_else(|| {
                    l.err(
                        format!("{at}.material"),
                        format!(
                            "{label}: faces of `{}` in {} have no material: give the mesh a `material`, \
                             or a `usemtl` naming one of [materials] before them",
                            g.object, m.file
                        ),
                    )
                })?
            }
        };
        let p: Vec<DVec3> = g.positions.iter().map(|v| placement.apply(*v)).collect();
        if let Some(k) = p.iter().position(|v| !v.is_finite()) {
            return Err(l.err(
                format!("{at}.file"),
                format!(
                    "{}: vertex {} is not a finite number once placed (its coordinates × `scale` × the \
                     units overflow): check the mesh's numbers and `scale`",
                    m.file,
                    k + 1
                ),
            ));
        }
        primitives.reserve(g.indices.len() / 3);
        for (f, poly) in g.polygons().enumerate() {
            for [a, b, c] in fan(poly.len()) {
                let corners = [p[poly[a] as usize], p[poly[b] as usize], p[poly[c] as usize]];
                let shape = triangle(corners, placement.mirrors).ok_or_else(|| {
                    if !quote {
                        return l.err(
                            format!("{at}.file"),
                            format!(
                                "{}: face {}: {}",
                                m.file,
                                f + 1,
                                unquoted("a triangle of its fan has zero area")
                            ),
                        );
                    }
                    l.err(
                        format!("{at}.file"),
                        format!(
                            "{}: `{}`, face {}: triangle (v{a}, v{b}, v{c}) of its fan has zero area \
                             (corners {}, {}, {} m once placed)",
                            m.file,
                            g.object,
                            f + 1,
                            corners[0],
                            corners[1],
                            corners[2]
                        ),
                    )
                })?;
                primitives.push(Primitive {
                    shape,
                    material,
                    emitter,
                });
                count += 1;
            }
        }
    }
    if count == 0 {
        return Err(l.err(format!("{at}.file"), format!("{} has no faces", m.file)));
    }
    if m.material.is_some() && !fallback_used {
        return Err(l.err(
            format!("{at}.material"),
            format!("unused: every face of {} has a `usemtl` material", m.file),
        ));
    }
    Ok(())
}
