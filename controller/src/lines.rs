//! The lines a client sends (dashboard, interpreter socket, script on 30001-30003), cut
//! by the core's [`LineDecoder`]: a line ends at `\n` and one `\r` before it is dropped; a line whose
//! content (a `\r` before its `\n` included) goes past the bound is reported once, at the
//! first byte past it, and the rest of it is dropped up to its `\n`.

use std::io::{self, Read};

use urscript_socket::line::LineDecoder;
use urscript_socket::{ErrorKind, RecvBuffer, Status};

/// The most bytes one [`LineReader::read_from`] takes: one page, the chunk the
/// connection threads read in.
pub(crate) const READ_CHUNK: usize = 4096;

/// What the received bytes hold, in stream order.
#[derive(Debug, PartialEq, Eq)]
pub(crate) enum Event<'a> {
    /// A complete line, without its `\n` and one `\r` before it.
    Line(&'a [u8]),
    /// A line went past the bound: its first bytes (at most the reader's `echo`). The
    /// rest of it is dropped as it arrives.
    TooLong(&'a [u8]),
    /// The line last reported [`TooLong`](Event::TooLong) has ended: it held `len` bytes
    /// (without its `\n`).
    LongEnded(u64),
}

/// One connection's received bytes and the line framing over them.
pub(crate) struct LineReader {
    /// `max_len + 1 + READ_CHUNK` bytes, allocated at the first read (a stream client
    /// that never sends a script costs nothing): between reads it holds less than one
    /// line (a longer one is reported and dropped), and a read adds one chunk.
    buf: Option<RecvBuffer<Box<[u8]>>>,
    lines: LineDecoder,
    max_len: usize,
    echo: usize,
    /// Stream offset of the first byte of the too-long line being dropped.
    long: Option<u64>,
}

impl LineReader {
    /// Lines of at most `max_len` bytes; a longer one is reported with its first `echo`
    /// bytes.
    pub(crate) fn new(max_len: usize, echo: usize) -> Self {
        LineReader {
            buf: None,
            lines: LineDecoder::with_max_len(max_len),
            max_len,
            echo,
            long: None,
        }
    }

    /// Whether part of a line is held, or a too-long line is being dropped.
    pub(crate) fn is_pending(&self) -> bool {
        self.buf.as_ref().is_some_and(|b| !b.is_empty()) || self.lines.is_discarding()
    }

    /// Reads once from `from` (at most [`READ_CHUNK`] bytes); `Ok(0)` at end of input.
    pub(crate) fn read_from(&mut self, from: &mut impl Read) -> io::Result<usize> {
        let capacity = self.max_len + 1 + READ_CHUNK;
        let buf = self
            .buf
            .get_or_insert_with(|| RecvBuffer::with_capacity(capacity));
        let spare = buf.spare();
        let room = spare.len().min(READ_CHUNK);
        let n = from.read(&mut spare[..room])?;
        buf.commit(n);
        Ok(n)
    }

    /// Hands every event the bytes received so far complete to `f`, in order; stops at
    /// the first error `f` returns.
    pub(crate) fn drain<E>(
        &mut self,
        mut f: impl FnMut(Event<'_>) -> Result<(), E>,
    ) -> Result<(), E> {
        let Some(buf) = &mut self.buf else {
            return Ok(());
        };
        loop {
            let data = buf.data();
            match self.lines.decode(data) {
                Ok(Status::Complete { item, consumed, at }) => {
                    let ended = self
                        .long
                        .take()
                        .map(|start| Event::LongEnded(at.saturating_sub(start + 1)));
                    let r = ended
                        .map_or(Ok(()), &mut f)
                        .and_then(|()| f(Event::Line(item)));
                    buf.consume(consumed);
                    r?;
                }
                Ok(Status::Partial { consumed }) => {
                    buf.consume(consumed);
                    if let Some(start) = self.long {
                        if !self.lines.is_discarding() {
                            self.long = None;
                            let end = self.lines.position().saturating_sub(start + 1);
                            f(Event::LongEnded(end))?;
                        }
                    }
                    return Ok(());
                }
                Err(e) => {
                    let skip = e.skip();
                    let r = match e.kind() {
                        ErrorKind::TooLong { .. } => {
                            // The line's content is the `max_len` bytes before the error.
                            let start = skip.saturating_sub(self.max_len);
                            let kept = &data[start..skip];
                            self.long = Some(e.offset().saturating_sub(self.max_len as u64));
                            f(Event::TooLong(&kept[..self.echo.min(kept.len())]))
                        }
                        // A line decoder has no other error.
                        _ => Ok(()),
                    };
                    buf.consume(skip);
                    r?;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every event of `input` fed in pieces of `piece` bytes, owned.
    fn events(max_len: usize, echo: usize, input: &[u8], piece: usize) -> Vec<String> {
        let mut reader = LineReader::new(max_len, echo);
        let mut out = Vec::new();
        for chunk in input.chunks(piece) {
            let mut from = chunk;
            while reader.read_from(&mut from).unwrap() > 0 {}
            reader
                .drain(|e| {
                    out.push(match e {
                        Event::Line(l) => format!("line {}", String::from_utf8_lossy(l)),
                        Event::TooLong(s) => format!("long {}", String::from_utf8_lossy(s)),
                        Event::LongEnded(n) => format!("ended {n}"),
                    });
                    Ok::<(), ()>(())
                })
                .unwrap();
        }
        out
    }

    #[test]
    fn lines_one_cr_and_long_lines_in_any_pieces() {
        let input = b"a\r\nb\r\r\n\nabcdefgh\r\nok\nxyz\r\n12345678\n";
        let want = [
            "line a", "line b\r", "line ", "long abc", "ended 9", "line ok", "line xyz",
            "long 123", "ended 8",
        ];
        for piece in [1, 2, 3, 5, 7, 64] {
            assert_eq!(events(7, 3, input, piece), want, "pieces of {piece}");
        }
    }

    #[test]
    fn a_line_at_the_bound_is_a_line_and_a_cr_counts() {
        assert_eq!(events(3, 8, b"abc\n", 1), ["line abc"]);
        // `abc\r` is 4 bytes of content: past a bound of 3.
        assert_eq!(
            events(3, 8, b"abc\r\nz\n", 4),
            ["long abc", "ended 4", "line z"]
        );
    }

    #[test]
    fn a_long_line_ending_with_the_read_is_reported_at_once() {
        let mut reader = LineReader::new(4, 2);
        let mut got = Vec::new();
        let mut first: &[u8] = b"123456";
        reader.read_from(&mut first).unwrap();
        let mut keep = |e: Event<'_>| {
            got.push(format!("{e:?}"));
            Ok::<(), ()>(())
        };
        reader.drain(&mut keep).unwrap();
        let mut second: &[u8] = b"78\n";
        reader.read_from(&mut second).unwrap();
        reader.drain(&mut keep).unwrap();
        assert_eq!(got, ["TooLong([49, 50])", "LongEnded(8)"]);
    }
}
