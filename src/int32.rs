//! Big-endian int32: `socket_send_int` on the robot, `socket_read_binary_integer(number)`
//! reading what the server sends, and the External Control messages built from them.
//!
//! Fixed-size: a message is `4 × number` bytes, so no scan is needed; the decoder only
//! counts bytes. Values are decoded in place from the caller's buffer ([`Int32Values`]).

use crate::framer::{FrameDecoder, Framer, Parse, ShapeKind};
use crate::{ArgumentError, ByteSink, EncodeError, ErrorKind};

/// The most values one `socket_read_binary_integer` call reads: the crate's one
/// `MAX_VALUES`, re-exported here.
pub use crate::MAX_VALUES;

/// Writes one int32 big-endian (4 bytes): what `socket_send_int(v)` sends.
///
/// ```
/// use urscript_socket::int32::encode_int32;
/// let mut out = Vec::new();
/// encode_int32(-1, &mut out).unwrap();
/// assert_eq!(out, [0xFF, 0xFF, 0xFF, 0xFF]);
/// ```
#[inline]
pub fn encode_int32<S: ByteSink + ?Sized>(value: i32, sink: &mut S) -> Result<usize, EncodeError> {
    sink.put(&value.to_be_bytes())?;
    Ok(4)
}

/// Writes each value as a big-endian int32, back to back: a message for
/// `socket_read_binary_integer(values.len())` (or any number of messages). Any length is
/// accepted; the robot reads at most 30 per call.
///
/// ```
/// use urscript_socket::int32::encode_int32_list;
/// let mut out = Vec::new();
/// encode_int32_list(&[100, 2000, 30000], &mut out).unwrap();
/// assert_eq!(out, [0, 0, 0, 0x64, 0, 0, 0x07, 0xD0, 0, 0, 0x75, 0x30]);
/// ```
pub fn encode_int32_list<S: ByteSink + ?Sized>(
    values: &[i32],
    sink: &mut S,
) -> Result<usize, EncodeError> {
    // Batch through a stack buffer: one `put` per 32 values rather than per value.
    let mut chunk = [0u8; 128];
    for group in values.chunks(32) {
        for (slot, v) in chunk.chunks_exact_mut(4).zip(group) {
            slot.copy_from_slice(&v.to_be_bytes());
        }
        sink.put(&chunk[..group.len() * 4])?;
    }
    Ok(values.len() * 4)
}

/// A complete message of big-endian int32 values, borrowed from the receive buffer.
///
/// ```
/// use urscript_socket::int32::Int32Decoder;
/// let mut dec = Int32Decoder::new(2).unwrap();
/// let vals = dec.decode(&[0, 0, 0, 1, 0xFF, 0xFF, 0xFF, 0xFE]).unwrap().item().unwrap();
/// assert_eq!(vals.iter().collect::<Vec<_>>(), [1, -2]);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Int32Values<'a> {
    bytes: &'a [u8],
}

impl<'a> Int32Values<'a> {
    /// A view over `bytes`; a trailing partial value (fewer than 4 bytes) is ignored.
    ///
    /// ```
    /// # use urscript_socket::int32::Int32Values;
    /// assert_eq!(Int32Values::new(&[0, 0, 0, 7, 1]).len(), 1);
    /// ```
    #[inline]
    pub fn new(bytes: &'a [u8]) -> Self {
        Int32Values {
            bytes: &bytes[..bytes.len() / 4 * 4],
        }
    }

    /// Number of values.
    ///
    /// ```
    /// # use urscript_socket::int32::Int32Values;
    /// assert_eq!(Int32Values::new(&[0; 8]).len(), 2);
    /// ```
    #[inline]
    pub fn len(&self) -> usize {
        self.bytes.len() / 4
    }

    /// True if there is no value.
    ///
    /// ```
    /// # use urscript_socket::int32::Int32Values;
    /// assert!(Int32Values::new(&[0; 3]).is_empty());
    /// ```
    pub fn is_empty(&self) -> bool {
        self.bytes.is_empty()
    }

    /// The value at `index`, if any (`None` past the end, however large `index` is).
    ///
    /// ```
    /// # use urscript_socket::int32::Int32Values;
    /// assert_eq!(Int32Values::new(&[0, 0, 0x75, 0x30]).get(0), Some(30000));
    /// assert_eq!(Int32Values::new(&[0, 0, 0x75, 0x30]).get(usize::MAX), None);
    /// ```
    #[inline]
    pub fn get(&self, index: usize) -> Option<i32> {
        let b = self
            .bytes
            .get(index.checked_mul(4)?..)?
            .first_chunk::<4>()?;
        Some(i32::from_be_bytes(*b))
    }

