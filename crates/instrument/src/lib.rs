//! Spectroradiometers, device-independent: what the daemon and the command
//! line see of an instrument.
//!
//! A layer of the workspace above `lightbooth-science`, the only crate of
//! lightbooth it uses; it knows nothing of the renderer, the store or HTTP,
//! and Cargo refuses a build where it would. `lightbooth` re-exports it as
//! `lightbooth::instrument`.
//!
//! An instrument is a [`Spectroradiometer`]: it says what it is
//! ([`InstrumentInfo`], with its native wavelength grid), what it can do
//! ([`Capabilities`]: sample limits, retries, the manufacturer's stated
//! accuracy from [`accuracy`]) and takes one sample at a time.
//! The [`averaging`] loop above every driver takes an averaged measurement
//! that keeps every raw [`Sample`] with its time and quality code. Bad
//! samples (an instrument error code, a stale spectral buffer) are reported
//! to the caller but never enter the mean. [`InstrumentSettings`] names the
//! model a daemon drives and opens it.
//!
//! Layers, each testable alone:
//!
//! - [`link`]: the serial port ([`link::serial`]: settings, flushing, the
//!   two-phase read), its line framing, and the one [`link::Session`] every
//!   driver shares: a command and its reply within the right timeouts, and
//!   the resynchronisation (drain, ping, drain) after a fault.
//! - [`reply`]: what every model's replies share: the one
//!   [`reply::ProtocolError`] and the number syntax.
//! - [`pr650`] and [`pr655`] (the PR-655 and PR-670): each model's protocol,
//!   pure (no I/O), what its codes mean, its settings, and a driver with only
//!   what is particular to the model (entering remote mode, identifying the
//!   unit, its setup, how one sample is measured and read, and how it reacts
//!   to a bad code) over the shared session.
//! - [`cs2000`] (the Konica Minolta CS-2000, CS-2000A, CS-3000) and
//!   [`cr250`] (the Colorimetry Research CR-250, CR-300): the same layers for
//!   spectroradiometers on 115200-baud USB ports with RTS/CTS.
//! - [`colorcal`] (the CRS ColorCAL MkII colorimeter) and [`ls100`] (the
//!   Konica Minolta LS-100 luminance meter and CS-100A chroma meter): the
//!   same layers for instruments without a spectrum, whose replies open with
//!   an `OKnn`/`ERnn` [`status_word`].
//! - [`averaging`]: the retry-and-average loop above every driver.
//! - [`sim`]: the simulated PR-650, PR-655, PR-670, CS-2000 family, CR-250,
//!   CR-300, ColorCAL MkII, LS-100 and CS-100A on real pseudo-terminals.
//! - [`discovery`]: which serial ports exist and who answers on each, under
//!   a hard deadline (`lightbooth instruments`, `serve --instrument auto`).
//!
//! The one loop that owns an instrument for async callers (a dedicated
//! thread, measurements one at a time, each sample stored as it is taken) is
//! the daemon's instrument task (`lightbooth_lab::measure::task`). Every
//! model is an implementation of [`Spectroradiometer`] and a variant of
//! [`InstrumentSettings`]; [`QualityCode`] carries signed codes and
//! [`InstrumentInfo`] the native grid, so the daemon, the store and the API
//! do not depend on the model.

pub mod accuracy;
pub mod averaging;
pub mod colorcal;
pub mod cr250;
pub mod cs2000;
pub mod discovery;
pub mod link;
pub mod ls100;
mod models;
pub mod pr650;
pub mod pr655;
pub mod reply;
pub mod sim;
pub mod status_word;

use std::time::SystemTime;

use serde::Serialize;
use tokio_util::sync::CancellationToken;

use lightbooth_science::colorimetry::{xyz_from_radiance, Observer};
use lightbooth_science::spectrum::{Grid, Spectrum};
pub use lightbooth_science::uncertainty::StatedAccuracy;

pub use models::{native_grid_of_length, reading_of_model, InstrumentSettings, MODEL_FLAGS};
pub use pr650::{open_pr650, Pr650Settings};

