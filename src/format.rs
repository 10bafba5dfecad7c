//! The format registry: every byte format of URScript's socket functions named once
//! ([`Format`]), one run-time decoder over all of them ([`AnyDecoder`]) and one message
//! type ([`Message`]).
//!
//! The robot emulation, the tokio codecs and the `ursock` tool are thin maps over this
//! module: a new format touches its own file and this registry, nothing else.
//!
//! ```
//! use urscript_socket::format::{Format, Message};
//! use urscript_socket::{Decode, RecvBuffer};
//!
//! // A server that lets its user pick the format at run time.
//! let format: Format = "var".parse().unwrap();
//! let mut decoder = format.decoder().unwrap();
//! let mut rx = RecvBuffer::<[u8; 64]>::new();
//! rx.extend(b"SET POS_Y 2200\nGET POS_Y\n");
//! let mut seen = Vec::new();
//! while let Some(message) = rx.decode(&mut decoder).unwrap() {
//!     seen.push(message.to_string());
//! }
//! assert_eq!(seen, ["SET POS_Y 2200", "GET POS_Y"]);
//! ```

use core::fmt;

use crate::ascii_float::{FloatReadPolicy, FloatTuple, FloatTupleDecoder};
use crate::byte_list::ByteListDecoder;
use crate::int32::{Int32Decoder, Int32Values};
use crate::line::LineDecoder;
use crate::string::{DelimitedDecoder, ReadStringDecoder};
use crate::stx_etx::StxEtxDecoder;
use crate::to_str::{write_list, Scalar, Value, ValueLineDecoder};
use crate::var::{VarMessage, VarMessageDecoder, VarReplyDecoder};
use crate::{ArgumentError, Decode, DecodeError, Status};

/// The most values one read or message of a counted format holds: the controller's
/// limit for `socket_read_ascii_float`, `socket_read_binary_integer` and
/// `socket_read_byte_list` (`number` in 1..=30). The crate's one
/// `MAX_VALUES`, re-exported here.
pub use crate::MAX_VALUES;

/// Every format on the wire between a UR robot and its server, with its parameters.
///
/// | format | robot side | wire |
/// |---|---|---|
/// | `FloatTuple { number }` | `socket_read_ascii_float(number)` | `(1.5,2,-3)` |
/// | `Int32 { number }` | `socket_send_int`, `socket_read_binary_integer(number)` | big-endian int32 |
/// | `Bytes { number }` | `socket_send_byte`, `socket_read_byte_list(number)` | raw bytes |
/// | `Line` | `socket_send_line`, `socket_read_line()` | `text\n` (`\r\n` read too) |
/// | `String { prefix, suffix, .. }` | `socket_read_string(prefix, suffix)` | `<prefix>text<suffix>` |
/// | `Delimited { delimiter }` | bare `socket_send_string` traffic | text up to a delimiter |
/// | `StxEtx` | `socket_send_byte(2)`, string, `socket_send_byte(3)` | `02 text 03` |
/// | `Var` | `socket_set_var`, `socket_get_var` | `SET name v\n`, `GET name\n` |
/// | `VarReply { name }` | the reply `socket_get_var(name)` reads | `name v\n` |
/// | `Value` | `socket_send_line(value)` of a number, list or pose | `p[1, 2, 3, 0, 0, 0]\n` |
///
/// ```
/// use urscript_socket::format::Format;
/// let f = Format::FloatTuple { number: 6 };
/// assert_eq!(f.name(), "float-tuple");
/// assert_eq!(f.robot_function(), "socket_read_ascii_float");
/// assert_eq!("line".parse::<Format>().unwrap(), Format::Line);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Format<'a> {
    /// Parenthesised ASCII floats, as `socket_read_ascii_float(number)` reads them.
    FloatTuple {
        /// Values per tuple, 1..=[`MAX_VALUES`].
        number: usize,
    },
    /// Big-endian int32 values, `number` per message.
    Int32 {
        /// Values per message, 1..=[`MAX_VALUES`].
        number: usize,
    },
    /// Raw bytes, `number` per message.
    Bytes {
        /// Bytes per message, 1..=[`MAX_VALUES`].
        number: usize,
    },
    /// LF-terminated lines (a CR before the LF is dropped).
    Line,
    /// `socket_read_string`'s prefix/suffix window.
    String {
        /// The prefix argument as written in the script.
        prefix: &'a [u8],
        /// The suffix argument as written in the script.
        suffix: &'a [u8],
        /// Whether `\n`, `\t`, `\r` written in prefix/suffix are interpreted.
        interpret_escape: bool,
    },
    /// Strings up to a delimiter of the server's choice.
    Delimited {
        /// The delimiter, 1 to 64 bytes.
        delimiter: &'a [u8],
    },
    /// `02 <payload> 03` frames.
    StxEtx,
    /// `SET name v` / `GET name` lines from the robot.
    Var,
    /// The `name v` reply that `socket_get_var(name)` reads.
    VarReply {
        /// The variable asked for.
        name: &'a str,
    },
    /// Lines holding the `to_str` text of a number, bool, list or pose.
    Value,
}

