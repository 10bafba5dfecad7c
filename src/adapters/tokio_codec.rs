//! tokio: `tokio_util::codec` codecs for every server-side format, so that
//! `Framed::new(stream, Int32Codec::new())` works, and [`AsyncRobotSocket`], the robot
//! emulation over a tokio `TcpStream` with `tokio::time` timeouts.
//!
//! Each codec wraps one core decoder and calls it on the `BytesMut` under the core's
//! contract; payloads are split off the buffer as `Bytes` without copying. Encoders take
//! what tokio-util users pass: text codecs any `AsRef<[u8]>` (`&str`, `String`,
//! `Vec<u8>`, `Bytes`, `&[u8]`, arrays), [`FloatTupleCodec`] any `AsRef<[f64]>`,
//! [`Int32Codec`] an `i32` or a list of them, [`ByteCodec`] a `u8` or a list.
//!
//! Two combinators cover what servers need beyond one codec:
//!
//! * [`RequestReply`]`<D, E>`: one `Framed` that decodes requests with `D` and encodes
//!   replies with `E` (a line in, a float tuple out), no `into_split()` needed.
//! * [`Tolerant`]`<C>`: bad bytes become an `Err(DecodeError)` *item* and the stream goes
//!   on. Without it, `tokio_util`'s `FramedRead` ends the stream after the first
//!   decoding error (the robot stays connected and gets only timeouts). The core
//!   decoders recover by themselves: the bad bytes are already skipped.
//!
//! ```
//! # tokio::runtime::Builder::new_current_thread().enable_all().build().unwrap().block_on(async {
//! use futures_util::{SinkExt, StreamExt};
//! use tokio::io::{AsyncReadExt, AsyncWriteExt};
//! use tokio_util::codec::Framed;
//! use urscript_socket::adapters::tokio_codec::{FloatTupleCodec, LineCodec, RequestReply, Tolerant};
//!
//! let (server, mut robot) = tokio::io::duplex(256);
//! let codec = RequestReply::new(Tolerant::new(LineCodec::with_max_len(16)), FloatTupleCodec::new(3)?);
//! let mut framed = Framed::new(server, codec);
//! robot.write_all(b"a line far longer than sixteen bytes\nshoot\n").await?;
//! assert!(framed.next().await.unwrap()?.is_err());          // reported, not fatal
//! assert_eq!(framed.next().await.unwrap()?.unwrap(), "shoot");
//! framed.send([0.4, -0.2, 0.3]).await?;                    // no LF after the tuple
//! let mut reply = [0u8; 14];
//! robot.read_exact(&mut reply).await?;
//! assert_eq!(&reply, b"(0.4,-0.2,0.3)");
//! # Ok::<(), Box<dyn std::error::Error>>(()) }).unwrap();
//! ```

use std::vec::Vec;

use bytes::Buf;
use tokio_util::codec;

use crate::adapters::{ByteStream, Int32Stream};
use crate::ascii_float::{encode_float_tuple, FloatTuple, FloatTupleDecoder};
use crate::byte_list::{encode_byte, encode_byte_list};
use crate::int32::{encode_int32, encode_int32_list};
use crate::line::{encode_line, LineDecoder};
use crate::string::{encode_string, DelimitedDecoder};
use crate::stx_etx::{encode_stx_etx, StxEtxDecoder};
use crate::var::{encode_var_reply, VarMessageDecoder};
use crate::{ArgumentError, Decode, DecodeError, Status};

pub use super::tokio_robot::AsyncRobotSocket;

/// The byte types the codecs take and yield (`bytes` 1.x, the version tokio-util uses):
/// decoders yield [`Bytes`] split off the `BytesMut` read buffer, and the text and byte
/// encoders accept [`Bytes`]. Re-exported so a server needs no `bytes` dependency of its
/// own to name them.
pub use bytes::{Bytes, BytesMut};

/// The error of every codec here: the adapters' [`AdapterError`](crate::adapters::AdapterError) over
/// `std::io::Error` (the transport, bad bytes with what and where, a value the encoder
/// refuses, [`WrongCount`](crate::adapters::AdapterError::WrongCount)). Converts into
/// `std::io::Error`, so `?` works in a function returning `io::Result`.
///
/// ```
/// use urscript_socket::adapters::tokio_codec::CodecError;
/// let e = CodecError::from(std::io::Error::other("boom"));
/// assert!(e.to_string().contains("boom"));
/// let e = std::io::Error::from(CodecError::WrongCount { expected: 6, found: 5 });
/// assert_eq!(e.kind(), std::io::ErrorKind::InvalidInput);
/// ```
pub type CodecError = crate::adapters::AdapterError<std::io::Error>;

