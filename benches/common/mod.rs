//! Inputs and baselines shared by the benches: what a server writer would otherwise use,
//! measured on the same bytes as ours.
#![allow(dead_code)]

use std::hint::black_box;
use std::io::BufRead;

use bytes::BytesMut;
use urscript_socket::ascii_float::{encode_float_tuple, FloatTupleDecoder};
use urscript_socket::int32::Int32Decoder;
use urscript_socket::line::LineDecoder;
use urscript_socket::{RecvBuffer, Status};

/// `n` six-value poses like `(-0.123456,0.5,...)\n`, values varied and realistic.
pub fn pose_stream(n: usize) -> Vec<u8> {
    let mut out = Vec::with_capacity(n * 64);
    let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
    for _ in 0..n {
        let mut pose = [0.0; 6];
        for v in &mut pose {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            // Six decimals, as vision systems send: -3.141593 .. 3.141593
            *v = ((x % 6_283_186) as f64 - 3_141_593.0) / 1e6;
        }
        encode_float_tuple(&pose, true, &mut out).unwrap();
    }
    out
}

/// Ours: the robot-side decoder over the whole stream. Returns (tuples, checksum). Out of
/// line so that callgrind can count it alone.
#[inline(never)]
pub fn ours_floats(stream: &[u8]) -> (usize, f64) {
    let mut d = FloatTupleDecoder::new(6).unwrap();
    let (mut n, mut sum, mut rest) = (0, 0.0, stream);
    while let Ok(Status::Complete { item, consumed, .. }) = d.decode(rest) {
        n += 1;
        sum += item.values()[0];
        rest = &rest[consumed..];
    }
    (n, sum)
}

/// Ours, fed `chunk` bytes at a time through a bounded `RecvBuffer`.
pub fn ours_floats_chunked(stream: &[u8], chunk: usize) -> (usize, f64) {
    let mut d = FloatTupleDecoder::new(6).unwrap();
    let mut rx = RecvBuffer::with_capacity(64 * 1024);
    let (mut n, mut sum) = (0, 0.0);
    for piece in stream.chunks(chunk) {
        rx.extend(piece);
        while let Ok(Some(t)) = rx.decode(&mut d) {
            n += 1;
            sum += t.values()[0];
        }
    }
    (n, sum)
}

/// (a) The naive way: lines, `from_utf8`, trim the parentheses, `split(',')`, parse.
pub fn naive_floats(stream: &[u8]) -> (usize, f64) {
    let (mut n, mut sum) = (0, 0.0);
    for line in stream.split(|&b| b == b'\n') {
        let Ok(text) = std::str::from_utf8(line) else {
            continue;
        };
        let text = text.trim();
        let Some(inner) = text.strip_prefix('(').and_then(|t| t.strip_suffix(')')) else {
            continue;
        };
        let values: Vec<f64> = inner
            .split(',')
            .filter_map(|t| t.trim().parse().ok())
            .collect();
        if values.len() == 6 {
            n += 1;
            sum += values[0];
        }
    }
    (n, sum)
}

fn nom_tuple(input: &[u8]) -> nom::IResult<&[u8], Vec<f64>> {
    use nom::bytes::streaming::tag;
    use nom::character::streaming::{multispace0, space0};
    use nom::multi::separated_list1;
    use nom::number::streaming::double;
    use nom::sequence::{delimited, preceded};
    use nom::Parser;
    preceded(
        multispace0,
        delimited(
            tag(&b"("[..]),
            separated_list1(tag(&b","[..]), delimited(space0, double, space0)),
            tag(&b")"[..]),
        ),
    )
    .parse(input)
}

/// (b) A nom streaming parser re-run from the start of the buffer on every new chunk.
pub fn nom_reparse(stream: &[u8], chunk: usize) -> (usize, f64) {
    let (mut n, mut sum) = (0, 0.0);
    let mut buf: Vec<u8> = Vec::new();
    for piece in stream.chunks(chunk) {
        buf.extend_from_slice(piece);
        while let Ok((rest, values)) = nom_tuple(&buf) {
            n += 1;
            sum += values[0];
            let used = buf.len() - rest.len();
            buf.drain(..used);
        }
    }
    (n, sum)
}

/// (c) The floor: the tokens, already split, through `str::parse::<f64>` alone.
pub fn pre_split_tokens(stream: &[u8]) -> Vec<String> {
    let text = std::str::from_utf8(stream).unwrap();
    text.split(['(', ')', ',', '\n'])
        .filter(|t| !t.is_empty())
        .map(String::from)
        .collect()
}

pub fn floor_parse(tokens: &[String]) -> (usize, f64) {
    let mut sum = 0.0;
    for t in tokens {
        sum += t.parse::<f64>().unwrap_or(0.0);
    }
    (tokens.len() / 6, sum)
}

/// External Control style: `n` messages of 8 big-endian int32.
pub fn int32_stream(n: usize) -> Vec<u8> {
    let mut out = Vec::with_capacity(n * 32);
    for i in 0..n {
        for k in 0..8 {
            out.extend_from_slice(
                &((i as i32).wrapping_mul(2654435761u32 as i32) ^ k).to_be_bytes(),
            );
        }
    }
    out
}

