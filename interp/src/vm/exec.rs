//! One thread's run: the compiled code's operations until the thread consumes time,
//! finishes or fails; reading variables and the place an assignment writes.

use super::call::bind_user;
use super::memory::{frame_bytes, thread_bytes, ENTRY_BYTES, FRAME_BYTES, SLOT_BYTES};
use super::{Called, Flow, Frame, Machine, Thread, Wait, MAX_THREADS, NATIVE_COPIES};
use crate::error::{Fault, RuntimeError, RuntimeErrorKind as K};
use crate::event::Event;
use crate::syntax::compile::{Op, PathStep, Program, Sym};
use crate::syntax::parser::Scope;
use crate::value::access::{index, index_mut, member, method_target, store_index, store_path};
use crate::value::ops::binary;
use crate::value::size::{binary_bytes, check_value, element_bytes, held_all, member_bytes};
use crate::value::{Value, MEMBER_BYTES, VALUE_BYTES};

impl Machine {
    pub(super) fn exec(&mut self, th: &mut Thread, prog: &Program) -> Result<Flow, RuntimeError> {
        let mut line = 0;
        let mut col;
        loop {
            let Some(frame) = th.frames.last_mut() else {
                return Ok(Flow::Finished);
            };
            let func = &prog.funcs[frame.func as usize];
            let pc = frame.pc as usize;
            let (Some(&op), Some(&at)) = (func.ops.get(pc), func.lines.get(pc)) else {
                return Err(RuntimeError::internal(line, "internal error: code ended"));
            };
            (line, col) = (at.line, at.col);
            frame.pc += 1;
            let fail = |f: Fault| RuntimeError::at(line, col, f);
            match op {
                Op::Stmt => {
                    if self.budget >= self.config.max_statements_per_step {
                        // The time slice is used: this statement runs in the next frame.
                        frame.pc -= 1;
                        th.wait = Wait::Slice(self.ctl.step.saturating_add(1));
                        return Ok(Flow::Blocked);
                    }
                    self.budget += 1;
                }
                Op::Const(c) => {
                    let v = &prog.consts[c as usize];
                    let bytes = if v.is_container() {
                        v.held_bytes()
                    } else {
                        SLOT_BYTES
                    };
                    self.charge(Some(&*th), bytes).map_err(fail)?;
                    th.stack.push(v.clone());
                }
                Op::Load(s) => {
                    let Some(v) = lookup(frame, &self.globals, s) else {
                        return Err(fail(Fault::new(
                            K::UnknownVariable,
                            format!("unknown variable `{}`", prog.names[s as usize]),
                        )));
                    };
                    if !v.is_container() {
                        let v = v.clone();
                        self.charge(Some(&*th), SLOT_BYTES).map_err(fail)?;
                        th.stack.push(v);
                        continue;
                    }
                    // A list, struct or string: the copy is counted before it is made.
                    let bytes = v.held_bytes();
                    self.charge(Some(&*th), bytes).map_err(fail)?;
                    let v = th
                        .frames
                        .last()
                        .and_then(|f| lookup(f, &self.globals, s))
                        .cloned()
                        .unwrap_or(Value::None);
                    th.stack.push(v);
                }
                Op::Store(s, scope) => {
                    let v = pop(&mut th.stack, line)?;
                    let program_scope = func.program_scope;
                    let entries = frame.locals.len();
                    let slot = self.slot(frame, s, scope, program_scope, true, prog, line)?;
                    let old = slot.replace(v);
                    // The value leaves its stack slot for the variable's; the old value
                    // and a new local's entry change the count.
                    let added = if frame.locals.len() > entries {
                        ENTRY_BYTES
                    } else {
                        0
                    };
                    self.ctl.mem.add(added);
                    self.ctl
                        .mem
                        .credit(SLOT_BYTES + old.as_ref().map_or(0, Value::content_bytes));
                }
                Op::StoreIndex(s, scope, n) => {
                    let v = pop(&mut th.stack, line)?;
                    let j = if n == 2 {
                        Some(pop(&mut th.stack, line)?)
                    } else {
                        None
                    };
                    let i = pop(&mut th.stack, line)?;
                    let program_scope = func.program_scope;
                    let max_size = self.config.max_value_size;
                    let slot = self.slot(frame, s, scope, program_scope, false, prog, line)?;
                    let name = &prog.names[s as usize];
                    let Some(target) = slot.as_mut() else {
                        return Err(fail(Fault::new(
                            K::UnknownVariable,
                            format!("unknown variable `{name}`"),
                        )));
                    };
                    // A list or string stored into a list may make it deeper or larger.
                    let grows = matches!(v, Value::List(_) | Value::Str(_));
                    // The value takes the element's place; the element (or, into a
                    // pose, the number) is dropped, and so are the indices.
                    let indices = if j.is_some() { 2 } else { 1 };
                    let dropped = match j {
                        None => store_index(target, &i, v).map_err(fail)?,
                        Some(j) => {
                            let inner = index_mut(target, &i).map_err(fail)?;
                            store_index(inner, &j, v).map_err(fail)?
                        }
                    };
                    let mut freed = dropped.held_bytes() + indices * SLOT_BYTES;
                    if grows {
                        if let Err(f) = check_value(target, max_size) {
                            // The variable keeps no value over the bounds.
                            freed = freed.saturating_add(target.content_bytes());
                            *slot = None;
                            self.ctl.mem.credit(freed);
                            return Err(fail(f));
                        }
                    }
                    self.ctl.mem.credit(freed);
                }
                Op::LoadIndex(s) => {
                    let Some(base) = lookup(frame, &self.globals, s) else {
                        return Err(fail(Fault::new(
                            K::UnknownVariable,
                            format!("unknown variable `{}`", prog.names[s as usize]),
                        )));
                    };
                    // The element's copy takes the index's stack slot.
                    let bytes = th.stack.last().map_or(0, |i| element_bytes(base, i));
                    self.charge(Some(&*th), bytes).map_err(fail)?;
                    let i = pop(&mut th.stack, line)?;
                    let base = th.frames.last().and_then(|f| lookup(f, &self.globals, s));
                    let v = base.map(|b| index(b, &i)).unwrap_or(Ok(Value::None));
                    th.stack.push(v.map_err(fail)?);
                }
                Op::Index => {
                    let bytes = match th.stack.as_slice() {
                        [.., b, i] => element_bytes(b, i),
                        _ => 0,
                    };
                    self.charge(Some(&*th), bytes).map_err(fail)?;
                    let i = pop(&mut th.stack, line)?;
                    let b = pop(&mut th.stack, line)?;
                    th.stack.push(index(&b, &i).map_err(fail)?);
                    // The list leaves the stack; the element's copy takes its index's slot.
                    self.ctl.mem.credit(b.held_bytes());
                }
                Op::MakeList(n) => {
                    // The items move into the list: one more stack slot, the list's.
                    self.charge(Some(&*th), SLOT_BYTES).map_err(fail)?;
                    let at = th.stack.len().saturating_sub(n as usize);
                    let items = th.stack.split_off(at);
                    let list = Value::List(items);
                    check_value(&list, self.config.max_value_size).map_err(fail)?;
                    th.stack.push(list);
                }
                Op::MakePose(n) => {
                    let at = th.stack.len().saturating_sub(n as usize);
                    let items = th.stack.split_off(at);
                    // Numbers into a pose: the items' slots but one are free.
                    self.ctl
                        .mem
                        .credit(held_all(&items).saturating_sub(SLOT_BYTES));
                    let mut p = [0.0; 6];
                    for (k, (slot, v)) in p.iter_mut().zip(&items).enumerate() {
                        *slot = v.as_f64().ok_or_else(|| {
                            fail(Fault::new(
                                K::Type,
                                format!(
                                    "type error: pose element {k} must be a number, got {}",
                                    v.type_name()
                                ),
                            ))
                        })?;
                    }
                    th.stack.push(Value::Pose(p));
                }
                Op::MakeStruct(shape) => {
                    let names = prog.shapes.get(shape as usize).map_or(&[][..], |v| v);
                    // The values become members (a name and a larger slot each), and the
                    // struct takes a stack slot.
                    let bytes = names
                        .iter()
                        .map(|n| MEMBER_BYTES - VALUE_BYTES + prog.names[*n as usize].len())
                        .fold(SLOT_BYTES, usize::saturating_add);
                    self.charge(Some(&*th), bytes).map_err(fail)?;
                    let at = th.stack.len().saturating_sub(names.len());
                    let values = th.stack.split_off(at);
                    let members = names
                        .iter()
                        .map(|n| prog.names[*n as usize].clone())
                        .zip(values)
                        .collect();
                    let v = Value::Struct(members);
                    check_value(&v, self.config.max_value_size).map_err(fail)?;
                    th.stack.push(v);
                }
                Op::Member(m) => {
                    let name = &prog.names[m as usize];
                    let bytes = th.stack.last().map_or(0, |v| member_bytes(v, name));
                    self.charge(Some(&*th), SLOT_BYTES + bytes).map_err(fail)?;
                    let v = pop(&mut th.stack, line)?;
                    th.stack.push(member(&v, name).map_err(fail)?);
                    self.ctl.mem.credit(v.held_bytes());
                }
                Op::LoadMember(s, m) => {
                    let name = &prog.names[m as usize];
                    let Some(bytes) =
                        lookup(frame, &self.globals, s).map(|v| member_bytes(v, name))
                    else {
                        return Err(fail(Fault::new(
                            K::UnknownVariable,
                            format!("unknown variable `{}`", prog.names[s as usize]),
                        )));
                    };
                    self.charge(Some(&*th), SLOT_BYTES + bytes).map_err(fail)?;
                    let v = th.frames.last().and_then(|f| lookup(f, &self.globals, s));
                    let v = v.map(|v| member(v, name)).unwrap_or(Ok(Value::None));
                    th.stack.push(v.map_err(fail)?);
                }
                Op::StorePath(s, path) => {
                    let steps = prog.paths.get(path as usize).map_or(&[][..], |v| v);
                    let v = pop(&mut th.stack, line)?;
                    let n = steps
                        .iter()
                        .filter(|p| matches!(p, PathStep::Index))
                        .count();
                    let at = th.stack.len().saturating_sub(n);
                    let indices = th.stack.split_off(at);
                    let program_scope = func.program_scope;
                    let max_size = self.config.max_value_size;
                    let slot =
                        self.slot(frame, s, Scope::Auto, program_scope, false, prog, line)?;
                    let name = &prog.names[s as usize];
                    let Some(target) = slot.as_mut() else {
                        return Err(fail(Fault::new(
                            K::UnknownVariable,
                            format!("unknown variable `{name}`"),
                        )));
                    };
                    // A list, struct or string stored may make the value deeper or
                    // larger; a number or pose cannot.
                    let grows = v.is_container();
                    // The indices leave the stack; the value takes the place of what it
                    // replaces (dropped).
                    let mut freed = held_all(&indices);
                    let dropped = store_path(target, steps, indices, v, prog).map_err(fail)?;
                    freed = freed.saturating_add(dropped.held_bytes());
                    if grows {
                        if let Err(f) = check_value(target, max_size) {
                            // The variable keeps no value over the bounds.
                            freed = freed.saturating_add(target.content_bytes());
                            *slot = None;
                            self.ctl.mem.credit(freed);
                            return Err(fail(f));
                        }
                    }
                    self.ctl.mem.credit(freed);
                }
                Op::Method(id) => {
                    let site = &prog.methods[id as usize];
                    let args = th
                        .stack
                        .split_off(th.stack.len().saturating_sub(usize::from(site.argc)));
                    let target = pop(&mut th.stack, line)?;
                    // The handle and the arguments leave the stack; the result (now,
                    // or when the call resumes) is counted as it comes.
                    let freed = held_all(&args).saturating_add(target.held_bytes());
                    let (target, method) =
                        method_target(target, &prog.names[site.name as usize])
                            .map_err(|f| RuntimeError::at(site.at.line, site.at.col, f))?;
                    if let Value::Eip(id) = target {
                        let v = self
                            .ctl
                            .eip
                            .call(
                                &mut self.ctl.arm.eip,
                                &self.ctl.arm.world.eip_from_plc,
                                id,
                                method,
                                &args,
                                self.ctl.step,
                            )
                            .map_err(|f| RuntimeError::at(site.at.line, site.at.col, f))?;
                        self.ctl.mem.credit(freed);
                        self.charge(Some(&*th), v.held_bytes()).map_err(fail)?;
                        th.stack.push(v);
                        continue;
                    }
                    let called = self.rpc_call(th, target, method, args, site.at)?;
                    self.ctl.mem.credit(freed);
                    match called {
                        Some(v) => {
                            self.charge(Some(&*th), v.held_bytes()).map_err(fail)?;
                            th.stack.push(v)
                        }
                        None => return Ok(Flow::Blocked),
                    }
                }
                Op::Neg => {
                    let v = pop(&mut th.stack, line)?;
                    th.stack.push(match v {
                        Value::Int(i) => Value::Int(i.wrapping_neg()),
                        Value::Float(f) => Value::Float(-f),
                        Value::Pose(p) => Value::Pose(p.map(|x| -x)),
                        other => {
                            return Err(fail(Fault::new(
                                K::Type,
                                format!("type error: cannot negate a {}", other.type_name()),
                            )))
                        }
                    });
                }
                Op::Not => {
                    let v = pop(&mut th.stack, line)?;
                    let b = as_bool(&v, "not").map_err(fail)?;
                    th.stack.push(Value::Bool(!b));
                }
                Op::Bin(op) => {
                    let r = pop(&mut th.stack, line)?;
                    let l = pop(&mut th.stack, line)?;
                    // Numbers in, a number out: nothing changes. A list or string
                    // result is bounded before it is made, then counted exactly.
                    if l.is_container() || r.is_container() {
                        th.stack.push(l);
                        th.stack.push(r);
                        let bytes = match th.stack.as_slice() {
                            [.., l, r] => binary_bytes(op, l, r),
                            _ => 0,
                        };
                        self.reserve(Some(&*th), bytes).map_err(fail)?;
                        let r = pop(&mut th.stack, line)?;
                        let l = pop(&mut th.stack, line)?;
                        let freed = l.held_bytes().saturating_add(r.held_bytes());
                        let v = binary(op, l, r).map_err(fail)?;
                        check_value(&v, self.config.max_value_size).map_err(fail)?;
                        self.ctl.mem.credit(freed);
                        self.charge(Some(&*th), v.held_bytes()).map_err(fail)?;
                        th.stack.push(v);
                    } else {
                        let v = binary(op, l, r).map_err(fail)?;
                        self.ctl.mem.credit(SLOT_BYTES);
                        th.stack.push(v);
                    }
                }
                Op::Jump(t) => frame.pc = t,
                Op::JumpIfFalse(t) => {
                    let v = pop(&mut th.stack, line)?;
                    if !as_bool(&v, "condition").map_err(fail)? {
                        frame.pc = t;
                    }
                    self.ctl.mem.credit(SLOT_BYTES);
                }
                Op::JumpIfFalseKeep(t) | Op::JumpIfTrueKeep(t) => {
                    let want = matches!(op, Op::JumpIfTrueKeep(_));
                    let v = th.stack.last().cloned().unwrap_or(Value::None);
                    let what = if want { "or" } else { "and" };
                    if as_bool(&v, what).map_err(fail)? == want {
                        frame.pc = t;
                    } else {
                        th.stack.pop();
                        self.ctl.mem.credit(SLOT_BYTES);
                    }
                }
                Op::CheckBool => {
                    let v = th.stack.last().cloned().unwrap_or(Value::None);
                    as_bool(&v, "and/or").map_err(fail)?;
                }
                Op::Call(fid, site) => {
                    let site = &prog.sites[site as usize];
                    let args = th
                        .stack
                        .split_off(th.stack.len().saturating_sub(usize::from(site.argc)));
                    let callee = &prog.funcs[fid as usize];
                    // The arguments leave the stack for the new frame's locals.
                    let freed = held_all(&args);
                    let locals = bind_user(
                        callee,
                        site,
                        args,
                        &self.globals,
                        &prog.names,
                        self.config.max_value_size,
                    )
                    .map_err(fail)?;
                    if th.frames.len() >= 256 {
                        return Err(fail(Fault::new(
                            K::Limit,
                            format!("calls nested too deeply (256) calling `{}`", callee.name),
                        )));
                    }
                    let frame = Frame {
                        func: fid,
                        pc: 0,
                        locals,
                        base: th.stack.len(),
                    };
                    self.ctl.mem.credit(freed);
                    self.charge(Some(&*th), frame_bytes(&frame)).map_err(fail)?;
                    th.frames.push(frame);
                }
                Op::Native(site) => {
                    let id = site as usize;
                    let site = &prog.sites[id];
                    let args = th
                        .stack
                        .split_off(th.stack.len().saturating_sub(usize::from(site.argc)));
                    let stub = self.site_stubs.get(id).copied().flatten();
                    // The arguments leave the stack; a call record or a message may keep
                    // copies of them and their text while the driver has not taken them.
                    let freed = held_all(&args);
                    let copies = freed.saturating_sub(args.len() * SLOT_BYTES);
                    self.reserve(Some(&*th), copies.saturating_mul(NATIVE_COPIES))
                        .map_err(fail)?;
                    let called = self
                        .call_native(prog, site, stub, args, &*th)
                        .map_err(fail)?;
                    self.ctl.mem.credit(freed);
                    match called {
                        // `powerdown()`: the program ends there, as `halt` ends it.
                        Called::Value(_) if self.ctl.effects.contains(&crate::Effect::PowerOff) => {
                            return Ok(Flow::Halt)
                        }
                        Called::Value(v) => {
                            check_value(&v, self.config.max_value_size).map_err(fail)?;
                            self.charge(Some(&*th), v.held_bytes()).map_err(fail)?;
                            th.stack.push(v)
                        }
                        Called::Block(w) => {
                            th.wait = w;
                            return Ok(Flow::Blocked);
                        }
                    }
                }
                Op::Return | Op::ReturnNone => {
                    let v = if matches!(op, Op::Return) {
                        pop(&mut th.stack, line)?
                    } else {
                        Value::None
                    };
                    // A returned value was counted on the stack; `None` is counted when
                    // it is pushed.
                    let returned = if matches!(op, Op::Return) {
                        v.held_bytes()
                    } else {
                        0
                    };
                    let base = frame.base;
                    let popped = th.frames.pop();
                    let left = th.stack.get(base..).map_or(0, held_all);
                    th.stack.truncate(base);
                    self.ctl.mem.credit(left);
                    if th.id == 0 && self.interp.executing == Some(th.frames.len()) {
                        // An interpreted statement ended: back to interpreter mode; the
                        // locals it borrowed go back to the function that called
                        // `interpreter_mode()`.
                        self.interp.executing = None;
                        self.ctl.mem.credit(FRAME_BYTES.saturating_add(returned));
                        if let (Some(p), Some(caller)) = (popped, th.frames.last_mut()) {
                            caller.locals = p.locals;
                        }
                        th.wait = Wait::Interpreter;
                        return Ok(Flow::Blocked);
                    }
                    self.ctl.mem.credit(popped.as_ref().map_or(0, frame_bytes));
                    if th.frames.is_empty() {
                        self.ctl.mem.credit(returned);
                        return Ok(Flow::Finished);
                    }
                    if returned == 0 {
                        self.ctl.mem.add(SLOT_BYTES);
                    }
                    th.stack.push(v);
                }
                Op::Pop => {
                    if let Some(v) = th.stack.pop() {
                        self.ctl.mem.credit(v.held_bytes());
                    }
                }
                Op::Halt => return Ok(Flow::Halt),
                Op::Run(fid) => {
                    let live = self.threads.iter().filter(|t| !t.done).count();
                    if live >= MAX_THREADS {
                        return Err(fail(Fault::new(
                            K::Limit,
                            format!(
                                "`run {}()`: more than {MAX_THREADS} threads running",
                                prog.funcs[fid as usize].name
                            ),
                        )));
                    }
                    // Handles are never reused: one of a finished thread names no other.
                    let id = self.next_thread_id;
                    self.next_thread_id = id.checked_add(1).ok_or_else(|| {
                        fail(Fault::new(K::Limit, "more than 4294967295 threads started"))
                    })?;
                    let new = Thread {
                        id,
                        frames: vec![Frame {
                            func: fid,
                            pc: 0,
                            locals: Vec::new(),
                            base: 0,
                        }],
                        stack: Vec::new(),
                        wait: Wait::None,
                        done: false,
                        critical: 0,
                    };
                    // The thread and its handle on the stack.
                    self.charge(Some(&*th), thread_bytes(&new).saturating_add(SLOT_BYTES))
                        .map_err(fail)?;
                    self.threads.push(new);
                    th.stack.push(Value::Thread(id));
                }
                Op::Join => {
                    let v = pop(&mut th.stack, line)?;
                    self.ctl.mem.credit(v.held_bytes());
                    if let Value::Thread(id) = v {
                        if id == th.id {
                            return Err(fail(Fault::from("a thread cannot join itself")));
                        }
                        if self.thread(id).is_some() {
                            th.wait = Wait::Join(id);
                            // Resume without a value: `join` is a statement.
                            return Ok(Flow::Blocked);
                        }
                    }
                }
                Op::Kill => {
                    let v = pop(&mut th.stack, line)?;
                    self.ctl.mem.credit(v.held_bytes());
                    if let Value::Thread(id) = v {
                        if id == th.id {
                            return Ok(Flow::Finished);
                        }
                        if let Some(t) = self.threads.iter_mut().find(|t| t.id == id && !t.done) {
                            // The motion it commanded stops where the arm is.
                            if self.ctl.motion.as_ref().is_some_and(|m| m.owner == id) {
                                self.ctl.halt();
                            }
                            self.ctl.mem.credit(thread_bytes(t));
                            t.done = true;
                            t.frames = Vec::new();
                            t.stack = Vec::new();
                            // A read it was waiting for ends with it.
                            match std::mem::replace(&mut t.wait, Wait::None) {
                                Wait::Read { socket, .. } => self.ctl.sockets.give_up(&socket),
                                Wait::Rpc(p) => self.ctl.events.push_back(Event::Close {
                                    socket_name: p.socket,
                                }),
                                _ => {}
                            }
                        }
                    }
                }
                Op::EnterCritical => th.critical = th.critical.saturating_add(1),
                Op::ExitCritical => th.critical = th.critical.saturating_sub(1),
            }
        }
    }

