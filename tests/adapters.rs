//! The adapters over real sockets on 127.0.0.1: fragmentation, coalescing, peers that
//! close mid-message or never send a terminator, and many concurrent robots.

use std::io::Write;
use std::net::{TcpListener, TcpStream};
use std::time::{Duration, Instant};

use futures_util::{SinkExt, StreamExt};
use urscript_socket::adapters::blocking::{MessageReader, ReadError};
use urscript_socket::adapters::tokio_codec::{AsyncRobotSocket, FloatTupleCodec, LineCodec};
use urscript_socket::byte_list::ByteListDecoder;
use urscript_socket::int32::Int32Decoder;
use urscript_socket::line::LineDecoder;
use urscript_socket::robot::{Policy, ReadCall, ReadResult, Timeout};
use urscript_socket::string::DelimitedDecoder;
use urscript_socket::stx_etx::StxEtxDecoder;
use urscript_socket::var::VarMessageDecoder;
use urscript_socket::{Decode, ErrorKind, Status};

/// Decodes `bytes` in one call per message: the unit-level reference.
fn unit_decode<D: Decode>(mut d: D, bytes: &[u8]) -> Vec<String>
where
    for<'a> D::Item<'a>: std::fmt::Debug,
{
    let mut out = Vec::new();
    let mut rest = bytes;
    loop {
        let (item, used) = match d.decode(rest).unwrap() {
            Status::Complete { item, consumed, .. } => (format!("{item:?}"), consumed),
            Status::Partial { .. } => break,
        };
        out.push(item);
        rest = &rest[used..];
    }
    out
}

/// Sends `bytes` to a `MessageReader` over TCP, written as `chunk`-byte writes with a
/// flush and a pause between them, and returns the decoded messages.
fn over_tcp<D: Decode + Send + 'static>(d: D, bytes: Vec<u8>, chunk: usize) -> Vec<String>
where
    for<'a> D::Item<'a>: std::fmt::Debug,
{
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap();
    let writer = std::thread::spawn(move || {
        let mut s = TcpStream::connect(addr).unwrap();
        s.set_nodelay(true).unwrap();
        for (i, part) in bytes.chunks(chunk).enumerate() {
            s.write_all(part).unwrap();
            s.flush().unwrap();
            if chunk == 1 && i % 16 == 0 {
                std::thread::sleep(Duration::from_micros(200));
            }
        }
    });
    let (stream, _) = listener.accept().unwrap();
    let mut reader = MessageReader::new(stream, d);
    let mut out = Vec::new();
    while let Some(item) = reader.next_with(|i| format!("{i:?}")).unwrap() {
        out.push(item);
    }
    writer.join().unwrap();
    out
}

fn streams() -> Vec<(&'static str, Vec<u8>)> {
    let mut ints = Vec::new();
    for v in [0, 1, -1, i32::MAX, i32::MIN, 123456] {
        ints.extend_from_slice(&v.to_be_bytes());
    }
    vec![
        ("int32", ints),
        ("bytes", vec![2, 3, 10, 13, 0, 255]),
        (
            "lines",
            b"hello\nreply from the server:\r\n\nlast\n".to_vec(),
        ),
        ("stx", b"\x02hi\x03\x02\x03\x02p[1, 2]\x03".to_vec()),
        ("delimited", b"OK,1<>NEXT<><>".to_vec()),
        ("var", b"SET POS_Y 2200\nGET POS_X\nSET A -1\n".to_vec()),
    ]
}

