//! The renderer against analytic truth: direct light from a spotlight,
//! interreflection in a closed sphere, colour codings with flat spectra, and
//! determinism across thread counts.
//!
//! Monte Carlo tolerances are the stated percentage plus 4 reported standard
//! errors (a 4σ band: a false failure about once in 16 000 runs, and the
//! seeds are fixed, so the outcome is deterministic).

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use lightbooth::colorimetry::Cmf;
use lightbooth::render::ies::write_symmetric_lm63;
use lightbooth::render::{load_scene, render, Coding, RenderSettings, SamplerKind};
use lightbooth::spectrum::Grid;

/// The booth spotlight's shape, I(θ) = I0·exp(−ln 2·(θ/18)²) (scene sheet).
fn gaussian_cd(i0: f64, theta_deg: f64) -> f64 {
    i0 * (-(2f64.ln()) * (theta_deg / 18.0).powi(2)).exp()
}

/// Writes the spot's IES file (2° steps, 0–90°, I0 = 100 cd) and a flat SPD.
fn write_common(dir: &Path) {
    let v: Vec<f64> = (0..=45).map(|i| 2.0 * i as f64).collect();
    let cd: Vec<f64> = v.iter().map(|&t| gaussian_cd(100.0, t)).collect();
    std::fs::write(
        dir.join("spot.ies"),
        write_symmetric_lm63(&[("TEST", "gaussian")], &v, &cd),
    )
    .unwrap();
    let iso_v = [0.0, 90.0, 180.0];
    std::fs::write(
        dir.join("iso.ies"),
        write_symmetric_lm63(&[("TEST", "isotropic")], &iso_v, &[100.0; 3]),
    )
    .unwrap();
    let mut flat = String::from("nm,e\n");
    for nm in (380..=780).step_by(5) {
        flat.push_str(&format!("{nm},1.0\n"));
    }
    std::fs::write(dir.join("flat.csv"), flat).unwrap();
}

