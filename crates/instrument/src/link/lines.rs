//! Line framing on the serial link, the same for every model: how the host
//! ends a command ([`Terminator`]), and how the link counts the lines of a
//! reply as they arrive (CR, LF or CR LF end a line; empty lines do not
//! count). Pure: no I/O.
//!
//! The models' protocol modules parse the lines' contents; the PR-650's
//! parser splits replies with [`split_lines`] too (its section 3: header
//! line 1 may end in a bare CR; a doubled CR LF is harmless).

/// How the host ends a command. The PR-650 accepts all three (its protocol's
/// section 1, \[confirmed\]); LF is what PTB, PsychoPy and mgl send. The
/// PR-655/PR-670 take CR.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Terminator {
    #[default]
    Lf,
    Cr,
    Crlf,
}

impl Terminator {
    pub fn bytes(self) -> &'static [u8] {
        match self {
            Terminator::Lf => b"\n",
            Terminator::Cr => b"\r",
            Terminator::Crlf => b"\r\n",
        }
    }
}

/// Lines of a reply, split at CR, LF or CR LF, empty ones skipped.
pub fn split_lines(bytes: &[u8]) -> Vec<&[u8]> {
    bytes
        .split(|b| *b == b'\r' || *b == b'\n')
        .filter(|l| !l.iter().all(|b| b.is_ascii_whitespace()))
        .collect()
}

/// Number of complete (terminated) non-empty lines in a growing buffer: what
/// the link counts to know a reply has fully arrived.
pub fn complete_lines(bytes: &[u8]) -> usize {
    let Some(last_term) = bytes.iter().rposition(|b| *b == b'\r' || *b == b'\n') else {
        return 0;
    };
    split_lines(&bytes[..=last_term]).len()
}

/// Cuts `reply` just after its `n`-th complete non-empty line.
pub(super) fn trim_to_lines(mut reply: Vec<u8>, n: usize) -> Vec<u8> {
    let mut seen = 0;
    let mut in_line = false;
    for (i, b) in reply.iter().enumerate() {
        if *b == b'\r' || *b == b'\n' {
            if in_line {
                seen += 1;
                in_line = false;
                if seen == n {
                    let mut end = i + 1;
                    if *b == b'\r' && reply.get(end) == Some(&b'\n') {
                        end += 1;
                    }
                    if end < reply.len() {
                        tracing::debug!(bytes = reply.len() - end, "bytes after the reply dropped");
                    }
                    reply.truncate(end);
                    return reply;
                }
            }
        } else if !b.is_ascii_whitespace() {
            in_line = true;
        }
    }
    reply
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trims_after_the_expected_lines() {
        assert_eq!(trim_to_lines(b"000\r\n00,0\r\n".to_vec(), 1), b"000\r\n");
        assert_eq!(trim_to_lines(b"a\rb\r\nc".to_vec(), 2), b"a\rb\r\n");
        assert_eq!(trim_to_lines(b"\r\n\r\na\n".to_vec(), 1), b"\r\n\r\na\n");
    }

    #[test]
    fn counts_only_terminated_non_empty_lines() {
        assert_eq!(complete_lines(b""), 0);
        assert_eq!(complete_lines(b"000"), 0, "not terminated yet");
        assert_eq!(complete_lines(b"000\r"), 1, "a bare CR ends a line");
        assert_eq!(
            complete_lines(b"000\r\n\r\n00,0\r\n2.8"),
            2,
            "doubled CR LF and the partial tail skipped"
        );
        assert_eq!(split_lines(b"a\rb\n\r\nc"), vec![&b"a"[..], b"b", b"c"]);
        assert_eq!(Terminator::Crlf.bytes(), b"\r\n");
    }
}