    /// The values in order.
    ///
    /// ```
    /// # use urscript_socket::int32::Int32Values;
    /// assert_eq!(Int32Values::new(&[0, 0, 0, 1]).iter().sum::<i32>(), 1);
    /// ```
    #[inline]
    pub fn iter(&self) -> impl ExactSizeIterator<Item = i32> + 'a {
        values(self.bytes)
    }

    /// The raw bytes, 4 per value.
    ///
    /// ```
    /// # use urscript_socket::int32::Int32Values;
    /// assert_eq!(Int32Values::new(&[0, 0, 0, 1]).as_bytes(), [0, 0, 0, 1]);
    /// ```
    #[inline]
    pub fn as_bytes(&self) -> &'a [u8] {
        self.bytes
    }

    /// Copies the values into `out`, returning how many were written (the smaller of
    /// the two lengths).
    ///
    /// ```
    /// # use urscript_socket::int32::Int32Values;
    /// let mut out = [0i32; 8];
    /// assert_eq!(Int32Values::new(&[0, 0, 0, 5]).copy_to(&mut out), 1);
    /// assert_eq!(out[0], 5);
    /// ```
    pub fn copy_to(&self, out: &mut [i32]) -> usize {
        let mut n = 0;
        for (slot, v) in out.iter_mut().zip(self.iter()) {
            *slot = v;
            n += 1;
        }
        n
    }
}

/// The values of `bytes` (a multiple of 4 long), in order.
#[inline]
fn values(bytes: &[u8]) -> impl ExactSizeIterator<Item = i32> + '_ {
    bytes
        .chunks_exact(4)
        .map(|b| i32::from_be_bytes([b[0], b[1], b[2], b[3]]))
}

/// Decoder of `number` big-endian int32 per message: the robot's
/// `socket_read_binary_integer(number)`, or, with `number = 1`, a server reading the
/// robot's `socket_send_int` stream.
///
/// Holds no bytes and no scan state: a message is complete once `4 × number` bytes are
/// buffered. Bound: `4 × number` ≤ 120 bytes. At end of input, leftover bytes short of a
/// message are [`Truncated`](crate::ErrorKind::Truncated).
///
/// ```
/// use urscript_socket::int32::Int32Decoder;
/// let mut dec = Int32Decoder::new(3).unwrap();
/// let bytes = [0, 0, 0, 0x64, 0, 0, 0x07, 0xD0, 0, 0, 0x75, 0x30];
/// assert!(dec.decode(&bytes[..7]).unwrap().item().is_none());
/// let vals = dec.decode(&bytes).unwrap().item().unwrap();
/// assert_eq!(vals.iter().collect::<Vec<_>>(), [100, 2000, 30000]);
/// assert!(dec.decode_eof(&[0, 0]).is_err());
/// ```
pub type Int32Decoder = FrameDecoder<Int32List>;

/// The parse step of [`Int32Decoder`]: `4 × number` bytes viewed as int32 values.
#[derive(Debug, Clone, Copy)]
pub struct Int32List {
    number: u8,
}

impl Parse for Int32List {
    type Output<'a> = Int32Values<'a>;
    const SHAPE: ShapeKind = ShapeKind::Counted;
    #[inline(always)]
    fn parse<'a>(&self, bytes: &'a [u8]) -> Result<Int32Values<'a>, (ErrorKind, usize)> {
        Ok(Int32Values { bytes })
    }
}

impl Int32Decoder {
    /// A decoder of `number` (1..=30) values per message.
    ///
    /// ```
    /// # use urscript_socket::int32::Int32Decoder;
    /// assert!(Int32Decoder::new(0).is_err());
    /// assert!(Int32Decoder::new(30).is_ok());
    /// ```
    #[inline]
    pub fn new(number: usize) -> Result<Self, ArgumentError> {
        if !(1..=MAX_VALUES).contains(&number) {
            return Err(ArgumentError::NumberOutOfRange { number });
        }
        Ok(Self::of(number as u8))
    }

    #[inline]
    const fn of(number: u8) -> Self {
        FrameDecoder::from_parts(
            Framer::counted(number as usize * 4, 4),
            Int32List { number },
        )
    }

    /// A decoder of one value per message: a server reading `socket_send_int`.
    ///
    /// ```
    /// # use urscript_socket::int32::Int32Decoder;
    /// assert_eq!(Int32Decoder::single().number(), 1);
    /// ```
    #[inline]
    pub const fn single() -> Self {
        Self::of(1)
    }

    /// Values per message.
    ///
    /// ```
    /// # use urscript_socket::int32::Int32Decoder;
    /// assert_eq!(Int32Decoder::new(8).unwrap().number(), 8);
    /// ```
    pub fn number(&self) -> usize {
        usize::from(self.parser.number)
    }

    /// The whole values available when the read must end early (the
    /// "return what arrived" timeout policy): `Some` with `consumed` if at least one
    /// whole value is buffered.
    ///
    /// ```
    /// # use urscript_socket::int32::Int32Decoder;
    /// let mut d = Int32Decoder::new(3).unwrap();
    /// let (vals, used) = d.take_partial(&[0, 0, 0, 9, 1, 2]).unwrap();
    /// assert_eq!((vals.len(), used), (1, 4));
    /// ```
    pub fn take_partial<'a>(&mut self, buf: &'a [u8]) -> Option<(Int32Values<'a>, usize)> {
        self.framer
            .take_counted(buf)
            .map(|(bytes, n)| (Int32Values { bytes }, n))
    }
}
