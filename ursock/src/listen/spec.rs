//! Reply specs: what the operator types (or gives to `--reply` / a rule) to send bytes.
//!
//! `FORMAT VALUES`: the server formats of `ursock encode` (`floats 1 2 3`, `floats-lf`,
//! `int32`, `bytes`, `framed P T S`, `var-reply NAME INT`), and
//! * `line TEXT` / `string TEXT`: TEXT exactly as typed (spaces kept), with / without LF;
//! * `text TEXT`: TEXT with escapes interpreted (`\r`, `\n`, `\t`, `\0`, `\\`, `\xHH`);
//! * `hex 02 41 03` (or `024103`, `0x02 0x41`): raw bytes.

use crate::formats::encode_server;

/// A checked reply: its bytes and what kind of read it is meant for.
#[derive(Clone, Debug)]
pub struct Reply {
    pub format: String,
    pub bytes: Vec<u8>,
}

impl Reply {
    /// A float tuple from `floats`/`floats-lf`.
    pub fn is_float_tuple(&self) -> bool {
        self.format == "floats" || self.format == "floats-lf"
    }

    /// Bytes meant for a binary read (`int32`, `bytes`).
    pub fn is_binary(&self) -> bool {
        self.format == "int32" || self.format == "bytes"
    }
}

pub const FORMATS: &str =
    "floats, floats-lf, int32, bytes, string, line, text, hex, framed, var-reply";

pub fn parse(spec: &str) -> Result<Reply, String> {
    let spec = spec.trim_start();
    // One separator (any whitespace character) after the format; the rest is kept as
    // typed, so `line a  b` sends two spaces.
    let (format, rest) = spec.split_once(char::is_whitespace).unwrap_or((spec, ""));
    if format.is_empty() {
        return Err(format!("empty reply spec (formats: {FORMATS})"));
    }
    let bytes = match format {
        "hex" => parse_hex(rest)?,
        "text" => unescape(rest)?,
        "string" => rest.as_bytes().to_vec(),
        "line" => {
            let mut v = rest.as_bytes().to_vec();
            v.push(b'\n');
            v
        }
        "floats" | "floats-lf" | "int32" | "bytes" | "framed" | "var-reply" => {
            let values: Vec<String> = rest.split_whitespace().map(String::from).collect();
            encode_server(format, &values).map_err(|e| format!("{format}: {e}"))?
        }
        other => {
            return Err(format!(
                "unknown reply format {other:?} (formats: {FORMATS})"
            ))
        }
    };
    Ok(Reply {
        format: format.to_string(),
        bytes,
    })
}

/// `02 41 03`, `024103`, `0x02,0x41`.
pub fn parse_hex(s: &str) -> Result<Vec<u8>, String> {
    let mut digits = Vec::new();
    for word in s.split(|c: char| c.is_whitespace() || c == ',') {
        let w = word
            .strip_prefix("0x")
            .or_else(|| word.strip_prefix("0X"))
            .unwrap_or(word);
        if w.len() % 2 != 0 {
            return Err(format!(
                "hex: {word:?} is not whole bytes (two digits each)"
            ));
        }
        for pair in w.as_bytes().chunks(2) {
            let text = std::str::from_utf8(pair).unwrap_or("?");
            let b = u8::from_str_radix(text, 16)
                .map_err(|_| format!("hex: {word:?} is not hexadecimal"))?;
            digits.push(b);
        }
    }
    if digits.is_empty() {
        return Err("hex: no bytes given (e.g. hex 02 41 03)".into());
    }
    Ok(digits)
}

/// `\r \n \t \0 \\ \xHH` in typed text.
pub fn unescape(s: &str) -> Result<Vec<u8>, String> {
    let mut out = Vec::with_capacity(s.len());
    let b = s.as_bytes();
    let mut i = 0;
    while i < b.len() {
        if b[i] != b'\\' {
            out.push(b[i]);
            i += 1;
            continue;
        }
        match b.get(i + 1) {
            Some(b'n') => out.push(b'\n'),
            Some(b'r') => out.push(b'\r'),
            Some(b't') => out.push(b'\t'),
            Some(b'0') => out.push(0),
            Some(b'\\') => out.push(b'\\'),
            Some(b'x') => {
                let hex = b
                    .get(i + 2..i + 4)
                    .and_then(|h| std::str::from_utf8(h).ok());
                let v = hex
                    .and_then(|h| u8::from_str_radix(h, 16).ok())
                    .ok_or_else(|| format!("text: \\x needs two hex digits at byte {i}"))?;
                out.push(v);
                i += 4;
                continue;
            }
            _ => {
                return Err(format!(
                    "text: unknown escape at byte {i} (use \\r \\n \\t \\0 \\\\ \\xHH)"
                ))
            }
        }
        i += 2;
    }
    Ok(out)
}
