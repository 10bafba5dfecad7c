//! The running program's memory budget ([`Config::max_memory`](crate::Config::max_memory)).
//!
//! The machine counts the bytes the program holds, as it allocates: every value on a
//! thread's stack ([`VALUE_BYTES`] plus what it owns: list elements, string bytes,
//! struct members, at every depth), every variable's value (globals and the locals of
//! every frame of every thread), each local's entry ([`ENTRY_BYTES`]), each call frame
//! ([`FRAME_BYTES`]), each thread ([`THREAD_BYTES`] plus its name), and the events
//! waiting for the driver (bytes to send, messages, call records: [`Events`]).
//!
//! The count is kept incrementally: charged where a value is made or copied, before
//! the allocation, and credited where one is dropped. A charge that would pass the
//! budget first recounts everything the program holds (the count only ever errs high:
//! a drop not credited leaves it above the truth), and fails only if the recount
//! confirms it: the program then stops with a [`Limit`](crate::RuntimeErrorKind::Limit)
//! error naming the budget and the bytes. A recount is linear in what the program
//! holds and happens only when the count reaches the budget.

use std::collections::VecDeque;

use super::{Frame, Machine, Thread};
use crate::error::{Fault, RuntimeErrorKind as K};
use crate::event::Event;
use crate::value::size::held_all;
use crate::value::{Value, VALUE_BYTES};

/// The default of [`Config::max_memory`](crate::Config::max_memory): 256 MiB.
pub(crate) const DEFAULT_MAX_MEMORY: usize = 256 * 1024 * 1024;

/// The bytes one call frame takes besides its locals (the frame record, with room for
/// its return address and stack base).
pub(crate) const FRAME_BYTES: usize = std::mem::size_of::<crate::vm::Frame>();

/// The bytes one local variable's entry takes in its frame (its name and its slot; the
/// value's own content is counted apart).
pub(crate) const ENTRY_BYTES: usize = std::mem::size_of::<(u32, Option<Value>)>();

/// The bytes one thread takes besides its name, frames and stack.
pub(crate) const THREAD_BYTES: usize = std::mem::size_of::<crate::vm::Thread>();

/// The bytes an event holds: the event itself and the text and values it owns.
fn event_bytes(e: &Event) -> usize {
    let held = |v: &Value| v.held_bytes();
    let extra = match e {
        Event::Connect {
            socket_name, host, ..
        } => socket_name.len() + host.len(),
        Event::Transmit { socket_name, bytes } => socket_name.len() + bytes.len(),
        Event::Close { socket_name } => socket_name.len(),
        Event::Message(m) => {
            let title = match &m.kind {
                crate::event::MessageKind::Popup { title, .. } => title.len(),
                _ => 0,
            };
            m.text.len() + title + m.args.iter().map(held).sum::<usize>()
        }
        Event::Call(r) => {
            std::mem::size_of::<crate::event::CallRecord>()
                + r.name.len()
                + r.args.iter().map(held).sum::<usize>()
                + r.kwargs
                    .iter()
                    .map(|(k, v)| k.len() + held(v))
                    .sum::<usize>()
                + r.assigned_to.as_ref().map_or(0, String::len)
                + held(&r.result)
                + match &r.outcome {
                    crate::event::Outcome::Failed(why) => why.len(),
                    _ => 0,
                }
                + r.socket.as_ref().map_or(0, String::len)
                + r.read.as_ref().map_or(0, |read| {
                    std::mem::size_of::<crate::event::ReadRecord>() + read.input.len()
                })
        }
        Event::MoveStart(_) => std::mem::size_of::<crate::event::MoveStart>(),
        Event::MoveEnd(_) => std::mem::size_of::<crate::event::MoveEnd>(),
        Event::Output(_) => 0,
    };
    std::mem::size_of::<Event>().saturating_add(extra)
}

/// The events waiting for the driver, oldest first, with the bytes they hold.
#[derive(Debug, Default)]
pub(crate) struct Events {
    queue: VecDeque<(Event, usize)>,
    bytes: usize,
}

impl Events {
    pub fn push_back(&mut self, e: Event) {
        let n = event_bytes(&e);
        self.bytes = self.bytes.saturating_add(n);
        self.queue.push_back((e, n));
    }

    pub fn pop_front(&mut self) -> Option<Event> {
        let (e, n) = self.queue.pop_front()?;
        self.bytes = self.bytes.saturating_sub(n);
        Some(e)
    }

    /// The bytes the waiting events hold.
    #[inline]
    pub fn bytes(&self) -> usize {
        self.bytes
    }
}

/// The count of what the program holds besides its events (see the module docs).
#[derive(Debug, Default)]
pub(crate) struct Memory {
    /// The bytes held: never below the truth.
    pub held: usize,
    /// The budget, [`Config::max_memory`](crate::Config::max_memory).
    pub limit: usize,
    /// A built-in refused to allocate ([`Runtime::reserve`](crate::runtime::Runtime::reserve))
    /// on the count: the machine recounts and runs it again once.
    pub refused: bool,
}

