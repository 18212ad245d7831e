//! Triangles for the RADIANCE surfaces the renderer has no analytic shape
//! for (cones, cups, rings with a hole) and for every emitting surface
//! (area lights are triangles, [`crate::lights::area`]).
//!
//! Approximations, stated:
//! - polygons are fan-triangulated from their first vertex; a concave
//!   polygon (a fan triangle facing against the polygon's normal) is
//!   refused rather than filled wrongly;
//! - circles (cylinders, tubes, cones, cups, rings) are regular polygons of
//!   [`SEGMENTS`] sides inscribed in the circle: the surface lies at most
//!   r·(1 − cos(π/256)) = 7.5·10⁻⁵·r inside the true one and its area is
//!   short by a fraction 1 − sin(2π/256)/(2π/256) ≈ 1.0·10⁻⁴;
//! - spheres (emitting ones) are icospheres of [`SPHERE_LEVELS`]
//!   subdivisions (5120 triangles) scaled so their area is the sphere's
//!   4πr² exactly: an emitting sphere sends out exactly the sphere's power;
//!   its vertices lie 0.2 % outside the radius, its face centres at most
//!   0.3 % inside.
//!
//! Every triangle is wound so its normal ((p1 − p0) × (p2 − p0)) points to
//! the surface's front: out of spheres, cylinders and cones, into bubbles,
//! tubes and cups, along a ring's normal, along a polygon's vertex order.

use glam::DVec3;

use crate::geometry::{basis, icosphere};

/// Sides of the regular polygon standing for a circle.
pub const SEGMENTS: usize = 256;

/// Subdivisions of the icosahedron standing for an emitting sphere.
pub const SPHERE_LEVELS: usize = 4;

pub type Triangle = [DVec3; 3];

fn normal(t: &Triangle) -> DVec3 {
    (t[1] - t[0]).cross(t[2] - t[0])
}

/// `t`, or `t` reversed, whichever faces `towards`.
fn facing(t: Triangle, towards: DVec3) -> Triangle {
    if normal(&t).dot(towards) >= 0.0 {
        t
    } else {
        [t[0], t[2], t[1]]
    }
}

/// A flat polygon as a fan from vertex 0; zero-area fan triangles (repeated
/// or collinear vertices) are dropped. A fan triangle wound against the
/// polygon's normal means the fan would cover area outside the polygon (it
/// is concave as seen from vertex 0): refused.
pub fn polygon(v: &[DVec3]) -> Result<Vec<Triangle>, String> {
    if v.len() < 3 {
        return Err(format!("has {} vertices; a polygon needs at least 3", v.len()));
    }
    // Newell's normal: the polygon's area vector, whatever its shape.
    let mut area = DVec3::ZERO;
    for i in 0..v.len() {
        let (a, b) = (v[i], v[(i + 1) % v.len()]);
        area += a.cross(b);
    }
    let extent = v.iter().map(|p| (*p - v[0]).length()).fold(0.0, f64::max);
    if area.length() <= 1e-12 * extent * extent || !area.is_finite() {
        return Err("has no area (its vertices are collinear or repeat)".into());
    }
    let mut out = Vec::new();
    for i in 1..v.len() - 1 {
        let t = [v[0], v[i], v[i + 1]];
        let n = normal(&t);
        if n.length() <= 1e-12 * extent * extent {
            continue;
        }
        if n.dot(area) < 0.0 {
            return Err(format!(
                "is concave at vertex {} (lightbooth fan-triangulates polygons from vertex 0): \
                 split it into convex polygons",
                i + 1
            ));
        }
        out.push(t);
    }
    Ok(out)
}

/// The lateral surface of a cone frustum from `p0` (radius `r0`) to `p1`
/// (radius `r1`); a cylinder when r0 = r1. Normals point away from the axis
/// (`inward`: towards it).
pub fn cone(p0: DVec3, p1: DVec3, r0: f64, r1: f64, inward: bool) -> Vec<Triangle> {
    let axis = (p1 - p0).normalize();
    let (u, w) = basis(axis);
    let ring = |c: DVec3, r: f64| -> Vec<DVec3> {
        (0..SEGMENTS)
            .map(|k| {
                let a = 2.0 * std::f64::consts::PI * k as f64 / SEGMENTS as f64;
                c + (u * a.cos() + w * a.sin()) * r
            })
            .collect()
    };
    let (a, b) = (ring(p0, r0), ring(p1, r1));
    let mut out = Vec::new();
    for k in 0..SEGMENTS {
        let k1 = (k + 1) % SEGMENTS;
        let mid = (a[k] + a[k1] + b[k] + b[k1]) / 4.0;
        let radial = {
            let q = mid - p0;
            q - axis * q.dot(axis)
        };
        // The outward normal of a frustum tilts along the axis by the slope.
        let out_dir = radial.normalize_or_zero() + axis * ((r0 - r1) / (p1 - p0).length());
        let want = if inward { -out_dir } else { out_dir };
        for t in [[a[k], a[k1], b[k1]], [a[k], b[k1], b[k]]] {
            if normal(&t).length() > 0.0 {
                out.push(facing(t, want));
            }
        }
    }
    out
}

