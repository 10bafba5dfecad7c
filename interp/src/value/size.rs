//! What a value costs the memory budget before an operation makes it, and the bound on
//! one value's size ([`Config::max_value_size`](crate::Config::max_value_size)).

use super::ops::is_matrix;
use super::{Value, MAX_VALUE_DEPTH, VALUE_BYTES};
use crate::error::{Fault, RuntimeErrorKind as K};
use crate::syntax::parser::BinOp;

/// The bytes values on a stack hold.
pub(crate) fn held_all(values: &[Value]) -> usize {
    values
        .iter()
        .map(Value::held_bytes)
        .fold(0, usize::saturating_add)
}

/// The content of the value at `i` in `b` (0 if there is none: indexing fails then).
pub(crate) fn element_bytes(b: &Value, i: &Value) -> usize {
    let Value::Int(k) = i else { return 0 };
    let Ok(k) = usize::try_from(*k) else { return 0 };
    match b {
        Value::List(items) => items.get(k).map_or(0, Value::content_bytes),
        Value::Struct(members) => members.get(k).map_or(0, |(_, v)| v.content_bytes()),
        _ => 0,
    }
}

/// The content of member `name` of `v` (0 if there is none).
pub(crate) fn member_bytes(v: &Value, name: &str) -> usize {
    match v {
        Value::Struct(members) => members
            .iter()
            .find(|(n, _)| n == name)
            .map_or(0, |(_, v)| v.content_bytes()),
        _ => 0,
    }
}

/// An upper bound of the bytes `binary(op, l, r)` allocates for its result, before it
/// runs: a list result has as many elements as its list operand (a matrix product: rows
/// times columns, plus the rows). Numbers, bools and poses make nothing; a string join
/// is at most [`MAX_STRING_LEN`](super::MAX_STRING_LEN) bytes.
pub(crate) fn binary_bytes(op: BinOp, l: &Value, r: &Value) -> usize {
    use Value::List;
    match (l, r) {
        (List(a), List(b)) if op == BinOp::Mul && is_matrix(a) => {
            let cols = match b.first() {
                Some(List(row)) => row.len(),
                _ => 1,
            };
            let cells = a.len().saturating_mul(cols.saturating_add(1));
            VALUE_BYTES.saturating_add(cells.saturating_mul(VALUE_BYTES))
        }
        (List(_), _) | (_, List(_)) => {
            VALUE_BYTES.saturating_add(l.content_bytes().max(r.content_bytes()))
        }
        (Value::Str(_), Value::Str(_)) => VALUE_BYTES + super::MAX_STRING_LEN,
        _ => VALUE_BYTES,
    }
}

/// A list, struct or string the program built, checked against [`MAX_VALUE_DEPTH`] and
/// [`Config::max_value_size`] (numbers and poses need no check).
pub(crate) fn check_value(v: &Value, max_size: usize) -> Result<(), Fault> {
    if !v.is_container() {
        return Ok(());
    }
    let (depth, size) = v.measure(max_size);
    if depth > MAX_VALUE_DEPTH {
        return Err(Fault::new(
            K::Limit,
            format!("a list or struct nested more than {MAX_VALUE_DEPTH} levels deep"),
        ));
    }
    if size > max_size {
        return Err(Fault::new(
            K::Limit,
            format!(
                "a value of more than {max_size} elements (list elements at every depth, string bytes)"
            ),
        ));
    }
    Ok(())
}
