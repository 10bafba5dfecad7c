//! The one framer: where a message starts and ends, for every frame shape UR's formats use,
//! and the only code in the crate that scans, bounds, discards to resync, keeps the absolute
//! stream offset or decides what end of input means.
//!
//! | shape | formats | a frame is |
//! |---|---|---|
//! | [`Shape::Delimited`] | lines, `SET`/`GET`, `GET` replies, value lines, delimited strings | the bytes before a 1-64 byte delimiter |
//! | [`Shape::Bracketed`] | `(`...`)` float tuples, `02`...`03` frames | the bytes between an open and a close byte |
//! | [`Shape::Counted`] | N int32 (4N bytes), N bytes | the next N bytes |
//! | [`Shape::Window`] | `socket_read_string(prefix, suffix)` | the bytes after the prefix, before the suffix, in a 1024-byte window |
//!
//! A format is a [`Framer`] plus a pure [`Parse`] of one complete frame; [`FrameDecoder`] joins
//! the two and implements [`Decode`] once for all of them. The parser gets the frame's
//! content and reports errors as offsets within it; the framer knows where the content sits
//! in the stream ([`Status::Complete`]'s `at`), so nobody else counts bytes.

use crate::{ArgumentError, Decode, DecodeError, ErrorKind, Status};

/// The longest prefix, suffix or delimiter stored inline (no allocation, no lifetime).
pub const MAX_PATTERN_LEN: usize = 64;

/// The largest bound a decoder accepts; larger ones (`usize::MAX`...) are clamped to it. No
/// buffer can hold more (a slice is at most `isize::MAX` bytes), and the headroom above it
/// keeps every `bound + delimiter` sum in range.
pub const MAX_BOUND: usize = isize::MAX as usize;

/// A short byte pattern held inline.
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct Pattern {
    bytes: [u8; MAX_PATTERN_LEN],
    len: u8,
}

impl core::fmt::Debug for Pattern {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "{:?}", self.as_bytes().escape_ascii())
    }
}

impl Pattern {
    pub const EMPTY: Pattern = Pattern {
        bytes: [0; MAX_PATTERN_LEN],
        len: 0,
    };

    pub fn new(bytes: &[u8]) -> Result<Self, ArgumentError> {
        if bytes.len() > MAX_PATTERN_LEN {
            return Err(ArgumentError::PatternTooLong {
                limit: MAX_PATTERN_LEN,
            });
        }
        let mut p = Pattern::EMPTY;
        p.bytes[..bytes.len()].copy_from_slice(bytes);
        p.len = bytes.len() as u8;
        Ok(p)
    }

    /// A one-byte pattern (always fits).
    pub const fn byte(b: u8) -> Self {
        let mut p = Pattern::EMPTY;
        p.bytes[0] = b;
        p.len = 1;
        p
    }

    #[inline]
    pub fn as_bytes(&self) -> &[u8] {
        &self.bytes[..usize::from(self.len)]
    }

    #[inline]
    pub fn len(&self) -> usize {
        usize::from(self.len)
    }
}

/// What to do with bytes before a bracketed frame's open byte.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Noise {
    /// Drop them silently.
    Skip,
    /// Report the first byte of each run (`UnexpectedByte`, with what was expected there),
    /// then drop the run up to the next open byte.
    Report(&'static str),
}

/// What end of input does to bytes that do not make a complete frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AtEof {
    /// They were a message cut off: a `Truncated` error, and they are dropped.
    Truncated,
    /// They are the last message (a peer that ends a message by closing or going quiet),
    /// at most the bound.
    Flush,
    /// They stay where they are, unconsumed (`socket_read_string`'s timeout).
    Keep,
}

/// Which [`Shape`] a parse step's frames have, known at compile time ([`Parse::SHAPE`]).
#[doc(hidden)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ShapeKind {
    Delimited,
    Bracketed,
    Counted,
    Window,
}

/// The frame shapes; see the module table.
#[derive(Debug, Clone, Copy)]
pub enum Shape {
    /// Content, then `close` (1 to 64 bytes).
    Delimited { close: Pattern },
    /// `open`, content, `close`. With `reopen`, an `open` inside a frame means the frame
    /// was cut short: an error there (the text says what was expected), and a new frame
    /// starts at it.
    Bracketed {
        open: u8,
        close: u8,
        noise: Noise,
        reopen: Option<&'static str>,
    },
    /// Exactly `len` bytes, `unit` bytes per value (for a read that ends early with the
    /// whole values that arrived).
    Counted { len: usize, unit: usize },
    /// `socket_read_string`: everything through the first `prefix` dropped, content up to
    /// `suffix` (consumed, not returned), all within [`WINDOW`] bytes counted from the
    /// prefix. Nothing is consumed until the frame is complete.
    Window { prefix: Pattern, suffix: Pattern },
}