    /// The variable `s` an assignment writes: a local of the frame, or a global.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn slot<'a>(
        &'a mut self,
        frame: &'a mut Frame,
        s: Sym,
        scope: Scope,
        program_scope: bool,
        create: bool,
        prog: &Program,
        line: u32,
    ) -> Result<&'a mut Option<Value>, RuntimeError> {
        let local_at = frame.locals.iter().rposition(|(n, _)| *n == s);
        let global = match scope {
            Scope::Global => true,
            Scope::Local => false,
            Scope::Auto => {
                local_at.is_none() && (program_scope || self.globals[s as usize].is_some())
            }
        };
        if global {
            return Ok(&mut self.globals[s as usize]);
        }
        let at = match local_at {
            Some(i) => i,
            None if create => {
                frame.locals.push((s, None));
                frame.locals.len() - 1
            }
            None => {
                return Err(RuntimeError::at(
                    line,
                    1,
                    Fault::new(
                        K::UnknownVariable,
                        format!("unknown variable `{}`", prog.names[s as usize]),
                    ),
                ))
            }
        };
        Ok(&mut frame.locals[at].1)
    }
}

/// The value of variable `s` as a frame reads it: its local, else the global.
fn lookup<'a>(frame: &'a Frame, globals: &'a [Option<Value>], s: Sym) -> Option<&'a Value> {
    frame
        .locals
        .iter()
        .rev()
        .find(|(n, _)| *n == s)
        .and_then(|(_, v)| v.as_ref())
        .or_else(|| globals.get(s as usize).and_then(Option::as_ref))
}

fn pop(stack: &mut Vec<Value>, line: u32) -> Result<Value, RuntimeError> {
    stack
        .pop()
        .ok_or_else(|| RuntimeError::internal(line, "internal error: stack empty"))
}

/// A condition's truth: a bool, or a number (non-zero is true: UR's own External Control
/// script tests a float, `if has_qnear:`). Anything else is a type error.
fn as_bool(v: &Value, what: &str) -> Result<bool, Fault> {
    match v {
        Value::Bool(b) => Ok(*b),
        Value::Int(i) => Ok(*i != 0),
        Value::Float(f) => Ok(*f != 0.0),
        other => Err(Fault::new(
            K::Type,
            format!(
                "type error: `{what}` needs a bool, got {} {}",
                other.type_name(),
                other.to_source()
            ),
        )),
    }
}
