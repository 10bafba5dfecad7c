//! Transport adapters: thin layers that move bytes between a transport and the core.
//! None of them parses a format: each drives a core [`Decode`](crate::Decode) over a
//! bounded [`RecvBuffer`](crate::RecvBuffer) and writes what a core encoder produced.
//!
//! * `blocking` (feature `std`): `std::io::Read`/`Write`, a `TcpStream` in practice;
//!   messages as an `Iterator` of owned items, or lent from the buffer with `next_with`.
//! * `tokio` (feature `tokio`): `tokio_util::codec` codecs for every server-side
//!   format, a request/reply pairing for one `Framed`, a tolerant mode, and an async robot
//!   socket with `tokio::time` timeouts.
//! * `embedded` (feature `embedded-io-async`): `embedded_io_async::{Read, Write}`
//!   (embassy-net, smoltcp), with no allocator.
//!
//! Shared by all three:
//!
//! * [`AdapterError`]`<E>`: the one error type, generic over the transport's error; it converts
//!   into `std::io::Error` for the std transports.
//! * [`Int32Stream`] and [`ByteStream`]: a server reading the robot's `socket_send_int` /
//!   `socket_send_byte` gets one `i32` / `u8` per message, whatever the adapter.
//! * [`OwnedDecoder`]: the owned form of every core decoder's message (`i32`, `u8`,
//!   `FloatTuple`; with `alloc` also `Vec<u8>`, `Vec<i32>` and `VarRequest`), which the
//!   blocking iterator and the embedded `next_owned` yield.

mod error;
pub use error::AdapterError;

mod single;
pub use single::{ByteStream, Int32Stream};

mod owned;
pub use owned::OwnedDecoder;
#[cfg(feature = "alloc")]
pub use owned::VarRequest;

#[cfg(feature = "std")]
pub mod blocking;
#[cfg(feature = "embedded-io-async")]
pub mod embedded;
#[cfg(feature = "tokio")]
pub mod tokio_codec;
#[cfg(feature = "tokio")]
mod tokio_robot;
#[cfg(feature = "std")]
pub(crate) mod virtual_robot;
