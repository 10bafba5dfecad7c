//! tokio: `tokio_util::codec` codecs for every server-side format, so that
//! `Framed::new(stream, Int32Codec::new())` works, and [`AsyncRobotSocket`], the robot
//! emulation over a tokio `TcpStream` with `tokio::time` timeouts.
//!
//! Each codec wraps one core decoder and calls it on the `BytesMut` under the core's
//! contract; payloads are split off the buffer as `Bytes` without copying.
//!
//! Note that `tokio_util`'s `FramedRead` ends the stream after the first decoding error.
//! The core decoders themselves recover (the bad bytes are already skipped), so a caller
//! that wants to go on can drive the codec with `Decoder::decode` directly.

use std::string::String;
use std::vec::Vec;

use ::tokio::io::{AsyncReadExt, AsyncWriteExt};
use ::tokio::net::{TcpStream, ToSocketAddrs};
use bytes::{Buf, Bytes, BytesMut};
use tokio_util::codec;

use crate::ascii_float::{encode_float_tuple, FloatTuple, FloatTupleDecoder};
use crate::byte_list::{encode_byte, ByteListDecoder};
use crate::int32::{encode_int32, Int32Decoder};
use crate::line::{encode_line, LineDecoder};
use crate::robot::{Policy, ReadCall, ReadResult, RobotError, SocketConnection, Timeout};
use crate::string::{encode_string, DelimitedDecoder};
use crate::stx_etx::{encode_stx_etx, StxEtxDecoder};
use crate::var::{encode_var_reply, VarMessage, VarMessageDecoder};
use crate::{ArgumentError, DecodeError, Decoder, EncodeError, Status};

/// The error of every codec here: the transport, bad bytes (what and where), or a
/// value the encoder refuses.
///
/// ```
/// use urscript_socket::adapters::tokio::CodecError;
/// let e = CodecError::from(std::io::Error::other("boom"));
/// assert!(e.to_string().contains("boom"));
/// ```
#[derive(Debug)]
#[non_exhaustive]
pub enum CodecError {
    /// The transport failed.
    Io(std::io::Error),
    /// Bad bytes.
    Decode(DecodeError),
    /// A value that cannot be encoded.
    Encode(EncodeError),
}

impl core::fmt::Display for CodecError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            CodecError::Io(e) => write!(f, "transport error: {e}"),
            CodecError::Decode(e) => write!(f, "bad input: {e}"),
            CodecError::Encode(e) => write!(f, "cannot encode: {e}"),
        }
    }
}

impl std::error::Error for CodecError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            CodecError::Io(e) => Some(e),
            CodecError::Decode(e) => Some(e),
            CodecError::Encode(e) => Some(e),
        }
    }
}

impl From<std::io::Error> for CodecError {
    fn from(e: std::io::Error) -> Self {
        CodecError::Io(e)
    }
}

impl From<DecodeError> for CodecError {
    fn from(e: DecodeError) -> Self {
        CodecError::Decode(e)
    }
}

impl From<EncodeError> for CodecError {
    fn from(e: EncodeError) -> Self {
        CodecError::Encode(e)
    }
}

