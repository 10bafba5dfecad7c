//! The one place the interpreter touches `urscript_socket::robot`: the robot's open
//! sockets, what each read function returns, and the conversion of its results into
//! URScript values. Everything else in the crate goes through [`Sockets`].

use urscript_socket::robot::{ReadCall, ReadResult, Robot};
pub use urscript_socket::robot::{Policy, Timeout};

use crate::value::Value;

/// A read function and its arguments, in the interpreter's terms.
#[derive(Debug, Clone)]
pub(crate) enum ReadSpec {
    AsciiFloat(usize),
    BinaryInteger(usize),
    ByteList(usize),
    Line,
    String {
        prefix: Vec<u8>,
        suffix: Vec<u8>,
        interpret_escape: bool,
    },
    GetVar(String),
}

impl ReadSpec {
    fn call(&self) -> ReadCall {
        match self {
            ReadSpec::AsciiFloat(n) => ReadCall::AsciiFloat { number: *n },
            ReadSpec::BinaryInteger(n) => ReadCall::BinaryInteger { number: *n },
            ReadSpec::ByteList(n) => ReadCall::ByteList { number: *n },
            ReadSpec::Line => ReadCall::Line,
            ReadSpec::String {
                prefix,
                suffix,
                interpret_escape,
            } => ReadCall::String {
                prefix: prefix.clone(),
                suffix: suffix.clone(),
                interpret_escape: *interpret_escape,
            },
            ReadSpec::GetVar(name) => ReadCall::GetVar { name: name.clone() },
        }
    }

    /// What the read returns on timeout, failure, or on a socket that is not open.
    pub fn sentinel(&self) -> Value {
        convert(self.call().sentinel())
    }

    /// How long the read may wait: its `timeout` argument, except `socket_get_var`, which
    /// always waits 2 s. `None` = forever.
    pub fn wait_limit(&self, timeout_secs: f64) -> Option<std::time::Duration> {
        let t = match self {
            ReadSpec::GetVar(_) => Timeout::default(),
            _ => Timeout::from_secs_f64(timeout_secs),
        };
        match t {
            Timeout::Forever => None,
            Timeout::After(d) => Some(d),
        }
    }
}

fn convert(r: ReadResult) -> Value {
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
        ReadResult::Text(t) => Value::Str(t),
        ReadResult::Int(i) => Value::Int(i),
    }
}

/// The robot's open sockets.
#[derive(Debug)]
pub(crate) struct Sockets {
    robot: Robot,
    open: Vec<String>,
}

impl Sockets {
    pub fn new(policy: Policy) -> Self {
        Sockets {
            robot: Robot::new(policy),
            open: Vec::new(),
        }
    }

    pub fn open(&mut self, name: &str) {
        self.robot.socket_open(name);
        if !self.is_open(name) {
            self.open.push(name.to_string());
        }
    }

    pub fn close(&mut self, name: &str) -> bool {
        self.open.retain(|n| n != name);
        self.robot.socket_close(name)
    }

    pub fn is_open(&self, name: &str) -> bool {
        self.open.iter().any(|n| n == name)
    }

    pub fn open_names(&self) -> Vec<String> {
        self.open.clone()
    }

    /// Runs `f` on the open socket `name`; false if it is not open.
    fn with<T>(
        &mut self,
        name: &str,
        f: impl FnOnce(&mut urscript_socket::robot::SocketConnection) -> T,
    ) -> Option<T> {
        self.robot.socket(name).map(f)
    }

    pub fn send_string(&mut self, name: &str, bytes: &[u8]) -> bool {
        self.with(name, |s| s.send_string(bytes)).is_some()
    }

    pub fn send_line(&mut self, name: &str, bytes: &[u8]) -> bool {
        self.with(name, |s| s.send_line(bytes)).is_some()
    }

    pub fn send_byte(&mut self, name: &str, b: u8) -> bool {
        self.with(name, |s| s.send_byte(b)).is_some()
    }

    pub fn send_int(&mut self, name: &str, v: i32) -> bool {
        self.with(name, |s| s.send_int(v)).is_some()
    }

    /// `SET var value\n`; an invalid name is an error message.
    pub fn set_var(&mut self, name: &str, var: &str, v: i32) -> Result<bool, String> {
        match self.with(name, |s| s.set_var(var, v)) {
            None => Ok(false),
            Some(Ok(())) => Ok(true),
            Some(Err(e)) => Err(e.to_string()),
        }
    }

    pub fn take_outgoing(&mut self, name: &str) -> Vec<u8> {
        self.with(name, |s| s.take_outgoing()).unwrap_or_default()
    }

    /// Starts a read: `Ok(Some(v))` if it completes from the buffered bytes at once,
    /// `Ok(None)` if it must wait; an argument the robot refuses is an error message.
    pub fn start_read(&mut self, name: &str, spec: &ReadSpec) -> Result<Option<Value>, String> {
        let call = spec.call();
        match self.with(name, |s| {
            s.start_read(call)?;
            Ok::<_, urscript_socket::robot::RobotError>(s.poll_read().map(convert))
        }) {
            None => Ok(Some(spec.sentinel())),
            Some(Ok(v)) => Ok(v),
            Some(Err(e)) => Err(e.to_string()),
        }
    }

    /// The pending read's result, if the bytes now buffered complete it.
    pub fn poll(&mut self, name: &str) -> Option<Value> {
        self.with(name, |s| s.poll_read().map(convert)).flatten()
    }

    /// The pending read timed out: its sentinel (or its policy's partial result).
    pub fn timeout(&mut self, name: &str, spec: &ReadSpec) -> Value {
        self.with(name, |s| s.handle_timeout().map(convert))
            .flatten()
            .unwrap_or_else(|| spec.sentinel())
    }

    /// Bytes from the server; returns how many the receive buffer accepted.
    pub fn receive(&mut self, name: &str, bytes: &[u8]) -> usize {
        self.with(name, |s| s.receive(bytes)).unwrap_or(0)
    }

    pub fn peer_closed(&mut self, name: &str) {
        self.with(name, |s| s.peer_closed());
    }
}
