//! Benchmark of the bounding volume hierarchy (`crates/render/src/bvh.rs`): build
//! time and nearest-hit rays per second on generated meshes of 1 k, 100 k
//! and 1 M triangles, and where it overtakes the linear scan.
//!
//! - Meshes: a closed torus (major radius 0.3 m, tube 0.1 m) of nu × 2nu
//!   quads, each split in two triangles, its tube radius displaced by
//!   ±20 % (a bumpy surface; 1 024, 99 856 and 1 000 000 triangles).
//! - Rays: half start inside the tube (random direction; a closed mesh, so
//!   every one hits), half start on a sphere of radius 1 m around it aimed
//!   at a random point of the tube; nearest hit, on one thread.
//! - Crossover: a booth-like scene (five walls of a 2.2 m booth plus n − 5
//!   small mixed shapes: quads, discs, spheres, cylinders, triangles), rays
//!   from inside in random directions, linear scan against the BVH.
//!
//! `cargo bench --bench bvh` runs criterion; `cargo bench --bench bvh --
//! --json` prints one JSON line per case instead, with the medians of
//! [`RUNS`] runs (`build_s`, `rays_per_s`). With `--features bench-obvhs`,
//! the same meshes and rays also go through `obvhs` 0.4 (f32, its BVH2 and
//! CWBVH with `medium_build`), for the crate-or-own decision. `--json` also
//! times loading a scene with a 1 M-triangle OBJ (a 501 × 1001-vertex grid
//! of quads) and two targets checked against every triangle (`mesh_load`).

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{BenchmarkId, Criterion, Throughput};
use glam::DVec3;

use lightbooth::render::bvh::Bvh;
use lightbooth::render::geometry::{Ray, Shape};
use lightbooth::render::sampling::Pcg32;

/// Mesh sizes: (name, nu); the torus has nu × 2nu quads = 4nu² triangles.
const MESHES: [(&str, usize); 3] = [("1k", 16), ("100k", 158), ("1M", 500)];

/// Rays per timed run.
const RAYS: usize = 200_000;

/// Runs per median in `--json` mode.
const RUNS: usize = 5;

const MAJOR_M: f64 = 0.3;
const TUBE_M: f64 = 0.1;

/// The displaced torus of nu × 2nu quads as triangles (vertices shared exactly).
fn torus(nu: usize) -> Vec<Shape> {
    let nv = 2 * nu;
    let vertex = |i: usize, j: usize| {
        let u = (i % nv) as f64 / nv as f64 * std::f64::consts::TAU;
        let v = (j % nu) as f64 / nu as f64 * std::f64::consts::TAU;
        let r = TUBE_M * (1.0 + 0.2 * (9.0 * u + 3.0 * v).sin() * (7.0 * v).cos());
        DVec3::new(
            (MAJOR_M + r * v.cos()) * u.cos(),
            r * v.sin(),
            (MAJOR_M + r * v.cos()) * u.sin(),
        )
    };
    let mut tris = Vec::with_capacity(2 * nu * nv);
    for i in 0..nv {
        for j in 0..nu {
            let (a, b, c, d) = (vertex(i, j), vertex(i + 1, j), vertex(i + 1, j + 1), vertex(i, j + 1));
            tris.extend(Shape::triangle(a, b, c));
            tris.extend(Shape::triangle(a, c, d));
        }
    }
    tris
}

fn unit_vector(rng: &mut Pcg32) -> DVec3 {
    loop {
        let v = DVec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 2.0 - DVec3::ONE;
        let l2 = v.length_squared();
        if l2 > 1e-6 && l2 <= 1.0 {
            return v / l2.sqrt();
        }
    }
}

/// A point inside the tube, at most `fraction` of its radius off the core circle.
fn in_tube(rng: &mut Pcg32, fraction: f64) -> DVec3 {
    let u = rng.uniform() * std::f64::consts::TAU;
    let core = DVec3::new(MAJOR_M * u.cos(), 0.0, MAJOR_M * u.sin());
    core + unit_vector(rng) * (fraction * TUBE_M * rng.uniform())
}