impl Shape {
    /// Which of the four shapes this is.
    pub fn kind(&self) -> ShapeKind {
        match self {
            Shape::Delimited { .. } => ShapeKind::Delimited,
            Shape::Bracketed { .. } => ShapeKind::Bracketed,
            Shape::Counted { .. } => ShapeKind::Counted,
            Shape::Window { .. } => ShapeKind::Window,
        }
    }
}

/// `socket_read_string`'s limit: at most 1024 bytes, prefix and suffix included.
pub const WINDOW: usize = 1024;

/// Where the scan stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum State {
    /// Between frames.
    Idle,
    /// In a frame that starts at `buf[0]` (its open byte, if the shape has one). For a
    /// window: the content starts at `buf[content]`.
    InFrame { content: usize },
    /// Dropping a run of bytes before an open byte, already reported.
    Noise,
    /// Dropping the rest of an over-long frame through its close.
    Discarding,
    /// Dropping the rest of an over-long counted frame: this many bytes.
    Skipping(usize),
}

/// One complete frame: its content, where that content starts in the stream, and how many
/// bytes of the caller's buffer it used (noise before it and its delimiters included).
#[derive(Debug, Clone, Copy)]
pub struct Frame<'a> {
    pub content: &'a [u8],
    pub at: u64,
    pub consumed: usize,
}

/// The bound of a shape, worked out once at construction.
#[derive(Debug, Clone, Copy)]
struct Limits {
    /// The bound, as given (clamped to [`MAX_BOUND`]): content bytes for delimited and STX
    /// frames, the whole frame for float tuples, `len` for counted ones, the content of a
    /// read-string window.
    bound: usize,
    /// The bytes of a frame (from its open byte) the close may end within.
    window: usize,
    /// Frame index reported as the first byte past the bound when no close is in `window`.
    report: usize,
    at_eof: AtEof,
}

/// The mutable half: where the scan stands and the absolute offset.
#[derive(Debug, Clone)]
struct Scan {
    state: State,
    /// Bytes at the front of the frame already known to hold no close (or, for a window
    /// still looking for its prefix, no prefix start). If `next` saw `(1,2` it holds 4 and
    /// the next call looks for `)` from index 4 on: chunked input is searched once.
    scanned: usize,
    /// Absolute stream offset of `buf[0]`.
    pos: u64,
}

/// What starts and ends a delimited or bracketed frame, as the scan uses it.
#[derive(Clone, Copy)]
struct Ends<'c> {
    /// The open byte and what to do with bytes before it; `None`: the frame starts at once.
    open: Option<(u8, Noise)>,
    /// The close: one byte, or a 1-64 byte delimiter.
    close: &'c [u8],
    /// An open byte inside a frame cuts it short (what was expected, for the error).
    reopen: Option<&'static str>,
}

/// The resumable scan for one shape, with its bound.
#[derive(Debug, Clone)]
pub struct Framer {
    shape: Shape,
    limits: Limits,
    scan: Scan,
}

/// First occurrence of `pattern` (a close, delimiter, prefix or suffix) in `hay`: the
/// framer's one search. memchr for one byte; memchr's `memmem` (a SIMD prefilter +
/// Two-Way) for longer patterns, so the cost is linear in `hay`. An empty pattern is found
/// at 0 (`memmem`'s rule).
#[inline(always)]
fn find(pattern: &[u8], hay: &[u8]) -> Option<usize> {
    match pattern {
        [b] => memchr::memchr(*b, hay),
        p => memchr::memmem::find(hay, p),
    }
}

impl Framer {
    #[inline]
    const fn with(shape: Shape, at_eof: AtEof, bound: usize, window: usize, report: usize) -> Self {
        Framer {
            shape,
            limits: Limits {
                bound,
                window,
                report,
                at_eof,
            },
            scan: Scan {
                state: State::Idle,
                scanned: 0,
                pos: 0,
            },
        }
    }

    /// Content of at most `max_len` bytes before `close` (not empty). TooLong is reported
    /// at the first content byte past the bound.
    pub fn delimited(close: Pattern, max_len: usize, at_eof: AtEof) -> Self {
        debug_assert!(close.len() > 0);
        let max_len = max_len.min(MAX_BOUND);
        let window = max_len + close.len();
        Framer::with(Shape::Delimited { close }, at_eof, max_len, window, max_len)
    }

