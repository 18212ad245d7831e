//! The PR-655/PR-670 remote protocol as bytes: command encoding, reply
//! parsing and reply formatting (the simulator's side). Pure: no I/O, no
//! clocks, and the parsers never panic, whatever the bytes (property-tested
//! below).
//!
//! The reference is `docs/src/instruments/pr655-670-protocol.md`; section numbers
//! below are its sections. Its confidence markers decide how strict a parser
//! is:
//!
//! - **Confirmed** (\[C\]) facts are checked strictly: the 12-byte banner
//!   ` REMOTE MODE`, CR LF line ends, one header line before the spectrum,
//!   the wavelength as a plain integer on the model's grid (101 points at
//!   4 nm, or 201 at 2 nm), the status as the first comma field.
//! - **Uncertain** (\[U\]) points are parsed leniently, each at its spot: the
//!   status's width (`00000`, `0000`) and the padding of negative codes
//!   (`-0008`, `-8`); the 16th byte of a spectral line (a trailing or
//!   leading space, or a three-digit exponent); a bare LF instead of CR LF;
//!   empty lines (12.7).
//! - Anything that fits neither is a typed [`ProtocolError`] that shows the
//!   offending bytes.
//!
//! Spectral values are per nm, as the instrument sends them (8.2): never
//! multiplied by the step into "power per band" as PTB does. The two models
//! are [`super::model`]; what the statuses mean is [`super::codes`].

use super::model::Model;
use lightbooth_science::spectrum::Grid;

use crate::reply::{malformed, show};
pub use crate::reply::{parse_number, ProtocolError};

/// The remote-mode banner (2.1, \[C\]): 12 bytes, a leading space, no CR LF.
pub const BANNER: &[u8] = b" REMOTE MODE";

/// The bytes that enter remote mode, each to be written on its own (2.1,
/// \[C\]: written as one string they are not recognised).
pub const REMOTE_ENTRY: [u8; 5] = *b"PHOTO";

/// Report codes lightbooth reads (section 6).
pub const REPORT_XYZ: u16 = 2;
pub const REPORT_SPECTRUM: u16 = 5;
pub const REPORT_SERIAL: u16 = 110;
pub const REPORT_MODEL: u16 = 111;
pub const REPORT_FIRMWARE: u16 = 114;
pub const REPORT_HARDWARE: u16 = 120;
pub const REPORT_SETUP_TEXT: u16 = 602;

/// A setup parameter (section 5): one per `S` command.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SetupParam {
    /// `SU`: 1 = SI (cd/m²), 0 = English.
    Units(u8),
    /// `SE`: exposure in ms, 0 = adaptive.
    Exposure(u32),
    /// `SN`: cycles averaged inside the instrument, 1–99. lightbooth averages
    /// itself so it keeps every sample: 1.
    Cycles(u8),
    /// `SO`: CIE observer of the instrument's XYZ, 2 or 10.
    Observer(u8),
    /// `SS`: sync mode, 0 none, 1 auto, 3 user frequency.
    Sync(u8),
}

/// A command (section 4). Only what lightbooth sends; `E` (echo), `Z…`
/// (reset, which switches the unit off) and `R` (recall) are absent.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Command {
    /// `M⟨code⟩`: measure, then send report `code`.
    Measure(u16),
    /// `D⟨code⟩`: report `code` of the last measurement.
    Report(u16),
    Setup(SetupParam),
    /// `F`: the source's flicker frequency.
    SyncFrequency,
    /// `Q`: leave remote mode. No reply.
    Quit,
}

impl Command {
    /// The command as typed, without terminator.
    pub fn text(&self) -> String {
        match self {
            Command::Measure(code) => format!("M{code}"),
            Command::Report(code) => format!("D{code}"),
            Command::Setup(p) => match p {
                SetupParam::Units(u) => format!("SU{u}"),
                SetupParam::Exposure(ms) => format!("SE{ms}"),
                SetupParam::Cycles(n) => format!("SN{n}"),
                SetupParam::Observer(o) => format!("SO{o}"),
                SetupParam::Sync(s) => format!("SS{s}"),
            },
            Command::SyncFrequency => "F".into(),
            Command::Quit => "Q".into(),
        }
    }

