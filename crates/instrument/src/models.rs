//! The instrument models lightbooth drives, and how a daemon or a command
//! opens the one its settings file names.
//!
//! A settings file (`instruments/pr650.toml`) may say `model = "pr650"`;
//! without the key it is a PR-650 file, as every file written before the key
//! existed. The rest of the file is the model's own settings, checked
//! strictly (an unknown key is an error naming it).
//!
//! ```
//! use lightbooth_instrument::InstrumentSettings;
//! let settings = InstrumentSettings::from_toml_str("model = \"pr650\"\nsamples = 3").unwrap();
//! assert_eq!(settings.capabilities().model, "PR-650");
//! assert_eq!(settings.capabilities().default_samples, 3);
//! ```

use std::path::Path;

use super::colorcal::ColorCalSettings;
use super::cr250::{self, Cr250Settings};
use super::cs2000::{self, Cs2000Settings};
use super::ls100::Ls100Settings;
use super::pr655::{Model, Pr655Settings};
use super::{Capabilities, InstrumentError, Pr650Settings, Spectroradiometer};

/// The native grid of a spectrum from an instrument lightbooth drives, by
/// its length: 101 points at 4 nm from 380 nm (the PR-650 and the PR-655),
/// 201 at 2 nm (the PR-670) or 401 at 1 nm (the CS-2000 family). Those
/// grids differ in length, so the length of a stored sample names its grid
/// exactly.
pub fn native_grid_of_length(len: usize) -> Option<lightbooth_science::spectrum::Grid> {
    use super::pr655::Model;
    [
        lightbooth_science::spectrum::Grid::pr650(),
        Model::Pr655.grid(),
        Model::Pr670.grid(),
        cs2000::Model::Cs2000.grid(),
    ]
    .into_iter()
    .find(|g| g.len() == len)
}

/// Every model lightbooth drives, as `--model` and a settings file's `model` key name it.
pub const MODEL_FLAGS: &[&str] = &[
    "pr650", "pr655", "pr670", "cs2000", "cs2000a", "cs3000", "cr250", "cr300", "colorcal", "ls100", "cs100a",
];

/// What the model stored as `name` (`PR-650`, `ColorCAL MkII`, `LS-100`, …)
/// reads: a spectrum, XYZ in an observer, or a luminance. `None` for a name
/// no model lightbooth drives has.
pub fn reading_of_model(name: &str) -> Option<super::Reading> {
    MODEL_FLAGS
        .iter()
        .filter_map(|flag| InstrumentSettings::defaults_for(flag).ok())
        .map(|s| s.capabilities())
        .find(|c| c.model == name)
        .map(|c| c.reading)
}

/// The settings of one instrument, by model.
#[derive(Clone, Debug, PartialEq)]
pub enum InstrumentSettings {
    Pr650(Pr650Settings),
    /// A PR-655 or a PR-670 (the model is in the settings).
    Pr655(Pr655Settings),
    /// A CS-2000, CS-2000A or CS-3000 (the model is in the settings).
    Cs2000(Cs2000Settings),
    /// A CR-250 or CR-300 (the model is in the settings).
    Cr250(Cr250Settings),
    /// A CRS ColorCAL MkII colorimeter.
    ColorCal(ColorCalSettings),
    /// A Konica Minolta LS-100 or CS-100A (the model is in the settings).
    Ls100(Ls100Settings),
}

impl Default for InstrumentSettings {
    fn default() -> InstrumentSettings {
        InstrumentSettings::Pr650(Pr650Settings::default())
    }
}