    /// `open` content `close`. With `counts_brackets`, `bound` is the whole frame's length
    /// and TooLong is reported at the first byte past it (float tuples); else it is the
    /// content's, reported at the first content byte past it (STX/ETX payloads).
    pub fn bracketed(
        open: u8,
        close: u8,
        noise: Noise,
        reopen: Option<&'static str>,
        bound: usize,
        counts_brackets: bool,
    ) -> Self {
        let bound = bound.min(MAX_BOUND);
        let (window, report) = if counts_brackets {
            (bound, bound)
        } else {
            (bound + 2, bound + 1)
        };
        let shape = Shape::Bracketed {
            open,
            close,
            noise,
            reopen,
        };
        Framer::with(shape, AtEof::Truncated, bound, window, report)
    }

    /// Exactly `len` bytes (at least 1), `unit` per value.
    #[inline]
    pub const fn counted(len: usize, unit: usize) -> Self {
        Framer::with(
            Shape::Counted { len, unit },
            AtEof::Truncated,
            len,
            len,
            len,
        )
    }

    /// `socket_read_string(prefix, suffix)`.
    pub fn window(prefix: Pattern, suffix: Pattern) -> Self {
        let bound = WINDOW - prefix.len() - suffix.len();
        Framer::with(Shape::Window { prefix, suffix }, AtEof::Keep, bound, 0, 0)
    }

    pub fn shape(&self) -> &Shape {
        &self.shape
    }

    /// The bound (see [`Limits::bound`]).
    pub fn bound(&self) -> usize {
        self.limits.bound
    }

    /// Absolute stream offset of the next byte to decode.
    #[inline]
    pub fn position(&self) -> u64 {
        self.scan.pos
    }

    /// Forgets the scan state (the bytes it covered are still the caller's).
    pub fn reset(&mut self) {
        self.scan.reset();
    }

