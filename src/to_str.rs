//! The text form of values: what `socket_send_string(x)`/`socket_send_line(x)` send for
//! a number, bool, list or pose (UR documents it as `to_str`), and a tolerant parser that
//! turns such text back into a typed [`Value`].
//!
//! Robot's form (spec section 2): ints in decimal; floats with at most 6 decimals,
//! trailing zeros and a bare point removed (`2.123456123456` → `2.123456`, `1.0` → `1`);
//! `True`/`False`; lists `[a, b, c]`; poses `p[a, b, c, d, e, f]`; at most 1023
//! characters.
//!
//! The parser accepts more, as servers should: any spaces, exponents, `true`/`false` in
//! any case, `nan`/`inf`, and a pose's `p` may be missing (then the text is a list).

use core::fmt::Write as _;

use nom::branch::alt;
use nom::bytes::complete::{tag_no_case, take_while1};
use nom::combinator::map;
use nom::{IResult, Parser};

use crate::framer::{FrameDecoder, Parse, ShapeKind};
use crate::line::{lf_framer, strip_cr};
use crate::number::{is_space, parse_float_token, parse_i32, write_i32};
use crate::{ByteSink, DecodeError, EncodeError, ErrorKind};

/// The longest text the robot produces for one value.
pub const MAX_TO_STR_LEN: usize = 1023;

/// A single number or bool.
///
/// ```
/// use urscript_socket::to_str::{parse_value, Scalar, Value};
/// assert_eq!(parse_value(b"-3").unwrap(), Value::Scalar(Scalar::Int(-3)));
/// ```
#[derive(Debug, Clone, Copy)]
pub enum Scalar {
    /// An integer (no point, no exponent, fits int32).
    Int(i32),
    /// Any other number.
    Float(f64),
    /// `True` / `False`.
    Bool(bool),
}

/// Equality is bitwise for floats, so NaN equals NaN.
impl PartialEq for Scalar {
    fn eq(&self, other: &Self) -> bool {
        match (self, other) {
            (Scalar::Int(a), Scalar::Int(b)) => a == b,
            (Scalar::Float(a), Scalar::Float(b)) => a.to_bits() == b.to_bits(),
            (Scalar::Bool(a), Scalar::Bool(b)) => a == b,
            _ => false,
        }
    }
}

/// A value in `to_str` form: a scalar, a pose or a flat list of scalars.
///
/// ```
/// use urscript_socket::to_str::{parse_value, Value};
/// let v = parse_value(b"p[1, 2, 3, 4, 5, 6]").unwrap();
/// assert_eq!(v, Value::Pose([1.0, 2.0, 3.0, 4.0, 5.0, 6.0]));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Value<'a> {
    /// A number or bool.
    Scalar(Scalar),
    /// `p[x, y, z, rx, ry, rz]`.
    Pose([f64; 6]),
    /// `[a, b, ...]`.
    List(List<'a>),
}

/// A flat list of scalars: either borrowed items (to encode) or validated text (parsed),
/// read without allocation through [`iter`](Self::iter).
///
/// ```
/// use urscript_socket::to_str::{parse_value, Scalar, Value};
/// let Value::List(list) = parse_value(b"[True, 2, 0.5]").unwrap() else { panic!() };
/// let items: Vec<Scalar> = list.iter().collect();
/// assert_eq!(items, [Scalar::Bool(true), Scalar::Int(2), Scalar::Float(0.5)]);
/// ```
#[derive(Debug, Clone, Copy)]
pub struct List<'a> {
    repr: ListRepr<'a>,
    len: usize,
}

