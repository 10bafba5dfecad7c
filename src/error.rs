//! The two error types of the core: [`DecodeError`] and [`EncodeError`].
//!
//! Both are small `Copy` values that say *what* was wrong and *where*: a decode error
//! carries the absolute byte offset in the stream at which the problem was found, and how
//! many bytes the caller must drop to get past it. Neither allocates.

use core::fmt;

/// What went wrong while decoding. See [`DecodeError`] for where.
///
/// ```
/// use urscript_socket::ErrorKind;
/// let kind = ErrorKind::TooLong { limit: 1024 };
/// assert_eq!(kind.to_string(), "message longer than the limit of 1024 bytes");
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum ErrorKind {
    /// A message grew past the decoder's bound without its terminator.
    TooLong {
        /// The bound, in bytes.
        limit: usize,
    },
    /// A byte that the grammar does not allow at this place.
    UnexpectedByte {
        /// The byte found.
        found: u8,
        /// What the grammar wanted there, in words.
        expected: &'static str,
    },
    /// A token that is not a number of the accepted form.
    InvalidNumber,
    /// An integer outside the 32-bit signed range.
    IntegerOutOfRange,
    /// More values than the read asked for (or than the 30-value limit).
    TooManyValues {
        /// The largest count accepted.
        limit: usize,
    },
    /// Fewer values than the read asked for, under a policy that makes it a failure.
    TooFewValues {
        /// Values found.
        found: usize,
        /// Values asked for.
        wanted: usize,
    },
    /// An empty field where a value was required (`(1,,2)`, `SET  5`).
    Empty,
    /// The message ended (end of input, flush or timeout) before it was complete.
    Truncated,
    /// A `GET` reply named another variable than the one asked for.
    NameMismatch,
}

impl fmt::Display for ErrorKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            ErrorKind::TooLong { limit } => {
                write!(f, "message longer than the limit of {limit} bytes")
            }
            ErrorKind::UnexpectedByte { found, expected } => {
                write!(f, "unexpected byte 0x{found:02X}")?;
                if found.is_ascii_graphic() {
                    write!(f, " ('{}')", found as char)?;
                }
                write!(f, ", expected {expected}")
            }
            ErrorKind::InvalidNumber => f.write_str("invalid number"),
            ErrorKind::IntegerOutOfRange => f.write_str("integer outside the int32 range"),
            ErrorKind::TooManyValues { limit } => write!(f, "more than {limit} values"),
            ErrorKind::TooFewValues { found, wanted } => {
                write!(f, "{found} values where {wanted} were asked for")
            }
            ErrorKind::Empty => f.write_str("empty field"),
            ErrorKind::Truncated => f.write_str("message cut off before its end"),
            ErrorKind::NameMismatch => f.write_str("reply names another variable"),
        }
    }
}

/// A decoding failure: what ([`kind`](Self::kind)), where ([`offset`](Self::offset)) and
/// how to get past it ([`skip`](Self::skip)).
///
/// Errors never cost a message that was already complete: a decoder returns every
/// complete message before it reports the error that follows them.
///
/// ```
/// use urscript_socket::{ascii_float::FloatTupleDecoder, ErrorKind};
/// let mut dec = FloatTupleDecoder::new(2).unwrap();
/// let err = dec.decode(b"(1,x)").unwrap_err();
/// assert_eq!(err.kind(), ErrorKind::InvalidNumber);
/// assert_eq!(err.offset(), 3); // the `x`
/// assert_eq!(err.skip(), 5);   // drop the whole tuple and go on
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DecodeError {
    kind: ErrorKind,
    offset: u64,
    skip: usize,
}

impl DecodeError {
    /// Builds an error (decoders use this; users rarely need to).
    ///
    /// ```
    /// use urscript_socket::{DecodeError, ErrorKind};
    /// let e = DecodeError::new(ErrorKind::Empty, 7, 8);
    /// assert_eq!((e.offset(), e.skip()), (7, 8));
    /// ```
    pub const fn new(kind: ErrorKind, offset: u64, skip: usize) -> Self {
        DecodeError { kind, offset, skip }
    }

    /// What was wrong.
    ///
    /// ```
    /// # use urscript_socket::{DecodeError, ErrorKind};
    /// assert_eq!(DecodeError::new(ErrorKind::Empty, 0, 1).kind(), ErrorKind::Empty);
    /// ```
    pub const fn kind(&self) -> ErrorKind {
        self.kind
    }

