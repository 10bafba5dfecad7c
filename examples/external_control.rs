//! An External Control reverse-interface server (spec section 4) talking to the virtual
//! robot: 8 big-endian int32 per message, read on the robot with
//! `socket_read_binary_integer(8, "reverse_socket", timeout)`:
//! `[0]` next read timeout in ms, `[1..=6]` joint positions × 1e6, `[7]` control mode
//! (1 = servoj, -2 = stopped). UR's script checks `result[0] > 0`.
//!
//! Run: `cargo run --example external_control`

use std::error::Error;
use std::net::TcpListener;

use urscript_socket::adapters::blocking::MessageWriter;
use urscript_socket::int32::encode_int32_list;
use urscript_socket::robot::{Policy, Timeout, VirtualRobot};

const MULT_JOINTSTATE: f64 = 1_000_000.0;
const MODE_SERVOJ: i32 = 1;
const MODE_STOPPED: i32 = -2;

fn message(read_timeout_ms: i32, joints: [f64; 6], mode: i32) -> [i32; 8] {
    let mut m = [0; 8];
    m[0] = read_timeout_ms;
    for (slot, q) in m[1..7].iter_mut().zip(joints) {
        *slot = (q * MULT_JOINTSTATE).round() as i32;
    }
    m[7] = mode;
    m
}

fn main() -> Result<(), Box<dyn Error>> {
    let listener = TcpListener::bind("127.0.0.1:0")?;
    let addr = listener.local_addr()?;
    let steps = 10;
    let server = std::thread::spawn(move || -> Result<(), String> {
        let (stream, _) = listener.accept().map_err(|e| e.to_string())?;
        let mut out = MessageWriter::new(stream);
        for i in 0..steps {
            let t = f64::from(i) * 0.01;
            let joints = [t, -1.57 + t, 1.57, -1.57, -1.57, 0.0];
            out.send(|o| encode_int32_list(&message(20, joints, MODE_SERVOJ), o))
                .map_err(|e| e.to_string())?;
        }
        out.send(|o| encode_int32_list(&message(0, [0.0; 6], MODE_STOPPED), o))
            .map_err(|e| e.to_string())
    });

    // The robot side of external_control.urscript's reverse-socket loop.
    let mut robot = VirtualRobot::new(Policy::default());
    if !robot.socket_open(addr, "reverse_socket")? {
        return Err("cannot reach the driver".into());
    }
    let mut received = 0;
    loop {
        let params =
            robot.socket_read_binary_integer(8, "reverse_socket", Timeout::from_secs_f64(1.0))?;
        if params.count() == 0 {
            return Err("reverse interface timed out".into());
        }
        let v = params.values();
        let joints: Vec<f64> = v[1..7]
            .iter()
            .map(|&x| f64::from(x) / MULT_JOINTSTATE)
            .collect();
        println!("timeout {:>3} ms  mode {:>2}  q = {joints:?}", v[0], v[7]);
        if v[7] == MODE_STOPPED {
            break;
        }
        received += 1;
    }
    robot.socket_close("reverse_socket");
    server.join().map_err(|_| "server thread failed")??;
    if received != steps {
        return Err(format!("received {received} servoj messages, expected {steps}").into());
    }
    println!("robot followed {received} servoj messages, then stopped");
    Ok(())
}
