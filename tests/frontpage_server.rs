//! The tokio server of the rustdoc front page (`src/lib.rs`), as the `tokio_front_page`
//! example holds it (only the address is 127.0.0.1:0 and the accept loop runs in a task), against robots
//! over 127.0.0.1. Proof that what a new user copies survives an over-long line and a
//! malformed one and keeps answering, on one `Framed` with request/reply and tolerant mode.

// The front page uses 3.14 as data (a pose angle), not as π.
#![allow(clippy::approx_constant)]

use std::time::Duration;

use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;
use urscript_socket::adapters::tokio_codec::AsyncRobotSocket;
use urscript_socket::robot::{Policy, ReadCall, ReadResult, Timeout};

// The front page's server lives in the example CI runs; this test drives the same code.
#[path = "../examples/tokio_front_page.rs"]
#[allow(dead_code)]
mod example;
use example::front_page_server;

const POSE: [f64; 6] = [0.4, -0.2, 0.3, 0.0, 3.14, 0.0];

#[tokio::test]
async fn survives_an_over_long_line_and_keeps_answering() {
    let addr = front_page_server().await.unwrap();
    let mut robot = AsyncRobotSocket::connect(addr, "camera", Policy::default())
        .await
        .unwrap();
    let over_long = vec![b'x'; 100_000]; // 25 x the codec's 4096-byte bound
    for round in 0..5 {
        robot.socket().send_line(&over_long);
        robot.socket().send_line(b"shoot");
        let r = robot
            .read(
                ReadCall::AsciiFloat { number: 6 },
                Timeout::from_secs_f64(5.0),
            )
            .await
            .unwrap();
        match r {
            ReadResult::Floats(t) => {
                assert_eq!(t.count(), 6, "round {round}: {t:?}");
                assert_eq!(t.values(), POSE);
            }
            other => panic!("round {round}: {other:?}"),
        }
    }
}

#[tokio::test]
async fn raw_bytes_exact_reply_and_several_robots() {
    let addr = front_page_server().await.unwrap();
    let mut tasks = Vec::new();
    for id in 0..8 {
        tasks.push(tokio::spawn(async move {
            let mut s = TcpStream::connect(addr).await.unwrap();
            // Over-long line written in pieces, an unknown request, invalid UTF-8, then
            // the real request split across writes.
            for _ in 0..10 {
                s.write_all(&[b'y'; 1000]).await.unwrap();
            }
            s.write_all(b"\nhello\n\xFF\xFE\nsho").await.unwrap();
            tokio::time::sleep(Duration::from_millis(5 * id)).await;
            s.write_all(b"ot\n").await.unwrap();
            let expected = b"(0.4,-0.2,0.3,0,3.14,0)";
            let mut reply = vec![0u8; expected.len()];
            tokio::time::timeout(Duration::from_secs(5), s.read_exact(&mut reply))
                .await
                .expect("the server answers after the over-long line")
                .unwrap();
            assert_eq!(reply, expected, "no LF after the tuple");
            // Still answering on the same connection.
            s.write_all(b"shoot\nshoot\n").await.unwrap();
            let mut two = vec![0u8; 2 * expected.len()];
            s.read_exact(&mut two).await.unwrap();
            assert_eq!(&two[..expected.len()], expected);
            assert_eq!(&two[expected.len()..], expected);
        }));
    }
    for t in tasks {
        t.await.unwrap();
    }
}
