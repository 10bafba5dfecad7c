//! The robot's side: a sans-IO model of a UR controller's socket client, and (feature
//! `std`) a [`VirtualRobot`] that runs it over real TCP.
//!
//! The model follows quinn-proto's shape: it never reads a clock or a socket. The caller
//! feeds received bytes ([`SocketConnection::receive`]), starts a read
//! ([`SocketConnection::start_read`]), asks whether it completed
//! ([`SocketConnection::poll_read`]), learns how long the read may wait
//! ([`SocketConnection::pending_timeout`]) and reports that the moment came
//! ([`SocketConnection::handle_timeout`]), which resolves the read to its URScript
//! sentinel. Tests therefore control time completely.
//!
//! Every read is one of the core decoders over the connection's bounded receive buffer;
//! the choices the UR manuals leave open are the fields of [`Policy`].
//!
//! ```
//! use urscript_socket::robot::{Policy, ReadCall, SocketConnection};
//!
//! let mut socket = SocketConnection::new("socket_0", Policy::default());
//! socket.send_line(b"shoot");                       // socket_send_line("shoot")
//! assert_eq!(socket.take_outgoing(), b"shoot\n");
//!
//! socket.start_read(ReadCall::AsciiFloat { number: 6 }).unwrap();
//! socket.receive(b"(0.4,-0.2,0.3,");                // half a reply: still pending
//! assert!(socket.poll_read().is_none());
//! socket.receive(b"0,3.14,0)\n");
//! let pose = socket.poll_read().unwrap();
//! assert_eq!(pose.to_urscript(), "[6, 0.4, -0.2, 0.3, 0, 3.14, 0]");
//!
//! socket.start_read(ReadCall::AsciiFloat { number: 2 }).unwrap();
//! let timed_out = socket.handle_timeout().unwrap();  // nothing came within the timeout
//! assert_eq!(timed_out.to_urscript(), "[0, nan, nan]");
//! ```
//!
//! ## Testing a vision server against the virtual robot
//!
//! ```
//! # #[cfg(feature = "std")] {
//! use std::io::{Read, Write};
//! use std::net::TcpListener;
//! use urscript_socket::{ascii_float::encode_float_tuple, line::LineDecoder, RecvBuffer};
//! use urscript_socket::robot::{Policy, Timeout, VirtualRobot};
//!
//! // The server under test: answers each line with a pose.
//! let listener = TcpListener::bind("127.0.0.1:0").unwrap();
//! let addr = listener.local_addr().unwrap();
//! let server = std::thread::spawn(move || {
//!     let (mut robot, _) = listener.accept().unwrap();
//!     let (mut rx, mut lines) = (RecvBuffer::with_capacity(1024), LineDecoder::new());
//!     loop {
//!         let n = robot.read(rx.spare()).unwrap();
//!         if n == 0 { break; }
//!         rx.commit(n);
//!         while let Some(_request) = rx.decode(&mut lines).unwrap() {
//!             let mut reply = Vec::new();
//!             encode_float_tuple(&[0.4, -0.2, 0.3, 0.0, 3.14, 0.0], true, &mut reply).unwrap();
//!             robot.write_all(&reply).unwrap();
//!         }
//!     }
//! });
//!
//! // The robot program, step by step.
//! let mut robot = VirtualRobot::new(Policy::default());
//! assert!(robot.socket_open(addr, "camera").unwrap());
//! robot.socket_send_line(b"shoot", "camera").unwrap();
//! let pose = robot.socket_read_ascii_float(6, "camera", Timeout::from_secs_f64(2.0)).unwrap();
//! assert_eq!(pose.count(), 6);
//! assert_eq!(pose.values(), [0.4, -0.2, 0.3, 0.0, 3.14, 0.0]);
//! robot.socket_close("camera");
//! server.join().unwrap();
//! # }
//! ```

use alloc::boxed::Box;
use alloc::string::String;
use alloc::vec::Vec;
use core::fmt::{self, Write as _};
use core::time::Duration;

use crate::ascii_float::{FloatReadPolicy, FloatTuple, FloatTupleDecoder};
use crate::byte_list::ByteListDecoder;
use crate::int32::Int32Decoder;
use crate::line::LineDecoder;
use crate::string::ReadStringDecoder;
use crate::to_str::Value;
use crate::var::VarReplyDecoder;
use crate::{ArgumentError, DecodeError, Decoder, EncodeError, RecvBuffer};

#[cfg(feature = "std")]
mod virtual_robot;
#[cfg(feature = "std")]
pub use virtual_robot::{Direction, VirtualRobot};

/// The socket name URScript uses when none is given.
pub const DEFAULT_SOCKET_NAME: &str = "socket_0";

