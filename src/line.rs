//! Lines: `socket_send_line` on the robot (`<s>\n`, LF only) and `socket_read_line()`
//! reading a server's `\n` or `\r\n` terminated reply.

use crate::framer::{Framer, Pattern};
use crate::{DecodeError, Decoder, EncodeError, Sink, Status};

/// Default bound on a line's content, in bytes (CR included, LF excluded). A robot's
/// `to_str` text is at most 1023 characters; 4 KiB leaves room without inviting abuse.
pub const DEFAULT_MAX_LINE_LEN: usize = 4096;

/// Writes `text` and a LF: what `socket_send_line(text)` sends, or a line for
/// `socket_read_line()`. A LF inside `text` would split the line and is refused.
///
/// ```
/// use urscript_socket::line::encode_line;
/// let mut out = Vec::new();
/// encode_line(b"hello", &mut out).unwrap();
/// assert_eq!(out, b"hello\n");
/// assert!(encode_line(b"a\nb", &mut out).is_err());
/// ```
pub fn encode_line<S: Sink + ?Sized>(text: &[u8], sink: &mut S) -> Result<usize, EncodeError> {
    if let Some(index) = memchr::memchr(b'\n', text) {
        return Err(EncodeError::ForbiddenByte { byte: b'\n', index });
    }
    sink.put(text)?;
    sink.put(b"\n")?;
    Ok(text.len() + 1)
}

/// Decoder of LF-terminated lines. The item is the line without its LF and without a CR
/// right before the LF (as `socket_read_line` returns it), borrowed from the buffer.
///
/// Linear: a memchr scan that resumes where the previous call stopped. Bound: content
/// longer than `max_len` ([`DEFAULT_MAX_LINE_LEN`]) is a
/// [`TooLong`](crate::ErrorKind::TooLong) error at the first byte past the bound; the rest
/// of that line is then discarded and decoding goes on after its LF. An unbounded line
/// decoder lets any peer exhaust memory, hence no such option.
///
/// ```
/// use urscript_socket::line::LineDecoder;
/// let mut lines = LineDecoder::new();
/// let got = lines.decode(b"reply from the server:\r\n").unwrap().item();
/// assert_eq!(got, Some(&b"reply from the server:"[..]));
/// ```
#[derive(Debug, Clone)]
pub struct LineDecoder {
    framer: Framer,
}

impl Default for LineDecoder {
    fn default() -> Self {
        Self::new()
    }
}

impl LineDecoder {
    /// A decoder with the default bound.
    ///
    /// ```
    /// # use urscript_socket::line::{LineDecoder, DEFAULT_MAX_LINE_LEN};
    /// assert_eq!(LineDecoder::new().max_len(), DEFAULT_MAX_LINE_LEN);
    /// ```
    pub fn new() -> Self {
        Self::with_max_len(DEFAULT_MAX_LINE_LEN)
    }

    /// A decoder whose lines hold at most `max_len` bytes before the LF.
    ///
    /// ```
    /// # use urscript_socket::line::LineDecoder;
    /// let mut d = LineDecoder::with_max_len(3);
    /// assert!(d.decode(b"abcd\n").is_err());
    /// ```
    pub fn with_max_len(max_len: usize) -> Self {
        // A one-byte pattern always fits.
        let lf = match Pattern::new(b"\n") {
            Ok(p) => p,
            Err(_) => Pattern::EMPTY,
        };
        LineDecoder {
            framer: Framer::new(lf, max_len),
        }
    }

    /// The bound on a line's content.
    ///
    /// ```
    /// # use urscript_socket::line::LineDecoder;
    /// assert_eq!(LineDecoder::with_max_len(9).max_len(), 9);
    /// ```
    pub fn max_len(&self) -> usize {
        self.framer.max_len()
    }

    /// Absolute stream offset of the next byte to decode.
    ///
    /// ```
    /// # use urscript_socket::line::LineDecoder;
    /// let mut d = LineDecoder::new();
    /// d.decode(b"ab\n").unwrap();
    /// assert_eq!(d.position(), 3);
    /// ```
    pub fn position(&self) -> u64 {
        self.framer.pos
    }

