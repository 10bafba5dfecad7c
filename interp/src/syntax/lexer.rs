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

/// The words that open a block an `end` closes. `for` is not URScript (the parser refuses
/// it with its own message) but is counted, so a program that uses it arrives whole.
const BLOCK_OPENERS: &[&str] = &["def", "sec", "thread", "if", "while", "for"];

/// What a top-level unit of a script sent line by line is.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum UnitKind {
    /// A `def NAME():` ... `end` program (the name empty if the line has none).
    Def(String),
    /// A `sec NAME():` ... `end` secondary program.
    Sec(String),
    /// Anything else: a statement, or a block (`if`, `while`, `thread`) at the top level.
    Other,
}

/// What one line fed to [`TopLevel::line`] did.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UnitLine {
    /// The line starts a unit, of this kind. `None` for a line inside a unit, and for a
    /// line between units that holds no code (blanks, a comment, a `$` step marker).
    pub starts: Option<UnitKind>,
    /// The unit is complete with this line: the blocks it opened are all closed.
    pub ends: bool,
}

/// Where the top-level units of URScript that arrives line by line end (a client
/// writing programs, secondary programs and single statements to the primary and
/// secondary ports), by this interpreter's lexer: a unit starts at the first line with
/// code, and ends with the line where every block opened since (`def`, `sec`, `thread`,
/// `if`, `while`, each closed by an `end`) is closed. Words inside strings and comments
/// do not count; a line that does not lex counts its tokens up to the fault (the
/// program is then refused with the lexer's error).
///
/// ```
/// use urscript_interp::{TopLevel, UnitKind};
/// let mut t = TopLevel::new();
/// assert_eq!(t.line("# a comment").starts, None);
/// assert_eq!(t.line("def move():").starts, Some(UnitKind::Def("move".into())));
/// assert!(!t.line("  if x: textmsg(\"end\") end").ends);
/// assert!(t.line("end").ends);
/// ```
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct TopLevel {
    /// Blocks open in the current unit (0 between units).
    open: usize,
}

impl TopLevel {
    /// Between units.
    pub fn new() -> Self {
        TopLevel::default()
    }

    /// Whether a unit has started and is not complete yet.
    pub fn is_inside(&self) -> bool {
        self.open > 0
    }

    /// Feeds the next line (without its line end).
    pub fn line(&mut self, line: &str) -> UnitLine {
        let (tokens, has_code) = line_tokens(line);
        let starts = if self.open == 0 {
            if !has_code {
                return UnitLine {
                    starts: None,
                    ends: false,
                };
            }
            Some(unit_kind(&tokens))
        } else {
            None
        };
        let mut after_dot = false;
        for t in &tokens {
            if let Tok::Ident(word) = &t.kind {
                if !after_dot {
                    if BLOCK_OPENERS.contains(&word.as_str()) {
                        self.open = self.open.saturating_add(1);
                    } else if word == "end" {
                        self.open = self.open.saturating_sub(1);
                    }
                }
            }
            after_dot = t.kind == Tok::Dot;
        }
        UnitLine {
            starts,
            ends: self.open == 0,
        }
    }
}

/// Where the first complete top-level unit of `src` ends, and what it is: the byte
/// offset just past its last line's `\n` (or `src.len()` if that line has none).
/// `None` while `src` holds no complete unit (nothing but blanks and comments, or a unit
/// whose blocks are still open). See [`TopLevel`] for the rules.
///
/// ```
/// use urscript_interp::{top_level_end, UnitKind};
/// let src = "# pick\ndef pick():\n  while True:\n    sync()\n  end\nend\ntextmsg(1)\n";
/// let (end, kind) = top_level_end(src).unwrap();
/// assert_eq!((&src[end..], kind), ("textmsg(1)\n", UnitKind::Def("pick".into())));
/// assert_eq!(top_level_end("def pick():\n  sync()\n"), None);
/// ```
pub fn top_level_end(src: &str) -> Option<(usize, UnitKind)> {
    let mut scan = TopLevel::new();
    let mut kind = None;
    let mut at = 0;
    for line in src.split_inclusive('\n') {
        at += line.len();
        let step = scan.line(line.strip_suffix('\n').unwrap_or(line));
        if step.starts.is_some() {
            kind = step.starts;
        }
        if step.ends {
            return kind.map(|k| (at, k));
        }
    }
    None
}

/// The tokens of one line (no `Newline`/`Eof`), and whether it holds code: a line that
/// does not lex gives its tokens before the fault, and holds code.
fn line_tokens(line: &str) -> (Vec<Token>, bool) {
    let code = |t: &Token| !matches!(t.kind, Tok::Newline | Tok::Eof);
    match lex(line) {
        Ok(tokens) => {
            let tokens: Vec<Token> = tokens.into_iter().filter(code).collect();
            let has_code = !tokens.is_empty();
            (tokens, has_code)
        }
        Err(e) => {
            let before = &line[..offset_of(line, e.line(), e.column())];
            let tokens =
                lex(before).map_or_else(|_| Vec::new(), |t| t.into_iter().filter(code).collect());
            (tokens, true)
        }
    }
}

