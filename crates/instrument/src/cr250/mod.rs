//! The Colorimetry Research CR-250 and CR-300 spectroradiometers: the two
//! models ([`Model`]), one remote protocol ([`protocol`], pure, after
//! `docs/src/instruments/cr250.md`), what its codes mean ([`codes`]), a
//! driver ([`driver`]) over the shared [`super::link::Session`], and the
//! settings ([`Cr250Settings`], `instruments/cr250.toml`).
//!
//! A USB CDC-ACM port at 115200 baud with RTS/CTS, word commands ending in
//! LF, `OK:`/`ER:` replies; spectra of 101 points at 4 nm (CR-250) or 401
//! at 1 nm (CR-300), which the unit's own header states. The family's
//! colorimeters and photometers answer the same protocol but give no
//! spectrum: lightbooth refuses them by their `RC InstrumentType`.

pub mod codes;
pub mod driver;
pub mod protocol;

use std::time::Duration;

use serde::Deserialize;

use super::link::{Framing, LinkSettings, SessionTiming, Terminator};
use super::{Capabilities, InstrumentError, Reading, Spectroradiometer};
use lightbooth_science::spectrum::Grid;

/// Most samples one averaged measurement takes (as for every model).
pub const MAX_SAMPLES: usize = 99;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Model {
    Cr250,
    Cr300,
}

impl Model {
    /// As `RC Model` answers (specio 62–70).
    pub fn name(self) -> &'static str {
        match self {
            Model::Cr250 => "CR-250",
            Model::Cr300 => "CR-300",
        }
    }

    pub fn flag(self) -> &'static str {
        match self {
            Model::Cr250 => "cr250",
            Model::Cr300 => "cr300",
        }
    }

    pub fn from_name(name: &str) -> Option<Model> {
        [Model::Cr250, Model::Cr300]
            .into_iter()
            .find(|m| m.name().eq_ignore_ascii_case(name.trim()))
    }

    /// The CR-250's 380–780 nm at 4 nm, the CR-300's at 1 nm (specio 460–463).
    pub fn grid(self) -> Grid {
        match self {
            Model::Cr250 => Grid::uniform(380.0, 4.0, 101),
            Model::Cr300 => Grid::one_nm(),
        }
    }
}

/// Everything configurable about a CR-250/CR-300 session. Timeouts in ms.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct Cr250Settings {
    #[serde(skip)]
    pub model: Option<Model>,
    pub port: Option<String>,
    pub samples: usize,
    pub retries: usize,
    /// Automatic exposure's speed: 0 slow, 1 normal, 2 fast, 3 2× fast.
    pub speed: u8,
    pub command_timeout_ms: u64,
    /// A whole `M`: specio allows 70, 21, 14 and 7 s for the four speeds (cr.py:427–437).
    pub measure_timeout_ms: Option<u64>,
    pub gap_timeout_ms: u64,
    pub resync_quiet_ms: u64,
}

impl Default for Cr250Settings {
    fn default() -> Cr250Settings {
        Cr250Settings {
            model: None,
            port: None,
            samples: 5,
            retries: 2,
            speed: 1,
            command_timeout_ms: 2_000,
            measure_timeout_ms: None,
            gap_timeout_ms: 1_000,
            resync_quiet_ms: 200,
        }
    }
}

impl Cr250Settings {
    pub fn for_model(model: Model) -> Cr250Settings {
        Cr250Settings {
            model: Some(model),
            ..Cr250Settings::default()
        }
    }

    pub fn from_toml_str(text: &str, model: Model) -> Result<Cr250Settings, String> {
        let mut s: Cr250Settings = toml::from_str(text).map_err(|e| e.to_string())?;
        s.model = Some(model);
        s.validate()?;
        Ok(s)
    }

    pub fn model(&self) -> Model {
        self.model.unwrap_or(Model::Cr250)
    }

    pub fn validate(&self) -> Result<(), String> {
        if !(1..=MAX_SAMPLES).contains(&self.samples) {
            return Err(format!(
                "samples = {}: lightbooth averages 1–{MAX_SAMPLES} samples per measurement",
                self.samples
            ));
        }
        if self.speed > 3 {
            return Err(format!("speed = {}: 0 slow, 1 normal, 2 fast or 3 2× fast", self.speed));
        }
        if self.command_timeout_ms == 0 || self.gap_timeout_ms == 0 || self.measure_timeout_ms == Some(0) {
            return Err("timeouts must be positive".into());
        }
        Ok(())
    }

    pub fn capabilities(&self) -> Capabilities {
        let model = self.model();
        Capabilities {
            model: model.name(),
            reading: Reading::Spectrum,
            native_grid: model.grid(),
            max_samples: MAX_SAMPLES,
            default_samples: self.samples,
            retries: self.retries,
            stated_accuracy: crate::accuracy::stated_accuracy_of(model.name()),
        }
    }

    /// 115200 baud, 8N1, RTS/CTS, LF (specio cr.py:37–45, 380).
    pub(crate) fn link(&self) -> LinkSettings {
        LinkSettings {
            baud: 115_200,
            terminator: Terminator::Lf,
            write_timeout_ms: self.command_timeout_ms.min(5_000),
            byte_delay_ms: 0,
            framing: Framing::EIGHT_N_ONE,
            flow_control: true,
        }
    }

    /// specio's allowance for one `M` at this speed.
    pub(crate) fn measure_timeout(&self) -> Duration {
        let s = [70_000, 21_000, 14_000, 7_000][usize::from(self.speed.min(3))];
        Duration::from_millis(self.measure_timeout_ms.unwrap_or(s))
    }

    pub(crate) fn timing(&self) -> SessionTiming {
        SessionTiming {
            command: Duration::from_millis(self.command_timeout_ms),
            measure: self.measure_timeout(),
            gap: Duration::from_millis(self.gap_timeout_ms),
            resync_quiet: Duration::from_millis(self.resync_quiet_ms),
            measuring_after_timeout: true,
        }
    }
}

/// Opens a CR-250 or CR-300 on `port`: identification and setup.
pub fn open_cr250(port: &str, settings: &Cr250Settings) -> Result<Box<dyn Spectroradiometer>, InstrumentError> {
    Ok(Box::new(driver::Cr250::open(port, settings)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shipped_settings_file_parses_and_states_the_defaults() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../instruments/cr250.toml");
        let settings = crate::InstrumentSettings::from_toml_file(&path).unwrap();
        let crate::InstrumentSettings::Cr250(s) = settings else {
            panic!("cr250.toml is not a CR-250 file");
        };
        assert_eq!(
            s,
            Cr250Settings {
                port: Some("/dev/ttyACM0".into()),
                ..Cr250Settings::for_model(Model::Cr250)
            }
        );
        assert_eq!(s.capabilities().native_grid.len(), 101);
        assert_eq!(
            Cr250Settings::for_model(Model::Cr300).capabilities().native_grid.len(),
            401
        );
        let e = Cr250Settings::from_toml_str("speed = 7", Model::Cr250).unwrap_err();
        assert!(e.contains("2× fast"), "{e}");
    }
}
