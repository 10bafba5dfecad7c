//! Hostile peers and hostile programs against the whole controller over TCP (the
//! in-process [`Server`] on 127.0.0.1): after every attack the controller still answers
//! a dashboard `robotmode`, a fresh RTDE client still gets data, its connection threads
//! stay within [`MAX_CONNECTIONS`] and [`MAX_INTERPRETER_CONNECTIONS`], the process did
//! not grow by what the attack sent, and nothing panicked.
//!
//! Every wait is bounded ([`WAIT`]) and no assertion is about time: a wait that runs out
//! fails the test with what was awaited. Random bytes come from a seeded generator, so
//! a failure replays. The tests share one process, so they take turns ([`SERIAL`]):
//! the thread and memory readings of `/proc/self` are then about one server.

use std::io::{ErrorKind, Read, Write};
use std::net::{Shutdown, SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread;
use std::time::Duration;

mod support;
use support::*;
use urscript_controller::net::{
    ServerEvent, MAX_CLIENTS, MAX_CONNECTIONS, MAX_INTERPRETER_CONNECTIONS, MAX_SERVER_THREADS,
    MAX_STALL,
};

/// The tests of this file run one at a time.
static SERIAL: Mutex<()> = Mutex::new(());
/// Panics anywhere in the process (the server's threads included).
static PANICS: AtomicUsize = AtomicUsize::new(0);

fn serial() -> MutexGuard<'static, ()> {
    static HOOK: std::sync::Once = std::sync::Once::new();
    HOOK.call_once(|| {
        let default = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            // The server's threads (a test's own failed assertion is not counted).
            if thread::current().name().is_some_and(server_thread) {
                PANICS.fetch_add(1, Ordering::SeqCst);
            }
            default(info);
        }));
    });
    SERIAL.lock().unwrap_or_else(|p| p.into_inner())
}

/// A small seeded generator (xorshift64*): the same seed, the same bytes.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    fn bytes(&mut self, n: usize) -> Vec<u8> {
        (0..n).map(|_| self.next() as u8).collect()
    }
}

/// The events the tests look at (the others are dropped, so a flood does not grow the
/// test itself).
#[derive(Default)]
struct Log {
    programs: Vec<(String, String, Option<String>)>,
    messages: Vec<String>,
    closes: Vec<(u64, String)>,
    connects: Vec<(u64, &'static str)>,
}

type Fixture = support::Fixture<Log>;

fn start() -> Fixture {
    support::start_logging(any_ports(), |l: &mut Log, e| {
        match e {
            ServerEvent::Program {
                what, name, text, ..
            } => l.programs.push((what.to_string(), name, text)),
            // Short ones only, the last 10 000: a program's message flood does not
            // grow the test.
            ServerEvent::Message(m) if m.text.len() < 256 => {
                if l.messages.len() >= 10_000 {
                    l.messages.remove(0);
                }
                l.messages.push(m.text)
            }
            ServerEvent::Close { conn, reason, .. } => l.closes.push((conn, reason)),
            ServerEvent::Connect { conn, service, .. } => l.connects.push((conn, service)),
            _ => {}
        }
    })
}

impl Fixture {
    /// The controller still serves: a dashboard `robotmode`, a fresh RTDE client's data,
    /// its threads within bounds, and nothing panicked.
    fn healthy(&self, after: &str) {
        // A connection the attack's peers still hold a slot for (their threads have not
        // seen them leave yet) is refused: the slots must come back, within WAIT.
        let mode = eventually(
            &format!("after {after}: the dashboard does not answer"),
            || dashboard_ask(self.addr("dashboard"), "robotmode"),
        );
        assert!(
            mode.starts_with("Robotmode: "),
            "after {after}: robotmode answered {mode:?}"
        );
        eventually(
            &format!("after {after}: a fresh RTDE client got no data"),
            || rtde_gets_data(self.addr("rtde")),
        );
        check_threads(after);
        assert_eq!(PANICS.load(Ordering::SeqCst), 0, "after {after}: a panic");
    }
}

/// Whether a thread of this name is one of the server's (by the prefixes it names its
/// threads with).
fn server_thread(name: &str) -> bool {
    [
        "dashboard",
        "interpreter",
        "controller",
        "load-program",
        "connect",
    ]
    .iter()
    .any(|p| name.starts_with(p))
}

/// The names of this process's threads now.
fn thread_names() -> Vec<String> {
    let Ok(dir) = std::fs::read_dir("/proc/self/task") else {
        return Vec::new();
    };
    dir.filter_map(|t| std::fs::read_to_string(t.ok()?.path().join("comm")).ok())
        .collect()
}

/// Connection threads of the server now: `dashboard-N` and `interpreter-N`.
fn connection_threads() -> usize {
    thread_names()
        .iter()
        .filter(|name| name.starts_with("dashboard-") || name.starts_with("interpreter-"))
        .count()
}

/// The server's threads within [`MAX_SERVER_THREADS`], its connection threads within
/// their limits.
fn check_threads(after: &str) {
    let n = connection_threads();
    assert!(
        n <= MAX_CONNECTIONS + MAX_INTERPRETER_CONNECTIONS,
        "after {after}: {n} connection threads, more than the bounds allow"
    );
    let all = thread_names()
        .iter()
        .filter(|name| server_thread(name))
        .count();
    assert!(
        all <= MAX_SERVER_THREADS,
        "after {after}: {all} server threads, more than {MAX_SERVER_THREADS}"
    );
}

/// The process's resident memory, in bytes (0 where /proc is absent).
fn rss() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmRSS:"))
                .and_then(|l| l.split_whitespace().nth(1)?.parse::<u64>().ok())
        })
        .map_or(0, |kb| kb * 1024)
}

