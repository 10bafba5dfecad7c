//! [`RecvBuffer`]: a bounded receive buffer that drives any [`Decode`].
//!
//! Transports deliver bytes in arbitrary pieces (smoltcp even hands one segment over as
//! two slices when its ring buffer wraps). `RecvBuffer` keeps the unconsumed bytes in a
//! fixed storage chosen by the caller, feeds them to a decoder and drops what the decoder
//! used. It never grows: its capacity is the storage's length.

use crate::{Decode, DecodeError, Status};

/// A fixed-capacity receive buffer. `S` is the storage: `[u8; N]` for no-allocation use,
/// or `Vec<u8>`/`Box<[u8]>` (feature `alloc`) sized once.
///
/// Bytes are appended at the end ([`extend`](Self::extend) or
/// [`spare`](Self::spare) + [`commit`](Self::commit)) and decoded from the front
/// ([`decode`](Self::decode)). Consumed space is reclaimed by moving the unconsumed rest
/// to the front only when the end of the storage is reached, so each byte is moved at
/// most once per buffer's worth of traffic.
///
/// ```
/// use urscript_socket::{RecvBuffer, line::LineDecoder};
/// let mut buf = RecvBuffer::<[u8; 32]>::new();
/// let mut lines = LineDecoder::new();
/// for chunk in [&b"hel"[..], b"lo\nwor", b"ld\n"] {
///     assert_eq!(buf.extend(chunk), chunk.len());
///     while let Some(line) = buf.decode(&mut lines).unwrap() {
///         println!("{}", String::from_utf8_lossy(line));
///     }
/// }
/// assert!(buf.is_empty());
/// ```
#[derive(Debug, Clone)]
pub struct RecvBuffer<S> {
    storage: S,
    /// Index of the first unconsumed byte.
    start: usize,
    /// Index one past the last received byte.
    end: usize,
}

impl<const N: usize> RecvBuffer<[u8; N]> {
    /// An empty buffer of `N` bytes, usable in `const`/`static` contexts.
    ///
    /// ```
    /// # use urscript_socket::RecvBuffer;
    /// let buf = RecvBuffer::<[u8; 128]>::new();
    /// assert_eq!(buf.capacity(), 128);
    /// ```
    pub const fn new() -> Self {
        RecvBuffer {
            storage: [0; N],
            start: 0,
            end: 0,
        }
    }
}

impl<const N: usize> Default for RecvBuffer<[u8; N]> {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(feature = "alloc")]
impl RecvBuffer<alloc::boxed::Box<[u8]>> {
    /// An empty heap buffer of `capacity` bytes, allocated once.
    ///
    /// ```
    /// # use urscript_socket::RecvBuffer;
    /// let buf = RecvBuffer::with_capacity(4096);
    /// assert_eq!(buf.capacity(), 4096);
    /// ```
    pub fn with_capacity(capacity: usize) -> Self {
        RecvBuffer::from_storage(alloc::vec![0u8; capacity].into_boxed_slice())
    }
}

impl<S: AsRef<[u8]> + AsMut<[u8]>> RecvBuffer<S> {
    /// A buffer over caller-provided storage (any contents are ignored).
    ///
    /// ```
    /// # use urscript_socket::RecvBuffer;
    /// let mut storage = [0u8; 16];
    /// let buf = RecvBuffer::from_storage(&mut storage[..]);
    /// assert_eq!(buf.capacity(), 16);
    /// ```
    pub fn from_storage(storage: S) -> Self {
        RecvBuffer {
            storage,
            start: 0,
            end: 0,
        }
    }

    /// The bound: the most bytes the buffer holds.
    ///
    /// ```
    /// # use urscript_socket::RecvBuffer;
    /// assert_eq!(RecvBuffer::<[u8; 8]>::new().capacity(), 8);
    /// ```
    pub fn capacity(&self) -> usize {
        self.storage.as_ref().len()
    }

    /// Unconsumed bytes held.
    ///
    /// ```
    /// # use urscript_socket::RecvBuffer;
    /// let mut buf = RecvBuffer::<[u8; 8]>::new();
    /// buf.extend(b"abc");
    /// assert_eq!(buf.len(), 3);
    /// ```
    pub fn len(&self) -> usize {
        self.end - self.start
    }

    /// True if no unconsumed byte is held.
    ///
    /// ```
    /// # use urscript_socket::RecvBuffer;
    /// assert!(RecvBuffer::<[u8; 8]>::new().is_empty());
    /// ```
    pub fn is_empty(&self) -> bool {
        self.start == self.end
    }

    /// True if no further byte fits.
    ///
    /// ```
    /// # use urscript_socket::RecvBuffer;
    /// let mut buf = RecvBuffer::<[u8; 2]>::new();
    /// buf.extend(b"ab");
    /// assert!(buf.is_full());
    /// ```
    pub fn is_full(&self) -> bool {
        self.len() == self.capacity()
    }

