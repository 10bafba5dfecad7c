//! One owner of the cell: while the real-time loop runs, it holds the [`Cell`] (the
//! controller's state and its time) and is the only thread that touches it. Every
//! other thread (a dashboard or interpreter connection, a program being loaded, the
//! operator through [`Server::with_cell`](super::Server::with_cell)) hands the loop a
//! request ([`Shared::ask`]): a function of the cell and the controller's time, run by
//! the loop between its steps (at once when the loop sleeps), its result sent back.
//!
//! Before the loop starts and after it ends, the cell is parked in [`Shared`] and a
//! request runs on the caller's thread instead. The loop parks the cell and runs every
//! request still waiting in one turn of the parking lot's lock, so no request is lost
//! between the two.

use std::panic::AssertUnwindSafe;
use std::sync::mpsc::{self, Receiver, SyncSender, TrySendError};
use std::sync::{Mutex, MutexGuard};
use std::time::Duration;

use crate::Cell;

use super::Shared;

/// How many requests may wait for the loop at once; a caller finding the queue full
/// waits its turn. Each waiting request is one blocked thread (a connection's, a
/// loader's or an API caller's), so this exceeds what the connection limits allow
/// together with room to spare.
pub const MAX_REQUESTS: usize = 256;

/// How long a caller that found the request queue full waits before it tries again.
const QUEUE_FULL_WAIT: Duration = Duration::from_micros(200);

/// A request to the loop that owns the cell.
pub(crate) trait Request: Send {
    /// Runs on the cell at controller time `now` (the cell has been advanced to it).
    fn run(self: Box<Self>, cell: &mut Cell, now: Duration);
}

/// A caller's function waiting to run on the cell. Run, its result goes back to the
/// caller; dropped unrun (the queue was full, or the loop ended), the function itself
/// goes back, to be tried again.
struct Pending<F, R> {
    f: Option<F>,
    reply: SyncSender<Result<R, F>>,
}

impl<F, R> Request for Pending<F, R>
where
    F: FnOnce(&mut Cell, Duration) -> R + Send,
    R: Send,
{
    fn run(mut self: Box<Self>, cell: &mut Cell, now: Duration) {
        if let Some(f) = self.f.take() {
            let _ = self.reply.try_send(Ok(f(cell, now)));
        }
    }
}

impl<F, R> Drop for Pending<F, R> {
    fn drop(&mut self) {
        if let Some(f) = self.f.take() {
            let _ = self.reply.try_send(Err(f));
        }
    }
}

/// The requests' queue.
pub(crate) type Requests = SyncSender<Box<dyn Request>>;

/// The queue and its receiving end, for the loop.
pub(crate) fn queue() -> (Requests, Receiver<Box<dyn Request>>) {
    mpsc::sync_channel(MAX_REQUESTS)
}

impl Shared {
    fn lock_parked(&self) -> MutexGuard<'_, Option<Cell>> {
        self.parked.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Runs `f` on the cell, advanced to the controller's time, and returns its result:
    /// on the loop that owns the cell while it runs, else on this thread. Never call it
    /// from the loop's own thread (the event sink): it would wait for itself.
    pub(crate) fn ask<F, R>(&self, f: F) -> R
    where
        F: FnOnce(&mut Cell, Duration) -> R + Send + 'static,
        R: Send + 'static,
    {
        let mut f = f;
        loop {
            let (reply, answer) = mpsc::sync_channel(1);
            {
                let mut parked = self.lock_parked();
                if let Some(cell) = parked.as_mut() {
                    let now = self.now();
                    cell.advance(now);
                    return f(cell, now);
                }
                let pending = Box::new(Pending { f: Some(f), reply });
                match self.requests.try_send(pending) {
                    Ok(()) => {}
                    // The request comes back whole (its drop returns the function).
                    Err(TrySendError::Full(p)) => {
                        drop(p);
                        drop(parked);
                        std::thread::sleep(QUEUE_FULL_WAIT);
                    }
                    // No loop to serve it and no cell parked: the loop's thread died
                    // without parking it.
                    Err(TrySendError::Disconnected(_)) => {
                        panic!("the controller's loop ended without parking its state")
                    }
                }
            }
            self.wake_loop();
            match answer.recv() {
                Ok(Ok(r)) => return r,
                Ok(Err(back)) => f = back,
                // The function ran and panicked on the loop: the caller fails as it
                // would have had it run the function itself.
                Err(_) => panic!("a request to the controller's loop panicked"),
            }
        }
    }

    /// The cell, for the loop to own: taken from the parking lot when the loop starts.
    pub(crate) fn take_cell(&self) -> Option<Cell> {
        self.lock_parked().take()
    }
}

/// The loop's side: the cell it owns and the requests it serves.
pub(crate) struct Owner {
    pub(crate) cell: Cell,
    requests: Receiver<Box<dyn Request>>,
}

impl Owner {
    pub(crate) fn new(cell: Cell, requests: Receiver<Box<dyn Request>>) -> Self {
        Owner { cell, requests }
    }

    /// Runs every waiting request, each on the cell advanced to the time it runs at;
    /// returns how many ran.
    /// A request whose function panics fails its caller (who gets no answer and
    /// panics as it would have had it run the function itself); the loop goes on.
    pub(crate) fn serve(&mut self, shared: &Shared) -> usize {
        let mut n = 0;
        while let Ok(request) = self.requests.try_recv() {
            let now = shared.now();
            self.cell.advance(now);
            let cell = &mut self.cell;
            let _ = std::panic::catch_unwind(AssertUnwindSafe(|| request.run(cell, now)));
            n += 1;
        }
        n
    }

    /// The loop ends: the requests still waiting run, and the cell goes back to the
    /// parking lot (under its lock, so that a request sent meanwhile either ran here or
    /// runs on its caller's thread).
    pub(crate) fn park(mut self, shared: &Shared) {
        let mut parked = shared.lock_parked();
        self.serve(shared);
        *parked = Some(self.cell);
    }
}

/// The parking lot, for [`Shared`]: the cell while no loop owns it.
pub(crate) fn parking(cell: Cell) -> Mutex<Option<Cell>> {
    Mutex::new(Some(cell))
}
