//! A tokio server handling many robots at once: each robot sends `pose?` lines
//! (`socket_send_line`) and reads the answer with `socket_read_ascii_float(6)`.
//! The server uses the crate's `tokio_util` codecs; the robots are the async robot
//! emulation. Everything runs over 127.0.0.1 in one process.
//!
//! Run: `cargo run --example tokio_many_robots --features tokio`
//!
//! Copied into a project of its own, it needs (`futures-util` is a dev-dependency here;
//! its `SinkExt::send` and `StreamExt::next` drive the `Framed`):
//!
//! ```toml
//! [dependencies]
//! urscript-socket = { version = "0.1", features = ["tokio"] }
//! tokio = { version = "1", features = ["full"] }
//! tokio-util = { version = "0.7", features = ["codec"] }
//! futures-util = { version = "0.3", features = ["sink"] }
//! ```

use std::error::Error;

use futures_util::{SinkExt, StreamExt};
use tokio::net::TcpListener;
use tokio_util::codec::Framed;
use urscript_socket::adapters::tokio_codec::{
    AsyncRobotSocket, FloatTupleCodec, LineCodec, RequestReply, Tolerant,
};
use urscript_socket::robot::{Policy, ReadCall, ReadResult, Timeout};

const ROBOTS: usize = 20;
const REQUESTS: usize = 50;

fn pose_for(n: i32) -> [f64; 6] {
    [f64::from(n) * 0.001, 0.5, -0.25, 0.0, 3.0, 0.0]
}

#[tokio::main]
async fn main() -> Result<(), Box<dyn Error>> {
    let listener = TcpListener::bind("127.0.0.1:0").await?;
    let addr = listener.local_addr()?;
    tokio::spawn(async move {
        while let Ok((stream, _)) = listener.accept().await {
            tokio::spawn(async move {
                // One Framed: lines in, tuples out; a bad line is reported, not fatal.
                let codec =
                    RequestReply::new(Tolerant::new(LineCodec::new()), FloatTupleCodec::new(6)?);
                let mut framed = Framed::new(stream, codec);
                while let Some(line) = framed.next().await {
                    let Ok(line) = line? else { continue };
                    // "pose? N" asks for the pose of part N.
                    let n: i32 = std::str::from_utf8(&line)
                        .ok()
                        .and_then(|s| s.strip_prefix("pose? "))
                        .and_then(|n| n.parse().ok())
                        .unwrap_or(-1);
                    framed.send(pose_for(n)).await?;
                }
                Ok::<_, Box<dyn Error + Send + Sync>>(())
            });
        }
    });

    let mut robots = Vec::new();
    for id in 0..ROBOTS {
        robots.push(tokio::spawn(async move {
            let mut robot = AsyncRobotSocket::connect(addr, "camera", Policy::default()).await?;
            for i in 0..REQUESTS {
                let n = (id * REQUESTS + i) as i32;
                robot.socket().send_line(format!("pose? {n}").as_bytes());
                let r = robot
                    .read(
                        ReadCall::AsciiFloat { number: 6 },
                        Timeout::from_secs_f64(5.0),
                    )
                    .await?;
                match r {
                    ReadResult::Floats(t) if t.count() == 6 && t.values() == pose_for(n) => {}
                    other => return Err(format!("robot {id}: unexpected {other}").into()),
                }
            }
            Ok::<usize, Box<dyn Error + Send + Sync>>(REQUESTS)
        }));
    }
    let mut total = 0;
    for r in robots {
        total += r.await?.map_err(|e| e.to_string())?;
    }
    println!("{ROBOTS} robots, {total} request/reply exchanges, all matched");
    Ok(())
}
