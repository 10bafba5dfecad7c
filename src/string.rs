//! Strings: `socket_send_string` (bytes, no terminator), `socket_read_string(prefix,
//! suffix, interpret_escape)` with its 1024-byte limit, and, on the server side, strings
//! split on a delimiter of the user's choice.
//!
//! * [`ReadStringDecoder`]: the robot's `socket_read_string` rules (spec section 3).
//! * [`DelimitedDecoder`]: a server splitting the robot's unframed `socket_send_string`
//!   traffic on a delimiter, with [`flush`](DelimitedDecoder::flush) for idle-time framing.
//! * [`encode_string`], [`encode_framed_string`]: what either side writes.

pub use crate::framer::MAX_PATTERN_LEN;
use crate::framer::{content_as_is, AtEof, FrameDecoder, Framer, Pattern, Shape};
use crate::{ArgumentError, ByteSink, EncodeError};

/// The most bytes one `socket_read_string` returns, terminators included (5.x manual): the
/// framer's read-string window.
pub const READ_STRING_LIMIT: usize = crate::framer::WINDOW;

/// Default bound on one delimited message's content, in bytes.
pub const DEFAULT_MAX_MESSAGE_LEN: usize = 4096;

/// Writes `text` unchanged, with no terminator: what `socket_send_string(text)` sends.
///
/// ```
/// use urscript_socket::string::encode_string;
/// let mut out = Vec::new();
/// encode_string(b"hi", &mut out).unwrap();
/// assert_eq!(out, b"hi");
/// ```
pub fn encode_string<S: ByteSink + ?Sized>(
    text: &[u8],
    sink: &mut S,
) -> Result<usize, EncodeError> {
    sink.put(text)?;
    Ok(text.len())
}

/// Writes `prefix`, `text`, `suffix`: a message for
/// `socket_read_string(prefix=.., suffix=..)`. Refused if the robot would see the suffix
/// before the end of `text` (inside it, or begun by its last bytes), reporting where.
///
/// ```
/// use urscript_socket::string::encode_framed_string;
/// let mut out = Vec::new();
/// encode_framed_string(b">", b"hello", b"<", &mut out).unwrap();
/// assert_eq!(out, b">hello<");
/// assert!(encode_framed_string(b">", b"a<b", b"<", &mut out).is_err());
/// // The text's end and the suffix would read as an earlier suffix: refused too.
/// assert!(encode_framed_string(b"!", b"{", b"{{", &mut out).is_err());
/// ```
pub fn encode_framed_string<S: ByteSink + ?Sized>(
    prefix: &[u8],
    text: &[u8],
    suffix: &[u8],
    sink: &mut S,
) -> Result<usize, EncodeError> {
    if let Some(index) = early_suffix(text, suffix) {
        return Err(EncodeError::ForbiddenByte {
            byte: text[index],
            index,
        });
    }
    sink.put(prefix)?;
    sink.put(text)?;
    sink.put(suffix)?;
    Ok(prefix.len() + text.len() + suffix.len())
}

/// Where the reader would see `suffix` start before the end of `text`: inside it, or
/// straddling its end (`text = "{"`, `suffix = "{{"` reads as an empty string followed
/// by `{`). `None` if `text` then `suffix` reads back as `text`.
fn early_suffix(text: &[u8], suffix: &[u8]) -> Option<usize> {
    if suffix.is_empty() {
        return None;
    }
    if let Some(index) = memchr::memmem::find(text, suffix) {
        return Some(index);
    }
    // An occurrence that begins in the last `suffix.len() - 1` bytes of the text.
    let from = text.len().saturating_sub(suffix.len() - 1);
    (from..text.len()).find(|&i| {
        let k = text.len() - i;
        // `text[i..] + suffix` starts with the suffix.
        suffix.starts_with(&text[i..]) && suffix[k..] == suffix[..suffix.len() - k]
    })
}

/// Turns a prefix or suffix argument into the bytes the controller matches: leading
/// spaces dropped, and with `interpret_escape` the two-character escapes `\n`, `\t`,
/// `\r` made into LF, TAB, CR (other backslashes stay as they are).
///
/// ```
/// use urscript_socket::string::controller_pattern;
/// let mut out = [0u8; 64];
/// let n = controller_pattern(br"  \r", true, &mut out).unwrap();
/// assert_eq!(&out[..n], b"\r");
/// ```
pub fn controller_pattern(
    arg: &[u8],
    interpret_escape: bool,
    out: &mut [u8; MAX_PATTERN_LEN],
) -> Result<usize, ArgumentError> {
    let start = arg.iter().position(|&b| b != b' ').unwrap_or(arg.len());
    let arg = &arg[start..];
    let mut n = 0;
    let mut i = 0;
    while i < arg.len() {
        let mut b = arg[i];
        if interpret_escape && b == b'\\' && i + 1 < arg.len() {
            let esc = match arg[i + 1] {
                b'n' => Some(b'\n'),
                b't' => Some(b'\t'),
                b'r' => Some(b'\r'),
                _ => None,
            };
            if let Some(e) = esc {
                b = e;
                i += 1;
            }
        }
        if n == MAX_PATTERN_LEN {
            return Err(ArgumentError::PatternTooLong {
                limit: MAX_PATTERN_LEN,
            });
        }
        out[n] = b;
        n += 1;
        i += 1;
    }
    Ok(n)
}