/// Runs a core decoder whose item is a slice of the buffer; returns the payload as
/// `Bytes` split off `src` (no copy).
fn decode_slice<D>(dec: &mut D, src: &mut BytesMut, eof: bool) -> Result<Option<Bytes>, CodecError>
where
    D: for<'a> Decode<Item<'a> = &'a [u8]>,
{
    let found = if eof {
        match dec.decode_eof(src) {
            Ok(Some((item, consumed))) => Some((
                item.as_ptr() as usize - src.as_ptr() as usize,
                item.len(),
                consumed,
            )),
            Ok(None) => {
                src.clear();
                return Ok(None);
            }
            Err(e) => {
                // Drop the bad bytes as in `decode`, so a caller that goes on (the
                // tolerant mode) does not meet them again.
                src.advance(e.skip().min(src.len()));
                return Err(e.into());
            }
        }
    } else {
        match dec.decode(src) {
            Ok(Status::Complete { item, consumed, .. }) => Some((
                item.as_ptr() as usize - src.as_ptr() as usize,
                item.len(),
                consumed,
            )),
            Ok(Status::Partial { consumed }) => {
                src.advance(consumed);
                None
            }
            Err(e) => {
                src.advance(e.skip().min(src.len()));
                return Err(e.into());
            }
        }
    };
    Ok(found.map(|(offset, len, consumed)| {
        let frame = src.split_to(consumed.min(src.len())).freeze();
        frame.slice(offset..offset + len)
    }))
}