    /// Absolute offset, counted from the first byte the decoder ever saw, of the byte
    /// at which the problem was found.
    ///
    /// ```
    /// # use urscript_socket::{DecodeError, ErrorKind};
    /// assert_eq!(DecodeError::new(ErrorKind::Empty, 42, 1).offset(), 42);
    /// ```
    pub const fn offset(&self) -> u64 {
        self.offset
    }

    /// How many bytes at the front of the buffer passed to `decode` the caller must drop
    /// before calling again. The decoder has already accounted for them.
    ///
    /// ```
    /// # use urscript_socket::{DecodeError, ErrorKind};
    /// assert_eq!(DecodeError::new(ErrorKind::Empty, 0, 3).skip(), 3);
    /// ```
    pub const fn skip(&self) -> usize {
        self.skip
    }
}

impl fmt::Display for DecodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} at byte {}", self.kind, self.offset)
    }
}

impl core::error::Error for DecodeError {}

/// Why a value could not be encoded. Encoders never guess: anything that has no exact
/// conservative form is refused.
///
/// ```
/// use urscript_socket::{ascii_float::encode_float_tuple, EncodeError};
/// let mut out = Vec::new();
/// assert_eq!(
///     encode_float_tuple(&[1.0, f64::NAN], false, &mut out),
///     Err(EncodeError::NotFinite { index: 1 })
/// );
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum EncodeError {
    /// The output buffer is too small; `needed` more bytes were required at least.
    BufferFull {
        /// Bytes that did not fit.
        needed: usize,
    },
    /// A float that is NaN or infinite, which the robot's reader cannot take.
    NotFinite {
        /// Position of the value in the input.
        index: usize,
    },
    /// No values where at least one is required.
    NoValues,
    /// More values than the robot reads in one call.
    TooManyValues {
        /// The limit (30).
        limit: usize,
    },
    /// A variable name that is empty, longer than a robot's string (1023 bytes), or holds
    /// a space, a control byte or a non-ASCII byte.
    InvalidName,
    /// A byte that would break the framing (an STX/ETX inside a framed payload, a LF in a
    /// variable name...).
    ForbiddenByte {
        /// The byte.
        byte: u8,
        /// Its position in the input.
        index: usize,
    },
    /// A text form longer than the robot produces (1023 characters for `to_str`).
    TooLong {
        /// The limit.
        limit: usize,
    },
}

impl fmt::Display for EncodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            EncodeError::BufferFull { needed } => {
                write!(f, "output buffer full ({needed} more bytes needed)")
            }
            EncodeError::NotFinite { index } => {
                write!(
                    f,
                    "value {index} is NaN or infinite and has no plain decimal form"
                )
            }
            EncodeError::NoValues => f.write_str("at least one value is required"),
            EncodeError::TooManyValues { limit } => write!(f, "more than {limit} values"),
            EncodeError::InvalidName => f.write_str(
                "variable name must be 1 to 1023 printable ASCII characters without spaces",
            ),
            EncodeError::ForbiddenByte { byte, index } => {
                write!(
                    f,
                    "byte 0x{byte:02X} at index {index} would break the framing"
                )
            }
            EncodeError::TooLong { limit } => write!(f, "text longer than {limit} characters"),
        }
    }
}

impl core::error::Error for EncodeError {}

/// A misuse of the API, refused before any byte is read or written: the URScript
/// function would have been called with an argument the controller rejects.
///
/// ```
/// use urscript_socket::{ascii_float::FloatTupleDecoder, ArgumentError};
/// assert_eq!(
///     FloatTupleDecoder::new(0).unwrap_err(),
///     ArgumentError::NumberOutOfRange { number: 0 }
/// );
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum ArgumentError {
    /// `number` of a read outside 1..=30.
    NumberOutOfRange {
        /// The number given.
        number: usize,
    },
    /// A prefix, suffix or delimiter longer than the decoder stores inline.
    PatternTooLong {
        /// The limit in bytes.
        limit: usize,
    },
    /// An empty delimiter.
    EmptyPattern,
    /// A variable name that is empty or holds a space, control or non-ASCII byte.
    InvalidName,
}

impl fmt::Display for ArgumentError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            ArgumentError::NumberOutOfRange { number } => {
                write!(f, "number must be 1..=30, got {number}")
            }
            ArgumentError::PatternTooLong { limit } => {
                write!(f, "prefix, suffix or delimiter longer than {limit} bytes")
            }
            ArgumentError::EmptyPattern => f.write_str("delimiter must not be empty"),
            ArgumentError::InvalidName => f.write_str(
                "variable name must be 1 or more printable ASCII characters without spaces",
            ),
        }
    }
}

impl core::error::Error for ArgumentError {}
