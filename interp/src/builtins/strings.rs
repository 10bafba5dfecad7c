//! Strings and lists: `str_*`, `to_str`, `to_num`, `length`, `size`, `make_list`.

use urscript_socket::to_str::{parse_value, Scalar, Value as WireValue};

use super::{opt, req, Args, Builtin, Default, Domain, Out};
use crate::error::Fault;
use crate::runtime::Runtime;
use crate::value::Value;

pub use crate::value::MAX_STRING_LEN;

const D: Domain = Domain::Strings;

pub(super) const TABLE: &[Builtin] = &[
    Builtin::new(
        "str_cat",
        D,
        &[req("op1"), req("op2")],
        "The two values' texts joined (at most 1023 characters).",
        str_cat,
    ),
    Builtin::new(
        "str_len",
        D,
        &[req("str")],
        "The string's length in bytes.",
        str_len,
    ),
    Builtin::new(
        "str_empty",
        D,
        &[req("str")],
        "True if the string is empty.",
        str_len,
    ),
    Builtin::new(
        "str_sub",
        D,
        &[req("src"), req("index"), opt("len", Default::Int(-1))],
        "The part of src from index, len bytes long (-1: to the end).",
        str_sub,
    ),
    Builtin::new(
        "str_find",
        D,
        &[
            req("src"),
            req("target"),
            opt("start_from", Default::Int(0)),
        ],
        "The index of target in src from start_from, or -1.",
        str_find,
    ),
    Builtin::new(
        "str_at",
        D,
        &[req("src"), req("index")],
        "The one-byte string at index (\"\" past the end).",
        str_at,
    ),
    Builtin::new(
        "to_str",
        D,
        &[req("val")],
        "The value's text, as the controller writes it.",
        to_str,
    ),
    Builtin::new(
        "to_num",
        D,
        &[req("str")],
        "The number the string holds (int or float).",
        to_num,
    ),
    Builtin::new(
        "length",
        D,
        &[req("v")],
        "The length of a list or string (6 for a pose).",
        length,
    ),
    Builtin::new(
        "size",
        D,
        &[req("v")],
        "The length of a list or string; [rows, columns] of a matrix (a list of lists).",
        size,
    ),
    Builtin::new(
        "make_list",
        D,
        &[
            req("length"),
            req("initial_value"),
            opt("capacity", Default::Absent),
        ],
        "A list of length copies of initial_value (capacity, if given, at least length).",
        make_list,
    ),
    Builtin::new(
        "get_list_length",
        D,
        &[req("v")],
        "The length of a list (as `length`).",
        length,
    ),
];

fn str_cat(_: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let mut out = a.v[0].to_str_bytes();
    out.extend(a.v[1].to_str_bytes());
    // The controller's strings hold at most 1023 characters.
    if out.len() > MAX_STRING_LEN {
        return Err(Fault::from(format!(
            "`str_cat`: the result would be {} characters, more than {MAX_STRING_LEN}",
            out.len()
        )));
    }
    Ok(Out::Value(Value::Str(out)))
}

fn str_len(_: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let st = a.bytes(0)?;
    Ok(Out::Value(if a.name == "str_len" {
        Value::Int(i32::try_from(st.len()).unwrap_or(i32::MAX))
    } else {
        Value::Bool(st.is_empty())
    }))
}

fn str_sub(_: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let start = usize::try_from(a.int(1)?).unwrap_or(usize::MAX);
    let len = a.int(2)?;
    let src = a.bytes(0)?;
    let start = start.min(src.len());
    let end = match usize::try_from(len) {
        Ok(l) => start.saturating_add(l).min(src.len()),
        Err(_) => src.len(),
    };
    Ok(Out::Value(Value::Str(src[start..end].to_vec())))
}

fn str_find(_: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let from = usize::try_from(a.int(2)?).unwrap_or(0);
    let (src, target) = (a.bytes(0)?, a.bytes(1)?);
    let from = from.min(src.len());
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

fn str_at(_: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let k = a.int(1)?;
    let src = a.bytes(0)?;
    let at = usize::try_from(k).ok().and_then(|k| src.get(k));
    Ok(Out::Value(Value::Str(
        at.map(|c| vec![*c]).unwrap_or_default(),
    )))
}

fn to_str(_: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(Value::Str(a.v[0].to_str_bytes())))
}

fn to_num(_: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let st = a.bytes(0)?;
    match parse_value(st) {
        Ok(WireValue::Scalar(Scalar::Int(x))) => Ok(Out::Value(Value::Int(x))),
        Ok(WireValue::Scalar(Scalar::Float(x))) => Ok(Out::Value(Value::Float(x))),
        _ => Err(Fault::from(format!(
            "`to_num`: \"{}\" is not a number",
            String::from_utf8_lossy(st)
        ))),
    }
}

fn length(_: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let n = match &a.v[0] {
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

fn size(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    if let Value::List(rows) = &a.v[0] {
        if let Some(Value::List(first)) = rows.first() {
            if rows.iter().all(|r| matches!(r, Value::List(_))) {
                let n = |x: usize| Value::Int(i32::try_from(x).unwrap_or(i32::MAX));
                return Ok(Out::Value(Value::List(vec![n(rows.len()), n(first.len())])));
            }
        }
    }
    length(c, a)
}

/// The longest list `make_list` makes (a guard, not the controller's limit).
const MAX_LIST_LEN: i32 = 1 << 20;

fn make_list(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let n = a.int(0)?;
    let cap = if a.is_absent(2) { n } else { a.int(2)? };
    if !(0..=MAX_LIST_LEN).contains(&n) || cap < n {
        return Err(Fault::from(format!(
            "`make_list`: length {n} must be 0-{MAX_LIST_LEN} and capacity {cap} at least it"
        )));
    }
    if matches!(a.v[1], Value::List(_)) {
        return Err(Fault::from(
            "`make_list`: a list of lists is a matrix, not made by make_list",
        ));
    }
    // The list's elements, each a copy of the value, counted before they are made.
    let n = n as usize;
    let bytes = n.saturating_mul(a.v[1].held_bytes());
    c.reserve(bytes)?;
    Ok(Out::Value(Value::List(vec![a.v[1].clone(); n])))
}
