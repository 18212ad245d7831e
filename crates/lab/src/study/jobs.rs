//! A study as a job: its request checked field by field against the
//! catalogue ([`StudyRunner::plan`]), then run on a blocking thread under
//! its cancellation flag, with panics caught, and its end recorded.
//!
//! The study itself (every coding against measurements or a reference,
//! sweeps, failure maps) is [`crate::study::run`]; this module runs it for
//! the daemon's queue ([`crate::render::jobs`]) and for render workers
//! ([`StudyRunner::run_row`]), and runs one now for the command line
//! ([`run_study_now`]), recorded the same way.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;
use std::sync::Arc;

use tokio::runtime::Handle;

use crate::error::LabError;
use crate::events::{Event, EventSink};
use crate::jobs::{self, job_end};
use crate::requests::StudyRequest;
use crate::scenes::SceneCatalog;
use crate::study::awaited::wait_for_measurements;
use crate::study::report::report_files;
use crate::study::run::{progress_fractions, run_study, Against, StudyOptions, StudyResult};
use lightbooth_render::Coding;
use lightbooth_science::colorimetry::Observer;
use lightbooth_store::{Job, JobEnd, Store};
use tokio_util::sync::CancellationToken;

/// Plans and runs studies of the catalogue's scenes.
pub struct StudyRunner {
    store: Store,
    catalogue: Arc<SceneCatalog>,
    events: EventSink,
    /// The codings every study compares.
    codings: Vec<Coding>,
    observer: Observer,
    /// The folder of scenes the simulated truth is rendered from instead
    /// of the model (`serve --mock-world`).
    truth_scene: Option<PathBuf>,
    /// The daemon's shutdown flag: a study it stops ends `interrupted`.
    shutdown: CancellationToken,
    runtime: Handle,
}

impl StudyRunner {
    /// A runner of studies of `catalogue`'s scenes in `codings`, with
    /// `observer`; `truth_scene` as [`StudyOptions::truth_scene`]. Call it
    /// on the runtime the studies' database queries should run on.
    pub fn new(
        store: Store,
        catalogue: Arc<SceneCatalog>,
        events: EventSink,
        codings: Vec<Coding>,
        observer: Observer,
        truth_scene: Option<PathBuf>,
        shutdown: CancellationToken,
    ) -> StudyRunner {
        StudyRunner {
            store,
            catalogue,
            events,
            codings,
            observer,
            truth_scene,
            shutdown,
            runtime: Handle::current(),
        }
    }

    /// The scene files and study options of an API request, checked field
    /// by field ([`LabError::Invalid`] naming the field).
    pub fn plan(&self, request: &StudyRequest) -> Result<(Vec<PathBuf>, StudyOptions), LabError> {
        let paths = match &request.scenes {
            None => self.catalogue.iter().map(|s| s.path.clone()).collect(),
            Some(list) => list
                .split(',')
                .map(str::trim)
                .filter(|s| !s.is_empty())
                .map(|id| {
                    self.catalogue.get(id).map(|e| e.path.clone()).ok_or_else(|| {
                        LabError::Invalid(format!(
                            "field `scenes`: no scene `{id}`; available: {}",
                            self.catalogue.ids().join(", ")
                        ))
                    })
                })
                .collect::<Result<Vec<_>, _>>()?,
        };
        if paths.is_empty() {
            return Err(LabError::Invalid("field `scenes`: name at least one scene".into()));
        }
        let against = match request.against.as_deref().unwrap_or("measurements") {
            "measurements" => Against::Measurements,
            "reference" => Against::Reference,
            other => {
                return Err(LabError::Invalid(format!(
                    "field `against`: `{other}` is neither `measurements` nor `reference`"
                )))
            }
        };
        let seeds = request.seeds.unwrap_or(8);
        if !(1..=64).contains(&seeds) {
            return Err(LabError::Invalid(format!("field `seeds`: {seeds} is outside 1–64")));
        }
        let failure_map = request.failure_map.unwrap_or(false);
        if failure_map && !paths.iter().any(|p| p.file_stem().is_some_and(|s| s == "cylinder")) {
            return Err(LabError::Invalid(
                "field `failure_map`: the failure maps need the `cylinder` scene".into(),
            ));
        }
        let auto = request
            .auto
            .as_deref()
            .filter(|t| !t.trim().is_empty())
            .map(|t| t.parse::<crate::study::auto::Tolerance>())
            .transpose()
            .map_err(|e| LabError::Invalid(format!("field `auto`: {e}")))?;
        let booth = match request.booth.as_deref() {
            Some(b) => b
                .parse()
                .map_err(|e: String| LabError::Invalid(format!("field `booth`: {e}")))?,
            None => lightbooth_store::Booth::default(),
        };
        let options = StudyOptions {
            auto,
            booth,
            codings: self.codings.clone(),
            seeds,
            against,
            sweeps: request.sweeps.unwrap_or(false),
            failure_map,
            observer: self.observer,
            truth_scene: self.truth_scene.clone(),
            ..StudyOptions::default()
        };
        Ok((paths, options))
    }

