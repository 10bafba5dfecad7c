//! Criterion throughput of every codec next to what users would otherwise use, on the same
//! bytes. `cargo bench --bench codecs` (add `-- --quick` for the fast mode).

mod common;

use std::hint::black_box;
use std::time::Duration;

use common::*;
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};

fn float_decode(c: &mut Criterion) {
    let stream = pose_stream(10_000);
    let tokens = pre_split_tokens(&stream);
    let mut g = c.benchmark_group("float_decode_10k_poses");
    g.throughput(Throughput::Bytes(stream.len() as u64));
    g.bench_function("ours", |b| b.iter(|| ours_floats(black_box(&stream))));
    g.bench_function("naive_split_parse", |b| {
        b.iter(|| naive_floats(black_box(&stream)))
    });
    g.bench_function("nom_reparse_64B_chunks", |b| {
        b.iter(|| nom_reparse(black_box(&stream), 64))
    });
    g.bench_function("floor_pre_split_parse", |b| {
        b.iter(|| floor_parse(black_box(&tokens)))
    });
    g.finish();
    let mut g = c.benchmark_group("float_decode_10k_poses_messages");
    g.throughput(Throughput::Elements(10_000));
    g.bench_function("ours", |b| b.iter(|| ours_floats(black_box(&stream))));
    g.finish();
}

fn float_encode(c: &mut Criterion) {
    let poses = poses(10_000);
    let mut out = Vec::with_capacity(1 << 20);
    ours_encode(&poses, &mut out);
    let mut g = c.benchmark_group("float_encode_10k_poses");
    g.throughput(Throughput::Bytes(out.len() as u64));
    g.bench_function("ours", |b| {
        b.iter(|| ours_encode(black_box(&poses), &mut out))
    });
    g.bench_function("write_display", |b| {
        b.iter(|| write_encode(black_box(&poses), &mut out))
    });
    g.finish();
}

fn int32(c: &mut Criterion) {
    let stream = int32_stream(100_000);
    let mut g = c.benchmark_group("int32_external_control_100k");
    g.throughput(Throughput::Bytes(stream.len() as u64));
    g.bench_function("ours", |b| b.iter(|| ours_int32(black_box(&stream))));
    g.bench_function("ours_runtime_number", |b| {
        b.iter(|| ours_int32_runtime_number(black_box(&stream)))
    });
    g.bench_function("chunks_exact", |b| {
        b.iter(|| chunks_exact_int32(black_box(&stream)))
    });
    g.finish();
}

fn lines(c: &mut Criterion) {
    let stream = line_stream(100_000);
    let mut g = c.benchmark_group("lines_100k");
    g.throughput(Throughput::Bytes(stream.len() as u64));
    g.bench_function("ours", |b| b.iter(|| ours_lines(black_box(&stream))));
    g.bench_function("tokio_util_LinesCodec", |b| {
        b.iter(|| lines_codec(black_box(&stream)))
    });
    g.bench_function("BufRead_read_until", |b| {
        b.iter(|| read_until(black_box(&stream)))
    });
    g.bench_function("floor_memchr_iter", |b| {
        b.iter(|| memchr_floor(black_box(&stream)))
    });
    g.finish();
}

fn chunking(c: &mut Criterion) {
    let poses = pose_stream(10_000);
    let lines = line_stream(20_000);
    let mut g = c.benchmark_group("chunking");
    g.throughput(Throughput::Bytes(poses.len() as u64));
    g.bench_function(BenchmarkId::new("float_decode", "whole"), |b| {
        b.iter(|| ours_floats(black_box(&poses)))
    });
    for size in [1usize, 7, 64, 4096] {
        g.bench_function(BenchmarkId::new("float_decode", size), |b| {
            b.iter(|| ours_floats_chunked(black_box(&poses), size))
        });
    }
    g.throughput(Throughput::Bytes(lines.len() as u64));
    g.bench_function(BenchmarkId::new("lines", "whole"), |b| {
        b.iter(|| ours_lines(black_box(&lines)))
    });
    for size in [1usize, 7, 64, 4096] {
        g.bench_function(BenchmarkId::new("lines", size), |b| {
            b.iter(|| ours_lines_chunked(black_box(&lines), size))
        });
    }
    g.finish();
}

fn growth(c: &mut Criterion) {
    let mut g = c.benchmark_group("growth_float_decode");
    g.sample_size(10);
    for mb in [1usize, 10] {
        let stream = pose_stream((mb << 20) / 64);
        g.throughput(Throughput::Bytes(stream.len() as u64));
        g.bench_function(BenchmarkId::from_parameter(format!("{mb}MB")), |b| {
            b.iter(|| ours_floats(black_box(&stream)))
        });
    }
    g.finish();
}

fn config() -> Criterion {
    Criterion::default()
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(1))
        .sample_size(20)
}

criterion_group! {
    name = benches;
    config = config();
    targets = float_decode, float_encode, int32, lines, chunking, growth
}
criterion_main!(benches);
