//! Reply specs: what the operator types (or gives to `--reply` / a rule) to send bytes.
//!
//! `FORMAT VALUES`: the server formats of `ursock encode` (`floats 1 2 3`, `floats-lf`,
//! `int32`, `bytes`, `framed P T S`, `var-reply NAME INT`), and
//! * `line TEXT` / `string TEXT`: TEXT exactly as typed (spaces kept), with / without LF;
//! * `text TEXT`: TEXT with escapes interpreted (`\r`, `\n`, `\t`, `\0`, `\\`, `\xHH`);
//! * `hex 02 41 03` (or `024103`, `0x02 0x41`): raw bytes.

use crate::diagnose::Sent;
use crate::formats::{encode_server, list, lookup, names};

/// A checked reply: its bytes and the format it was written in.
#[derive(Clone, Debug)]
pub struct Reply {
    /// The name in [`names::SERVER`] (or `text`).
    pub format: String,
    pub bytes: Vec<u8>,
}

impl Reply {
    /// The reply as the diagnosis rules see it, by the core format its name stands for:
    /// a float tuple, or bytes meant for a binary read (int32, bytes).
    pub fn sent(&self) -> Sent<'_> {
        let core = lookup(names::SERVER, &self.format).and_then(|n| n.core);
        Sent {
            bytes: &self.bytes,
            float_tuple: core == Some("float-tuple"),
            binary: matches!(core, Some("int32" | "bytes")),
        }
    }
}

/// The reply formats, for messages: the server's ([`names::SERVER`]) and `text`.
pub fn formats() -> String {
    format!("{}, {}", list(names::SERVER), names::TEXT.name)
}

pub fn parse(spec: &str) -> Result<Reply, String> {
    let spec = spec.trim_start();
    // One separator (any whitespace character) after the format; the rest is kept as
    // typed, so `line a  b` sends two spaces.
    let (format, rest) = spec.split_once(char::is_whitespace).unwrap_or((spec, ""));
    if format.is_empty() {
        return Err(format!("empty reply spec (formats: {})", formats()));
    }
    let name = if format == names::TEXT.name {
        &names::TEXT
    } else {
        lookup(names::SERVER, format)
            .ok_or_else(|| format!("unknown reply format {format:?} (formats: {})", formats()))?
    };
    let bytes = match name.name {
        "hex" => crate::typed::hex([rest]).map_err(|e| format!("hex: {e}"))?,
        "text" => crate::typed::unescape(rest).map_err(|e| format!("text: {e}"))?,
        "string" => rest.as_bytes().to_vec(),
        "line" => {
            let mut v = rest.as_bytes().to_vec();
            v.push(b'\n');
            v
        }
        other => {
            let values: Vec<String> = rest.split_whitespace().map(String::from).collect();
            encode_server(other, &values).map_err(|e| format!("{other}: {e}"))?
        }
    };
    Ok(Reply {
        format: name.name.to_string(),
        bytes,
    })
}
