//! The instrument families lightbooth can identify on a port, the harmless
//! command each is asked, and the parsers of their identity replies. Pure:
//! no I/O, and no parser panics, whatever the bytes.
//!
//! Each command only reads the unit's identity; none measures and none
//! writes a setting (a settings write on the CS-2000 goes to its flash):
//!
//! - PR-655/PR-670: `PHOTO` (each letter its own write) enters remote mode,
//!   answered by the 12-byte banner ` REMOTE MODE`; `D111` reports the model
//!   and `D110` the serial number; `Q` leaves remote mode again. The
//!   parsers are the driver's ([`crate::pr655::protocol`]);
//!   facts from `docs/src/instruments/pr655-670-protocol.md` sections 2, 6.
//! - Konica Minolta CS-2000/CS-2000A/CS-3000: `RMTS,1` switches remote mode
//!   on (as colour-specio's own discovery does before anything else,
//!   `konica_minolta.py:205-208`, which wants exactly `OK00\n`), then `IDDR`
//!   → `OK00,<name>,<variation>,<serial>`; variation 1 is the CS-2000, 2 the
//!   CS-2000A, anything else goes by the name (`konica_minolta.py:257-268`).
//!   Replies end in LF (`konica_minolta.py:286`). `RMTS,0` is not sent: no
//!   public client sends it, so the unit stays in remote mode until the
//!   next client (which sends `RMTS,1` anyway) or until it is switched off.
//! - Colorimetry Research CR-250/CR-300: `RC Model` → `OK:0:RC Model:CR-250`
//!   and `RC ID` → `OK:0:RC ID:<serial>` (`colorimetry_research.py:62-70`,
//!   402-425: the fourth `:` field is the answer; `ER:<code>:…` an error).
//!   The reply's line end is not documented, so CR, LF or both end it.
//! - CRS ColorCAL MkII: `IDR` → `\n\rOK00,1,<rom>,100.10,<serial>,<build>\n\r>`
//!   (psychopy-crs 0.0.2 `colorcal.py:205-217`; Psychtoolbox `ColorCal2.m`
//!   reads it with sscanf), the `>` prompt ending the reply (`colorcal.py:136-141`).
//!
//! The PR-650 and the LS-100/CS-100A have no identity command and are
//! never asked (see the parent module).

use serde::Serialize;

use crate::cs2000::codes as cs2000_codes;
use crate::cs2000::protocol as cs2000;
use crate::pr655::protocol as pr655;
use crate::pr655::Model as Pr655Model;

/// A family of instruments that share one identity command.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Family {
    /// Photo Research PR-655 and PR-670.
    Pr655,
    /// Konica Minolta CS-2000, CS-2000A, CS-3000.
    Cs2000,
    /// Colorimetry Research CR-250, CR-300.
    ColorimetryResearch,
    /// Cambridge Research Systems ColorCAL MkII.
    ColorCal,
}

impl Family {
    /// The order in which a port nothing is known about is asked: the
    /// LF-terminated families first (their commands leave no half line
    /// behind, and a PR-655/670 in local mode ignores them), fastest first;
    /// the PR-655/670 last, since `PHOTO` and `Q` carry no terminator.
    pub const UNKNOWN_PORT_ORDER: [Family; 4] = [
        Family::ColorimetryResearch,
        Family::ColorCal,
        Family::Cs2000,
        Family::Pr655,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Family::Pr655 => "Photo Research PR-655/PR-670",
            Family::Cs2000 => "Konica Minolta CS-2000/CS-2000A/CS-3000",
            Family::ColorimetryResearch => "Colorimetry Research CR-250/CR-300",
            Family::ColorCal => "CRS ColorCAL MkII",
        }
    }

    /// The baud rate the family's clients open at: the PR-655/670 driver's
    /// 9600 (`LinkSettings::at_9600_baud`); colour-specio's 115200 for the
    /// CS-2000 (`konica_minolta.py:167-175`) and the CR (`colorimetry_research.py:37-45`);
    /// the ColorCAL, which takes any (`colorcal.py:95-102`), PsychoPy's final 115200.
    pub fn baud(self) -> u32 {
        match self {
            Family::Pr655 => 9600,
            Family::Cs2000 | Family::ColorimetryResearch | Family::ColorCal => 115_200,
        }
    }

    /// The family's share of a port's deadline when several are asked in
    /// turn: the CR answers within 25 ms (`colorimetry_research.py:36`), the
    /// CS-2000 within colour-specio's 1 s timeout; the PR-655/670 needs
    /// 250 ms to spell `PHOTO` and then its banner.
    pub(super) fn weight(self) -> u32 {
        match self {
            Family::ColorimetryResearch => 2,
            Family::ColorCal => 3,
            Family::Cs2000 => 4,
            Family::Pr655 => 8,
        }
    }

    /// The commands asked, as the docs and the table show them.
    pub fn identity_commands(self) -> &'static str {
        match self {
            Family::Pr655 => "PHOTO, D111, D110, Q",
            Family::Cs2000 => "RMTS,1, IDDR",
            Family::ColorimetryResearch => "RC Model, RC ID",
            Family::ColorCal => "IDR",
        }
    }
}