    /// The next complete line.
    ///
    /// ```
    /// # use urscript_socket::{line::LineDecoder, Status};
    /// let mut d = LineDecoder::new();
    /// assert_eq!(d.decode(b"a\nb").unwrap(), Status::Complete { item: &b"a"[..], consumed: 2 });
    /// assert_eq!(d.decode(b"b").unwrap(), Status::Partial { consumed: 0 });
    /// ```
    #[inline]
    pub fn decode<'a>(&mut self, buf: &'a [u8]) -> Result<Status<&'a [u8]>, DecodeError> {
        Ok(match self.framer.next(buf)? {
            Status::Complete { item, consumed } => Status::Complete {
                item: strip_cr(item),
                consumed,
            },
            Status::Partial { consumed } => Status::Partial { consumed },
        })
    }

    /// At end of input: bytes after the last LF are a
    /// [`Truncated`](crate::ErrorKind::Truncated) error (a robot never sends a line
    /// without its LF).
    ///
    /// ```
    /// # use urscript_socket::line::LineDecoder;
    /// let mut d = LineDecoder::new();
    /// assert_eq!(d.decode_eof(b"a\n").unwrap(), Some((&b"a"[..], 2)));
    /// assert!(d.decode_eof(b"tail").is_err());
    /// ```
    pub fn decode_eof<'a>(
        &mut self,
        buf: &'a [u8],
    ) -> Result<Option<(&'a [u8], usize)>, DecodeError> {
        let r = match self.decode(buf) {
            Ok(Status::Complete { item, consumed }) => Ok(Some((item, consumed))),
            Ok(Status::Partial { consumed }) if consumed == buf.len() => Ok(None),
            Ok(Status::Partial { consumed }) => {
                let mut pos = self.framer.pos;
                let r = crate::status::truncated(&mut pos, &buf[consumed..])
                    .map_err(|e| DecodeError::new(e.kind(), e.offset(), buf.len()));
                self.framer.pos = pos;
                r
            }
            Err(e) => Err(e),
        };
        self.framer.reset();
        r
    }
}

#[inline]
fn strip_cr(line: &[u8]) -> &[u8] {
    match line {
        [rest @ .., b'\r'] => rest,
        _ => line,
    }
}

impl Decoder for LineDecoder {
    type Item<'buf> = &'buf [u8];
    #[inline]
    fn decode<'buf>(&mut self, buf: &'buf [u8]) -> Result<Status<&'buf [u8]>, DecodeError> {
        LineDecoder::decode(self, buf)
    }
    fn decode_eof<'buf>(
        &mut self,
        buf: &'buf [u8],
    ) -> Result<Option<(&'buf [u8], usize)>, DecodeError> {
        LineDecoder::decode_eof(self, buf)
    }
    fn position(&self) -> u64 {
        self.framer.pos
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ErrorKind;

    #[test]
    fn bound_is_exact_and_recovers() {
        let mut d = LineDecoder::with_max_len(3);
        assert_eq!(d.decode(b"abc\n").unwrap().item(), Some(&b"abc"[..]));
        let e = d.decode(b"abcd").unwrap_err();
        assert_eq!(
            (e.kind(), e.offset(), e.skip()),
            (ErrorKind::TooLong { limit: 3 }, 7, 3)
        );
        assert_eq!(d.decode(b"d").unwrap(), Status::Partial { consumed: 1 });
        assert_eq!(
            d.decode(b"ef\nok\n").unwrap(),
            Status::Complete {
                item: &b"ok"[..],
                consumed: 6
            }
        );
    }

    #[test]
    fn only_one_cr_dropped() {
        let mut d = LineDecoder::new();
        assert_eq!(d.decode(b"a\r\r\n").unwrap().item(), Some(&b"a\r"[..]));
        assert_eq!(d.decode(b"\n").unwrap().item(), Some(&b""[..]));
    }
}
