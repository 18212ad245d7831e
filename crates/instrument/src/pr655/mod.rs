//! The Photo Research PR-655 and PR-670 SpectraScan: the two models
//! ([`model`]), one remote protocol ([`protocol`], pure, after
//! `docs/src/instruments/pr655-670-protocol.md`), what its statuses mean
//! ([`codes`]), one driver ([`driver`]: what is particular to these models
//! over the shared [`super::link::Session`]) and their settings
//! ([`Pr655Settings`], the files `instruments/pr655.toml` and
//! `instruments/pr670.toml`).
//!
//! They differ from the PR-650 in every layer: a USB virtual serial port
//! (`/dev/ttyACM0`), `PHOTO` sent letter by letter to enter remote mode and a
//! 12-byte banner, CR-terminated commands, signed five-digit statuses, and
//! spectra of 101 points at 4 nm (PR-655) or 201 at 2 nm (PR-670).

pub mod codes;
pub mod driver;
pub mod model;
pub mod protocol;

use std::time::Duration;

use serde::Deserialize;

use super::link::{LinkSettings, SessionTiming, Terminator};
use super::{Capabilities, InstrumentError, Spectroradiometer};
pub use model::Model;

/// Most samples one averaged measurement takes (lightbooth's series of
/// single measurements keeps the instrument's own `SN` bound, 1–99).
pub const MAX_SAMPLES: usize = 99;

/// Everything configurable about a PR-655/PR-670 session. Timeouts are in
/// ms. Deserialised from `instruments/pr655.toml` or `pr670.toml` (the
/// `model` key is read by [`super::InstrumentSettings`]); every other field
/// has a default.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct Pr655Settings {
    /// Which of the two (from the file's `model` key).
    #[serde(skip)]
    pub model: Option<Model>,
    /// The serial device, e.g. `/dev/ttyACM0` (`--port` overrides it).
    pub port: Option<String>,
    /// Samples per averaged measurement.
    pub samples: usize,
    /// Extra attempts allowed over the whole series.
    pub retries: usize,
    /// First byte of the reply to an ordinary command (`D`, `S`) and to the
    /// resynchronisation ping: a live unit answers at once, so this bounds
    /// how long a dead link goes unnoticed.
    pub command_timeout_ms: u64,
    /// First byte after `M5`, the whole measurement. Default: 60 s on the
    /// PR-655, 300 s on the PR-670 (PTB's and BrainardLab's time-outs).
    pub measure_timeout_ms: Option<u64>,
    /// Longest silence inside a reply before it counts as cut off.
    pub gap_timeout_ms: u64,
    /// How long to wait for the ` REMOTE MODE` banner (clients: 10 s).
    pub banner_timeout_ms: u64,
    /// `PHOTO` tries before telling the operator to power-cycle (BrainardLab sends it twice).
    pub remote_mode_attempts: u32,
    /// Pause between the five letters of `PHOTO`, each its own write (PTB: 50 ms).
    pub remote_entry_delay_ms: u64,
    /// Send `Q` and wait 0.5 s before `PHOTO`: the PR-670 answers `PHOTO`
    /// only once (PTB). Default: on for the PR-670, off for the PR-655.
    pub quit_before_entry: Option<bool>,
    /// Pause between the bytes of other commands; 0 = whole-command writes
    /// (reported to work, but not certain: 12.1). PTB paces 50 ms, iris ~1 ms.
    pub byte_delay_ms: u64,
    /// Quiet time that ends a resynchronisation after a fault.
    pub resync_quiet_ms: u64,
    /// Exposure: 0 = adaptive, else the model's fixed range (PR-655 3–6000
    /// ms, PR-670 6–6000 ms).
    pub exposure_ms: u32,
    /// Synchronise to the source's flicker: `F`, then `SS1` when a frequency
    /// was found; after a sync failure (codes −1, −3, −9, −10) sync is turned
    /// off and the sample retaken, as PTB does.
    pub sync: bool,
}

impl Default for Pr655Settings {
    fn default() -> Pr655Settings {
        Pr655Settings {
            model: None,
            port: None,
            samples: 5,
            retries: 2,
            command_timeout_ms: 3_000,
            measure_timeout_ms: None,
            gap_timeout_ms: 2_000,
            banner_timeout_ms: 10_000,
            remote_mode_attempts: 2,
            remote_entry_delay_ms: 50,
            quit_before_entry: None,
            byte_delay_ms: 10,
            resync_quiet_ms: 200,
            exposure_ms: 0,
            sync: false,
        }
    }
}

impl Pr655Settings {
    /// The defaults for `model`.
    pub fn for_model(model: Model) -> Pr655Settings {
        Pr655Settings {
            model: Some(model),
            ..Pr655Settings::default()
        }
    }

    /// Parses the file's keys (without `model`) for `model`.
    pub fn from_toml_str(text: &str, model: Model) -> Result<Pr655Settings, String> {
        let mut s: Pr655Settings = toml::from_str(text).map_err(|e| e.to_string())?;
        s.model = Some(model);
        s.validate()?;
        Ok(s)
    }

