//! Cancellation at the renderer's entry points: the token is a parameter
//! (no thread-local), and a token cancelled before a render, or while it
//! runs, ends it with `RenderError::Cancelled` — for the radiometer
//! (`render`), the timing of codings (`cost::time_renders`), the measuring
//! camera (`render_camera_image`) and the dashboard's preview
//! (`sensor::render_camera`). "While it runs" is made deterministic by
//! cancelling from the render's own progress callback, which it calls
//! after a batch (the radiometer) or a pass (the camera) is done.

use std::path::Path;

use lightbooth::render::camera::{render_camera_image, CameraSettings};
use lightbooth::render::cost::time_renders;
use lightbooth::render::integrator::Transport;
use lightbooth::render::sensor::render_camera;
use lightbooth::render::{
    load_scene, render, ChannelLayout, Coding, LightSampling, RenderError, RenderSettings, Scene, BATCH_SAMPLES,
};
use tokio_util::sync::CancellationToken;

fn white() -> Scene {
    load_scene(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/white.toml")).unwrap()
}

fn many_batches() -> RenderSettings {
    RenderSettings {
        codings: vec![Coding::Rgb],
        samples: 64 * BATCH_SAMPLES,
        target_relative_se: None,
        ..RenderSettings::default()
    }
}

fn camera_settings() -> CameraSettings {
    CameraSettings {
        codings: vec![Coding::Rgb],
        reference: None,
        se_every_coding: false,
        observer: ChannelLayout::new(&[Coding::Rgb]).observer(),
        transport: Transport {
            max_bounces: Some(2),
            russian_roulette_from: None,
            light_sampler: LightSampling::Power,
        },
        seed: 1,
        min_spp: 2,
        first_sample: 0,
        max_spp: 8,
        target_relative_se: None,
        time_budget: None,
    }
}

#[test]
fn a_render_given_a_cancelled_token_stops_with_the_cancelled_error() {
    let scene = white();
    let cancelled = CancellationToken::new();
    cancelled.cancel();
    let settings = many_batches();
    assert!(matches!(
        render(&scene, &settings, None, Some(&cancelled)),
        Err(RenderError::Cancelled)
    ));
    assert!(matches!(
        time_renders(&scene, std::slice::from_ref(&settings), 1, Some(&cancelled)),
        Err(RenderError::Cancelled)
    ));
    let mut camera = scene.camera.clone().unwrap();
    camera.width = 8;
    camera.height = 6;
    assert!(matches!(
        render_camera_image(&scene, &camera, &camera_settings(), None, Some(&cancelled)),
        Err(RenderError::Cancelled)
    ));
    let transport = camera_settings().transport;
    assert!(matches!(
        render_camera(&scene, &camera, Coding::Srgb, 2, &transport, 1, Some(&cancelled)),
        Err(RenderError::Cancelled)
    ));
    // The same calls with a live token (or none) finish.
    let live = CancellationToken::new();
    assert!(render(&scene, &RenderSettings { samples: 1, ..settings }, None, Some(&live)).is_ok());
    assert!(render_camera_image(&scene, &camera, &camera_settings(), None, None).is_ok());
}

#[test]
fn a_render_whose_token_is_cancelled_while_it_runs_stops_with_the_cancelled_error() {
    let scene = white();
    // The radiometer: cancelled when the first batch of 64 reports.
    let token = CancellationToken::new();
    let batches = std::sync::atomic::AtomicU64::new(0);
    let cancel_at_first = |_done: u64, _total: u64| {
        batches.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        token.cancel();
    };
    let r = render(&scene, &many_batches(), Some(&cancel_at_first), Some(&token));
    assert!(matches!(r, Err(RenderError::Cancelled)), "{r:?}");
    let traced = batches.load(std::sync::atomic::Ordering::Relaxed);
    assert!(
        traced < 64,
        "stopped within a batch per worker thread, not after all 64 ({traced})"
    );

    // The camera: cancelled when its first pass (of four) reports.
    let token = CancellationToken::new();
    let passes = std::sync::atomic::AtomicU32::new(0);
    let cancel_after_pass = |_| {
        passes.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        token.cancel();
    };
    let mut camera = scene.camera.clone().unwrap();
    camera.width = 8;
    camera.height = 6;
    let img = render_camera_image(
        &scene,
        &camera,
        &camera_settings(),
        Some(&cancel_after_pass),
        Some(&token),
    );
    assert!(
        matches!(img, Err(RenderError::Cancelled)),
        "{:?}",
        img.map(|i| i.passes)
    );
    assert_eq!(
        passes.load(std::sync::atomic::Ordering::Relaxed),
        1,
        "no pass after the cancel"
    );
}
