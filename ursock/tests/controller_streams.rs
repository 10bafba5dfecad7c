//! `ursock controller`'s streaming interfaces against real TCP clients on 127.0.0.1,
//! written from UR's primary/secondary and realtime guides: the version message first,
//! robot state packages, programs sent as a client would send them running on the
//! virtual arm, robot messages for a program's start, end and runtime error, and a
//! client that never reads slowing nobody. Every wait is bounded.

mod controller_common;
mod urp_common;

use std::io::{Read, Write};
use std::net::TcpStream;
use std::process::Command;
use std::time::{Duration, Instant};

use controller_common::{Controller, WAIT};

/// One message of the primary/secondary stream: its type and its bytes after the
/// 5-byte header.
fn message(s: &mut TcpStream) -> (u8, Vec<u8>) {
    let mut head = [0u8; 5];
    s.read_exact(&mut head).expect("a message header");
    let len = u32::from_be_bytes(head[..4].try_into().unwrap()) as usize;
    assert!((5..1 << 20).contains(&len), "message length {len}");
    let mut body = vec![0u8; len - 5];
    s.read_exact(&mut body).expect("a message body");
    (head[4], body)
}

/// One realtime package: its bytes after the 4-byte length.
fn realtime_package(s: &mut TcpStream) -> Vec<u8> {
    let mut head = [0u8; 4];
    s.read_exact(&mut head).expect("a package length");
    let len = u32::from_be_bytes(head) as usize;
    assert_eq!(len, 1220, "the e-Series (5.x) realtime package size");
    let mut body = vec![0u8; len - 4];
    s.read_exact(&mut body).expect("a package");
    body
}

fn f64_at(body: &[u8], offset_in_package: usize) -> f64 {
    let i = offset_in_package - 4;
    f64::from_be_bytes(body[i..i + 8].try_into().unwrap())
}

/// `q actual` starts at byte 252 of the realtime package (after Time, q/qd/qdd/I/M
/// target).
fn q_actual(body: &[u8]) -> [f64; 6] {
    std::array::from_fn(|j| f64_at(body, 252 + 8 * j))
}

#[test]
fn primary_and_secondary_send_the_version_then_robot_state() {
    let c = Controller::start();
    for service in ["primary", "secondary"] {
        let mut s = c.connect(service);
        let (ty, body) = message(&mut s);
        assert_eq!(ty, 20, "{service}: a robot message first");
        assert_eq!(body[9], 3, "{service}: the version message");
        let name_len = body[10] as usize;
        assert_eq!(&body[11..11 + name_len], b"URControl");
        let (major, minor) = (body[11 + name_len], body[12 + name_len]);
        assert_eq!((major, minor), (5, 23), "the default version");
        let mut states = 0;
        while states < 3 {
            let (ty, body) = message(&mut s);
            if ty == 16 {
                states += 1;
                // The first package is robot mode data (type 0) with the mode POWER_OFF.
                let sub_len = u32::from_be_bytes(body[..4].try_into().unwrap()) as usize;
                assert_eq!(body[4], 0, "robot mode data first");
                assert!(sub_len > 30);
            }
        }
    }
}

#[test]
fn a_program_sent_on_the_secondary_moves_the_arm_the_realtime_stream_shows() {
    let c = Controller::start();
    c.ready();
    let mut rt = c.connect("realtime");
    let home = q_actual(&realtime_package(&mut rt));
    assert!(
        (home[1] + std::f64::consts::FRAC_PI_2).abs() < 1e-9,
        "{home:?}"
    );
    let target = [0.3, -1.2, 0.9, -1.4, 0.5, 0.1];
    let mut sec = c.connect("secondary");
    let program = format!(
        "def move_it():\n  movej({target:?})\n  write_output_integer_register(7, 42)\nend\n"
    );
    sec.write_all(program.as_bytes()).unwrap();
    let started = c.wait_event("program started", |v| v["event"] == "program");
    assert_eq!(started["what"], "started");
    assert_eq!(started["name"], "move_it");
    let start = Instant::now();
    loop {
        let q = q_actual(&realtime_package(&mut rt));
        if q.iter().zip(target).all(|(a, b)| (a - b).abs() < 1e-6) {
            break;
        }
        assert!(
            start.elapsed() < WAIT,
            "the arm never reached {target:?}: {q:?}"
        );
    }
    let ended = c.wait_event("program finished", |v| v["event"] == "program");
    assert_eq!(ended["what"], "finished");
}

