//! pbrt-v4's tokens: quoted strings (with C escapes), `[`, `]`, and bare
//! words (directives, numbers, `true`/`false`), separated by whitespace;
//! `#` starts a comment to the end of the line. Every token keeps its line
//! and column.

use crate::error::{FileLoc, LoadError, Result};
use std::path::PathBuf;
use std::sync::Arc;

/// What a token is.
#[derive(Debug, Clone, PartialEq)]
pub enum Tok {
    /// A quoted string, escapes resolved.
    Str(String),
    /// `[`
    Open,
    /// `]`
    Close,
    /// Anything else: a directive name, a number, `true` or `false`.
    Word(String),
}

/// A token and where it starts.
#[derive(Debug, Clone)]
pub struct Token {
    /// The token.
    pub tok: Tok,
    /// Its first character's line and column.
    pub loc: FileLoc,
}

/// Splits one file's text into tokens.
pub struct Lexer<'a> {
    text: &'a [u8],
    pos: usize,
    line: u32,
    /// A position on the current line (its start after a newline) and its
    /// column: the next token's column is counted on from there. Counted
    /// from the line's start, a file with all its numbers on one line took
    /// time in the square of that line's length.
    col_pos: usize,
    col: u32,
    file: Arc<PathBuf>,
}

impl<'a> Lexer<'a> {
    /// A lexer over `text`, the contents of `file`.
    pub fn new(text: &'a str, file: Arc<PathBuf>) -> Self {
        Lexer { text: text.as_bytes(), pos: 0, line: 1, col_pos: 0, col: 1, file }
    }

    /// Where `pos` (on the current line, at or after the last position
    /// asked for) is. Columns count characters, not bytes: the bytes that
    /// do not continue a UTF-8 sequence.
    fn loc(&mut self, pos: usize) -> FileLoc {
        debug_assert!(self.col_pos <= pos);
        let chars = self.text[self.col_pos..pos].iter().filter(|&&b| (b as i8) >= -0x40).count();
        self.col += chars as u32;
        self.col_pos = pos;
        FileLoc::new(self.file.clone(), self.line, self.col)
    }

