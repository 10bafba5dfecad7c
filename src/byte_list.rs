//! Raw bytes: `socket_send_byte` on the robot, `socket_read_byte_list(number)` reading
//! what the server sends (values 0–255).
//!
//! Fixed-size like int32: a message is `number` bytes, counted, never scanned.

use crate::{ArgumentError, DecodeError, Decoder, EncodeError, Sink, Status};

/// The most bytes one `socket_read_byte_list` call reads.
pub const MAX_VALUES: usize = 30;

/// Writes one byte: what `socket_send_byte(v)` sends.
///
/// ```
/// use urscript_socket::byte_list::encode_byte;
/// let mut out = Vec::new();
/// encode_byte(2, &mut out).unwrap();
/// assert_eq!(out, [2]);
/// ```
pub fn encode_byte<S: Sink + ?Sized>(value: u8, sink: &mut S) -> Result<usize, EncodeError> {
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
pub fn encode_byte_list<S: Sink + ?Sized>(
    values: &[u8],
    sink: &mut S,
) -> Result<usize, EncodeError> {
    sink.put(values)?;
    Ok(values.len())
}

/// Decoder of `number` raw bytes per message: the robot's
/// `socket_read_byte_list(number)`, or a server's byte stream with `number = 1`.
/// The item borrows the bytes. Bound: `number` ≤ 30 bytes.
///
/// ```
/// use urscript_socket::byte_list::ByteListDecoder;
/// let mut dec = ByteListDecoder::new(3).unwrap();
/// assert_eq!(dec.decode(b"ack").unwrap().item(), Some(&b"ack"[..]));
/// ```
#[derive(Debug, Clone)]
pub struct ByteListDecoder {
    number: u8,
    pos: u64,
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
        Ok(ByteListDecoder {
            number: number as u8,
            pos: 0,
        })
    }

    /// A decoder of one byte per message: a server reading `socket_send_byte`.
    ///
    /// ```
    /// # use urscript_socket::byte_list::ByteListDecoder;
    /// assert_eq!(ByteListDecoder::single().number(), 1);
    /// ```
    pub const fn single() -> Self {
        ByteListDecoder { number: 1, pos: 0 }
    }

    /// Bytes per message.
    ///
    /// ```
    /// # use urscript_socket::byte_list::ByteListDecoder;
    /// assert_eq!(ByteListDecoder::new(3).unwrap().number(), 3);
    /// ```
    pub fn number(&self) -> usize {
        usize::from(self.number)
    }

    /// Absolute stream offset of the next byte to decode.
    ///
    /// ```
    /// # use urscript_socket::byte_list::ByteListDecoder;
    /// let mut d = ByteListDecoder::new(1).unwrap();
    /// d.decode(b"a").unwrap();
    /// assert_eq!(d.position(), 1);
    /// ```
    pub fn position(&self) -> u64 {
        self.pos
    }

    /// The next `number` bytes, once they are there.
    ///
    /// ```
    /// # use urscript_socket::byte_list::ByteListDecoder;
    /// let mut d = ByteListDecoder::new(2).unwrap();
    /// assert!(d.decode(b"a").unwrap().item().is_none());
    /// ```
    #[inline]
    pub fn decode<'a>(&mut self, buf: &'a [u8]) -> Result<Status<&'a [u8]>, DecodeError> {
        let need = usize::from(self.number);
        if buf.len() < need {
            return Ok(Status::Partial { consumed: 0 });
        }
        self.pos += need as u64;
        Ok(Status::Complete {
            item: &buf[..need],
            consumed: need,
        })
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
        let n = buf.len().min(usize::from(self.number));
        if n == 0 {
            return None;
        }
        self.pos += n as u64;
        Some((&buf[..n], n))
    }

    /// At end of input: leftover bytes short of a message are
    /// [`Truncated`](crate::ErrorKind::Truncated).
    ///
    /// ```
    /// # use urscript_socket::byte_list::ByteListDecoder;
    /// assert!(ByteListDecoder::new(2).unwrap().decode_eof(b"a").is_err());
    /// ```
    pub fn decode_eof<'a>(
        &mut self,
        buf: &'a [u8],
    ) -> Result<Option<(&'a [u8], usize)>, DecodeError> {
        match self.decode(buf)? {
            Status::Complete { item, consumed } => Ok(Some((item, consumed))),
            Status::Partial { .. } if buf.is_empty() => Ok(None),
            Status::Partial { .. } => crate::status::truncated(&mut self.pos, buf),
        }
    }
}

impl Decoder for ByteListDecoder {
    type Item<'buf> = &'buf [u8];
    #[inline]
    fn decode<'buf>(&mut self, buf: &'buf [u8]) -> Result<Status<&'buf [u8]>, DecodeError> {
        ByteListDecoder::decode(self, buf)
    }
    fn decode_eof<'buf>(
        &mut self,
        buf: &'buf [u8],
    ) -> Result<Option<(&'buf [u8], usize)>, DecodeError> {
        ByteListDecoder::decode_eof(self, buf)
    }
    fn position(&self) -> u64 {
        self.pos
    }
}
