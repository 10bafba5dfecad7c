//! `ursock demo`: a server and a virtual robot on 127.0.0.1, every socket function, and a
//! transcript of both sides. Needs no robot.

use std::io::{Read, Write};
use std::net::TcpListener;
use std::sync::mpsc;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use urscript_socket::robot::{Direction, Policy, ReadCall, ReadResult, Timeout, VirtualRobot};
use urscript_socket::to_str::Value;
use urscript_socket::RecvBuffer;

use urscript_socket::format::Message;
use urscript_socket::var::{encode_var_reply, VarMessage};

use crate::formats::{encode_server, DecodeFormat};
use crate::outln;
use crate::show::{hex, message_text, quoted, text_and_hex};
use crate::vars::Vars;

/// What the server expects at each step: the decoder to use and the reply to send.
struct Expect {
    format: DecodeFormat,
    reply: Option<&'static [&'static str]>,
}

const SERVER_SCRIPT: &[Expect] = &[
    Expect {
        format: DecodeFormat::StxEtx,
        reply: None,
    },
    Expect {
        format: DecodeFormat::Int32,
        reply: None,
    },
    Expect {
        format: DecodeFormat::Line,
        reply: None,
    },
    Expect {
        format: DecodeFormat::Value,
        reply: None,
    },
    Expect {
        format: DecodeFormat::Var,
        reply: None,
    },
    // GET is answered from the SET above, by the var step itself.
    Expect {
        format: DecodeFormat::Var,
        reply: None,
    },
    Expect {
        format: DecodeFormat::Line,
        reply: Some(&["floats", "0.4", "-0.2", "0.3", "0", "3.14", "0"]),
    },
    Expect {
        format: DecodeFormat::Line,
        reply: Some(&["int32", "100", "2000", "30000"]),
    },
    Expect {
        format: DecodeFormat::Line,
        reply: Some(&["bytes", "100", "200", "44"]),
    },
    Expect {
        format: DecodeFormat::Line,
        reply: Some(&["string", "noise>hello<"]),
    },
    Expect {
        format: DecodeFormat::Line,
        reply: Some(&["string", "reply from the server:\r\n"]),
    },
    // The robot asks, the server stays silent: the robot's read times out.
    Expect {
        format: DecodeFormat::Line,
        reply: None,
    },
];

/// The server side: decodes each expected message with the library's decoders and sends
/// the scripted reply, reporting each event on `events`.
fn server(listener: TcpListener, events: mpsc::Sender<String>) -> Result<(), String> {
    let (mut stream, peer) = listener.accept().map_err(|e| e.to_string())?;
    let _ = events.send(format!(
        "server accepted the robot's connection from {peer}"
    ));
    stream.set_nodelay(true).map_err(|e| e.to_string())?;
    let mut rx = RecvBuffer::with_capacity(4096);
    let mut vars = Vars::new(crate::listen::DEFAULT_MAX_VARS);
    // The demo's one robot creates its few names.
    let mut created = 0;
    for step in SERVER_SCRIPT {
        let mut dec = step.format.decoder(b"")?;
        let (text, reply) = loop {
            match rx.decode(&mut dec) {
                Ok(Some(msg)) => {
                    let text = message_text(&msg);
                    let mut reply = None;
                    match msg {
                        Message::Var(VarMessage::Set { name, value }) => {
                            let _ = vars.set(name, value, &mut created);
                        }
                        Message::Var(VarMessage::Get { name }) => {
                            let mut out = Vec::new();
                            encode_var_reply(name, vars.get(name).unwrap_or(0), &mut out)
                                .map_err(|e| e.to_string())?;
                            reply = Some(out);
                        }
                        _ => {}
                    }
                    break (text, reply);
                }
                Ok(None) => {}
                Err(e) => return Err(format!("server: bad input: {e}")),
            }
            let n = stream.read(rx.spare()).map_err(|e| e.to_string())?;
            if n == 0 {
                return Err("server: robot closed early".into());
            }
            rx.commit(n);
        };
        let kind = match step.format {
            DecodeFormat::StxEtx => "stx-etx frame",
            DecodeFormat::Int32 => "int32",
            DecodeFormat::Value => "value",
            DecodeFormat::Var => "var",
            _ => "line",
        };
        let _ = events.send(format!("server decoded     {kind} {text}"));
        let reply = match (reply, step.reply) {
            (Some(r), _) => Some(r),
            (None, Some(spec)) => {
                let words: Vec<String> = spec.iter().map(|s| (*s).to_string()).collect();
                Some(encode_server(&words[0], &words[1..])?)
            }
            (None, None) => None,
        };
        match reply {
            Some(bytes) => {
                let _ = events.send(show_bytes("server -> robot", &bytes));
                stream.write_all(&bytes).map_err(|e| e.to_string())?;
            }
            None => {
                let _ = events.send("server             (no reply)".to_string());
            }
        }
    }
    // Wait for the robot to close.
    let mut rest = [0u8; 64];
    while matches!(stream.read(&mut rest), Ok(n) if n > 0) {}
    let _ = events.send("server saw the robot close the connection".to_string());
    Ok(())
}

type Traffic = Arc<Mutex<Vec<(Direction, Vec<u8>)>>>;

/// `label "text"` and, under it, the hex of the same bytes.
fn show_bytes(label: &str, bytes: &[u8]) -> String {
    if bytes.len() <= 16 {
        format!("{label:<19}{}\n    {:<19}{}", quoted(bytes), "", hex(bytes))
    } else {
        format!("{label:<19}{}", text_and_hex(bytes, "    "))
    }
}

struct Transcript {
    step: usize,
    traffic: Traffic,
    events: mpsc::Receiver<String>,
}

