//! The Colorimetry Research CR-250/CR-300 remote protocol, pure (no I/O),
//! after `docs/src/instruments/cr250.md`: ASCII commands ending in LF, and
//! replies `OK:<code>:<command>:<argument>` or `ER:<code>:<command>:<message>`
//! (colour-specio 0.4.1 `colorimetry_research.py` 380–425). `RM Spectrum`
//! answers a header whose argument is `<start>,<end>,<step>` and then one
//! value per line (specio 450–467): 380,780,4 on the CR-250 (101 lines),
//! 380,780,1 on the CR-300 (401 lines).

use crate::reply::{show, ProtocolError};

/// A command lightbooth sends (and the simulator answers), as typed.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Command {
    /// `RC InstrumentType`: 0 photometer, 1 colorimeter, 2 spectroradiometer.
    InstrumentType,
    /// `RC Model`: `CR-250`, `CR-300`.
    Model,
    /// `RC ID`: the serial number.
    Id,
    /// `RC Firmware`.
    Firmware,
    /// `SM ExposureMode 0`: automatic exposure.
    AutoExposure,
    /// `SM Speed n`: 0 slow, 1 normal, 2 fast, 3 2× fast (automatic exposure's speed).
    Speed(u8),
    /// `SM ExposureX n`: exposures averaged by the unit, 1–50; lightbooth asks 1.
    ExposureX(u8),
    /// `M`: measure; the reply comes when the measurement ends.
    Measure,
    /// `RM Spectrum`: the last measurement's spectral radiance.
    Spectrum,
    /// `RM XYZ`: the last measurement's X, Y, Z (cd/m²).
    Xyz,
    /// `RM Exposure`: the last measurement's exposure, ms.
    Exposure,
}

impl Command {
    pub fn text(&self) -> String {
        match self {
            Command::InstrumentType => "RC InstrumentType".into(),
            Command::Model => "RC Model".into(),
            Command::Id => "RC ID".into(),
            Command::Firmware => "RC Firmware".into(),
            Command::AutoExposure => "SM ExposureMode 0".into(),
            Command::Speed(n) => format!("SM Speed {n}"),
            Command::ExposureX(n) => format!("SM ExposureX {n}"),
            Command::Measure => "M".into(),
            Command::Spectrum => "RM Spectrum".into(),
            Command::Xyz => "RM XYZ".into(),
            Command::Exposure => "RM Exposure".into(),
        }
    }
}

/// One reply line, split at its first three colons.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Reply {
    pub ok: bool,
    pub code: i32,
    /// The command the unit says it answers.
    pub command: String,
    /// The rest of the line (an argument, or an error's message).
    pub argument: String,
}

/// The first non-empty line of `bytes` as a reply.
pub fn parse_reply(bytes: &[u8]) -> Result<Reply, ProtocolError> {
    let lines = crate::link::lines::split_lines(bytes);
    let line = lines.first().ok_or(ProtocolError::Empty)?;
    let bad = || ProtocolError::Malformed {
        line: 1,
        text: show(line),
        expected: "OK:<code>:<command>:<argument> or ER:<code>:<command>:<message>",
    };
    let text = std::str::from_utf8(line).map_err(|_| bad())?.trim();
    let mut parts = text.splitn(4, ':');
    let (Some(kind), Some(code), Some(command), Some(argument)) =
        (parts.next(), parts.next(), parts.next(), parts.next())
    else {
        return Err(bad());
    };
    let ok = match kind {
        "OK" => true,
        "ER" => false,
        _ => return Err(bad()),
    };
    let code = code.trim().parse::<i32>().map_err(|_| bad())?;
    Ok(Reply {
        ok,
        code,
        command: command.to_string(),
        argument: argument.to_string(),
    })
}

/// The `RM Spectrum` header's grid: first and last wavelength, step, nm.
pub fn parse_spectrum_header(argument: &str) -> Option<(f64, f64, f64)> {
    let v: Vec<f64> = argument
        .split(',')
        .map(|f| f.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .ok()?;
    match v.as_slice() {
        [start, end, step] if *step > 0.0 && end > start && start.is_finite() && end.is_finite() => {
            Some((*start, *end, *step))
        }
        _ => None,
    }
}

/// How many value lines follow a spectrum header (at most 2001: no
/// instrument here has more; a header that asks for more is garbage).
pub fn spectrum_lines(header: &[u8]) -> Option<usize> {
    let reply = parse_reply(header).ok()?;
    let (start, end, step) = parse_spectrum_header(&reply.argument)?;
    let n = ((end - start) / step).round() as usize + 1;
    (n <= 2001).then_some(n)
}

/// The values after the header: each a finite decimal number.
pub fn parse_values(lines: &[&[u8]]) -> Result<Vec<f64>, ProtocolError> {
    lines
        .iter()
        .enumerate()
        .map(|(i, line)| {
            std::str::from_utf8(line)
                .ok()
                .and_then(|t| t.trim().parse::<f64>().ok())
                .filter(|v| v.is_finite())
                .ok_or_else(|| ProtocolError::Malformed {
                    line: i + 2,
                    text: show(line),
                    expected: "a finite decimal number",
                })
        })
        .collect()
}

/// `X,Y,Z`.
pub fn parse_xyz(argument: &str) -> Option<[f64; 3]> {
    let v: Vec<f64> = argument
        .split(',')
        .map(|f| f.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .ok()?;
    match v.as_slice() {
        [x, y, z] if v.iter().all(|n| n.is_finite()) => Some([*x, *y, *z]),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn replies_split_at_their_first_three_colons() {
        let r = parse_reply(b"OK:0:RC Model:CR-250\n").unwrap();
        assert!(r.ok);
        assert_eq!(
            (r.code, r.command.as_str(), r.argument.as_str()),
            (0, "RC Model", "CR-250")
        );
        let e = parse_reply(b"ER:-500:XX:Invalid command\r\n").unwrap();
        assert!(!e.ok && e.code == -500 && e.argument == "Invalid command");
        // specio needs the fourth field: a reply without it is malformed.
        assert!(parse_reply(b"OK:0:M\n").is_err());
        assert!(parse_reply(b"\x00\xffOK?\n").is_err());
        assert!(parse_reply(b"").is_err());
    }

    #[test]
    fn a_spectrum_header_names_its_grid_and_its_length() {
        assert_eq!(spectrum_lines(b"OK:0:RM Spectrum:380,780,4\n"), Some(101));
        assert_eq!(spectrum_lines(b"OK:0:RM Spectrum:380,780,1\n"), Some(401));
        assert_eq!(spectrum_lines(b"OK:0:RM Spectrum:380,780000,0.001\n"), None, "bounded");
        assert_eq!(spectrum_lines(b"OK:0:RM Spectrum:780,380,4\n"), None);
        assert_eq!(parse_values(&[b"1.5e-3", b" 2.0 "]).unwrap(), vec![1.5e-3, 2.0]);
        let e = parse_values(&[b"1.0", b"nan"]).unwrap_err();
        assert!(e.to_string().contains("line 3"), "{e}");
        assert_eq!(parse_xyz("1,2.5,3e1"), Some([1.0, 2.5, 30.0]));
        assert_eq!(parse_xyz("1,2"), None);
    }
}
