//! Tokens of URScript. Newlines end statements except inside `(...)` and `[...]`, where a
//! statement may continue over lines. `#` starts a comment to the end of the line; a line
//! starting with `$` (PolyScope's `$ 1 "Robot Program"` step markers) is skipped too.

use nom::branch::alt;
use nom::bytes::complete::take_while1;
use nom::character::complete::{char, digit0, digit1, one_of};
use nom::combinator::opt;
use nom::{IResult, Parser};

use crate::error::ParseError;

/// One token with its 1-based position.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Token {
    pub kind: Tok,
    pub line: u32,
    pub col: u32,
}

/// Token kinds.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Tok {
    Int(i32),
    /// The integer literal `2147483648` (2^31): one more than `i32::MAX`, so only valid
    /// right after a unary minus, as `-2147483648` (`i32::MIN`; OnRobot's URCap
    /// preamble writes it). The parser refuses it anywhere else.
    IntMinMagnitude,
    Float(f64),
    Str(String),
    Ident(String),
    /// `p[`: the opening of a pose literal (no space between `p` and `[`).
    PoseOpen,
    LParen,
    RParen,
    LBracket,
    RBracket,
    Comma,
    Colon,
    Assign,
    Plus,
    Minus,
    Star,
    Slash,
    Percent,
    Eq,
    Ne,
    Lt,
    Le,
    Gt,
    Ge,
    Dot,
    Newline,
    Eof,
}

impl Tok {
    /// How the token is shown in an error message.
    pub fn describe(&self) -> String {
        match self {
            Tok::Int(v) => format!("number `{v}`"),
            Tok::IntMinMagnitude => "number `2147483648`".into(),
            Tok::Float(v) => format!("number `{v}`"),
            Tok::Str(s) => format!("string \"{s}\""),
            Tok::Ident(s) => format!("`{s}`"),
            Tok::PoseOpen => "`p[`".into(),
            Tok::LParen => "`(`".into(),
            Tok::RParen => "`)`".into(),
            Tok::LBracket => "`[`".into(),
            Tok::RBracket => "`]`".into(),
            Tok::Comma => "`,`".into(),
            Tok::Colon => "`:`".into(),
            Tok::Assign => "`=`".into(),
            Tok::Plus => "`+`".into(),
            Tok::Minus => "`-`".into(),
            Tok::Star => "`*`".into(),
            Tok::Slash => "`/`".into(),
            Tok::Percent => "`%`".into(),
            Tok::Eq => "`==`".into(),
            Tok::Ne => "`!=`".into(),
            Tok::Lt => "`<`".into(),
            Tok::Le => "`<=`".into(),
            Tok::Gt => "`>`".into(),
            Tok::Ge => "`>=`".into(),
            Tok::Dot => "`.`".into(),
            Tok::Newline => "end of line".into(),
            Tok::Eof => "end of program".into(),
        }
    }
}

/// A number literal: `12`, `1.5`, `.5`, `1.`, `1e-3`, `2.5E+2` (no sign: unary minus is an
/// operator).
///
/// The text is cut by the length of what is left, not by `recognize`: at the very end of
/// the input a parser may hand back an empty rest that is not a slice of the input, and
/// `recognize`'s pointer arithmetic then returns `2.` of `2.25`.
fn number(input: &str) -> IResult<&str, &str> {
    let exponent = (one_of("eE"), opt(one_of("+-")), digit1);
    let (after, ()) = alt((
        (digit1, opt((char('.'), digit0)), opt(exponent)).map(|_| ()),
        (
            char('.'),
            digit1,
            opt((one_of("eE"), opt(one_of("+-")), digit1)),
        )
            .map(|_| ()),
    ))
    .parse(input)?;
    let used = input.len().saturating_sub(after.len());
    Ok((after, input.get(..used).unwrap_or(input)))
}

fn ident(input: &str) -> IResult<&str, &str> {
    take_while1(|c: char| c.is_ascii_alphanumeric() || c == '_')(input)
}

