//! The Konica Minolta CS-2000/CS-2000A/CS-3000 remote protocol, pure (no
//! I/O): the commands lightbooth and the public clients send, and their
//! replies, after `docs/src/instruments/cs2000.md`.
//!
//! Every command is ASCII ending in LF; every reply one line
//! `<code>[,<field>…]` ending in LF, where the code is `OK00` or `ERnn`
//! (colour-specio 0.4.1 `konica_minolta.py` 282–296). `MEAS,1` is the one
//! command with two lines: `OK00,<seconds>` at once (the unit's estimate of
//! the measurement time, a whole number), then a second `OK00` line when the
//! measurement ends (the TU Berlin `CS2000_measure.m` reads it; specio
//! sleeps the estimate and discards it). Spectral data come in four blocks
//! (`MEDR,1,<format>,1…4`) of 100, 100, 100 and 101 values, 380–780 nm at
//! 1 nm; format 1 is IEEE-754 single precision, big-endian, as 8 hex digits
//! (specio 389: `struct.unpack(">f", bytes.fromhex(d))`), format 0 decimal.

use crate::reply::ProtocolError;

/// The spectral blocks of `MEDR,1,…,n`: how many values each holds.
pub const BLOCK_LENGTHS: [usize; 4] = [100, 100, 100, 101];

/// Values in a whole spectrum (380–780 nm at 1 nm).
pub const SPECTRUM_LEN: usize = 401;

/// A command lightbooth sends, or one a public client sends to the simulator.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Command {
    /// `RMTS,1`: remote mode on (`RMTS,0` off).
    Remote(bool),
    /// `IDDR`: model name, variation code, serial number.
    Identify,
    /// `MEAS,1`: start a measurement (`MEAS,0` aborts one in progress).
    Measure,
    /// `MEAS,0`: abort the measurement in progress.
    Abort,
    /// `MEDR,0,0,1`: the last measurement's conditions; `ER02` while measuring.
    Conditions,
    /// `MEDR,1,<1 hex | 0 decimal>,<block 1–4>`: spectral radiance.
    Spectrum { hex: bool, block: u8 },
    /// `MEDR,2,0,00`: colorimetric data (Le, Lv, X, Y, Z, …).
    Colorimetry,
    /// `SPMR`: read the speed mode (never written on connect: `SPMS` goes to flash).
    ReadSpeed,
    /// `SCMR`: read the sync mode (likewise; `SCMS` goes to flash).
    ReadSync,
}

impl Command {
    /// The command as typed, without its LF.
    pub fn text(&self) -> String {
        match self {
            Command::Remote(on) => format!("RMTS,{}", u8::from(*on)),
            Command::Identify => "IDDR".into(),
            Command::Measure => "MEAS,1".into(),
            Command::Abort => "MEAS,0".into(),
            Command::Conditions => "MEDR,0,0,1".into(),
            Command::Spectrum { hex, block } => format!("MEDR,1,{},{block}", u8::from(*hex)),
            Command::Colorimetry => "MEDR,2,0,00".into(),
            Command::ReadSpeed => "SPMR".into(),
            Command::ReadSync => "SCMR".into(),
        }
    }

    /// Whether the command writes to the instrument's flash memory (`SPMS`,
    /// `SCMS`, and every other `…S` settings command the manual lists):
    /// the driver never sends one unless the operator asks.
    pub fn writes_flash(text: &str) -> bool {
        let name = text.split(',').next().unwrap_or("").trim().to_ascii_uppercase();
        matches!(
            name.as_str(),
            "SPMS" | "SCMS" | "LSMS" | "UCSS" | "UCNS" | "STMS" | "CCMS"
        )
    }
}

/// A reply's status: `OK00`, or `ERnn` with the number.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Status {
    Ok,
    Error(u8),
}

impl Status {
    /// `OK00`, `ER02`, …
    pub fn text(self) -> String {
        match self {
            Status::Ok => "OK00".into(),
            Status::Error(n) => format!("ER{n:02}"),
        }
    }
}

/// One reply line, split.
#[derive(Clone, Debug, PartialEq)]
pub struct Reply {
    pub status: Status,
    pub fields: Vec<String>,
}

/// Reads one reply: the first non-empty line of `bytes`, trailing CR
/// tolerated (a unit or adapter that sends CR LF).
pub fn parse_reply(bytes: &[u8]) -> Result<Reply, ProtocolError> {
    let lines = crate::link::lines::split_lines(bytes);
    let Some(line) = lines.first() else {
        return Err(ProtocolError::Empty);
    };
    let text = std::str::from_utf8(line)
        .map_err(|_| malformed(line, "ASCII text"))?
        .trim();
    let mut parts = text.split(',');
    let code = parts.next().unwrap_or("");
    let status = match code {
        "OK00" => Status::Ok,
        c if c.len() == 4 && c.starts_with("ER") => match c[2..].parse::<u8>() {
            Ok(n) => Status::Error(n),
            Err(_) => return Err(malformed(line, "a status OK00 or ERnn")),
        },
        _ => return Err(malformed(line, "a status OK00 or ERnn")),
    };
    Ok(Reply {
        status,
        fields: parts.map(|f| f.trim().to_string()).collect(),
    })
}

