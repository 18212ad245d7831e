//! The shipped booth scenes, scene validation, and the converged spectrum
//! cache for the simulated PR-650.

use std::path::{Path, PathBuf};

use lightbooth::render::{
    cache_file, converged_target_spectrum, load_scene, render, scene_hash, truth_hash, truth_settings, Coding,
    RenderSettings,
};
use lightbooth::spectrum::{Grid, SpectralUnit};

fn scenes() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes")
}

/// Every shipped scene declares its CIELAB white: the simple scenes the
/// WHITE scene's Spectralon, CYLINDER (and its F11 variant) the top target.
#[test]
fn every_scene_declares_its_cielab_white() {
    use lightbooth::render::scene::CielabWhite;
    let white_patch = CielabWhite::Target {
        scene: Some("white".into()),
        target: "patch".into(),
    };
    for name in ["red", "green", "blue"] {
        let s = load_scene(&scenes().join(format!("{name}.toml"))).unwrap();
        assert_eq!(s.cielab_white, Some(white_patch.clone()), "{name}");
    }
    let own = |t: &str| {
        Some(CielabWhite::Target {
            scene: None,
            target: t.into(),
        })
    };
    assert_eq!(
        load_scene(&scenes().join("white.toml")).unwrap().cielab_white,
        own("patch")
    );
    for f in ["cylinder.toml", "variants/cylinder_f11.toml", "truth/cylinder.toml"] {
        assert_eq!(load_scene(&scenes().join(f)).unwrap().cielab_white, own("h21"), "{f}");
    }
    // A diffuser white is computed from the scene: the WHITE spotlight
    // (110 cd along the normal from 1 m) on ρ = 1 gives 110/π cd/m² in
    // V(λ), the CIE 1931 ȳ that defines the candela (issue 46).
    let w = load_scene(&scenes().join("white.toml")).unwrap();
    let l = w.light_on_perfect_diffuser(
        glam::DVec3::new(0.0, 1.0, -0.6),
        glam::DVec3::new(0.0, std::f64::consts::FRAC_1_SQRT_2, std::f64::consts::FRAC_1_SQRT_2),
    );
    let y = lightbooth::colorimetry::xyz_from_radiance(&l, lightbooth::colorimetry::Observer::Cie1931)
        .unwrap()
        .y;
    assert!((y / (110.0 / std::f64::consts::PI) - 1.0).abs() < 1e-3, "{y}");
}

#[test]
fn the_five_booth_scenes_load_with_their_targets() {
    for name in ["white", "red", "green", "blue"] {
        let s = load_scene(&scenes().join(format!("{name}.toml"))).unwrap();
        assert_eq!(s.targets(), vec!["patch"], "{name}");
        assert_eq!(s.lights.len(), 1);
        assert!(s.camera.is_some());
    }
    let c = load_scene(&scenes().join("cylinder.toml")).unwrap();
    let ids: Vec<String> = (1..=21).map(|i| format!("h{i:02}")).collect();
    assert_eq!(c.targets(), ids.iter().map(String::as_str).collect::<Vec<_>>());
    assert_eq!(c.lights.len(), 2);
    // Sheet: y = 0.7505 + h, z = −0.40 + √(r² − (h − r)²), r = 0.1275.
    let r = 0.1275;
    for (i, t) in c.target_list.iter().enumerate() {
        let h = (i + 1) as f64 / 100.0;
        assert!((t.point.y - (0.7505 + h)).abs() < 1e-9);
        assert!((t.point.z - (-0.40 + (r * r - (h - r) * (h - r)).sqrt())).abs() < 1e-9);
    }
}

/// The WHITE scene: the standard (ρ = 0.99) is lit along its normal from
/// 1 m by I0 = 110 cd, so its direct luminance is ρ·I0/(π·1 m²) = 34.66 cd/m²
/// (the sheet's "about 34"); the black booth adds little, and the 1° field
/// sees slightly off-axis intensity, within 1 %.
#[test]
fn the_white_standard_reads_what_the_sheet_says() {
    let s = load_scene(&scenes().join("white.toml")).unwrap();
    let r = render(
        &s,
        &RenderSettings {
            codings: vec![Coding::Spectral],
            samples: 2048,
            target_relative_se: None,
            ..RenderSettings::default()
        },
        None,
        None,
    )
    .unwrap();
    let y = r.targets[0].codings[0].1.luminance_cd_m2;
    let truth = 0.99 * 110.0 / std::f64::consts::PI;
    assert!((y / truth - 1.0).abs() < 0.01, "{y} vs {truth}");
}

