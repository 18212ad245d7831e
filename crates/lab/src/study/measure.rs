//! Measurements for a reproducible study without a booth: every target of
//! every scene measured with the simulated PR-650 (on a pty, through the
//! real driver), aimed at the simulated booth's truth for the target — the
//! converged solution of the scene ([`render::converged_target_spectrum`]:
//! its own seed, no bounce cap, 1 nm), or of the *truth scene* when the booth
//! differs from the model — and stored like any measurement. Bounce
//! truncation and sampling of the renderings under test, the instrument
//! model (slit, noise) and any truth-scene perturbation are what make these
//! "measurements" differ from the renderings. Each measurement is recorded
//! and taken as the daemon takes one ([`Recorder::take`]): every sample is
//! stored before the next is taken.

use std::path::{Path, PathBuf};

use crate::measure::recorder::{Outcome, Recorder};
use crate::study::run::truth_path;
use lightbooth_instrument::sim::{spawn_mock, MockConfig};
use lightbooth_instrument::{open_pr650, Pr650Settings};
use lightbooth_render as render;
use lightbooth_science::colorimetry::Observer;
use lightbooth_store::{Booth, NewMeasurement, Store};
use tokio_util::sync::CancellationToken;

/// The simulated PR-650 a study measures with.
#[derive(Clone, Copy, Debug)]
pub struct SimulatedPr650 {
    /// Fixes the simulated noise (same seed, same samples).
    pub seed: u64,
    /// Time scale: 0 instant, 1 the real instrument's measurement and wire times.
    pub speed: f64,
}

/// Measures every target of `scenes` (five samples each) with `simulator`
/// and stores the measurements, taken in `booth`; returns their ids.
/// `truth_scene` (a scene file or folder, see
/// [`super::run::StudyOptions::truth_scene`]) is the booth as it is;
/// `observer` names the XYZ stored with each measurement. Needs a
/// multi-threaded runtime (the driver and the store writes block a thread).
#[allow(clippy::too_many_arguments)] // the booth joined seven (issue 32); each is a separate choice
pub async fn measure_with_simulator(
    scenes: &[PathBuf],
    store: &Store,
    booth: &Booth,
    cache_dir: &Path,
    simulator: SimulatedPr650,
    observer: Observer,
    truth_scene: Option<&Path>,
    progress: &(dyn Fn(&str) + Sync),
) -> anyhow::Result<Vec<i64>> {
    std::fs::create_dir_all(cache_dir)?;
    let mut config = MockConfig::new(lightbooth_science::spectrum::Spectrum::constant(
        lightbooth_science::spectrum::Grid::one_nm(),
        lightbooth_science::spectrum::SpectralUnit::SpectralRadiance,
        0.01,
    )?);
    config.speed = simulator.speed;
    config.seed = simulator.seed;
    let seed = simulator.seed;
    let mock = spawn_mock(config)?;
    let port = mock.device_path().display().to_string();
    let settings = Pr650Settings::default();
    let mut instrument = open_pr650(&port, &settings)?;
    let info = instrument.info().clone();
    let instrument_id = store
        .upsert_instrument(booth, &info.model, info.serial.as_deref(), &port)
        .await?;
    let mut ids = Vec::new();
    for path in scenes {
        let scene_id = path
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or_default()
            .to_string();
        let scene = render::load_scene(path)?;
        let truth = truth_path(truth_scene, path);
        for target in scene.targets() {
            progress(&format!("measuring {scene_id}/{target} with the simulated PR-650"));
            let converged = render::converged_target_truth(&truth, target, Some(cache_dir))?;
            let truth_relative_se = converged.relative_se_y;
            mock.set_truth(converged.spectrum)?;
            let mut settings_json = serde_json::json!({
                "samples": settings.samples,
                "simulated": true,
                "seed": seed,
                "truth_scene": truth.display().to_string(),
            });
            // The truth is a render, an estimate too: its SE joins the
            // error budget of every comparison with this measurement.
            settings_json[lightbooth_store::SIMULATED_TRUTH_KEY] = serde_json::json!(truth_relative_se);
            let id = store
                .create_measurement(&NewMeasurement {
                    booth: booth.clone(),
                    session_id: None,
                    scene: Some(scene_id.clone()),
                    target: Some(target.to_string()),
                    samples: settings.samples,
                    settings_json,
                    note: "study: simulated PR-650".into(),
                })
                .await?;
            // The daemon's workflow (`lab::measure::recorder`): each sample is on
            // disk before the next is taken, so a study killed
            // mid-measurement keeps every sample it took. The driver and the
            // recorder block: this runtime thread is handed over to them meanwhile.
            let outcome = tokio::task::block_in_place(|| -> anyhow::Result<Outcome> {
                let runtime = tokio::runtime::Handle::current();
                let never = CancellationToken::new();
                let recorder = Recorder::start(store, &runtime, id, Some(instrument_id), &never)?;
                let cancel = CancellationToken::new();
                Ok(recorder.take(
                    instrument.as_mut(),
                    settings.samples,
                    observer,
                    &cancel,
                    &never,
                    &mut |_, _| {},
                ))
            })?;
            if let Outcome::Ended { message, .. } = outcome {
                anyhow::bail!("measuring {scene_id}/{target}: {message}");
            }
            ids.push(id);
        }
    }
    Ok(ids)
}