/// The robot's `socket_read_string(prefix, suffix, interpret_escape)`, as a decoder.
///
/// Rules (spec sections 3 and 6):
/// * no prefix, no suffix: everything buffered (at least one byte), up to 1024 bytes;
/// * prefix: everything up to and including the first prefix is dropped; without a
///   suffix the read completes once a byte follows the prefix;
/// * suffix: the result ends before the suffix, which is consumed; bytes after it stay;
/// * the window is [`READ_STRING_LIMIT`] bytes from the start of the prefix (or of the
///   buffer): if the suffix is not within it, the window's content is returned and the
///   rest stays buffered;
/// * until complete nothing is consumed, so a timeout leaves the buffer unchanged; end of
///   input is the robot's timeout: `Ok(None)` (the read returns `""`), nothing consumed.
///
/// Linear: the prefix and suffix searches resume where they stopped.
///
/// ```
/// use urscript_socket::string::ReadStringDecoder;
/// let mut read = ReadStringDecoder::new(b">", b"<", false).unwrap();
/// let buf = b">hello<>world<";
/// let first = read.decode(buf).unwrap();
/// assert_eq!(first.consumed(), 7);
/// assert_eq!(first.item(), Some(&b"hello"[..]));
/// assert_eq!(read.decode(&buf[7..]).unwrap().item(), Some(&b"world"[..]));
/// ```
pub type ReadStringDecoder = FrameDecoder<ReadString>;

content_as_is!(
    /// The parse step of [`ReadStringDecoder`]: the content as it is.
    ReadString,
    Window
);

impl ReadStringDecoder {
    /// A read with the given URScript arguments (leading spaces dropped, escapes
    /// interpreted if asked). Each pattern may hold at most 64 bytes.
    ///
    /// ```
    /// # use urscript_socket::string::ReadStringDecoder;
    /// let mut read = ReadStringDecoder::new(b"", br"\r", true).unwrap();
    /// assert_eq!(read.decode(b"OK,1\rNEXT\r").unwrap().item(), Some(&b"OK,1"[..]));
    /// ```
    pub fn new(
        prefix: &[u8],
        suffix: &[u8],
        interpret_escape: bool,
    ) -> Result<Self, ArgumentError> {
        let mut tmp = [0u8; MAX_PATTERN_LEN];
        let n = controller_pattern(prefix, interpret_escape, &mut tmp)?;
        let prefix = Pattern::new(&tmp[..n])?;
        let n = controller_pattern(suffix, interpret_escape, &mut tmp)?;
        let suffix = Pattern::new(&tmp[..n])?;
        Ok(FrameDecoder::from_parts(
            Framer::window(prefix, suffix),
            ReadString,
        ))
    }

    /// Forgets the search progress (for a read that timed out: the next read starts
    /// over on the unchanged buffer).
    ///
    /// ```
    /// # use urscript_socket::string::ReadStringDecoder;
    /// let mut r = ReadStringDecoder::new(b">", b"<", false).unwrap();
    /// r.decode(b">hel").unwrap();
    /// r.reset();
    /// assert_eq!(r.decode(b">hello<").unwrap().item(), Some(&b"hello"[..]));
    /// ```
    pub fn reset(&mut self) {
        self.framer.reset();
    }

    /// Drops what can never begin the prefix from a full buffer `buf` that holds none, as
    /// the controller does; how many bytes of `buf` to drop (see the framer's
    /// `drop_before_prefix`).
    #[cfg(feature = "alloc")]
    pub(crate) fn drop_before_prefix(&mut self, buf: &[u8]) -> usize {
        self.framer.drop_before_prefix(buf)
    }
}

/// Server-side decoder that splits a byte stream on a delimiter of the user's choice
/// (1 to 64 bytes): the way to frame a robot's bare `socket_send_string` traffic. The
/// item is the message without its delimiter, borrowed from the buffer.
///
/// For peers that mark the end of a message only by going quiet,
/// [`flush`](DelimitedDecoder::flush) returns what is buffered as one message; end of
/// input does the same (the bytes after the last delimiter are the last message).
///
/// Bound: content longer than `max_len` ([`DEFAULT_MAX_MESSAGE_LEN`]) is a
/// [`TooLong`](crate::ErrorKind::TooLong) error; the rest of it is discarded through the
/// next delimiter.
///
/// ```
/// use urscript_socket::string::DelimitedDecoder;
/// let mut dec = DelimitedDecoder::new(b"\r\n").unwrap();
/// let buf = b"OK\r\nNE";
/// let s = dec.decode(buf).unwrap();
/// assert_eq!(s.item(), Some(&b"OK"[..]));
/// assert_eq!(dec.flush(&buf[4..]), Some((&b"NE"[..], 2)));
/// ```
pub type DelimitedDecoder = FrameDecoder<Delimited>;

content_as_is!(
    /// The parse step of [`DelimitedDecoder`]: the message as it is.
    Delimited,
    Delimited
);