/// What a unit said it is.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct Identity {
    pub family: Family,
    /// "PR-670", "CS-2000A", "CR-250", "ColorCAL MkII".
    pub model: String,
    pub serial: Option<String>,
    /// Firmware, where the identity reply carries it (ColorCAL: ROM and build).
    pub firmware: Option<String>,
}

/// Why a reply is not the identity asked for.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum IdentityError {
    #[error("no reply")]
    Empty,
    #[error("`{got}` is not {expected}")]
    NotThisFamily { got: String, expected: &'static str },
    #[error("the unit answered `{command}` with error {code} ({meaning})")]
    Refused {
        command: &'static str,
        code: String,
        meaning: String,
    },
}

/// At most this many characters of a reply are shown.
const SHOWN_CHARS: usize = 48;

/// Bytes as a message shows them: at most [`SHOWN_CHARS`] characters, escaped.
pub fn show(bytes: &[u8]) -> String {
    let s: String = String::from_utf8_lossy(bytes).chars().take(SHOWN_CHARS).collect();
    s.escape_debug().to_string()
}

fn not_this(bytes: &[u8], expected: &'static str) -> IdentityError {
    IdentityError::NotThisFamily {
        got: show(bytes),
        expected,
    }
}

/// The non-empty lines of a reply, whatever ends them (CR, LF, both, `\n\r`).
fn lines(bytes: &[u8]) -> impl Iterator<Item = &[u8]> {
    bytes
        .split(|b| *b == b'\n' || *b == b'\r')
        .map(<[u8]>::trim_ascii)
        .filter(|l| !l.is_empty())
}

/// True once `bytes` hold a whole non-empty line (its CR or LF has come).
pub fn has_complete_line(bytes: &[u8]) -> bool {
    match bytes.iter().position(|b| !b.is_ascii_whitespace()) {
        Some(start) => bytes[start..].iter().any(|b| *b == b'\n' || *b == b'\r'),
        None => false,
    }
}

/// A CS-2000 reply's status, or why it is not one. Parsed by the driver's
/// [`crate::cs2000::protocol::parse_reply`]; an `ERnn` is typed
/// by [`crate::cs2000::codes::command_error`].
fn cs2000_reply(bytes: &[u8], command: &'static str, expected: &'static str) -> Result<cs2000::Reply, IdentityError> {
    if lines(bytes).next().is_none() {
        return Err(IdentityError::Empty);
    }
    let reply = cs2000::parse_reply(bytes).map_err(|_| not_this(bytes.trim_ascii(), expected))?;
    match reply.status {
        cs2000::Status::Ok => Ok(reply),
        cs2000::Status::Error(n) => {
            let code = cs2000_codes::command_error(n);
            Err(IdentityError::Refused {
                command,
                code: format!("ER{n:02}"),
                meaning: code.message,
            })
        }
    }
}

