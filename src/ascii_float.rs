//! ASCII float tuples: `(1.414,3.14159)`, what `socket_read_ascii_float(number)` reads.
//!
//! * Server → robot: [`encode_float_tuple`] writes the conservative form of spec section 3:
//!   `(`, values joined by `,`, `)`, each the shortest plain decimal that parses back to
//!   the same `f64`, no exponent, finite only, 1..=30 values, optional trailing LF.
//! * Robot side: [`FloatTupleDecoder`] reads one tuple under a [`FloatReadPolicy`] and
//!   yields a [`FloatTuple`], the URScript result `[count, v1, ..., vN]`.
//!
//! Grammar read (spec sections 3 and 6), spaces meaning space, tab, CR or LF:
//!
//! ```text
//! tuple  = "(" spaces number (spaces "," spaces number)* spaces ")"
//! number = [+-]? (digits ("." digits?)? | "." digits) ([eE] [+-]? digits)?
//! ```

use crate::framer::{FrameDecoder, Framer, Noise, Parse, ShapeKind};
use crate::number::{is_space, parse_float_prefix, write_plain_f64, MAX_PLAIN_F64_LEN};
#[cfg(doc)]
use crate::DecodeError;
use crate::{ArgumentError, ByteSink, EncodeError, ErrorKind};

/// The most values one `socket_read_ascii_float` call reads (and one tuple may carry): the
/// crate's one `MAX_VALUES`, re-exported here.
pub use crate::MAX_VALUES;

/// Default bound on one tuple's length in bytes, parentheses included. Every tuple
/// [`encode_float_tuple`] can produce fits (at most [`MAX_ENCODED_LEN`] bytes).
pub const DEFAULT_MAX_TUPLE_LEN: usize = 16 * 1024;

/// The longest output of [`encode_float_tuple`]: 30 values of at most 327 bytes, 29
/// commas, two parentheses and a LF.
pub const MAX_ENCODED_LEN: usize = MAX_VALUES * MAX_PLAIN_F64_LEN + (MAX_VALUES - 1) + 3;

/// Writes `values` as `(v1,v2,...)` (plus `\n` if `trailing_lf`) and returns the length.
///
/// Errors, with nothing guessed: no values, more than 30, or a NaN/infinity.
///
/// ```
/// use urscript_socket::ascii_float::encode_float_tuple;
/// let mut out = Vec::new();
/// encode_float_tuple(&[1.414, 3.14159, 0.0, -2e-7], true, &mut out).unwrap();
/// assert_eq!(out, b"(1.414,3.14159,0,-0.0000002)\n");
/// ```
pub fn encode_float_tuple<S: ByteSink + ?Sized>(
    values: &[f64],
    trailing_lf: bool,
    sink: &mut S,
) -> Result<usize, EncodeError> {
    if values.is_empty() {
        return Err(EncodeError::NoValues);
    }
    if values.len() > MAX_VALUES {
        return Err(EncodeError::TooManyValues { limit: MAX_VALUES });
    }
    if let Some(index) = values.iter().position(|v| !v.is_finite()) {
        return Err(EncodeError::NotFinite { index });
    }
    // The text is built in a 1 KiB stack buffer and handed to the sink when the next value
    // might not fit: one `put` per typical tuple, no 10 KB worst case on the stack.
    let mut buf = [0u8; 1024];
    let mut len = 0;
    let mut total = 0;
    for (i, &v) in values.iter().enumerate() {
        if buf.len() - len < MAX_PLAIN_F64_LEN + 3 {
            sink.put(&buf[..len])?;
            total += len;
            len = 0;
        }
        buf[len] = if i == 0 { b'(' } else { b',' };
        len += 1;
        len += write_plain_f64(v, &mut buf[len..]);
    }
    buf[len] = b')';
    len += 1;
    if trailing_lf {
        buf[len] = b'\n';
        len += 1;
    }
    sink.put(&buf[..len])?;
    Ok(total + len)
}

/// What to do with bytes before the `(` of a tuple (for example the `\n` a server sent
/// after the previous tuple). Spec section 6.
///
/// ```
/// use urscript_socket::ascii_float::LeadingBytes;
/// assert_eq!(LeadingBytes::default(), LeadingBytes::Skip);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LeadingBytes {
    /// Drop them silently (default).
    #[default]
    Skip,
    /// Fail the read at the first such byte, dropping the bytes up to the next `(`.
    Fail,
}