fn dashboard_ask(addr: SocketAddr, command: &str) -> std::io::Result<String> {
    ask(&mut dashboard(addr)?, command)
}

/// A client of protocol 2 sets up `timestamp` at 125 Hz, starts, and reads packets
/// until a data package comes (at most 1000 packets).
fn rtde_gets_data(addr: SocketAddr) -> std::io::Result<()> {
    let mut s = connect(addr)?;
    s.write_all(&rtde_packet(b'V', &2u16.to_be_bytes()))?;
    let mut setup = 125.0f64.to_be_bytes().to_vec();
    setup.extend_from_slice(b"timestamp");
    s.write_all(&rtde_packet(b'O', &setup))?;
    s.write_all(&rtde_packet(b'S', &[]))?;
    for _ in 0..1000 {
        if rtde_read(&mut s)?.0 == b'U' {
            return Ok(());
        }
    }
    Err(std::io::Error::other("no data package in 1000 packets"))
}

/// Writes `bytes` as far as the peer takes them within [`WAIT`] (a peer that closed, or
/// stopped reading, ends it): how many went.
fn write_some(s: &mut TcpStream, bytes: &[u8]) -> usize {
    let mut sent = 0;
    for chunk in bytes.chunks(64 * 1024) {
        match s.write_all(chunk) {
            Ok(()) => sent += chunk.len(),
            Err(_) => break,
        }
    }
    sent
}

/// Drains what the peer sends, in a thread, until it closes or `stop`.
fn drain(mut s: TcpStream, stop: Arc<AtomicBool>) -> thread::JoinHandle<()> {
    let _ = s.set_read_timeout(Some(Duration::from_millis(50)));
    thread::spawn(move || {
        let mut buf = [0u8; 64 * 1024];
        while !stop.load(Ordering::SeqCst) {
            match s.read(&mut buf) {
                Ok(0) => return,
                Ok(_) => {}
                Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {}
                Err(_) => return,
            }
        }
    })
}

const LINE_PORTS: [&str; 5] = [
    "dashboard",
    "primary",
    "secondary",
    "realtime",
    "interpreter",
];
const ALL_PORTS: [&str; 6] = [
    "dashboard",
    "primary",
    "secondary",
    "realtime",
    "rtde",
    "interpreter",
];

