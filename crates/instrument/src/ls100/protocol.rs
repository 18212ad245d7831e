//! The Konica Minolta LS-100 / CS-100A serial protocol, pure (no I/O): its
//! commands, the measurement reply of each model, and the parsers and
//! formatters a driver and a simulator share.
//!
//! Sources (file:line of the public clients):
//! - psychopy-minolta 0.0.2 `psychopy_minolta/minolta.py` (mi.py): 4800 baud,
//!   7 data bits, even parity, 2 stop bits (mi.py:137-141, 394-399);
//!   commands and replies end in CR LF (mi.py:243-248, 114-121); `MDS,04`
//!   (absolute mode) answered `OK…` on opening (mi.py:151-164, 409-422);
//!   `MDS,08` peak and `MDS,09` continuous (mi.py:171-173); `MES` on the
//!   LS-100 gives the luminance as the last whitespace-separated token
//!   (mi.py:443), so a space precedes it; on the CS-100A it gives
//!   `OKnn, L, x, y`, split at commas (mi.py:187-196); `CLE` (mi.py:213);
//!   a reply is good when it starts with `OK` (mi.py:224);
//! - a public CS-100A script ("KMpy"): `MDS,00`/`01` preset/variable
//!   calibration, `04`/`05` absolute/difference, `06`/`07` fast/slow; its
//!   reads of 28 bytes (`OK00, 120.15, .3920, .3930` CR LF).
//!
//! The LS-100 reads luminance only; the CS-100A adds the chromaticity x, y
//! (CIE 1931 2°, the meter's own filters).

use crate::reply::{parse_number, show, ProtocolError};
use crate::status_word::StatusWord;

use super::Model;

/// The commands lightbooth and its simulator know.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Command {
    /// `MDS,nn`: a mode (`04` absolute, the one lightbooth uses).
    SetMode(u8),
    /// `MES`: measure.
    Measure,
    /// `CLE`: clear the memory.
    ClearMemory,
}

/// Absolute measurement (`MDS,04`): what PsychoPy sets on opening.
pub const ABSOLUTE_MODE: u8 = 4;

/// The `MDS` codes the public sources name: 00/01 preset/variable
/// calibration, 04/05 absolute/difference, 06/07 fast/slow, 08 peak,
/// 09 continuous. Others are refused with `ER01` by lightbooth's simulator
/// (the real set is not in the public sources).
pub const KNOWN_MODES: [u8; 8] = [0, 1, 4, 5, 6, 7, 8, 9];

impl Command {
    /// The command as typed, without its CR LF.
    pub fn text(&self) -> String {
        match self {
            Command::SetMode(n) => format!("MDS,{n:02}"),
            Command::Measure => "MES".into(),
            Command::ClearMemory => "CLE".into(),
        }
    }
}

/// What the meter makes of a command line (terminator removed).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Received {
    Command(Command),
    /// `MDS,` with an argument that is not two digits.
    BadSetting,
    /// Anything else.
    Unknown,
}

/// A command line as the meter receives it, upper case as the clients send it.
pub fn parse_command(line: &[u8]) -> Received {
    let line = line.trim_ascii();
    match line {
        b"MES" => Received::Command(Command::Measure),
        b"CLE" => Received::Command(Command::ClearMemory),
        [b'M', b'D', b'S', b',', rest @ ..] => match rest {
            [a @ b'0'..=b'9', b @ b'0'..=b'9'] => Received::Command(Command::SetMode((a - b'0') * 10 + (b - b'0'))),
            _ => Received::BadSetting,
        },
        _ => Received::Unknown,
    }
}

/// One measurement as the meter reports it with an `OKnn` status.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Measured {
    /// `OK00`, or `OK11`–`OK13` (a range warning, the value still sent).
    pub status: StatusWord,
    /// Luminance, cd/m².
    pub luminance: f64,
    /// The CS-100A's chromaticity x, y (CIE 1931 2°); none from an LS-100.
    pub xy: Option<(f64, f64)>,
}