fn check_all(chunk: usize) {
    for (name, bytes) in streams() {
        let (unit, tcp) = match name {
            "int32" => (
                unit_decode(Int32Decoder::single(), &bytes),
                over_tcp(Int32Decoder::single(), bytes, chunk),
            ),
            "bytes" => (
                unit_decode(ByteListDecoder::single(), &bytes),
                over_tcp(ByteListDecoder::single(), bytes, chunk),
            ),
            "lines" => (
                unit_decode(LineDecoder::new(), &bytes),
                over_tcp(LineDecoder::new(), bytes, chunk),
            ),
            "stx" => (
                unit_decode(StxEtxDecoder::new(), &bytes),
                over_tcp(StxEtxDecoder::new(), bytes, chunk),
            ),
            "delimited" => {
                let d = || DelimitedDecoder::new(b"<>").unwrap();
                (unit_decode(d(), &bytes), over_tcp(d(), bytes, chunk))
            }
            _ => (
                unit_decode(VarMessageDecoder::new(), &bytes),
                over_tcp(VarMessageDecoder::new(), bytes, chunk),
            ),
        };
        assert!(!unit.is_empty(), "{name}");
        assert_eq!(unit, tcp, "{name} in {chunk}-byte writes");
    }
}

#[test]
fn fragmentation_one_byte_writes_match_unit_decode() {
    check_all(1);
}

#[test]
fn coalescing_thousands_of_messages_in_one_write() {
    let mut bytes = Vec::new();
    for i in 0..5000 {
        bytes.extend_from_slice(format!("SET V{i} {i}\n").as_bytes());
    }
    let unit = unit_decode(VarMessageDecoder::new(), &bytes);
    assert_eq!(unit.len(), 5000);
    assert_eq!(
        over_tcp(VarMessageDecoder::new(), bytes.clone(), bytes.len()),
        unit
    );
    check_all(1 << 20);
}

#[test]
fn peer_closing_mid_message_delivers_what_was_complete() {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap();
    let w = std::thread::spawn(move || {
        let mut s = TcpStream::connect(addr).unwrap();
        s.write_all(b"one\ntwo\nthr").unwrap();
    });
    let (stream, _) = listener.accept().unwrap();
    w.join().unwrap();
    let mut r = MessageReader::new(stream, LineDecoder::new());
    assert_eq!(r.next_with(|l| l.to_vec()).unwrap(), Some(b"one".to_vec()));
    assert_eq!(r.next_with(|l| l.to_vec()).unwrap(), Some(b"two".to_vec()));
    match r.next_with(|l| l.to_vec()) {
        Err(ReadError::Decode(e)) => assert_eq!((e.kind(), e.offset()), (ErrorKind::Truncated, 8)),
        other => panic!("expected a truncation error, got {other:?}"),
    }
    assert_eq!(r.next_with(|l| l.to_vec()).unwrap(), None);
}

#[test]
fn endless_message_hits_the_bound_and_memory_stays_bounded() {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap();
    // A hostile peer: 8 MB and no LF, then one good line.
    let w = std::thread::spawn(move || {
        let mut s = TcpStream::connect(addr).unwrap();
        let junk = vec![b'x'; 64 * 1024];
        for _ in 0..128 {
            if s.write_all(&junk).is_err() {
                return;
            }
        }
        let _ = s.write_all(b"\nok\n");
    });
    let (stream, _) = listener.accept().unwrap();
    let capacity = 8 * 1024;
    let mut r = MessageReader::with_capacity(stream, LineDecoder::with_max_len(1024), capacity);
    let mut errors = 0;
    let got = loop {
        match r.next_with(|l| l.to_vec()) {
            Ok(Some(line)) => break line,
            Ok(None) => panic!("closed before the good line"),
            Err(ReadError::Decode(e)) => {
                assert_eq!(e.kind(), ErrorKind::TooLong { limit: 1024 });
                assert_eq!(e.offset(), 1024);
                errors += 1;
            }
            Err(e) => panic!("{e}"),
        }
        assert!(r.buffered().len() <= capacity);
    };
    assert_eq!(errors, 1, "one error for one over-long line");
    assert_eq!(got, b"ok");
    w.join().unwrap();
}

#[test]
fn read_timeout_is_distinguishable_and_resumable() {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap();
    let mut client = TcpStream::connect(addr).unwrap();
    let (stream, _) = listener.accept().unwrap();
    stream
        .set_read_timeout(Some(Duration::from_millis(50)))
        .unwrap();
    let mut r = MessageReader::new(stream, LineDecoder::new());
    client.write_all(b"hal").unwrap();
    assert!(matches!(
        r.next_with(|l| l.to_vec()),
        Err(ReadError::TimedOut)
    ));
    client.write_all(b"f\n").unwrap();
    assert_eq!(r.next_with(|l| l.to_vec()).unwrap(), Some(b"half".to_vec()));
}