/// Ours: an `Int32Decoder::new(8)` built where it is used, so the compiler sees the
/// message length (32 bytes) as a constant. Out of line here and below so that callgrind can
/// count each loop alone (`--toggle-collect='*ours_int32'`); one call per pass.
#[inline(never)]
pub fn ours_int32(stream: &[u8]) -> i64 {
    int32_sum(Int32Decoder::new(8).unwrap(), stream)
}

/// Ours with a message length known only at run time (a decoder kept in a struct, or built
/// from configuration): the same loop over `Int32Values::iter`.
#[inline(never)]
pub fn ours_int32_runtime_number(stream: &[u8]) -> i64 {
    int32_sum(Int32Decoder::new(black_box(8)).unwrap(), stream)
}

#[inline(always)]
fn int32_sum(mut d: Int32Decoder, stream: &[u8]) -> i64 {
    let (mut sum, mut rest) = (0i64, stream);
    while let Ok(Status::Complete { item, consumed, .. }) = d.decode(rest) {
        for v in item.iter() {
            sum += i64::from(v);
        }
        rest = &rest[consumed..];
    }
    sum
}

#[inline(never)]
pub fn chunks_exact_int32(stream: &[u8]) -> i64 {
    let mut sum = 0i64;
    for msg in stream.chunks_exact(32) {
        for b in msg.chunks_exact(4) {
            sum += i64::from(i32::from_be_bytes([b[0], b[1], b[2], b[3]]));
        }
    }
    sum
}

/// Lines like a robot's `socket_send_line` traffic.
pub fn line_stream(n: usize) -> Vec<u8> {
    let mut out = Vec::with_capacity(n * 40);
    for i in 0..n {
        out.extend_from_slice(format!("p[{i}, 0.25, -0.5, 0, 3.1, {}]\n", i % 97).as_bytes());
    }
    out
}

pub fn ours_lines(stream: &[u8]) -> (usize, usize) {
    let mut d = LineDecoder::new();
    let (mut n, mut bytes, mut rest) = (0, 0, stream);
    while let Ok(Status::Complete { item, consumed, .. }) = d.decode(rest) {
        n += 1;
        bytes += item.len();
        rest = &rest[consumed..];
    }
    (n, bytes)
}

pub fn ours_lines_chunked(stream: &[u8], chunk: usize) -> (usize, usize) {
    let mut d = LineDecoder::new();
    let mut rx = RecvBuffer::with_capacity(64 * 1024);
    let (mut n, mut bytes) = (0, 0);
    for piece in stream.chunks(chunk) {
        rx.extend(piece);
        while let Ok(Some(l)) = rx.decode(&mut d) {
            n += 1;
            bytes += l.len();
        }
    }
    (n, bytes)
}

pub fn lines_codec(stream: &[u8]) -> (usize, usize) {
    use tokio_util::codec::Decoder;
    let mut codec = tokio_util::codec::LinesCodec::new();
    let mut buf = BytesMut::from(stream);
    let (mut n, mut bytes) = (0, 0);
    while let Ok(Some(line)) = codec.decode(&mut buf) {
        n += 1;
        bytes += line.len();
    }
    (n, bytes)
}

pub fn read_until(stream: &[u8]) -> (usize, usize) {
    let mut r = std::io::BufReader::new(stream);
    let mut line = Vec::new();
    let (mut n, mut bytes) = (0, 0);
    while r.read_until(b'\n', &mut line).unwrap_or(0) > 0 {
        n += 1;
        bytes += line.len() - 1;
        line.clear();
    }
    (n, bytes)
}

pub fn memchr_floor(stream: &[u8]) -> (usize, usize) {
    let (mut n, mut bytes, mut start) = (0, 0, 0);
    for end in memchr::memchr_iter(b'\n', stream) {
        let line = &stream[start..end];
        n += 1;
        bytes += line.len();
        start = end + 1;
    }
    (n, bytes)
}

/// Poses to encode.
pub fn poses(n: usize) -> Vec<[f64; 6]> {
    let stream = pose_stream(n);
    let mut d = FloatTupleDecoder::new(6).unwrap();
    let mut rest = &stream[..];
    let mut out = Vec::new();
    while let Ok(Status::Complete { item, consumed, .. }) = d.decode(rest) {
        let mut p = [0.0; 6];
        p.copy_from_slice(item.values());
        out.push(p);
        rest = &rest[consumed..];
    }
    out
}

pub fn ours_encode(poses: &[[f64; 6]], out: &mut Vec<u8>) {
    out.clear();
    for p in poses {
        encode_float_tuple(p, true, out).unwrap();
    }
}

pub fn write_encode(poses: &[[f64; 6]], out: &mut Vec<u8>) {
    use std::io::Write;
    out.clear();
    for p in poses {
        writeln!(
            out,
            "({},{},{},{},{},{})",
            p[0], p[1], p[2], p[3], p[4], p[5]
        )
        .unwrap();
    }
}