#[test]
fn primary_clients_get_the_program_messages_and_its_runtime_error() {
    let c = Controller::start();
    c.ready();
    let mut p = c.connect("primary");
    p.write_all(b"def failing():\n  textmsg(\"before\")\n  l = [1, 2]\n  x = l[5]\nend\n")
        .unwrap();
    let mut seen = Vec::new();
    let start = Instant::now();
    while !seen.iter().any(|(k, _)| *k == 10) {
        assert!(start.elapsed() < WAIT, "no runtime exception: {seen:?}");
        let (ty, body) = message(&mut p);
        if ty == 20 && body.len() > 9 {
            seen.push((body[9], body[10..].to_vec()));
        }
    }
    let kinds: Vec<u8> = seen.iter().map(|(k, _)| *k).collect();
    let version = kinds.iter().position(|&k| k == 3).expect("version");
    let text = kinds.iter().position(|&k| k == 0).expect("the textmsg");
    let exception = kinds.iter().position(|&k| k == 10).unwrap();
    assert!(version < text && text < exception, "{kinds:?}");
    let (_, body) = &seen[text];
    assert_eq!(body.as_slice(), b"before");
    let (_, body) = &seen[exception];
    let line = i32::from_be_bytes(body[..4].try_into().unwrap());
    assert_eq!(line, 4, "the line of l[5]");
    let ended = c.wait_event("program error", |v| {
        v["event"] == "program" && v["what"] != "started"
    });
    assert_eq!(ended["what"], "error");
    assert_eq!(ended["line"], 4);
}

#[test]
fn a_realtime_client_that_never_reads_slows_nobody() {
    let c = Controller::start();
    let _idle = c.connect("realtime"); // never read
    let mut rt = c.connect("realtime");
    // 3 s of packages at 500 Hz is 1500; the idle client's queue fills long before.
    let start = Instant::now();
    let mut n = 0;
    let mut last_time = 0.0;
    while start.elapsed() < Duration::from_secs(3) {
        let body = realtime_package(&mut rt);
        let t = f64_at(&body, 4);
        assert!(t >= last_time, "time goes forward");
        last_time = t;
        n += 1;
    }
    assert!(n > 300, "only {n} packages in 3 s");
    // The controller still answers.
    c.dashboard();
}

#[test]
fn a_program_is_refused_while_the_arm_is_powered_off() {
    let c = Controller::start();
    let mut p = c.connect("primary");
    p.write_all(b"textmsg(\"never\")\n").unwrap();
    let v = c.wait_event("refused", |v| v["event"] == "program");
    assert_eq!(v["what"], "refused");
    assert!(v["text"].as_str().unwrap().contains("POWER_OFF"), "{v}");
}

/// A `.urp` with an External Control node, gzip-compressed as PolyScope saves it.
fn external_control_urp() -> Vec<u8> {
    urp_common::urp(
        "ec",
        r#"<Script type="Line"><expression>textmsg(&quot;before&quot;)</expression></Script>
        <Contributed strategyClass="com.fzi.externalcontrol.ExternalControlNode" strategyProgramNodeType="External Control"><dataModel/></Contributed>"#,
    )
}