    /// The next frame in `buf` (the caller's unconsumed bytes): the one scan-and-discard
    /// machine of the crate. Every return accounts for the bytes it tells the caller to drop.
    ///
    /// `kind` is the shape's kind. A parse step passes its own ([`Parse::SHAPE`]), known at
    /// compile time, so the match below folds to the one arm: a counted read costs a length
    /// check and a line a memchr, with no dispatch and no call. Other callers pass
    /// [`Shape::kind`].
    #[inline(always)]
    pub fn next<'a>(
        &mut self,
        kind: ShapeKind,
        buf: &'a [u8],
    ) -> Result<Status<Frame<'a>>, DecodeError> {
        let Framer {
            shape,
            limits,
            scan,
        } = self;
        match (kind, &*shape) {
            // A counted frame's length is its bound.
            (ShapeKind::Counted, _) => Ok(scan.counted(buf, limits.bound)),
            (ShapeKind::Delimited, Shape::Delimited { close }) => {
                let ends = Ends {
                    open: None,
                    close: close.as_bytes(),
                    reopen: None,
                };
                scan.delimited(buf, limits, ends)
            }
            (
                ShapeKind::Bracketed,
                Shape::Bracketed {
                    open,
                    close,
                    noise,
                    reopen,
                },
            ) => {
                let ends = Ends {
                    open: Some((*open, *noise)),
                    close: core::slice::from_ref(close),
                    reopen: *reopen,
                };
                scan.delimited(buf, limits, ends)
            }
            (ShapeKind::Window, Shape::Window { prefix, suffix }) => {
                Ok(scan.window(buf, limits, prefix, suffix))
            }
            // A kind that is not the shape's (no parse step is built so): the shape decides.
            _ => self.next_by_shape(buf),
        }
    }

    /// [`next`](Self::next) with the kind read from the shape, out of line: the cold arm
    /// above, kept from bloating the decode loops it is inlined into.
    #[cold]
    #[inline(never)]
    fn next_by_shape<'a>(&mut self, buf: &'a [u8]) -> Result<Status<Frame<'a>>, DecodeError> {
        self.next(self.shape.kind(), buf)
    }

    /// The input ended: the frame in `buf` if there is one, else the shape's end-of-input
    /// rule for what is left. Every path is final: after an error its bytes are dropped
    /// (or being discarded) and a call on what remains returns `Ok(None)`; after `Ok(None)`
    /// every byte of `buf` is accounted for (except [`AtEof::Keep`], which consumes
    /// nothing) and the scan is reset.
    pub fn finish<'a>(&mut self, buf: &'a [u8]) -> Result<Option<Frame<'a>>, DecodeError> {
        let consumed = match self.next(self.shape.kind(), buf)? {
            Status::Complete { item, .. } => return Ok(Some(item)),
            Status::Partial { consumed } => consumed,
        };
        let rest = &buf[consumed..];
        // Bytes left while idle or in a frame are an unfinished frame; left while noise
        // or an over-long frame is being dropped, they are the tail of what is dropped.
        let unfinished = matches!(self.scan.state, State::Idle | State::InFrame { .. });
        let at_eof = self.limits.at_eof;
        self.scan.reset();
        if at_eof == AtEof::Keep {
            return Ok(None);
        }
        if rest.is_empty() || !unfinished {
            self.scan.pos += rest.len() as u64;
            return Ok(None);
        }
        if at_eof == AtEof::Flush {
            if let Some((content, n)) = self.take_all(rest) {
                return Ok(Some(Frame {
                    content,
                    at: self.scan.pos - n as u64,
                    consumed: consumed + n,
                }));
            }
            // Nothing fits a bound of 0: the rest is over-long, reported and dropped (an
            // empty message that consumes nothing would be returned forever).
            let kind = ErrorKind::TooLong {
                limit: self.limits.bound,
            };
            let e = DecodeError::new(kind, self.scan.pos, buf.len());
            self.scan.pos += rest.len() as u64;
            return Err(e);
        }
        let e = DecodeError::new(ErrorKind::Truncated, self.scan.pos, buf.len());
        self.scan.pos += rest.len() as u64;
        Err(e)
    }

    /// Everything buffered as one frame (flush on idle or end of input), at most the
    /// bound, and resets the scan. `None` if nothing is held, or while the rest of an
    /// over-long message is being discarded (that goes on through its delimiter).
    pub fn take_all<'a>(&mut self, buf: &'a [u8]) -> Option<(&'a [u8], usize)> {
        if self.scan.state == State::Discarding {
            return None;
        }
        self.scan.reset();
        if buf.is_empty() {
            return None;
        }
        let n = buf.len().min(self.limits.bound);
        if n == 0 {
            return None;
        }
        self.scan.pos += n as u64;
        Some((&buf[..n], n))
    }

    /// The whole values of a counted frame that arrived, when a read must end early.
    pub fn take_counted<'a>(&mut self, buf: &'a [u8]) -> Option<(&'a [u8], usize)> {
        let Shape::Counted { len, unit } = self.shape else {
            return None;
        };
        let n = buf.len().min(len) / unit * unit;
        if n == 0 || self.scan.state != State::Idle {
            return None;
        }
        self.scan.pos += n as u64;
        Some((&buf[..n], n))
    }

    /// `socket_read_string`'s resync, for a window still looking for its prefix over a full
    /// buffer (`buf` is all of it) that holds no occurrence of it: the controller discards
    /// everything before the prefix, so the bytes that cannot begin it (all but the last
    /// `prefix.len() - 1`) are dropped and the scan starts afresh on the rest. Without this
    /// a flood of junk would wedge the read and every later one on the socket. Returns how
    /// many bytes of `buf` to drop: 0 for other shapes, an empty prefix, or a prefix found.
    #[cfg(feature = "alloc")]
    pub fn drop_before_prefix(&mut self, buf: &[u8]) -> usize {
        let Shape::Window { prefix, .. } = &self.shape else {
            return 0;
        };
        let prefix = prefix.as_bytes();
        if prefix.is_empty() || find(prefix, buf).is_some() {
            return 0;
        }
        let drop = buf.len() - (prefix.len() - 1).min(buf.len());
        if drop > 0 {
            // The scan state referred to the dropped bytes.
            self.scan.reset();
            self.scan.pos += drop as u64;
        }
        drop
    }

    /// The caller's buffer is full (`buf` is all of it) and the frame in it cannot
    /// complete: a buffer smaller than the bound. Treats the frame as over-long at the
    /// buffer's size: a `TooLong` error, the bytes dropped, and the rest of the frame
    /// discarded (through its close, or its remaining count) so decoding resyncs on the next
    /// one. `None` for a window, which by its rule consumes nothing until complete.
    pub fn overflow(&mut self, buf: &[u8]) -> Option<DecodeError> {
        let limit = buf.len();
        if limit == 0 {
            return None;
        }
        let scan = &mut self.scan;
        let kind = ErrorKind::TooLong { limit };
        match (&self.shape, scan.state) {
            (Shape::Counted { len, .. }, State::Idle) if limit < *len => {
                scan.state = State::Skipping(len - limit);
                Some(scan.error(kind, limit, limit))
            }
            (Shape::Delimited { close }, State::InFrame { .. }) => {
                // Keep the last clen-1 bytes: they may begin a split delimiter.
                let skip = limit - (close.len() - 1).min(limit - 1);
                scan.state = State::Discarding;
                scan.scanned = 0;
                Some(scan.error(kind, skip, skip))
            }
            (Shape::Bracketed { .. }, State::InFrame { .. }) => {
                scan.state = State::Discarding;
                scan.scanned = 0;
                Some(scan.error(kind, limit, limit))
            }
            _ => None,
        }
    }
}