#[derive(Debug, Clone, Copy)]
enum ListRepr<'a> {
    Items(&'a [Scalar]),
    /// The text between the brackets, already checked to be `scalar (, scalar)*`.
    Text(&'a [u8]),
}

impl<'a> List<'a> {
    /// A list of the given items, for encoding.
    ///
    /// ```
    /// use urscript_socket::to_str::{List, Scalar};
    /// assert_eq!(List::from_items(&[Scalar::Int(1)]).len(), 1);
    /// ```
    pub fn from_items(items: &'a [Scalar]) -> Self {
        List {
            repr: ListRepr::Items(items),
            len: items.len(),
        }
    }

    /// Number of items.
    ///
    /// ```
    /// # use urscript_socket::to_str::{parse_value, Value};
    /// let Value::List(l) = parse_value(b"[]").unwrap() else { panic!() };
    /// assert!(l.is_empty());
    /// ```
    pub fn len(&self) -> usize {
        self.len
    }

    /// True if the list has no item.
    ///
    /// ```
    /// # use urscript_socket::to_str::List;
    /// assert!(List::from_items(&[]).is_empty());
    /// ```
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The items in order.
    ///
    /// ```
    /// # use urscript_socket::to_str::{parse_value, Scalar, Value};
    /// let Value::List(l) = parse_value(b"[1,2]").unwrap() else { panic!() };
    /// assert_eq!(l.iter().count(), 2);
    /// ```
    pub fn iter(&self) -> ListIter<'a> {
        ListIter {
            repr: self.repr,
            index: 0,
        }
    }
}

impl PartialEq for List<'_> {
    fn eq(&self, other: &Self) -> bool {
        self.len == other.len && self.iter().eq(other.iter())
    }
}

/// Iterator over a [`List`]'s items.
///
/// ```
/// # use urscript_socket::to_str::{List, Scalar};
/// let items = [Scalar::Bool(false)];
/// assert_eq!(List::from_items(&items).iter().next(), Some(Scalar::Bool(false)));
/// ```
#[derive(Debug, Clone)]
pub struct ListIter<'a> {
    repr: ListRepr<'a>,
    index: usize,
}

impl Iterator for ListIter<'_> {
    type Item = Scalar;
    fn next(&mut self) -> Option<Scalar> {
        match self.repr {
            ListRepr::Items(items) => {
                let item = items.get(self.index).copied();
                self.index += 1;
                item
            }
            ListRepr::Text(text) => {
                let rest = text.get(self.index..)?;
                let end = memchr::memchr(b',', rest).unwrap_or(rest.len());
                let token = crate::number::trim(&rest[..end]).1;
                if token.is_empty() {
                    return None;
                }
                self.index += end + 1;
                // Validated by `parse_value`; an invalid token just ends the iteration.
                scalar_token(token).ok()
            }
        }
    }
}

/// Writes the robot's `to_str` text of `value` and returns its length. Errors: the text
/// would exceed [`MAX_TO_STR_LEN`] characters.
///
/// ```
/// use urscript_socket::to_str::{encode_value, Scalar, Value, List};
/// let mut out = Vec::new();
/// encode_value(&Value::Pose([1.0, 2.0, 3.0, 4.0, 5.0, 6.0]), &mut out).unwrap();
/// assert_eq!(out, b"p[1, 2, 3, 4, 5, 6]");
/// out.clear();
/// let items = [Scalar::Bool(true), Scalar::Bool(false), Scalar::Bool(true)];
/// encode_value(&Value::List(List::from_items(&items)), &mut out).unwrap();
/// assert_eq!(out, b"[True, False, True]");
/// ```
pub fn encode_value<S: ByteSink + ?Sized>(
    value: &Value<'_>,
    sink: &mut S,
) -> Result<usize, EncodeError> {
    let mut counted = Counted { sink, len: 0 };
    match value {
        Value::Scalar(s) => put_scalar(*s, &mut counted)?,
        Value::Pose(p) => {
            counted.put(b"p")?;
            put_list(p.iter().map(|&v| Scalar::Float(v)), &mut counted)?;
        }
        Value::List(l) => put_list(l.iter(), &mut counted)?,
    }
    Ok(counted.len)
}

/// Writes the `to_str` text of one float: 6 decimals, trailing zeros and point removed.
///
/// ```
/// use urscript_socket::to_str::encode_float;
/// let mut out = Vec::new();
/// encode_float(2.123456123456, &mut out).unwrap();
/// assert_eq!(out, b"2.123456");
/// ```
pub fn encode_float<S: ByteSink + ?Sized>(value: f64, sink: &mut S) -> Result<usize, EncodeError> {
    encode_value(&Value::Scalar(Scalar::Float(value)), sink)
}

struct Counted<'s, S: ?Sized> {
    sink: &'s mut S,
    len: usize,
}

