//! The split-invariance driver shared by the property tests and the fuzz-seed replay.

use std::fmt::Debug;

use urscript_socket::{Decode, ErrorKind, Status};

#[derive(Debug, PartialEq)]
pub enum Event {
    Item(String),
    Error(ErrorKind, u64),
}

/// Feeds `input` split at `cuts` (sorted offsets) and returns what came out. `bound` is
/// the most bytes the decoder may leave unconsumed before it must decide.
pub fn feed<D>(mut dec: D, input: &[u8], cuts: &[usize], bound: usize) -> Vec<Event>
where
    D: Decode,
    for<'a> D::Item<'a>: Debug,
{
    let mut events = Vec::new();
    let mut buf: Vec<u8> = Vec::new();
    let mut start = 0;
    let mut edges: Vec<usize> = cuts
        .iter()
        .copied()
        .filter(|&c| c > 0 && c < input.len())
        .collect();
    edges.push(input.len());
    let mut guard = 0usize;
    for &end in &edges {
        if end < start {
            continue;
        }
        buf.extend_from_slice(&input[start..end]);
        start = end;
        loop {
            guard += 1;
            assert!(guard < 10 * input.len() + 100, "decoder made no progress");
            // (event, bytes to drop, need more input)
            let (event, drop, more) = match dec.decode(&buf) {
                Ok(Status::Complete { item, consumed, .. }) => {
                    assert!(consumed > 0, "a complete message uses bytes");
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
        assert!(
            buf.len() <= bound,
            "{} bytes held, bound {bound}",
            buf.len()
        );
        assert_eq!(
            dec.position() + buf.len() as u64,
            start as u64,
            "position tracks the stream"
        );
    }
    match dec.decode_eof(&buf) {
        Ok(Some((item, _))) => events.push(Event::Item(format!("{item:?}"))),
        Ok(None) => {}
        Err(e) => events.push(Event::Error(e.kind(), e.offset())),
    }
    events
}

/// Whole, one byte at a time, and the given cuts must agree.
pub fn check<D>(make: impl Fn() -> D, input: &[u8], cuts: &[usize], bound: usize)
where
    D: Decode,
    for<'a> D::Item<'a>: Debug,
{
    let whole = feed(make(), input, &[], usize::MAX);
    let bytewise: Vec<usize> = (1..input.len()).collect();
    prop_assert_eq_hack(&whole, &feed(make(), input, &bytewise, bound));
    prop_assert_eq_hack(&whole, &feed(make(), input, cuts, bound));
}

pub fn prop_assert_eq_hack(a: &[Event], b: &[Event]) {
    assert_eq!(a, b);
}
