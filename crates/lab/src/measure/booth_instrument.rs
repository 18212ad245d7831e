//! The lab's handle on the booth's instrument, for everything that is not
//! the instrument task itself: asking for a measurement
//! ([`BoothInstrument::request`], the validation and the enqueueing),
//! cancelling one, taking and releasing the calibration's hold, and reading
//! the live status and the queue. The HTTP handlers call these methods and
//! never the queue's channels or the store for it; the instrument task
//! takes the jobs at the other end and records each through
//! [`crate::measure::recorder::Recorder::take`].

use std::sync::Arc;
use std::time::Duration;

use tokio::sync::{mpsc, watch};

use crate::error::LabError;
use crate::events::{Event, EventSink};
use crate::measure::queue::{CancelMeasurement, HoldInfo, InstrumentHold, InstrumentStatus, MeasurementJob};
use crate::requests::SceneInfo;
use lightbooth_instrument::Capabilities;
use lightbooth_store::{Booth, MeasurementFilter, MeasurementState, MeasurementSummary, NewMeasurement, Store};

/// How long a cancel waits for a running measurement to stop before
/// answering that it is still stopping (it stops within one poll slice of
/// the instrument's reply).
const CANCEL_WAIT: Duration = Duration::from_secs(5);

/// Why no measurement is queued once the instrument task has stopped.
const TASK_STOPPED: &str = "the instrument task has stopped; no measurement can run (see /api/health)";

/// A measurement to take, as an operator or a script asks for it.
#[derive(Clone, Debug, Default)]
pub struct MeasurementRequest {
    /// With `target`: the scene target measured, rendered and compared.
    pub scene: Option<String>,
    pub target: Option<String>,
    /// Samples to average; `None`: the instrument model's default.
    pub samples: Option<usize>,
    pub session_id: Option<i64>,
    /// Free text kept with the measurement.
    pub note: String,
    /// The instrument hold this measurement belongs to (see [`InstrumentHold`]).
    pub hold: Option<i64>,
    /// Queue it even when the same measurement is already on its way
    /// (repeated measurements of one target, on purpose).
    pub repeat: bool,
}

/// What a measurement request came to (see [`BoothInstrument::request`]).
#[derive(Debug)]
pub enum Requested {
    /// Recorded and queued: its id.
    Queued(i64),
    /// The same measurement — this booth's instrument, the same scene
    /// target, samples, note, session and hold — is already queued or running:
    /// that one, as it is now; nothing new was queued.
    AlreadyOnItsWay(Box<MeasurementSummary>),
}

/// What a study's "measure the missing targets first" came to (see
/// [`BoothInstrument::request_targets`]).
#[derive(Debug, Default, PartialEq)]
pub struct TargetsRequested {
    /// The measurements queued now, one per target with none on its way.
    pub queued: Vec<i64>,
    /// The measurements already queued or running for the other targets
    /// (skipped: not queued again; the study waits for these too).
    pub already_on_their_way: Vec<i64>,
}

/// How a cancel ended (see [`BoothInstrument::cancel`]).
#[derive(Debug)]
pub enum Cancelled {
    /// The measurement is cancelled; its row as it is now.
    Done(MeasurementSummary),
    /// The running measurement was asked to stop and has not yet.
    Stopping(MeasurementSummary),
}

/// The booth's instrument as the lab sees it (see the module doc). Cheap to clone.
#[derive(Clone)]
pub struct BoothInstrument {
    store: Store,
    jobs: mpsc::Sender<MeasurementJob>,
    status: watch::Receiver<InstrumentStatus>,
    events: EventSink,
    hold: Arc<InstrumentHold>,
    /// Stops the running measurement (the instrument task's; None without one).
    running: Option<Arc<dyn CancelMeasurement>>,
    capabilities: Capabilities,
    booth: Booth,
    /// Held from the look for a measurement on its way to its queueing, so
    /// two identical requests at once queue one measurement, not two.
    admitting: Arc<tokio::sync::Mutex<()>>,
}