/// Runs a core decoder whose item is a slice of the buffer; returns the payload as
/// `Bytes` split off `src` (no copy).
fn decode_slice<D>(dec: &mut D, src: &mut BytesMut, eof: bool) -> Result<Option<Bytes>, CodecError>
where
    D: for<'a> Decoder<Item<'a> = &'a [u8]>,
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
                // Drop the bad bytes, so a second call does not report them again.
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
    D: Decoder,
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

        impl<'a> codec::Encoder<&'a [u8]> for $name {
            type Error = CodecError;
            fn encode(&mut self, item: &'a [u8], dst: &mut BytesMut) -> Result<(), CodecError> {
                #[allow(clippy::redundant_closure_call)]
                ($enc)(&*self, item, dst)?;
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
    /// use urscript_socket::adapters::tokio::LineCodec;
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
    /// # use urscript_socket::adapters::tokio::LineCodec;
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
    /// # use urscript_socket::adapters::tokio::LineCodec;
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
    /// use urscript_socket::adapters::tokio::StxEtxCodec;
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
    /// # use urscript_socket::adapters::tokio::StxEtxCodec;
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
    /// use urscript_socket::adapters::tokio::DelimitedCodec;
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
    /// # use urscript_socket::adapters::tokio::DelimitedCodec;
    /// assert!(DelimitedCodec::new(b"").is_err());
    /// ```
    pub fn new(delimiter: &[u8]) -> Result<Self, ArgumentError> {
        Ok(DelimitedCodec {
            inner: DelimitedDecoder::new(delimiter)?,
        })
    }
}

/// Big-endian int32 (`socket_send_int`), one value per item.
///
/// ```
/// use bytes::BytesMut;
/// use tokio_util::codec::{Decoder, Encoder};
/// use urscript_socket::adapters::tokio::Int32Codec;
/// let mut c = Int32Codec::new();
/// let mut buf = BytesMut::new();
/// c.encode(-1, &mut buf).unwrap();
/// assert_eq!(c.decode(&mut buf).unwrap(), Some(-1));
/// ```
#[derive(Debug, Clone)]
pub struct Int32Codec {
    inner: Int32Decoder,
}

impl Int32Codec {
    /// A codec of single int32 values.
    ///
    /// ```
    /// # use urscript_socket::adapters::tokio::Int32Codec;
    /// let c = Int32Codec::new();
    /// ```
    pub fn new() -> Self {
        Self::default()
    }
}

impl Default for Int32Codec {
    fn default() -> Self {
        Int32Codec {
            inner: Int32Decoder::single(),
        }
    }
}

impl codec::Decoder for Int32Codec {
    type Item = i32;
    type Error = CodecError;
    fn decode(&mut self, src: &mut BytesMut) -> Result<Option<i32>, CodecError> {
        decode_value(&mut self.inner, src, false, |v| {
            v.get(0).unwrap_or_default()
        })
    }
    fn decode_eof(&mut self, src: &mut BytesMut) -> Result<Option<i32>, CodecError> {
        decode_value(&mut self.inner, src, true, |v| v.get(0).unwrap_or_default())
    }
}

impl codec::Encoder<i32> for Int32Codec {
    type Error = CodecError;
    fn encode(&mut self, item: i32, dst: &mut BytesMut) -> Result<(), CodecError> {
        encode_int32(item, dst)?;
        Ok(())
    }
}

/// Single bytes (`socket_send_byte`), one per item.
///
/// ```
/// use bytes::BytesMut;
/// use tokio_util::codec::Decoder;
/// use urscript_socket::adapters::tokio::ByteCodec;
/// let mut buf = BytesMut::from(&[2u8, 3][..]);
/// assert_eq!(ByteCodec::new().decode(&mut buf).unwrap(), Some(2));
/// ```
#[derive(Debug, Clone)]
pub struct ByteCodec {
    inner: ByteListDecoder,
}

impl ByteCodec {
    /// A codec of single bytes.
    ///
    /// ```
    /// # use urscript_socket::adapters::tokio::ByteCodec;
    /// let c = ByteCodec::new();
    /// ```
    pub fn new() -> Self {
        Self::default()
    }
}

impl Default for ByteCodec {
    fn default() -> Self {
        ByteCodec {
            inner: ByteListDecoder::single(),
        }
    }
}

impl codec::Decoder for ByteCodec {
    type Item = u8;
    type Error = CodecError;
    fn decode(&mut self, src: &mut BytesMut) -> Result<Option<u8>, CodecError> {
        decode_value(&mut self.inner, src, false, |b| {
            b.first().copied().unwrap_or_default()
        })
    }
    fn decode_eof(&mut self, src: &mut BytesMut) -> Result<Option<u8>, CodecError> {
        decode_value(&mut self.inner, src, true, |b| {
            b.first().copied().unwrap_or_default()
        })
    }
}

impl codec::Encoder<u8> for ByteCodec {
    type Error = CodecError;
    fn encode(&mut self, item: u8, dst: &mut BytesMut) -> Result<(), CodecError> {
        encode_byte(item, dst)?;
        Ok(())
    }
}

/// An owned `SET`/`GET` message from the robot.
///
/// ```
/// use urscript_socket::adapters::tokio::VarRequest;
/// let r = VarRequest::Get { name: "POS_X".into() };
/// assert_eq!(r.name(), "POS_X");
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum VarRequest {
    /// `socket_set_var(name, value)`.
    Set {
        /// Variable name.
        name: String,
        /// New value.
        value: i32,
    },
    /// `socket_get_var(name)`: answer with the codec's encoder within 2 s.
    Get {
        /// Variable name.
        name: String,
    },
}

impl VarRequest {
    /// The variable's name.
    ///
    /// ```
    /// # use urscript_socket::adapters::tokio::VarRequest;
    /// assert_eq!(VarRequest::Set { name: "A".into(), value: 1 }.name(), "A");
    /// ```
    pub fn name(&self) -> &str {
        match self {
            VarRequest::Set { name, .. } | VarRequest::Get { name } => name,
        }
    }
}

/// `SET`/`GET` messages in, `name value\n` replies out (`(name, value)` items).
///
/// ```
/// use bytes::BytesMut;
/// use tokio_util::codec::{Decoder, Encoder};
/// use urscript_socket::adapters::tokio::{VarCodec, VarRequest};
/// let mut c = VarCodec::new();
/// let mut buf = BytesMut::from(&b"GET POS_X\n"[..]);
/// assert_eq!(c.decode(&mut buf).unwrap(), Some(VarRequest::Get { name: "POS_X".into() }));
/// c.encode(("POS_X", 1234), &mut buf).unwrap();
/// assert_eq!(buf, &b"POS_X 1234\n"[..]);
/// ```
#[derive(Debug, Clone, Default)]
pub struct VarCodec {
    inner: VarMessageDecoder,
}

impl VarCodec {
    /// A codec with the core's default line bound.
    ///
    /// ```
    /// # use urscript_socket::adapters::tokio::VarCodec;
    /// let c = VarCodec::new();
    /// ```
    pub fn new() -> Self {
        Self::default()
    }
}

fn owned(m: VarMessage<'_>) -> VarRequest {
    match m {
        VarMessage::Set { name, value } => VarRequest::Set {
            name: String::from(name),
            value,
        },
        VarMessage::Get { name } => VarRequest::Get {
            name: String::from(name),
        },
    }
}

impl codec::Decoder for VarCodec {
    type Item = VarRequest;
    type Error = CodecError;
    fn decode(&mut self, src: &mut BytesMut) -> Result<Option<VarRequest>, CodecError> {
        decode_value(&mut self.inner, src, false, owned)
    }
    fn decode_eof(&mut self, src: &mut BytesMut) -> Result<Option<VarRequest>, CodecError> {
        decode_value(&mut self.inner, src, true, owned)
    }
}

impl<'a> codec::Encoder<(&'a str, i32)> for VarCodec {
    type Error = CodecError;
    fn encode(
        &mut self,
        (name, value): (&'a str, i32),
        dst: &mut BytesMut,
    ) -> Result<(), CodecError> {
        encode_var_reply(name, value, dst)?;
        Ok(())
    }
}

/// ASCII float tuples: encodes what a server sends for `socket_read_ascii_float` (with a
/// trailing LF if asked), and decodes tuples as the robot reads them.
///
/// ```
/// use bytes::BytesMut;
/// use tokio_util::codec::{Decoder, Encoder};
/// use urscript_socket::adapters::tokio::FloatTupleCodec;
/// let mut c = FloatTupleCodec::new(2).unwrap();
/// let mut buf = BytesMut::new();
/// c.encode(&[1.5, -2.0][..], &mut buf).unwrap();
/// assert_eq!(buf, &b"(1.5,-2)"[..]);
/// assert_eq!(c.decode(&mut buf).unwrap().unwrap().values(), [1.5, -2.0]);
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
    /// # use urscript_socket::adapters::tokio::FloatTupleCodec;
    /// assert!(FloatTupleCodec::new(31).is_err());
    /// ```
    pub fn new(number: usize) -> Result<Self, ArgumentError> {
        Ok(FloatTupleCodec {
            inner: FloatTupleDecoder::new(number)?,
            trailing_lf: false,
        })
    }