/// Half from inside the tube, half from a 1 m sphere aimed at the tube.
fn torus_rays(n: usize, seed: u64) -> Vec<Ray> {
    let mut rng = Pcg32::new(seed, 17);
    (0..n)
        .map(|i| {
            if i % 2 == 0 {
                Ray {
                    origin: in_tube(&mut rng, 0.5),
                    dir: unit_vector(&mut rng),
                }
            } else {
                let origin = unit_vector(&mut rng);
                let aim = in_tube(&mut rng, 1.0);
                Ray {
                    origin,
                    dir: (aim - origin).normalize(),
                }
            }
        })
        .collect()
}

/// Five booth walls and n − 5 small mixed shapes inside.
fn booth_soup(n: usize, seed: u64) -> Vec<Shape> {
    let mut rng = Pcg32::new(seed, 5);
    let (lo, w) = (DVec3::new(-1.1, 0.0, -1.1), 2.2);
    let mut shapes = vec![
        Shape::quad(lo, DVec3::X * w, DVec3::Y * w),
        Shape::quad(lo, DVec3::Z * w, DVec3::Y * w),
        Shape::quad(lo + DVec3::X * w, DVec3::Z * w, DVec3::Y * w),
        Shape::quad(lo, DVec3::X * w, DVec3::Z * w),
        Shape::quad(DVec3::new(-0.6, 0.75, -0.7), DVec3::X * 1.2, DVec3::Z * 0.8),
    ];
    while shapes.len() < n {
        let c = DVec3::new(rng.uniform() - 0.5, 0.75 + 0.4 * rng.uniform(), -0.8 * rng.uniform());
        let s = 0.02 + 0.1 * rng.uniform();
        let shape = match shapes.len() % 5 {
            0 => Shape::quad(c, unit_vector(&mut rng) * s, unit_vector(&mut rng) * s),
            1 => Shape::Disc {
                centre: c,
                normal: unit_vector(&mut rng),
                radius: s,
            },
            2 => Shape::Sphere { centre: c, radius: s },
            3 => Shape::Cylinder {
                base: c,
                axis: unit_vector(&mut rng),
                length: 2.0 * s,
                radius: 0.5 * s,
            },
            _ => match Shape::triangle(c, c + unit_vector(&mut rng) * s, c + unit_vector(&mut rng) * s) {
                Some(t) => t,
                None => continue,
            },
        };
        shapes.push(shape);
    }
    shapes.truncate(n);
    shapes
}

fn booth_rays(n: usize, seed: u64) -> Vec<Ray> {
    let mut rng = Pcg32::new(seed, 9);
    (0..n)
        .map(|_| Ray {
            origin: DVec3::new(
                rng.uniform() - 0.5,
                0.8 + 0.6 * rng.uniform(),
                0.4 - 1.2 * rng.uniform(),
            ),
            dir: unit_vector(&mut rng),
        })
        .collect()
}

/// The integrator's linear scan: every shape, the nearest hit.
fn linear_nearest(shapes: &[Shape], ray: &Ray) -> Option<usize> {
    let mut best = None;
    let mut t_max = f64::INFINITY;
    for (i, s) in shapes.iter().enumerate() {
        if let Some(h) = s.intersect(ray, t_max) {
            t_max = h.t;
            best = Some(i);
        }
    }
    best
}

