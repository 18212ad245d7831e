//! The PR-650's remote protocol as bytes: command encoding, reply parsing and
//! reply formatting (the simulator's side). Pure: no I/O, no clocks, and the
//! parsers never panic, whatever the bytes (property-tested below).
//!
//! The reference is `docs/src/instruments/pr650-protocol.md` (sections 1–4). Where it
//! marks a point \[uncertain\], the choice made here is commented at the spot.
//!
//! Replies are split into lines at CR, LF or CR LF, with empty lines skipped
//! ([`split_lines`], the link's own framing; section 3: header line 1 may end
//! in a bare CR; a doubled CR LF is harmless). What the quality codes and
//! setup statuses mean is [`super::codes`].
//!
//! Spectral data lines are recognised by their form and their wavelength
//! must be the next one of the expected grid, so reordered, doubled or
//! missing lines are errors, never silently shifted data.

use crate::link::lines::{split_lines, Terminator};
use lightbooth_science::spectrum::Grid;

use crate::reply::{malformed, show};
pub use crate::reply::{parse_number, ProtocolError};

/// The `sync` field of the `S` command.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SyncSetting {
    /// Empty field: no synchronisation.
    Off,
    /// `1`: use the frequency found by the last `F`.
    LastF,
    /// 40–250 Hz.
    Hz(u32),
}

/// The fields of the `S` measurement-setup command that lightbooth sets.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Setup {
    /// Primary accessory, 1–12 (1 = standard objective, MS-75).
    pub primary_accessory: u8,
    pub sync: SyncSetting,
    /// 0 = adaptive, or 10–6000 ms.
    pub integration_ms: u32,
    /// Measurements averaged inside the instrument, 1–99. lightbooth averages
    /// itself so it keeps every sample: 1.
    pub averages: u8,
    /// Metric units (cd/m²), not English (fL).
    pub metric: bool,
}

impl Default for Setup {
    fn default() -> Setup {
        Setup {
            primary_accessory: 1,
            sync: SyncSetting::Off,
            integration_ms: 0,
            averages: 1,
            metric: true,
        }
    }
}

/// A command to the PR-650 (section 2). `E` (echo) is deliberately absent:
/// it cannot be undone without a power cycle.
#[derive(Clone, Debug, PartialEq)]
pub enum Command {
    /// `B<n>`: backlight 0–3; the usual first command and ping. Reply `000`.
    Backlight(u8),
    /// `S…`: measurement setup. Reply `pp`.
    Setup(Setup),
    /// `M0`: measure and hold. Reply `000` when done.
    MeasureAndHold,
    /// `D<code>`: resend report `code` of the last measurement; never measures.
    Report(u16),
    /// `F`: measure the source's flicker frequency. Reply `qq,<Hz>`.
    SyncFrequency,
}

/// Report codes used with `D`.
pub const REPORT_YXY: u16 = 1;
pub const REPORT_XYZ: u16 = 2;
pub const REPORT_SPECTRUM: u16 = 5;
pub const REPORT_SERIAL: u16 = 110;
pub const REPORT_CONFIG: u16 = 120;
pub const REPORT_SETUP_STATUS: u16 = 201;

impl Command {
    /// The command text without terminator, as the log and errors show it.
    pub fn text(&self) -> String {
        match self {
            Command::Backlight(n) => format!("B{n}"),
            Command::Setup(s) => {
                let sync = match s.sync {
                    SyncSetting::Off => String::new(),
                    SyncSetting::LastF => "1".into(),
                    SyncSetting::Hz(hz) => hz.to_string(),
                };
                // Accessories 2–4 empty = unchanged; PTB's `s01,,,,,0,01,1` has this shape.
                format!(
                    "S{:02},,,,{sync},{},{:02},{}",
                    s.primary_accessory,
                    s.integration_ms,
                    s.averages,
                    u8::from(s.metric)
                )
            }
            Command::MeasureAndHold => "M0".into(),
            Command::Report(code) => format!("D{code}"),
            Command::SyncFrequency => "F".into(),
        }
    }