/// The largest program [`lex`] accepts, in bytes (16 MiB): a bound on the memory parsing
/// takes (tokens, then the syntax tree, are a small multiple of the text).
pub(crate) const MAX_PROGRAM_BYTES: usize = 16 * 1024 * 1024;

/// The length of the line end `rest` starts with: `\r\n`, `\n`, or a `\r` alone (old Mac
/// files).
fn line_end(rest: &str) -> Option<usize> {
    if rest.starts_with("\r\n") {
        Some(2)
    } else if rest.starts_with(['\n', '\r']) {
        Some(1)
    } else {
        None
    }
}

/// The error for a program over [`MAX_PROGRAM_BYTES`].
pub(crate) fn check_size(len: usize) -> Result<(), ParseError> {
    if len > MAX_PROGRAM_BYTES {
        return Err(ParseError::new(
            1,
            1,
            format!("program too large: {len} bytes (at most {MAX_PROGRAM_BYTES} bytes, 16 MiB)"),
        ));
    }
    Ok(())
}

/// The 1-based line and column (in characters) of byte `offset` of `src`, with the line
/// ends [`lex`] knows (`\n`, `\r\n`, `\r`).
pub(crate) fn position_of(src: &str, offset: usize) -> (u32, u32) {
    let mut line = 1u32;
    let mut line_start = 0usize;
    let bytes = src.as_bytes();
    let mut i = 0usize;
    while i < offset.min(bytes.len()) {
        match bytes[i] {
            b'\n' => {
                line = line.saturating_add(1);
                line_start = i + 1;
            }
            b'\r' if bytes.get(i + 1) != Some(&b'\n') => {
                line = line.saturating_add(1);
                line_start = i + 1;
            }
            _ => {}
        }
        i += 1;
    }
    let end = offset.min(src.len());
    let col = src.get(line_start..end).map_or(0, |s| s.chars().count());
    (line, u32::try_from(col + 1).unwrap_or(u32::MAX))
}