    /// The bytes on the wire: upper-case text and CR (3.1, \[C\]); `Q` goes
    /// without a terminator, as most clients send it (2.2).
    pub fn encode(&self) -> Vec<u8> {
        let mut out = self.text().into_bytes();
        if *self != Command::Quit {
            out.push(b'\r');
        }
        out
    }

    /// How many lines the whole reply has, given its first line: a spectrum
    /// is a header and one line per wavelength, unless the status is an error,
    /// which comes alone (3.2, \[M\]). `None` until the first line is complete.
    pub fn reply_lines(&self, first_line: &[u8], grid_len: usize) -> usize {
        match self {
            Command::Measure(REPORT_SPECTRUM) | Command::Report(REPORT_SPECTRUM) => match parse_status(first_line) {
                Ok(0) => 1 + grid_len,
                _ => 1,
            },
            Command::Quit => 0,
            _ => 1,
        }
    }
}

/// The reply's lines: split at LF, CR and spaces stripped, empty lines
/// skipped (8.1: "split on LF, strip CR and spaces"; 12.7: a stray empty
/// line is harmless).
pub fn split_lines(bytes: &[u8]) -> Vec<&[u8]> {
    bytes
        .split(|b| *b == b'\n')
        .map(|l| l.trim_ascii())
        .filter(|l| !l.is_empty())
        .collect()
}

/// Complete (LF-terminated) non-empty lines in `bytes` so far.
pub fn complete_lines(bytes: &[u8]) -> usize {
    match bytes.iter().rposition(|b| *b == b'\n') {
        Some(last) => split_lines(&bytes[..=last]).len(),
        None => 0,
    }
}

/// True when `bytes` is the banner. Lenient about what surrounds it (a CR
/// LF as on the PR-705, 2.1), strict about the words.
pub fn is_banner(bytes: &[u8]) -> bool {
    bytes.trim_ascii() == b"REMOTE MODE"
}

/// Checks a banner, or says what came instead.
pub fn parse_banner(bytes: &[u8]) -> Result<(), ProtocolError> {
    if is_banner(bytes) {
        Ok(())
    } else {
        Err(ProtocolError::Banner { got: show(bytes) })
    }
}

/// The status: a signed integer up to the first comma or the end of the
/// line (3.3). Width and zero padding are uncertain (12.2), so `00000`,
/// `0000`, `-0008` and `-8` are all read; anything else is an error.
pub fn parse_status(line: &[u8]) -> Result<i32, ProtocolError> {
    let line = line.trim_ascii();
    let field = line.split(|b| *b == b',').next().unwrap_or_default().trim_ascii();
    let (negative, digits) = match field.split_first() {
        Some((b'-', rest)) => (true, rest),
        _ => (false, field),
    };
    if digits.is_empty() || digits.len() > 6 || !digits.iter().all(u8::is_ascii_digit) {
        return Err(malformed(1, line, "a status such as `00000` or `-1003`"));
    }
    let value: i32 = std::str::from_utf8(digits)
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0);
    Ok(if negative { -value } else { value })
}

/// A status-only reply (setup commands, and any error).
pub fn parse_status_reply(bytes: &[u8]) -> Result<i32, ProtocolError> {
    let lines = split_lines(bytes);
    let first = lines.first().ok_or(ProtocolError::Empty)?;
    let status = parse_status(first)?;
    if lines.len() > 1 {
        return Err(ProtocolError::Trailing {
            extra: lines.len() - 1,
            first: show(lines[1]),
        });
    }
    Ok(status)
}

/// The comma fields of a one-line report after a zero status; or the error status.
fn report_fields<'a>(bytes: &'a [u8], expected: &'static str) -> Result<Result<Vec<&'a [u8]>, i32>, ProtocolError> {
    let lines = split_lines(bytes);
    let first = *lines.first().ok_or(ProtocolError::Empty)?;
    let status = parse_status(first)?;
    if status != 0 {
        return Ok(Err(status));
    }
    if lines.len() > 1 {
        return Err(ProtocolError::Trailing {
            extra: lines.len() - 1,
            first: show(lines[1]),
        });
    }
    let fields: Vec<&[u8]> = first.split(|b| *b == b',').map(|f| f.trim_ascii()).collect();
    if fields.len() < 2 {
        return Err(malformed(1, first, expected));
    }
    Ok(Ok(fields))
}