/// The reply to `RMTS,1`: `Ok(())` for `OK00`.
pub fn parse_cs2000_remote(bytes: &[u8]) -> Result<(), IdentityError> {
    let reply = cs2000_reply(bytes, "RMTS,1", "`OK00` (a CS-2000 in remote mode)")?;
    if reply.fields.is_empty() {
        Ok(())
    } else {
        Err(not_this(bytes.trim_ascii(), "`OK00` (a CS-2000 in remote mode)"))
    }
}

/// The reply to `IDDR`: `OK00,<name>,<variation>,<serial>`, read by the
/// driver's [`cs2000::parse_identity`]; the model by its variation.
pub fn parse_cs2000_identity(bytes: &[u8]) -> Result<Identity, IdentityError> {
    let expected = "`OK00,<name>,<variation>,<serial>` (a CS-2000's IDDR)";
    let reply = cs2000_reply(bytes, "IDDR", expected)?;
    match cs2000::parse_identity(&reply) {
        Ok(Ok(id)) if !id.name.is_empty() && reply.fields.len() == 3 => Ok(Identity {
            family: Family::Cs2000,
            model: id.model_name(),
            serial: Some(id.serial).filter(|s| !s.is_empty()),
            firmware: None,
        }),
        _ => Err(not_this(bytes.trim_ascii(), expected)),
    }
}

/// Colorimetry Research error codes an identity query may meet
/// (`colorimetry_research.py:82-138`).
pub fn cr_error_meaning(code: &str) -> &'static str {
    match code {
        "-500" => "invalid command",
        _ => "see the instrument's manual",
    }
}

/// The answer to a Colorimetry Research `RC …` query: the fourth `:` field
/// of `OK:0:<command>:<answer>`, whose third field must echo `command`.
pub fn parse_cr_answer(bytes: &[u8], command: &'static str) -> Result<String, IdentityError> {
    let expected = "`OK:0:<command>:<answer>` (a Colorimetry Research reply)";
    let line = lines(bytes).next().ok_or(IdentityError::Empty)?;
    let text = String::from_utf8_lossy(line);
    let fields: Vec<&str> = text.splitn(4, ':').collect();
    match fields.as_slice() {
        ["OK", "0", echoed, answer] if *echoed == command && !answer.trim().is_empty() => Ok(answer.trim().to_string()),
        ["ER", code, echoed, _] if *echoed == command => Err(IdentityError::Refused {
            command,
            code: code.to_string(),
            meaning: cr_error_meaning(code).into(),
        }),
        _ => Err(not_this(line, expected)),
    }
}

/// `RC Model`'s answer, then `RC ID`'s (or none).
pub fn cr_identity(model: String, serial: Option<String>) -> Identity {
    Identity {
        family: Family::ColorimetryResearch,
        model,
        serial,
        firmware: None,
    }
}

/// True once a ColorCAL reply is whole: its `>` prompt has come.
pub fn colorcal_reply_complete(bytes: &[u8]) -> bool {
    bytes.contains(&b'>')
}

/// The reply to `IDR`: `\n\rOK00,1,<rom>,100.10,<serial>,<build>\n\r>`.
pub fn parse_colorcal_identity(bytes: &[u8]) -> Result<Identity, IdentityError> {
    let expected = "`OK00,1,<rom>,100.10,<serial>,<build>` (a ColorCAL MkII's IDR)";
    let line = lines(bytes).find(|l| *l != b">").ok_or(IdentityError::Empty)?;
    let fields: Vec<String> = line
        .split(|b| *b == b',')
        .map(|f| String::from_utf8_lossy(f.trim_ascii()).into_owned())
        .collect();
    if fields.len() == 1 && fields[0].starts_with("ER") {
        return Err(IdentityError::Refused {
            command: "IDR",
            code: fields[0].clone(),
            meaning: "not documented for IDR".into(),
        });
    }
    let serial_ok = fields
        .get(4)
        .is_some_and(|s| !s.is_empty() && s.bytes().all(|b| b.is_ascii_alphanumeric()));
    if fields.len() != 6 || fields[0] != "OK00" || !serial_ok || !line.is_ascii() {
        return Err(not_this(line, expected));
    }
    Ok(Identity {
        family: Family::ColorCal,
        model: "ColorCAL MkII".into(),
        serial: Some(fields[4].clone()),
        firmware: Some(format!("ROM {}, build {}", fields[2], fields[5])),
    })
}