impl Scan {
    fn reset(&mut self) {
        self.state = State::Idle;
        self.scanned = 0;
    }

    /// Bytes `buf[..n]` are dropped with nothing to report.
    #[inline(always)]
    fn partial(&mut self, n: usize) -> Status<Frame<'static>> {
        self.pos += n as u64;
        Status::Partial { consumed: n }
    }

    /// An error at `buf[at]`; `buf[..skip]` are dropped.
    #[inline]
    fn error(&mut self, kind: ErrorKind, at: usize, skip: usize) -> DecodeError {
        let e = DecodeError::new(kind, self.pos + at as u64, skip);
        self.pos += skip as u64;
        e
    }

    /// A frame whose content is `buf[start..end]`, using `buf[..consumed]`.
    #[inline(always)]
    fn complete<'a>(
        &mut self,
        buf: &'a [u8],
        start: usize,
        end: usize,
        consumed: usize,
    ) -> Status<Frame<'a>> {
        self.state = State::Idle;
        self.scanned = 0;
        let at = self.pos + start as u64;
        self.pos += consumed as u64;
        Status::Complete {
            item: Frame {
                content: &buf[start..end],
                at,
                consumed,
            },
            consumed,
            at,
        }
    }

    /// Delimited and bracketed frames (`open` is `None` for delimited ones): one loop over
    /// the states, each arm one transition.
    #[inline(always)]
    fn delimited<'a>(
        &mut self,
        buf: &'a [u8],
        limits: &Limits,
        ends: Ends<'_>,
    ) -> Result<Status<Frame<'a>>, DecodeError> {
        let Ends { open, close, .. } = ends;
        let clen = close.len();
        // The common cases first: in a frame, or a delimited frame starting now.
        match (self.state, open) {
            (State::InFrame { content }, _) => return self.frame(buf, 0, content, limits, ends),
            (State::Idle, None) => {
                self.state = State::InFrame { content: 0 };
                self.scanned = 0;
                return self.frame(buf, 0, 0, limits, ends);
            }
            _ => {}
        }
        // Bytes of `buf` already dropped in this call.
        let mut lead = 0;
        loop {
            let rest = &buf[lead..];
            match (self.state, open) {
                // The rest of an over-long frame: drop through the close, then go on.
                (State::Discarding, _) => match find(close, rest) {
                    Some(i) => {
                        lead += i + clen;
                        self.state = State::Idle;
                    }
                    // Keep the last clen-1 bytes: they may begin a split delimiter.
                    None => return Ok(self.partial(buf.len() - (clen - 1).min(rest.len()))),
                },
                // A reported run of noise: drop up to the next open byte.
                (State::Noise, Some((o, _))) => match memchr::memchr(o, rest) {
                    Some(i) => {
                        lead += i;
                        self.state = State::Idle;
                    }
                    None => return Ok(self.partial(buf.len())),
                },
                (State::InFrame { content }, _) => {
                    return self.frame(buf, lead, content, limits, ends);
                }
                // Delimited: every byte is content.
                (_, None) => {
                    self.state = State::InFrame { content: 0 };
                    self.scanned = 0;
                }
                (_, Some((o, noise))) => match rest.first() {
                    None => return Ok(self.partial(lead)),
                    Some(&b) if b == o => {
                        self.state = State::InFrame { content: 1 };
                        // The open byte is no close (and no reopen).
                        self.scanned = 1;
                    }
                    Some(&found) => {
                        let next_open = memchr::memchr(o, rest);
                        match (noise, next_open) {
                            (Noise::Skip, Some(i)) => lead += i,
                            (Noise::Skip, None) => return Ok(self.partial(buf.len())),
                            (Noise::Report(expected), _) => {
                                let skip = match next_open {
                                    Some(i) => lead + i,
                                    None => {
                                        self.state = State::Noise;
                                        buf.len()
                                    }
                                };
                                let kind = ErrorKind::UnexpectedByte { found, expected };
                                return Err(self.error(kind, lead, skip));
                            }
                        }
                    }
                },
            }
        }
    }

    /// The frame starts at `buf[lead]`, its content `content` bytes later: find its close
    /// within the bound, resuming where the last call stopped.
    #[inline(always)]
    fn frame<'a>(
        &mut self,
        buf: &'a [u8],
        lead: usize,
        content: usize,
        limits: &Limits,
        ends: Ends<'_>,
    ) -> Result<Status<Frame<'a>>, DecodeError> {
        let Ends {
            open,
            close,
            reopen,
        } = ends;
        let clen = close.len();
        let frame = &buf[lead..];
        let window = frame.len().min(limits.window);
        // Never before the content (a caller that passed fewer bytes than last time must not
        // make the content end before it starts).
        let from = self
            .scanned
            .saturating_sub(clen - 1)
            .max(content)
            .min(window);
        let hay = &frame[from..window];
        let found = match (reopen, open) {
            // A reopen is looked for together with the close: one pass (memchr2).
            (Some(_), Some((o, _))) => memchr::memchr2(o, close[0], hay).map(|i| (i, hay[i] == o)),
            _ => find(close, hay).map(|i| (i, false)),
        };
        match found {
            Some((i, false)) => {
                let end = lead + from + i;
                Ok(self.complete(buf, lead + content, end, end + clen))
            }
            Some((i, true)) => {
                // A new frame opens before this one closed: it was cut short.
                self.reset();
                let at = lead + from + i;
                let kind = ErrorKind::UnexpectedByte {
                    found: buf[at],
                    expected: reopen.unwrap_or(""),
                };
                Err(self.error(kind, at, at))
            }
            None if frame.len() >= limits.report.saturating_add(clen) => {
                // Over the bound without a close: report at the first byte past it, drop
                // what we have and discard through the next close.
                self.state = State::Discarding;
                self.scanned = 0;
                let at = lead + limits.report;
                let kind = ErrorKind::TooLong {
                    limit: limits.bound,
                };
                Err(self.error(kind, at, at))
            }
            None => {
                // Keep the frame, moved to the front of the caller's buffer.
                self.scanned = window;
                Ok(self.partial(lead))
            }
        }
    }

    /// A whole counted frame of `len` bytes at the front of `buf`, between frames: every
    /// call in a steady stream, so it is only a length check (the state is already Idle).
    #[inline(always)]
    fn whole<'a>(&mut self, buf: &'a [u8], len: usize) -> Option<Frame<'a>> {
        if self.state != State::Idle || buf.len() < len {
            return None;
        }
        let at = self.pos;
        self.pos += len as u64;
        Some(Frame {
            content: &buf[..len],
            at,
            consumed: len,
        })
    }

    /// A whole frame at the front of `buf`, between frames, its content `content` bytes in
    /// (after an open byte already checked, or at once): every call in a steady stream of
    /// lines or tuples. On a miss the scan is left where the general step resumes it (in
    /// the frame, `scanned` bytes searched), so no byte is searched twice.
    #[inline(always)]
    fn whole_delimited<'a>(
        &mut self,
        buf: &'a [u8],
        limits: &Limits,
        content: usize,
        close: &[u8],
    ) -> Option<Frame<'a>> {
        if self.state != State::Idle {
            return None;
        }
        let window = buf.len().min(limits.window);
        let from = content.min(window);
        match find(close, &buf[from..window]) {
            Some(i) => {
                let end = from + i;
                let consumed = end + close.len();
                let at = self.pos + content as u64;
                self.pos += consumed as u64;
                Some(Frame {
                    content: &buf[content..end],
                    at,
                    consumed,
                })
            }
            None => {
                self.state = State::InFrame { content };
                self.scanned = window;
                None
            }
        }
    }

    /// Counted frames: no scan, only a length.
    #[inline(always)]
    fn counted<'a>(&mut self, buf: &'a [u8], len: usize) -> Status<Frame<'a>> {
        let mut lead = 0;
        if let State::Skipping(left) = self.state {
            lead = left.min(buf.len());
            if lead < left {
                self.state = State::Skipping(left - lead);
                return self.partial(lead);
            }
            self.state = State::Idle;
        }
        if buf.len() - lead < len {
            return self.partial(lead);
        }
        self.complete(buf, lead, lead + len, lead + len)
    }

    /// `socket_read_string`: nothing is consumed until the frame is complete.
    fn window<'a>(
        &mut self,
        buf: &'a [u8],
        limits: &Limits,
        prefix: &Pattern,
        suffix: &Pattern,
    ) -> Status<Frame<'a>> {
        let plen = prefix.len();
        let content_start = match self.state {
            // A caller that passed fewer bytes than last time: search them afresh.
            State::InFrame { content } if content > buf.len() => {
                self.reset();
                return self.window(buf, limits, prefix, suffix);
            }
            State::InFrame { content } => content,
            _ if plen == 0 => 0,
            _ => {
                let from = self.scanned.saturating_sub(plen - 1).min(buf.len());
                match find(prefix.as_bytes(), &buf[from..]) {
                    Some(i) => {
                        let c = from + i + plen;
                        self.state = State::InFrame { content: c };
                        self.scanned = 0;
                        c
                    }
                    None => {
                        self.scanned = buf.len();
                        return Status::Partial { consumed: 0 };
                    }
                }
            }
        };
        let content = &buf[content_start..];
        let slen = suffix.len();
        // The 1024-byte window counts the prefix and the suffix.
        let max_content = limits.bound;
        if slen == 0 {
            if content.is_empty() {
                return Status::Partial { consumed: 0 };
            }
            let end = content_start + content.len().min(max_content);
            return self.complete(buf, content_start, end, end);
        }
        let window = content.len().min(max_content + slen);
        let from = self.scanned.saturating_sub(slen - 1).min(window);
        match find(suffix.as_bytes(), &content[from..window]) {
            Some(i) => {
                let end = content_start + from + i;
                self.complete(buf, content_start, end, end + slen)
            }
            None if content.len() >= max_content + slen => {
                let end = content_start + max_content;
                self.complete(buf, content_start, end, end)
            }
            None => {
                self.scanned = window;
                Status::Partial { consumed: 0 }
            }
        }
    }
}

