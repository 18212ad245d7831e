//! The four-character status word that opens every reply of the Konica
//! Minolta LS-100 / CS-100A and of the CRS ColorCAL MkII (which adopted the
//! Minolta conventions): `OK` or `ER` and two digits, `OK00` for success.
//! Pure: parsing, and the one signed number a [`crate::QualityCode`]
//! carries for it.
//!
//! Sources: psychopy-minolta 0.0.2 `psychopy_minolta/minolta.py:114-121`
//! (the `ERnn` table) and `:157`, `:224` (a reply is good when it starts with
//! `OK`); psychopy-crs 0.0.2 `psychopy_crs/colorcal.py:165`, `:253-256`
//! (`OK00`, `ER11`).
//!
//! Numbering (lightbooth's, so one integer keeps both halves): `OKnn` is
//! `nn`, `ERnn` is `100 + nn`. `OK11` is 11 and `ER11` is 111: a warning
//! with a value and a refusal without one stay distinct.

/// `OKnn` or `ERnn`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StatusWord {
    /// `OKnn`: the command was carried out (nn ≠ 0: with a warning).
    Ok(u8),
    /// `ERnn`: the command was refused or the measurement failed.
    Er(u8),
}

impl StatusWord {
    /// `OK00`.
    pub const SUCCESS: StatusWord = StatusWord::Ok(0);

    /// Reads the first four characters of `field` (spaces around it are
    /// trimmed): `OK` or `ER`, case as sent, then exactly two digits.
    pub fn parse(field: &[u8]) -> Option<StatusWord> {
        let field = field.trim_ascii();
        if field.len() != 4 || !field[2].is_ascii_digit() || !field[3].is_ascii_digit() {
            return None;
        }
        let n = (field[2] - b'0') * 10 + (field[3] - b'0');
        match &field[..2] {
            b"OK" => Some(StatusWord::Ok(n)),
            b"ER" => Some(StatusWord::Er(n)),
            _ => None,
        }
    }

    /// The signed code a quality code carries: `OKnn` → nn, `ERnn` → 100 + nn.
    pub fn code(self) -> i32 {
        match self {
            StatusWord::Ok(n) => i32::from(n),
            StatusWord::Er(n) => 100 + i32::from(n),
        }
    }

    /// True for `OKnn` (with or without a warning).
    pub fn is_ok(self) -> bool {
        matches!(self, StatusWord::Ok(_))
    }
}

impl std::fmt::Display for StatusWord {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StatusWord::Ok(n) => write!(f, "OK{n:02}"),
            StatusWord::Er(n) => write!(f, "ER{n:02}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn status_words_parse_and_number_apart() {
        assert_eq!(StatusWord::parse(b"OK00"), Some(StatusWord::SUCCESS));
        assert_eq!(StatusWord::parse(b" ER11 "), Some(StatusWord::Er(11)));
        assert_eq!(StatusWord::Er(11).code(), 111);
        assert_eq!(StatusWord::Ok(11).code(), 11);
        assert_eq!(StatusWord::Er(0).to_string(), "ER00");
        for bad in [&b"OK0"[..], b"OK000", b"ok00", b"XX00", b"OK0a", b"", b"\xff\xfe00"] {
            assert_eq!(StatusWord::parse(bad), None, "{:?}", String::from_utf8_lossy(bad));
        }
    }
}