/// What an instrument is, as far as it can tell.
#[derive(Clone, Debug, PartialEq)]
pub struct InstrumentInfo {
    /// "PR-650" (the PR-650 has no model query; later models answer `D111`).
    pub model: String,
    /// Serial number, when the instrument reports one.
    pub serial: Option<String>,
    /// Firmware version, when the instrument reports one (PR-655/670 `D114`).
    pub firmware: Option<String>,
    /// The native wavelength grid of its spectra (PR-650: 380–780 nm at 4 nm).
    pub grid: Grid,
}

/// Broad meaning of an instrument's quality code, shared by every model.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum QualityKind {
    /// The measurement is good.
    Ok,
    /// Too little light. The PR-650 then leaves its spectral buffer stale.
    LowLight,
    /// Too much light: the detector saturated.
    Overload,
    /// Could not synchronise to the source's flicker.
    Sync,
    /// A hardware, firmware or battery problem.
    Hardware,
    /// A documented code that fits none of the above (noisy signal, …).
    Other,
    /// A code the instrument's documentation does not list.
    Unknown,
}

/// An instrument's measurement quality code with its documented meaning.
/// Signed, because PR-655/PR-670 codes are negative numbers.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct QualityCode {
    pub code: i32,
    pub kind: QualityKind,
    pub message: String,
}

impl QualityCode {
    pub fn is_ok(&self) -> bool {
        self.kind == QualityKind::Ok
    }

    /// True when the numbers sent with this code are not from this
    /// measurement (PR-650 codes 10 and 18 leave the spectral buffer stale).
    pub fn spectrum_is_stale(&self) -> bool {
        self.kind == QualityKind::LowLight
    }
}

impl std::fmt::Display for QualityCode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "code {:02} ({})", self.code, self.message)
    }
}

/// One raw measurement of an averaged series, good or bad.
#[derive(Clone, Debug)]
pub struct Sample {
    /// Position in the series, counting bad samples too (0-based).
    pub index: usize,
    /// When the instrument finished this measurement.
    pub time: SystemTime,
    /// The quality code from the instrument's report.
    pub code: QualityCode,
    /// The spectrum on the native grid; `None` unless the code is OK (a bad
    /// code means a stale or untrustworthy buffer, which must not be kept as data).
    pub radiance: Option<Spectrum>,
    /// Luminance in cd/m² as the instrument reported it (`D2`), when good.
    pub luminance: Option<f64>,
    /// X, Y, Z (cd/m² scale) as the instrument itself reported them, in the
    /// observer its [`Reading`] names, when good: a colorimeter's only
    /// reading, a spectroradiometer's own colorimetry (the CS-2000's); none
    /// when the instrument sends none.
    pub instrument_xyz: Option<[f64; 3]>,
}

impl Sample {
    /// Whether this sample enters the mean of a series of `reading`: its
    /// code is good and it carries that reading (a spectrum, the
    /// instrument's XYZ, its luminance).
    pub fn is_usable(&self, reading: Reading) -> bool {
        self.code.is_ok()
            && match reading {
                Reading::Spectrum => self.radiance.is_some(),
                Reading::Tristimulus { .. } => self.instrument_xyz.is_some(),
                Reading::Luminance { .. } => self.luminance.is_some(),
            }
    }
}

/// The result of [`measure_averaged`](averaging::measure_averaged): every sample, and
/// statistics over the good ones only.
#[derive(Clone, Debug)]
pub struct AveragedMeasurement {
    pub info: InstrumentInfo,
    /// What the samples carry (the model's [`Capabilities::reading`]).
    pub reading: Reading,
    /// Every sample taken, including the bad ones, in order.
    pub samples: Vec<Sample>,
    /// Mean of the good samples' spectra, on the instrument's native grid,
    /// per nm; none from a colorimeter or a luminance meter.
    pub mean: Option<Spectrum>,
    /// Per-wavelength sample standard deviation (n − 1) of the good samples,
    /// same unit as `mean`; zeros for a single sample; empty without spectra.
    pub sd: Vec<f64>,
    /// Luminance, cd/m²: of the mean spectrum (CIE 1931 2°, Km = 683 lm/W,
    /// as the PR-650 computes it), or the mean of the instrument's own
    /// readings when it gives no spectrum.
    pub luminance_cd_m2: f64,
    /// Chromaticity x, y: CIE 1931 of the mean spectrum, or of the mean of
    /// the instrument's XYZ (in its reading's observer); none from a
    /// luminance meter.
    pub x: Option<f64>,
    pub y: Option<f64>,
    /// The mean of the good samples' own XYZ, when the instrument gives them.
    pub instrument_xyz: Option<[f64; 3]>,
    /// Standard deviation over mean of the good samples' luminances, each
    /// computed like `luminance_cd_m2` (dimensionless).
    pub luminance_cv: f64,
}

