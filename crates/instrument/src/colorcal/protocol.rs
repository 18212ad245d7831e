//! The CRS ColorCAL MkII's serial protocol, pure (no I/O): its commands,
//! the shape of its replies, the Minolta number format of its calibration
//! matrix, and the parsers and formatters a driver and a simulator share.
//!
//! Sources (file:line of the public clients):
//! - psychopy-crs 0.0.2 `psychopy_crs/colorcal.py` (cc.py): the reply's eol
//!   `\n\r` (cc.py:29), LF-terminated commands (cc.py:127-128), the `>`
//!   prompt that ends a reply (cc.py:136-141), `IDR` (cc.py:205-217), `MES`
//!   and XYZ = matrix · raw (cc.py:175-182), `UZC` → `OK00` or `ER11`
//!   (cc.py:249-256), `r01`–`r03` (cc.py:275-288), the Minolta format
//!   (cc.py:326-354);
//! - Psychtoolbox `PsychHardware/ColorCal2/ColorCal2.m` (J. Ales 2016):
//!   CR-terminated commands, the blank at the start of each reply, the
//!   example replies `OK00, 8053,52040,50642` (a matrix row) and
//!   `OK00,242.85,248.11, 89.05` (a measurement).
//!
//! A reply is `\n\r` + body + `\n\r` + `>`; the body is one line that
//! starts with a [`StatusWord`]. The unit answers at USB speed and the
//! whole reply must go out in one write: under Python 3 psychopy-crs never
//! matches its eol (cc.py:317 compares a bytearray with a str) and reads
//! until its time-out, so a reply split by a pause longer than that is cut.

use crate::reply::{parse_number, show, ProtocolError};
use crate::status_word::StatusWord;

/// What opens every reply (PTB: "a blank character at the start of each line").
pub const REPLY_START: &[u8] = b"\n\r";
/// What ends every reply: the eol and the prompt.
pub const REPLY_END: &[u8] = b"\n\r>";

/// The ColorCAL MkII's commands that lightbooth and its simulator know.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Command {
    /// `IDR`: identity (ROM, serial number, firmware build).
    Identify,
    /// `r01`..`r09`: row n of the three stored 3×3 correction matrices;
    /// `r01`–`r03` is the one PsychoPy uses.
    MatrixRow(u8),
    /// `MES`: measure; the raw, uncorrected tristimulus values.
    Measure,
    /// `UZC`: zero calibration (the sensor must be covered).
    ZeroCalibrate,
}

impl Command {
    /// The command as typed, without its terminator.
    pub fn text(&self) -> String {
        match self {
            Command::Identify => "IDR".into(),
            Command::MatrixRow(n) => format!("r{n:02}"),
            Command::Measure => "MES".into(),
            Command::ZeroCalibrate => "UZC".into(),
        }
    }

    /// A command line as the unit receives it (terminator removed, ends
    /// trimmed); letters in either case. `None` for anything else.
    pub fn parse(line: &[u8]) -> Option<Command> {
        let line = line.trim_ascii();
        let upper = line.to_ascii_uppercase();
        match upper.as_slice() {
            b"IDR" => Some(Command::Identify),
            b"MES" => Some(Command::Measure),
            b"UZC" => Some(Command::ZeroCalibrate),
            [b'R', b'0', d @ b'1'..=b'9'] => Some(Command::MatrixRow(d - b'0')),
            _ => None,
        }
    }
}

/// `\n\r` + `body` + `\n\r>`: a whole reply, to be written at once.
pub fn frame_reply(body: &str) -> Vec<u8> {
    let mut out = Vec::with_capacity(body.len() + 5);
    out.extend_from_slice(REPLY_START);
    out.extend_from_slice(body.as_bytes());
    out.extend_from_slice(REPLY_END);
    out
}

/// The body of a reply: its one non-empty line other than the `>` prompt.
pub fn reply_body(reply: &[u8]) -> Result<&[u8], ProtocolError> {
    let lines: Vec<&[u8]> = reply
        .split(|b| *b == b'\r' || *b == b'\n')
        .map(<[u8]>::trim_ascii)
        .filter(|l| !l.is_empty() && *l != b">")
        .collect();
    match lines.as_slice() {
        [] => Err(ProtocolError::Empty),
        [body] => Ok(body),
        [_, second, ..] => Err(ProtocolError::Trailing {
            extra: lines.len() - 1,
            first: show(second),
        }),
    }
}

