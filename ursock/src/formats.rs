//! The formats `ursock` decodes and encodes: the clap spelling of the core's format
//! registry ([`urscript_socket::format`]) and the command-line grammar of values.

use clap::ValueEnum;
use urscript_socket::byte_list::{encode_byte, encode_byte_list};
use urscript_socket::format::{AnyDecoder, Format, Message};
use urscript_socket::int32::{encode_int32, encode_int32_list};
use urscript_socket::line::encode_line;
use urscript_socket::string::{encode_framed_string, encode_string};
use urscript_socket::stx_etx::encode_stx_etx;
use urscript_socket::to_str::{encode_value, parse_value};
use urscript_socket::var::{encode_get_var, encode_set_var, encode_var_reply};
use urscript_socket::{ascii_float::encode_float_tuple, DecodeError, RecvBuffer};

/// What the robot sends, as a server decodes it: the command line's names for the
/// core's [`Format`]s (one value per message for the counted ones).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
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
    let mut out = Vec::new();
    let r = match (side, format) {
        (_, "hex") => return crate::typed::hex(values.iter().map(String::as_str)),
        (_, "line") => encode_line(&text(values, escapes)?, &mut out),
        (_, "string") => encode_string(&text(values, escapes)?, &mut out),
        (Side::Server, "floats" | "floats-lf") => {
            encode_float_tuple(&nums(values, "float")?, format == "floats-lf", &mut out)
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
        (Side::Server, other) => {
            return Err(format!(
                "unknown format {other:?} (floats, floats-lf, int32, bytes, string, line, framed, var-reply, hex)"
            ))
        }
        // One socket_send_byte / socket_send_int per value.
        (Side::Robot, "byte" | "bytes") => counted(values, format, "byte (0-255)")?
            .into_iter()
            .try_fold(0, |n, v| Ok(n + encode_byte(v, &mut out)?)),
        (Side::Robot, "int" | "int32") => counted(values, format, "int32")?
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
        (Side::Robot, other) => {
            return Err(format!(
                "unknown robot format {other:?} (line, string, byte, int, set-var, get-var, stx-etx, value, hex)"
            ))
        }
    };
    r.map_err(crate::messages::encode_error)?;
    Ok(out)
}