#[test]
fn random_and_adversarial_bytes_on_every_port() {
    let _turn = serial();
    let f = start();
    let mut rng = Rng(0x5EED_1234_ABCD_0001);
    let adversarial: [&[u8]; 8] = [
        b"\0\0\0\0\xff\xff\xff\xff",
        b"\n\n\n\r\n\r\r\r\n",
        b"def p():\ndef q():\nthread t():\n",
        b"end\nend\nend\nend\n",
        b"\xff\xffV\x00\x02\xff\xffO",
        b"\x00\x03S\x00\x03P\x00\x02V\x00\x00U",
        b"power on\nset speed1e308\nset speed-nan\nset speed\n",
        b"\"\"\"'''#\xc3\x28\xe2\x82\xa1\xf0\x90\x8c\xbc\n",
    ];
    for service in ALL_PORTS {
        for round in 0..4 {
            let mut s = connect(f.addr(service)).expect("connect");
            let stop = Arc::new(AtomicBool::new(false));
            let reader = drain(s.try_clone().expect("clone"), Arc::clone(&stop));
            let mut bytes = rng.bytes(64 * 1024);
            bytes.extend_from_slice(adversarial[(round * 2) % adversarial.len()]);
            bytes.extend_from_slice(adversarial[(round * 2 + 1) % adversarial.len()]);
            write_some(&mut s, &bytes);
            let _ = s.shutdown(Shutdown::Both);
            stop.store(true, Ordering::SeqCst);
            let _ = reader.join();
        }
        f.healthy(&format!("random bytes on {service}"));
    }
}

#[test]
fn a_line_of_many_mib_without_a_newline() {
    let _turn = serial();
    let f = start();
    const SENT: usize = 24 * 1024 * 1024;
    let line = vec![b'x'; SENT];
    for service in LINE_PORTS {
        let before = rss();
        let mut s = connect(f.addr(service)).expect("connect");
        let stop = Arc::new(AtomicBool::new(false));
        let reader = drain(s.try_clone().expect("clone"), Arc::clone(&stop));
        let sent = write_some(&mut s, &line);
        assert_eq!(sent, SENT, "{service} stopped reading a long line");
        // Still connected, the line unfinished: whatever it held of the line is held now.
        let grown = rss().saturating_sub(before);
        assert!(
            grown < (SENT / 4) as u64,
            "{service}: the process grew by {grown} bytes while a {SENT}-byte line came"
        );
        f.healthy(&format!("a {SENT}-byte line on {service}"));
        let _ = s.shutdown(Shutdown::Both);
        stop.store(true, Ordering::SeqCst);
        let _ = reader.join();
    }
    // RTDE: a header announcing the largest size, then its bytes trickling in; the size
    // is refused at once (past RTDE_MAX_PACKET_SIZE) or the packet waits, bounded.
    for size in [u16::MAX, 8192] {
        let mut s = connect(f.addr("rtde")).expect("connect");
        let mut head = size.to_be_bytes().to_vec();
        head.push(b'O');
        let _ = s.write_all(&head);
        for i in 0..50u8 {
            if s.write_all(&[i]).is_err() {
                break;
            }
            thread::sleep(Duration::from_millis(2));
        }
        f.healthy(&format!(
            "an RTDE packet of announced size {size} trickling"
        ));
    }
}

