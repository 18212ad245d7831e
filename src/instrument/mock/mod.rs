//! A simulated PR-650 on a real pseudo-terminal, for tests, for the daemon's
//! `serve --mock`, and for `lightbooth mock-pr650`.
//!
//! [`spawn_mock`] opens a pty pair, runs the simulated instrument on the
//! master end on its own thread, and hands back the path of the device end,
//! which any serial client (lightbooth, PTB, PsychoPy) opens like a real port.
//! The simulator follows the checklist of `docs/src/instruments/pr650-protocol.md` §7:
//! power-on window and local mode, CR/LF/CR LF framing, case-insensitive
//! commands, `B`/`S`/`M`/`D`/`F`/`E`, the fixed-width reports 1/2/5 (with a
//! bare-CR header switch), stale buffers on low light, realistic timing scaled
//! by [`MockConfig::speed`], and injected faults ([`Fault`]).
//!
//! What it "sees" is a spectral radiance ([`MockHandle::set_truth`]); what it
//! reports goes through the [`model::InstrumentModel`] (slit, noise, limits).
//!
//! The same pty, truth, noise model and faults also run a simulated PR-655
//! or PR-670 ([`Personality::Pr655`]): its remote protocol with every
//! behaviour that `docs/src/instruments/pr655-670-protocol.md` §13 says a simulator
//! should let one switch ([`Pr655Switches`]).

pub use pr655_device::{AfterFailure, Pr655Switches, StrayTerminator, SyncFailure};

mod device;
mod firmware;
pub mod model;
mod pr655_device;

use std::path::{Path, PathBuf};
use std::str::FromStr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;

use serialport::SerialPort as _;

use crate::spectrum::{Grid, Spectrum, SpectrumError};
use model::{InstrumentModel, Reading};

/// The kinds of injectable faults (`--fault KIND[:RATE]`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FaultKind {
    /// A `D5` gets no reply at all.
    NoAnswer,
    /// A `D5` reply stops after about half the spectrum.
    Truncate,
    /// A `D5` reply has some characters replaced by line noise.
    Garble,
    /// Junk (a stale partial report) lands in the host's input buffer after
    /// the `D2` reply, before the next command: tests the flush.
    Stale,
    /// A measurement ends with [`MockConfig::error_code`] (default 18, whose
    /// spectral buffer stays stale) instead of its real code.
    ErrorCode,
    /// The port closes during a measurement: the cable pulled. The simulator stops.
    CablePull,
    /// A `D5` reply's first byte comes late: after the fault's own delay
    /// (`slow@2500ms`), else after [`MockConfig::slow_ms`].
    Slow,
    /// A `D5` reply carries an extra, empty CR LF after its header (harmless
    /// to a correct parser).
    DoubleCrlf,
    /// A `D5` reply stops after about half the spectrum and the unit then
    /// answers nothing until power-cycled: a cable cut behind a USB adapter
    /// (the port stays open, the line goes quiet, nothing signals a hang-up).
    LinkDies,
}

/// How often a fault fires at each point where it applies.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FaultRate {
    Always,
    /// Independently each time, with this probability (seeded).
    Probability(f64),
    /// The next N times, then never.
    Times(u32),
}

/// One injected fault: `KIND`, `KIND:0.25` (probability), `KIND:once`,
/// `KIND:3x`; a `slow` fault may carry its delay, `slow@2500ms:once`
/// (also `slow@2.5s`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fault {
    pub kind: FaultKind,
    pub rate: FaultRate,
    /// The delay of a [`FaultKind::Slow`] reply, ms; `None` uses [`MockConfig::slow_ms`].
    pub delay_ms: Option<u64>,
}

impl Fault {
    pub fn always(kind: FaultKind) -> Fault {
        Fault {
            kind,
            rate: FaultRate::Always,
            delay_ms: None,
        }
    }

    pub fn times(kind: FaultKind, n: u32) -> Fault {
        Fault {
            kind,
            rate: FaultRate::Times(n),
            delay_ms: None,
        }
    }

    /// A [`FaultKind::Slow`] fault whose replies come `delay_ms` late.
    pub fn slow(delay_ms: u64, rate: FaultRate) -> Fault {
        Fault {
            kind: FaultKind::Slow,
            rate,
            delay_ms: Some(delay_ms),
        }
    }
}

/// The fault kinds and the rate syntax, for error messages and `--help`.
pub const FAULT_SYNTAX: &str = "KIND[:RATE] with KIND one of no-answer, truncate, garble, stale, error-code, \
     cable-pull, slow, double-crlf, link-dies, and RATE a probability 0–1, `once` or `Nx`; `slow` takes its delay \
     as slow@MS ms or slow@S s, e.g. slow@2500ms:once";

/// The longest `slow` delay accepted: ten minutes, far past any timeout.
const MAX_SLOW_MS: u64 = 600_000;

