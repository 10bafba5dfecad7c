//! Indexing and member access: the value read, the place an assignment writes, and the
//! store of a value there.

use super::Value;
use crate::error::{Fault, RuntimeErrorKind as K};
use crate::syntax::compile::{PathStep, Program};

/// The value a method call `v.a.b.m(...)` calls on, and the method's name: a struct's
/// members are entered while the name has dots (`s.h.get()` calls `get` on member `h`);
/// what is left is called on whatever comes, so `h.server.getTCP()` on an `rpc_factory`
/// handle calls the XML-RPC method `server.getTCP`.
pub(crate) fn method_target(mut v: Value, mut method: &str) -> Result<(Value, &str), Fault> {
    while let (Value::Struct(_), Some((first, rest))) = (&v, method.split_once('.')) {
        v = member(&v, first)?;
        method = rest;
    }
    Ok((v, method))
}

/// `v.name`: a member of a struct.
pub(crate) fn member(v: &Value, name: &str) -> Result<Value, Fault> {
    match v {
        Value::Struct(members) => members
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.clone())
            .ok_or_else(|| {
                Fault::new(
                    K::UnknownMember,
                    format!("the struct has no member `{name}`"),
                )
            }),
        other => Err(Fault::new(
            K::Type,
            format!(
                "type error: `.{name}` reads a member of a struct, not of a {}",
                other.type_name()
            ),
        )),
    }
}

/// Assigns `v` at `steps` (members and indices) inside `target`; the value it drops
/// (see [`store_index`]). A struct's members are fixed when it is made: assigning one it
/// does not have is an error, as reading one is.
pub(crate) fn store_path(
    target: &mut Value,
    steps: &[PathStep],
    indices: Vec<Value>,
    v: Value,
    prog: &Program,
) -> Result<Value, Fault> {
    let mut indices = indices.into_iter();
    let mut at = target;
    let Some((last, inner)) = steps.split_last() else {
        return Ok(std::mem::replace(at, v));
    };
    for step in inner {
        at = match step {
            PathStep::Member(m) => member_mut(at, &prog.names[*m as usize])?,
            PathStep::Index => {
                let i = indices.next().unwrap_or(Value::None);
                index_mut(at, &i)?
            }
        };
    }
    match last {
        PathStep::Member(m) => Ok(std::mem::replace(
            member_mut(at, &prog.names[*m as usize])?,
            v,
        )),
        PathStep::Index => {
            let i = indices.next().unwrap_or(Value::None);
            store_index(at, &i, v)
        }
    }
}

fn member_mut<'a>(v: &'a mut Value, name: &str) -> Result<&'a mut Value, Fault> {
    match v {
        Value::Struct(members) => members
            .iter_mut()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v)
            .ok_or_else(|| {
                Fault::new(
                    K::UnknownMember,
                    format!("the struct has no member `{name}`"),
                )
            }),
        other => Err(Fault::new(
            K::Type,
            format!(
                "type error: `.{name} = ...` assigns a member of a struct, not of a {}",
                other.type_name()
            ),
        )),
    }
}

fn index_of(i: &Value, len: usize) -> Result<usize, Fault> {
    let Value::Int(k) = i else {
        return Err(Fault::new(
            K::Type,
            format!(
                "type error: an index must be an int, got {} {}",
                i.type_name(),
                i.to_source()
            ),
        ));
    };
    usize::try_from(*k)
        .ok()
        .filter(|k| *k < len)
        .ok_or_else(|| {
            Fault::new(
                K::Index,
                format!("index out of range: index {k}, length {len}"),
            )
        })
}

pub(crate) fn index(b: &Value, i: &Value) -> Result<Value, Fault> {
    match b {
        Value::List(items) => Ok(items[index_of(i, items.len())?].clone()),
        Value::Pose(p) => Ok(Value::Float(p[index_of(i, 6)?])),
        // A struct's members by position, in the order they were given (UR's own
        // EtherNet/IP example indexes the struct a `read` returns: `r[fixture]`).
        Value::Struct(members) => Ok(members[index_of(i, members.len())?].1.clone()),
        other => Err(Fault::new(
            K::Type,
            format!("type error: cannot index a {}", other.type_name()),
        )),
    }
}

pub(crate) fn index_mut<'a>(b: &'a mut Value, i: &Value) -> Result<&'a mut Value, Fault> {
    match b {
        Value::List(items) => {
            let k = index_of(i, items.len())?;
            Ok(&mut items[k])
        }
        Value::Struct(members) => {
            let k = index_of(i, members.len())?;
            Ok(&mut members[k].1)
        }
        other => Err(Fault::new(
            K::Type,
            format!(
                "type error: cannot assign into an element of a {}",
                other.type_name()
            ),
        )),
    }
}

/// Stores `v` at `i` in `b`; the value it drops: the element replaced, or `v` itself
/// when its number went into a pose.
pub(crate) fn store_index(b: &mut Value, i: &Value, v: Value) -> Result<Value, Fault> {
    match b {
        Value::List(items) => {
            let k = index_of(i, items.len())?;
            Ok(std::mem::replace(&mut items[k], v))
        }
        Value::Struct(members) => {
            let k = index_of(i, members.len())?;
            Ok(std::mem::replace(&mut members[k].1, v))
        }
        Value::Pose(p) => {
            let k = index_of(i, 6)?;
            p[k] = v.as_f64().ok_or_else(|| {
                Fault::type_error(format!(
                    "type error: a pose element must be a number, got {}",
                    v.type_name()
                ))
            })?;
            Ok(v)
        }
        other => Err(Fault::new(
            K::Type,
            format!(
                "type error: cannot assign into an element of a {}",
                other.type_name()
            ),
        )),
    }
}