impl Memory {
    pub fn new(limit: usize) -> Self {
        Memory {
            held: 0,
            limit,
            refused: false,
        }
    }

    /// Adds bytes that need no check (a few, where a check follows soon).
    #[inline]
    pub fn add(&mut self, bytes: usize) {
        self.held = self.held.saturating_add(bytes);
    }

    /// Adds `bytes` if they fit with `events` bytes of events waiting.
    #[inline]
    pub fn try_add(&mut self, events: usize, bytes: usize) -> bool {
        let fits = self.fits(events, bytes);
        if fits {
            self.held += bytes;
        }
        fits
    }

    /// Bytes dropped.
    #[inline]
    pub fn credit(&mut self, bytes: usize) {
        self.held = self.held.saturating_sub(bytes);
    }

    /// Whether `bytes` more fit, with `events` bytes of events waiting.
    #[inline]
    pub fn fits(&self, events: usize, bytes: usize) -> bool {
        self.held.saturating_add(events).saturating_add(bytes) <= self.limit
    }

    /// The error of a program that would pass its budget: what it holds and needs.
    pub fn over(&self, events: usize, bytes: usize) -> Fault {
        Fault::new(
            K::Limit,
            format!(
                "memory budget exceeded: the program holds {} bytes and needs {bytes} more, over its budget of {} bytes (values of every variable, frame and thread, call frames, threads, events not yet taken)",
                self.held.saturating_add(events),
                self.limit
            ),
        )
    }
}

/// The bytes one stack slot takes (a value's own slot).
pub(crate) const SLOT_BYTES: usize = VALUE_BYTES;

impl Machine {
    /// Sets the count to what the program holds now: the globals and every live thread,
    /// with `current` (the thread running, out of the list while it runs).
    pub(super) fn recount(&mut self, current: Option<&Thread>) {
        let globals = self
            .globals
            .iter()
            .filter_map(Option::as_ref)
            .map(Value::content_bytes)
            .fold(0, usize::saturating_add);
        let threads = self
            .threads
            .iter()
            .filter(|t| !t.done)
            .chain(current)
            .map(thread_bytes)
            .fold(0, usize::saturating_add);
        self.ctl.mem.held = globals.saturating_add(threads);
    }

    /// Counts `bytes` the program is about to allocate, or refuses them (a recount
    /// first, if the count says they do not fit) with the budget's error.
    #[inline]
    pub(super) fn charge(&mut self, current: Option<&Thread>, bytes: usize) -> Result<(), Fault> {
        if self.ctl.mem.try_add(self.ctl.events.bytes(), bytes) {
            return Ok(());
        }
        self.charge_after_recount(current, bytes)
    }

    /// [`charge`](Self::charge) when the count says the bytes do not fit.
    #[cold]
    #[inline(never)]
    fn charge_after_recount(
        &mut self,
        current: Option<&Thread>,
        bytes: usize,
    ) -> Result<(), Fault> {
        self.reserve(current, bytes)?;
        self.ctl.mem.add(bytes);
        Ok(())
    }

    /// Whether `bytes` more fit in the budget (a recount first, if the count says they
    /// do not), without counting them.
    #[inline]
    pub(super) fn reserve(&mut self, current: Option<&Thread>, bytes: usize) -> Result<(), Fault> {
        let events = self.ctl.events.bytes();
        if !self.ctl.mem.fits(events, bytes) {
            self.recount(current);
            if !self.ctl.mem.fits(events, bytes) {
                return Err(self.ctl.mem.over(events, bytes));
            }
        }
        Ok(())
    }

    /// The count of the program's memory and a recount of it now, for tests of the
    /// accounting (the count must never be below the recount). Not for drivers.
    #[doc(hidden)]
    pub fn memory_audit(&mut self) -> (usize, usize) {
        let counted = self.ctl.mem.held;
        self.recount(None);
        let recounted = self.ctl.mem.held;
        self.ctl.mem.held = counted;
        (counted, recounted)
    }
}

/// The bytes a frame holds: the frame, its locals' entries and their values' content.
pub(super) fn frame_bytes(f: &Frame) -> usize {
    let values: usize = f
        .locals
        .iter()
        .filter_map(|(_, v)| v.as_ref())
        .map(Value::content_bytes)
        .fold(0, usize::saturating_add);
    FRAME_BYTES
        .saturating_add(f.locals.len().saturating_mul(ENTRY_BYTES))
        .saturating_add(values)
}

/// The bytes a thread holds: itself, its name, its frames and its stack.
pub(super) fn thread_bytes(t: &Thread) -> usize {
    t.frames
        .iter()
        .map(frame_bytes)
        .fold(THREAD_BYTES, usize::saturating_add)
        .saturating_add(held_all(&t.stack))
}