    /// The next token, `None` at the end of the file.
    pub fn next_token(&mut self) -> Result<Option<Token>> {
        // Whitespace and comments.
        while self.pos < self.text.len() {
            match self.text[self.pos] {
                b'\n' => {
                    self.pos += 1;
                    self.line += 1;
                    (self.col_pos, self.col) = (self.pos, 1);
                }
                b' ' | b'\t' | b'\r' => self.pos += 1,
                b'#' => {
                    while self.pos < self.text.len() && self.text[self.pos] != b'\n' {
                        self.pos += 1;
                    }
                }
                _ => break,
            }
        }
        if self.pos >= self.text.len() {
            return Ok(None);
        }
        let start = self.pos;
        let loc = self.loc(start);
        let tok = match self.text[start] {
            b'[' => {
                self.pos += 1;
                Tok::Open
            }
            b']' => {
                self.pos += 1;
                Tok::Close
            }
            b'"' => {
                self.pos += 1;
                let mut s = Vec::new();
                loop {
                    let Some(&c) = self.text.get(self.pos) else {
                        return Err(LoadError::at(&loc, "unterminated string: add the closing '\"'"));
                    };
                    self.pos += 1;
                    match c {
                        b'"' => break,
                        b'\n' => return Err(LoadError::at(
                            &loc,
                            "a string runs to the end of its line: add the closing '\"' (strings may not span lines)",
                        )),
                        b'\\' => {
                            let Some(&e) = self.text.get(self.pos) else {
                                return Err(LoadError::at(&loc, "unterminated string: add the closing '\"'"));
                            };
                            self.pos += 1;
                            s.push(match e {
                                b'b' => 8,
                                b'f' => 12,
                                b'n' => b'\n',
                                b'r' => b'\r',
                                b't' => b'\t',
                                b'\\' => b'\\',
                                b'\'' => b'\'',
                                b'"' => b'"',
                                other => {
                                    let at = self.loc(self.pos - 2);
                                    return Err(LoadError::at(
                                        &at,
                                        format!("unknown escape '\\{}' in a string", other as char),
                                    ));
                                }
                            });
                        }
                        c => s.push(c),
                    }
                }
                // The file is UTF-8 (checked when read), and escapes are ASCII.
                Tok::Str(String::from_utf8_lossy(&s).into_owned())
            }
            _ => {
                while self.pos < self.text.len()
                    && !matches!(self.text[self.pos], b' ' | b'\t' | b'\r' | b'\n' | b'"' | b'[' | b']' | b'#')
                {
                    self.pos += 1;
                }
                Tok::Word(String::from_utf8_lossy(&self.text[start..self.pos]).into_owned())
            }
        };
        Ok(Some(Token { tok, loc }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lex(s: &str) -> Result<Vec<(Tok, u32, u32)>> {
        let mut l = Lexer::new(s, Arc::new(PathBuf::from("t.pbrt")));
        let mut v = Vec::new();
        while let Some(t) = l.next_token()? {
            v.push((t.tok, t.loc.line, t.loc.col));
        }
        Ok(v)
    }

    /// Columns count characters on each line as counting from the line's
    /// start does: multi-byte characters in strings, words and comments,
    /// CRLF line ends, an escape error after them.
    #[test]
    fn columns_count_characters_from_the_line_start() {
        let text = "Shape \"sphère\" [ 1 2 ] # ç\r\n\t\"ü\" wörd [\n  \"é\" x\n";
        let mut v = Vec::new();
        let mut l = Lexer::new(text, Arc::new(PathBuf::from("t.pbrt")));
        while let Some(t) = l.next_token().unwrap() {
            v.push((t.loc.line, t.loc.col));
        }
        // Each token's position found by counting from the start of its line.
        let mut expect = Vec::new();
        for (n, line) in text.split('\n').enumerate() {
            let mut in_word = false;
            let mut in_str = false;
            for (col, c) in line.chars().enumerate() {
                if line.chars().take(col).any(|c| c == '#') && !in_str {
                    break;
                }
                let starts = match c {
                    '"' if !in_str => {
                        in_str = true;
                        true
                    }
                    '"' => {
                        in_str = false;
                        false
                    }
                    _ if in_str => false,
                    '[' | ']' => {
                        in_word = false;
                        true
                    }
                    ' ' | '\t' | '\r' | '#' => {
                        in_word = false;
                        false
                    }
                    _ => !std::mem::replace(&mut in_word, true),
                };
                if starts {
                    expect.push((n as u32 + 1, col as u32 + 1));
                }
            }
        }
        assert_eq!(v, expect);
        assert_eq!(v.len(), 11);
        let err = lex("\"é\" \"ü\\q\"").unwrap_err();
        assert_eq!((err.loc.as_ref().unwrap().line, err.loc.as_ref().unwrap().col), (1, 7), "{err}");
    }

    #[test]
    fn tokens_with_positions() {
        let v = lex("Shape \"sphere\" # c\n  \"float radius\" [2.5]\n\"string s\" \"a\\\"b\\n\"").unwrap();
        assert_eq!(
            v,
            vec![
                (Tok::Word("Shape".into()), 1, 1),
                (Tok::Str("sphere".into()), 1, 7),
                (Tok::Str("float radius".into()), 2, 3),
                (Tok::Open, 2, 18),
                (Tok::Word("2.5".into()), 2, 19),
                (Tok::Close, 2, 22),
                (Tok::Str("string s".into()), 3, 1),
                (Tok::Str("a\"b\n".into()), 3, 12),
            ]
        );
    }

    #[test]
    fn bad_strings_are_errors_with_positions() {
        let e = lex("Shape \"sphere").unwrap_err().to_string();
        assert!(e.contains("t.pbrt:1:7") && e.contains("unterminated"), "{e}");
        let e = lex("A\n  \"x\ny\"").unwrap_err().to_string();
        assert!(e.contains("t.pbrt:2:3") && e.contains("end of its line"), "{e}");
        let e = lex("\"a\\q\"").unwrap_err().to_string();
        assert!(e.contains("t.pbrt:1:3") && e.contains("\\q"), "{e}");
    }
}