/// Default bound of each connection's receive buffer, in bytes. Bytes past it are not
/// accepted ([`SocketConnection::receive`] says how many were), as a full TCP window
/// would hold them back on a real controller.
pub const DEFAULT_RECEIVE_CAPACITY: usize = 64 * 1024;

/// What an int or byte read returns when it times out with some but not all of its bytes
/// buffered. Spec section 6.
///
/// ```
/// use urscript_socket::robot::ShortRead;
/// assert_eq!(ShortRead::default(), ShortRead::Sentinel);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ShortRead {
    /// `[0, -1, ...]`; the bytes stay buffered for the next read (default).
    #[default]
    Sentinel,
    /// `[k, v1..vk, -1, ...]` with the k whole values that arrived, which are consumed.
    WholeValues,
}

/// Every choice spec section 6 leaves open, with the project's defaults. A user who
/// learns how their controller really behaves changes a field here and nothing else.
///
/// | field | default | alternative |
/// |---|---|---|
/// | `float.leading_bytes` | bytes before `(` skipped | fail |
/// | `float.allow_exponent` | `1e-3` accepted | refused |
/// | `float.extra_values` | more values than `number`: failure | first `number` |
/// | `float.missing_values` | fewer: `[count, values, nan...]` | failure |
/// | `short_read` | int/byte timeout with a partial message: `[0, -1...]`, bytes kept | whole values |
/// | `receive_capacity` | 64 KiB per connection | any bound |
///
/// Fixed rules (not options): `number` outside 1..=30 is an error before any byte is
/// read; a malformed float tuple fails and is consumed through its `)`;
/// `socket_read_string` returns at most 1024 bytes and leaves the rest buffered; a prefix
/// or suffix not seen before the timeout gives `""` with the buffer unchanged; a peer
/// that closes resolves every pending read to its sentinel.
///
/// ```
/// use urscript_socket::robot::{Policy, ShortRead};
/// let p = Policy { short_read: ShortRead::WholeValues, ..Policy::default() };
/// assert_eq!(p.receive_capacity, 64 * 1024);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Policy {
    /// The ASCII float read's choices.
    pub float: FloatReadPolicy,
    /// Int/byte reads timing out with a partial message.
    pub short_read: ShortRead,
    /// Bound of each connection's receive buffer, in bytes (at least 1024 is sensible:
    /// `socket_read_string` returns up to 1024).
    pub receive_capacity: usize,
}

impl Default for Policy {
    fn default() -> Self {
        Policy {
            float: FloatReadPolicy::default(),
            short_read: ShortRead::Sentinel,
            receive_capacity: DEFAULT_RECEIVE_CAPACITY,
        }
    }
}

/// How long a read waits. URScript's `timeout` argument in seconds: 0 or negative waits
/// forever; the default is 2 s (`socket_get_var` always waits 2 s).
///
/// ```
/// use std::time::Duration;
/// use urscript_socket::robot::Timeout;
/// assert_eq!(Timeout::from_secs_f64(0.0), Timeout::Forever);
/// assert_eq!(Timeout::from_secs_f64(-1.0), Timeout::Forever);
/// assert_eq!(Timeout::default(), Timeout::After(Duration::from_secs(2)));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Timeout {
    /// Wait until the message is complete or the peer closes.
    Forever,
    /// Give up after this long and return the sentinel.
    After(Duration),
}

impl Timeout {
    /// URScript's `timeout=` seconds: 0, negative or NaN mean forever.
    ///
    /// ```
    /// # use urscript_socket::robot::Timeout;
    /// assert!(matches!(Timeout::from_secs_f64(0.5), Timeout::After(_)));
    /// ```
    pub fn from_secs_f64(secs: f64) -> Self {
        if secs > 0.0 {
            Duration::try_from_secs_f64(secs).map_or(Timeout::Forever, Timeout::After)
        } else {
            Timeout::Forever
        }
    }
}

impl Default for Timeout {
    fn default() -> Self {
        Timeout::After(Duration::from_secs(2))
    }
}

/// A URScript socket read function and its arguments.
///
/// ```
/// use urscript_socket::robot::ReadCall;
/// let call = ReadCall::String { prefix: b">".to_vec(), suffix: b"<".to_vec(), interpret_escape: false };
/// assert_eq!(call.function_name(), "socket_read_string");
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ReadCall {
    /// `socket_read_ascii_float(number)`.
    AsciiFloat {
        /// Values to read, 1..=30.
        number: usize,
    },
    /// `socket_read_binary_integer(number)`.
    BinaryInteger {
        /// Values to read, 1..=30.
        number: usize,
    },
    /// `socket_read_byte_list(number)`.
    ByteList {
        /// Bytes to read, 1..=30.
        number: usize,
    },
    /// `socket_read_line()`.
    Line,
    /// `socket_read_string(prefix, suffix, interpret_escape)`.
    String {
        /// The prefix argument, as written in the script.
        prefix: Vec<u8>,
        /// The suffix argument, as written in the script.
        suffix: Vec<u8>,
        /// Whether `\n`, `\t`, `\r` in prefix/suffix are interpreted.
        interpret_escape: bool,
    },
    /// `socket_get_var(name)`: sends `GET name\n`, reads `name int\n`.
    GetVar {
        /// Variable name.
        name: String,
    },
}

