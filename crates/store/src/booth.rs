//! A booth's name: which lighting booth (and its instrument) a measurement
//! was taken in, when several booths share one database (`serve --booth`).
//!
//! Names are short and URL-safe, so a MATLAB script can ask for one booth's
//! data with `?booth=NAME` without escaping:
//!
//! ```
//! use lightbooth_store::Booth;
//! let b: Booth = "booth-2".parse().unwrap();
//! assert_eq!(b.as_str(), "booth-2");
//! assert!("booth 2".parse::<Booth>().unwrap_err().contains("space"));
//! ```

use std::fmt;
use std::str::FromStr;

/// The booth of a daemon that was not given `--booth`, and of every
/// measurement stored before booths were recorded (migration 0009): a lab
/// with one booth never needs to name it.
pub const DEFAULT_BOOTH: &str = "default";

/// The longest booth name, in characters.
pub const MAX_BOOTH_NAME: usize = 64;

/// A validated booth name: 1–64 ASCII letters, digits, `-`, `_` or `.`.
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Booth(String);

impl Booth {
    pub fn as_str(&self) -> &str {
        &self.0
    }
}

impl Default for Booth {
    fn default() -> Booth {
        Booth(DEFAULT_BOOTH.to_string())
    }
}

impl fmt::Display for Booth {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl FromStr for Booth {
    type Err = String;
    fn from_str(s: &str) -> Result<Booth, String> {
        if s.is_empty() {
            return Err("a booth name is empty: give one such as `booth-2`".into());
        }
        if s.chars().count() > MAX_BOOTH_NAME {
            return Err(format!(
                "the booth name `{s}` is longer than {MAX_BOOTH_NAME} characters"
            ));
        }
        if let Some(c) = s
            .chars()
            .find(|c| !(c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.')))
        {
            let what = if c == ' ' {
                "a space".to_string()
            } else {
                format!("`{c}`")
            };
            return Err(format!(
                "the booth name `{s}` contains {what}: use letters, digits, `-`, `_` or `.` (e.g. `booth-2`)"
            ));
        }
        Ok(Booth(s.to_string()))
    }
}

impl serde::Serialize for Booth {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&self.0)
    }
}

impl<'de> serde::Deserialize<'de> for Booth {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Booth, D::Error> {
        let s = String::deserialize(d)?;
        s.parse().map_err(serde::de::Error::custom)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn booth_names_are_url_safe_or_refused_with_the_reason() {
        for ok in ["default", "booth-2", "B_3", "lab.north", &"x".repeat(64)] {
            assert_eq!(ok.parse::<Booth>().unwrap().as_str(), ok);
        }
        for (bad, says) in [
            ("", "empty"),
            ("booth 2", "a space"),
            ("booth/2", "`/`"),
            ("büro", "`ü`"),
            (&"x".repeat(65) as &str, "longer than 64"),
        ] {
            let e = bad.parse::<Booth>().unwrap_err();
            assert!(e.contains(says), "{bad}: {e}");
        }
    }
}
