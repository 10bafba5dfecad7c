//! The tokio server of the rustdoc front page, run against the crate's async robot
//! emulation over 127.0.0.1: one `Framed` with `RequestReply` (lines in, float tuples
//! out) and `Tolerant` (a bad line is reported, the connection goes on). The robot sends
//! an over-long line before each request; every request is still answered.
//!
//! Run: `cargo run --example tokio_front_page --features tokio`
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

// 3.14 is a pose angle here, not π.
#![allow(clippy::approx_constant)]

use futures_util::{SinkExt, StreamExt};
use tokio::net::TcpListener;
use tokio_util::codec::Framed;
use urscript_socket::adapters::tokio_codec::{
    AsyncRobotSocket, FloatTupleCodec, LineCodec, RequestReply, Tolerant,
};
use urscript_socket::robot::{Policy, ReadCall, Timeout};

/// The front page's server, from `let listener` on (bound to an ephemeral port on
/// 127.0.0.1, the accept loop in a task). `tests/frontpage_server.rs` runs this one too.
pub async fn front_page_server() -> std::io::Result<std::net::SocketAddr> {
    let listener = TcpListener::bind("127.0.0.1:0").await?;
    let addr = listener.local_addr()?;
    tokio::spawn(async move {
        loop {
            let (robot, peer) = listener.accept().await?; // the robot's socket_open
            tokio::spawn(async move {
                let codec =
                    RequestReply::new(Tolerant::new(LineCodec::new()), FloatTupleCodec::new(6)?);
                let mut framed = Framed::new(robot, codec);
                while let Some(request) = framed.next().await {
                    match request? {
                        Ok(line) if line == "shoot" => {
                            framed.send([0.4, -0.2, 0.3, 0.0, 3.14, 0.0]).await?;
                        }
                        Ok(line) => eprintln!("server: {peer}: unknown request {line:?}"),
                        Err(bad) => println!("server: skipped {bad}"), // the stream goes on
                    }
                }
                Ok::<_, Box<dyn std::error::Error + Send + Sync>>(())
            });
        }
        #[allow(unreachable_code)]
        Ok::<_, std::io::Error>(())
    });
    Ok(addr)
}

#[tokio::main]
async fn main() -> Result<(), Box<dyn std::error::Error>> {
    let addr = front_page_server().await?;

    // The robot: socket_send_line(<5000 x's>), socket_send_line("shoot"),
    // pose = socket_read_ascii_float(6), three times.
    let mut robot = AsyncRobotSocket::connect(addr, "camera", Policy::default()).await?;
    for _ in 0..3 {
        robot.socket().send_line(&[b'x'; 5000]);
        robot.socket().send_line(b"shoot");
        let pose = robot
            .read(
                ReadCall::AsciiFloat { number: 6 },
                Timeout::from_secs_f64(5.0),
            )
            .await?;
        println!(
            "robot:  pose = socket_read_ascii_float(6) -> {}",
            pose.to_urscript()
        );
        if pose.is_sentinel() {
            return Err("the server stopped answering".into());
        }
    }
    Ok(())
}