/// The body's status word and the fields after it (comma-separated).
fn status_and_fields<'a>(
    reply: &'a [u8],
    expected: &'static str,
) -> Result<(StatusWord, Vec<&'a [u8]>), ProtocolError> {
    let body = reply_body(reply)?;
    let mut fields = body.split(|b| *b == b',');
    let first = fields.next().unwrap_or_default();
    let status = StatusWord::parse(first).ok_or_else(|| malformed(body, expected))?;
    Ok((status, fields.collect()))
}

fn malformed(body: &[u8], expected: &'static str) -> ProtocolError {
    ProtocolError::Malformed {
        line: 1,
        text: show(body),
        expected,
    }
}

/// What `IDR` says: `OK00,1,<rom>,100.10,<serial>,<build>` (PTB's sscanf;
/// PsychoPy keeps fields 2, 4 and the last, cc.py:205-217).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Identification {
    /// Field 2: the ROM (firmware) version.
    pub rom: String,
    /// Field 4: the eight-digit serial number.
    pub serial: String,
    /// The last field: the firmware build. PsychoPy asks for a dark zero
    /// calibration when it is below `877`, comparing strings (cc.py:233).
    pub build: String,
}

const IDENTITY: &str = "OK00,1,<rom>,100.10,<serial>,<build>";

/// `IDR`'s reply: the identification, or the unit's refusal.
pub fn parse_identification(reply: &[u8]) -> Result<Result<Identification, StatusWord>, ProtocolError> {
    let (status, fields) = status_and_fields(reply, IDENTITY)?;
    if status != StatusWord::SUCCESS {
        return Ok(Err(status));
    }
    let text = |f: &[u8]| String::from_utf8_lossy(f.trim_ascii()).into_owned();
    match fields.as_slice() {
        [_, rom, _, serial, .., build] if !serial.trim_ascii().is_empty() => Ok(Ok(Identification {
            rom: text(rom),
            serial: text(serial),
            build: text(build),
        })),
        _ => Err(malformed(reply_body(reply)?, IDENTITY)),
    }
}

/// The simulator's `IDR` body.
pub fn format_identification(id: &Identification) -> String {
    format!("OK00,1,{},100.10,{},{}", id.rom, id.serial, id.build)
}

/// The largest number the Minolta format holds: 4.9999.
pub const MINOLTA_MAX: f64 = 4.9999;

/// A matrix element in Minolta format (cc.py:326-354): v ≥ 0 is sent as
/// v·10⁴, v < 0 as −v·10⁴ + 50000. `None` above 99999 (not five digits).
/// PsychoPy reads 50000 itself as 0 (its scalar branch) or −0 (its array
/// branch): the same number.
pub fn minolta_to_float(n: u32) -> Option<f64> {
    match n {
        0..=50_000 => Some(f64::from(n) / 10_000.0),
        50_001..=99_999 => Some(-(f64::from(n) - 50_000.0) / 10_000.0),
        _ => None,
    }
}

/// The Minolta form of `v`, rounded to 10⁻⁴; `None` when |v| > 4.9999 or
/// not finite.
pub fn float_to_minolta(v: f64) -> Option<u32> {
    if !v.is_finite() || v.abs() > MINOLTA_MAX + 0.000_05 {
        return None;
    }
    let n = (v.abs() * 10_000.0).round() as u32;
    Some(if v < 0.0 && n > 0 { n + 50_000 } else { n })
}

const MATRIX_ROW: &str = "OK00,nnnnn,nnnnn,nnnnn (a matrix row in Minolta format)";