impl ReadCall {
    /// The URScript function this call stands for.
    ///
    /// ```
    /// # use urscript_socket::robot::ReadCall;
    /// assert_eq!(ReadCall::Line.function_name(), "socket_read_line");
    /// ```
    pub fn function_name(&self) -> &'static str {
        match self {
            ReadCall::AsciiFloat { .. } => "socket_read_ascii_float",
            ReadCall::BinaryInteger { .. } => "socket_read_binary_integer",
            ReadCall::ByteList { .. } => "socket_read_byte_list",
            ReadCall::Line => "socket_read_line",
            ReadCall::String { .. } => "socket_read_string",
            ReadCall::GetVar { .. } => "socket_get_var",
        }
    }

    /// The sentinel this read returns on timeout or failure.
    ///
    /// ```
    /// # use urscript_socket::robot::ReadCall;
    /// assert_eq!(ReadCall::ByteList { number: 2 }.sentinel().to_urscript(), "[0, -1, -1]");
    /// ```
    pub fn sentinel(&self) -> ReadResult {
        match self {
            ReadCall::AsciiFloat { number } => ReadResult::Floats(FloatTuple::failed(*number)),
            ReadCall::BinaryInteger { number } | ReadCall::ByteList { number } => {
                ReadResult::Ints(IntList::failed(*number))
            }
            ReadCall::Line | ReadCall::String { .. } => ReadResult::Text(Vec::new()),
            ReadCall::GetVar { .. } => ReadResult::Int(0),
        }
    }
}

/// `[count, v1, ..., vnumber]` of an int or byte read, the slots past `count` being -1.
///
/// ```
/// use urscript_socket::robot::IntList;
/// let l = IntList::failed(3);
/// assert_eq!((l.count(), l.values()), (0, &[-1, -1, -1][..]));
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct IntList {
    count: usize,
    values: Vec<i32>,
}

impl IntList {
    /// The timeout sentinel `[0, -1, ...]` for a read of `number` values.
    ///
    /// ```
    /// # use urscript_socket::robot::IntList;
    /// assert_eq!(IntList::failed(1).values(), [-1]);
    /// ```
    pub fn failed(number: usize) -> Self {
        IntList {
            count: 0,
            values: alloc::vec![-1; number],
        }
    }

    fn read(number: usize, got: impl Iterator<Item = i32>) -> Self {
        let mut l = IntList::failed(number);
        for (slot, v) in l.values.iter_mut().zip(got) {
            *slot = v;
            l.count += 1;
        }
        l
    }

    /// How many values were read: URScript's `result[0]`.
    ///
    /// ```
    /// # use urscript_socket::robot::IntList;
    /// assert_eq!(IntList::failed(2).count(), 0);
    /// ```
    pub fn count(&self) -> usize {
        self.count
    }

    /// The `number` value slots: URScript's `result[1..]`.
    ///
    /// ```
    /// # use urscript_socket::robot::IntList;
    /// assert_eq!(IntList::failed(2).values().len(), 2);
    /// ```
    pub fn values(&self) -> &[i32] {
        &self.values
    }
}

/// What a read function returned, as the robot program sees it.
///
/// ```
/// use urscript_socket::robot::ReadResult;
/// assert_eq!(ReadResult::Text(b"hi\n".to_vec()).to_urscript(), r#""hi\n""#);
/// assert_eq!(ReadResult::Int(1234).to_urscript(), "1234");
/// ```
// Returned by value once per read; boxing the float tuple would cost an allocation.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, PartialEq)]
pub enum ReadResult {
    /// `socket_read_ascii_float`: `[count, floats...]`.
    Floats(FloatTuple),
    /// `socket_read_binary_integer`, `socket_read_byte_list`: `[count, ints...]`.
    Ints(IntList),
    /// `socket_read_line`, `socket_read_string`: a string (`""` on timeout).
    Text(Vec<u8>),
    /// `socket_get_var`: an int (0 on timeout).
    Int(i32),
}

