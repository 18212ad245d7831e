//! What a simulated instrument is told to be: which model
//! ([`Personality`]), what it is aimed at, how fast it runs, which faults it
//! injects, and its behaviours the protocol sheets leave open.

use super::faults::Fault;
use super::model::InstrumentModel;
use super::pr655::switches::Pr655Switches;
use lightbooth_science::spectrum::Spectrum;

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
    /// A Konica Minolta CS-2000, CS-2000A or CS-3000 (`docs/src/instruments/cs2000.md`).
    Cs2000(crate::cs2000::Model),
    /// A Colorimetry Research CR-250 or CR-300 (`docs/src/instruments/cr250.md`).
    Cr250(crate::cr250::Model),
    /// A CRS ColorCAL MkII (`super::colorcal`).
    ColorCal,
    /// A Konica Minolta LS-100 or CS-100A (`super::ls100`).
    Ls100(crate::ls100::Model),
}

impl Personality {
    /// The model's name as the unit reports it: `PR-650`, `PR-655` or `PR-670`.
    pub fn model_name(&self) -> &'static str {
        match self {
            Personality::Pr650 => "PR-650",
            Personality::Pr655(switches) => switches.model.name(),
            Personality::Cs2000(model) => model.name(),
            Personality::Cr250(model) => model.name(),
            Personality::ColorCal => crate::colorcal::MODEL_NAME,
            Personality::Ls100(model) => model.name(),
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
    /// Delay of a [`FaultKind::Slow`](super::faults::FaultKind::Slow) reply that names none, ms (not scaled by speed).
    pub slow_ms: u64,
    /// Code of a [`FaultKind::ErrorCode`](super::faults::FaultKind::ErrorCode) measurement.
    pub error_code: u8,
    /// The same for a model with signed codes (the CR-250's 100, −303 … −306).
    pub error_status: i32,
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
    /// CS-2000: announce 0 s for `MEAS,1` and send no end line, so a client
    /// must poll `MEDR,0,0,1` through its `ER02` (not ready) answers.
    pub short_estimate: bool,
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
            error_status: 100,
            serial: "60954303".into(),
            header_bare_cr: false,
            pace_output: true,
            before_first: BeforeFirstMeasurement::StaleZeros,
            busy_input: BusyInput::Queue,
            flicker_hz: None,
            unsyncable: false,
            short_estimate: false,
            model: InstrumentModel::default(),
        }
    }

    /// A simulated CS-2000, CS-2000A or CS-3000: its 1 nm grid, slit and detector.
    pub fn cs2000(truth: Spectrum, model: crate::cs2000::Model) -> MockConfig {
        MockConfig {
            personality: Personality::Cs2000(model),
            model: InstrumentModel::for_cs2000(),
            serial: "20101234".into(),
            error_code: 71,
            ..MockConfig::new(truth)
        }
    }

    /// A simulated CR-250 or CR-300: its grid, slit and detector.
    pub fn cr250(truth: Spectrum, model: crate::cr250::Model) -> MockConfig {
        MockConfig {
            personality: Personality::Cr250(model),
            model: InstrumentModel::for_cr250(model),
            serial: "25010042".into(),
            pace_output: false,
            ..MockConfig::new(truth)
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

    /// A simulated ColorCAL MkII: USB (replies in one write), no power-on
    /// window, an eight-digit serial.
    pub fn colorcal(truth: Spectrum) -> MockConfig {
        MockConfig {
            personality: Personality::ColorCal,
            remote_window_ms: None,
            pace_output: false,
            serial: "10003154".into(),
            ..MockConfig::new(truth)
        }
    }

    /// A simulated LS-100 or CS-100A in communication mode; an `error-code`
    /// fault answers `ER` + [`MockConfig::error_code`] (default `ER10`,
    /// measuring range over).
    pub fn ls100(truth: Spectrum, model: crate::ls100::Model) -> MockConfig {
        MockConfig {
            personality: Personality::Ls100(model),
            remote_window_ms: None,
            pace_output: false,
            error_code: 10,
            serial: String::new(),
            ..MockConfig::new(truth)
        }
    }

    /// The default simulator of `personality` aimed at `truth`.
    pub fn for_personality(truth: Spectrum, personality: Personality) -> MockConfig {
        match personality {
            Personality::Pr650 => MockConfig::new(truth),
            Personality::Pr655(switches) => MockConfig::pr655(truth, switches),
            Personality::Cs2000(model) => MockConfig::cs2000(truth, model),
            Personality::Cr250(model) => MockConfig::cr250(truth, model),
            Personality::ColorCal => MockConfig::colorcal(truth),
            Personality::Ls100(model) => MockConfig::ls100(truth, model),
        }
    }
}
