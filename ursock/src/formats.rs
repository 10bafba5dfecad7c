//! The formats `ursock` decodes and encodes: the clap spelling of the core's format
//! registry ([`urscript_socket::format`]) and the command-line grammar of values.

use clap::ValueEnum;
use urscript_socket::byte_list::{encode_byte, encode_byte_list};
use urscript_socket::format::{AnyDecoder, Format, Message};
use urscript_socket::int32::{encode_int32, encode_int32_list};
use urscript_socket::line::encode_line;
use urscript_socket::robot::ReadCall;
use urscript_socket::string::{encode_framed_string, encode_string};
use urscript_socket::stx_etx::encode_stx_etx;
use urscript_socket::to_str::{encode_value, parse_value};
use urscript_socket::var::{encode_get_var, encode_set_var, encode_var_reply};
use urscript_socket::{ascii_float::encode_float_tuple, DecodeError, RecvBuffer};

/// One name the command line gives a format: the name, its aliases, and the core
/// registry's name for the format it stands for ([`FORMAT_NAMES`](urscript_socket::format::FORMAT_NAMES); `None` for raw bytes
/// that no format frames: `hex`, `text`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Name {
    pub name: &'static str,
    pub aliases: &'static [&'static str],
    pub core: Option<&'static str>,
}

const fn name(name: &'static str, core: &'static str) -> Name {
    Name {
        name,
        aliases: &[],
        core: Some(core),
    }
}

/// The command line's format names, each table in the order `--help` and messages list
/// them. Every `core` is one of the core registry's [`FORMAT_NAMES`](urscript_socket::format::FORMAT_NAMES) (a unit test checks).
pub mod names {
    use super::{name, Name};

    /// What the robot sends, as `decode` and `listen --decode` name it.
    pub const DECODE: &[Name] = &[
        Name {
            aliases: &["int"],
            ..name("int32", "int32")
        },
        Name {
            aliases: &["bytes"],
            ..name("byte", "bytes")
        },
        name("line", "line"),
        name("stx-etx", "stx-etx"),
        Name {
            aliases: &["delimited"],
            ..name("delimiter", "delimited")
        },
        name("var", "var"),
        name("value", "value"),
    ];

    /// What a server sends: `encode`, and `listen`'s reply specs (which add `text`).
    pub const SERVER: &[Name] = &[
        name("floats", "float-tuple"),
        name("floats-lf", "float-tuple"),
        name("int32", "int32"),
        name("bytes", "bytes"),
        name("string", "string"),
        name("line", "line"),
        name("framed", "string"),
        name("var-reply", "var-reply"),
        Name {
            name: "hex",
            aliases: &[],
            core: None,
        },
    ];

    /// `listen`'s reply specs: the server's formats and `text` (escapes interpreted).
    pub const TEXT: Name = Name {
        name: "text",
        aliases: &[],
        core: None,
    };

    /// What the robot sends: `encode --robot`.
    pub const ROBOT: &[Name] = &[
        name("line", "line"),
        name("string", "delimited"),
        Name {
            aliases: &["bytes"],
            ..name("byte", "bytes")
        },
        Name {
            aliases: &["int32"],
            ..name("int", "int32")
        },
        name("set-var", "var"),
        name("get-var", "var"),
        name("stx-etx", "stx-etx"),
        name("value", "value"),
        Name {
            name: "hex",
            aliases: &[],
            core: None,
        },
    ];

    /// The robot's reads: `read`'s subcommands and `listen --robot-reads`.
    pub const READS: &[Name] = &[
        name("ascii-float", "float-tuple"),
        name("binary-integer", "int32"),
        name("byte-list", "bytes"),
        name("line", "line"),
        name("string", "string"),
    ];
}

