//! The scene format's new keys (units, polygons, meshes, area lights, plain
//! luminaires, spectra with `outside`), each parsed and each error naming
//! the file and the key. Scenes and their files are written to temp dirs.

use std::path::{Path, PathBuf};

use glam::DVec3;

use super::*;
use lightbooth_science::colorimetry::xyz_from_radiance;
use lightbooth_science::colorimetry::PHOTOMETRIC_OBSERVER;

/// A flat 380–780 nm grey and a 400–700 nm spectrum (as the Cornell box's).
const SPECTRA: &str = "nm,grey,shiny\n380,0.5,0.9\n780,0.5,0.9\n";
const SHORT: &str = "nm,white,light\n400,0.6,0.0\n500,0.7,8.0\n600,0.75,15.6\n700,0.8,18.4\n";

/// A scene in `dir`: a 2 m floor quad at y = 0, a target on it and
/// whatever `extra` adds; returns its path.
fn scene(dir: &Path, extra: &str) -> PathBuf {
    scene_in(dir, "probe.toml", "", 1.0, extra)
}

/// The base scene with its lengths × `k` and the header line `units`.
fn scene_in(dir: &Path, name: &str, units: &str, k: f64, extra: &str) -> PathBuf {
    std::fs::write(dir.join("refl.csv"), SPECTRA).unwrap();
    std::fs::write(dir.join("short.csv"), SHORT).unwrap();
    let text = format!(
        r#"name = "probe"
{units}
[radiometer]
position = [0.0, {one}, {one}]
[[target]]
id = "centre"
point = [0.0, 0.0, 0.0]
[materials]
grey = {{ reflectance = "refl.csv:grey" }}
[[quad]]
corner = [-{one}, 0.0, -{one}]
edge_u = [{two}, 0.0, 0.0]
edge_v = [0.0, 0.0, {two}]
material = "grey"
{extra}"#,
        one = k,
        two = 2.0 * k
    );
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn load(extra: &str) -> Result<Scene, SceneError> {
    let dir = tempfile::tempdir().unwrap();
    load_scene(&scene(dir.path(), extra))
}

/// Asserts the error names the scene file and `key`, and contains `words`.
fn refused(extra: &str, key: &str, words: &[&str]) -> SceneError {
    let e = load(extra).expect_err(key);
    assert!(e.file.ends_with("probe.toml"), "{e}");
    assert_eq!(e.key, key, "{e}");
    for w in words {
        assert!(e.to_string().contains(w), "`{e}` should say `{w}`");
    }
    e
}

fn triangle(p: &Primitive) -> [DVec3; 3] {
    match p.shape {
        Shape::Triangle { p0, p1, p2, .. } => [p0, p1, p2],
        ref s => panic!("not a triangle: {s:?}"),
    }
}

const SQUARE: &str = "vertices = [[0.0, 0.5, 0.0], [1.0, 0.5, 0.0], [1.0, 0.5, 1.0], [0.0, 0.5, 1.0]]";

#[test]
fn polygon_is_fan_triangulated_from_its_first_vertex() {
    let s = load(&format!(
        "[[polygon]]\nname = \"sheet\"\n{SQUARE}\nmaterial = \"grey\"\n"
    ))
    .unwrap();
    let tris: Vec<[DVec3; 3]> = s.primitives[1..].iter().map(triangle).collect();
    let v = [
        DVec3::new(0.0, 0.5, 0.0),
        DVec3::new(1.0, 0.5, 0.0),
        DVec3::new(1.0, 0.5, 1.0),
        DVec3::new(0.0, 0.5, 1.0),
    ];
    // The Cornell sheet's (v0, v1, v2), (v0, v2, v3).
    assert_eq!(tris, vec![[v[0], v[1], v[2]], [v[0], v[2], v[3]]]);
    assert!(s.primitives[1..].iter().all(|p| p.emitter.is_none() && p.material == 0));
    // A pentagon gives three triangles.
    let s = load(
        "[[polygon]]\nvertices = [[0.0, 0.5, 0.0], [1.0, 0.5, 0.0], [1.5, 0.5, 0.5], [1.0, 0.5, 1.0], [0.0, 0.5, 1.0]]\nmaterial = \"grey\"\n",
    )
    .unwrap();
    assert_eq!(s.primitives.len(), 1 + 3);
}

#[test]
fn polygon_errors_name_the_file_and_the_key() {
    let e = refused(
        &format!("[[polygon]]\n{SQUARE}\nmaterial = \"grey\"\ncolour = 1\n"),
        "polygon[0].colour",
        &["unknown field"],
    );
    assert!(e.message.contains("colour"), "{e}");
    refused(
        "[[polygon]]\nvertices = [[0.0, 0.5, 0.0], [1.0, 0.5, 0.0]]\nmaterial = \"grey\"\n",
        "polygon[0].vertices",
        &["at least 3"],
    );
    // v2 on the line through v0 and v1: the first fan triangle is degenerate.
    refused(
        "[[polygon]]\nname = \"flat\"\nvertices = [[0.0, 0.5, 0.0], [1.0, 0.5, 0.0], [2.0, 0.5, 0.0], [0.0, 0.5, 1.0]]\nmaterial = \"grey\"\n",
        "polygon[0].vertices[2]",
        &["`flat`", "(v0, v1, v2)", "zero area"],
    );
    refused(
        &format!("[[polygon]]\n{SQUARE}\n"),
        "polygon[0].material",
        &["needs a material"],
    );
    refused(
        &format!("[[polygon]]\n{SQUARE}\nmaterial = \"gold\"\n"),
        "polygon[0].material",
        &["no material `gold`"],
    );
    refused(
        &format!("[[polygon]]\n{SQUARE}\nmaterial = \"grey\"\ntwo_sided = true\n"),
        "polygon[0].two_sided",
        &["only used with `emission`"],
    );
}

/// Extra geometry of the units test, its lengths × `k`.
fn geometry(k: f64) -> String {
    let l = |v: f64| v * k;
    format!(
        r#"
[[polygon]]
vertices = [[{a}, {b}, {c}], [{d}, {b}, {c}], [{d}, {b}, {e}]]
material = "grey"
[[disc]]
centre = [0.0, {f}, 0.0]
normal = [0.0, 1.0, 0.0]
radius = {g}
material = "grey"
[[mesh]]
file = "tri_{k}.obj"
material = "grey"
scale = 2.0
rotate_deg = [0.0, 90.0, 0.0]
translate = [{a}, {f}, {c}]
[[light]]
id = "bulb"
position = [0.0, {h}, 0.0]
intensity_cd = 100.0
blackbody_k = 3000
[camera]
position = [0.0, {k1}, {k2}]
look_at = [0.0, 0.0, 0.0]
fov_deg = 40.0
width = 8
height = 8
[cielab_white]
light_on_perfect_diffuser = true
point = [{a}, 0.0, {c}]
normal = [0.0, 1.0, 0.0]
"#,
        a = l(0.1),
        b = l(0.5),
        c = l(0.2),
        d = l(0.4),
        e = l(0.6),
        f = l(0.3),
        g = l(0.25),
        h = l(0.9),
        k1 = l(1.0),
        k2 = l(2.0),
    )
}

fn tri_obj(dir: &Path, k: f64) {
    let text = format!("v 0 0 0\nv {a} 0 0\nv 0 0 {a}\nf 1 3 2\n", a = 0.1 * k);
    std::fs::write(dir.join(format!("tri_{k}.obj")), text).unwrap();
}

#[test]
fn units_mm_give_the_metre_scene_times_a_thousandth() {
    let dir = tempfile::tempdir().unwrap();
    tri_obj(dir.path(), 1.0);
    tri_obj(dir.path(), 1000.0);
    let m = load_scene(&scene_in(dir.path(), "m.toml", "", 1.0, &geometry(1.0))).unwrap();
    let mm = load_scene(&scene_in(
        dir.path(),
        "mm.toml",
        "units = \"mm\"",
        1000.0,
        &geometry(1000.0),
    ))
    .unwrap();
    let explicit_m = load_scene(&scene_in(dir.path(), "m2.toml", "units = \"m\"", 1.0, &geometry(1.0))).unwrap();
    let cm = load_scene(&scene_in(
        dir.path(),
        "cm.toml",
        "units = \"cm\"",
        100.0,
        &geometry(100.0),
    ));
    assert!(cm.is_err(), "the cm scene names tri_100.obj, which is not written");
    assert_eq!(m.primitives.len(), 1 + 1 + 1 + 1);
    assert_eq!(m.primitives.len(), mm.primitives.len());
    let close = |a: DVec3, b: DVec3| (a - b).length() <= 1e-15 * (1.0 + a.length());
    for s in [&mm, &explicit_m] {
        for (a, b) in m.primitives.iter().zip(&s.primitives) {
            match (&a.shape, &b.shape) {
                (Shape::Triangle { .. }, Shape::Triangle { .. }) => {
                    for (p, q) in triangle(a).into_iter().zip(triangle(b)) {
                        assert!(close(p, q), "{p} vs {q}");
                    }
                }
                (
                    Shape::Disc { centre, radius, .. },
                    Shape::Disc {
                        centre: c, radius: r, ..
                    },
                ) => {
                    assert!(
                        close(*centre, *c) && (radius - r).abs() < 1e-15,
                        "{centre} {radius} vs {c} {r}"
                    );
                }
                (
                    Shape::Quad { corner, u, v, .. },
                    Shape::Quad {
                        corner: c,
                        u: u2,
                        v: v2,
                        ..
                    },
                ) => {
                    assert!(close(*corner, *c) && close(*u, *u2) && close(*v, *v2));
                }
                (x, y) => panic!("{x:?} vs {y:?}"),
            }
        }
        assert!(close(m.lights[0].position, s.lights[0].position));
        assert!(close(m.radiometer.position, s.radiometer.position));
        assert!(close(m.target_list[0].point, s.target_list[0].point));
        let (c, c2) = (m.camera.as_ref().unwrap(), s.camera.as_ref().unwrap());
        assert!(close(c.position, c2.position) && close(c.look_at, c2.look_at));
        assert_eq!(m.cielab_white, s.cielab_white);
    }
    // The mesh: (a, 0, 0) scaled ×2, turned 90° about y (x → −z), moved:
    // (0.1, 0.3, 0.2) + (0, 0, −0.2) in metres, from either file.
    let mesh = triangle(&mm.primitives[3]);
    assert!(close(mesh[2], DVec3::new(0.1, 0.3, 0.0)), "{}", mesh[2]);
    assert!(close(mesh[1], DVec3::new(0.1 + 0.2, 0.3, 0.2)), "{}", mesh[1]);

    // Point-luminaire irradiance follows the distance in metres: the metre
    // file's numbers read as mm put the light 1000× closer, 10⁶× the
    // irradiance (E = I cos θ / d²); radiance on the diffuser likewise.
    let as_mm = load_scene(&scene_in(
        dir.path(),
        "as_mm.toml",
        "units = \"mm\"",
        1.0,
        &geometry(1.0),
    ))
    .unwrap();
    let (p, n) = (DVec3::new(0.1, 0.0, 0.2), DVec3::Y);
    let l_m = m.light_on_perfect_diffuser(p, n);
    let l_mm = as_mm.light_on_perfect_diffuser(p * 1e-3, n);
    for (a, b) in l_m.values().iter().zip(l_mm.values()) {
        assert!((b / a - 1e6).abs() < 1e-6 * 1e6, "{b} / {a}");
    }
    let e = load_scene(&scene_in(dir.path(), "ft.toml", "units = \"ft\"", 1.0, "")).unwrap_err();
    assert!(
        e.file.ends_with("ft.toml") && e.key == "units" && e.message.contains("\"mm\""),
        "{e}"
    );
}

#[test]
fn a_short_spectrum_is_an_error_that_says_how_to_extend_it() {
    let e = refused(
        "[materials.white]\nreflectance = \"short.csv:white\"\n",
        "materials.white.reflectance",
        &[
            "400–700 nm",
            "outside = \"hold\"",
            "outside = \"zero\"",
            "{ csv = \"short.csv:white\"",
        ],
    );
    assert!(e.file.ends_with("probe.toml"));
    // The same rule for a light's spd and filter.
    refused(
        "[[light]]\nid = \"bulb\"\nposition = [0.0, 0.9, 0.0]\nintensity_cd = 10.0\nspd = \"short.csv:light\"\n",
        "light[0].spd",
        &["400–700 nm", "outside"],
    );
    refused(
        "[[light]]\nid = \"bulb\"\nposition = [0.0, 0.9, 0.0]\nintensity_cd = 10.0\nblackbody_k = 3000\nfilter = \"short.csv:white\"\n",
        "light[0].filter",
        &["outside"],
    );
    // A misspelt rule is refused with the accepted forms.
    refused(
        "[materials.white]\nreflectance = { csv = \"short.csv:white\", outside = \"extend\" }\n",
        "materials.white.reflectance",
        &["outside = \"hold\" | \"zero\""],
    );
}

#[test]
fn outside_hold_and_zero_continue_a_short_spectrum_by_their_rule() {
    let s = load(
        "[materials.held]\nreflectance = { csv = \"short.csv:white\", outside = \"hold\" }\n\
         [materials.zeroed]\nreflectance = { csv = \"short.csv:white\", outside = \"zero\" }\n",
    )
    .unwrap();
    let material = |name: &str| &s.materials.iter().find(|m| m.name == name).unwrap().reflectance;
    let (held, zeroed) = (material("held"), material("zeroed"));
    // hold: below 400 nm the 400 nm value, above 700 nm the 700 nm value.
    assert_eq!(held.value_at(390.0), Some(0.6));
    assert_eq!(held.value_at(750.0), Some(0.8));
    assert_eq!(held.value_at(380.0), Some(0.6));
    assert_eq!(held.value_at(780.0), Some(0.8));
    // zero: 0 outside, at any wavelength of the grids the renderer uses.
    assert_eq!(zeroed.value_at(390.0), Some(0.0));
    assert_eq!(zeroed.value_at(750.0), Some(0.0));
    let one_nm = zeroed.resample(&Grid::one_nm()).unwrap();
    assert_eq!(one_nm.values()[399 - 380], 0.0);
    assert_eq!(one_nm.values()[701 - 380], 0.0);
    assert_eq!(one_nm.values()[400 - 380], 0.6);
    // Inside, both interpolate linearly between the samples.
    for r in [held, zeroed] {
        assert!((r.value_at(450.0).unwrap() - 0.65).abs() < 1e-12);
        assert_eq!(r.value_at(700.0), Some(0.8));
    }
}

/// The Cornell light's radiance, 0 below 400 nm and 18.4 above 700 nm (hold).
const CORNELL_LIGHT: &str = "emission = { radiance = { csv = \"short.csv:light\", outside = \"hold\" } }";

#[test]
fn a_polygon_area_light_has_its_radiance_and_reflects_nothing() {
    let s = load(&format!(
        "[[polygon]]\nname = \"light\"\n{SQUARE}\n{CORNELL_LIGHT}\n[[polygon]]\n{SQUARE}\nmaterial = \"grey\"\ntwo_sided = true\nemission = {{ radiance = 0.5 }}\n"
    ))
    .unwrap();
    assert_eq!(s.emitters.len(), 2);
    let light = &s.emitters[0];
    assert!(!light.two_sided && s.emitters[1].two_sided);
    assert!(light.name.contains("polygon[0]") && light.name.contains("light"));
    assert!(light.radiance.grid().same_as(&Grid::one_nm()));
    assert_eq!(light.radiance.unit(), SpectralUnit::SpectralRadiance);
    let at = |nm: usize| light.radiance.values()[nm - 380];
    assert_eq!(
        (at(390), at(400), at(500), at(600), at(700), at(750)),
        (0.0, 0.0, 8.0, 15.6, 18.4, 18.4)
    );
    assert!((at(550) - 11.8).abs() < 1e-12);
    let panel: Vec<&Primitive> = s.primitives.iter().filter(|p| p.emitter == Some(0)).collect();
    assert_eq!(panel.len(), 2);
    let black = &s.materials[panel[0].material].reflectance;
    assert!(black.values().iter().all(|r| *r == 0.0));
    // The second polygon emits and reflects its own material.
    let grey = s.primitives.iter().find(|p| p.emitter == Some(1)).unwrap();
    assert_eq!(s.materials[grey.material].name, "grey");
    // Front side: (v1 − v0) × (v2 − v0) of the square points down (−y).
    if let Shape::Triangle { normal, .. } = panel[0].shape {
        assert_eq!(normal, -DVec3::Y);
    }
}

#[test]
fn emission_by_luminance_is_normalised_to_that_luminance() {
    let s = load(&format!(
        "[[polygon]]\n{SQUARE}\nemission = {{ luminance_cd_m2 = 250.0, blackbody_k = 5000 }}\n\
         [[polygon]]\n{SQUARE}\nemission = {{ luminance_cd_m2 = 40.0, spd = {{ csv = \"short.csv:light\", outside = \"zero\" }} }}\n"
    ))
    .unwrap();
    // L = 683 lm/W · Σ L(λ) V(λ) Δλ, computed by the colorimetry module
    // with V(λ) (CIE 1931 ȳ): a cd/m² is defined by it (issue 46).
    for (e, lum) in s.emitters.iter().zip([250.0, 40.0]) {
        let y = xyz_from_radiance(&e.radiance, PHOTOMETRIC_OBSERVER).unwrap().y;
        assert!((y / lum - 1.0).abs() < 1e-12, "{y} vs {lum}");
    }
    // The blackbody's shape is Planck's: L(λ₁)/L(λ₂) = (λ₂/λ₁)⁵ (e^{c₂/λ₂T} − 1)/(e^{c₂/λ₁T} − 1).
    let v = s.emitters[0].radiance.values();
    let (l1, l2, t, c2): (f64, f64, f64, f64) = (450e-9, 650e-9, 5000.0, 1.438_776_877e-2);
    let planck = (l2 / l1).powi(5) * ((c2 / (l2 * t)).exp() - 1.0) / ((c2 / (l1 * t)).exp() - 1.0);
    assert!((v[450 - 380] / v[650 - 380] / planck - 1.0).abs() < 1e-12);
    // The zero rule: nothing emitted outside 400–700 nm.
    assert_eq!(s.emitters[1].radiance.values()[390 - 380], 0.0);
    assert_eq!(s.emitters[1].radiance.values()[750 - 380], 0.0);
}

#[test]
fn emission_errors_name_the_file_and_the_key() {
    refused(
        &format!("[[polygon]]\n{SQUARE}\nemission = {{ radiance = 1.0, luminance_cd_m2 = 5.0 }}\n"),
        "polygon[0].emission",
        &["exactly one"],
    );
    refused(
        &format!("[[polygon]]\n{SQUARE}\nemission = {{ radiance = 1.0, blackbody_k = 3000 }}\n"),
        "polygon[0].emission.blackbody_k",
        &["only used with `luminance_cd_m2`"],
    );
    refused(
        &format!("[[polygon]]\n{SQUARE}\nemission = {{ luminance_cd_m2 = 5.0 }}\n"),
        "polygon[0].emission.spd",
        &["`blackbody_k`"],
    );
    refused(
        &format!("[[polygon]]\n{SQUARE}\nemission = {{ radiance = \"short.csv:light\" }}\n"),
        "polygon[0].emission.radiance",
        &["400–700 nm", "outside"],
    );
    refused(
        &format!("[[polygon]]\n{SQUARE}\nemission = {{ radiance = 1.0, watts = 3 }}\n"),
        "polygon[0].emission.watts",
        &["unknown field"],
    );
    // The diffuser white knows only point luminaires.
    refused(
        &format!(
            "[[polygon]]\n{SQUARE}\n{CORNELL_LIGHT}\n[cielab_white]\nlight_on_perfect_diffuser = true\npoint = [0.0, 0.0, 0.0]\nnormal = [0.0, 1.0, 0.0]\n"
        ),
        "cielab_white.light_on_perfect_diffuser",
        &["area lights", "target"],
    );
    assert!(load(&format!(
        "[[polygon]]\n{SQUARE}\n{CORNELL_LIGHT}\n[cielab_white]\ntarget = \"centre\"\n"
    ))
    .is_ok());
}

const BULB: &str = "[[light]]\nid = \"bulb\"\nposition = [0.0, 0.9, 0.0]\nblackbody_k = 3000\n";

#[test]
fn a_plain_luminaire_is_isotropic_or_a_cone_with_a_smooth_edge() {
    let s = load(&format!("{BULB}intensity_cd = 50.0\n")).unwrap();
    let light = &s.lights[0];
    assert!(matches!(
        light.distribution,
        LightDistribution::Cone {
            intensity_cd: 50.0,
            cone_deg: 180.0,
            falloff_deg: 0.0
        }
    ));
    for d in [DVec3::X, -DVec3::Y, DVec3::new(0.3, 0.4, -0.5).normalize()] {
        assert_eq!(light.candela_toward(d), 50.0);
    }
    let s = load(&format!(
        "{BULB}intensity_cd = 80.0\ncone_deg = 30.0\nfalloff_deg = 10.0\naim = [0.0, -1.0, 0.0]\n"
    ))
    .unwrap();
    let light = &s.lights[0];
    let toward = |gamma_deg: f64| {
        let g = gamma_deg.to_radians();
        light.candela_toward(DVec3::new(g.sin(), -g.cos(), 0.0))
    };
    // Full inside cone − falloff, 0 at and beyond the cone, and the
    // smoothstep 3x² − 2x³ of x = (cos γ − cos 30°)/(cos 20° − cos 30°) between.
    assert_eq!(toward(0.0), 80.0);
    assert_eq!(toward(19.9), 80.0);
    assert_eq!(toward(30.0), 0.0);
    assert_eq!(toward(45.0), 0.0);
    let x =
        (25f64.to_radians().cos() - 30f64.to_radians().cos()) / (20f64.to_radians().cos() - 30f64.to_radians().cos());
    assert!((toward(25.0) - 80.0 * x * x * (3.0 - 2.0 * x)).abs() < 1e-9);
    // Its spectrum is normalised to 1 cd, as an IES luminaire's.
    let per_cd = Spectrum::new(
        Grid::one_nm(),
        SpectralUnit::SpectralRadiance,
        light.spectrum_per_cd.values().to_vec(),
    )
    .unwrap();
    assert!((xyz_from_radiance(&per_cd, PHOTOMETRIC_OBSERVER).unwrap().y - 1.0).abs() < 1e-12);
}

#[test]
fn plain_luminaire_errors_name_the_file_and_the_key() {
    refused(BULB, "light[0].ies", &["exactly one of `ies`"]);
    refused(
        &format!("{BULB}intensity_cd = 5.0\nies = \"x.ies\"\naim = [0.0, -1.0, 0.0]\n"),
        "light[0].ies",
        &["exactly one"],
    );
    refused(
        &format!("{BULB}intensity_cd = 5.0\naim = [0.0, -1.0, 0.0]\n"),
        "light[0].aim",
        &["isotropic"],
    );
    refused(
        &format!("{BULB}intensity_cd = 5.0\ncone_deg = 30.0\n"),
        "light[0].aim",
        &["cone needs `aim`"],
    );
    refused(
        &format!("{BULB}intensity_cd = 5.0\nc0 = [1.0, 0.0, 0.0]\n"),
        "light[0].c0",
        &["`ies`"],
    );
    refused(
        &format!("{BULB}intensity_cd = 5.0\nintensity_scale = 2.0\n"),
        "light[0].intensity_scale",
        &["IES"],
    );
    refused(
        &format!("{BULB}intensity_cd = 5.0\nfalloff_deg = 5.0\n"),
        "light[0].falloff_deg",
        &["`cone_deg`"],
    );
    refused(
        &format!("{BULB}intensity_cd = 5.0\ncone_deg = 20.0\nfalloff_deg = 25.0\naim = [0.0, -1.0, 0.0]\n"),
        "light[0].falloff_deg",
        &["[0, cone_deg = 20]"],
    );
    refused(
        &format!("{BULB}intensity_cd = 5.0\ncone_deg = 0.0\naim = [0.0, -1.0, 0.0]\n"),
        "light[0].cone_deg",
        &["(0, 180]"],
    );
    refused(
        &format!("{BULB}intensity_cd = -5.0\n"),
        "light[0].intensity_cd",
        &["positive"],
    );
}

/// A unit box's floor (a quad face) and one triangle, in two usemtl groups
/// (its `mtllib` file does not exist: materials come from the scene).
const BOX_OBJ: &str = "# fixture
mtllib box.mtl
o box
v 0 0 0
v 1 0 0
v 1 0 1
v 0 0 1
v 0 1 0
usemtl grey
f 1 2 3 4
usemtl shiny
f 1 2 5
l 1 2 3
";

const SHINY: &str = "[materials.shiny]\nreflectance = \"refl.csv:shiny\"\n";

/// Loads the base scene plus `extra` with `meshes/box.obj` = `obj`.
fn with_obj(obj: &str, extra: &str) -> Result<Scene, SceneError> {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("meshes")).unwrap();
    std::fs::write(dir.path().join("meshes/box.obj"), obj).unwrap();
    load_scene(&scene(dir.path(), extra))
}

