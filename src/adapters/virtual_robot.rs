//! [`VirtualRobot`]: the sans-IO model driven over real blocking TCP sockets.

use std::boxed::Box;
use std::io::{self, Read, Write};
use std::net::{TcpStream, ToSocketAddrs};
use std::string::String;
use std::time::{Duration, Instant};
use std::vec::Vec;

use crate::ascii_float::FloatTuple;
use crate::robot::{
    IntList, Policy, ReadCall, ReadResult, Robot, RobotError, SocketConnection, Step, Timeout,
};
use crate::to_str::Value;

/// Which way bytes went, for a traffic observer.
///
/// ```
/// use urscript_socket::robot::Direction;
/// assert_ne!(Direction::RobotToServer, Direction::ServerToRobot);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    /// Sent by the robot.
    RobotToServer,
    /// Received by the robot.
    ServerToRobot,
}

type Observer = Box<dyn FnMut(&str, Direction, &[u8]) + Send>;

/// A virtual UR robot: runs URScript socket calls against a real server over TCP, with
/// the robot's read rules, sentinels and timeouts (real time).
///
/// Each method is the URScript function of the same name; `socket_name` picks the
/// connection as on the robot. Results are what the robot program would see; misuse
/// (unknown socket, `number` outside 1..=30) and transport failures are errors.
///
/// ```no_run
/// use urscript_socket::robot::{Policy, Timeout, VirtualRobot};
/// let mut robot = VirtualRobot::new(Policy::default());
/// if robot.socket_open("192.168.0.10:30000", "socket_0")? {
///     robot.socket_send_line(b"hello", "socket_0")?;
///     let reply = robot.socket_read_line("socket_0", Timeout::default())?;
///     println!("{}", String::from_utf8_lossy(&reply));
/// }
/// # Ok::<(), urscript_socket::robot::RobotError>(())
/// ```
pub struct VirtualRobot {
    robot: Robot<TcpStream>,
    observer: Option<Observer>,
    /// Time zero of the machine's clock (`now` = `epoch.elapsed()`).
    epoch: Instant,
    /// Why the last `socket_open` failed.
    open_error: Option<io::Error>,
}

impl core::fmt::Debug for VirtualRobot {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("VirtualRobot")
            .field("policy", self.robot.policy())
            .field("sockets", &self.robot.names().collect::<Vec<_>>())
            .finish()
    }
}

impl VirtualRobot {
    /// A robot with no socket open.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, VirtualRobot};
    /// let robot = VirtualRobot::new(Policy::default());
    /// assert!(robot.socket_names().is_empty());
    /// ```
    pub fn new(policy: Policy) -> Self {
        VirtualRobot {
            robot: Robot::new(policy),
            observer: None,
            epoch: Instant::now(),
            open_error: None,
        }
    }

    /// Calls `observer(socket_name, direction, bytes)` for every chunk sent or received.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, VirtualRobot};
    /// let mut robot = VirtualRobot::new(Policy::default());
    /// robot.set_observer(|name, dir, bytes| println!("{name} {dir:?} {bytes:?}"));
    /// ```
    pub fn set_observer(&mut self, observer: impl FnMut(&str, Direction, &[u8]) + Send + 'static) {
        self.observer = Some(Box::new(observer));
    }

    /// `socket_open(address, port, socket_name)`: connects; `Ok(false)` if the server
    /// cannot be reached (as the robot's `False`; [`last_open_error`](Self::last_open_error)
    /// says why). Re-opening a name closes the old connection first.
    ///
    /// ```no_run
    /// # use urscript_socket::robot::{Policy, VirtualRobot};
    /// # let mut robot = VirtualRobot::new(Policy::default());
    /// if !robot.socket_open("127.0.0.1:30000", "socket_0")? {
    ///     eprintln!("{}", robot.last_open_error().unwrap());
    /// }
    /// # Ok::<(), urscript_socket::robot::RobotError>(())
    /// ```
    pub fn socket_open(
        &mut self,
        address: impl ToSocketAddrs,
        socket_name: &str,
    ) -> Result<bool, RobotError> {
        self.socket_close(socket_name);
        let stream = match TcpStream::connect(address) {
            Ok(s) => s,
            Err(e) => {
                self.open_error = Some(e);
                return Ok(false);
            }
        };
        self.open_error = None;
        stream.set_nodelay(true).map_err(RobotError::Io)?;
        self.robot.open(socket_name, stream);
        Ok(true)
    }

    /// Why the last [`socket_open`](Self::socket_open) returned false (connection refused,
    /// unknown host...): the operating system's reason, which the robot program never sees.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, VirtualRobot};
    /// let mut robot = VirtualRobot::new(Policy::default());
    /// assert!(!robot.socket_open("no-such-host.invalid:1", "s").unwrap());
    /// assert!(robot.last_open_error().is_some());
    /// ```
    pub fn last_open_error(&self) -> Option<&io::Error> {
        self.open_error.as_ref()
    }