    /// The bytes on the wire.
    pub fn encode(&self, terminator: Terminator) -> Vec<u8> {
        let mut out = self.text().into_bytes();
        out.extend_from_slice(terminator.bytes());
        out
    }

    /// How many non-empty reply lines to wait for.
    pub fn reply_lines(&self, grid_len: usize) -> usize {
        match self {
            Command::Report(REPORT_SPECTRUM) => 2 + grid_len,
            _ => 1,
        }
    }
}

fn trim(line: &[u8]) -> &[u8] {
    line.trim_ascii()
}

/// A decimal of only digits: the status fields `000`, `pp`, `qq`.
fn parse_digits(field: &[u8]) -> Option<u32> {
    if field.is_empty() || field.len() > 6 || !field.iter().all(u8::is_ascii_digit) {
        return None;
    }
    std::str::from_utf8(field).ok()?.parse().ok()
}

/// The `000` acknowledgement of `B` and `M0`.
pub fn parse_ack(bytes: &[u8]) -> Result<u32, ProtocolError> {
    let lines = split_lines(bytes);
    let first = lines.first().ok_or(ProtocolError::Empty)?;
    parse_digits(trim(first)).ok_or_else(|| malformed(1, first, "a status number such as `000`"))
}

/// The two-digit status of `S` (and `D201`): 0 = OK, 1–8 the bad field, 50 accessory.
pub fn parse_setup_status(bytes: &[u8]) -> Result<u8, ProtocolError> {
    let lines = split_lines(bytes);
    let first = lines.first().ok_or(ProtocolError::Empty)?;
    parse_digits(trim(first))
        .and_then(|v| u8::try_from(v).ok())
        .ok_or_else(|| malformed(1, first, "a two-digit setup status such as `00`"))
}

/// The `qq,U` header of reports 1–6.
fn parse_code_unit(line: &[u8], line_no: usize) -> Result<(u8, u8), ProtocolError> {
    let fields: Vec<&[u8]> = trim(line).split(|b| *b == b',').collect();
    let bad = || malformed(line_no, line, "a `qq,U` header (two-digit quality code, unit digit)");
    if fields.len() < 2 || fields[0].len() != 2 || fields[1].len() != 1 {
        return Err(bad());
    }
    let code = parse_digits(fields[0]).ok_or_else(bad)? as u8;
    let unit = parse_digits(fields[1]).ok_or_else(bad)? as u8;
    Ok((code, unit))
}

/// Report 5: the spectrum.
#[derive(Clone, Debug, PartialEq)]
pub struct SpectralReport {
    /// The quality code from the header (the one that counts, not `M0`'s ack).
    pub code: u8,
    /// 0 radiance W/(sr·m²·nm), 1 irradiance W/(m²·nm), 2 uncalibrated.
    pub unit_flag: u8,
    /// Area under the curve (W/(sr·m²) for radiance).
    pub integral: f64,
    /// Per-nm values on the expected grid (not multiplied by the step).
    pub values: Vec<f64>,
}

