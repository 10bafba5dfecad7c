//! Variables: the robot's `socket_set_var(name, v)` (`SET name v\n`) and
//! `socket_get_var(name)` (`GET name\n`, answered by the server with `name v\n`).
//!
//! Each message is one line: the LF framer of [`LineDecoder`](crate::line::LineDecoder)
//! frames it, then a small nom parser (complete mode, run once per line) reads it.
//!
//! # The grammar and its errors
//!
//! ```text
//! message = ("SET" blank name blank int | "GET" blank name) [blank]
//! reply   = name blank int [blank]
//! blank   = 1*(SP | HTAB)      name = 1*(printable ASCII but space)
//! int     = ["+" | "-"] 1*DIGIT   (leading zeros allowed; it must fit an i32)
//! ```
//!
//! A line that does not have this shape is an
//! [`UnexpectedByte`](ErrorKind::UnexpectedByte) error at the first byte that cannot
//! continue it (`GEX A` at byte 2, the `X`), or [`Truncated`](ErrorKind::Truncated) at
//! the line's end when it stops early (`SET A`). Only a line of the right shape has its
//! number read: one that does not fit is
//! [`IntegerOutOfRange`](ErrorKind::IntegerOutOfRange) at the number's first byte.
//! The decoders drop one CR before the LF, as every line framer of this crate does.
//!
//! # Why nom for two keywords
//!
//! Does nom earn its place in a grammar this small? It does: nom was asked for by the
//! project's user, and it is a dependency of the core anyway (the value-line grammar of
//! [`to_str`](crate::to_str) is larger and uses it), so this module costs no dependency,
//! compiles without `std` or `alloc` (`default-features = false`), and allocates nothing.
//! In complete mode over one framed line, every failure carries the input where it
//! happened, so the error position is `line.len() - rest.len()` with no bookkeeping of
//! ours. The keyword is read byte by byte (`one_of("SG")`, `E`, `T`) rather than with
//! `alt((tag("SET"), tag("GET")))`, because a failed `tag` reports where the tag started,
//! not the byte that differs. A hand-written reader of the grammar exists too, in the tests
//! (`tests/var_grammar/oracle.rs`): with its cursor and its error rule spelled out it takes
//! about three times the lines of the parser here, which is what nom saves. The property
//! tests in `tests/var_grammar.rs` and the `var_message` and `var_reply` fuzz targets
//! require the two to agree on values, error kinds and offsets.

use nom::bytes::complete::take_while1;
use nom::character::complete::{char, one_of, space1};
use nom::combinator::{opt, recognize};
use nom::sequence::preceded;
use nom::{IResult, Parser};

use crate::framer::{FrameDecoder, Parse, Pattern, ShapeKind};
use crate::line::{lf_framer, strip_cr};
use crate::number::{parse_i32, write_i32};
use crate::{ArgumentError, ByteSink, EncodeError, ErrorKind};

/// The longest variable name a robot can send: a URScript string holds at most 1023
/// characters.
pub const MAX_VAR_NAME_LEN: usize = 1023;

/// Default bound on one variable line, in bytes: the longest line a robot can send,
/// `SET` + a [`MAX_VAR_NAME_LEN`]-byte name + the longest int + LF (1,040 bytes), so a
/// server with the default bound accepts everything a robot can say.
pub const DEFAULT_MAX_VAR_LINE_LEN: usize = 4 + MAX_VAR_NAME_LEN + 12 + 1;

/// A variable name the robot can send: 1 to 1023 printable ASCII bytes, no space.
fn is_name_byte(b: u8) -> bool {
    b.is_ascii_graphic()
}

fn check_name(name: &str) -> Result<(), EncodeError> {
    if name.is_empty() || name.len() > MAX_VAR_NAME_LEN || !name.bytes().all(is_name_byte) {
        return Err(EncodeError::InvalidName);
    }
    Ok(())
}

fn put_named<S: ByteSink + ?Sized>(
    head: &[u8],
    name: &str,
    value: Option<i32>,
    sink: &mut S,
) -> Result<usize, EncodeError> {
    check_name(name)?;
    sink.put(head)?;
    sink.put(name.as_bytes())?;
    let mut n = head.len() + name.len();
    if let Some(v) = value {
        let mut digits = [0u8; 12];
        digits[0] = b' ';
        let mut text = [0u8; 11];
        let len = write_i32(v, &mut text);
        digits[1..=len].copy_from_slice(&text[..len]);
        sink.put(&digits[..=len])?;
        n += len + 1;
    }
    sink.put(b"\n")?;
    Ok(n + 1)
}

