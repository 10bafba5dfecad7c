//! Strings and lists: `str_*`, `to_str`, `to_num`, `length`, `size`, `make_list`.

use urscript_socket::to_str::{parse_value, Scalar, Value as WireValue};

use super::{builtin, Args, Builtin, Domain, Out};
use crate::error::Fault;
use crate::runtime::Runtime;
use crate::value::Value;

pub use crate::value::MAX_STRING_LEN;

const D: Domain = Domain::Strings;

pub(super) const TABLE: &[Builtin] = &[
    builtin!(
        str_cat(op1: &Value, op2: &Value) => str_cat,
        "The two values' texts joined (at most 1023 characters).",
    ),
    builtin!(
        str_len(str: &[u8]) => |_, _, s: &[u8]| Ok(Out::Value(Value::Int(
            i32::try_from(s.len()).unwrap_or(i32::MAX)
        ))),
        "The string's length in bytes.",
    ),
    builtin!(
        str_empty(str: &[u8]) => |_, _, s: &[u8]| Ok(Out::Value(Value::Bool(s.is_empty()))),
        "True if the string is empty.",
    ),
    builtin!(
        str_sub(src: &[u8], index: i32, len: i32 = Int(-1)) => str_sub,
        "The part of src from index, len bytes long (-1: to the end).",
    ),
    builtin!(
        str_find(src: &[u8], target: &[u8], start_from: i32 = Int(0)) => str_find,
        "The index of target in src from start_from, or -1.",
    ),
    builtin!(
        str_at(src: &[u8], index: i32) => str_at,
        "The one-byte string at index (\"\" past the end).",
    ),
    builtin!(
        to_str(val: &Value) => |_, _, v: &Value| Ok(Out::Value(Value::Str(v.to_str_bytes()))),
        "The value's text, as the controller writes it.",
    ),
    builtin!(
        to_num(str: &[u8]) => to_num,
        "The number the string holds (int or float).",
    ),
    builtin!(
        length(v: &Value) => length,
        "The length of a list or string (6 for a pose).",
    ),
    builtin!(
        size(v: &Value) => size,
        "The length of a list or string; [rows, columns] of a matrix (a list of lists).",
    ),
    builtin!(
        make_list(length: i32, initial_value: &Value, capacity: Option<i32> = Absent) => make_list,
        "A list of length copies of initial_value (capacity, if given, at least length).",
    ),
    builtin!(
        get_list_length(v: &Value) => length,
        "The length of a list (as `length`).",
    ),
];

fn str_cat(_: &mut Runtime, _: &mut Args, op1: &Value, op2: &Value) -> Result<Out, Fault> {
    let mut out = op1.to_str_bytes();
    out.extend(op2.to_str_bytes());
    // The controller's strings hold at most 1023 characters.
    if out.len() > MAX_STRING_LEN {
        return Err(Fault::from(format!(
            "`str_cat`: the result would be {} characters, more than {MAX_STRING_LEN}",
            out.len()
        )));
    }
    Ok(Out::Value(Value::Str(out)))
}

fn str_sub(_: &mut Runtime, _: &mut Args, src: &[u8], index: i32, len: i32) -> Result<Out, Fault> {
    let start = usize::try_from(index).unwrap_or(usize::MAX).min(src.len());
    let end = match usize::try_from(len) {
        Ok(l) => start.saturating_add(l).min(src.len()),
        Err(_) => src.len(),
    };
    Ok(Out::Value(Value::Str(src[start..end].to_vec())))
}

fn str_find(
    _: &mut Runtime,
    _: &mut Args,
    src: &[u8],
    target: &[u8],
    start_from: i32,
) -> Result<Out, Fault> {
    let from = usize::try_from(start_from).unwrap_or(0).min(src.len());
    let found = if target.is_empty() {
        Some(from)
    } else {
        src[from..]
            .windows(target.len())
            .position(|w| w == target)
            .map(|p| p + from)
    };
    Ok(Out::Value(Value::Int(
        found.map_or(-1, |p| i32::try_from(p).unwrap_or(-1)),
    )))
}

fn str_at(_: &mut Runtime, _: &mut Args, src: &[u8], index: i32) -> Result<Out, Fault> {
    let at = usize::try_from(index).ok().and_then(|k| src.get(k));
    Ok(Out::Value(Value::Str(
        at.map(|c| vec![*c]).unwrap_or_default(),
    )))
}

fn to_num(_: &mut Runtime, _: &mut Args, st: &[u8]) -> Result<Out, Fault> {
    match parse_value(st) {
        Ok(WireValue::Scalar(Scalar::Int(x))) => Ok(Out::Value(Value::Int(x))),
        Ok(WireValue::Scalar(Scalar::Float(x))) => Ok(Out::Value(Value::Float(x))),
        _ => Err(Fault::from(format!(
            "`to_num`: \"{}\" is not a number",
            String::from_utf8_lossy(st)
        ))),
    }
}

fn length(_: &mut Runtime, a: &mut Args, v: &Value) -> Result<Out, Fault> {
    let n = match v {
        Value::List(items) => items.len(),
        Value::Str(st) => st.len(),
        Value::Pose(_) => 6,
        other => {
            return Err(Fault::type_error(format!(
                "type error: `{}` of a {}",
                a.name,
                other.type_name()
            )))
        }
    };
    Ok(Out::Value(Value::Int(i32::try_from(n).unwrap_or(i32::MAX))))
}

fn size(c: &mut Runtime, a: &mut Args, v: &Value) -> Result<Out, Fault> {
    if let Value::List(rows) = v {
        if let Some(Value::List(first)) = rows.first() {
            if rows.iter().all(|r| matches!(r, Value::List(_))) {
                let n = |x: usize| Value::Int(i32::try_from(x).unwrap_or(i32::MAX));
                return Ok(Out::Value(Value::List(vec![n(rows.len()), n(first.len())])));
            }
        }
    }
    length(c, a, v)
}

/// The longest list `make_list` makes (a guard, not the controller's limit).
const MAX_LIST_LEN: i32 = 1 << 20;

fn make_list(
    c: &mut Runtime,
    _: &mut Args,
    n: i32,
    initial_value: &Value,
    capacity: Option<i32>,
) -> Result<Out, Fault> {
    let cap = capacity.unwrap_or(n);
    if !(0..=MAX_LIST_LEN).contains(&n) || cap < n {
        return Err(Fault::from(format!(
            "`make_list`: length {n} must be 0-{MAX_LIST_LEN} and capacity {cap} at least it"
        )));
    }
    if matches!(initial_value, Value::List(_)) {
        return Err(Fault::from(
            "`make_list`: a list of lists is a matrix, not made by make_list",
        ));
    }
    // The list's elements, each a copy of the value, counted before they are made.
    let n = n as usize;
    let bytes = n.saturating_mul(initial_value.held_bytes());
    c.reserve(bytes)?;
    Ok(Out::Value(Value::List(vec![initial_value.clone(); n])))
}