/// The names [`Format::name`] gives and [`str::parse`] takes, in table order.
pub const FORMAT_NAMES: [&str; 10] = [
    "float-tuple",
    "int32",
    "bytes",
    "line",
    "string",
    "delimited",
    "stx-etx",
    "var",
    "var-reply",
    "value",
];

impl Format<'_> {
    /// The format's short name (`float-tuple`, `int32`, `line`...).
    ///
    /// ```
    /// # use urscript_socket::format::Format;
    /// assert_eq!(Format::StxEtx.name(), "stx-etx");
    /// ```
    pub fn name(&self) -> &'static str {
        FORMAT_NAMES[self.index()]
    }

    fn index(&self) -> usize {
        match self {
            Format::FloatTuple { .. } => 0,
            Format::Int32 { .. } => 1,
            Format::Bytes { .. } => 2,
            Format::Line => 3,
            Format::String { .. } => 4,
            Format::Delimited { .. } => 5,
            Format::StxEtx => 6,
            Format::Var => 7,
            Format::VarReply { .. } => 8,
            Format::Value => 9,
        }
    }

    /// The URScript function on the robot's side of this format.
    ///
    /// ```
    /// # use urscript_socket::format::Format;
    /// assert_eq!(Format::Int32 { number: 1 }.robot_function(), "socket_read_binary_integer");
    /// assert_eq!(Format::Var.robot_function(), "socket_set_var");
    /// ```
    pub fn robot_function(&self) -> &'static str {
        match self {
            Format::FloatTuple { .. } => "socket_read_ascii_float",
            Format::Int32 { .. } => "socket_read_binary_integer",
            Format::Bytes { .. } => "socket_read_byte_list",
            Format::Line => "socket_read_line",
            Format::String { .. } => "socket_read_string",
            Format::Delimited { .. } => "socket_send_string",
            Format::StxEtx => "socket_send_byte",
            Format::Var => "socket_set_var",
            Format::VarReply { .. } => "socket_get_var",
            Format::Value => "socket_send_line",
        }
    }

    /// A decoder for this format with the default bounds and float policy.
    /// Errors: a `number` outside 1..=[`MAX_VALUES`], a bad delimiter, prefix or name.
    ///
    /// ```
    /// # use urscript_socket::format::Format;
    /// assert!(Format::Int32 { number: 31 }.decoder().is_err());
    /// assert!(Format::Line.decoder().is_ok());
    /// ```
    pub fn decoder(&self) -> Result<AnyDecoder, ArgumentError> {
        self.decoder_with(FloatReadPolicy::default())
    }

    /// A decoder for this format; `float` rules float tuples (the robot's read policy).
    ///
    /// ```
    /// # use urscript_socket::{ascii_float::FloatReadPolicy, format::Format};
    /// let d = Format::FloatTuple { number: 2 }.decoder_with(FloatReadPolicy::default());
    /// assert!(d.is_ok());
    /// ```
    pub fn decoder_with(&self, float: FloatReadPolicy) -> Result<AnyDecoder, ArgumentError> {
        Ok(AnyDecoder(match *self {
            Format::FloatTuple { number } => {
                Inner::FloatTuple(FloatTupleDecoder::with_policy(number, float)?)
            }
            Format::Int32 { number } => Inner::Int32(Int32Decoder::new(number)?),
            Format::Bytes { number } => Inner::Bytes(ByteListDecoder::new(number)?),
            Format::Line => Inner::Line(LineDecoder::new()),
            Format::String {
                prefix,
                suffix,
                interpret_escape,
            } => Inner::String(ReadStringDecoder::new(prefix, suffix, interpret_escape)?),
            Format::Delimited { delimiter } => Inner::Delimited(DelimitedDecoder::new(delimiter)?),
            Format::StxEtx => Inner::StxEtx(StxEtxDecoder::new()),
            Format::Var => Inner::Var(VarMessageDecoder::new()),
            Format::VarReply { name } => Inner::VarReply(VarReplyDecoder::new(name)?),
            Format::Value => Inner::Value(ValueLineDecoder::new()),
        }))
    }
}

