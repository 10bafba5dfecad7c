//! # urscript-socket
//!
//! The byte formats a Universal Robots controller speaks through its URScript
//! `socket_*` functions, as a pure sans-IO codec: encoders and incremental decoders for
//! both directions, that never allocate, never panic and hold at most a documented
//! number of bytes.
//!
//! The robot is always the TCP client; the PC (camera, vision system, PLC gateway,
//! driver) is the server. The stream has no framing and the robot's reads time out
//! silently, so every format needs its own rule for where a message ends. This crate
//! writes those rules down once.
//!
//! ## Layers
//!
//! ```text
//!  ursock (CLI, feature `cli`)        demo · listen · robot · encode · read · decode
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
//! Every decoder follows one contract ([`Decoder`], [`Status`]): the caller owns the
//! buffer, the decoder remembers how far it looked, and complete messages borrow the
//! buffer. [`RecvBuffer`] packages that loop over a fixed storage.
//!
//! ## Example: a vision server answering `socket_read_ascii_float(6)`
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
//!         encode_float_tuple(&[0.4, -0.2, 0.3, 0.0, 3.14, 0.0], true, &mut reply).unwrap();
//!     }
//! }
//! assert_eq!(reply, b"(0.4,-0.2,0.3,0,3.14,0)\n");
//! ```
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

pub use buffer::RecvBuffer;
pub use error::{ArgumentError, DecodeError, EncodeError, ErrorKind};
pub use framer::{Framed, Parse, MAX_BOUND};
pub use sink::{Sink, SliceSink};
pub use status::{Decoder, Status};

/// The README's code, compiled as a doc test so it cannot rot.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
