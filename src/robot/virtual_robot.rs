//! [`VirtualRobot`]: the sans-IO model driven over real blocking TCP sockets.

use std::boxed::Box;
use std::io::{self, Read, Write};
use std::net::{TcpStream, ToSocketAddrs};
use std::string::String;
use std::time::Instant;
use std::vec::Vec;

use super::{IntList, Policy, ReadCall, ReadResult, RobotError, SocketConnection, Timeout};
use crate::ascii_float::FloatTuple;
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
    policy: Policy,
    sockets: Vec<(SocketConnection, TcpStream)>,
    observer: Option<Observer>,
}

impl core::fmt::Debug for VirtualRobot {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("VirtualRobot")
            .field("policy", &self.policy)
            .field(
                "sockets",
                &self
                    .sockets
                    .iter()
                    .map(|(s, _)| s.name())
                    .collect::<Vec<_>>(),
            )
            .finish()
    }
}

impl VirtualRobot {
    /// A robot with no socket open.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, VirtualRobot};
    /// let robot = VirtualRobot::new(Policy::default());
    /// ```
    pub fn new(policy: Policy) -> Self {
        VirtualRobot {
            policy,
            sockets: Vec::new(),
            observer: None,
        }
    }

    /// Calls `observer(socket_name, direction, bytes)` for every chunk sent or received:
    /// the hook behind `ursock demo`'s transcript.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, VirtualRobot};
    /// let mut robot = VirtualRobot::new(Policy::default());
    /// robot.set_observer(|name, dir, bytes| println!("{name} {dir:?} {bytes:02X?}"));
    /// ```
    pub fn set_observer(&mut self, observer: impl FnMut(&str, Direction, &[u8]) + Send + 'static) {
        self.observer = Some(Box::new(observer));
    }

    /// `socket_open(address, port, socket_name)`: connects; `Ok(false)` if the server
    /// cannot be reached, as URScript returns `False`. An open socket of the same name is
    /// closed first.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, VirtualRobot};
    /// let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    /// let mut robot = VirtualRobot::new(Policy::default());
    /// assert!(robot.socket_open(listener.local_addr().unwrap(), "socket_0").unwrap());
    /// ```
    pub fn socket_open(
        &mut self,
        address: impl ToSocketAddrs,
        socket_name: &str,
    ) -> Result<bool, RobotError> {
        self.socket_close(socket_name);
        let stream = match TcpStream::connect(address) {
            Ok(s) => s,
            Err(_) => return Ok(false),
        };
        stream.set_nodelay(true).map_err(RobotError::Io)?;
        self.sockets
            .push((SocketConnection::new(socket_name, self.policy), stream));
        Ok(true)
    }

    /// [`socket_open`](Self::socket_open) that keeps the reason: `Ok(Err(e))` carries
    /// the OS error of a connection that failed (refused, unreachable, unknown host,
    /// missing port), where `socket_open` says only `Ok(false)`. For tools that must tell
    /// the user why; the URScript result is still `False`.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, VirtualRobot};
    /// let mut robot = VirtualRobot::new(Policy::default());
    /// assert!(robot.socket_open_or_reason("no-port-given", "socket_0").unwrap().is_err());
    /// ```
    pub fn socket_open_or_reason(
        &mut self,
        address: impl ToSocketAddrs,
        socket_name: &str,
    ) -> Result<Result<(), io::Error>, RobotError> {
        self.socket_close(socket_name);
        let stream = match TcpStream::connect(address) {
            Ok(s) => s,
            Err(e) => return Ok(Err(e)),
        };
        stream.set_nodelay(true).map_err(RobotError::Io)?;
        self.sockets
            .push((SocketConnection::new(socket_name, self.policy), stream));
        Ok(Ok(()))
    }

    /// `socket_close(socket_name)`; returns whether it was open.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, VirtualRobot};
    /// assert!(!VirtualRobot::new(Policy::default()).socket_close("socket_0"));
    /// ```
    pub fn socket_close(&mut self, socket_name: &str) -> bool {
        let before = self.sockets.len();
        self.sockets.retain(|(s, stream)| {
            if s.name() == socket_name {
                let _ = stream.shutdown(std::net::Shutdown::Both);
                false
            } else {
                true
            }
        });
        before != self.sockets.len()
    }

    /// The names of the open sockets.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, VirtualRobot};
    /// assert!(VirtualRobot::new(Policy::default()).socket_names().is_empty());
    /// ```
    pub fn socket_names(&self) -> Vec<String> {
        self.sockets
            .iter()
            .map(|(s, _)| String::from(s.name()))
            .collect()
    }

