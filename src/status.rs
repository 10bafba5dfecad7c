//! The result of one decoding step, and the [`Decode`] trait every format implements.

use crate::DecodeError;

/// What one call to a decoder's `decode` found, in the manner of `httparse::Status`, plus
/// the bytes the caller must drop in either case and, for a message, where it sits.
///
/// The caller keeps the unconsumed bytes in its own buffer. After
/// `Complete { consumed, .. }` or `Partial { consumed }` it drops `consumed` bytes from the
/// front, appends whatever arrives next, and calls `decode` again with the whole
/// unconsumed rest. The decoder remembers how far it has already looked, so a search never
/// goes back over bytes it already searched (at most a delimiter's length minus one):
/// chunked input costs what whole input costs, linear in its length.
///
/// ```
/// use urscript_socket::{line::LineDecoder, Status};
/// let mut lines = LineDecoder::new();
/// assert_eq!(lines.decode(b"hel").unwrap(), Status::Partial { consumed: 0 });
/// assert_eq!(
///     lines.decode(b"hello\nwor").unwrap(),
///     Status::Complete { item: &b"hello"[..], consumed: 6, at: 0 }
/// );
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Status<T> {
    /// A message is complete. `item` borrows the input where the format allows it.
    Complete {
        /// The decoded message.
        item: T,
        /// Bytes of the input that the message (and anything skipped before it) used.
        consumed: usize,
        /// Absolute stream offset of the first byte of the message's content: the line's
        /// first byte, the first byte after `(`, STX or the prefix, the first int32 byte.
        /// A parse error inside the content is `at` + its index there.
        at: u64,
    },
    /// More input is needed. `consumed` bytes (noise the format skips, or the rest of an
    /// over-long message being discarded) can already be dropped.
    Partial {
        /// Bytes the caller may drop now.
        consumed: usize,
    },
}

impl<T> Status<T> {
    /// The bytes to drop from the front of the buffer, in both cases.
    ///
    /// ```
    /// use urscript_socket::Status;
    /// assert_eq!(Status::<()>::Partial { consumed: 3 }.consumed(), 3);
    /// ```
    #[inline]
    pub fn consumed(&self) -> usize {
        match *self {
            Status::Complete { consumed, .. } | Status::Partial { consumed } => consumed,
        }
    }

    /// Where the complete message's content starts in the stream (`None` if partial).
    ///
    /// ```
    /// use urscript_socket::{line::LineDecoder, Status};
    /// let mut lines = LineDecoder::new();
    /// assert_eq!(lines.decode(b"ab\ncd\n").unwrap().at(), Some(0));
    /// assert_eq!(lines.decode(b"cd\n").unwrap().at(), Some(3));
    /// assert_eq!(Status::<()>::Partial { consumed: 0 }.at(), None);
    /// ```
    #[inline]
    pub fn at(&self) -> Option<u64> {
        match *self {
            Status::Complete { at, .. } => Some(at),
            Status::Partial { .. } => None,
        }
    }

    /// The same status with its item converted (`consumed` and `at` unchanged).
    ///
    /// ```
    /// use urscript_socket::Status;
    /// let s = Status::Complete { item: 5, consumed: 1, at: 9 };
    /// assert_eq!(s.map(|v| v * 2), Status::Complete { item: 10, consumed: 1, at: 9 });
    /// ```
    #[inline]
    pub fn map<U>(self, f: impl FnOnce(T) -> U) -> Status<U> {
        match self {
            Status::Complete { item, consumed, at } => Status::Complete {
                item: f(item),
                consumed,
                at,
            },
            Status::Partial { consumed } => Status::Partial { consumed },
        }
    }

    /// The item, if complete.
    ///
    /// ```
    /// use urscript_socket::Status;
    /// assert_eq!(Status::Complete { item: 5, consumed: 1, at: 0 }.item(), Some(5));
    /// ```
    #[inline]
    pub fn item(self) -> Option<T> {
        match self {
            Status::Complete { item, .. } => Some(item),
            Status::Partial { .. } => None,
        }
    }
}

/// An incremental decoder over a caller-owned buffer: the one interface the adapters,
/// the robot emulation and the CLI drive. Every format's decoder implements it.
///
/// Contract: `buf` is always the unconsumed bytes, oldest first. After any return the
/// caller drops the bytes it was told to drop (`Status::consumed`, or
/// [`DecodeError::skip`]) and calls again with what is left plus what arrived since.
/// A decoder never panics, never searches the same bytes again on a later call, and holds
/// at most a few words of state; the largest message it will buffer is its documented bound.
///
/// ```
/// use urscript_socket::{Decode, RecvBuffer, int32::Int32Decoder};
/// let mut buf = RecvBuffer::<[u8; 64]>::new();
/// let mut ints = Int32Decoder::new(1).unwrap();
/// buf.extend(&[0, 0, 0]);
/// assert!(buf.decode(&mut ints).unwrap().is_none());
/// buf.extend(&[100]);
/// assert_eq!(buf.decode(&mut ints).unwrap().unwrap().get(0), Some(100));
/// ```
pub trait Decode {
    /// What a complete message decodes to; borrows the buffer where it can.
    type Item<'buf>;

    /// Looks at `buf` (the unconsumed bytes) for the next message.
    fn decode<'buf>(&mut self, buf: &'buf [u8]) -> Result<Status<Self::Item<'buf>>, DecodeError>;

    /// The input ended (peer closed, end of file): returns the next complete message (call
    /// again for more), a last message if the format can end without a terminator,
    /// `Ok(None)` when nothing is left, and an error of kind
    /// [`Truncated`](crate::ErrorKind::Truncated) if a message was cut off. Idempotent:
    /// after an error the caller drops its `skip` and the next call on what remains returns
    /// `Ok(None)`; after `Ok(None)` the decoder is reset and [`position`](Self::position)
    /// accounts for every byte it dropped.
    fn decode_eof<'buf>(
        &mut self,
        buf: &'buf [u8],
    ) -> Result<Option<(Self::Item<'buf>, usize)>, DecodeError>;

    /// Bytes consumed so far: the absolute stream offset of `buf[0]` on the next call.
    fn position(&self) -> u64;

    /// The caller's buffer is full (`buf` is all it holds) and `decode` still needs more:
    /// the buffer is smaller than this decoder's bound, so the message can never complete
    /// in it. Returns the error to report once (a [`TooLong`](crate::ErrorKind::TooLong)
    /// whose limit is the buffer's size) after which the decoder discards the rest of that
    /// message and resyncs on the next; the caller drops [`DecodeError::skip`] bytes.
    /// `None` (the default) if the decoder has no way out: the caller must then report a
    /// full buffer. [`RecvBuffer::decode`](crate::RecvBuffer::decode) calls this.
    fn overflow(&mut self, buf: &[u8]) -> Option<DecodeError> {
        let _ = buf;
        None
    }
}
