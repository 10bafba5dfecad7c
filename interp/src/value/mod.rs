//! URScript values and their text.

use std::fmt;

use urscript_socket::to_str::{encode_value, List, Scalar, Value as WireValue};

pub(crate) mod access;
pub(crate) mod ops;
pub(crate) mod size;

/// A URScript value.
///
/// ```
/// use urscript_interp::Value;
/// assert_eq!(Value::Pose([1.0, 2.0, 3.0, 0.0, 0.0, 0.5]).to_str(), "p[1, 2, 3, 0, 0, 0.5]");
/// assert_eq!(Value::List(vec![Value::Int(1), Value::Bool(true)]).to_str(), "[1, True]");
/// ```
#[derive(Debug, Clone)]
pub enum Value {
    /// 32-bit signed integer.
    Int(i32),
    /// Float.
    Float(f64),
    /// `True` / `False`.
    Bool(bool),
    /// A string: bytes, no encoding (URScript strings are byte arrays).
    Str(Vec<u8>),
    /// `[a, b, ...]`.
    List(Vec<Value>),
    /// `p[x, y, z, rx, ry, rz]`.
    Pose([f64; 6]),
    /// A thread handle from `run`.
    Thread(u32),
    /// `struct(name=value, ...)`: named members in the order given (at most
    /// [`MAX_STRUCT_MEMBERS`]). A value, like a list: assigning or passing it copies it.
    Struct(Vec<(String, Value)>),
    /// The handle `rpc_factory("xmlrpc", url)` gives: the server's URL. Its methods are
    /// called as `handle.name(args...)`.
    Rpc(String),
    /// A handle of `eip_reader_factory`/`eip_writer_factory` (the program's n-th): its
    /// methods define the instance's layout and read or write it (see
    /// [`crate::eip`]).
    Eip(u32),
    /// What a function without `return value` returns.
    None,
}

/// Equality as the `==` operator sees it: numbers compare by value across int and float.
impl PartialEq for Value {
    fn eq(&self, other: &Self) -> bool {
        match (self, other) {
            (Value::Int(a), Value::Int(b)) => a == b,
            (Value::Str(a), Value::Str(b)) => a == b,
            (Value::Bool(a), Value::Bool(b)) => a == b,
            (Value::List(a), Value::List(b)) => a == b,
            (Value::Pose(a), Value::Pose(b)) => a == b,
            (Value::Thread(a), Value::Thread(b)) => a == b,
            (Value::Struct(a), Value::Struct(b)) => a == b,
            (Value::Rpc(a), Value::Rpc(b)) => a == b,
            (Value::Eip(a), Value::Eip(b)) => a == b,
            (Value::None, Value::None) => true,
            (a, b) => match (a.as_f64(), b.as_f64()) {
                (Some(x), Some(y)) => x == y,
                _ => false,
            },
        }
    }
}

/// The deepest nesting of lists a value may have (`[[1]]` is 2 levels; a number, string
/// or pose is 0). A running program that builds a deeper one stops with a
/// [`Limit`](crate::RuntimeErrorKind::Limit) error, so nothing recursive over a value
/// (copying, comparing, writing, dropping it) can exhaust the stack.
pub const MAX_VALUE_DEPTH: usize = 32;

/// The most members a struct may have: a `struct(...)` with more is a compile error.
pub const MAX_STRUCT_MEMBERS: usize = 64;

/// The longest string `str_cat` makes, as on the controller.
pub const MAX_STRING_LEN: usize = 1023;

/// The default of [`Config::max_value_size`](crate::Config::max_value_size).
pub(crate) const DEFAULT_MAX_VALUE_SIZE: usize = 1_000_000;

/// The bytes one value takes where it sits: a list element, a stack slot (the enum
/// itself; what it owns outside is its [`content_bytes`](Value::content_bytes)).
pub(crate) const VALUE_BYTES: usize = std::mem::size_of::<Value>();

/// The bytes one struct member takes besides its name's text and its value's content.
pub(crate) const MEMBER_BYTES: usize = std::mem::size_of::<(String, Value)>();

