//! What a robot program asks for and gets: the read functions and their arguments, the
//! policy for what UR leaves open, timeouts and results.

use alloc::string::String;
use alloc::vec::Vec;
use core::fmt::{self, Write as _};
use core::time::Duration;

use crate::ascii_float::{FloatReadPolicy, FloatTuple};
use crate::format::{write_quoted, Format, Message};
use crate::to_str::{write_list, Scalar};

use super::DEFAULT_RECEIVE_CAPACITY;

/// What an int or byte read returns when it times out with some but not all of its bytes
/// buffered. Spec section 6 left this open; the default follows UR's text and the
/// programs that run on real arms: the manual says the first element is "the number of
/// bytes read" (of integers read), and Robotiq's gripper URCap asks
/// `socket_read_byte_list(17)` for a reply of a few bytes and uses that count.
///
/// ```
/// use urscript_socket::robot::ShortRead;
/// assert_eq!(ShortRead::default(), ShortRead::WholeValues);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ShortRead {
    /// `[0, -1, ...]`; the bytes stay buffered for the next read.
    Sentinel,
    /// `[k, v1..vk, -1, ...]` with the k whole values that arrived, which are consumed
    /// (default); an int32 read leaves a trailing part of a value buffered; with nothing
    /// at all, `[0, -1, ...]`.
    #[default]
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
/// | `short_read` | int/byte timeout with a partial message: the whole values that arrived, counted | `[0, -1...]`, bytes kept |
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
/// let p = Policy { short_read: ShortRead::Sentinel, ..Policy::default() };
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
            short_read: ShortRead::WholeValues,
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
        self.format().robot_function()
    }

    /// The wire format this read decodes.
    ///
    /// ```
    /// # use urscript_socket::{format::Format, robot::ReadCall};
    /// assert_eq!(ReadCall::AsciiFloat { number: 6 }.format(), Format::FloatTuple { number: 6 });
    /// ```
    pub fn format(&self) -> Format<'_> {
        match self {
            ReadCall::AsciiFloat { number } => Format::FloatTuple { number: *number },
            ReadCall::BinaryInteger { number } => Format::Int32 { number: *number },
            ReadCall::ByteList { number } => Format::Bytes { number: *number },
            ReadCall::Line => Format::Line,
            ReadCall::String {
                prefix,
                suffix,
                interpret_escape,
            } => Format::String {
                prefix,
                suffix,
                interpret_escape: *interpret_escape,
            },
            ReadCall::GetVar { name } => Format::VarReply { name },
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

    pub(crate) fn read(number: usize, got: impl Iterator<Item = i32>) -> Self {
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
    /// What the robot program gets for a complete message of its read's format.
    ///
    /// ```
    /// use urscript_socket::{format::Message, robot::ReadResult};
    /// assert_eq!(ReadResult::from_message(&Message::Bytes(&[2, 3])).to_urscript(), "[2, 2, 3]");
    /// ```
    pub fn from_message(message: &Message<'_>) -> Self {
        match message {
            Message::FloatTuple(t) => ReadResult::Floats(*t),
            Message::Int32(v) => ReadResult::Ints(IntList::read(v.len(), v.iter())),
            Message::Bytes(b) => {
                ReadResult::Ints(IntList::read(b.len(), b.iter().map(|&x| i32::from(x))))
            }
            Message::Text(t) => ReadResult::Text(t.to_vec()),
            Message::Var(_) | Message::Value(_) => {
                ReadResult::Text(alloc::format!("{message}").into_bytes())
            }
            Message::VarReply(v) => ReadResult::Int(*v),
        }
    }

    /// The value in URScript notation, by the robot's own `to_str` rules (the one text
    /// writer, [`to_str::write_value`](crate::to_str::write_value)): lists as
    /// `[4, 1.414, 3.14159, 1.616, 0]` (floats with at most 6 decimals, NaN as `nan`),
    /// strings quoted as a URScript literal would be written, with `\n`, `\r`, `\t`, `\\`,
    /// `\"` and `\xHH` escapes for display, ints in decimal.
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
            ReadResult::Floats(t) => write_list(
                core::iter::once(count(t.count()))
                    .chain(t.values().iter().map(|&v| Scalar::Float(v))),
                s,
            )?,
            ReadResult::Ints(l) => write_list(
                core::iter::once(count(l.count()))
                    .chain(l.values().iter().map(|&v| Scalar::Int(v))),
                s,
            )?,
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

/// A read's count (at most 30) as the first element of its URScript list.
fn count(n: usize) -> Scalar {
    Scalar::Int(i32::try_from(n).unwrap_or(i32::MAX))
}