fn malformed(line: &[u8], expected: &'static str) -> ProtocolError {
    ProtocolError::Malformed {
        line: 1,
        text: crate::reply::show(line),
        expected,
    }
}

/// The unit's answer to `IDDR`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Identity {
    /// The name field (`CS-2000`, `CS-3000`).
    pub name: String,
    /// The variation code: 1 = CS-2000, 2 = CS-2000A (specio 257–268).
    pub variation: u32,
    pub serial: String,
}

impl Identity {
    /// The model as the operator knows it: the variation decides for the
    /// CS-2000 family (specio 262–266), else the name field.
    pub fn model_name(&self) -> String {
        match self.variation {
            1 => "CS-2000".into(),
            2 => "CS-2000A".into(),
            _ => self.name.clone(),
        }
    }
}

/// `OK00,<name>,<variation>,<serial>`; an error status is returned as such.
pub fn parse_identity(reply: &Reply) -> Result<Result<Identity, Status>, ProtocolError> {
    if reply.status != Status::Ok {
        return Ok(Err(reply.status));
    }
    let [name, variation, serial, ..] = reply.fields.as_slice() else {
        return Err(ProtocolError::Malformed {
            line: 1,
            text: reply.fields.join(","),
            expected: "OK00,<name>,<variation>,<serial>",
        });
    };
    let variation = variation.parse::<u32>().map_err(|_| ProtocolError::Malformed {
        line: 1,
        text: variation.clone(),
        expected: "a whole-number variation code",
    })?;
    Ok(Ok(Identity {
        name: name.clone(),
        variation,
        serial: serial.clone(),
    }))
}

/// The first line of the reply to `MEAS,1`: the announced measuring time, s.
pub fn parse_measuring_seconds(reply: &Reply) -> Result<Result<u32, Status>, ProtocolError> {
    if reply.status != Status::Ok {
        return Ok(Err(reply.status));
    }
    let field = reply.fields.first().ok_or(ProtocolError::Malformed {
        line: 1,
        text: "OK00".into(),
        expected: "OK00,<seconds>",
    })?;
    field.parse::<u32>().map(Ok).map_err(|_| ProtocolError::Malformed {
        line: 1,
        text: field.clone(),
        expected: "a whole number of seconds",
    })
}

/// `MEDR,0,0,1`: field 2 is the integration time in µs (specio 395); the
/// others are not documented publicly and are kept as text.
pub fn parse_integration_us(reply: &Reply) -> Result<Result<f64, Status>, ProtocolError> {
    if reply.status != Status::Ok {
        return Ok(Err(reply.status));
    }
    let field = reply.fields.get(2).ok_or_else(|| ProtocolError::Malformed {
        line: 1,
        text: reply.fields.join(","),
        expected: "at least three condition fields",
    })?;
    parse_number(field).map(Ok)
}

/// One block of spectral values, in either format; its length is checked.
pub fn parse_spectral_block(reply: &Reply, block: u8, hex: bool) -> Result<Result<Vec<f64>, Status>, ProtocolError> {
    if reply.status != Status::Ok {
        return Ok(Err(reply.status));
    }
    let want = BLOCK_LENGTHS[usize::from(block.clamp(1, 4)) - 1];
    if reply.fields.len() != want {
        return Err(ProtocolError::Malformed {
            line: 1,
            text: format!("{} values", reply.fields.len()),
            expected: match block {
                4 => "101 values in block 4",
                _ => "100 values in blocks 1–3",
            },
        });
    }
    reply
        .fields
        .iter()
        .map(|f| if hex { decode_hex_f32(f) } else { parse_number(f) })
        .collect::<Result<Vec<_>, _>>()
        .map(Ok)
}

/// `MEDR,2,0,00`: Le (W/(sr·m²)), Lv (cd/m²), X, Y, Z (TU Berlin
/// `CS2000_measure.m` fields 1–5); later fields are not read.
pub fn parse_colorimetry(reply: &Reply) -> Result<Result<Colorimetry, Status>, ProtocolError> {
    if reply.status != Status::Ok {
        return Ok(Err(reply.status));
    }
    if reply.fields.len() < 5 {
        return Err(ProtocolError::Malformed {
            line: 1,
            text: reply.fields.join(","),
            expected: "OK00,Le,Lv,X,Y,Z,…",
        });
    }
    let v = reply.fields[..5]
        .iter()
        .map(|f| parse_number(f))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(Ok(Colorimetry {
        radiance_w_sr_m2: v[0],
        luminance_cd_m2: v[1],
        xyz: [v[2], v[3], v[4]],
    }))
}