impl Measured {
    /// X, Y, Z (cd/m²) from Y, x, y; `None` without x, y or when y is not
    /// positive (XYZ would be infinite).
    pub fn xyz(&self) -> Option<[f64; 3]> {
        let (x, y) = self.xy?;
        // Also false for a NaN y.
        if y.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            return None;
        }
        let big_y = self.luminance;
        Some([x * big_y / y, big_y, (1.0 - x - y) * big_y / y])
    }
}

/// A reply line to `MES` from a meter of `model`: the measurement, or the
/// `ERnn` status of a failed one. A reply with the other model's fields is
/// an error that says so.
pub fn parse_measurement(line: &[u8], model: Model) -> Result<Result<Measured, StatusWord>, ProtocolError> {
    let line = line.trim_ascii();
    if line.is_empty() {
        return Err(ProtocolError::Empty);
    }
    let expected = match model {
        Model::Ls100 => "OKnn, <luminance> (an LS-100 measurement)",
        Model::Cs100a => "OKnn, <luminance>, <x>, <y> (a CS-100A measurement)",
    };
    let bad = |expected| ProtocolError::Malformed {
        line: 1,
        text: show(line),
        expected,
    };
    let fields: Vec<&[u8]> = line.split(|b| *b == b',').collect();
    let status = StatusWord::parse(fields[0]).ok_or_else(|| bad(expected))?;
    if !status.is_ok() {
        return if fields.len() == 1 {
            Ok(Err(status))
        } else {
            Err(bad("an ERnn status alone"))
        };
    }
    let number = |f: &[u8]| parse_number(f);
    match (model, &fields[1..]) {
        (Model::Ls100, [l]) => {
            let luminance = number(l).ok_or_else(|| bad(expected))?;
            Ok(Ok(Measured {
                status,
                luminance,
                xy: None,
            }))
        }
        (Model::Cs100a, [l, x, y]) => match (number(l), number(x), number(y)) {
            (Some(luminance), Some(x), Some(y)) => Ok(Ok(Measured {
                status,
                luminance,
                xy: Some((x, y)),
            })),
            _ => Err(bad(expected)),
        },
        (Model::Ls100, [_, _, _]) => Err(bad(
            "an LS-100 measurement (this reply has x and y: a CS-100A? set model = \"cs100a\")",
        )),
        (Model::Cs100a, [_]) => Err(bad(
            "a CS-100A measurement (this reply has no x, y: an LS-100? set model = \"ls100\")",
        )),
        _ => Err(bad(expected)),
    }
}

/// A reply that is a status word alone (`MDS`, `CLE`).
pub fn parse_status_reply(line: &[u8]) -> Result<StatusWord, ProtocolError> {
    let line = line.trim_ascii();
    if line.is_empty() {
        return Err(ProtocolError::Empty);
    }
    StatusWord::parse(line).ok_or_else(|| ProtocolError::Malformed {
        line: 1,
        text: show(line),
        expected: "a status word (OK00, ER01)",
    })
}

/// The widest luminance a 6-character field holds: `99999.`.
pub const MAX_LUMINANCE: f64 = 99_999.0;

/// A luminance in a field of six characters with five significant digits
/// (`120.15`, `1.2345`, `.12345`, `12345.`): the simulator's choice, so a
/// CS-100A line is the 28 bytes of KMpy's example. `None` when it does not
/// fit (over 99999, negative, not finite).
pub fn format_luminance(v: f64) -> Option<String> {
    if !v.is_finite() || v < 0.0 {
        return None;
    }
    // The most decimals that fit: rounding may add a digit (9.99999 → 10.000).
    (0..=5usize).rev().find_map(|decimals| {
        let mut text = format!("{v:.decimals$}");
        if text.starts_with("0.") {
            text.remove(0);
        }
        if decimals == 0 {
            text.push('.');
        }
        (text.len() <= 6).then(|| format!("{text:>6}"))
    })
}

/// A chromaticity as the CS-100A sends it: four decimals, no leading zero (`.3920`).
pub fn format_chromaticity(v: f64) -> String {
    let s = format!("{:.4}", v.clamp(0.0, 0.9999));
    s.trim_start_matches('0').to_string()
}