    pub fn model(&self) -> Model {
        self.model.unwrap_or(Model::Pr655)
    }

    /// Ranges the instrument or common sense requires.
    pub fn validate(&self) -> Result<(), String> {
        let model = self.model();
        if !(1..=MAX_SAMPLES).contains(&self.samples) {
            return Err(format!(
                "samples = {}: the {} averages 1–{MAX_SAMPLES} samples per measurement",
                self.samples,
                model.name()
            ));
        }
        let range = model.exposure_range_ms();
        if self.exposure_ms != 0 && !range.contains(&self.exposure_ms) {
            return Err(format!(
                "exposure_ms = {}: the {} takes 0 (adaptive) or {}–{} ms",
                self.exposure_ms,
                model.name(),
                range.start(),
                range.end()
            ));
        }
        if self.remote_mode_attempts == 0 {
            return Err("remote_mode_attempts must be at least 1".into());
        }
        if self.command_timeout_ms == 0
            || self.gap_timeout_ms == 0
            || self.banner_timeout_ms == 0
            || self.measure_timeout_ms == Some(0)
        {
            return Err("timeouts must be positive".into());
        }
        Ok(())
    }

    /// What the model can do, with these settings' samples and retries.
    pub fn capabilities(&self) -> Capabilities {
        let model = self.model();
        Capabilities {
            model: model.name(),
            reading: crate::Reading::Spectrum,
            native_grid: model.grid(),
            max_samples: MAX_SAMPLES,
            default_samples: self.samples,
            retries: self.retries,
            stated_accuracy: crate::accuracy::stated_accuracy_of(model.name()),
        }
    }

    pub(crate) fn link(&self) -> LinkSettings {
        LinkSettings::at_9600_baud(Terminator::Cr, self.command_timeout_ms, self.byte_delay_ms)
    }

    /// The session's timeouts. An `M5` that timed out may still be
    /// measuring, so the next ping waits a whole measurement.
    pub(crate) fn timing(&self) -> SessionTiming {
        SessionTiming {
            command: Duration::from_millis(self.command_timeout_ms),
            measure: self.measure_timeout(),
            gap: Duration::from_millis(self.gap_timeout_ms),
            resync_quiet: Duration::from_millis(self.resync_quiet_ms),
            measuring_after_timeout: true,
        }
    }

    pub(crate) fn measure_timeout(&self) -> Duration {
        Duration::from_millis(self.measure_timeout_ms.unwrap_or(match self.model() {
            Model::Pr655 => 60_000,
            Model::Pr670 => 300_000,
        }))
    }

    pub(crate) fn quit_before_entry(&self) -> bool {
        self.quit_before_entry.unwrap_or(self.model() == Model::Pr670)
    }
}

/// Opens a PR-655 or PR-670 on `port`: remote mode, identification, setup.
pub fn open_pr655(port: &str, settings: &Pr655Settings) -> Result<Box<dyn Spectroradiometer>, InstrumentError> {
    Ok(Box::new(driver::Pr655::open(port, settings)?))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    #[test]
    fn the_shipped_settings_files_parse_and_state_the_defaults() {
        for (file, model) in [("pr655.toml", Model::Pr655), ("pr670.toml", Model::Pr670)] {
            let path = Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../../instruments")
                .join(file);
            let settings = crate::InstrumentSettings::from_toml_file(&path).unwrap();
            let crate::InstrumentSettings::Pr655(s) = settings else {
                panic!("{file} is not a PR-655/PR-670 file");
            };
            assert_eq!(
                s,
                Pr655Settings {
                    port: Some("/dev/ttyACM0".into()),
                    ..Pr655Settings::for_model(model)
                },
                "{file} states the defaults"
            );
        }
    }

    #[test]
    fn bad_settings_say_what_is_wrong() {
        let e = Pr655Settings::from_toml_str("exposure_ms = 4", Model::Pr670).unwrap_err();
        assert!(e.contains("PR-670") && e.contains("6–6000"), "{e}");
        assert!(Pr655Settings::from_toml_str("exposure_ms = 4", Model::Pr655).is_ok());
        let e = Pr655Settings::from_toml_str("exposure = 4", Model::Pr655).unwrap_err();
        assert!(e.contains("exposure"), "{e}");
    }

    #[test]
    fn the_pr670_waits_longer_and_quits_first() {
        let pr670 = Pr655Settings::for_model(Model::Pr670);
        assert_eq!(pr670.measure_timeout(), Duration::from_secs(300));
        assert!(pr670.quit_before_entry());
        let pr655 = Pr655Settings::for_model(Model::Pr655);
        assert_eq!(pr655.measure_timeout(), Duration::from_secs(60));
        assert!(!pr655.quit_before_entry());
        assert_eq!(pr655.capabilities().native_grid.len(), 101);
        assert_eq!(pr670.capabilities().native_grid.len(), 201);
    }
}
