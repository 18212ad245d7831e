//! The Konica Minolta CS-2000, CS-2000A and CS-3000 spectroradiometers: the
//! three models ([`Model`]), one remote protocol ([`protocol`], pure, after
//! `docs/src/instruments/cs2000.md`), what its error codes mean ([`codes`]),
//! a driver ([`driver`]) over the shared [`super::link::Session`], and the
//! settings ([`Cs2000Settings`], `instruments/cs2000.toml`).
//!
//! They differ from the Photo Research units in every layer: a USB virtual
//! serial port at 115200 baud with RTS/CTS, LF-terminated commands,
//! `OK00`/`ERnn` replies, a measurement that is started, announced
//! (`OK00,<seconds>`), ended by a second `OK00` line and then read in
//! blocks, and spectra of 401 points at 1 nm as hexadecimal floats. Their
//! speed and sync settings live in the instrument's flash memory:
//! lightbooth reads them and never writes them.

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

/// One of the family.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Model {
    Cs2000,
    Cs2000A,
    Cs3000,
}

impl Model {
    pub fn name(self) -> &'static str {
        match self {
            Model::Cs2000 => "CS-2000",
            Model::Cs2000A => "CS-2000A",
            Model::Cs3000 => "CS-3000",
        }
    }

    /// `cs2000`, `cs2000a`, `cs3000` (what `--model` and the settings file say).
    pub fn flag(self) -> &'static str {
        match self {
            Model::Cs2000 => "cs2000",
            Model::Cs2000A => "cs2000a",
            Model::Cs3000 => "cs3000",
        }
    }

    /// From the name `IDDR` gives ([`protocol::Identity::model_name`]).
    pub fn from_name(name: &str) -> Option<Model> {
        [Model::Cs2000, Model::Cs2000A, Model::Cs3000]
            .into_iter()
            .find(|m| m.name().eq_ignore_ascii_case(name.trim()))
    }

    /// The variation code `IDDR` answers: 1 and 2 are specio's (257–268);
    /// the CS-3000's is not public, and the simulator's 3 is a choice.
    pub fn variation(self) -> u32 {
        match self {
            Model::Cs2000 => 1,
            Model::Cs2000A => 2,
            Model::Cs3000 => 3,
        }
    }

    /// 380–780 nm at 1 nm, every model of the family.
    pub fn grid(self) -> Grid {
        Grid::one_nm()
    }
}

/// Everything configurable about a CS-2000 session. Timeouts in ms.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct Cs2000Settings {
    /// Which of the three (from the file's `model` key).
    #[serde(skip)]
    pub model: Option<Model>,
    /// The serial device, e.g. `/dev/ttyACM0` (`--port` overrides it).
    pub port: Option<String>,
    pub samples: usize,
    pub retries: usize,
    /// First byte of the reply to an ordinary command and to the ping.
    pub command_timeout_ms: u64,
    /// A whole measurement, past its announced time: the catalogue's
    /// longest normal-mode measurement is about 243 s.
    pub measure_timeout_ms: u64,
    /// How long past the announced time to wait for the end line before
    /// asking `MEDR,0,0,1` (then every `poll_interval_ms`, as specio does).
    pub end_margin_ms: u64,
    pub poll_interval_ms: u64,
    pub gap_timeout_ms: u64,
    pub resync_quiet_ms: u64,
}

impl Default for Cs2000Settings {
    fn default() -> Cs2000Settings {
        Cs2000Settings {
            model: None,
            port: None,
            samples: 5,
            retries: 2,
            command_timeout_ms: 3_000,
            measure_timeout_ms: 300_000,
            end_margin_ms: 2_000,
            poll_interval_ms: 500,
            gap_timeout_ms: 2_000,
            resync_quiet_ms: 200,
        }
    }
}

impl Cs2000Settings {
    pub fn for_model(model: Model) -> Cs2000Settings {
        Cs2000Settings {
            model: Some(model),
            ..Cs2000Settings::default()
        }
    }

    /// Parses the file's keys (without `model`) for `model`.
    pub fn from_toml_str(text: &str, model: Model) -> Result<Cs2000Settings, String> {
        let mut s: Cs2000Settings = toml::from_str(text).map_err(|e| e.to_string())?;
        s.model = Some(model);
        s.validate()?;
        Ok(s)
    }

    pub fn model(&self) -> Model {
        self.model.unwrap_or(Model::Cs2000)
    }

    pub fn validate(&self) -> Result<(), String> {
        if !(1..=MAX_SAMPLES).contains(&self.samples) {
            return Err(format!(
                "samples = {}: lightbooth averages 1–{MAX_SAMPLES} samples per measurement",
                self.samples
            ));
        }
        if [
            self.command_timeout_ms,
            self.measure_timeout_ms,
            self.gap_timeout_ms,
            self.poll_interval_ms,
        ]
        .contains(&0)
        {
            return Err("timeouts and the poll interval must be positive".into());
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

    /// 115200 baud, 8N1, RTS/CTS, LF (specio `konica_minolta.py` 167–175, 282).
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

    pub(crate) fn timing(&self) -> SessionTiming {
        SessionTiming {
            command: Duration::from_millis(self.command_timeout_ms),
            measure: Duration::from_millis(self.measure_timeout_ms),
            gap: Duration::from_millis(self.gap_timeout_ms),
            resync_quiet: Duration::from_millis(self.resync_quiet_ms),
            measuring_after_timeout: true,
        }
    }
}

/// Opens a CS-2000 family unit on `port`: remote mode on, identification.
pub fn open_cs2000(port: &str, settings: &Cs2000Settings) -> Result<Box<dyn Spectroradiometer>, InstrumentError> {
    Ok(Box::new(driver::Cs2000::open(port, settings)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shipped_settings_file_parses_and_states_the_defaults() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../instruments/cs2000.toml");
        let settings = crate::InstrumentSettings::from_toml_file(&path).unwrap();
        let crate::InstrumentSettings::Cs2000(s) = settings else {
            panic!("cs2000.toml is not a CS-2000 file");
        };
        assert_eq!(
            s,
            Cs2000Settings {
                port: Some("/dev/ttyACM0".into()),
                ..Cs2000Settings::for_model(Model::Cs2000)
            }
        );
        assert_eq!(s.capabilities().native_grid.len(), 401);
        let e = Cs2000Settings::from_toml_str("speed = 1", Model::Cs2000).unwrap_err();
        assert!(e.contains("speed"), "{e}");
    }
}