fn mesh_refused(obj: &str, extra: &str, key: &str, words: &[&str]) {
    let e = with_obj(obj, extra).expect_err(key);
    assert!(e.file.ends_with("probe.toml"), "{e}");
    assert_eq!(e.key, key, "{e}");
    for w in words {
        assert!(e.to_string().contains(w), "`{e}` should say `{w}`");
    }
}

#[test]
fn an_obj_mesh_is_placed_triangulated_and_takes_its_usemtl_materials() {
    let s = with_obj(
        BOX_OBJ,
        &format!("{SHINY}[[mesh]]\nfile = \"meshes/box.obj\"\nscale = 0.5\nrotate_deg = [0.0, 90.0, 0.0]\ntranslate = [0.0, 0.2, 0.0]\n"),
    )
    .unwrap();
    // The quad face is two fan triangles; the `l` polyline adds none.
    let mesh = &s.primitives[1..];
    assert_eq!(mesh.len(), 3);
    let name = |p: &Primitive| s.materials[p.material].name.clone();
    assert_eq!(
        [name(&mesh[0]), name(&mesh[1]), name(&mesh[2])],
        ["grey", "grey", "shiny"]
    );
    // p ↦ Ry(90°)(0.5 p) + (0, 0.2, 0): (1, 0, 0) → (0, 0.2, −0.5), (0, 0, 1) → (0.5, 0.2, 0).
    let close = |a: DVec3, b: DVec3| (a - b).length() < 1e-15;
    let [a, b, c] = triangle(&mesh[0]);
    assert!(close(a, DVec3::new(0.0, 0.2, 0.0)), "{a}");
    assert!(close(b, DVec3::new(0.0, 0.2, -0.5)), "{b}");
    assert!(close(c, DVec3::new(0.5, 0.2, -0.5)), "{c}");
    let [_, _, top] = triangle(&mesh[2]);
    assert!(close(top, DVec3::new(0.0, 0.7, 0.0)), "{top}");
    assert!(close(triangle(&mesh[1])[2], DVec3::new(0.5, 0.2, 0.0)));
    // The mesh file is part of the scene's content.
    assert!(s.files.iter().any(|f| f.ends_with("meshes/box.obj")));
    assert!(mesh.iter().all(|p| p.emitter.is_none()));
}

