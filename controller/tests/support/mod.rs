//! What the controller's TCP tests share: an in-process [`Server`] on loopback with its
//! events, clients of its line and RTDE services, and bounded waits. Every read and wait
//! ends within [`WAIT`].

// Each test file uses a part of this module.
#![allow(dead_code)]

use std::io::{BufRead, BufReader, ErrorKind, Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::sync::{mpsc, Arc, Mutex, MutexGuard};
use std::thread;
use std::time::{Duration, Instant};

use urscript_controller::net::{Ports, Server, ServerEvent, ServerOptions};

/// The longest any wait of these tests lasts before the test fails.
pub const WAIT: Duration = Duration::from_secs(20);

/// How often a polling wait tries again.
pub const POLL: Duration = Duration::from_millis(20);

/// Tries `done` every [`POLL`] until it holds. After `limit` the test fails, saying
/// `why()` (worked out then, so that it can tell how far the wait got).
pub fn poll_until(limit: Duration, mut done: impl FnMut() -> bool, why: impl Fn() -> String) {
    let start = Instant::now();
    while !done() {
        assert!(start.elapsed() < limit, "{}", why());
        thread::sleep(POLL);
    }
}

/// Tries `f` every [`POLL`] until it succeeds; after [`WAIT`] the test fails with
/// `what` and the last error.
pub fn eventually<T>(what: &str, mut f: impl FnMut() -> std::io::Result<T>) -> T {
    let start = Instant::now();
    loop {
        match f() {
            Ok(t) => return t,
            Err(e) => assert!(start.elapsed() < WAIT, "{what}: {e}"),
        }
        thread::sleep(POLL);
    }
}

/// Options for a server on loopback, every port chosen by the system.
pub fn any_ports() -> ServerOptions {
    ServerOptions {
        ports: Ports::any(),
        ..ServerOptions::default()
    }
}

/// A server on any ports, its events on a channel.
pub fn start() -> (Server, mpsc::Receiver<ServerEvent>) {
    start_with(any_ports())
}

/// A server with `options`, its events on a channel.
pub fn start_with(options: ServerOptions) -> (Server, mpsc::Receiver<ServerEvent>) {
    let (tx, rx) = mpsc::channel();
    let tx = Mutex::new(tx);
    let server = Server::start(options, move |e| {
        let _ = tx.lock().unwrap_or_else(|p| p.into_inner()).send(e);
    })
    .expect("the server starts");
    (server, rx)
}

/// The first event `want` accepts (at most [`WAIT`]).
pub fn wait_for(
    rx: &mpsc::Receiver<ServerEvent>,
    want: impl Fn(&ServerEvent) -> bool,
) -> ServerEvent {
    let start = Instant::now();
    loop {
        let e = rx
            .recv_timeout(WAIT.saturating_sub(start.elapsed()))
            .expect("the event");
        if want(&e) {
            return e;
        }
    }
}

/// A server whose events a test folds into a log of its own (`L`), so that a flood of
/// events does not grow the test.
pub struct Fixture<L> {
    pub server: Server,
    log: Arc<Mutex<L>>,
}

/// Starts a server with `options`, each event given to `record` with the log.
pub fn start_logging<L: Default + Send + 'static>(
    options: ServerOptions,
    record: impl Fn(&mut L, ServerEvent) + Send + Sync + 'static,
) -> Fixture<L> {
    let log = Arc::new(Mutex::new(L::default()));
    let sink = Arc::clone(&log);
    let server = Server::start(options, move |e| {
        record(&mut sink.lock().unwrap_or_else(|p| p.into_inner()), e);
    })
    .expect("the server starts");
    Fixture { server, log }
}

impl<L> Fixture<L> {
    pub fn addr(&self, service: &str) -> SocketAddr {
        self.server.addr(service).expect("the service listens")
    }

    pub fn log(&self) -> MutexGuard<'_, L> {
        self.log.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Waits (at most [`WAIT`]) until `f` finds something in the log.
    pub fn wait_log<T>(&self, what: &str, f: impl Fn(&L) -> Option<T>) -> T {
        let start = Instant::now();
        loop {
            if let Some(t) = f(&self.log()) {
                return t;
            }
            assert!(start.elapsed() < WAIT, "never saw {what}");
            thread::sleep(Duration::from_millis(10));
        }
    }
}

/// A connection with [`WAIT`] as its read and write timeouts.
pub fn connect(addr: SocketAddr) -> std::io::Result<TcpStream> {
    let s = TcpStream::connect_timeout(&addr, WAIT)?;
    s.set_read_timeout(Some(WAIT))?;
    s.set_write_timeout(Some(WAIT))?;
    Ok(s)
}

/// A connection to `service` on `server`, with [`WAIT`] as its timeouts.
pub fn connect_to(server: &Server, service: &str) -> TcpStream {
    connect(server.addr(service).expect("the service listens")).expect("connect")
}

