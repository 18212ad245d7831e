//! What the PR-655/PR-670's statuses mean: the signed codes of section 7
//! of `docs/src/instruments/pr655-670-protocol.md`, typed by their broad
//! [`QualityKind`], and what the operator should do about each kind. Pure
//! tables.

use crate::{QualityCode, QualityKind};

/// A status code with its documented meaning (section 7). Codes not in the
/// table are [`QualityKind::Unknown`], with the number kept.
pub fn quality_code(code: i32) -> QualityCode {
    use QualityKind::*;
    let (kind, message) = match code {
        0 => (Ok, "no error"),
        -1 => (Other, "light source not constant"),
        -2 => (Overload, "light overload: signal too intense"),
        -3 => (
            Sync,
            "cannot sync to the light source (below 20 Hz, above 400 Hz, or too weak)",
        ),
        -4 => (Other, "adaptive-mode error"),
        -8 => (LowLight, "weak light: not enough signal"),
        -9 => (Sync, "sync error"),
        -10 => (Sync, "cannot auto-sync to the light source"),
        -12 => (Other, "adaptive-mode time-out; light source not constant"),
        -1000 => (Other, "illegal command"),
        -1001 => (Other, "too many fields in a setup command"),
        -1004..=-1002 | -1025 => (Other, "invalid accessory code"),
        -1007..=-1005 => (Other, "accessory not usable in that position"),
        -1008 => (Other, "invalid aperture index"),
        -1009 => (Other, "invalid units code"),
        -1010 => (Other, "invalid exposure time"),
        -1011 => (Other, "invalid gain code"),
        -1012 => (Other, "invalid number of cycles (1–99)"),
        -1015 => (Other, "invalid CIE observer (2 or 10)"),
        -1017 => (Other, "invalid dark-measurement mode"),
        -1019 => (Other, "invalid sync mode (0, 1, 3)"),
        -1021 => (Other, "title too long"),
        -1022 => (Other, "title empty"),
        -1023 => (Other, "invalid user sync frequency (20–400 Hz)"),
        -1024 => (Other, "invalid R command"),
        -1026 => (Other, "invalid sensitivity mode"),
        -1035 => (Other, "parameter not applicable to this instrument"),
        -2000 => (Other, "the report does not exist, or no measurement has been made yet"),
        _ => (Unknown, "not in the PR-655/PR-670 status table"),
    };
    QualityCode {
        code,
        kind,
        message: message.into(),
    }
}

/// What the operator should do about a series that failed with this kind of status.
pub fn quality_hint(kind: QualityKind) -> &'static str {
    match kind {
        QualityKind::Ok => "",
        QualityKind::LowLight => {
            "Check the lens cap, aim at a brighter target, or use a fixed, longer exposure (exposure_ms)"
        }
        QualityKind::Overload => "Too much light: add a neutral-density filter or use a shorter fixed exposure",
        QualityKind::Sync => "Turn synchronisation off (sync = false) or check that the source flickers steadily",
        QualityKind::Hardware => "Power-cycle the instrument and re-plug its USB cable",
        QualityKind::Other | QualityKind::Unknown => "Measure again; if it persists, check the source is steady",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn status_codes_carry_their_documented_meaning() {
        assert_eq!(quality_code(0).kind, QualityKind::Ok);
        assert_eq!(quality_code(-8).kind, QualityKind::LowLight);
        assert_eq!(quality_code(-2).kind, QualityKind::Overload);
        assert_eq!(quality_code(-10).kind, QualityKind::Sync);
        assert!(quality_code(-1035).message.contains("not applicable"));
        assert!(quality_code(-2000).message.contains("no measurement"));
        let unknown = quality_code(-4242);
        assert_eq!((unknown.code, unknown.kind), (-4242, QualityKind::Unknown));
        // PR-650 codes copied into PR-655 clients are not PR-655 codes (section 7).
        assert_eq!(quality_code(18).kind, QualityKind::Unknown);
        assert!(quality_hint(QualityKind::LowLight).contains("exposure_ms"));
    }
}