/// Nearest hits of every ray; returns how many hit.
fn trace(bvh: &Bvh, shapes: &[Shape], rays: &[Ray]) -> usize {
    rays.iter()
        .filter(|r| black_box(bvh.nearest(shapes, r, f64::INFINITY)).is_some())
        .count()
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Median seconds of `RUNS` calls of `f`.
fn median_seconds(mut f: impl FnMut()) -> f64 {
    median(
        (0..RUNS)
            .map(|_| {
                let t = Instant::now();
                f();
                t.elapsed().as_secs_f64()
            })
            .collect(),
    )
}

#[cfg(feature = "bench-obvhs")]
mod with_obvhs {
    //! The same meshes and rays through obvhs 0.4 (f32).
    use super::*;
    use obvhs::ray::{Ray as Ray32, RayHit};
    use obvhs::triangle::Triangle;
    use obvhs::BvhBuildParams;

    pub fn triangles(shapes: &[Shape]) -> Vec<Triangle> {
        shapes
            .iter()
            .map(|s| match *s {
                Shape::Triangle { p0, p1, p2, .. } => Triangle {
                    v0: p0.as_vec3().to_array().into(),
                    v1: p1.as_vec3().to_array().into(),
                    v2: p2.as_vec3().to_array().into(),
                },
                _ => unreachable!("meshes are triangles"),
            })
            .collect()
    }

    pub fn rays(rays: &[Ray]) -> Vec<Ray32> {
        rays.iter()
            .map(|r| {
                Ray32::new(
                    r.origin.as_vec3().to_array().into(),
                    r.dir.as_vec3().to_array().into(),
                    0.0,
                    f32::INFINITY,
                )
            })
            .collect()
    }

    pub fn build_bvh2(tris: &[Triangle]) -> obvhs::bvh2::Bvh2 {
        obvhs::bvh2::builder::build_bvh2_from_tris(tris, BvhBuildParams::medium_build(), &mut Duration::default())
    }

    pub fn build_cwbvh(tris: &[Triangle]) -> (obvhs::cwbvh::CwBvh, Vec<Triangle>) {
        let bvh = obvhs::cwbvh::builder::build_cwbvh_from_tris(
            tris,
            BvhBuildParams::medium_build(),
            &mut Duration::default(),
        );
        // Triangles in the BVH's order, as obvhs's own examples do.
        let ordered = bvh.primitive_indices.iter().map(|&i| tris[i as usize]).collect();
        (bvh, ordered)
    }

    /// Nearest hits with the BVH2: (hits, primitive of each ray or u32::MAX).
    pub fn trace_bvh2(bvh: &obvhs::bvh2::Bvh2, tris: &[Triangle], rays: &[Ray32]) -> Vec<u32> {
        rays.iter()
            .map(|&r| {
                let mut hit = RayHit::none();
                if bvh.ray_traverse(r, &mut hit, |ray, id| {
                    tris[bvh.primitive_indices[id] as usize].intersect(ray)
                }) {
                    bvh.primitive_indices[hit.primitive_id as usize]
                } else {
                    u32::MAX
                }
            })
            .collect()
    }

    pub fn trace_cwbvh(bvh: &obvhs::cwbvh::CwBvh, ordered: &[Triangle], rays: &[Ray32]) -> Vec<u32> {
        rays.iter()
            .map(|&r| {
                let mut hit = RayHit::none();
                if bvh.ray_traverse(r, &mut hit, |ray, id| ordered[id].intersect(ray)) {
                    bvh.primitive_indices[hit.primitive_id as usize]
                } else {
                    u32::MAX
                }
            })
            .collect()
    }
}

/// `--json`: loading a scene whose OBJ mesh has 1 M triangles (written to a
/// temporary folder first), median of RUNS loads.
fn mesh_load_summary() {
    use std::fmt::Write;
    let (nx, nz) = (501usize, 1001usize);
    let mut obj = String::with_capacity(60_000_000);
    for j in 0..nz {
        for i in 0..nx {
            writeln!(obj, "v {} 0.5 {}", i as f64 / 500.0, j as f64 / 1000.0).unwrap();
        }
    }
    for j in 0..nz - 1 {
        for i in 0..nx - 1 {
            let a = j * nx + i + 1;
            writeln!(obj, "f {} {} {} {}", a, a + 1, a + nx + 1, a + nx).unwrap();
        }
    }
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("grid.obj"), obj).unwrap();
    let scene = dir.path().join("grid.toml");
    std::fs::write(
        &scene,
        "name = \"grid\"\n[radiometer]\nposition = [0.5, 1.5, 0.5]\n\
         [[target]]\nid = \"on_mesh\"\npoint = [0.25, 0.5, 0.25]\n\
         [[target]]\nid = \"corner\"\npoint = [0.999, 0.5, 0.999]\n\
         [materials]\ngrey = { reflectance = 0.5 }\n\
         [[mesh]]\nfile = \"grid.obj\"\nmaterial = \"grey\"\n",
    )
    .unwrap();
    let mut triangles = 0;
    let load_s = median_seconds(|| {
        triangles = lightbooth::render::load_scene(&scene).unwrap().primitives.len();
    });
    println!(
        "{}",
        serde_json::json!({"bench": "mesh_load", "triangles": triangles, "load_s": load_s})
    );
}