/// What to do when the tuple holds more values than the read asked for. Spec section 6.
///
/// ```
/// use urscript_socket::ascii_float::ExtraValues;
/// assert_eq!(ExtraValues::default(), ExtraValues::Fail);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ExtraValues {
    /// The read fails; the whole tuple is consumed (default).
    #[default]
    Fail,
    /// Take the first `number` values; the rest of the tuple is consumed too.
    TakeFirst,
}

/// What to do when the tuple holds fewer values than the read asked for. Spec section 6.
///
/// ```
/// use urscript_socket::ascii_float::MissingValues;
/// assert_eq!(MissingValues::default(), MissingValues::Count);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum MissingValues {
    /// `[count, values..., nan...]`: count says how many were read (default).
    #[default]
    Count,
    /// The read fails.
    Fail,
}

/// The choices spec section 6 leaves open for an ASCII float read, with the project's
/// defaults. The robot emulation's `Policy` carries one of these.
///
/// ```
/// use urscript_socket::ascii_float::{FloatReadPolicy, LeadingBytes};
/// let strict = FloatReadPolicy { leading_bytes: LeadingBytes::Fail, ..Default::default() };
/// assert!(strict.allow_exponent);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FloatReadPolicy {
    /// Bytes before `(`: skipped (default) or a failure.
    pub leading_bytes: LeadingBytes,
    /// Accept `1e-3` style exponents (default `true`).
    pub allow_exponent: bool,
    /// More values than asked: failure (default) or the first `number`.
    pub extra_values: ExtraValues,
    /// Fewer values than asked: counted (default) or a failure.
    pub missing_values: MissingValues,
}

impl Default for FloatReadPolicy {
    fn default() -> Self {
        FloatReadPolicy {
            leading_bytes: LeadingBytes::Skip,
            allow_exponent: true,
            extra_values: ExtraValues::Fail,
            missing_values: MissingValues::Count,
        }
    }
}

/// The result of a `socket_read_ascii_float(number)`: `[count, v1, ..., vnumber]`, the
/// slots past `count` being NaN. Holds its values inline (no allocation).
///
/// ```
/// use urscript_socket::ascii_float::FloatTuple;
/// let timeout = FloatTuple::failed(3);
/// assert_eq!(timeout.count(), 0);
/// assert!(timeout.values().iter().all(|v| v.is_nan()));
/// assert_eq!(timeout.values().len(), 3);
/// ```
#[derive(Debug, Clone, Copy)]
pub struct FloatTuple {
    count: u8,
    number: u8,
    values: [f64; MAX_VALUES],
}

impl FloatTuple {
    /// The failure/timeout sentinel `[0, nan, ...]` for a read of `number` values
    /// (clamped to 1..=30).
    ///
    /// ```
    /// # use urscript_socket::ascii_float::FloatTuple;
    /// assert_eq!(FloatTuple::failed(2).to_urscript_list().as_slice().len(), 3);
    /// ```
    pub fn failed(number: usize) -> Self {
        FloatTuple {
            count: 0,
            number: number.clamp(1, MAX_VALUES) as u8,
            values: [f64::NAN; MAX_VALUES],
        }
    }

    /// How many values were read: the URScript `result[0]`.
    ///
    /// ```
    /// # use urscript_socket::ascii_float::FloatTupleDecoder;
    /// let t = FloatTupleDecoder::new(6).unwrap().decode(b"(3)").unwrap().item().unwrap();
    /// assert_eq!(t.count(), 1);
    /// ```
    #[inline]
    pub fn count(&self) -> usize {
        usize::from(self.count)
    }

    /// The `number` value slots, NaN past `count`: URScript's `result[1..]`.
    ///
    /// ```
    /// # use urscript_socket::ascii_float::FloatTupleDecoder;
    /// let t = FloatTupleDecoder::new(2).unwrap().decode(b"(3)").unwrap().item().unwrap();
    /// assert_eq!(t.values()[0], 3.0);
    /// assert!(t.values()[1].is_nan());
    /// ```
    #[inline]
    pub fn values(&self) -> &[f64] {
        &self.values[..usize::from(self.number)]
    }

    /// Only the values actually read.
    ///
    /// ```
    /// # use urscript_socket::ascii_float::FloatTupleDecoder;
    /// let t = FloatTupleDecoder::new(6).unwrap().decode(b"(1,2)").unwrap().item().unwrap();
    /// assert_eq!(t.read(), [1.0, 2.0]);
    /// ```
    #[inline]
    pub fn read(&self) -> &[f64] {
        &self.values[..usize::from(self.count)]
    }

