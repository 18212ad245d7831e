//! What the Colorimetry Research codes mean: colour-specio 0.4.1's table
//! (`colorimetry_research.py` 82–138), typed by their broad
//! [`QualityKind`], with what to do about each kind. Pure.

use crate::{QualityCode, QualityKind};

/// A reply's code with its documented meaning.
pub fn quality_code(code: i32) -> QualityCode {
    use QualityKind::*;
    let (kind, message) = match code {
        0 => (Ok, "no error"),
        100 => (LowLight, "too dark to measure"),
        101 => (Sync, "cannot sync to a constant source"),
        102 => (Sync, "cannot auto-sync"),
        103 => (Sync, "sync frequency too low"),
        -300 | -521 => (Other, "invalid sync mode"),
        -301 => (Other, "invalid sync period"),
        -302 => (Sync, "cannot sync to the light"),
        -303 => (Other, "the light intensity fluctuates"),
        -304 => (LowLight, "light intensity too low"),
        -305 => (Other, "light intensity not measurable"),
        -306 => (Overload, "light intensity too high"),
        -331 => (Hardware, "hardware malfunction"),
        -332 => (Hardware, "matrix version mismatch"),
        -333 => (Other, "invalid matrix index"),
        -334 => (Hardware, "no CIE tables"),
        -335 => (Hardware, "no colour-matching-function tables"),
        -336 => (Other, "no matrix for this id"),
        -500 => (Other, "invalid command"),
        -505 => (Other, "duplicate filter selection"),
        -506 => (Other, "no accessory for this index"),
        -507 => (Other, "no filter for this index"),
        -508 => (Other, "the index is not a valid accessory"),
        -511..=-509 => (Other, "the index is not a valid filter"),
        -512 => (Other, "invalid range mode"),
        -513 => (Other, "invalid range index"),
        -514 => (Other, "invalid exposure multiplier"),
        -515 => (Other, "the index does not select an aperture"),
        -518 => (Other, "invalid exposure mode"),
        -519 => (Other, "invalid exposure value"),
        -522 => (Other, "invalid sync frequency"),
        -552 => (Other, "invalid matrix mode"),
        -553 => (Other, "invalid matrix id"),
        -555 => (Other, "invalid matrix name"),
        -559 => (Hardware, "error saving the matrix to flash"),
        -560 => (Other, "invalid user-calibration mode"),
        _ => (Unknown, "not in the Colorimetry Research code table"),
    };
    QualityCode {
        code,
        kind,
        message: message.into(),
    }
}

/// What the operator should do about a series that failed with this kind of code.
pub fn quality_hint(kind: QualityKind) -> &'static str {
    match kind {
        QualityKind::Ok => "",
        QualityKind::LowLight => "Aim at a brighter target, or use a slower speed (speed = 0) for a longer exposure",
        QualityKind::Overload => "Too much light: fit an ND accessory or move further from the source",
        QualityKind::Sync => "Check the source flickers steadily, or measure without sync",
        QualityKind::Hardware => "Power-cycle the instrument and re-plug its USB cable; if it persists, call the maker",
        QualityKind::Other | QualityKind::Unknown => "Check that the source is steady and measure again",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_light_level_codes_carry_their_meaning() {
        assert_eq!(quality_code(100).kind, QualityKind::LowLight);
        assert_eq!(quality_code(-304).kind, QualityKind::LowLight);
        assert_eq!(quality_code(-306).kind, QualityKind::Overload);
        assert!(quality_code(-303).message.contains("fluctuates"));
        assert_eq!(quality_code(102).kind, QualityKind::Sync);
        assert!(quality_code(-500).message.contains("invalid command"));
        assert_eq!(quality_code(-4242).kind, QualityKind::Unknown);
        assert!(quality_hint(QualityKind::Overload).contains("ND"));
    }
}
