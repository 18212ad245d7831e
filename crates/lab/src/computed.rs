//! The heavy results the dashboards and downloads poll, computed once per
//! state of what they are computed from, off the async runtime and a
//! bounded number at a time.
//!
//! - **What**: an experiment's analysis ([`Experiments::analyze`]: every
//!   trial read, percent correct, d′ and the threshold fits), and a scene's
//!   comparisons summarised per coding with their Monte Carlo uncertainty
//!   ([`summary::scene_comparisons`]: every compared measurement read with
//!   its samples), which the scene's JSON, CSV, MAT, charts and the scenes'
//!   overview all read.
//! - **Keyed by**: the experiment id or scene, and the
//!   [`InputsVersion`] the store gives of what the result reads
//!   ([`Store::experiment_inputs`]: sessions, complete sessions, trials,
//!   newest verification; [`Store::scene_comparison_inputs`]: the
//!   comparisons' number, newest id and their rewritable whites), read in
//!   one small query per request, so a write by any daemon sharing the
//!   database is seen.
//! - **Invalidated**: by a new version: a trial, session or verification
//!   recorded, a comparison added (a measurement compared, a render
//!   compared) or its white rewritten. The version is read before the
//!   result, so a result is never kept under a version older than the
//!   rows it read; at worst it is computed once more.
//! - **Bounded**: [`COMPUTING_AT_ONCE`] computations run at once, each on
//!   the blocking pool (never on the runtime's workers), each holding at
//!   most one database connection at a time; [`READING_AT_ONCE`] version
//!   reads at once, so polling clients never hold more than those of the
//!   pool's connections and a running measurement's sample writes and
//!   `/api/health` always find one; [`ENTRIES`] results per kind, the least
//!   recently used dropped. Requests for the same key while it is computed
//!   wait for that one computation (single-flight); an error is not kept.

use std::collections::HashMap;
use std::future::Future;
use std::hash::Hash;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

use tokio::sync::{OnceCell, Semaphore};

use crate::comparisons::summary::{self, SceneComparisons};
use crate::error::LabError;
use crate::experiments::analysis::Analysis;
use crate::experiments::Experiments;
use lightbooth_science::colorimetry::Observer;
use lightbooth_store::{InputsVersion, Store, StoreError};

/// Heavy computations running at once (the machine's cores are shared with
/// the renderer and the instrument task).
pub const COMPUTING_AT_ONCE: usize = 2;

/// Version reads at once: fewer than the store's pool of 8 connections, so
/// the writes of a running measurement never queue behind polling clients.
pub const READING_AT_ONCE: usize = 4;

/// Results kept per kind (experiments, scenes).
pub const ENTRIES: usize = 64;

/// Experiments one figure may draw (`/api/experiments/figure.svg?ids=…`).
pub const MAX_FIGURE_EXPERIMENTS: usize = 24;

/// One kept result: the version it was computed for, and the cell its
/// computation fills once.
struct Entry<V> {
    version: InputsVersion,
    cell: Arc<OnceCell<Arc<V>>>,
    used: u64,
}

/// The results of one kind, by key.
struct Kept<K, V> {
    entries: Mutex<HashMap<K, Entry<V>>>,
    tick: AtomicU64,
}

impl<K: Eq + Hash + Clone, V> Kept<K, V> {
    fn new() -> Self {
        Kept {
            entries: Mutex::new(HashMap::new()),
            tick: AtomicU64::new(0),
        }
    }

    /// The cell of `key` at `version`: the kept one, or a new empty one
    /// replacing an older version's (dropping the least recently used
    /// entry when full).
    fn cell(&self, key: &K, version: InputsVersion) -> Arc<OnceCell<Arc<V>>> {
        let used = self.tick.fetch_add(1, Ordering::Relaxed);
        let mut entries = self.entries.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(e) = entries.get_mut(key) {
            if e.version == version {
                e.used = used;
                return e.cell.clone();
            }
        } else if entries.len() >= ENTRIES {
            if let Some(oldest) = entries.iter().min_by_key(|(_, e)| e.used).map(|(k, _)| k.clone()) {
                entries.remove(&oldest);
            }
        }
        let cell = Arc::new(OnceCell::new());
        entries.insert(
            key.clone(),
            Entry {
                version,
                cell: cell.clone(),
                used,
            },
        );
        cell
    }
}

