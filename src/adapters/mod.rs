//! Transport adapters: thin layers that move bytes between a transport and the core.
//! None of them parses a format: each drives a core [`Decoder`](crate::Decoder) over a
//! bounded [`RecvBuffer`](crate::RecvBuffer) and writes what a core encoder produced.
//!
//! * `blocking` (feature `std`): `std::io::Read`/`Write`, a `TcpStream` in practice.
//! * `tokio` (feature `tokio`): `tokio_util::codec` codecs for every server-side
//!   format, and an async robot socket with `tokio::time` timeouts.
//! * `embedded` (feature `embedded-io-async`): `embedded_io_async::{Read, Write}`
//!   (embassy-net, smoltcp), with no allocator.

#[cfg(feature = "std")]
pub mod blocking;
#[cfg(feature = "embedded-io-async")]
pub mod embedded;
#[cfg(feature = "tokio")]
pub mod tokio;
#[cfg(feature = "std")]
pub(crate) mod virtual_robot;
