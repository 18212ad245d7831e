//! The heavy results the dashboards and downloads poll, computed once per
//! state of what they are computed from, off the async runtime and a
//! bounded number at a time; and the response bodies made from them (JSON,
//! CSV, MAT, SVG), made once per result.
//!
//! - **What**: an experiment's analysis ([`Experiments::analyze`]: every
//!   trial read, percent correct, d′ and the threshold fits), a scene's
//!   comparisons summarised per coding with their Monte Carlo uncertainty
//!   ([`summary::scene_comparisons`]: every compared measurement read with
//!   its samples), which the scene's JSON, CSV, MAT, charts and the scenes'
//!   overview all read, and the scenes' overview itself
//!   ([`crate::compare::overview`]).
//! - **Keyed by**: the experiment id, scene or booth, and the
//!   [`InputsVersion`] the store gives of what the result reads
//!   ([`Store::experiment_inputs`]: sessions, complete sessions, trials,
//!   newest verification; [`Store::scene_comparison_inputs`]: the
//!   comparisons' number, newest id and their rewritable whites;
//!   [`Store::overview_inputs`]: the booth's complete measurements and the
//!   newest preview).
//! - **Versions, without a query per request**: a version read from the
//!   database is trusted until this process writes something a result reads
//!   ([`Store::writes`] grows: a trial, a comparison, a measurement ended…)
//!   or [`OTHERS_SEEN_WITHIN`] has passed, whichever comes first; then it is
//!   read again, once for all the requests waiting on it. So a daemon's own
//!   writes are seen by its next request, and a write by another daemon
//!   sharing the database (render workers, other booths on PostgreSQL)
//!   within [`OTHERS_SEEN_WITHIN`]. 200 clients polling one result cost one
//!   small query a second, not one each.
//! - **Invalidated**: by a new version. The version is read before the
//!   result, so a result is never kept under a version older than the rows
//!   it read; at worst it is computed once more.
//! - **Bounded**: [`COMPUTING_AT_ONCE`] computations run at once, each on
//!   the blocking pool (never on the runtime's workers), each holding at
//!   most one database connection at a time; [`READING_AT_ONCE`] version
//!   reads at once, so polling clients never hold more than those of the
//!   pool's connections and a running measurement's sample writes always
//!   find one; [`ENTRIES`] results per kind and [`OUTPUTS`] response
//!   bodies, the least recently used dropped. Requests for the same key
//!   while it is computed wait for that one computation (single-flight); an
//!   error is not kept.

use std::any::Any;
use std::collections::HashMap;
use std::hash::Hash;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, Weak};
use std::time::Duration;

use tokio::sync::{OnceCell, Semaphore};
use tokio::time::Instant;

use crate::compare::overview::ScenesOverview;
use crate::compare::summary::{self, SceneComparisons};
use crate::error::LabError;
use crate::experiments::analysis::Analysis;
use crate::experiments::Experiments;
use crate::requests::SceneInfo;
use lightbooth_science::colorimetry::Observer;
use lightbooth_store::{Booth, BoxFuture, InputsVersion, Store, StoreError};

/// Heavy computations running at once (the machine's cores are shared with
/// the renderer and the instrument task).
pub const COMPUTING_AT_ONCE: usize = 2;

/// Version reads at once: fewer than the store's pool of 8 connections, so
/// the writes of a running measurement never queue behind polling clients.
pub const READING_AT_ONCE: usize = 4;

/// How long a version read from the database is trusted while this process
/// writes nothing the result reads: the longest a write by another daemon
/// on the same database takes to show in this daemon's results.
pub const OTHERS_SEEN_WITHIN: Duration = Duration::from_secs(1);

/// Results kept per kind (experiments, scenes, overviews).
pub const ENTRIES: usize = 64;

/// Response bodies kept (each made from one kept result).
pub const OUTPUTS: usize = 256;

/// Version checks remembered (experiments, scenes, booths asked about);
/// forgotten all at once beyond this (they are only re-read).
const CHECKS: usize = 1024;

/// Experiments one figure may draw (`/api/experiments/figure.svg?ids=…`).
pub const MAX_FIGURE_EXPERIMENTS: usize = 24;

/// What a version is the version of.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
enum Inputs {
    Experiment(i64),
    Scene(String),
    /// The booth's measurements and previews (the overview's other inputs).
    Overview(Booth),
}

/// A version read from the database: when, and [`Store::writes`] just
/// before it was read.
#[derive(Clone, Copy)]
struct Checked {
    version: InputsVersion,
    writes: u64,
    at: Instant,
}