impl fmt::Display for Format<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A format name [`str::parse`] did not know; lists the names it knows.
///
/// ```
/// use urscript_socket::format::Format;
/// let e = "floats".parse::<Format>().unwrap_err();
/// assert!(e.to_string().contains("float-tuple"));
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UnknownFormat;

impl fmt::Display for UnknownFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("unknown format; known: ")?;
        for (i, n) in FORMAT_NAMES.iter().enumerate() {
            if i > 0 {
                f.write_str(", ")?;
            }
            f.write_str(n)?;
        }
        Ok(())
    }
}

impl core::error::Error for UnknownFormat {}

impl core::str::FromStr for Format<'static> {
    type Err = UnknownFormat;

    /// A format by name, with the parameters a name alone can give: one value per
    /// message for counted formats, LF as the delimiter, no prefix or suffix, and the
    /// name `"x"` for `var-reply` (build those with their fields for anything else).
    fn from_str(s: &str) -> Result<Self, UnknownFormat> {
        Ok(match s {
            "float-tuple" => Format::FloatTuple { number: 1 },
            "int32" => Format::Int32 { number: 1 },
            "bytes" => Format::Bytes { number: 1 },
            "line" => Format::Line,
            "string" => Format::String {
                prefix: b"",
                suffix: b"",
                interpret_escape: false,
            },
            "delimited" => Format::Delimited { delimiter: b"\n" },
            "stx-etx" => Format::StxEtx,
            "var" => Format::Var,
            "var-reply" => Format::VarReply { name: "x" },
            "value" => Format::Value,
            _ => return Err(UnknownFormat),
        })
    }
}