    /// Runs the recorded study `id` of `paths` with `options`: first waits
    /// for the measurements queued for it (`measured_first`), then the
    /// study on a blocking thread (its renders use the rayon pool; never
    /// the async workers) under `cancel`, and records how it ended.
    pub async fn run(
        self: &Arc<Self>,
        id: i64,
        paths: Vec<PathBuf>,
        options: StudyOptions,
        measured_first: Vec<i64>,
        cancel: CancellationToken,
    ) -> anyhow::Result<()> {
        if !self.store.start_job(Job::Study, id).await? {
            tracing::info!(study_id = id, "study no longer queued (cancelled); not run");
            return Ok(());
        }
        tracing::info!(study_id = id, scenes = paths.len(), "study started");
        // `measure_missing`: the measurements queued for it come first.
        if !measured_first.is_empty() {
            let events = self.events.clone();
            let progress = move |message: &str| {
                events.send(Event::StudyProgress {
                    study_id: id,
                    message: message.to_string(),
                    fraction: None,
                });
            };
            if let Err(e) = wait_for_measurements(&self.store, &measured_first, &progress).await {
                self.store.end_job(Job::Study, id, JobEnd::Failed, &e).await?;
                tracing::warn!(study_id = id, error = %e, "study did not complete");
                self.events.send(Event::StudyFinished {
                    study_id: id,
                    ok: false,
                    error: Some(e),
                });
                return Ok(());
            }
        }
        let this = Arc::clone(self);
        let flag = cancel.clone();
        let outcome = tokio::task::spawn_blocking(move || {
            catch_unwind(AssertUnwindSafe(|| {
                for p in &paths {
                    if let Some(scene) = p.file_stem().and_then(|s| s.to_str()) {
                        if jobs::test_panic_requested(scene) {
                            jobs::panic_on_the_pool(scene);
                        }
                    }
                }
                let events = this.events.clone();
                // The k-th step begun: the study's work before it, each
                // scene's steps weighed by its targets.
                let targets: Vec<usize> = paths
                    .iter()
                    .map(|p| lightbooth_render::load_scene(p).map_or(1, |s| s.targets().len()))
                    .collect();
                let fractions = progress_fractions(&targets, &options);
                let begun = std::sync::atomic::AtomicUsize::new(0);
                let progress = move |message: &str| {
                    let k = begun.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    events.send(Event::StudyProgress {
                        study_id: id,
                        message: message.to_string(),
                        fraction: Some(fractions.get(k).copied().unwrap_or(1.0).min(1.0)),
                    });
                };
                this.runtime
                    .block_on(run_study(&paths, &options, Some(&this.store), &progress, Some(&flag)))
                    .map_err(|e| e.to_string())
                    .and_then(|result| {
                        let files = report_files(&result).map_err(|e| e.to_string())?;
                        let json = serde_json::to_value(&result).map_err(|e| e.to_string())?;
                        Ok((json, result.wall_seconds, files))
                    })
            }))
            .map_err(|panic| format!("the study panicked: {}", jobs::panic_message(&*panic)))
        })
        .await?;
        let outcome = match outcome {
            Ok(Ok((json, wall_seconds, files))) if !cancel.is_cancelled() => {
                match self.store.complete_study(id, &json, wall_seconds, &files).await {
                    Ok(()) => Ok(()),
                    Err(e) => Err(Some(e.to_string())),
                }
            }
            Ok(Ok(_)) => Err(None),
            // A render stopped by the flag fails the study with its error.
            Ok(Err(_)) if cancel.is_cancelled() => Err(None),
            Ok(Err(e)) | Err(e) => Err(Some(e)),
        };
        let error = match outcome {
            Ok(()) => {
                tracing::info!(study_id = id, "study complete");
                None
            }
            Err(error) => {
                let (end, message) = job_end(Job::Study, error.is_none(), self.shutdown.is_cancelled(), error);
                self.store.end_job(Job::Study, id, end, &message).await?;
                tracing::warn!(study_id = id, state = end.as_str(), error = %message, "study did not complete");
                Some(message)
            }
        };
        self.events.send(Event::StudyFinished {
            study_id: id,
            ok: error.is_none(),
            error,
        });
        Ok(())
    }

