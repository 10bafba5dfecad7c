//! Raw bytes: `socket_send_byte` on the robot, `socket_read_byte_list(number)` reading
//! what the server sends (values 0–255).
//!
//! Fixed-size like int32: a message is `number` bytes, counted, never scanned.

use crate::framer::{FrameDecoder, Framer, Parse, ShapeKind};
use crate::{ArgumentError, ByteSink, EncodeError, ErrorKind};

/// The most bytes one `socket_read_byte_list` call reads: the crate's one
/// `MAX_VALUES`, re-exported here.
pub use crate::MAX_VALUES;

/// Writes one byte: what `socket_send_byte(v)` sends.
///
/// ```
/// use urscript_socket::byte_list::encode_byte;
/// let mut out = Vec::new();
/// encode_byte(2, &mut out).unwrap();
/// assert_eq!(out, [2]);
/// ```
pub fn encode_byte<S: ByteSink + ?Sized>(value: u8, sink: &mut S) -> Result<usize, EncodeError> {
    sink.put(&[value])?;
    Ok(1)
}

/// Writes `values` unchanged: a message for `socket_read_byte_list(values.len())`.
///
/// ```
/// use urscript_socket::byte_list::encode_byte_list;
/// let mut out = Vec::new();
/// encode_byte_list(&[100, 200, 44], &mut out).unwrap();
/// assert_eq!(out, [0x64, 0xC8, 0x2C]);
/// ```
pub fn encode_byte_list<S: ByteSink + ?Sized>(
    values: &[u8],
    sink: &mut S,
) -> Result<usize, EncodeError> {
    sink.put(values)?;
    Ok(values.len())
}

/// Decoder of `number` raw bytes per message: the robot's
/// `socket_read_byte_list(number)`, or a server's byte stream with `number = 1`.
/// The item borrows the bytes. Bound: `number` ≤ 30 bytes. At end of input, leftover
/// bytes short of a message are [`Truncated`](crate::ErrorKind::Truncated).
///
/// ```
/// use urscript_socket::byte_list::ByteListDecoder;
/// let mut dec = ByteListDecoder::new(3).unwrap();
/// assert_eq!(dec.decode(b"ack").unwrap().item(), Some(&b"ack"[..]));
/// assert!(dec.decode(b"a").unwrap().item().is_none());
/// assert!(ByteListDecoder::new(2).unwrap().decode_eof(b"a").is_err());
/// ```
pub type ByteListDecoder = FrameDecoder<ByteList>;

/// The parse step of [`ByteListDecoder`]: the bytes as they are.
#[derive(Debug, Clone, Copy)]
pub struct ByteList {
    number: u8,
}

impl Parse for ByteList {
    type Output<'a> = &'a [u8];
    const SHAPE: ShapeKind = ShapeKind::Counted;
    #[inline(always)]
    fn parse<'a>(&self, bytes: &'a [u8]) -> Result<&'a [u8], (ErrorKind, usize)> {
        Ok(bytes)
    }
}

impl ByteListDecoder {
    /// A decoder of `number` (1..=30) bytes per message.
    ///
    /// ```
    /// # use urscript_socket::byte_list::ByteListDecoder;
    /// assert!(ByteListDecoder::new(31).is_err());
    /// ```
    pub fn new(number: usize) -> Result<Self, ArgumentError> {
        if !(1..=MAX_VALUES).contains(&number) {
            return Err(ArgumentError::NumberOutOfRange { number });
        }
        Ok(Self::of(number as u8))
    }

    const fn of(number: u8) -> Self {
        FrameDecoder::from_parts(Framer::counted(number as usize, 1), ByteList { number })
    }

    /// A decoder of one byte per message: a server reading `socket_send_byte`.
    ///
    /// ```
    /// # use urscript_socket::byte_list::ByteListDecoder;
    /// assert_eq!(ByteListDecoder::single().number(), 1);
    /// ```
    pub const fn single() -> Self {
        Self::of(1)
    }

    /// Bytes per message.
    ///
    /// ```
    /// # use urscript_socket::byte_list::ByteListDecoder;
    /// assert_eq!(ByteListDecoder::new(3).unwrap().number(), 3);
    /// ```
    pub fn number(&self) -> usize {
        usize::from(self.parser.number)
    }

    /// The bytes available when the read must end early (the "return what arrived"
    /// timeout policy), at most `number`.
    ///
    /// ```
    /// # use urscript_socket::byte_list::ByteListDecoder;
    /// let mut d = ByteListDecoder::new(3).unwrap();
    /// assert_eq!(d.take_partial(b"ab"), Some((&b"ab"[..], 2)));
    /// ```
    pub fn take_partial<'a>(&mut self, buf: &'a [u8]) -> Option<(&'a [u8], usize)> {
        self.framer.take_counted(buf)
    }
}
