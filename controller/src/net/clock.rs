//! The virtual controller's clock: the time since the start, less the time the host
//! took the real-time loop away for longer than [`MAX_CATCH_UP`].
//!
//! A real controller never falls behind its steps. The virtual one runs on a host that
//! may stall its real-time thread (a loaded machine, a debugger, a suspended process).
//! The real-time loop computes every step and sends every package, late if it must:
//! after a stall it runs the steps it owes back to back (catch-up), each at its own
//! time, so the streams' timestamps stay consecutive. A stall longer than
//! [`MAX_CATCH_UP`] is not run through (minutes of steps in one burst would run the
//! program with none of its sockets read in between, so a `socket_read_...` whose reply
//! had long arrived would time out): [`Clock::catch_up`] holds the time past the next
//! step back, and the time held back is not controller time for anyone (every interface
//! reads [`Clock::now`]); the loop reports it.

use std::sync::Mutex;
use std::time::{Duration, Instant};

/// How far behind the wall clock the real-time loop may fall and still compute every
/// step it owes (500 steps at 2 ms): a loaded host's stalls of a few to a few hundred
/// milliseconds are caught up in full, while a process suspended for minutes does not
/// compute tens of thousands of steps in one burst.
pub const MAX_CATCH_UP: Duration = Duration::from_secs(1);

/// The controller's clock (see the module).
#[derive(Debug)]
pub(crate) struct Clock {
    start: Instant,
    /// Wall time that is not controller time.
    lag: Mutex<Duration>,
}

impl Clock {
    /// A clock starting now.
    pub(crate) fn new() -> Clock {
        Clock {
            start: Instant::now(),
            lag: Mutex::new(Duration::ZERO),
        }
    }

    fn lag(&self) -> std::sync::MutexGuard<'_, Duration> {
        self.lag.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// The controller time now.
    pub(crate) fn now(&self) -> Duration {
        self.now_at(self.start.elapsed())
    }

    /// The controller time at `wall` (time since the start).
    pub(crate) fn now_at(&self, wall: Duration) -> Duration {
        wall.saturating_sub(*self.lag())
    }

    /// The controller time for the real-time loop whose next step is at `due`, and the
    /// time held back: [`Clock::now`], unless that is more than [`MAX_CATCH_UP`] after
    /// `due`, in which case the excess is held back and the time is `due`.
    pub(crate) fn catch_up(&self, due: Duration) -> (Duration, Duration) {
        self.catch_up_at(self.start.elapsed(), due)
    }

    /// [`Clock::catch_up`] at `wall` (time since the start).
    pub(crate) fn catch_up_at(&self, wall: Duration, due: Duration) -> (Duration, Duration) {
        let mut lag = self.lag();
        let now = wall.saturating_sub(*lag);
        if now > due.saturating_add(MAX_CATCH_UP) {
            let held = now - due;
            *lag = lag.saturating_add(held);
            return (due, held);
        }
        (now, Duration::ZERO)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ms(n: u64) -> Duration {
        Duration::from_millis(n)
    }

    #[test]
    fn on_time_is_wall_time() {
        let c = Clock::new();
        for n in 0..100 {
            assert_eq!(c.catch_up_at(ms(2 * n), ms(2 * n)), (ms(2 * n), ms(0)));
        }
        assert_eq!(c.now_at(ms(200)), ms(200));
    }

    #[test]
    fn a_delay_within_the_bound_is_caught_up() {
        let c = Clock::new();
        // 900 ms late: nothing held back, the loop owes 450 steps.
        assert_eq!(c.catch_up_at(ms(912), ms(12)), (ms(912), ms(0)));
        assert_eq!(c.now_at(ms(930)), ms(930));
    }

    #[test]
    fn a_stall_past_the_bound_is_held_back_for_every_reader() {
        let c = Clock::new();
        // The host stalled the loop for a minute: the controller is at the due step.
        assert_eq!(c.catch_up_at(ms(60_012), ms(12)), (ms(12), ms(60_000)));
        assert_eq!(c.now_at(ms(60_012)), ms(12));
        assert_eq!(c.now_at(ms(60_022)), ms(22));
        // And goes on in real time from there.
        assert_eq!(c.catch_up_at(ms(60_014), ms(14)), (ms(14), ms(0)));
    }

    #[test]
    fn never_overflows() {
        let c = Clock::new();
        let (now, _) = c.catch_up_at(Duration::MAX, ms(50));
        assert_eq!(now, ms(50));
        assert!(c.now_at(Duration::MAX) >= now);
    }
}