impl<S: ByteSink + ?Sized> Counted<'_, S> {
    fn put(&mut self, bytes: &[u8]) -> Result<(), EncodeError> {
        if self.len + bytes.len() > MAX_TO_STR_LEN {
            return Err(EncodeError::TooLong {
                limit: MAX_TO_STR_LEN,
            });
        }
        self.sink.put(bytes)?;
        self.len += bytes.len();
        Ok(())
    }
}

fn put_list<S: ByteSink + ?Sized>(
    items: impl Iterator<Item = Scalar>,
    out: &mut Counted<'_, S>,
) -> Result<(), EncodeError> {
    out.put(b"[")?;
    for (i, s) in items.enumerate() {
        if i > 0 {
            out.put(b", ")?;
        }
        put_scalar(s, out)?;
    }
    out.put(b"]")
}

/// A stack buffer for `core::fmt` output.
struct StackText<const N: usize> {
    buf: [u8; N],
    len: usize,
}

impl<const N: usize> core::fmt::Write for StackText<N> {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        let end = self.len + s.len();
        if end > N {
            return Err(core::fmt::Error);
        }
        self.buf[self.len..end].copy_from_slice(s.as_bytes());
        self.len = end;
        Ok(())
    }
}

fn put_scalar<S: ByteSink + ?Sized>(
    s: Scalar,
    out: &mut Counted<'_, S>,
) -> Result<(), EncodeError> {
    match s {
        Scalar::Int(v) => {
            let mut text = [0u8; 11];
            let n = write_i32(v, &mut text);
            out.put(&text[..n])
        }
        Scalar::Bool(true) => out.put(b"True"),
        Scalar::Bool(false) => out.put(b"False"),
        Scalar::Float(v) => {
            let text = FloatText::new(v);
            out.put(text.as_bytes())
        }
    }
}

/// The `to_str` text of one float, on the stack: `nan`, `inf`, `-inf`, or 6 decimals
/// with trailing zeros and the point removed. The one float writer of the crate.
struct FloatText {
    text: StackText<320>,
}

impl FloatText {
    fn new(v: f64) -> Self {
        let mut text = StackText::<320> {
            buf: [0; 320],
            len: 0,
        };
        // `{:.6}` rounds correctly from the exact binary value; the longest finite
        // result is 309 integer digits, a sign, a point and 6 decimals, so it fits.
        let _ = if v.is_nan() {
            text.write_str("nan")
        } else if v.is_infinite() {
            text.write_str(if v > 0.0 { "inf" } else { "-inf" })
        } else {
            write!(text, "{v:.6}")
        };
        if !v.is_finite() {
            return FloatText { text };
        }
        let mut len = text.len;
        while len > 0 && text.buf[len - 1] == b'0' {
            len -= 1;
        }
        if len > 0 && text.buf[len - 1] == b'.' {
            len -= 1;
        }
        text.len = len;
        FloatText { text }
    }

    fn as_bytes(&self) -> &[u8] {
        &self.text.buf[..self.text.len]
    }

    fn as_str(&self) -> &str {
        // Only ASCII was written.
        core::str::from_utf8(self.as_bytes()).unwrap_or("nan")
    }
}

/// Writes the `to_str` text of a scalar (`2.123456`, `-3`, `True`) to a formatter: the
/// same rules as [`encode_value`], without its 1023-character bound. For display.
///
/// ```
/// use urscript_socket::to_str::{write_scalar, Scalar};
/// let mut s = String::new();
/// write_scalar(Scalar::Float(3.14159265), &mut s).unwrap();
/// write_scalar(Scalar::Float(f64::NAN), &mut s).unwrap();
/// assert_eq!(s, "3.141593nan");
/// ```
pub fn write_scalar(s: Scalar, out: &mut impl core::fmt::Write) -> core::fmt::Result {
    match s {
        Scalar::Int(v) => write!(out, "{v}"),
        Scalar::Bool(true) => out.write_str("True"),
        Scalar::Bool(false) => out.write_str("False"),
        Scalar::Float(v) => out.write_str(FloatText::new(v).as_str()),
    }
}

