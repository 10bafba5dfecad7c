//! The robot's one table of open sockets.

use alloc::vec::Vec;
use core::time::Duration;

use super::{Policy, SocketConnection};

/// The robot's set of open sockets, by name (`socket_open(address, port, socket_name)`),
/// each with the transport a driver attached to it (`T`: `()` for a pure model, a
/// `TcpStream` in [`VirtualRobot`](super::VirtualRobot)). The one socket table of the
/// crate: every driver keeps its connections here.
///
/// Bound: as on the controller, a program opens few sockets; the table is a `Vec` searched
/// by name, and re-opening a name replaces the old socket.
///
/// ```
/// use urscript_socket::robot::{Policy, Robot};
/// let mut robot = Robot::new(Policy::default());
/// robot.socket_open("camera").send_line(b"go");
/// assert_eq!(robot.socket("camera").unwrap().outgoing(), b"go\n");
/// robot.socket_close("camera");
/// assert!(robot.socket("camera").is_none());
/// ```
#[derive(Debug)]
pub struct Robot<T = ()> {
    policy: Policy,
    sockets: Vec<(SocketConnection, T)>,
}

impl<T> Robot<T> {
    /// A robot with no socket open.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, Robot};
    /// let mut robot: Robot = Robot::new(Policy::default());
    /// assert!(robot.socket("socket_0").is_none());
    /// ```
    pub fn new(policy: Policy) -> Self {
        Robot {
            policy,
            sockets: Vec::new(),
        }
    }

    /// The policy every socket opened here gets.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, Robot};
    /// assert_eq!(*Robot::<()>::new(Policy::default()).policy(), Policy::default());
    /// ```
    pub fn policy(&self) -> &Policy {
        &self.policy
    }

    /// Opens the socket `name` over `transport`. As on the robot, opening a name that is
    /// open replaces that socket afresh; its transport is handed back to be shut down.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, Robot};
    /// let mut robot = Robot::new(Policy::default());
    /// assert_eq!(robot.open("cam", 1), None);
    /// assert_eq!(robot.open("cam", 2), Some(1));
    /// ```
    pub fn open(&mut self, name: &str, transport: T) -> Option<T> {
        let old = self.close(name);
        self.sockets
            .push((SocketConnection::new(name, self.policy), transport));
        old
    }

    /// The socket `name` and its transport.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, Robot};
    /// let mut robot = Robot::new(Policy::default());
    /// robot.open("cam", 7);
    /// let (socket, transport) = robot.get("cam").unwrap();
    /// assert_eq!((socket.name(), *transport), ("cam", 7));
    /// ```
    pub fn get(&mut self, name: &str) -> Option<(&mut SocketConnection, &mut T)> {
        self.sockets
            .iter_mut()
            .find(|(s, _)| s.name() == name)
            .map(|(s, t)| (s, t))
    }

    /// The open socket `name`.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, Robot};
    /// let mut robot = Robot::new(Policy::default());
    /// robot.socket_open("a");
    /// assert!(robot.socket("a").is_some());
    /// ```
    pub fn socket(&mut self, name: &str) -> Option<&mut SocketConnection> {
        self.get(name).map(|(s, _)| s)
    }

    /// Closes the socket `name`, handing back its transport if it was open.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, Robot};
    /// let mut robot = Robot::new(Policy::default());
    /// robot.open("a", "stream");
    /// assert_eq!(robot.close("a"), Some("stream"));
    /// assert_eq!(robot.close("a"), None);
    /// ```
    pub fn close(&mut self, name: &str) -> Option<T> {
        let i = self.sockets.iter().position(|(s, _)| s.name() == name)?;
        Some(self.sockets.remove(i).1)
    }

    /// The names of the open sockets, in the order they were opened.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, Robot};
    /// let mut robot = Robot::new(Policy::default());
    /// robot.socket_open("a");
    /// robot.socket_open("b");
    /// assert_eq!(robot.names().collect::<Vec<_>>(), ["a", "b"]);
    /// ```
    pub fn names(&self) -> impl Iterator<Item = &str> {
        self.sockets.iter().map(|(s, _)| s.name())
    }

    /// The earliest deadline of any pending read: when the robot next needs waking.
    ///
    /// ```
    /// # use std::time::Duration;
    /// # use urscript_socket::robot::{Policy, ReadCall, Robot, Timeout};
    /// let mut robot = Robot::new(Policy::default());
    /// robot.socket_open("a").start_read(ReadCall::Line, Timeout::default(), Duration::ZERO).unwrap();
    /// robot.socket_open("b").start_read(ReadCall::Line, Timeout::from_secs_f64(0.1), Duration::ZERO).unwrap();
    /// assert_eq!(robot.poll_timeout(), Some(Duration::from_millis(100)));
    /// ```
    pub fn poll_timeout(&self) -> Option<Duration> {
        self.sockets
            .iter()
            .filter_map(|(s, _)| s.poll_timeout())
            .min()
    }
}

impl Robot<()> {
    /// Opens (or, as on the robot, re-opens afresh) the socket `name`, with no transport.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, Robot, DEFAULT_SOCKET_NAME};
    /// let mut robot = Robot::new(Policy::default());
    /// assert_eq!(robot.socket_open(DEFAULT_SOCKET_NAME).name(), "socket_0");
    /// ```
    pub fn socket_open(&mut self, name: &str) -> &mut SocketConnection {
        self.open(name, ());
        let last = self.sockets.len() - 1;
        &mut self.sockets[last].0
    }

    /// Closes the socket `name`; returns whether it was open.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, Robot};
    /// let mut robot = Robot::new(Policy::default());
    /// assert!(!robot.socket_close("a"));
    /// ```
    pub fn socket_close(&mut self, name: &str) -> bool {
        self.close(name).is_some()
    }
}