impl ReadResult {
    /// The value in URScript notation: lists as `[4, 1.414, 3.14159, 1.616, 0]` (floats
    /// in shortest round-trip form, NaN as `nan`), strings quoted with `\n`, `\r`, `\t`,
    /// `\\`, `\"` and `\xHH` escapes, ints in decimal.
    ///
    /// ```
    /// use urscript_socket::{ascii_float::FloatTuple, robot::ReadResult};
    /// assert_eq!(ReadResult::Floats(FloatTuple::failed(1)).to_urscript(), "[0, nan]");
    /// ```
    pub fn to_urscript(&self) -> String {
        let mut s = String::new();
        // Writing into a String cannot fail.
        let _ = self.write_urscript(&mut s);
        s
    }

    fn write_urscript(&self, s: &mut String) -> fmt::Result {
        match self {
            ReadResult::Floats(t) => {
                write!(s, "[{}", t.count())?;
                for v in t.values() {
                    s.push_str(", ");
                    write_float(s, *v)?;
                }
                s.push(']');
            }
            ReadResult::Ints(l) => {
                write!(s, "[{}", l.count())?;
                for v in l.values() {
                    write!(s, ", {v}")?;
                }
                s.push(']');
            }
            ReadResult::Text(t) => write_quoted(s, t)?,
            ReadResult::Int(v) => write!(s, "{v}")?,
        }
        Ok(())
    }

    /// True if this is the call's timeout/failure sentinel (`count` 0, `""` or 0). As on
    /// the robot, an empty string or a 0 that really arrived look the same.
    ///
    /// ```
    /// # use urscript_socket::robot::{ReadCall, ReadResult};
    /// assert!(ReadCall::Line.sentinel().is_sentinel());
    /// ```
    pub fn is_sentinel(&self) -> bool {
        match self {
            ReadResult::Floats(t) => t.count() == 0,
            ReadResult::Ints(l) => l.count() == 0,
            ReadResult::Text(t) => t.is_empty(),
            ReadResult::Int(v) => *v == 0,
        }
    }
}

impl fmt::Display for ReadResult {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.to_urscript())
    }
}

/// Writes a float in shortest round-trip form (Rust's `{}`), NaN as `nan`, infinities as
/// `inf`/`-inf`.
pub(crate) fn write_float(s: &mut impl fmt::Write, v: f64) -> fmt::Result {
    if v.is_nan() {
        s.write_str("nan")
    } else if v.is_infinite() {
        s.write_str(if v > 0.0 { "inf" } else { "-inf" })
    } else {
        write!(s, "{v}")
    }
}

/// Writes `bytes` as a quoted string literal with `\n \r \t \\ \"` and `\xHH` escapes.
pub(crate) fn write_quoted(s: &mut impl fmt::Write, bytes: &[u8]) -> fmt::Result {
    s.write_char('"')?;
    for &b in bytes {
        match b {
            b'\n' => s.write_str("\\n")?,
            b'\r' => s.write_str("\\r")?,
            b'\t' => s.write_str("\\t")?,
            b'\\' => s.write_str("\\\\")?,
            b'"' => s.write_str("\\\"")?,
            0x20..=0x7E => s.write_char(b as char)?,
            _ => write!(s, "\\x{b:02X}")?,
        }
    }
    s.write_char('"')
}

/// A misuse of the emulated socket API, refused before any byte is read or sent.
///
/// ```
/// use urscript_socket::robot::{Policy, ReadCall, RobotError, SocketConnection};
/// let mut s = SocketConnection::new("socket_0", Policy::default());
/// assert!(matches!(
///     s.start_read(ReadCall::AsciiFloat { number: 31 }),
///     Err(RobotError::Argument(_))
/// ));
/// ```
#[derive(Debug)]
#[non_exhaustive]
pub enum RobotError {
    /// An argument the controller rejects (`number` outside 1..=30, a bad name...).
    Argument(ArgumentError),
    /// A value that cannot be sent (a variable name with a space...).
    Encode(EncodeError),
    /// A read was started while another one is pending on the same socket.
    ReadPending,
    /// No socket of that name is open.
    NotOpen(String),
    /// The transport failed (virtual robot only).
    #[cfg(feature = "std")]
    Io(std::io::Error),
}

impl fmt::Display for RobotError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RobotError::Argument(e) => write!(f, "invalid argument: {e}"),
            RobotError::Encode(e) => write!(f, "cannot send: {e}"),
            RobotError::ReadPending => f.write_str("a read is already pending on this socket"),
            RobotError::NotOpen(name) => write!(f, "no open socket named \"{name}\""),
            #[cfg(feature = "std")]
            RobotError::Io(e) => write!(f, "socket error: {e}"),
        }
    }
}

impl core::error::Error for RobotError {
    fn source(&self) -> Option<&(dyn core::error::Error + 'static)> {
        match self {
            RobotError::Argument(e) => Some(e),
            RobotError::Encode(e) => Some(e),
            #[cfg(feature = "std")]
            RobotError::Io(e) => Some(e),
            _ => None,
        }
    }
}

impl From<ArgumentError> for RobotError {
    fn from(e: ArgumentError) -> Self {
        RobotError::Argument(e)
    }
}