    /// The unconsumed bytes, oldest first.
    ///
    /// ```
    /// # use urscript_socket::RecvBuffer;
    /// let mut buf = RecvBuffer::<[u8; 8]>::new();
    /// buf.extend(b"abc");
    /// buf.consume(1);
    /// assert_eq!(buf.data(), b"bc");
    /// ```
    #[inline]
    pub fn data(&self) -> &[u8] {
        &self.storage.as_ref()[self.start..self.end]
    }

    /// Writable free space after the data, for a transport to read into; follow with
    /// [`commit`](Self::commit). Empty when the buffer is full.
    ///
    /// ```
    /// # use urscript_socket::RecvBuffer;
    /// let mut buf = RecvBuffer::<[u8; 8]>::new();
    /// let space = buf.spare();
    /// space[..2].copy_from_slice(b"hi");
    /// buf.commit(2);
    /// assert_eq!(buf.data(), b"hi");
    /// ```
    #[inline]
    pub fn spare(&mut self) -> &mut [u8] {
        if self.end == self.capacity() && self.start > 0 {
            // Reclaim consumed space: one move of the unconsumed rest.
            self.storage.as_mut().copy_within(self.start..self.end, 0);
            self.end -= self.start;
            self.start = 0;
        }
        let end = self.end;
        &mut self.storage.as_mut()[end..]
    }

    /// Marks `n` bytes of [`spare`](Self::spare) as received. `n` is clamped to the free
    /// space, so a wrong count can never make the buffer read outside its storage.
    ///
    /// ```
    /// # use urscript_socket::RecvBuffer;
    /// let mut buf = RecvBuffer::<[u8; 4]>::new();
    /// buf.spare()[0] = b'x';
    /// buf.commit(1);
    /// assert_eq!(buf.data(), b"x");
    /// ```
    #[inline]
    pub fn commit(&mut self, n: usize) {
        self.end = (self.end + n).min(self.capacity());
    }

    /// Copies as much of `chunk` as fits and returns how much that was. A return smaller
    /// than `chunk.len()` means the buffer is full: decode (or fail) before feeding more.
    ///
    /// ```
    /// # use urscript_socket::RecvBuffer;
    /// let mut buf = RecvBuffer::<[u8; 4]>::new();
    /// assert_eq!(buf.extend(b"abcdef"), 4);
    /// ```
    #[inline]
    pub fn extend(&mut self, chunk: &[u8]) -> usize {
        let space = self.spare();
        let n = space.len().min(chunk.len());
        space[..n].copy_from_slice(&chunk[..n]);
        self.commit(n);
        n
    }

    /// Drops `n` bytes from the front (clamped to the data held).
    ///
    /// ```
    /// # use urscript_socket::RecvBuffer;
    /// let mut buf = RecvBuffer::<[u8; 4]>::new();
    /// buf.extend(b"abcd");
    /// buf.consume(3);
    /// assert_eq!(buf.data(), b"d");
    /// ```
    #[inline]
    pub fn consume(&mut self, n: usize) {
        advance(&mut self.start, &mut self.end, n);
    }

    /// Drops everything held.
    ///
    /// ```
    /// # use urscript_socket::RecvBuffer;
    /// let mut buf = RecvBuffer::<[u8; 4]>::new();
    /// buf.extend(b"ab");
    /// buf.clear();
    /// assert!(buf.is_empty());
    /// ```
    pub fn clear(&mut self) {
        self.start = 0;
        self.end = 0;
    }