impl AveragedMeasurement {
    /// The good samples, those that entered the mean.
    pub fn good_samples(&self) -> impl Iterator<Item = &Sample> {
        let reading = self.reading;
        self.samples.iter().filter(move |s| s.is_usable(reading))
    }
}

/// Where in a reply a wait ran out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WaitPhase {
    /// Waiting for the first byte of the reply.
    FirstByte,
    /// Inside the reply: no byte arrived for the gap timeout.
    MidReply,
}

impl std::fmt::Display for WaitPhase {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            WaitPhase::FirstByte => write!(f, "for the first byte of the reply"),
            WaitPhase::MidReply => write!(f, "in the middle of the reply"),
        }
    }
}

/// Everything that can go wrong with an instrument, each with what to do.
#[derive(Debug, thiserror::Error)]
pub enum InstrumentError {
    #[error(
        "cannot open serial port {port}: {reason}. Check the path (ls /dev/ttyUSB* /dev/ttyACM*) and that you \
         may use it (be in the `dialout` group, then log in again)"
    )]
    Open { port: String, reason: String },
    #[error(
        "no reply to `{command}` after {waited_ms} ms: check that the instrument is on and in remote mode, its \
         cable (a PR-650's switch on CTRLR), and that the port is the right one (`lightbooth instruments --probe`)"
    )]
    NoReply { command: String, waited_ms: u64 },
    #[error(
        "the PR-650 did not answer in {attempts} attempts: it is probably in local mode because no command \
         reached it within 5 s of power-on. Switch it off and on again, then run lightbooth within 5 s"
    )]
    NotInRemoteMode { attempts: u32 },
    #[error(
        "only {good} of {needed} good samples after the allowed retries; last instrument {code:02}: {message}. \
         {hint}"
    )]
    Quality {
        code: i32,
        message: String,
        good: usize,
        needed: usize,
        hint: &'static str,
    },
    #[error("garbled reply to `{command}`: {detail}. The line may be noisy; check the cable and the baud rate (9600 for the Photo Research units, 115200 for the CS-2000 and CR-250/300, 4800 for the Minolta meters)")]
    Protocol { command: String, detail: String },
    #[error(
        "the reply to `{command}` stopped after {lines} of {expected} lines (nothing for {gap_ms} ms): \
         a slow or disturbed link; the measurement was discarded"
    )]
    Truncated {
        command: String,
        lines: usize,
        expected: usize,
        gap_ms: u64,
    },
    #[error("timed out after {waited_ms} ms waiting {phase} to `{command}`; raise the timeout if the source is dim")]
    Timeout {
        command: String,
        phase: WaitPhase,
        waited_ms: u64,
    },
    #[error("the instrument refused `{command}` with status {status:02}: {meaning}. Fix that setting")]
    Setup {
        command: String,
        status: u8,
        meaning: &'static str,
    },
    #[error(
        "the {model} did not answer `PHOTO` with ` REMOTE MODE` in {attempts} attempts ({waited_ms} ms each): check \
         that it is on and that this is its port (ls /dev/ttyACM*), then power-cycle it or re-plug its USB cable"
    )]
    NoBanner {
        model: &'static str,
        attempts: u32,
        waited_ms: u64,
    },
    #[error("the {model} did not answer `{command}` in {attempts} attempt(s) of {waited_ms} ms: {advice}")]
    Silent {
        model: &'static str,
        command: String,
        attempts: u32,
        waited_ms: u64,
        /// What to check, in the model's terms (communication mode, USB cable).
        advice: &'static str,
    },
    #[error("the instrument refused `{command}` with status {code}. Fix that setting or command")]
    Refused { command: String, code: QualityCode },
    #[error("serial port {port} closed: the cable was pulled, the adapter unplugged or the instrument switched off (a PR-655/670 does after a `ZReset…` command). Reconnect it or switch it on, and start again")]
    PortClosed { port: String },
    #[error(
        "the instrument stopped answering: no reply to `{command}` for {waited_ms} ms after `{after}` failed \
         ({reason}). The cable may be cut or loose behind the adapter, or the unit switched off: check the cable \
         and the power, then power-cycle the unit"
    )]
    Unresponsive {
        /// The command whose reply failed first (e.g. a cut-off `D5`).
        after: String,
        /// Why that reply failed.
        reason: String,
        /// The ping that then got no reply at all.
        command: String,
        waited_ms: u64,
    },
    #[error("measurement cancelled")]
    Cancelled,
    #[error("serial I/O on {port}: {source}")]
    Io {
        port: String,
        #[source]
        source: std::io::Error,
    },
    #[error("bad instrument settings: {0}")]
    Settings(String),
}

