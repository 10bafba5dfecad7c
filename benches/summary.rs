//! `cargo bench --bench summary`: every ratio target of the benchmark issue, measured in one
//! run on the same bytes, one line each: `name measured-ratio target met|missed`.
//! Best-of-N wall-clock timing; well under a minute.

mod common;

use std::hint::black_box;
use std::time::Instant;

use common::*;

/// Best time per call of `f`, in seconds, over `rounds` rounds of ~40 ms.
fn time<R>(mut f: impl FnMut() -> R) -> f64 {
    let mut reps = 1u32;
    loop {
        let t = Instant::now();
        for _ in 0..reps {
            black_box(f());
        }
        if t.elapsed().as_secs_f64() > 0.04 {
            break;
        }
        reps *= 2;
    }
    let mut best = f64::INFINITY;
    for _ in 0..9 {
        let t = Instant::now();
        for _ in 0..reps {
            black_box(f());
        }
        best = best.min(t.elapsed().as_secs_f64() / f64::from(reps));
    }
    best
}

struct Report {
    missed: usize,
}

impl Report {
    /// `ratio` = how many times faster ours is (baseline time / our time).
    fn at_least(&mut self, name: &str, ratio: f64, target: f64) {
        let met = ratio >= target;
        self.missed += usize::from(!met);
        println!(
            "{name:<44} {ratio:>7.2}x  >= {target:<5}  {}",
            if met { "met" } else { "missed" }
        );
    }

    fn within(&mut self, name: &str, ratio: f64, lo: f64, hi: f64) {
        let met = (lo..=hi).contains(&ratio);
        self.missed += usize::from(!met);
        println!(
            "{name:<44} {ratio:>7.2}x  {lo}-{hi}x  {}",
            if met { "met" } else { "missed" }
        );
    }
}

fn main() {
    if std::env::args().any(|a| a == "--list") {
        return; // `cargo bench -- --list` and test harness probes
    }
    let mut r = Report { missed: 0 };
    println!("{:<44} {:>8}  {:<7}  result", "name", "ratio", "target");

    // Float tuple decode: 10,000 six-value poses.
    let stream = pose_stream(10_000);
    let tokens = pre_split_tokens(&stream);
    assert_eq!(ours_floats(&stream).0, 10_000);
    assert_eq!(naive_floats(&stream), ours_floats(&stream));
    assert_eq!(nom_reparse(&stream, 64).0, 10_000);
    let ours = time(|| ours_floats(&stream));
    r.at_least(
        "float decode vs floor (pre-split str::parse)",
        time(|| floor_parse(&tokens)) / ours,
        1.0,
    );
    r.at_least(
        "float decode vs naive (split + parse)",
        time(|| naive_floats(&stream)) / ours,
        2.5,
    );
    r.at_least(
        "float decode vs nom re-parse, 64-byte chunks",
        time(|| nom_reparse(&stream, 64)) / ours,
        3.0,
    );

    // Float tuple encode.
    let poses = poses(10_000);
    let (mut a, mut b) = (Vec::with_capacity(1 << 20), Vec::with_capacity(1 << 20));
    ours_encode(&poses, &mut a);
    write_encode(&poses, &mut b);
    assert_eq!(a, b, "same text as {{}} for these values");
    let ours = time(|| ours_encode(&poses, &mut a));
    r.at_least(
        "float encode vs write! {}",
        time(|| write_encode(&poses, &mut b)) / ours,
        3.0,
    );

    // int32: External Control messages.
    let ints = int32_stream(100_000);
    assert_eq!(ours_int32(&ints), chunks_exact_int32(&ints));
    r.at_least(
        "int32 decode vs chunks_exact",
        time(|| chunks_exact_int32(&ints)) / time(|| ours_int32(&ints)),
        0.8,
    );
    assert_eq!(ours_int32_runtime_number(&ints), chunks_exact_int32(&ints));
    r.at_least(
        "int32, length known at run time, vs chunks_exact",
        time(|| chunks_exact_int32(&ints)) / time(|| ours_int32_runtime_number(&ints)),
        0.8,
    );

    // Lines.
    let lines = line_stream(100_000);
    assert_eq!(ours_lines(&lines), lines_codec(&lines));
    assert_eq!(ours_lines(&lines), memchr_floor(&lines));
    let ours = time(|| ours_lines(&lines));
    r.at_least(
        "lines vs tokio-util LinesCodec",
        time(|| lines_codec(&lines)) / ours,
        3.0,
    );
    r.at_least(
        "lines vs BufRead::read_until",
        time(|| read_until(&lines)) / ours,
        1.0,
    );
    r.at_least(
        "lines vs bare memchr_iter loop",
        time(|| memchr_floor(&lines)) / ours,
        0.5,
    );

    // Chunking: 64-byte pieces through RecvBuffer vs whole.
    r.at_least(
        "float decode 64-byte chunks vs whole",
        ours_time_ratio(|| ours_floats(&stream), || ours_floats_chunked(&stream, 64)),
        0.5,
    );
    r.at_least(
        "lines 64-byte chunks vs whole",
        ours_time_ratio(|| ours_lines(&lines), || ours_lines_chunked(&lines, 64)),
        0.5,
    );

    // Growth: 10 MB costs 9x-11x of 1 MB.
    let mb1 = pose_stream(1 << 20 >> 6);
    let mb10 = pose_stream(10 << 20 >> 6);
    r.within(
        "float decode 10 MB / 1 MB time",
        time(|| ours_floats(&mb10)) / time(|| ours_floats(&mb1)),
        9.0,
        11.0,
    );

    println!("{} target(s) missed", r.missed);
}

/// time(whole) / time(chunked): 1.0 means chunking costs nothing.
fn ours_time_ratio<R1, R2>(whole: impl FnMut() -> R1, chunked: impl FnMut() -> R2) -> f64 {
    time(whole) / time(chunked)
}
