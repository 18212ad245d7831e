//! Criterion benchmark of the renderer: the CYLINDER scene, all 21 targets,
//! all seven codings in one pass, and each coding alone (the cost of a
//! coding). Paths per second = 21 × samples / the reported median time.
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
            b.iter(|| render(&scene, s, None).unwrap())
        });
    }
    group.finish();
}

criterion_group!(benches, cylinder);
criterion_main!(benches);
