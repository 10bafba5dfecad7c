//! Rendering bytes and decoded messages for people (hex, text, URScript notation, JSON).

use std::fmt::Write as _;

use urscript_socket::to_str::{Scalar, Value};
use urscript_socket::var::VarMessage;

/// `00 00 00 64`
pub fn hex(bytes: &[u8]) -> String {
    let mut s = String::with_capacity(bytes.len() * 3);
    for (i, b) in bytes.iter().enumerate() {
        if i > 0 {
            s.push(' ');
        }
        let _ = write!(s, "{b:02X}");
    }
    s
}

/// A quoted string literal with `\n \r \t \\ \"` and `\xHH` escapes. Valid UTF-8
/// beyond ASCII is shown as text (`"café"`); bytes that are not UTF-8 as `\xHH`.
pub fn quoted(bytes: &[u8]) -> String {
    let mut s = String::with_capacity(bytes.len() + 2);
    s.push('"');
    for chunk in bytes.utf8_chunks() {
        for c in chunk.valid().chars() {
            match c {
                '\n' => s.push_str("\\n"),
                '\r' => s.push_str("\\r"),
                '\t' => s.push_str("\\t"),
                '\\' => s.push_str("\\\\"),
                '"' => s.push_str("\\\""),
                ' '..='~' => s.push(c),
                c if (c as u32) < 0x80 => {
                    let _ = write!(s, "\\x{:02X}", c as u32);
                }
                c if c.is_control() => {
                    let _ = write!(s, "\\u{{{:04X}}}", c as u32);
                }
                c => s.push(c),
            }
        }
        for b in chunk.invalid() {
            let _ = write!(s, "\\x{b:02X}");
        }
    }
    s.push('"');
    s
}

/// A read's result in URScript notation, strings as [`quoted`] (valid UTF-8 shown as
/// text, where the library's notation escapes every non-ASCII byte).
pub fn read_result(r: &urscript_socket::robot::ReadResult) -> String {
    match r {
        urscript_socket::robot::ReadResult::Text(t) => quoted(t),
        other => other.to_urscript(),
    }
}

/// A hex dump, 16 bytes per row, each row with its offset and the printable ASCII:
///
/// ```text
/// 0000  68 65 6C 6C 6F 0A                                 |hello.|
/// ```
pub fn hex_dump(bytes: &[u8]) -> Vec<String> {
    bytes
        .chunks(16)
        .enumerate()
        .map(|(row, chunk)| {
            let mut s = format!("{:04X}  ", row * 16);
            for i in 0..16 {
                match chunk.get(i) {
                    Some(b) => {
                        let _ = write!(s, "{b:02X} ");
                    }
                    None => s.push_str("   "),
                }
                if i == 7 {
                    s.push(' ');
                }
            }
            s.push('|');
            s.extend(chunk.iter().map(|&b| {
                if b.is_ascii_graphic() || b == b' ' {
                    b as char
                } else {
                    '.'
                }
            }));
            s.push('|');
            s
        })
        .collect()
}

/// Bytes for a person: up to 16 bytes as the quoted text and the hex on one line;
/// longer chunks as their length, the start of the text, and a [`hex_dump`] below, one
/// row per 16 bytes, each row prefixed by `indent` (never one line of 12,000 characters).
pub fn text_and_hex(bytes: &[u8], indent: &str) -> String {
    const PREVIEW: usize = 48;
    if bytes.len() <= 16 {
        return format!("{}  {}", quoted(bytes), hex(bytes));
    }
    let mut s = format!("{} bytes", bytes.len());
    if bytes.len() <= PREVIEW {
        s = format!("{}  ({s})", quoted(bytes));
    } else {
        // Do not cut a UTF-8 character in two: back off over continuation bytes.
        let mut cut = PREVIEW;
        while cut > PREVIEW - 3 && bytes[cut] & 0xC0 == 0x80 {
            cut -= 1;
        }
        s = format!("{}...  ({s})", quoted(&bytes[..cut]));
    }
    for row in hex_dump(bytes) {
        s.push('\n');
        s.push_str(indent);
        s.push_str(&row);
    }
    s
}

/// Raw bytes in JSON, saying which form it chose: `{"encoding":"utf-8","text":"café"}`
/// when the bytes are valid UTF-8, else `{"encoding":"hex","hex":"e9"}`.
#[derive(serde::Serialize)]
#[serde(tag = "encoding")]
pub enum JsonBytes {
    #[serde(rename = "utf-8")]
    Utf8 { text: String },
    #[serde(rename = "hex")]
    Hex { hex: String },
}