impl BoothInstrument {
    /// The handle on the instrument task at the other end of `jobs`, whose
    /// live status is `status`, measuring in `booth` with `capabilities`.
    pub fn new(
        store: Store,
        jobs: mpsc::Sender<MeasurementJob>,
        status: watch::Receiver<InstrumentStatus>,
        events: EventSink,
        running: Option<Arc<dyn CancelMeasurement>>,
        capabilities: Capabilities,
        booth: Booth,
    ) -> BoothInstrument {
        BoothInstrument {
            store,
            jobs,
            status,
            events,
            hold: Arc::default(),
            running,
            capabilities,
            booth,
            admitting: Arc::default(),
        }
    }

    /// What the instrument is doing now.
    pub fn status(&self) -> InstrumentStatus {
        self.status.borrow().clone()
    }

    /// Measurements queued (or being queued) and not yet taken by the task.
    pub fn queued(&self) -> usize {
        self.jobs.max_capacity() - self.jobs.capacity()
    }

    /// True when the instrument task has stopped: nothing queued will run.
    pub fn task_stopped(&self) -> bool {
        self.jobs.is_closed()
    }

    /// What the instrument model can do.
    pub fn capabilities(&self) -> &Capabilities {
        &self.capabilities
    }

    /// The booth it measures in.
    pub fn booth(&self) -> &Booth {
        &self.booth
    }

    /// The calibration's hold on the instrument.
    pub fn hold(&self) -> &InstrumentHold {
        &self.hold
    }

    /// Checks `request` against the instrument model, the `scenes` the
    /// daemon can render, the instrument's status and the sessions, then
    /// records and queues it (`Queued`, its id) — unless a measurement of
    /// the same scene target with the same samples, note, session and hold is
    /// already queued or running in this booth: then nothing is queued and
    /// the answer is that one (`AlreadyOnItsWay`; a page clicked twice, or
    /// a script's retry, once queued every target twice), unless it asks
    /// to `repeat`. `Invalid` names the field.
    pub async fn request(&self, request: MeasurementRequest, scenes: &[SceneInfo]) -> Result<Requested, LabError> {
        let capabilities = &self.capabilities;
        let samples = request.samples.unwrap_or(capabilities.default_samples);
        if !(1..=capabilities.max_samples).contains(&samples) {
            return Err(LabError::Invalid(format!(
                "field `samples`: {samples} is outside 1–{}, what the {} averages per measurement",
                capabilities.max_samples, capabilities.model
            )));
        }
        match (&request.scene, &request.target) {
            (Some(scene), target) => check_scene_target(scenes, scene, target.as_deref())?,
            (None, Some(_)) => return Err(LabError::Invalid("field `target`: a target needs its `scene`".into())),
            (None, None) => {}
        }
        self.refuse_unavailable("")?;
        if let Some(session) = request.session_id {
            if !self.store.list_sessions().await?.iter().any(|s| s.id == session) {
                return Err(LabError::Invalid(format!(
                    "field `session_id`: no session {session}; create one with POST /api/sessions"
                )));
            }
        }
        let _admitting = self.admitting.lock().await;
        if let (Some(scene), Some(target), false) = (&request.scene, &request.target, request.repeat) {
            let same = self.on_its_way(scene, target).await?.into_iter().find(|m| {
                m.samples_requested == samples as i64
                    && m.note == request.note
                    && m.session_id == request.session_id
                    && m.hold.as_ref().map(|h| h.id) == request.hold
            });
            if let Some(existing) = same {
                tracing::info!(measurement_id = existing.id, %scene, %target, "measurement already on its way; not queued again");
                return Ok(Requested::AlreadyOnItsWay(Box::new(existing)));
            }
        }
        self.enqueue(
            request.hold,
            NewMeasurement {
                booth: self.booth.clone(),
                session_id: request.session_id,
                scene: request.scene,
                target: request.target,
                samples,
                settings_json: serde_json::json!({ "samples": samples }),
                note: request.note,
            },
        )
        .await
        .map(Requested::Queued)
    }