/// The kind of the unit whose first line has `tokens`.
fn unit_kind(tokens: &[Token]) -> UnitKind {
    let name = || match tokens.get(1).map(|t| &t.kind) {
        Some(Tok::Ident(name)) => name.clone(),
        _ => String::new(),
    };
    match tokens.first().map(|t| &t.kind) {
        Some(Tok::Ident(w)) if w == "def" => UnitKind::Def(name()),
        Some(Tok::Ident(w)) if w == "sec" => UnitKind::Sec(name()),
        _ => UnitKind::Other,
    }
}

/// The byte offset of 1-based `line` and `column` (in characters) of `src`, with the line
/// ends [`lex`] knows: the inverse of [`position_of`]. Past the end: `src.len()`.
fn offset_of(src: &str, line: u32, column: u32) -> usize {
    let mut at_line = 1u32;
    let mut start = 0usize;
    let bytes = src.as_bytes();
    let mut i = 0usize;
    while at_line < line && i < bytes.len() {
        let end = match bytes[i] {
            b'\r' if bytes.get(i + 1) == Some(&b'\n') => Some(2),
            b'\n' | b'\r' => Some(1),
            _ => None,
        };
        match end {
            Some(n) => {
                i += n;
                at_line += 1;
                start = i;
            }
            None => i += 1,
        }
    }
    let skip = usize::try_from(column.saturating_sub(1)).unwrap_or(usize::MAX);
    src[start..]
        .char_indices()
        .nth(skip)
        .map_or(src.len(), |(k, _)| start + k)
}

#[cfg(test)]
mod top_level_tests {
    use super::*;

    fn ends(lines: &[&str]) -> Vec<(Option<UnitKind>, bool)> {
        let mut t = TopLevel::new();
        lines
            .iter()
            .map(|l| {
                let s = t.line(l);
                (s.starts, s.ends)
            })
            .collect()
    }

    #[test]
    fn programs_blocks_and_statements() {
        use UnitKind::*;
        assert_eq!(
            ends(&[
                "",
                "  # note",
                "$ 1 \"Robot Program\"",
                "textmsg(1)",
                "def a():",
                "  if x:",
                "  elif y:",
                "  else:",
                "  end",
                "end",
                "sec s():",
                "end",
                "end"
            ]),
            [
                (None, false),
                (None, false),
                (None, false),
                (Some(Other), true),
                (Some(Def("a".into())), false),
                (None, false),
                (None, false),
                (None, false),
                (None, false),
                (None, true),
                (Some(Sec("s".into())), false),
                (None, true),
                // A stray `end` is a unit of its own (the parser refuses it).
                (Some(Other), true),
            ]
        );
    }

    #[test]
    fn strings_comments_members_and_one_line_blocks_do_not_miscount() {
        let mut t = TopLevel::new();
        assert!(!t.line("def f():").ends);
        for line in [
            "  textmsg(\"end\")",
            "  textmsg('if x:')",
            "  x = 1 # end",
            "  y = s.end",
            "  if x: y = 1 end",
            "  while False: sync() end",
            "  thread t(): return 1 end",
        ] {
            assert_eq!(
                t.line(line),
                UnitLine {
                    starts: None,
                    ends: false
                },
                "{line}"
            );
        }
        assert!(t.line("end").ends);
        // At the top level a one-line block is a whole unit.
        assert!(t.line("if True: textmsg(1) end").ends);
        assert!(!t.is_inside());
    }

    #[test]
    fn a_line_that_does_not_lex_counts_its_tokens_before_the_fault() {
        let mut t = TopLevel::new();
        assert_eq!(t.line("{{placeholder}}").starts, Some(UnitKind::Other));
        assert!(!t.is_inside());
        assert!(!t.line("def f():").ends);
        assert!(!t.line("  if x == @:").ends);
        assert!(!t.line("  textmsg(\"end").ends);
        assert!(!t.line("  end").ends);
        assert!(t.line("end").ends);
    }

    #[test]
    fn top_level_end_finds_the_first_unit() {
        assert_eq!(top_level_end(""), None);
        assert_eq!(top_level_end("# only\n\n"), None);
        assert_eq!(top_level_end("x = 1"), Some((5, UnitKind::Other)));
        assert_eq!(
            top_level_end("\r\nsec s():\r\n  x = 1\r\nend\r\ny = 2\n"),
            Some((26, UnitKind::Sec("s".into())))
        );
        assert_eq!(top_level_end("def f():\n  if x:\n  end\n"), None);
    }

    #[test]
    fn offsets_invert_positions() {
        let src = "ab\r\ncé\rx\ny";
        for i in (0..=src.len()).filter(|&i| src.is_char_boundary(i)) {
            let (line, col) = position_of(src, i);
            let back = offset_of(src, line, col);
            // A line end maps to the start of its line's end: same position.
            assert_eq!(position_of(src, back), (line, col), "{i}");
        }
    }
}
