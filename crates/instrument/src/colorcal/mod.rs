//! The CRS ColorCAL MkII colorimeter: its serial protocol ([`protocol`],
//! pure), what its status words mean ([`codes`]), a driver over the shared
//! [`super::link::Session`] ([`driver`]) and its settings
//! ([`ColorCalSettings`], the file `instruments/colorcal.toml`).
//!
//! A USB CDC device (`/dev/ttyACM0`) at any baud rate (psychopy-crs
//! `psychopy_crs/colorcal.py:95-102`). It measures XYZ through three
//! filters that approximate the CIE 1931 2° matching functions, corrected by
//! a 3×3 matrix stored in the unit: a [`Reading::Tristimulus`] in
//! [`Observer::Cie1931`], with no spectrum. Protocol notes with their
//! sources: `docs/src/instruments/colorcal.md`.

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

/// The model's name as lightbooth reports it.
pub const MODEL_NAME: &str = "ColorCAL MkII";

/// What a ColorCAL measures: XYZ in the CIE 1931 2° observer its filters approximate.
pub const READING: Reading = Reading::Tristimulus {
    observer: Observer::Cie1931,
};

/// Everything configurable about a ColorCAL session (timeouts in ms), from
/// `instruments/colorcal.toml`; every field has a default.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct ColorCalSettings {
    /// The serial device, e.g. `/dev/ttyACM0` (`--port` overrides it).
    pub port: Option<String>,
    /// Samples per averaged measurement.
    pub samples: usize,
    /// Extra attempts allowed over the whole series.
    pub retries: usize,
    /// First byte of the reply to `IDR`, `r0n`, `UZC` and the resync ping.
    pub command_timeout_ms: u64,
    /// First byte of the reply to `MES` (PsychoPy allows 5 s, cc.py:170).
    pub measure_timeout_ms: u64,
    /// Longest silence inside a reply before it counts as cut off.
    pub gap_timeout_ms: u64,
    /// Quiet time that ends a resynchronisation after a fault.
    pub resync_quiet_ms: u64,
    /// Send `UZC` (zero calibration) on opening. The sensor must then be
    /// covered; the unit refuses with `ER11` otherwise. Units with firmware
    /// build 877 or later keep a factory zero (cc.py:220-236).
    pub zero_calibrate: bool,
}

impl Default for ColorCalSettings {
    fn default() -> ColorCalSettings {
        ColorCalSettings {
            port: None,
            samples: 5,
            retries: 2,
            command_timeout_ms: 1_000,
            measure_timeout_ms: 5_000,
            gap_timeout_ms: 500,
            resync_quiet_ms: 200,
            zero_calibrate: false,
        }
    }
}

impl ColorCalSettings {
    pub fn from_toml_str(text: &str) -> Result<ColorCalSettings, String> {
        let s: ColorCalSettings = toml::from_str(text).map_err(|e| e.to_string())?;
        s.validate()?;
        Ok(s)
    }

    /// Ranges common sense requires.
    pub fn validate(&self) -> Result<(), String> {
        if !(1..=MAX_SAMPLES).contains(&self.samples) {
            return Err(format!(
                "samples = {}: the {MODEL_NAME} averages 1–{MAX_SAMPLES} samples per measurement",
                self.samples
            ));
        }
        if self.command_timeout_ms == 0 || self.measure_timeout_ms == 0 || self.gap_timeout_ms == 0 {
            return Err("timeouts must be positive".into());
        }
        Ok(())
    }

    /// What the model can do, with these settings' samples and retries.
    pub fn capabilities(&self) -> Capabilities {
        Capabilities {
            model: MODEL_NAME,
            reading: READING,
            // No spectra: the grid is only a placeholder the identity carries.
            native_grid: lightbooth_science::spectrum::Grid::pr650(),
            max_samples: MAX_SAMPLES,
            default_samples: self.samples,
            retries: self.retries,
            stated_accuracy: crate::accuracy::stated_accuracy_of(MODEL_NAME),
        }
    }

    /// USB CDC: the baud rate is ignored by the unit; 115200 as PsychoPy
    /// sets it (cc.py:99), 8N1, LF-terminated commands (cc.py:127-128).
    pub(crate) fn link(&self) -> LinkSettings {
        LinkSettings {
            baud: 115_200,
            terminator: Terminator::Lf,
            write_timeout_ms: self.command_timeout_ms.min(5_000),
            byte_delay_ms: 0,
            framing: Framing::EIGHT_N_ONE,
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

/// Opens a ColorCAL MkII on `port`: identification and its matrix.
pub fn open_colorcal(port: &str, settings: &ColorCalSettings) -> Result<Box<dyn Spectroradiometer>, InstrumentError> {
    Ok(Box::new(driver::ColorCal::open(port, settings)?))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    #[test]
    fn the_shipped_settings_file_parses_and_states_the_defaults() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../instruments/colorcal.toml");
        let settings = crate::InstrumentSettings::from_toml_file(&path).unwrap();
        let crate::InstrumentSettings::ColorCal(s) = settings else {
            panic!("colorcal.toml is not a ColorCAL file");
        };
        assert_eq!(
            s,
            ColorCalSettings {
                port: Some("/dev/ttyACM0".into()),
                ..ColorCalSettings::default()
            }
        );
    }

    #[test]
    fn bad_settings_say_what_is_wrong() {
        let e = ColorCalSettings::from_toml_str("samples = 0").unwrap_err();
        assert!(e.contains("1–99"), "{e}");
        let e = ColorCalSettings::from_toml_str("spectrum = true").unwrap_err();
        assert!(e.contains("spectrum"), "{e}");
    }
}