/// `2500ms`, `2.5s`: a delay with its unit.
fn parse_delay(s: &str) -> Result<u64, String> {
    let bad = || format!("delay `{s}`: write it with its unit, e.g. 2500ms or 2.5s");
    let ms = if let Some(v) = s.strip_suffix("ms") {
        v.trim().parse::<u64>().map_err(|_| bad())?
    } else if let Some(v) = s.strip_suffix('s') {
        let secs: f64 = v.trim().parse().map_err(|_| bad())?;
        if !(secs.is_finite() && secs >= 0.0) {
            return Err(bad());
        }
        (secs * 1000.0).round().min(u64::MAX as f64) as u64
    } else {
        return Err(bad());
    };
    if ms > MAX_SLOW_MS {
        return Err(format!("delay `{s}` is over the limit of {} s", MAX_SLOW_MS / 1000));
    }
    Ok(ms)
}

impl FromStr for FaultKind {
    type Err = String;
    fn from_str(s: &str) -> Result<FaultKind, String> {
        Ok(match s {
            "no-answer" => FaultKind::NoAnswer,
            "truncate" => FaultKind::Truncate,
            "garble" => FaultKind::Garble,
            "stale" => FaultKind::Stale,
            "error-code" => FaultKind::ErrorCode,
            "cable-pull" => FaultKind::CablePull,
            "slow" => FaultKind::Slow,
            "double-crlf" => FaultKind::DoubleCrlf,
            "link-dies" => FaultKind::LinkDies,
            _ => {
                return Err(format!(
                    "unknown fault `{s}`: use no-answer, truncate, garble, stale, error-code, cable-pull, slow, \
                     double-crlf or link-dies"
                ))
            }
        })
    }
}

impl FromStr for Fault {
    type Err = String;
    fn from_str(s: &str) -> Result<Fault, String> {
        let (kind, rate) = match s.split_once(':') {
            Some((k, r)) => (k, Some(r)),
            None => (s, None),
        };
        let (kind, delay) = match kind.split_once('@') {
            Some((k, d)) => (k, Some(d)),
            None => (kind, None),
        };
        let kind: FaultKind = kind.parse()?;
        let delay_ms = match delay {
            None => None,
            Some(d) if kind == FaultKind::Slow => Some(parse_delay(d)?),
            Some(_) => return Err(format!("only `slow` takes a delay (`@…`), not `{s}`")),
        };
        let rate = match rate {
            None => FaultRate::Always,
            Some("once") => FaultRate::Times(1),
            Some(r) if r.ends_with('x') => FaultRate::Times(
                r[..r.len() - 1]
                    .parse()
                    .map_err(|_| format!("fault rate `{r}`: write e.g. 3x for the next three times"))?,
            ),
            Some(r) => {
                let p: f64 = r
                    .parse()
                    .map_err(|_| format!("fault rate `{r}`: a probability 0–1, `once` or `Nx`"))?;
                if !(0.0..=1.0).contains(&p) {
                    return Err(format!("fault rate {p} is not a probability in 0–1"));
                }
                FaultRate::Probability(p)
            }
        };
        Ok(Fault { kind, rate, delay_ms })
    }
}

/// What `D5` answers before the first measurement ever (undocumented, §7.7).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BeforeFirstMeasurement {
    /// A report of zeros with code 00.
    StaleZeros,
    /// Nothing.
    NoReply,
}

/// What happens to bytes that arrive while measuring (undocumented, §7.5).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BusyInput {
    /// Processed after the measurement.
    Queue,
    /// Discarded.
    Drop,
}

/// Which instrument the simulator is.
#[derive(Clone, Debug, PartialEq)]
pub enum Personality {
    /// The PR-650 (`docs/src/instruments/pr650-protocol.md`).
    Pr650,
    /// A PR-655 or PR-670, with the protocol's uncertain behaviours chosen.
    Pr655(Pr655Switches),
}

impl Personality {
    /// The model's name as the unit reports it: `PR-650`, `PR-655` or `PR-670`.
    pub fn model_name(&self) -> &'static str {
        match self {
            Personality::Pr650 => "PR-650",
            Personality::Pr655(switches) => switches.model.name(),
        }
    }
}

