//! What the ColorCAL MkII's status words mean, typed by their broad
//! [`QualityKind`], and what the operator should do about each kind. Pure
//! tables.
//!
//! The public clients document one error: `ER11` to `UZC` when light
//! reaches the sensor (psychopy-crs `psychopy_crs/colorcal.py:253-256`,
//! "Is it properly covered?"). `ER00` is lightbooth's simulator's answer to
//! a command it does not know (no public source says what the unit sends;
//! the Minolta meters, whose conventions the ColorCAL shares, use `ER00`
//! for "unknown command", psychopy-minolta `minolta.py:115`). Codes follow
//! [`StatusWord::code`]: `OKnn` → nn, `ERnn` → 100 + nn.

use crate::status_word::StatusWord;
use crate::{QualityCode, QualityKind};

/// A status word with its meaning; any other is [`QualityKind::Unknown`], the word kept.
pub fn quality_code(status: StatusWord) -> QualityCode {
    use QualityKind::*;
    let (kind, message) = match status {
        StatusWord::Ok(0) => (Ok, "OK00: no error".to_string()),
        StatusWord::Er(11) => (
            LowLight,
            "ER11: zero calibration refused, light reaches the sensor (it must be covered)".to_string(),
        ),
        StatusWord::Er(0) => (Other, "ER00: unknown command".to_string()),
        other => (
            Unknown,
            format!("{other}: not a status word the ColorCAL's public clients document"),
        ),
    };
    QualityCode {
        code: status.code(),
        kind,
        message,
    }
}

/// What the operator should do about a series that failed with this kind of status.
pub fn quality_hint(kind: QualityKind) -> &'static str {
    match kind {
        QualityKind::Ok => "",
        QualityKind::LowLight => "Cover the sensor completely for a zero calibration, then measure again",
        QualityKind::Overload => "Too much light for the ColorCAL: measure a dimmer target",
        QualityKind::Hardware => "Re-plug the ColorCAL's USB cable",
        QualityKind::Sync | QualityKind::Other | QualityKind::Unknown => {
            "Re-plug the ColorCAL's USB cable and measure again; if it persists, check the firmware"
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn documented_statuses_carry_their_meaning() {
        assert!(quality_code(StatusWord::SUCCESS).is_ok());
        let er11 = quality_code(StatusWord::Er(11));
        assert_eq!((er11.code, er11.kind), (111, QualityKind::LowLight));
        assert!(er11.message.contains("covered"), "{}", er11.message);
        assert_eq!(quality_code(StatusWord::Er(0)).kind, QualityKind::Other);
        let unknown = quality_code(StatusWord::Er(42));
        assert_eq!((unknown.code, unknown.kind), (142, QualityKind::Unknown));
        assert!(unknown.message.contains("ER42"));
        assert!(quality_hint(QualityKind::LowLight).contains("Cover"));
    }
}
