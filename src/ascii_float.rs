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

use crate::number::{is_space, parse_short_decimal, write_plain_f64, MAX_PLAIN_F64_LEN};
use crate::{ArgumentError, DecodeError, Decoder, EncodeError, ErrorKind, Sink, Status};

/// The most values one `socket_read_ascii_float` call reads (and one tuple may carry).
pub const MAX_VALUES: usize = 30;

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
pub fn encode_float_tuple<S: Sink + ?Sized>(
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
/// Incremental: it finds the tuple's `)` with a resumable scan (remembering where it
/// stopped, so a chunked stream is searched once), then parses the complete tuple in one
/// pass. Bound: a tuple longer than `max_len` bytes ([`DEFAULT_MAX_TUPLE_LEN`]) is an
/// error at the byte past the bound; the decoder then discards through the next `)`.
///
/// Failures (a malformed number, too many values...) are errors whose
/// [`skip`](DecodeError::skip) consumes the whole tuple, as spec section 6 asks; the robot
/// emulation turns them into the `[0, nan...]` sentinel.
///
/// ```
/// use urscript_socket::ascii_float::FloatTupleDecoder;
/// let mut dec = FloatTupleDecoder::new(4).unwrap();
/// let t = dec.decode(b"( 1.414 , 3.14159, 1.616, 0.0 )").unwrap().item().unwrap();
/// assert_eq!(t.count(), 4);
/// assert_eq!(t.values(), [1.414, 3.14159, 1.616, 0.0]);
/// ```
#[derive(Debug, Clone)]
pub struct FloatTupleDecoder {
    number: u8,
    policy: FloatReadPolicy,
    max_len: usize,
    /// Bytes at the front of `buf` already known to hold no `)`. Only meaningful while
    /// `in_tuple` (the tuple's `(` is then `buf[0]`). If `decode` saw `(1,2` it holds 4
    /// and the next call looks for `)` from index 4 on.
    scanned: usize,
    /// A `(` was seen and moved to the front of the buffer; waiting for its `)`.
    in_tuple: bool,
    /// After a bound or leading-byte error: dropping bytes until the resync point (`)`
    /// after an over-long tuple, `(` after leading bytes), reporting nothing more.
    discarding: Discard,
    /// Absolute stream offset of `buf[0]`.
    pos: u64,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Discard {
    No,
    /// Through the next `)` (inclusive).
    ThroughClose,
    /// Up to the next `(` (exclusive).
    UntilOpen,
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
        Ok(FloatTupleDecoder {
            number: number as u8,
            policy,
            max_len: DEFAULT_MAX_TUPLE_LEN,
            scanned: 0,
            in_tuple: false,
            discarding: Discard::No,
            pos: 0,
        })
    }

    /// Sets the bound on one tuple's length in bytes (at least 2).
    ///
    /// ```
    /// # use urscript_socket::ascii_float::FloatTupleDecoder;
    /// let mut d = FloatTupleDecoder::new(1).unwrap().with_max_len(8);
    /// assert!(d.decode(b"(1.000000000)").is_err());
    /// ```
    pub fn with_max_len(mut self, max_len: usize) -> Self {
        self.max_len = max_len.max(2);
        self
    }

    /// The `number` this decoder reads.
    ///
    /// ```
    /// # use urscript_socket::ascii_float::FloatTupleDecoder;
    /// assert_eq!(FloatTupleDecoder::new(6).unwrap().number(), 6);
    /// ```
    pub fn number(&self) -> usize {
        usize::from(self.number)
    }

    /// Absolute stream offset of the next byte to decode.
    ///
    /// ```
    /// # use urscript_socket::ascii_float::FloatTupleDecoder;
    /// let mut d = FloatTupleDecoder::new(1).unwrap();
    /// d.decode(b"(1)").unwrap();
    /// assert_eq!(d.position(), 3);
    /// ```
    pub fn position(&self) -> u64 {
        self.pos
    }

    /// Looks for the next tuple in `buf`. See [`Status`] for the contract.
    ///
    /// ```
    /// # use urscript_socket::{ascii_float::FloatTupleDecoder, Status};
    /// let mut d = FloatTupleDecoder::new(2).unwrap();
    /// assert_eq!(d.decode(b"\n(1,").unwrap(), Status::Partial { consumed: 1 });
    /// let t = d.decode(b"(1,2)\n").unwrap();
    /// assert_eq!(t.consumed(), 5);
    /// ```
    #[inline]
    pub fn decode(&mut self, buf: &[u8]) -> Result<Status<FloatTuple>, DecodeError> {
        let mut lead = 0;
        match self.discarding {
            Discard::ThroughClose => match memchr::memchr(b')', buf) {
                Some(i) => {
                    self.discarding = Discard::No;
                    lead = i + 1;
                }
                None => return Ok(self.partial(buf.len())),
            },
            Discard::UntilOpen => match memchr::memchr(b'(', buf) {
                Some(i) => {
                    self.discarding = Discard::No;
                    lead = i;
                }
                None => return Ok(self.partial(buf.len())),
            },
            Discard::No => {}
        }
        let rest = &buf[lead..];
        if !self.in_tuple {
            match rest.first() {
                None => return Ok(self.partial(lead)),
                Some(b'(') => {}
                Some(&found) => match self.policy.leading_bytes {
                    LeadingBytes::Skip => match memchr::memchr(b'(', rest) {
                        Some(i) => lead += i,
                        None => return Ok(self.partial(buf.len())),
                    },
                    LeadingBytes::Fail => {
                        let at = self.pos + lead as u64;
                        let skip = match memchr::memchr(b'(', rest) {
                            Some(i) => lead + i,
                            None => {
                                self.discarding = Discard::UntilOpen;
                                buf.len()
                            }
                        };
                        return Err(self.error(
                            ErrorKind::UnexpectedByte {
                                found,
                                expected: "'(' starting a tuple",
                            },
                            at,
                            skip,
                        ));
                    }
                },
            }
            self.in_tuple = true;
            self.scanned = 1;
        }
        let tuple = &buf[lead..];
        // Resume the scan for `)` where the last call stopped; never past the bound.
        let limit = tuple.len().min(self.max_len);
        match memchr::memchr(b')', &tuple[self.scanned.min(limit)..limit]) {
            Some(i) => {
                let close = self.scanned + i;
                let frame = &tuple[..=close];
                let consumed = lead + close + 1;
                self.in_tuple = false;
                self.scanned = 0;
                let frame_pos = self.pos + lead as u64;
                match parse_tuple(frame, self.number, &self.policy) {
                    Ok(item) => {
                        self.pos += consumed as u64;
                        Ok(Status::Complete { item, consumed })
                    }
                    Err((kind, at)) => Err(self.error(kind, frame_pos + at as u64, consumed)),
                }
            }
            None if tuple.len() > self.max_len => {
                // Over the bound without `)`: report at the first byte past the bound,
                // drop what we have and discard through the next `)`.
                let at = self.pos + (lead + self.max_len) as u64;
                self.in_tuple = false;
                self.scanned = 0;
                self.discarding = Discard::ThroughClose;
                let skip = lead + self.max_len;
                Err(self.error(
                    ErrorKind::TooLong {
                        limit: self.max_len,
                    },
                    at,
                    skip,
                ))
            }
            None => {
                self.scanned = limit;
                if lead > 0 {
                    // Move the tuple to the front of the caller's buffer.
                    self.pos += lead as u64;
                }
                Ok(Status::Partial { consumed: lead })
            }
        }
    }

    /// At end of input: a tuple cut off before its `)` is a
    /// [`Truncated`](ErrorKind::Truncated) error; leading bytes alone are dropped.
    ///
    /// ```
    /// # use urscript_socket::ascii_float::FloatTupleDecoder;
    /// let mut d = FloatTupleDecoder::new(2).unwrap();
    /// assert!(d.decode_eof(b"(1,2").is_err());
    /// assert_eq!(d.decode_eof(b"(1,2)").unwrap().unwrap().0.count(), 2);
    /// ```
    pub fn decode_eof(&mut self, buf: &[u8]) -> Result<Option<(FloatTuple, usize)>, DecodeError> {
        let result = match self.decode(buf) {
            Ok(Status::Complete { item, consumed }) => Ok(Some((item, consumed))),
            Ok(Status::Partial { consumed }) if consumed == buf.len() => Ok(None),
            Ok(Status::Partial { consumed }) => {
                let at = self.pos;
                self.pos += (buf.len() - consumed) as u64;
                Err(DecodeError::new(ErrorKind::Truncated, at, buf.len()))
            }
            Err(e) => Err(e),
        };
        self.reset_state();
        result
    }

    fn partial(&mut self, consumed: usize) -> Status<FloatTuple> {
        self.pos += consumed as u64;
        Status::Partial { consumed }
    }

    fn error(&mut self, kind: ErrorKind, at: u64, skip: usize) -> DecodeError {
        self.pos += skip as u64;
        DecodeError::new(kind, at, skip)
    }

    fn reset_state(&mut self) {
        self.in_tuple = false;
        self.scanned = 0;
        self.discarding = Discard::No;
    }
}

impl Decoder for FloatTupleDecoder {
    type Item<'buf> = FloatTuple;
    #[inline]
    fn decode(&mut self, buf: &[u8]) -> Result<Status<FloatTuple>, DecodeError> {
        FloatTupleDecoder::decode(self, buf)
    }
    fn decode_eof(&mut self, buf: &[u8]) -> Result<Option<(FloatTuple, usize)>, DecodeError> {
        FloatTupleDecoder::decode_eof(self, buf)
    }
    fn position(&self) -> u64 {
        self.pos
    }
}

/// Parses a complete tuple `frame` = `( ... )`. Errors carry the offset within `frame`.
///
/// One pass over the tuple: each number is parsed in place (Clinger's exact fast path for
/// short plain decimals, else fast-float's `parse_partial`), which also says where the
/// number ends, so the separator check starts right there: one pass over the tuple. fast-float accepts exactly our number
/// grammar plus `inf`/`nan`, which the first-byte check excludes; the exponent policy is
/// checked on the (short) span fast-float consumed.
#[inline]
fn parse_tuple(
    frame: &[u8],
    number: u8,
    policy: &FloatReadPolicy,
) -> Result<FloatTuple, (ErrorKind, usize)> {
    let number_usize = usize::from(number);
    let mut out = FloatTuple {
        count: 0,
        number,
        values: [f64::NAN; MAX_VALUES],
    };
    let end = frame.len() - 1; // index of `)`
    let inner = &frame[..end];
    let mut i = 1;
    let mut count = 0usize;
    loop {
        while i < end && is_space(inner[i]) {
            i += 1;
        }
        let token = &inner[i..];
        let first_digit = match token {
            [] | [b',', ..] => return Err((ErrorKind::Empty, i)),
            [b'+' | b'-', rest @ ..] => rest.first(),
            [first, ..] => Some(first),
        };
        if !matches!(first_digit, Some(b'0'..=b'9' | b'.')) {
            return Err((ErrorKind::InvalidNumber, i));
        }
        // Plain decimals of up to 15 digits (every pose value) take the exact fast path;
        // anything else goes to fast-float.
        let (v, len) = match parse_short_decimal(token) {
            Some(found) => found,
            None => fast_float2::parse_partial::<f64, _>(token)
                .map_err(|_| (ErrorKind::InvalidNumber, i))?,
        };
        if !policy.allow_exponent {
            if let Some(e) = token[..len].iter().position(|&b| b | 0x20 == b'e') {
                return Err((ErrorKind::InvalidNumber, i + e));
            }
        }
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
