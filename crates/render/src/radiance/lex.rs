//! Reading a RADIANCE scene file's characters into words, with line numbers.
//!
//! RADIANCE's scene syntax (Ward, "The RADIANCE 6.0 Synthetic Imaging
//! System", `ray.html`, section "Scene Description") is a stream of words
//! separated by white space, so a primitive's arguments may run over any
//! number of lines. Two things are recognised only where a primitive may
//! start, which is why the parser asks for them explicitly
//! ([`Lexer::line_comment_or_command`]): a `#` comment up to the end of the
//! line, and a `!command` whose arguments run to the end of the line (a
//! backslash before the newline continues it). A word in double quotes may
//! hold white space (RADIANCE's `fgetword`).

/// One word and the line (1-based) it starts on.
#[derive(Clone, Debug, PartialEq)]
pub struct Word {
    pub text: String,
    pub line: usize,
}

/// What may stand where a primitive starts.
#[derive(Clone, Debug, PartialEq)]
pub enum Opening {
    /// A `!command` line (without the `!`), continuation lines joined.
    Command(Word),
    /// The first word of a primitive (its modifier).
    Word(Word),
    /// The end of the text.
    End,
}

/// A cursor over the text of one file.
pub struct Lexer<'a> {
    chars: std::iter::Peekable<std::str::Chars<'a>>,
    line: usize,
}

impl<'a> Lexer<'a> {
    pub fn new(text: &'a str) -> Lexer<'a> {
        Lexer {
            chars: text.chars().peekable(),
            line: 1,
        }
    }

    /// The current line (1-based).
    pub fn line(&self) -> usize {
        self.line
    }

    fn bump(&mut self) -> Option<char> {
        let c = self.chars.next()?;
        if c == '\n' {
            self.line += 1;
        }
        Some(c)
    }

    fn skip_space(&mut self) {
        while self.chars.peek().is_some_and(|c| c.is_whitespace()) {
            self.bump();
        }
    }

    /// Skips comments; returns the next command, primitive word or the end.
    pub fn line_comment_or_command(&mut self) -> Result<Opening, String> {
        loop {
            self.skip_space();
            match self.chars.peek() {
                None => return Ok(Opening::End),
                Some('#') => {
                    while self.chars.peek().is_some_and(|&c| c != '\n') {
                        self.bump();
                    }
                }
                Some('!') => {
                    let line = self.line;
                    self.bump();
                    let mut text = String::new();
                    while let Some(&c) = self.chars.peek() {
                        if c == '\n' {
                            break;
                        }
                        self.bump();
                        if c == '\\' && self.chars.peek() == Some(&'\n') {
                            self.bump();
                            text.push(' ');
                            continue;
                        }
                        text.push(c);
                    }
                    return Ok(Opening::Command(Word { text, line }));
                }
                Some(_) => {
                    return match self.word()? {
                        Some(w) => Ok(Opening::Word(w)),
                        None => Ok(Opening::End),
                    }
                }
            }
        }
    }

    /// The next word, `None` at the end of the text.
    pub fn word(&mut self) -> Result<Option<Word>, String> {
        self.skip_space();
        let line = self.line;
        let mut text = String::new();
        if self.chars.peek() == Some(&'"') {
            self.bump();
            loop {
                match self.bump() {
                    None => return Err(format!("the quoted word opened on line {line} is never closed")),
                    Some('"') => break,
                    Some(c) => text.push(c),
                }
            }
            return Ok(Some(Word { text, line }));
        }
        while let Some(&c) = self.chars.peek() {
            if c.is_whitespace() {
                break;
            }
            self.bump();
            text.push(c);
        }
        Ok((!text.is_empty()).then_some(Word { text, line }))
    }
}

/// Splits a command line into words as a shell would for the simple
/// commands RADIANCE files hold: white space separates, single or double
/// quotes group. Pipes, redirections and substitutions are returned as
/// words and refused by the caller.
pub fn command_words(text: &str) -> Result<Vec<String>, String> {
    let mut words = Vec::new();
    let mut cur = String::new();
    let mut in_word = false;
    let mut chars = text.chars();
    while let Some(c) = chars.next() {
        match c {
            '\'' | '"' => {
                in_word = true;
                loop {
                    match chars.next() {
                        None => return Err(format!("unclosed {c} quote")),
                        Some(q) if q == c => break,
                        Some(q) => cur.push(q),
                    }
                }
            }
            c if c.is_whitespace() => {
                if in_word {
                    words.push(std::mem::take(&mut cur));
                    in_word = false;
                }
            }
            c => {
                in_word = true;
                cur.push(c);
            }
        }
    }
    if in_word {
        words.push(cur);
    }
    Ok(words)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn words_carry_their_lines_and_comments_and_commands_are_recognised() {
        let mut l = Lexer::new("# a comment\n\nvoid plastic\n  red 0 0\n!xform -t 1 \\\n 2 3 x.rad\n\"a b\"");
        assert_eq!(
            l.line_comment_or_command().unwrap(),
            Opening::Word(Word {
                text: "void".into(),
                line: 3
            })
        );
        assert_eq!(l.word().unwrap().unwrap().text, "plastic");
        let red = l.word().unwrap().unwrap();
        assert_eq!((red.text.as_str(), red.line), ("red", 4));
        l.word().unwrap();
        l.word().unwrap();
        match l.line_comment_or_command().unwrap() {
            Opening::Command(w) => {
                assert_eq!(w.line, 5);
                assert_eq!(command_words(&w.text).unwrap(), ["xform", "-t", "1", "2", "3", "x.rad"]);
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(l.word().unwrap().unwrap().text, "a b");
        assert_eq!(l.line_comment_or_command().unwrap(), Opening::End);
    }

    #[test]
    fn an_unclosed_quote_is_an_error() {
        assert!(Lexer::new("\"abc").word().is_err());
        assert!(command_words("xform 'a").is_err());
    }
}
