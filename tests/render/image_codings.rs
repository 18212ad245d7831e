//! Every coding of a camera image from one set of paths (issue 48, part 1):
//! the images of a multi-coding render are each coding's own render, two
//! codings that agree on every path differ by exactly nothing with no noise
//! (the closed form), the paired noise predicts the spread of the
//! difference over independent seeds, and the layered files open in
//! OpenEXR's own reader and the `matfile` crate.

use std::path::{Path, PathBuf};
use std::process::Command;

use lightbooth::colorimetry::{Observer, Xyz};
use lightbooth::export::image::write_camera_images;
use lightbooth::render::camera::{render_camera_image, render_camera_images, CameraImages, CameraSettings, Y};
use lightbooth::render::integrator::Transport;
use lightbooth::render::{load_scene, Coding, LightSampling, Scene};

/// Paths capped at 5 bounces and no roulette: the roulette's survival is
/// the largest channel of every coding's throughput, so with it a path's
/// length would depend on which codings ride along.
const CAPPED: Transport = Transport {
    max_bounces: Some(5),
    russian_roulette_from: None,
    light_sampler: LightSampling::Power,
};

fn settings(codings: &[Coding], seed: u64, spp: u32) -> CameraSettings {
    CameraSettings {
        codings: codings.to_vec(),
        reference: None,
        se_every_coding: false,
        observer: Observer::JuddVos,
        transport: CAPPED,
        seed,
        min_spp: spp,
        first_sample: 0,
        max_spp: spp,
        target_relative_se: None,
        time_budget: None,
    }
}

