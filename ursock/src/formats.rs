//! The formats `ursock` decodes and encodes, each mapped onto the library's core.

use clap::ValueEnum;
use urscript_socket::byte_list::{encode_byte, encode_byte_list, ByteListDecoder};
use urscript_socket::int32::{encode_int32, encode_int32_list, Int32Decoder};
use urscript_socket::line::{encode_line, LineDecoder};
use urscript_socket::string::{encode_framed_string, encode_string, DelimitedDecoder};
use urscript_socket::stx_etx::{encode_stx_etx, StxEtxDecoder};
use urscript_socket::to_str::{encode_value, parse_value};
use urscript_socket::var::{encode_get_var, encode_set_var, encode_var_reply, VarMessageDecoder};
use urscript_socket::{ascii_float::encode_float_tuple, DecodeError, RecvBuffer};

use crate::show::Message;

/// What the robot sends, as a server decodes it.
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

/// One core decoder, chosen at run time.
pub enum AnyDecoder {
    Int32(Int32Decoder),
    Byte(ByteListDecoder),
    Line(LineDecoder),
    StxEtx(StxEtxDecoder),
    Delimiter(DelimitedDecoder),
    Var(VarMessageDecoder),
    Value(LineDecoder),
}

impl AnyDecoder {
    pub fn new(format: DecodeFormat, delimiter: &[u8]) -> Result<Self, String> {
        Ok(match format {
            DecodeFormat::Int32 => {
                AnyDecoder::Int32(Int32Decoder::new(1).map_err(|e| e.to_string())?)
            }
            DecodeFormat::Byte => {
                AnyDecoder::Byte(ByteListDecoder::new(1).map_err(|e| e.to_string())?)
            }
            DecodeFormat::Line => AnyDecoder::Line(LineDecoder::new()),
            DecodeFormat::StxEtx => AnyDecoder::StxEtx(StxEtxDecoder::new()),
            DecodeFormat::Delimiter => AnyDecoder::Delimiter(
                DelimitedDecoder::new(delimiter).map_err(|e| format!("--delimiter: {e}"))?,
            ),
            DecodeFormat::Var => AnyDecoder::Var(VarMessageDecoder::new()),
            DecodeFormat::Value => AnyDecoder::Value(LineDecoder::new()),
        })
    }

