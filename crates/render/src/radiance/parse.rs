//! A RADIANCE file's text as a list of primitives and inline commands —
//! pure parsing, no file access, no meaning attached yet.
//!
//! A primitive is `modifier type identifier`, then three argument lists,
//! each a count followed by that many words: strings, integers (which no
//! primitive lightbooth reads uses; a non-zero count is refused where the
//! primitive is interpreted) and reals. Everything after a `!` where a
//! primitive could start is an inline command ([`super::lex`]).

use super::lex::{Lexer, Opening, Word};
use super::RadError;

/// One primitive as written.
#[derive(Clone, Debug, PartialEq)]
pub struct RawPrimitive {
    pub modifier: String,
    pub kind: String,
    pub id: String,
    pub strings: Vec<String>,
    pub integers: Vec<String>,
    pub reals: Vec<f64>,
    /// The line of its modifier word.
    pub line: usize,
}

/// A primitive or an inline command, in file order.
#[derive(Clone, Debug, PartialEq)]
pub enum Item {
    Primitive(RawPrimitive),
    /// `!command args…` (the text after `!`) and its line.
    Command {
        text: String,
        line: usize,
    },
}

/// Most arguments one primitive may declare (a polygon of 100 000
/// vertices has 300 000): a larger count is an error, not an allocation.
pub const MAX_ARGUMENTS: usize = 1 << 20;

/// Parses the text of `file` (the name is only used in errors).
pub fn parse(text: &str, file: &str) -> Result<Vec<Item>, RadError> {
    let mut lexer = Lexer::new(text);
    let mut items = Vec::new();
    loop {
        let at = lexer.line();
        let opening = lexer
            .line_comment_or_command()
            .map_err(|m| RadError::new(file, at, None, m))?;
        match opening {
            Opening::End => return Ok(items),
            Opening::Command(w) => items.push(Item::Command {
                text: w.text,
                line: w.line,
            }),
            Opening::Word(modifier) => items.push(Item::Primitive(primitive(&mut lexer, modifier, file)?)),
        }
    }
}

fn primitive(lexer: &mut Lexer, modifier: Word, file: &str) -> Result<RawPrimitive, RadError> {
    let line = modifier.line;
    let err = |label: Option<String>, m: String| RadError::new(file, line, label, m);
    let mut next = |what: &str, label: Option<String>| -> Result<Word, RadError> {
        match lexer.word() {
            Ok(Some(w)) => Ok(w),
            Ok(None) => Err(RadError::new(
                file,
                line,
                label,
                format!("the file ends where {what} should be"),
            )),
            Err(m) => Err(RadError::new(file, line, label, m)),
        }
    };
    let kind = next("the primitive's type (after its modifier)", None)?.text;
    let id = next("the primitive's identifier", None)?.text;
    let label = Some(format!("{kind} {id}"));
    let mut lists: [Vec<String>; 3] = Default::default();
    for (list, what) in lists.iter_mut().zip(["string", "integer", "real"]) {
        let count_word = next(&format!("the number of {what} arguments"), label.clone())?;
        let count: usize = count_word.text.parse().map_err(|_| {
            RadError::new(
                file,
                count_word.line,
                label.clone(),
                format!(
                    "`{}` should be the number of {what} arguments (a whole number ≥ 0)",
                    count_word.text
                ),
            )
        })?;
        if count > MAX_ARGUMENTS {
            return Err(err(
                label.clone(),
                format!("{count} {what} arguments: more than the {MAX_ARGUMENTS} accepted"),
            ));
        }
        for i in 0..count {
            list.push(next(&format!("{what} argument {} of {count}", i + 1), label.clone())?.text);
        }
    }
    let [strings, integers, real_words] = lists;
    let mut reals = Vec::with_capacity(real_words.len());
    for (i, w) in real_words.iter().enumerate() {
        match w.parse::<f64>() {
            Ok(v) if v.is_finite() => reals.push(v),
            _ => {
                return Err(err(
                    label.clone(),
                    format!("real argument {} is `{w}`, not a finite number", i + 1),
                ))
            }
        }
    }
    Ok(RawPrimitive {
        modifier: modifier.text,
        kind,
        id,
        strings,
        integers,
        reals,
        line,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn prim(item: &Item) -> &RawPrimitive {
        match item {
            Item::Primitive(p) => p,
            other => panic!("not a primitive: {other:?}"),
        }
    }

    #[test]
    fn multi_line_arguments_comments_and_commands() {
        let text = "# floor\nvoid plastic grey\n0\n0\n5 0.5 0.5 0.5\n  0 0\n\n!genbox grey box 1 2 3\ngrey polygon floor 0 0 9\n 0 0 0\n 1 0 0\n 1 1 0\n";
        let items = parse(text, "t.rad").unwrap();
        assert_eq!(items.len(), 3);
        let m = prim(&items[0]);
        assert_eq!(
            (m.modifier.as_str(), m.kind.as_str(), m.id.as_str(), m.line),
            ("void", "plastic", "grey", 2)
        );
        assert_eq!(m.reals, [0.5, 0.5, 0.5, 0.0, 0.0]);
        assert_eq!(
            items[1],
            Item::Command {
                text: "genbox grey box 1 2 3".into(),
                line: 8
            }
        );
        let p = prim(&items[2]);
        assert_eq!(
            (p.kind.as_str(), p.id.as_str(), p.line, p.reals.len()),
            ("polygon", "floor", 9, 9)
        );
    }

    #[test]
    fn string_arguments_are_kept() {
        let items = parse("void specfile sp 1 \"spectra/a b.dat\" 0 0", "t.rad").unwrap();
        assert_eq!(prim(&items[0]).strings, ["spectra/a b.dat"]);
    }

    #[test]
    fn errors_name_the_file_the_line_and_the_primitive() {
        let e = parse("\n\nvoid plastic red 0 0 5 1 1 x 0 0\n", "a.rad").unwrap_err();
        assert_eq!(
            e.to_string(),
            "a.rad:3: plastic red: real argument 3 is `x`, not a finite number"
        );
        let e = parse("void plastic red 0 0 5 1 1\n", "a.rad").unwrap_err();
        assert!(
            e.to_string()
                .starts_with("a.rad:1: plastic red: the file ends where real argument 3 of 5"),
            "{e}"
        );
        let e = parse("void plastic red zero 0 5\n", "a.rad").unwrap_err();
        assert!(
            e.to_string()
                .contains("`zero` should be the number of string arguments"),
            "{e}"
        );
        let e = parse("void plastic red 0 0 99999999999\n", "a.rad").unwrap_err();
        assert!(e.to_string().contains("more than the"), "{e}");
        let e = parse("void plastic red 0 0 1 inf\n", "a.rad").unwrap_err();
        assert!(e.to_string().contains("not a finite number"), "{e}");
    }

    proptest::proptest! {
        /// No input makes the lexer or parser panic: every text is items or an error.
        #[test]
        fn parsing_never_panics(text in "(?s).{0,400}") {
            let _ = parse(&text, "fuzz.rad");
        }

        /// Nor does text made of RADIANCE's own vocabulary, which reaches deeper.
        #[test]
        fn parsing_radiance_like_text_never_panics(
            words in proptest::collection::vec(
                "(void|plastic|polygon|sphere|0|1|3|5|-2\\.5|1e300|#|!xform|\"|\n|x)", 0..60)
        ) {
            let _ = parse(&words.join(" "), "fuzz.rad");
        }
    }
}