/// `--json`: medians of RUNS runs, one line per case.
fn json_summary() {
    for (name, nu) in MESHES {
        let shapes = torus(nu);
        let rays = torus_rays(RAYS, 1);
        let mut bvh = None;
        let build_s = median_seconds(|| bvh = Some(Bvh::build(&shapes[..])));
        let bvh = bvh.unwrap();
        let mut hits = 0;
        let trace_s = median_seconds(|| hits = trace(&bvh, &shapes, &rays));
        println!(
            "{}",
            serde_json::json!({
                "bench": "bvh", "impl": "lightbooth", "mesh": name, "triangles": shapes.len(),
                "build_s": build_s, "rays_per_s": RAYS as f64 / trace_s,
                "hit_fraction": hits as f64 / RAYS as f64, "nodes": bvh.node_count(),
                "depth": bvh.depth(), "bvh_mib": bvh.memory_bytes() as f64 / (1 << 20) as f64,
            })
        );
        #[cfg(feature = "bench-obvhs")]
        {
            let tris = with_obvhs::triangles(&shapes);
            let rays32 = with_obvhs::rays(&rays);
            // Which primitive the f64 BVH finds, to count agreements.
            let reference: Vec<u32> = rays
                .iter()
                .map(|r| {
                    bvh.nearest(&shapes[..], r, f64::INFINITY)
                        .map_or(u32::MAX, |h| h.1 as u32)
                })
                .collect();
            let agree = |got: &[u32]| got.iter().zip(&reference).filter(|(a, b)| a == b).count() as f64 / RAYS as f64;
            let mut b2 = None;
            let build_s = median_seconds(|| b2 = Some(with_obvhs::build_bvh2(&tris)));
            let b2 = b2.unwrap();
            let mut got = Vec::new();
            let trace_s = median_seconds(|| got = with_obvhs::trace_bvh2(&b2, &tris, &rays32));
            println!(
                "{}",
                serde_json::json!({
                    "bench": "bvh", "impl": "obvhs-bvh2-f32", "mesh": name, "triangles": shapes.len(),
                    "build_s": build_s, "rays_per_s": RAYS as f64 / trace_s,
                    "hit_fraction": got.iter().filter(|&&p| p != u32::MAX).count() as f64 / RAYS as f64,
                    "same_primitive_as_f64": agree(&got),
                })
            );
            let mut cw = None;
            let build_s = median_seconds(|| cw = Some(with_obvhs::build_cwbvh(&tris)));
            let (cw, ordered) = cw.unwrap();
            let trace_s = median_seconds(|| got = with_obvhs::trace_cwbvh(&cw, &ordered, &rays32));
            println!(
                "{}",
                serde_json::json!({
                    "bench": "bvh", "impl": "obvhs-cwbvh-f32", "mesh": name, "triangles": shapes.len(),
                    "build_s": build_s, "rays_per_s": RAYS as f64 / trace_s,
                    "hit_fraction": got.iter().filter(|&&p| p != u32::MAX).count() as f64 / RAYS as f64,
                    "same_primitive_as_f64": agree(&got),
                })
            );
        }
    }
    for n in [6, 9, 12, 16, 24, 32, 48, 64, 128] {
        let shapes = booth_soup(n, 3);
        let rays = booth_rays(RAYS, 4);
        let bvh = Bvh::build(&shapes[..]);
        let linear_s = median_seconds(|| {
            rays.iter().for_each(|r| {
                black_box(linear_nearest(&shapes, r));
            })
        });
        let bvh_s = median_seconds(|| {
            black_box(trace(&bvh, &shapes, &rays));
        });
        println!(
            "{}",
            serde_json::json!({
                "bench": "crossover", "primitives": n,
                "linear_rays_per_s": RAYS as f64 / linear_s, "bvh_rays_per_s": RAYS as f64 / bvh_s,
            })
        );
    }
}

