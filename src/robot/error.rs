//! The errors of the robot emulation.

use alloc::string::String;
use core::fmt;

use crate::{ArgumentError, EncodeError};

/// A misuse of the emulated socket API, refused before any byte is read or sent.
///
/// ```
/// use std::time::Duration;
/// use urscript_socket::robot::{Policy, ReadCall, RobotError, SocketConnection, Timeout};
/// let mut s = SocketConnection::new("socket_0", Policy::default());
/// assert!(matches!(
///     s.start_read(ReadCall::AsciiFloat { number: 31 }, Timeout::default(), Duration::ZERO),
///     Err(RobotError::Argument(_))
/// ));
/// ```
#[derive(Debug)]
#[non_exhaustive]
pub enum RobotError {
    /// An argument the controller rejects (`number` outside 1..=30, a bad name...).
    Argument(ArgumentError),
    /// A value that cannot be sent (a variable name with a space...).
    Encode(EncodeError),
    /// A read was started while another one is pending on the same socket.
    ReadPending,
    /// A read loop stepped a socket with no read pending ([`Step::Idle`](super::Step::Idle)).
    NoReadPending,
    /// No socket of that name is open.
    NotOpen(String),
    /// The transport failed (virtual robot only).
    #[cfg(feature = "std")]
    Io(std::io::Error),
}

impl fmt::Display for RobotError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RobotError::Argument(e) => write!(f, "invalid argument: {e}"),
            RobotError::Encode(e) => write!(f, "cannot send: {e}"),
            RobotError::ReadPending => f.write_str("a read is already pending on this socket"),
            RobotError::NoReadPending => f.write_str("no read is pending on this socket"),
            RobotError::NotOpen(name) => write!(f, "no open socket named \"{name}\""),
            #[cfg(feature = "std")]
            RobotError::Io(e) => write!(f, "socket error: {e}"),
        }
    }
}

impl core::error::Error for RobotError {
    fn source(&self) -> Option<&(dyn core::error::Error + 'static)> {
        match self {
            RobotError::Argument(e) => Some(e),
            RobotError::Encode(e) => Some(e),
            #[cfg(feature = "std")]
            RobotError::Io(e) => Some(e),
            _ => None,
        }
    }
}

impl From<ArgumentError> for RobotError {
    fn from(e: ArgumentError) -> Self {
        RobotError::Argument(e)
    }
}

impl From<EncodeError> for RobotError {
    fn from(e: EncodeError) -> Self {
        RobotError::Encode(e)
    }
}
