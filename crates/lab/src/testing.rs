//! What the lab's unit tests share: a store on a fresh SQLite file, the
//! shipped scenes' catalogue, and a render runner with few paths per
//! target (the tests check what is recorded, not how accurate it is).

use std::path::Path;
use std::sync::Arc;

use super::events::{Event, EventSink};
use super::scenes::SceneCatalog;
use crate::render::runner::RenderRunner;
use lightbooth_render::Coding;
use lightbooth_science::colorimetry::Observer;
use lightbooth_store::{Average, Booth, NewMeasurement, Store};
use tokio_util::sync::CancellationToken;

/// Paths per target of the tests' renders.
pub const TEST_SAMPLES: u64 = 64;

/// A store on a new SQLite file in `dir`.
pub async fn store_in(dir: &Path) -> Store {
    Store::open(&format!("sqlite://{}", dir.join("lab.sqlite").display()))
        .await
        .expect("a store on a new SQLite file")
}

/// A new measurement of one sample in the default booth, queued, of
/// `scene`/`target` (or of nothing in particular).
pub async fn queued_measurement(store: &Store, scene_target: Option<(&str, &str)>) -> i64 {
    store
        .create_measurement(&NewMeasurement {
            booth: Booth::default(),
            session_id: None,
            scene: scene_target.map(|(scene, _)| scene.into()),
            target: scene_target.map(|(_, target)| target.into()),
            samples: 1,
            settings_json: serde_json::json!({}),
            note: String::new(),
        })
        .await
        .expect("the store queues a measurement")
}

/// A measurement of `scene`/`target`, queued, run and completed with a
/// flat, dark average (for what is recorded about it, not its colour).
pub async fn completed_measurement(store: &Store, scene_target: Option<(&str, &str)>) -> i64 {
    let id = queued_measurement(store, scene_target).await;
    complete(store, id, vec![380.0, 780.0]).await
}

/// A measurement of nothing in particular taken under the instrument hold
/// `hold` (its id and purpose), completed with a flat, dark average on the
/// PR-650's 4 nm grid (fine enough for its XYZ).
pub async fn completed_held_measurement(store: &Store, hold: (i64, &str)) -> i64 {
    let id = store
        .create_held_measurement(
            &NewMeasurement {
                booth: Booth::default(),
                session_id: None,
                scene: None,
                target: None,
                samples: 1,
                settings_json: serde_json::json!({}),
                note: String::new(),
            },
            Some(hold),
        )
        .await
        .expect("the store queues a measurement");
    complete(store, id, (0..=100).map(|i| 380.0 + 4.0 * i as f64).collect()).await
}

/// Runs and completes queued measurement `id` with a flat, dark average on
/// `wavelength_nm`.
async fn complete(store: &Store, id: i64, wavelength_nm: Vec<f64>) -> i64 {
    store
        .mark_running(id, None)
        .await
        .expect("the store runs a measurement");
    let n = wavelength_nm.len();
    let average = Average {
        wavelength_nm,
        radiance: vec![0.01; n],
        radiance_sd: vec![0.0; n],
        luminance_cd_m2: 0.0,
        x: Some(0.0),
        y: Some(0.0),
        luminance_cv: 0.0,
        xyz: None,
        observer: None,
    };
    store
        .complete_measurement(id, &average)
        .await
        .expect("the store completes a measurement");
    id
}

/// The catalogue of the shipped `scenes/`.
pub fn shipped_scenes() -> Arc<SceneCatalog> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    Arc::new(SceneCatalog::from_folder(&dir, Observer::JuddVos).expect("the shipped scenes load"))
}

/// A runner of the shipped scenes in `rgb` and `spectral` with
/// [`TEST_SAMPLES`] paths per target, sending its events to the returned
/// receiver.
pub fn runner(store: &Store) -> (Arc<RenderRunner>, tokio::sync::broadcast::Receiver<Event>) {
    let bus = EventSink::bus(1024);
    let events = bus.subscribe().expect("a bus");
    let runner = RenderRunner::new(
        store.clone(),
        shipped_scenes(),
        bus,
        vec![Coding::Rgb, Coding::Spectral],
        TEST_SAMPLES,
        Observer::JuddVos,
        CancellationToken::new(),
    )
    // The camera preview at its least, 16 paths per pixel: never a number.
    .with_preview_paths(1);
    (Arc::new(runner), events)
}

/// Every event received so far.
pub fn drain(events: &mut tokio::sync::broadcast::Receiver<Event>) -> Vec<Event> {
    std::iter::from_fn(|| events.try_recv().ok()).collect()
}