#[test]
fn a_program_that_never_ends_and_floods_of_setups_and_lines() {
    let _turn = serial();
    let f = start();
    // `def p():` and then endless lines: dropped past MAX_PROGRAM, never buffered whole.
    for service in ["primary", "secondary", "realtime"] {
        let mut program = b"def p():\n".to_vec();
        while program.len() < 12 * 1024 * 1024 {
            program.extend_from_slice(b"  x = [1, 2, 3]  # and on, and on\n");
        }
        let before = rss();
        let mut s = connect(f.addr(service)).expect("connect");
        let stop = Arc::new(AtomicBool::new(false));
        let reader = drain(s.try_clone().expect("clone"), Arc::clone(&stop));
        let sent = write_some(&mut s, &program);
        assert_eq!(sent, program.len(), "{service} stopped reading");
        let grown = rss().saturating_sub(before);
        assert!(
            grown < (program.len() / 2) as u64,
            "{service}: the process grew by {grown} bytes for an endless program"
        );
        f.healthy(&format!("an endless program on {service}"));
        let _ = s.shutdown(Shutdown::Both);
        stop.store(true, Ordering::SeqCst);
        let _ = reader.join();
    }
    // RTDE setup floods from a client that never reads its replies: its replies are
    // bounded (it is dropped, or its packages are skipped), the others go on.
    {
        let mut s = connect(f.addr("rtde")).expect("connect");
        s.write_all(&rtde_packet(b'V', &2u16.to_be_bytes()))
            .expect("write");
        let mut flood = Vec::new();
        let mut setup = 500.0f64.to_be_bytes().to_vec();
        setup.extend_from_slice(b"timestamp,actual_q,actual_TCP_pose,target_qd,runtime_state");
        let inputs = b"input_int_register_0,input_double_register_1,speed_slider_mask".to_vec();
        for _ in 0..20_000 {
            flood.extend_from_slice(&rtde_packet(b'O', &setup));
            flood.extend_from_slice(&rtde_packet(b'I', &inputs));
        }
        flood.extend_from_slice(&rtde_packet(b'S', &[]));
        let _ = s.set_write_timeout(Some(Duration::from_secs(2)));
        write_some(&mut s, &flood);
        f.healthy("an RTDE setup flood from a client that does not read");
    }
    // Dashboard command floods: from every slot at once, nobody reading the replies
    // (each connection ends once its replies cannot be written, WRITE_TIMEOUT).
    {
        let lines = b"robotmode\nprogramState\nget serial number\n".repeat(20_000);
        let floods: Vec<_> = (0..MAX_CONNECTIONS - 1)
            .map(|_| {
                let addr = f.addr("dashboard");
                let lines = lines.clone();
                thread::spawn(move || {
                    if let Ok(mut s) = connect(addr) {
                        let _ = s.set_write_timeout(Some(Duration::from_secs(2)));
                        write_some(&mut s, &lines);
                    }
                })
            })
            .collect();
        for t in floods {
            let _ = t.join();
        }
        f.healthy("dashboard command floods");
    }
    // Interpreter lines flood, nobody reading the replies (no program runs: each is
    // discarded; the connection ends once its replies cannot be written).
    {
        let mut s = connect(f.addr("interpreter")).expect("connect");
        let _ = s.set_write_timeout(Some(Duration::from_secs(2)));
        let lines = b"x = 1\n".repeat(200_000);
        write_some(&mut s, &lines);
        f.healthy("an interpreter line flood");
    }
}

#[test]
fn connection_floods_half_closes_and_reconnect_storms() {
    let _turn = serial();
    let f = start();
    // Floods beyond the limits, on every port, held open.
    for service in ALL_PORTS {
        let limit = match service {
            "dashboard" => MAX_CONNECTIONS,
            "interpreter" => MAX_INTERPRETER_CONNECTIONS,
            _ => MAX_CLIENTS,
        };
        let mut held = Vec::new();
        for _ in 0..limit + 16 {
            if let Ok(s) = connect(f.addr(service)) {
                held.push(s);
            }
        }
        check_threads(&format!("a flood of {} on {service}", held.len()));
        // Those past the limit were closed by the server: a read ends (bounded).
        let mut closed = 0;
        for s in held.iter_mut().rev().take(16) {
            let _ = s.set_read_timeout(Some(Duration::from_secs(2)));
            let mut buf = [0u8; 4096];
            // A served stream client gets data without end: at most 50 reads.
            for _ in 0..50 {
                match s.read(&mut buf) {
                    Ok(0) => {
                        closed += 1;
                        break;
                    }
                    Err(_) => break,
                    Ok(_) => {}
                }
            }
        }
        assert!(
            closed > 0,
            "{service}: no connection past the limit was closed"
        );
        drop(held);
        // Once the flood is gone, its slots come back (healthy waits for them).
        f.healthy(&format!("a connection flood on {service}"));
    }
    // Half-closed sockets: the client sends, shuts its writing side, and reads.
    for service in ALL_PORTS {
        let mut s = connect(f.addr(service)).expect("connect");
        let _ = s.write_all(b"robotmode\n");
        let _ = s.shutdown(Shutdown::Write);
        let _ = s.set_read_timeout(Some(Duration::from_secs(2)));
        let mut buf = [0u8; 4096];
        for _ in 0..100 {
            if !matches!(s.read(&mut buf), Ok(n) if n > 0) {
                break;
            }
        }
        // And one that shuts its reading side and keeps sending.
        let mut s = connect(f.addr(service)).expect("connect");
        let _ = s.shutdown(Shutdown::Read);
        for _ in 0..100 {
            if s.write_all(b"robotmode\n").is_err() {
                break;
            }
        }
        f.healthy(&format!("half-closed sockets on {service}"));
    }
    // Reconnect storms: connect, say a little, leave, many times over on every port.
    for service in ALL_PORTS {
        for i in 0..150u32 {
            if let Ok(mut s) = TcpStream::connect_timeout(&f.addr(service), WAIT) {
                if i % 2 == 0 {
                    let _ = s.write_all(b"robotmode\n");
                }
            }
        }
        f.healthy(&format!("a reconnect storm on {service}"));
    }
    // Every connection thread ends once its client is gone.
    poll_until(
        WAIT,
        || connection_threads() == 0,
        || {
            format!(
                "{} connection threads outlive their clients",
                connection_threads()
            )
        },
    );
}

