//! The BVH checked against a linear scan over every shape (same nearest
//! hit, bit-identical renders), across threads, on cache changes, and for
//! watertightness at shared mesh edges.

use super::*;
use crate::geometry::{icosphere, RAY_EPSILON_M};
use crate::sampling::Pcg32;

fn uniform_in(rng: &mut Pcg32, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * rng.uniform()
}

fn point_in(rng: &mut Pcg32, lo: f64, hi: f64) -> DVec3 {
    DVec3::new(
        uniform_in(rng, lo, hi),
        uniform_in(rng, lo, hi),
        uniform_in(rng, lo, hi),
    )
}

fn unit_vector(rng: &mut Pcg32) -> DVec3 {
    loop {
        let v = point_in(rng, -1.0, 1.0);
        let l2 = v.length_squared();
        if l2 > 1e-6 && l2 <= 1.0 {
            return v / l2.sqrt();
        }
    }
}

/// A random soup of every kind of shape in a 1 m cube, with exact
/// duplicates (equal t on different primitives: the tie rule).
fn mixed_soup(rng: &mut Pcg32, n: usize) -> Vec<Shape> {
    let mut shapes: Vec<Shape> = Vec::new();
    while shapes.len() < n {
        let c = point_in(rng, -0.5, 0.5);
        let size = uniform_in(rng, 0.005, 0.15);
        let s = match shapes.len() % 6 {
            0 => Shape::quad(c, unit_vector(rng) * size, unit_vector(rng) * size),
            1 => Shape::Disc {
                centre: c,
                normal: unit_vector(rng),
                radius: size,
            },
            2 => Shape::Sphere {
                centre: c,
                radius: size,
            },
            3 => Shape::Cylinder {
                base: c,
                axis: unit_vector(rng),
                length: 2.0 * size,
                radius: 0.5 * size,
            },
            4 => match Shape::triangle(c, c + unit_vector(rng) * size, c + unit_vector(rng) * size) {
                Some(t) => t,
                None => continue,
            },
            _ => match shapes.last() {
                // An axis-aligned quad (a flat box), then a duplicate of some shape.
                Some(_) if rng.uniform() < 0.5 => shapes[(rng.next_u32() as usize) % shapes.len()].clone(),
                _ => Shape::quad(c, DVec3::X * size, DVec3::Z * size),
            },
        };
        shapes.push(s);
    }
    shapes
}

/// The list of record: every shape in order, the first of equal t wins.
fn brute_nearest(shapes: &[Shape], ray: &Ray, t_max: f64) -> Option<(Hit, usize)> {
    let mut best: Option<(Hit, usize)> = None;
    let mut limit = t_max;
    for (i, s) in shapes.iter().enumerate() {
        if let Some(h) = s.intersect(ray, limit) {
            limit = h.t;
            best = Some((h, i));
        }
    }
    best
}

/// Rays of every kind: random, and aimed exactly at corners, vertices and
/// centres of the shapes (the boundaries where a box could wrongly cull).
fn soup_rays(rng: &mut Pcg32, shapes: &[Shape], n: usize) -> Vec<Ray> {
    (0..n)
        .map(|i| {
            let origin = point_in(rng, -0.8, 0.8);
            let aim = match (i % 3, &shapes[(rng.next_u32() as usize) % shapes.len()]) {
                (0, _) => origin + unit_vector(rng),
                (1, Shape::Quad { corner, u, v, .. }) => *corner + *u * (rng.next_u32() % 2) as f64 + *v,
                (1, Shape::Triangle { p0, p1, p2, .. }) => [*p0, *p1, *p2][(rng.next_u32() % 3) as usize],
                (_, s) => s.bounds().centroid(),
            };
            Ray {
                origin,
                dir: (aim - origin).normalize(),
            }
        })
        .collect()
}