/// Writes `SET name value\n`: what `socket_set_var(name, value)` sends.
///
/// ```
/// use urscript_socket::var::encode_set_var;
/// let mut out = Vec::new();
/// encode_set_var("POS_Y", 2200, &mut out).unwrap();
/// assert_eq!(out, b"SET POS_Y 2200\n");
/// ```
pub fn encode_set_var<S: ByteSink + ?Sized>(
    name: &str,
    value: i32,
    sink: &mut S,
) -> Result<usize, EncodeError> {
    put_named(b"SET ", name, Some(value), sink)
}

/// Writes `GET name\n`: what `socket_get_var(name)` sends before waiting for the reply.
///
/// ```
/// use urscript_socket::var::encode_get_var;
/// let mut out = Vec::new();
/// encode_get_var("POS_X", &mut out).unwrap();
/// assert_eq!(out, b"GET POS_X\n");
/// ```
pub fn encode_get_var<S: ByteSink + ?Sized>(
    name: &str,
    sink: &mut S,
) -> Result<usize, EncodeError> {
    put_named(b"GET ", name, None, sink)
}

/// Writes the server's reply to `GET name`: `name value\n`.
///
/// ```
/// use urscript_socket::var::encode_var_reply;
/// let mut out = Vec::new();
/// encode_var_reply("POS_X", 1234, &mut out).unwrap();
/// assert_eq!(out, b"POS_X 1234\n");
/// ```
pub fn encode_var_reply<S: ByteSink + ?Sized>(
    name: &str,
    value: i32,
    sink: &mut S,
) -> Result<usize, EncodeError> {
    put_named(b"", name, Some(value), sink)
}

/// A variable message from the robot.
///
/// ```
/// use urscript_socket::var::{VarMessage, VarMessageDecoder};
/// let mut dec = VarMessageDecoder::new();
/// let msg = dec.decode(b"SET POS_Y 2200\n").unwrap().item().unwrap();
/// assert_eq!(msg, VarMessage::Set { name: "POS_Y", value: 2200 });
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VarMessage<'a> {
    /// `SET name value`: `socket_set_var`. No reply is expected.
    Set {
        /// Variable name.
        name: &'a str,
        /// Its new value.
        value: i32,
    },
    /// `GET name`: `socket_get_var`. Answer with [`encode_var_reply`] within 2 s.
    Get {
        /// Variable name.
        name: &'a str,
    },
}

type PResult<'a, T> = IResult<&'a [u8], T>;

/// (is `SET`, name, value token).
type VarParts<'a> = (bool, &'a [u8], Option<&'a [u8]>);

fn name(input: &[u8]) -> PResult<'_, &[u8]> {
    take_while1(is_name_byte)(input)
}

fn int_token(input: &[u8]) -> PResult<'_, &[u8]> {
    recognize((opt(one_of("+-")), take_while1(|b: u8| b.is_ascii_digit()))).parse(input)
}

/// `SET name int` | `GET name`, spaces or tabs between, nothing after. The keyword is
/// read byte by byte so that an error points at the first byte that is neither keyword
/// (`GEX` at the `X`; a failed `tag` would point at its start).
fn var_message(input: &[u8]) -> PResult<'_, VarParts<'_>> {
    let (rest, (first, _, _)) = (one_of("SG"), char('E'), char('T')).parse(input)?;
    if first == 'S' {
        let (rest, (n, v)) = (preceded(space1, name), preceded(space1, int_token)).parse(rest)?;
        Ok((rest, (true, n, Some(v))))
    } else {
        let (rest, n) = preceded(space1, name).parse(rest)?;
        Ok((rest, (false, n, None)))
    }
}

/// `name int`.
fn var_reply(input: &[u8]) -> PResult<'_, (&[u8], &[u8])> {
    (name, preceded(space1, int_token)).parse(input)
}