    /// Runs the queued study row `id` (another daemon's, for a render
    /// worker) under `cancel`, from its stored request and the
    /// measurements its daemon queued for it first.
    pub async fn run_row(self: &Arc<Self>, id: i64, cancel: CancellationToken) -> anyhow::Result<()> {
        let row = self
            .store
            .get_study(id)
            .await?
            .ok_or_else(|| anyhow::anyhow!("no study {id}"))?;
        let measured_first: Vec<i64> = row
            .request
            .get("measured_first")
            .and_then(|m| serde_json::from_value(m.clone()).ok())
            .unwrap_or_default();
        let request: StudyRequest = serde_json::from_value(row.request.clone())
            .map_err(|e| anyhow::anyhow!("study {id}'s stored request: {e}"))?;
        let (paths, options) = match self.plan(&request) {
            Ok(plan) => plan,
            Err(e) => {
                let why = format!("study {id}'s request on this worker: {e}");
                self.store.end_job(Job::Study, id, JobEnd::Failed, &why).await?;
                anyhow::bail!(why);
            }
        };
        self.run(id, paths, options, measured_first, cancel).await
    }
}

/// A study run now by its caller (`lightbooth study`), not queued: with a
/// `store`, recorded as created and started at once (a study left `queued`
/// could not be completed), then completed with its result and report
/// files, or failed with its error, as a daemon's study ends. Returns the
/// result and the id it is stored under.
pub async fn run_study_now(
    scenes: &[PathBuf],
    options: &StudyOptions,
    store: Option<&Store>,
    request: &serde_json::Value,
    progress: &(dyn Fn(&str) + Sync),
) -> anyhow::Result<(StudyResult, Option<i64>)> {
    let id = match store {
        Some(store) => {
            let id = store.create_study(request).await?;
            anyhow::ensure!(
                store.start_job(Job::Study, id).await?,
                "study {id} was ended before it started"
            );
            Some(id)
        }
        None => None,
    };
    let result = match run_study(scenes, options, store, progress, None).await {
        Ok(r) => r,
        Err(e) => {
            if let (Some(store), Some(id)) = (store, id) {
                store.fail_study(id, &e.to_string()).await?;
            }
            return Err(e.into());
        }
    };
    if let (Some(store), Some(id)) = (store, id) {
        let files = report_files(&result)?;
        store
            .complete_study(id, &serde_json::to_value(&result)?, result.wall_seconds, &files)
            .await?;
    }
    Ok((result, id))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{shipped_scenes, store_in};

    fn refusal(runner: &StudyRunner, request: StudyRequest) -> String {
        match runner.plan(&request) {
            Err(LabError::Invalid(m)) => m,
            Ok(_) => panic!("{request:?} was accepted"),
            Err(other) => panic!("{request:?}: {other:?}"),
        }
    }

    #[tokio::test]
    async fn a_study_request_is_checked_field_by_field_against_the_catalogue() {
        let dir = tempfile::tempdir().unwrap();
        let runner = StudyRunner::new(
            store_in(dir.path()).await,
            shipped_scenes(),
            EventSink::nowhere(),
            vec![Coding::Rgb, Coding::Spectral],
            Observer::JuddVos,
            None,
            CancellationToken::new(),
        );
        let with = |f: fn(&mut StudyRequest)| {
            let mut r = StudyRequest::default();
            f(&mut r);
            r
        };
        let unknown = refusal(&runner, with(|r| r.scenes = Some("white,attic".into())));
        assert!(
            unknown.starts_with("field `scenes`: no scene `attic`; available: white, red, green, blue, cylinder"),
            "{unknown}"
        );
        assert!(refusal(&runner, with(|r| r.scenes = Some(" , ".into()))).contains("name at least one scene"));
        assert!(refusal(&runner, with(|r| r.against = Some("truth".into()))).starts_with("field `against`"));
        assert!(refusal(&runner, with(|r| r.seeds = Some(0))).starts_with("field `seeds`: 0 is outside 1–64"));
        assert!(refusal(&runner, with(|r| r.seeds = Some(65))).starts_with("field `seeds`: 65"));
        let no_cylinder = with(|r| {
            r.scenes = Some("white".into());
            r.failure_map = Some(true);
        });
        assert!(refusal(&runner, no_cylinder).contains("need the `cylinder` scene"));
        assert!(refusal(&runner, with(|r| r.auto = Some("de00".into()))).starts_with("field `auto`"));

        // Accepted: the scenes asked for, in the asked order, with the
        // runner's codings and observer and the defaults.
        let (paths, options) = runner.plan(&with(|r| r.scenes = Some("red, white".into()))).unwrap();
        let names: Vec<_> = paths.iter().map(|p| p.file_stem().unwrap().to_str().unwrap()).collect();
        assert_eq!(names, ["red", "white"]);
        assert_eq!(options.codings, [Coding::Rgb, Coding::Spectral]);
        assert_eq!((options.seeds, options.against), (8, Against::Measurements));
        assert_eq!(
            runner.plan(&StudyRequest::default()).unwrap().0.len(),
            runner.catalogue.iter().count()
        );
    }
}