    /// The measurements of `scene`/`target` in this booth queued or running,
    /// oldest first. Queued ones are read first: a measurement only moves
    /// from queued to running, so one the instrument takes between the two
    /// reads is found by the second (read the other way round it was missed,
    /// and a duplicate queued).
    async fn on_its_way(&self, scene: &str, target: &str) -> Result<Vec<MeasurementSummary>, LabError> {
        let mut found = Vec::new();
        for state in [MeasurementState::Queued, MeasurementState::Running] {
            let filter = MeasurementFilter {
                booth: Some(self.booth.clone()),
                scene: Some(scene.into()),
                target: Some(target.into()),
                state: Some(state),
                limit: Some(1000),
                ..MeasurementFilter::default()
            };
            found.extend(self.store.list_measurements(&filter).await?.items);
        }
        found.sort_by_key(|m| m.id);
        Ok(found)
    }

    /// Queues a measurement of each scene target in `missing` (a study's
    /// first measurements), with the default samples and `note`, skipping
    /// each target that already has a measurement queued or running in
    /// this booth (any samples: the study waits for that one instead).
    /// Refused as a whole when the queue has not room for all the new ones
    /// before the first is queued; should a concurrent request fill the
    /// queue meanwhile, the ones already queued stay ordinary measurements.
    pub async fn request_targets(
        &self,
        missing: &[(String, String)],
        note: &str,
    ) -> Result<TargetsRequested, LabError> {
        let what = format!("no complete measurement of {}, and ", describe_targets(missing));
        self.refuse_unavailable(&what)?;
        let _admitting = self.admitting.lock().await;
        let mut requested = TargetsRequested::default();
        let mut to_queue = Vec::with_capacity(missing.len());
        for (scene, target) in missing {
            match self.on_its_way(scene, target).await?.first() {
                Some(existing) => requested.already_on_their_way.push(existing.id),
                None => to_queue.push((scene, target)),
            }
        }
        if self.jobs.capacity() < to_queue.len() {
            return Err(LabError::Conflict(format!(
                "measuring the {} missing targets needs {} places in the instrument queue and {} are free; \
                 try again when the queued measurements have finished",
                to_queue.len(),
                to_queue.len(),
                self.jobs.capacity()
            )));
        }
        let samples = self.capabilities.default_samples;
        for (scene, target) in to_queue {
            let new = NewMeasurement {
                booth: self.booth.clone(),
                session_id: None,
                scene: Some(scene.clone()),
                target: Some(target.clone()),
                samples,
                settings_json: serde_json::json!({ "samples": samples }),
                note: note.into(),
            };
            requested.queued.push(self.enqueue(None, new).await?);
        }
        tracing::info!(
            queued = requested.queued.len(),
            already_on_their_way = requested.already_on_their_way.len(),
            "missing targets queued for a study"
        );
        Ok(requested)
    }

    /// Why a measurement asked for now would be refused with 503 (the
    /// instrument starting, disconnected or in error, or its task stopped),
    /// in the words of that refusal; `None` when it would be queued. What
    /// `/api/health` says of measurements.
    pub fn unavailable(&self) -> Option<String> {
        match self.refuse_unavailable("") {
            Err(e) => Some(e.to_string()),
            Ok(()) => self.task_stopped().then(|| TASK_STOPPED.to_string()),
        }
    }

    /// 503 when the instrument is disconnected or in error; `context`
    /// (empty, or ending in ", and ") says what was asked.
    fn refuse_unavailable(&self, context: &str) -> Result<(), LabError> {
        let (state, why) = match &*self.status.borrow() {
            // A study's first measurements: "unavailable to take them".
            InstrumentStatus::Disconnected { reason } if context.is_empty() => ("unavailable", reason.clone()),
            InstrumentStatus::Disconnected { reason } => ("unavailable to take them", reason.clone()),
            InstrumentStatus::Error { message } => ("in error", message.clone()),
            _ => return Ok(()),
        };
        Err(LabError::Unavailable(format!(
            "{context}the instrument is {state}: {why}"
        )))
    }