/// The study's qualitative result in CYLINDER: along the 21 points the
/// luminance rises (mutual illumination from the card), dips, and rises
/// again (direct light); N-step with N ≥ 9 agrees with spectral within a few
/// percent (asserted: 5 %; N = 81 samples the same spectra at 5 nm instead
/// of 1 nm: 1 %). The RGB and 3-step deviations are reported in the JSON
/// (`deviation_from_spectral`), not asserted: they depend on the spectra.
#[test]
fn cylinder_profile_rises_dips_and_rises_and_nstep9_tracks_spectral() {
    let s = load_scene(&scenes().join("cylinder.toml")).unwrap();
    let r = render(
        &s,
        &RenderSettings {
            samples: 8192,
            target_relative_se: None,
            ..RenderSettings::default()
        },
        None,
        None,
    )
    .unwrap();
    let y: Vec<(f64, f64)> = r
        .targets
        .iter()
        .map(|t| {
            let c = t.coding("spectral").unwrap();
            (c.luminance_cd_m2, c.luminance_se_cd_m2)
        })
        .collect();
    let argmax = |range: std::ops::Range<usize>| range.max_by(|&a, &b| y[a].0.total_cmp(&y[b].0)).unwrap();
    let argmin = |range: std::ops::Range<usize>| range.min_by(|&a, &b| y[a].0.total_cmp(&y[b].0)).unwrap();
    let separated = |hi: usize, lo: usize| y[hi].0 - y[lo].0 > 4.0 * (y[hi].1 + y[lo].1);
    let peak = argmax(2..9); // h03–h09: the mutual-illumination bump
    let dip = argmin(peak + 1..16);
    assert!(separated(peak, 0), "rises from the contact line: {y:?}");
    assert!(separated(peak, dip), "dips after the bump: {y:?}");
    assert!(separated(20, peak), "rises again towards the top: {y:?}");
    for t in &r.targets {
        let sp = t.coding("spectral").unwrap();
        for (name, tol) in [("nstep9", 0.05), ("nstep27", 0.05), ("nstep81", 0.01)] {
            let c = t.coding(name).unwrap();
            let dy = c.luminance_cd_m2 / sp.luminance_cd_m2 - 1.0;
            let noise = 4.0 * (c.luminance_se_cd_m2 + sp.luminance_se_cd_m2) / sp.luminance_cd_m2;
            assert!(dy.abs() < tol + noise, "{} {name}: {:+.2} %", t.id, 100.0 * dy);
        }
    }
    for name in ["rgb", "srgb", "nstep3", "nstep9", "nstep27", "nstep81"] {
        let d = &r.deviation_from_spectral.iter().find(|d| d.0 == name).unwrap().1;
        assert_eq!(d.y_rel.len(), 21);
    }
}

/// Writes a minimal valid scene, with `edit` applied to its text.
fn scene_with(dir: &Path, edit: impl Fn(String) -> String) -> PathBuf {
    std::fs::copy(scenes().join("luminaires/mr16_ctb.ies"), dir.join("spot.ies")).unwrap();
    std::fs::write(dir.join("refl.csv"), "nm,grey,shiny\n380,0.5,0.9\n780,0.5,1.2\n").unwrap();
    let text = r#"name = "probe"
[radiometer]
position = [0.0, 1.0, 1.0]
[[target]]
id = "centre"
point = [0.0, 0.0, 0.0]
[materials]
grey = { reflectance = "refl.csv:grey" }
[[light]]
id = "spot"
position = [0.0, 1.0, 0.0]
aim = [0.0, -1.0, 0.0]
ies = "spot.ies"
blackbody_k = 3200
[[quad]]
corner = [-1.0, 0.0, -1.0]
edge_u = [2.0, 0.0, 0.0]
edge_v = [0.0, 0.0, 2.0]
material = "grey"
"#;
    let p = dir.join("probe.toml");
    std::fs::write(&p, edit(text.to_string())).unwrap();
    p
}