#[test]
fn bvh_nearest_hit_equals_the_linear_scan_over_a_random_soup_of_mixed_shapes() {
    let mut rng = Pcg32::new(11, 1);
    for &n in &[1usize, 2, 7, 40, 600, 3000] {
        let shapes = mixed_soup(&mut rng, n);
        let bvh = Bvh::build(&shapes[..]);
        assert_eq!(bvh.len(), n);
        let mut hits = 0;
        let mut ties = 0;
        for ray in soup_rays(&mut rng, &shapes, 4000) {
            for t_max in [f64::INFINITY, uniform_in(&mut rng, 0.0, 1.0)] {
                let want = brute_nearest(&shapes, &ray, t_max);
                let got = bvh.nearest(&shapes[..], &ray, t_max);
                match (want, got) {
                    (None, None) => {}
                    (Some((wh, wi)), Some((gh, gi))) => {
                        assert_eq!(
                            (wh.t.to_bits(), wi, wh.normal.to_array().map(f64::to_bits)),
                            (gh.t.to_bits(), gi, gh.normal.to_array().map(f64::to_bits)),
                            "n = {n}, ray {ray:?}, t_max {t_max}"
                        );
                        hits += 1;
                        ties += shapes
                            .iter()
                            .skip(wi + 1)
                            .filter(|s| s.intersect(&ray, wh.t.next_up()).is_some_and(|h| h.t == wh.t))
                            .count();
                    }
                    _ => panic!("n = {n}, ray {ray:?}, t_max {t_max}: linear {want:?}, BVH {got:?}"),
                }
                let any = shapes.iter().any(|s| s.intersect(&ray, t_max).is_some());
                assert_eq!(bvh.occluded(&shapes[..], &ray, t_max), any, "n = {n}, ray {ray:?}");
            }
        }
        // The soup must exercise hits and, once big enough, equal-t ties.
        assert!(hits > 100 || n < 7, "n = {n}: only {hits} hits");
        if n >= 600 {
            assert!(ties > 0, "n = {n}: no tie between duplicates was tested");
            assert!(bvh.depth() < 40, "n = {n}: depth {}", bvh.depth());
        }
    }
}

#[test]
fn a_scene_traced_through_the_bvh_renders_bit_identically_to_the_linear_scan() {
    use crate::scene::Primitive;
    use crate::{load_scene, render, Coding, RenderSettings};
    // CYLINDER (9 primitives: the linear scan) and the same scene with
    // 40 triangles under its floor, where no path can reach them (every
    // path starts inside the booth): over LINEAR_SCAN_BELOW, so it is
    // traced through the BVH, and every nearest hit must be the same.
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/cylinder.toml");
    let scene = load_scene(&path).unwrap();
    assert!(scene.primitives.len() < LINEAR_SCAN_BELOW);
    let mut with_mesh = scene.clone();
    for i in 0..40 {
        let x = -1.0 + 0.05 * i as f64;
        let tri = Shape::triangle(
            DVec3::new(x, -0.5, -1.0),
            DVec3::new(x + 0.04, -0.5, -1.0),
            DVec3::new(x, -0.5, 1.0),
        )
        .unwrap();
        with_mesh.primitives.push(Primitive {
            shape: tri,
            ..scene.primitives[0].clone()
        });
    }
    assert!(with_mesh.primitives.len() >= LINEAR_SCAN_BELOW);
    let settings = |threads| RenderSettings {
        codings: vec![Coding::Rgb, Coding::NStep(9), Coding::Spectral],
        samples: 2048,
        targets: Some(vec!["h01".into(), "h11".into(), "h21".into()]),
        threads: Some(threads),
        target_relative_se: None,
        seed: 7,
        ..RenderSettings::default()
    };
    let json = |r: &crate::RenderResult| serde_json::to_string(&r.targets).unwrap();
    let linear = json(&render(&scene, &settings(2), None, None).unwrap());
    for threads in [1, 2] {
        let bvh = json(&render(&with_mesh, &settings(threads), None, None).unwrap());
        assert_eq!(bvh, linear, "{threads} threads");
    }
}

#[test]
fn bvh_of_nothing_finds_nothing() {
    let bvh = Bvh::build(&[][..] as &[Shape]);
    let ray = Ray {
        origin: DVec3::ZERO,
        dir: DVec3::X,
    };
    assert!(bvh.nearest(&[][..] as &[Shape], &ray, f64::INFINITY).is_none());
    assert!(!bvh.occluded(&[][..] as &[Shape], &ray, f64::INFINITY));
}

/// A displaced grid of `n`×`n` quads, each split into two triangles.
fn grid(n: usize, rng: &mut Pcg32) -> Vec<Shape> {
    let z: Vec<f64> = (0..(n + 1) * (n + 1)).map(|_| 0.01 * rng.uniform()).collect();
    let v = |i: usize, j: usize| DVec3::new(i as f64 / n as f64, z[i * (n + 1) + j], j as f64 / n as f64);
    let mut out = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let (a, b, c, d) = (v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j + 1));
            out.extend(Shape::triangle(a, b, c));
            out.extend(Shape::triangle(a, c, d));
        }
    }
    out
}