/// The entry of `table` that `word` names (its name or an alias).
pub fn lookup(table: &'static [Name], word: &str) -> Option<&'static Name> {
    table
        .iter()
        .find(|n| n.name == word || n.aliases.contains(&word))
}

/// The names of `table`, for messages: `floats, floats-lf, int32`.
pub fn list(table: &[Name]) -> String {
    table.iter().map(|n| n.name).collect::<Vec<_>>().join(", ")
}

/// The robot read a [`names::READS`] name stands for, with its number of values (the
/// counted reads) or its prefix and suffix (`string`).
pub fn read_call(name: &Name, number: Option<usize>) -> Result<ReadCall, String> {
    let need = || number.ok_or_else(|| format!("{} needs the number of values", name.name));
    Ok(match name.core {
        Some("float-tuple") => ReadCall::AsciiFloat { number: need()? },
        Some("int32") => ReadCall::BinaryInteger { number: need()? },
        Some("bytes") => ReadCall::ByteList { number: need()? },
        Some("line") => ReadCall::Line,
        Some("string") => ReadCall::String {
            prefix: Vec::new(),
            suffix: Vec::new(),
            interpret_escape: false,
        },
        _ => return Err(format!("{}: not a read", name.name)),
    })
}

/// What the robot sends, as a server decodes it: the core's [`Format`]s named by
/// [`names::DECODE`] (one value per message for the counted ones).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DecodeFormat {
    /// Big-endian int32 (`socket_send_int`).
    Int32,
    /// Single bytes (`socket_send_byte`).
    Byte,
    /// LF-terminated lines (`socket_send_line`).
    Line,
    /// `02 <payload> 03` frames.
    StxEtx,
    /// Strings split on `--delimiter`.
    Delimiter,
    /// `SET name v` / `GET name` lines.
    Var,
    /// Lines holding the text of a number, bool, list or pose.
    Value,
}

impl ValueEnum for DecodeFormat {
    fn value_variants<'a>() -> &'a [Self] {
        use DecodeFormat::*;
        &[Int32, Byte, Line, StxEtx, Delimiter, Var, Value]
    }

    /// The name and aliases of [`names::DECODE`] for this variant's core format.
    fn to_possible_value(&self) -> Option<clap::builder::PossibleValue> {
        let core = self.format(b"\n").name();
        let n = names::DECODE.iter().find(|n| n.core == Some(core))?;
        let help = match self {
            DecodeFormat::Int32 => "Big-endian int32 (`socket_send_int`)",
            DecodeFormat::Byte => "Single bytes (`socket_send_byte`)",
            DecodeFormat::Line => "LF-terminated lines (`socket_send_line`)",
            DecodeFormat::StxEtx => "`02 <payload> 03` frames",
            DecodeFormat::Delimiter => "Strings split on `--delimiter`",
            DecodeFormat::Var => "`SET name v` / `GET name` lines",
            DecodeFormat::Value => "Lines holding the text of a number, bool, list or pose",
        };
        Some(
            clap::builder::PossibleValue::new(n.name)
                .aliases(n.aliases.iter().copied())
                .help(help),
        )
    }
}

impl DecodeFormat {
    /// The core format this name stands for; `delimiter` is `--delimiter`'s bytes.
    pub fn format(self, delimiter: &[u8]) -> Format<'_> {
        match self {
            DecodeFormat::Int32 => Format::Int32 { number: 1 },
            DecodeFormat::Byte => Format::Bytes { number: 1 },
            DecodeFormat::Line => Format::Line,
            DecodeFormat::StxEtx => Format::StxEtx,
            DecodeFormat::Delimiter => Format::Delimited { delimiter },
            DecodeFormat::Var => Format::Var,
            DecodeFormat::Value => Format::Value,
        }
    }

    /// The core's decoder for this format.
    pub fn decoder(self, delimiter: &[u8]) -> Result<AnyDecoder, String> {
        self.format(delimiter).decoder().map_err(|e| match self {
            DecodeFormat::Delimiter => format!("--delimiter: {e}"),
            _ => e.to_string(),
        })
    }

    /// What a text message of this format is called in output and JSON (`line`,
    /// `frame`, `string`).
    pub fn text_kind(self) -> &'static str {
        match self {
            DecodeFormat::StxEtx => "frame",
            DecodeFormat::Delimiter => "string",
            _ => "line",
        }
    }

    /// Whether a message of this format ends with a terminator (LF or the delimiter),
    /// so that input ending without one was cut off.
    pub fn terminated(self) -> bool {
        matches!(
            self,
            DecodeFormat::Line | DecodeFormat::Value | DecodeFormat::Var | DecodeFormat::Delimiter
        )
    }
}

/// `--delimiter`'s bytes, with the escapes of [`crate::typed::unescape`].
pub fn delimiter(s: &str) -> Result<Vec<u8>, String> {
    crate::typed::unescape(s).map_err(|e| format!("--delimiter: {e}"))
}