#[test]
fn scene_errors_name_the_file_and_the_key() {
    let dir = tempfile::tempdir().unwrap();
    let ok = scene_with(dir.path(), |t| t);
    assert!(load_scene(&ok).is_ok(), "{:?}", load_scene(&ok).err());
    type Edit = Box<dyn Fn(String) -> String>;
    let cases: Vec<(&str, Edit, &str)> = vec![
        (
            "unknown key",
            Box::new(|t| t.replace("blackbody_k = 3200", "blackbody_k = 3200\ncolour = 1")),
            "colour",
        ),
        (
            "unknown cielab_white key",
            Box::new(|t| format!("{t}[cielab_white]\ntarget = \"centre\"\nsource = \"x\"\n")),
            "source",
        ),
        (
            "cielab_white with two kinds",
            Box::new(|t| format!("{t}[cielab_white]\ntarget = \"centre\"\nxyz = [1.0, 1.0, 1.0]\n")),
            "cielab_white",
        ),
        (
            "cielab_white naming no target",
            Box::new(|t| format!("{t}[cielab_white]\ntarget = \"top\"\n")),
            "cielab_white.target",
        ),
        (
            "cielab_white diffuser without a normal",
            Box::new(|t| format!("{t}[cielab_white]\nlight_on_perfect_diffuser = true\npoint = [0.0, 0.0, 0.0]\n")),
            "cielab_white.normal",
        ),
        (
            "missing spectrum file",
            Box::new(|t| t.replace("refl.csv:grey", "nothere.csv:grey")),
            "materials.grey.reflectance",
        ),
        (
            "missing column",
            Box::new(|t| t.replace("refl.csv:grey", "refl.csv:gray")),
            "materials.grey.reflectance",
        ),
        (
            "reflectance above 1",
            Box::new(|t| t.replace("refl.csv:grey", "refl.csv:shiny")),
            "materials.grey.reflectance",
        ),
        (
            "target off every surface",
            Box::new(|t| t.replace("point = [0.0, 0.0, 0.0]", "point = [0.0, 0.2, 0.0]")),
            "target[0] (centre).point",
        ),
        (
            "light inside geometry",
            Box::new(|t| t + "[[box]]\nmin = [-0.1, 0.9, -0.1]\nmax = [0.1, 1.1, 0.1]\nmaterial = \"grey\"\n"),
            "light[0].position",
        ),
        (
            "missing IES file",
            Box::new(|t| t.replace("spot.ies", "none.ies")),
            "light[0].ies",
        ),
        (
            "unknown material",
            Box::new(|t| t.replace("material = \"grey\"", "material = \"gold\"")),
            "quad[0].material",
        ),
    ];
    for (what, edit, key) in cases {
        let p = scene_with(dir.path(), edit);
        let e = load_scene(&p).expect_err(what).to_string();
        assert!(e.contains("probe.toml"), "{what}: {e}");
        assert!(e.contains(key), "{what}: `{e}` should name `{key}`");
    }
}