impl JsonBytes {
    pub fn new(bytes: &[u8]) -> Self {
        match std::str::from_utf8(bytes) {
            Ok(t) => JsonBytes::Utf8 {
                text: t.to_string(),
            },
            Err(_) => JsonBytes::Hex {
                hex: bytes.iter().fold(String::new(), |mut s, b| {
                    let _ = write!(s, "{b:02x}");
                    s
                }),
            },
        }
    }
}

/// A float in shortest round-trip form, `nan`, `inf`.
pub fn float(v: f64) -> String {
    if v.is_nan() {
        "nan".into()
    } else if v.is_infinite() {
        if v > 0.0 { "inf" } else { "-inf" }.into()
    } else {
        format!("{v}")
    }
}

fn scalar(s: Scalar) -> String {
    match s {
        Scalar::Int(v) => v.to_string(),
        Scalar::Float(v) => float(v),
        Scalar::Bool(true) => "True".into(),
        Scalar::Bool(false) => "False".into(),
    }
}

fn json_scalar(s: Scalar) -> serde_json::Value {
    match s {
        Scalar::Int(v) => v.into(),
        Scalar::Float(v) => v.into(),
        Scalar::Bool(b) => b.into(),
    }
}

/// A decoded message, ready to print as text or JSON.
pub enum Message<'a> {
    Int(i32),
    Byte(u8),
    Text(&'static str, &'a [u8]),
    Var(VarMessage<'a>),
    Value(Value<'a>),
}

impl Message<'_> {
    pub fn text(&self) -> String {
        match self {
            Message::Int(v) => v.to_string(),
            Message::Byte(b) => b.to_string(),
            Message::Text(_, t) => quoted(t),
            Message::Var(VarMessage::Set { name, value }) => format!("SET {name} {value}"),
            Message::Var(VarMessage::Get { name }) => format!("GET {name}"),
            Message::Value(Value::Scalar(s)) => scalar(*s),
            Message::Value(Value::Pose(p)) => {
                let items: Vec<String> = p.iter().map(|v| float(*v)).collect();
                format!("p[{}]", items.join(", "))
            }
            Message::Value(Value::List(l)) => {
                let items: Vec<String> = l.iter().map(scalar).collect();
                format!("[{}]", items.join(", "))
            }
        }
    }

    /// One JSON object, through serde_json: `{"type":"line","value":{...}}`.
    pub fn json(&self) -> String {
        serde_json::to_string(&self.json_value()).unwrap_or_default()
    }

    fn json_value(&self) -> JsonMessage<'_> {
        match self {
            Message::Int(v) => JsonMessage::Int32 { value: *v },
            Message::Byte(b) => JsonMessage::Byte { value: *b },
            Message::Text("frame", t) => JsonMessage::Frame {
                value: JsonBytes::new(t),
            },
            Message::Text("string", t) => JsonMessage::String {
                value: JsonBytes::new(t),
            },
            Message::Text(_, t) => JsonMessage::Line {
                value: JsonBytes::new(t),
            },
            Message::Var(VarMessage::Set { name, value }) => JsonMessage::Set {
                name,
                value: *value,
            },
            Message::Var(VarMessage::Get { name }) => JsonMessage::Get { name },
            Message::Value(Value::Scalar(Scalar::Int(v))) => JsonMessage::Int { value: *v },
            Message::Value(Value::Scalar(Scalar::Float(v))) => JsonMessage::Float { value: *v },
            Message::Value(Value::Scalar(Scalar::Bool(v))) => JsonMessage::Bool { value: *v },
            Message::Value(Value::Pose(p)) => JsonMessage::Pose { value: *p },
            Message::Value(Value::List(l)) => JsonMessage::List {
                value: l.iter().map(json_scalar).collect(),
            },
        }
    }
}

/// The JSON shape of a decoded message (non-finite floats become `null`).
#[derive(serde::Serialize)]
#[serde(tag = "type", rename_all = "lowercase")]
enum JsonMessage<'a> {
    Int32 { value: i32 },
    Byte { value: u8 },
    Line { value: JsonBytes },
    Frame { value: JsonBytes },
    String { value: JsonBytes },
    Set { name: &'a str, value: i32 },
    Get { name: &'a str },
    Int { value: i32 },
    Float { value: f64 },
    Bool { value: bool },
    Pose { value: [f64; 6] },
    List { value: Vec<serde_json::Value> },
}
