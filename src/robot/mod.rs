//! The robot's side: a sans-IO model of a UR controller's socket client, and (feature
//! `std`) a [`VirtualRobot`] that runs it over real TCP.
//!
//! The model follows quinn-proto's shape: it never reads a clock or a socket. Time is an
//! input everywhere, as a [`Duration`](core::time::Duration) since any epoch the driver
//! chooses (program start, `Instant` of the driver's first call, a test's virtual clock).
//! The caller feeds received bytes ([`SocketConnection::receive`]), starts a read at a
//! moment ([`SocketConnection::start_read`]`(call, timeout, now)`), asks whether it
//! completed ([`SocketConnection::poll_read`]), asks when the machine next needs waking
//! ([`SocketConnection::poll_timeout`]) and reports that the moment came
//! ([`SocketConnection::handle_timeout`]`(now)`), which resolves the read to its URScript
//! sentinel. Tests therefore control time completely. [`SocketConnection::next`]`(now)`
//! makes those calls in order and answers with a [`Step`], what the driver must do (receive
//! bytes until a deadline, sleep until it, or take the result), so every I/O driver (the
//! blocking [`VirtualRobot`], the async robot of the tokio adapter) is a short loop over it.
//!
//! Files: `call.rs` (what a program asks and gets: [`ReadCall`], [`Timeout`], [`Policy`],
//! [`ReadResult`]), `socket.rs` (the one-socket machine, [`SocketConnection`]), `table.rs`
//! (the robot's one socket table, [`Robot`]).
//!
//! Every read is one of the core decoders over the connection's bounded receive buffer;
//! the choices the UR manuals leave open are the fields of [`Policy`].
//!
//! ```
//! use std::time::Duration;
//! use urscript_socket::robot::{Policy, ReadCall, SocketConnection, Timeout};
//!
//! let mut socket = SocketConnection::new("socket_0", Policy::default());
//! socket.send_line(b"shoot");                       // socket_send_line("shoot")
//! assert_eq!(socket.take_outgoing(), b"shoot\n");
//!
//! let t0 = Duration::ZERO;
//! socket.start_read(ReadCall::AsciiFloat { number: 6 }, Timeout::default(), t0).unwrap();
//! socket.receive(b"(0.4,-0.2,0.3,");                // half a reply: still pending
//! assert!(socket.poll_read().is_none());
//! socket.receive(b"0,3.14,0)\n");
//! let pose = socket.poll_read().unwrap();
//! assert_eq!(pose.to_urscript(), "[6, 0.4, -0.2, 0.3, 0, 3.14, 0]");
//!
//! let t1 = Duration::from_millis(20);
//! socket.start_read(ReadCall::AsciiFloat { number: 2 }, Timeout::from_secs_f64(0.5), t1).unwrap();
//! assert_eq!(socket.poll_timeout(), Some(Duration::from_millis(520)));
//! assert!(socket.handle_timeout(Duration::from_millis(519)).is_none());
//! let timed_out = socket.handle_timeout(Duration::from_millis(520)).unwrap();
//! assert_eq!(timed_out.to_urscript(), "[0, nan, nan]");
//! ```
//!
//! ## Testing a vision server against the virtual robot
//!
//! ```
//! # #[cfg(feature = "std")] {
//! use std::io::{Read, Write};
//! use std::net::TcpListener;
//! use urscript_socket::{ascii_float::encode_float_tuple, line::LineDecoder, RecvBuffer};
//! use urscript_socket::robot::{Policy, Timeout, VirtualRobot};
//!
//! // The server under test: answers each line with a pose.
//! let listener = TcpListener::bind("127.0.0.1:0").unwrap();
//! let addr = listener.local_addr().unwrap();
//! let server = std::thread::spawn(move || {
//!     let (mut robot, _) = listener.accept().unwrap();
//!     let (mut rx, mut lines) = (RecvBuffer::with_capacity(1024), LineDecoder::new());
//!     loop {
//!         let n = robot.read(rx.spare()).unwrap();
//!         if n == 0 { break; }
//!         rx.commit(n);
//!         while let Some(_request) = rx.decode(&mut lines).unwrap() {
//!             let mut reply = Vec::new();
//!             encode_float_tuple(&[0.4, -0.2, 0.3, 0.0, 3.14, 0.0], true, &mut reply).unwrap();
//!             robot.write_all(&reply).unwrap();
//!         }
//!     }
//! });
//!
//! // The robot program, step by step.
//! let mut robot = VirtualRobot::new(Policy::default());
//! assert!(robot.socket_open(addr, "camera").unwrap());
//! robot.socket_send_line(b"shoot", "camera").unwrap();
//! let pose = robot.socket_read_ascii_float(6, "camera", Timeout::from_secs_f64(2.0)).unwrap();
//! assert_eq!(pose.count(), 6);
//! assert_eq!(pose.values(), [0.4, -0.2, 0.3, 0.0, 3.14, 0.0]);
//! robot.socket_close("camera");
//! server.join().unwrap();
//! # }
//! ```

mod call;
mod error;
mod socket;
mod table;

pub use call::{IntList, Policy, ReadCall, ReadResult, ShortRead, Timeout};
pub use error::RobotError;
pub use socket::{SocketConnection, Step};
pub use table::Robot;

#[cfg(feature = "std")]
pub use crate::adapters::virtual_robot::{Direction, VirtualRobot};

/// The socket name URScript uses when none is given.
pub const DEFAULT_SOCKET_NAME: &str = "socket_0";

/// Default bound of each connection's receive buffer, in bytes. Bytes past it are not
/// accepted ([`SocketConnection::receive`] says how many were), as a full TCP window
/// would hold them back on a real controller.
pub const DEFAULT_RECEIVE_CAPACITY: usize = 64 * 1024;
