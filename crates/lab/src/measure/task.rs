//! The one task that owns the instrument. It runs on a dedicated thread (the
//! driver does blocking serial I/O), takes queued measurements one at a
//! time so commands never interleave on the wire, and:
//!
//! - records each measurement through [`crate::measure::recorder::Recorder`]: each
//!   raw sample is in the store *before* the next sample starts (the thread
//!   blocks on the write), so a crash or a pulled cable keeps every sample
//!   taken, and the end of a measurement is written again until a database
//!   that was away answers;
//! - publishes its live [`InstrumentStatus`] and an [`Event`] per step;
//! - reopens a lost port with exponential backoff (1 s doubling to 30 s),
//!   saying so in the status and the log;
//! - with `--mock`, runs the simulated PR-650 on a pty and re-aims it at each
//!   measurement's scene target, as an operator re-aims the real one;
//! - is supervised: a panic fails the measurement it was taking (with the
//!   panic's message), the status says `error` while the task waits (1 s
//!   doubling to 30 s), and the task starts again with the same queue;
//! - never records a measurement `complete` unless every one of its samples
//!   was written: a failed sample write stops it, `failed`, with the error.
//!
//! Every log line of a measurement carries its `measurement_id`.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use tokio::runtime::Handle;
use tokio::sync::{mpsc, watch};

use crate::compare::Comparisons;
use crate::events::{Event, EventSink};
use crate::measure::queue::InstrumentStatus;
use crate::measure::queue::MeasurementJob;
use crate::measure::queue::MockControl;
use crate::measure::recorder::{self as recorder, Outcome, Recorder};
use crate::measure::simulated_truth::SimulatedTruth;
use lightbooth_instrument::sim::{spawn_mock, Fault, MockConfig, MockHandle};
use lightbooth_instrument::{InstrumentSettings, Sample, Spectroradiometer};
use lightbooth_science::colorimetry::xyz_from_radiance;
use lightbooth_store::{Booth, MeasurementState, NewSample, Store};
use tokio_util::sync::CancellationToken;

/// Settings of the simulated PR-650.
#[derive(Clone, Debug)]
pub struct MockSettings {
    /// Which instrument is simulated: the model the settings file names.
    pub personality: lightbooth_instrument::sim::Personality,
    pub speed: f64,
    pub faults: Vec<Fault>,
    pub cache_dir: PathBuf,
}

pub struct TaskConfig {
    pub store: Store,
    pub jobs: mpsc::Receiver<MeasurementJob>,
    pub status: watch::Sender<InstrumentStatus>,
    pub events: EventSink,
    /// Where each complete measurement of a scene target is compared.
    pub comparisons: Arc<Comparisons>,
    /// What the simulated instrument measures (with `mock`).
    pub truth: Arc<SimulatedTruth>,
    /// The observer of every XYZ computed from a spectrum.
    pub observer: lightbooth_science::colorimetry::Observer,
    pub settings: InstrumentSettings,
    /// The booth this instrument measures in; recorded with it.
    pub booth: Booth,
    pub mock: Option<MockSettings>,
    pub runtime: Handle,
    /// The daemon's shutdown: cancelling it stops the running measurement
    /// (`interrupted`) and ends the task once the job queue closes.
    pub shutdown: CancellationToken,
}

/// The simulated PR-650, shared between the instrument thread (which re-aims
/// and, after a pulled cable, replaces it) and the API (which injects faults).
/// The mutex is held only for those short calls, never during a measurement.
pub struct MockSlot {
    handle: Mutex<Option<MockHandle>>,
    settings: MockSettings,
    /// What the calibration page shows on the simulated display, kept so a
    /// replugged simulator still sees it.
    shown: Mutex<Option<lightbooth_science::spectrum::Spectrum>>,
}

impl MockSlot {
    fn with<R>(&self, f: impl FnOnce(&MockHandle) -> R) -> Option<R> {
        self.handle.lock().unwrap_or_else(|p| p.into_inner()).as_ref().map(f)
    }

    /// Powers a (new) simulated PR-650 on; returns its device path.
    fn power_on(&self) -> std::io::Result<String> {
        let shown = self.shown.lock().unwrap_or_else(|p| p.into_inner()).clone();
        let truth = shown.unwrap_or_else(default_truth);
        let mut config = MockConfig::for_personality(truth, self.settings.personality.clone());
        config.speed = self.settings.speed;
        config.faults = self.settings.faults.clone();
        // The daemon talks to it at once, so the 5 s remote window is kept as the real one is.
        let handle = spawn_mock(config)?;
        let path = handle.device_path().display().to_string();
        *self.handle.lock().unwrap_or_else(|p| p.into_inner()) = Some(handle);
        Ok(path)
    }