    /// `socket_close(socket_name)`; returns whether it was open.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, VirtualRobot};
    /// let mut robot = VirtualRobot::new(Policy::default());
    /// assert!(!robot.socket_close("socket_0"));
    /// ```
    pub fn socket_close(&mut self, socket_name: &str) -> bool {
        match self.robot.close(socket_name) {
            Some(stream) => {
                let _ = stream.shutdown(std::net::Shutdown::Both);
                true
            }
            None => false,
        }
    }

    /// The names of the open sockets.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, VirtualRobot};
    /// assert!(VirtualRobot::new(Policy::default()).socket_names().is_empty());
    /// ```
    pub fn socket_names(&self) -> Vec<String> {
        self.robot.names().map(String::from).collect()
    }

    /// The machine's clock: time since this robot was made.
    fn now(&self) -> Duration {
        self.epoch.elapsed()
    }

    /// Runs `queue` on the socket and sends what it queued; `Ok(false)` if the socket is
    /// broken for writing (the peer went away), as `socket_send_*` returns False.
    fn send_with(
        &mut self,
        socket_name: &str,
        queue: impl FnOnce(&mut SocketConnection) -> Result<bool, RobotError>,
    ) -> Result<bool, RobotError> {
        let (socket, stream) = self
            .robot
            .get(socket_name)
            .ok_or_else(|| RobotError::NotOpen(String::from(socket_name)))?;
        if !queue(socket)? {
            return Ok(false);
        }
        Ok(flush(socket, stream, &mut self.observer))
    }

    /// `socket_send_string(text, socket_name)`.
    ///
    /// ```no_run
    /// # use urscript_socket::robot::{Policy, VirtualRobot};
    /// # let mut robot = VirtualRobot::new(Policy::default());
    /// robot.socket_send_string(b"hi", "socket_0")?;
    /// # Ok::<(), urscript_socket::robot::RobotError>(())
    /// ```
    pub fn socket_send_string(
        &mut self,
        text: &[u8],
        socket_name: &str,
    ) -> Result<bool, RobotError> {
        self.send_with(socket_name, |s| Ok(s.send_string(text)))
    }

    /// `socket_send_line(text, socket_name)`.
    ///
    /// ```no_run
    /// # use urscript_socket::robot::{Policy, VirtualRobot};
    /// # let mut robot = VirtualRobot::new(Policy::default());
    /// robot.socket_send_line(b"hello", "socket_0")?;
    /// # Ok::<(), urscript_socket::robot::RobotError>(())
    /// ```
    pub fn socket_send_line(&mut self, text: &[u8], socket_name: &str) -> Result<bool, RobotError> {
        self.send_with(socket_name, |s| Ok(s.send_line(text)))
    }

    /// `socket_send_string(value)` / `socket_send_line(value)` of a number, bool, list or
    /// pose: its `to_str` text.
    ///
    /// ```no_run
    /// # use urscript_socket::robot::{Policy, VirtualRobot};
    /// use urscript_socket::to_str::Value;
    /// # let mut robot = VirtualRobot::new(Policy::default());
    /// robot.socket_send_value(&Value::Pose([0.1, 0.2, 0.3, 0.0, 3.14, 0.0]), false, "socket_0")?;
    /// # Ok::<(), urscript_socket::robot::RobotError>(())
    /// ```
    pub fn socket_send_value(
        &mut self,
        value: &Value<'_>,
        line: bool,
        socket_name: &str,
    ) -> Result<bool, RobotError> {
        self.send_with(socket_name, |s| s.send_value(value, line))
    }

    /// `socket_send_byte(value, socket_name)`.
    ///
    /// ```no_run
    /// # use urscript_socket::robot::{Policy, VirtualRobot};
    /// # let mut robot = VirtualRobot::new(Policy::default());
    /// robot.socket_send_byte(2, "socket_0")?;
    /// # Ok::<(), urscript_socket::robot::RobotError>(())
    /// ```
    pub fn socket_send_byte(&mut self, value: u8, socket_name: &str) -> Result<bool, RobotError> {
        self.send_with(socket_name, |s| Ok(s.send_byte(value)))
    }

    /// `socket_send_int(value, socket_name)`.
    ///
    /// ```no_run
    /// # use urscript_socket::robot::{Policy, VirtualRobot};
    /// # let mut robot = VirtualRobot::new(Policy::default());
    /// robot.socket_send_int(-1, "socket_0")?;
    /// # Ok::<(), urscript_socket::robot::RobotError>(())
    /// ```
    pub fn socket_send_int(&mut self, value: i32, socket_name: &str) -> Result<bool, RobotError> {
        self.send_with(socket_name, |s| Ok(s.send_int(value)))
    }