impl From<EncodeError> for RobotError {
    fn from(e: EncodeError) -> Self {
        RobotError::Encode(e)
    }
}

/// The decoder of the read in progress.
#[allow(clippy::large_enum_variant)]
#[derive(Debug)]
enum Reader {
    Float(FloatTupleDecoder),
    Int(Int32Decoder),
    Bytes(ByteListDecoder),
    Line(LineDecoder),
    Str(ReadStringDecoder),
    Var(VarReplyDecoder),
}

/// One socket of the robot (`socket_open(address, port, socket_name)`): its bounded
/// receive buffer, its outgoing bytes and the read in progress. Sans-IO: the caller moves
/// bytes and reports time.
///
/// ```
/// use urscript_socket::robot::{Policy, ReadCall, SocketConnection};
/// let mut s = SocketConnection::new("socket_0", Policy::default());
/// s.receive(b">hello<>world<");
/// let call = ReadCall::String { prefix: b">".to_vec(), suffix: b"<".to_vec(), interpret_escape: false };
/// s.start_read(call.clone()).unwrap();
/// assert_eq!(s.poll_read().unwrap().to_urscript(), "\"hello\"");
/// s.start_read(call).unwrap();
/// assert_eq!(s.poll_read().unwrap().to_urscript(), "\"world\"");
/// ```
#[derive(Debug)]
pub struct SocketConnection {
    name: String,
    policy: Policy,
    rx: RecvBuffer<Box<[u8]>>,
    tx: Vec<u8>,
    pending: Option<(ReadCall, Reader)>,
    peer_closed: bool,
    last_failure: Option<DecodeError>,
}

