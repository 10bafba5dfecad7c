//! # urscript-socket
//!
//! The byte formats a Universal Robots controller speaks through its URScript
//! `socket_*` functions, as a pure sans-IO codec: encoders and incremental decoders for
//! both directions, that never allocate, never panic and hold at most a documented
//! number of bytes; and thin adapters for blocking `std::io`, tokio and
//! `embedded-io-async`.
//!
//! The robot is always the TCP client; the PC (camera, vision system, PLC gateway,
//! driver) is the server. The stream has no framing and the robot's reads time out
//! silently, so every format needs its own rule for where a message ends. This crate
//! writes those rules down once.
//!
//! ## Adding it
//!
//! ```toml
//! [dependencies]
//! # the core and the blocking std adapters (default feature `std`)
//! urscript-socket = "0.1"
//! # or, for a tokio server: the tokio_util codecs
//! # urscript-socket = { version = "0.1", features = ["tokio"] }
//! # or the no_std core alone, no allocator
//! # urscript-socket = { version = "0.1", default-features = false }
//! # or firmware on embassy-net/smoltcp: the embedded-io-async adapters, no allocator
//! # urscript-socket = { version = "0.1", default-features = false, features = ["embedded-io-async"] }
//! ```
//!
//! The tokio server below also uses `tokio`, `tokio-util` (feature `codec`) and
//! `futures-util` (feature `sink`, for `SinkExt::send`).
//!
//! ## Which API do I pick?
//!
//! | you are writing | use | feature |
//! |---|---|---|
//! | a tokio server (vision, PLC gateway, camera, driver) | `adapters::tokio_codec`: `Framed` + `RequestReply<Tolerant<LineCodec>, FloatTupleCodec>` and friends | `tokio` |
//! | a blocking server, a thread per robot | `adapters::blocking`: `MessageReader` (an `Iterator`), `MessageWriter` | `std` (default) |
//! | firmware on embassy-net or smoltcp, no allocator | `adapters::embedded`: `MessageReader<_, _, N>`, `send` | `embedded-io-async` |
//! | your own event loop, another runtime, a test harness | the core: a decoder, [`RecvBuffer`], an `encode_*` function | none (`no_std`) |
//! | a test of your server without a robot | `robot::VirtualRobot`, `adapters::tokio_codec::AsyncRobotSocket` | `std` / `tokio` |
//!
//! | the robot calls | the server decodes with | the server answers with |
//! |---|---|---|
//! | `socket_send_line` | `LineCodec` / [`line::LineDecoder`] | |
//! | `socket_read_ascii_float(n)` | | `FloatTupleCodec::new(n)` / [`ascii_float::encode_float_tuple`] |
//! | `socket_send_int` | `Int32Codec` / [`adapters::Int32Stream`] | |
//! | `socket_read_binary_integer(n)` | | `Int32Codec` / [`int32::encode_int32_list`] |
//! | `socket_send_byte` (STX/ETX) | `StxEtxCodec` / [`stx_etx::StxEtxDecoder`], `ByteCodec` | |
//! | `socket_send_string` | `DelimitedCodec` / [`string::DelimitedDecoder`] | `LineCodec`, [`string::encode_string`] for `socket_read_string` |
//! | `socket_set_var`, `socket_get_var` | `VarCodec` / [`var::VarMessageDecoder`] | `VarCodec` / [`var::encode_var_reply`] |
//!
//! The `cookbook` module (feature `tokio`; the text is `docs/cookbook/` in the package, compiled
//! as doc tests) has the four servers people write: a vision system (float tuples), a PLC
//! gateway (`SET`/`GET`), a camera with CR framing (KEYENCE-style), and External Control
//! (int32).
//!
//! ## A tokio server
//!
//! A robot sends `socket_send_line("shoot")` and reads the pose with
//! `socket_read_ascii_float(6)`. One `Framed` decodes lines and encodes tuples (no LF after
//! the tuple: it would stay in the robot's buffer), and the tolerant mode reports a bad
//! line (say, one over the 4096-byte bound) as an item instead of ending the stream:
//!
//! ```no_run
//! # #[cfg(feature = "tokio")] mod doc {
//! use futures_util::{SinkExt, StreamExt};
//! use tokio::net::TcpListener;
//! use tokio_util::codec::Framed;
//! use urscript_socket::adapters::tokio_codec::{FloatTupleCodec, LineCodec, RequestReply, Tolerant};
//!
//! #[tokio::main]
//! async fn main() -> std::io::Result<()> {
//!     let listener = TcpListener::bind("0.0.0.0:30000").await?;
//!     loop {
//!         let (robot, peer) = listener.accept().await?; // the robot's socket_open
//!         tokio::spawn(async move {
//!             let codec = RequestReply::new(Tolerant::new(LineCodec::new()), FloatTupleCodec::new(6)?);
//!             let mut framed = Framed::new(robot, codec);
//!             while let Some(request) = framed.next().await {
//!                 match request? {
//!                     Ok(line) if line == "shoot" => {
//!                         framed.send([0.4, -0.2, 0.3, 0.0, 3.14, 0.0]).await?;
//!                     }
//!                     Ok(line) => eprintln!("{peer}: unknown request {line:?}"),
//!                     Err(bad) => eprintln!("{peer}: skipped {bad}"), // the stream goes on
//!                 }
//!             }
//!             Ok::<_, Box<dyn std::error::Error + Send + Sync>>(())
//!         });
//!     }
//! }
//! # }
//! # fn main() {}
//! ```
//!
//! Encoders take what tokio-util users pass: `framed.send("OK")`, `String`, `Vec<u8>`,
//! `Bytes` for text codecs; `[f64; 6]`, `&[f64]`, `Vec<f64>` for `FloatTupleCodec`
//! (exactly `n` values, else an error); `i32` or `[i32; N]`/`Vec<i32>` for `Int32Codec`.
//!
//! ## A blocking server
//!
//! The same server on threads. `MessageReader` is an `Iterator` of owned messages; bad
//! bytes and read timeouts are yielded as recoverable errors and the iteration goes on.
//! Both error types convert into `std::io::Error`.
//!
//! ```no_run
//! use std::net::TcpListener;
//! use urscript_socket::adapters::blocking::{MessageReader, MessageWriter};
//! use urscript_socket::{ascii_float::encode_float_tuple, line::LineDecoder};
//!
//! fn main() -> std::io::Result<()> {
//!     let listener = TcpListener::bind("0.0.0.0:30000")?;
//!     for robot in listener.incoming() {
//!         let robot = robot?;
//!         std::thread::spawn(move || -> std::io::Result<()> {
//!             let mut replies = MessageWriter::new(robot.try_clone()?);
//!             for request in MessageReader::new(robot, LineDecoder::new()) {
//!                 match request {
//!                     Ok(line) if line == b"shoot" => replies.send(|out| {
//!                         encode_float_tuple(&[0.4, -0.2, 0.3, 0.0, 3.14, 0.0], false, out)
//!                     })?,
//!                     Ok(line) => eprintln!("unknown request {:?}", line.escape_ascii().to_string()),
//!                     Err(e) if e.is_recoverable() => eprintln!("skipped: {e}"),
//!                     Err(e) => return Err(e.into()),
//!                 }
//!             }
//!             Ok(())
//!         });
//!     }
//!     Ok(())
//! }
//! ```
//!
//! ## An embassy task
//!
//! The same server with no allocator: any `embedded_io_async` stream (an embassy-net
//! `TcpSocket` after `accept`, a smoltcp socket wrapper), a 256-byte receive buffer inside
//! the reader and a 64-byte scratch buffer for the reply.
//!
//! ```no_run
//! # #[cfg(feature = "embedded-io-async")] mod doc {
//! use embedded_io_async::{Read, Write};
//! use urscript_socket::adapters::embedded::{send, AdapterError, MessageReader};
//! use urscript_socket::{ascii_float::encode_float_tuple, line::LineDecoder};
//!
//! pub async fn serve_robot<S: Read + Write>(socket: S) -> Result<(), AdapterError<S::Error>> {
//!     let mut requests: MessageReader<S, LineDecoder, 256> =
//!         MessageReader::new(socket, LineDecoder::with_max_len(200));
//!     let mut scratch = [0u8; 64];
//!     loop {
//!         match requests.next_with(|line| line == b"shoot").await {
//!             Ok(Some(true)) => {
//!                 let pose = [0.4, -0.2, 0.3, 0.0, 3.14, 0.0];
//!                 send(requests.get_mut(), &mut scratch, |out| encode_float_tuple(&pose, false, out)).await?
//!             }
//!             Ok(Some(false)) => {}                 // not a request we know
//!             Ok(None) => return Ok(()),            // the robot closed
//!             Err(AdapterError::Decode(_)) => {}    // bad bytes, already skipped
//!             Err(e) => return Err(e),
//!         }
//!     }
//! }
//!
//! // With embassy-net:
//! // #[embassy_executor::task]
//! // async fn robot_task(stack: embassy_net::Stack<'static>) {
//! //     let (mut rx, mut tx) = ([0u8; 1024], [0u8; 1024]);
//! //     loop {
//! //         let mut socket = embassy_net::tcp::TcpSocket::new(stack, &mut rx, &mut tx);
//! //         if socket.accept(30000).await.is_ok() {
//! //             let _ = serve_robot(&mut socket).await;
//! //         }
//! //     }
//! // }
//! # }
//! # fn main() {}
//! ```
//!
//! ## Layers
//!
//! ```text
//!  ursock (CLI, its own package)       demo · listen · robot · encode · read · decode
//!        │
//!  adapters (`std`, `tokio`, `embedded-io-async`)   move bytes, never parse
//!        │
//!  robot emulation                     URScript read/send functions, time as an input
//!        │
//!  core codec (no_std, no alloc)       one module per wire format
//! ```
//!
//! ## Core modules, one per wire format
//!
//! | module | robot sends | server sends |
//! |---|---|---|
//! | [`ascii_float`] | | `(1.414,3.14159)` for `socket_read_ascii_float` |
//! | [`int32`] | `socket_send_int` | int32 lists for `socket_read_binary_integer` |
//! | [`byte_list`] | `socket_send_byte` | bytes for `socket_read_byte_list` |
//! | [`line`](mod@line) | `socket_send_line` | lines for `socket_read_line` |
//! | [`string`] | `socket_send_string` | strings for `socket_read_string` (prefix/suffix) |
//! | [`stx_etx`] | `02 <s> 03` framing | |
//! | [`var`] | `SET name v`, `GET name` | `name v` replies |
//! | [`to_str`] | text of numbers, bools, lists, poses | |
//!
//! Every decoder follows one contract ([`Decode`], [`Status`]): the caller owns the
//! buffer, the decoder remembers how far it looked, and complete messages borrow the
//! buffer. [`RecvBuffer`] packages that loop over a fixed storage.
//!
//! ## The sans-IO loop: a vision server answering `socket_read_ascii_float(6)`
//!
//! ```
//! use urscript_socket::{ascii_float::encode_float_tuple, line::LineDecoder, RecvBuffer};
//!
//! // What the robot sent: `socket_send_line("shoot")`, in two TCP segments.
//! let mut rx = RecvBuffer::<[u8; 256]>::new();
//! let mut requests = LineDecoder::new();
//! let mut reply = Vec::new();
//! for segment in [&b"sho"[..], b"ot\n"] {
//!     rx.extend(segment);
//!     while let Some(request) = rx.decode(&mut requests).unwrap() {
//!         assert_eq!(request, b"shoot");
//!         encode_float_tuple(&[0.4, -0.2, 0.3, 0.0, 3.14, 0.0], false, &mut reply).unwrap();
//!     }
//! }
//! assert_eq!(reply, b"(0.4,-0.2,0.3,0,3.14,0)");
//! ```
//!
//! ## MSRV
//!
//! The library builds with Rust 1.85 (`rust-version`, checked in CI); its tests, benches
//! and examples use dev-dependencies that need a newer toolchain.
#![no_std]
#![forbid(unsafe_code)]
#![warn(missing_docs)]
// The spec's vectors use 3.14 and 3.14159 as data, not as π.
#![cfg_attr(test, allow(clippy::approx_constant))]
#![cfg_attr(docsrs, feature(doc_cfg))]