    fn unplugged(&self) -> bool {
        self.with(|h| h.is_unplugged()).unwrap_or(true)
    }
}

impl MockControl for MockSlot {
    fn set_faults(&self, spec: &str) -> Result<(), String> {
        let faults = spec
            .split(',')
            .map(str::trim)
            .filter(|s| !s.is_empty())
            .map(str::parse::<Fault>)
            .collect::<Result<Vec<_>, _>>()?;
        tracing::warn!(faults = spec, "faults injected into the simulated PR-650");
        self.with(|h| h.set_faults(faults))
            .ok_or_else(|| "the simulated PR-650 is not running".to_string())
    }

    fn show_on_display(&self, drive: [f64; 3]) -> Result<(), String> {
        if let Some(c) = drive.iter().position(|v| !(0.0..=1.0).contains(v)) {
            return Err(format!(
                "{} drive {} is outside 0–1",
                ["red", "green", "blue"][c],
                drive[c]
            ));
        }
        let display = lightbooth_science::display::SimulatedDisplay::crt().map_err(|e| e.to_string())?;
        self.aim_at_display(display.spectrum(drive), &format!("drive {drive:?}"))
    }

    fn show_codes_on_display(&self, codes: &lightbooth_science::display::CodeCounts) -> Result<(), String> {
        let display = lightbooth_science::display::SimulatedDisplay::crt().map_err(|e| e.to_string())?;
        let truth = display.mean_spectrum(codes)?;
        self.aim_at_display(truth, "a patch of counted codes")
    }
}

impl MockSlot {
    /// Aims the simulated instrument at the simulated display showing `truth`.
    fn aim_at_display(&self, truth: lightbooth_science::spectrum::Spectrum, what: &str) -> Result<(), String> {
        *self.shown.lock().unwrap_or_else(|p| p.into_inner()) = Some(truth.clone());
        match self.with(|h| h.set_truth(truth)) {
            Some(Err(e)) => Err(format!("cannot aim the simulated instrument: {e}")),
            // Not running (cable pulled): it sees the colour once powered on.
            _ => {
                tracing::info!(shown = what, "simulated display shows a colour");
                Ok(())
            }
        }
    }
}

/// What the simulated PR-650 sees before any scene is named: a flat
/// 0.01 W/(sr·m²·nm), about 73 cd/m² (a bright grey card).
fn default_truth() -> lightbooth_science::spectrum::Spectrum {
    lightbooth_science::spectrum::Spectrum::constant(
        lightbooth_science::spectrum::Grid::one_nm(),
        lightbooth_science::spectrum::SpectralUnit::SpectralRadiance,
        0.01,
    )
    .expect("a flat spectrum is valid")
}

/// Cancels the running measurement when the operator cancels it (`POST
/// /api/measurements/{id}/cancel`) or the daemon shuts down: each
/// measurement's token is a child of the daemon's shutdown token.
#[derive(Clone)]
pub struct Canceller {
    /// The measurement the instrument has taken, with its token.
    current: Arc<Mutex<Option<(i64, CancellationToken)>>>,
    shutdown: CancellationToken,
}

impl Canceller {
    /// A token for the next measurement: cancelled alone, or with the daemon.
    fn next_measurement(&self) -> CancellationToken {
        self.shutdown.child_token()
    }

    fn set_current(&self, current: Option<(i64, CancellationToken)>) {
        *self.current.lock().unwrap_or_else(|p| p.into_inner()) = current;
    }

    fn is_shutting_down(&self) -> bool {
        self.shutdown.is_cancelled()
    }
}

impl crate::measure::queue::CancelMeasurement for Canceller {
    fn cancel(&self, id: i64) -> bool {
        match self.current.lock().unwrap_or_else(|p| p.into_inner()).as_ref() {
            Some((running, t)) if *running == id => {
                t.cancel();
                true
            }
            _ => false,
        }
    }
}

/// The running instrument thread.
pub struct InstrumentTask {
    thread: std::thread::JoinHandle<()>,
    canceller: Canceller,
    mock: Option<Arc<MockSlot>>,
}

impl InstrumentTask {
    pub fn canceller(&self) -> Canceller {
        self.canceller.clone()
    }

    pub fn mock_control(&self) -> Option<Arc<dyn MockControl>> {
        self.mock.clone().map(|m| m as Arc<dyn MockControl>)
    }

    /// Waits (without blocking the runtime) for the thread to finish.
    pub async fn join(self) {
        let _ = tokio::task::spawn_blocking(move || self.thread.join()).await;
    }
}

