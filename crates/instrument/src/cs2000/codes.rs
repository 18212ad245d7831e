//! What the CS-2000 family's `ERnn` codes mean, typed by their broad
//! [`QualityKind`], and what the operator should do about each kind. The
//! table is colour-specio 0.4.1's (`konica_minolta.py` 34–50, the codes it
//! names from the manufacturer's communication specification); pure.

use crate::{QualityCode, QualityKind};

/// An `ERnn` code (0 for `OK00`) with its documented meaning.
pub fn quality_code(code: u8) -> QualityCode {
    use QualityKind::*;
    let (kind, message) = match code {
        0 => (Ok, "no error"),
        2 => (Other, "measurement not ready yet"),
        10 => (
            Overload,
            "over range: the radiance is too high for the measurement mode",
        ),
        17 => (
            Other,
            "parameter error: the command's parameters could not be interpreted",
        ),
        51 | 52 => (Hardware, "instrument temperature abnormal"),
        71 => (Sync, "could not synchronise to the light source's flicker"),
        83 => (
            Other,
            "measurement area abnormal: the target does not fill the measuring spot",
        ),
        _ => (Unknown, "not in the CS-2000's documented error codes"),
    };
    QualityCode {
        code: i32::from(code),
        kind,
        message: message.into(),
    }
}

/// The meaning of a command error (`ER00`, `ER17`), for a refused command.
pub fn command_error(code: u8) -> QualityCode {
    match code {
        0 => QualityCode {
            code: 0,
            kind: QualityKind::Other,
            message: "the command could not be interpreted (ER00)".into(),
        },
        other => quality_code(other),
    }
}

/// What the operator should do about a series that failed with this kind of code.
pub fn quality_hint(kind: QualityKind) -> &'static str {
    match kind {
        QualityKind::Ok => "",
        QualityKind::LowLight => "Aim at a brighter target or use a longer integration (the instrument's speed mode)",
        QualityKind::Overload => {
            "Too much light for the measurement mode: fit the ND filter or choose a faster speed mode on the instrument"
        }
        QualityKind::Sync => {
            "Check the source flickers steadily, or turn sync off on the instrument (sync is kept in its flash)"
        }
        QualityKind::Hardware => {
            "Let the instrument reach its operating temperature (or cool down), then measure again"
        }
        QualityKind::Other | QualityKind::Unknown => {
            "Check that the target fills the measuring spot in the viewfinder, then measure again"
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_documented_code_has_its_meaning() {
        for (code, kind, words) in [
            (10, QualityKind::Overload, "too high"),
            (51, QualityKind::Hardware, "temperature"),
            (52, QualityKind::Hardware, "temperature"),
            (71, QualityKind::Sync, "flicker"),
            (83, QualityKind::Other, "measuring spot"),
            (2, QualityKind::Other, "not ready"),
            (17, QualityKind::Other, "parameter"),
        ] {
            let q = quality_code(code);
            assert_eq!((q.code, q.kind), (i32::from(code), kind), "ER{code:02}");
            assert!(q.message.contains(words), "ER{code:02}: {}", q.message);
        }
        assert!(command_error(0).message.contains("ER00"));
        assert_eq!(quality_code(99).kind, QualityKind::Unknown);
        assert!(quality_hint(QualityKind::Overload).contains("ND"));
    }
}
