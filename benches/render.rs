//! Criterion benchmark of the renderer: the CYLINDER scene, all 21 targets,
//! all seven codings in one pass, and each coding alone (the cost of a
//! coding). Paths per second = 21 × samples / the reported median time.
//!
//! `cornell_box/goal`: the Cornell box's nine targets in the codings
//! `rgb,srgb,nstep9,nstep81,spectral`, rendered until the standard error of
//! Y is at most 0.3 % at every target in every coding (the default
//! settings: no bounce cap, Russian roulette from bounce 3) — the
//! performance goal of issue 11 is a median of
//! ≤ 1.5 s on a 2-core machine. The same with the command line:
//! `lightbooth render scenes/cornell_box.toml --codings rgb,srgb,nstep9,nstep81,spectral --json`
//! (`wall_seconds`).
//!
//! `glossy_booth/all7`: the glossy example scene
//! (`scenes/examples/glossy_booth.toml`: RADIANCE `plastic` and `metal`
//! spheres, a spot and an area light), four targets, all seven codings,
//! 8192 paths per target.
//!
//! `cargo bench --bench render` (release profile). Measurement time is kept
//! short: the machine is shared.

use std::path::Path;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};

use lightbooth::render::{load_scene, render, Coding, RenderSettings};

const SAMPLES: u64 = 8192;

fn cylinder(c: &mut Criterion) {
    let scene = load_scene(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cylinder.toml")).unwrap();
    let paths = SAMPLES * scene.targets().len() as u64;
    let mut group = c.benchmark_group("cylinder");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3))
        .throughput(Throughput::Elements(paths));
    let mut cases: Vec<(String, Vec<Coding>)> = vec![("all7".into(), Coding::ALL.to_vec())];
    cases.extend(Coding::ALL.iter().map(|c| (c.to_string(), vec![*c])));
    for (name, codings) in cases {
        let settings = RenderSettings {
            codings,
            samples: SAMPLES,
            target_relative_se: None,
            ..RenderSettings::default()
        };
        group.bench_with_input(BenchmarkId::new("codings", name), &settings, |b, s| {
            b.iter(|| render(&scene, s, None, None).unwrap())
        });
    }
    group.finish();
}

fn cornell_box(c: &mut Criterion) {
    let scene = load_scene(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell_box.toml")).unwrap();
    let mut group = c.benchmark_group("cornell_box");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(10));
    let settings = RenderSettings {
        codings: vec![
            Coding::Rgb,
            Coding::Srgb,
            Coding::NStep(9),
            Coding::NStep(81),
            Coding::Spectral,
        ],
        target_relative_se: Some(0.003),
        ..RenderSettings::default()
    };
    group.bench_function("goal", |b| {
        b.iter(|| {
            let r = render(&scene, &settings, None, None).unwrap();
            assert!(r.max_relative_se() <= 0.003);
            r
        })
    });
    group.finish();
}

fn glossy_booth(c: &mut Criterion) {
    let scene = load_scene(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/examples/glossy_booth.toml")).unwrap();
    let paths = SAMPLES * scene.targets().len() as u64;
    let mut group = c.benchmark_group("glossy_booth");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3))
        .throughput(Throughput::Elements(paths));
    let settings = RenderSettings {
        codings: Coding::ALL.to_vec(),
        samples: SAMPLES,
        target_relative_se: None,
        ..RenderSettings::default()
    };
    group.bench_function("all7", |b| b.iter(|| render(&scene, &settings, None, None).unwrap()));
    group.finish();
}

criterion_group!(benches, cylinder, cornell_box, glossy_booth);
criterion_main!(benches);
