//! [`AsyncRobotSocket`]: one robot socket over a tokio `TcpStream`, a short loop over the
//! sans-IO model's [`SocketConnection::next`] with `tokio::time` for the deadlines.
//! Re-exported from [`tokio_codec`](super::tokio_codec), its public path.

use std::vec::Vec;

use ::tokio::io::{AsyncReadExt, AsyncWriteExt};
use ::tokio::net::{TcpStream, ToSocketAddrs};

use crate::robot::{Policy, ReadCall, ReadResult, RobotError, SocketConnection, Step, Timeout};

/// One robot socket over a tokio `TcpStream`: the sans-IO robot model with real time.
/// Queue sends on [`socket`](Self::socket), then [`flush`](Self::flush); reads wait with
/// `tokio::time` and resolve to the URScript sentinel on timeout.
///
/// ```no_run
/// # async fn demo() -> Result<(), urscript_socket::robot::RobotError> {
/// use urscript_socket::adapters::tokio_codec::AsyncRobotSocket;
/// use urscript_socket::robot::{Policy, ReadCall, Timeout};
/// let mut robot = AsyncRobotSocket::connect("127.0.0.1:30000", "socket_0", Policy::default()).await?;
/// robot.socket().send_line(b"shoot");
/// let pose = robot.read(ReadCall::AsciiFloat { number: 6 }, Timeout::default()).await?;
/// println!("{}", pose.to_urscript());
/// # Ok(()) }
/// ```
#[derive(Debug)]
pub struct AsyncRobotSocket {
    conn: SocketConnection,
    stream: TcpStream,
    /// Time zero of the machine's clock.
    epoch: ::tokio::time::Instant,
}

impl AsyncRobotSocket {
    /// `socket_open(address, port, socket_name)`.
    ///
    /// ```no_run
    /// # async fn demo() {
    /// # use urscript_socket::{adapters::tokio_codec::AsyncRobotSocket, robot::Policy};
    /// let s = AsyncRobotSocket::connect("127.0.0.1:30000", "socket_0", Policy::default()).await;
    /// # }
    /// ```
    pub async fn connect(
        addr: impl ToSocketAddrs,
        socket_name: &str,
        policy: Policy,
    ) -> Result<Self, RobotError> {
        let stream = TcpStream::connect(addr).await.map_err(RobotError::Io)?;
        stream.set_nodelay(true).map_err(RobotError::Io)?;
        Ok(AsyncRobotSocket {
            conn: SocketConnection::new(socket_name, policy),
            stream,
            epoch: ::tokio::time::Instant::now(),
        })
    }

    /// The sans-IO socket: queue sends here (`send_line`, `send_int`, `set_var`...).
    ///
    /// ```no_run
    /// # async fn demo(robot: &mut urscript_socket::adapters::tokio_codec::AsyncRobotSocket) {
    /// robot.socket().send_int(7);
    /// # }
    /// ```
    pub fn socket(&mut self) -> &mut SocketConnection {
        &mut self.conn
    }

    /// Writes everything queued. `Ok(false)` if the peer has gone: the socket is then
    /// broken for writing and later sends return false, as `socket_send_*` returns False
    /// on the controller.
    ///
    /// ```no_run
    /// # async fn demo(robot: &mut urscript_socket::adapters::tokio_codec::AsyncRobotSocket) {
    /// robot.socket().send_line(b"go");
    /// assert!(robot.flush().await.unwrap());
    /// # }
    /// ```
    pub async fn flush(&mut self) -> Result<bool, RobotError> {
        let out: Vec<u8> = self.conn.take_outgoing();
        if !out.is_empty() && self.stream.write_all(&out).await.is_err() {
            self.conn.send_failed();
        }
        Ok(!self.conn.is_send_broken())
    }

    /// Runs a read call: sends what is queued (a `GET` for `GetVar`), then waits until the
    /// read completes, fails, the peer closes, or the timeout passes (the sentinel).
    ///
    /// ```no_run
    /// # async fn demo(robot: &mut urscript_socket::adapters::tokio_codec::AsyncRobotSocket) {
    /// use urscript_socket::robot::{ReadCall, Timeout};
    /// let r = robot.read(ReadCall::Line, Timeout::from_secs_f64(0.5)).await.unwrap();
    /// # }
    /// ```
    pub async fn read(
        &mut self,
        call: ReadCall,
        timeout: Timeout,
    ) -> Result<ReadResult, RobotError> {
        self.conn.start_read(call, timeout, self.epoch.elapsed())?;
        self.flush().await?;
        loop {
            match self.conn.next(self.epoch.elapsed()) {
                Step::Done(result) => return Ok(result),
                Step::NeedBytes { until } => {
                    // A deadline past what the clock can represent is no deadline.
                    let deadline = until.and_then(|d| self.epoch.checked_add(d));
                    let read = self.stream.read(self.conn.receive_space());
                    let n = match deadline {
                        Some(d) => match ::tokio::time::timeout_at(d, read).await {
                            Ok(r) => r,
                            Err(_elapsed) => continue,
                        },
                        None => read.await,
                    };
                    match n {
                        Ok(0) | Err(_) => self.conn.peer_closed(),
                        Ok(n) => self.conn.commit_received(n),
                    }
                }
                Step::Sleep { until } => match self.epoch.checked_add(until) {
                    Some(d) => ::tokio::time::sleep_until(d).await,
                    // A deadline past what the clock can represent never comes.
                    None => core::future::pending().await,
                },
                Step::Idle => return Err(RobotError::NoReadPending),
            }
        }
    }
}