/// The PR-655/670's `D111` reply: the model, if it is one of the two.
pub fn parse_pr655_model(bytes: &[u8]) -> Result<Pr655Model, IdentityError> {
    let expected = "`00000,PR-655` or `00000,PR-670` (a PR-655/670's D111)";
    if lines(bytes).next().is_none() {
        return Err(IdentityError::Empty);
    }
    match pr655::parse_text_report(bytes) {
        Ok(Ok(name)) => Pr655Model::from_name(&name).ok_or_else(|| not_this(bytes.trim_ascii(), expected)),
        Ok(Err(status)) => Err(IdentityError::Refused {
            command: "D111",
            code: status.to_string(),
            meaning: crate::pr655::codes::quality_code(status).message,
        }),
        Err(_) => Err(not_this(bytes.trim_ascii(), expected)),
    }
}

/// The PR-655/670's `D110` reply: the serial number, its first 8
/// characters trimmed (PTB: it "may contain trailing blanks"), as the driver keeps it.
pub fn parse_pr655_serial(bytes: &[u8]) -> Option<String> {
    match pr655::parse_text_report(bytes) {
        Ok(Ok(serial)) => Some(serial.chars().take(8).collect::<String>().trim().to_string()).filter(|s| !s.is_empty()),
        _ => None,
    }
}

/// True once `bytes` may be the banner (12 bytes, or the words with anything around them).
pub fn banner_complete(bytes: &[u8]) -> bool {
    bytes.len() >= pr655::BANNER.len() || pr655::is_banner(bytes)
}