/// Writes the `to_str` text of a value to a formatter (`p[1, 2, 3, 0, 3.141593, 0]`,
/// `[True, False]`), without [`encode_value`]'s 1023-character bound. For display.
///
/// ```
/// use urscript_socket::to_str::{write_value, Value};
/// let mut s = String::new();
/// write_value(&Value::Pose([0.1, 0.2, 0.3, 0.0, 3.14159265, 0.0]), &mut s).unwrap();
/// assert_eq!(s, "p[0.1, 0.2, 0.3, 0, 3.141593, 0]");
/// ```
pub fn write_value(value: &Value<'_>, out: &mut impl core::fmt::Write) -> core::fmt::Result {
    match value {
        Value::Scalar(s) => write_scalar(*s, out),
        Value::Pose(p) => {
            out.write_char('p')?;
            write_list(p.iter().map(|&v| Scalar::Float(v)), out)
        }
        Value::List(l) => write_list(l.iter(), out),
    }
}

/// Writes `[a, b, c]` with the scalars' `to_str` text.
pub fn write_list(
    items: impl IntoIterator<Item = Scalar>,
    out: &mut impl core::fmt::Write,
) -> core::fmt::Result {
    out.write_char('[')?;
    for (i, s) in items.into_iter().enumerate() {
        if i > 0 {
            out.write_str(", ")?;
        }
        write_scalar(s, out)?;
    }
    out.write_char(']')
}

impl core::fmt::Display for Value<'_> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write_value(self, f)
    }
}

type PResult<'a, T> = IResult<&'a [u8], T>;

fn scalar_token(token: &[u8]) -> Result<Scalar, usize> {
    if token.eq_ignore_ascii_case(b"true") {
        return Ok(Scalar::Bool(true));
    }
    if token.eq_ignore_ascii_case(b"false") {
        return Ok(Scalar::Bool(false));
    }
    let unsigned = match token {
        [b'+' | b'-', rest @ ..] => rest,
        _ => token,
    };
    if unsigned.eq_ignore_ascii_case(b"nan") {
        return Ok(Scalar::Float(f64::NAN));
    }
    if unsigned.eq_ignore_ascii_case(b"inf") || unsigned.eq_ignore_ascii_case(b"infinity") {
        let neg = token[0] == b'-';
        return Ok(Scalar::Float(if neg {
            f64::NEG_INFINITY
        } else {
            f64::INFINITY
        }));
    }
    if !unsigned.is_empty() && unsigned.iter().all(u8::is_ascii_digit) {
        if let Ok(v) = parse_i32(token) {
            return Ok(Scalar::Int(v));
        }
    }
    parse_float_token(token, true).map(Scalar::Float)
}

/// A scalar token: letters, digits, sign, point.
fn token(input: &[u8]) -> PResult<'_, &[u8]> {
    take_while1(|b: u8| b.is_ascii_alphanumeric() || matches!(b, b'+' | b'-' | b'.'))(input)
}

/// The opening of a bracketed value: `p[` (pose) or `[` (list), spaces allowed.
fn opening(input: &[u8]) -> PResult<'_, bool> {
    alt((
        map(
            (
                tag_no_case(&b"p"[..]),
                nom::character::complete::space0,
                nom::bytes::complete::tag(&b"["[..]),
            ),
            |_| true,
        ),
        map(nom::bytes::complete::tag(&b"["[..]), |_| false),
    ))
    .parse(input)
}