#[test]
fn a_mirroring_scale_keeps_each_triangles_front_side() {
    let obj = "v 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 2 3\n";
    let normal = |scale: &str| {
        let s = with_obj(obj, &format!("[[mesh]]\nfile = \"meshes/box.obj\"\nmaterial = \"grey\"\nscale = {scale}\ntranslate = [0.0, 0.5, 0.0]\n")).unwrap();
        match s.primitives[1].shape {
            Shape::Triangle { normal, .. } => normal,
            _ => unreachable!(),
        }
    };
    // (1, 0, 0) × (0, 0, 1) = −y; mirrored in x the surface still faces −y.
    assert_eq!(normal("1.0"), -DVec3::Y);
    assert_eq!(normal("[-1.0, 1.0, 1.0]"), -DVec3::Y);
}

#[test]
fn an_emitting_mesh_without_material_is_black() {
    let s = with_obj(
        "v 0 0.5 0\nv 1 0.5 0\nv 1 0.5 1\nf 1 3 2\n",
        &format!("[[mesh]]\nfile = \"meshes/box.obj\"\n{CORNELL_LIGHT}\ntwo_sided = true\n"),
    )
    .unwrap();
    assert_eq!(s.emitters.len(), 1);
    assert!(s.emitters[0].two_sided && s.emitters[0].name == "mesh[0]");
    let p = &s.primitives[1];
    assert_eq!(p.emitter, Some(0));
    assert!(s.materials[p.material].reflectance.values().iter().all(|r| *r == 0.0));
}

