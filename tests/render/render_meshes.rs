//! Meshes, plain luminaires and units against analytic truth: a tessellated
//! integrating sphere, a cone luminaire's edge, and one scene written in
//! metres and in millimetres.
//!
//! Monte Carlo tolerances are the stated percentage plus 4 reported standard
//! errors (seeds are fixed, so the outcome is deterministic).

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use lightbooth::render::{load_scene, render, Coding, RenderSettings};

/// An icosphere of radius `r` around the origin (the library's mesh of
/// 20·4^levels triangles), as OBJ-ready vertex coordinates and faces.
fn icosphere(r: f64, levels: usize) -> (Vec<[f64; 3]>, Vec<[usize; 3]>) {
    let (v, f) = lightbooth::render::geometry::icosphere(levels);
    (v.into_iter().map(|p| (p * r).to_array()).collect(), f)
}

fn write_obj(path: &Path, v: &[[f64; 3]], f: &[[usize; 3]]) {
    let mut s = String::from("# icosphere written by tests/render/render_meshes.rs\n");
    for p in v {
        s.push_str(&format!("v {} {} {}\n", p[0], p[1], p[2]));
    }
    for t in f {
        s.push_str(&format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1));
    }
    std::fs::write(path, s).unwrap();
}

fn write_flat(dir: &Path) {
    let mut flat = String::from("nm,e\n");
    for nm in (380..=780).step_by(5) {
        flat.push_str(&format!("{nm},1.0\n"));
    }
    std::fs::write(dir.join("flat.csv"), flat).unwrap();
}

fn settings(codings: &[Coding], samples: u64, bounces: u32) -> RenderSettings {
    RenderSettings {
        codings: codings.to_vec(),
        samples,
        max_bounces: Some(bounces),
        russian_roulette_from: None,
        target_relative_se: None,
        ..RenderSettings::default()
    }
}

/// The centroid of face `i`, which is on the mesh (a valid target point).
fn centroid(v: &[[f64; 3]], t: [usize; 3]) -> [f64; 3] {
    let mut c = [0.0; 3];
    for k in 0..3 {
        c[k] = (v[t[0]][k] + v[t[1]][k] + v[t[2]][k]) / 3.0;
    }
    c
}

/// A sphere scene in `unit` with every coordinate multiplied by `k`: an
/// isotropic plain luminaire of `i_cd` at the centre of a tessellated
/// sphere (OBJ, radius 2 × k) of reflectance ρ.
fn mesh_sphere_scene(dir: &Path, unit: &str, k: f64, rho: f64, i_cd: f64) -> PathBuf {
    let (v, f) = icosphere(2.0 * k, 5);
    write_obj(&dir.join(format!("sphere_{unit}_{k}.obj")), &v, &f);
    write_flat(dir);
    let target = centroid(&v, f[1234]);
    let text = format!(
        r#"name = "tessellated integrating sphere"
units = "{unit}"
[radiometer]
position = [{rx}, {ry}, 0.0]
field_deg = 1.0
[[target]]
id = "wall"
point = [{t0}, {t1}, {t2}]
[materials]
wall = {{ reflectance = {rho} }}
[[light]]
id = "iso"
position = [0.0, 0.0, 0.0]
intensity_cd = {i_cd}
spd = "flat.csv:e"
[[mesh]]
file = "sphere_{unit}_{k}.obj"
material = "wall"
"#,
        rx = 0.1 * k,
        ry = 0.05 * k,
        t0 = target[0],
        t1 = target[1],
        t2 = target[2],
    );
    let p = dir.join(format!("sphere_{unit}_{k}.toml"));
    std::fs::write(&p, text).unwrap();
    p
}

/// The closed-sphere interreflection test of `render_physics.rs`, with the
/// sphere as 20 480 triangles (an icosphere of 5 levels; the facets lie
/// within 1 − cos(1.9°) ≈ 6e-4 of the radius, and the luminaire is a plain
/// `intensity_cd` light): after k bounces the wall's luminance is
/// L = ρ/π · I/R² · (1 + ρ + … + ρᵏ), the analytic sphere's value.
#[test]
fn a_tessellated_sphere_reproduces_the_integrating_sphere() {
    let dir = tempfile::tempdir().unwrap();
    let (i_cd, r_m, rho) = (100.0, 2.0, 0.5);
    let scene = load_scene(&mesh_sphere_scene(dir.path(), "m", 1.0, rho, i_cd)).unwrap();
    assert_eq!(scene.primitives.len(), 20 * 4usize.pow(5));
    for k in [0u32, 2, 5] {
        let r = render(&scene, &settings(&[Coding::Spectral, Coding::Rgb], 4096, k), None, None).unwrap();
        let series: f64 = (0..=k).map(|j| rho.powi(j as i32)).sum();
        let truth = rho / PI * i_cd / (r_m * r_m) * series;
        for (coding, c) in &r.targets[0].codings {
            let tol = 0.01 * truth + 4.0 * c.luminance_se_cd_m2;
            assert!(
                (c.luminance_cd_m2 - truth).abs() < tol,
                "{coding}, k = {k}: {} ± {} vs {truth}",
                c.luminance_cd_m2,
                c.luminance_se_cd_m2
            );
        }
    }
}