#[test]
fn bvh_is_the_same_tree_on_one_and_two_threads() {
    // Big enough for the parallel build (PARALLEL_BUILD_MIN) to split.
    let shapes = grid(200, &mut Pcg32::new(3, 3));
    assert!(shapes.len() > 2 * PARALLEL_BUILD_MIN);
    let build_on = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| Bvh::build(&shapes[..]))
    };
    let dump = |b: &Bvh| -> Vec<u64> {
        std::iter::once(&b.root)
            .chain(b.pairs.iter().flat_map(|p| &p.0))
            .flat_map(|n| {
                let mut v: Vec<u64> = n.min.into_iter().chain(n.max).map(|x| x.to_bits() as u64).collect();
                v.push(((n.index as u64) << 32) | n.count as u64);
                v
            })
            .chain(b.slots.iter().map(|s| s.tagged as u64))
            .collect()
    };
    let (one, two) = (build_on(1), build_on(2));
    assert_eq!(dump(&one), dump(&two));
    // Every primitive sits in exactly one leaf.
    let mut seen = vec![false; shapes.len()];
    for s in &one.slots {
        let p = (s.tagged & !TRIANGLE_BIT) as usize;
        assert!(!seen[p]);
        seen[p] = true;
    }
    assert!(seen.iter().all(|&s| s));
}

#[test]
fn the_cache_rebuilds_when_the_geometry_changes() {
    let mut shapes = grid(10, &mut Pcg32::new(5, 5));
    let cache = BvhCache::default();
    let first = cache.get_or_build(&shapes[..]);
    assert!(Arc::ptr_eq(&first, &cache.get_or_build(&shapes[..])));
    // Move one triangle up by 1 m: a ray from above must find it there.
    if let Shape::Triangle { p0, p1, p2, .. } = shapes[7] {
        shapes[7] = Shape::triangle(p0 + DVec3::Y, p1 + DVec3::Y, p2 + DVec3::Y).unwrap();
    }
    let second = cache.get_or_build(&shapes[..]);
    assert!(!Arc::ptr_eq(&first, &second));
    let Shape::Triangle { p0, p1, p2, .. } = shapes[7] else {
        unreachable!()
    };
    let aim = (p0 + p1 + p2) / 3.0;
    let ray = Ray {
        origin: aim + DVec3::Y,
        dir: -DVec3::Y,
    };
    assert_eq!(second.nearest(&shapes[..], &ray, f64::INFINITY).map(|h| h.1), Some(7));
}

/// Möller & Trumbore (1997) with the usual barycentric bounds: not
/// watertight (each triangle rounds its own edge test), the control that
/// shows the watertightness tests can fail.
fn moller_trumbore(ray: &Ray, p0: DVec3, p1: DVec3, p2: DVec3) -> bool {
    let (e1, e2) = (p1 - p0, p2 - p0);
    let p = ray.dir.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 {
        return false;
    }
    let inv = 1.0 / det;
    let s = ray.origin - p0;
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return false;
    }
    let q = s.cross(e1);
    let v = ray.dir.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return false;
    }
    e2.dot(q) * inv > RAY_EPSILON_M
}

/// Rays from `origins` aimed exactly at the points at `fractions` along
/// every edge (p, q) (0: at p).
fn edge_rays(v: &[DVec3], edges: &[(usize, usize)], origins: &[DVec3], fractions: &[f64]) -> Vec<Ray> {
    let mut rays = Vec::new();
    for &o in origins {
        for &(p, q) in edges {
            for &s in fractions {
                let aim = v[p] + (v[q] - v[p]) * s;
                rays.push(Ray {
                    origin: o,
                    dir: (aim - o).normalize(),
                });
            }
        }
    }
    rays
}

/// (escapes of the watertight test through the BVH, of Möller–Trumbore).
fn escapes(v: &[DVec3], faces: &[[usize; 3]], rays: &[Ray]) -> (usize, usize) {
    let shapes: Vec<Shape> = faces
        .iter()
        .map(|&[a, b, c]| Shape::triangle(v[a], v[b], v[c]).unwrap())
        .collect();
    let bvh = Bvh::build(&shapes[..]);
    let watertight = rays
        .iter()
        .filter(|r| {
            bvh.nearest(&shapes[..], r, f64::INFINITY).is_none() || !bvh.occluded(&shapes[..], r, f64::INFINITY)
        })
        .count();
    let mt = rays
        .iter()
        .filter(|r| !faces.iter().any(|&[a, b, c]| moller_trumbore(r, v[a], v[b], v[c])))
        .count();
    (watertight, mt)
}