    /// Records and queues one measurement for the instrument. A slot in the
    /// queue is held before the row exists: a refused request (queue full,
    /// instrument task gone) leaves nothing behind, and an admitted one
    /// cannot find the queue full.
    ///
    /// While the instrument is held only a measurement naming the hold is
    /// queued; the check follows the reservation, so a hold taken meanwhile
    /// either sees the slot reserved (and is refused) or is seen here.
    async fn enqueue(&self, hold: Option<i64>, new: NewMeasurement) -> Result<i64, LabError> {
        let permit = self.jobs.try_reserve().map_err(|e| match e {
            mpsc::error::TrySendError::Full(()) => LabError::Conflict(format!(
                "the instrument is busy: {} measurements are already queued; try again when one finishes",
                self.jobs.max_capacity()
            )),
            mpsc::error::TrySendError::Closed(()) => LabError::Unavailable(TASK_STOPPED.into()),
        })?;
        let what = match (&new.scene, &new.target) {
            (Some(scene), Some(target)) => format!("a measurement of {scene}/{target}"),
            _ => "a measurement".to_string(),
        };
        let held = self.hold.admit(hold, &what, lightbooth_store::now())?;
        let (scene, target, samples) = (new.scene.clone(), new.target.clone(), new.samples);
        let id = self
            .store
            .create_held_measurement(&new, held.as_ref().map(|h| (h.id, h.purpose.as_str())))
            .await?;
        permit.send(MeasurementJob {
            id,
            samples,
            scene,
            target,
        });
        tracing::info!(measurement_id = id, samples, "measurement queued");
        self.events.send(Event::MeasurementQueued { measurement_id: id });
        Ok(id)
    }

    /// Cancels a queued or running measurement. A queued one never starts;
    /// a running one stops at once (between instrument commands, or while
    /// a reply is read), keeping every sample already taken. `Stopping`
    /// when it has not stopped within 5 s; `NotFound`, `Conflict` when it
    /// had already finished (or ended otherwise meanwhile), `Unavailable`
    /// when it runs and no instrument task here can stop it.
    pub async fn cancel(&self, id: i64) -> Result<Cancelled, LabError> {
        let m = self.summary(id).await?;
        if m.state.is_final() {
            return Err(LabError::Conflict(format!(
                "measurement {id} is already {}{}; only a queued or running measurement can be cancelled",
                m.state.as_str(),
                m.error.as_ref().map(|e| format!(" ({e})")).unwrap_or_default()
            )));
        }
        let queued_message = format!(
            "cancelled by the operator before it started; no sample taken ({} requested)",
            m.samples_requested
        );
        if self.store.cancel_queued(id, &queued_message).await? {
            tracing::info!(measurement_id = id, "queued measurement cancelled");
            self.events.send(Event::MeasurementFinished {
                measurement_id: id,
                state: MeasurementState::Cancelled,
                error: Some(queued_message),
            });
            return Ok(Cancelled::Done(self.summary(id).await?));
        }
        // The instrument has taken it: stop it there.
        let signalled = self.running.as_ref().is_some_and(|c| c.cancel(id));
        if signalled {
            tracing::info!(measurement_id = id, "cancel requested for the running measurement");
        }
        let deadline = tokio::time::Instant::now() + CANCEL_WAIT;
        loop {
            let now = self.summary(id).await?;
            match now.state {
                MeasurementState::Cancelled => return Ok(Cancelled::Done(now)),
                s if s.is_final() => {
                    return Err(LabError::Conflict(format!(
                        "measurement {id} ended {} before it could be cancelled{}",
                        s.as_str(),
                        now.error.as_ref().map(|e| format!(" ({e})")).unwrap_or_default()
                    )))
                }
                _ if !signalled && self.running.is_none() => {
                    return Err(LabError::Unavailable(format!(
                        "measurement {id} is {} and no instrument task runs here to stop it",
                        now.state.as_str()
                    )))
                }
                _ if tokio::time::Instant::now() >= deadline => return Ok(Cancelled::Stopping(now)),
                _ => tokio::time::sleep(Duration::from_millis(50)).await,
            }
        }
    }

