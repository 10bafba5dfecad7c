//! Where encoders write: the [`ByteSink`] trait, a fixed slice ([`SliceSink`]) and, with
//! `alloc`, a `Vec<u8>`.

use crate::EncodeError;

/// A byte sink an encoder appends to. Implemented by [`SliceSink`] (no allocation),
/// `Vec<u8>` (feature `alloc`) and `bytes::BytesMut` (feature `tokio`).
///
/// On error the sink may hold the first part of the message; callers discard it.
///
/// ```
/// use urscript_socket::{ByteSink, SliceSink};
/// let mut storage = [0u8; 4];
/// let mut sink = SliceSink::new(&mut storage);
/// sink.put(b"ab").unwrap();
/// assert!(sink.put(b"cde").is_err());
/// assert_eq!(sink.written(), b"ab");
/// ```
pub trait ByteSink {
    /// Appends all of `bytes`, or nothing and an error.
    fn put(&mut self, bytes: &[u8]) -> Result<(), EncodeError>;
}

impl<S: ByteSink + ?Sized> ByteSink for &mut S {
    #[inline]
    fn put(&mut self, bytes: &[u8]) -> Result<(), EncodeError> {
        (**self).put(bytes)
    }
}

#[cfg(feature = "alloc")]
impl ByteSink for alloc::vec::Vec<u8> {
    #[inline]
    fn put(&mut self, bytes: &[u8]) -> Result<(), EncodeError> {
        self.extend_from_slice(bytes);
        Ok(())
    }
}

#[cfg(feature = "tokio")]
impl ByteSink for bytes::BytesMut {
    #[inline]
    fn put(&mut self, bytes: &[u8]) -> Result<(), EncodeError> {
        self.extend_from_slice(bytes);
        Ok(())
    }
}

/// A [`ByteSink`] over a caller's fixed buffer; the bound is the buffer's length.
///
/// ```
/// use urscript_socket::{int32::encode_int32, SliceSink};
/// let mut storage = [0u8; 8];
/// let mut sink = SliceSink::new(&mut storage);
/// assert_eq!(encode_int32(100, &mut sink), Ok(4));
/// assert_eq!(sink.written(), [0, 0, 0, 100]);
/// ```
#[derive(Debug)]
pub struct SliceSink<'a> {
    buf: &'a mut [u8],
    len: usize,
}

impl<'a> SliceSink<'a> {
    /// Wraps `buf`; writing starts at its first byte.
    ///
    /// ```
    /// # use urscript_socket::SliceSink;
    /// let mut b = [0u8; 2];
    /// assert_eq!(SliceSink::new(&mut b).len(), 0);
    /// ```
    pub fn new(buf: &'a mut [u8]) -> Self {
        SliceSink { buf, len: 0 }
    }

    /// The bytes written so far.
    ///
    /// ```
    /// # use urscript_socket::{ByteSink, SliceSink};
    /// let mut b = [0u8; 2];
    /// let mut s = SliceSink::new(&mut b);
    /// s.put(b"x").unwrap();
    /// assert_eq!(s.written(), b"x");
    /// ```
    pub fn written(&self) -> &[u8] {
        &self.buf[..self.len]
    }

    /// Number of bytes written so far.
    ///
    /// ```
    /// # use urscript_socket::{ByteSink, SliceSink};
    /// let mut b = [0u8; 2];
    /// let mut s = SliceSink::new(&mut b);
    /// s.put(b"xy").unwrap();
    /// assert_eq!(s.len(), 2);
    /// ```
    pub fn len(&self) -> usize {
        self.len
    }

    /// True if nothing was written yet.
    ///
    /// ```
    /// # use urscript_socket::SliceSink;
    /// let mut b = [0u8; 2];
    /// assert!(SliceSink::new(&mut b).is_empty());
    /// ```
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Forgets what was written, keeping the buffer.
    ///
    /// ```
    /// # use urscript_socket::{ByteSink, SliceSink};
    /// let mut b = [0u8; 2];
    /// let mut s = SliceSink::new(&mut b);
    /// s.put(b"xy").unwrap();
    /// s.clear();
    /// assert!(s.put(b"zw").is_ok());
    /// ```
    pub fn clear(&mut self) {
        self.len = 0;
    }
}

impl ByteSink for SliceSink<'_> {
    #[inline]
    fn put(&mut self, bytes: &[u8]) -> Result<(), EncodeError> {
        let free = self.buf.len() - self.len;
        if bytes.len() > free {
            return Err(EncodeError::BufferFull {
                needed: bytes.len() - free,
            });
        }
        self.buf[self.len..self.len + bytes.len()].copy_from_slice(bytes);
        self.len += bytes.len();
        Ok(())
    }
}
