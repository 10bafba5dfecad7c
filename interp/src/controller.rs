//! The virtual controller's state that built-ins act on: the arm, the robot's sockets,
//! program time, and the events for the driver. The scheduler ([`crate::machine`]) owns
//! one and lends it to each built-in call; built-ins see nothing of threads.

use std::collections::VecDeque;
use std::f64::consts::FRAC_PI_2;
use std::time::Duration;

use urscript_socket::robot::ReadCall;

use crate::builtins::{Args, Out};
use crate::error::Fault;
use crate::event::{Event, ReadRecord, MAX_READ_INPUT};
use crate::sockets::Sockets;

/// The virtual arm: commanded state, not dynamics (see [`crate::builtins::motion`]).
#[derive(Debug, Clone)]
pub(crate) struct Arm {
    pub q: [f64; 6],
    pub qd: [f64; 6],
    pub pose: [f64; 6],
    pub tcp_speed: [f64; 6],
    pub tcp: [f64; 6],
    pub digital_out: [bool; 18],
    pub tool_out: [bool; 2],
    pub analog_out: [f64; 2],
    pub int_regs: [i32; 48],
    pub float_regs: [f64; 48],
    pub bool_regs: [bool; 64],
    pub random_state: u64,
}

impl Default for Arm {
    fn default() -> Self {
        Arm {
            q: [0.0, -FRAC_PI_2, 0.0, -FRAC_PI_2, 0.0, 0.0],
            qd: [0.0; 6],
            pose: [0.0; 6],
            tcp_speed: [0.0; 6],
            tcp: [0.0; 6],
            digital_out: [false; 18],
            tool_out: [false; 2],
            analog_out: [0.0; 2],
            int_regs: [0; 48],
            float_regs: [0.0; 48],
            bool_regs: [false; 64],
            random_state: 0x2545_F491_4F6C_DD1D,
        }
    }
}

/// The controller's state.
#[derive(Debug)]
pub(crate) struct Controller {
    /// Length of one step.
    pub step_time: Duration,
    /// The step running now (or next).
    pub step: u64,
    pub arm: Arm,
    pub sockets: Sockets,
    /// What the driver must do or show, oldest first.
    pub events: VecDeque<Event>,
}

impl Controller {
    /// The program time of the step running now.
    pub fn now(&self) -> Duration {
        self.time_of(self.step)
    }

    /// The program time of step `step`.
    pub fn time_of(&self, step: u64) -> Duration {
        let nanos = self.step_time.as_nanos().saturating_mul(u128::from(step));
        Duration::from_nanos(u64::try_from(nanos).unwrap_or(u64::MAX))
    }

    /// Queues the socket's outgoing bytes as an event.
    pub fn flush(&mut self, name: &str) {
        let bytes = self.sockets.take_outgoing(name);
        if !bytes.is_empty() {
            self.events.push_back(Event::Transmit {
                socket_name: name.to_string(),
                bytes,
            });
        }
    }

    /// Closes `name` if it is open, sending what it still holds first.
    pub fn close(&mut self, name: &str) {
        if self.sockets.is_open(name) {
            self.flush(name);
            self.sockets.close(name);
            self.events.push_back(Event::Close {
                socket_name: name.to_string(),
            });
        }
    }

    /// Starts a read that may wait `timeout` seconds: the value at once if the buffered
    /// bytes complete it (or the socket is not open: the sentinel), else a wait.
    pub fn start_read(
        &mut self,
        socket: String,
        call: ReadCall,
        timeout: f64,
        args: &mut Args,
    ) -> Result<Out, Fault> {
        let now = self.now();
        // What the read sees first: the bytes already buffered (kept for the record).
        let (input, buffered_at_start) = if args.traced {
            let n = self.sockets.buffered_len(&socket);
            (self.sockets.buffered(&socket, MAX_READ_INPUT), n)
        } else {
            (Vec::new(), 0)
        };
        let done = self.sockets.start_read(&socket, &call, timeout, now)?;
        self.flush(&socket);
        Ok(match done {
            Some(result) => {
                let v = crate::sockets::to_value(&result);
                if !self.sockets.is_open(&socket) {
                    args.failure = Some(format!("the socket \"{socket}\" is not open"));
                }
                args.read = Some(ReadRecord {
                    call,
                    result,
                    input,
                    buffered_at_start,
                });
                Out::Value(v)
            }
            None => Out::Read {
                socket,
                call,
                input,
                buffered_at_start,
            },
        })
    }
}