/// Parses the `to_str` text of a value (tolerantly, see the module docs). Errors give the
/// offset of the offending byte within `text`.
///
/// ```
/// use urscript_socket::to_str::{parse_value, Scalar, Value};
/// assert_eq!(parse_value(b" 2.5e1 ").unwrap(), Value::Scalar(Scalar::Float(25.0)));
/// assert_eq!(parse_value(b"False").unwrap(), Value::Scalar(Scalar::Bool(false)));
/// let err = parse_value(b"[1, x]").unwrap_err();
/// assert_eq!(err.offset(), 4);
/// ```
pub fn parse_value(text: &[u8]) -> Result<Value<'_>, DecodeError> {
    let fail = |kind, at: usize| DecodeError::new(kind, at as u64, text.len());
    let (lead, body) = crate::number::trim(text);
    if body.is_empty() {
        return Err(fail(ErrorKind::Empty, lead));
    }
    let Ok((after_open, is_pose)) = opening(body) else {
        // A scalar: the whole body must be one token.
        return match token(body) {
            Ok((b"", tok)) => scalar_token(tok)
                .map(Value::Scalar)
                .map_err(|i| fail(ErrorKind::InvalidNumber, lead + i)),
            Ok((rest, _)) => Err(fail(
                ErrorKind::UnexpectedByte {
                    found: rest[0],
                    expected: "a number, True or False",
                },
                lead + body.len() - rest.len(),
            )),
            Err(_) => Err(fail(
                ErrorKind::UnexpectedByte {
                    found: body[0],
                    expected: "a number, True, False, '[' or 'p['",
                },
                lead,
            )),
        };
    };
    let inner_at = lead + body.len() - after_open.len();
    let Some((&b']', inner)) = after_open.split_last() else {
        let last = body.len() - 1;
        return Err(fail(
            ErrorKind::UnexpectedByte {
                found: body[last],
                expected: "']' closing the list",
            },
            lead + last,
        ));
    };
    // Validate each item once; count them.
    let mut count = 0usize;
    let mut pose = [0.0; 6];
    if !crate::number::trim(inner).1.is_empty() {
        let mut i = 0;
        loop {
            let end = memchr::memchr(b',', &inner[i..]).map_or(inner.len(), |e| i + e);
            let (s, tok) = crate::number::trim(&inner[i..end]);
            let at = inner_at + i + s;
            if tok.is_empty() {
                return Err(fail(ErrorKind::Empty, at));
            }
            if tok.iter().any(|&b| is_space(b)) || tok.contains(&b'[') || tok.contains(&b']') {
                return Err(fail(ErrorKind::InvalidNumber, at));
            }
            let scalar = scalar_token(tok).map_err(|k| fail(ErrorKind::InvalidNumber, at + k))?;
            if is_pose {
                let v = match scalar {
                    Scalar::Int(v) => f64::from(v),
                    Scalar::Float(v) => v,
                    Scalar::Bool(_) => return Err(fail(ErrorKind::InvalidNumber, at)),
                };
                if count >= 6 {
                    return Err(fail(ErrorKind::TooManyValues { limit: 6 }, at));
                }
                pose[count] = v;
            }
            count += 1;
            if end == inner.len() {
                break;
            }
            i = end + 1;
        }
    }
    if is_pose {
        if count != 6 {
            return Err(fail(
                ErrorKind::TooFewValues {
                    found: count,
                    wanted: 6,
                },
                lead + body.len() - 1,
            ));
        }
        return Ok(Value::Pose(pose));
    }
    Ok(Value::List(List {
        repr: ListRepr::Text(inner),
        len: count,
    }))
}

/// Decoder of lines holding the `to_str` text of one value: what a robot's
/// `socket_send_line(x)` puts on the wire for a number, bool, list or pose. The item is the
/// parsed [`Value`], borrowing the line; a line that is no value is an error at the
/// offending byte (absolute, CR LF or LF alike) and is consumed whole.
///
/// Framed as [`LineDecoder`](crate::line::LineDecoder) lines (LF, one CR before it
/// dropped, bound `max_len`, truncated at end of input), parsed by [`parse_value`].
///
/// ```
/// use urscript_socket::to_str::{Value, ValueLineDecoder};
/// let mut d = ValueLineDecoder::new();
/// let v = d.decode(b"p[1, 2, 3, 4, 5, 6]\n").unwrap().item().unwrap();
/// assert_eq!(v, Value::Pose([1.0, 2.0, 3.0, 4.0, 5.0, 6.0]));
/// let e = d.decode(b"[1, x]\r\n").unwrap_err();
/// assert_eq!((e.offset(), e.skip()), (20 + 4, 8));
/// ```
pub type ValueLineDecoder = FrameDecoder<ValueLine>;

/// The parse step of [`ValueLineDecoder`]: [`parse_value`] on one line.
#[derive(Debug, Clone, Copy, Default)]
pub struct ValueLine;