/// A one-line text report (`D110` serial, `D111` model, `D114` firmware):
/// the last comma field, trimmed (PsychoPy and SweepMe take the last field;
/// PTB keeps 8 characters of a serial that "may contain trailing blanks").
/// `Err(status)` inside when the instrument answered with an error.
pub fn parse_text_report(bytes: &[u8]) -> Result<Result<String, i32>, ProtocolError> {
    Ok(report_fields(bytes, "`00000,` followed by text")?.map(|fields| {
        let text = fields.last().copied().unwrap_or_default();
        String::from_utf8_lossy(text).into_owned()
    }))
}

/// Report 2: CIE 1931 X, Y, Z (observer per `SO`), units flag first.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct XyzReport {
    pub units: i32,
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

pub fn parse_xyz_report(bytes: &[u8]) -> Result<Result<XyzReport, i32>, ProtocolError> {
    let lines = split_lines(bytes);
    let expected = "`00000,U,X,Y,Z` (status, units, three numbers)";
    match report_fields(bytes, expected)? {
        Err(status) => Ok(Err(status)),
        Ok(fields) => {
            let bad = || malformed(1, lines[0], expected);
            if fields.len() != 5 {
                return Err(bad());
            }
            let units = parse_status(fields[1]).map_err(|_| bad())?;
            let n = |i: usize| parse_number(fields[i]).ok_or_else(bad);
            Ok(Ok(XyzReport {
                units,
                x: n(2)?,
                y: n(3)?,
                z: n(4)?,
            }))
        }
    }
}

/// Report 120: the hardware configuration (6, \[M\]; iris parses the same order).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HardwareConfig {
    pub points: usize,
    pub bandwidth_nm: f64,
    pub first_nm: u32,
    pub last_nm: u32,
    pub increment_nm: u32,
}

impl HardwareConfig {
    /// The grid it describes, when consistent.
    pub fn grid(&self) -> Option<Grid> {
        if self.increment_nm == 0 || self.last_nm <= self.first_nm {
            return None;
        }
        let span = self.last_nm - self.first_nm;
        (span.is_multiple_of(self.increment_nm) && (span / self.increment_nm) as usize + 1 == self.points)
            .then(|| Grid::uniform(self.first_nm as f64, self.increment_nm as f64, self.points))
    }
}

pub fn parse_hardware_config(bytes: &[u8]) -> Result<Result<HardwareConfig, i32>, ProtocolError> {
    let lines = split_lines(bytes);
    let expected = "`00000,points,bandwidth,first,last,increment,…` (report 120)";
    match report_fields(bytes, expected)? {
        Err(status) => Ok(Err(status)),
        Ok(fields) => {
            let bad = || malformed(1, lines[0], expected);
            if fields.len() < 6 {
                return Err(bad());
            }
            let int = |i: usize| -> Result<u32, ProtocolError> {
                let v = parse_number(fields[i]).ok_or_else(bad)?;
                (v >= 0.0 && v.fract() == 0.0 && v < 1e6)
                    .then_some(v as u32)
                    .ok_or_else(bad)
            };
            Ok(Ok(HardwareConfig {
                points: int(1)? as usize,
                bandwidth_nm: parse_number(fields[2]).ok_or_else(bad)?,
                first_nm: int(3)?,
                last_nm: int(4)?,
                increment_nm: int(5)?,
            }))
        }
    }
}

/// `F`: `0000,60.00 Hertz (Period = nnnnn milliseconds)` (4, \[M\] format,
/// \[C\] `status,frequency`). `Ok(None)` when the status is an error or the
/// frequency is 0 (PTB treats both as "no sync", 12.10).
pub fn parse_sync_frequency(bytes: &[u8]) -> Result<(i32, Option<f64>), ProtocolError> {
    let lines = split_lines(bytes);
    let first = *lines.first().ok_or(ProtocolError::Empty)?;
    let status = parse_status(first)?;
    if status != 0 {
        return Ok((status, None));
    }
    let expected = "`0000,ff.ff Hertz …`";
    let field = first
        .split(|b| *b == b',')
        .nth(1)
        .ok_or_else(|| malformed(1, first, expected))?;
    let number = field.trim_ascii().split(|b| *b == b' ').next().unwrap_or_default();
    let hz = parse_number(number).ok_or_else(|| malformed(1, first, expected))?;
    Ok((status, (hz > 0.0).then_some(hz)))
}

