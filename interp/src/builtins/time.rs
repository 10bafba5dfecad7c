//! Threads and time: `sync`, `sleep`, `get_steptime`, `time`. (`run`, `join`, `kill`,
//! `enter_critical` and `exit_critical` are statements, in [`crate::machine`].)
//!
//! `time(mode=0)` (e-Series 5.x manual, the `time` page of its function reference)
//! returns `struct(sec, nanosec)`, both ints, from one of the manual's sources, on the
//! virtual controller's clock (the program time, which is an input; no real clock is
//! read):
//! - `0`: controller execution time, monotonic: [`World::controller_uptime`] plus the
//!   program time (the start of the step the call runs in).
//! - `2`: system time, GMT: [`World::system_time`] plus the program time.
//! - `1` is "reserved" in the manual, and it names no other mode: both are a runtime
//!   error here (our choice; the manual does not say what the controller does).
//!
//! `sec` is a URScript int (32 bits): a time past 2038-01-19 (2³¹ s) is a runtime error
//! rather than a wrapped number.
//!
//! [`World::controller_uptime`]: crate::World::controller_uptime
//! [`World::system_time`]: crate::World::system_time

use super::{builtin, secs, Args, Builtin, Domain, Out};
use crate::error::Fault;
use crate::runtime::Runtime;
use crate::value::Value;

const D: Domain = Domain::Time;

pub(super) const TABLE: &[Builtin] = &[
    builtin!(
        sync() => sync,
        "Uses up the rest of this step: the thread goes on at the next one.",
    ),
    builtin!(
        sleep(t: f64) => sleep,
        "Waits t seconds of program time (at least one step).",
    ),
    builtin!(
        get_steptime() => get_steptime,
        "The length of one step in seconds (0.002 e-Series, 0.008 CB3).",
    ),
    builtin!(
        time(mode: i32 = Int(0)) => time,
        "The time as struct(sec, nanosec): mode 0 the controller's execution time, mode 2 the system time (GMT), both on the virtual clock.",
    ),
];

fn sync(c: &mut Runtime, _: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Wait(c.step_time, Value::None))
}

fn sleep(_: &mut Runtime, _: &mut Args, t: f64) -> Result<Out, Fault> {
    Ok(Out::Wait(secs(t), Value::None))
}

fn get_steptime(c: &mut Runtime, _: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(Value::Float(c.step_time.as_secs_f64())))
}

fn time(c: &mut Runtime, _: &mut Args, mode: i32) -> Result<Out, Fault> {
    let start = match mode {
        0 => c.arm.world.controller_uptime,
        2 => c.arm.world.system_time,
        1 => {
            return Err(Fault::from(
                "`time`: mode 1 is reserved (modes: 0, 2)".to_string(),
            ))
        }
        m => return Err(Fault::from(format!("`time`: no mode {m} (modes: 0, 2)"))),
    };
    let t = start.saturating_add(c.now());
    let sec = i32::try_from(t.as_secs()).map_err(|_| {
        Fault::from(format!(
            "`time`: {} s does not fit in an int (at most {})",
            t.as_secs(),
            i32::MAX
        ))
    })?;
    // subsec_nanos() < 10⁹ < 2³¹.
    let nanosec = i32::try_from(t.subsec_nanos()).unwrap_or(i32::MAX);
    Ok(Out::Value(Value::Struct(vec![
        ("sec".to_string(), Value::Int(sec)),
        ("nanosec".to_string(), Value::Int(nanosec)),
    ])))
}
