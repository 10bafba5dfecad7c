//! The virtual controller's clock: the time since the start, less the time the host
//! took the real-time loop away.
//!
//! A real controller never falls behind its steps. The virtual one runs on a host that
//! may stall its real-time thread (a loaded machine, a debugger, a suspended process);
//! advancing the cell by the whole stall at once would run many steps of the program
//! with none of its sockets read in between, so a `socket_read_...` whose reply had long
//! arrived would time out, and a client waiting for RTDE packages would see a gap that no
//! robot makes. So the real-time loop reads the clock with [`Clock::tick`]: a reading
//! more than [`MAX_LATE_STEPS`] steps after the previous one is held back to one step
//! after it, and the time held back is not controller time for anyone (every interface
//! reads [`Clock::now`]). Stalls shorter than that run in catch-up, as before.

use std::sync::Mutex;
use std::time::{Duration, Instant};

/// How many steps late the real-time loop may be before the clock holds the rest back.
pub(crate) const MAX_LATE_STEPS: u32 = 4;

#[derive(Debug, Default, Clone, Copy)]
struct State {
    /// Wall time that is not controller time.
    lag: Duration,
    /// The controller time of the last tick.
    last: Option<Duration>,
}

/// The controller's clock (see the module).
#[derive(Debug)]
pub(crate) struct Clock {
    start: Instant,
    step: Duration,
    state: Mutex<State>,
}

impl Clock {
    /// A clock starting now, for a controller stepping every `step`.
    pub(crate) fn new(step: Duration) -> Clock {
        Clock {
            start: Instant::now(),
            step,
            state: Mutex::new(State::default()),
        }
    }

    fn state(&self) -> std::sync::MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// The controller time now.
    pub(crate) fn now(&self) -> Duration {
        self.now_at(self.start.elapsed())
    }

    /// The controller time at `wall` (time since the start).
    pub(crate) fn now_at(&self, wall: Duration) -> Duration {
        wall.saturating_sub(self.state().lag)
    }

    /// The controller time for the real-time loop's next step: [`Clock::now`], unless
    /// that is more than [`MAX_LATE_STEPS`] steps after the last tick, in which case the
    /// excess is held back and the time is one step after the last tick.
    pub(crate) fn tick(&self) -> Duration {
        self.tick_at(self.start.elapsed())
    }

    /// [`Clock::tick`] at `wall` (time since the start).
    pub(crate) fn tick_at(&self, wall: Duration) -> Duration {
        let mut s = self.state();
        let mut now = wall.saturating_sub(s.lag);
        if let Some(last) = s.last {
            let due = last.saturating_add(self.step);
            if now > due.saturating_add(self.step.saturating_mul(MAX_LATE_STEPS)) {
                s.lag = s.lag.saturating_add(now - due);
                now = due;
            }
            // A tick never goes back (another thread may not move `last`, but be safe).
            now = now.max(last);
        }
        s.last = Some(now);
        now
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const STEP: Duration = Duration::from_millis(2);

    fn ms(n: u64) -> Duration {
        Duration::from_millis(n)
    }

    #[test]
    fn on_time_ticks_are_wall_time() {
        let c = Clock::new(STEP);
        for n in 0..100 {
            assert_eq!(c.tick_at(ms(2 * n)), ms(2 * n));
        }
        assert_eq!(c.now_at(ms(200)), ms(200));
    }

    #[test]
    fn a_short_delay_is_caught_up() {
        let c = Clock::new(STEP);
        c.tick_at(ms(10));
        // Four steps late: still caught up, no time held back.
        assert_eq!(c.tick_at(ms(20)), ms(20));
        assert_eq!(c.now_at(ms(30)), ms(30));
    }

    #[test]
    fn a_stall_is_held_back_for_every_reader() {
        let c = Clock::new(STEP);
        c.tick_at(ms(10));
        // The host stalled the loop for 300 ms: the controller moves one step only.
        assert_eq!(c.tick_at(ms(310)), ms(12));
        assert_eq!(c.now_at(ms(310)), ms(12));
        assert_eq!(c.now_at(ms(320)), ms(22));
        // And goes on in real time from there.
        assert_eq!(c.tick_at(ms(312)), ms(14));
        assert_eq!(c.tick_at(ms(314)), ms(16));
    }

    #[test]
    fn ticks_never_go_back_and_never_overflow() {
        let c = Clock::new(STEP);
        assert_eq!(c.tick_at(ms(50)), ms(50));
        assert_eq!(c.tick_at(ms(40)), ms(50));
        let far = c.tick_at(Duration::MAX);
        assert_eq!(far, ms(52));
        assert!(c.now_at(Duration::MAX) >= far);
    }
}
