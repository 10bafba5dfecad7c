//! The one place the interpreter touches `urscript_socket::robot`: the robot's open
//! sockets, what each read function returns, and the conversion of its results into
//! URScript values. Everything else in the crate goes through [`Sockets`].

use std::time::Duration;

pub use urscript_socket::robot::{Policy, Timeout};
use urscript_socket::robot::{ReadCall, ReadResult, Robot};

use crate::value::Value;

/// A read's result as the URScript value the program gets.
pub(crate) fn to_value(r: &ReadResult) -> Value {
    match r {
        ReadResult::Floats(t) => {
            let mut v = Vec::with_capacity(t.values().len() + 1);
            v.push(Value::Float(t.count() as f64));
            v.extend(t.values().iter().map(|&x| Value::Float(x)));
            Value::List(v)
        }
        ReadResult::Ints(l) => {
            let mut v = Vec::with_capacity(l.values().len() + 1);
            v.push(Value::Int(i32::try_from(l.count()).unwrap_or(i32::MAX)));
            v.extend(l.values().iter().map(|&x| Value::Int(x)));
            Value::List(v)
        }
        ReadResult::Text(t) => Value::Str(t.clone()),
        ReadResult::Int(i) => Value::Int(*i),
    }
}

/// The robot's open sockets: the robot model's one socket table. Every read's deadline
/// lives in the model (started with the program time, resolved with
/// [`handle_timeout`](Self::handle_timeout)); the interpreter keeps no clock of its own.
#[derive(Debug)]
pub(crate) struct Sockets {
    robot: Robot,
}

impl Sockets {
    pub fn new(policy: Policy) -> Self {
        Sockets {
            robot: Robot::new(policy),
        }
    }

    pub fn open(&mut self, name: &str) {
        self.robot.socket_open(name);
    }

    pub fn close(&mut self, name: &str) -> bool {
        self.robot.socket_close(name)
    }

    pub fn is_open(&mut self, name: &str) -> bool {
        self.robot.socket(name).is_some()
    }

    /// How many sockets are open now.
    pub fn count(&self) -> usize {
        self.robot.names().count()
    }

    pub fn open_names(&self) -> Vec<String> {
        self.robot.names().map(str::to_string).collect()
    }

    /// Runs `f` on the open socket `name`; `None` if it is not open.
    fn with<T>(
        &mut self,
        name: &str,
        f: impl FnOnce(&mut urscript_socket::robot::SocketConnection) -> T,
    ) -> Option<T> {
        self.robot.socket(name).map(f)
    }

    /// `socket_send_string`: false if the socket is not open or the peer is gone.
    pub fn send_string(&mut self, name: &str, bytes: &[u8]) -> bool {
        self.with(name, |s| s.send_string(bytes)).unwrap_or(false)
    }

    pub fn send_line(&mut self, name: &str, bytes: &[u8]) -> bool {
        self.with(name, |s| s.send_line(bytes)).unwrap_or(false)
    }

    pub fn send_byte(&mut self, name: &str, b: u8) -> bool {
        self.with(name, |s| s.send_byte(b)).unwrap_or(false)
    }

    pub fn send_int(&mut self, name: &str, v: i32) -> bool {
        self.with(name, |s| s.send_int(v)).unwrap_or(false)
    }

    /// A send on `name` would fail because the connection is broken (a write failed).
    pub fn is_broken(&mut self, name: &str) -> bool {
        self.with(name, |s| s.is_send_broken()).unwrap_or(false)
    }

    /// The first `max` bytes buffered on `name` (not yet read by the program).
    pub fn buffered(&mut self, name: &str, max: usize) -> Vec<u8> {
        self.with(name, |s| {
            let b = s.buffered();
            b[..b.len().min(max)].to_vec()
        })
        .unwrap_or_default()
    }

    /// How many bytes are buffered on `name`.
    pub fn buffered_len(&mut self, name: &str) -> usize {
        self.with(name, |s| s.buffered().len()).unwrap_or(0)
    }

    /// The transport could not write: later sends on `name` return false.
    pub fn send_failed(&mut self, name: &str) {
        self.with(name, |s| s.send_failed());
    }

    /// `SET var value\n`; an invalid name is an error message.
    pub fn set_var(&mut self, name: &str, var: &str, v: i32) -> Result<bool, String> {
        match self.with(name, |s| s.set_var(var, v)) {
            None => Ok(false),
            Some(Ok(ok)) => Ok(ok),
            Some(Err(e)) => Err(e.to_string()),
        }
    }

    pub fn take_outgoing(&mut self, name: &str) -> Vec<u8> {
        self.with(name, |s| s.take_outgoing()).unwrap_or_default()
    }

    /// Starts a read at program time `now` that may wait `timeout` seconds (the model
    /// makes `socket_get_var` wait 2 s whatever is asked): `Ok(Some(r))` if it completes
    /// from the buffered bytes at once (or the socket is not open: the sentinel),
    /// `Ok(None)` if it must wait; an argument the robot refuses is an error message.
    pub fn start_read(
        &mut self,
        name: &str,
        call: &ReadCall,
        timeout_secs: f64,
        now: Duration,
    ) -> Result<Option<ReadResult>, String> {
        let timeout = Timeout::from_secs_f64(timeout_secs);
        match self.with(name, |s| {
            s.start_read(call.clone(), timeout, now)?;
            Ok::<_, urscript_socket::robot::RobotError>(s.poll_read())
        }) {
            None => Ok(Some(call.sentinel())),
            Some(Ok(r)) => Ok(r),
            Some(Err(e)) => Err(e.to_string()),
        }
    }

    /// The pending read's result, if the bytes now buffered complete it.
    pub fn poll(&mut self, name: &str) -> Option<ReadResult> {
        self.with(name, |s| s.poll_read()).flatten()
    }

    /// The earliest deadline of any pending read (the model's).
    pub fn poll_timeout(&self) -> Option<Duration> {
        self.robot.poll_timeout()
    }

    /// Time `now` came: the pending read's sentinel (or its policy's partial result) if
    /// its deadline has passed, `None` if it still waits. A socket that is no longer open
    /// gives the sentinel.
    pub fn handle_timeout(
        &mut self,
        name: &str,
        call: &ReadCall,
        now: Duration,
    ) -> Option<ReadResult> {
        match self.with(name, |s| s.handle_timeout(now)) {
            None => Some(call.sentinel()),
            Some(v) => v,
        }
    }

    /// Ends the pending read now (its thread was killed, or the program stops).
    pub fn give_up(&mut self, name: &str) {
        self.with(name, |s| s.give_up());
    }

    /// Bytes from the server; returns how many the receive buffer accepted.
    pub fn receive(&mut self, name: &str, bytes: &[u8]) -> usize {
        self.with(name, |s| s.receive(bytes)).unwrap_or(0)
    }

    pub fn peer_closed(&mut self, name: &str) {
        self.with(name, |s| s.peer_closed());
    }
}