/// The most values one `socket_read_ascii_float`, `socket_read_binary_integer` or
/// `socket_read_byte_list` call reads (spec section 1): the robot's limit, and the bound on
/// every `number` argument.
pub const MAX_VALUES: usize = 30;

#[cfg(feature = "alloc")]
extern crate alloc;
#[cfg(all(test, not(feature = "alloc")))]
extern crate alloc;
#[cfg(feature = "std")]
extern crate std;

mod buffer;
mod error;
mod framer;
mod number;
mod sink;
mod status;

pub mod ascii_float;
pub mod byte_list;
pub mod format;
pub mod int32;
pub mod line;
pub mod string;
pub mod stx_etx;
pub mod to_str;
pub mod var;

#[cfg(feature = "alloc")]
pub mod robot;

pub mod adapters;

#[cfg(feature = "tokio")]
#[cfg_attr(docsrs, doc(cfg(feature = "tokio")))]
pub mod cookbook {
    //! The four servers people write, each a complete tokio server (feature `tokio`).
    //! The robot is always the TCP client (`socket_open`); these are the PC side. Every
    //! recipe here is compiled as a doc test of the crate, so it cannot rot; the text is
    //! `docs/cookbook/*.md` in the package.
    //!
    //! | recipe | the robot sends | the server answers |
    //! |---|---|---|
    //! | [`vision`] | `socket_send_line("shoot")` | `(x,y,z,rx,ry,rz)` for `socket_read_ascii_float(6)` |
    //! | [`plc_gateway`] | `socket_set_var`, `socket_get_var` | `name value\n` |
    //! | [`camera_cr`] | `T1` + CR (`socket_send_string`, `socket_send_byte(13)`) | `OK,x,y,angle` + CR for `socket_read_string(suffix="\r")` |
    //! | [`external_control`] | `socket_send_int(result)` | 8 int32 for `socket_read_binary_integer(8)` |
    //!
    //! Every recipe uses [`Tolerant`](crate::adapters::tokio_codec::Tolerant), so one bad
    //! message is reported and the connection goes on answering: without it a
    //! `tokio_util::codec::Framed` stream ends at the first decoding error while the robot
    //! stays connected and sees only read timeouts.
    //!
    //! What the recipes need in `Cargo.toml` (`futures-util` for `SinkExt::send` and
    //! `StreamExt::next` on a `Framed`):
    //!
    //! ```toml
    //! [dependencies]
    //! urscript-socket = { version = "0.1", features = ["tokio"] }
    //! tokio = { version = "1", features = ["full"] }
    //! tokio-util = { version = "0.7", features = ["codec"] }
    //! futures-util = { version = "0.3", features = ["sink"] }
    //! ```

    pub mod vision {
        #![doc = include_str!("../docs/cookbook/vision.md")]
    }
    pub mod plc_gateway {
        #![doc = include_str!("../docs/cookbook/plc-gateway.md")]
    }
    pub mod camera_cr {
        #![doc = include_str!("../docs/cookbook/camera-cr.md")]
    }
    pub mod external_control {
        #![doc = include_str!("../docs/cookbook/external-control.md")]
    }
}

pub use buffer::RecvBuffer;
pub use error::{ArgumentError, DecodeError, EncodeError, ErrorKind};
pub use framer::{FrameDecoder, Parse, MAX_BOUND};
pub use sink::{ByteSink, SliceSink};
pub use status::{Decode, Status};

/// The README's code, compiled as a doc test so it cannot rot.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