    /// Decodes the next complete message in `rx`, if there is one.
    pub fn next<'b, S: AsRef<[u8]> + AsMut<[u8]>>(
        &mut self,
        rx: &'b mut RecvBuffer<S>,
    ) -> Result<Option<Message<'b>>, DecodeError> {
        Ok(match self {
            AnyDecoder::Int32(d) => rx.decode(d)?.map(|v| Message::Int(v.get(0).unwrap_or(0))),
            AnyDecoder::Byte(d) => rx
                .decode(d)?
                .map(|b| Message::Byte(b.first().copied().unwrap_or(0))),
            AnyDecoder::Line(d) => rx.decode(d)?.map(|l| Message::Text("line", l)),
            AnyDecoder::StxEtx(d) => rx.decode(d)?.map(|l| Message::Text("frame", l)),
            AnyDecoder::Delimiter(d) => rx.decode(d)?.map(|l| Message::Text("string", l)),
            AnyDecoder::Var(d) => rx.decode(d)?.map(Message::Var),
            AnyDecoder::Value(d) => match rx.decode(d)? {
                Some(line) => {
                    let end = d.position();
                    match parse_value(line) {
                        Ok(v) => Some(Message::Value(v)),
                        Err(e) => {
                            // Parse offsets are within the line; the line ended at `end`
                            // (its LF, and a CR if one was dropped, follow the text).
                            let line_start = end.saturating_sub(line.len() as u64 + 1);
                            return Err(DecodeError::new(e.kind(), line_start + e.offset(), 0));
                        }
                    }
                }
                None => None,
            },
        })
    }

    /// Decodes every complete message in `rx`, calling `on` for each message or error.
    /// With `eof`, the end of input is applied afterwards.
    pub fn drain<S: AsRef<[u8]> + AsMut<[u8]>>(
        &mut self,
        rx: &mut RecvBuffer<S>,
        eof: bool,
        on: &mut dyn FnMut(Result<Message<'_>, DecodeError>),
    ) {
        loop {
            match self.next(rx) {
                Ok(Some(m)) => on(Ok(m)),
                Ok(None) => break,
                Err(e) => on(Err(e)),
            }
        }
        if eof {
            let last = match self {
                AnyDecoder::Int32(d) => rx
                    .decode_eof(d)
                    .map(|m| m.map(|v| Message::Int(v.get(0).unwrap_or(0)))),
                AnyDecoder::Byte(d) => rx
                    .decode_eof(d)
                    .map(|m| m.map(|b| Message::Byte(b.first().copied().unwrap_or(0)))),
                AnyDecoder::Line(d) | AnyDecoder::Value(d) => rx
                    .decode_eof(d)
                    .map(|m| m.map(|l| Message::Text("line", l))),
                AnyDecoder::StxEtx(d) => rx
                    .decode_eof(d)
                    .map(|m| m.map(|l| Message::Text("frame", l))),
                AnyDecoder::Delimiter(d) => rx
                    .decode_eof(d)
                    .map(|m| m.map(|l| Message::Text("string", l))),
                AnyDecoder::Var(d) => rx.decode_eof(d).map(|m| m.map(Message::Var)),
            };
            match last {
                Ok(Some(m)) => on(Ok(m)),
                Ok(None) => {}
                Err(e) => on(Err(e)),
            }
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

/// `02 41 03`, `024103`, `0x02 0x41`: the bytes of hex tokens (pairs of hex digits,
/// spaces and `0x` optional).
pub fn parse_hex(values: &[String]) -> Result<Vec<u8>, String> {
    let mut out = Vec::new();
    for v in values {
        let digits = v
            .strip_prefix("0x")
            .or_else(|| v.strip_prefix("0X"))
            .unwrap_or(v);
        let digits: Vec<u8> = digits
            .bytes()
            .filter(|b| !matches!(b, b':' | b'-' | b','))
            .collect();
        if digits.is_empty() || digits.len() % 2 != 0 {
            return Err(format!(
                "{v:?} is not hex bytes (pairs of hex digits, like 02 41 03)"
            ));
        }
        for pair in digits.chunks(2) {
            let text = std::str::from_utf8(pair).unwrap_or("");
            out.push(u8::from_str_radix(text, 16).map_err(|_| {
                format!("{v:?} is not hex bytes (pairs of hex digits, like 02 41 03)")
            })?);
        }
    }
    if out.is_empty() {
        return Err("usage: hex HH HH ... (at least one byte, like 02 41 03)".into());
    }
    Ok(out)
}

/// Typed text with `\r \n \t \0 \\ \xHH` escapes interpreted (`--escapes`); an
/// unknown escape is an error rather than a guess.
pub fn unescape_text(s: &str) -> Result<Vec<u8>, String> {
    let mut out = Vec::new();
    let mut it = s.bytes();
    while let Some(b) = it.next() {
        if b != b'\\' {
            out.push(b);
            continue;
        }
        match it.next() {
            Some(b'n') => out.push(b'\n'),
            Some(b'r') => out.push(b'\r'),
            Some(b't') => out.push(b'\t'),
            Some(b'0') => out.push(0),
            Some(b'\\') => out.push(b'\\'),
            Some(b'x') => {
                let hi = it.next();
                let lo = it.next();
                let pair = [hi.unwrap_or(b'?'), lo.unwrap_or(b'?')];
                let v = std::str::from_utf8(&pair)
                    .ok()
                    .and_then(|t| u8::from_str_radix(t, 16).ok())
                    .ok_or_else(|| format!("{s:?}: \\x needs two hex digits"))?;
                out.push(v);
            }
            Some(other) => {
                return Err(format!(
                    "{s:?}: unknown escape \\{} (known: \\r \\n \\t \\0 \\\\ \\xHH)",
                    other as char
                ))
            }
            None => return Err(format!("{s:?}: a lone \\ at the end")),
        }
    }
    Ok(out)
}

/// The text of the values, joined by spaces; with `escapes`, each one unescaped.
fn text(values: &[String], escapes: bool) -> Result<Vec<u8>, String> {
    let joined = values.join(" ");
    if escapes {
        unescape_text(&joined)
    } else {
        Ok(joined.into_bytes())
    }
}

fn one(value: &str, escapes: bool) -> Result<Vec<u8>, String> {
    text(std::slice::from_ref(&value.to_string()), escapes)
}

fn at_least_one(values: &[String], format: &str) -> Result<(), String> {
    if values.is_empty() {
        return Err(format!("{format}: at least one value is required"));
    }
    Ok(())
}

/// Encodes what a server sends: `floats`, `int32`, `bytes`, `string`, `line`,
/// `framed PREFIX TEXT SUFFIX`, `var-reply NAME INT`, `hex HH...`.
pub fn encode_server(format: &str, values: &[String]) -> Result<Vec<u8>, String> {
    encode_server_with(format, values, false)
}

/// [`encode_server`], with `escapes` interpreted in text values.
pub fn encode_server_with(
    format: &str,
    values: &[String],
    escapes: bool,
) -> Result<Vec<u8>, String> {
    let mut out = Vec::new();
    let r = match format {
        "hex" => return parse_hex(values),
        "floats" => {
            let v: Vec<f64> = values.iter().map(|s| num(s, "float")).collect::<Result<_, _>>()?;
            encode_float_tuple(&v, false, &mut out)
        }
        "floats-lf" => {
            let v: Vec<f64> = values.iter().map(|s| num(s, "float")).collect::<Result<_, _>>()?;
            encode_float_tuple(&v, true, &mut out)
        }
        "int32" => {
            at_least_one(values, "int32")?;
            let v: Vec<i32> = values.iter().map(|s| num(s, "int32")).collect::<Result<_, _>>()?;
            encode_int32_list(&v, &mut out)
        }
        "bytes" => {
            at_least_one(values, "bytes")?;
            let v: Vec<u8> = values.iter().map(|s| num(s, "byte (0-255)")).collect::<Result<_, _>>()?;
            encode_byte_list(&v, &mut out)
        }
        "string" => encode_string(&text(values, escapes)?, &mut out),
        "line" => encode_line(&text(values, escapes)?, &mut out),
        "framed" => {
            need(values, 3, "framed PREFIX TEXT SUFFIX")?;
            encode_framed_string(
                &one(&values[0], escapes)?,
                &one(&values[1], escapes)?,
                &one(&values[2], escapes)?,
                &mut out,
            )
        }
        "var-reply" => {
            need(values, 2, "var-reply NAME INT")?;
            encode_var_reply(&values[0], num(&values[1], "int32")?, &mut out)
        }
        other => {
            return Err(format!(
                "unknown format {other:?} (floats, floats-lf, int32, bytes, string, line, framed, var-reply, hex)"
            ))
        }
    };
    r.map_err(crate::messages::encode_error)?;
    Ok(out)
}

/// Encodes what the robot sends: `line`, `string`, `byte`, `int`, `set-var NAME INT`,
/// `get-var NAME`, `stx-etx TEXT`, `value TEXT` (the `to_str` form of a number, bool,
/// list or pose), `hex HH...`; with `escapes` interpreted in text values.
pub fn encode_robot_with(
    format: &str,
    values: &[String],
    escapes: bool,
) -> Result<Vec<u8>, String> {
    let mut out = Vec::new();
    let r = match format {
        "hex" => return parse_hex(values),
        "line" => encode_line(&text(values, escapes)?, &mut out),
        "string" => encode_string(&text(values, escapes)?, &mut out),
        "byte" | "bytes" => {
            at_least_one(values, format)?;
            for s in values {
                encode_byte(num(s, "byte (0-255)")?, &mut out).map_err(crate::messages::encode_error)?;
            }
            Ok(values.len())
        }
        "int" | "int32" => {
            at_least_one(values, format)?;
            for s in values {
                encode_int32(num(s, "int32")?, &mut out).map_err(crate::messages::encode_error)?;
            }
            Ok(values.len() * 4)
        }
        "set-var" => {
            need(values, 2, "set-var NAME INT")?;
            encode_set_var(&values[0], num(&values[1], "int32")?, &mut out)
        }
        "get-var" => {
            need(values, 1, "get-var NAME")?;
            encode_get_var(&values[0], &mut out)
        }
        "stx-etx" => encode_stx_etx(&text(values, escapes)?, &mut out),
        "value" => {
            let text = values.join(" ");
            let value = parse_value(text.as_bytes())
                .map_err(|e| format!("value {text:?}: {}", crate::messages::value_error(&e)))?;
            encode_value(&value, &mut out)
        }
        other => {
            return Err(format!(
                "unknown robot format {other:?} (line, string, byte, int, set-var, get-var, stx-etx, value, hex)"
            ))
        }
    };
    r.map_err(crate::messages::encode_error)?;
    Ok(out)
}