/// One complete message of any format, borrowing the receive buffer where it can.
///
/// `Display` writes it in URScript notation, by the robot's own `to_str` rules
/// (`[2, 1.5, -3]`, `"text"`, `SET X 5`, `p[1, 2, 3, 0, 0, 0]`).
///
/// ```
/// use urscript_socket::format::Message;
/// assert_eq!(Message::Text(b"hi\r").to_string(), r#""hi\r""#);
/// assert_eq!(Message::Bytes(&[2, 65]).to_string(), "[2, 65]");
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum Message<'a> {
    /// A float tuple (`[count, values...]` on the robot).
    FloatTuple(FloatTuple),
    /// Big-endian int32 values.
    Int32(Int32Values<'a>),
    /// Raw bytes.
    Bytes(&'a [u8]),
    /// A line, a string read, a delimited string or an STX/ETX payload.
    Text(&'a [u8]),
    /// A `SET` or `GET` from the robot.
    Var(VarMessage<'a>),
    /// The value of a `socket_get_var` reply.
    VarReply(i32),
    /// The value a `to_str` text line holds.
    Value(Value<'a>),
}

impl fmt::Display for Message<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Message::FloatTuple(t) => write_list(
                core::iter::once(Scalar::Int(count(t.count())))
                    .chain(t.values().iter().map(|&v| Scalar::Float(v))),
                f,
            ),
            Message::Int32(v) => {
                write_list((0..v.len()).filter_map(|i| v.get(i)).map(Scalar::Int), f)
            }
            Message::Bytes(b) => write_list(b.iter().map(|&b| Scalar::Int(i32::from(b))), f),
            Message::Text(t) => write_quoted(f, t),
            Message::Var(VarMessage::Set { name, value }) => write!(f, "SET {name} {value}"),
            Message::Var(VarMessage::Get { name }) => write!(f, "GET {name}"),
            Message::VarReply(v) => write!(f, "{v}"),
            Message::Value(v) => write!(f, "{v}"),
        }
    }
}

/// A [`Message`] that owns its data (feature `alloc`): what an adapter hands out when
/// the receive buffer moves on.
///
/// ```
/// use urscript_socket::format::{Format, Message, OwnedMessage};
/// use urscript_socket::Decode;
/// let mut d = Format::Var.decoder().unwrap();
/// let m = d.decode(b"SET X 5\n").unwrap().item().unwrap();
/// let owned = OwnedMessage::from(&m);
/// assert_eq!(owned, OwnedMessage::Set { name: "X".into(), value: 5 });
/// assert_eq!(owned.to_string(), "SET X 5");
/// ```
#[cfg(feature = "alloc")]
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum OwnedMessage {
    /// A float tuple.
    FloatTuple(FloatTuple),
    /// Big-endian int32 values.
    Int32(alloc::vec::Vec<i32>),
    /// Raw bytes.
    Bytes(alloc::vec::Vec<u8>),
    /// A line, a string read, a delimited string or an STX/ETX payload.
    Text(alloc::vec::Vec<u8>),
    /// `SET name value`.
    Set {
        /// Variable name.
        name: alloc::string::String,
        /// Its new value.
        value: i32,
    },
    /// `GET name`.
    Get {
        /// Variable name.
        name: alloc::string::String,
    },
    /// The value of a `socket_get_var` reply.
    VarReply(i32),
    /// A `to_str` value: a scalar, a pose or a list.
    Value(OwnedValue),
}

/// The owned form of a [`Value`] (feature `alloc`).
#[cfg(feature = "alloc")]
#[derive(Debug, Clone, PartialEq)]
pub enum OwnedValue {
    /// A number or bool.
    Scalar(Scalar),
    /// `p[x, y, z, rx, ry, rz]`.
    Pose([f64; 6]),
    /// `[a, b, ...]`.
    List(alloc::vec::Vec<Scalar>),
}

#[cfg(feature = "alloc")]
impl From<&Message<'_>> for OwnedMessage {
    fn from(m: &Message<'_>) -> Self {
        match *m {
            Message::FloatTuple(t) => OwnedMessage::FloatTuple(t),
            Message::Int32(v) => OwnedMessage::Int32(v.iter().collect()),
            Message::Bytes(b) => OwnedMessage::Bytes(b.to_vec()),
            Message::Text(t) => OwnedMessage::Text(t.to_vec()),
            Message::Var(VarMessage::Set { name, value }) => OwnedMessage::Set {
                name: name.into(),
                value,
            },
            Message::Var(VarMessage::Get { name }) => OwnedMessage::Get { name: name.into() },
            Message::VarReply(v) => OwnedMessage::VarReply(v),
            Message::Value(Value::Scalar(s)) => OwnedMessage::Value(OwnedValue::Scalar(s)),
            Message::Value(Value::Pose(p)) => OwnedMessage::Value(OwnedValue::Pose(p)),
            Message::Value(Value::List(l)) => {
                OwnedMessage::Value(OwnedValue::List(l.iter().collect()))
            }
        }
    }
}