/// Declares a parse step that hands a frame's content on as it is (STX/ETX payloads,
/// read strings, delimited strings): one line per format instead of one impl each.
macro_rules! content_as_is {
    ($(#[$doc:meta])* $name:ident, $shape:ident) => {
        $(#[$doc])*
        #[derive(Debug, Clone, Copy, Default)]
        pub struct $name;

        impl $crate::Parse for $name {
            type Output<'a> = &'a [u8];
            const SHAPE: $crate::framer::ShapeKind = $crate::framer::ShapeKind::$shape;
            #[inline(always)]
            fn parse<'a>(&self, content: &'a [u8]) -> Result<&'a [u8], ($crate::ErrorKind, usize)> {
                Ok(content)
            }
        }
    };
}
pub(crate) use content_as_is;

/// The pure half of a format: one complete frame's content to an item. Errors are (what,
/// offset within `content`); [`FrameDecoder`] makes the offset absolute.
pub trait Parse {
    /// What a frame decodes to; borrows the frame where the format allows it.
    type Output<'a>;

    /// The shape of this format's frames, so that the framer's dispatch is resolved at
    /// compile time. Internal.
    #[doc(hidden)]
    const SHAPE: ShapeKind;

    /// Parses the content of one complete frame.
    fn parse<'a>(&self, content: &'a [u8]) -> Result<Self::Output<'a>, (ErrorKind, usize)>;
}

