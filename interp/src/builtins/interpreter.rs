//! Interpreter mode (e-Series 5.10+): `interpreter_mode`, `end_interpreter`,
//! `clear_interpreter`. They act on the program itself (its queue of interpreted
//! statements, its main thread), so the machine runs them: the entries here give their
//! names and parameters to the compiler. See [`crate::interpreter`] for the mode and the
//! interpreter socket's lines.

use super::{opt, Args, Builtin, Default, Domain, Out};
use crate::error::Fault;
use crate::runtime::Runtime;

const D: Domain = Domain::Interpreter;

pub(super) const TABLE: &[Builtin] = &[
    Builtin::new(
        "clear_interpreter",
        D,
        &[],
        "Removes everything interpreted in the current interpreter mode (functions, threads, variables) once the statement calling it ends; lines sent after it wait until then. Only in interpreter mode.",
        by_machine,
    ),
    Builtin::new(
        "end_interpreter",
        D,
        &[],
        "Ends interpreter mode: `interpreter_mode()` returns once the statement running ends. Nothing happens outside interpreter mode.",
        by_machine,
    ),
    Builtin::new(
        "interpreter_mode",
        D,
        &[
            opt("clearQueueOnEnter", Default::Bool(true)),
            opt("clearOnEnd", Default::Bool(true)),
        ],
        "Blocks the main thread in interpreter mode: statements sent to the interpreter socket (30020) run in order until `end_interpreter()`.",
        by_machine,
    ),
];

/// The machine intercepts these built-ins before their code would run.
fn by_machine(_: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    Err(Fault::from(format!(
        "internal error: `{}` is run by the machine",
        a.name
    )))
}