#[test]
fn mesh_errors_name_the_mesh_file_and_line() {
    let mesh = "[[mesh]]\nfile = \"meshes/box.obj\"\nmaterial = \"grey\"\n";
    let by_usemtl = format!("{SHINY}[[mesh]]\nfile = \"meshes/box.obj\"\n");
    mesh_refused(
        BOX_OBJ,
        "[[mesh]]\nfile = \"meshes/none.obj\"\nmaterial = \"grey\"\n",
        "mesh[0].file",
        &["meshes/none.obj"],
    );
    mesh_refused(
        BOX_OBJ,
        &format!("{mesh}colour = 1\n"),
        "mesh[0].colour",
        &["unknown field"],
    );
    mesh_refused(
        "v 0 0 0\nv 1 0 0\nv 1 0 x\nf 1 2 3\n",
        mesh,
        "mesh[0].file",
        &["meshes/box.obj line 3", "`v 1 0 x`", "position parse error"],
    );
    mesh_refused(
        "v 0 0 0\nv 1 0 0\nv 1 0 nan\nf 1 2 3\n",
        mesh,
        "mesh[0].file",
        &["meshes/box.obj line 3", "not a finite number"],
    );
    mesh_refused(
        &BOX_OBJ.replace("usemtl shiny", "usemtl gold"),
        &by_usemtl,
        "mesh[0].file",
        &["meshes/box.obj line 11", "usemtl `gold`", "grey, shiny"],
    );
    // tobj notices a bad index only when the object ends; the line is found again.
    mesh_refused(
        "v 0 0 0\nv 1 0 0\nv 1 0 1\nf 1 2 3\nf 1 2 9\nv 0 1 0\n",
        mesh,
        "mesh[0].file",
        &["meshes/box.obj line 5", "`f 1 2 9`", "out of bounds"],
    );
    mesh_refused(
        "v 0 0 0\nv 1 0 0\nf 1 2\n",
        mesh,
        "mesh[0].file",
        &["meshes/box.obj", "2 vertices"],
    );
    mesh_refused(
        "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n",
        mesh,
        "mesh[0].file",
        &["meshes/box.obj", "face 1", "zero area"],
    );
    // Faces before any usemtl, and no `material`.
    mesh_refused(
        &BOX_OBJ.replace("usemtl grey\n", ""),
        &by_usemtl,
        "mesh[0].material",
        &["no material", "`box`"],
    );
    // Every face has its usemtl: `material` is unused.
    mesh_refused(BOX_OBJ, &format!("{SHINY}{mesh}"), "mesh[0].material", &["unused"]);
    mesh_refused(
        BOX_OBJ,
        &format!("{mesh}scale = [1.0, 0.0, 1.0]\n"),
        "mesh[0].scale",
        &["non-zero"],
    );
    mesh_refused("# nothing\n", mesh, "mesh[0].file", &["no faces"]);
    mesh_refused(
        BOX_OBJ,
        "[[mesh]]\nfile = \"meshes/box.stl\"\nmaterial = \"grey\"\n",
        "mesh[0].file",
        &[".obj or .ply"],
    );
}

