//! What the simulated PR-650 (`serve --mock`) measures: the converged
//! spectral radiance of a scene target ([`render::converged_target_spectrum`]:
//! its own seed, no bounce cap, 1 nm), never the comparison render. With
//! `--mock-world DIR` it is the scene of the same id in DIR instead (the
//! booth as it is, when it differs from the model the codings render).
//!
//! The converged spectra are rendered on a rayon pool of their own, not the
//! global pool the render jobs use: a job's batches fill the global pool's
//! queues, and the instrument thread, which waits for the truth before it
//! measures, would wait behind all of them.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::jobs;
use crate::scenes::SceneCatalog;
use lightbooth_render as render;
use lightbooth_science::spectrum::Spectrum;

/// The simulated booth's converged truth of the catalogue's scenes.
pub struct SimulatedTruth {
    catalogue: Arc<SceneCatalog>,
    /// Scene files measured instead of the model, by scene id.
    mock_world: Option<PathBuf>,
    pool: rayon::ThreadPool,
}

impl SimulatedTruth {
    /// The truth of `catalogue`'s scenes, or of the scenes of the same id
    /// in `mock_world` where it has one (each checked to load now).
    pub fn new(catalogue: Arc<SceneCatalog>, mock_world: Option<PathBuf>) -> anyhow::Result<SimulatedTruth> {
        if let Some(world) = &mock_world {
            for s in catalogue.iter() {
                let p = world.join(format!("{}.toml", s.id));
                if p.exists() {
                    render::load_scene(&p)?;
                    tracing::info!(scene = s.id, world = %p.display(), "the simulated PR-650 measures the mock world's scene");
                } else {
                    tracing::info!(
                        scene = s.id,
                        "no scene in the mock world: the simulated PR-650 measures the model"
                    );
                }
            }
        }
        let pool = rayon::ThreadPoolBuilder::new()
            .thread_name(|i| format!("converge-{i}"))
            .build()
            .map_err(|e| anyhow::anyhow!("cannot start the simulated booth's threads: {e}"))?;
        Ok(SimulatedTruth {
            catalogue,
            mock_world,
            pool,
        })
    }

    /// The scene file measured for the catalogue's scene at `model`: the
    /// mock world's of the same id when there is one, else the model.
    fn world_path(&self, model: &Path) -> PathBuf {
        crate::study::run::truth_path(self.mock_world.as_deref(), model)
    }

    /// The converged spectral radiance of `scene`/`target` on 1 nm, cached
    /// in `cache_dir` by scene content and truth settings. Blocks: call it
    /// from the instrument thread, not the async runtime.
    pub fn spectrum(&self, scene: &str, target: &str, cache_dir: &Path) -> Result<Spectrum, String> {
        self.truth(scene, target, cache_dir).map(|t| t.spectrum)
    }

    /// [`SimulatedTruth::spectrum`] with the truth's own relative standard
    /// error of Y, which the measurement records
    /// ([`lightbooth_store::Store::record_simulated_truth`]) for the error
    /// budget of its comparisons.
    pub fn truth(&self, scene: &str, target: &str, cache_dir: &Path) -> Result<render::ConvergedTruth, String> {
        let entry = self.catalogue.get(scene).ok_or_else(|| format!("no scene `{scene}`"))?;
        std::fs::create_dir_all(cache_dir).map_err(|e| format!("cache folder {}: {e}", cache_dir.display()))?;
        self.pool.install(|| {
            if jobs::test_panic_requested(scene) {
                jobs::panic_on_the_pool(scene);
            }
            render::converged_target_truth(&self.world_path(&entry.path), target, Some(cache_dir))
                .map_err(|e| e.to_string())
        })
    }
}