/// Decodes every complete message in `rx`, calling `on` for each message or error.
/// With `eof`, the end of input is applied afterwards (the core's `decode_eof`).
pub fn drain<S: AsRef<[u8]> + AsMut<[u8]>>(
    decoder: &mut AnyDecoder,
    rx: &mut RecvBuffer<S>,
    eof: bool,
    on: &mut dyn FnMut(Result<Message<'_>, DecodeError>),
) {
    loop {
        match rx.decode(decoder) {
            Ok(Some(m)) => on(Ok(m)),
            Ok(None) => break,
            Err(e) => on(Err(e)),
        }
    }
    if eof {
        match rx.decode_eof(decoder) {
            Ok(Some(m)) => on(Ok(m)),
            Ok(None) => {}
            Err(e) => on(Err(e)),
        }
    }
}

fn num<T: std::str::FromStr>(s: &str, what: &str) -> Result<T, String> {
    s.parse()
        .map_err(|_| format!("{s:?} is not a valid {what}"))
}

fn need(values: &[String], n: usize, usage: &str) -> Result<(), String> {
    if values.len() < n {
        return Err(format!("usage: {usage}"));
    }
    Ok(())
}

/// The text of the values, joined by spaces; with `escapes`, each one unescaped.
fn text(values: &[String], escapes: bool) -> Result<Vec<u8>, String> {
    let joined = values.join(" ");
    if escapes {
        crate::typed::unescape(&joined)
    } else {
        Ok(joined.into_bytes())
    }
}

fn one(value: &str, escapes: bool) -> Result<Vec<u8>, String> {
    text(std::slice::from_ref(&value.to_string()), escapes)
}

/// The values as numbers, `what` naming their kind in errors.
fn nums<T: std::str::FromStr>(values: &[String], what: &str) -> Result<Vec<T>, String> {
    values.iter().map(|s| num(s, what)).collect()
}

/// [`nums`] of a counted format, which needs at least one value.
fn counted<T: std::str::FromStr>(
    values: &[String],
    format: &str,
    what: &str,
) -> Result<Vec<T>, String> {
    if values.is_empty() {
        return Err(format!("{format}: at least one value is required"));
    }
    nums(values, what)
}

/// Which end of the connection sends what [`encode`] writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    /// The PC-side server: `floats`, `floats-lf`, `int32`, `bytes`, `string`, `line`,
    /// `framed PREFIX TEXT SUFFIX`, `var-reply NAME INT`, `hex HH...`.
    Server,
    /// The robot: `line`, `string`, `byte`, `int`, `set-var NAME INT`, `get-var NAME`,
    /// `stx-etx TEXT`, `value TEXT` (the `to_str` form of a number, bool, list or pose),
    /// `hex HH...`.
    Robot,
}

/// Encodes what a server sends (no escapes interpreted).
pub fn encode_server(format: &str, values: &[String]) -> Result<Vec<u8>, String> {
    encode(Side::Server, format, values, false)
}

