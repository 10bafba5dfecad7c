//! Interpreter mode (e-Series 5.10+): `interpreter_mode`, `end_interpreter`,
//! `clear_interpreter`. They act on the program itself (its queue of interpreted
//! statements, its main thread): each returns its request to the machine, which acts on
//! it. See [`crate::interpreter`] for the mode and the interpreter socket's lines.

use super::{builtin, Args, Builtin, Domain, Out};
use crate::error::Fault;
use crate::native::InterpreterRequest;
use crate::runtime::Runtime;

const D: Domain = Domain::Interpreter;

pub(super) const TABLE: &[Builtin] = &[
    builtin!(
        clear_interpreter() => |_, _| request(InterpreterRequest::Clear),
        "Removes everything interpreted in the current interpreter mode (functions, threads, variables) once the statement calling it ends; lines sent after it wait until then. Only in interpreter mode.",
    ),
    builtin!(
        end_interpreter() => |_, _| request(InterpreterRequest::End),
        "Ends interpreter mode: `interpreter_mode()` returns once the statement running ends. Nothing happens outside interpreter mode.",
    ),
    builtin!(
        interpreter_mode(clearQueueOnEnter: bool = Bool(true), clearOnEnd: bool = Bool(true)) => enter,
        "Blocks the main thread in interpreter mode: statements sent to the interpreter socket (30020) run in order until `end_interpreter()`.",
    ),
];

fn request(r: InterpreterRequest) -> Result<Out, Fault> {
    Ok(Out::Interpreter(r))
}

fn enter(
    _: &mut Runtime,
    _: &mut Args,
    clear_queue: bool,
    clear_on_end: bool,
) -> Result<Out, Fault> {
    request(InterpreterRequest::Enter {
        clear_queue,
        clear_on_end,
    })
}
