//! A second reading of the variable lines of `urscript_socket::var`, written byte by byte
//! without nom, from the grammar in that module's docs. `tests/var_grammar.rs` and the
//! `var_message`/`var_reply` fuzz targets require the nom parser to agree with it on
//! every line: the same values, and the same error kind at the same offset.
//!
//! The rules, as the module documents them: a line that does not have the shape is
//! `UnexpectedByte` at the first byte that cannot continue it (`Truncated` at the end of
//! the line when the line stops early); only a line of the right shape has its number
//! read, and one that does not fit an i32 is `IntegerOutOfRange` at the number's start.
//! The number is read by the standard library's `i32::from_str` (sign, leading zeros).

#![allow(dead_code)] // Each includer uses part of it.

use urscript_socket::ErrorKind;

/// The `expected` text of a bad `SET`/`GET` line's error.
pub const EXPECTED_MESSAGE: &str = "`SET name int` or `GET name`";
/// The `expected` text of a bad reply line's error.
pub const EXPECTED_REPLY: &str = "`name int`";

/// (kind, offset in the line).
pub type Error = (ErrorKind, usize);

/// A message line read: `(is SET, name, value)` or the error.
pub type Message<'a> = Result<(bool, &'a [u8], Option<i32>), Error>;

struct Cursor<'a> {
    line: &'a [u8],
    at: usize,
    expected: &'static str,
}

impl<'a> Cursor<'a> {
    fn fail(&self) -> Error {
        match self.line.get(self.at) {
            Some(&found) => (
                ErrorKind::UnexpectedByte {
                    found,
                    expected: self.expected,
                },
                self.at,
            ),
            None => (ErrorKind::Truncated, self.at),
        }
    }

    fn byte(&mut self, want: u8) -> Result<(), Error> {
        if self.line.get(self.at) == Some(&want) {
            self.at += 1;
            Ok(())
        } else {
            Err(self.fail())
        }
    }

    /// One or more bytes with `pred`.
    fn run(&mut self, pred: fn(u8) -> bool) -> Result<&'a [u8], Error> {
        let start = self.at;
        while self.line.get(self.at).is_some_and(|&b| pred(b)) {
            self.at += 1;
        }
        if self.at == start {
            return Err(self.fail());
        }
        Ok(&self.line[start..self.at])
    }

    /// An optional sign and one or more digits: (the token, where it starts).
    fn int(&mut self) -> Result<(&'a [u8], usize), Error> {
        let start = self.at;
        if matches!(self.line.get(self.at), Some(b'+' | b'-')) {
            self.at += 1;
        }
        self.run(|b| b.is_ascii_digit())?;
        Ok((&self.line[start..self.at], start))
    }

    /// Spaces and tabs, then the end of the line.
    fn end(&mut self) -> Result<(), Error> {
        while matches!(self.line.get(self.at), Some(b' ' | b'\t')) {
            self.at += 1;
        }
        if self.at == self.line.len() {
            Ok(())
        } else {
            Err(self.fail())
        }
    }
}

fn blank(b: u8) -> bool {
    b == b' ' || b == b'\t'
}

fn name_byte(b: u8) -> bool {
    b.is_ascii_graphic()
}

fn value((token, start): (&[u8], usize)) -> Result<i32, Error> {
    // The token is ASCII (sign and digits), so always UTF-8.
    let text = std::str::from_utf8(token).map_err(|_| (ErrorKind::InvalidNumber, start))?;
    text.parse::<i32>()
        .map_err(|_| (ErrorKind::IntegerOutOfRange, start))
}

/// `SET name int` → `(true, name, Some(value))`, `GET name` → `(false, name, None)`.
pub fn var_message(line: &[u8]) -> Message<'_> {
    let mut c = Cursor {
        line,
        at: 0,
        expected: EXPECTED_MESSAGE,
    };
    let is_set = match line.first() {
        Some(b'S') => true,
        Some(b'G') => false,
        _ => return Err(c.fail()),
    };
    c.at = 1;
    c.byte(b'E')?;
    c.byte(b'T')?;
    c.run(blank)?;
    let name = c.run(name_byte)?;
    if !is_set {
        c.end()?;
        return Ok((false, name, None));
    }
    c.run(blank)?;
    let token = c.int()?;
    c.end()?;
    Ok((true, name, Some(value(token)?)))
}

/// `name int`, answering a `GET` of `want`.
pub fn var_reply(line: &[u8], want: &[u8]) -> Result<i32, Error> {
    let mut c = Cursor {
        line,
        at: 0,
        expected: EXPECTED_REPLY,
    };
    let name = c.run(name_byte)?;
    c.run(blank)?;
    let token = c.int()?;
    c.end()?;
    if name != want {
        return Err((ErrorKind::NameMismatch, 0));
    }
    value(token)
}