    /// The whole URScript list `[count, v1, ..., vnumber]` as floats.
    ///
    /// ```
    /// # use urscript_socket::ascii_float::FloatTupleDecoder;
    /// let t = FloatTupleDecoder::new(2).unwrap().decode(b"(1,2)").unwrap().item().unwrap();
    /// assert_eq!(t.to_urscript_list().as_slice(), [2.0, 1.0, 2.0]);
    /// ```
    pub fn to_urscript_list(&self) -> UrList {
        let mut out = [0.0; MAX_VALUES + 1];
        out[0] = f64::from(self.count);
        out[1..=self.values().len()].copy_from_slice(self.values());
        UrList {
            len: self.number + 1,
            values: out,
        }
    }
}

/// Equality is bitwise on the values, so two timeout sentinels (all NaN) are equal.
impl PartialEq for FloatTuple {
    fn eq(&self, other: &Self) -> bool {
        self.count == other.count
            && self.number == other.number
            && self
                .values()
                .iter()
                .zip(other.values())
                .all(|(a, b)| a.to_bits() == b.to_bits())
    }
}

/// A `[count, values...]` list of floats, as URScript sees a float read's result.
///
/// ```
/// # use urscript_socket::ascii_float::FloatTuple;
/// let l = FloatTuple::failed(1).to_urscript_list();
/// assert_eq!(l.as_slice()[0], 0.0);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UrList {
    len: u8,
    values: [f64; MAX_VALUES + 1],
}

impl UrList {
    /// The list's elements.
    ///
    /// ```
    /// # use urscript_socket::ascii_float::FloatTuple;
    /// assert_eq!(FloatTuple::failed(4).to_urscript_list().as_slice().len(), 5);
    /// ```
    pub fn as_slice(&self) -> &[f64] {
        &self.values[..usize::from(self.len)]
    }
}

/// Robot-side decoder of one ASCII float tuple per message, as
/// `socket_read_ascii_float(number)` reads it.
///
/// Incremental: the framer finds the tuple's `)` with a resumable scan (remembering where
/// it stopped, so a chunked stream is searched once), then [`FloatTuples`] parses the
/// complete tuple in one pass. Bound: a tuple longer than `max_len` bytes
/// ([`DEFAULT_MAX_TUPLE_LEN`]) is an error at the byte past the bound; the decoder then
/// discards through the next `)`.
///
/// Failures (a malformed number, too many values...) are errors whose
/// [`skip`](DecodeError::skip) consumes the whole tuple, as spec section 6 asks; the robot
/// emulation turns them into the `[0, nan...]` sentinel. At end of input a tuple cut off
/// before its `)` is [`Truncated`](ErrorKind::Truncated); leading bytes alone are dropped.
///
/// ```
/// use urscript_socket::ascii_float::FloatTupleDecoder;
/// let mut dec = FloatTupleDecoder::new(4).unwrap();
/// let t = dec.decode(b"( 1.414 , 3.14159, 1.616, 0.0 )").unwrap().item().unwrap();
/// assert_eq!(t.count(), 4);
/// assert_eq!(t.values(), [1.414, 3.14159, 1.616, 0.0]);
/// assert!(dec.decode_eof(b"(1,2").is_err());
/// ```
pub type FloatTupleDecoder = FrameDecoder<FloatTuples>;

/// The parse step of [`FloatTupleDecoder`]: the text between `(` and `)` of one tuple, for a
/// read of `number` values under a [`FloatReadPolicy`].
#[derive(Debug, Clone, Copy)]
pub struct FloatTuples {
    number: u8,
    policy: FloatReadPolicy,
}

impl Parse for FloatTuples {
    type Output<'a> = FloatTuple;
    const SHAPE: ShapeKind = ShapeKind::Bracketed;
    #[inline(always)]
    fn parse(&self, inner: &[u8]) -> Result<FloatTuple, (ErrorKind, usize)> {
        parse_tuple(inner, self.number, &self.policy)
    }
}

fn tuple_framer(policy: &FloatReadPolicy, max_len: usize) -> Framer {
    let noise = match policy.leading_bytes {
        LeadingBytes::Skip => Noise::Skip,
        LeadingBytes::Fail => Noise::Report("'(' starting a tuple"),
    };
    // The bound counts the parentheses: a tuple is at most `max_len` bytes.
    Framer::bracketed(b'(', b')', noise, None, max_len.max(2), true)
}