/// Everything about a simulated instrument (a PR-650 unless [`MockConfig::personality`] says otherwise).
#[derive(Clone, Debug)]
pub struct MockConfig {
    pub personality: Personality,
    /// The radiance it is aimed at, W/(sr·m²·nm), any grid covering 380–780 nm.
    pub truth: Spectrum,
    /// Time scale: 1.0 = the real instrument's measurement and wire times, 0 = instant.
    pub speed: f64,
    /// Seed of the noise and fault-rate generator.
    pub seed: u64,
    /// The remote-mode window after power-on; `None` = never closes.
    pub remote_window_ms: Option<u64>,
    pub faults: Vec<Fault>,
    /// Delay of a [`FaultKind::Slow`] reply that names none, ms (not scaled by speed).
    pub slow_ms: u64,
    /// Code of a [`FaultKind::ErrorCode`] measurement.
    pub error_code: u8,
    /// What `D110` answers (8 characters).
    pub serial: String,
    /// End header line 1 of the spectral report in a bare CR.
    pub header_bare_cr: bool,
    /// Pace replies at 9600 baud (scaled by speed).
    pub pace_output: bool,
    pub before_first: BeforeFirstMeasurement,
    pub busy_input: BusyInput,
    /// The source's flicker frequency for `F`; `None` = steady (`F` answers 20).
    pub flicker_hz: Option<f64>,
    /// With sync on, every measurement fails with 07 (tests the sync-off path).
    pub unsyncable: bool,
    pub model: InstrumentModel,
}

impl MockConfig {
    /// Defaults: real speed, a 5 s remote window, no faults, stale zeros
    /// before the first measurement, queued input while busy, and `slow`
    /// replies 12 s late (past the driver's default timeouts).
    pub fn new(truth: Spectrum) -> MockConfig {
        MockConfig {
            personality: Personality::Pr650,
            truth,
            speed: 1.0,
            seed: 1,
            remote_window_ms: Some(5000),
            faults: Vec::new(),
            slow_ms: 12_000,
            error_code: 18,
            serial: "60954303".into(),
            header_bare_cr: false,
            pace_output: true,
            before_first: BeforeFirstMeasurement::StaleZeros,
            busy_input: BusyInput::Queue,
            flicker_hz: None,
            unsyncable: false,
            model: InstrumentModel::default(),
        }
    }

    /// A simulated PR-655 or PR-670 with the default switches: the model's
    /// grid and slit, and its statuses.
    pub fn pr655(truth: Spectrum, switches: Pr655Switches) -> MockConfig {
        let model = InstrumentModel::for_pr655(switches.model);
        MockConfig {
            personality: Personality::Pr655(switches),
            model,
            serial: "67065106".into(),
            ..MockConfig::new(truth)
        }
    }
}

/// State shared between a [`MockHandle`] and its simulator thread, behind one
/// `Mutex`: the thread takes it briefly at each command, never while sleeping.
#[derive(Debug)]
struct Shared {
    truth_1nm: Spectrum,
    faults: Vec<Fault>,
    power_cycle_requested: bool,
    measurements: u64,
    unplugged: bool,
    /// Set by a [`FaultKind::LinkDies`] fault: the unit answers nothing until power-cycled.
    link_dead: bool,
    /// When the last byte of a reply went out.
    last_byte_at: Option<std::time::Instant>,
    integration_ms: u32,
    /// The simulated PR-655/PR-670's last measurement time at speed 1, ms.
    last_measurement_ms: Option<f64>,
}

/// A running simulated PR-650, PR-655 or PR-670. Dropping it stops the simulator and closes the pty.
pub struct MockHandle {
    /// The simulated model's name (`PR-650`, `PR-655`, `PR-670`), for the log.
    name: &'static str,
    device_path: PathBuf,
    shared: Arc<Mutex<Shared>>,
    /// Set to stop the simulator thread; it polls between reads.
    stop: Arc<AtomicBool>,
    model: InstrumentModel,
    thread: Option<JoinHandle<()>>,
}

fn lock(shared: &Mutex<Shared>) -> MutexGuard<'_, Shared> {
    // A panic in the simulator thread must not take the handle down with it.
    shared.lock().unwrap_or_else(|p| p.into_inner())
}

fn to_1nm(radiance: &Spectrum) -> Result<Spectrum, SpectrumError> {
    radiance.to_per_nm().resample(&Grid::one_nm())
}

/// Opens a pty pair and runs the simulated instrument `config` describes on it.
pub fn spawn_mock(config: MockConfig) -> std::io::Result<MockHandle> {
    let truth_1nm = to_1nm(&config.truth).map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidInput, e))?;
    let (master, slave) = serialport::TTYPort::pair().map_err(std::io::Error::from)?;
    let device_path = PathBuf::from(
        slave
            .name()
            .ok_or_else(|| std::io::Error::other("the pty has no device name"))?,
    );
    let shared = Arc::new(Mutex::new(Shared {
        truth_1nm,
        faults: config.faults.clone(),
        power_cycle_requested: false,
        measurements: 0,
        unplugged: false,
        link_dead: false,
        last_byte_at: None,
        integration_ms: 0,
        last_measurement_ms: None,
    }));
    let stop = Arc::new(AtomicBool::new(false));
    let model = config.model.clone();
    let name = config.personality.model_name();
    let thread = {
        let shared = Arc::clone(&shared);
        let stop = Arc::clone(&stop);
        match config.personality.clone() {
            Personality::Pr650 => std::thread::Builder::new()
                .name("mock-pr650".into())
                .spawn(move || device::Device::new(config, master, slave, shared, stop).run())?,
            Personality::Pr655(switches) => std::thread::Builder::new()
                .name("mock-pr655".into())
                .spawn(move || pr655_device::Device::new(config, switches, master, slave, shared, stop).run())?,
        }
    };
    tracing::info!(device = %device_path.display(), "simulated {name} powered on");
    Ok(MockHandle {
        name,
        device_path,
        shared,
        stop,
        model,
        thread: Some(thread),
    })
}

