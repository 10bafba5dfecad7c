//! The programs the stream clients send, compiled on a thread of their own: compiling a
//! large program takes long (a 4 MiB one, seconds in a debug build), and the real-time
//! loop must not stop stepping meanwhile. The loop hands a program over
//! ([`Compiles::send`]), holds that client's later items back until it comes back
//! compiled ([`Compiles::take`]), and starts it then; so a client's items keep their
//! order, and the other clients and the streams go on.
//!
//! At most [`MAX_COMPILES`] programs wait to be compiled (each client has at most one
//! in flight), in the order they came: a client's program waits behind at most one
//! program of each other client. If the thread cannot be started, programs are
//! compiled on the loop.

use std::collections::VecDeque;
use std::sync::mpsc::{self, Receiver, SyncSender, TrySendError};

use crate::{Compiled, Compiler};

/// Programs waiting for the compiling thread: one per stream client
/// ([`MAX_CLIENTS`](super::MAX_CLIENTS)), as a client has at most one in flight; one
/// evicted while its program compiles lets a newcomer's in, so a full queue makes the
/// newcomer's program wait a step.
pub const MAX_COMPILES: usize = super::MAX_CLIENTS;

/// A program to compile for client `conn`.
pub(crate) struct Job {
    pub conn: u64,
    pub secondary: bool,
    pub text: String,
}

/// A program compiled for client `conn`.
pub(crate) struct Done {
    pub conn: u64,
    pub secondary: bool,
    pub program: Compiled,
}

pub(crate) struct Compiles {
    jobs: Option<SyncSender<Job>>,
    done: Option<Receiver<Done>>,
    /// Compiled on the loop (no thread).
    inline: VecDeque<Done>,
    compiler: Compiler,
    /// Programs handed over and not taken back yet.
    in_flight: usize,
}

impl Compiles {
    /// Starts the compiling thread.
    pub fn start(compiler: Compiler) -> Self {
        let (jobs, job_rx) = mpsc::sync_channel::<Job>(MAX_COMPILES);
        let (done_tx, done) = mpsc::channel::<Done>();
        let worker = compiler.clone();
        let spawned = std::thread::Builder::new()
            .name("compile".into())
            .spawn(move || {
                // Ends when the loop drops its sender (or its receiver).
                for job in job_rx {
                    // A compiler fault refuses that program only.
                    let program = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                        worker.program(&job.text)
                    }))
                    .unwrap_or_else(|_| {
                        Compiled::refused("the program could not be compiled".to_string())
                    });
                    let done = Done {
                        conn: job.conn,
                        secondary: job.secondary,
                        program,
                    };
                    if done_tx.send(done).is_err() {
                        return;
                    }
                }
            });
        let (jobs, done) = match spawned {
            Ok(_) => (Some(jobs), Some(done)),
            Err(_) => (None, None),
        };
        Compiles {
            jobs,
            done,
            inline: VecDeque::new(),
            compiler,
            in_flight: 0,
        }
    }

    /// Whether a program may be handed over: fewer than [`MAX_COMPILES`] are.
    pub fn has_room(&self) -> bool {
        self.in_flight < MAX_COMPILES
    }

    /// Hands `job` over (see [`Compiles::has_room`]; past it, or with no thread, it is
    /// compiled here).
    pub fn send(&mut self, job: Job) {
        match &self.jobs {
            Some(jobs) => match jobs.try_send(job) {
                Ok(()) => {}
                Err(TrySendError::Full(job)) => self.compile_inline(job),
                Err(TrySendError::Disconnected(job)) => {
                    // The thread is gone: compile here from now on.
                    self.jobs = None;
                    self.compile_inline(job);
                }
            },
            None => self.compile_inline(job),
        }
        self.in_flight += 1;
    }

    fn compile_inline(&mut self, job: Job) {
        let program = self.compiler.program(&job.text);
        self.inline.push_back(Done {
            conn: job.conn,
            secondary: job.secondary,
            program,
        });
    }

    /// A program compiled since, if any.
    pub fn take(&mut self) -> Option<Done> {
        let done = self
            .inline
            .pop_front()
            .or_else(|| self.done.as_ref().and_then(|rx| rx.try_recv().ok()));
        if done.is_some() {
            self.in_flight = self.in_flight.saturating_sub(1);
        }
        done
    }

    /// Whether a program is being compiled.
    pub fn busy(&self) -> bool {
        self.in_flight > 0
    }
}
