//! Calls: a user function's arguments bound to its parameters, and a built-in (or the
//! stub that replaces it) called with its arguments, its memory charge and its record.

use super::{Called, Machine, Stub, Thread, Wait};
use crate::error::{Fault, RuntimeErrorKind as K};
use crate::event::{CallRecord, Event, Outcome};
use crate::native::{Args, Out};
use crate::syntax::compile::{CallSite, Program, Sym};
use crate::value::size::check_value;
use crate::value::Value;

/// Binds a user function's arguments to its parameters, as the compiler matched them
/// (every parameter without a default is given: the compiler checked). A default that
/// names a variable is that global's value now; a global never assigned is an error.
pub(super) fn bind_user(
    callee: &crate::syntax::compile::Func,
    site: &CallSite,
    args: Vec<Value>,
    globals: &[Option<Value>],
    names: &[String],
    max_size: usize,
) -> Result<Vec<(Sym, Option<Value>)>, Fault> {
    let mut out: Vec<(Sym, Option<Value>)> = Vec::with_capacity(callee.params.len());
    let mut given = vec![false; callee.params.len()];
    for slot in &site.slots {
        if let Some(g) = given.get_mut(usize::from(*slot)) {
            *g = true;
        }
    }
    for ((p, default), given) in callee.params.iter().zip(&given) {
        let v = match default {
            _ if *given => None,
            None => None,
            Some(d) => {
                let v = default_value(d, globals, names, *p, &callee.name)?;
                check_value(&v, max_size)?;
                Some(v)
            }
        };
        out.push((*p, v));
    }
    for (slot, v) in site.slots.iter().zip(args) {
        if let Some(o) = out.get_mut(usize::from(*slot)) {
            o.1 = Some(v);
        }
    }
    Ok(out)
}

/// The value of parameter `param`'s default now: names are the globals' values (a
/// global never assigned is an error), list and pose literals are built from their items
/// (a pose item must be a number). The result is checked against the value bounds by
/// the caller.
fn default_value(
    d: &crate::syntax::parser::ParamDefault<Sym>,
    globals: &[Option<Value>],
    names: &[String],
    param: Sym,
    func: &str,
) -> Result<Value, Fault> {
    use crate::syntax::parser::ParamDefault as D;
    let name = |s: Sym| names.get(s as usize).map_or("?", |n| n.as_str());
    Ok(match d {
        D::Const(v) => v.clone(),
        D::Var(g) => match globals.get(*g as usize).and_then(|v| v.as_ref()) {
            Some(v) => v.clone(),
            None => {
                return Err(Fault::new(
                    K::UnknownVariable,
                    format!(
                        "unknown variable `{}`, the default of parameter `{}` of `{func}`",
                        name(*g),
                        name(param),
                    ),
                ))
            }
        },
        D::List(items) => Value::List(
            items
                .iter()
                .map(|d| default_value(d, globals, names, param, func))
                .collect::<Result<_, _>>()?,
        ),
        D::Pose(items) => {
            let mut p = [0.0; 6];
            for (slot, d) in p.iter_mut().zip(items) {
                let v = default_value(d, globals, names, param, func)?;
                *slot = v.as_f64().ok_or_else(|| {
                    Fault::new(
                        K::Type,
                        format!(
                            "the default of parameter `{}` of `{func}`: a pose item is {}, not a number",
                            name(param),
                            v.type_name()
                        ),
                    )
                })?;
            }
            Value::Pose(p)
        }
    })
}