/// The annulus r0 ≤ |p − centre| ≤ r1 in the plane normal to `n` (unit),
/// facing along `n`; a disc when r0 = 0.
pub fn ring(centre: DVec3, n: DVec3, r0: f64, r1: f64) -> Vec<Triangle> {
    let (u, w) = basis(n);
    let at = |k: usize, r: f64| {
        let a = 2.0 * std::f64::consts::PI * k as f64 / SEGMENTS as f64;
        centre + (u * a.cos() + w * a.sin()) * r
    };
    let mut out = Vec::new();
    for k in 0..SEGMENTS {
        let k1 = (k + 1) % SEGMENTS;
        if r0 == 0.0 {
            out.push(facing([centre, at(k, r1), at(k1, r1)], n));
        } else {
            out.push(facing([at(k, r0), at(k, r1), at(k1, r1)], n));
            out.push(facing([at(k, r0), at(k1, r1), at(k1, r0)], n));
        }
    }
    out
}

/// A sphere as an icosphere of the sphere's area, facing out (`inward`: in).
pub fn sphere(centre: DVec3, radius: f64, inward: bool) -> Vec<Triangle> {
    let (v, f) = icosphere(SPHERE_LEVELS);
    let unit_area: f64 = f
        .iter()
        .map(|t| normal(&[v[t[0]], v[t[1]], v[t[2]]]).length() / 2.0)
        .sum();
    let k = radius * (4.0 * std::f64::consts::PI / unit_area).sqrt();
    f.iter()
        .map(|t| {
            let tri = [v[t[0]], v[t[1]], v[t[2]]].map(|p| centre + p * k);
            let out = (tri[0] + tri[1] + tri[2]) / 3.0 - centre;
            facing(tri, if inward { -out } else { out })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn area(ts: &[Triangle]) -> f64 {
        ts.iter().map(|t| normal(t).length() / 2.0).sum()
    }

    #[test]
    fn areas_and_orientations_are_as_stated() {
        let s = sphere(DVec3::new(1.0, 2.0, 3.0), 0.5, false);
        assert!((area(&s) / (PI) - 1.0).abs() < 1e-12);
        for t in &s {
            let c = (t[0] + t[1] + t[2]) / 3.0 - DVec3::new(1.0, 2.0, 3.0);
            assert!(normal(t).dot(c) > 0.0);
            assert!((c.length() / 0.5 - 1.0).abs() < 3e-3);
        }
        let b = sphere(DVec3::ZERO, 1.0, true);
        assert!(b.iter().all(|t| normal(t).dot(t[0]) < 0.0));

        // Cylinder of radius 1, length 2: area 4π, short by ~1e-4.
        let c = cone(DVec3::ZERO, DVec3::new(0.0, 0.0, 2.0), 1.0, 1.0, false);
        assert!((area(&c) / (4.0 * PI) - 1.0).abs() < 2e-4, "{}", area(&c));
        assert!(c.iter().all(|t| normal(t).dot(DVec3::new(t[0].x, t[0].y, 0.0)) > 0.0));
        let tube = cone(DVec3::ZERO, DVec3::new(0.0, 0.0, 2.0), 1.0, 1.0, true);
        assert!(tube
            .iter()
            .all(|t| normal(t).dot(DVec3::new(t[0].x, t[0].y, 0.0)) < 0.0));
        // A cone of radius 1 and height 1: lateral area π·r·slant = π√2.
        let k = cone(DVec3::ZERO, DVec3::Z, 1.0, 0.0, false);
        assert!((area(&k) / (PI * 2f64.sqrt()) - 1.0).abs() < 2e-4);
        assert!(k.iter().all(|t| normal(t).z > 0.0));

        let r = ring(DVec3::ZERO, DVec3::Z, 0.5, 1.0);
        assert!((area(&r) / (PI * 0.75) - 1.0).abs() < 2e-4);
        assert!(r.iter().all(|t| normal(t).z > 0.0));
    }

    #[test]
    fn polygons_fan_and_refuse_concave_ones() {
        let square = [DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y];
        let t = polygon(&square).unwrap();
        assert_eq!(t.len(), 2);
        assert!((area(&t) - 1.0).abs() < 1e-15 && t.iter().all(|t| normal(t).z > 0.0));
        // An L-shape whose fan from vertex 0 folds back over its last triangle.
        let l = [
            DVec3::new(0.0, 1.0, 0.0),
            DVec3::new(0.0, 2.0, 0.0),
            DVec3::new(2.0, 2.0, 0.0),
            DVec3::new(2.0, 0.0, 0.0),
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(1.0, 1.0, 0.0),
        ];
        assert!(polygon(&l).unwrap_err().contains("concave"));
        assert!(polygon(&[DVec3::ZERO, DVec3::X, DVec3::X * 2.0])
            .unwrap_err()
            .contains("no area"));
    }
}
