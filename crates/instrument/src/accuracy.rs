//! Each model's accuracy as its manufacturer states it, with the source:
//! the one table [`Capabilities::stated_accuracy`](crate::Capabilities)
//! reads, and what `lightbooth_science::uncertainty` propagates.
//!
//! A figure is set only where a source was found that states it; every
//! other figure is `None`, and the entry's `source` says what was searched
//! and not found. None is ever filled in from memory, a reseller's page or
//! another model. The searches (2026-12) covered the stored documentation,
//! web pages and public code corpora available to this project, with
//! queries such as "PR-650 SpectraScan specifications luminance accuracy",
//! "PR-655 PR-670 specifications accuracy", "CS-2000 specifications luminance
//! accuracy chromaticity", "CR-250 specifications", "ColorCAL MkII accuracy"
//! and "LS-100 luminance meter accuracy specifications", and the protocol
//! notes of the drivers (their spectral-configuration replies carry a
//! bandwidth field whose meaning is undocumented, so it is not used here).
//! They found the PR-655/670 user manual's remote-mode chapters and the
//! CS-2000 communication specification (KMSE-TI-08002), which give no
//! accuracy table, and no manufacturer's data sheet for any model.
//!
//! The one figure set is secondary: Ruppertsberg & Bloj (2006), who measured
//! their scenes with a PR-650, give "the measuring accuracy of the
//! spectroradiometer (4 %)"; it is read as ±4 % of luminance, its conditions
//! unstated. Replace it, and fill the rest, from the data sheets when they
//! are at hand (title, publisher, URL or document number in `source`).

use std::borrow::Cow;

use lightbooth_science::uncertainty::StatedAccuracy;

/// What an entry without figures says: nothing found, nothing guessed.
const NOT_FOUND: &str = "Not found: no data sheet or manual stating this model's accuracy was found in the \
     sources searched (see lightbooth_instrument::accuracy); every figure is left unset";

/// The PR-650's luminance accuracy, from the study lightbooth reproduces.
const PR650: StatedAccuracy = StatedAccuracy {
    luminance_bound_percent: Some(4.0),
    luminance_conditions: None,
    chromaticity_bound_x: None,
    chromaticity_bound_y: None,
    chromaticity_conditions: None,
    wavelength_bound_nm: None,
    bandwidth_fwhm_nm: None,
    luminance_repeatability_percent: None,
    source: Cow::Borrowed(
        "Secondary source: A. I. Ruppertsberg and M. Bloj, \"Rendering complex scenes for psychophysics \
         using RADIANCE: How accurate can you get?\", J. Opt. Soc. Am. A 23(4), 759-768 (2006), Optica \
         Publishing Group, http://www.opticsinfobase.org/vjbo/abstract.cfm?uri=josaa-23-4-759: \"the \
         measuring accuracy of the spectroradiometer (4 %)\" of the PR-650 they used, read as +/-4 % of \
         luminance; its illuminant and level are not stated there. Photo Research's PR-650 SpectraScan \
         data sheet was not found; its other figures are left unset",
    ),
};

/// Every model lightbooth drives, by the name its capabilities give, with
/// its stated accuracy.
const TABLE: &[(&str, StatedAccuracy)] = &[
    ("PR-650", PR650),
    ("PR-655", StatedAccuracy::unstated(NOT_FOUND)),
    ("PR-670", StatedAccuracy::unstated(NOT_FOUND)),
    ("CS-2000", StatedAccuracy::unstated(NOT_FOUND)),
    ("CS-2000A", StatedAccuracy::unstated(NOT_FOUND)),
    ("CS-3000", StatedAccuracy::unstated(NOT_FOUND)),
    ("CR-250", StatedAccuracy::unstated(NOT_FOUND)),
    ("CR-300", StatedAccuracy::unstated(NOT_FOUND)),
    ("ColorCAL MkII", StatedAccuracy::unstated(NOT_FOUND)),
    ("LS-100", StatedAccuracy::unstated(NOT_FOUND)),
    ("CS-100A", StatedAccuracy::unstated(NOT_FOUND)),
];

/// The stated accuracy of the model named `model` ("PR-650", "CS-2000A",
/// …). A name without an entry gets no figures and a source saying so.
pub fn stated_accuracy_of(model: &str) -> StatedAccuracy {
    TABLE
        .iter()
        .find(|(name, _)| *name == model)
        .map(|(_, accuracy)| accuracy.clone())
        .unwrap_or_else(|| StatedAccuracy {
            source: Cow::Owned(format!(
                "no entry for the model \"{model}\" in lightbooth's accuracy table"
            )),
            ..StatedAccuracy::unstated("")
        })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{InstrumentSettings, MODEL_FLAGS};

    /// Every model lightbooth drives has an entry, reached through its capabilities.
    #[test]
    fn every_model_has_an_entry() {
        for flag in MODEL_FLAGS {
            let capabilities = InstrumentSettings::defaults_for(flag).unwrap().capabilities();
            assert!(
                TABLE.iter().any(|(name, _)| *name == capabilities.model),
                "{flag}: no entry for {}",
                capabilities.model
            );
            assert_eq!(capabilities.stated_accuracy, stated_accuracy_of(capabilities.model));
        }
        assert_eq!(
            TABLE.len(),
            MODEL_FLAGS.len(),
            "an entry for a model lightbooth does not drive"
        );
    }

    /// Every entry names a source; an entry with a figure cites one (not
    /// the "not found" text), and its figures are finite and not negative.
    #[test]
    fn each_set_figure_has_a_source() {
        for (model, accuracy) in TABLE {
            assert!(!accuracy.source.trim().is_empty(), "{model}: no source");
            accuracy.validate().unwrap();
            if accuracy.has_any_figure() {
                assert!(
                    !accuracy.source.starts_with("Not found"),
                    "{model}: a figure without a source"
                );
                assert!(accuracy.source.contains("http"), "{model}: the source gives no address");
            } else {
                assert_eq!(accuracy.source, NOT_FOUND, "{model}");
            }
        }
        assert!(stated_accuracy_of("PR-999").source.contains("PR-999"));
        assert!(!stated_accuracy_of("PR-999").has_any_figure());
    }
}