impl Transcript {
    /// Prints one step: the call, the robot's bytes out, the server's events, the robot's
    /// bytes in, and the result the robot program sees.
    fn step(&mut self, call: &str, server_events: usize, result: Option<String>) {
        self.step += 1;
        outln!("{:>2}. {call}", self.step);
        let traffic: Vec<(Direction, Vec<u8>)> =
            std::mem::take(&mut *self.traffic.lock().unwrap_or_else(|p| p.into_inner()));
        for (dir, bytes) in &traffic {
            if *dir == Direction::RobotToServer {
                outln!("    {}", show_bytes("robot  -> server", bytes));
            }
        }
        for _ in 0..server_events {
            match self.events.recv_timeout(Duration::from_secs(5)) {
                Ok(e) => outln!("    {e}"),
                Err(_) => outln!("    (server said nothing)"),
            }
        }
        for (dir, bytes) in &traffic {
            if *dir == Direction::ServerToRobot {
                outln!("    {}", show_bytes("robot  <- server", bytes));
            }
        }
        if let Some(r) = result {
            outln!("    result             {r}");
        }
    }
}

pub fn run() -> Result<(), String> {
    let listener =
        TcpListener::bind("127.0.0.1:0").map_err(|e| format!("cannot listen on 127.0.0.1: {e}"))?;
    let addr = listener.local_addr().map_err(|e| e.to_string())?;
    let (tx, events) = mpsc::channel();
    let server = std::thread::spawn(move || server(listener, tx));

    outln!("ursock demo: a virtual UR robot (client) and a server, both on {addr}");
    outln!("Every byte below crossed a real TCP connection; every decode is the library's.\n");

    let traffic: Traffic = Arc::new(Mutex::new(Vec::new()));
    let mut robot = VirtualRobot::new(Policy::default());
    let sink = Arc::clone(&traffic);
    robot.set_observer(move |_, dir, bytes| {
        sink.lock()
            .unwrap_or_else(|p| p.into_inner())
            .push((dir, bytes.to_vec()));
    });
    let mut t = Transcript {
        step: 0,
        traffic,
        events,
    };
    let s = "socket_0";
    let e = |e: urscript_socket::robot::RobotError| e.to_string();

    let ok = robot.socket_open(addr, s).map_err(e)?;
    if !ok {
        return Err(format!("the virtual robot could not connect to {addr}"));
    }
    t.step(
        &format!(
            "socket_open(\"{}\", {}, \"socket_0\")",
            addr.ip(),
            addr.port()
        ),
        1,
        Some("True".into()),
    );

    robot.socket_send_byte(2, s).map_err(e)?;
    robot.socket_send_string(b"hi", s).map_err(e)?;
    robot.socket_send_byte(3, s).map_err(e)?;
    t.step(
        "socket_send_byte(2)  socket_send_string(\"hi\")  socket_send_byte(3)",
        2,
        None,
    );

    robot.socket_send_int(-1, s).map_err(e)?;
    t.step("socket_send_int(-1)", 2, None);

    robot.socket_send_line(b"hello", s).map_err(e)?;
    t.step("socket_send_line(\"hello\")", 2, None);

    robot
        .socket_send_value(&Value::Pose([0.1, -0.25, 0.3, 0.0, 2.5, 0.0]), true, s)
        .map_err(e)?;
    t.step("socket_send_line(p[0.1, -0.25, 0.3, 0, 2.5, 0])", 2, None);

    robot.socket_set_var("POS_Y", 2200, s).map_err(e)?;
    t.step("socket_set_var(\"POS_Y\", 2200)", 2, None);

    let v = robot.socket_get_var("POS_Y", s).map_err(e)?;
    t.step("socket_get_var(\"POS_Y\")", 2, Some(v.to_string()));

    let reads: [(&str, &[u8], ReadCall); 5] = [
        (
            "pose = socket_read_ascii_float(6)",
            b"pose?",
            ReadCall::AsciiFloat { number: 6 },
        ),
        (
            "ints = socket_read_binary_integer(3)",
            b"ints?",
            ReadCall::BinaryInteger { number: 3 },
        ),
        (
            "bytes = socket_read_byte_list(3)",
            b"bytes?",
            ReadCall::ByteList { number: 3 },
        ),
        (
            "s = socket_read_string(prefix=\">\", suffix=\"<\")",
            b"string?",
            ReadCall::String {
                prefix: b">".to_vec(),
                suffix: b"<".to_vec(),
                interpret_escape: false,
            },
        ),
        ("line = socket_read_line()", b"line?", ReadCall::Line),
    ];
    for (shown, request, call) in reads {
        robot.socket_send_line(request, s).map_err(e)?;
        let r: ReadResult = robot
            .read(call, s, Timeout::from_secs_f64(2.0))
            .map_err(e)?;
        t.step(
            &format!(
                "socket_send_line(\"{}\")  {shown}",
                String::from_utf8_lossy(request)
            ),
            2,
            Some(r.to_urscript()),
        );
    }

    robot.socket_send_line(b"nothing?", s).map_err(e)?;
    let r = robot
        .read(
            ReadCall::AsciiFloat { number: 3 },
            s,
            Timeout::from_secs_f64(0.3),
        )
        .map_err(e)?;
    t.step(
        "socket_send_line(\"nothing?\")  x = socket_read_ascii_float(3, timeout=0.3)   # the server stays silent",
        2,
        Some(format!("{}   (the timeout sentinel)", r.to_urscript())),
    );

    robot.socket_close(s);
    t.step("socket_close()", 1, None);

    match server.join() {
        Ok(Ok(())) => {}
        Ok(Err(msg)) => return Err(msg),
        Err(_) => return Err("the demo server thread failed".into()),
    }
    outln!("\nDone: every socket function crossed the wire and decoded as expected.");
    Ok(())
}