/// Report 5: the spectrum, per nm on the model's grid (8.1).
#[derive(Clone, Debug, PartialEq)]
pub struct SpectralReport {
    /// The second header field; 0 in every example (its meaning is disputed, 12.4).
    pub units: i32,
    pub peak_nm: f64,
    /// Σ value × step, as the instrument computes it.
    pub integrated: f64,
    pub photon_integrated: f64,
    /// Per-nm values at the grid's wavelengths.
    pub values: Vec<f64>,
}

/// Parses a spectrum reply on `grid`. `Ok(Err(status))` for an error status
/// (which comes alone, 3.2; any lines after it are ignored, never read as
/// data). A data line is `wavelength,value`: the wavelength a plain integer
/// that must be the grid's next (\[C\]); the value any float form, spaces
/// around it allowed (8.1 \[U\]).
pub fn parse_spectral_report(bytes: &[u8], grid: &Grid) -> Result<Result<SpectralReport, i32>, ProtocolError> {
    let lines = split_lines(bytes);
    let header = *lines.first().ok_or(ProtocolError::Empty)?;
    let status = parse_status(header)?;
    if status != 0 {
        return Ok(Err(status));
    }
    let expected_header = "a spectrum header `00000,U,peak,integrated,photon`";
    let fields: Vec<&[u8]> = header.split(|b| *b == b',').collect();
    if fields.len() != 5 {
        return Err(malformed(1, header, expected_header));
    }
    let units = parse_status(fields[1]).map_err(|_| malformed(1, header, expected_header))?;
    let number = |i: usize| parse_number(fields[i]).ok_or_else(|| malformed(1, header, expected_header));
    let (peak_nm, integrated, photon_integrated) = (number(2)?, number(3)?, number(4)?);

    let wavelengths = grid.wavelengths();
    let data = &lines[1..];
    let mut values = Vec::with_capacity(wavelengths.len());
    for (k, line) in data.iter().enumerate() {
        let line_no = k + 2;
        let expected_line = "a data line `wavelength,value` such as `380,1.627e-06`";
        let Some(&due) = wavelengths.get(k) else {
            return Err(ProtocolError::Trailing {
                extra: data.len() - wavelengths.len(),
                first: show(line),
            });
        };
        let mut parts = line.splitn(2, |b| *b == b',');
        let (nm_field, value_field) = (parts.next().unwrap_or_default(), parts.next());
        let nm_field = nm_field.trim_ascii();
        let Some(value_field) = value_field else {
            return Err(malformed(line_no, line, expected_line));
        };
        if nm_field.is_empty() || nm_field.len() > 4 || !nm_field.iter().all(u8::is_ascii_digit) {
            return Err(malformed(line_no, line, expected_line));
        }
        let nm: u32 = std::str::from_utf8(nm_field)
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(0);
        if f64::from(nm) != due {
            return Err(ProtocolError::WrongWavelength {
                line: line_no,
                got_nm: f64::from(nm),
                expected_nm: due,
            });
        }
        let value = parse_number(value_field).ok_or_else(|| malformed(line_no, line, expected_line))?;
        values.push(value);
    }
    if values.len() < wavelengths.len() {
        return Err(ProtocolError::Truncated {
            got: values.len(),
            expected: wavelengths.len(),
        });
    }
    Ok(Ok(SpectralReport {
        units,
        peak_nm,
        integrated,
        photon_integrated,
        values,
    }))
}

// ---------------------------------------------------------------------------
// The instrument's side, for the simulator (section 13).

/// How the simulator writes a status (13.5).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum StatusStyle {
    /// `00000`; errors sign-aware zero-padded to five characters (`-0008`).
    #[default]
    FiveDigits,
    /// `0000`; errors unpadded (`-8`).
    FourDigits,
}

pub fn format_status(code: i32, style: StatusStyle) -> String {
    match (style, code) {
        (StatusStyle::FiveDigits, 0) => "00000".into(),
        (StatusStyle::FourDigits, 0) => "0000".into(),
        (StatusStyle::FiveDigits, c) if c < 0 => format!("-{:04}", c.unsigned_abs()),
        (_, c) => c.to_string(),
    }
}

/// The 16th byte of a spectral line (8.1, 12.5).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LineStyle {
    /// `380,1.627e-06 ` (the transcribed manual example).
    #[default]
    TrailingSpace,
    /// ` 380,1.627e-06` (vidolu's "lines starting with a space").
    LeadingSpace,
    /// `380,1.627e-006` (PTB's 10-character read).
    ThreeDigitExponent,
    /// `380,1.627e-06`: 15-byte lines.
    Plain,
}