impl InstrumentError {
    /// A fault of the link or of one reply, after which a resynchronised port
    /// can try again (as opposed to a closed port, a cancel or bad settings).
    pub fn is_retryable_link_fault(&self) -> bool {
        matches!(
            self,
            InstrumentError::NoReply { .. }
                | InstrumentError::Protocol { .. }
                | InstrumentError::Truncated { .. }
                | InstrumentError::Timeout { .. }
        )
    }
}

/// What an instrument's good sample carries: a spectrum (and maybe its
/// own XYZ), XYZ only (a colorimeter), or luminance only (a luminance
/// meter). What needs more than a model reads refuses, naming the reading.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum Reading {
    /// Spectral radiance on the model's native grid.
    Spectrum,
    /// X, Y, Z in cd/m², in `observer` (a colorimeter's filters
    /// approximate one observer's matching functions; its XYZ cannot be
    /// recomputed in another).
    Tristimulus { observer: Observer },
    /// Luminance Y in cd/m² only (with `observer`'s V(λ)).
    Luminance { observer: Observer },
}

impl Reading {
    /// "spectrum", "XYZ", "luminance": what the dashboard's card says it measures.
    pub fn name(self) -> &'static str {
        match self {
            Reading::Spectrum => "spectrum",
            Reading::Tristimulus { .. } => "XYZ",
            Reading::Luminance { .. } => "luminance",
        }
    }
}

/// What a model can do and how its settings ask it to be driven, known
/// before a unit is connected (the API checks requests against it).
#[derive(Clone, Debug, PartialEq)]
pub struct Capabilities {
    /// The model's name as the operator knows it ("PR-650").
    pub model: &'static str,
    /// What a good sample carries.
    pub reading: Reading,
    /// The grid its spectra come on until the unit says otherwise.
    pub native_grid: Grid,
    /// Most samples one averaged measurement may ask for.
    pub max_samples: usize,
    /// Samples per measurement when a request does not say (settings file).
    pub default_samples: usize,
    /// Extra attempts allowed over one series, for samples lost to a bad
    /// quality code or a link fault (settings file).
    pub retries: usize,
    /// The manufacturer's stated accuracy with its source ([`accuracy`]);
    /// a figure no source was found for is `None`.
    pub stated_accuracy: StatedAccuracy,
}

/// Everything a caller asks of a connected unit besides its samples: what
/// it said it is, what its model can do, and what its codes advise.
#[derive(Clone, Debug)]
pub struct Identity {
    pub info: InstrumentInfo,
    pub capabilities: Capabilities,
    /// The model's advice for a series that failed with a code of this kind
    /// (each model's `codes::quality_hint`).
    pub quality_hint: fn(QualityKind) -> &'static str,
}