    /// `socket_set_var(name, value, socket_name)`.
    ///
    /// ```no_run
    /// # use urscript_socket::robot::{Policy, VirtualRobot};
    /// # let mut robot = VirtualRobot::new(Policy::default());
    /// robot.socket_set_var("POS_Y", 2200, "socket_0")?;
    /// # Ok::<(), urscript_socket::robot::RobotError>(())
    /// ```
    pub fn socket_set_var(
        &mut self,
        name: &str,
        value: i32,
        socket_name: &str,
    ) -> Result<bool, RobotError> {
        self.send_with(socket_name, |s| s.set_var(name, value))
    }

    /// Runs any read call with a timeout, blocking until it completes, fails, the peer
    /// closes or the timeout passes (then the sentinel). `socket_get_var` always waits 2 s.
    ///
    /// ```no_run
    /// # use urscript_socket::robot::{Policy, ReadCall, Timeout, VirtualRobot};
    /// # let mut robot = VirtualRobot::new(Policy::default());
    /// let r = robot.read(ReadCall::Line, "socket_0", Timeout::from_secs_f64(0.5))?;
    /// println!("{}", r.to_urscript());
    /// # Ok::<(), urscript_socket::robot::RobotError>(())
    /// ```
    pub fn read(
        &mut self,
        call: ReadCall,
        socket_name: &str,
        timeout: Timeout,
    ) -> Result<ReadResult, RobotError> {
        let now = self.now();
        let epoch = self.epoch;
        let (socket, stream) = self
            .robot
            .get(socket_name)
            .ok_or_else(|| RobotError::NotOpen(String::from(socket_name)))?;
        socket.start_read(call, timeout, now)?;
        flush(socket, stream, &mut self.observer);
        loop {
            let now = epoch.elapsed();
            match socket.next(now) {
                Step::Done(result) => return Ok(result),
                // Wait for bytes at most until the deadline (None: forever).
                Step::NeedBytes { until } => {
                    let wait = until.map(|d| d.saturating_sub(now));
                    receive(socket, stream, wait, &mut self.observer);
                }
                Step::Sleep { until } => std::thread::sleep(until.saturating_sub(now)),
                Step::Idle => return Err(RobotError::NoReadPending),
            }
        }
    }

    /// `socket_read_ascii_float(number, socket_name, timeout)`.
    ///
    /// ```no_run
    /// # use urscript_socket::robot::{Policy, Timeout, VirtualRobot};
    /// # let mut robot = VirtualRobot::new(Policy::default());
    /// let pose = robot.socket_read_ascii_float(6, "socket_0", Timeout::default())?;
    /// if pose.count() == 6 { println!("{:?}", pose.values()); }
    /// # Ok::<(), urscript_socket::robot::RobotError>(())
    /// ```
    pub fn socket_read_ascii_float(
        &mut self,
        number: usize,
        socket_name: &str,
        timeout: Timeout,
    ) -> Result<FloatTuple, RobotError> {
        match self.read(ReadCall::AsciiFloat { number }, socket_name, timeout)? {
            ReadResult::Floats(t) => Ok(t),
            _ => Ok(FloatTuple::failed(number)),
        }
    }

    /// `socket_read_binary_integer(number, socket_name, timeout)`.
    ///
    /// ```no_run
    /// # use urscript_socket::robot::{Policy, Timeout, VirtualRobot};
    /// # let mut robot = VirtualRobot::new(Policy::default());
    /// let ints = robot.socket_read_binary_integer(8, "reverse_socket", Timeout::default())?;
    /// # Ok::<(), urscript_socket::robot::RobotError>(())
    /// ```
    pub fn socket_read_binary_integer(
        &mut self,
        number: usize,
        socket_name: &str,
        timeout: Timeout,
    ) -> Result<IntList, RobotError> {
        self.int_read(
            ReadCall::BinaryInteger { number },
            number,
            socket_name,
            timeout,
        )
    }

    /// `socket_read_byte_list(number, socket_name, timeout)`.
    ///
    /// ```no_run
    /// # use urscript_socket::robot::{Policy, Timeout, VirtualRobot};
    /// # let mut robot = VirtualRobot::new(Policy::default());
    /// let bytes = robot.socket_read_byte_list(3, "socket_0", Timeout::default())?;
    /// # Ok::<(), urscript_socket::robot::RobotError>(())
    /// ```
    pub fn socket_read_byte_list(
        &mut self,
        number: usize,
        socket_name: &str,
        timeout: Timeout,
    ) -> Result<IntList, RobotError> {
        self.int_read(ReadCall::ByteList { number }, number, socket_name, timeout)
    }

