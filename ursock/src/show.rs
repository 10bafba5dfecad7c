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

/// A quoted string literal with `\n \r \t \\ \"` and `\xHH` escapes.
pub fn quoted(bytes: &[u8]) -> String {
    let mut s = String::with_capacity(bytes.len() + 2);
    s.push('"');
    for &b in bytes {
        match b {
            b'\n' => s.push_str("\\n"),
            b'\r' => s.push_str("\\r"),
            b'\t' => s.push_str("\\t"),
            b'\\' => s.push_str("\\\\"),
            b'"' => s.push_str("\\\""),
            0x20..=0x7E => s.push(b as char),
            _ => {
                let _ = write!(s, "\\x{b:02X}");
            }
        }
    }
    s.push('"');
    s
}

/// A JSON string (bytes outside printable ASCII as `\u00XX`).
pub fn json_str(bytes: &[u8]) -> String {
    let mut s = String::with_capacity(bytes.len() + 2);
    s.push('"');
    for &b in bytes {
        match b {
            b'"' => s.push_str("\\\""),
            b'\\' => s.push_str("\\\\"),
            b'\n' => s.push_str("\\n"),
            b'\r' => s.push_str("\\r"),
            b'\t' => s.push_str("\\t"),
            0x20..=0x7E => s.push(b as char),
            _ => {
                let _ = write!(s, "\\u{b:04x}");
            }
        }
    }
    s.push('"');
    s
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

fn json_float(v: f64) -> String {
    if v.is_finite() {
        format!("{v}")
    } else {
        "null".into()
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

fn json_scalar(s: Scalar) -> String {
    match s {
        Scalar::Int(v) => v.to_string(),
        Scalar::Float(v) => json_float(v),
        Scalar::Bool(b) => b.to_string(),
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

    pub fn json(&self) -> String {
        match self {
            Message::Int(v) => format!("{{\"type\":\"int32\",\"value\":{v}}}"),
            Message::Byte(b) => format!("{{\"type\":\"byte\",\"value\":{b}}}"),
            Message::Text(kind, t) => format!("{{\"type\":\"{kind}\",\"value\":{}}}", json_str(t)),
            Message::Var(VarMessage::Set { name, value }) => format!(
                "{{\"type\":\"set\",\"name\":{},\"value\":{value}}}",
                json_str(name.as_bytes())
            ),
            Message::Var(VarMessage::Get { name }) => {
                format!(
                    "{{\"type\":\"get\",\"name\":{}}}",
                    json_str(name.as_bytes())
                )
            }
            Message::Value(Value::Scalar(s)) => {
                let kind = match s {
                    Scalar::Int(_) => "int",
                    Scalar::Float(_) => "float",
                    Scalar::Bool(_) => "bool",
                };
                format!("{{\"type\":\"{kind}\",\"value\":{}}}", json_scalar(*s))
            }
            Message::Value(Value::Pose(p)) => {
                let items: Vec<String> = p.iter().map(|v| json_float(*v)).collect();
                format!("{{\"type\":\"pose\",\"value\":[{}]}}", items.join(","))
            }
            Message::Value(Value::List(l)) => {
                let items: Vec<String> = l.iter().map(json_scalar).collect();
                format!("{{\"type\":\"list\",\"value\":[{}]}}", items.join(","))
            }
        }
    }
}