#[test]
fn play_runs_a_urp_whose_external_control_node_fetches_its_script() {
    // The driver's side: answers `request_program` with a script, then closes.
    let host = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let host_port = host.local_addr().unwrap().port();
    let driver = std::thread::spawn(move || {
        let (mut s, _) = host.accept().unwrap();
        s.set_read_timeout(Some(WAIT)).unwrap();
        let mut request = [0u8; 16];
        s.read_exact(&mut request).unwrap();
        s.write_all(b"textmsg(\"driven\")\nwrite_output_integer_register(1, 99)\n")
            .unwrap();
        request
    });
    let dir = std::env::temp_dir().join(format!("ursock-urp-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("ec.urp"), external_control_urp()).unwrap();
    let c = Controller::start_with(&[
        "--programs",
        dir.to_str().unwrap(),
        "--urcap-host",
        &format!("127.0.0.1:{host_port}"),
    ]);
    c.ready();
    let mut d = c.dashboard();
    for (cmd, want) in [
        ("load ec.urp", "Loading program: ec.urp"),
        ("play", "Starting program"),
    ] {
        assert_eq!(d.ask(cmd), want);
    }
    assert_eq!(&driver.join().unwrap(), b"request_program\n");
    let started = c.wait_event("program started", |v| v["event"] == "program");
    assert_eq!(started["what"], "started", "{started}");
    assert_eq!(started["name"], "ec.urp");
    let before = c.wait_event("message", |v| v["event"] == "message");
    assert_eq!(before["text"], "before");
    let driven = c.wait_event("message", |v| v["event"] == "message");
    assert_eq!(driven["text"], "driven");
    let ended = c.wait_event("program end", |v| v["event"] == "program");
    assert_eq!(ended["what"], "finished", "{ended}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A `.urp` whose Script line calls a URCap's function, as PolyScope saves it.
fn urcap_urp() -> Vec<u8> {
    urp_common::urp(
        "pick",
        r#"<Script type="Line"><expression>gripper_grip(40)</expression></Script>"#,
    )
}

/// `--preamble`: the installation's URCap preamble runs at the top of each `.urp`
/// program played (PolyScope writes it there), not in scripts clients send; `--set`
/// gives what the robot senses from the start.
#[test]
fn a_played_urp_calls_the_preamble_and_programs_read_what_set_gave() {
    let dir = std::env::temp_dir().join(format!("ursock-preamble-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("pick.urp"), urcap_urp()).unwrap();
    let preamble = dir.join("gripper.script");
    std::fs::write(
        &preamble,
        "def gripper_grip(width):\n  textmsg(\"grip \", width)\nend\n",
    )
    .unwrap();
    let c = Controller::start_with(&[
        "--programs",
        dir.to_str().unwrap(),
        "--preamble",
        preamble.to_str().unwrap(),
        "--set",
        "digital_in[2]=True",
    ]);
    c.ready();
    let mut d = c.dashboard();
    assert_eq!(d.ask("load pick.urp"), "Loading program: pick.urp");
    assert_eq!(d.ask("play"), "Starting program");
    let grip = c.wait_event("message", |v| v["event"] == "message");
    assert_eq!(grip["text"], "grip 40", "{grip}");
    let ended = c.wait_event("program end", |v| {
        v["event"] == "program" && v["what"] != "started"
    });
    assert_eq!(ended["what"], "finished", "{ended}");
    // A script sent on the primary port gets no preamble: refused before it starts.
    let mut p = c.connect("primary");
    p.write_all(b"def direct():\n  gripper_grip(10)\nend\n")
        .unwrap();
    let refused = c.wait_event("error", |v| {
        v["event"] == "program" && v["what"] != "started"
    });
    assert!(
        refused["text"]
            .as_str()
            .is_some_and(|t| t.contains("gripper_grip")),
        "{refused}"
    );
    // What --set gave.
    p.write_all(b"def sense():\n  textmsg(\"in2 \", get_standard_digital_in(2))\nend\n")
        .unwrap();
    let sensed = c.wait_event("message", |v| v["event"] == "message");
    assert_eq!(sensed["text"], "in2 True", "{sensed}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// What a program sends just before it ends reaches the server, then the socket closes
/// (the script manual: a program's sockets close when it ends; bytes already sent are
/// not taken back).
#[test]
fn the_last_bytes_a_program_sends_before_it_ends_reach_the_server() {
    use std::net::TcpListener;
    let c = Controller::start();
    c.ready();
    let server = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = server.local_addr().unwrap().port();
    let mut p = c.connect("primary");
    let program = format!(
        "def last_words():\n  socket_open(\"127.0.0.1\", {port}, \"s\")\n  \
         socket_send_string(\"bye\", \"s\")\nend\n"
    );
    p.write_all(program.as_bytes()).unwrap();
    let (mut conn, _) = server.accept().unwrap();
    conn.set_read_timeout(Some(WAIT)).unwrap();
    let mut got = Vec::new();
    conn.read_to_end(&mut got).unwrap();
    assert_eq!(String::from_utf8_lossy(&got), "bye");
}

/// Sends a signal to the controller's process (Unix `kill`).
#[cfg(unix)]
fn signal(c: &Controller, sig: &str) {
    let ok = Command::new("kill")
        .args([sig, &c.child.id().to_string()])
        .status()
        .is_ok_and(|s| s.success());
    assert!(ok, "kill {sig}");
}

/// The host stalls the controller (here: SIGSTOP for longer than the program's read
/// timeout) while the server's reply is on its way. A controller whose steps are real
/// time never sees that stall: the reply, there before the timeout in controller time,
/// reaches the read, as UR's client library expects of the External Control script's
/// reads with a timeout.
#[cfg(unix)]
#[test]
fn a_host_stall_does_not_expire_a_read_whose_reply_came_in_time() {
    use std::net::TcpListener;
    let c = Controller::start();
    c.ready();
    let server = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = server.local_addr().unwrap().port();
    let mut p = c.connect("primary");
    let program = format!(
        "def wait_reply():\n  socket_open(\"127.0.0.1\", {port}, \"s\")\n  \
         socket_send_string(\"ready\", \"s\")\n  r = socket_read_binary_integer(1, \"s\", 0.3)\n  \
         socket_send_string(to_str(r), \"s\")\nend\n"
    );
    p.write_all(program.as_bytes()).unwrap();
    let (mut conn, _) = server.accept().unwrap();
    conn.set_read_timeout(Some(WAIT)).unwrap();
    let mut ready = [0u8; 5];
    conn.read_exact(&mut ready).unwrap();
    assert_eq!(&ready, b"ready");
    signal(&c, "-STOP");
    std::thread::sleep(Duration::from_millis(800));
    conn.write_all(&7i32.to_be_bytes()).unwrap();
    std::thread::sleep(Duration::from_millis(50));
    signal(&c, "-CONT");
    let mut got = Vec::new();
    let mut buf = [0u8; 64];
    let start = Instant::now();
    while !got.contains(&b']') {
        assert!(start.elapsed() < WAIT, "no reply: {got:?}");
        let n = conn.read(&mut buf).unwrap();
        assert!(n > 0, "closed: {:?}", String::from_utf8_lossy(&got));
        got.extend_from_slice(&buf[..n]);
    }
    assert_eq!(String::from_utf8_lossy(&got), "[1, 7]");
}
