//! The analytic surfaces of the scene format: `[[quad]]`, `[[disc]]`,
//! `[[cylinder]]`, `[[sphere]]`, `[[box]]` and the ColorChecker `[[chart]]`
//! (see [`super::file::ChartFile`]), with the solids they enclose.

use glam::DVec3;

use super::file::{ChartFile, SceneFile};
use super::{positive, unit, Loader, Primitive, SceneError};
use crate::geometry::{box_faces, Shape, Solid};
use lightbooth_science::spectrum::SpectralUnit;

/// Adds every analytic surface of `raw` (in metres) to `primitives`.
pub(super) fn add_analytic(
    l: &mut Loader,
    raw: &SceneFile,
    primitives: &mut Vec<Primitive>,
    solids: &mut Vec<Solid>,
) -> Result<(), SceneError> {
    let surface = |shape, material| Primitive {
        shape,
        material,
        emitter: None,
    };
    for (i, q) in raw.quads.iter().enumerate() {
        let material = l.material(&q.material, &format!("quad[{i}].material"))?;
        let (u, v) = (DVec3::from(q.edge_u), DVec3::from(q.edge_v));
        if u.cross(v).length() < 1e-12 {
            return Err(l.err(format!("quad[{i}].edge_v"), "the edges are parallel or zero"));
        }
        primitives.push(surface(Shape::quad(DVec3::from(q.corner), u, v), material));
    }
    for (i, d) in raw.discs.iter().enumerate() {
        let material = l.material(&d.material, &format!("disc[{i}].material"))?;
        let shape = Shape::Disc {
            centre: DVec3::from(d.centre),
            normal: unit(d.normal, l, &format!("disc[{i}].normal"))?,
            radius: positive(d.radius, l, &format!("disc[{i}].radius"))?,
        };
        primitives.push(surface(shape, material));
    }
    for (i, c) in raw.cylinders.iter().enumerate() {
        let material = l.material(&c.material, &format!("cylinder[{i}].material"))?;
        let (from, to) = (DVec3::from(c.from), DVec3::from(c.to));
        let axis = unit((to - from).to_array(), l, &format!("cylinder[{i}].to"))?;
        let length = (to - from).length();
        let radius = positive(c.radius, l, &format!("cylinder[{i}].radius"))?;
        let side = Shape::Cylinder {
            base: from,
            axis,
            length,
            radius,
        };
        primitives.push(surface(side, material));
        if c.caps {
            for (centre, normal) in [(from, -axis), (to, axis)] {
                primitives.push(surface(Shape::Disc { centre, normal, radius }, material));
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
        let radius = positive(s.radius, l, &format!("sphere[{i}].radius"))?;
        primitives.push(surface(Shape::Sphere { centre, radius }, material));
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
            primitives.push(surface(shape, material));
        }
        solids.push(Solid::Box { min, max });
    }
    for (i, c) in raw.charts.iter().enumerate() {
        add_chart(l, primitives, c, i)?;
    }
    Ok(())
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
        .table(c.reflectances.file(), &table_key)?
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
                &c.reflectances.column(&columns[patch - 1]),
                SpectralUnit::Reflectance,
                &table_key,
            )?;
            let m = l.add_material(&format!("chart{i}.{}", columns[patch - 1]), s);
            (quad(centre + offset(patch), c.patch_size, c.patch_size), m)
        };
        primitives.push(Primitive {
            shape,
            material,
            emitter: None,
        });
    }
    Ok(())
}
