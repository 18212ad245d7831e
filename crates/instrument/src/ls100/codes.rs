//! What the LS-100 / CS-100A status words mean, typed by their broad
//! [`QualityKind`], and what the operator should do about each kind. Pure
//! tables.
//!
//! Meanings: psychopy-minolta 0.0.2 `psychopy_minolta/minolta.py:114-121`
//! (and :371-378), the same table in the public CS-100A script KMpy; `OK11`,
//! `OK12` and `OK13` are range warnings there, with no more said. Codes
//! follow [`StatusWord::code`]: `OKnn` → nn, `ERnn` → 100 + nn.
//!
//! lightbooth does not average a sample with a range warning: the meter
//! sent a value it flags, and the public sources do not say which limit it
//! crossed.

use crate::status_word::StatusWord;
use crate::{QualityCode, QualityKind};

/// A status word with its documented meaning; any other is
/// [`QualityKind::Unknown`], the word kept.
pub fn quality_code(status: StatusWord) -> QualityCode {
    use QualityKind::*;
    let (kind, meaning) = match status {
        StatusWord::Ok(0) => (Ok, "no error"),
        StatusWord::Ok(11..=13) => (
            Other,
            "range warning: the value is sent but flagged (the public sources do not say which limit)",
        ),
        StatusWord::Er(0) => (Other, "unknown command"),
        StatusWord::Er(1) => (Other, "setting error"),
        StatusWord::Er(10) => (Overload, "measuring range over"),
        StatusWord::Er(11) => (Other, "memory value error"),
        StatusWord::Er(19) => (Overload, "display range over"),
        StatusWord::Er(20) => (Hardware, "EEPROM error (the photometer needs repair)"),
        StatusWord::Er(30) => (Hardware, "battery exhausted"),
        _ => (Unknown, "not in the LS-100/CS-100A status table"),
    };
    QualityCode {
        code: status.code(),
        kind,
        message: format!("{status}: {meaning}"),
    }
}

/// What the operator should do about a series that failed with this kind of status.
pub fn quality_hint(kind: QualityKind) -> &'static str {
    match kind {
        QualityKind::Ok => "",
        QualityKind::Overload => "The target is outside the meter's range: measure a dimmer target or check the range",
        QualityKind::Hardware => "Replace the meter's battery; an EEPROM error needs a repair by Konica Minolta",
        QualityKind::LowLight => "Aim at a brighter target",
        QualityKind::Sync | QualityKind::Other | QualityKind::Unknown => {
            "Measure again; if it persists, switch the meter off and on again with F held (communication mode)"
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every code of the table (mi.py:114-121) with its meaning and kind.
    #[test]
    fn every_documented_code_has_its_meaning() {
        let table = [
            (StatusWord::Er(0), 100, QualityKind::Other, "unknown command"),
            (StatusWord::Er(1), 101, QualityKind::Other, "setting error"),
            (StatusWord::Er(10), 110, QualityKind::Overload, "measuring range over"),
            (StatusWord::Er(11), 111, QualityKind::Other, "memory value error"),
            (StatusWord::Er(19), 119, QualityKind::Overload, "display range over"),
            (StatusWord::Er(20), 120, QualityKind::Hardware, "EEPROM"),
            (StatusWord::Er(30), 130, QualityKind::Hardware, "battery"),
            (StatusWord::Ok(11), 11, QualityKind::Other, "range warning"),
            (StatusWord::Ok(12), 12, QualityKind::Other, "range warning"),
            (StatusWord::Ok(13), 13, QualityKind::Other, "range warning"),
        ];
        for (status, code, kind, meaning) in table {
            let q = quality_code(status);
            assert_eq!((q.code, q.kind), (code, kind), "{status}");
            assert!(
                q.message.contains(meaning) && q.message.starts_with(&status.to_string()),
                "{}",
                q.message
            );
        }
        assert!(quality_code(StatusWord::SUCCESS).is_ok());
        assert_eq!(quality_code(StatusWord::Er(42)).kind, QualityKind::Unknown);
        assert!(quality_hint(QualityKind::Hardware).contains("battery"));
    }
}
