//! Server and robot over smoltcp's loopback device in one process: no std networking.
//! The core is driven straight from smoltcp's socket buffers: the server copies what
//! `recv` hands it (a ring buffer, so one segment may come as two slices) into a bounded
//! `RecvBuffer` and decodes lines; the robot side feeds the sans-IO robot model the same
//! way and reads float tuples. Socket buffers are tiny (64 bytes) so messages wrap.
//!
//! Run: `cargo run --example smoltcp_loopback`

use smoltcp::iface::{Config, Interface, SocketSet};
use smoltcp::phy::{Loopback, Medium};
use smoltcp::socket::tcp;
use smoltcp::time::{Duration, Instant};
use smoltcp::wire::{EthernetAddress, IpAddress, IpCidr};

use urscript_socket::ascii_float::encode_float_tuple;
use urscript_socket::line::{encode_line, LineDecoder};
use urscript_socket::robot::{Policy, ReadCall, ReadResult, SocketConnection, Timeout};
use urscript_socket::{RecvBuffer, SliceSink};

const PORT: u16 = 30002;
const EXCHANGES: u32 = 40;

fn pose(n: u32) -> [f64; 6] {
    [f64::from(n) * 0.125, -0.5, 0.25, 0.0, 3.0, -1.0]
}

fn main() -> Result<(), String> {
    let mut device = Loopback::new(Medium::Ethernet);
    let config = Config::new(EthernetAddress([0x02, 0, 0, 0, 0, 1]).into());
    let mut now = Instant::from_millis(0);
    let mut iface = Interface::new(config, &mut device, now);
    iface.update_ip_addrs(|addrs| {
        let _ = addrs.push(IpCidr::new(IpAddress::v4(127, 0, 0, 1), 8));
    });
    let tcp_socket = || {
        tcp::Socket::new(
            tcp::SocketBuffer::new(vec![0; 64]),
            tcp::SocketBuffer::new(vec![0; 64]),
        )
    };
    let mut storage: [_; 2] = Default::default();
    let mut sockets = SocketSet::new(&mut storage[..]);
    let server = sockets.add(tcp_socket());
    let client = sockets.add(tcp_socket());
    sockets
        .get_mut::<tcp::Socket>(server)
        .listen(PORT)
        .map_err(|e| e.to_string())?;
    sockets
        .get_mut::<tcp::Socket>(client)
        .connect(iface.context(), (IpAddress::v4(127, 0, 0, 1), PORT), 49152)
        .map_err(|e| e.to_string())?;

    // Server state: a bounded receive buffer and the core line decoder.
    let mut server_rx = RecvBuffer::<[u8; 256]>::new();
    let mut requests = LineDecoder::new();
    let mut server_tx: Vec<u8> = Vec::new();
    // Robot state: the sans-IO robot model.
    let mut robot = SocketConnection::new(
        "socket_0",
        Policy {
            receive_capacity: 256,
            ..Policy::default()
        },
    );
    let mut robot_tx: Vec<u8> = Vec::new();
    let mut asked = 0u32;
    let mut answered = 0u32;

    while answered < EXCHANGES && now < Instant::from_millis(60_000) {
        iface.poll(now, &mut device, &mut sockets);

        // Server: smoltcp's buffer -> RecvBuffer -> LineDecoder -> encode reply.
        let s = sockets.get_mut::<tcp::Socket>(server);
        while s.can_recv() && !server_rx.is_full() {
            let got = s.recv(|data| {
                let n = server_rx.extend(data);
                (n, n)
            });
            if !matches!(got, Ok(n) if n > 0) {
                break;
            }
        }
        while let Some(line) = server_rx.decode(&mut requests).map_err(|e| e.to_string())? {
            let n: u32 = std::str::from_utf8(line)
                .ok()
                .and_then(|l| l.strip_prefix("pose "))
                .and_then(|n| n.parse().ok())
                .ok_or("bad request")?;
            encode_float_tuple(&pose(n), false, &mut server_tx).map_err(|e| e.to_string())?;
        }
        if !server_tx.is_empty() && s.can_send() {
            let n = s.send_slice(&server_tx).map_err(|e| e.to_string())?;
            server_tx.drain(..n);
        }

        // Robot: one request at a time, read with socket_read_ascii_float(6).
        let c = sockets.get_mut::<tcp::Socket>(client);
        if c.may_send() && robot.pending_read().is_none() && asked < EXCHANGES {
            let mut line = [0u8; 32];
            let mut sink = SliceSink::new(&mut line);
            encode_line(format!("pose {asked}").as_bytes(), &mut sink)
                .map_err(|e| e.to_string())?;
            robot_tx.extend_from_slice(sink.written());
            robot
                .start_read(
                    ReadCall::AsciiFloat { number: 6 },
                    Timeout::default(),
                    clock(now),
                )
                .map_err(|e| e.to_string())?;
            asked += 1;
        }
        if !robot_tx.is_empty() && c.can_send() {
            let n = c.send_slice(&robot_tx).map_err(|e| e.to_string())?;
            robot_tx.drain(..n);
        }
        while c.can_recv() {
            let got = c.recv(|data| {
                let n = robot.receive(data);
                (n, n)
            });
            if !matches!(got, Ok(n) if n > 0) {
                break;
            }
        }
        // The robot model takes the same simulated time as smoltcp.
        if robot.handle_timeout(clock(now)).is_some() {
            return Err(format!("exchange {answered}: timed out"));
        }
        if let Some(result) = robot.poll_read() {
            let want = pose(answered);
            match &result {
                ReadResult::Floats(t) if t.count() == 6 && t.values() == want => {}
                other => return Err(format!("exchange {answered}: got {other}")),
            }
            if answered % 10 == 0 {
                println!("exchange {answered:>2}: {}", result.to_urscript());
            }
            answered += 1;
        }

        // Simulated time: one millisecond per turn. The loopback device delivers on the
        // next poll, so there is never a reason to jump further ahead.
        now += Duration::from_millis(1);
    }
    if answered != EXCHANGES {
        return Err(format!(
            "only {answered} of {EXCHANGES} exchanges completed"
        ));
    }
    println!("{answered} request/reply exchanges over smoltcp's loopback device, all matched");
    Ok(())
}

/// smoltcp's simulated instant as the robot model's clock (time since the epoch).
fn clock(now: Instant) -> core::time::Duration {
    core::time::Duration::from_micros(u64::try_from(now.total_micros()).unwrap_or(0))
}
