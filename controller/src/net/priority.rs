//! Real-time scheduling for the real-time loop's thread, where the host permits it: a
//! real controller's loop never waits for another process, and on a busy machine the
//! kernel's fair scheduler makes the virtual one wait milliseconds. The loop asks for
//! `SCHED_FIFO` at [`FIFO_PRIORITY`], else a nice value of [`NICE`], and for its
//! process's memory to stay in RAM as it is touched (`mlockall` with `MCL_ONFAULT`, so
//! nothing is made resident ahead); it runs the same whatever it got, and says once what
//! that was ([`super::ServerEvent::Scheduling`]).

/// Whether the loop asks for real-time scheduling.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Realtime {
    /// Ask, and run with whatever is granted (the default).
    #[default]
    Auto,
    /// Do not ask: the thread keeps the process's scheduling.
    Off,
}

/// What the loop's thread got.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Scheduling {
    /// `SCHED_FIFO 10`, `nice -10`, or `normal`.
    pub policy: String,
    /// Whether the process's memory is locked in RAM.
    pub memory_locked: bool,
    /// Why the better ones were refused (the system's errors), if they were.
    pub refused: Vec<String>,
}

/// The `SCHED_FIFO` priority asked for (1 to 99): above every normal thread, below the
/// kernel's own real-time threads (50) and the usual audio and control daemons, so a
/// virtual controller never starves the host.
pub const FIFO_PRIORITY: u8 = 10;

/// The nice value asked for when `SCHED_FIFO` is refused: the most favoured a process may
/// usually take with `CAP_SYS_NICE` or a raised `RLIMIT_NICE`, short of the -20 that
/// starves interactive work.
pub const NICE: i32 = -10;

/// Applies `mode` to the calling thread.
pub(crate) fn apply(mode: Realtime) -> Scheduling {
    let mut s = Scheduling {
        policy: "normal".into(),
        ..Scheduling::default()
    };
    if mode == Realtime::Off {
        return s;
    }
    apply_os(&mut s);
    s
}

#[cfg(target_os = "linux")]
fn apply_os(s: &mut Scheduling) {
    use thread_priority::unix::{
        set_thread_priority_and_policy, thread_native_id, RealtimeThreadSchedulePolicy,
        ThreadSchedulePolicy,
    };
    use thread_priority::{ThreadPriority, ThreadPriorityValue};
    let fifo = ThreadPriorityValue::try_from(FIFO_PRIORITY)
        .map_err(|e| e.to_string())
        .and_then(|p| {
            set_thread_priority_and_policy(
                thread_native_id(),
                ThreadPriority::Crossplatform(p),
                ThreadSchedulePolicy::Realtime(RealtimeThreadSchedulePolicy::Fifo),
            )
            .map_err(|e| format!("{e:?}"))
        });
    match fifo {
        Ok(()) => s.policy = format!("SCHED_FIFO {FIFO_PRIORITY}"),
        Err(e) => {
            s.refused.push(format!("SCHED_FIFO: {e}"));
            let tid = rustix::thread::gettid();
            match rustix::process::setpriority_process(Some(tid), NICE) {
                Ok(()) => s.policy = format!("nice {NICE}"),
                Err(e) => s.refused.push(format!("nice {NICE}: {e}")),
            }
        }
    }
    use rustix::mm::{mlockall, MlockAllFlags};
    match mlockall(MlockAllFlags::CURRENT | MlockAllFlags::FUTURE | MlockAllFlags::ONFAULT) {
        Ok(()) => s.memory_locked = true,
        Err(e) => s.refused.push(format!("mlockall: {e}")),
    }
}

#[cfg(not(target_os = "linux"))]
fn apply_os(s: &mut Scheduling) {
    s.refused
        .push("real-time scheduling is asked for on Linux only".into());
}