/// The unit's own colorimetry of its last measurement.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Colorimetry {
    pub radiance_w_sr_m2: f64,
    pub luminance_cd_m2: f64,
    pub xyz: [f64; 3],
}

/// A finite decimal number.
fn parse_number(field: &str) -> Result<f64, ProtocolError> {
    match field.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(ProtocolError::Malformed {
            line: 1,
            text: crate::reply::show(field.as_bytes()),
            expected: "a finite decimal number",
        }),
    }
}

/// 8 hex digits: an IEEE-754 single, big-endian; NaN and infinities refused.
pub fn decode_hex_f32(field: &str) -> Result<f64, ProtocolError> {
    let bad = || ProtocolError::Malformed {
        line: 1,
        text: crate::reply::show(field.as_bytes()),
        expected: "8 hex digits of a big-endian IEEE-754 single",
    };
    if field.len() != 8 {
        return Err(bad());
    }
    let bits = u32::from_str_radix(field, 16).map_err(|_| bad())?;
    let value = f32::from_bits(bits);
    if value.is_finite() {
        Ok(f64::from(value))
    } else {
        Err(bad())
    }
}

/// The inverse of [`decode_hex_f32`] (upper-case digits), for the simulator.
pub fn encode_hex_f32(value: f64) -> String {
    format!("{:08X}", (value as f32).to_bits())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hex_floats_are_big_endian_singles_as_python_reads_them() {
        // struct.pack(">f", 1.0).hex() == "3f800000"; 0.0031 → "3b4b295f".
        assert_eq!(decode_hex_f32("3f800000").unwrap(), 1.0);
        assert_eq!(encode_hex_f32(1.0), "3F800000");
        assert!((decode_hex_f32("3b4b295f").unwrap() - 0.0031).abs() < 1e-9);
        for v in [0.0, 1.25e-3, 4.2e-7, 12.5] {
            let back = decode_hex_f32(&encode_hex_f32(v)).unwrap();
            assert!((back - v).abs() <= v * 1e-7, "{v} → {back}");
        }
        assert!(decode_hex_f32("7fc00000").is_err(), "NaN refused");
        assert!(decode_hex_f32("3f80000").is_err(), "7 digits refused");
        assert!(decode_hex_f32("zz800000").is_err());
    }

    #[test]
    fn replies_split_into_status_and_fields() {
        let r = parse_reply(b"OK00,CS-2000,1,10001234\n").unwrap();
        assert_eq!(r.status, Status::Ok);
        let id = parse_identity(&r).unwrap().unwrap();
        assert_eq!((id.model_name().as_str(), id.serial.as_str()), ("CS-2000", "10001234"));
        let a = parse_identity(&parse_reply(b"OK00,CS-2000,2,7\r\n").unwrap())
            .unwrap()
            .unwrap();
        assert_eq!(a.model_name(), "CS-2000A");
        assert_eq!(parse_reply(b"ER02\n").unwrap().status, Status::Error(2));
        assert!(parse_reply(b"OK0").is_err());
        assert!(parse_reply(b"\x13\x99garbage\n").is_err());
        assert!(parse_identity(&parse_reply(b"OK00,CS-2000\n").unwrap()).is_err());
    }

    #[test]
    fn the_measuring_time_is_a_whole_number_of_seconds() {
        let r = parse_reply(b"OK00,3\n").unwrap();
        assert_eq!(parse_measuring_seconds(&r).unwrap(), Ok(3));
        assert!(parse_measuring_seconds(&parse_reply(b"OK00,3.5\n").unwrap()).is_err());
        assert_eq!(
            parse_measuring_seconds(&parse_reply(b"ER10\n").unwrap()).unwrap(),
            Err(Status::Error(10))
        );
    }

    #[test]
    fn a_spectral_block_must_have_its_length() {
        let fields: Vec<String> = (0..100).map(|_| encode_hex_f32(0.5)).collect();
        let r = parse_reply(format!("OK00,{}\n", fields.join(",")).as_bytes()).unwrap();
        assert_eq!(parse_spectral_block(&r, 1, true).unwrap().unwrap().len(), 100);
        assert!(parse_spectral_block(&r, 4, true).is_err(), "block 4 has 101");
        let dec = parse_reply(b"OK00,1.0e-3,2.0e-3\n").unwrap();
        assert!(parse_spectral_block(&dec, 1, false).is_err());
    }

    #[test]
    fn flash_writes_are_recognised() {
        assert!(Command::writes_flash("SPMS,1,2"));
        assert!(Command::writes_flash("scms,1,6000"));
        assert!(!Command::writes_flash("SPMR"));
        assert!(!Command::writes_flash(&Command::Measure.text()));
    }
}