fn cylinder() -> Scene {
    load_scene(Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cylinder.toml"))).unwrap()
}

/// A small view of CYLINDER's camera (its framing, fewer pixels).
fn small_camera(scene: &Scene, width: u32, height: u32) -> lightbooth::render::scene::Camera {
    let mut camera = scene.camera.clone().unwrap();
    camera.width = width;
    camera.height = height;
    camera
}

/// A booth of flat (grey) surfaces under a 3200 K isotropic lamp: every
/// reflectance is the same at every wavelength, so the `rgb` and `srgb`
/// codings carry each path's light exactly as `spectral` does (a grey ρ is
/// (ρ, ρ, ρ) in RGB, and XYZ is linear in the light), while `nstep9`'s band
/// means of the lamp's spectrum give a slightly different XYZ.
fn grey_booth(dir: &Path) -> PathBuf {
    let path = dir.join("grey_booth.toml");
    std::fs::write(
        &path,
        r#"
name = "GREY"
[radiometer]
position = [0.0, 1.0, 1.5]
field_deg = 1.0
[[target]]
id = "floor"
point = [0.0, 0.0, 0.0]
[materials]
light_grey = { reflectance = 0.8 }
mid_grey = { reflectance = 0.4 }
dark_grey = { reflectance = 0.1 }
[[light]]
id = "lamp"
position = [0.2, 1.6, 0.1]
intensity_cd = 150.0
blackbody_k = 3200
[[quad]]
corner = [-1.0, 0.0, -1.0]
edge_u = [2.0, 0.0, 0.0]
edge_v = [0.0, 0.0, 2.0]
material = "mid_grey"
[[quad]]
corner = [-1.0, 0.0, -1.0]
edge_u = [2.0, 0.0, 0.0]
edge_v = [0.0, 2.0, 0.0]
material = "light_grey"
[[quad]]
corner = [-1.0, 0.0, -1.0]
edge_u = [0.0, 0.0, 2.0]
edge_v = [0.0, 2.0, 0.0]
material = "dark_grey"
[camera]
position = [0.3, 1.0, 1.6]
look_at = [-0.2, 0.5, -0.5]
fov_deg = 60.0
width = 12
height = 9
"#,
    )
    .unwrap();
    path
}

/// The CIELAB white of these tests: 100 cd/m² equal-energy-ish (x, y of D65).
fn white() -> Xyz {
    Xyz::new(95.047, 100.0, 108.883)
}

/// A multi-coding render gives each coding exactly the image its own render
/// gives (same seed, same paths): the codings ride along the same paths
/// without changing them.
#[test]
fn each_coding_of_a_multi_coding_image_is_its_own_render_bit_for_bit() {
    let scene = cylinder();
    let camera = small_camera(&scene, 10, 6);
    let codings = [Coding::Rgb, Coding::NStep(9), Coding::Spectral];
    let all = render_camera_images(&scene, &camera, &settings(&codings, 5, 8), None, None).unwrap();
    assert_eq!(all.images.len(), 3);
    assert_eq!(
        all.reference_image().coding,
        Coding::Spectral,
        "the last is the reference"
    );
    for (i, coding) in codings.iter().enumerate() {
        let alone = render_camera_image(&scene, &camera, &settings(&[*coding], 5, 8), None, None).unwrap();
        let together = &all.images[i];
        assert_eq!(together.coding, *coding);
        for k in 0..alone.stride() {
            assert_eq!(together.plane(k), alone.plane(k), "{coding} quantity {k}");
            assert_eq!(together.se_plane(k), alone.se_plane(k), "{coding} SE of quantity {k}");
        }
    }
}

/// The closed form: on the grey booth, `rgb` and `srgb` equal `spectral` on
/// every path, so their ΔE00 against it is 0 (to f32 rounding) and the
/// paired difference has no noise, while two independent renders of the
/// same image would differ by the images' own noise. `nstep9` differs in
/// the mean (its band means of the lamp), still with a paired noise far
/// below the independent one.
#[test]
fn codings_equal_on_every_path_differ_by_zero_with_zero_paired_noise() {
    let dir = tempfile::tempdir().unwrap();
    let scene = load_scene(&grey_booth(dir.path())).unwrap();
    let camera = scene.camera.clone().unwrap();
    let codings = [Coding::Rgb, Coding::Srgb, Coding::NStep(9), Coding::Spectral];
    let images = render_camera_images(&scene, &camera, &settings(&codings, 3, 32), None, None).unwrap();
    let reference = images.reference_image();
    let lit = (0..reference.samples.len())
        .filter(|&p| reference.plane(reference.xyz_index() + Y)[p] > 0.5)
        .count();
    assert!(
        lit > reference.samples.len() / 2,
        "the view shows lit walls: {lit} pixels"
    );
    for c in 0..2 {
        let d = images.difference(c, white());
        println!("{d:?}");
        assert!(d.max < 1e-3, "{}: ΔE00 max {}", d.coding, d.max);
        assert!(d.noise_paired < 1e-4, "{}: paired noise {}", d.coding, d.noise_paired);
        assert!(
            d.noise_independent > 1e-2 && d.noise_independent > 1e3 * d.noise_paired.max(1e-12),
            "{}: independent noise {} against paired {}",
            d.coding,
            d.noise_independent,
            d.noise_paired
        );
    }
    let d = images.difference(2, white());
    println!("{d:?}");
    assert!(
        d.mean > 1e-3,
        "nstep9 differs from spectral under a blackbody: {}",
        d.mean
    );
    assert!(
        d.noise_paired < 0.1 * d.noise_independent,
        "the paired noise {} is far below the independent {}",
        d.noise_paired,
        d.noise_independent
    );
}

/// The paired noise is the difference's own: over 24 seeds, the spread of
/// CYLINDER's mean ΔE00 of `nstep3` against `spectral` stays within the
/// predicted standard error `se_mean` (an upper bound, see its doc) and is
/// not far below it, while an independent render's noise is larger.
#[test]
fn the_paired_standard_error_predicts_the_spread_over_seeds() {
    let scene = cylinder();
    let camera = small_camera(&scene, 8, 5);
    let codings = [Coding::NStep(3), Coding::Spectral];
    let runs: Vec<_> = (0..24u64)
        .map(|seed| {
            let images =
                render_camera_images(&scene, &camera, &settings(&codings, 100 + seed, 16), None, None).unwrap();
            images.difference(0, white())
        })
        .collect();
    let means: Vec<f64> = runs.iter().map(|d| d.mean).collect();
    let m = means.iter().sum::<f64>() / 24.0;
    let sd = (means.iter().map(|v| (v - m).powi(2)).sum::<f64>() / 23.0).sqrt();
    let predicted = (runs.iter().map(|d| d.se_mean.powi(2)).sum::<f64>() / 24.0).sqrt();
    println!("mean ΔE00 {m:.4}, spread over seeds {sd:.3e}, predicted SE {predicted:.3e}");
    assert!(m > 0.05, "nstep3 is visibly off spectral on the gradient: {m}");
    // 24 seeds: the sample SD is within ±30 % of the truth 95 % of the time.
    assert!(sd < 1.4 * predicted, "spread {sd} above the predicted SE {predicted}");
    assert!(
        sd > 0.25 * predicted,
        "spread {sd} far below the predicted SE {predicted}"
    );
    let independent = runs.iter().map(|d| d.noise_independent).sum::<f64>() / 24.0;
    let paired = runs.iter().map(|d| d.noise_paired).sum::<f64>() / 24.0;
    assert!(
        paired < independent,
        "paired {paired} against independent {independent}"
    );
}

/// Batches of paths (each with its own first path index, as a render
/// worker traces them) merged with `CameraImages::merge` are one render of
/// all their paths: every mean and SE, and the paired difference's noise,
/// agree within the f32 rounding of the stored moments (the merge tree
/// differs from one render's). A batch of another seed does not (so the
/// comparison can fail), nor does a batch that repeats the first paths; the
/// bytes a worker hands over read back bit for bit.
#[test]
fn batches_of_paths_merged_are_one_render_of_them_all() {
    let scene = cylinder();
    let camera = small_camera(&scene, 16, 10);
    let codings = [Coding::Rgb, Coding::NStep(9), Coding::Spectral];
    let batch = |first: u32, spp: u32, seed: u64| {
        let mut s = settings(&codings, seed, spp);
        s.first_sample = first;
        render_camera_images(&scene, &camera, &s, None, None).unwrap()
    };
    let whole = batch(0, 24, 7);
    let merged_of = |batches: &[(u32, u64)]| {
        let mut merged = batch(batches[0].0, 8, batches[0].1);
        for &(first, seed) in &batches[1..] {
            let b = batch(first, 8, seed);
            let bytes = b.to_bytes();
            let read = CameraImages::from_bytes(&bytes).unwrap();
            assert_eq!(read.to_bytes(), bytes, "the bytes read back bit for bit");
            merged.merge(&read).unwrap();
        }
        merged
    };
    // Worst relative disagreement of means and SEs, over every coding, pixel and quantity.
    let worst = |a: &CameraImages| -> (f64, f64) {
        let (mut mean, mut se) = (0.0f64, 0.0f64);
        for (x, w) in a.images.iter().zip(&whole.images) {
            assert_eq!(x.samples, w.samples);
            for k in 0..w.stride() {
                for (p, (mx, mw)) in x.plane(k).iter().zip(w.plane(k)).enumerate() {
                    let scale = (mw.abs() as f64).max(1e-3);
                    mean = mean.max((mx - mw).abs() as f64 / scale);
                    let (sx, sw) = (x.se_plane(k)[p] as f64, w.se_plane(k)[p] as f64);
                    se = se.max((sx - sw).abs() / sw.max(1e-4 * scale));
                }
            }
        }
        (mean, se)
    };
    let merged = merged_of(&[(0, 7), (8, 7), (16, 7)]);
    assert_eq!(merged.images[0].paths, whole.images[0].paths);
    let (mean, se) = worst(&merged);
    println!("merged batches against one render: means within {mean:.1e}, SEs within {se:.1e} (relative)");
    assert!(mean < 1e-5, "means differ by {mean} (relative)");
    assert!(se < 1e-3, "standard errors differ by {se} (relative)");
    let (a, b) = (merged.difference(1, white()), whole.difference(1, white()));
    assert!((a.mean - b.mean).abs() < 1e-5 * b.mean, "{} against {}", a.mean, b.mean);
    assert!(
        (a.noise_paired - b.noise_paired).abs() < 1e-3 * b.noise_paired,
        "paired noise {} against {}",
        a.noise_paired,
        b.noise_paired
    );
    for wrong in [[(0, 7), (8, 7), (16, 8)], [(0, 7), (8, 7), (0, 7)]] {
        let (mean, _) = worst(&merged_of(&wrong));
        assert!(
            mean > 1e-3,
            "batches {wrong:?} are not the paths of one render, yet agree to {mean}"
        );
    }
    let other_size = render_camera_images(
        &scene,
        &small_camera(&scene, 8, 5),
        &settings(&codings, 7, 8),
        None,
        None,
    )
    .unwrap();
    let err = merged_of(&[(0, 7)]).merge(&other_size).unwrap_err();
    assert!(err.contains("8 × 5") && err.contains("16 × 10"), "{err}");
    let mut cut = whole.to_bytes();
    cut.truncate(cut.len() - 4);
    let err = CameraImages::from_bytes(&cut).unwrap_err();
    assert!(err.contains("not"), "{err}");
}

/// The stopping rule follows the reference, or every coding with the flag.
#[test]
fn the_se_target_stops_on_the_reference_or_on_every_coding() {
    let scene = cylinder();
    let camera = small_camera(&scene, 6, 4);
    let mut s = settings(&[Coding::Rgb, Coding::Spectral], 9, 8);
    s.max_spp = 4096;
    s.target_relative_se = Some(0.05);
    let on_reference = render_camera_images(&scene, &camera, &s, None, None).unwrap();
    s.se_every_coding = true;
    let on_every = render_camera_images(&scene, &camera, &s, None, None).unwrap();
    for images in [&on_reference, &on_every] {
        assert_eq!(
            images.reference_image().stop,
            lightbooth::render::camera::StopReason::Converged
        );
    }
    let worst = |images: &CameraImages, c: usize| {
        let img = &images.images[c];
        let k = img.xyz_index() + Y;
        let floor = 0.01 * img.plane(k).iter().map(|v| *v as f64).sum::<f64>() / img.samples.len() as f64;
        img.plane(k)
            .iter()
            .zip(img.se_plane(k))
            .map(|(y, se)| se as f64 / (*y as f64).abs().max(floor))
            .fold(0.0, f64::max)
    };
    assert!(worst(&on_reference, 1) <= 0.05 + 1e-6, "{}", worst(&on_reference, 1));
    assert!(worst(&on_every, 0) <= 0.05 + 1e-6 && worst(&on_every, 1) <= 0.05 + 1e-6);
    // A reference that is not rendered is refused, naming the codings.
    let mut bad = settings(&[Coding::Rgb, Coding::Spectral], 1, 4);
    bad.reference = Some(Coding::NStep(9));
    let e = render_camera_images(&scene, &camera, &bad, None, None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("nstep9") && e.contains("rgb,spectral"), "{e}");
}

/// The layered files, read by programs the project did not write: the EXR
/// by OpenEXR's own Python binding (a layer per coding, `nstep9.X`,
/// `nstep9.SE.X`, one `paths`), the MAT-file by the `matfile` crate (each
/// coding's variables under its prefix), each value the image's own.
#[test]
fn the_layered_exr_and_mat_open_in_other_readers_with_a_layer_per_coding() {
    let scene = cylinder();
    let camera = small_camera(&scene, 6, 4);
    let codings = [Coding::Srgb, Coding::NStep(9), Coding::Spectral];
    let images = render_camera_images(&scene, &camera, &settings(&codings, 2, 4), None, None).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let exr = dir.path().join("layers.exr");
    assert_eq!(write_camera_images(&images, &exr).unwrap(), vec![exr.clone()]);
    let py = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/py/bin/python");
    let out = Command::new(&py)
        .arg("-c")
        .arg(
            r#"
import json, sys
import OpenEXR
with OpenEXR.File(sys.argv[1], separate_channels=True) as f:
    part = f.parts[0]
    header = {k: str(v) for k, v in part.header.items()}
    channels = {n: float(c.pixels[2, 1]) for n, c in part.channels.items()}
    print(json.dumps({"header": header, "channels": channels}))
"#,
        )
        .arg(&exr)
        .output()
        .expect("run the venv's python (tests/setup.sh installs OpenEXR there)");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let read: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(read["header"]["lightbooth.codings"], "srgb,nstep9,spectral");
    assert_eq!(read["header"]["lightbooth.reference"], "spectral");
    let ch = &read["channels"];
    let at = |img: usize, k: usize| images.images[img].plane(k)[2 * 6 + 1] as f64;
    let se_at = |img: usize, k: usize| images.images[img].se_plane(k)[2 * 6 + 1] as f64;
    for (i, layer) in ["srgb", "nstep9", "spectral"].iter().enumerate() {
        let x0 = images.images[i].xyz_index();
        assert_eq!(ch[format!("{layer}.Y")].as_f64().unwrap(), at(i, x0 + Y), "{layer}.Y");
        assert_eq!(
            ch[format!("{layer}.SE.Y")].as_f64().unwrap(),
            se_at(i, x0 + Y),
            "{layer}.SE.Y"
        );
    }
    assert_eq!(ch["srgb.R"].as_f64().unwrap(), at(0, 0));
    assert!(
        ch.get("spectral.S0.550,000000nm").is_some(),
        "the spectral layer's 1 nm bands"
    );
    assert_eq!(ch["paths"].as_f64().unwrap(), 4.0);
    let names = ch.as_object().unwrap().len();
    assert_eq!(
        names,
        2 * ((3 + 6) + (9 + 6) + (401 + 6)) + 1,
        "every channel and its SE, and paths"
    );

    let mat = dir.path().join("layers.mat");
    write_camera_images(&images, &mat).unwrap();
    let parsed = matfile::MatFile::parse(std::fs::File::open(&mat).unwrap()).expect("a MAT-file MATLAB can load");
    for (i, prefix) in ["srgb", "nstep9", "spectral"].iter().enumerate() {
        let xyz = parsed.find_by_name(&format!("{prefix}_XYZ")).unwrap();
        assert_eq!(xyz.size(), &vec![4, 6, 3]);
        let matfile::NumericData::Single { real, .. } = xyz.data() else {
            panic!("{prefix}_XYZ is not single")
        };
        // Column-major H × W × 3: Y of pixel (x = 1, y = 2) at 2 + 4·1 + 24·1.
        assert_eq!(real[2 + 4 + 24] as f64, at(i, images.images[i].xyz_index() + Y));
    }
    assert!(parsed.find_by_name("spectral_radiance").is_some() && parsed.find_by_name("paths").is_some());

    // ENVI: a file pair per coding and its SE pair.
    let bsq = dir.path().join("layers.bsq");
    let written = write_camera_images(&images, &bsq).unwrap();
    assert_eq!(written.len(), 3 * 4, "{written:?}");
    assert!(dir.path().join("layers.nstep9.hdr").exists());
}

/// The command line: `--image-coding` takes a list, the JSON states each
/// coding's ΔE00 against the reference with its paired SE and both noises
/// and the white it used (CYLINDER's target h21, rendered here), and a
/// reference that is not rendered is refused before any work.
#[test]
fn the_cli_renders_a_list_of_image_codings_and_reports_each_against_the_reference() {
    let dir = tempfile::tempdir().unwrap();
    let exr = dir.path().join("cyl.exr");
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cylinder.toml");
    let out = Command::new(env!("CARGO_BIN_EXE_lightbooth"))
        .args([
            "render",
            scene,
            "--targets",
            "h21",
            "--target-se",
            "0",
            "--samples",
            "2048",
        ])
        .args([
            "--image-coding",
            "rgb,nstep9,spectral",
            "--spp",
            "2",
            "--json",
            "--image",
        ])
        .arg(&exr)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let image = &v["image"];
    assert_eq!(image["codings"], serde_json::json!(["rgb", "nstep9", "spectral"]));
    assert_eq!(image["reference"], "spectral");
    assert!(image["white"]["source"].as_str().unwrap().contains("h21"), "{image}");
    let d = image["differences"].as_array().unwrap();
    assert_eq!(d.len(), 2);
    for (row, coding) in d.iter().zip(["rgb", "nstep9"]) {
        assert_eq!(row["coding"], coding);
        for key in ["mean", "p95", "max", "se_mean", "noise_paired", "noise_independent"] {
            assert!(row[key].as_f64().unwrap().is_finite(), "{key}: {row}");
        }
        assert!(
            row["noise_paired"].as_f64().unwrap() < row["noise_independent"].as_f64().unwrap(),
            "{row}"
        );
    }
    assert!(stderr.contains("image ΔE00 against spectral"), "{stderr}");
    assert!(exr.exists());

    let out = Command::new(env!("CARGO_BIN_EXE_lightbooth"))
        .args([
            "render",
            scene,
            "--image-coding",
            "rgb,spectral",
            "--image-reference",
            "nstep9",
            "--image",
        ])
        .arg(&exr)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        stderr.contains("--image-reference nstep9 is not one of --image-coding rgb,spectral"),
        "{stderr}"
    );
}

