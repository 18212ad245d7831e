//! Every shipped scene, rendered with a fixed seed, gives the same bits as
//! the renderer before issue 23's integrator redesign (one direct-light
//! estimate and one Russian roulette for every material, one `Light`
//! interface). Issue 34's light sampler (one light chosen by probability
//! per vertex instead of every point light) changed the pins of the scenes
//! with two lights — `cylinder`, `truth/cylinder`, `variants/cylinder_f11`
//! and `examples/glossy_booth` — after checking that the new values agree
//! with the old within their standard errors; every scene with one light
//! keeps its bits.
//!
//! This is a regression pin, not a validation: it says the renderer's
//! results did not change, bit for bit. Accuracy is validated elsewhere
//! (closed forms in `render_physics`, RADIANCE's own numbers in
//! `glossy_materials`, published values in `cornell_box`).
//!
//! The pins are in `tests/render/fixed_seed_pins.txt`, one line per scene,
//! setting, target and coding (Y, x, y as the bits of their `f64`), and per
//! scene with a camera a hash of a small camera image's bits. A change that
//! is meant to change the renderer's numbers regenerates them with
//! `LIGHTBOOTH_WRITE_PINS=1 cargo test --release --test render fixed_seed_pins`
//! and says why in its commit.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use lightbooth::render::scene::Camera;
use lightbooth::render::sensor::render_camera;
use lightbooth::render::{load_scene, render, Coding, LightSampling, RenderSettings, SamplerKind, Transport};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).to_path_buf()
}

/// Every scene file the repository ships, relative to its root.
const SHIPPED: &[&str] = &[
    "scenes/blue.toml",
    "scenes/cornell_box.toml",
    "scenes/cylinder.toml",
    "scenes/examples/glossy_booth.toml",
    "scenes/examples/own_booth.toml",
    "scenes/green.toml",
    "scenes/material_bench.toml",
    "scenes/radiance/metal_sphere.toml",
    "scenes/radiance/plastic_sphere.toml",
    "scenes/red.toml",
    "scenes/truth/cylinder.toml",
    "scenes/variants/cylinder_f11.toml",
    "scenes/white.toml",
];

/// The settings each scene is rendered with: the default transport
/// (Russian roulette from bounce 3, no cap), a bounce cap (the last vertex
/// takes its light sample unweighted), and independent random numbers.
fn settings() -> Vec<(&'static str, RenderSettings)> {
    let base = RenderSettings {
        codings: Coding::ALL.to_vec(),
        samples: 1024,
        target_relative_se: None,
        threads: Some(2),
        seed: 7,
        ..RenderSettings::default()
    };
    vec![
        ("default", base.clone()),
        (
            "bounces2",
            RenderSettings {
                max_bounces: Some(2),
                russian_roulette_from: None,
                ..base.clone()
            },
        ),
        (
            "independent",
            RenderSettings {
                sampler: SamplerKind::Independent,
                russian_roulette_from: Some(1),
                ..base
            },
        ),
    ]
}

/// FNV-1a over the image's f32 bits.
fn image_hash(rgb: &[[f32; 3]]) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for v in rgb.iter().flatten() {
        for b in v.to_bits().to_le_bytes() {
            h ^= b as u64;
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    h
}

/// The pins of the renderer as it is now.
fn current_pins() -> String {
    let mut out = String::new();
    for file in SHIPPED {
        let scene = load_scene(&root().join(file)).unwrap_or_else(|e| panic!("{file}: {e}"));
        for (name, s) in settings() {
            let r = render(&scene, &s, None, None).unwrap_or_else(|e| panic!("{file} {name}: {e}"));
            for t in &r.targets {
                for (coding, c) in &t.codings {
                    writeln!(
                        out,
                        "{file} {name} {} {coding} Y={:016x} x={:016x} y={:016x}",
                        t.id,
                        c.luminance_cd_m2.to_bits(),
                        c.x.to_bits(),
                        c.y.to_bits()
                    )
                    .unwrap();
                }
            }
            writeln!(out, "{file} {name} rays={}", r.rays).unwrap();
        }
        if let Some(cam) = &scene.camera {
            // A small view keeps the pin cheap; every pixel still runs the
            // whole integrator.
            let small = Camera {
                width: 40,
                height: 30,
                ..cam.clone()
            };
            let transport = Transport {
                max_bounces: None,
                russian_roulette_from: Some(3),
                light_sampler: LightSampling::Power,
            };
            for coding in [Coding::Spectral, Coding::Rgb] {
                let img = render_camera(&scene, &small, coding, 4, &transport, 11, None)
                    .unwrap_or_else(|e| panic!("{file} camera: {e}"));
                writeln!(out, "{file} camera {coding} {:016x}", image_hash(&img.rgb)).unwrap();
            }
        }
    }
    out
}

#[test]
fn every_shipped_scene_renders_the_pinned_bits_for_a_fixed_seed() {
    let pins_file = root().join("tests/render/fixed_seed_pins.txt");
    let now = current_pins();
    if std::env::var_os("LIGHTBOOTH_WRITE_PINS").is_some() {
        std::fs::write(&pins_file, &now).unwrap();
        return;
    }
    let pinned = std::fs::read_to_string(&pins_file)
        .unwrap_or_else(|e| panic!("{}: {e} (write it with LIGHTBOOTH_WRITE_PINS=1)", pins_file.display()));
    let pinned_lines: Vec<&str> = pinned.lines().collect();
    let now_lines: Vec<&str> = now.lines().collect();
    let differing: Vec<String> = pinned_lines
        .iter()
        .zip(&now_lines)
        .filter(|(a, b)| a != b)
        .take(10)
        .map(|(a, b)| format!("  pinned {a}\n  now    {b}"))
        .collect();
    assert!(
        differing.is_empty() && pinned_lines.len() == now_lines.len(),
        "the renderer's fixed-seed results changed ({} pinned lines, {} now); first differences:\n{}",
        pinned_lines.len(),
        now_lines.len(),
        differing.join("\n")
    );
}