pub fn spawn(config: TaskConfig) -> std::io::Result<InstrumentTask> {
    let canceller = Canceller {
        current: Arc::default(),
        shutdown: config.shutdown.clone(),
    };
    let mock = config.mock.clone().map(|settings| {
        Arc::new(MockSlot {
            handle: Mutex::new(None),
            settings,
            shown: Mutex::new(None),
        })
    });
    let worker = Worker {
        config,
        canceller: canceller.clone(),
        mock: mock.clone(),
        current: None,
        seconds_per_sample: None,
    };
    let thread = std::thread::Builder::new()
        .name("instrument".into())
        .spawn(move || supervise(worker))?;
    Ok(InstrumentTask {
        thread,
        canceller,
        mock,
    })
}

struct Worker {
    config: TaskConfig,
    canceller: Canceller,
    mock: Option<Arc<MockSlot>>,
    /// The measurement being taken (to fail it if the task panics).
    current: Option<i64>,
    /// Seconds per sample of the last measurement that took one: the
    /// estimate of the next measurement's time before its first sample.
    seconds_per_sample: Option<f64>,
}

/// Runs the worker, restarting it after a panic (see the module doc). The
/// job queue lives in the worker, so queued measurements survive a restart;
/// the thread ends only at shutdown.
fn supervise(mut worker: Worker) {
    let mut backoff = Duration::from_secs(1);
    loop {
        let started = Instant::now();
        let Err(panic) = catch_unwind(AssertUnwindSafe(|| worker.run())) else {
            return;
        };
        let message = crate::jobs::panic_message(&*panic);
        tracing::error!(panic = %message, restart_in_s = backoff.as_secs(), "the instrument task panicked");
        worker.canceller.set_current(None);
        if let Some(id) = worker.current.take() {
            worker.finish_failed(
                id,
                MeasurementState::Failed,
                &format!("the instrument task panicked during this measurement: {message}"),
            );
        }
        if started.elapsed() > Duration::from_secs(60) {
            backoff = Duration::from_secs(1);
        }
        worker.set_status(InstrumentStatus::Error {
            message: format!(
                "the instrument task panicked ({message}); restarting it in {} s",
                backoff.as_secs()
            ),
        });
        if worker.wait_or_shutdown(backoff) {
            return;
        }
        backoff = (backoff * 2).min(Duration::from_secs(30));
    }
}

/// What ended the use of an open instrument.
enum Disconnect {
    /// The job queue closed: the daemon is shutting down.
    Shutdown,
    /// The port was lost; reopen it.
    Lost(String),
}

impl Worker {
    fn set_status(&self, status: InstrumentStatus) {
        tracing::info!(?status, "instrument state");
        self.config.status.send_replace(status.clone());
        self.config.events.send(Event::InstrumentStatus { status });
    }

    fn block_on<F: std::future::Future>(&self, f: F) -> F::Output {
        self.config.runtime.block_on(f)
    }

    fn run(&mut self) {
        let mut backoff = Duration::from_secs(1);
        loop {
            if self.canceller.is_shutting_down() {
                return;
            }
            match self.connect() {
                Ok((instrument, port)) => {
                    backoff = Duration::from_secs(1);
                    match self.serve_jobs(instrument, &port) {
                        Disconnect::Shutdown => return,
                        Disconnect::Lost(reason) => {
                            self.set_status(InstrumentStatus::Disconnected {
                                reason: format!("{reason}; reopening the port"),
                            });
                        }
                    }
                }
                Err(reason) => {
                    tracing::warn!(error = %reason, retry_in_s = backoff.as_secs(), "cannot open the instrument");
                    self.set_status(InstrumentStatus::Disconnected {
                        reason: format!("{reason} (retrying in {} s)", backoff.as_secs()),
                    });
                    if self.wait_or_shutdown(backoff) {
                        return;
                    }
                    backoff = (backoff * 2).min(Duration::from_secs(30));
                }
            }
        }
    }