/// The booth's targets in the camera's view: CYLINDER's camera sees its 21
/// heights inside the image, top to bottom in order (h01 is the lowest),
/// and a point projects back to the pixel whose ray passes through it.
#[test]
fn cylinders_targets_project_into_its_camera_view_in_height_order() {
    use lightbooth::render::camera::{targets_in_view, Pinhole};
    let scene = cylinder();
    let camera = scene.camera.clone().unwrap();
    let seen = targets_in_view(&scene, &camera).unwrap();
    assert_eq!(seen.len(), 21);
    for t in &seen {
        assert!(t.inside && t.visible, "{t:?}");
    }
    for pair in seen.windows(2) {
        assert!(
            pair[1].y < pair[0].y,
            "{} is above {}: {pair:?}",
            pair[1].id,
            pair[0].id
        );
    }
    // The inverse of a pixel's ray: the point 2 m along the ray of image
    // point (37.25, 101.5) projects back to it.
    let pinhole = Pinhole::new(&camera);
    let dir = pinhole.direction(37.25, 101.5);
    let (x, y) = pinhole.project(camera.position + 2.0 * dir).unwrap();
    assert!((x - 37.25).abs() < 1e-9 && (y - 101.5).abs() < 1e-9, "({x}, {y})");
    assert!(pinhole.project(camera.position - dir).is_none(), "behind the camera");
    // A target hidden behind a wall: WHITE's patch seen from behind the back wall.
    let white = load_scene(Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/white.toml"))).unwrap();
    let mut behind = white.camera.clone().unwrap();
    behind.position = glam::DVec3::new(0.0, 1.0, -1.5);
    behind.look_at = glam::DVec3::new(0.0, 1.0, -0.6);
    let seen = targets_in_view(&white, &behind).unwrap();
    assert!(seen[0].inside && !seen[0].visible, "{:?}", seen[0]);
}