impl Parse for ValueLine {
    type Output<'a> = Value<'a>;
    const SHAPE: ShapeKind = ShapeKind::Delimited;
    fn parse<'a>(&self, line: &'a [u8]) -> Result<Value<'a>, (ErrorKind, usize)> {
        parse_value(strip_cr(line)).map_err(|e| (e.kind(), e.offset() as usize))
    }
}

impl Default for ValueLineDecoder {
    fn default() -> Self {
        Self::new()
    }
}

impl ValueLineDecoder {
    /// A decoder with the line decoder's default bound.
    ///
    /// ```
    /// # use urscript_socket::{line::DEFAULT_MAX_LINE_LEN, to_str::ValueLineDecoder};
    /// assert_eq!(ValueLineDecoder::new().max_len(), DEFAULT_MAX_LINE_LEN);
    /// ```
    pub fn new() -> Self {
        Self::with_max_len(crate::line::DEFAULT_MAX_LINE_LEN)
    }

    /// A decoder whose lines hold at most `max_len` bytes before the LF (clamped to
    /// [`MAX_BOUND`](crate::MAX_BOUND)).
    ///
    /// ```
    /// # use urscript_socket::to_str::ValueLineDecoder;
    /// assert!(ValueLineDecoder::with_max_len(2).decode(b"123\n").is_err());
    /// ```
    pub fn with_max_len(max_len: usize) -> Self {
        FrameDecoder::from_parts(lf_framer(max_len), ValueLine)
    }

    /// The bound on a line's content.
    ///
    /// ```
    /// # use urscript_socket::to_str::ValueLineDecoder;
    /// assert_eq!(ValueLineDecoder::with_max_len(9).max_len(), 9);
    /// ```
    pub fn max_len(&self) -> usize {
        self.framer.bound()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use alloc::vec::Vec;

    fn text(v: &Value<'_>) -> alloc::string::String {
        let mut out = Vec::new();
        encode_value(v, &mut out).unwrap();
        alloc::string::String::from_utf8(out).unwrap()
    }

    #[test]
    fn robot_forms() {
        assert_eq!(text(&Value::Scalar(Scalar::Int(10))), "10");
        assert_eq!(text(&Value::Scalar(Scalar::Int(-3))), "-3");
        assert_eq!(text(&Value::Scalar(Scalar::Float(1.0))), "1");
        assert_eq!(text(&Value::Scalar(Scalar::Float(0.1))), "0.1");
        assert_eq!(text(&Value::Scalar(Scalar::Float(-0.0000004))), "-0");
        assert_eq!(
            text(&Value::Scalar(Scalar::Float(1e20))),
            "100000000000000000000"
        );
        assert_eq!(text(&Value::Scalar(Scalar::Float(f64::NAN))), "nan");
    }

    #[test]
    fn tolerant_parse() {
        assert_eq!(
            parse_value(b"[1,2,3,4,5,6]").unwrap(),
            Value::List(List::from_items(&[
                Scalar::Int(1),
                Scalar::Int(2),
                Scalar::Int(3),
                Scalar::Int(4),
                Scalar::Int(5),
                Scalar::Int(6)
            ]))
        );
        assert_eq!(
            parse_value(b" P [ 1e-3 ,2,3,4,5, -6 ] ").unwrap(),
            Value::Pose([0.001, 2.0, 3.0, 4.0, 5.0, -6.0])
        );
        assert_eq!(
            parse_value(b"99999999999").unwrap(),
            Value::Scalar(Scalar::Float(99999999999.0))
        );
        assert_eq!(
            parse_value(b"p[1,2]").unwrap_err().kind(),
            ErrorKind::TooFewValues {
                found: 2,
                wanted: 6
            }
        );
        assert_eq!(parse_value(b"[1,,2]").unwrap_err().kind(), ErrorKind::Empty);
        assert!(parse_value(b"[1 2]").is_err());
        assert!(parse_value(b"[1, [2]]").is_err());
        assert!(parse_value(b"[1").is_err());
        assert!(parse_value(b"").is_err());
    }

    #[test]
    fn too_long() {
        let items = [Scalar::Int(-1_000_000_000); 100];
        let mut out = Vec::new();
        assert_eq!(
            encode_value(&Value::List(List::from_items(&items)), &mut out),
            Err(EncodeError::TooLong {
                limit: MAX_TO_STR_LEN
            })
        );
    }
}