    fn index(&self, socket_name: &str) -> Result<usize, RobotError> {
        self.sockets
            .iter()
            .position(|(s, _)| s.name() == socket_name)
            .ok_or_else(|| RobotError::NotOpen(String::from(socket_name)))
    }

    /// Sends what the model queued on socket `i`.
    fn flush(&mut self, i: usize) -> Result<(), RobotError> {
        let (socket, stream) = &mut self.sockets[i];
        let out = socket.take_outgoing();
        if out.is_empty() {
            return Ok(());
        }
        if let Some(obs) = self.observer.as_mut() {
            obs(socket.name(), Direction::RobotToServer, &out);
        }
        stream.write_all(&out).map_err(RobotError::Io)
    }

    fn send_with(
        &mut self,
        socket_name: &str,
        f: impl FnOnce(&mut SocketConnection) -> Result<(), RobotError>,
    ) -> Result<(), RobotError> {
        let i = self.index(socket_name)?;
        f(&mut self.sockets[i].0)?;
        self.flush(i)
    }

    /// `socket_send_string(text, socket_name)`.
    ///
    /// ```no_run
    /// # use urscript_socket::robot::{Policy, VirtualRobot};
    /// # let mut robot = VirtualRobot::new(Policy::default());
    /// robot.socket_send_string(b"hi", "socket_0")?;
    /// # Ok::<(), urscript_socket::robot::RobotError>(())
    /// ```
    pub fn socket_send_string(&mut self, text: &[u8], socket_name: &str) -> Result<(), RobotError> {
        self.send_with(socket_name, |s| {
            s.send_string(text);
            Ok(())
        })
    }

    /// `socket_send_line(text, socket_name)`.
    ///
    /// ```no_run
    /// # use urscript_socket::robot::{Policy, VirtualRobot};
    /// # let mut robot = VirtualRobot::new(Policy::default());
    /// robot.socket_send_line(b"hello", "socket_0")?;
    /// # Ok::<(), urscript_socket::robot::RobotError>(())
    /// ```
    pub fn socket_send_line(&mut self, text: &[u8], socket_name: &str) -> Result<(), RobotError> {
        self.send_with(socket_name, |s| {
            s.send_line(text);
            Ok(())
        })
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
    ) -> Result<(), RobotError> {
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
    pub fn socket_send_byte(&mut self, value: u8, socket_name: &str) -> Result<(), RobotError> {
        self.send_with(socket_name, |s| {
            s.send_byte(value);
            Ok(())
        })
    }

    /// `socket_send_int(value, socket_name)`.
    ///
    /// ```no_run
    /// # use urscript_socket::robot::{Policy, VirtualRobot};
    /// # let mut robot = VirtualRobot::new(Policy::default());
    /// robot.socket_send_int(-1, "socket_0")?;
    /// # Ok::<(), urscript_socket::robot::RobotError>(())
    /// ```
    pub fn socket_send_int(&mut self, value: i32, socket_name: &str) -> Result<(), RobotError> {
        self.send_with(socket_name, |s| {
            s.send_int(value);
            Ok(())
        })
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
    ) -> Result<(), RobotError> {
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
        let i = self.index(socket_name)?;
        self.sockets[i].0.start_read(call)?;
        self.flush(i)?;
        let wait = self.sockets[i]
            .0
            .pending_timeout(timeout)
            .unwrap_or(timeout);
        let deadline = match wait {
            Timeout::After(d) => Some(Instant::now() + d),
            Timeout::Forever => None,
        };
        loop {
            let (socket, stream) = &mut self.sockets[i];
            if let Some(result) = socket.poll_read() {
                return Ok(result);
            }
            let remaining = match deadline {
                Some(d) => {
                    let now = Instant::now();
                    if now >= d {
                        return Ok(socket.handle_timeout().unwrap_or(ReadResult::Int(0)));
                    }
                    Some(d - now)
                }
                None => None,
            };
            stream.set_read_timeout(remaining).map_err(RobotError::Io)?;
            let space = socket.receive_space();
            if space.is_empty() {
                // Buffer full and the read still incomplete: nothing more can help it
                // but the timeout, exactly as a full TCP window on the robot.
                match remaining {
                    Some(r) => std::thread::sleep(r),
                    None => return Ok(socket.handle_timeout().unwrap_or(ReadResult::Int(0))),
                }
                continue;
            }
            match stream.read(space) {
                Ok(0) => socket.peer_closed(),
                Ok(n) => {
                    socket.commit_received(n);
                    if let Some(obs) = self.observer.as_mut() {
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
                        io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
                    ) => {}
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(_) => socket.peer_closed(),
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
