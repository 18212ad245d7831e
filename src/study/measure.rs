//! Measurements for a reproducible study without a booth: every target of
//! every scene measured with the simulated PR-650 (on a pty, through the
//! real driver), aimed at the simulated booth's truth for the target — the
//! converged solution of the scene ([`render::converged_target_spectrum`]:
//! its own seed, no bounce cap, 1 nm), or of the *truth scene* when the booth
//! differs from the model — and stored like any measurement. Bounce
//! truncation and sampling of the renderings under test, the instrument
//! model (slit, noise) and any truth-scene perturbation are what make these
//! "measurements" differ from the renderings.

use std::path::{Path, PathBuf};

use crate::colorimetry::Observer;
use crate::daemon::instrument_task::{average_row, sample_row};
use crate::instrument::mock::{spawn_mock, MockConfig};
use crate::instrument::{open_pr650, CancelToken, Pr650Settings};
use crate::render;
use crate::store::{Booth, MeasurementState, NewMeasurement, Store};
use crate::study::run::truth_path;

/// Measures every target of `scenes` (five samples each) and stores the
/// measurements; returns their ids. `seed` fixes the simulator's noise;
/// `truth_scene` (a scene file or folder, see
/// [`super::run::StudyOptions::truth_scene`]) is the booth as it is;
/// `observer` names the XYZ stored with each measurement.
pub async fn measure_with_simulator(
    scenes: &[PathBuf],
    store: &Store,
    cache_dir: &Path,
    seed: u64,
    observer: Observer,
    truth_scene: Option<&Path>,
    progress: &(dyn Fn(&str) + Sync),
) -> anyhow::Result<Vec<i64>> {
    std::fs::create_dir_all(cache_dir)?;
    let mut config = MockConfig::new(crate::spectrum::Spectrum::constant(
        crate::spectrum::Grid::one_nm(),
        crate::spectrum::SpectralUnit::SpectralRadiance,
        0.01,
    )?);
    config.speed = 0.0;
    config.seed = seed;
    let mock = spawn_mock(config)?;
    let port = mock.device_path().display().to_string();
    let settings = Pr650Settings::default();
    let mut instrument = open_pr650(&port, &settings)?;
    let info = instrument.info().clone();
    let instrument_id = store
        .upsert_instrument(&Booth::default(), &info.model, info.serial.as_deref(), &port)
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
            mock.set_truth(render::converged_target_spectrum(&truth, target, Some(cache_dir))?)?;
            let id = store
                .create_measurement(&NewMeasurement {
                    booth: Booth::default(),
                    session_id: None,
                    scene: Some(scene_id.clone()),
                    target: Some(target.to_string()),
                    samples: settings.samples,
                    settings_json: serde_json::json!({
                        "samples": settings.samples,
                        "simulated": true,
                        "seed": seed,
                        "truth_scene": truth.display().to_string(),
                    }),
                    note: "study: simulated PR-650".into(),
                })
                .await?;
            store.mark_running(id, Some(instrument_id)).await?;
            let mut rows = Vec::new();
            let result =
                instrument.measure_averaged(settings.samples, &CancelToken::new(), &mut |s| rows.push(sample_row(s)));
            // The driver is synchronous; the samples are written right after it returns.
            for row in &rows {
                store.insert_sample(id, row).await?;
            }
            match result {
                Ok(avg) => store.complete_measurement(id, &average_row(&avg, observer)).await?,
                Err(e) => {
                    store
                        .end_measurement(id, MeasurementState::Failed, &e.to_string())
                        .await?;
                    anyhow::bail!("measuring {scene_id}/{target}: {e}");
                }
            }
            ids.push(id);
        }
    }
    Ok(ids)
}