impl FloatTupleDecoder {
    /// A decoder for reads of `number` values (1..=30) with the default policy and bound.
    ///
    /// ```
    /// # use urscript_socket::ascii_float::FloatTupleDecoder;
    /// assert!(FloatTupleDecoder::new(6).is_ok());
    /// assert!(FloatTupleDecoder::new(31).is_err());
    /// ```
    pub fn new(number: usize) -> Result<Self, ArgumentError> {
        Self::with_policy(number, FloatReadPolicy::default())
    }

    /// A decoder with an explicit [`FloatReadPolicy`].
    ///
    /// ```
    /// # use urscript_socket::ascii_float::{FloatTupleDecoder, FloatReadPolicy};
    /// let p = FloatReadPolicy { allow_exponent: false, ..Default::default() };
    /// let mut d = FloatTupleDecoder::with_policy(1, p).unwrap();
    /// assert!(d.decode(b"(1e3)").is_err());
    /// ```
    pub fn with_policy(number: usize, policy: FloatReadPolicy) -> Result<Self, ArgumentError> {
        if !(1..=MAX_VALUES).contains(&number) {
            return Err(ArgumentError::NumberOutOfRange { number });
        }
        let parser = FloatTuples {
            number: number as u8,
            policy,
        };
        Ok(FrameDecoder::from_parts(
            tuple_framer(&policy, DEFAULT_MAX_TUPLE_LEN),
            parser,
        ))
    }

    /// Sets the bound on one tuple's length in bytes (at least 2, at most
    /// [`MAX_BOUND`](crate::MAX_BOUND)).
    ///
    /// ```
    /// # use urscript_socket::ascii_float::FloatTupleDecoder;
    /// let mut d = FloatTupleDecoder::new(1).unwrap().with_max_len(8);
    /// assert!(d.decode(b"(1.000000000)").is_err());
    /// ```
    pub fn with_max_len(mut self, max_len: usize) -> Self {
        self.framer = tuple_framer(&self.parser.policy, max_len);
        self
    }

    /// The bound on one tuple's length.
    ///
    /// ```
    /// # use urscript_socket::ascii_float::FloatTupleDecoder;
    /// assert_eq!(FloatTupleDecoder::new(1).unwrap().with_max_len(0).max_len(), 2);
    /// ```
    pub fn max_len(&self) -> usize {
        self.framer.bound()
    }

    /// The `number` this decoder reads.
    ///
    /// ```
    /// # use urscript_socket::ascii_float::FloatTupleDecoder;
    /// assert_eq!(FloatTupleDecoder::new(6).unwrap().number(), 6);
    /// ```
    pub fn number(&self) -> usize {
        usize::from(self.parser.number)
    }
}