/// Runs a complete-mode parser over a whole line; the error is (kind, offset in line).
fn whole_line<'a, T>(
    line: &'a [u8],
    parser: impl Fn(&'a [u8]) -> PResult<'a, T>,
    expected: &'static str,
) -> Result<T, (ErrorKind, usize)> {
    match parser(line) {
        Ok((rest, v)) => {
            // Trailing spaces are tolerated; anything else is not.
            let trailing = rest.iter().position(|&b| b != b' ' && b != b'\t');
            match trailing {
                None => Ok(v),
                Some(i) => {
                    let at = line.len() - rest.len() + i;
                    Err((unexpected(line, at, expected), at))
                }
            }
        }
        Err(nom::Err::Error(e) | nom::Err::Failure(e)) => {
            let at = line.len() - e.input.len();
            Err((unexpected(line, at, expected), at))
        }
        Err(nom::Err::Incomplete(_)) => Err((ErrorKind::Truncated, line.len())),
    }
}

fn unexpected(line: &[u8], at: usize, expected: &'static str) -> ErrorKind {
    match line.get(at) {
        Some(&found) => ErrorKind::UnexpectedByte { found, expected },
        None => ErrorKind::Truncated,
    }
}

fn int_value(token: &[u8], token_at: usize) -> Result<i32, (ErrorKind, usize)> {
    parse_i32(token).map_err(|(k, i)| (k, token_at + i))
}

fn offset_in(line: &[u8], part: &[u8]) -> usize {
    part.as_ptr() as usize - line.as_ptr() as usize
}

/// Server-side decoder of the robot's `SET`/`GET` lines. Bound: lines of at most
/// `max_len` bytes ([`DEFAULT_MAX_VAR_LINE_LEN`]). A malformed line is an error at the
/// offending byte and is consumed whole; the next line decodes normally. At end of input an
/// unterminated line is [`Truncated`](ErrorKind::Truncated).
///
/// ```
/// use urscript_socket::var::{VarMessage, VarMessageDecoder};
/// let mut dec = VarMessageDecoder::new();
/// let buf = b"GET POS_X\nSET A 1\n";
/// let first = dec.decode(buf).unwrap();
/// assert_eq!(first.consumed(), 10);
/// assert_eq!(first.item(), Some(VarMessage::Get { name: "POS_X" }));
/// let e = dec.decode(b"SET A x\n").unwrap_err();
/// assert_eq!(e.offset(), 16);
/// assert!(VarMessageDecoder::new().decode_eof(b"GET A").is_err());
/// ```
pub type VarMessageDecoder = FrameDecoder<VarMessages>;

/// The parse step of [`VarMessageDecoder`]: [`parse_var_message`] on one line.
#[derive(Debug, Clone, Copy, Default)]
pub struct VarMessages;

impl Parse for VarMessages {
    type Output<'a> = VarMessage<'a>;
    const SHAPE: ShapeKind = ShapeKind::Delimited;
    #[inline]
    fn parse<'a>(&self, line: &'a [u8]) -> Result<VarMessage<'a>, (ErrorKind, usize)> {
        parse_var_message(strip_cr(line))
    }
}

impl Default for VarMessageDecoder {
    fn default() -> Self {
        Self::new()
    }
}

impl VarMessageDecoder {
    /// A decoder with the default bound.
    ///
    /// ```
    /// # use urscript_socket::var::VarMessageDecoder;
    /// let _ = VarMessageDecoder::new();
    /// ```
    pub fn new() -> Self {
        FrameDecoder::from_parts(lf_framer(DEFAULT_MAX_VAR_LINE_LEN), VarMessages)
    }
}

/// Parses one `SET name int` / `GET name` line (without its LF).
///
/// ```
/// use urscript_socket::var::{parse_var_message, VarMessage};
/// assert_eq!(parse_var_message(b"GET A"), Ok(VarMessage::Get { name: "A" }));
/// assert!(parse_var_message(b"PUT A").is_err());
/// ```
pub fn parse_var_message(line: &[u8]) -> Result<VarMessage<'_>, (ErrorKind, usize)> {
    let (is_set, name, value) = whole_line(line, var_message, "`SET name int` or `GET name`")?;
    let name = ascii(name);
    match value {
        Some(token) => Ok(VarMessage::Set {
            name,
            value: int_value(token, offset_in(line, token))?,
        }),
        None if is_set => Err((ErrorKind::Truncated, line.len())),
        None => Ok(VarMessage::Get { name }),
    }
}

