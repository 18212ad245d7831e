//! The bounded queue of renders and studies the API starts.
//!
//! - A request is admitted only with a slot reserved in the queue
//!   ([`JOB_QUEUE_CAPACITY`] waiting at most; more answer 409), and its row
//!   is written only once the slot is held, so a refused request leaves
//!   nothing behind.
//! - One worker runs the jobs one at a time, on the global rayon pool, each
//!   under its own [`CancellationToken`] (checked by the renderer between batches
//!   of paths) and inside `catch_unwind`: a panic fails that job with the
//!   panic's message instead of aborting the daemon.
//! - `POST /api/{renders,studies}/{id}/cancel` ends a queued job at once and
//!   stops a running one within a batch; shutdown cancels the running job
//!   and marks it and every queued one `interrupted`.
//! - Renders and studies of a crashed daemon are marked `interrupted` when
//!   the store next opens; `POST /api/{renders,studies}/{id}/retry` queues a
//!   new job (a new id) with the same request, keeping the old row as the
//!   record of what happened.
//!
//! The simulated PR-650's converged spectra are rendered on a separate pool
//! (see [`SimulatedTruth`](crate::measure::simulated_truth::SimulatedTruth)), so a long job never leaves
//! the instrument thread waiting behind its batches.

use std::collections::HashMap;
use std::sync::Mutex;

use tokio::sync::mpsc;

use crate::error::LabError;
use lightbooth_store::{Job, JobEnd, Store};
use tokio_util::sync::CancellationToken;

/// Renders and studies that may wait for the worker; more get 409.
pub const JOB_QUEUE_CAPACITY: usize = 8;

/// Radiometer paths per target a render request may ask for: the renderer's
/// own cap on adaptive sampling (`RenderSettings::max_samples`, 2²²).
pub const MAX_RENDER_SAMPLES: u32 = 1 << 22;

/// The largest bounce cap a render request may ask for (`bounces`; absent:
/// no cap, Russian roulette). The study used 5; past a few dozen bounces
/// the booth's reflectances leave nothing to add.
pub const MAX_RENDER_BOUNCES: u32 = 64;

/// Set in the environment of a test daemon: renders, studies and converged
/// spectra of this scene id panic (on a rayon worker), to test that a panic
/// fails one job and never the daemon. Read on every job; never set in use.
pub const TEST_PANIC_ENV: &str = "LIGHTBOOTH_TEST_PANIC_SCENE";

/// True when [`TEST_PANIC_ENV`] names `scene`.
pub fn test_panic_requested(scene: &str) -> bool {
    std::env::var(TEST_PANIC_ENV).is_ok_and(|s| !s.is_empty() && s == scene)
}

/// A panic on rayon's workers, as a real bug in the renderer would raise it.
pub fn panic_on_the_pool(scene: &str) {
    use rayon::prelude::*;
    (0..2u32).into_par_iter().for_each(|_| {
        panic!("test panic in the renderer for scene `{scene}` ({TEST_PANIC_ENV})");
    });
}

/// The text of a caught panic.
pub fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "a panic without a message".into())
}

/// One admitted job, as the worker receives it.
pub struct Queued<W> {
    pub job: Job,
    pub id: i64,
    pub work: W,
    pub cancel: CancellationToken,
}

/// The queue and the cancellation flags of every admitted, unfinished job.
pub struct JobQueue<W> {
    sender: Mutex<Option<mpsc::Sender<Queued<W>>>>,
    receiver: Mutex<Option<mpsc::Receiver<Queued<W>>>>,
    flags: Mutex<HashMap<(Job, i64), CancellationToken>>,
    /// The daemon's shutdown: every job's token is a child of it.
    shutdown: CancellationToken,
    store: Store,
}

