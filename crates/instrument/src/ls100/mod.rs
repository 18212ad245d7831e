//! The Konica Minolta LS-100 luminance meter and CS-100A chroma meter: one
//! serial protocol ([`protocol`], pure), what their status words mean
//! ([`codes`]), one driver over the shared [`super::link::Session`]
//! ([`driver`]) and their settings ([`Ls100Settings`], the file
//! `instruments/ls100.toml`; `model = "cs100a"` for the CS-100A).
//!
//! RS-232 at 4800 baud, 7 data bits, even parity, 2 stop bits, CR LF both
//! ways (psychopy-minolta `psychopy_minolta/minolta.py:137-141`,
//! `:243-248`). The meter must be switched on with F held to talk
//! (mi.py:27-29). It has no identity query: the driver takes a unit that
//! answers the harmless `MDS,04` (absolute mode, what PsychoPy sends on
//! opening, mi.py:151-164) with `OK` to be the model the settings name, and
//! a measurement with the other model's fields is an error naming it.
//! Protocol notes with sources: `docs/src/instruments/ls100.md`.

pub mod codes;
pub mod driver;
pub mod protocol;

use std::time::Duration;

use serde::Deserialize;

use super::link::{Framing, LinkSettings, SessionTiming, Terminator};
use super::{Capabilities, InstrumentError, Reading, Spectroradiometer};
use lightbooth_science::colorimetry::Observer;

/// Most samples one averaged measurement takes.
pub const MAX_SAMPLES: usize = 99;

/// Which of the two meters.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Model {
    /// LS-100: luminance only.
    Ls100,
    /// CS-100A: luminance and chromaticity x, y.
    Cs100a,
}

impl Model {
    pub fn name(self) -> &'static str {
        match self {
            Model::Ls100 => "LS-100",
            Model::Cs100a => "CS-100A",
        }
    }

    /// What a good sample carries: the LS-100's luminance, the CS-100A's
    /// XYZ (from its Y, x, y), both in the CIE 1931 2° observer their
    /// filters approximate.
    pub fn reading(self) -> Reading {
        match self {
            Model::Ls100 => Reading::Luminance {
                observer: Observer::Cie1931,
            },
            Model::Cs100a => Reading::Tristimulus {
                observer: Observer::Cie1931,
            },
        }
    }
}

/// Everything configurable about an LS-100/CS-100A session (timeouts in
/// ms), from `instruments/ls100.toml`; the `model` key is read by
/// [`super::InstrumentSettings`]; every other field has a default.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct Ls100Settings {
    /// Which of the two (from the file's `model` key).
    #[serde(skip)]
    pub model: Option<Model>,
    /// The serial device, e.g. `/dev/ttyUSB0` (`--port` overrides it).
    pub port: Option<String>,
    /// Samples per averaged measurement.
    pub samples: usize,
    /// Extra attempts allowed over the whole series.
    pub retries: usize,
    /// First byte of the reply to `MDS` and to the resynchronisation ping.
    pub command_timeout_ms: u64,
    /// First byte of the reply to `MES` (PsychoPy waits 5 s, mi.py:235).
    pub measure_timeout_ms: u64,
    /// Longest silence inside a reply before it counts as cut off.
    pub gap_timeout_ms: u64,
    /// Quiet time that ends a resynchronisation after a fault.
    pub resync_quiet_ms: u64,
    /// `MDS,04` tries on opening before telling the operator to switch
    /// the meter on with F held (PsychoPy tries 10 times, mi.py:154).
    pub handshake_attempts: u32,
}

impl Default for Ls100Settings {
    fn default() -> Ls100Settings {
        Ls100Settings {
            model: None,
            port: None,
            samples: 5,
            retries: 2,
            command_timeout_ms: 2_000,
            measure_timeout_ms: 10_000,
            gap_timeout_ms: 1_000,
            resync_quiet_ms: 300,
            handshake_attempts: 3,
        }
    }
}

