//! What the PR-650's numbers mean: the quality codes of its reports
//! (`docs/src/instruments/pr650-protocol.md` section 4) typed by their broad
//! [`QualityKind`], what the operator should do about each kind, and the
//! statuses of the `S` setup command (section 2). Pure tables.

use crate::{QualityCode, QualityKind};

/// What a non-zero `S` status means (section 2): the number of the invalid
/// field, or 50 for the accessory.
pub fn setup_status_meaning(status: u8) -> &'static str {
    match status {
        0 => "setup accepted",
        1 => "field 1, the primary accessory (01–12), is invalid",
        2..=4 => "an add-on accessory field (02–12) is invalid",
        5 => "field 5, sync (empty, 1, or 40–250 Hz), is invalid",
        6 => "field 6, the integration time (0 = adaptive, or 10–6000 ms), is invalid",
        7 => "field 7, the number of measurements averaged (01–99), is invalid",
        8 => "field 8, units (0 English, 1 metric), is invalid",
        50 => "no primary accessory, more than one, or the first accessory is not a primary",
        _ => "an undocumented setup status",
    }
}

/// The PR-650 quality codes of section 4 with their manual texts.
pub fn quality_code(code: u8) -> QualityCode {
    use QualityKind::*;
    let (kind, message) = match code {
        0 => (Ok, "measurement OK"),
        1 => (Hardware, "no EOS signal at start of measurement"),
        3 => (Hardware, "no start signal"),
        4 => (Hardware, "no EOS signal to start integration time"),
        5 => (Hardware, "DMA failure"),
        6 => (Sync, "no EOS after change to SYNC mode"),
        7 => (Sync, "unable to sync to the light source"),
        8 => (Sync, "sync lost during measurement"),
        10 => (LowLight, "weak light signal"),
        12 => (Hardware, "unspecified hardware malfunction"),
        13 => (Hardware, "software error"),
        14 => (Other, "no sample in L*u*v* or L*a*b* calculation"),
        16 => (
            Other,
            "adaptive integration took too long to find an integration time (source may be varying)",
        ),
        17 => (Hardware, "main battery low"),
        18 => (LowLight, "low light level"),
        19 => (Overload, "light level too high (overload)"),
        20 => (Sync, "no sync signal"),
        21 => (Hardware, "RAM error"),
        29 => (Other, "corrupted data"),
        30 => (Other, "noisy signal"),
        _ => (Unknown, "not a PR-650 quality code"),
    };
    QualityCode {
        code: i32::from(code),
        kind,
        message: message.to_string(),
    }
}

/// What the operator should do about a quality code.
pub fn quality_hint(kind: QualityKind) -> &'static str {
    match kind {
        QualityKind::Ok => "",
        QualityKind::LowLight => "Aim at a brighter target, open the aperture or use a fixed, longer integration time",
        QualityKind::Overload => "Too much light: add a neutral-density filter or use a shorter integration time",
        QualityKind::Sync => "Turn synchronisation off (sync = false) or check that the source flickers steadily",
        QualityKind::Hardware => "Power-cycle the instrument; if it persists, it needs service (or a charged battery)",
        QualityKind::Other | QualityKind::Unknown => "Measure again; if it persists, check the source is steady",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn setup_statuses_name_the_bad_field() {
        assert_eq!(setup_status_meaning(0), "setup accepted");
        assert!(setup_status_meaning(6).contains("integration time"));
        assert!(setup_status_meaning(50).contains("primary"));
        assert_eq!(setup_status_meaning(42), "an undocumented setup status");
    }

    #[test]
    fn every_kind_but_ok_has_advice() {
        for kind in [
            QualityKind::LowLight,
            QualityKind::Overload,
            QualityKind::Sync,
            QualityKind::Hardware,
            QualityKind::Other,
            QualityKind::Unknown,
        ] {
            assert!(!quality_hint(kind).is_empty(), "{kind:?}");
        }
        assert_eq!(quality_hint(QualityKind::Ok), "");
    }
}