#[test]
fn clients_that_never_read_are_bounded_and_slow_nothing_down() {
    let _turn = serial();
    let f = start();
    let before = rss();
    // Stream clients that connect and never read.
    let mut idle = Vec::new();
    for service in ["primary", "secondary", "realtime", "rtde"] {
        for _ in 0..8 {
            idle.push(connect(f.addr(service)).expect("connect"));
        }
    }
    // A primary client that never reads while a program floods it with messages: past
    // MAX_QUEUE it is dropped ("the client stopped reading").
    let deaf = connect(f.addr("primary")).expect("connect");
    let deaf_conn = f.wait_log("the deaf client's connection", |l| {
        l.connects
            .iter()
            .rev()
            .find(|(_, s)| *s == "primary")
            .map(|(c, _)| *c)
    });
    running(&f.server);
    let mut p = connect(f.addr("primary")).expect("connect");
    let text = "m".repeat(1000);
    p.write_all(
        format!(
            "def spam():\n  while True:\n    i = 0\n    while i < 40:\n      textmsg(\"{text}\")\n      i = i + 1\n    end\n    sync()\n  end\nend\n"
        )
        .as_bytes(),
    )
    .expect("write");
    let reason = f.wait_log("the deaf primary client dropped", |l| {
        l.closes
            .iter()
            .find(|(c, _)| *c == deaf_conn)
            .map(|(_, r)| r.clone())
    });
    assert_eq!(reason, "the client stopped reading");
    assert_eq!(
        dashboard_ask(f.addr("dashboard"), "stop").expect("stop"),
        "Stopped"
    );
    // The realtime clients that never read: their packages skipped, then, after
    // MAX_STALL of taking nothing, dropped.
    let realtime: Vec<u64> = f
        .log()
        .connects
        .iter()
        .filter(|(_, s)| *s == "realtime")
        .map(|(c, _)| *c)
        .collect();
    assert_eq!(realtime.len(), 8);
    let dropped = || {
        f.log()
            .closes
            .iter()
            .filter(|(c, r)| realtime.contains(c) && r == "the client stopped reading")
            .count()
    };
    poll_until(
        WAIT + MAX_STALL,
        || dropped() == realtime.len(),
        || {
            format!(
                "only {} of the deaf realtime clients were dropped",
                dropped()
            )
        },
    );
    f.healthy("clients that never read");
    let grown = rss().saturating_sub(before);
    // 33 clients, each at most MAX_QUEUE (4 MiB) queued: well under this.
    assert!(
        grown < 33 * 4 * 1024 * 1024 + 64 * 1024 * 1024,
        "the process grew by {grown} bytes for clients that never read"
    );
    drop(idle);
    drop(deaf);
}

/// A primary client that reads everything, keeping the last 4 MiB.
struct Primary {
    stop: Arc<AtomicBool>,
    bytes: Arc<Mutex<Vec<u8>>>,
    thread: Option<thread::JoinHandle<()>>,
    stream: TcpStream,
}

impl Primary {
    fn connect(addr: SocketAddr) -> Primary {
        let stream = connect(addr).expect("connect");
        let mut r = stream.try_clone().expect("clone");
        let _ = r.set_read_timeout(Some(Duration::from_millis(50)));
        let stop = Arc::new(AtomicBool::new(false));
        let bytes = Arc::new(Mutex::new(Vec::new()));
        let thread = thread::spawn({
            let (stop, bytes) = (Arc::clone(&stop), Arc::clone(&bytes));
            move || {
                let mut buf = [0u8; 64 * 1024];
                while !stop.load(Ordering::SeqCst) {
                    match r.read(&mut buf) {
                        Ok(0) => return,
                        Ok(n) => {
                            let mut b = bytes.lock().unwrap_or_else(|p| p.into_inner());
                            b.extend_from_slice(&buf[..n]);
                            if b.len() > 4 << 20 {
                                let cut = b.len() - (4 << 20);
                                b.drain(..cut);
                            }
                        }
                        Err(e)
                            if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {}
                        Err(_) => return,
                    }
                }
            }
        });
        Primary {
            stop,
            bytes,
            thread: Some(thread),
            stream,
        }
    }