/// A matrix row's reply `OK00,%5d,%5d,%5d`: the three elements, or the
/// unit's refusal.
pub fn parse_matrix_row(reply: &[u8]) -> Result<Result<[f64; 3], StatusWord>, ProtocolError> {
    let (status, fields) = status_and_fields(reply, MATRIX_ROW)?;
    if status != StatusWord::SUCCESS {
        return Ok(Err(status));
    }
    let body = reply_body(reply)?;
    let [a, b, c] = fields.as_slice() else {
        return Err(malformed(body, MATRIX_ROW));
    };
    let element = |f: &[u8]| -> Option<f64> {
        let f = f.trim_ascii();
        if f.is_empty() || f.len() > 5 || !f.iter().all(u8::is_ascii_digit) {
            return None;
        }
        minolta_to_float(std::str::from_utf8(f).ok()?.parse().ok()?)
    };
    match (element(a), element(b), element(c)) {
        (Some(a), Some(b), Some(c)) => Ok(Ok([a, b, c])),
        _ => Err(malformed(body, MATRIX_ROW)),
    }
}

/// The simulator's body for a matrix row (`%5d` each, as PTB's example).
pub fn format_matrix_row(row: [f64; 3]) -> Option<String> {
    let [a, b, c] = row.map(float_to_minolta);
    Some(format!("OK00,{:5},{:5},{:5}", a?, b?, c?))
}

const RAW: &str = "OK00,<raw X>,<raw Y>,<raw Z> (three decimal numbers)";

/// `MES`'s reply `OK00,%6.2f,%6.2f,%6.2f`: the raw values, or the status
/// of a failed measurement.
pub fn parse_raw_measurement(reply: &[u8]) -> Result<Result<[f64; 3], StatusWord>, ProtocolError> {
    let (status, fields) = status_and_fields(reply, RAW)?;
    if status != StatusWord::SUCCESS {
        return Ok(Err(status));
    }
    let body = reply_body(reply)?;
    let [a, b, c] = fields.as_slice() else {
        return Err(malformed(body, RAW));
    };
    match (parse_number(a), parse_number(b), parse_number(c)) {
        (Some(a), Some(b), Some(c)) => Ok(Ok([a, b, c])),
        _ => Err(malformed(body, RAW)),
    }
}

/// The simulator's `MES` body.
pub fn format_raw_measurement(raw: [f64; 3]) -> String {
    format!("OK00,{:6.2},{:6.2},{:6.2}", raw[0], raw[1], raw[2])
}

/// A reply that is a status word alone (`UZC`): the status.
pub fn parse_status_reply(reply: &[u8]) -> Result<StatusWord, ProtocolError> {
    let (status, fields) = status_and_fields(reply, "a status word (OK00, ER11)")?;
    if !fields.is_empty() {
        return Err(malformed(reply_body(reply)?, "a status word alone (OK00, ER11)"));
    }
    Ok(status)
}

/// A 3×3 matrix, rows first.
pub type Matrix = [[f64; 3]; 3];

/// XYZ = `matrix` · `raw` (cc.py:175-182).
pub fn apply(matrix: &Matrix, raw: [f64; 3]) -> [f64; 3] {
    matrix.map(|row| row[0] * raw[0] + row[1] * raw[1] + row[2] * raw[2])
}