/// `1.865e+01`: four significant digits, lower-case `e`, a signed exponent
/// of `exponent_digits` digits. Non-positive or non-finite values are 0.
pub fn format_float(v: f64, exponent_digits: usize) -> String {
    if !v.is_finite() || v <= 0.0 {
        return format!("0.000e+{:0exponent_digits$}", 0);
    }
    let s = format!("{v:.3e}");
    let (mantissa, exp) = s.split_once('e').unwrap_or((&s, "0"));
    let exp: i32 = exp.parse().unwrap_or(0);
    let sign = if exp < 0 { '-' } else { '+' };
    format!("{mantissa}e{sign}{:0exponent_digits$}", exp.unsigned_abs())
}

/// The value the instrument sends for `v`, as read back (four significant digits).
pub fn as_sent(v: f64) -> f64 {
    parse_number(format_float(v, 2).as_bytes()).unwrap_or(0.0)
}

/// Report 5 on the wire: header and one line per wavelength, CR LF each.
pub fn format_spectral_report(grid: &Grid, values: &[f64], status: StatusStyle, lines: LineStyle) -> Vec<u8> {
    let step = grid.wavelengths().get(1).map_or(1.0, |b| b - grid.wavelengths()[0]);
    let integrated: f64 = values.iter().map(|v| as_sent(*v) * step).sum();
    let peak = grid
        .wavelengths()
        .iter()
        .zip(values)
        .max_by(|a, b| a.1.total_cmp(b.1))
        .map_or(0.0, |(nm, _)| *nm);
    // Photon radiance: ∫ L λ / (h c) dλ, per second (the unit is undocumented, 12.15).
    let photon: f64 = grid
        .wavelengths()
        .iter()
        .zip(values)
        .map(|(nm, v)| v * step * nm * 1e-9 / (6.626_070_15e-34 * 299_792_458.0))
        .sum();
    let mut out = format!(
        "{},0,{},{},{}\r\n",
        format_status(0, status),
        format_float(peak, 3),
        format_float(integrated, 2),
        format_float(photon, 2)
    );
    for (nm, v) in grid.wavelengths().iter().zip(values) {
        let line = match lines {
            LineStyle::TrailingSpace => format!("{nm:.0},{} ", format_float(*v, 2)),
            LineStyle::LeadingSpace => format!(" {nm:.0},{}", format_float(*v, 2)),
            LineStyle::ThreeDigitExponent => format!("{nm:.0},{}", format_float(*v, 3)),
            LineStyle::Plain => format!("{nm:.0},{}", format_float(*v, 2)),
        };
        out.push_str(&line);
        out.push_str("\r\n");
    }
    out.into_bytes()
}

/// Report 2 on the wire.
pub fn format_xyz_report(xyz: [f64; 3], status: StatusStyle) -> Vec<u8> {
    format!(
        "{},0,{},{},{}\r\n",
        format_status(0, status),
        format_float(xyz[0], 2),
        format_float(xyz[1], 2),
        format_float(xyz[2], 2)
    )
    .into_bytes()
}

/// A status-only reply (an error, or a setup command's answer).
pub fn format_status_reply(code: i32, style: StatusStyle) -> Vec<u8> {
    format!("{}\r\n", format_status(code, style)).into_bytes()
}

/// A one-line text report (`D110`, `D111`, `D114`).
pub fn format_text_report(text: &str, style: StatusStyle) -> Vec<u8> {
    format!("{},{text}\r\n", format_status(0, style)).into_bytes()
}