    /// Runs `decoder` on the held bytes and drops what it used. `Ok(None)` means more
    /// input is needed; on error the bad bytes are already dropped, so the next call goes
    /// on with the message after them.
    ///
    /// A buffer smaller than the decoder's bound: when the buffer is full and the message
    /// in it still incomplete, it can never complete here. The decoder is then asked for a
    /// way out ([`Decode::overflow`]): the message is reported once as
    /// [`TooLong`](crate::ErrorKind::TooLong) with the buffer's capacity as its limit, its
    /// bytes are dropped, the rest of it is discarded as it arrives, and decoding resyncs
    /// on the next message. Every decoder of the crate has that way out except
    /// [`ReadStringDecoder`](crate::string::ReadStringDecoder), which by the controller's
    /// rule consumes nothing until complete: a full buffer stays full (`Ok(None)`). A buffer
    /// must also hold a whole delimiter (any of 64 bytes or more does) for a
    /// [`DelimitedDecoder`](crate::string::DelimitedDecoder) to find one.
    ///
    /// ```
    /// # use urscript_socket::{RecvBuffer, byte_list::ByteListDecoder, line::LineDecoder, ErrorKind};
    /// let mut buf = RecvBuffer::<[u8; 8]>::new();
    /// let mut two = ByteListDecoder::new(2).unwrap();
    /// buf.extend(b"abc");
    /// assert_eq!(buf.decode(&mut two).unwrap(), Some(&b"ab"[..]));
    /// assert_eq!(buf.decode(&mut two).unwrap(), None);
    ///
    /// // 8 bytes of buffer, lines of up to 4096: a long line is reported, then skipped.
    /// let mut buf = RecvBuffer::<[u8; 8]>::new();
    /// let mut lines = LineDecoder::new();
    /// buf.extend(b"too long");
    /// let e = buf.decode(&mut lines).unwrap_err();
    /// assert_eq!(e.kind(), ErrorKind::TooLong { limit: 8 });
    /// buf.extend(b"ine\nok\n");
    /// assert_eq!(buf.decode(&mut lines).unwrap(), Some(&b"ok"[..]));
    /// ```
    #[inline]
    pub fn decode<D: Decode>(
        &mut self,
        decoder: &mut D,
    ) -> Result<Option<D::Item<'_>>, DecodeError> {
        self.decode_with(decoder, true)
    }

    /// [`decode`](Self::decode) without the way out: a full buffer whose message cannot
    /// complete stays as it is (`Ok(None)`, [`is_full`](Self::is_full)), and the caller
    /// decides what happens (the robot emulation lets the read run to its deadline, as the
    /// controller would).
    ///
    /// ```
    /// # use urscript_socket::{RecvBuffer, line::LineDecoder};
    /// let mut buf = RecvBuffer::<[u8; 4]>::new();
    /// buf.extend(b"long");
    /// assert_eq!(buf.decode_without_overflow(&mut LineDecoder::new()).unwrap(), None);
    /// assert!(buf.is_full());
    /// ```
    #[inline]
    pub fn decode_without_overflow<D: Decode>(
        &mut self,
        decoder: &mut D,
    ) -> Result<Option<D::Item<'_>>, DecodeError> {
        self.decode_with(decoder, false)
    }

    #[inline(always)]
    fn decode_with<D: Decode>(
        &mut self,
        decoder: &mut D,
        overflow: bool,
    ) -> Result<Option<D::Item<'_>>, DecodeError> {
        let data = &self.storage.as_ref()[self.start..self.end];
        match decoder.decode(data) {
            Ok(Status::Complete { item, consumed, .. }) => {
                // The item borrows the storage, not the indices, so they can move now.
                advance(&mut self.start, &mut self.end, consumed);
                Ok(Some(item))
            }
            Ok(Status::Partial { consumed }) => {
                advance(&mut self.start, &mut self.end, consumed);
                if overflow
                    && self.end - self.start == data.len()
                    && data.len() == self.storage.as_ref().len()
                {
                    // Full, and no progress: the message cannot complete in this buffer.
                    if let Some(e) = decoder.overflow(data) {
                        advance(&mut self.start, &mut self.end, e.skip());
                        return Err(e);
                    }
                }
                Ok(None)
            }
            Err(e) => {
                advance(&mut self.start, &mut self.end, e.skip());
                Err(e)
            }
        }
    }

    /// The input ended: runs [`Decode::decode_eof`] on the held bytes and empties the
    /// buffer of what it used. Idempotent: once it returned `Ok(None)` or an error, the
    /// next call returns `Ok(None)` (or the messages and errors still held after an error).
    ///
    /// ```
    /// # use urscript_socket::{RecvBuffer, line::LineDecoder};
    /// let mut buf = RecvBuffer::<[u8; 8]>::new();
    /// let mut lines = LineDecoder::new();
    /// buf.extend(b"tail");
    /// assert!(buf.decode_eof(&mut lines).is_err()); // no LF: cut off
    /// assert!(buf.is_empty());
    /// assert_eq!(buf.decode_eof(&mut lines).unwrap(), None);
    /// ```
    pub fn decode_eof<D: Decode>(
        &mut self,
        decoder: &mut D,
    ) -> Result<Option<D::Item<'_>>, DecodeError> {
        let data = &self.storage.as_ref()[self.start..self.end];
        let before = decoder.position();
        match decoder.decode_eof(data) {
            Ok(Some((item, consumed))) => {
                advance(&mut self.start, &mut self.end, consumed);
                Ok(Some(item))
            }
            Ok(None) => {
                // Drop what the decoder accounted for (everything, except for a read
                // that consumes nothing until complete).
                let used = decoder.position().saturating_sub(before);
                advance(&mut self.start, &mut self.end, used as usize);
                Ok(None)
            }
            Err(e) => {
                advance(&mut self.start, &mut self.end, e.skip());
                Err(e)
            }
        }
    }
}

/// Drops `n` bytes (clamped) from the front of `start..end`; an emptied buffer restarts
/// at index 0 so the next bytes need no move.
#[inline]
fn advance(start: &mut usize, end: &mut usize, n: usize) {
    *start += n.min(*end - *start);
    if *start == *end {
        *start = 0;
        *end = 0;
    }
}
