//! The one resumable delimiter scan behind every delimiter-framed format (lines,
//! `SET`/`GET` messages, `GET` replies, user-delimited strings). Internal.

use crate::{ArgumentError, DecodeError, ErrorKind, Status};

/// The longest prefix, suffix or delimiter stored inline (no allocation, no lifetime).
pub const MAX_PATTERN_LEN: usize = 64;

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

    #[inline]
    pub fn as_bytes(&self) -> &[u8] {
        &self.bytes[..usize::from(self.len)]
    }

    #[inline]
    pub fn len(&self) -> usize {
        usize::from(self.len)
    }

    #[inline]
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// First occurrence in `hay`. memchr for one byte; memchr's `memmem` (a SIMD
    /// prefilter + Two-Way) for longer patterns, so the cost is linear in `hay`.
    #[inline(always)]
    pub fn find(&self, hay: &[u8]) -> Option<usize> {
        match self.as_bytes() {
            [] => Some(0),
            [b] => memchr::memchr(*b, hay),
            p => memchr::memmem::find(hay, p),
        }
    }
}

/// Resumable scan for `pattern` with a bound on the content before it.
#[derive(Debug, Clone)]
pub struct Framer {
    pattern: Pattern,
    max_len: usize,
    /// Bytes at the front of `buf` already known not to start a delimiter occurrence.
    /// If `next` was called with `abc` and delimiter `\n`, it holds 3; the next call
    /// searches from index 3 (minus `pattern.len() - 1`, for a delimiter split across
    /// chunks).
    scanned: usize,
    /// After a bound error: dropping bytes through the next delimiter.
    discarding: bool,
    /// Absolute stream offset of `buf[0]`.
    pub pos: u64,
}

impl Framer {
    pub fn new(pattern: Pattern, max_len: usize) -> Self {
        debug_assert!(!pattern.is_empty());
        Framer {
            pattern,
            max_len,
            scanned: 0,
            discarding: false,
            pos: 0,
        }
    }

    pub fn max_len(&self) -> usize {
        self.max_len
    }

    pub fn pattern(&self) -> &Pattern {
        &self.pattern
    }

    /// Next frame: the content before the delimiter; `consumed` includes the delimiter.
    #[inline]
    pub fn next<'a>(&mut self, buf: &'a [u8]) -> Result<Status<&'a [u8]>, DecodeError> {
        let dlen = self.pattern.len();
        let mut lead = 0;
        if self.discarding {
            match self.pattern.find(buf) {
                Some(i) => {
                    self.discarding = false;
                    lead = i + dlen;
                }
                None => {
                    // Keep the last dlen-1 bytes: they may begin a split delimiter.
                    let drop = buf.len().saturating_sub(dlen - 1);
                    self.pos += drop as u64;
                    return Ok(Status::Partial { consumed: drop });
                }
            }
        }
        let data = &buf[lead..];
        // A delimiter must start at or before `max_len` for the content to fit.
        let window = data.len().min(self.max_len + dlen);
        let from = self.scanned.saturating_sub(dlen - 1).min(window);
        match self.pattern.find(&data[from..window]) {
            Some(i) => {
                let at = from + i;
                self.scanned = 0;
                let consumed = lead + at + dlen;
                self.pos += consumed as u64;
                Ok(Status::Complete {
                    item: &data[..at],
                    consumed,
                })
            }
            None if data.len() >= self.max_len + dlen => {
                let at = self.pos + (lead + self.max_len) as u64;
                self.scanned = 0;
                self.discarding = true;
                let skip = lead + self.max_len;
                self.pos += skip as u64;
                Err(DecodeError::new(
                    ErrorKind::TooLong {
                        limit: self.max_len,
                    },
                    at,
                    skip,
                ))
            }
            None => {
                self.scanned = window;
                self.pos += lead as u64;
                Ok(Status::Partial { consumed: lead })
            }
        }
    }

    /// Everything buffered as one frame (flush / end of input), minus the rest of a
    /// message being discarded. Resets the scan.
    pub fn take_all<'a>(&mut self, buf: &'a [u8]) -> Option<(&'a [u8], usize)> {
        self.scanned = 0;
        if self.discarding {
            self.discarding = false;
            self.pos += buf.len() as u64;
            return None;
        }
        if buf.is_empty() {
            return None;
        }
        let n = buf.len().min(self.max_len);
        self.pos += n as u64;
        Some((&buf[..n], n))
    }

    /// Forgets the scan state (the bytes it covered are still the caller's).
    pub fn reset(&mut self) {
        self.scanned = 0;
        self.discarding = false;
    }
}