/// Written as the borrowed [`Message`] is (`[2, 1.5, -3]`, `"text"`, `SET X 5`).
#[cfg(feature = "alloc")]
impl fmt::Display for OwnedMessage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let m = match self {
            OwnedMessage::Int32(v) => return write_list(v.iter().map(|&v| Scalar::Int(v)), f),
            OwnedMessage::FloatTuple(t) => Message::FloatTuple(*t),
            OwnedMessage::Bytes(b) => Message::Bytes(b),
            OwnedMessage::Text(t) => Message::Text(t),
            OwnedMessage::Set { name, value } => Message::Var(VarMessage::Set {
                name,
                value: *value,
            }),
            OwnedMessage::Get { name } => Message::Var(VarMessage::Get { name }),
            OwnedMessage::VarReply(v) => Message::VarReply(*v),
            OwnedMessage::Value(OwnedValue::Scalar(s)) => Message::Value(Value::Scalar(*s)),
            OwnedMessage::Value(OwnedValue::Pose(p)) => Message::Value(Value::Pose(*p)),
            OwnedMessage::Value(OwnedValue::List(l)) => {
                Message::Value(Value::List(crate::to_str::List::from_items(l)))
            }
        };
        m.fmt(f)
    }
}

/// A count (at most 30) as a URScript int.
fn count(n: usize) -> i32 {
    i32::try_from(n).unwrap_or(i32::MAX)
}

/// Writes `bytes` as a quoted string literal with `\n \r \t \\ \"` and `\xHH` escapes:
/// the crate's one way to show text that may hold any byte.
///
/// ```
/// let mut s = String::new();
/// urscript_socket::format::write_quoted(&mut s, b"a\"\n\xE9").unwrap();
/// assert_eq!(s, r#""a\"\n\xE9""#);
/// ```
pub fn write_quoted(s: &mut impl fmt::Write, bytes: &[u8]) -> fmt::Result {
    s.write_char('"')?;
    for &b in bytes {
        match b {
            b'\n' => s.write_str("\\n")?,
            b'\r' => s.write_str("\\r")?,
            b'\t' => s.write_str("\\t")?,
            b'\\' => s.write_str("\\\\")?,
            b'"' => s.write_str("\\\"")?,
            0x20..=0x7E => s.write_char(char::from(b))?,
            _ => write!(s, "\\x{b:02X}")?,
        }
    }
    s.write_char('"')
}

/// A decoder of any [`Format`], chosen at run time: the one decoder the robot
/// emulation, the tokio codecs and the CLI drive when the format is data.
///
/// ```
/// use urscript_socket::format::{Format, Message};
/// use urscript_socket::Decode;
/// let mut d = Format::Value.decoder().unwrap();
/// let m = d.decode(b"p[1, 2, 3, 0, 0, 0.5]\n").unwrap().item().unwrap();
/// assert_eq!(m.to_string(), "p[1, 2, 3, 0, 0, 0.5]");
/// ```
#[derive(Debug, Clone)]
pub struct AnyDecoder(Inner);

/// The registry's one table of run-time decoders: each line names a variant of `Inner`,
/// the concrete decoder it holds and the [`Message`] its items become. The enum and the
/// whole [`Decode`] dispatch of [`AnyDecoder`] are generated from it, so a format is one
/// line here and every method matches over the same list (no allocation, no trait object).
macro_rules! any_decoder {
    ($($variant:ident($decoder:ty) => $message:path,)*) => {
        #[allow(clippy::large_enum_variant)]
        #[derive(Debug, Clone)]
        enum Inner {
            $($variant($decoder),)*
        }

        /// Runs `$body` with `$d` bound to the concrete decoder inside `$inner` and `$m`
        /// to the constructor of its [`Message`] variant.
        macro_rules! each {
            ($inner:expr, |$d:ident, $m:ident| $body:expr) => {
                match $inner {
                    $(Inner::$variant($d) => {
                        let $m = $message;
                        $body
                    })*
                }
            };
        }
    };
}

