//! Reply specs: what the operator types (or gives to `--reply` / a rule) to send bytes.
//!
//! `FORMAT VALUES`: the server formats of `ursock encode` (`floats 1 2 3`, `floats-lf`,
//! `int32`, `bytes`, `framed P T S`, `var-reply NAME INT`), and
//! * `line TEXT` / `string TEXT`: TEXT exactly as typed (spaces kept), with / without LF;
//! * `text TEXT`: TEXT with escapes interpreted (`\r`, `\n`, `\t`, `\0`, `\\`, `\xHH`);
//! * `hex 02 41 03` (or `024103`, `0x02 0x41`): raw bytes.

use crate::diagnose::Sent;
use crate::formats::encode_server;

/// A checked reply: its bytes and what kind of read it is meant for.
#[derive(Clone, Debug)]
pub struct Reply {
    pub format: String,
    pub bytes: Vec<u8>,
}

impl Reply {
    /// The reply as the diagnosis rules see it: a float tuple from `floats`/`floats-lf`,
    /// bytes meant for a binary read from `int32`/`bytes`.
    pub fn sent(&self) -> Sent<'_> {
        Sent {
            bytes: &self.bytes,
            float_tuple: self.format == "floats" || self.format == "floats-lf",
            binary: self.format == "int32" || self.format == "bytes",
        }
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
        "hex" => crate::typed::hex([rest]).map_err(|e| format!("hex: {e}"))?,
        "text" => crate::typed::unescape(rest).map_err(|e| format!("text: {e}"))?,
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
