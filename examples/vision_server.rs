//! A blocking vision server answering `socket_read_ascii_float(6)` with a pose, tested
//! against the virtual robot in the same process.
//!
//! The robot program it serves:
//! ```text
//! socket_open("127.0.0.1", PORT, "camera")
//! socket_send_line("shoot", "camera")
//! pose = socket_read_ascii_float(6, "camera")
//! ```
//!
//! Run: `cargo run --example vision_server`

use std::error::Error;
use std::net::{TcpListener, TcpStream};

use urscript_socket::adapters::blocking::{MessageReader, MessageWriter};
use urscript_socket::ascii_float::encode_float_tuple;
use urscript_socket::line::LineDecoder;
use urscript_socket::robot::{Policy, Timeout, VirtualRobot};

/// The camera: one detected part per request, as x, y, z, rx, ry, rz.
fn detect(shot: u32) -> [f64; 6] {
    let k = f64::from(shot);
    [0.4 + 0.01 * k, -0.2, 0.05, 0.0, 3.0, -0.1 * k]
}

/// Serves one robot: every line it sends is a request; every reply a float tuple.
fn serve(stream: TcpStream) -> Result<u32, Box<dyn Error>> {
    let mut requests = MessageReader::new(stream.try_clone()?, LineDecoder::new());
    let mut replies = MessageWriter::new(stream);
    let mut shots = 0;
    while let Some(is_shoot) = requests.next_with(|line| line == b"shoot")? {
        if is_shoot {
            let pose = detect(shots);
            replies.send(|out| encode_float_tuple(&pose, true, out))?;
            shots += 1;
        }
    }
    Ok(shots)
}

fn main() -> Result<(), Box<dyn Error>> {
    let listener = TcpListener::bind("127.0.0.1:0")?;
    let addr = listener.local_addr()?;
    let server = std::thread::spawn(move || -> Result<u32, String> {
        let (stream, _) = listener.accept().map_err(|e| e.to_string())?;
        serve(stream).map_err(|e| e.to_string())
    });

    let mut robot = VirtualRobot::new(Policy::default());
    if !robot.socket_open(addr, "camera")? {
        return Err("cannot reach the vision server".into());
    }
    for shot in 0..3 {
        robot.socket_send_line(b"shoot", "camera")?;
        let pose = robot.socket_read_ascii_float(6, "camera", Timeout::from_secs_f64(2.0))?;
        println!(
            "shot {shot}: count {} pose {:?}",
            pose.count(),
            pose.values()
        );
        if pose.count() != 6 || pose.values() != detect(shot) {
            return Err(format!("shot {shot}: unexpected result").into());
        }
    }
    robot.socket_close("camera");
    let served = server.join().map_err(|_| "server thread failed")??;
    println!("vision server answered {served} requests");
    Ok(())
}
