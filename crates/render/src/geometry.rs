//! Primitives and their analytic ray intersections, in metres.
//!
//! Only what the booth scenes need: parallelogram quads (planes are quads
//! bounded to the booth), discs, open finite cylinders (caps are discs),
//! spheres, boxes (six quads) and triangles (meshes and polygons). Every
//! shape has an axis-aligned bounding box ([`Shape::bounds`]) for the
//! bounding volume hierarchy of [`super::bvh`].
//!
//! Surfaces are two-sided: the shading normal is flipped to face the ray, so
//! a wall is lit from either side and the inside of a sphere is a room.

use std::collections::HashMap;

use glam::DVec3;

/// Smallest accepted hit distance in m: rays are spawned this far from their
/// surface along the normal, so self-intersection is impossible and the 0.5 mm
/// chart-patch offsets stay resolvable.
pub const RAY_EPSILON_M: f64 = 1e-7;

/// A ray: origin in m, unit direction.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    pub origin: DVec3,
    pub dir: DVec3,
}

/// An analytic surface.
#[derive(Clone, Debug)]
pub enum Shape {
    /// The parallelogram corner + s·u + t·v, s, t ∈ [0, 1]; build it with
    /// [`Shape::quad`], which precomputes n = u × v, w = n/|n|² (for the
    /// planar coordinates) and the unit normal.
    Quad {
        corner: DVec3,
        u: DVec3,
        v: DVec3,
        n: DVec3,
        w: DVec3,
        unit_normal: DVec3,
    },
    /// A flat disc.
    Disc {
        centre: DVec3,
        normal: DVec3,
        radius: f64,
    },
    /// The open side of a finite cylinder from `base` along the unit `axis`.
    Cylinder {
        base: DVec3,
        axis: DVec3,
        length: f64,
        radius: f64,
    },
    Sphere {
        centre: DVec3,
        radius: f64,
    },
    /// The triangle p0, p1, p2, intersected watertight (Woop, Benthin & Wald
    /// 2013): rays through a shared edge or vertex hit one of its triangles.
    /// Build it with [`Shape::triangle`]; `normal` is the unit geometric
    /// normal (p1 − p0) × (p2 − p0), so the vertex order gives the front side.
    Triangle {
        p0: DVec3,
        p1: DVec3,
        p2: DVec3,
        normal: DVec3,
    },
}

/// An axis-aligned box, m: the points p with min ≤ p ≤ max per axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: DVec3,
    pub max: DVec3,
}

impl Aabb {
    /// The empty box (the identity of [`Aabb::union`]).
    pub const EMPTY: Aabb = Aabb {
        min: DVec3::INFINITY,
        max: DVec3::NEG_INFINITY,
    };

    /// The smallest box holding every point.
    pub fn from_points(points: &[DVec3]) -> Aabb {
        points.iter().fold(Aabb::EMPTY, |b, &p| b.union_point(p))
    }