    /// Takes the hold for `purpose`: granted only while nothing is
    /// measuring, being queued, or queued or running in the store for this
    /// booth (see [`InstrumentHold::take`]).
    pub async fn take_hold(&self, purpose: &str) -> Result<HoldInfo, LabError> {
        let mut busy = Vec::new();
        if let InstrumentStatus::Measuring { measurement_id, .. } = &*self.status.borrow() {
            busy.push(format!("measurement {measurement_id} under way"));
        }
        let reserved = self.queued();
        if reserved > 0 {
            busy.push(if reserved == 1 {
                "1 measurement being queued".to_string()
            } else {
                format!("{reserved} measurements being queued")
            });
        }
        let unfinished = self.store.unfinished_measurements_in_booth(&self.booth).await?;
        if !unfinished.is_empty() {
            let ids: Vec<String> = unfinished.iter().map(i64::to_string).collect();
            busy.push(format!("measurements {} queued or running", ids.join(", ")));
        }
        let busy = (!busy.is_empty()).then(|| busy.join("; "));
        // Refused before an id is drawn when it would be; checked again on taking it.
        self.hold
            .check_take(purpose, busy.as_deref(), lightbooth_store::now())?;
        let id = self.store.record_instrument_hold(&self.booth, purpose.trim()).await?;
        let hold = self.hold.take(id, purpose, busy, lightbooth_store::now())?;
        tracing::info!(hold = hold.id, purpose = %hold.purpose, "instrument held");
        Ok(hold)
    }

    async fn summary(&self, id: i64) -> Result<MeasurementSummary, LabError> {
        Ok(self
            .store
            .get_measurement(id)
            .await?
            .ok_or_else(|| LabError::NotFound(format!("no measurement {id}")))?
            .summary)
    }
}

/// `scene` is one of `scenes` and `target` one of its targets; else
/// `Invalid`, naming the field and what is available.
pub fn check_scene_target(scenes: &[SceneInfo], scene: &str, target: Option<&str>) -> Result<(), LabError> {
    let Some(info) = scenes.iter().find(|s| s.id == scene) else {
        let names: Vec<&str> = scenes.iter().map(|s| s.id.as_str()).collect();
        return Err(LabError::Invalid(format!(
            "field `scene`: no scene `{scene}`; available: {}",
            names.join(", ")
        )));
    };
    match target {
        None => Err(LabError::Invalid(format!(
            "field `target`: measuring scene `{scene}` needs a target; available: {}",
            info.targets.join(", ")
        ))),
        Some(t) if !info.targets.iter().any(|x| x == t) => Err(LabError::Invalid(format!(
            "field `target`: scene `{scene}` has no target `{t}`; available: {}",
            info.targets.join(", ")
        ))),
        Some(_) => Ok(()),
    }
}

/// `cylinder (h00, h01, h02), red/patch`, in plain words: scene targets
/// for a refusal, grouped by scene.
pub fn describe_targets(missing: &[(String, String)]) -> String {
    let mut parts: Vec<String> = Vec::new();
    let mut i = 0;
    while i < missing.len() {
        let scene = &missing[i].0;
        let targets: Vec<&str> = missing[i..]
            .iter()
            .take_while(|(s, _)| s == scene)
            .map(|(_, t)| t.as_str())
            .collect();
        i += targets.len();
        parts.push(match targets.as_slice() {
            [one] => format!("{scene}/{one}"),
            many => format!("{scene} ({})", many.join(", ")),
        });
    }
    parts.join(", ")
}