impl Identity {
    /// A unit of the model `capabilities` describe, before it has said more
    /// about itself: its model's name and native grid, no serial, no firmware.
    pub fn new(capabilities: Capabilities, quality_hint: fn(QualityKind) -> &'static str) -> Identity {
        Identity {
            info: InstrumentInfo {
                model: capabilities.model.into(),
                serial: None,
                firmware: None,
                grid: capabilities.native_grid.clone(),
            },
            capabilities,
            quality_hint,
        }
    }
}

/// A spectroradiometer as the daemon drives it: identify, say what it can
/// do, take one sample. The retry-and-average loop is the same for every
/// model and lives above the drivers ([`averaging`]). Implementations run
/// blocking I/O: call them from a dedicated thread (see
/// `lightbooth_lab::measure::task`).
pub trait Spectroradiometer: Send {
    /// What the connected unit said it is, what its model can do, and its
    /// advice on bad codes. A driver keeps it in its [`link::Session`].
    fn identity(&self) -> &Identity;

    /// One measurement: its quality code, and its spectrum when the code is
    /// good. A link fault (no reply, a cut-off or garbled report) is an
    /// `Err` with [`InstrumentError::is_retryable_link_fault`]; the driver
    /// resynchronises before its next command.
    fn take_sample(&mut self, index: usize, cancel: &CancellationToken) -> Result<Sample, InstrumentError>;

    /// Called after a sample with a bad code, before the next attempt (the
    /// PR-650 turns flicker sync off after a sync failure).
    fn after_bad_sample(&mut self, _code: &QualityCode, _cancel: &CancellationToken) -> Result<(), InstrumentError> {
        Ok(())
    }

    /// What the connected unit said it is.
    fn info(&self) -> &InstrumentInfo {
        &self.identity().info
    }

    /// What its model can do, with the settings' samples and retries.
    fn capabilities(&self) -> &Capabilities {
        &self.identity().capabilities
    }

    /// What the operator should do about a series that failed with a code of this kind.
    fn quality_hint(&self, kind: QualityKind) -> &'static str {
        (self.identity().quality_hint)(kind)
    }
}

impl dyn Spectroradiometer + '_ {
    /// Takes `n` good samples and averages them ([`averaging::measure_averaged`]).
    /// `on_sample` is called as each sample is taken (the daemon stores it
    /// immediately, before the next sample), including samples with bad codes.
    pub fn measure_averaged(
        &mut self,
        n: usize,
        cancel: &CancellationToken,
        on_sample: &mut dyn FnMut(&Sample),
    ) -> Result<AveragedMeasurement, InstrumentError> {
        averaging::measure_averaged(self, n, cancel, on_sample)
    }
}