/// A decoder: the framer for a format's frame shape and the format's [`Parse`]. Every
/// decoder of the crate is one of these (`LineDecoder` is `FrameDecoder<Line>`, ...), so the
/// [`Decode`] contract is implemented once, here.
///
/// `decode`, `decode_eof` and `position` are also inherent methods, so calling them needs
/// no trait import.
#[derive(Debug, Clone)]
pub struct FrameDecoder<P> {
    pub(crate) framer: Framer,
    pub(crate) parser: P,
}

impl<P: Parse> FrameDecoder<P> {
    pub(crate) const fn from_parts(framer: Framer, parser: P) -> Self {
        FrameDecoder { framer, parser }
    }

    /// Looks at `buf` (the unconsumed bytes) for the next message. See [`Status`] for the
    /// contract.
    ///
    /// ```
    /// # use urscript_socket::{line::LineDecoder, Status};
    /// let mut d = LineDecoder::new();
    /// assert_eq!(
    ///     d.decode(b"a\nb").unwrap(),
    ///     Status::Complete { item: &b"a"[..], consumed: 2, at: 0 }
    /// );
    /// assert_eq!(d.decode(b"b").unwrap(), Status::Partial { consumed: 0 });
    /// ```
    #[inline]
    pub fn decode<'a>(&mut self, buf: &'a [u8]) -> Result<Status<P::Output<'a>>, DecodeError> {
        // The common case (between frames, a whole frame there) without the general step.
        let whole = match (P::SHAPE, &self.framer.shape) {
            (ShapeKind::Counted, _) => self.framer.scan.whole(buf, self.framer.limits.bound),
            (ShapeKind::Delimited, Shape::Delimited { close }) => {
                self.framer
                    .scan
                    .whole_delimited(buf, &self.framer.limits, 0, close.as_bytes())
            }
            _ => None,
        };
        let frame = match whole {
            Some(frame) => frame,
            None => match self.framer.next(P::SHAPE, buf)? {
                Status::Complete { item, .. } => item,
                Status::Partial { consumed } => return Ok(Status::Partial { consumed }),
            },
        };
        // One match, no combinators: a large item (a float tuple is 256 bytes) is built
        // once in the result instead of being moved through each layer.
        match self.parser.parse(frame.content) {
            Ok(item) => Ok(Status::Complete {
                item,
                consumed: frame.consumed,
                at: frame.at,
            }),
            Err((kind, off)) => Err(DecodeError::new(
                kind,
                frame.at + off as u64,
                frame.consumed,
            )),
        }
    }

    /// The input ended (peer closed, end of file): the next message if one is complete
    /// (call again for more), else the format's end-of-input rule for what is left (a
    /// [`Truncated`](ErrorKind::Truncated) error, a last unterminated message, or, for
    /// `socket_read_string`, nothing consumed). Idempotent: after an error, drop its
    /// [`skip`](DecodeError::skip) and the next call on what remains returns `Ok(None)`;
    /// after `Ok(None)` every byte of `buf` is accounted for in
    /// [`position`](Self::position) and the decoder is reset.
    ///
    /// ```
    /// # use urscript_socket::line::LineDecoder;
    /// let mut d = LineDecoder::new();
    /// assert_eq!(d.decode_eof(b"a\n").unwrap(), Some((&b"a"[..], 2)));
    /// let e = d.decode_eof(b"tail").unwrap_err();
    /// assert_eq!((e.offset(), e.skip()), (2, 4));
    /// assert_eq!(d.decode_eof(b"").unwrap(), None);
    /// ```
    pub fn decode_eof<'a>(
        &mut self,
        buf: &'a [u8],
    ) -> Result<Option<(P::Output<'a>, usize)>, DecodeError> {
        match self.framer.finish(buf)? {
            Some(frame) => self.parse(frame).map(|item| Some((item, frame.consumed))),
            None => Ok(None),
        }
    }

    /// Absolute stream offset of the next byte to decode.
    ///
    /// ```
    /// # use urscript_socket::line::LineDecoder;
    /// let mut d = LineDecoder::new();
    /// d.decode(b"ab\n").unwrap();
    /// assert_eq!(d.position(), 3);
    /// ```
    #[inline]
    pub fn position(&self) -> u64 {
        self.framer.position()
    }

    /// Whether the rest of an over-long message is being dropped: after its
    /// [`TooLong`](ErrorKind::TooLong) error and until its close (a line's LF) has been
    /// consumed. A caller that reports how long the dropped message was reads
    /// [`position`](Self::position) once this turns false.
    ///
    /// ```
    /// # use urscript_socket::{line::LineDecoder, Status};
    /// let mut d = LineDecoder::with_max_len(2);
    /// assert!(d.decode(b"abc").is_err());
    /// assert!(d.is_discarding());
    /// assert_eq!(d.decode(b"cde\n").unwrap(), Status::Partial { consumed: 4 });
    /// assert!(!d.is_discarding());
    /// assert_eq!(d.position(), 6); // the dropped line was 5 bytes and its LF
    /// ```
    pub fn is_discarding(&self) -> bool {
        matches!(self.framer.scan.state, State::Discarding)
    }

    /// The parse step, its error offsets made absolute; the frame's bytes are consumed
    /// either way (a malformed message is dropped whole).
    #[inline(always)]
    fn parse<'a>(&self, frame: Frame<'a>) -> Result<P::Output<'a>, DecodeError> {
        self.parser
            .parse(frame.content)
            .map_err(|(kind, off)| DecodeError::new(kind, frame.at + off as u64, frame.consumed))
    }
}

impl<P: Parse> Decode for FrameDecoder<P> {
    type Item<'buf> = P::Output<'buf>;

    #[inline]
    fn decode<'buf>(&mut self, buf: &'buf [u8]) -> Result<Status<Self::Item<'buf>>, DecodeError> {
        FrameDecoder::decode(self, buf)
    }

    fn decode_eof<'buf>(
        &mut self,
        buf: &'buf [u8],
    ) -> Result<Option<(Self::Item<'buf>, usize)>, DecodeError> {
        FrameDecoder::decode_eof(self, buf)
    }

    #[inline]
    fn position(&self) -> u64 {
        self.framer.position()
    }

    fn overflow(&mut self, buf: &[u8]) -> Option<DecodeError> {
        self.framer.overflow(buf)
    }
}
