//! Shared checks for the fuzz targets: drive any core decoder through the documented
//! caller contract, whole and in fuzzer-chosen chunks, and require identical results,
//! bounded buffers and steady progress.

use std::fmt::Debug;

use urscript_socket::{Decode, ErrorKind, Status};

/// What a decoder produced: items (rendered) and errors (kind, absolute offset).
#[derive(Debug, PartialEq)]
pub enum Event {
    Item(String),
    Error(ErrorKind, u64),
}

/// Feeds `input` in pieces whose lengths come from `sizes` (cycled; 0 means whole), and
/// checks that at most `bound` unconsumed bytes are held after each piece.
pub fn drive<D>(mut dec: D, input: &[u8], sizes: &[u8], bound: usize) -> Vec<Event>
where
    D: Decode,
    for<'a> D::Item<'a>: Debug,
{
    let mut events = Vec::new();
    let mut buf: Vec<u8> = Vec::new();
    let mut at = 0;
    let mut k = 0;
    while at < input.len() {
        let size = match sizes.get(k % sizes.len().max(1)) {
            Some(&s) if s > 0 => usize::from(s),
            _ => input.len(),
        };
        k += 1;
        let end = (at + size).min(input.len());
        buf.extend_from_slice(&input[at..end]);
        at = end;
        let mut steps = 0;
        loop {
            steps += 1;
            assert!(steps <= buf.len() + 2 + input.len(), "no progress");
            let (event, drop, more) = match dec.decode(&buf) {
                Ok(Status::Complete { item, consumed, .. }) => {
                    assert!(consumed > 0);
                    (Some(Event::Item(format!("{item:?}"))), consumed, false)
                }
                Ok(Status::Partial { consumed }) => (None, consumed, true),
                Err(e) => (Some(Event::Error(e.kind(), e.offset())), e.skip(), false),
            };
            assert!(drop <= buf.len());
            buf.drain(..drop);
            events.extend(event);
            if more {
                break;
            }
        }
        assert!(buf.len() <= bound, "{} bytes held over the bound {bound}", buf.len());
        assert_eq!(dec.position() + buf.len() as u64, at as u64);
    }
    match dec.decode_eof(&buf) {
        Ok(Some((item, _))) => events.push(Event::Item(format!("{item:?}"))),
        Ok(None) => {}
        Err(e) => events.push(Event::Error(e.kind(), e.offset())),
    }
    events
}

/// The first bytes of a fuzz input choose the chunk sizes; the rest is the stream.
pub fn split_input(data: &[u8]) -> (&[u8], &[u8]) {
    let n = usize::from(data.first().copied().unwrap_or(0) % 8);
    let sizes_end = (1 + n).min(data.len());
    (data.get(1..sizes_end).unwrap_or(&[]), data.get(sizes_end..).unwrap_or(&[]))
}

/// Whole vs. one byte at a time vs. fuzzer-chosen chunks: all must agree.
pub fn check_split<D>(make: impl Fn() -> D, data: &[u8], bound: usize)
where
    D: Decode,
    for<'a> D::Item<'a>: Debug,
{
    let (sizes, input) = split_input(data);
    let whole = drive(make(), input, &[], usize::MAX);
    assert_eq!(whole, drive(make(), input, &[1], bound));
    let largest_piece = usize::from(sizes.iter().copied().max().unwrap_or(0));
    assert_eq!(whole, drive(make(), input, sizes, bound.saturating_add(largest_piece)));
}
