//! Parsing speed on large programs (issue 18): lexing and parsing are linear in the
//! program's length, however long its lines, and interning names is not quadratic.
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use urscript_interp::Program;

/// About `bytes` of ordinary statements, many lines.
fn many_lines(bytes: usize) -> String {
    let block = "def step_{i}(a, b=2):\n  x = [a, b, 3.5] # a comment\n  if x[0] > 1 and b != 3:\n    textmsg(\"value \", x[1] * 2 + a / 4)\n  end\n  return x\nend\ny_{i} = step_{i}({i})\n";
    let mut out = String::with_capacity(bytes + block.len() * 2);
    let mut i = 0;
    while out.len() < bytes {
        out.push_str(&block.replace("{i}", &i.to_string()));
        i += 1;
    }
    out
}

/// One line of about `bytes`: a list literal of numbers and strings.
fn one_line(bytes: usize) -> String {
    let mut out = String::from("x = [");
    while out.len() < bytes {
        out.push_str("1.5, \"é\", 42,   ");
    }
    out.push_str("0]\n");
    out
}

fn parse(c: &mut Criterion) {
    let mut g = c.benchmark_group("parse");
    g.sample_size(10);
    let big = many_lines(10 * 1024 * 1024);
    g.throughput(Throughput::Bytes(big.len() as u64));
    g.bench_function("program_10mb", |b| b.iter(|| Program::parse(&big).unwrap()));
    let line = one_line(1024 * 1024);
    g.throughput(Throughput::Bytes(line.len() as u64));
    g.bench_function("line_1mb", |b| b.iter(|| Program::parse(&line).unwrap()));
    let spaces = format!("x = 1{}\n", " ".repeat(1024 * 1024));
    g.throughput(Throughput::Bytes(spaces.len() as u64));
    g.bench_function("spaces_1mb", |b| {
        b.iter(|| Program::parse(&spaces).unwrap())
    });
    let names: String = (0..200_000).map(|i| format!("f{i}()\n")).collect();
    g.throughput(Throughput::Elements(200_000));
    g.bench_function("distinct_names_200k", |b| {
        b.iter(|| Program::parse(&names).unwrap())
    });
    g.finish();
}

criterion_group!(benches, parse);
criterion_main!(benches);