fn ascii(name: &[u8]) -> &str {
    // `name` only holds ASCII graphic bytes (the parser checked), so this never fails.
    core::str::from_utf8(name).unwrap_or("")
}

/// Robot-side decoder of the server's reply to `GET name`: a line `name int` (leading
/// zeros allowed, as gripper daemons send `PRE 077`). A reply naming another variable is a
/// [`NameMismatch`](ErrorKind::NameMismatch) error; the emulated `get_var` then returns 0.
/// At end of input an unterminated line is [`Truncated`](ErrorKind::Truncated).
///
/// ```
/// use urscript_socket::{var::VarReplyDecoder, ErrorKind};
/// let mut dec = VarReplyDecoder::new("POS_X").unwrap();
/// assert_eq!(dec.decode(b"POS_X 1234\n").unwrap().item(), Some(1234));
/// assert_eq!(dec.decode(b"POS 1\n").unwrap_err().kind(), ErrorKind::NameMismatch);
/// assert!(VarReplyDecoder::new("A").unwrap().decode_eof(b"A 1").is_err());
/// ```
pub type VarReplyDecoder = FrameDecoder<VarReply>;

/// The parse step of [`VarReplyDecoder`]: `name int` for one variable name.
#[derive(Debug, Clone, Copy)]
pub struct VarReply {
    name: Pattern,
}

impl Parse for VarReply {
    type Output<'a> = i32;
    const SHAPE: ShapeKind = ShapeKind::Delimited;
    #[inline]
    fn parse(&self, line: &[u8]) -> Result<i32, (ErrorKind, usize)> {
        let line = strip_cr(line);
        let (name, token) = whole_line(line, var_reply, "`name int`")?;
        if name != self.name.as_bytes() {
            return Err((ErrorKind::NameMismatch, 0));
        }
        int_value(token, offset_in(line, token))
    }
}

impl VarReplyDecoder {
    /// A decoder for replies about `name` (1 to 64 printable ASCII bytes, no space).
    ///
    /// ```
    /// # use urscript_socket::var::VarReplyDecoder;
    /// assert!(VarReplyDecoder::new("has space").is_err());
    /// ```
    pub fn new(name: &str) -> Result<Self, ArgumentError> {
        if check_name(name).is_err() {
            return Err(ArgumentError::InvalidName);
        }
        let parser = VarReply {
            name: Pattern::new(name.as_bytes())?,
        };
        Ok(FrameDecoder::from_parts(
            lf_framer(DEFAULT_MAX_VAR_LINE_LEN),
            parser,
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use alloc::vec::Vec;

    #[test]
    fn messages_and_errors() {
        assert_eq!(
            parse_var_message(b"SET  X\t-5  "),
            Ok(VarMessage::Set {
                name: "X",
                value: -5
            })
        );
        assert_eq!(
            parse_var_message(b"SET X").unwrap_err().0,
            ErrorKind::Truncated
        );
        assert_eq!(
            parse_var_message(b"SET X 99999999999").unwrap_err().0,
            ErrorKind::IntegerOutOfRange
        );
        let (kind, at) = parse_var_message(b"GET X Y").unwrap_err();
        assert_eq!(
            (kind, at),
            (
                ErrorKind::UnexpectedByte {
                    found: b'Y',
                    expected: "`SET name int` or `GET name`"
                },
                6
            )
        );
    }

    #[test]
    fn error_offsets_are_absolute() {
        let mut d = VarMessageDecoder::new();
        let buf = b"GET A\r\nSET B z\n";
        assert_eq!(d.decode(buf).unwrap().consumed(), 7);
        let e = d.decode(&buf[7..]).unwrap_err();
        assert_eq!((e.offset(), e.skip()), (13, 8));
    }

    #[test]
    fn names_are_checked() {
        let mut out = Vec::new();
        assert_eq!(
            encode_set_var("", 1, &mut out),
            Err(EncodeError::InvalidName)
        );
        assert_eq!(
            encode_get_var("a b", &mut out),
            Err(EncodeError::InvalidName)
        );
        assert_eq!(
            encode_var_reply("a\n", 1, &mut out),
            Err(EncodeError::InvalidName)
        );
    }
}