    /// Whether encoded tuples end with `\n`.
    ///
    /// ```
    /// # use urscript_socket::adapters::tokio::FloatTupleCodec;
    /// let c = FloatTupleCodec::new(6).unwrap().with_trailing_lf(true);
    /// ```
    pub fn with_trailing_lf(mut self, trailing_lf: bool) -> Self {
        self.trailing_lf = trailing_lf;
        self
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

impl<'a> codec::Encoder<&'a [f64]> for FloatTupleCodec {
    type Error = CodecError;
    fn encode(&mut self, item: &'a [f64], dst: &mut BytesMut) -> Result<(), CodecError> {
        encode_float_tuple(item, self.trailing_lf, dst)?;
        Ok(())
    }
}

/// One robot socket over a tokio `TcpStream`: the sans-IO robot model with real time.
/// Queue sends on [`socket`](Self::socket), then [`flush`](Self::flush); reads wait with
/// `tokio::time` and resolve to the URScript sentinel on timeout.
///
/// ```no_run
/// # async fn demo() -> Result<(), urscript_socket::robot::RobotError> {
/// use urscript_socket::adapters::tokio::AsyncRobotSocket;
/// use urscript_socket::robot::{Policy, ReadCall, Timeout};
/// let mut robot = AsyncRobotSocket::connect("127.0.0.1:30000", "socket_0", Policy::default()).await?;
/// robot.socket().send_line(b"shoot");
/// let pose = robot.read(ReadCall::AsciiFloat { number: 6 }, Timeout::default()).await?;
/// println!("{}", pose.to_urscript());
/// # Ok(()) }
/// ```
#[derive(Debug)]
pub struct AsyncRobotSocket {
    conn: SocketConnection,
    stream: TcpStream,
    /// Time zero of the machine's clock.
    epoch: ::tokio::time::Instant,
}

impl AsyncRobotSocket {
    /// `socket_open(address, port, socket_name)`.
    ///
    /// ```no_run
    /// # async fn demo() {
    /// # use urscript_socket::{adapters::tokio::AsyncRobotSocket, robot::Policy};
    /// let s = AsyncRobotSocket::connect("127.0.0.1:30000", "socket_0", Policy::default()).await;
    /// # }
    /// ```
    pub async fn connect(
        addr: impl ToSocketAddrs,
        socket_name: &str,
        policy: Policy,
    ) -> Result<Self, RobotError> {
        let stream = TcpStream::connect(addr).await.map_err(RobotError::Io)?;
        stream.set_nodelay(true).map_err(RobotError::Io)?;
        Ok(AsyncRobotSocket {
            conn: SocketConnection::new(socket_name, policy),
            stream,
            epoch: ::tokio::time::Instant::now(),
        })
    }

    /// The sans-IO socket: queue sends here (`send_line`, `send_int`, `set_var`...).
    ///
    /// ```no_run
    /// # async fn demo(robot: &mut urscript_socket::adapters::tokio::AsyncRobotSocket) {
    /// robot.socket().send_int(7);
    /// # }
    /// ```
    pub fn socket(&mut self) -> &mut SocketConnection {
        &mut self.conn
    }

    /// Writes everything queued. `Ok(false)` if the peer has gone: the socket is then
    /// broken for writing and later sends return false, as `socket_send_*` returns False
    /// on the controller.
    ///
    /// ```no_run
    /// # async fn demo(robot: &mut urscript_socket::adapters::tokio::AsyncRobotSocket) {
    /// robot.socket().send_line(b"go");
    /// assert!(robot.flush().await.unwrap());
    /// # }
    /// ```
    pub async fn flush(&mut self) -> Result<bool, RobotError> {
        let out: Vec<u8> = self.conn.take_outgoing();
        if !out.is_empty() && self.stream.write_all(&out).await.is_err() {
            self.conn.send_failed();
        }
        Ok(!self.conn.is_send_broken())
    }

    /// Runs a read call: sends what is queued (a `GET` for `GetVar`), then waits until the
    /// read completes, fails, the peer closes, or the timeout passes (the sentinel).
    ///
    /// ```no_run
    /// # async fn demo(robot: &mut urscript_socket::adapters::tokio::AsyncRobotSocket) {
    /// use urscript_socket::robot::{ReadCall, Timeout};
    /// let r = robot.read(ReadCall::Line, Timeout::from_secs_f64(0.5)).await.unwrap();
    /// # }
    /// ```
    pub async fn read(
        &mut self,
        call: ReadCall,
        timeout: Timeout,
    ) -> Result<ReadResult, RobotError> {
        self.conn.start_read(call, timeout, self.epoch.elapsed())?;
        self.flush().await?;
        loop {
            if let Some(r) = self.conn.poll_read() {
                return Ok(r);
            }
            if let Some(r) = self.conn.handle_timeout(self.epoch.elapsed()) {
                return Ok(r);
            }
            // A deadline past what the clock can represent is no deadline.
            let deadline = self
                .conn
                .poll_timeout()
                .and_then(|d| self.epoch.checked_add(d));
            let space = self.conn.receive_space();
            if space.is_empty() {
                // Full buffer, incomplete read: only the deadline ends it (a read with no
                // deadline already ended in poll_read).
                if let Some(d) = deadline {
                    ::tokio::time::sleep_until(d).await;
                }
                continue;
            }
            let read = self.stream.read(space);
            let n = match deadline {
                Some(d) => match ::tokio::time::timeout_at(d, read).await {
                    Ok(r) => r,
                    Err(_elapsed) => continue,
                },
                None => read.await,
            };
            match n {
                Ok(0) | Err(_) => self.conn.peer_closed(),
                Ok(n) => self.conn.commit_received(n),
            }
        }
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
