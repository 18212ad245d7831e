//! Benchmark of the measuring camera in every coding from one set of paths
//! (issue 48): CYLINDER's camera view (default 960 × 540) in all seven
//! codings at once against the reference coding (`spectral`) alone and the
//! cheapest coding (`rgb`) alone, the same paths per pixel each time.
//!
//! `cargo bench --bench image_codings -- --json [--size WxH] [--spp N]
//! [--pass N] [--runs N]` (defaults 960x540, 32 paths per pixel in passes
//! of 16, 3 runs) prints one JSON line per case with the medians of the runs:
//! wall seconds, CPU seconds (user + system of this process, from
//! `/proc/self/stat` in USER_HZ = 100 ticks), paths and rays per second
//! per core, and then a summary line with the cost of all seven codings as
//! a multiple of the reference alone, and the time the seven-coding render
//! would take to reach a per-pixel SE(Y) of 1 % of Y in the reference,
//! projected from the per-pixel variance measured here (each pixel needs
//! n·(SE/(0.01·Y))² paths, at least the paths it has; the camera's floor
//! for dark pixels, 1 % of the image's mean Y, applies as in the render).
//!
//! `--only all7` (or `spectral`, `rgb`) times one case, for a profiler.
//!
//! A timing, not a test: nothing here asserts a speed.

use std::path::Path;
use std::time::Instant;

use lightbooth::render::camera::{render_camera_images, CameraImages, CameraSettings, Y};
use lightbooth::render::{load_scene, Coding, RenderSettings};

/// CPU seconds (user + system) of this process so far.
fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    // Fields after the command's closing parenthesis: utime is the 14th
    // field of the line, the 12th after it.
    let after = stat.rsplit_once(')').map(|(_, r)| r).unwrap_or("");
    let fields: Vec<&str> = after.split_whitespace().collect();
    let ticks = |i: usize| fields.get(i).and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0);
    (ticks(11) + ticks(12)) / 100.0
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Paths the reference image would need for SE(Y) ≤ 1 % of Y at every pixel.
fn paths_to_one_percent(images: &CameraImages) -> f64 {
    let img = images.reference_image();
    let k = img.xyz_index() + Y;
    let y = img.plane(k);
    let se = img.se_plane(k);
    let floor = 0.01 * y.iter().map(|v| *v as f64).sum::<f64>() / y.len() as f64;
    y.iter()
        .zip(&se)
        .zip(&img.samples)
        .map(|((y, se), n)| {
            let target = 0.01 * (*y as f64).abs().max(floor);
            let n = *n as f64;
            (n * (*se as f64 / target).powi(2)).max(n)
        })
        .sum()
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let value = |flag: &str| {
        args.iter()
            .position(|a| a == flag)
            .and_then(|i| args.get(i + 1))
            .cloned()
    };
    if !args.iter().any(|a| a == "--json") {
        eprintln!("image_codings: run with -- --json (a --json timing, no criterion run)");
        return;
    }
    let (width, height) = value("--size")
        .and_then(|s| s.split_once('x').map(|(w, h)| (w.parse().unwrap(), h.parse().unwrap())))
        .unwrap_or((960u32, 540u32));
    // Passes of 16 paths per pixel, as `lightbooth render --image` makes them
    // (its first pass and each later one), so each stored pixel is merged
    // as often per path as in a real render.
    let spp: u32 = value("--spp").map(|s| s.parse().unwrap()).unwrap_or(32);
    let pass: u32 = value("--pass").map(|s| s.parse().unwrap()).unwrap_or(16).min(spp);
    let runs: usize = value("--runs").map(|s| s.parse().unwrap()).unwrap_or(3);
    let scene = load_scene(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cylinder.toml")).unwrap();
    let mut camera = scene.camera.clone().unwrap();
    camera.width = width;
    camera.height = height;
    let cores = rayon::current_num_threads() as f64;
    let cases: [(&str, Vec<Coding>); 3] = [
        ("all7", Coding::ALL.to_vec()),
        ("spectral", vec![Coding::Spectral]),
        ("rgb", vec![Coding::Rgb]),
    ];
    let mut medians = Vec::new();
    let mut projected_paths = 0.0;
    let only = value("--only");
    for (name, codings) in cases {
        if only.as_deref().is_some_and(|o| o != name) {
            continue;
        }
        let settings = CameraSettings {
            codings,
            // The last coding: `spectral` for all seven (`Coding::ALL` ends with it).
            reference: None,
            se_every_coding: false,
            observer: RenderSettings::default().observer,
            transport: RenderSettings::default().transport(),
            seed: 1,
            min_spp: pass,
            first_sample: 0,
            max_spp: spp,
            target_relative_se: None,
            time_budget: None,
        };
        let (mut wall, mut cpu) = (Vec::new(), Vec::new());
        let (mut paths, mut rays) = (0, 0);
        for _ in 0..runs {
            let (t0, c0) = (Instant::now(), cpu_seconds());
            let images = render_camera_images(&scene, &camera, &settings, None, None).unwrap();
            wall.push(t0.elapsed().as_secs_f64());
            cpu.push(cpu_seconds() - c0);
            let img = images.reference_image();
            (paths, rays) = (img.paths, img.rays);
            if name == "all7" {
                projected_paths = paths_to_one_percent(&images);
            }
        }
        let (w, c) = (median(wall), median(cpu));
        println!(
            "{}",
            serde_json::json!({
                "case": name, "width": width, "height": height, "spp": spp, "paths_per_pass": pass, "runs": runs,
                "wall_s": w, "cpu_s": c, "paths": paths, "rays": rays,
                "paths_per_s_per_core": paths as f64 / w / cores,
                "rays_per_s_per_core": rays as f64 / w / cores, "threads": cores,
            })
        );
        medians.push((name, w, paths));
    }
    if medians.len() < 3 {
        return;
    }
    let all7 = medians[0].1;
    let spectral = medians[1].1;
    let per_path = all7 / medians[0].2 as f64;
    println!(
        "{}",
        serde_json::json!({
            "summary": "all seven codings from one set of paths against the reference alone",
            "all7_over_spectral": all7 / spectral,
            "all7_over_rgb": all7 / medians[2].1,
            "paths_to_one_percent_se_y": projected_paths,
            "projected_wall_s_to_one_percent": projected_paths * per_path,
            "projected_from": format!("{spp} paths per pixel, the reference's per-pixel SE(Y)"),
        })
    );
}