/// The simulator's `MES` line (without CR LF): `OK00, L` or `OK00, L, x, y`.
pub fn format_measurement(status: StatusWord, luminance: &str, xy: Option<(f64, f64)>) -> String {
    match xy {
        None => format!("{status},{luminance:>7}"),
        Some((x, y)) => format!(
            "{status},{luminance:>7}, {}, {}",
            format_chromaticity(x),
            format_chromaticity(y)
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commands_as_the_clients_send_them() {
        assert_eq!(parse_command(b"MDS,04"), Received::Command(Command::SetMode(4)));
        assert_eq!(parse_command(b"MES"), Received::Command(Command::Measure));
        assert_eq!(parse_command(b"CLE"), Received::Command(Command::ClearMemory));
        assert_eq!(parse_command(b"MDS,4x"), Received::BadSetting);
        assert_eq!(parse_command(b"XYZ"), Received::Unknown);
        assert_eq!(Command::SetMode(4).text(), "MDS,04");
    }

    #[test]
    fn measurements_of_both_models() {
        let ls = parse_measurement(b"OK00,  120.15", Model::Ls100).unwrap().unwrap();
        assert_eq!((ls.luminance, ls.xy), (120.15, None));
        let cs = parse_measurement(b"OK00, 120.15, .3920, .3930", Model::Cs100a)
            .unwrap()
            .unwrap();
        assert_eq!(cs.xy, Some((0.392, 0.393)));
        let xyz = cs.xyz().unwrap();
        assert!((xyz[0] - 0.392 * 120.15 / 0.393).abs() < 1e-9 && xyz[1] == 120.15);
        assert!((xyz[2] - (1.0 - 0.392 - 0.393) * 120.15 / 0.393).abs() < 1e-9);
        assert_eq!(parse_measurement(b"ER10", Model::Ls100), Ok(Err(StatusWord::Er(10))));
        let warned = parse_measurement(b"OK12,   0.01", Model::Ls100).unwrap().unwrap();
        assert_eq!(warned.status, StatusWord::Ok(12));
    }

    #[test]
    fn the_other_models_reply_is_named() {
        let e = parse_measurement(b"OK00, 120.15, .3920, .3930", Model::Ls100).unwrap_err();
        assert!(e.to_string().contains("cs100a"), "{e}");
        let e = parse_measurement(b"OK00, 120.15", Model::Cs100a).unwrap_err();
        assert!(e.to_string().contains("ls100"), "{e}");
    }

    #[test]
    fn garbage_and_cut_lines_are_errors_not_panics() {
        for bad in [
            &b""[..],
            b"OK00",
            b"OK00, 12#.15",
            b"OK00, 120.15, .39",
            b"\xff\xfe",
            b"ER10, 5",
            b"OK00,,",
        ] {
            assert!(
                parse_measurement(bad, Model::Cs100a).is_err(),
                "{:?}",
                String::from_utf8_lossy(bad)
            );
        }
        assert!(parse_measurement(b"OK00, inf", Model::Ls100).is_err());
        let zero_y = parse_measurement(b"OK00, 1.0, .3000, .0000", Model::Cs100a)
            .unwrap()
            .unwrap();
        assert_eq!(zero_y.xyz(), None);
    }

    #[test]
    fn the_simulators_fields_have_fixed_widths() {
        assert_eq!(format_luminance(120.15).unwrap(), "120.15");
        assert_eq!(format_luminance(1.23456).unwrap(), "1.2346");
        assert_eq!(format_luminance(0.123456).unwrap(), ".12346");
        assert_eq!(format_luminance(12345.4).unwrap(), "12345.");
        assert_eq!(format_luminance(0.0).unwrap(), ".00000");
        assert_eq!(format_luminance(9.99999).unwrap(), "10.000");
        assert_eq!(format_luminance(1e6), None);
        assert_eq!(format_luminance(f64::NAN), None);
        let line = format_measurement(StatusWord::SUCCESS, "120.15", Some((0.392, 0.393)));
        assert_eq!(format!("{line}\r\n"), "OK00, 120.15, .3920, .3930\r\n");
        assert_eq!(format!("{line}\r\n").len(), 28);
        assert_eq!(format_measurement(StatusWord::SUCCESS, "120.15", None), "OK00, 120.15");
    }
}