impl Value {
    /// The depth (levels of lists) and the size of the value: every list element counts
    /// one, at any depth, and a string its bytes. Counting stops, without recursion,
    /// once the depth passes [`MAX_VALUE_DEPTH`] or the size passes `max_size`, so the
    /// cost is bounded by the part of the value within the bounds.
    pub(crate) fn measure(&self, max_size: usize) -> (usize, usize) {
        let mut depth = 0;
        let mut size = 0usize;
        let mut todo: Vec<(&Value, usize)> = vec![(self, 0)];
        while let Some((v, d)) = todo.pop() {
            match v {
                Value::List(items) => {
                    let d = d + 1;
                    depth = depth.max(d);
                    size = size.saturating_add(items.len());
                    if depth > MAX_VALUE_DEPTH || size > max_size {
                        break;
                    }
                    todo.extend(items.iter().filter(|i| i.is_container()).map(|i| (i, d)));
                }
                // A struct is a level, as a list is, and each member counts one.
                Value::Struct(members) => {
                    let d = d + 1;
                    depth = depth.max(d);
                    size = size.saturating_add(members.len());
                    if depth > MAX_VALUE_DEPTH || size > max_size {
                        break;
                    }
                    todo.extend(
                        members
                            .iter()
                            .map(|(_, v)| v)
                            .filter(|v| v.is_container())
                            .map(|v| (v, d)),
                    );
                }
                Value::Rpc(url) => {
                    size = size.saturating_add(url.len());
                    if size > max_size {
                        break;
                    }
                }
                Value::Str(s) => {
                    size = size.saturating_add(s.len());
                    if size > max_size {
                        break;
                    }
                }
                _ => {}
            }
        }
        (depth, size)
    }

    /// The bytes the value owns outside its own slot, as the memory budget counts them
    /// ([`Config::max_memory`](crate::Config::max_memory)): [`VALUE_BYTES`] per list
    /// element, a string's bytes, [`MEMBER_BYTES`] plus the name per struct member, at
    /// every depth; 0 for a number, bool, pose or handle. Iterative; the cost is linear
    /// in the value's size.
    #[inline]
    pub(crate) fn content_bytes(&self) -> usize {
        match self {
            Value::Str(s) => s.len(),
            Value::Rpc(url) => url.len(),
            // A flat list (the common case: joints, poses as lists) without a walk.
            Value::List(items) if !items.iter().any(Value::is_container) => {
                items.len().saturating_mul(VALUE_BYTES)
            }
            Value::List(_) | Value::Struct(_) => self.nested_content_bytes(),
            _ => 0,
        }
    }

    /// [`content_bytes`](Self::content_bytes) of a list or struct that may hold others.
    fn nested_content_bytes(&self) -> usize {
        let mut bytes = 0usize;
        let mut todo: Vec<&Value> = vec![self];
        while let Some(v) = todo.pop() {
            match v {
                Value::List(items) => {
                    bytes = bytes.saturating_add(items.len().saturating_mul(VALUE_BYTES));
                    todo.extend(items.iter().filter(|i| i.is_container()));
                }
                Value::Struct(members) => {
                    for (name, m) in members {
                        bytes = bytes.saturating_add(MEMBER_BYTES + name.len());
                        if m.is_container() {
                            todo.push(m);
                        }
                    }
                }
                Value::Str(s) => bytes = bytes.saturating_add(s.len()),
                Value::Rpc(url) => bytes = bytes.saturating_add(url.len()),
                _ => {}
            }
        }
        bytes
    }

    /// The bytes the value takes on a stack or as a list element: [`VALUE_BYTES`] plus
    /// its [`content_bytes`](Self::content_bytes).
    #[inline]
    pub(crate) fn held_bytes(&self) -> usize {
        VALUE_BYTES.saturating_add(self.content_bytes())
    }

    /// A list, struct or string: what [`measure`](Self::measure) looks into.
    #[inline]
    pub(crate) fn is_container(&self) -> bool {
        matches!(
            self,
            Value::List(_) | Value::Str(_) | Value::Struct(_) | Value::Rpc(_)
        )
    }

    /// The value as a float if it is a number.
    ///
    /// ```
    /// # use urscript_interp::Value;
    /// assert_eq!(Value::Int(2).as_f64(), Some(2.0));
    /// ```
    pub fn as_f64(&self) -> Option<f64> {
        match self {
            Value::Int(v) => Some(f64::from(*v)),
            Value::Float(v) => Some(*v),
            _ => None,
        }
    }