/// The converged spectrum for the simulated PR-650: on the 1 nm grid, in
/// W/(sr·m²·nm); cached by content hash so the second call reads the cache,
/// and an edited scene gets a new hash.
#[test]
fn converged_spectrum_is_cached_by_scene_content() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    let scene_path = scene_with(dir.path(), |t| t);
    let s = converged_target_spectrum(&scene_path, "centre", Some(&cache)).unwrap();
    assert!(s.grid().same_as(&Grid::one_nm()));
    assert_eq!(s.unit(), SpectralUnit::SpectralRadiance);
    // Direct light only reaches the eye here (a lone plane): L = ρ I0 / (π d²)
    // on the axis, I0 = 100 cd, d = 1 m, ρ = 0.5; the Y of the spectrum must agree.
    let y = lightbooth::colorimetry::xyz_from_radiance(&s, lightbooth::colorimetry::Observer::JuddVos)
        .unwrap()
        .y;
    let truth = 0.5 * 100.0 / std::f64::consts::PI;
    assert!((y / truth - 1.0).abs() < 0.005, "{y} vs {truth}");

    let scene = load_scene(&scene_path).unwrap();
    let hash = scene_hash(&scene).unwrap();
    let file = cache_file(
        &cache,
        &truth_hash(&scene, &truth_settings("centre")).unwrap(),
        "centre",
    );
    assert!(file.exists());
    // The cache keeps the truth's relative SE of Y beside it (issue 46).
    let cached = std::fs::read_to_string(&file).unwrap();
    assert!(cached.starts_with("nm,radiance,y_relative_se\n"), "{}", &cached[..40]);
    // Overwrite the cached values: the second call must return them.
    let mut text = String::from("nm,radiance,y_relative_se\n");
    for nm in 380..=780 {
        text.push_str(&format!("{nm},0.125,0.0009\n"));
    }
    std::fs::write(&file, text).unwrap();
    let again = converged_target_spectrum(&scene_path, "centre", Some(&cache)).unwrap();
    assert!(
        again.values().iter().all(|&v| v == 0.125),
        "the second call reads the cache"
    );
    let truth = lightbooth::render::converged_target_truth(&scene_path, "centre", Some(&cache)).unwrap();
    assert_eq!(truth.relative_se_y, 0.0009, "the truth's SE is read from the cache");
    // A cache file from before the SE was kept is a miss, not an SE of 0.
    std::fs::write(&file, "nm,radiance\n380,0.125\n780,0.125\n").unwrap();
    let recomputed = lightbooth::render::converged_target_truth(&scene_path, "centre", Some(&cache)).unwrap();
    assert!(recomputed.relative_se_y > 0.0 && recomputed.relative_se_y <= lightbooth::render::CONVERGED_RELATIVE_SE);

    // Editing the scene (or a file it references) changes the hash.
    let edited = scene_with(dir.path(), |t| t.replace("blackbody_k = 3200", "blackbody_k = 3000"));
    let hash2 = scene_hash(&load_scene(&edited).unwrap()).unwrap();
    assert_ne!(hash, hash2);
    std::fs::write(dir.path().join("refl.csv"), "nm,grey,shiny\n380,0.4,0.9\n780,0.4,1.0\n").unwrap();
    let hash3 = scene_hash(&load_scene(&edited).unwrap()).unwrap();
    assert_ne!(hash2, hash3, "a referenced CSV is part of the hash");
    let fresh = converged_target_spectrum(&edited, "centre", None).unwrap();
    assert!(fresh.values().iter().all(|&v| v != 0.125));
    // The in-memory cache returns the identical spectrum.
    assert_eq!(converged_target_spectrum(&edited, "centre", None).unwrap(), fresh);
    assert!(converged_target_spectrum(&edited, "nowhere", None).is_err());
}