impl Ls100Settings {
    /// The defaults for `model`.
    pub fn for_model(model: Model) -> Ls100Settings {
        Ls100Settings {
            model: Some(model),
            ..Ls100Settings::default()
        }
    }

    /// Parses the file's keys (without `model`) for `model`.
    pub fn from_toml_str(text: &str, model: Model) -> Result<Ls100Settings, String> {
        let mut s: Ls100Settings = toml::from_str(text).map_err(|e| e.to_string())?;
        s.model = Some(model);
        s.validate()?;
        Ok(s)
    }

    pub fn model(&self) -> Model {
        self.model.unwrap_or(Model::Ls100)
    }

    /// Ranges common sense requires.
    pub fn validate(&self) -> Result<(), String> {
        if !(1..=MAX_SAMPLES).contains(&self.samples) {
            return Err(format!(
                "samples = {}: the {} averages 1–{MAX_SAMPLES} samples per measurement",
                self.samples,
                self.model().name()
            ));
        }
        if self.handshake_attempts == 0 {
            return Err("handshake_attempts must be at least 1".into());
        }
        if self.command_timeout_ms == 0 || self.measure_timeout_ms == 0 || self.gap_timeout_ms == 0 {
            return Err("timeouts must be positive".into());
        }
        Ok(())
    }

    /// What the model can do, with these settings' samples and retries.
    pub fn capabilities(&self) -> Capabilities {
        let model = self.model();
        Capabilities {
            model: model.name(),
            reading: model.reading(),
            // No spectra: the grid is only a placeholder the identity carries.
            native_grid: lightbooth_science::spectrum::Grid::pr650(),
            max_samples: MAX_SAMPLES,
            default_samples: self.samples,
            retries: self.retries,
            stated_accuracy: crate::accuracy::stated_accuracy_of(model.name()),
        }
    }

    /// 4800 baud, 7E2, CR LF (mi.py:137-141, 243-248). On a pseudo-terminal
    /// (a simulator) the link falls back to 8N2 with a logged warning.
    pub(crate) fn link(&self) -> LinkSettings {
        LinkSettings {
            baud: 4800,
            terminator: Terminator::Crlf,
            write_timeout_ms: self.command_timeout_ms.min(5_000),
            byte_delay_ms: 0,
            framing: Framing::SEVEN_E_TWO,
            flow_control: false,
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

/// Opens an LS-100 or CS-100A on `port`: the `MDS,04` handshake.
pub fn open_ls100(port: &str, settings: &Ls100Settings) -> Result<Box<dyn Spectroradiometer>, InstrumentError> {
    Ok(Box::new(driver::Ls100::open(port, settings)?))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    #[test]
    fn the_shipped_settings_file_parses_and_states_the_defaults() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../instruments/ls100.toml");
        let settings = crate::InstrumentSettings::from_toml_file(&path).unwrap();
        let crate::InstrumentSettings::Ls100(s) = settings else {
            panic!("ls100.toml is not an LS-100 file");
        };
        assert_eq!(
            s,
            Ls100Settings {
                port: Some("/dev/ttyUSB0".into()),
                ..Ls100Settings::for_model(Model::Ls100)
            }
        );
    }

    #[test]
    fn the_models_read_what_their_filters_give() {
        let cs = Ls100Settings::from_toml_str("samples = 3", Model::Cs100a).unwrap();
        assert_eq!(cs.capabilities().model, "CS-100A");
        assert!(matches!(cs.capabilities().reading, Reading::Tristimulus { .. }));
        let ls = Ls100Settings::for_model(Model::Ls100);
        assert!(matches!(ls.capabilities().reading, Reading::Luminance { .. }));
        assert_eq!(ls.link().baud, 4800);
        assert_eq!(ls.link().framing, Framing::SEVEN_E_TWO);
        let e = Ls100Settings::from_toml_str("samples = 100", Model::Ls100).unwrap_err();
        assert!(e.contains("LS-100") && e.contains("1–99"), "{e}");
    }
}