    /// Sleeps `d` unless the daemon shuts down first (returns true then).
    fn wait_or_shutdown(&mut self, d: Duration) -> bool {
        let deadline = std::time::Instant::now() + d;
        while std::time::Instant::now() < deadline {
            if self.canceller.is_shutting_down() || self.config.jobs.is_closed() {
                return true;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        false
    }

    fn connect(&mut self) -> Result<(Box<dyn Spectroradiometer>, String), String> {
        let port = match &self.mock {
            Some(mock) => {
                if mock.unplugged() {
                    if mock.with(|_| ()).is_some() {
                        tracing::warn!("the simulated PR-650's cable was pulled: plugging in a new one");
                    }
                    mock.power_on()
                        .map_err(|e| format!("cannot start the simulated PR-650: {e}"))?
                } else {
                    mock.with(|h| h.device_path().display().to_string()).unwrap_or_default()
                }
            }
            None => self.config.settings.port().map(str::to_string).ok_or_else(|| {
                "no serial port configured: set `port` in instruments/pr650.toml or use --mock".to_string()
            })?,
        };
        tracing::info!(port, "opening the instrument");
        let instrument = self.config.settings.open(&port).map_err(|e| e.to_string())?;
        let info = instrument.info().clone();
        let id = self
            .block_on(self.config.store.upsert_instrument(
                &self.config.booth,
                &info.model,
                info.serial.as_deref(),
                &port,
            ))
            .map_err(|e| format!("cannot record the instrument: {e}"))?;
        tracing::info!(instrument_id = id, model = %info.model, serial = ?info.serial, port, "instrument ready");
        self.set_status(InstrumentStatus::Idle {
            model: info.model.clone(),
            serial: info.serial.clone(),
            measures: instrument.capabilities().reading.name().into(),
            port: port.clone(),
        });
        Ok((instrument, port))
    }

    fn serve_jobs(&mut self, mut instrument: Box<dyn Spectroradiometer>, port: &str) -> Disconnect {
        let info = instrument.info().clone();
        let measures = instrument.capabilities().reading.name().to_string();
        let instrument_id = self
            .block_on(self.config.store.upsert_instrument(
                &self.config.booth,
                &info.model,
                info.serial.as_deref(),
                port,
            ))
            .ok();
        loop {
            let Some(job) = self.config.jobs.blocking_recv() else {
                return Disconnect::Shutdown;
            };
            let outcome = self.measure(instrument.as_mut(), instrument_id, &job);
            self.canceller.set_current(None);
            if let Some(reason) = outcome {
                return Disconnect::Lost(reason);
            }
            if self.canceller.is_shutting_down() {
                return Disconnect::Shutdown;
            }
            self.set_status(InstrumentStatus::Idle {
                model: info.model.clone(),
                serial: info.serial.clone(),
                measures: measures.clone(),
                port: port.into(),
            });
        }
    }

    /// Takes one measurement. Returns `Some(reason)` when the port was lost.
    fn measure(
        &mut self,
        instrument: &mut dyn Spectroradiometer,
        instrument_id: Option<i64>,
        job: &MeasurementJob,
    ) -> Option<String> {
        let id = job.id;
        let span = tracing::info_span!("measurement", measurement_id = id);
        let _enter = span.enter();
        let store = self.config.store.clone();
        // Registered before the store says `running`, so a cancel request that
        // finds the measurement no longer queued always finds its token.
        let cancel = self.canceller.next_measurement();
        self.canceller.set_current(Some((id, cancel.clone())));
        let recorder = match Recorder::start(&store, &self.config.runtime, id, instrument_id, &self.config.shutdown) {
            Ok(recorder) => recorder,
            Err(e) => {
                tracing::warn!(error = %e, "measurement no longer queued; skipped");
                return None;
            }
        };
        self.current = Some(id);
        let outcome = self.take_running(instrument, recorder, job, cancel);
        self.current = None;
        outcome
    }

    /// Takes a measurement already marked running (see [`Worker::measure`]).
    fn take_running(
        &mut self,
        instrument: &mut dyn Spectroradiometer,
        recorder: Recorder,
        job: &MeasurementJob,
        cancel: CancellationToken,
    ) -> Option<String> {
        let id = recorder.id();
        self.config.events.send(Event::MeasurementStarted {
            measurement_id: id,
            samples: job.samples,
        });
        let started = Instant::now();
        let started_at = lightbooth_store::now();
        let measuring = |sample: usize, seconds_per_sample: Option<f64>| InstrumentStatus::Measuring {
            measurement_id: id,
            sample,
            of: job.samples,
            scene: job.scene.clone(),
            target: job.target.clone(),
            started_at,
            expected_finish_at: seconds_per_sample.map(|pace| started_at + pace * job.samples as f64),
        };
        self.set_status(measuring(0, self.seconds_per_sample));

        // Re-aim the simulated instrument at the scene target.
        if let Err(why) = self.aim_simulator(job) {
            let outcome = recorder.fail(why, &self.config.shutdown);
            return self.published(id, job, outcome);
        }

        let events = self.config.events.clone();
        let status = self.config.status.clone();
        let of = job.samples;
        let observer = self.config.observer;
        let mut measured_pace = None;
        let mut on_sample = |s: &Sample, row: &NewSample| {
            let done = (s.index + 1).min(of);
            let pace = started.elapsed().as_secs_f64() / done.max(1) as f64;
            measured_pace = Some(pace);
            let st = measuring(done, Some(pace));
            status.send_replace(st.clone());
            events.send(Event::InstrumentStatus { status: st });
            events.send(Event::Sample {
                measurement_id: id,
                index: s.index,
                of,
                code: row.code,
                message: row.message.clone(),
                usable: row.usable,
                // A colorimeter's Y is its own, in its reading's observer.
                luminance_cd_m2: match &s.radiance {
                    Some(r) => xyz_from_radiance(r, observer).ok().map(|xyz| xyz.y),
                    None => s.instrument_xyz.map(|v| v[1]).or(s.luminance),
                },
                instrument_luminance_cd_m2: row.luminance_cd_m2,
                wavelength_nm: s
                    .radiance
                    .as_ref()
                    .map(|r| r.grid().wavelengths().to_vec())
                    .unwrap_or_default(),
                radiance: row.radiance.clone(),
            });
        };
        // The comparison uses the daemon's observer on both sides; the
        // stored instrument_x, instrument_y are the instrument's own (CIE
        // 1931, as the PR-650 reports), never compared or charted.
        let outcome = recorder.take(
            instrument,
            job.samples,
            observer,
            &cancel,
            &self.config.shutdown,
            &mut on_sample,
        );
        if measured_pace.is_some() {
            self.seconds_per_sample = measured_pace;
        }
        self.published(id, job, outcome)
    }

    /// Aims the simulated instrument (with `--mock`) at the job's scene
    /// target, as an operator re-aims the real one; why it could not.
    fn aim_simulator(&self, job: &MeasurementJob) -> Result<(), String> {
        let (Some(mock), Some(scene), Some(target)) = (&self.mock, &job.scene, &job.target) else {
            return Ok(());
        };
        let truth = self
            .config
            .truth
            .truth(scene, target, &mock.settings.cache_dir)
            .map_err(|e| format!("cannot render {scene}/{target}: {e}"))?;
        // The truth is a render, an estimate too: its standard error goes
        // with the measurement into every comparison's error budget.
        self.block_on(self.config.store.record_simulated_truth(job.id, truth.relative_se_y))
            .map_err(|e| format!("cannot record the simulated truth's standard error: {e}"))?;
        if let Some(Err(e)) = mock.with(|h| h.set_truth(truth.spectrum)) {
            return Err(format!(
                "cannot aim the simulated {}: {e}",
                self.config.settings.capabilities().model
            ));
        }
        tracing::info!(scene, target, "simulated instrument aimed at the scene target");
        Ok(())
    }

    /// Publishes how measurement `id` ended and, when complete, hands it to
    /// the comparisons. Returns the lost port's reason, if the port was lost.
    fn published(&self, id: i64, job: &MeasurementJob, outcome: Outcome) -> Option<String> {
        let (state, error, port_lost) = match outcome {
            Outcome::Complete { comparable, .. } => {
                if let (Some(scene), Some(target)) = (&job.scene, &job.target) {
                    match comparable {
                        // In its own observer: a colour, or a luminance meter's
                        // luminance alone.
                        Ok(measured) => self.config.comparisons.compare_measurement_later(
                            id,
                            scene.clone(),
                            target.clone(),
                            measured,
                        ),
                        Err(e) => tracing::warn!(measurement_id = id, error = %e, "measurement not compared"),
                    }
                }
                (MeasurementState::Complete, None, None)
            }
            Outcome::Ended {
                state,
                message,
                port_lost,
            } => (state, Some(message), port_lost),
        };
        self.config.events.send(Event::MeasurementFinished {
            measurement_id: id,
            state,
            error,
        });
        port_lost
    }

    /// Ends measurement `id` `state` with `message`, writing it again while
    /// the database is away ([`recorder::end_measurement`]) unless the
    /// daemon shuts down meanwhile.
    fn finish_failed(&self, id: i64, state: MeasurementState, message: &str) -> Option<String> {
        if let Err(e) = recorder::end_measurement(
            &self.config.store,
            &self.config.runtime,
            id,
            state,
            message,
            &self.config.shutdown,
        ) {
            tracing::error!(error = %e, measurement_id = id, "cannot record the end of a measurement");
        }
        self.config.events.send(Event::MeasurementFinished {
            measurement_id: id,
            state,
            error: Some(message.to_string()),
        });
        None
    }
}