/// Mean, per-wavelength SD, colorimetry and luminance CV of the good
/// samples of a series of `reading`. Bad samples stay in `samples` for the
/// record and are skipped here. Errors when there is no good sample or the
/// good ones disagree on grid or unit.
pub fn average_samples(
    info: InstrumentInfo,
    reading: Reading,
    samples: Vec<Sample>,
) -> Result<AveragedMeasurement, String> {
    let good: Vec<&Sample> = samples.iter().filter(|s| s.is_usable(reading)).collect();
    if good.is_empty() {
        return Err(format!(
            "no good sample to average (the instrument reads {})",
            reading.name()
        ));
    }
    let k = good.len() as f64;
    let mean_of = |v: &dyn Fn(&Sample) -> Option<f64>| -> Option<f64> {
        let values: Vec<f64> = good.iter().filter_map(|s| v(s)).collect();
        (values.len() == good.len()).then(|| values.iter().sum::<f64>() / k)
    };
    let instrument_xyz = match (
        mean_of(&|s| s.instrument_xyz.map(|v| v[0])),
        mean_of(&|s| s.instrument_xyz.map(|v| v[1])),
        mean_of(&|s| s.instrument_xyz.map(|v| v[2])),
    ) {
        (Some(x), Some(y), Some(z)) => Some([x, y, z]),
        _ => None,
    };
    let (mean, sd, luminance_cd_m2, xy, lums) = match reading {
        Reading::Spectrum => {
            let spectra: Vec<&Spectrum> = good.iter().filter_map(|s| s.radiance.as_ref()).collect();
            let (mean, sd) = mean_spectrum(&spectra)?;
            let xyz = xyz_from_radiance(&mean, Observer::Cie1931).map_err(|e| e.to_string())?;
            // Per-sample luminance from each spectrum, not the instrument's own Y: that
            // has four significant digits (`1.009E+02`), too coarse for a CV of 0.1 %.
            let lums: Vec<f64> = spectra
                .iter()
                .map(|s| xyz_from_radiance(s, Observer::Cie1931).map(|x| x.y))
                .collect::<Result<_, _>>()
                .map_err(|e| e.to_string())?;
            let xy = xyz.chromaticity();
            (Some(mean), sd, xyz.y, Some((xy.x, xy.y)), lums)
        }
        Reading::Tristimulus { .. } => {
            let xyz = instrument_xyz.expect("every good tristimulus sample has its XYZ");
            let lums: Vec<f64> = good.iter().filter_map(|s| s.instrument_xyz.map(|v| v[1])).collect();
            let sum = xyz[0] + xyz[1] + xyz[2];
            let xy = (sum > 0.0 && sum.is_finite()).then(|| (xyz[0] / sum, xyz[1] / sum));
            (None, Vec::new(), xyz[1], xy, lums)
        }
        Reading::Luminance { .. } => {
            let lums: Vec<f64> = good.iter().filter_map(|s| s.luminance).collect();
            let y = lums.iter().sum::<f64>() / k;
            (None, Vec::new(), y, None, lums)
        }
    };
    if !luminance_cd_m2.is_finite() {
        return Err(format!("the mean luminance is not a number ({luminance_cd_m2})"));
    }
    Ok(AveragedMeasurement {
        info,
        reading,
        samples,
        mean,
        sd,
        luminance_cd_m2,
        x: xy.map(|c| c.0),
        y: xy.map(|c| c.1),
        instrument_xyz,
        luminance_cv: coefficient_of_variation(&lums),
    })
}

/// The mean of `spectra` and the per-wavelength SD (n − 1; zeros for one).
fn mean_spectrum(spectra: &[&Spectrum]) -> Result<(Spectrum, Vec<f64>), String> {
    let first = spectra[0];
    let k = spectra.len();
    let len = first.values().len();
    let mut sum = vec![0.0; len];
    for spectrum in spectra {
        spectrum.require_same_grid(first).map_err(|e| e.to_string())?;
        if spectrum.unit() != first.unit() {
            return Err(format!(
                "samples in different units: {} and {}",
                spectrum.unit(),
                first.unit()
            ));
        }
        for (acc, v) in sum.iter_mut().zip(spectrum.values()) {
            *acc += v;
        }
    }
    let mean_values: Vec<f64> = sum.iter().map(|s| s / k as f64).collect();
    let sd = if k < 2 {
        vec![0.0; len]
    } else {
        (0..len)
            .map(|i| {
                let ss: f64 = spectra.iter().map(|s| (s.values()[i] - mean_values[i]).powi(2)).sum();
                (ss / (k - 1) as f64).sqrt()
            })
            .collect()
    };
    let mean = Spectrum::new(first.grid().clone(), first.unit(), mean_values).map_err(|e| e.to_string())?;
    Ok((mean, sd))
}

/// SD (n − 1) over mean; 0 for fewer than two values or a zero mean.
fn coefficient_of_variation(values: &[f64]) -> f64 {
    let n = values.len();
    if n < 2 {
        return 0.0;
    }
    let mean = values.iter().sum::<f64>() / n as f64;
    if mean == 0.0 {
        return 0.0;
    }
    let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
    var.sqrt() / mean.abs()
}

#[cfg(test)]
mod tests {
    use super::*;
    use lightbooth_science::spectrum::SpectralUnit;

    fn sample(index: usize, code: i32, value: f64) -> Sample {
        let ok = code == 0;
        Sample {
            index,
            time: SystemTime::now(),
            code: pr650::codes::quality_code(code as u8),
            radiance: ok.then(|| Spectrum::constant(Grid::pr650(), SpectralUnit::SpectralRadiance, value).unwrap()),
            luminance: None,
            instrument_xyz: None,
        }
    }

