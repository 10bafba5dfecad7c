//! Threads and time: `sync`, `sleep`, `get_steptime`. (`run`, `join`, `kill`,
//! `enter_critical` and `exit_critical` are statements, in [`crate::machine`].)

use super::{req, secs, Args, Builtin, Domain, Out};
use crate::controller::Controller;
use crate::error::Fault;
use crate::value::Value;

const D: Domain = Domain::Time;

pub(super) const TABLE: &[Builtin] = &[
    Builtin::new(
        "sync",
        D,
        &[],
        "Uses up the rest of this step: the thread goes on at the next one.",
        sync,
    ),
    Builtin::new(
        "sleep",
        D,
        &[req("t")],
        "Waits t seconds of program time (at least one step).",
        sleep,
    ),
    Builtin::new(
        "get_steptime",
        D,
        &[],
        "The length of one step in seconds (0.002 e-Series, 0.008 CB3).",
        get_steptime,
    ),
];

fn sync(c: &mut Controller, _: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Wait(c.step_time, Value::None))
}

fn sleep(_: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Wait(secs(a.num(0)?), Value::None))
}

fn get_steptime(c: &mut Controller, _: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(Value::Float(c.step_time.as_secs_f64())))
}