    fn int_read(
        &mut self,
        call: ReadCall,
        number: usize,
        socket_name: &str,
        timeout: Timeout,
    ) -> Result<IntList, RobotError> {
        match self.read(call, socket_name, timeout)? {
            ReadResult::Ints(l) => Ok(l),
            _ => Ok(IntList::failed(number)),
        }
    }

    /// `socket_read_line(socket_name, timeout)`: the line without CR/LF, `""` on timeout.
    ///
    /// ```no_run
    /// # use urscript_socket::robot::{Policy, Timeout, VirtualRobot};
    /// # let mut robot = VirtualRobot::new(Policy::default());
    /// let line = robot.socket_read_line("socket_0", Timeout::default())?;
    /// # Ok::<(), urscript_socket::robot::RobotError>(())
    /// ```
    pub fn socket_read_line(
        &mut self,
        socket_name: &str,
        timeout: Timeout,
    ) -> Result<Vec<u8>, RobotError> {
        self.text_read(ReadCall::Line, socket_name, timeout)
    }

    /// `socket_read_string(socket_name, prefix, suffix, interpret_escape, timeout)`.
    ///
    /// ```no_run
    /// # use urscript_socket::robot::{Policy, Timeout, VirtualRobot};
    /// # let mut robot = VirtualRobot::new(Policy::default());
    /// let s = robot.socket_read_string("socket_0", b">", b"<", false, Timeout::default())?;
    /// # Ok::<(), urscript_socket::robot::RobotError>(())
    /// ```
    pub fn socket_read_string(
        &mut self,
        socket_name: &str,
        prefix: &[u8],
        suffix: &[u8],
        interpret_escape: bool,
        timeout: Timeout,
    ) -> Result<Vec<u8>, RobotError> {
        let call = ReadCall::String {
            prefix: prefix.to_vec(),
            suffix: suffix.to_vec(),
            interpret_escape,
        };
        self.text_read(call, socket_name, timeout)
    }

    fn text_read(
        &mut self,
        call: ReadCall,
        socket_name: &str,
        timeout: Timeout,
    ) -> Result<Vec<u8>, RobotError> {
        match self.read(call, socket_name, timeout)? {
            ReadResult::Text(t) => Ok(t),
            _ => Ok(Vec::new()),
        }
    }

    /// `socket_get_var(name, socket_name)`: sends `GET name\n`, waits up to 2 s for
    /// `name int\n`; 0 on timeout.
    ///
    /// ```no_run
    /// # use urscript_socket::robot::{Policy, VirtualRobot};
    /// # let mut robot = VirtualRobot::new(Policy::default());
    /// let x = robot.socket_get_var("POS_X", "socket_0")?;
    /// # Ok::<(), urscript_socket::robot::RobotError>(())
    /// ```
    pub fn socket_get_var(&mut self, name: &str, socket_name: &str) -> Result<i32, RobotError> {
        let call = ReadCall::GetVar {
            name: String::from(name),
        };
        match self.read(call, socket_name, Timeout::default())? {
            ReadResult::Int(v) => Ok(v),
            _ => Ok(0),
        }
    }
}

/// Sends what the model queued; false (and the socket marked broken) if the write failed.
fn flush(
    socket: &mut SocketConnection,
    stream: &mut TcpStream,
    observer: &mut Option<Observer>,
) -> bool {
    let out = socket.take_outgoing();
    if out.is_empty() {
        return !socket.is_send_broken();
    }
    if let Some(obs) = observer.as_mut() {
        obs(socket.name(), Direction::RobotToServer, &out);
    }
    match stream.write_all(&out) {
        Ok(()) => true,
        Err(_) => {
            socket.send_failed();
            false
        }
    }
}

/// One blocking read from `stream` into the socket, waiting at most `wait`.
fn receive(
    socket: &mut SocketConnection,
    stream: &mut TcpStream,
    wait: Option<Duration>,
    observer: &mut Option<Observer>,
) {
    // A zero read timeout is refused by the OS; the caller only waits for a future deadline.
    let wait = wait.map(|w| w.max(Duration::from_micros(1)));
    if stream.set_read_timeout(wait).is_err() {
        socket.peer_closed();
        return;
    }
    let space = socket.receive_space();
    match stream.read(space) {
        Ok(0) => socket.peer_closed(),
        Ok(n) => {
            socket.commit_received(n);
            if let Some(obs) = observer.as_mut() {
                let data = socket.buffered();
                obs(
                    socket.name(),
                    Direction::ServerToRobot,
                    &data[data.len() - n..],
                );
            }
        }
        Err(e)
            if matches!(
                e.kind(),
                io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut | io::ErrorKind::Interrupted
            ) => {}
        Err(_) => socket.peer_closed(),
    }
}