/// Parses a `D5`/`M5` reply. `grid` is the instrument's spectral
/// configuration (`D120`; [`Grid::pr650`] by default): every data line must
/// carry the next wavelength of it. Lines before the `qq,U` header that do
/// not look like one (a stale `000`) are skipped, as PTB's search for the
/// first data line does; anything after the last data line is an error.
pub fn parse_spectral_report(bytes: &[u8], grid: &Grid) -> Result<SpectralReport, ProtocolError> {
    let lines = split_lines(bytes);
    if lines.is_empty() {
        return Err(ProtocolError::Empty);
    }
    let header_at = lines
        .iter()
        .position(|l| parse_code_unit(l, 0).is_ok())
        .ok_or_else(|| malformed(1, lines[0], "a `qq,U` spectral header"))?;
    let (code, unit_flag) = parse_code_unit(lines[header_at], header_at + 1)?;
    let integral_line = lines.get(header_at + 1).ok_or(ProtocolError::Truncated {
        got: 0,
        expected: grid.len(),
    })?;
    let integral = parse_number(integral_line)
        .ok_or_else(|| malformed(header_at + 2, integral_line, "the integrated value (`i.iiiEsee`)"))?;
    let data = &lines[header_at + 2..];
    let mut values = Vec::with_capacity(grid.len());
    for (i, &expected_nm) in grid.wavelengths().iter().enumerate() {
        let line_no = header_at + 3 + i;
        let Some(line) = data.get(i) else {
            return Err(ProtocolError::Truncated {
                got: i,
                expected: grid.len(),
            });
        };
        let (nm, value) = parse_data_line(line, line_no)?;
        if (nm - expected_nm).abs() > 1e-6 {
            return Err(ProtocolError::WrongWavelength {
                line: line_no,
                got_nm: nm,
                expected_nm,
            });
        }
        values.push(value);
    }
    if data.len() > grid.len() {
        return Err(ProtocolError::Trailing {
            extra: data.len() - grid.len(),
            first: show(data[grid.len()]),
        });
    }
    Ok(SpectralReport {
        code,
        unit_flag,
        integral,
        values,
    })
}

/// `wwww.,r.rrrEsee`.
fn parse_data_line(line: &[u8], line_no: usize) -> Result<(f64, f64), ProtocolError> {
    let bad = || malformed(line_no, line, "a spectral line `wwww.,r.rrrEsee`");
    let mut fields = trim(line).split(|b| *b == b',');
    let (Some(w), Some(v), None) = (fields.next(), fields.next(), fields.next()) else {
        return Err(bad());
    };
    let nm = parse_number(w).ok_or_else(bad)?;
    let value = parse_number(v).ok_or_else(bad)?;
    Ok((nm, value))
}

/// Report 2: `qq,U,X,Y,Z`; Y in cd/m² (metric units, U = 0).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct XyzReport {
    pub code: u8,
    pub unit_flag: u8,
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

pub fn parse_xyz_report(bytes: &[u8]) -> Result<XyzReport, ProtocolError> {
    let [a, b, c, code, unit_flag] = parse_three_values(bytes, "a `qq,U,X,Y,Z` report")?;
    Ok(XyzReport {
        code: code as u8,
        unit_flag: unit_flag as u8,
        x: a,
        y: b,
        z: c,
    })
}

/// Report 1: `qq,U,Y,.xxxx,.yyyy`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct YxyReport {
    pub code: u8,
    pub unit_flag: u8,
    pub luminance: f64,
    pub x: f64,
    pub y: f64,
}

pub fn parse_yxy_report(bytes: &[u8]) -> Result<YxyReport, ProtocolError> {
    let [l, x, y, code, unit_flag] = parse_three_values(bytes, "a `qq,U,Y,x,y` report")?;
    Ok(YxyReport {
        code: code as u8,
        unit_flag: unit_flag as u8,
        luminance: l,
        x,
        y,
    })
}

/// `qq,U,a,b,c` → [a, b, c, qq, U]. On a bad quality code the PR-650 may send
/// fewer numbers \[uncertain\]; then the missing values are 0 (the caller
/// discards them anyway, since the code is bad).
fn parse_three_values(bytes: &[u8], expected: &'static str) -> Result<[f64; 5], ProtocolError> {
    let lines = split_lines(bytes);
    let first = lines.first().ok_or(ProtocolError::Empty)?;
    let (code, unit) = parse_code_unit(first, 1).map_err(|_| malformed(1, first, expected))?;
    let fields: Vec<&[u8]> = trim(first).split(|b| *b == b',').collect();
    let mut out = [0.0, 0.0, 0.0, f64::from(code), f64::from(unit)];
    if code != 0 && fields.len() == 2 {
        return Ok(out);
    }
    if fields.len() != 5 {
        return Err(malformed(1, first, expected));
    }
    for i in 0..3 {
        out[i] = parse_number(fields[2 + i]).ok_or_else(|| malformed(1, first, expected))?;
    }
    if lines.len() > 1 {
        return Err(ProtocolError::Trailing {
            extra: lines.len() - 1,
            first: show(lines[1]),
        });
    }
    Ok(out)
}