impl DelimitedDecoder {
    /// A decoder splitting on `delimiter`, with the default bound.
    ///
    /// ```
    /// # use urscript_socket::string::DelimitedDecoder;
    /// assert!(DelimitedDecoder::new(b"").is_err());
    /// assert!(DelimitedDecoder::new(b";").is_ok());
    /// ```
    pub fn new(delimiter: &[u8]) -> Result<Self, ArgumentError> {
        Self::with_max_len(delimiter, DEFAULT_MAX_MESSAGE_LEN)
    }

    /// A decoder splitting on `delimiter` whose messages hold at most `max_len` bytes
    /// (clamped to [`MAX_BOUND`](crate::MAX_BOUND)).
    ///
    /// ```
    /// # use urscript_socket::string::DelimitedDecoder;
    /// let mut d = DelimitedDecoder::with_max_len(b";", 2).unwrap();
    /// assert!(d.decode(b"abc;").is_err());
    /// let big = DelimitedDecoder::with_max_len(b";", usize::MAX).unwrap();
    /// assert_eq!(big.max_len(), urscript_socket::MAX_BOUND);
    /// ```
    pub fn with_max_len(delimiter: &[u8], max_len: usize) -> Result<Self, ArgumentError> {
        if delimiter.is_empty() {
            return Err(ArgumentError::EmptyPattern);
        }
        let framer = Framer::delimited(Pattern::new(delimiter)?, max_len, AtEof::Flush);
        Ok(FrameDecoder::from_parts(framer, Delimited))
    }

    /// The delimiter.
    ///
    /// ```
    /// # use urscript_socket::string::DelimitedDecoder;
    /// assert_eq!(DelimitedDecoder::new(b";").unwrap().delimiter(), b";");
    /// ```
    pub fn delimiter(&self) -> &[u8] {
        match self.framer.shape() {
            Shape::Delimited { close } => close.as_bytes(),
            _ => &[],
        }
    }

    /// The bound on a message's content.
    ///
    /// ```
    /// # use urscript_socket::string::DelimitedDecoder;
    /// assert_eq!(DelimitedDecoder::with_max_len(b";", 9).unwrap().max_len(), 9);
    /// ```
    pub fn max_len(&self) -> usize {
        self.framer.bound()
    }

    /// Returns everything buffered as one message (at most `max_len` bytes) and resets
    /// the scan: for peers that end a message by going idle. `None` if nothing is held.
    ///
    /// ```
    /// # use urscript_socket::string::DelimitedDecoder;
    /// let mut d = DelimitedDecoder::new(b";").unwrap();
    /// assert_eq!(d.flush(b"partial"), Some((&b"partial"[..], 7)));
    /// assert_eq!(d.flush(b""), None);
    /// ```
    pub fn flush<'a>(&mut self, buf: &'a [u8]) -> Option<(&'a [u8], usize)> {
        self.framer.take_all(buf)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Status;

    fn read_once<'a>(d: &mut ReadStringDecoder, buf: &'a [u8]) -> Option<(&'a [u8], usize)> {
        match d.decode(buf).unwrap() {
            Status::Complete { item, consumed, .. } => Some((item, consumed)),
            Status::Partial { consumed } => {
                assert_eq!(consumed, 0);
                None
            }
        }
    }

    #[test]
    fn limit_without_suffix() {
        let big = [b'a'; 3000];
        let mut d = ReadStringDecoder::new(b"", b"", false).unwrap();
        assert_eq!(read_once(&mut d, &big).unwrap().1, READ_STRING_LIMIT);
        let mut d = ReadStringDecoder::new(b"", b";", false).unwrap();
        let (s, used) = read_once(&mut d, &big).unwrap();
        assert_eq!(
            (s.len(), used),
            (READ_STRING_LIMIT - 1, READ_STRING_LIMIT - 1)
        );
    }

    #[test]
    fn prefix_waits_for_content() {
        let mut d = ReadStringDecoder::new(b">", b"", false).unwrap();
        assert_eq!(read_once(&mut d, b"xx>"), None);
        assert_eq!(read_once(&mut d, b"xx>a"), Some((&b"a"[..], 4)));
    }

    #[test]
    fn split_prefix_and_suffix() {
        let mut d = ReadStringDecoder::new(b"<<", b">>", false).unwrap();
        let all = b"..<<hi>>";
        for end in 0..all.len() {
            assert_eq!(read_once(&mut d, &all[..end]), None, "{end}");
        }
        assert_eq!(read_once(&mut d, all), Some((&b"hi"[..], 8)));
    }

    #[test]
    fn escapes_only_when_asked() {
        let mut d = ReadStringDecoder::new(b"", br"\n", false).unwrap();
        assert_eq!(read_once(&mut d, b"a\\nb"), Some((&b"a"[..], 3)));
        let mut out = [0u8; MAX_PATTERN_LEN];
        let n = controller_pattern(br"\x\t", true, &mut out).unwrap();
        assert_eq!(&out[..n], b"\\x\t");
        assert!(controller_pattern(&[b'a'; 65], false, &mut out).is_err());
    }
}