    #[inline]
    pub fn union(self, other: Aabb) -> Aabb {
        Aabb {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }

    #[inline]
    pub fn union_point(self, p: DVec3) -> Aabb {
        Aabb {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    #[inline]
    pub fn centroid(&self) -> DVec3 {
        (self.min + self.max) * 0.5
    }

    /// Half the surface area, m² (0 for an empty box): the SAH only needs
    /// areas up to a common factor.
    #[inline]
    pub fn half_area(&self) -> f64 {
        let d = self.max - self.min;
        if d.x < 0.0 || d.y < 0.0 || d.z < 0.0 {
            return 0.0;
        }
        d.x * d.y + d.y * d.z + d.z * d.x
    }

    /// True when `p` lies in the box (boundary included).
    pub fn contains(&self, p: DVec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }
}

/// Where a ray meets a surface.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    /// Distance along the ray, m.
    pub t: f64,
    /// Unit geometric normal (not yet flipped towards the ray).
    pub normal: DVec3,
}

/// The unit normal of the triangle (p0, p1, p2), by the right-hand rule
/// over its vertex order: `(p1 − p0) × (p2 − p0)`, normalised; `None` for a
/// degenerate triangle. [`Shape::triangle`] stores exactly this, and the BVH
/// recomputes it from the vertices it holds instead of reading the shape.
#[inline]
pub fn triangle_normal(p0: DVec3, p1: DVec3, p2: DVec3) -> Option<DVec3> {
    let n = (p1 - p0).cross(p2 - p0);
    let len = n.length();
    if !len.is_finite() || len <= 0.0 {
        return None;
    }
    Some(n / len)
}

impl Shape {
    /// The parallelogram corner + s·u + t·v.
    pub fn quad(corner: DVec3, u: DVec3, v: DVec3) -> Shape {
        let n = u.cross(v);
        Shape::Quad {
            corner,
            u,
            v,
            n,
            w: n / n.length_squared(),
            unit_normal: n.normalize(),
        }
    }

    /// The triangle p0, p1, p2; `None` when it is degenerate (zero area).
    pub fn triangle(p0: DVec3, p1: DVec3, p2: DVec3) -> Option<Shape> {
        let normal = triangle_normal(p0, p1, p2)?;
        Some(Shape::Triangle { p0, p1, p2, normal })
    }

    /// The axis-aligned bounding box. Up to rounding (a few ulps for the
    /// curved shapes, whose extents involve a square root): users that need
    /// a conservative box, such as the BVH, pad it.
    pub fn bounds(&self) -> Aabb {
        match *self {
            Shape::Quad { corner, u, v, .. } => Aabb::from_points(&[corner, corner + u, corner + v, corner + u + v]),
            Shape::Disc { centre, normal, radius } => disc_bounds(centre, normal, radius),
            Shape::Cylinder {
                base,
                axis,
                length,
                radius,
            } => {
                // The convex hull of the two rim circles: the union of the end discs' boxes.
                disc_bounds(base, axis, radius).union(disc_bounds(base + axis * length, axis, radius))
            }
            Shape::Sphere { centre, radius } => Aabb {
                min: centre - DVec3::splat(radius),
                max: centre + DVec3::splat(radius),
            },
            Shape::Triangle { p0, p1, p2, .. } => Aabb::from_points(&[p0, p1, p2]),
        }
    }

    /// The nearest hit with RAY_EPSILON_M < t < t_max.
    #[inline]
    pub fn intersect(&self, ray: &Ray, t_max: f64) -> Option<Hit> {
        match *self {
            Shape::Quad {
                corner,
                u,
                v,
                n,
                w,
                unit_normal,
            } => {
                let denom = n.dot(ray.dir);
                if denom == 0.0 {
                    return None;
                }
                let t = n.dot(corner - ray.origin) / denom;
                if !(t > RAY_EPSILON_M && t < t_max) {
                    return None;
                }
                // Barycentric-like coordinates of the planar hit (pbrt's quad test).
                let p = ray.origin + ray.dir * t - corner;
                let s = w.dot(p.cross(v));
                let tt = w.dot(u.cross(p));
                if !(0.0..=1.0).contains(&s) || !(0.0..=1.0).contains(&tt) {
                    return None;
                }
                Some(Hit { t, normal: unit_normal })
            }
            Shape::Disc { centre, normal, radius } => {
                let denom = normal.dot(ray.dir);
                if denom == 0.0 {
                    return None;
                }
                let t = normal.dot(centre - ray.origin) / denom;
                if !(t > RAY_EPSILON_M && t < t_max) {
                    return None;
                }
                let p = ray.origin + ray.dir * t;
                if (p - centre).length_squared() > radius * radius {
                    return None;
                }
                Some(Hit { t, normal })
            }
            Shape::Cylinder {
                base,
                axis,
                length,
                radius,
            } => {
                // Solve |(o + t d − base)⊥|² = r², ⊥ = perpendicular to the axis.
                let oc = ray.origin - base;
                let d_perp = ray.dir - axis * ray.dir.dot(axis);
                let o_perp = oc - axis * oc.dot(axis);
                let a = d_perp.length_squared();
                if a == 0.0 {
                    return None;
                }
                let b = 2.0 * d_perp.dot(o_perp);
                let c = o_perp.length_squared() - radius * radius;
                let disc = b * b - 4.0 * a * c;
                if disc < 0.0 {
                    return None;
                }
                let sq = disc.sqrt();
                // Numerically stable roots.
                let q = -0.5 * (b + b.signum() * sq);
                let (mut t0, mut t1) = (q / a, c / q);
                if t0 > t1 {
                    std::mem::swap(&mut t0, &mut t1);
                }
                for t in [t0, t1] {
                    if t > RAY_EPSILON_M && t < t_max {
                        let h = (oc + ray.dir * t).dot(axis);
                        if (0.0..=length).contains(&h) {
                            let normal = ((oc + ray.dir * t) - axis * h).normalize();
                            return Some(Hit { t, normal });
                        }
                    }
                }
                None
            }
            Shape::Sphere { centre, radius } => {
                let oc = ray.origin - centre;
                let b = oc.dot(ray.dir);
                let c = oc.length_squared() - radius * radius;
                let disc = b * b - c;
                if disc < 0.0 {
                    return None;
                }
                let sq = disc.sqrt();
                for t in [-b - sq, -b + sq] {
                    if t > RAY_EPSILON_M && t < t_max {
                        let normal = (ray.origin + ray.dir * t - centre) / radius;
                        return Some(Hit { t, normal });
                    }
                }
                None
            }
            Shape::Triangle { p0, p1, p2, normal } => {
                let t = intersect_triangle_watertight(ray, p0, p1, p2, t_max)?;
                Some(Hit { t, normal })
            }
        }
    }

    /// Distance from a point to this surface, m (for validating targets).
    pub fn distance_to(&self, p: DVec3) -> f64 {
        match *self {
            Shape::Quad { corner, u, v, .. } => {
                // Closest point on the parallelogram: clamp the planar coordinates,
                // then the distance to the four edges when outside.
                let n = u.cross(v).normalize();
                let d_plane = (p - corner).dot(n).abs();
                let w = u.cross(v) / u.cross(v).length_squared();
                let q = p - corner;
                let s = w.dot(q.cross(v));
                let t = w.dot(u.cross(q));
                if (0.0..=1.0).contains(&s) && (0.0..=1.0).contains(&t) {
                    return d_plane;
                }
                let edges = [(corner, u), (corner, v), (corner + u, v), (corner + v, u)];
                edges
                    .iter()
                    .map(|&(a, e)| {
                        let k = ((p - a).dot(e) / e.length_squared()).clamp(0.0, 1.0);
                        (p - (a + e * k)).length()
                    })
                    .fold(f64::INFINITY, f64::min)
            }
            Shape::Disc { centre, normal, radius } => {
                let q = p - centre;
                let h = q.dot(normal);
                let radial = (q - normal * h).length();
                if radial <= radius {
                    h.abs()
                } else {
                    (h * h + (radial - radius).powi(2)).sqrt()
                }
            }
            Shape::Cylinder {
                base,
                axis,
                length,
                radius,
            } => {
                let q = p - base;
                let h = q.dot(axis);
                let radial = (q - axis * h).length();
                let dh = if h < 0.0 {
                    -h
                } else if h > length {
                    h - length
                } else {
                    0.0
                };
                ((radial - radius).powi(2) + dh * dh).sqrt()
            }
            Shape::Sphere { centre, radius } => ((p - centre).length() - radius).abs(),
            Shape::Triangle { p0, p1, p2, .. } => (p - closest_point_on_triangle(p, p0, p1, p2)).length(),
        }
    }
}

/// The box of a circle of `radius` around `centre` in the plane with unit
/// normal `normal`: along axis i the circle reaches r·√(1 − nᵢ²).
fn disc_bounds(centre: DVec3, normal: DVec3, radius: f64) -> Aabb {
    let e = (DVec3::ONE - normal * normal).max(DVec3::ZERO);
    let half = DVec3::new(e.x.sqrt(), e.y.sqrt(), e.z.sqrt()) * radius;
    Aabb {
        min: centre - half,
        max: centre + half,
    }
}

/// The watertight ray–triangle test of Woop, Benthin & Wald (2013),
/// "Watertight Ray/Triangle Intersection", JCGT 2(1): the vertices are
/// translated to the ray origin and sheared so the ray runs along +z, and
/// the 2D edge functions U, V, W decide the hit. Along a shared edge both
/// triangles evaluate the same edge function with opposite sign, so a ray
/// there hits at least one of them (no cracks). Everything here is f64; the
/// paper's fallback to double precision for U, V or W = 0 is therefore not
/// needed. Returns t with RAY_EPSILON_M < t < t_max.
#[inline]
pub fn intersect_triangle_watertight(ray: &Ray, p0: DVec3, p1: DVec3, p2: DVec3, t_max: f64) -> Option<f64> {
    ShearedRay::new(ray).intersect_triangle(p0, p1, p2, t_max)
}

/// The per-ray part of [`intersect_triangle_watertight`]: the axis
/// permutation and shear, computed once for a ray that meets many triangles
/// (the BVH). The results are those of `intersect_triangle_watertight`,
/// bit for bit: it is this same code.
#[derive(Clone, Copy, Debug)]
pub struct ShearedRay {
    origin: DVec3,
    kx: usize,
    ky: usize,
    kz: usize,
    sx: f64,
    sy: f64,
    sz: f64,
}

impl ShearedRay {
    #[inline]
    pub fn new(ray: &Ray) -> ShearedRay {
        let d = ray.dir;
        let ad = d.abs();
        // kz: the dimension where the direction is largest; kx, ky the others,
        // swapped when d[kz] < 0 to keep the winding.
        let kz = if ad.x > ad.y {
            if ad.x > ad.z {
                0
            } else {
                2
            }
        } else if ad.y > ad.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let sz = 1.0 / d[kz];
        ShearedRay {
            origin: ray.origin,
            kx,
            ky,
            kz,
            sx: d[kx] * sz,
            sy: d[ky] * sz,
            sz,
        }
    }

    /// The watertight test of the triangle p0, p1, p2: t with
    /// RAY_EPSILON_M < t < t_max.
    #[inline]
    pub fn intersect_triangle(&self, p0: DVec3, p1: DVec3, p2: DVec3, t_max: f64) -> Option<f64> {
        let (kx, ky, kz, sx, sy, sz) = (self.kx, self.ky, self.kz, self.sx, self.sy, self.sz);
        let a = (p0 - self.origin).to_array();
        let b = (p1 - self.origin).to_array();
        let c = (p2 - self.origin).to_array();
        let (ax, ay) = (a[kx] - sx * a[kz], a[ky] - sy * a[kz]);
        let (bx, by) = (b[kx] - sx * b[kz], b[ky] - sy * b[kz]);
        let (cx, cy) = (c[kx] - sx * c[kz], c[ky] - sy * c[kz]);
        let u = cx * by - cy * bx;
        let v = ax * cy - ay * cx;
        let w = bx * ay - by * ax;
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v + w;
        if det == 0.0 {
            return None;
        }
        let (az, bz, cz) = (sz * a[kz], sz * b[kz], sz * c[kz]);
        let t_scaled = u * az + v * bz + w * cz;
        let t = t_scaled / det;
        if t > RAY_EPSILON_M && t < t_max {
            Some(t)
        } else {
            None
        }
    }
}

/// An icosahedron subdivided `levels` times and projected on the unit
/// sphere: a closed mesh of 20·4^levels triangles whose neighbours share
/// vertices exactly (for tests and benchmarks of meshes: watertightness, a
/// tessellated integrating sphere).
pub fn icosphere(levels: usize) -> (Vec<DVec3>, Vec<[usize; 3]>) {
    let g = (1.0 + 5f64.sqrt()) / 2.0;
    let mut v: Vec<DVec3> = [
        (-1.0, g, 0.0),
        (1.0, g, 0.0),
        (-1.0, -g, 0.0),
        (1.0, -g, 0.0),
        (0.0, -1.0, g),
        (0.0, 1.0, g),
        (0.0, -1.0, -g),
        (0.0, 1.0, -g),
        (g, 0.0, -1.0),
        (g, 0.0, 1.0),
        (-g, 0.0, -1.0),
        (-g, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| DVec3::new(x, y, z).normalize())
    .collect();
    let mut f: Vec<[usize; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut mid: HashMap<(usize, usize), usize> = HashMap::new();
        let mut m = |a: usize, b: usize, v: &mut Vec<DVec3>| {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                v.push(((v[a] + v[b]) * 0.5).normalize());
                v.len() - 1
            })
        };
        f = f
            .iter()
            .flat_map(|&[a, b, c]| {
                let (ab, bc, ca) = (m(a, b, &mut v), m(b, c, &mut v), m(c, a, &mut v));
                [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
            })
            .collect();
    }
    (v, f)
}

/// The point of triangle (a, b, c) closest to p (Ericson, "Real-Time
/// Collision Detection", 2005, §5.1.5).
pub fn closest_point_on_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

/// A solid whose inside is "inside geometry": a light there is an error.
#[derive(Clone, Debug)]
pub enum Solid {
    Box {
        min: DVec3,
        max: DVec3,
    },
    Sphere {
        centre: DVec3,
        radius: f64,
    },
    Cylinder {
        base: DVec3,
        axis: DVec3,
        length: f64,
        radius: f64,
    },
}

impl Solid {
    /// True when `p` is strictly inside (or on the surface within 1e-9 m).
    pub fn contains(&self, p: DVec3) -> bool {
        const EPS: f64 = 1e-9;
        match *self {
            Solid::Box { min, max } => p.cmpge(min - EPS).all() && p.cmple(max + EPS).all(),
            Solid::Sphere { centre, radius } => (p - centre).length() <= radius + EPS,
            Solid::Cylinder {
                base,
                axis,
                length,
                radius,
            } => {
                let q = p - base;
                let h = q.dot(axis);
                (-EPS..=length + EPS).contains(&h) && (q - axis * h).length() <= radius + EPS
            }
        }
    }
}

/// The six faces of an axis-aligned box as quads.
pub fn box_faces(min: DVec3, max: DVec3) -> [Shape; 6] {
    let d = max - min;
    let (x, y, z) = (DVec3::X * d.x, DVec3::Y * d.y, DVec3::Z * d.z);
    [
        Shape::quad(min, y, z),
        Shape::quad(min + x, y, z),
        Shape::quad(min, x, z),
        Shape::quad(min + y, x, z),
        Shape::quad(min, x, y),
        Shape::quad(min + z, x, y),
    ]
}

/// An orthonormal basis (t, b, n) around the unit vector n (Duff et al. 2017,
/// "Building an orthonormal basis, revisited").
#[inline]
pub fn basis(n: DVec3) -> (DVec3, DVec3) {
    let sign = 1f64.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        DVec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ray(o: [f64; 3], d: [f64; 3]) -> Ray {
        Ray {
            origin: DVec3::from(o),
            dir: DVec3::from(d).normalize(),
        }
    }

    #[test]
    fn quad_hits_inside_and_misses_outside() {
        let q = Shape::quad(
            DVec3::new(-1.0, 0.0, -1.0),
            DVec3::new(2.0, 0.0, 0.0),
            DVec3::new(0.0, 0.0, 2.0),
        );
        let h = q
            .intersect(&ray([0.5, 2.0, 0.5], [0.0, -1.0, 0.0]), f64::INFINITY)
            .unwrap();
        assert!((h.t - 2.0).abs() < 1e-12 && h.normal.y.abs() == 1.0);
        assert!(q
            .intersect(&ray([1.5, 2.0, 0.5], [0.0, -1.0, 0.0]), f64::INFINITY)
            .is_none());
        assert!(q.distance_to(DVec3::new(0.0, 0.0, 0.0)) < 1e-15);
        assert!((q.distance_to(DVec3::new(2.0, 0.0, 0.0)) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn cylinder_sphere_and_disc_hits_are_on_their_surfaces() {
        let c = Shape::Cylinder {
            base: DVec3::new(-0.2, 0.878, -0.4),
            axis: DVec3::X,
            length: 0.4,
            radius: 0.1275,
        };
        let h = c
            .intersect(&ray([0.0, 0.878, 1.0], [0.0, 0.0, -1.0]), f64::INFINITY)
            .unwrap();
        assert!((h.t - (1.4 - 0.1275)).abs() < 1e-12);
        assert!((h.normal - DVec3::Z).length() < 1e-12);
        assert!(c
            .intersect(&ray([0.3, 0.878, 1.0], [0.0, 0.0, -1.0]), f64::INFINITY)
            .is_none());
        let s = Shape::Sphere {
            centre: DVec3::ZERO,
            radius: 2.0,
        };
        let h = s.intersect(&ray([0.0; 3], [0.3, 0.4, 0.5]), f64::INFINITY).unwrap();
        assert!((h.t - 2.0).abs() < 1e-12);
        let d = Shape::Disc {
            centre: DVec3::ZERO,
            normal: DVec3::X,
            radius: 0.1,
        };
        assert!(d.intersect(&ray([1.0, 0.05, 0.05], [-1.0, 0.0, 0.0]), 10.0).is_some());
        assert!(d.intersect(&ray([1.0, 0.08, 0.08], [-1.0, 0.0, 0.0]), 10.0).is_none());
    }

    #[test]
    fn triangle_distance_and_intersection_agree_with_a_hand_computed_case() {
        // The right triangle (0,0,0), (2,0,0), (0,2,0) in the plane z = 0,
        // front side +z ((p1 − p0) × (p2 − p0) = (0, 0, 4)).
        let tri = Shape::triangle(DVec3::ZERO, DVec3::new(2.0, 0.0, 0.0), DVec3::new(0.0, 2.0, 0.0)).unwrap();
        // Straight down onto (0.5, 0.5, 0) from 3 m above: t = 3, normal +z.
        let h = tri
            .intersect(&ray([0.5, 0.5, 3.0], [0.0, 0.0, -1.0]), f64::INFINITY)
            .unwrap();
        assert_eq!(h.t, 3.0);
        assert_eq!(h.normal, DVec3::Z);
        assert_eq!(tri.distance_to(DVec3::new(0.5, 0.5, 3.0)), 3.0);
        // From (1, 1, 1) along −(1, 1, 1)/√3 to the origin vertex: t = √3.
        let h = tri
            .intersect(&ray([1.0, 1.0, 1.0], [-1.0, -1.0, -1.0]), f64::INFINITY)
            .unwrap();
        assert!((h.t - 3f64.sqrt()).abs() < 1e-15, "{}", h.t);
        // Beyond the hypotenuse x + y = 2: a miss; the nearest point of
        // (2, 2, 0) is (1, 1, 0), at √2; of (−1, −1, 1) the vertex, at √3.
        assert!(tri
            .intersect(&ray([1.5, 1.5, 3.0], [0.0, 0.0, -1.0]), f64::INFINITY)
            .is_none());
        assert!((tri.distance_to(DVec3::new(2.0, 2.0, 0.0)) - 2f64.sqrt()).abs() < 1e-15);
        assert!((tri.distance_to(DVec3::new(-1.0, -1.0, 1.0)) - 3f64.sqrt()).abs() < 1e-15);
        // Hit from behind: same t, the same (unflipped) geometric normal.
        let h = tri
            .intersect(&ray([0.5, 0.5, -2.0], [0.0, 0.0, 1.0]), f64::INFINITY)
            .unwrap();
        assert_eq!((h.t, h.normal), (2.0, DVec3::Z));
        // Not before RAY_EPSILON_M, not at or beyond t_max.
        assert!(tri.intersect(&ray([0.5, 0.5, 3.0], [0.0, 0.0, -1.0]), 3.0).is_none());
        assert!(tri.intersect(&ray([0.5, 0.5, 1e-8], [0.0, 0.0, -1.0]), 1.0).is_none());
        assert!(Shape::triangle(DVec3::ZERO, DVec3::X, DVec3::X * 2.0).is_none());
    }

    #[test]
    fn bounds_hold_every_shape() {
        // Points on each surface lie in its box (hand-checked extents too).
        let d = Shape::Disc {
            centre: DVec3::new(1.0, 2.0, 3.0),
            normal: DVec3::new(0.0, 0.6, 0.8),
            radius: 0.5,
        };
        let b = d.bounds();
        // Along x the disc reaches r; along y r·√(1 − 0.36) = 0.4, along z 0.3.
        assert!((b.max - DVec3::new(1.5, 2.4, 3.3)).abs().max_element() < 1e-15, "{b:?}");
        assert!((b.min - DVec3::new(0.5, 1.6, 2.7)).abs().max_element() < 1e-15, "{b:?}");
        let c = Shape::Cylinder {
            base: DVec3::ZERO,
            axis: DVec3::Y,
            length: 2.0,
            radius: 0.5,
        };
        assert_eq!(
            c.bounds(),
            Aabb {
                min: DVec3::new(-0.5, 0.0, -0.5),
                max: DVec3::new(0.5, 2.0, 0.5)
            }
        );
        let q = Shape::quad(DVec3::ZERO, DVec3::new(1.0, 1.0, 0.0), DVec3::new(-1.0, 0.0, 1.0));
        assert_eq!(
            q.bounds(),
            Aabb {
                min: DVec3::new(-1.0, 0.0, 0.0),
                max: DVec3::new(1.0, 1.0, 1.0)
            }
        );
        let s = Shape::Sphere {
            centre: DVec3::ONE,
            radius: 2.0,
        };
        assert_eq!(s.bounds().min, DVec3::splat(-1.0));
        // Random rays' hits on a tilted cylinder and disc lie in their boxes.
        let tilted = Shape::Cylinder {
            base: DVec3::new(0.1, 0.2, 0.3),
            axis: DVec3::new(1.0, 2.0, 2.0) / 3.0,
            length: 0.7,
            radius: 0.2,
        };
        for shape in [tilted, d] {
            let b = shape.bounds();
            let mut hits = 0;
            for i in 0..2000 {
                let a = i as f64 * 0.618_034;
                let dir = DVec3::new(a.sin() * (3.0 * a).cos(), a.cos(), a.sin() * (3.0 * a).sin());
                let origin = b.centroid() - dir * 5.0 + DVec3::new((7.0 * a).sin(), (5.0 * a).cos(), 0.0) * 0.3;
                if let Some(h) = shape.intersect(&Ray { origin, dir }, f64::INFINITY) {
                    let p = origin + dir * h.t;
                    let pad = DVec3::splat(1e-12);
                    assert!(
                        Aabb {
                            min: b.min - pad,
                            max: b.max + pad
                        }
                        .contains(p),
                        "{p} outside {b:?}"
                    );
                    hits += 1;
                }
            }
            assert!(hits > 100, "{hits}");
        }
    }

    #[test]
    fn basis_is_orthonormal() {
        for n in [DVec3::Z, -DVec3::Z, DVec3::new(0.3, -0.4, 0.5).normalize()] {
            let (t, b) = basis(n);
            assert!(t.dot(b).abs() < 1e-12 && t.dot(n).abs() < 1e-12 && (t.length() - 1.0).abs() < 1e-12);
            assert!((t.cross(b) - n).length() < 1e-12);
        }
    }
}