/// Runs a core decoder whose item is a value; `convert` makes it owned.
fn decode_value<D, T>(
    dec: &mut D,
    src: &mut BytesMut,
    eof: bool,
    convert: impl FnOnce(D::Item<'_>) -> T,
) -> Result<Option<T>, CodecError>
where
    D: Decode,
{
    if eof {
        let out = match dec.decode_eof(src) {
            Ok(Some((item, consumed))) => Ok(Some((convert(item), consumed))),
            Ok(None) => Ok(None),
            Err(e) => Err(e),
        };
        return match out {
            Ok(Some((v, consumed))) => {
                src.advance(consumed.min(src.len()));
                Ok(Some(v))
            }
            Ok(None) => {
                src.clear();
                Ok(None)
            }
            Err(e) => {
                src.advance(e.skip().min(src.len()));
                Err(e.into())
            }
        };
    }
    let out = match dec.decode(src) {
        Ok(Status::Complete { item, consumed, .. }) => Ok((Some(convert(item)), consumed)),
        Ok(Status::Partial { consumed }) => Ok((None, consumed)),
        Err(e) => Err(e),
    };
    match out {
        Ok((v, consumed)) => {
            src.advance(consumed.min(src.len()));
            Ok(v)
        }
        Err(e) => {
            src.advance(e.skip().min(src.len()));
            Err(e.into())
        }
    }
}

macro_rules! slice_codec {
    ($(#[$doc:meta])* $name:ident, $dec:ty, $enc:expr) => {
        $(#[$doc])*
        #[derive(Debug, Clone)]
        pub struct $name {
            inner: $dec,
        }

        impl codec::Decoder for $name {
            type Item = Bytes;
            type Error = CodecError;
            fn decode(&mut self, src: &mut BytesMut) -> Result<Option<Bytes>, CodecError> {
                decode_slice(&mut self.inner, src, false)
            }
            fn decode_eof(&mut self, src: &mut BytesMut) -> Result<Option<Bytes>, CodecError> {
                decode_slice(&mut self.inner, src, true)
            }
        }

        /// Encodes anything that is bytes: `&str`, `String`, `Vec<u8>`, `Bytes`, `&[u8]`,
        /// `[u8; N]`.
        impl<T: AsRef<[u8]>> codec::Encoder<T> for $name {
            type Error = CodecError;
            fn encode(&mut self, item: T, dst: &mut BytesMut) -> Result<(), CodecError> {
                #[allow(clippy::redundant_closure_call)]
                ($enc)(&*self, item.as_ref(), dst)?;
                Ok(())
            }
        }
    };
}

slice_codec!(
    /// Lines (`socket_send_line`): items are the line without LF/CR; encoding appends LF.
    ///
    /// ```
    /// use bytes::BytesMut;
    /// use tokio_util::codec::Decoder;
    /// use urscript_socket::adapters::tokio_codec::LineCodec;
    /// let mut buf = BytesMut::from(&b"hello\r\nwor"[..]);
    /// assert_eq!(LineCodec::new().decode(&mut buf).unwrap().unwrap(), &b"hello"[..]);
    /// assert_eq!(buf, &b"wor"[..]);
    /// ```
    LineCodec,
    LineDecoder,
    |_: &LineCodec, item: &[u8], dst: &mut BytesMut| encode_line(item, dst)
);

impl LineCodec {
    /// A codec with the core's default line bound.
    ///
    /// ```
    /// # use urscript_socket::adapters::tokio_codec::LineCodec;
    /// let c = LineCodec::new();
    /// ```
    pub fn new() -> Self {
        LineCodec {
            inner: LineDecoder::new(),
        }
    }

    /// A codec whose lines hold at most `max_len` bytes.
    ///
    /// ```
    /// # use urscript_socket::adapters::tokio_codec::LineCodec;
    /// let c = LineCodec::with_max_len(256);
    /// ```
    pub fn with_max_len(max_len: usize) -> Self {
        LineCodec {
            inner: LineDecoder::with_max_len(max_len),
        }
    }
}

slice_codec!(
    /// STX/ETX frames: items are payloads; encoding frames a payload.
    ///
    /// ```
    /// use bytes::BytesMut;
    /// use tokio_util::codec::{Decoder, Encoder};
    /// use urscript_socket::adapters::tokio_codec::StxEtxCodec;
    /// let mut c = StxEtxCodec::new();
    /// let mut buf = BytesMut::new();
    /// c.encode(&b"hi"[..], &mut buf).unwrap();
    /// assert_eq!(c.decode(&mut buf).unwrap().unwrap(), &b"hi"[..]);
    /// ```
    StxEtxCodec,
    StxEtxDecoder,
    |_: &StxEtxCodec, item: &[u8], dst: &mut BytesMut| encode_stx_etx(item, dst)
);

impl StxEtxCodec {
    /// A codec with the core's default frame bound.
    ///
    /// ```
    /// # use urscript_socket::adapters::tokio_codec::StxEtxCodec;
    /// let c = StxEtxCodec::new();
    /// ```
    pub fn new() -> Self {
        StxEtxCodec {
            inner: StxEtxDecoder::new(),
        }
    }
}

slice_codec!(
    /// Strings split on a delimiter (a robot's bare `socket_send_string` traffic); encoding
    /// appends the delimiter.
    ///
    /// ```
    /// use bytes::BytesMut;
    /// use tokio_util::codec::Decoder;
    /// use urscript_socket::adapters::tokio_codec::DelimitedCodec;
    /// let mut c = DelimitedCodec::new(b";").unwrap();
    /// let mut buf = BytesMut::from(&b"a;b"[..]);
    /// assert_eq!(c.decode(&mut buf).unwrap().unwrap(), &b"a"[..]);
    /// assert_eq!(c.decode_eof(&mut buf).unwrap().unwrap(), &b"b"[..]);
    /// ```
    DelimitedCodec,
    DelimitedDecoder,
    |c: &DelimitedCodec, item: &[u8], dst: &mut BytesMut| {
        encode_string(item, dst)?;
        encode_string(c.inner.delimiter(), dst)
    }
);

impl DelimitedCodec {
    /// A codec splitting on `delimiter` (1 to 64 bytes).
    ///
    /// ```
    /// # use urscript_socket::adapters::tokio_codec::DelimitedCodec;
    /// assert!(DelimitedCodec::new(b"").is_err());
    /// ```
    pub fn new(delimiter: &[u8]) -> Result<Self, ArgumentError> {
        Ok(DelimitedCodec {
            inner: DelimitedDecoder::new(delimiter)?,
        })
    }
}

/// Big-endian int32 (`socket_send_int`), one `i32` per item, as
/// [`Int32Stream`] gives in every adapter. Encodes an `i32`
/// or a list of them (`&[i32]`, `Vec<i32>`, `[i32; N]`) for `socket_read_binary_integer`.
///
/// ```
/// use bytes::BytesMut;
/// use tokio_util::codec::{Decoder, Encoder};
/// use urscript_socket::adapters::tokio_codec::Int32Codec;
/// let mut c = Int32Codec::new();
/// let mut buf = BytesMut::new();
/// c.encode(-1, &mut buf).unwrap();
/// c.encode([1, 2], &mut buf).unwrap();
/// c.encode(vec![3], &mut buf).unwrap();
/// assert_eq!(buf.len(), 16);
/// assert_eq!(c.decode(&mut buf).unwrap(), Some(-1));
/// assert_eq!(c.decode(&mut buf).unwrap(), Some(1));
/// ```
#[derive(Debug, Clone, Default)]
pub struct Int32Codec {
    inner: Int32Stream,
}

impl Int32Codec {
    /// A codec of single int32 values.
    ///
    /// ```
    /// # use urscript_socket::adapters::tokio_codec::Int32Codec;
    /// let c = Int32Codec::new();
    /// ```
    pub fn new() -> Self {
        Self::default()
    }
}

impl codec::Decoder for Int32Codec {
    type Item = i32;
    type Error = CodecError;
    fn decode(&mut self, src: &mut BytesMut) -> Result<Option<i32>, CodecError> {
        decode_value(&mut self.inner, src, false, |v| v)
    }
    fn decode_eof(&mut self, src: &mut BytesMut) -> Result<Option<i32>, CodecError> {
        decode_value(&mut self.inner, src, true, |v| v)
    }
}

impl codec::Encoder<i32> for Int32Codec {
    type Error = CodecError;
    fn encode(&mut self, item: i32, dst: &mut BytesMut) -> Result<(), CodecError> {
        encode_int32(item, dst)?;
        Ok(())
    }
}

/// `impl Encoder<$t>` by way of `$enc(&[..], dst)`: the list forms of a codec's item.
macro_rules! list_encoders {
    ($codec:ty, $elem:ty, $enc:path) => {
        impl<'a> codec::Encoder<&'a [$elem]> for $codec {
            type Error = CodecError;
            fn encode(&mut self, item: &'a [$elem], dst: &mut BytesMut) -> Result<(), CodecError> {
                $enc(item, dst)?;
                Ok(())
            }
        }
        impl<'a> codec::Encoder<&'a Vec<$elem>> for $codec {
            type Error = CodecError;
            fn encode(
                &mut self,
                item: &'a Vec<$elem>,
                dst: &mut BytesMut,
            ) -> Result<(), CodecError> {
                $enc(item, dst)?;
                Ok(())
            }
        }
        impl codec::Encoder<Vec<$elem>> for $codec {
            type Error = CodecError;
            fn encode(&mut self, item: Vec<$elem>, dst: &mut BytesMut) -> Result<(), CodecError> {
                $enc(&item, dst)?;
                Ok(())
            }
        }
        impl<const N: usize> codec::Encoder<[$elem; N]> for $codec {
            type Error = CodecError;
            fn encode(&mut self, item: [$elem; N], dst: &mut BytesMut) -> Result<(), CodecError> {
                $enc(&item, dst)?;
                Ok(())
            }
        }
        impl<'a, const N: usize> codec::Encoder<&'a [$elem; N]> for $codec {
            type Error = CodecError;
            fn encode(
                &mut self,
                item: &'a [$elem; N],
                dst: &mut BytesMut,
            ) -> Result<(), CodecError> {
                $enc(item, dst)?;
                Ok(())
            }
        }
    };
}

list_encoders!(Int32Codec, i32, encode_int32_list);

/// Single bytes (`socket_send_byte`), one `u8` per item. Encodes a `u8` or a list
/// (`&[u8]`, `Vec<u8>`, `[u8; N]`, `Bytes`) for `socket_read_byte_list`.
///
/// ```
/// use bytes::BytesMut;
/// use tokio_util::codec::{Decoder, Encoder};
/// use urscript_socket::adapters::tokio_codec::ByteCodec;
/// let mut c = ByteCodec::new();
/// let mut buf = BytesMut::from(&[2u8, 3][..]);
/// assert_eq!(c.decode(&mut buf).unwrap(), Some(2));
/// c.encode([10u8, 13], &mut buf).unwrap();
/// assert_eq!(buf, &[3u8, 10, 13][..]);
/// ```
#[derive(Debug, Clone, Default)]
pub struct ByteCodec {
    inner: ByteStream,
}

impl ByteCodec {
    /// A codec of single bytes.
    ///
    /// ```
    /// # use urscript_socket::adapters::tokio_codec::ByteCodec;
    /// let c = ByteCodec::new();
    /// ```
    pub fn new() -> Self {
        Self::default()
    }
}

impl codec::Decoder for ByteCodec {
    type Item = u8;
    type Error = CodecError;
    fn decode(&mut self, src: &mut BytesMut) -> Result<Option<u8>, CodecError> {
        decode_value(&mut self.inner, src, false, |b| b)
    }
    fn decode_eof(&mut self, src: &mut BytesMut) -> Result<Option<u8>, CodecError> {
        decode_value(&mut self.inner, src, true, |b| b)
    }
}

impl codec::Encoder<u8> for ByteCodec {
    type Error = CodecError;
    fn encode(&mut self, item: u8, dst: &mut BytesMut) -> Result<(), CodecError> {
        encode_byte(item, dst)?;
        Ok(())
    }
}

list_encoders!(ByteCodec, u8, encode_byte_list);

impl codec::Encoder<Bytes> for ByteCodec {
    type Error = CodecError;
    fn encode(&mut self, item: Bytes, dst: &mut BytesMut) -> Result<(), CodecError> {
        encode_byte_list(&item, dst)?;
        Ok(())
    }
}

/// The owned `SET`/`GET` message, shared by every adapter (feature `alloc`).
pub use crate::adapters::VarRequest;

/// `SET`/`GET` messages in, `name value\n` replies out (`(name, value)` items, the name
/// any `AsRef<str>`: `&str`, `String`).
///
/// ```
/// use bytes::BytesMut;
/// use tokio_util::codec::{Decoder, Encoder};
/// use urscript_socket::adapters::tokio_codec::{VarCodec, VarRequest};
/// let mut c = VarCodec::new();
/// let mut buf = BytesMut::from(&b"GET POS_X\n"[..]);
/// assert_eq!(c.decode(&mut buf).unwrap(), Some(VarRequest::Get { name: "POS_X".into() }));
/// c.encode(("POS_X", 1234), &mut buf).unwrap();
/// c.encode((String::from("POS_Y"), -1), &mut buf).unwrap();
/// assert_eq!(buf, &b"POS_X 1234\nPOS_Y -1\n"[..]);
/// ```
#[derive(Debug, Clone, Default)]
pub struct VarCodec {
    inner: VarMessageDecoder,
}

impl VarCodec {
    /// A codec with the core's default line bound.
    ///
    /// ```
    /// # use urscript_socket::adapters::tokio_codec::VarCodec;
    /// let c = VarCodec::new();
    /// ```
    pub fn new() -> Self {
        Self::default()
    }
}

impl codec::Decoder for VarCodec {
    type Item = VarRequest;
    type Error = CodecError;
    fn decode(&mut self, src: &mut BytesMut) -> Result<Option<VarRequest>, CodecError> {
        decode_value(&mut self.inner, src, false, |m| VarRequest::from(m))
    }
    fn decode_eof(&mut self, src: &mut BytesMut) -> Result<Option<VarRequest>, CodecError> {
        decode_value(&mut self.inner, src, true, |m| VarRequest::from(m))
    }
}

impl<S: AsRef<str>> codec::Encoder<(S, i32)> for VarCodec {
    type Error = CodecError;
    fn encode(&mut self, (name, value): (S, i32), dst: &mut BytesMut) -> Result<(), CodecError> {
        encode_var_reply(name.as_ref(), value, dst)?;
        Ok(())
    }
}

/// Any format of the registry, chosen at run time ([`Format`](crate::format::Format)):
/// items are [`OwnedMessage`](crate::format::OwnedMessage)s. A format added to the
/// registry works here with no new codec. Decoding only: pair it with an encoding codec
/// in a [`RequestReply`] to answer.
///
/// ```
/// use bytes::BytesMut;
/// use tokio_util::codec::Decoder;
/// use urscript_socket::adapters::tokio_codec::FormatCodec;
/// use urscript_socket::format::{Format, OwnedMessage};
/// let mut codec = FormatCodec::new(Format::Int32 { number: 2 }).unwrap();
/// let mut buf = BytesMut::from(&[0, 0, 0, 1, 0xFF, 0xFF, 0xFF, 0xFF][..]);
/// assert_eq!(codec.decode(&mut buf).unwrap(), Some(OwnedMessage::Int32(vec![1, -1])));
/// ```
#[derive(Debug, Clone)]
pub struct FormatCodec {
    inner: crate::format::AnyDecoder,
}

impl FormatCodec {
    /// A codec for `format`, with its default bounds. Errors as [`Format::decoder`](crate::format::Format::decoder).
    ///
    /// ```
    /// # use urscript_socket::{adapters::tokio_codec::FormatCodec, format::Format};
    /// assert!(FormatCodec::new(Format::Bytes { number: 0 }).is_err());
    /// ```
    pub fn new(format: crate::format::Format<'_>) -> Result<Self, ArgumentError> {
        Ok(FormatCodec {
            inner: format.decoder()?,
        })
    }
}

impl codec::Decoder for FormatCodec {
    type Item = crate::format::OwnedMessage;
    type Error = CodecError;
    fn decode(&mut self, src: &mut BytesMut) -> Result<Option<Self::Item>, CodecError> {
        decode_value(&mut self.inner, src, false, |m| {
            crate::format::OwnedMessage::from(&m)
        })
    }
    fn decode_eof(&mut self, src: &mut BytesMut) -> Result<Option<Self::Item>, CodecError> {
        decode_value(&mut self.inner, src, true, |m| {
            crate::format::OwnedMessage::from(&m)
        })
    }
}

/// ASCII float tuples: encodes what a server sends for `socket_read_ascii_float(number)`
/// (with a trailing LF if asked), and decodes tuples as the robot reads them.
///
/// The encoder takes any `AsRef<[f64]>` (`[f64; 6]`, `&[f64]`, `Vec<f64>`) holding exactly
/// `number` values; another count is refused with [`CodecError::WrongCount`] and nothing
/// is written (the robot's read of it would fail).
///
/// ```
/// use bytes::BytesMut;
/// use tokio_util::codec::{Decoder, Encoder};
/// use urscript_socket::adapters::tokio_codec::{CodecError, FloatTupleCodec};
/// let mut c = FloatTupleCodec::new(2).unwrap();
/// let mut buf = BytesMut::new();
/// c.encode([1.5, -2.0], &mut buf).unwrap();
/// assert_eq!(buf, &b"(1.5,-2)"[..]);
/// assert_eq!(c.decode(&mut buf).unwrap().unwrap().values(), [1.5, -2.0]);
/// let refused = c.encode(vec![1.0, 2.0, 3.0], &mut buf);
/// assert!(matches!(refused, Err(CodecError::WrongCount { expected: 2, found: 3 })));
/// assert!(buf.is_empty());
/// ```
#[derive(Debug, Clone)]
pub struct FloatTupleCodec {
    inner: FloatTupleDecoder,
    trailing_lf: bool,
}

impl FloatTupleCodec {
    /// A codec of `number`-value tuples (1..=30), no trailing LF.
    ///
    /// ```
    /// # use urscript_socket::adapters::tokio_codec::FloatTupleCodec;
    /// assert!(FloatTupleCodec::new(31).is_err());
    /// ```
    pub fn new(number: usize) -> Result<Self, ArgumentError> {
        Ok(FloatTupleCodec {
            inner: FloatTupleDecoder::new(number)?,
            trailing_lf: false,
        })
    }

    /// Whether encoded tuples end with `\n`. Off by default: the robot's
    /// `socket_read_ascii_float` consumes through `)`, so an LF stays in its buffer and is
    /// what a later `socket_read_line` or `socket_read_binary_integer` sees first.
    ///
    /// ```
    /// # use urscript_socket::adapters::tokio_codec::FloatTupleCodec;
    /// let c = FloatTupleCodec::new(6).unwrap().with_trailing_lf(true);
    /// ```
    pub fn with_trailing_lf(mut self, trailing_lf: bool) -> Self {
        self.trailing_lf = trailing_lf;
        self
    }

    /// Values per tuple.
    ///
    /// ```
    /// # use urscript_socket::adapters::tokio_codec::FloatTupleCodec;
    /// assert_eq!(FloatTupleCodec::new(6).unwrap().number(), 6);
    /// ```
    pub fn number(&self) -> usize {
        self.inner.number()
    }
}

impl codec::Decoder for FloatTupleCodec {
    type Item = FloatTuple;
    type Error = CodecError;
    fn decode(&mut self, src: &mut BytesMut) -> Result<Option<FloatTuple>, CodecError> {
        decode_value(&mut self.inner, src, false, |t| t)
    }
    fn decode_eof(&mut self, src: &mut BytesMut) -> Result<Option<FloatTuple>, CodecError> {
        decode_value(&mut self.inner, src, true, |t| t)
    }
}

impl<T: AsRef<[f64]>> codec::Encoder<T> for FloatTupleCodec {
    type Error = CodecError;
    fn encode(&mut self, item: T, dst: &mut BytesMut) -> Result<(), CodecError> {
        let values = item.as_ref();
        if values.len() != self.number() {
            return Err(CodecError::WrongCount {
                expected: self.number(),
                found: values.len(),
            });
        }
        let start = dst.len();
        if let Err(e) = encode_float_tuple(values, self.trailing_lf, dst) {
            dst.truncate(start);
            return Err(e.into());
        }
        Ok(())
    }
}

/// One codec for one `Framed`: requests decoded with `D`, replies encoded with `E`.
/// The commonest server (a line in, a float tuple out) needs no `into_split()`:
///
/// ```
/// use tokio_util::codec::{Decoder, Encoder};
/// use bytes::BytesMut;
/// use urscript_socket::adapters::tokio_codec::{FloatTupleCodec, LineCodec, RequestReply};
/// let mut codec = RequestReply::new(LineCodec::new(), FloatTupleCodec::new(2).unwrap());
/// let mut rx = BytesMut::from(&b"shoot\n"[..]);
/// assert_eq!(codec.decode(&mut rx).unwrap().unwrap(), "shoot");
/// let mut tx = BytesMut::new();
/// codec.encode([0.5, 1.0], &mut tx).unwrap();
/// assert_eq!(tx, &b"(0.5,1)"[..]);   // no LF appended by the line codec
/// ```
///
/// With a socket: `Framed::new(stream, RequestReply::new(LineCodec::new(),
/// FloatTupleCodec::new(6)?))`, then `framed.next().await` / `framed.send(pose).await`.
#[derive(Debug, Clone, Default)]
pub struct RequestReply<D, E> {
    decoder: D,
    encoder: E,
}

impl<D, E> RequestReply<D, E> {
    /// Pairs a decoder of requests with an encoder of replies.
    ///
    /// ```
    /// # use urscript_socket::adapters::tokio_codec::{Int32Codec, VarCodec, RequestReply};
    /// let c = RequestReply::new(VarCodec::new(), Int32Codec::new());
    /// ```
    pub fn new(decoder: D, encoder: E) -> Self {
        RequestReply { decoder, encoder }
    }

    /// The request decoder.
    ///
    /// ```
    /// # use urscript_socket::adapters::tokio_codec::{FloatTupleCodec, LineCodec, RequestReply};
    /// let c = RequestReply::new(LineCodec::new(), FloatTupleCodec::new(6).unwrap());
    /// let _lines: &LineCodec = c.decoder();
    /// ```
    pub fn decoder(&self) -> &D {
        &self.decoder
    }

    /// The request decoder, mutably.
    ///
    /// ```
    /// # use urscript_socket::adapters::tokio_codec::{FloatTupleCodec, LineCodec, RequestReply};
    /// let mut c = RequestReply::new(LineCodec::new(), FloatTupleCodec::new(6).unwrap());
    /// let _lines: &mut LineCodec = c.decoder_mut();
    /// ```
    pub fn decoder_mut(&mut self) -> &mut D {
        &mut self.decoder
    }

    /// The reply encoder.
    ///
    /// ```
    /// # use urscript_socket::adapters::tokio_codec::{FloatTupleCodec, LineCodec, RequestReply};
    /// let c = RequestReply::new(LineCodec::new(), FloatTupleCodec::new(6).unwrap());
    /// assert_eq!(c.encoder().number(), 6);
    /// ```
    pub fn encoder(&self) -> &E {
        &self.encoder
    }

    /// The reply encoder, mutably (e.g. to swap it for another reply shape).
    ///
    /// ```
    /// # use urscript_socket::adapters::tokio_codec::{FloatTupleCodec, LineCodec, RequestReply};
    /// let mut c = RequestReply::new(LineCodec::new(), FloatTupleCodec::new(6).unwrap());
    /// *c.encoder_mut() = FloatTupleCodec::new(3).unwrap();
    /// ```
    pub fn encoder_mut(&mut self) -> &mut E {
        &mut self.encoder
    }

    /// The two halves.
    ///
    /// ```
    /// # use urscript_socket::adapters::tokio_codec::{FloatTupleCodec, LineCodec, RequestReply};
    /// let (d, e) = RequestReply::new(LineCodec::new(), FloatTupleCodec::new(6).unwrap()).into_parts();
    /// ```
    pub fn into_parts(self) -> (D, E) {
        (self.decoder, self.encoder)
    }
}

impl<D: codec::Decoder, E> codec::Decoder for RequestReply<D, E> {
    type Item = D::Item;
    type Error = D::Error;
    fn decode(&mut self, src: &mut BytesMut) -> Result<Option<D::Item>, D::Error> {
        self.decoder.decode(src)
    }
    fn decode_eof(&mut self, src: &mut BytesMut) -> Result<Option<D::Item>, D::Error> {
        self.decoder.decode_eof(src)
    }
}

impl<T, D, E: codec::Encoder<T>> codec::Encoder<T> for RequestReply<D, E> {
    type Error = E::Error;
    fn encode(&mut self, item: T, dst: &mut BytesMut) -> Result<(), E::Error> {
        self.encoder.encode(item, dst)
    }
}

/// Tolerant mode: a bad message is an `Err(DecodeError)` item and the stream goes on.
/// Only a transport error ends it. Wraps any codec of this module (or a
/// [`RequestReply`] of them); encoding passes through.
///
/// Without it, `FramedRead`/`Framed` end the stream at the first bad message (an
/// over-long line, a malformed `SET`): the robot stays connected and its reads time out.
///
/// ```
/// use bytes::BytesMut;
/// use tokio_util::codec::Decoder;
/// use urscript_socket::adapters::tokio_codec::{LineCodec, Tolerant};
/// use urscript_socket::ErrorKind;
/// let mut c = Tolerant::new(LineCodec::with_max_len(4));
/// let mut buf = BytesMut::from(&b"much too long\nok\n"[..]);
/// let bad = c.decode(&mut buf).unwrap().unwrap().unwrap_err();
/// assert_eq!(bad.kind(), ErrorKind::TooLong { limit: 4 });
/// assert_eq!(c.decode(&mut buf).unwrap().unwrap().unwrap(), "ok");
/// ```
#[derive(Debug, Clone, Default)]
pub struct Tolerant<C> {
    inner: C,
}

impl<C> Tolerant<C> {
    /// Wraps `codec`.
    ///
    /// ```
    /// # use urscript_socket::adapters::tokio_codec::{Tolerant, VarCodec};
    /// let c = Tolerant::new(VarCodec::new());
    /// ```
    pub fn new(codec: C) -> Self {
        Tolerant { inner: codec }
    }

    /// The wrapped codec.
    ///
    /// ```
    /// # use urscript_socket::adapters::tokio_codec::{Tolerant, VarCodec};
    /// let _: &VarCodec = Tolerant::new(VarCodec::new()).get_ref();
    /// ```
    pub fn get_ref(&self) -> &C {
        &self.inner
    }

    /// The wrapped codec, mutably.
    ///
    /// ```
    /// # use urscript_socket::adapters::tokio_codec::{Tolerant, VarCodec};
    /// let _: &mut VarCodec = Tolerant::new(VarCodec::new()).get_mut();
    /// ```
    pub fn get_mut(&mut self) -> &mut C {
        &mut self.inner
    }

    /// The wrapped codec.
    ///
    /// ```
    /// # use urscript_socket::adapters::tokio_codec::{Tolerant, VarCodec};
    /// let _: VarCodec = Tolerant::new(VarCodec::new()).into_inner();
    /// ```
    pub fn into_inner(self) -> C {
        self.inner
    }
}

fn tolerate<T>(
    r: Result<Option<T>, CodecError>,
) -> Result<Option<Result<T, DecodeError>>, CodecError> {
    match r {
        Ok(item) => Ok(item.map(Ok)),
        Err(CodecError::Decode(e)) => Ok(Some(Err(e))),
        Err(e) => Err(e),
    }
}

impl<C: codec::Decoder<Error = CodecError>> codec::Decoder for Tolerant<C> {
    type Item = Result<C::Item, DecodeError>;
    type Error = CodecError;
    fn decode(&mut self, src: &mut BytesMut) -> Result<Option<Self::Item>, CodecError> {
        tolerate(self.inner.decode(src))
    }
    fn decode_eof(&mut self, src: &mut BytesMut) -> Result<Option<Self::Item>, CodecError> {
        let before = src.len();
        let r = tolerate(self.inner.decode_eof(src));
        if matches!(r, Ok(Some(Err(_)))) && src.len() == before {
            // Nothing more will arrive: never report the same bytes twice.
            src.clear();
        }
        r
    }
}

impl<T, C: codec::Encoder<T>> codec::Encoder<T> for Tolerant<C> {
    type Error = C::Error;
    fn encode(&mut self, item: T, dst: &mut BytesMut) -> Result<(), C::Error> {
        self.inner.encode(item, dst)
    }
}

impl Default for LineCodec {
    fn default() -> Self {
        Self::new()
    }
}

impl Default for StxEtxCodec {
    fn default() -> Self {
        Self::new()
    }
}