/// `D110`: the serial number. PTB takes the first 8 characters, which "may
/// contain trailing blanks"; no status prefix \[uncertain\]. A `qq,` prefix (as
/// later models send) is tolerated and dropped.
pub fn parse_serial(bytes: &[u8]) -> Result<String, ProtocolError> {
    let lines = split_lines(bytes);
    let first = lines.first().ok_or(ProtocolError::Empty)?;
    let text = String::from_utf8_lossy(trim(first)).into_owned();
    let text = match text.split_once(',') {
        Some((status, rest)) if status.bytes().all(|b| b.is_ascii_digit()) => rest.to_string(),
        _ => text,
    };
    let serial: String = text.chars().take(8).collect::<String>().trim().to_string();
    if serial.is_empty()
        || !serial
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == ' ')
    {
        return Err(malformed(1, first, "a serial number"));
    }
    Ok(serial)
}

/// `D120`: `pppp,bbb.b,ffff.,wwww.,iii.`, the spectral configuration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpectralConfig {
    pub points: usize,
    pub bandwidth_nm: f64,
    pub first_nm: f64,
    pub last_nm: f64,
    pub step_nm: f64,
}

impl SpectralConfig {
    /// The grid it describes, if self-consistent.
    pub fn grid(&self) -> Option<Grid> {
        let consistent = self.points >= 2
            && self.points <= 2000
            && self.step_nm > 0.0
            && (self.first_nm + self.step_nm * (self.points - 1) as f64 - self.last_nm).abs() < 1e-6;
        consistent.then(|| Grid::uniform(self.first_nm, self.step_nm, self.points))
    }
}

pub fn parse_spectral_config(bytes: &[u8]) -> Result<SpectralConfig, ProtocolError> {
    let expected = "a configuration line `pppp,bbb.b,ffff.,wwww.,iii.`";
    let lines = split_lines(bytes);
    let first = lines.first().ok_or(ProtocolError::Empty)?;
    let fields: Vec<&[u8]> = trim(first).split(|b| *b == b',').collect();
    if fields.len() != 5 {
        return Err(malformed(1, first, expected));
    }
    let mut v = [0.0; 5];
    for (slot, field) in v.iter_mut().zip(&fields) {
        *slot = parse_number(field).ok_or_else(|| malformed(1, first, expected))?;
    }
    if v[0] < 1.0 || v[0] > 10_000.0 || v[0].fract() != 0.0 {
        return Err(malformed(1, first, expected));
    }
    Ok(SpectralConfig {
        points: v[0] as usize,
        bandwidth_nm: v[1],
        first_nm: v[2],
        last_nm: v[3],
        step_nm: v[4],
    })
}

/// `F`: `qq,<Hz>`; on failure maybe only `qq` \[uncertain\]. Returns the code
/// and the frequency when the code is 0.
pub fn parse_sync_frequency(bytes: &[u8]) -> Result<(u8, Option<f64>), ProtocolError> {
    let expected = "a sync reply `qq,<Hz>`";
    let lines = split_lines(bytes);
    let first = lines.first().ok_or(ProtocolError::Empty)?;
    let fields: Vec<&[u8]> = trim(first).split(|b| *b == b',').collect();
    let code = parse_digits(fields[0])
        .and_then(|c| u8::try_from(c).ok())
        .ok_or_else(|| malformed(1, first, expected))?;
    let hz = match fields.get(1) {
        Some(f) => Some(parse_number(f).ok_or_else(|| malformed(1, first, expected))?),
        None => None,
    };
    if code == 0 && hz.is_none() {
        return Err(malformed(1, first, expected));
    }
    Ok((code, if code == 0 { hz } else { None }))
}

