//! What every model's replies have in common, pure (no I/O): the one
//! [`ProtocolError`] a parser returns when a reply that arrived whole does
//! not read, with the line and the bytes that were wrong, and the number
//! syntax both instrument families send. Each model's `protocol.rs` parses
//! its own reports with these.

/// What is wrong with a reply. Always names the line (1-based among the
/// non-empty lines) and shows it, so a log reader can see the bytes.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ProtocolError {
    #[error("empty reply")]
    Empty,
    #[error("line {line}: `{text}` is not {expected}")]
    Malformed {
        line: usize,
        text: String,
        expected: &'static str,
    },
    #[error("spectral data line {line}: wavelength {got_nm} nm where {expected_nm} nm was due (reordered, doubled or missing line, or another model's grid)")]
    WrongWavelength { line: usize, got_nm: f64, expected_nm: f64 },
    #[error("spectrum cut short: {got} of {expected} data lines")]
    Truncated { got: usize, expected: usize },
    #[error("{extra} unexpected line(s) after the reply, first `{first}`")]
    Trailing { extra: usize, first: String },
    /// The PR-655/PR-670 greet remote mode with a banner; the PR-650 has none.
    #[error("the banner was `{got}`, not ` REMOTE MODE`: this port may not be a PR-655/PR-670")]
    Banner { got: String },
}

/// At most this many characters of a bad line are shown in an error.
const SHOWN_CHARS: usize = 48;

/// A line as an error shows it: at most [`SHOWN_CHARS`] characters, escaped.
pub(crate) fn show(bytes: &[u8]) -> String {
    let s: String = String::from_utf8_lossy(bytes).chars().take(SHOWN_CHARS).collect();
    s.escape_debug().to_string()
}

/// Line `line` (1-based) is `text`, which is not `expected`.
pub(super) fn malformed(line: usize, text: &[u8], expected: &'static str) -> ProtocolError {
    ProtocolError::Malformed {
        line,
        text: show(text),
        expected,
    }
}

/// A number in any of the forms the instruments send, after trimming
/// spaces: `d.dddEsdd` (PR-650; the case of the E is \[uncertain\], so
/// either is accepted), `1.865e+01`, `9.910e-007`, plain decimals (`.3127`,
/// `60.02`, `0380.`, `380`). Only digits, signs, a dot and E: no
/// `inf`/`nan`, and the value must be finite.
pub fn parse_number(field: &[u8]) -> Option<f64> {
    let field = field.trim_ascii();
    if field.is_empty() || field.len() > 24 {
        return None;
    }
    let allowed = |b: &u8| b.is_ascii_digit() || matches!(b, b'.' | b'e' | b'E' | b'+' | b'-');
    if !field.iter().all(allowed) || !field.iter().any(u8::is_ascii_digit) {
        return None;
    }
    let v: f64 = std::str::from_utf8(field).ok()?.parse().ok()?;
    v.is_finite().then_some(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_in_both_families_forms_and_nothing_else() {
        assert_eq!(parse_number(b" 1.865e+01 "), Some(18.65));
        assert_eq!(parse_number(b"9.910e-007"), Some(9.91e-7));
        assert_eq!(parse_number(b"4.000E+02"), Some(400.0));
        assert_eq!(parse_number(b".3127"), Some(0.3127));
        assert_eq!(parse_number(b"0380."), Some(380.0));
        for bad in [&b""[..], b"inf", b"nan", b"1e999", b"1,5", b"--", b"e", b"12 34"] {
            assert_eq!(parse_number(bad), None, "{:?}", String::from_utf8_lossy(bad));
        }
    }

    #[test]
    fn a_shown_line_is_cut_and_escaped() {
        let long = [b'x'; 100];
        assert_eq!(show(&long).len(), SHOWN_CHARS);
        assert_eq!(show(b"\x1b[0m"), "\\u{1b}[0m");
    }
}