impl SocketConnection {
    /// A connected socket named `name` (URScript's `socket_name`).
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, SocketConnection};
    /// assert_eq!(SocketConnection::new("cam", Policy::default()).name(), "cam");
    /// ```
    pub fn new(name: &str, policy: Policy) -> Self {
        SocketConnection {
            name: String::from(name),
            policy,
            rx: RecvBuffer::with_capacity(policy.receive_capacity),
            tx: Vec::new(),
            pending: None,
            peer_closed: false,
            last_failure: None,
        }
    }

    /// The socket's name.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, SocketConnection};
    /// assert_eq!(SocketConnection::new("socket_0", Policy::default()).name(), "socket_0");
    /// ```
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The policy in force.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, SocketConnection};
    /// assert_eq!(*SocketConnection::new("s", Policy::default()).policy(), Policy::default());
    /// ```
    pub fn policy(&self) -> &Policy {
        &self.policy
    }

    /// Adds bytes that arrived from the server and returns how many were accepted (fewer
    /// when the receive buffer is full; the rest must be offered again later).
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, SocketConnection};
    /// let mut s = SocketConnection::new("s", Policy { receive_capacity: 4, ..Policy::default() });
    /// assert_eq!(s.receive(b"abcdef"), 4);
    /// ```
    pub fn receive(&mut self, bytes: &[u8]) -> usize {
        self.rx.extend(bytes)
    }

    /// Free space in the receive buffer, for a transport to read into; follow with
    /// [`commit_received`](Self::commit_received).
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, SocketConnection};
    /// let mut s = SocketConnection::new("s", Policy::default());
    /// s.receive_space()[..2].copy_from_slice(b"hi");
    /// s.commit_received(2);
    /// assert_eq!(s.buffered(), b"hi");
    /// ```
    pub fn receive_space(&mut self) -> &mut [u8] {
        self.rx.spare()
    }

    /// Marks `n` bytes of [`receive_space`](Self::receive_space) as received.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, SocketConnection};
    /// let mut s = SocketConnection::new("s", Policy::default());
    /// s.commit_received(0);
    /// assert!(s.buffered().is_empty());
    /// ```
    pub fn commit_received(&mut self, n: usize) {
        self.rx.commit(n);
    }

    /// The bytes received and not yet read: what the next read will see.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, SocketConnection};
    /// let mut s = SocketConnection::new("s", Policy::default());
    /// s.receive(b"ack");
    /// assert_eq!(s.buffered(), b"ack");
    /// ```
    pub fn buffered(&self) -> &[u8] {
        self.rx.data()
    }

    /// The server closed the connection: pending and later reads resolve to their
    /// sentinels once the buffered bytes do not complete them.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, ReadCall, SocketConnection};
    /// let mut s = SocketConnection::new("s", Policy::default());
    /// s.start_read(ReadCall::Line).unwrap();
    /// s.peer_closed();
    /// assert_eq!(s.poll_read().unwrap().to_urscript(), "\"\"");
    /// ```
    pub fn peer_closed(&mut self) {
        self.peer_closed = true;
    }

    /// True once [`peer_closed`](Self::peer_closed) was reported.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, SocketConnection};
    /// assert!(!SocketConnection::new("s", Policy::default()).is_peer_closed());
    /// ```
    pub fn is_peer_closed(&self) -> bool {
        self.peer_closed
    }

    /// Why the last read that failed on malformed bytes failed (the robot only shows the
    /// sentinel; the emulation can say what and where).
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, ReadCall, SocketConnection};
    /// use urscript_socket::ErrorKind;
    /// let mut s = SocketConnection::new("s", Policy::default());
    /// s.receive(b"(1,x)");
    /// s.start_read(ReadCall::AsciiFloat { number: 2 }).unwrap();
    /// assert_eq!(s.poll_read().unwrap().to_urscript(), "[0, nan, nan]");
    /// assert_eq!(s.last_failure().unwrap().kind(), ErrorKind::InvalidNumber);
    /// ```
    pub fn last_failure(&self) -> Option<DecodeError> {
        self.last_failure
    }

    /// The read in progress, if any.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, ReadCall, SocketConnection};
    /// let mut s = SocketConnection::new("s", Policy::default());
    /// s.start_read(ReadCall::Line).unwrap();
    /// assert_eq!(s.pending_read(), Some(&ReadCall::Line));
    /// ```
    pub fn pending_read(&self) -> Option<&ReadCall> {
        self.pending.as_ref().map(|(c, _)| c)
    }

    /// How long the pending read may wait: its `timeout` argument, except for
    /// `socket_get_var`, which always waits 2 s. `None` if no read is pending.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, ReadCall, SocketConnection, Timeout};
    /// let mut s = SocketConnection::new("s", Policy::default());
    /// s.start_read(ReadCall::GetVar { name: "X".into() }).unwrap();
    /// assert_eq!(s.pending_timeout(Timeout::Forever), Some(Timeout::default()));
    /// ```
    pub fn pending_timeout(&self, requested: Timeout) -> Option<Timeout> {
        match self.pending_read()? {
            ReadCall::GetVar { .. } => Some(Timeout::default()),
            _ => Some(requested),
        }
    }

    /// Starts a read. Arguments are checked first (`number` in 1..=30, names, pattern
    /// lengths); a refused call consumes nothing. `GetVar` queues `GET name\n` to the
    /// outgoing bytes.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, ReadCall, SocketConnection};
    /// let mut s = SocketConnection::new("s", Policy::default());
    /// s.start_read(ReadCall::GetVar { name: "POS_X".into() }).unwrap();
    /// assert_eq!(s.take_outgoing(), b"GET POS_X\n");
    /// ```
    pub fn start_read(&mut self, call: ReadCall) -> Result<(), RobotError> {
        if self.pending.is_some() {
            return Err(RobotError::ReadPending);
        }
        let reader = match &call {
            ReadCall::AsciiFloat { number } => {
                Reader::Float(FloatTupleDecoder::with_policy(*number, self.policy.float)?)
            }
            ReadCall::BinaryInteger { number } => Reader::Int(Int32Decoder::new(*number)?),
            ReadCall::ByteList { number } => Reader::Bytes(ByteListDecoder::new(*number)?),
            ReadCall::Line => Reader::Line(LineDecoder::new()),
            ReadCall::String {
                prefix,
                suffix,
                interpret_escape,
            } => Reader::Str(ReadStringDecoder::new(prefix, suffix, *interpret_escape)?),
            ReadCall::GetVar { name } => {
                let reader = VarReplyDecoder::new(name)?;
                crate::var::encode_get_var(name, &mut self.tx)?;
                Reader::Var(reader)
            }
        };
        self.pending = Some((call, reader));
        Ok(())
    }

    /// The pending read's result if the buffered bytes complete it (or the peer closed,
    /// or they make it fail); `None` while it must wait.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, ReadCall, SocketConnection};
    /// let mut s = SocketConnection::new("s", Policy::default());
    /// s.start_read(ReadCall::BinaryInteger { number: 1 }).unwrap();
    /// s.receive(&[0xFF, 0xFF]);
    /// assert!(s.poll_read().is_none());
    /// s.receive(&[0xFF, 0xFF]);
    /// assert_eq!(s.poll_read().unwrap().to_urscript(), "[1, -1]");
    /// ```
    pub fn poll_read(&mut self) -> Option<ReadResult> {
        let (call, reader) = self.pending.as_mut()?;
        let outcome = match reader {
            Reader::Float(d) => decode_with(&mut self.rx, d, |t| ReadResult::Floats(*t)),
            Reader::Int(d) => decode_with(&mut self.rx, d, |v| {
                ReadResult::Ints(IntList::read(v.len(), v.iter()))
            }),
            Reader::Bytes(d) => decode_with(&mut self.rx, d, |b| {
                ReadResult::Ints(IntList::read(b.len(), b.iter().map(|&x| i32::from(x))))
            }),
            Reader::Line(d) => decode_with(&mut self.rx, d, |l| ReadResult::Text(l.to_vec())),
            Reader::Str(d) => decode_with(&mut self.rx, d, |s| ReadResult::Text(s.to_vec())),
            Reader::Var(d) => decode_with(&mut self.rx, d, |v| ReadResult::Int(*v)),
        };
        let result = match outcome {
            Outcome::Done(r) => r,
            // A malformed message fails the read; its bytes are already dropped.
            Outcome::Failed(e) => {
                self.last_failure = Some(e);
                call.sentinel()
            }
            Outcome::Waiting if self.peer_closed => return self.handle_timeout(),
            Outcome::Waiting => return None,
        };
        self.pending = None;
        Some(result)
    }

    /// The pending read's deadline passed (or the caller gives up): the read ends with
    /// its sentinel (`[0, nan...]`, `[0, -1...]`, `""`, `0`), or, for int/byte reads
    /// under [`ShortRead::WholeValues`], with the whole values that arrived. A string read
    /// leaves the buffer unchanged. `None` if no read was pending.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, ReadCall, SocketConnection};
    /// let mut s = SocketConnection::new("s", Policy::default());
    /// s.receive(&[0, 0, 0, 7, 0]);
    /// s.start_read(ReadCall::BinaryInteger { number: 2 }).unwrap();
    /// assert!(s.poll_read().is_none());
    /// assert_eq!(s.handle_timeout().unwrap().to_urscript(), "[0, -1, -1]");
    /// assert_eq!(s.buffered().len(), 5); // the bytes stay for the next read
    /// ```
    pub fn handle_timeout(&mut self) -> Option<ReadResult> {
        let (call, mut reader) = self.pending.take()?;
        if self.policy.short_read == ShortRead::WholeValues {
            let number = match call {
                ReadCall::BinaryInteger { number } | ReadCall::ByteList { number } => number,
                _ => 0,
            };
            let data = self.rx.data();
            let taken = match &mut reader {
                Reader::Int(d) => d
                    .take_partial(data)
                    .map(|(v, n)| (IntList::read(number, v.iter()), n)),
                Reader::Bytes(d) => d
                    .take_partial(data)
                    .map(|(b, n)| (IntList::read(number, b.iter().map(|&x| i32::from(x))), n)),
                _ => None,
            };
            if let Some((list, used)) = taken {
                self.rx.consume(used);
                return Some(ReadResult::Ints(list));
            }
        }
        Some(call.sentinel())
    }

    /// Queues `text` unchanged: `socket_send_string(text)`.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, SocketConnection};
    /// let mut s = SocketConnection::new("s", Policy::default());
    /// s.send_string(b"hi");
    /// assert_eq!(s.take_outgoing(), b"hi");
    /// ```
    pub fn send_string(&mut self, text: &[u8]) {
        self.tx.extend_from_slice(text);
    }

    /// Queues `text` and a LF: `socket_send_line(text)`. The bytes of `text` go out as
    /// they are (URScript does not check them).
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, SocketConnection};
    /// let mut s = SocketConnection::new("s", Policy::default());
    /// s.send_line(b"hello");
    /// assert_eq!(s.take_outgoing(), [0x68, 0x65, 0x6C, 0x6C, 0x6F, 0x0A]);
    /// ```
    pub fn send_line(&mut self, text: &[u8]) {
        self.tx.extend_from_slice(text);
        self.tx.push(b'\n');
    }

    /// Queues the `to_str` text of a number, bool, list or pose:
    /// `socket_send_string(value)`, or with `line` `socket_send_line(value)`.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, SocketConnection};
    /// use urscript_socket::to_str::Value;
    /// let mut s = SocketConnection::new("s", Policy::default());
    /// s.send_value(&Value::Pose([1.0, 2.0, 3.0, 4.0, 5.0, 6.0]), false).unwrap();
    /// assert_eq!(s.take_outgoing(), b"p[1, 2, 3, 4, 5, 6]");
    /// ```
    pub fn send_value(&mut self, value: &Value<'_>, line: bool) -> Result<(), RobotError> {
        let mut text = Vec::new();
        crate::to_str::encode_value(value, &mut text)?;
        self.tx.extend_from_slice(&text);
        if line {
            self.tx.push(b'\n');
        }
        Ok(())
    }

    /// Queues one byte: `socket_send_byte(value)` (2 = STX, 3 = ETX, 10 = LF).
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, SocketConnection};
    /// let mut s = SocketConnection::new("s", Policy::default());
    /// s.send_byte(2);
    /// s.send_string(b"hi");
    /// s.send_byte(3);
    /// assert_eq!(s.take_outgoing(), [0x02, 0x68, 0x69, 0x03]);
    /// ```
    pub fn send_byte(&mut self, value: u8) {
        self.tx.push(value);
    }

    /// Queues a big-endian int32: `socket_send_int(value)`.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, SocketConnection};
    /// let mut s = SocketConnection::new("s", Policy::default());
    /// s.send_int(-1);
    /// assert_eq!(s.take_outgoing(), [0xFF; 4]);
    /// ```
    pub fn send_int(&mut self, value: i32) {
        self.tx.extend_from_slice(&value.to_be_bytes());
    }

    /// Queues `SET name value\n`: `socket_set_var(name, value)`.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, SocketConnection};
    /// let mut s = SocketConnection::new("s", Policy::default());
    /// s.set_var("POS_Y", 2200).unwrap();
    /// assert_eq!(s.take_outgoing(), b"SET POS_Y 2200\n");
    /// ```
    pub fn set_var(&mut self, name: &str, value: i32) -> Result<(), RobotError> {
        crate::var::encode_set_var(name, value, &mut self.tx)?;
        Ok(())
    }

    /// The bytes queued for the server so far (not yet taken).
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, SocketConnection};
    /// let mut s = SocketConnection::new("s", Policy::default());
    /// s.send_byte(10);
    /// assert_eq!(s.outgoing(), b"\n");
    /// ```
    pub fn outgoing(&self) -> &[u8] {
        &self.tx
    }

    /// Takes the bytes queued for the server, leaving the queue empty.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, SocketConnection};
    /// let mut s = SocketConnection::new("s", Policy::default());
    /// s.send_int(1);
    /// assert_eq!(s.take_outgoing().len(), 4);
    /// assert!(s.outgoing().is_empty());
    /// ```
    pub fn take_outgoing(&mut self) -> Vec<u8> {
        core::mem::take(&mut self.tx)
    }
}