/// Parses the text between a tuple's `(` and `)`. Errors carry the offset within `inner`.
///
/// One pass over the tuple: each number is parsed in place by the crate's one float
/// grammar ([`parse_float_prefix`]: Clinger's exact fast path for short plain decimals,
/// SWAR fraction digits, else fast-float), which also says where the number ends, so the
/// separator check starts right there.
#[inline]
fn parse_tuple(
    inner: &[u8],
    number: u8,
    policy: &FloatReadPolicy,
) -> Result<FloatTuple, (ErrorKind, usize)> {
    let number_usize = usize::from(number);
    let mut out = FloatTuple {
        count: 0,
        number,
        values: [f64::NAN; MAX_VALUES],
    };
    let end = inner.len();
    let mut i = 0;
    let mut count = 0usize;
    loop {
        while i < end && is_space(inner[i]) {
            i += 1;
        }
        let token = &inner[i..];
        if let [] | [b',', ..] = token {
            return Err((ErrorKind::Empty, i));
        }
        let (v, len) = parse_float_prefix(token, policy.allow_exponent)
            .map_err(|at| (ErrorKind::InvalidNumber, i + at))?;
        if count < number_usize {
            out.values[count] = v;
        } else if policy.extra_values == ExtraValues::Fail {
            return Err((
                ErrorKind::TooManyValues {
                    limit: number_usize,
                },
                i,
            ));
        }
        count += 1;
        i += len;
        while i < end && is_space(inner[i]) {
            i += 1;
        }
        if i == end {
            break;
        }
        if inner[i] != b',' {
            return Err((ErrorKind::InvalidNumber, i));
        }
        i += 1;
    }
    if count < number_usize && policy.missing_values == MissingValues::Fail {
        return Err((
            ErrorKind::TooFewValues {
                found: count,
                wanted: number_usize,
            },
            end,
        ));
    }
    out.count = count.min(number_usize) as u8;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{DecodeError, Status};
    use alloc::vec::Vec;

    fn read(number: usize, input: &[u8]) -> Result<FloatTuple, DecodeError> {
        let mut d = FloatTupleDecoder::new(number).unwrap();
        match d.decode(input)? {
            Status::Complete { item, .. } => Ok(item),
            Status::Partial { .. } => panic!("partial"),
        }
    }

    #[test]
    fn spaces_and_forms() {
        let t = read(3, b"(\t1 ,\r\n-2.5e1, +.5 )").unwrap();
        assert_eq!(t.read(), [1.0, -25.0, 0.5]);
    }

    #[test]
    fn errors_say_where() {
        let e = read(3, b"(1,,2)").unwrap_err();
        assert_eq!((e.kind(), e.offset(), e.skip()), (ErrorKind::Empty, 3, 6));
        let e = read(3, b"()").unwrap_err();
        assert_eq!(e.kind(), ErrorKind::Empty);
        let e = read(1, b"(1,2)").unwrap_err();
        assert_eq!(e.kind(), ErrorKind::TooManyValues { limit: 1 });
        assert_eq!(e.offset(), 3);
        let e = read(2, b"(1, nan)").unwrap_err();
        assert_eq!((e.kind(), e.offset()), (ErrorKind::InvalidNumber, 4));
    }

    #[test]
    fn take_first_and_fail_missing() {
        let p = FloatReadPolicy {
            extra_values: ExtraValues::TakeFirst,
            missing_values: MissingValues::Fail,
            ..Default::default()
        };
        let mut d = FloatTupleDecoder::with_policy(2, p).unwrap();
        let t = d.decode(b"(1,2,3)").unwrap().item().unwrap();
        assert_eq!((t.count(), t.values()), (2, &[1.0, 2.0][..]));
        let e = d.decode(b"(1)").unwrap_err();
        assert_eq!(
            e.kind(),
            ErrorKind::TooFewValues {
                found: 1,
                wanted: 2
            }
        );
    }

    #[test]
    fn leading_fail_reports_once_per_run() {
        let p = FloatReadPolicy {
            leading_bytes: LeadingBytes::Fail,
            ..Default::default()
        };
        let mut d = FloatTupleDecoder::with_policy(1, p).unwrap();
        let e = d.decode(b"ab").unwrap_err();
        assert_eq!((e.offset(), e.skip()), (0, 2));
        assert_eq!(d.decode(b"c(").unwrap(), Status::Partial { consumed: 1 });
        assert_eq!(d.decode(b"(5)").unwrap().item().unwrap().read(), [5.0]);
        assert_eq!(d.position(), 6);
    }

    #[test]
    fn bound_then_resync() {
        let mut d = FloatTupleDecoder::new(1).unwrap().with_max_len(4);
        let e = d.decode(b"(1234").unwrap_err();
        assert_eq!((e.kind(), e.offset()), (ErrorKind::TooLong { limit: 4 }, 4));
        let t = d.decode(b"5)(7)").unwrap();
        assert_eq!(t.consumed(), 5);
        assert_eq!(t.item().unwrap().read(), [7.0]);
        // Exactly at the bound is fine.
        let mut d = FloatTupleDecoder::new(1).unwrap().with_max_len(4);
        assert!(d.decode(b"(12)").unwrap().item().is_some());
    }

    #[test]
    fn encode_shapes() {
        let mut out = Vec::new();
        encode_float_tuple(&[-0.15, -0.5, 0.3, 0.0, -3.14, 0.0], false, &mut out).unwrap();
        assert_eq!(out, b"(-0.15,-0.5,0.3,0,-3.14,0)");
        assert_eq!(
            encode_float_tuple(&[], false, &mut out),
            Err(EncodeError::NoValues)
        );
        assert_eq!(
            encode_float_tuple(&[0.0; 31], false, &mut out),
            Err(EncodeError::TooManyValues { limit: 30 })
        );
        let mut big = Vec::new();
        let n = encode_float_tuple(&[-5e-324; 30], true, &mut big).unwrap();
        assert_eq!(n, MAX_ENCODED_LEN);
        let t = read(30, &big).unwrap();
        assert!(t
            .values()
            .iter()
            .all(|v| v.to_bits() == (-5e-324f64).to_bits()));
    }
}