fn criterion_benches(c: &mut Criterion) {
    let mut build = c.benchmark_group("bvh_build");
    build
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(5));
    for (name, nu) in MESHES {
        let shapes = torus(nu);
        build.throughput(Throughput::Elements(shapes.len() as u64));
        build.bench_with_input(BenchmarkId::new("lightbooth", name), &shapes, |b, s| {
            b.iter(|| Bvh::build(&s[..]))
        });
        #[cfg(feature = "bench-obvhs")]
        {
            let tris = with_obvhs::triangles(&shapes);
            build.bench_with_input(BenchmarkId::new("obvhs-bvh2-f32", name), &tris, |b, t| {
                b.iter(|| with_obvhs::build_bvh2(t))
            });
            build.bench_with_input(BenchmarkId::new("obvhs-cwbvh-f32", name), &tris, |b, t| {
                b.iter(|| with_obvhs::build_cwbvh(t))
            });
        }
    }
    build.finish();

    let mut nearest = c.benchmark_group("bvh_nearest");
    nearest
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3))
        .throughput(Throughput::Elements(RAYS as u64));
    let rays = torus_rays(RAYS, 1);
    for (name, nu) in MESHES {
        let shapes = torus(nu);
        let bvh = Bvh::build(&shapes[..]);
        nearest.bench_function(BenchmarkId::new("lightbooth", name), |b| {
            b.iter(|| trace(&bvh, &shapes, &rays))
        });
        #[cfg(feature = "bench-obvhs")]
        {
            let tris = with_obvhs::triangles(&shapes);
            let rays32 = with_obvhs::rays(&rays);
            let b2 = with_obvhs::build_bvh2(&tris);
            nearest.bench_function(BenchmarkId::new("obvhs-bvh2-f32", name), |b| {
                b.iter(|| with_obvhs::trace_bvh2(&b2, &tris, &rays32))
            });
            let (cw, ordered) = with_obvhs::build_cwbvh(&tris);
            nearest.bench_function(BenchmarkId::new("obvhs-cwbvh-f32", name), |b| {
                b.iter(|| with_obvhs::trace_cwbvh(&cw, &ordered, &rays32))
            });
        }
    }
    nearest.finish();

    let mut crossover = c.benchmark_group("crossover");
    let rays = booth_rays(20_000, 4);
    crossover
        .sample_size(10)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(1))
        .throughput(Throughput::Elements(rays.len() as u64));
    for n in [9, 16, 24, 32, 64] {
        let shapes = booth_soup(n, 3);
        let bvh = Bvh::build(&shapes[..]);
        crossover.bench_function(BenchmarkId::new("linear", n), |b| {
            b.iter(|| rays.iter().filter_map(|r| linear_nearest(&shapes, r)).count())
        });
        crossover.bench_function(BenchmarkId::new("bvh", n), |b| b.iter(|| trace(&bvh, &shapes, &rays)));
    }
    crossover.finish();
}

fn main() {
    if std::env::args().any(|a| a == "--json") {
        json_summary();
        mesh_load_summary();
        return;
    }
    let mut c = Criterion::default().configure_from_args();
    criterion_benches(&mut c);
    c.final_summary();
}