/// The inverse of `m`, when its determinant is far enough from zero to
/// trust (|det| > 10⁻⁶): the simulator turns a target's XYZ into raw values
/// with it, and the driver refuses a matrix without one.
pub fn inverse(m: &Matrix) -> Option<Matrix> {
    let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    if !det.is_finite() || det.abs() < 1e-6 {
        return None;
    }
    let c = |r0: usize, c0: usize, r1: usize, c1: usize| m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0];
    Some([
        [c(1, 1, 2, 2) / det, -c(0, 1, 2, 2) / det, c(0, 1, 1, 2) / det],
        [-c(1, 0, 2, 2) / det, c(0, 0, 2, 2) / det, -c(0, 0, 1, 2) / det],
        [c(1, 0, 2, 1) / det, -c(0, 0, 2, 1) / det, c(0, 0, 1, 1) / det],
    ])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commands_as_psychopy_and_ptb_send_them() {
        assert_eq!(Command::parse(b"IDR"), Some(Command::Identify));
        assert_eq!(Command::parse(b"r01"), Some(Command::MatrixRow(1)));
        assert_eq!(Command::parse(b"R09 "), Some(Command::MatrixRow(9)));
        assert_eq!(Command::parse(b"mes"), Some(Command::Measure));
        assert_eq!(Command::parse(b"r00"), None);
        assert_eq!(Command::parse(b"r99"), None);
        assert_eq!(Command::MatrixRow(3).text(), "r03");
    }

    #[test]
    fn minolta_numbers_as_psychopy_reads_them() {
        // cc.py's doctest: 50347 → −0.0347, 10630 → 1.063.
        assert_eq!(minolta_to_float(50347), Some(-0.0347));
        assert_eq!(minolta_to_float(10630), Some(1.063));
        assert_eq!(minolta_to_float(8053), Some(0.8053));
        assert_eq!(minolta_to_float(100_000), None);
        for v in [0.8053, -0.204, -0.0642, 0.0, 1.1021, -4.9999, 4.9999] {
            let n = float_to_minolta(v).unwrap();
            assert!((minolta_to_float(n).unwrap() - v).abs() < 1e-12, "{v} → {n}");
        }
        assert_eq!(float_to_minolta(-0.204), Some(52040));
        assert_eq!(float_to_minolta(5.5), None);
        assert_eq!(float_to_minolta(f64::NAN), None);
    }

    #[test]
    fn replies_parse_as_ptbs_examples() {
        let row = frame_reply("OK00, 8053,52040,50642");
        assert_eq!(parse_matrix_row(&row), Ok(Ok([0.8053, -0.204, -0.0642])));
        let raw = frame_reply("OK00,242.85,248.11, 89.05");
        assert_eq!(parse_raw_measurement(&raw), Ok(Ok([242.85, 248.11, 89.05])));
        assert_eq!(parse_status_reply(&frame_reply("ER11")), Ok(StatusWord::Er(11)));
        let id = parse_identification(&frame_reply("OK00,1,101,100.10,12345678,905"))
            .unwrap()
            .unwrap();
        assert_eq!(
            (id.rom.as_str(), id.serial.as_str(), id.build.as_str()),
            ("101", "12345678", "905")
        );
        assert_eq!(format_identification(&id), "OK00,1,101,100.10,12345678,905");
        assert_eq!(
            format_matrix_row([0.8053, -0.204, -0.0642]).unwrap(),
            "OK00, 8053,52040,50642"
        );
        assert_eq!(
            format_raw_measurement([242.85, 248.11, 89.05]),
            "OK00,242.85,248.11, 89.05"
        );
    }

    #[test]
    fn garbage_and_cut_replies_are_errors_not_panics() {
        for bad in [
            &b""[..],
            b"\n\r>",
            b"\n\rOK00,242.85,24#.11, 89.05\n\r>",
            b"\n\rOK00,242.85\n\r>",
            b"\n\rOK00,242.85,248.11,\n\r>",
            b"\n\r\xff\xfe\n\r>",
            b"\n\rOK00,1,2\n\rOK00\n\r>",
        ] {
            assert!(
                parse_raw_measurement(bad).is_err(),
                "{:?}",
                String::from_utf8_lossy(bad)
            );
        }
        assert!(parse_matrix_row(b"\n\rOK00,99999999,1,1\n\r>").is_err());
        assert!(parse_matrix_row(b"\n\rOK00,-8053,1,1\n\r>").is_err());
        assert!(parse_identification(b"\n\rOK00,1\n\r>").is_err());
        assert_eq!(parse_raw_measurement(&frame_reply("ER00")), Ok(Err(StatusWord::Er(0))));
    }

    #[test]
    fn a_matrix_and_its_inverse_undo_each_other() {
        let m = [
            [0.8053, -0.204, -0.0642],
            [-0.041, 0.987, 0.0375],
            [0.012, -0.0535, 1.1021],
        ];
        let inv = inverse(&m).unwrap();
        let xyz = [40.0, 50.0, 60.0];
        let back = apply(&m, apply(&inv, xyz));
        for i in 0..3 {
            assert!((back[i] - xyz[i]).abs() < 1e-9);
        }
        assert!(inverse(&[[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 0.0, 1.0]]).is_none());
    }
}