// ---------------------------------------------------------------------------
// Formatting: the instrument's side, used by the simulator.

/// `d.dddEsdd`: 9 characters, upper-case E, signed two-digit exponent. Values
/// are clamped into what the format can hold: negatives (noise below zero) are
/// sent as `0.000E+00` so every data line keeps its 17-byte stride (how the
/// real unit prints negatives is undocumented; fixed-stride parsers like PTB's
/// would break on a 10-character field).
pub fn format_float(v: f64) -> String {
    if !v.is_finite() || v <= 0.0 {
        return "0.000E+00".into();
    }
    let s = format!("{v:.3E}"); // e.g. 1.203E-5
    let (mantissa, exp) = s.split_once('E').unwrap_or((&s, "0"));
    let exp: i32 = exp.parse().unwrap_or(0);
    if exp < -99 {
        return "0.000E+00".into();
    }
    if exp > 99 {
        return "9.999E+99".into();
    }
    let sign = if exp < 0 { '-' } else { '+' };
    format!("{mantissa}E{sign}{:02}", exp.abs())
}

/// The value the instrument would actually send for `v` (after rounding to
/// four significant digits), for comparisons in tests.
pub fn as_sent(v: f64) -> f64 {
    parse_number(format_float(v).as_bytes()).unwrap_or(0.0)
}

/// Report 5 on the wire. `header_bare_cr` ends header line 1 in CR only, the
/// variant Mcalibrator2's paraphrase of the manual prints (section 3).
pub fn format_spectral_report(
    code: u8,
    unit_flag: u8,
    integral: f64,
    grid: &Grid,
    values: &[f64],
    header_bare_cr: bool,
) -> Vec<u8> {
    let mut out = format!("{code:02},{unit_flag}").into_bytes();
    out.extend_from_slice(if header_bare_cr { b"\r" } else { b"\r\n" });
    out.extend_from_slice(format!("{}\r\n", format_float(integral)).as_bytes());
    for (nm, v) in grid.wavelengths().iter().zip(values) {
        out.extend_from_slice(format!("{:04}.,{}\r\n", nm.round() as i64, format_float(*v)).as_bytes());
    }
    out
}

/// Report 2 on the wire.
pub fn format_xyz_report(code: u8, unit_flag: u8, x: f64, y: f64, z: f64) -> Vec<u8> {
    format!(
        "{code:02},{unit_flag},{},{},{}\r\n",
        format_float(x),
        format_float(y),
        format_float(z)
    )
    .into_bytes()
}

/// A chromaticity as `.xxxx` (no leading zero).
pub fn format_chromaticity(v: f64) -> String {
    let s = format!("{:.4}", v.clamp(0.0, 0.9999));
    s.trim_start_matches('0').to_string()
}

/// Report 1 on the wire.
pub fn format_yxy_report(code: u8, unit_flag: u8, luminance: f64, x: f64, y: f64) -> Vec<u8> {
    format!(
        "{code:02},{unit_flag},{},{},{}\r\n",
        format_float(luminance),
        format_chromaticity(x),
        format_chromaticity(y)
    )
    .into_bytes()
}