const SQUARE_PLY: &str = "ply
format ascii 1.0
comment a unit square at y = 0.5
element vertex 4
property float x
property float y
property float z
element face 1
property list uchar int vertex_indices
end_header
0 0.5 0
1 0.5 0
1 0.5 1
0 0.5 1
4 0 1 2 3
";

fn with_ply(ply: &[u8], extra: &str) -> Result<Scene, SceneError> {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("square.ply"), ply).unwrap();
    load_scene(&scene(dir.path(), extra))
}

#[test]
fn a_ply_mesh_ascii_or_binary_is_read_and_its_errors_name_the_line() {
    let mesh = "[[mesh]]\nfile = \"square.ply\"\nmaterial = \"grey\"\n";
    let s = with_ply(SQUARE_PLY.as_bytes(), mesh).unwrap();
    let v = |x: f64, z: f64| DVec3::new(x, 0.5, z);
    let tris: Vec<[DVec3; 3]> = s.primitives[1..].iter().map(triangle).collect();
    assert_eq!(
        tris,
        vec![
            [v(0.0, 0.0), v(1.0, 0.0), v(1.0, 1.0)],
            [v(0.0, 0.0), v(1.0, 1.0), v(0.0, 1.0)]
        ]
    );
    // The same square, binary little-endian, with doubles.
    let mut bin = b"ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty double x\nproperty double y\nproperty double z\nelement face 1\nproperty list uchar uint vertex_indices\nend_header\n".to_vec();
    for (x, z) in [(0.0f64, 0.0f64), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)] {
        for c in [x, 0.5, z] {
            bin.extend_from_slice(&c.to_le_bytes());
        }
    }
    bin.push(4);
    for i in 0u32..4 {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    let b = with_ply(&bin, mesh).unwrap();
    let tris_b: Vec<[DVec3; 3]> = b.primitives[1..].iter().map(triangle).collect();
    assert_eq!(tris, tris_b);

    let e = with_ply(SQUARE_PLY.replace("4 0 1 2 3", "4 0 1 2 7").as_bytes(), mesh).unwrap_err();
    assert_eq!(e.key, "mesh[0].file");
    assert!(
        e.message.contains("square.ply line 15") && e.message.contains("vertex index 7"),
        "{e}"
    );
    let e = with_ply(SQUARE_PLY.replace("1 0.5 1", "1 0.5 q").as_bytes(), mesh).unwrap_err();
    assert!(e.message.contains("square.ply") && e.message.contains("Line 13"), "{e}");
    // PLY has no materials: the mesh must name one.
    let e = with_ply(SQUARE_PLY.as_bytes(), "[[mesh]]\nfile = \"square.ply\"\n").unwrap_err();
    assert_eq!(e.key, "mesh[0].material", "{e}");
}