impl Machine {
    /// Calls a built-in (or the stub that replaces it) from call site `site`.
    pub(super) fn call_native(
        &mut self,
        prog: &Program,
        site: &CallSite,
        stub: Option<u32>,
        args: Vec<Value>,
        current: &Thread,
    ) -> Result<Called, Fault> {
        let name = &prog.names[site.name as usize];
        let traced = match site.builtin {
            _ if stub.is_some() => true,
            Some(b) if b.domain == crate::native::Domain::Sockets => {
                self.config.trace_socket_calls || self.config.trace_all_calls
            }
            _ => self.config.trace_all_calls,
        };
        let mut record = traced.then(|| {
            let positional = usize::from(site.positional).min(args.len());
            Box::new(CallRecord {
                line: site.at.line,
                column: site.at.col,
                name: name.clone(),
                builtin: site.builtin,
                args: args[..positional].to_vec(),
                kwargs: site
                    .kwnames
                    .iter()
                    .map(|k| prog.names[*k as usize].clone())
                    .zip(args[positional..].iter().cloned())
                    .collect(),
                assigned_to: site.assigned.map(|s| prog.names[s as usize].clone()),
                result: Value::None,
                outcome: Outcome::Returned,
                socket: None,
                read: None,
            })
        });
        if let Some(i) = stub {
            let v = match self.config.stubs.get(i as usize).map(|(_, s)| s) {
                Some(Stub::Return(v)) => v.clone(),
                _ => Value::None,
            };
            if let Some(mut r) = record {
                r.result = v.clone();
                r.outcome = Outcome::Stubbed;
                self.ctl.events.push_back(Event::Call(r));
            }
            return Ok(Called::Value(v));
        }
        let Some(builtin) = site.builtin else {
            return Err(Fault::new(
                K::UnknownFunction,
                format!(
                    "`{name}` is not a built-in this interpreter supports (stub it to run past it)"
                ),
            ));
        };
        let mut v: Vec<Value> = builtin
            .params
            .iter()
            .map(|p| p.default.value().unwrap_or(Value::None))
            .collect();
        for (slot, a) in site.slots.iter().zip(args) {
            if let Some(x) = v.get_mut(usize::from(*slot)) {
                *x = a;
            }
        }
        let mut a = Args {
            name: builtin.name,
            params: builtin.params,
            v,
            positional: usize::from(site.positional),
            line: site.at.line,
            read: None,
            failure: None,
            traced: record.is_some(),
        };
        if let Some(r) = record.as_mut() {
            if let Some(k) = builtin.param("socket_name") {
                r.socket = match a.v.get(k) {
                    Some(Value::Str(s)) => Some(String::from_utf8_lossy(s).into_owned()),
                    _ => None,
                };
            }
        }
        // A built-in refuses to allocate past the count before it changes anything: the
        // count may be high (drops not credited), so a recount decides, once.
        let out = match (builtin.run)(&mut self.ctl, &mut a) {
            Err(_) if std::mem::take(&mut self.ctl.mem.refused) => {
                self.recount(Some(current));
                (builtin.run)(&mut self.ctl, &mut a)
            }
            out => out,
        };
        self.ctl.mem.refused = false;
        let out = out?;
        if let Some(r) = record.as_mut() {
            r.read = a.read.take();
            if let Some(why) = a.failure.take() {
                r.outcome = Outcome::Failed(why);
            }
        }
        let (value, wait) = match out {
            Out::Value(v) => (v, None),
            Out::Wait(d, v) => (v, Some(Ok(d))),
            Out::Motion(until, v) => (v, Some(Err(until))),
            Out::Read {
                socket,
                call,
                input,
                buffered_at_start,
            } => {
                return Ok(Called::Block(Wait::Read {
                    socket,
                    call,
                    record,
                    input,
                    buffered_at_start,
                }))
            }
            Out::Connect { socket } => return Ok(Called::Block(Wait::Connect { socket, record })),
            Out::Interpreter(r) => return self.interpreter_request(r),
        };
        if let Some(mut r) = record {
            r.result = value.clone();
            self.ctl.events.push_back(Event::Call(r));
        }
        Ok(match wait {
            Some(Ok(d)) => Called::Block(self.wait_for(d, value)),
            Some(Err(until)) => Called::Block(Wait::Motion {
                until,
                after: self.ctl.step.saturating_add(1),
                result: value,
            }),
            None => Called::Value(value),
        })
    }
}