    #[test]
    fn bad_samples_are_kept_but_not_averaged() {
        let info = InstrumentInfo {
            model: "PR-650".into(),
            serial: None,
            firmware: None,
            grid: Grid::pr650(),
        };
        let samples = vec![sample(0, 0, 1.0), sample(1, 18, 99.0), sample(2, 0, 3.0)];
        let m = average_samples(info, Reading::Spectrum, samples).unwrap();
        assert_eq!(m.samples.len(), 3);
        assert_eq!(m.good_samples().count(), 2);
        assert!(m
            .mean
            .as_ref()
            .unwrap()
            .values()
            .iter()
            .all(|v| (v - 2.0).abs() < 1e-12));
        assert!(m.sd.iter().all(|v| (v - 2f64.sqrt()).abs() < 1e-12));
        assert!(m.luminance_cv > 0.0);
    }

    #[test]
    fn no_good_sample_is_an_error() {
        let info = InstrumentInfo {
            model: "PR-650".into(),
            serial: None,
            firmware: None,
            grid: Grid::pr650(),
        };
        assert!(average_samples(info, Reading::Spectrum, vec![sample(0, 10, 1.0)]).is_err());
    }

    fn colorimeter_sample(index: usize, code: i32, xyz: [f64; 3]) -> Sample {
        Sample {
            index,
            time: SystemTime::now(),
            code: pr650::codes::quality_code(code as u8),
            radiance: None,
            luminance: Some(xyz[1]),
            instrument_xyz: Some(xyz),
        }
    }

    fn colorimeter() -> InstrumentInfo {
        InstrumentInfo {
            model: "ColorCAL MkII".into(),
            serial: None,
            firmware: None,
            grid: Grid::pr650(),
        }
    }

    /// A colorimeter's series: the mean of the good samples' own XYZ, x y
    /// from that mean, the CV of their Y; no spectrum, and the bad sample
    /// (code 18) kept but not averaged.
    #[test]
    fn a_colorimeters_series_averages_its_own_xyz() {
        let reading = Reading::Tristimulus {
            observer: Observer::Cie1931,
        };
        let samples = vec![
            colorimeter_sample(0, 0, [40.0, 50.0, 10.0]),
            colorimeter_sample(1, 18, [999.0, 999.0, 999.0]),
            colorimeter_sample(2, 0, [44.0, 54.0, 12.0]),
        ];
        let m = average_samples(colorimeter(), reading, samples).unwrap();
        assert!(m.mean.is_none() && m.sd.is_empty());
        assert_eq!(m.good_samples().count(), 2);
        assert_eq!(m.instrument_xyz, Some([42.0, 52.0, 11.0]));
        assert_eq!(m.luminance_cd_m2, 52.0);
        assert!((m.x.unwrap() - 42.0 / 105.0).abs() < 1e-12);
        assert!((m.y.unwrap() - 52.0 / 105.0).abs() < 1e-12);
        // SD of 50 and 54 is 2√2; over the mean 52.
        assert!((m.luminance_cv - 2.0 * 2f64.sqrt() / 52.0).abs() < 1e-12);
    }

    /// A luminance meter's series has a Y and no colour; a sample without
    /// a luminance is not averaged, and no usable sample is an error.
    #[test]
    fn a_luminance_meters_series_has_luminance_and_no_chromaticity() {
        let reading = Reading::Luminance {
            observer: Observer::Cie1931,
        };
        let mut s = colorimeter_sample(0, 0, [0.0, 30.0, 0.0]);
        s.instrument_xyz = None;
        let mut t = s.clone();
        t.index = 1;
        t.luminance = Some(32.0);
        let m = average_samples(colorimeter(), reading, vec![s.clone(), t]).unwrap();
        assert_eq!(
            (m.luminance_cd_m2, m.x, m.y, m.instrument_xyz),
            (31.0, None, None, None)
        );
        s.luminance = None;
        assert!(average_samples(colorimeter(), reading, vec![s]).is_err());
    }
}