/// One kept result: the version it was computed for, and the cell its
/// computation fills once.
struct Entry<V> {
    version: Vec<InputsVersion>,
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
    fn cell(&self, key: &K, version: Vec<InputsVersion>) -> Arc<OnceCell<Arc<V>>> {
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

/// A response body made from a kept result: the result it was made from
/// (weakly: a result no longer kept or served is let go, and while this
/// lives its address is never reused by another), and the body once made.
struct Output {
    from: Weak<dyn Any + Send + Sync>,
    cell: Arc<OnceCell<Arc<Vec<u8>>>>,
    used: u64,
}

/// The lab's computed results (see the module doc). Shared by every clone
/// of the [`LabHandle`](crate::LabHandle).
pub struct Computed {
    store: Store,
    observer: Observer,
    experiments: Experiments,
    analyses: Kept<i64, Analysis>,
    scenes: Kept<String, SceneComparisons>,
    overviews: Kept<Booth, ScenesOverview>,
    outputs: Mutex<HashMap<(usize, String), Output>>,
    output_tick: AtomicU64,
    checked: Mutex<HashMap<Inputs, Arc<tokio::sync::Mutex<Option<Checked>>>>>,
    computing: Semaphore,
    reading: Semaphore,
    computations: AtomicU64,
    version_reads: AtomicU64,
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
            overviews: Kept::new(),
            outputs: Mutex::new(HashMap::new()),
            output_tick: AtomicU64::new(0),
            checked: Mutex::new(HashMap::new()),
            computing: Semaphore::new(COMPUTING_AT_ONCE),
            reading: Semaphore::new(READING_AT_ONCE),
            computations: AtomicU64::new(0),
            version_reads: AtomicU64::new(0),
        }
    }

    /// How many results and bodies have been computed (not served from
    /// what is kept) since the lab started: what the tests count.
    pub fn computations(&self) -> u64 {
        self.computations.load(Ordering::Relaxed)
    }

    /// How many versions have been read from the database: what the tests
    /// count.
    pub fn version_reads(&self) -> u64 {
        self.version_reads.load(Ordering::Relaxed)
    }

    /// The analysis of experiment `id` (computed for the stored trials now).
    pub async fn analysis(&self, id: i64) -> Result<Arc<Analysis>, LabError> {
        let version = self.version(Inputs::Experiment(id)).await?;
        let experiments = self.experiments.clone();
        self.get(&self.analyses, &id, vec![version], async move {
            experiments.analyze(id).await
        })
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
    /// scene is not checked here: [`crate::LabHandle::scene_comparisons`] does).
    pub async fn scene_comparisons(&self, scene: &str) -> Result<Arc<SceneComparisons>, LabError> {
        Ok(self.scene_comparisons_versioned(scene).await?.1)
    }

    /// [`Self::scene_comparisons`] with the version it was computed for.
    async fn scene_comparisons_versioned(
        &self,
        scene: &str,
    ) -> Result<(InputsVersion, Arc<SceneComparisons>), LabError> {
        let version = self.version(Inputs::Scene(scene.to_string())).await?;
        let (store, observer, owned) = (self.store.clone(), self.observer, scene.to_string());
        let summary = self
            .get(&self.scenes, &scene.to_string(), vec![version], async move {
                Ok(summary::scene_comparisons(&store, &owned, observer).await?)
            })
            .await?;
        Ok((version, summary))
    }

    /// The overview of `scenes` in `booth` ([`crate::compare::overview`]):
    /// kept until one of the scenes' comparisons, the booth's complete
    /// measurements or the newest preview changes.
    pub async fn scenes_overview(
        &self,
        scenes: Vec<SceneInfo>,
        booth: &Booth,
    ) -> Result<Arc<ScenesOverview>, LabError> {
        let mut version = Vec::with_capacity(scenes.len() + 1);
        let mut summaries = Vec::with_capacity(scenes.len());
        for s in &scenes {
            let (v, summary) = self.scene_comparisons_versioned(&s.id).await?;
            version.push(v);
            summaries.push(summary);
        }
        version.push(self.version(Inputs::Overview(booth.clone())).await?);
        let (store, observer, owned) = (self.store.clone(), self.observer, booth.clone());
        self.get(&self.overviews, booth, version, async move {
            Ok(crate::compare::overview::scenes_overview(&store, &scenes, &summaries, &owned, observer).await?)
        })
        .await
    }

    /// A response body made by `make` from the kept result `from` (its
    /// JSON, CSV, MAT file or a chart, named by `what`): made once per
    /// result, on the blocking pool, single-flight as results are.
    pub async fn output<V: Send + Sync + 'static>(
        &self,
        from: &Arc<V>,
        what: &str,
        make: impl FnOnce(&V) -> Result<Vec<u8>, String> + Send + 'static,
    ) -> Result<Arc<Vec<u8>>, LabError> {
        let cell = self.output_cell(from, what);
        let from = from.clone();
        let body = cell
            .get_or_try_init(|| async {
                let _permit = self.computing.acquire().await.expect("the semaphore is never closed");
                self.computations.fetch_add(1, Ordering::Relaxed);
                let body = tokio::task::spawn_blocking(move || make(&from))
                    .await
                    .map_err(|e| LabError::Internal(format!("making a response failed: {e}")))?
                    .map_err(LabError::Internal)?;
                Ok::<_, LabError>(Arc::new(body))
            })
            .await?;
        Ok(body.clone())
    }