/// Reads one line without its newline (bounded by [`WAIT`] per read and by 64 KiB);
/// reads byte by byte, so nothing after the line is taken from the socket.
pub fn read_line(s: &mut TcpStream) -> std::io::Result<String> {
    let mut line = Vec::new();
    let mut b = [0u8; 1];
    while line.len() < 64 * 1024 {
        match s.read(&mut b)? {
            0 => return Err(ErrorKind::UnexpectedEof.into()),
            _ if b[0] == b'\n' => return Ok(String::from_utf8_lossy(&line).into_owned()),
            _ => line.push(b[0]),
        }
    }
    Err(ErrorKind::InvalidData.into())
}

/// A client of a line service (dashboard, interpreter): sends lines, reads reply lines.
pub struct LineClient {
    reader: BufReader<TcpStream>,
    pub writer: TcpStream,
}

impl LineClient {
    /// A client of `service` on `server`.
    pub fn new(server: &Server, service: &str) -> LineClient {
        LineClient::on(connect_to(server, service))
    }

    pub fn on(s: TcpStream) -> LineClient {
        LineClient {
            reader: BufReader::new(s.try_clone().expect("clone")),
            writer: s,
        }
    }

    /// A dashboard client past its greeting.
    pub fn dashboard(server: &Server) -> LineClient {
        let mut d = LineClient::new(server, "dashboard");
        assert_eq!(
            d.read_line(),
            "Connected: Universal Robots Dashboard Server"
        );
        d
    }

    /// The next whole line, without its newline (and a `\r` before it).
    pub fn read_line(&mut self) -> String {
        let mut line = String::new();
        self.reader.read_line(&mut line).expect("a line");
        assert!(line.ends_with('\n'), "a whole line: {line:?}");
        line.pop();
        if line.ends_with('\r') {
            line.pop();
        }
        line
    }

    /// Sends one line, reads the one reply line.
    pub fn say(&mut self, text: &str) -> String {
        self.writer
            .write_all(format!("{text}\n").as_bytes())
            .expect("send");
        self.read_line()
    }
}

/// A dashboard client past its greeting (no panic: a flood may refuse it).
pub fn dashboard(addr: SocketAddr) -> std::io::Result<TcpStream> {
    let mut s = connect(addr)?;
    let greeting = read_line(&mut s)?;
    if !greeting.starts_with("Connected") {
        return Err(std::io::Error::other(format!("greeting {greeting:?}")));
    }
    Ok(s)
}

/// Sends `command`, reads its one reply line.
pub fn ask(s: &mut TcpStream, command: &str) -> std::io::Result<String> {
    s.write_all(format!("{command}\n").as_bytes())?;
    read_line(s)
}

/// Releases the brakes on the dashboard and waits until the arm is RUNNING.
pub fn running(server: &Server) {
    let mut d = LineClient::dashboard(server);
    assert_eq!(d.say("brake release"), "Brake releasing");
    poll_until(
        WAIT,
        || d.say("robotmode") == "Robotmode: RUNNING",
        || "the arm never ran".into(),
    );
}

/// An RTDE packet: size, type, payload.
pub fn rtde_packet(kind: u8, payload: &[u8]) -> Vec<u8> {
    let size = u16::try_from(payload.len() + 3).expect("a small packet");
    let mut p = size.to_be_bytes().to_vec();
    p.push(kind);
    p.extend_from_slice(payload);
    p
}

/// The next RTDE packet: its type and payload.
pub fn rtde_read(s: &mut TcpStream) -> std::io::Result<(u8, Vec<u8>)> {
    let mut head = [0u8; 3];
    s.read_exact(&mut head)?;
    let size = usize::from(u16::from_be_bytes([head[0], head[1]]));
    let mut payload = vec![0u8; size.saturating_sub(3)];
    s.read_exact(&mut payload)?;
    Ok((head[2], payload))
}

/// Reads RTDE packets until one of type `kind` (at most 10 000 packets).
pub fn rtde_expect(s: &mut TcpStream, kind: u8) -> std::io::Result<Vec<u8>> {
    for _ in 0..10_000 {
        let (k, p) = rtde_read(s)?;
        if k == kind {
            return Ok(p);
        }
    }
    Err(std::io::Error::other(format!("no packet {}", kind as char)))
}

/// A protocol-2 RTDE session: version accepted.
pub fn rtde_session(addr: SocketAddr) -> std::io::Result<TcpStream> {
    let mut s = connect(addr)?;
    s.write_all(&rtde_packet(b'V', &2u16.to_be_bytes()))?;
    let accepted = rtde_expect(&mut s, b'V')?;
    if accepted != [1] {
        return Err(std::io::Error::other("protocol 2 refused"));
    }
    Ok(s)
}
