//! STX/ETX framing: `socket_send_byte(2)`, `socket_send_string(s)`, `socket_send_byte(3)`
//! puts `02 <s> 03` on the wire, the most common way robot programs frame a message.

use crate::framer::{content_as_is, FrameDecoder, Framer, Noise};
use crate::{ByteSink, EncodeError};

/// Start of text, `socket_send_byte(2)`.
pub const STX: u8 = 2;
/// End of text, `socket_send_byte(3)`.
pub const ETX: u8 = 3;
/// Default bound on one frame's payload, in bytes.
pub const DEFAULT_MAX_FRAME_LEN: usize = 4096;

/// Writes `02 <payload> 03`. A payload holding STX or ETX would break the framing and
/// is refused with its position.
///
/// ```
/// use urscript_socket::stx_etx::encode_stx_etx;
/// let mut out = Vec::new();
/// encode_stx_etx(b"hi", &mut out).unwrap();
/// assert_eq!(out, [0x02, 0x68, 0x69, 0x03]);
/// ```
pub fn encode_stx_etx<S: ByteSink + ?Sized>(
    payload: &[u8],
    sink: &mut S,
) -> Result<usize, EncodeError> {
    if let Some(index) = memchr::memchr2(STX, ETX, payload) {
        return Err(EncodeError::ForbiddenByte {
            byte: payload[index],
            index,
        });
    }
    sink.put(&[STX])?;
    sink.put(payload)?;
    sink.put(&[ETX])?;
    Ok(payload.len() + 2)
}

/// Server-side decoder of STX/ETX frames; the item is the payload, borrowed.
///
/// * Bytes outside a frame are reported once per run, as an
///   [`UnexpectedByte`](crate::ErrorKind::UnexpectedByte) error at the run's first byte, and
///   dropped up to the next STX.
/// * An STX inside a frame means the frame was cut short: an error at that STX, and a
///   new frame starts there.
/// * Bound: a payload longer than `max_len` ([`DEFAULT_MAX_FRAME_LEN`]) is a
///   [`TooLong`](crate::ErrorKind::TooLong) error; the rest is discarded through the next ETX.
/// * At end of input an open frame is [`Truncated`](crate::ErrorKind::Truncated).
///
/// ```
/// use urscript_socket::stx_etx::StxEtxDecoder;
/// let mut dec = StxEtxDecoder::new();
/// let got = dec.decode(b"\x02hi\x03\x02next").unwrap();
/// assert_eq!(got.item(), Some(&b"hi"[..]));
/// assert_eq!(got.consumed(), 4);
/// let e = dec.decode(b"junk\x02ok\x03").unwrap_err();
/// assert_eq!((e.offset(), e.skip()), (4, 4));
/// assert!(StxEtxDecoder::new().decode_eof(b"\x02open").is_err());
/// ```
pub type StxEtxDecoder = FrameDecoder<StxEtx>;

content_as_is!(
    /// The parse step of [`StxEtxDecoder`]: the payload as it is.
    StxEtx,
    Bracketed
);

impl Default for StxEtxDecoder {
    fn default() -> Self {
        Self::new()
    }
}

impl StxEtxDecoder {
    /// A decoder with the default bound.
    ///
    /// ```
    /// # use urscript_socket::stx_etx::StxEtxDecoder;
    /// let _ = StxEtxDecoder::new();
    /// ```
    pub fn new() -> Self {
        Self::with_max_len(DEFAULT_MAX_FRAME_LEN)
    }

    /// A decoder whose payloads hold at most `max_len` bytes (clamped to
    /// [`MAX_BOUND`](crate::MAX_BOUND)).
    ///
    /// ```
    /// # use urscript_socket::stx_etx::StxEtxDecoder;
    /// assert!(StxEtxDecoder::with_max_len(1).decode(b"\x02ab\x03").is_err());
    /// assert_eq!(StxEtxDecoder::with_max_len(usize::MAX).max_len(), urscript_socket::MAX_BOUND);
    /// ```
    pub fn with_max_len(max_len: usize) -> Self {
        let framer = Framer::bracketed(
            STX,
            ETX,
            Noise::Report("STX (0x02) starting a frame"),
            Some("ETX (0x03) ending the open frame"),
            max_len,
            false,
        );
        FrameDecoder::from_parts(framer, StxEtx)
    }

    /// The bound on a payload.
    ///
    /// ```
    /// # use urscript_socket::stx_etx::StxEtxDecoder;
    /// assert_eq!(StxEtxDecoder::with_max_len(9).max_len(), 9);
    /// ```
    pub fn max_len(&self) -> usize {
        self.framer.bound()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{ErrorKind, Status};

    #[test]
    fn cut_frame_then_next() {
        let mut d = StxEtxDecoder::new();
        let e = d.decode(b"\x02ab\x02cd\x03").unwrap_err();
        assert_eq!((e.offset(), e.skip()), (3, 3));
        assert_eq!(d.decode(b"\x02cd\x03").unwrap().item(), Some(&b"cd"[..]));
    }

    #[test]
    fn bound() {
        let mut d = StxEtxDecoder::with_max_len(2);
        assert_eq!(d.decode(b"\x02ab\x03").unwrap().item(), Some(&b"ab"[..]));
        let e = d.decode(b"\x02abc").unwrap_err();
        assert_eq!(
            (e.kind(), e.offset(), e.skip()),
            (ErrorKind::TooLong { limit: 2 }, 7, 3)
        );
        assert_eq!(
            d.decode(b"c\x03\x02z\x03").unwrap(),
            Status::Complete {
                item: &b"z"[..],
                consumed: 5,
                at: 10
            }
        );
    }
}