/// `units`: the same scene written in metres and in millimetres (every
/// coordinate × 1000, `units = "mm"`) gives the same radiance; the metre
/// numbers read as millimetres are a sphere 1000 × smaller, where the point
/// luminaire's irradiance, I/d², and so every term of the series, is 10⁶ ×
/// larger.
#[test]
fn the_same_scene_in_metres_and_millimetres_gives_the_same_radiance() {
    let dir = tempfile::tempdir().unwrap();
    let s = settings(&[Coding::Spectral, Coding::NStep(9)], 2048, 2);
    let y = |path: PathBuf| {
        let scene = load_scene(&path).unwrap();
        let r = render(&scene, &s, None, None).unwrap();
        r.targets[0]
            .codings
            .iter()
            .map(|c| c.1.luminance_cd_m2)
            .collect::<Vec<_>>()
    };
    let metres = y(mesh_sphere_scene(dir.path(), "m", 1.0, 0.5, 100.0));
    let millimetres = y(mesh_sphere_scene(dir.path(), "mm", 1000.0, 0.5, 100.0));
    let small = y(mesh_sphere_scene(dir.path(), "mm", 1.0, 0.5, 100.0));
    for i in 0..metres.len() {
        assert!(
            (millimetres[i] / metres[i] - 1.0).abs() < 1e-6,
            "{millimetres:?} vs {metres:?}"
        );
        assert!(
            (small[i] / metres[i] / 1e6 - 1.0).abs() < 1e-6,
            "{small:?} vs {metres:?} × 1e6"
        );
    }
}

/// A plain luminaire with a cone: on a plane 1 m below, the luminance of a
/// Lambertian ρ is ρ·I·cos θ/(π d²) inside the cone (θ < cone − falloff),
/// zero outside it, and in the falloff I·smoothstep(cos cone, cos(cone −
/// falloff), cos θ) (the documented rule).
#[test]
fn a_cone_luminaire_lights_inside_its_cone_only() {
    let dir = tempfile::tempdir().unwrap();
    write_flat(dir.path());
    let (i_cd, rho, cone, falloff) = (50.0, 0.8, 30.0f64, 10.0f64);
    // Targets on the floor y = 0 at angle θ from the light's axis (light at y = 1).
    let angles = [0.0f64, 15.0, 25.0, 35.0];
    let mut targets = String::new();
    for (i, a) in angles.iter().enumerate() {
        targets.push_str(&format!(
            "[[target]]\nid = \"t{i}\"\npoint = [{}, 0.0, 0.0]\n",
            a.to_radians().tan()
        ));
    }
    let text = format!(
        r#"name = "cone"
[radiometer]
position = [0.3, 0.5, 0.8]
field_deg = 0.01
{targets}
[materials]
floor = {{ reflectance = {rho} }}
[[light]]
id = "spot"
position = [0.0, 1.0, 0.0]
aim = [0.0, -1.0, 0.0]
intensity_cd = {i_cd}
cone_deg = {cone}
falloff_deg = {falloff}
spd = "flat.csv:e"
[[polygon]]
vertices = [[-2.0, 0.0, -2.0], [2.0, 0.0, -2.0], [2.0, 0.0, 2.0], [-2.0, 0.0, 2.0]]
material = "floor"
"#
    );
    let path = dir.path().join("cone.toml");
    std::fs::write(&path, text).unwrap();
    let scene = load_scene(&path).unwrap();
    // The cone's candela are in V(λ) (issue 46): so is the Y compared.
    let photometric = RenderSettings {
        observer: lightbooth::colorimetry::PHOTOMETRIC_OBSERVER,
        ..settings(&[Coding::Spectral], 256, 0)
    };
    let r = render(&scene, &photometric, None, None).unwrap();
    for (i, a) in angles.iter().enumerate() {
        let (cos_t, d2) = (a.to_radians().cos(), 1.0 / a.to_radians().cos().powi(2));
        let (cos_out, cos_in) = (cone.to_radians().cos(), (cone - falloff).to_radians().cos());
        let f = ((cos_t - cos_out) / (cos_in - cos_out)).clamp(0.0, 1.0);
        let smooth = f * f * (3.0 - 2.0 * f);
        let truth = rho * i_cd * smooth * cos_t / (PI * d2);
        let got = r.targets[i].codings[0].1.luminance_cd_m2;
        assert!(
            (got - truth).abs() <= 1e-3 * truth.max(1e-9),
            "θ = {a}°: {got} vs {truth}"
        );
    }
}

/// The manual's "your own booth" example is `scenes/examples/own_booth.toml`
/// itself (the scene-format chapter includes the file, so it cannot drift;
/// `cli::book_examples` checks that every include resolves), and it renders
/// on the first try: an OBJ vase (its `usemtl`
/// naming a scene material), polygons, an area light given by luminance and
/// colour temperature, centimetres.
#[test]
fn the_manuals_own_booth_example_renders_as_shipped() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let chapter = std::fs::read_to_string(root.join("docs/src/scenes/format.md")).unwrap();
    assert!(
        chapter.contains("{{#include ../../../scenes/examples/own_booth.toml}}"),
        "docs/src/scenes/format.md must include scenes/examples/own_booth.toml itself"
    );
    let scene = load_scene(&root.join("scenes/examples/own_booth.toml")).unwrap();
    assert_eq!(scene.emitters.len(), 1);
    let r = render(&scene, &settings(&Coding::ALL, 2048, 5), None, None).unwrap();
    for t in &r.targets {
        for (coding, c) in &t.codings {
            assert!(c.luminance_cd_m2 > 0.0, "{} {coding}: {}", t.id, c.luminance_cd_m2);
        }
    }
    // The orange glaze is redder than the grey table under the same light.
    let x = |id: &str| r.target(id).unwrap().coding("spectral").unwrap().x;
    assert!(x("vase") > x("table") + 0.05, "{} vs {}", x("vase"), x("table"));
}