any_decoder! {
    FloatTuple(FloatTupleDecoder) => Message::FloatTuple,
    Int32(Int32Decoder) => Message::Int32,
    Bytes(ByteListDecoder) => Message::Bytes,
    Line(LineDecoder) => Message::Text,
    String(ReadStringDecoder) => Message::Text,
    Delimited(DelimitedDecoder) => Message::Text,
    StxEtx(StxEtxDecoder) => Message::Text,
    Var(VarMessageDecoder) => Message::Var,
    VarReply(VarReplyDecoder) => Message::VarReply,
    Value(ValueLineDecoder) => Message::Value,
}

impl AnyDecoder {
    /// The counted decoder inside (int32 or bytes), for the robot's short-read policy,
    /// which needs its partial state.
    #[cfg(feature = "alloc")]
    pub(crate) fn as_counted(&mut self) -> Counted<'_> {
        match &mut self.0 {
            Inner::Int32(d) => Counted::Int32(d),
            Inner::Bytes(d) => Counted::Bytes(d),
            _ => Counted::Other,
        }
    }

    /// A full receive buffer `buf` that holds no complete message: how many of its bytes a
    /// `socket_read_string` drops because they cannot begin its prefix (0 for every other
    /// format). The framer decides; see `Framer::drop_before_prefix`.
    #[cfg(feature = "alloc")]
    pub(crate) fn drop_before_prefix(&mut self, buf: &[u8]) -> usize {
        match &mut self.0 {
            Inner::String(d) => d.drop_before_prefix(buf),
            _ => 0,
        }
    }
}

/// The counted decoders, for the robot's short-read policy.
#[cfg(feature = "alloc")]
pub(crate) enum Counted<'d> {
    Int32(&'d mut Int32Decoder),
    Bytes(&'d mut ByteListDecoder),
    Other,
}

impl Decode for AnyDecoder {
    type Item<'buf> = Message<'buf>;

    fn decode<'buf>(&mut self, buf: &'buf [u8]) -> Result<Status<Message<'buf>>, DecodeError> {
        each!(&mut self.0, |d, message| d
            .decode(buf)
            .map(|s| s.map(message)))
    }

    fn decode_eof<'buf>(
        &mut self,
        buf: &'buf [u8],
    ) -> Result<Option<(Message<'buf>, usize)>, DecodeError> {
        each!(&mut self.0, |d, message| d
            .decode_eof(buf)
            .map(|o| o.map(|(item, n)| (message(item), n))))
    }

    fn overflow(&mut self, buf: &[u8]) -> Option<DecodeError> {
        each!(&mut self.0, |d, _message| d.overflow(buf))
    }

    fn position(&self) -> u64 {
        each!(&self.0, |d, _message| d.position())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use alloc::string::ToString;

    #[test]
    fn every_name_parses_back_to_its_format() {
        for name in FORMAT_NAMES {
            let f: Format = name.parse().unwrap();
            assert_eq!(f.name(), name);
            assert!(f.decoder().is_ok(), "{name}");
        }
    }

    /// `p[1,2,x,4,5,6]\r\n`: the bad token is at byte 6 of the stream, also when a CR
    /// ends the line and when earlier lines came first (the CLI once said byte 7).
    #[test]
    fn value_line_errors_point_at_the_bad_byte() {
        let mut d = Format::Value.decoder().unwrap();
        let e = d.decode(b"p[1,2,x,4,5,6]\r\n").unwrap_err();
        assert_eq!(e.offset(), 6);
        let mut d = Format::Value.decoder().unwrap();
        let first = d.decode(b"[1]\np[1,2,x]\n").unwrap();
        assert_eq!(first.consumed(), 4);
        let e = d.decode(b"p[1,2,x]\n[2]\n").unwrap_err();
        assert_eq!((e.offset(), e.skip()), (4 + 6, 9));
        // The bad line is dropped whole; the next one decodes.
        let next = d.decode(b"[2]\n").unwrap().item().unwrap();
        assert_eq!(next.to_string(), "[2]");
    }
}