/// Report 120 for a model (the PR-670 values are the manual's example; the
/// PR-655's pixel counts are unknown, 12.15, and given the same).
pub fn format_hardware_config(model: Model, style: StatusStyle) -> Vec<u8> {
    let grid = model.grid();
    let step = match model {
        Model::Pr655 => 4,
        Model::Pr670 => 2,
    };
    format!(
        "{},{},0.00,380,780,{step},256,7,247\r\n",
        format_status(0, style),
        grid.len()
    )
    .into_bytes()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A spectrum reply in the manual example's form: its header, its
    /// `382,9.910e-07` line, the rest filled in the same format.
    fn example_spectrum(model: Model, style: LineStyle) -> (Vec<u8>, Vec<f64>) {
        let grid = model.grid();
        let values: Vec<f64> = (0..grid.len()).map(|i| as_sent(1e-6 + i as f64 * 1e-6)).collect();
        (
            format_spectral_report(&grid, &values, StatusStyle::FiveDigits, style),
            values,
        )
    }

    #[test]
    fn commands_encode_as_the_clients_send_them() {
        assert_eq!(Command::Measure(5).encode(), b"M5\r");
        assert_eq!(Command::Report(110).encode(), b"D110\r");
        assert_eq!(Command::Report(602).encode(), b"D602\r");
        assert_eq!(Command::Setup(SetupParam::Units(1)).encode(), b"SU1\r");
        assert_eq!(Command::Setup(SetupParam::Exposure(0)).encode(), b"SE0\r");
        assert_eq!(Command::Setup(SetupParam::Cycles(1)).encode(), b"SN1\r");
        assert_eq!(Command::Setup(SetupParam::Sync(0)).encode(), b"SS0\r");
        assert_eq!(Command::SyncFrequency.encode(), b"F\r");
        assert_eq!(Command::Quit.encode(), b"Q", "Q goes without a terminator (2.2)");
        assert_eq!(&REMOTE_ENTRY, b"PHOTO");
    }

    #[test]
    fn the_banner_is_twelve_bytes_without_a_line_end() {
        assert_eq!(BANNER.len(), 12);
        assert!(is_banner(b" REMOTE MODE"));
        assert!(is_banner(b" REMOTE MODE\r\n"), "the PR-705 form is tolerated");
        assert!(!is_banner(b"D"), "psychopy's stray Linux device that answers `D`");
        let e = parse_banner(b"REMOTE MOD").unwrap_err();
        assert!(e.to_string().contains("REMOTE MOD"), "{e}");
    }

    #[test]
    fn statuses_of_every_documented_width_parse() {
        // 3.3 and 12.2: five digits on data reports, four in the command descriptions,
        // negative codes padded or not.
        for (text, code) in [
            ("00000", 0),
            ("0000", 0),
            ("00000,PR-670", 0),
            ("-0008", -8),
            ("-008", -8),
            ("-8", -8),
            ("-1035", -1035),
            ("-2000", -2000),
            (" 00000 ", 0),
        ] {
            assert_eq!(parse_status(text.as_bytes()), Ok(code), "{text}");
        }
        for bad in ["", "-", "OK", "0x00", "--8", "00000000", "1.0"] {
            assert!(parse_status(bad.as_bytes()).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn the_manual_examples_parse() {
        // Section 6 (manual examples) and section 10 (the example session).
        assert_eq!(
            parse_text_report(b"00000,PR-670\r\n").unwrap(),
            Ok("PR-670".to_string())
        );
        assert_eq!(
            parse_text_report(b"00000,67065106\r\n").unwrap(),
            Ok("67065106".to_string())
        );
        assert_eq!(parse_text_report(b"00000,2.22D\r\n").unwrap(), Ok("2.22D".to_string()));
        assert_eq!(
            parse_xyz_report(b"00000,0,6.136e+01,1.865e+01,2.681e+01\r\n").unwrap(),
            Ok(XyzReport {
                units: 0,
                x: 61.36,
                y: 18.65,
                z: 26.81
            })
        );
        let hw = parse_hardware_config(b"00000,201,0.00,380,780,2,256,7,247\r\n")
            .unwrap()
            .unwrap();
        assert_eq!(hw.grid(), Some(Model::Pr670.grid()));
        assert_eq!(parse_status_reply(b"00000\r\n"), Ok(0));
        assert_eq!(parse_status_reply(b"-1035\r\n"), Ok(-1035));
        assert_eq!(parse_status_reply(b"-2000\r\n"), Ok(-2000));
        assert_eq!(
            parse_sync_frequency(b"0000,60.00 Hertz (Period = 16667 milliseconds)\r\n"),
            Ok((0, Some(60.0)))
        );
        assert_eq!(parse_sync_frequency(b"-0003\r\n"), Ok((-3, None)));
        assert_eq!(parse_sync_frequency(b"0000,0.00 Hertz\r\n"), Ok((0, None)));
        // An error instead of a report is the status, not garbage.
        assert_eq!(parse_xyz_report(b"-0008\r\n").unwrap(), Err(-8));
        assert_eq!(parse_text_report(b"-2000\r\n").unwrap(), Err(-2000));
    }

    #[test]
    fn the_manual_example_spectrum_header_and_line_parse() {
        // 8.1: `00000,0,0.000e+000,1.827e-01,5.147e+01`, then `380,…`, `382,9.910e-07 `.
        let grid = Model::Pr670.grid();
        let mut reply = b"00000,0,0.000e+000,1.827e-01,5.147e+01\r\n".to_vec();
        for (i, nm) in grid.wavelengths().iter().enumerate() {
            let v = if i == 1 {
                "9.910e-07 ".to_string()
            } else {
                "1.627e-06 ".to_string()
            };
            reply.extend(format!("{nm:.0},{v}\r\n").bytes());
        }
        let report = parse_spectral_report(&reply, &grid).unwrap().unwrap();
        assert_eq!(report.values.len(), 201);
        assert_eq!(report.values[1], 9.910e-07);
        assert_eq!((report.units, report.integrated), (0, 0.1827));
    }

    #[test]
    fn every_uncertain_line_style_parses_to_the_same_per_nm_values() {
        for model in [Model::Pr655, Model::Pr670] {
            for style in [
                LineStyle::TrailingSpace,
                LineStyle::LeadingSpace,
                LineStyle::ThreeDigitExponent,
                LineStyle::Plain,
            ] {
                let (reply, values) = example_spectrum(model, style);
                let report = parse_spectral_report(&reply, &model.grid()).unwrap().unwrap();
                assert_eq!(report.values, values, "{model:?} {style:?}");
            }
        }
        // The PR-655's 16-byte lines (8.1): one of the three candidates makes each line 16 bytes.
        let (reply, _) = example_spectrum(Model::Pr655, LineStyle::TrailingSpace);
        let second = reply.split(|b| *b == b'\n').nth(1).unwrap();
        assert_eq!(second.len() + 1, 16, "`380,1.000e-06 \\r\\n`");
    }

    #[test]
    fn a_bare_lf_and_stray_empty_lines_are_tolerated() {
        let (reply, values) = example_spectrum(Model::Pr655, LineStyle::Plain);
        let lf_only: Vec<u8> = reply.iter().copied().filter(|b| *b != b'\r').collect();
        let mut with_empty = b"\r\n".to_vec();
        with_empty.extend(&reply);
        for bytes in [lf_only, with_empty] {
            let report = parse_spectral_report(&bytes, &Model::Pr655.grid()).unwrap().unwrap();
            assert_eq!(report.values, values);
        }
    }

    #[test]
    fn a_spectrum_on_the_wrong_grid_or_out_of_order_is_an_error_never_shifted_data() {
        let (pr670, _) = example_spectrum(Model::Pr670, LineStyle::Plain);
        assert_eq!(
            parse_spectral_report(&pr670, &Model::Pr655.grid()),
            Err(ProtocolError::WrongWavelength {
                line: 3,
                got_nm: 382.0,
                expected_nm: 384.0
            })
        );
        let (pr655, _) = example_spectrum(Model::Pr655, LineStyle::Plain);
        let text = String::from_utf8(pr655).unwrap();
        let mut lines: Vec<&str> = text.split_inclusive('\n').collect();
        lines.swap(5, 6);
        let swapped = lines.concat();
        assert!(matches!(
            parse_spectral_report(swapped.as_bytes(), &Model::Pr655.grid()),
            Err(ProtocolError::WrongWavelength { line: 6, .. })
        ));
        let cut: String = text.split_inclusive('\n').take(50).collect();
        assert_eq!(
            parse_spectral_report(cut.as_bytes(), &Model::Pr655.grid()),
            Err(ProtocolError::Truncated { got: 49, expected: 101 })
        );
        let mut doubled = text.clone();
        doubled.push_str("780,1.000e-06\r\n");
        assert!(matches!(
            parse_spectral_report(doubled.as_bytes(), &Model::Pr655.grid()),
            Err(ProtocolError::Trailing { extra: 1, .. })
        ));
    }

    #[test]
    fn garbled_lines_are_errors_that_show_the_bytes() {
        let (reply, _) = example_spectrum(Model::Pr655, LineStyle::Plain);
        let mut text = String::from_utf8(reply).unwrap();
        text = text.replacen("388,", "388;", 1);
        let e = parse_spectral_report(text.as_bytes(), &Model::Pr655.grid()).unwrap_err();
        assert!(e.to_string().contains("388;"), "{e}");
        let e = parse_spectral_report(b"00000,0,garbage\r\n", &Model::Pr655.grid()).unwrap_err();
        assert!(e.to_string().contains("garbage"), "{e}");
        let e = parse_xyz_report(b"00000,0,1.0,2.0\r\n").unwrap_err();
        assert!(e.to_string().contains("00000,0,1.0,2.0"), "{e}");
    }

    #[test]
    fn an_error_status_is_reported_and_lines_after_it_are_never_data() {
        let grid = Model::Pr655.grid();
        assert_eq!(parse_spectral_report(b"-0008\r\n", &grid), Ok(Err(-8)));
        assert_eq!(parse_spectral_report(b"-8\r\n380,1.0e-06\r\n", &grid), Ok(Err(-8)));
    }

    #[test]
    fn reply_length_follows_the_status_of_the_first_line() {
        let m5 = Command::Measure(REPORT_SPECTRUM);
        assert_eq!(m5.reply_lines(b"00000,0,5.4e+02,1.8e-01,5.1e+01", 201), 202);
        assert_eq!(m5.reply_lines(b"-0008", 201), 1);
        assert_eq!(Command::Report(REPORT_XYZ).reply_lines(b"00000,0,1,2,3", 101), 1);
        assert_eq!(Command::Quit.reply_lines(b"", 101), 0);
    }

    #[test]
    fn statuses_format_in_both_simulator_styles() {
        assert_eq!(format_status(0, StatusStyle::FiveDigits), "00000");
        assert_eq!(format_status(-8, StatusStyle::FiveDigits), "-0008");
        assert_eq!(format_status(-1035, StatusStyle::FiveDigits), "-1035");
        assert_eq!(format_status(0, StatusStyle::FourDigits), "0000");
        assert_eq!(format_status(-8, StatusStyle::FourDigits), "-8");
        assert_eq!(format_float(18.65, 2), "1.865e+01");
        assert_eq!(format_float(9.91e-7, 3), "9.910e-007");
    }

    proptest! {
        #[test]
        fn parsers_never_panic_on_arbitrary_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..4000)) {
            let _ = parse_spectral_report(&bytes, &Model::Pr655.grid());
            let _ = parse_spectral_report(&bytes, &Model::Pr670.grid());
            let _ = parse_xyz_report(&bytes);
            let _ = parse_text_report(&bytes);
            let _ = parse_hardware_config(&bytes);
            let _ = parse_sync_frequency(&bytes);
            let _ = parse_status_reply(&bytes);
            let _ = parse_banner(&bytes);
            let _ = complete_lines(&bytes);
            let _ = Command::Measure(5).reply_lines(&bytes, 201);
        }

        #[test]
        fn any_formatted_spectrum_parses_back_to_four_digits(
            values in proptest::collection::vec(1e-9f64..1e3, 201),
            style in 0usize..4,
        ) {
            let grid = Model::Pr670.grid();
            let style = [LineStyle::TrailingSpace, LineStyle::LeadingSpace, LineStyle::ThreeDigitExponent, LineStyle::Plain][style];
            let reply = format_spectral_report(&grid, &values, StatusStyle::FiveDigits, style);
            let report = parse_spectral_report(&reply, &grid).unwrap().unwrap();
            for (got, want) in report.values.iter().zip(&values) {
                prop_assert!((got - want).abs() <= want * 6e-4, "{got} vs {want}");
            }
        }

        #[test]
        fn near_miss_spectra_are_errors_not_data(cut in 1usize..200, byte in any::<u8>()) {
            // A spectrum with one byte replaced inside a wavelength field either still
            // parses to the right grid or is an error; it is never shifted.
            let grid = Model::Pr670.grid();
            let (reply, _) = example_spectrum(Model::Pr670, LineStyle::Plain);
            let text = String::from_utf8(reply).unwrap();
            let mut lines: Vec<String> = text.split_inclusive('\n').map(String::from).collect();
            let mut line = lines[cut].clone().into_bytes();
            line[1] = byte;
            lines[cut] = String::from_utf8_lossy(&line).into_owned();
            if let Ok(Ok(report)) = parse_spectral_report(lines.concat().as_bytes(), &grid) {
                prop_assert_eq!(report.values.len(), 201);
            }
        }
    }
}
