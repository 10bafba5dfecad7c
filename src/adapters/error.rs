//! The one error type of the adapter layer, generic over the transport's error.

use core::fmt;

use crate::{DecodeError, EncodeError};

/// Why an adapter call failed: the transport (`E`: `std::io::Error` for the blocking
/// and tokio adapters, the socket's error for `embedded-io-async`), bad bytes, a value
/// the encoder refuses, or a bound. Each adapter names it for its transport:
/// `blocking::ReadError`/`WriteError` and `tokio::CodecError` are
/// `AdapterError<std::io::Error>`; the embedded adapter returns it over the socket's error.
///
/// With `std`, `AdapterError<std::io::Error>` converts into `std::io::Error`, so `?` works
/// in a function returning `io::Result`.
///
/// ```
/// use urscript_socket::adapters::AdapterError;
/// use urscript_socket::EncodeError;
/// let e: AdapterError<core::fmt::Error> = AdapterError::Encode(EncodeError::NoValues);
/// assert!(e.is_recoverable());
/// assert_eq!(e.to_string(), "cannot encode: at least one value is required");
/// ```
#[derive(Debug)]
#[non_exhaustive]
pub enum AdapterError<E> {
    /// The transport failed.
    Io(E),
    /// Bad bytes: what and where. They are already skipped; the next call goes on with
    /// the next message.
    Decode(DecodeError),
    /// The encoder refused the message; nothing was written.
    Encode(EncodeError),
    /// A list of another length than the codec was made for (e.g. 5 values given to
    /// `FloatTupleCodec::new(6)`): the robot's read would fail on it. Nothing was written.
    WrongCount {
        /// Values per message the codec was made for.
        expected: usize,
        /// Values given.
        found: usize,
    },
    /// The receive buffer is full and still holds no complete message.
    BufferFull {
        /// The buffer's capacity in bytes.
        capacity: usize,
    },
    /// The read timeout set on the transport passed first; call again to go on waiting.
    TimedOut,
}

impl<E> AdapterError<E> {
    /// Whether the connection can go on after this error: bad bytes (already skipped),
    /// a refused value and a read timeout are recoverable; a transport error, a close
    /// mid-message and a full buffer are not.
    ///
    /// ```
    /// use urscript_socket::adapters::AdapterError;
    /// assert!(AdapterError::<()>::TimedOut.is_recoverable());
    /// assert!(!AdapterError::<()>::BufferFull { capacity: 8 }.is_recoverable());
    /// ```
    pub fn is_recoverable(&self) -> bool {
        matches!(
            self,
            AdapterError::Decode(_)
                | AdapterError::Encode(_)
                | AdapterError::WrongCount { .. }
                | AdapterError::TimedOut
        )
    }
}

impl<E: fmt::Display> fmt::Display for AdapterError<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            AdapterError::Io(e) => write!(f, "transport error: {e}"),
            AdapterError::Decode(e) => write!(f, "bad input: {e}"),
            AdapterError::Encode(e) => write!(f, "cannot encode: {e}"),
            AdapterError::WrongCount { expected, found } => write!(
                f,
                "cannot encode: {found} values given to a codec of {expected} values per message"
            ),
            AdapterError::BufferFull { capacity } => write!(
                f,
                "receive buffer of {capacity} bytes full without a complete message"
            ),
            AdapterError::TimedOut => f.write_str("no complete message before the read timeout"),
        }
    }
}

impl<E: core::error::Error + 'static> core::error::Error for AdapterError<E> {
    fn source(&self) -> Option<&(dyn core::error::Error + 'static)> {
        match self {
            AdapterError::Io(e) => Some(e),
            AdapterError::Decode(e) => Some(e),
            AdapterError::Encode(e) => Some(e),
            _ => None,
        }
    }
}

impl<E> From<DecodeError> for AdapterError<E> {
    fn from(e: DecodeError) -> Self {
        AdapterError::Decode(e)
    }
}

impl<E> From<EncodeError> for AdapterError<E> {
    fn from(e: EncodeError) -> Self {
        AdapterError::Encode(e)
    }
}

#[cfg(feature = "std")]
impl From<std::io::Error> for AdapterError<std::io::Error> {
    fn from(e: std::io::Error) -> Self {
        AdapterError::Io(e)
    }
}

/// A transport error comes back as it was; the others get the nearest kind: bad bytes
/// `InvalidData`, a refused value `InvalidInput`, a timeout `TimedOut`, a cut message
/// `UnexpectedEof`, a full buffer `OutOfMemory`.
///
/// ```
/// use urscript_socket::adapters::AdapterError;
/// let e = std::io::Error::from(AdapterError::<std::io::Error>::TimedOut);
/// assert_eq!(e.kind(), std::io::ErrorKind::TimedOut);
/// ```
#[cfg(feature = "std")]
impl From<AdapterError<std::io::Error>> for std::io::Error {
    fn from(e: AdapterError<std::io::Error>) -> Self {
        use std::io::ErrorKind as K;
        let kind = match &e {
            AdapterError::Io(_) => {
                return match e {
                    AdapterError::Io(inner) => inner,
                    other => std::io::Error::other(other),
                }
            }
            AdapterError::Decode(_) => K::InvalidData,
            AdapterError::Encode(_) | AdapterError::WrongCount { .. } => K::InvalidInput,
            AdapterError::BufferFull { .. } => K::OutOfMemory,
            AdapterError::TimedOut => K::TimedOut,
        };
        std::io::Error::new(kind, e)
    }
}