/// Encodes what `side` sends in `format`; with `escapes`, `\r \n \t \0 \\ \xHH` are
/// interpreted in text values.
pub fn encode(
    side: Side,
    format: &str,
    values: &[String],
    escapes: bool,
) -> Result<Vec<u8>, String> {
    let (table, what) = match side {
        Side::Server => (names::SERVER, "format"),
        Side::Robot => (names::ROBOT, "robot format"),
    };
    let Some(entry) = lookup(table, format) else {
        return Err(format!("unknown {what} {format:?} ({})", list(table)));
    };
    let mut out = Vec::new();
    let r = match (side, entry.name) {
        (_, "hex") => return crate::typed::hex(values.iter().map(String::as_str)),
        (_, "line") => encode_line(&text(values, escapes)?, &mut out),
        (_, "string") => encode_string(&text(values, escapes)?, &mut out),
        (Side::Server, name @ ("floats" | "floats-lf")) => {
            encode_float_tuple(&nums(values, "float")?, name == "floats-lf", &mut out)
        }
        (Side::Server, "int32") => encode_int32_list(&counted(values, format, "int32")?, &mut out),
        (Side::Server, "bytes") => {
            encode_byte_list(&counted(values, format, "byte (0-255)")?, &mut out)
        }
        (Side::Server, "framed") => {
            need(values, 3, "framed PREFIX TEXT SUFFIX")?;
            encode_framed_string(
                &one(&values[0], escapes)?,
                &one(&values[1], escapes)?,
                &one(&values[2], escapes)?,
                &mut out,
            )
        }
        (Side::Server, "var-reply") => {
            need(values, 2, "var-reply NAME INT")?;
            encode_var_reply(&values[0], num(&values[1], "int32")?, &mut out)
        }

        // One socket_send_byte / socket_send_int per value.
        (Side::Robot, "byte") => counted(values, format, "byte (0-255)")?
            .into_iter()
            .try_fold(0, |n, v| Ok(n + encode_byte(v, &mut out)?)),
        (Side::Robot, "int") => counted(values, format, "int32")?
            .into_iter()
            .try_fold(0, |n, v| Ok(n + encode_int32(v, &mut out)?)),
        (Side::Robot, "set-var") => {
            need(values, 2, "set-var NAME INT")?;
            encode_set_var(&values[0], num(&values[1], "int32")?, &mut out)
        }
        (Side::Robot, "get-var") => {
            need(values, 1, "get-var NAME")?;
            encode_get_var(&values[0], &mut out)
        }
        (Side::Robot, "stx-etx") => encode_stx_etx(&text(values, escapes)?, &mut out),
        (Side::Robot, "value") => {
            let text = values.join(" ");
            let value = parse_value(text.as_bytes())
                .map_err(|e| format!("value {text:?}: {}", crate::messages::value_error(&e)))?;
            encode_value(&value, &mut out)
        }
        // A name in the table without an encoder here (a unit test checks there is none).
        (_, other) => return Err(format!("{other}: no encoder for this name")),
    };
    r.map_err(crate::messages::encode_error)?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use urscript_socket::format::FORMAT_NAMES;

    #[test]
    fn every_name_maps_onto_the_core_registry() {
        for table in [
            names::DECODE,
            names::SERVER,
            names::ROBOT,
            names::READS,
            &[names::TEXT],
        ] {
            for n in table {
                if let Some(core) = n.core {
                    assert!(FORMAT_NAMES.contains(&core), "{}: {core}", n.name);
                    assert_eq!(core.parse::<Format>().map(|f| f.name()), Ok(core));
                }
            }
        }
        for f in DecodeFormat::value_variants() {
            let v = f
                .to_possible_value()
                .expect("every decode format has a name");
            let n = lookup(names::DECODE, v.get_name()).unwrap();
            assert_eq!(n.core, Some(f.format(b"\n").name()));
        }
        assert_eq!(DecodeFormat::value_variants().len(), names::DECODE.len());
    }

    #[test]
    fn every_encode_name_has_an_encoder() {
        for (side, table) in [(Side::Server, names::SERVER), (Side::Robot, names::ROBOT)] {
            for n in table {
                for word in std::iter::once(&n.name).chain(n.aliases) {
                    let values: Vec<String> = ["1", "2", "3"].map(String::from).to_vec();
                    let r = encode(side, word, &values, false);
                    assert!(
                        !r.as_ref()
                            .is_err_and(|e| e.contains("no encoder") || e.contains("unknown")),
                        "{word}: {r:?}"
                    );
                }
            }
        }
        assert!(encode(Side::Server, "nope", &[], false)
            .unwrap_err()
            .contains("(floats, floats-lf, int32, bytes, string, line, framed, var-reply, hex)"));
    }

    #[test]
    fn reads_are_named_once() {
        let call = |w: &str, n| read_call(lookup(names::READS, w).unwrap(), n);
        assert_eq!(
            call("ascii-float", Some(3)),
            Ok(ReadCall::AsciiFloat { number: 3 })
        );
        assert_eq!(
            call("byte-list", Some(2)),
            Ok(ReadCall::ByteList { number: 2 })
        );
        assert!(call("binary-integer", None).is_err());
        assert_eq!(call("line", None), Ok(ReadCall::Line));
        for n in names::READS {
            let number = Some(1);
            let c = read_call(n, number).unwrap();
            assert_eq!(Some(c.format().name()), n.core, "{}", n.name);
        }
    }
}