/// Report 120 on the wire for a uniform grid.
pub fn format_spectral_config(grid: &Grid, bandwidth_nm: f64) -> Vec<u8> {
    format!(
        "{:04},{:05.1},{:04}.,{:04}.,{:04}.\r\n",
        grid.len(),
        bandwidth_nm,
        grid.first_nm().round() as i64,
        grid.last_nm().round() as i64,
        grid.step_nm().unwrap_or(0.0).round() as i64
    )
    .into_bytes()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::lines::complete_lines;
    use crate::pr650::codes::{quality_code, setup_status_meaning};
    use crate::QualityKind;
    use proptest::prelude::*;

    /// The document's example spectrum: its three example lines, the rest filled
    /// in the same fixed-width format.
    fn example_d5(header_end: &str) -> Vec<u8> {
        let mut s = format!("00,0{header_end}2.817E-01\r\n");
        for i in 0..101 {
            let nm = 380 + 4 * i;
            let v = match nm {
                380 => "1.203E-05".to_string(),
                384 => "1.388E-05".to_string(),
                780 => "3.042E-04".to_string(),
                _ => format_float(1e-4 + i as f64 * 1e-6),
            };
            s.push_str(&format!("{nm:04}.,{v}\r\n"));
        }
        s.into_bytes()
    }

    #[test]
    fn commands_encode_as_the_clients_send_them() {
        assert_eq!(Command::Backlight(3).encode(Terminator::Lf), b"B3\n");
        assert_eq!(Command::MeasureAndHold.encode(Terminator::Cr), b"M0\r");
        assert_eq!(Command::Report(5).encode(Terminator::Crlf), b"D5\r\n");
        assert_eq!(Command::Setup(Setup::default()).text(), "S01,,,,,0,01,1");
        let synced = Setup {
            sync: SyncSetting::LastF,
            ..Setup::default()
        };
        assert_eq!(Command::Setup(synced).text(), "S01,,,,1,0,01,1"); // PTB's sync-on string
        assert_eq!(Command::Report(110).text(), "D110");
    }

    #[test]
    fn parses_the_documents_spectral_example() {
        let bytes = example_d5("\r\n");
        assert_eq!(bytes.len(), 1734, "6 + 11 + 101·17 bytes");
        let r = parse_spectral_report(&bytes, &Grid::pr650()).unwrap();
        assert_eq!((r.code, r.unit_flag), (0, 0));
        assert_eq!(r.integral, 0.2817);
        assert_eq!(r.values.len(), 101);
        assert_eq!(r.values[0], 1.203e-5);
        assert_eq!(r.values[1], 1.388e-5);
        assert_eq!(r.values[100], 3.042e-4);
        assert_eq!(complete_lines(&bytes), 103);
    }

    #[test]
    fn tolerates_a_bare_cr_header_lowercase_e_and_a_leading_ack() {
        let mut bytes = b"000\r\n".to_vec();
        bytes.extend(
            String::from_utf8(example_d5("\r"))
                .unwrap()
                .replace('E', "e")
                .into_bytes(),
        );
        let r = parse_spectral_report(&bytes, &Grid::pr650()).unwrap();
        assert_eq!(r.values[0], 1.203e-5);
    }

    #[test]
    fn parses_the_documents_report_examples() {
        let r1 = parse_yxy_report(b"00,0,4.404E+01,.3127,.3290\r\n").unwrap();
        assert_eq!((r1.code, r1.luminance, r1.x, r1.y), (0, 44.04, 0.3127, 0.3290));
        let r2 = parse_xyz_report(b"00,0,4.185E+01,4.404E+01,4.795E+01\r\n").unwrap();
        assert_eq!((r2.x, r2.y, r2.z), (41.85, 44.04, 47.95));
        assert_eq!(parse_ack(b"000\r\n").unwrap(), 0);
        assert_eq!(parse_setup_status(b"00\r\n").unwrap(), 0);
        assert_eq!(parse_setup_status(b"06\r\n").unwrap(), 6);
        assert!(setup_status_meaning(6).contains("integration time"));
        assert!(setup_status_meaning(50).contains("primary"));
        assert_eq!(parse_sync_frequency(b"00,60.02\r\n").unwrap(), (0, Some(60.02)));
        assert_eq!(parse_sync_frequency(b"07\r\n").unwrap(), (7, None));
        let c = parse_spectral_config(b"0101,008.0,0380.,0780.,0004.\r\n").unwrap();
        assert_eq!(c.grid().unwrap(), Grid::pr650());
        assert_eq!(c.bandwidth_nm, 8.0);
        assert_eq!(parse_serial(b"60954303  \r\n").unwrap(), "60954303");
        assert_eq!(parse_serial(b"A1234567\r\n").unwrap(), "A1234567");
    }

    #[test]
    fn every_documented_code_has_a_typed_meaning() {
        let table: [(u8, QualityKind); 20] = [
            (0, QualityKind::Ok),
            (1, QualityKind::Hardware),
            (3, QualityKind::Hardware),
            (4, QualityKind::Hardware),
            (5, QualityKind::Hardware),
            (6, QualityKind::Sync),
            (7, QualityKind::Sync),
            (8, QualityKind::Sync),
            (10, QualityKind::LowLight),
            (12, QualityKind::Hardware),
            (13, QualityKind::Hardware),
            (14, QualityKind::Other),
            (16, QualityKind::Other),
            (17, QualityKind::Hardware),
            (18, QualityKind::LowLight),
            (19, QualityKind::Overload),
            (20, QualityKind::Sync),
            (21, QualityKind::Hardware),
            (29, QualityKind::Other),
            (30, QualityKind::Other),
        ];
        for (code, kind) in table {
            let q = quality_code(code);
            assert_eq!(q.kind, kind, "code {code}");
            assert_eq!(q.code, i32::from(code));
            assert!(!q.message.is_empty() && q.message != "not a PR-650 quality code");
            // The report carries it; the parser hands it back typed.
            let mut d5 = example_d5("\r\n");
            d5[..2].copy_from_slice(format!("{code:02}").as_bytes());
            assert_eq!(parse_spectral_report(&d5, &Grid::pr650()).unwrap().code, code);
            let r2 = parse_xyz_report(format!("{code:02},0,0.000E+00,0.000E+00,0.000E+00\r\n").as_bytes()).unwrap();
            assert_eq!(r2.code, code);
        }
        assert!(quality_code(18).spectrum_is_stale() && quality_code(10).spectrum_is_stale());
        assert!(!quality_code(19).spectrum_is_stale());
        assert_eq!(quality_code(2).kind, QualityKind::Unknown);
        assert!(
            parse_xyz_report(b"18,0\r\n").is_ok(),
            "a failed report may carry only qq,U"
        );
    }

    #[test]
    fn truncated_reordered_doubled_and_garbled_spectra_are_errors() {
        let good = example_d5("\r\n");
        let text = String::from_utf8(good.clone()).unwrap();
        let lines: Vec<&str> = text.split_inclusive("\r\n").collect();
        // Truncated mid-spectrum (and mid-line).
        let cut = &good[..good.len() / 2];
        assert!(matches!(
            parse_spectral_report(cut, &Grid::pr650()),
            Err(ProtocolError::Truncated { .. }) | Err(ProtocolError::Malformed { .. })
        ));
        let cut_at_line: String = lines[..50].concat();
        assert_eq!(
            parse_spectral_report(cut_at_line.as_bytes(), &Grid::pr650()),
            Err(ProtocolError::Truncated { got: 48, expected: 101 })
        );
        // Two lines swapped.
        let mut swapped = lines.clone();
        swapped.swap(10, 11);
        assert!(matches!(
            parse_spectral_report(swapped.concat().as_bytes(), &Grid::pr650()),
            Err(ProtocolError::WrongWavelength { .. })
        ));
        // A line doubled.
        let mut doubled = lines.clone();
        doubled.insert(10, lines[10]);
        assert!(matches!(
            parse_spectral_report(doubled.concat().as_bytes(), &Grid::pr650()),
            Err(ProtocolError::WrongWavelength { .. })
        ));
        // The last line doubled.
        let mut tail = lines.clone();
        tail.push(lines[102]);
        assert!(matches!(
            parse_spectral_report(tail.concat().as_bytes(), &Grid::pr650()),
            Err(ProtocolError::Trailing { .. })
        ));
        // A doubled CR LF is harmless.
        let mut blank = lines.clone();
        blank.insert(20, "\r\n");
        assert!(parse_spectral_report(blank.concat().as_bytes(), &Grid::pr650()).is_ok());
        // Garbage in a value.
        let garbled = text.replacen("1.388E-05", "1.3#8E-05", 1);
        assert!(matches!(
            parse_spectral_report(garbled.as_bytes(), &Grid::pr650()),
            Err(ProtocolError::Malformed { line: 4, .. })
        ));
        assert!(parse_spectral_report(b"nan,0\r\n", &Grid::pr650()).is_err());
        assert!(parse_number(b"inf").is_none() && parse_number(b"NaN").is_none());
    }

    #[test]
    fn formatting_round_trips_in_the_fixed_widths() {
        for v in [1.203e-5, 0.2817, 44.04, 9.9996e3, 1.0, 123456.0] {
            let s = format_float(v);
            assert_eq!(s.len(), 9, "{s}");
            assert!(
                (parse_number(s.as_bytes()).unwrap() - v).abs() <= v * 5e-4,
                "{s} vs {v}"
            );
        }
        assert_eq!(format_float(1.203e-5), "1.203E-05");
        assert_eq!(format_float(-1e-6), "0.000E+00");
        assert_eq!(format_chromaticity(0.3127), ".3127");
        assert_eq!(
            format_spectral_config(&Grid::pr650(), 8.0),
            b"0101,008.0,0380.,0780.,0004.\r\n"
        );
        let values = vec![1e-3; 101];
        let bytes = format_spectral_report(0, 0, 0.4, &Grid::pr650(), &values, false);
        assert_eq!(bytes.len(), 1734);
        assert!(bytes
            .split(|b| *b == b'\n')
            .skip(2)
            .filter(|l| !l.is_empty())
            .all(|l| l.len() == 16));
    }

    proptest! {
        #[test]
        fn parsers_never_panic_on_arbitrary_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..2000)) {
            let _ = parse_spectral_report(&bytes, &Grid::pr650());
            let _ = parse_xyz_report(&bytes);
            let _ = parse_yxy_report(&bytes);
            let _ = parse_ack(&bytes);
            let _ = parse_setup_status(&bytes);
            let _ = parse_serial(&bytes);
            let _ = parse_spectral_config(&bytes);
            let _ = parse_sync_frequency(&bytes);
            let _ = complete_lines(&bytes);
        }

        #[test]
        fn any_formatted_spectrum_parses_back_to_four_digits(
            values in proptest::collection::vec(1e-9f64..1e3, 101),
            code in 0u8..31,
            bare_cr in any::<bool>(),
        ) {
            let bytes = format_spectral_report(code, 0, 1.0, &Grid::pr650(), &values, bare_cr);
            prop_assert_eq!(complete_lines(&bytes), 103);
            let r = parse_spectral_report(&bytes, &Grid::pr650()).unwrap();
            prop_assert_eq!(r.code, code);
            for (got, want) in r.values.iter().zip(&values) {
                prop_assert!((got - want).abs() <= 5e-4 * want, "{} vs {}", got, want);
            }
        }

        #[test]
        fn mangled_spectra_are_rejected_or_exact(
            ops in proptest::collection::vec((0usize..103, 0usize..103, 0u8..4), 1..6)
        ) {
            let good = example_d5("\r\n");
            let text = String::from_utf8(good).unwrap();
            let original: Vec<String> = text.split_inclusive("\r\n").map(String::from).collect();
            let mut lines = original.clone();
            for (a, b, op) in ops {
                let (a, b) = (a % lines.len().max(1), b % lines.len().max(1));
                match op {
                    0 => { lines.truncate(a); }           // cut off
                    1 => { lines.swap(a, b); }            // reordered
                    2 => { let l = lines[a].clone(); lines.insert(b, l); } // doubled
                    _ => { lines.remove(a); }             // dropped
                }
                if lines.is_empty() { break; }
            }
            let reply = lines.concat();
            // Accepted only when the data lines came through intact and in order.
            if let Ok(r) = parse_spectral_report(reply.as_bytes(), &Grid::pr650()) {
                let reference = parse_spectral_report(original.concat().as_bytes(), &Grid::pr650()).unwrap();
                prop_assert_eq!(r.values, reference.values);
            }
        }
    }
}