#[test]
fn a_chart_table_takes_the_outside_rule_for_all_its_columns() {
    let dir = tempfile::tempdir().unwrap();
    let mut csv = String::from("nm");
    for k in 1..=24 {
        csv.push_str(&format!(",p{k:02}"));
    }
    for nm in [400, 500, 600, 700] {
        csv.push_str(&format!("\n{nm}"));
        for k in 1..=24 {
            csv.push_str(&format!(",{}", 0.01 * k as f64 + 0.0001 * f64::from(nm - 400)));
        }
    }
    std::fs::write(dir.path().join("chart.csv"), csv + "\n").unwrap();
    let chart = |reflectances: &str| {
        format!(
            "[[chart]]\nreflectances = {reflectances}\nmeasured_patch = 1\nmeasured_point = [0.0, 0.3, 0.0]\n\
             normal = [0.0, 0.0, 1.0]\nright = [1.0, 0.0, 0.0]\ncard_size = [0.3, 0.2]\ncard_reflectance = 0.1\n\
             patch_size = 0.04\npitch = 0.045\n"
        )
    };
    let e = load_scene(&scene(dir.path(), &chart("\"chart.csv\""))).unwrap_err();
    assert_eq!(e.key, "chart[0].reflectances");
    assert!(e.message.contains("400–700 nm") && e.message.contains("outside"), "{e}");
    let s = load_scene(&scene(
        dir.path(),
        &chart("{ csv = \"chart.csv\", outside = \"hold\" }"),
    ))
    .unwrap();
    let p24 = &s.materials.iter().find(|m| m.name == "chart0.p24").unwrap().reflectance;
    assert!((p24.value_at(390.0).unwrap() - 0.24).abs() < 1e-12);
    assert!((p24.value_at(750.0).unwrap() - 0.27).abs() < 1e-12);
}