#[test]
fn rays_at_shared_edges_and_vertices_of_a_closed_mesh_never_escape() {
    // Ray origins inside the sphere of radius 1 (the mesh lies on it).
    let (v, faces) = icosphere(3);
    assert_eq!(faces.len(), 1280);
    let mut rng = Pcg32::new(7, 7);
    let mut origins = vec![DVec3::ZERO, DVec3::new(0.1, -0.2, 0.3)];
    origins.extend((0..4).map(|_| point_in(&mut rng, -0.5, 0.5)));
    let edges: Vec<(usize, usize)> = faces.iter().flat_map(|&[a, b, c]| [(a, b), (b, c), (c, a)]).collect();
    let rays = edge_rays(&v, &edges, &origins, &[0.0, 0.1, 1.0 / 3.0, 0.5, 0.7, 0.999]);
    let (watertight, mt) = escapes(&v, &faces, &rays);
    assert_eq!(
        watertight,
        0,
        "{watertight} of {} rays escaped the closed mesh",
        rays.len()
    );
    // The same rays find cracks in a non-watertight test: the test has teeth.
    assert!(mt > 0, "Möller–Trumbore found no crack: these rays would not catch one");
}

#[test]
fn rays_at_the_diagonal_of_cornell_quads_split_in_two_triangles_never_escape() {
    // The Cornell box's (slightly non-planar) walls and blocks in m,
    // each quad (v0, v1, v2, v3) as (v0, v1, v2), (v0, v2, v3).
    let quads_mm = [
        [
            [552.8, 0.0, 0.0],
            [0.0, 0.0, 0.0],
            [0.0, 0.0, 559.2],
            [549.6, 0.0, 559.2],
        ],
        [
            [556.0, 548.8, 0.0],
            [556.0, 548.8, 559.2],
            [0.0, 548.8, 559.2],
            [0.0, 548.8, 0.0],
        ],
        [
            [549.6, 0.0, 559.2],
            [0.0, 0.0, 559.2],
            [0.0, 548.8, 559.2],
            [556.0, 548.8, 559.2],
        ],
        [
            [0.0, 0.0, 559.2],
            [0.0, 0.0, 0.0],
            [0.0, 548.8, 0.0],
            [0.0, 548.8, 559.2],
        ],
        [
            [552.8, 0.0, 0.0],
            [549.6, 0.0, 559.2],
            [556.0, 548.8, 559.2],
            [556.0, 548.8, 0.0],
        ],
        [
            [130.0, 165.0, 65.0],
            [82.0, 165.0, 225.0],
            [240.0, 165.0, 272.0],
            [290.0, 165.0, 114.0],
        ],
        [
            [130.0, 0.0, 65.0],
            [130.0, 165.0, 65.0],
            [290.0, 165.0, 114.0],
            [290.0, 0.0, 114.0],
        ],
        [
            [423.0, 330.0, 247.0],
            [265.0, 330.0, 296.0],
            [314.0, 330.0, 456.0],
            [472.0, 330.0, 406.0],
        ],
        [
            [265.0, 0.0, 296.0],
            [265.0, 330.0, 296.0],
            [423.0, 330.0, 247.0],
            [423.0, 0.0, 247.0],
        ],
    ];
    let mut v = Vec::new();
    let mut faces = Vec::new();
    let mut diagonals = Vec::new();
    for q in quads_mm {
        let k = v.len();
        v.extend(q.map(|p| DVec3::from(p) * 1e-3));
        faces.push([k, k + 1, k + 2]);
        faces.push([k, k + 2, k + 3]);
        diagonals.push((k, k + 2));
    }
    // From inside the box and from the camera in front of it (mm → m).
    let origins = [
        [278.0, 273.0, 279.6],
        [278.0, 273.0, -800.0],
        [100.0, 400.0, 500.0],
        [500.0, 50.0, 20.0],
    ]
    .map(|p| DVec3::from(p) * 1e-3);
    // Points strictly inside the diagonal (v0, v2) (its ends are the
    // quad's outer corners, shared with nothing here).
    let fractions: Vec<f64> = (1..40)
        .map(|k| k as f64 / 40.0)
        .chain([1e-6, 0.3, 1.0 - 1e-9])
        .collect();
    let rays = edge_rays(&v, &diagonals, &origins, &fractions);
    let (watertight, mt) = escapes(&v, &faces, &rays);
    assert_eq!(
        watertight,
        0,
        "{watertight} of {} rays escaped through a diagonal",
        rays.len()
    );
    assert!(mt > 0, "Möller–Trumbore found no crack: these rays would not catch one");
}
