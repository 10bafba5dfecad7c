//! STX/ETX framing: `socket_send_byte(2)`, `socket_send_string(s)`, `socket_send_byte(3)`
//! puts `02 <s> 03` on the wire, the most common way robot programs frame a message.

use crate::{DecodeError, Decoder, EncodeError, ErrorKind, Sink, Status};

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
pub fn encode_stx_etx<S: Sink + ?Sized>(
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
///   [`UnexpectedByte`](ErrorKind::UnexpectedByte) error at the run's first byte, and
///   dropped up to the next STX.
/// * An STX inside a frame means the frame was cut short: an error at that STX, and a
///   new frame starts there.
/// * Bound: a payload longer than `max_len` ([`DEFAULT_MAX_FRAME_LEN`]) is a
///   [`TooLong`](ErrorKind::TooLong) error; the rest is discarded through the next ETX.
///
/// ```
/// use urscript_socket::stx_etx::StxEtxDecoder;
/// let mut dec = StxEtxDecoder::new();
/// let got = dec.decode(b"\x02hi\x03\x02next").unwrap();
/// assert_eq!(got.item(), Some(&b"hi"[..]));
/// assert_eq!(got.consumed(), 4);
/// ```
#[derive(Debug, Clone)]
pub struct StxEtxDecoder {
    max_len: usize,
    state: State,
    /// While `InFrame`: bytes of `buf` (STX at index 0) known to hold no STX/ETX after the
    /// STX. If `decode` saw `02 h i`, it holds 3.
    scanned: usize,
    pos: u64,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum State {
    /// Waiting for STX; the next non-STX byte is reported.
    Idle,
    /// Dropping a run of bytes outside frames that was already reported.
    InNoise,
    /// STX at `buf[0]`, looking for ETX.
    InFrame,
    /// Dropping the rest of an over-long frame through its ETX.
    Discarding,
}

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

    /// A decoder whose payloads hold at most `max_len` bytes.
    ///
    /// ```
    /// # use urscript_socket::stx_etx::StxEtxDecoder;
    /// assert!(StxEtxDecoder::with_max_len(1).decode(b"\x02ab\x03").is_err());
    /// ```
    pub fn with_max_len(max_len: usize) -> Self {
        StxEtxDecoder {
            max_len,
            state: State::Idle,
            scanned: 0,
            pos: 0,
        }
    }

    /// Absolute stream offset of the next byte to decode.
    ///
    /// ```
    /// # use urscript_socket::stx_etx::StxEtxDecoder;
    /// let mut d = StxEtxDecoder::new();
    /// d.decode(b"\x02\x03").unwrap();
    /// assert_eq!(d.position(), 2);
    /// ```
    pub fn position(&self) -> u64 {
        self.pos
    }

    /// The next frame's payload.
    ///
    /// ```
    /// # use urscript_socket::stx_etx::StxEtxDecoder;
    /// let mut d = StxEtxDecoder::new();
    /// let e = d.decode(b"junk\x02ok\x03").unwrap_err();
    /// assert_eq!((e.offset(), e.skip()), (0, 4));
    /// assert_eq!(d.decode(b"\x02ok\x03").unwrap().item(), Some(&b"ok"[..]));
    /// ```
    pub fn decode<'a>(&mut self, buf: &'a [u8]) -> Result<Status<&'a [u8]>, DecodeError> {
        let mut lead = 0;
        loop {
            let rest = &buf[lead..];
            match self.state {
                State::Discarding => match memchr::memchr(ETX, rest) {
                    Some(i) => {
                        lead += i + 1;
                        self.state = State::Idle;
                    }
                    None => return Ok(self.partial(buf.len())),
                },
                State::InNoise => match memchr::memchr(STX, rest) {
                    Some(i) => {
                        lead += i;
                        self.state = State::Idle;
                    }
                    None => return Ok(self.partial(buf.len())),
                },
                State::Idle => match rest.first() {
                    None => return Ok(self.partial(lead)),
                    Some(&STX) => {
                        self.state = State::InFrame;
                        self.scanned = 1;
                    }
                    Some(&found) => {
                        let at = self.pos + lead as u64;
                        let skip = match memchr::memchr(STX, rest) {
                            Some(i) => lead + i,
                            None => {
                                self.state = State::InNoise;
                                buf.len()
                            }
                        };
                        return Err(self.error(
                            ErrorKind::UnexpectedByte {
                                found,
                                expected: "STX (0x02) starting a frame",
                            },
                            at,
                            skip,
                        ));
                    }
                },
                State::InFrame => {
                    // The frame starts at rest[0] (its STX).
                    let frame = rest;
                    let limit = frame.len().min(self.max_len + 2);
                    let from = self.scanned.min(limit);
                    return match memchr::memchr2(STX, ETX, &frame[from..limit]) {
                        Some(i) if frame[from + i] == ETX => {
                            let end = from + i;
                            self.state = State::Idle;
                            self.scanned = 0;
                            let consumed = lead + end + 1;
                            self.pos += consumed as u64;
                            Ok(Status::Complete {
                                item: &frame[1..end],
                                consumed,
                            })
                        }
                        Some(i) => {
                            // A new STX before the ETX: the open frame was cut short.
                            let at = self.pos + (lead + from + i) as u64;
                            self.state = State::Idle;
                            self.scanned = 0;
                            Err(self.error(
                                ErrorKind::UnexpectedByte {
                                    found: STX,
                                    expected: "ETX (0x03) ending the open frame",
                                },
                                at,
                                lead + from + i,
                            ))
                        }
                        None if frame.len() >= self.max_len + 2 => {
                            let at = self.pos + (lead + self.max_len + 1) as u64;
                            self.state = State::Discarding;
                            self.scanned = 0;
                            Err(self.error(
                                ErrorKind::TooLong {
                                    limit: self.max_len,
                                },
                                at,
                                lead + self.max_len + 1,
                            ))
                        }
                        None => {
                            // Keep the frame, moved to the front of the caller's buffer.
                            self.scanned = limit;
                            Ok(self.partial(lead))
                        }
                    };
                }
            }
        }
    }

    /// At end of input: an open frame is [`Truncated`](ErrorKind::Truncated).
    ///
    /// ```
    /// # use urscript_socket::stx_etx::StxEtxDecoder;
    /// assert!(StxEtxDecoder::new().decode_eof(b"\x02open").is_err());
    /// ```
    pub fn decode_eof<'a>(
        &mut self,
        buf: &'a [u8],
    ) -> Result<Option<(&'a [u8], usize)>, DecodeError> {
        let r = match self.decode(buf) {
            Ok(Status::Complete { item, consumed }) => Ok(Some((item, consumed))),
            Ok(Status::Partial { consumed }) if consumed == buf.len() => Ok(None),
            Ok(Status::Partial { consumed }) => {
                let at = self.pos;
                self.pos += (buf.len() - consumed) as u64;
                Err(DecodeError::new(ErrorKind::Truncated, at, buf.len()))
            }
            Err(e) => Err(e),
        };
        self.state = State::Idle;
        self.scanned = 0;
        r
    }

    fn partial(&mut self, consumed: usize) -> Status<&'static [u8]> {
        self.pos += consumed as u64;
        Status::Partial { consumed }
    }

    fn error(&mut self, kind: ErrorKind, at: u64, skip: usize) -> DecodeError {
        self.pos += skip as u64;
        DecodeError::new(kind, at, skip)
    }
}

impl Decoder for StxEtxDecoder {
    type Item<'buf> = &'buf [u8];
    #[inline]
    fn decode<'buf>(&mut self, buf: &'buf [u8]) -> Result<Status<&'buf [u8]>, DecodeError> {
        StxEtxDecoder::decode(self, buf)
    }
    fn decode_eof<'buf>(
        &mut self,
        buf: &'buf [u8],
    ) -> Result<Option<(&'buf [u8], usize)>, DecodeError> {
        StxEtxDecoder::decode_eof(self, buf)
    }
    fn position(&self) -> u64 {
        self.pos
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
                consumed: 5
            }
        );
    }
}
