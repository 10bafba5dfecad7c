//! Lines: `socket_send_line` on the robot (`<s>\n`, LF only) and `socket_read_line()`
//! reading a server's `\n` or `\r\n` terminated reply.

use crate::framer::{AtEof, FrameDecoder, Framer, Parse, Pattern, ShapeKind};
use crate::{ByteSink, EncodeError, ErrorKind};

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
pub fn encode_line<S: ByteSink + ?Sized>(text: &[u8], sink: &mut S) -> Result<usize, EncodeError> {
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
/// decoder lets any peer exhaust memory, hence no such option. At end of input, bytes after
/// the last LF are a [`Truncated`](crate::ErrorKind::Truncated) error (a robot never sends
/// a line without its LF).
///
/// ```
/// use urscript_socket::line::LineDecoder;
/// let mut lines = LineDecoder::new();
/// let got = lines.decode(b"reply from the server:\r\n").unwrap().item();
/// assert_eq!(got, Some(&b"reply from the server:"[..]));
/// assert!(lines.decode_eof(b"tail").is_err());
/// ```
pub type LineDecoder = FrameDecoder<Line>;

/// The parse step of [`LineDecoder`]: a line's content minus one trailing CR.
#[derive(Debug, Clone, Copy, Default)]
pub struct Line;

impl Parse for Line {
    type Output<'a> = &'a [u8];
    const SHAPE: ShapeKind = ShapeKind::Delimited;
    #[inline(always)]
    fn parse<'a>(&self, line: &'a [u8]) -> Result<&'a [u8], (ErrorKind, usize)> {
        Ok(strip_cr(line))
    }
}

/// The framer of every LF-terminated format (lines, `SET`/`GET`, replies, value lines):
/// content of at most `max_len` bytes before a LF; cut off at end of input = truncated.
pub(crate) fn lf_framer(max_len: usize) -> Framer {
    Framer::delimited(Pattern::byte(b'\n'), max_len, AtEof::Truncated)
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

    /// A decoder whose lines hold at most `max_len` bytes before the LF. A bound above
    /// [`MAX_BOUND`](crate::MAX_BOUND) (`usize::MAX`, say) is clamped to it: no buffer
    /// holds more.
    ///
    /// ```
    /// # use urscript_socket::line::LineDecoder;
    /// let mut d = LineDecoder::with_max_len(3);
    /// assert!(d.decode(b"abcd\n").is_err());
    /// assert_eq!(LineDecoder::with_max_len(usize::MAX).max_len(), urscript_socket::MAX_BOUND);
    /// ```
    pub fn with_max_len(max_len: usize) -> Self {
        FrameDecoder::from_parts(lf_framer(max_len), Line)
    }

    /// The bound on a line's content.
    ///
    /// ```
    /// # use urscript_socket::line::LineDecoder;
    /// assert_eq!(LineDecoder::with_max_len(9).max_len(), 9);
    /// ```
    pub fn max_len(&self) -> usize {
        self.framer.bound()
    }
}

/// A line's content without one CR right before its LF.
#[inline(always)]
pub(crate) fn strip_cr(line: &[u8]) -> &[u8] {
    match line {
        [rest @ .., b'\r'] => rest,
        _ => line,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Status;

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
                consumed: 6,
                at: 11
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