pub fn is_pr655_banner(bytes: &[u8]) -> bool {
    pr655::is_banner(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cs2000_identity_names_the_model_by_its_variation() {
        let id = parse_cs2000_identity(b"OK00,CS-2000,1,10012345\n").unwrap();
        assert_eq!((id.model.as_str(), id.serial.as_deref()), ("CS-2000", Some("10012345")));
        let id = parse_cs2000_identity(b"OK00,CS-2000,2,20000001\n").unwrap();
        assert_eq!(id.model, "CS-2000A");
        // The CS-3000's variation is not published: the name decides.
        let id = parse_cs2000_identity(b"OK00,CS-3000,7,30000001\r\n").unwrap();
        assert_eq!(id.model, "CS-3000");
        assert_eq!(parse_cs2000_remote(b"OK00\n"), Ok(()));
        assert!(matches!(
            parse_cs2000_identity(b"ER00\n"),
            Err(IdentityError::Refused { code, meaning, .. }) if code == "ER00" && meaning.contains("could not be interpreted")
        ));
        for bad in [
            &b"OK00\n"[..],
            b"OK00,CS-2000,1\n",
            b"IDDR\n",
            b"OK00,,1,2\n",
            b"\xff\xfe,1,2,3\n",
        ] {
            assert!(
                matches!(parse_cs2000_identity(bad), Err(IdentityError::NotThisFamily { .. })),
                "{}",
                show(bad)
            );
        }
        assert_eq!(parse_cs2000_identity(b"\n\n"), Err(IdentityError::Empty));
        assert!(matches!(
            parse_cs2000_remote(b"ER02\n"),
            Err(IdentityError::Refused { .. })
        ));
        assert!(matches!(
            parse_cs2000_remote(b"RMTS,1\n"),
            Err(IdentityError::NotThisFamily { .. })
        ));
    }

    #[test]
    fn a_colorimetry_research_answer_is_the_fourth_field_of_its_own_command() {
        assert_eq!(
            parse_cr_answer(b"OK:0:RC Model:CR-250\r\n", "RC Model").unwrap(),
            "CR-250"
        );
        assert_eq!(parse_cr_answer(b"OK:0:RC ID:1234567\n", "RC ID").unwrap(), "1234567");
        // An answer to another command, an echo, an error.
        assert!(matches!(
            parse_cr_answer(b"OK:0:RC ID:1234567\n", "RC Model"),
            Err(IdentityError::NotThisFamily { .. })
        ));
        assert!(matches!(
            parse_cr_answer(b"RC Model\n", "RC Model"),
            Err(IdentityError::NotThisFamily { .. })
        ));
        assert!(matches!(
            parse_cr_answer(b"ER:-500:RC Model:Invalid command\n", "RC Model"),
            Err(IdentityError::Refused { meaning, .. }) if meaning == "invalid command"
        ));
        assert!(matches!(
            parse_cr_answer(b"OK:0:RC Model:\n", "RC Model"),
            Err(IdentityError::NotThisFamily { .. })
        ));
    }

    #[test]
    fn a_colorcal_identity_comes_between_its_blank_line_and_prompt() {
        let id = parse_colorcal_identity(b"\n\rOK00,1,201,100.10,00041234,877\n\r>").unwrap();
        assert_eq!(id.model, "ColorCAL MkII");
        assert_eq!(id.serial.as_deref(), Some("00041234"));
        assert_eq!(id.firmware.as_deref(), Some("ROM 201, build 877"));
        assert!(colorcal_reply_complete(b"\n\rOK00,1,201,100.10,00041234,877\n\r>"));
        assert!(!colorcal_reply_complete(b"\n\rOK00,1,201"));
        for bad in [&b"IDR\n"[..], b"\n\rOK00,1,201,100.10\n\r>", b"\n\rOK00,1,2,3,,5\n\r>"] {
            assert!(matches!(
                parse_colorcal_identity(bad),
                Err(IdentityError::NotThisFamily { .. })
            ));
        }
        assert!(matches!(
            parse_colorcal_identity(b"\n\rER01\n\r>"),
            Err(IdentityError::Refused { .. })
        ));
        assert_eq!(parse_colorcal_identity(b"\n\r>"), Err(IdentityError::Empty));
    }

    #[test]
    fn a_pr655_identity_reuses_the_drivers_parsers() {
        assert_eq!(parse_pr655_model(b"00000,PR-670\r\n"), Ok(Pr655Model::Pr670));
        assert_eq!(parse_pr655_model(b"0000,PR-655\r\n"), Ok(Pr655Model::Pr655));
        assert!(matches!(
            parse_pr655_model(b"00000,PR-705\r\n"),
            Err(IdentityError::NotThisFamily { .. })
        ));
        assert!(matches!(
            parse_pr655_model(b"-1000\r\n"),
            Err(IdentityError::Refused { .. })
        ));
        assert!(matches!(
            parse_pr655_model(b"D111\r"),
            Err(IdentityError::NotThisFamily { .. })
        ));
        assert_eq!(parse_pr655_serial(b"00000,67065106  \r\n").as_deref(), Some("67065106"));
        assert_eq!(parse_pr655_serial(b"-1000\r\n"), None);
        assert!(is_pr655_banner(b" REMOTE MODE"));
        assert!(!is_pr655_banner(b"PHOTO"));
    }

    #[test]
    fn lines_complete_only_after_content_and_its_end() {
        assert!(!has_complete_line(b"\r\n"));
        assert!(!has_complete_line(b"\nOK:0"));
        assert!(has_complete_line(b"\nOK:0:RC Model:CR-250\r"));
    }

    #[test]
    fn no_parser_panics_on_any_short_garbage() {
        let alphabet = b"OK0ER,:\r\n>1-. RCMD";
        let mut seed: u64 = 7;
        for _ in 0..20_000 {
            let len = (seed % 24) as usize;
            let bytes: Vec<u8> = (0..len)
                .map(|_| {
                    seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                    let r = (seed >> 33) as usize;
                    if r.is_multiple_of(7) {
                        (r >> 3) as u8
                    } else {
                        alphabet[r % alphabet.len()]
                    }
                })
                .collect();
            let _ = parse_cs2000_identity(&bytes);
            let _ = parse_cs2000_remote(&bytes);
            let _ = parse_cr_answer(&bytes, "RC Model");
            let _ = parse_colorcal_identity(&bytes);
            let _ = parse_pr655_model(&bytes);
            let _ = parse_pr655_serial(&bytes);
            let _ = has_complete_line(&bytes);
            seed = seed.wrapping_add(len as u64);
        }
    }
}