impl MockHandle {
    /// The device end: give this path to the driver.
    pub fn device_path(&self) -> &Path {
        &self.device_path
    }

    /// Re-aims the instrument at another target: a spectral radiance on any
    /// grid covering 380–780 nm (resampled to 1 nm internally).
    pub fn set_truth(&self, radiance: Spectrum) -> Result<(), SpectrumError> {
        let one_nm = to_1nm(&radiance)?;
        lock(&self.shared).truth_1nm = one_nm;
        tracing::info!("simulated {} re-aimed", self.name);
        Ok(())
    }

    /// Replaces the injected faults.
    pub fn set_faults(&self, faults: Vec<Fault>) {
        lock(&self.shared).faults = faults;
    }

    /// Switches the simulated unit off and on: local state is lost and the
    /// remote-mode window opens again.
    pub fn power_cycle(&self) {
        lock(&self.shared).power_cycle_requested = true;
    }

    /// Measurements taken so far.
    pub fn measurements(&self) -> u64 {
        lock(&self.shared).measurements
    }

    /// How long the simulated PR-655/PR-670's last measurement took at speed
    /// 1, ms: base time, sync detection, exposures and dark exposures (the
    /// protocol sheet's 13.7), whatever [`MockConfig::speed`] made of it in
    /// wall time. `None` before the first measurement, and on the PR-650.
    pub fn last_measurement_ms(&self) -> Option<f64> {
        lock(&self.shared).last_measurement_ms
    }

    /// True once a cable-pull fault has closed the port.
    pub fn is_unplugged(&self) -> bool {
        lock(&self.shared).unplugged
    }

    /// True once a link-dies fault has silenced the unit (until a power cycle).
    pub fn is_link_dead(&self) -> bool {
        lock(&self.shared).link_dead
    }

    /// When the simulator last wrote a byte to the host (`None` before any reply).
    pub fn last_byte_at(&self) -> Option<std::time::Instant> {
        lock(&self.shared).last_byte_at
    }

    /// What the model predicts for the current target and setup: the
    /// noise-free reading, its per-sample σ, the code and the time. This is
    /// the independent truth tests compare measurements with.
    pub fn expected_reading(&self) -> Result<Reading, SpectrumError> {
        let (truth, itime) = {
            let s = lock(&self.shared);
            (s.truth_1nm.clone(), s.integration_ms)
        };
        self.model.reading(&truth, itime)
    }

    /// Stops the simulator and closes the pty.
    pub fn shutdown(mut self) {
        self.stop_thread();
    }

    fn stop_thread(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for MockHandle {
    fn drop(&mut self) {
        self.stop_thread();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fault_specs_parse() {
        assert_eq!("garble".parse::<Fault>().unwrap(), Fault::always(FaultKind::Garble));
        assert_eq!(
            "truncate:once".parse::<Fault>().unwrap(),
            Fault::times(FaultKind::Truncate, 1)
        );
        assert_eq!("slow:3x".parse::<Fault>().unwrap(), Fault::times(FaultKind::Slow, 3));
        assert_eq!(
            "slow@2500ms:once".parse::<Fault>().unwrap(),
            Fault::slow(2500, FaultRate::Times(1))
        );
        assert_eq!(
            "slow@1.5s".parse::<Fault>().unwrap(),
            Fault::slow(1500, FaultRate::Always)
        );
        assert!("slow@2500".parse::<Fault>().unwrap_err().contains("2500ms"));
        assert!("slow@1e9s".parse::<Fault>().unwrap_err().contains("limit"));
        assert!("garble@10ms".parse::<Fault>().unwrap_err().contains("only `slow`"));
        assert_eq!(
            "link-dies:once".parse::<Fault>().unwrap(),
            Fault::times(FaultKind::LinkDies, 1)
        );
        assert_eq!(
            "no-answer:0.25".parse::<Fault>().unwrap().rate,
            FaultRate::Probability(0.25)
        );
        assert!("garble:2".parse::<Fault>().is_err());
        assert!("smoke".parse::<Fault>().unwrap_err().contains("no-answer"));
    }
}