    fn saw(&self, text: &str) -> bool {
        let b = self.bytes.lock().unwrap_or_else(|p| p.into_inner());
        b.windows(text.len()).any(|w| w == text.as_bytes())
    }
}

impl Drop for Primary {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

#[test]
fn hostile_programs_end_in_runtime_errors_and_the_next_program_runs() {
    let _turn = serial();
    let f = start();
    running(&f.server);
    // A server for the programs' sockets: it takes every connection and keeps it.
    let server = TcpListener::bind("127.0.0.1:0").expect("bind");
    let port = server.local_addr().expect("addr").port();
    let stop = Arc::new(AtomicBool::new(false));
    let acceptor = {
        let stop = Arc::clone(&stop);
        server.set_nonblocking(true).expect("nonblocking");
        thread::spawn(move || {
            let mut kept = Vec::new();
            while !stop.load(Ordering::SeqCst) && kept.len() < 10_000 {
                match server.accept() {
                    Ok((s, _)) => kept.push(s),
                    Err(_) => thread::sleep(Duration::from_millis(1)),
                }
            }
        })
    };
    let programs: [(&str, String, &str); 4] = [
        (
            "allocation",
            "def grow():\n  l = [1, 2]\n  while True:\n    l = [l, l]\n    sync()\n  end\nend\n"
                .to_string(),
            "more than 1000000 elements",
        ),
        (
            "recursion",
            "def deep():\n  def r(n):\n    return r(n + 1)\n  end\n  r(0)\nend\n".to_string(),
            "nested too deeply",
        ),
        (
            "thread storm",
            "def storm():\n  thread t():\n    sleep(100)\n  end\n  while True:\n    h = run t()\n    sync()\n  end\nend\n"
                .to_string(),
            "more than 64 threads",
        ),
        (
            "socket storm",
            format!(
                "def sockets():\n  i = 0\n  while True:\n    socket_open(\"127.0.0.1\", {port}, str_cat(\"s\", i))\n    i = i + 1\n  end\nend\n"
            ),
            "64 sockets are open already",
        ),
    ];
    let primary = Primary::connect(f.addr("primary"));
    let mut sender = connect(f.addr("primary")).expect("connect");
    for (n, (what, source, expected)) in programs.iter().enumerate() {
        let seen = f.log().programs.len();
        sender.write_all(source.as_bytes()).expect("send");
        let (how, text) = f.wait_log(&format!("the {what} program's end"), |l| {
            l.programs[seen.min(l.programs.len())..]
                .iter()
                .find(|(w, _, _)| w != "started")
                .map(|(w, _, t)| (w.clone(), t.clone().unwrap_or_default()))
        });
        assert_eq!(how, "error", "the {what} program ended {how}: {text}");
        assert!(
            text.contains(expected),
            "the {what} program's error: {text}"
        );
        poll_until(
            WAIT,
            || primary.saw(&text),
            || format!("the primary client never heard of the {what} program's error {text:?}"),
        );
        // The next program runs.
        let hello = format!("next program {n}");
        sender
            .write_all(format!("def next():\n  textmsg(\"{hello}\")\nend\n").as_bytes())
            .expect("send");
        f.wait_log(&format!("the program after the {what} one"), |l| {
            l.messages.contains(&hello).then_some(())
        });
        f.healthy(&format!("the {what} program"));
    }
    stop.store(true, Ordering::SeqCst);
    let _ = acceptor.join();
    let _ = primary.stream.shutdown(Shutdown::Both);
}

#[test]
fn connects_to_a_server_that_never_answers_block_nothing() {
    let _turn = serial();
    let f = start();
    running(&f.server);
    // A server that never answers: a listener that never accepts, its backlog full, so
    // the kernel drops further SYNs and a connect waits out its timeout.
    let blackhole = TcpListener::bind("127.0.0.1:0").expect("bind");
    let addr = blackhole.local_addr().expect("addr");
    let mut filling = Vec::new();
    for _ in 0..4096 {
        match TcpStream::connect_timeout(&addr, Duration::from_millis(300)) {
            Ok(s) => filling.push(s),
            Err(_) => break,
        }
    }
    let port = addr.port();
    // Forty program threads connecting to it over and over: were a connect made in the
    // real-time loop, the loop (and the dashboard, waiting for the cell) would hang for
    // the connect timeout of each in turn.
    let mut p = connect(f.addr("primary")).expect("connect");
    p.write_all(
        format!(
            "def hang():\n  thread t():\n    while True:\n      socket_open(\"127.0.0.1\", {port}, \"x\")\n    end\n  end\n  i = 0\n  while i < 40:\n    h = run t()\n    i = i + 1\n  end\n  while True:\n    sync()\n  end\nend\n"
        )
        .as_bytes(),
    )
    .expect("send");
    f.wait_log("the program started", |l| {
        l.programs
            .iter()
            .any(|(w, _, _)| w == "started")
            .then_some(())
    });
    for round in 0..3 {
        f.healthy(&format!("connects that never finish (round {round})"));
    }
    let stopped = dashboard_ask(f.addr("dashboard"), "stop").expect("stop");
    assert_eq!(stopped, "Stopped");
    p.write_all(b"def after():\n  textmsg(\"after the hang\")\nend\n")
        .expect("send");
    f.wait_log("the next program", |l| {
        l.messages
            .iter()
            .any(|m| m == "after the hang")
            .then_some(())
    });
    f.healthy("a program whose connects never finished");
    drop(filling);
}

#[test]
fn an_interpreter_flood_while_a_program_is_in_interpreter_mode() {
    let _turn = serial();
    let f = start();
    running(&f.server);
    let mut p = connect(f.addr("primary")).expect("connect");
    p.write_all(b"def im():\n  interpreter_mode()\nend\n")
        .expect("send");
    f.wait_log("the interpreter program started", |l| {
        l.programs
            .iter()
            .any(|(w, _, _)| w == "started")
            .then_some(())
    });
    let lines = b"x = [1, 2, 3]\nsleep(10)\ntextmsg(\"flood\")\n".repeat(60_000);
    let before = rss();
    // Two flooders that never read their replies, and one that floods without newlines.
    let mut floods = Vec::new();
    for _ in 0..2 {
        let mut s = connect(f.addr("interpreter")).expect("connect");
        let _ = s.set_write_timeout(Some(Duration::from_secs(2)));
        write_some(&mut s, &lines);
        floods.push(s);
    }
    f.healthy("an interpreter flood in interpreter mode");
    let grown = rss().saturating_sub(before);
    assert!(
        grown < lines.len() as u64,
        "the process grew by {grown} bytes for an interpreter flood of {} bytes",
        2 * lines.len()
    );
    // A client that reads gets answers still.
    let mut s = connect(f.addr("interpreter")).expect("connect");
    s.write_all(b"statelastexecuted\n").expect("send");
    let reply = read_line(&mut s).expect("a reply");
    assert!(reply.starts_with("state: "), "{reply:?}");
    drop(floods);
    let _ = dashboard_ask(f.addr("dashboard"), "stop");
    f.healthy("an interpreter flood, the program stopped");
}

#[test]
fn a_tight_loop_runs_on_a_slice_per_step_and_the_controller_still_serves() {
    let _turn = serial();
    let f = start();
    running(&f.server);
    let mut sender = connect(f.addr("primary")).expect("connect");
    let seen = f.log().programs.len();
    sender
        .write_all(b"def spin():\n  x = 0\n  while True:\n    x = x + 1\n  end\nend\n")
        .expect("send");
    f.wait_log("the tight loop's start", |l| {
        l.programs[seen.min(l.programs.len())..]
            .iter()
            .any(|(w, _, _)| w == "started")
            .then_some(())
    });
    thread::sleep(Duration::from_millis(500));
    // The manual's "Thread scheduling": it uses its slice and waits for the next frame;
    // it is not stopped.
    let ended: Vec<_> = f.log().programs[seen..]
        .iter()
        .filter(|(w, _, _)| w != "started")
        .cloned()
        .collect();
    assert!(ended.is_empty(), "the tight loop ended: {ended:?}");
    f.healthy("a tight loop");
    let hello = "after the tight loop";
    sender
        .write_all(format!("def next():\n  textmsg(\"{hello}\")\nend\n").as_bytes())
        .expect("send");
    f.wait_log("the program after the tight loop", |l| {
        l.messages.iter().any(|m| m == hello).then_some(())
    });
}