fn write_scene(dir: &Path, name: &str, text: &str) -> PathBuf {
    write_common(dir);
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn settings(codings: &[Coding], samples: u64) -> RenderSettings {
    RenderSettings {
        codings: codings.to_vec(),
        samples,
        target_relative_se: None,
        ..RenderSettings::default()
    }
}

/// Direct light on a Lambertian plane: L = ρ·I(θ)·cos θᵢ / (π d²)
/// (the radiance of a Lambertian reflector under irradiance E = I cos θᵢ/d²,
/// L = ρE/π). Luminance: Y = ρ·I_cd(θ)·cos θᵢ/(π d²), since the light's
/// spectrum is normalised to 1 cd. The plane is alone (no interreflection),
/// the radiometer field is 0.01° so the field mean is the point value.
/// Tolerance 0.5 %: the IES table is linear between 2° steps, whose error is
/// at most h²/8·max|I″| = (2°)²/8 · I0·2 ln2/18² ≈ 0.21 % of I0.
#[test]
fn direct_light_from_a_spotlight_matches_the_inverse_square_cosine_law() {
    let dir = tempfile::tempdir().unwrap();
    let rho = 0.6;
    let light = [0.3, 1.2, -0.1];
    let aim = [0.0, -1.0, 0.0];
    for target in [[0.0, 0.0, 0.0], [0.5, 0.0, 0.2], [0.3, 0.0, -0.1], [-0.2, 0.0, 0.4]] {
        let text = format!(
            r#"
name = "direct"
[radiometer]
position = [0.0, 2.0, 2.0]
field_deg = 0.01
[[target]]
id = "t"
point = [{}, {}, {}]
[materials]
grey = {{ reflectance = {rho} }}
[[light]]
id = "spot"
position = [{}, {}, {}]
aim = [{}, {}, {}]
ies = "spot.ies"
intensity_scale = 2.0
spd = "flat.csv:e"
[[quad]]
corner = [-2.0, 0.0, -2.0]
edge_u = [4.0, 0.0, 0.0]
edge_v = [0.0, 0.0, 4.0]
material = "grey"
"#,
            target[0], target[1], target[2], light[0], light[1], light[2], aim[0], aim[1], aim[2]
        );
        let path = write_scene(dir.path(), "direct.toml", &text);
        let scene = load_scene(&path).unwrap();
        // The IES file's candela are in V(λ) (issue 46): so is the Y compared.
        let photometric = RenderSettings {
            observer: lightbooth::colorimetry::PHOTOMETRIC_OBSERVER,
            ..settings(&Coding::ALL, 1024)
        };
        let r = render(&scene, &photometric, None, None).unwrap();
        let to_target = glam::DVec3::from(target) - glam::DVec3::from(light);
        let d = to_target.length();
        let theta = to_target.normalize().dot(glam::DVec3::from(aim)).acos().to_degrees();
        let cos_i = -to_target.normalize().y; // plane normal +y
        let truth = rho * gaussian_cd(200.0, theta) * cos_i / (PI * d * d);
        for (coding, c) in &r.targets[0].codings {
            let tol = 0.005 * truth + 4.0 * c.luminance_se_cd_m2;
            assert!(
                (c.luminance_cd_m2 - truth).abs() < tol,
                "{coding} at θ = {theta:.1}°: Y = {} cd/m², analytic {truth}",
                c.luminance_cd_m2
            );
        }
    }
}

fn sphere_scene(dir: &Path, rho: f64) -> PathBuf {
    let text = format!(
        r#"
name = "integrating sphere"
[radiometer]
position = [0.1, 0.05, 0.0]
field_deg = 1.0
[[target]]
id = "wall"
point = [0.0, 0.0, -2.0]
[materials]
wall = {{ reflectance = {rho} }}
[[light]]
id = "iso"
position = [0.0, 0.0, 0.0]
aim = [0.0, -1.0, 0.0]
ies = "iso.ies"
spd = "flat.csv:e"
[[sphere]]
centre = [0.0, 0.0, 0.0]
radius = 2.0
interior = "room"
material = "wall"
[camera]
position = [0.3, -0.2, 0.1]
look_at = [1.0, 0.5, -1.0]
fov_deg = 60.0
width = 8
height = 6
"#
    );
    write_scene(dir, "sphere.toml", &text)
}

/// An isotropic point source of I = 100 cd at the centre of a closed sphere of
/// radius R and reflectance ρ: each reflection spreads uniformly over the
/// sphere (the configuration factor between any two points of a sphere is
/// constant), so the irradiance after k indirect bounces is
/// E = (I/R²)(1 + ρ + … + ρᵏ), and the wall's luminance is L = ρE/π; the
/// limit is E = I/(R²(1 − ρ)) (the integrating-sphere equation).
#[test]
fn interreflection_in_a_closed_sphere_matches_the_geometric_series() {
    let dir = tempfile::tempdir().unwrap();
    let (i_cd, r_m, rho) = (100.0, 2.0, 0.5);
    let scene = load_scene(&sphere_scene(dir.path(), rho)).unwrap();
    for k in [0u32, 1, 2, 5] {
        let s = RenderSettings {
            max_bounces: Some(k),
            russian_roulette_from: None,
            ..settings(&[Coding::Spectral, Coding::Rgb, Coding::NStep(9)], 2048)
        };
        let r = render(&scene, &s, None, None).unwrap();
        let series: f64 = (0..=k).map(|j| rho.powi(j as i32)).sum();
        let truth = rho / PI * i_cd / (r_m * r_m) * series;
        for (coding, c) in &r.targets[0].codings {
            let tol = 0.01 * truth + 4.0 * c.luminance_se_cd_m2;
            assert!(
                (c.luminance_cd_m2 - truth).abs() < tol,
                "{coding}, k = {k}: {} vs {truth}",
                c.luminance_cd_m2
            );
        }
    }
    // The limit with Russian roulette (unbiased, so only noisier): 60 bounces
    // leave ρ⁶¹ ≈ 4e-19 of the series out.
    for sampler in [SamplerKind::Sobol, SamplerKind::Independent] {
        let s = RenderSettings {
            max_bounces: Some(60),
            russian_roulette_from: Some(1),
            sampler,
            ..settings(&[Coding::Spectral], 16_384)
        };
        let r = render(&scene, &s, None, None).unwrap();
        let truth = rho / PI * i_cd / (r_m * r_m * (1.0 - rho));
        let c = &r.targets[0].codings[0].1;
        assert!(c.luminance_se_cd_m2 > 0.0, "roulette adds variance");
        assert!(
            (c.luminance_cd_m2 - truth).abs() < 0.01 * truth + 4.0 * c.luminance_se_cd_m2,
            "{sampler:?}: {} ± {} vs {truth}",
            c.luminance_cd_m2,
            c.luminance_se_cd_m2
        );
    }
}

/// The camera inside the same sphere (flat spectra, k = 2 bounces): every
/// pixel sees the wall, whose luminance is the same everywhere,
/// L = ρ/π · I/R² · (1 + ρ + ρ²); each pixel's Y (Rec. 709 weights of its
/// linear sRGB) must match it, and the PFM and PNG files must be written.
#[test]
fn the_camera_sees_the_uniform_sphere_wall() {
    use lightbooth::render::integrator::Transport;
    use lightbooth::render::sensor::render_camera;
    let dir = tempfile::tempdir().unwrap();
    let scene = load_scene(&sphere_scene(dir.path(), 0.5)).unwrap();
    let transport = Transport {
        max_bounces: Some(2),
        russian_roulette_from: None,
        light_sampler: lightbooth::render::LightSampling::Power,
    };
    let img = render_camera(
        &scene,
        scene.camera.as_ref().unwrap(),
        Coding::Srgb,
        2,
        &transport,
        1,
        None,
    )
    .unwrap();
    // The lamp's candela are in V(λ) (issue 46); the camera's sRGB is in the
    // renderer's observer, whose ȳ weighs the flat spectrum by Σȳ/ΣV.
    let [_, ybar, _] = Cmf::of(lightbooth::render::coding::OBSERVER).on_grid(&Grid::one_nm());
    let [_, v, _] = Cmf::of(lightbooth::colorimetry::PHOTOMETRIC_OBSERVER).on_grid(&Grid::one_nm());
    let in_observer = ybar.iter().sum::<f64>() / v.iter().sum::<f64>();
    let truth = 0.5 / PI * 100.0 / 4.0 * (1.0 + 0.5 + 0.25) * in_observer;
    for p in &img.rgb {
        let y = 0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64;
        assert!((y / truth - 1.0).abs() < 1e-4, "{y} vs {truth}");
    }
    img.write(&dir.path().join("s.pfm")).unwrap();
    img.write(&dir.path().join("s.png")).unwrap();
}

/// The booth's CYLINDER geometry with every spectrum flat (reflectances and
/// the light's SPD): then every coding must give the same colour (the study:
/// RGB is right when all spectra are flat). The only difference allowed is
/// the colorimetric sum itself: N-step integrates on the 5 nm grid and
/// spectral on the 1 nm grid, whose Σȳ·Δλ for a flat spectrum differ by
/// `grid_rel` (computed below); RGB reproduces the light's 1 nm XYZ exactly.
#[test]
fn with_flat_spectra_every_coding_gives_the_same_colour() {
    use lightbooth::colorimetry::{Cmf, Observer};
    let dir = tempfile::tempdir().unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    std::fs::copy(root.join("luminaires/mr16_ctb.ies"), dir.path().join("mr16.ies")).unwrap();
    let text = std::fs::read_to_string(root.join("cylinder.toml")).unwrap();
    let text = text
        .replace("\"spectra/blue_carpet.csv:blue_carpet\"", "0.05")
        .replace("\"spectra/colorchecker_classic.csv:p14_green\"", "0.3")
        .replace("\"spectra/white_paint.csv:white_paint\"", "0.85")
        .replace("luminaires/mr16_ctb.ies", "mr16.ies")
        .replace("blackbody_k = 3200", "spd = \"flat.csv:e\"")
        .replace("filter = \"spectra/ctb_filter.csv:full_half_ctb\"\n", "");
    let path = write_scene(dir.path(), "flat.toml", &text);
    let scene = load_scene(&path).unwrap();
    let s = RenderSettings {
        targets: Some(vec!["h02".into(), "h10".into(), "h20".into()]),
        ..settings(&Coding::ALL, 2048)
    };
    let r = render(&scene, &s, None, None).unwrap();
    let cmf = Cmf::of(Observer::JuddVos);
    let sum = |g: &Grid, step: f64| cmf.on_grid(g)[1].iter().sum::<f64>() * step;
    let grid_rel = (sum(&Grid::analysis(), 5.0) / sum(&Grid::one_nm(), 1.0) - 1.0).abs();
    for t in &r.targets {
        let spectral = t.coding("spectral").unwrap();
        for (name, c) in &t.codings {
            let tol = if name.starts_with("nstep") {
                grid_rel + 1e-5
            } else {
                1e-5
            };
            let dy = c.luminance_cd_m2 / spectral.luminance_cd_m2 - 1.0;
            assert!(
                dy.abs() <= tol,
                "{}: {name} Y differs by {dy:e} (allowed {tol:e})",
                t.id
            );
            assert!(
                (c.x - spectral.x).abs() < 1e-4 && (c.y - spectral.y).abs() < 1e-4,
                "{}: {name} xy ({}, {}) vs spectral ({}, {})",
                t.id,
                c.x,
                c.y,
                spectral.x,
                spectral.y
            );
        }
    }
}

/// `nstep81` is the spectral solution at the 5 nm samples: the same paths, and
/// every channel product at 380, 385, … nm uses the same numbers (the 1 nm
/// spectra are the 5 nm ones linearly interpolated, so they agree at the
/// knots), hence equal to rounding.
#[test]
fn nstep81_is_spectral_at_the_5nm_samples() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let scene = load_scene(&root.join("cylinder.toml")).unwrap();
    let s = RenderSettings {
        targets: Some(vec!["h03".into(), "h15".into()]),
        ..settings(&[Coding::NStep(81), Coding::Spectral], 1024)
    };
    let r = render(&scene, &s, None, None).unwrap();
    for t in &r.targets {
        let n81 = &t.coding("nstep81").unwrap().bands;
        let sp = &t.coding("spectral").unwrap().bands;
        for (i, v) in n81.iter().enumerate() {
            let w = sp[5 * i];
            assert!(
                (v - w).abs() <= 1e-9 * w.abs().max(1e-12),
                "{} at {} nm: {v} vs {w}",
                t.id,
                380 + 5 * i
            );
        }
    }
}

