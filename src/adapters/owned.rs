//! Owned forms of every core message: what an adapter hands out when the item must
//! outlive the receive buffer (an iterator, a channel, another task). Messages that are
//! values already (`i32`, `u8`, `FloatTuple`) need no allocator; byte strings, int32
//! lists and variable names need `alloc`.

#[cfg(feature = "alloc")]
use alloc::{string::String, vec::Vec};

use super::{ByteStream, Int32Stream};
use crate::ascii_float::{FloatTuple, FloatTupleDecoder};
#[cfg(feature = "alloc")]
use crate::byte_list::ByteListDecoder;
#[cfg(feature = "alloc")]
use crate::int32::{Int32Decoder, Int32Values};
#[cfg(feature = "alloc")]
use crate::line::LineDecoder;
#[cfg(feature = "alloc")]
use crate::string::{DelimitedDecoder, ReadStringDecoder};
#[cfg(feature = "alloc")]
use crate::stx_etx::StxEtxDecoder;
use crate::var::VarReplyDecoder;
#[cfg(feature = "alloc")]
use crate::var::{VarMessage, VarMessageDecoder};
use crate::Decode;

/// A core decoder whose messages have an owned form: the blocking reader's iterator
/// yields [`Owned`](Self::Owned) items, so nothing borrows the receive buffer.
///
/// | decoder | borrowed item | owned item |
/// |---|---|---|
/// | `LineDecoder`, `StxEtxDecoder`, `DelimitedDecoder`, `ReadStringDecoder`, `ByteListDecoder` | `&[u8]` | `Vec<u8>` |
/// | `Int32Decoder` | `Int32Values` | `Vec<i32>` |
/// | [`Int32Stream`] / [`ByteStream`] | `i32` / `u8` | `i32` / `u8` |
/// | `FloatTupleDecoder` | `FloatTuple` | `FloatTuple` |
/// | `VarMessageDecoder` | `VarMessage` | [`VarRequest`] |
/// | `VarReplyDecoder` | `i32` | `i32` |
///
/// The rows that allocate (`Vec`, [`VarRequest`]) need feature `alloc`.
///
/// ```
/// # #[cfg(feature = "alloc")] {
/// use urscript_socket::{adapters::OwnedDecoder, line::LineDecoder, Decode};
/// let mut lines = LineDecoder::new();
/// let line: Vec<u8> = LineDecoder::to_owned_item(lines.decode(b"hi\n").unwrap().item().unwrap());
/// assert_eq!(line, b"hi");
/// # }
/// ```
pub trait OwnedDecoder: Decode {
    /// The message, owning its data.
    type Owned;
    /// Copies a decoded message out of the buffer.
    fn to_owned_item(item: Self::Item<'_>) -> Self::Owned;
}

#[cfg(feature = "alloc")]
macro_rules! owned_bytes {
    ($($dec:ty),*) => {$(
        impl OwnedDecoder for $dec {
            type Owned = Vec<u8>;
            #[inline]
            fn to_owned_item(item: &[u8]) -> Vec<u8> {
                item.to_vec()
            }
        }
    )*};
}
#[cfg(feature = "alloc")]
owned_bytes!(
    LineDecoder,
    StxEtxDecoder,
    DelimitedDecoder,
    ReadStringDecoder,
    ByteListDecoder
);

#[cfg(feature = "alloc")]
impl OwnedDecoder for Int32Decoder {
    type Owned = Vec<i32>;
    fn to_owned_item(item: Int32Values<'_>) -> Vec<i32> {
        item.iter().collect()
    }
}

impl OwnedDecoder for Int32Stream {
    type Owned = i32;
    fn to_owned_item(item: i32) -> i32 {
        item
    }
}

impl OwnedDecoder for ByteStream {
    type Owned = u8;
    fn to_owned_item(item: u8) -> u8 {
        item
    }
}

impl OwnedDecoder for FloatTupleDecoder {
    type Owned = FloatTuple;
    fn to_owned_item(item: FloatTuple) -> FloatTuple {
        item
    }
}

impl OwnedDecoder for VarReplyDecoder {
    type Owned = i32;
    fn to_owned_item(item: i32) -> i32 {
        item
    }
}

#[cfg(feature = "alloc")]
impl OwnedDecoder for VarMessageDecoder {
    type Owned = VarRequest;
    fn to_owned_item(item: VarMessage<'_>) -> VarRequest {
        VarRequest::from(item)
    }
}

#[cfg(feature = "alloc")]
/// An owned `SET`/`GET` message from the robot: [`VarMessage`] without the borrow.
///
/// ```
/// use urscript_socket::{adapters::VarRequest, var::VarMessage};
/// let r = VarRequest::from(VarMessage::Get { name: "POS_X" });
/// assert_eq!(r, VarRequest::Get { name: "POS_X".into() });
/// assert_eq!(r.name(), "POS_X");
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum VarRequest {
    /// `socket_set_var(name, value)`: no reply expected.
    Set {
        /// Variable name.
        name: String,
        /// New value.
        value: i32,
    },
    /// `socket_get_var(name)`: answer `name value\n` within 2 s.
    Get {
        /// Variable name.
        name: String,
    },
}

#[cfg(feature = "alloc")]
impl VarRequest {
    /// The variable's name.
    ///
    /// ```
    /// # use urscript_socket::adapters::VarRequest;
    /// assert_eq!(VarRequest::Set { name: "A".into(), value: 1 }.name(), "A");
    /// ```
    pub fn name(&self) -> &str {
        match self {
            VarRequest::Set { name, .. } | VarRequest::Get { name } => name,
        }
    }

    /// The borrowed form, e.g. to compare with a freshly decoded message.
    ///
    /// ```
    /// # use urscript_socket::{adapters::VarRequest, var::VarMessage};
    /// let r = VarRequest::Set { name: "A".into(), value: 1 };
    /// assert_eq!(r.as_message(), VarMessage::Set { name: "A", value: 1 });
    /// ```
    pub fn as_message(&self) -> VarMessage<'_> {
        match self {
            VarRequest::Set { name, value } => VarMessage::Set {
                name,
                value: *value,
            },
            VarRequest::Get { name } => VarMessage::Get { name },
        }
    }
}

#[cfg(feature = "alloc")]
impl From<VarMessage<'_>> for VarRequest {
    fn from(m: VarMessage<'_>) -> Self {
        match m {
            VarMessage::Set { name, value } => VarRequest::Set {
                name: String::from(name),
                value,
            },
            VarMessage::Get { name } => VarRequest::Get {
                name: String::from(name),
            },
        }
    }
}

/// The registry's run-time decoder: any format, owned [`OwnedMessage`](crate::format::OwnedMessage) items.
#[cfg(feature = "alloc")]
impl OwnedDecoder for crate::format::AnyDecoder {
    type Owned = crate::format::OwnedMessage;
    fn to_owned_item(item: crate::format::Message<'_>) -> crate::format::OwnedMessage {
        crate::format::OwnedMessage::from(&item)
    }
}