    /// URScript's name of the value's type, for error messages.
    ///
    /// ```
    /// # use urscript_interp::Value;
    /// assert_eq!(Value::Float(1.0).type_name(), "float");
    /// ```
    pub fn type_name(&self) -> &'static str {
        match self {
            Value::Int(_) => "int",
            Value::Float(_) => "float",
            Value::Bool(_) => "bool",
            Value::Str(_) => "string",
            Value::List(_) => "list",
            Value::Pose(_) => "pose",
            Value::Thread(_) => "thread",
            Value::Struct(_) => "struct",
            Value::Rpc(_) => "rpc handle",
            Value::Eip(_) => "EtherNet/IP handle",
            Value::None => "none",
        }
    }

    fn scalar(&self) -> Option<Scalar> {
        match self {
            Value::Int(v) => Some(Scalar::Int(*v)),
            Value::Float(v) => Some(Scalar::Float(*v)),
            Value::Bool(v) => Some(Scalar::Bool(*v)),
            _ => None,
        }
    }

    /// The text `to_str`, `textmsg` and `socket_send_string` give: the crate's `to_str`
    /// writer for numbers, bools, lists and poses; a string as its bytes.
    ///
    /// ```
    /// # use urscript_interp::Value;
    /// assert_eq!(Value::Float(2.123456123456).to_str(), "2.123456");
    /// assert_eq!(Value::Str(b"hi".to_vec()).to_str(), "hi");
    /// ```
    pub fn to_str(&self) -> String {
        String::from_utf8_lossy(&self.to_str_bytes()).into_owned()
    }

    /// [`to_str`](Self::to_str) as bytes (a string's bytes unchanged).
    ///
    /// ```
    /// # use urscript_interp::Value;
    /// assert_eq!(Value::Int(-3).to_str_bytes(), b"-3");
    /// ```
    pub fn to_str_bytes(&self) -> Vec<u8> {
        let mut out = Vec::new();
        self.write_text(&mut out, false);
        out
    }

    /// The value as URScript source: like [`to_str`](Self::to_str) but strings quoted
    /// (used by the call trace).
    ///
    /// ```
    /// # use urscript_interp::Value;
    /// assert_eq!(Value::Str(b"hi".to_vec()).to_source(), "\"hi\"");
    /// assert_eq!(Value::Str(b"a\"b".to_vec()).to_source(), "'a\"b'");
    /// ```
    pub fn to_source(&self) -> String {
        let mut out = Vec::new();
        self.write_text(&mut out, true);
        String::from_utf8_lossy(&out).into_owned()
    }

    fn write_text(&self, out: &mut Vec<u8>, quote: bool) {
        // The crate's writer bounds its text at 1023 characters; past that (long lists)
        // the items are written one by one.
        let start = out.len();
        let wire = match self {
            Value::Pose(p) => Some(encode_value(&WireValue::Pose(*p), out)),
            Value::List(items) => {
                let scalars: Option<Vec<Scalar>> = items.iter().map(Value::scalar).collect();
                scalars.map(|s| encode_value(&WireValue::List(List::from_items(&s)), out))
            }
            other => other
                .scalar()
                .map(|s| encode_value(&WireValue::Scalar(s), out)),
        };
        if let Some(Ok(_)) = wire {
            return;
        }
        out.truncate(start);
        {
            match self {
                Value::Str(s) if quote => {
                    // A literal that reads back: double quotes, or single quotes when
                    // the text holds a double quote (URScript has both), escaped only
                    // when it holds both.
                    let q = if s.contains(&b'"') && !s.contains(&b'\'') {
                        b'\''
                    } else {
                        b'"'
                    };
                    out.push(q);
                    for &b in s.iter() {
                        if b == q || (b == b'\\' && s.contains(&b'"') && s.contains(&b'\'')) {
                            out.push(b'\\');
                        }
                        out.push(b);
                    }
                    out.push(q);
                }
                Value::Str(s) => out.extend_from_slice(s),
                Value::List(items) => {
                    out.push(b'[');
                    for (i, v) in items.iter().enumerate() {
                        if i > 0 {
                            out.extend_from_slice(b", ");
                        }
                        v.write_text(out, quote);
                    }
                    out.push(b']');
                }
                Value::Thread(id) => out.extend_from_slice(format!("<thread {id}>").as_bytes()),
                Value::Eip(id) => out.extend_from_slice(format!("<eip handle {id}>").as_bytes()),
                // The manual gives no text for a struct; this one reads back as the
                // expression that builds it: `struct(a=1, b=[1, 2])`.
                Value::Struct(members) => {
                    out.extend_from_slice(b"struct(");
                    for (i, (name, v)) in members.iter().enumerate() {
                        if i > 0 {
                            out.extend_from_slice(b", ");
                        }
                        out.extend_from_slice(name.as_bytes());
                        out.push(b'=');
                        v.write_text(out, true);
                    }
                    out.push(b')');
                }
                Value::Rpc(url) => {
                    out.extend_from_slice(b"rpc_factory(\"xmlrpc\", \"");
                    out.extend_from_slice(url.as_bytes());
                    out.extend_from_slice(b"\")");
                }
                Value::None => out.extend_from_slice(b"None"),
                _ => {}
            }
        }
    }
}

impl fmt::Display for Value {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.to_source())
    }
}