impl InstrumentSettings {
    /// Reads a settings file; errors name the file.
    pub fn from_toml_file(path: &Path) -> Result<InstrumentSettings, InstrumentError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| InstrumentError::Settings(format!("cannot read {}: {e}", path.display())))?;
        InstrumentSettings::from_toml_str(&text)
            .map_err(|e| InstrumentError::Settings(format!("{}: {e}", path.display())))
    }

    pub fn from_toml_str(text: &str) -> Result<InstrumentSettings, String> {
        let mut table: toml::Table = toml::from_str(text).map_err(|e| e.to_string())?;
        let model = match table.remove("model") {
            None => "pr650".to_string(),
            Some(toml::Value::String(m)) => m,
            Some(other) => {
                return Err(format!(
                    "key `model`: expected a string such as \"pr650\", found {other}"
                ))
            }
        };
        let rest = toml::to_string(&table).map_err(|e| e.to_string())?;
        match model.to_ascii_lowercase().replace('-', "").as_str() {
            "pr650" => Pr650Settings::from_toml_str(&rest).map(InstrumentSettings::Pr650),
            "pr655" => Pr655Settings::from_toml_str(&rest, Model::Pr655).map(InstrumentSettings::Pr655),
            "pr670" => Pr655Settings::from_toml_str(&rest, Model::Pr670).map(InstrumentSettings::Pr655),
            "cs2000" => Cs2000Settings::from_toml_str(&rest, cs2000::Model::Cs2000).map(InstrumentSettings::Cs2000),
            "cs2000a" => Cs2000Settings::from_toml_str(&rest, cs2000::Model::Cs2000A).map(InstrumentSettings::Cs2000),
            "cs3000" => Cs2000Settings::from_toml_str(&rest, cs2000::Model::Cs3000).map(InstrumentSettings::Cs2000),
            "cr250" => Cr250Settings::from_toml_str(&rest, cr250::Model::Cr250).map(InstrumentSettings::Cr250),
            "cr300" => Cr250Settings::from_toml_str(&rest, cr250::Model::Cr300).map(InstrumentSettings::Cr250),
            "colorcal" | "colorcalmkii" => ColorCalSettings::from_toml_str(&rest).map(InstrumentSettings::ColorCal),
            "ls100" => Ls100Settings::from_toml_str(&rest, super::ls100::Model::Ls100).map(InstrumentSettings::Ls100),
            "cs100a" => Ls100Settings::from_toml_str(&rest, super::ls100::Model::Cs100a).map(InstrumentSettings::Ls100),
            _ => Err(format!(
                "key `model`: \"{model}\" is not a model lightbooth drives; use one of {}",
                MODEL_FLAGS.join(", ")
            )),
        }
    }

    /// The defaults of a model named as on the command line (`pr650`,
    /// `pr655`, `pr670`, `cs2000`, `colorcal`, …; `PR-670` too).
    pub fn defaults_for(model: &str) -> Result<InstrumentSettings, String> {
        InstrumentSettings::from_toml_str(&format!("model = \"{}\"", model.escape_default()))
    }

    /// The simulated instrument that stands in for this model (`--mock`).
    pub fn simulated_personality(&self) -> super::sim::Personality {
        match self {
            InstrumentSettings::Pr650(_) => super::sim::Personality::Pr650,
            InstrumentSettings::Pr655(s) => {
                super::sim::Personality::Pr655(super::sim::Pr655Switches::for_model(s.model()))
            }
            InstrumentSettings::Cs2000(s) => super::sim::Personality::Cs2000(s.model()),
            InstrumentSettings::Cr250(s) => super::sim::Personality::Cr250(s.model()),
            InstrumentSettings::ColorCal(_) => super::sim::Personality::ColorCal,
            InstrumentSettings::Ls100(s) => super::sim::Personality::Ls100(s.model()),
        }
    }

    /// What the model can do, with this file's samples and retries.
    pub fn capabilities(&self) -> Capabilities {
        match self {
            InstrumentSettings::Pr650(s) => s.capabilities(),
            InstrumentSettings::Pr655(s) => s.capabilities(),
            InstrumentSettings::Cs2000(s) => s.capabilities(),
            InstrumentSettings::Cr250(s) => s.capabilities(),
            InstrumentSettings::ColorCal(s) => s.capabilities(),
            InstrumentSettings::Ls100(s) => s.capabilities(),
        }
    }

    /// The serial device the file names, if any.
    pub fn port(&self) -> Option<&str> {
        match self {
            InstrumentSettings::Pr650(s) => s.port.as_deref(),
            InstrumentSettings::Pr655(s) => s.port.as_deref(),
            InstrumentSettings::Cs2000(s) => s.port.as_deref(),
            InstrumentSettings::Cr250(s) => s.port.as_deref(),
            InstrumentSettings::ColorCal(s) => s.port.as_deref(),
            InstrumentSettings::Ls100(s) => s.port.as_deref(),
        }
    }

    /// Sets the serial device (what `serve --instrument auto` found).
    pub fn set_port(&mut self, port: String) {
        let slot = match self {
            InstrumentSettings::Pr650(s) => &mut s.port,
            InstrumentSettings::Pr655(s) => &mut s.port,
            InstrumentSettings::Cs2000(s) => &mut s.port,
            InstrumentSettings::Cr250(s) => &mut s.port,
            InstrumentSettings::ColorCal(s) => &mut s.port,
            InstrumentSettings::Ls100(s) => &mut s.port,
        };
        *slot = Some(port);
    }

    /// Overrides the file's samples per measurement and extra attempts.
    pub fn set_samples(&mut self, samples: Option<usize>, retries: Option<usize>) {
        let (s, r) = match self {
            InstrumentSettings::Pr650(s) => (&mut s.samples, &mut s.retries),
            InstrumentSettings::Pr655(s) => (&mut s.samples, &mut s.retries),
            InstrumentSettings::Cs2000(s) => (&mut s.samples, &mut s.retries),
            InstrumentSettings::Cr250(s) => (&mut s.samples, &mut s.retries),
            InstrumentSettings::ColorCal(s) => (&mut s.samples, &mut s.retries),
            InstrumentSettings::Ls100(s) => (&mut s.samples, &mut s.retries),
        };
        if let Some(n) = samples {
            *s = n;
        }
        if let Some(n) = retries {
            *r = n;
        }
    }

    /// Checks the settings against what the model accepts.
    pub fn validate(&self) -> Result<(), String> {
        match self {
            InstrumentSettings::Pr650(s) => s.validate(),
            InstrumentSettings::Pr655(s) => s.validate(),
            InstrumentSettings::Cs2000(s) => s.validate(),
            InstrumentSettings::Cr250(s) => s.validate(),
            InstrumentSettings::ColorCal(s) => s.validate(),
            InstrumentSettings::Ls100(s) => s.validate(),
        }
    }

    /// Opens the instrument on `port`: whatever the model needs before it
    /// can take a sample (remote mode, setup, identification).
    pub fn open(&self, port: &str) -> Result<Box<dyn Spectroradiometer>, InstrumentError> {
        match self {
            InstrumentSettings::Pr650(s) => super::open_pr650(port, s),
            InstrumentSettings::Pr655(s) => super::pr655::open_pr655(port, s),
            InstrumentSettings::Cs2000(s) => cs2000::open_cs2000(port, s),
            InstrumentSettings::Cr250(s) => cr250::open_cr250(port, s),
            InstrumentSettings::ColorCal(s) => super::colorcal::open_colorcal(port, s),
            InstrumentSettings::Ls100(s) => super::ls100::open_ls100(port, s),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_without_a_model_is_a_pr650_file() {
        let s = InstrumentSettings::from_toml_str("samples = 7").unwrap();
        assert_eq!(
            s,
            InstrumentSettings::Pr650(Pr650Settings {
                samples: 7,
                ..Pr650Settings::default()
            })
        );
    }

    #[test]
    fn an_unknown_model_or_key_is_named() {
        let e = InstrumentSettings::from_toml_str("model = \"pr999\"").unwrap_err();
        assert!(e.contains("pr999") && e.contains("pr670"), "{e}");
        let e = InstrumentSettings::from_toml_str("model = \"pr650\"\nsamplez = 3").unwrap_err();
        assert!(e.contains("samplez"), "{e}");
    }

    #[test]
    fn samples_beyond_the_models_limit_are_refused() {
        let e = InstrumentSettings::from_toml_str("samples = 100").unwrap_err();
        assert!(e.contains("99"), "{e}");
    }
}