/// The CIELAB white "light on a perfect diffuser" is the closed form of a
/// point source on a Lambertian surface: a source of I cd at distance d and
/// incidence θ gives E = I·cos θ / d², and the diffuser (ρ = 1) reflects
/// L = ρE/π, per unit of the lamp's spectrum per cd.
#[test]
fn the_diffuser_white_is_rho_e_over_pi_of_a_point_source() {
    // The BULB 0.9 m above the floor's origin; the diffuser 0.3 m to the
    // side of it on the floor: d² = 0.9² + 0.3², cos θ = 0.9/d.
    let s = load(&format!("{BULB}intensity_cd = 120.0\n")).unwrap();
    let (d2, cos) = (0.9f64 * 0.9 + 0.3 * 0.3, 0.9 / (0.9f64 * 0.9 + 0.3 * 0.3).sqrt());
    let l = s.light_on_perfect_diffuser(DVec3::new(0.3, 0.0, 0.0), DVec3::Y);
    let per_cd = s.lights[0].spectrum_per_cd.values();
    for (k, (v, sp)) in l.values().iter().zip(per_cd).enumerate() {
        let truth = 1.0 * (120.0 * cos / d2) / std::f64::consts::PI * sp;
        assert!((v / truth - 1.0).abs() < 1e-13, "{} nm: {v} vs {truth}", 380 + k);
    }
    // In V(λ): Y = ρ·E_v/π with E_v = I·cos θ / d² in lux (the candela is V-weighted).
    let y = xyz_from_radiance(&l, PHOTOMETRIC_OBSERVER).unwrap().y;
    assert!(
        (y / (120.0 * cos / d2 / std::f64::consts::PI) - 1.0).abs() < 1e-3,
        "{y}"
    );
    // Facing away from the lamp, the diffuser gets nothing.
    let dark = s.light_on_perfect_diffuser(DVec3::new(0.3, 0.0, 0.0), -DVec3::Y);
    assert!(dark.values().iter().all(|v| *v == 0.0));
}