/// Settings round-trip through JSON (the daemon receives them that way).
#[test]
fn render_settings_round_trip_through_json() {
    let s = RenderSettings {
        codings: vec![Coding::Rgb, Coding::NStep(9), Coding::Spectral],
        samples: 2048,
        ..RenderSettings::default()
    };
    let json = serde_json::to_string(&s).unwrap();
    assert!(json.contains(r#""codings":["rgb","nstep9","spectral"]"#), "{json}");
    let back: RenderSettings = serde_json::from_str(&json).unwrap();
    assert_eq!(back.codings, s.codings);
    assert_eq!(back.samples, 2048);
    let partial: RenderSettings = serde_json::from_str(r#"{"codings":["nstep27"]}"#).unwrap();
    // No bounce cap by default (JSON `null`), Russian roulette instead.
    assert_eq!(partial.max_bounces, None);
    assert_eq!(partial.russian_roulette_from, Some(3));
    assert!(json.contains(r#""max_bounces":null"#), "{json}");
    assert!(serde_json::from_str::<RenderSettings>(r#"{"codings":["cmyk"]}"#).is_err());
    assert!(serde_json::from_str::<RenderSettings>(r#"{"colour":1}"#).is_err());
}

/// The simulated PR-650 read a render with seed 1 and 5 bounces: the
/// comparison render's own first paths, with its bounce cap. The truth now
/// has its own seed, no bounce cap (Russian roulette) and 1 nm, and these
/// settings are in its cache key. Checked against an analytic answer that a
/// 5-bounce render cannot give: inside a closed sphere (R = 1 m, ρ = 0.8)
/// with an isotropic 100 cd point source at its centre, the wall's
/// irradiance is E_d = I/R² = 100 lx direct plus, from all interreflections,
/// E_ind = ρΦ/(4πR²(1 − ρ)) = 400 lx (Φ = 4πI), so L = ρ(E_d + E_ind)/π =
/// 127.3 cd/m²; five bounces keep only (1 − ρ⁵) of E_ind: 93.9 cd/m².
#[test]
fn simulated_truth_is_not_the_comparison_render() {
    let s = truth_settings("wall");
    let comparison = RenderSettings::default();
    assert_ne!(s.seed, comparison.seed);
    assert!((1..=64).all(|study_seed| s.seed != study_seed));
    assert_eq!(s.max_bounces, None);
    assert!(s.russian_roulette_from.is_some());
    assert_eq!(s.codings, vec![Coding::Spectral]);

    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("iso.ies"),
        "IESNA:LM-63-2002\n[TEST] isotropic 100 cd\nTILT=NONE\n1 -1 1 3 1 1 2 0 0 0\n1 1 0\n0 90 180\n0\n100 100 100\n",
    )
    .unwrap();
    let text = r#"name = "integrating sphere"
[radiometer]
position = [0.0, 0.3, 0.5]
[[target]]
id = "wall"
point = [0.0, 0.0, -1.0]
[materials]
white = { reflectance = 0.8 }
[[light]]
id = "bulb"
position = [0.0, 0.0, 0.0]
aim = [0.0, -1.0, 0.0]
ies = "iso.ies"
blackbody_k = 3200
[[sphere]]
centre = [0.0, 0.0, 0.0]
radius = 1.0
interior = "room"
material = "white"
[cielab_white]
target = "wall"
"#;
    let path = dir.path().join("sphere.toml");
    std::fs::write(&path, text).unwrap();
    let scene = load_scene(&path).unwrap();
    // The cache key changes with the truth's settings, not only the scene.
    let other = RenderSettings {
        seed: 1,
        ..truth_settings("wall")
    };
    assert_ne!(truth_hash(&scene, &s).unwrap(), truth_hash(&scene, &other).unwrap());

    let truth = lightbooth::colorimetry::xyz_from_radiance(
        &converged_target_spectrum(&path, "wall", None).unwrap(),
        lightbooth::colorimetry::Observer::JuddVos,
    )
    .unwrap()
    .y;
    let five = render(
        &scene,
        &RenderSettings {
            codings: vec![Coding::Spectral],
            max_bounces: Some(5),
            russian_roulette_from: None,
            target_relative_se: Some(1e-3),
            ..RenderSettings::default()
        },
        None,
        None,
    )
    .unwrap()
    .targets[0]
        .codings[0]
        .1
        .luminance_cd_m2;
    let (rho, pi) = (0.8f64, std::f64::consts::PI);
    let analytic = rho * (100.0 + rho * 100.0 / (1.0 - rho)) / pi;
    let analytic_five = rho * (100.0 + rho * 100.0 * (1.0 - rho.powi(5)) / (1.0 - rho)) / pi;
    assert!((truth / analytic - 1.0).abs() < 0.01, "truth {truth} vs {analytic}");
    assert!(
        (five / analytic_five - 1.0).abs() < 0.01,
        "5 bounces {five} vs {analytic_five}"
    );
}

/// A NaN light position used to panic the renderer or print `"Y": null`; a
/// NaN wall corner was silently dropped. Every non-finite number is now an
/// error naming the file and the key.
#[test]
fn nan_or_inf_anywhere_in_a_scene_is_an_error_naming_the_key() {
    let dir = tempfile::tempdir().unwrap();
    type Edit = Box<dyn Fn(String) -> String>;
    let cases: Vec<(Edit, &str)> = vec![
        (
            Box::new(|t| t.replace("position = [0.0, 1.0, 0.0]", "position = [0.0, nan, 0.0]")),
            "light[0].position[1]",
        ),
        (
            Box::new(|t| t.replace("corner = [-1.0, 0.0, -1.0]", "corner = [nan, 0.0, -1.0]")),
            "quad[0].corner[0]",
        ),
        (
            Box::new(|t| t.replace("position = [0.0, 1.0, 1.0]", "position = [0.0, 1.0, inf]")),
            "radiometer.position[2]",
        ),
        (
            Box::new(|t| t.replace("[radiometer]", "[radiometer]\nfield_deg = -inf")),
            "radiometer.field_deg",
        ),
        (
            Box::new(|t| t.replace("\"refl.csv:grey\"", "nan")),
            "materials.grey.reflectance",
        ),
        (
            Box::new(|t| t.replace("blackbody_k = 3200", "blackbody_k = 3200\nintensity_scale = inf")),
            "light[0].intensity_scale",
        ),
        (
            Box::new(|t| {
                t + "[camera]\nposition = [0.0, 1.0, 2.0]\nlook_at = [0.0, 0.0, nan]\nfov_deg = 40.0\nwidth = 8\nheight = 8\n"
            }),
            "camera.look_at[2]",
        ),
    ];
    for (edit, key) in cases {
        let p = scene_with(dir.path(), edit);
        let e = load_scene(&p).expect_err(key).to_string();
        assert!(e.contains("probe.toml"), "{key}: {e}");
        assert!(e.contains(&format!(": {key}: ")), "`{e}` should name `{key}`");
        assert!(e.contains("not a finite number"), "{e}");
    }
    // A NaN in a spectrum CSV is refused too, naming the file's line.
    std::fs::write(dir.path().join("nan.csv"), "nm,grey\n380,0.5\n580,NaN\n780,0.5\n").unwrap();
    let p = dir.path().join("nan_probe.toml");
    let text = std::fs::read_to_string(scene_with(dir.path(), |t| t.replace("refl.csv:grey", "nan.csv:grey"))).unwrap();
    std::fs::write(&p, text).unwrap();
    let e = load_scene(&p).expect_err("NaN in a CSV").to_string();
    assert!(e.contains("materials.grey.reflectance") && e.contains("nan.csv"), "{e}");
}

/// A camera looking nowhere, with `up` along its view, or with no field of
/// view rendered a black image; an image side of 0 was silently made 1.
#[test]
fn degenerate_camera_and_oversized_image_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    let camera = |position: &str, look_at: &str, up: &str, fov: &str, width: u32| {
        format!(
            "[camera]\nposition = {position}\nlook_at = {look_at}\nup = {up}\nfov_deg = {fov}\nwidth = {width}\nheight = 8\n"
        )
    };
    let good = camera("[0.0, 1.0, 2.0]", "[0.0, 0.0, 0.0]", "[0.0, 1.0, 0.0]", "40.0", 8);
    let ok = scene_with(dir.path(), |t| t + &good);
    assert!(load_scene(&ok).unwrap().camera.is_some());
    let cases = [
        (
            camera("[0.0, 1.0, 2.0]", "[0.0, 1.0, 2.0]", "[0.0, 1.0, 0.0]", "40.0", 8),
            "camera.look_at",
        ),
        (
            camera("[0.0, 2.0, 0.0]", "[0.0, 0.0, 0.0]", "[0.0, 1.0, 0.0]", "40.0", 8),
            "camera.up",
        ),
        (
            camera("[0.0, 1.0, 2.0]", "[0.0, 0.0, 0.0]", "[0.0, 0.0, 0.0]", "40.0", 8),
            "camera.up",
        ),
        (
            camera("[0.0, 1.0, 2.0]", "[0.0, 0.0, 0.0]", "[0.0, 1.0, 0.0]", "0.0", 8),
            "camera.fov_deg",
        ),
        (
            camera("[0.0, 1.0, 2.0]", "[0.0, 0.0, 0.0]", "[0.0, 1.0, 0.0]", "180.0", 8),
            "camera.fov_deg",
        ),
        (
            camera("[0.0, 1.0, 2.0]", "[0.0, 0.0, 0.0]", "[0.0, 1.0, 0.0]", "40.0", 0),
            "camera.width",
        ),
        (
            camera("[0.0, 1.0, 2.0]", "[0.0, 0.0, 0.0]", "[0.0, 1.0, 0.0]", "40.0", 100_000),
            "camera.width",
        ),
    ];
    for (block, key) in cases {
        let p = scene_with(dir.path(), |t| t + &block);
        let e = load_scene(&p).expect_err(key).to_string();
        assert!(e.contains(&format!("probe.toml: {key}: ")), "`{e}` should name `{key}`");
    }
}