/// The lab's computed results (see the module doc). Shared by every clone
/// of the [`Lab`](crate::Lab).
pub struct Computed {
    store: Store,
    observer: Observer,
    experiments: Experiments,
    analyses: Kept<i64, Analysis>,
    scenes: Kept<String, SceneComparisons>,
    computing: Semaphore,
    reading: Semaphore,
    computations: AtomicU64,
}

impl Computed {
    /// The results of `store`'s experiments and of its scenes' comparisons
    /// in `observer`.
    pub fn new(store: Store, observer: Observer) -> Computed {
        Computed {
            experiments: Experiments::new(store.clone()),
            store,
            observer,
            analyses: Kept::new(),
            scenes: Kept::new(),
            computing: Semaphore::new(COMPUTING_AT_ONCE),
            reading: Semaphore::new(READING_AT_ONCE),
            computations: AtomicU64::new(0),
        }
    }

    /// How many results have been computed (not served from what is
    /// kept) since the lab started: what the tests count.
    pub fn computations(&self) -> u64 {
        self.computations.load(Ordering::Relaxed)
    }

    /// The analysis of experiment `id` (computed for the stored trials now).
    pub async fn analysis(&self, id: i64) -> Result<Arc<Analysis>, LabError> {
        let version = self.version(self.store.experiment_inputs(id)).await?;
        let experiments = self.experiments.clone();
        self.get(
            &self.analyses,
            &id,
            version,
            async move { experiments.analyze(id).await },
        )
        .await
    }

    /// The analyses of experiments `ids` in their order, each once (a
    /// repeated id is drawn once): at most [`MAX_FIGURE_EXPERIMENTS`].
    pub async fn analyses(&self, ids: &[i64]) -> Result<Vec<Arc<Analysis>>, LabError> {
        let mut distinct: Vec<i64> = Vec::with_capacity(ids.len());
        for id in ids {
            if !distinct.contains(id) {
                distinct.push(*id);
            }
        }
        if distinct.is_empty() || distinct.len() > MAX_FIGURE_EXPERIMENTS {
            return Err(LabError::Invalid(format!(
                "query `ids`: {} distinct experiment ids; give 1–{MAX_FIGURE_EXPERIMENTS}",
                distinct.len()
            )));
        }
        let mut out = Vec::with_capacity(distinct.len());
        for id in distinct {
            out.push(self.analysis(id).await?);
        }
        Ok(out)
    }

    /// Scene `scene`'s newest comparisons summarised per coding (the
    /// scene is not checked here: [`crate::Lab::scene_comparisons`] does).
    pub async fn scene_comparisons(&self, scene: &str) -> Result<Arc<SceneComparisons>, LabError> {
        let version = self.version(self.store.scene_comparison_inputs(scene)).await?;
        let (store, observer, owned) = (self.store.clone(), self.observer, scene.to_string());
        self.get(&self.scenes, &scene.to_string(), version, async move {
            Ok(summary::scene_comparisons(&store, &owned, observer).await?)
        })
        .await
    }

    /// Reads a version, at most [`READING_AT_ONCE`] at a time.
    async fn version(
        &self,
        read: impl Future<Output = Result<InputsVersion, StoreError>>,
    ) -> Result<InputsVersion, LabError> {
        let _permit = self.reading.acquire().await.expect("the semaphore is never closed");
        Ok(read.await?)
    }

    /// The result of `key` at `version`: the kept one, the one being
    /// computed, or `compute` run now on the blocking pool (at most
    /// [`COMPUTING_AT_ONCE`] at a time) and kept.
    async fn get<K: Eq + Hash + Clone, V: Send + Sync + 'static>(
        &self,
        kept: &Kept<K, V>,
        key: &K,
        version: InputsVersion,
        compute: impl Future<Output = Result<V, LabError>> + Send + 'static,
    ) -> Result<Arc<V>, LabError> {
        let cell = kept.cell(key, version);
        let value = cell
            .get_or_try_init(|| async {
                let _permit = self.computing.acquire().await.expect("the semaphore is never closed");
                self.computations.fetch_add(1, Ordering::Relaxed);
                let runtime = tokio::runtime::Handle::current();
                let value = tokio::task::spawn_blocking(move || runtime.block_on(compute))
                    .await
                    .map_err(|e| LabError::Internal(format!("a computation failed: {e}")))??;
                Ok::<_, LabError>(Arc::new(value))
            })
            .await?;
        Ok(value.clone())
    }
}