/// 200 concurrent async robots, 1,000 request/reply exchanges each, against one tokio
/// server built from the codecs. Prints the exchange rate (a figure, not a pass
/// condition). Set `URSOCK_LOAD_EXCHANGES` to change the per-robot count.
#[test]
fn load_200_robots() {
    let per_robot: usize = std::env::var("URSOCK_LOAD_EXCHANGES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1000);
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .unwrap();
    rt.block_on(async move {
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
        let addr = listener.local_addr().unwrap();
        tokio::spawn(async move {
            while let Ok((stream, _)) = listener.accept().await {
                tokio::spawn(async move {
                    let (r, w) = stream.into_split();
                    let mut req = tokio_util::codec::FramedRead::new(r, LineCodec::new());
                    let mut rep =
                        tokio_util::codec::FramedWrite::new(w, FloatTupleCodec::new(2).unwrap());
                    while let Some(Ok(line)) = req.next().await {
                        let n: f64 = std::str::from_utf8(&line).unwrap().parse().unwrap();
                        if rep.send(&[n, -n][..]).await.is_err() {
                            return;
                        }
                    }
                });
            }
        });
        let start = Instant::now();
        let mut robots = Vec::new();
        for id in 0..200usize {
            robots.push(tokio::spawn(async move {
                let mut robot = AsyncRobotSocket::connect(addr, "socket_0", Policy::default())
                    .await
                    .unwrap();
                for i in 0..per_robot {
                    let n = (id * per_robot + i) as f64 * 0.5;
                    robot.socket().send_line(n.to_string().as_bytes());
                    let r = robot
                        .read(
                            ReadCall::AsciiFloat { number: 2 },
                            Timeout::from_secs_f64(30.0),
                        )
                        .await
                        .unwrap();
                    match r {
                        ReadResult::Floats(t) => {
                            assert_eq!((t.count(), t.values()), (2, &[n, -n][..]))
                        }
                        other => panic!("{other}"),
                    }
                }
                per_robot
            }));
        }
        let mut total = 0;
        for r in robots {
            total += r.await.unwrap();
        }
        let secs = start.elapsed().as_secs_f64();
        assert_eq!(total, 200 * per_robot);
        eprintln!(
            "load: {total} exchanges by 200 robots in {secs:.2} s = {:.0} exchanges/s",
            total as f64 / secs
        );
    });
}

/// `timeout=1e19` used to overflow `Instant + Duration` inside the async robot's read.
#[tokio::test]
async fn async_robot_huge_timeout_and_closed_peer() {
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = listener.local_addr().unwrap();
    let server = tokio::spawn(async move {
        use tokio::io::AsyncWriteExt;
        let (mut robot, _) = listener.accept().await.unwrap();
        robot.write_all(b"(1,2)").await.unwrap();
        // Then the server goes away.
    });
    let mut robot = AsyncRobotSocket::connect(addr, "socket_0", Policy::default())
        .await
        .unwrap();
    let r = robot
        .read(
            ReadCall::AsciiFloat { number: 2 },
            Timeout::from_secs_f64(1e19),
        )
        .await
        .unwrap();
    assert_eq!(r.to_urscript(), "[2, 1, 2]");
    server.await.unwrap();
    // Sends to the closed server: false once the write fails, never an error.
    let mut sent = Vec::new();
    for _ in 0..200 {
        robot.socket().send_line(b"x");
        sent.push(robot.flush().await.unwrap());
        tokio::time::sleep(Duration::from_millis(1)).await;
    }
    assert_eq!(sent.last(), Some(&false));
    let r = robot
        .read(ReadCall::Line, Timeout::from_secs_f64(1e19))
        .await
        .unwrap();
    assert_eq!(r.to_urscript(), "\"\"");
}