/// A fixed seed gives bit-identical results on 1 and 2 threads.
#[test]
fn a_fixed_seed_is_bit_identical_on_one_and_two_threads() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let scene = load_scene(&root.join("cylinder.toml")).unwrap();
    let base = RenderSettings {
        targets: Some(vec!["h01".into(), "h11".into()]),
        seed: 42,
        ..settings(&[Coding::Rgb, Coding::NStep(9), Coding::Spectral], 4096)
    };
    let one = render(
        &scene,
        &RenderSettings {
            threads: Some(1),
            ..base.clone()
        },
        None,
        None,
    )
    .unwrap();
    let two = render(
        &scene,
        &RenderSettings {
            threads: Some(2),
            ..base.clone()
        },
        None,
        None,
    )
    .unwrap();
    let json = |r: &lightbooth::render::RenderResult| serde_json::to_string(&r.targets).unwrap();
    assert_eq!(json(&one), json(&two));
    let other_seed = render(&scene, &RenderSettings { seed: 43, ..base }, None, None).unwrap();
    assert_ne!(json(&one), json(&other_seed), "the seed must matter");
}

/// Issue 46: every booth lamp rendered 0.435 % too dim, because a lamp's
/// candela were turned into W/(sr·nm) with the renderer's analysis observer
/// (Judd–Vos ȳ) instead of V(λ), the function that defines the candela
/// (CIE 1924 photopic, tabulated as CIE 1931 ȳ: CIE S 017, ISO 23539).
///
/// A plain luminaire of I0 cd with a 2856 K blackbody spectrum (not flat,
/// so the two functions differ) at d m straight above a Lambertian plane of
/// reflectance ρ: the plane's radiance is ρ·E/π with E = I0/d², so its
/// V(λ)-weighted luminance, 683 lm/W · Σ L(λ)·V(λ)·1 nm of the `spectral`
/// coding's 1 nm radiance, is exactly ρ·I0/(π·d²). The plane is alone (no
/// interreflection) and the radiometer's field 0.01°, so the only error is
/// the render's own: its relative SE must be ≤ 0.01 %, and the luminance
/// within 4 of those SEs of the truth, plus 1e-6 for the rounding of the
/// bands' single-precision sums (the estimate here is exact: SE 0; before
/// the fix it was 0.146 % low).
#[test]
fn a_lamps_candela_are_v_lambda_so_a_booth_lamp_is_not_0_44_percent_dim() {
    use lightbooth::colorimetry::{Cmf, Observer, KM_LM_PER_W};
    let dir = tempfile::tempdir().unwrap();
    let (i0, d, rho) = (250.0, 1.5, 0.8);
    let text = format!(
        r#"
name = "one lamp over a white patch"
[radiometer]
position = [0.7, 1.0, 0.4]
field_deg = 0.01
[[target]]
id = "patch"
point = [0.0, 0.0, 0.0]
[materials]
white = {{ reflectance = {rho} }}
[[light]]
id = "lamp"
position = [0.0, {d}, 0.0]
intensity_cd = {i0}
blackbody_k = 2856
[[quad]]
corner = [-2.0, 0.0, -2.0]
edge_u = [4.0, 0.0, 0.0]
edge_v = [0.0, 0.0, 4.0]
material = "white"
"#
    );
    let path = dir.path().join("lamp.toml");
    std::fs::write(&path, text).unwrap();
    let scene = load_scene(&path).unwrap();
    let r = render(&scene, &settings(&[Coding::Spectral], 4096), None, None).unwrap();
    let (_, c) = &r.targets[0].codings[0];
    let relative_se = c.luminance_se_cd_m2 / c.luminance_cd_m2;
    assert!(
        relative_se <= 1e-4,
        "the render's relative SE is {relative_se:e}, above 0.01 %"
    );
    let v_lambda = &Cmf::of(Observer::Cie1931).on_grid(&Grid::one_nm())[1];
    assert_eq!(c.bands.len(), v_lambda.len(), "the spectral coding's 1 nm bands");
    let luminance_v: f64 = KM_LM_PER_W * c.bands.iter().zip(v_lambda).map(|(l, v)| l * v).sum::<f64>();
    let truth = rho * i0 / (PI * d * d);
    let allowed_standard_errors = 4.0;
    assert!(
        (luminance_v / truth - 1.0).abs() <= allowed_standard_errors * relative_se + 1e-6,
        "V(λ)-weighted luminance {luminance_v} cd/m², analytic ρ·I0/(π·d²) = {truth} cd/m²: off by {:.4} % \
         at a relative SE of {:.5} %",
        100.0 * (luminance_v / truth - 1.0),
        100.0 * relative_se
    );
}