impl<W: Send + 'static> JobQueue<W> {
    /// A queue whose jobs stop when `shutdown` is cancelled.
    pub fn new(store: Store, shutdown: CancellationToken) -> JobQueue<W> {
        let (tx, rx) = mpsc::channel(JOB_QUEUE_CAPACITY);
        JobQueue {
            sender: Mutex::new(Some(tx)),
            receiver: Mutex::new(Some(rx)),
            flags: Mutex::default(),
            shutdown,
            store,
        }
    }

    /// The receiving end, for the one worker (`None` once taken).
    pub fn take_receiver(&self) -> Option<mpsc::Receiver<Queued<W>>> {
        self.receiver.lock().unwrap_or_else(|p| p.into_inner()).take()
    }

    /// Admits a job: reserves a slot (409 when the queue is full, 503 when
    /// the daemon is shutting down), then records the row with `create`
    /// and queues `work`. Nothing is written for a refused request.
    pub async fn enqueue<F>(&self, job: Job, create: F, work: W) -> Result<i64, LabError>
    where
        F: std::future::Future<Output = Result<i64, LabError>>,
    {
        let sender = self
            .sender
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .clone()
            .ok_or_else(|| LabError::Unavailable("the daemon is shutting down".into()))?;
        let permit = sender.try_reserve().map_err(|e| match e {
            mpsc::error::TrySendError::Full(()) => LabError::Conflict(format!(
                "the render queue is full: {JOB_QUEUE_CAPACITY} renders and studies are already waiting; \
                 try again when one finishes, or cancel one"
            )),
            mpsc::error::TrySendError::Closed(()) => LabError::Unavailable("the daemon is shutting down".into()),
        })?;
        let id = create.await?;
        // Cancelled with the daemon's shutdown, or alone by a client.
        let cancel = self.shutdown.child_token();
        self.flags
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .insert((job, id), cancel.clone());
        permit.send(Queued { job, id, work, cancel });
        Ok(id)
    }

    /// Cancels a render or study: a queued one ends `cancelled` at once, a
    /// running one is stopped (the worker records `cancelled` within a batch
    /// of paths). 404 for an unknown id, 409 when it has already ended.
    pub async fn cancel(&self, job: Job, id: i64) -> Result<(), LabError> {
        let noun = job.noun();
        let state = self
            .store
            .job_state(job, id)
            .await?
            .ok_or_else(|| LabError::NotFound(format!("no {noun} {id}")))?;
        match state.as_str() {
            "queued" => {
                if self
                    .store
                    .end_job(job, id, JobEnd::Cancelled, "cancelled by a client before it started")
                    .await?
                {
                    tracing::info!(job = noun, id, "cancelled while queued");
                    return Ok(());
                }
                // It started meanwhile: stop it as a running one.
                self.flag(job, id);
                Ok(())
            }
            "running" => {
                if !self.flag(job, id) {
                    // Not this daemon's: a crash left it (start-up marks those interrupted).
                    self.store
                        .end_job(job, id, JobEnd::Cancelled, "cancelled by a client")
                        .await?;
                }
                tracing::info!(job = noun, id, "cancellation requested");
                Ok(())
            }
            other => Err(LabError::Conflict(format!(
                "{noun} {id} is already {other}; nothing to cancel"
            ))),
        }
    }

    /// Sets the flag of an admitted job; false when it has none (finished).
    fn flag(&self, job: Job, id: i64) -> bool {
        match self.flags.lock().unwrap_or_else(|p| p.into_inner()).get(&(job, id)) {
            Some(f) => {
                f.cancel();
                true
            }
            None => false,
        }
    }

    /// The worker is done with a job: forget its flag.
    pub fn finished(&self, job: Job, id: i64) {
        self.flags.lock().unwrap_or_else(|p| p.into_inner()).remove(&(job, id));
    }

    pub fn is_shutting_down(&self) -> bool {
        self.shutdown.is_cancelled()
    }

    /// Refuses new jobs and cancels every admitted one; the worker then
    /// marks them `interrupted` and stops once the queue is empty.
    pub fn shutdown(&self) {
        self.sender.lock().unwrap_or_else(|p| p.into_inner()).take();
        // Cancels every admitted job's token, its children.
        self.shutdown.cancel();
    }

    /// How a job that did not complete ends, and why ([`job_end`], with
    /// this queue's shutdown).
    pub fn end_of(&self, job: Job, cancelled: bool, error: Option<String>) -> (JobEnd, String) {
        job_end(job, cancelled, self.is_shutting_down(), error)
    }
}

/// How a job that did not complete ends, and why: stopped by the daemon's
/// shutdown, `interrupted` (retry it); stopped otherwise, `cancelled` by a
/// client; else `failed` with its error.
pub fn job_end(job: Job, cancelled: bool, shutting_down: bool, error: Option<String>) -> (JobEnd, String) {
    let noun = job.noun();
    match (cancelled, error) {
        (true, _) if shutting_down => (
            JobEnd::Interrupted,
            format!(
                "the daemon shut down during this {noun}; retry it with POST /api/{}/{{id}}/retry",
                job.table()
            ),
        ),
        (true, _) => (JobEnd::Cancelled, "cancelled by a client".into()),
        (false, Some(e)) => (JobEnd::Failed, e),
        (false, None) => (JobEnd::Failed, format!("the {noun} ended without a result")),
    }
}