#[allow(clippy::large_enum_variant)]
enum Outcome {
    Done(ReadResult),
    Failed(DecodeError),
    Waiting,
}

/// Runs `decoder` on the receive buffer and converts a complete item.
fn decode_with<D: Decoder>(
    rx: &mut RecvBuffer<Box<[u8]>>,
    decoder: &mut D,
    convert: impl FnOnce(&D::Item<'_>) -> ReadResult,
) -> Outcome {
    match rx.decode(decoder) {
        Ok(Some(item)) => Outcome::Done(convert(&item)),
        Ok(None) => Outcome::Waiting,
        Err(e) => Outcome::Failed(e),
    }
}

/// The robot's set of open sockets, by name (`socket_open(address, port, socket_name)`).
///
/// ```
/// use urscript_socket::robot::{Policy, Robot};
/// let mut robot = Robot::new(Policy::default());
/// robot.socket_open("camera").send_line(b"go");
/// assert_eq!(robot.socket("camera").unwrap().outgoing(), b"go\n");
/// robot.socket_close("camera");
/// assert!(robot.socket("camera").is_none());
/// ```
#[derive(Debug)]
pub struct Robot {
    policy: Policy,
    sockets: Vec<SocketConnection>,
}

impl Robot {
    /// A robot with no socket open.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, Robot};
    /// assert!(Robot::new(Policy::default()).socket("socket_0").is_none());
    /// ```
    pub fn new(policy: Policy) -> Self {
        Robot {
            policy,
            sockets: Vec::new(),
        }
    }

    /// Opens (or, as on the robot, re-opens afresh) the socket `name`.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, Robot, DEFAULT_SOCKET_NAME};
    /// let mut robot = Robot::new(Policy::default());
    /// assert_eq!(robot.socket_open(DEFAULT_SOCKET_NAME).name(), "socket_0");
    /// ```
    pub fn socket_open(&mut self, name: &str) -> &mut SocketConnection {
        self.sockets.retain(|s| s.name() != name);
        self.sockets.push(SocketConnection::new(name, self.policy));
        let last = self.sockets.len() - 1;
        &mut self.sockets[last]
    }

    /// The open socket `name`.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, Robot};
    /// let mut robot = Robot::new(Policy::default());
    /// robot.socket_open("a");
    /// assert!(robot.socket("a").is_some());
    /// ```
    pub fn socket(&mut self, name: &str) -> Option<&mut SocketConnection> {
        self.sockets.iter_mut().find(|s| s.name() == name)
    }

    /// Closes the socket `name`; returns whether it was open.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, Robot};
    /// let mut robot = Robot::new(Policy::default());
    /// assert!(!robot.socket_close("a"));
    /// ```
    pub fn socket_close(&mut self, name: &str) -> bool {
        let before = self.sockets.len();
        self.sockets.retain(|s| s.name() != name);
        before != self.sockets.len()
    }
}
