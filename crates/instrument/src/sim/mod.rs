//! The simulated instruments: a PR-650, PR-655, PR-670, a Konica Minolta
//! CS-2000/CS-2000A/CS-3000 or a Colorimetry Research CR-250/CR-300 on a real
//! pseudo-terminal, for tests, for the daemon's `serve --mock`, and for
//! `lightbooth mock-pr650` (`mock-pr655`, `mock-pr670`, `mock-cs2000`,
//! `mock-cr250`); and the colorimeters, a ColorCAL MkII (`colorcal`,
//! `lightbooth mock-colorcal`) and an LS-100 or CS-100A (`ls100`,
//! `lightbooth mock-ls100`), on the same unit machinery.
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

//!
//! Layout: [`config`] says what to simulate, [`faults`] what to inject,
//! [`model`] what the optics and detector make of the target; `unit` is
//! what both simulated units share (the pty, the read loop, paced or burst
//! replies, faults on a spectrum reply), `pr650`, `pr655`, `cs2000` and `cr250` the
//! firmwares over it.

mod colorcal;
pub mod config;
mod cr250;
mod cs2000;
pub mod faults;
mod ls100;
pub mod model;
mod pr650;
mod pr655;
mod unit;

pub use config::{BeforeFirstMeasurement, BusyInput, MockConfig, Personality};
pub use faults::{Fault, FaultKind, FaultRate, FAULT_SYNTAX};
pub use pr655::switches::{AfterFailure, Pr655Switches, StrayTerminator, SyncFailure};

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;

use serialport::SerialPort as _;

use lightbooth_science::spectrum::{Grid, Spectrum, SpectrumError};
use model::{InstrumentModel, Reading};
use unit::{lock, Shared};

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
    let shared = Arc::new(Mutex::new(Shared::new(truth_1nm, config.faults.clone())));
    let stop = Arc::new(AtomicBool::new(false));
    let model = config.model.clone();
    let name = config.personality.model_name();
    let thread = {
        let shared = Arc::clone(&shared);
        let stop = Arc::clone(&stop);
        match config.personality.clone() {
            Personality::Pr650 => std::thread::Builder::new()
                .name("mock-pr650".into())
                .spawn(move || unit::run(pr650::Device::new(config, master, slave, shared, stop)))?,
            Personality::Pr655(switches) => std::thread::Builder::new()
                .name("mock-pr655".into())
                .spawn(move || unit::run(pr655::Device::new(config, switches, master, slave, shared, stop)))?,
            Personality::Cr250(model) => std::thread::Builder::new()
                .name("mock-cr250".into())
                .spawn(move || unit::run(cr250::Device::new(config, model, master, slave, shared, stop)))?,
            Personality::Cs2000(model) => std::thread::Builder::new()
                .name("mock-cs2000".into())
                .spawn(move || unit::run(cs2000::Device::new(config, model, master, slave, shared, stop)))?,
            Personality::ColorCal => std::thread::Builder::new()
                .name("mock-colorcal".into())
                .spawn(move || unit::run(colorcal::Device::new(config, master, slave, shared, stop)))?,
            Personality::Ls100(model) => std::thread::Builder::new()
                .name("mock-ls100".into())
                .spawn(move || unit::run(ls100::Device::new(config, model, master, slave, shared, stop)))?,
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

    /// Settings the simulated unit was told to write to its flash memory
    /// (the CS-2000's `SPMS`, `SCMS`): a driver must never do it unasked.
    pub fn flash_writes(&self) -> u64 {
        lock(&self.shared).flash_writes
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