    /// A response body made by `make` now (from several results, so not
    /// kept), on the blocking pool within the bound of computations.
    pub async fn output_not_kept(
        &self,
        make: impl FnOnce() -> Result<Vec<u8>, String> + Send + 'static,
    ) -> Result<Vec<u8>, LabError> {
        let _permit = self.computing.acquire().await.expect("the semaphore is never closed");
        self.computations.fetch_add(1, Ordering::Relaxed);
        tokio::task::spawn_blocking(make)
            .await
            .map_err(|e| LabError::Internal(format!("making a response failed: {e}")))?
            .map_err(LabError::Internal)
    }

    /// The cell of the body `what` of `from`: the kept one or a new one
    /// (dropping the bodies of results let go, and the least recently used
    /// when full).
    fn output_cell<V: Send + Sync + 'static>(&self, from: &Arc<V>, what: &str) -> Arc<OnceCell<Arc<Vec<u8>>>> {
        let used = self.output_tick.fetch_add(1, Ordering::Relaxed);
        let key = (Arc::as_ptr(from) as *const () as usize, what.to_string());
        let mut outputs = self.outputs.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(o) = outputs.get_mut(&key) {
            // The same address is the same result while the weak handle
            // lives; a result let go cannot be asked about.
            if o.from.strong_count() > 0 {
                o.used = used;
                return o.cell.clone();
            }
        }
        // The bodies of results let go (an analysis replaced by a newer
        // version) are dropped at once, not when the map is full: each can
        // be megabytes, and an experiment under way replaces its analysis
        // with every trial.
        outputs.retain(|_, o| o.from.strong_count() > 0);
        if outputs.len() >= OUTPUTS {
            if let Some(oldest) = outputs.iter().min_by_key(|(_, o)| o.used).map(|(k, _)| k.clone()) {
                outputs.remove(&oldest);
            }
        }
        let any: Arc<dyn Any + Send + Sync> = from.clone();
        let cell = Arc::new(OnceCell::new());
        outputs.insert(
            key,
            Output {
                from: Arc::downgrade(&any),
                cell: cell.clone(),
                used,
            },
        );
        cell
    }

    /// The version of `inputs`: the one read last, while this process has
    /// written nothing since and it is younger than [`OTHERS_SEEN_WITHIN`];
    /// otherwise read now (at most [`READING_AT_ONCE`] reads at a time, one
    /// per `inputs` however many requests wait for it).
    async fn version(&self, inputs: Inputs) -> Result<InputsVersion, LabError> {
        let slot = {
            let mut checked = self.checked.lock().unwrap_or_else(|e| e.into_inner());
            if checked.len() >= CHECKS && !checked.contains_key(&inputs) {
                checked.clear();
            }
            checked.entry(inputs.clone()).or_default().clone()
        };
        let mut last = slot.lock().await;
        if let Some(c) = *last {
            if c.writes == self.store.writes() && c.at.elapsed() < OTHERS_SEEN_WITHIN {
                return Ok(c.version);
            }
        }
        // The count before the read: a write while it runs forces another.
        let writes = self.store.writes();
        let at = Instant::now();
        let version = {
            let _permit = self.reading.acquire().await.expect("the semaphore is never closed");
            self.version_reads.fetch_add(1, Ordering::Relaxed);
            self.read_version(&inputs).await?
        };
        *last = Some(Checked { version, writes, at });
        Ok(version)
    }

    /// The version of `inputs` as the database has it now.
    fn read_version<'a>(&'a self, inputs: &'a Inputs) -> BoxFuture<'a, Result<InputsVersion, StoreError>> {
        match inputs {
            Inputs::Experiment(id) => self.store.experiment_inputs(*id),
            Inputs::Scene(scene) => self.store.scene_comparison_inputs(scene),
            Inputs::Overview(booth) => self.store.overview_inputs(booth),
        }
    }

    /// The result of `key` at `version`: the kept one, the one being
    /// computed, or `compute` run now on the blocking pool (at most
    /// [`COMPUTING_AT_ONCE`] at a time) and kept.
    async fn get<K: Eq + Hash + Clone, V: Send + Sync + 'static>(
        &self,
        kept: &Kept<K, V>,
        key: &K,
        version: Vec<InputsVersion>,
        compute: impl std::future::Future<Output = Result<V, LabError>> + Send + 'static,
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
