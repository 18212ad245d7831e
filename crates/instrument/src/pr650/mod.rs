//! The Photo Research PR-650 SpectraScan: its protocol ([`protocol`], pure),
//! what its codes mean ([`codes`]), its driver ([`driver`]: what is
//! PR-650-specific over the shared [`super::link::Session`]) and its settings
//! ([`Pr650Settings`], the `instruments/pr650.toml` file).

pub mod codes;
pub mod driver;
pub mod protocol;

use std::path::Path;
use std::time::Duration;

use serde::Deserialize;

use super::link::{LinkSettings, SessionTiming, Terminator};
use super::{Capabilities, InstrumentError, Spectroradiometer};

/// Most samples one averaged measurement takes: the PR-650's own averaging
/// count (the `S` command's `avg` field) runs 01–99, and lightbooth keeps
/// the same bound for its series of single `M0` measurements.
pub const MAX_SAMPLES: usize = 99;

/// Everything configurable about a PR-650 session. Timeouts are in ms.
/// Deserialised from `instruments/pr650.toml`; every field has a default.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct Pr650Settings {
    /// The serial device, e.g. `/dev/ttyUSB0` (the command line's `--port` overrides it).
    pub port: Option<String>,
    /// Samples per averaged measurement.
    pub samples: usize,
    /// Extra attempts allowed, over the whole series, for samples lost to a
    /// bad quality code or a link fault.
    pub retries: usize,
    /// First byte of a reply to an ordinary command (`B1`, `S`, `D5`, `D2`)
    /// and of the resynchronisation ping. A live PR-650 answers these at once;
    /// this bounds how long a dead one goes unnoticed (see [`driver`]).
    pub command_timeout_ms: u64,
    /// First byte after `M0`: the whole measurement (PTB, PsychoPy: 30 s; dim
    /// sources in adaptive mode can take that long).
    pub measure_timeout_ms: u64,
    /// Longest silence inside a reply before it counts as cut off.
    pub gap_timeout_ms: u64,
    /// Tries of the remote-mode handshake before telling the operator to power-cycle (PTB: 5).
    pub remote_mode_attempts: u32,
    /// Command terminator: "lf" (PTB, PsychoPy, mgl), "cr" or "crlf".
    pub terminator: Terminator,
    /// Pause between command bytes (0 = whole-command writes).
    pub byte_delay_ms: u64,
    /// How long the line must be quiet when resynchronising after a fault.
    pub resync_quiet_ms: u64,
    /// Integration time: 0 = adaptive, else 10–6000 ms.
    pub integration_ms: u32,
    /// Synchronise to the source's flicker (runs `F` at start; on codes 7/8
    /// sync is turned off and the sample retaken, as PTB does).
    pub sync: bool,
}

impl Default for Pr650Settings {
    fn default() -> Pr650Settings {
        Pr650Settings {
            port: None,
            samples: 5,
            retries: 2,
            command_timeout_ms: 3_000,
            measure_timeout_ms: 30_000,
            gap_timeout_ms: 2_000,
            remote_mode_attempts: 5,
            terminator: Terminator::Lf,
            byte_delay_ms: 0,
            resync_quiet_ms: 200,
            integration_ms: 0,
            sync: false,
        }
    }
}

impl Pr650Settings {
    /// Reads `instruments/pr650.toml` (or any file of that shape).
    pub fn from_toml_file(path: &Path) -> Result<Pr650Settings, InstrumentError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| InstrumentError::Settings(format!("cannot read {}: {e}", path.display())))?;
        Pr650Settings::from_toml_str(&text).map_err(|e| InstrumentError::Settings(format!("{}: {e}", path.display())))
    }

    pub fn from_toml_str(text: &str) -> Result<Pr650Settings, String> {
        let s: Pr650Settings = toml::from_str(text).map_err(|e| e.to_string())?;
        s.validate()?;
        Ok(s)
    }

    /// Ranges the instrument or common sense requires.
    pub fn validate(&self) -> Result<(), String> {
        if !(1..=MAX_SAMPLES).contains(&self.samples) {
            return Err(format!(
                "samples = {}: the PR-650 averages 1–{MAX_SAMPLES} samples per measurement",
                self.samples
            ));
        }
        if self.integration_ms != 0 && !(10..=6000).contains(&self.integration_ms) {
            return Err(format!(
                "integration_ms = {}: the PR-650 takes 0 (adaptive) or 10–6000 ms",
                self.integration_ms
            ));
        }
        if self.remote_mode_attempts == 0 {
            return Err("remote_mode_attempts must be at least 1".into());
        }
        if self.command_timeout_ms == 0 || self.measure_timeout_ms == 0 || self.gap_timeout_ms == 0 {
            return Err("timeouts must be positive".into());
        }
        Ok(())
    }

    /// What a PR-650 can do, with these settings' samples and retries.
    pub fn capabilities(&self) -> Capabilities {
        Capabilities {
            model: driver::MODEL,
            reading: crate::Reading::Spectrum,
            native_grid: lightbooth_science::spectrum::Grid::pr650(),
            max_samples: MAX_SAMPLES,
            default_samples: self.samples,
            retries: self.retries,
            stated_accuracy: crate::accuracy::stated_accuracy_of(driver::MODEL),
        }
    }

    pub(crate) fn link(&self) -> LinkSettings {
        LinkSettings::at_9600_baud(self.terminator, self.command_timeout_ms, self.byte_delay_ms)
    }

    /// The session's timeouts. A PR-650 `M0` that timed out is not taken to
    /// be still measuring (only a cancelled one is).
    pub(crate) fn timing(&self) -> SessionTiming {
        SessionTiming {
            command: Duration::from_millis(self.command_timeout_ms),
            measure: Duration::from_millis(self.measure_timeout_ms),
            gap: Duration::from_millis(self.gap_timeout_ms),
            resync_quiet: Duration::from_millis(self.resync_quiet_ms),
            measuring_after_timeout: false,
        }
    }
}

/// Opens a PR-650 on `port`: remote mode, setup, identification.
pub fn open_pr650(port: &str, settings: &Pr650Settings) -> Result<Box<dyn Spectroradiometer>, InstrumentError> {
    Ok(Box::new(driver::Pr650::open(port, settings)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shipped_settings_file_parses() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../instruments/pr650.toml");
        let s = Pr650Settings::from_toml_file(&path).unwrap();
        assert_eq!(s.samples, 5);
        assert_eq!(s.measure_timeout_ms, 30_000);
        let defaults = Pr650Settings {
            port: Some("/dev/ttyUSB0".into()),
            ..Pr650Settings::default()
        };
        assert_eq!(s, defaults, "the file states the defaults");
    }

    #[test]
    fn bad_settings_say_what_is_wrong() {
        let e = Pr650Settings::from_toml_str("integration_ms = 5").unwrap_err();
        assert!(e.contains("10–6000"), "{e}");
        assert!(Pr650Settings::from_toml_str("samplez = 5").is_err());
    }
}