/// Splits `src` into tokens, in time linear in its length.
pub(crate) fn lex(src: &str) -> Result<Vec<Token>, ParseError> {
    check_size(src.len())?;
    let mut out = Vec::new();
    let mut rest = src;
    let mut line = 1u32;
    let mut depth = 0usize; // open ( and [
    let mut at_line_start = true;
    // The column is counted incrementally (characters since the last token), never from
    // the line's start again: a long line stays linear.
    let mut col_at = 0usize; // byte offset where `col` was counted
    let mut col = 1u32;
    while !rest.is_empty() {
        let offset = src.len() - rest.len();
        let step = src.get(col_at..offset).map_or(0, |s| s.chars().count());
        col = col.saturating_add(u32::try_from(step).unwrap_or(u32::MAX));
        col_at = offset;
        let c = rest.chars().next().unwrap_or(' ');
        let err = |what: String| ParseError::new(line, col, what);
        if let Some(n) = line_end(rest) {
            if depth == 0
                && !matches!(
                    out.last(),
                    Some(Token {
                        kind: Tok::Newline,
                        ..
                    }) | None
                )
            {
                out.push(Token {
                    kind: Tok::Newline,
                    line,
                    col,
                });
            }
            rest = &rest[n..];
            line = line.saturating_add(1);
            (col_at, col) = (offset + n, 1);
            at_line_start = true;
            continue;
        }
        if c == ' ' || c == '\t' || c == '\u{feff}' {
            rest = &rest[c.len_utf8()..];
            continue;
        }
        if c == '#' || (c == '$' && at_line_start) {
            let end = rest.find(['\n', '\r']).unwrap_or(rest.len());
            rest = &rest[end..];
            continue;
        }
        if c == '\\' {
            let after = rest[1..].trim_start_matches([' ', '\t']);
            if let Some(n) = line_end(after) {
                // Explicit line continuation.
                rest = &after[n..];
                line = line.saturating_add(1);
                (col_at, col) = (src.len() - rest.len(), 1);
                continue;
            }
        }
        at_line_start = false;
        let mut push = |kind: Tok, len: usize, rest: &mut &str| {
            out.push(Token { kind, line, col });
            *rest = &rest[len..];
        };
        if c.is_ascii_digit() || (c == '.' && rest[1..].starts_with(|d: char| d.is_ascii_digit())) {
            let Ok((after, text)) = number(rest) else {
                return Err(err(format!("invalid number `{}`", &rest[..1])));
            };
            if after.starts_with(|d: char| d.is_ascii_alphabetic() || d == '_') {
                return Err(err(format!("invalid number `{text}{}`", &after[..1])));
            }
            let kind = if text.bytes().all(|b| b.is_ascii_digit()) {
                match text.parse::<i32>() {
                    Ok(v) => Tok::Int(v),
                    Err(_) if text.trim_start_matches('0') == "2147483648" => Tok::IntMinMagnitude,
                    Err(_) => {
                        return Err(err(format!(
                            "integer literal `{text}` does not fit 32 bits"
                        )))
                    }
                }
            } else {
                match text.parse::<f64>() {
                    Ok(v) => Tok::Float(v),
                    Err(_) => return Err(err(format!("invalid number `{text}`"))),
                }
            };
            push(kind, text.len(), &mut rest);
            continue;
        }
        if c.is_ascii_alphabetic() || c == '_' {
            let Ok((after, name)) = ident(rest) else {
                return Err(err("invalid name".into()));
            };
            if name == "p" && after.starts_with('[') {
                depth += 1;
                push(Tok::PoseOpen, 2, &mut rest);
            } else {
                push(Tok::Ident(name.to_string()), name.len(), &mut rest);
            }
            continue;
        }
        if c == '"' || c == '\'' {
            let body = &rest[1..];
            let Some(end) = body.find([c, '\n', '\r']) else {
                return Err(err("string literal not closed".into()));
            };
            if body[end..].starts_with(['\n', '\r']) {
                return Err(err("string literal not closed on its line".into()));
            }
            let text = body[..end].to_string();
            push(Tok::Str(text), end + 2, &mut rest);
            continue;
        }
        let two = rest.get(..2).unwrap_or("");
        let (kind, len) = match two {
            "==" => (Tok::Eq, 2),
            "!=" => (Tok::Ne, 2),
            "<=" => (Tok::Le, 2),
            ">=" => (Tok::Ge, 2),
            _ => match c {
                '(' => (Tok::LParen, 1),
                ')' => (Tok::RParen, 1),
                '[' => (Tok::LBracket, 1),
                ']' => (Tok::RBracket, 1),
                ',' => (Tok::Comma, 1),
                ':' => (Tok::Colon, 1),
                '=' => (Tok::Assign, 1),
                '+' => (Tok::Plus, 1),
                '-' => (Tok::Minus, 1),
                '*' => (Tok::Star, 1),
                '/' => (Tok::Slash, 1),
                '%' => (Tok::Percent, 1),
                '<' => (Tok::Lt, 1),
                '>' => (Tok::Gt, 1),
                '.' => (Tok::Dot, 1),
                '{' => {
                    return Err(err(
                        "a template placeholder (`{{...}}` or `{% ... %}`) must be filled in before the program runs".into(),
                    ))
                }
                other => return Err(err(format!("unexpected character `{other}`"))),
            },
        };
        match kind {
            Tok::LParen | Tok::LBracket => depth += 1,
            Tok::RParen | Tok::RBracket => depth = depth.saturating_sub(1),
            _ => {}
        }
        push(kind, len, &mut rest);
    }
    let step = src.get(col_at..).map_or(0, |s| s.chars().count());
    let col = col.saturating_add(u32::try_from(step).unwrap_or(u32::MAX));
    if depth == 0
        && !matches!(
            out.last(),
            Some(Token {
                kind: Tok::Newline,
                ..
            }) | None
        )
    {
        out.push(Token {
            kind: Tok::Newline,
            line,
            col,
        });
    }
    out.push(Token {
        kind: Tok::Eof,
        line,
        col,
    });
    Ok(out)
}
