//! One value per message: the robot's `socket_send_int` and `socket_send_byte` streams as
//! plain `i32` / `u8` items, the same type in every adapter.

use crate::byte_list::ByteListDecoder;
use crate::int32::Int32Decoder;
use crate::{Decode, DecodeError, Status};

/// A server reading the robot's `socket_send_int(v)`: one big-endian int32 per message,
/// decoded to an `i32`. (For `n` values per message use
/// [`Int32Decoder::new(n)`](crate::int32::Int32Decoder::new).)
///
/// ```
/// use urscript_socket::{adapters::Int32Stream, Decode};
/// let mut ints = Int32Stream::new();
/// let status = ints.decode(&[0xFF, 0xFF, 0xFF, 0xFE, 0]).unwrap();
/// assert_eq!(status.item(), Some(-2));
/// ```
#[derive(Debug, Clone)]
pub struct Int32Stream {
    inner: Int32Decoder,
}

impl Int32Stream {
    /// A decoder of single int32 values.
    ///
    /// ```
    /// # use urscript_socket::adapters::Int32Stream;
    /// let d = Int32Stream::new();
    /// ```
    pub const fn new() -> Self {
        Int32Stream {
            inner: Int32Decoder::single(),
        }
    }
}

impl Default for Int32Stream {
    fn default() -> Self {
        Self::new()
    }
}

impl Decode for Int32Stream {
    type Item<'buf> = i32;
    #[inline]
    fn decode(&mut self, buf: &[u8]) -> Result<Status<i32>, DecodeError> {
        Ok(self
            .inner
            .decode(buf)?
            .map(|v| v.get(0).unwrap_or_default()))
    }
    fn decode_eof(&mut self, buf: &[u8]) -> Result<Option<(i32, usize)>, DecodeError> {
        Ok(self
            .inner
            .decode_eof(buf)?
            .map(|(v, n)| (v.get(0).unwrap_or_default(), n)))
    }
    fn position(&self) -> u64 {
        self.inner.position()
    }
}

/// A server reading the robot's `socket_send_byte(v)`: one `u8` per message.
///
/// ```
/// use urscript_socket::{adapters::ByteStream, Decode};
/// let mut bytes = ByteStream::new();
/// assert_eq!(bytes.decode(&[2, 3]).unwrap().item(), Some(2));
/// ```
#[derive(Debug, Clone)]
pub struct ByteStream {
    inner: ByteListDecoder,
}

impl ByteStream {
    /// A decoder of single bytes.
    ///
    /// ```
    /// # use urscript_socket::adapters::ByteStream;
    /// let d = ByteStream::new();
    /// ```
    pub const fn new() -> Self {
        ByteStream {
            inner: ByteListDecoder::single(),
        }
    }
}

impl Default for ByteStream {
    fn default() -> Self {
        Self::new()
    }
}

impl Decode for ByteStream {
    type Item<'buf> = u8;
    #[inline]
    fn decode(&mut self, buf: &[u8]) -> Result<Status<u8>, DecodeError> {
        Ok(self
            .inner
            .decode(buf)?
            .map(|b| b.first().copied().unwrap_or_default()))
    }
    fn decode_eof(&mut self, buf: &[u8]) -> Result<Option<(u8, usize)>, DecodeError> {
        Ok(self
            .inner
            .decode_eof(buf)?
            .map(|(b, n)| (b.first().copied().unwrap_or_default(), n)))
    }
    fn position(&self) -> u64 {
        self.inner.position()
    }
}
