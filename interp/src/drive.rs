//! Running a [`Machine`] in real time against real TCP servers (`std::net`): **the** driver
//! loop, used by `ursock robot` and by library users alike. What a front end needs to
//! show (bytes per socket, connect failures, peers that close) reaches it through an
//! observer ([`Activity`]); the front end keeps no loop of its own.
//!
//! [`Driver`] is a small poll loop. Each round it runs the machine up to program time,
//! acts on the machine's events, writes what is queued and reads what the servers sent;
//! between rounds it sleeps until the machine's next timeout, at most
//! [`Options::poll_interval`]. `socket_open` connects with a blocking
//! `TcpStream::connect_timeout`.
//!
//! ## Time
//! Program time is the real time since the start (`Instant`), less the time the
//! interpreter overran: a round whose step (its statements, a blocking connect) takes
//! longer than one step of real time holds program time at that step instead of leaving
//! the program behind real time. So a program on a slow host, or with a tiny step time,
//! runs its steps one round at a time with the sockets serviced between any two; every
//! wait (a read's timeout, a `sleep`) lasts its real length; and a reply a server sent at
//! once reaches the read that waits for it. A step that keeps up is not delayed: program
//! time then is real time.
//!
//!
//! With [`Options::virtual_time`], a program with no connection open does not wait in
//! real time: program time jumps to its next wake (a `sleep`'s end, a move's), so it
//! runs faster than real time with the same results (the same steps run, at the same
//! program times). Once it opens a connection, time is real again until it closes.
//!
//! ## Bounds
//! - Bytes the program sends are written without blocking; what a server does not read
//!   waits in a per-socket queue of at most [`MAX_UNSENT`] bytes. Past that the
//!   connection counts as broken, as a failed write does: later sends on it return
//!   `False`, and reads on it end with their sentinels. [`Options::max_time`] is honoured
//!   whatever the servers do.
//! - Bytes read from a server that the socket's receive buffer cannot take yet stay in a
//!   backlog, and no more is read from that server until the program has taken them (a
//!   full TCP window, as on the robot).

use std::collections::HashMap;
use std::io::{ErrorKind, Read, Write};
use std::net::{Shutdown, TcpStream, ToSocketAddrs};
use std::time::{Duration, Instant};

use crate::error::RuntimeError;
use crate::event::Event;
use crate::vm::{Machine, State};

/// The most bytes a socket keeps queued for a server that does not read them.
pub const MAX_UNSENT: usize = 16 * 1024 * 1024;

/// How a [`Driver`] runs.
#[derive(Debug, Clone)]
pub struct Options {
    /// End a program that runs longer than this (it counts as a success).
    pub max_time: Option<Duration>,
    /// How long `socket_open` may take to connect before it returns `False`.
    pub connect_timeout: Duration,
    /// The longest sleep between two rounds of reading the sockets.
    pub poll_interval: Duration,
    /// Run in virtual time while the program has no connection open: a wait (a
    /// `sleep`, a move, a read's timeout) ends at once instead of lasting its real
    /// length, and the program gives the same results faster than real time. While a
    /// connection is open, time is real (a server answers in real time). With it,
    /// [`max_time`](Self::max_time) counts program time.
    pub virtual_time: bool,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            max_time: None,
            connect_timeout: Duration::from_secs(2),
            poll_interval: Duration::from_millis(1),
            virtual_time: false,
        }
    }
}

/// What a [`Driver`] reports as it runs: the machine's events, and what the servers did
/// (for a trace that shows both directions, or a diagnosis of failed reads).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Activity<'a> {
    /// An event of the machine, before the driver acts on it.
    Event(&'a Event),
    /// Bytes a server sent on a socket, as read.
    Received {
        /// The socket's name.
        socket_name: &'a str,
        /// The bytes.
        bytes: &'a [u8],
    },
    /// A server closed its end.
    PeerClosed {
        /// The socket's name.
        socket_name: &'a str,
    },
    /// Writing to a server failed (it reset the connection, or left more than
    /// [`MAX_UNSENT`] bytes unread): later sends on the socket return `False`.
    SendFailed {
        /// The socket's name.
        socket_name: &'a str,
        /// Why, in words.
        reason: &'a str,
    },
}

/// How a program run by a [`Driver`] ended without error.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// The program ended.
    Finished,
    /// `halt` ran.
    Halted,
    /// [`Options::max_time`] passed first.
    MaxTime,
    /// The arm made a protective stop (a `movel`/`movep`/`movec` whose path left the
    /// arm's reach, or `protective_stop()`; [`Effect::ProtectiveStop`](crate::Effect)). A
    /// controller pauses the program there until an operator resumes it; with no
    /// operator, the driver stops running it.
    ProtectiveStop,
}

/// One open connection of the program.
struct Conn {
    stream: TcpStream,
    /// Bytes read but not yet accepted by the socket's receive buffer.
    backlog: Vec<u8>,
    /// Bytes the program sent that the server has not taken yet.
    unsent: Vec<u8>,
    /// The server closed its end.
    closed: bool,
    /// A write failed: nothing more is written or read.
    broken: bool,
}

impl Conn {
    fn new(stream: TcpStream) -> Self {
        Conn {
            stream,
            backlog: Vec::new(),
            unsent: Vec::new(),
            closed: false,
            broken: false,
        }
    }
}

/// The real-time TCP driver of a [`Machine`]. See the module docs.
///
/// ```no_run
/// use urscript_interp::{drive::{Driver, Options}, Config, Machine, Program};
/// let program = Program::parse(&std::fs::read_to_string("prog.script")?)?;
/// let mut machine = Machine::new(program, Config::default());
/// let mut driver = Driver::new(Options::default());
/// driver.connect(&mut machine, "socket_0", "127.0.0.1", 30000)?; // opened before the start
/// let outcome = driver.run(&mut machine, |a| println!("{a:?}"))?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct Driver {
    options: Options,
    conns: HashMap<String, Conn>,
    buf: Vec<u8>,
}

impl Driver {
    /// A driver with no connection open.
    pub fn new(options: Options) -> Self {
        Driver {
            options,
            conns: HashMap::new(),
            buf: vec![0u8; 16 * 1024],
        }
    }

    /// Opens `socket_name` to `host:port` before the program starts, as if the program
    /// had called `socket_open` (the CLI's `--connect`). The error is the reason, in
    /// words ([`describe_connect_error`]).
    pub fn connect(
        &mut self,
        machine: &mut Machine,
        socket_name: &str,
        host: &str,
        port: u16,
    ) -> Result<(), String> {
        let stream = connect_stream(host, port, self.options.connect_timeout)
            .map_err(|e| describe_connect_error(host, port, &e))?;
        self.conns
            .insert(socket_name.to_string(), Conn::new(stream));
        machine.handle_connected(socket_name, Ok(()));
        Ok(())
    }

    /// Answers the machine's [`Event::Connect`] for `socket_name` with the outcome of a
    /// connect made elsewhere (a caller whose loop must not block on a connect, as a
    /// virtual controller's real-time loop, connects in a thread of its own with
    /// [`connect_stream`], then hands the stream, or the reason in words, here).
    pub fn adopt(
        &mut self,
        machine: &mut Machine,
        socket_name: &str,
        result: Result<TcpStream, String>,
    ) {
        match result {
            Ok(stream) => {
                if let Some(old) = self
                    .conns
                    .insert(socket_name.to_string(), Conn::new(stream))
                {
                    let _ = old.stream.shutdown(Shutdown::Both);
                }
                machine.handle_connected(socket_name, Ok(()));
            }
            Err(why) => machine.handle_connected(socket_name, Err(why)),
        }
    }

    /// Runs `machine` against real servers until it ends, fails, or
    /// [`Options::max_time`] passes. `on_activity` sees every event first, and every
    /// read from a server; a runtime error is the `Err`. The machine stays with the
    /// caller, to read its globals or arm state afterwards.
    pub fn run(
        &mut self,
        machine: &mut Machine,
        mut on_activity: impl FnMut(Activity<'_>),
    ) -> Result<Outcome, RuntimeError> {
        let start = Instant::now();
        // Program time is real time minus `lag`: the time the interpreter overran its
        // steps. A step that takes longer than a step (a slow host, a tiny step time)
        // delays program time instead of leaving the program behind it, so every wait
        // (a read's timeout, a sleep) lasts its real duration and the sockets are serviced
        // between any two steps, however slow the steps are.
        let mut lag = Duration::ZERO;
        // Virtual time: the program time skipped (waits that ended at once).
        let mut skipped = Duration::ZERO;
        loop {
            let elapsed = start.elapsed();
            let program_time = (elapsed + skipped).saturating_sub(lag);
            let limit = if self.options.virtual_time {
                program_time
            } else {
                elapsed
            };
            if self.options.max_time.is_some_and(|m| limit >= m) {
                return Ok(Outcome::MaxTime);
            }
            let now = program_time;
            // Behind by more than a step (the last step overran, a connection took long
            // to open): program time resumes at the step that is due, not past it.
            let slack = machine.step_time();
            let due = match machine.poll_timeout() {
                Some(wake) if now > wake + slack => {
                    lag += now - wake;
                    wake
                }
                _ => now,
            };
            machine.run_until(due);
            self.act_on_events(machine, &mut on_activity);
            // What the step did (its statements, a blocking connect) happened at `due`:
            // time it overran by more than a step is not program time.
            let overrun = start.elapsed().saturating_sub(lag).saturating_sub(due);
            if overrun > slack {
                lag += overrun;
            }
            let stopped = machine.effects().contains(&crate::Effect::ProtectiveStop);
            if stopped && !matches!(machine.state(), State::Error(_)) {
                return Ok(Outcome::ProtectiveStop);
            }
            match machine.state() {
                State::Running => {}
                State::Finished => return Ok(Outcome::Finished),
                State::Halted => return Ok(Outcome::Halted),
                State::Error(e) => return Err(e.clone()),
            }
            let busy = self.service_sockets(machine, &mut on_activity);
            if !busy && self.options.virtual_time && self.conns.is_empty() {
                // No peer to wait for: program time jumps to the next wake.
                let now = (start.elapsed() + skipped).saturating_sub(lag);
                if let Some(wake) = machine.poll_timeout() {
                    let mut jump = wake.saturating_sub(now);
                    if let Some(m) = self.options.max_time {
                        jump = jump.min(m.saturating_sub(now));
                    }
                    if !jump.is_zero() {
                        skipped += jump;
                        continue;
                    }
                }
            }
            if !busy {
                let now = (start.elapsed() + skipped).saturating_sub(lag);
                let mut wait = self.options.poll_interval;
                if let Some(wake) = machine.poll_timeout() {
                    wait = wait.min(wake.saturating_sub(now));
                }
                if let Some(m) = self.options.max_time {
                    let limit = if self.options.virtual_time {
                        now
                    } else {
                        start.elapsed()
                    };
                    wait = wait.min(m.saturating_sub(limit));
                }
                if !wait.is_zero() {
                    std::thread::sleep(wait);
                    // What arrived during the sleep reaches the machine before its time
                    // advances: a reply that came before a read's deadline is read, also
                    // when the sleep ends at the deadline or past it.
                    self.service_sockets(machine, &mut on_activity);
                }
            }
        }
    }

    fn act_on_events(&mut self, machine: &mut Machine, on_activity: &mut impl FnMut(Activity<'_>)) {
        while let Some(event) = machine.poll_event() {
            on_activity(Activity::Event(&event));
            self.handle_event(machine, event, on_activity);
        }
    }

    /// Acts on one event of `machine` that asks for the network (`Connect`, `Transmit`,
    /// `Close`); other events need nothing of the driver. For a caller with a loop of
    /// its own that takes the machine's events itself ([`Machine::poll_event`]), as a
    /// virtual controller does, then gives the sockets' ones here and calls
    /// [`poll_sockets`](Self::poll_sockets) each round.
    pub fn handle_event(
        &mut self,
        machine: &mut Machine,
        event: Event,
        on_activity: &mut impl FnMut(Activity<'_>),
    ) {
        match event {
            Event::Connect {
                socket_name,
                host,
                port,
            } => match connect_stream(&host, port, self.options.connect_timeout) {
                Ok(stream) => {
                    if let Some(old) = self.conns.insert(socket_name.clone(), Conn::new(stream)) {
                        let _ = old.stream.shutdown(Shutdown::Both);
                    }
                    machine.handle_connected(&socket_name, Ok(()));
                }
                Err(e) => {
                    let why = describe_connect_error(&host, port, &e);
                    machine.handle_connected(&socket_name, Err(why));
                }
            },
            Event::Transmit { socket_name, bytes } => {
                if let Some(c) = self.conns.get_mut(&socket_name) {
                    if !c.broken {
                        c.unsent.extend_from_slice(&bytes);
                        if let Err(reason) = flush(c) {
                            fail_send(machine, c, &socket_name, &reason, on_activity);
                        }
                    }
                }
            }
            Event::Close { socket_name } => {
                if let Some(mut c) = self.conns.remove(&socket_name) {
                    // What the program sent before closing still goes out, as far as
                    // the server takes it now.
                    let _ = flush(&mut c);
                    let _ = c.stream.shutdown(Shutdown::Both);
                }
            }
            Event::Message(_)
            | Event::Call(_)
            | Event::MoveStart(_)
            | Event::MoveEnd(_)
            | Event::Output(_) => {}
        }
    }

    /// Acts on one event a program left behind when it ended (its last sends, the
    /// closing of its sockets), with no machine left to tell of a failure: a `Transmit`
    /// is queued and written as far as the server takes it now, a `Close` closes that
    /// socket after writing what it holds. Without this, what a program sends just
    /// before its end would never reach the server.
    pub fn handle_event_after_end(&mut self, event: Event) {
        match event {
            Event::Transmit { socket_name, bytes } => {
                if let Some(c) = self.conns.get_mut(&socket_name) {
                    if !c.broken && c.unsent.len().saturating_add(bytes.len()) <= MAX_UNSENT {
                        c.unsent.extend_from_slice(&bytes);
                        if flush(c).is_err() {
                            c.broken = true;
                        }
                    }
                }
            }
            Event::Close { socket_name } => {
                if let Some(mut c) = self.conns.remove(&socket_name) {
                    let _ = flush(&mut c);
                    let _ = c.stream.shutdown(Shutdown::Both);
                }
            }
            Event::Connect { .. }
            | Event::Message(_)
            | Event::Call(_)
            | Event::MoveStart(_)
            | Event::MoveEnd(_)
            | Event::Output(_) => {}
        }
    }

    /// Closes every connection, sending what each still holds as far as its server
    /// takes it now: the program that opened them has ended.
    pub fn close_all(&mut self) {
        for (_, mut c) in self.conns.drain() {
            let _ = flush(&mut c);
            let _ = c.stream.shutdown(Shutdown::Both);
        }
    }

    /// Writes what is queued and reads what arrived on every connection; true if
    /// anything moved. See [`handle_event`](Self::handle_event).
    pub fn poll_sockets(
        &mut self,
        machine: &mut Machine,
        on_activity: &mut impl FnMut(Activity<'_>),
    ) -> bool {
        self.service_sockets(machine, on_activity)
    }

    /// Writes what is queued, reads what arrived; true if anything moved.
    fn service_sockets(
        &mut self,
        machine: &mut Machine,
        on_activity: &mut impl FnMut(Activity<'_>),
    ) -> bool {
        let mut busy = false;
        for (name, c) in self.conns.iter_mut() {
            if c.broken {
                continue;
            }
            if !c.unsent.is_empty() {
                let before = c.unsent.len();
                if let Err(reason) = flush(c) {
                    fail_send(machine, c, name, &reason, on_activity);
                    continue;
                }
                busy |= c.unsent.len() != before;
            }
            if !c.backlog.is_empty() {
                let n = machine.handle_received(name, &c.backlog);
                c.backlog.drain(..n);
                busy |= n > 0;
                if !c.backlog.is_empty() {
                    continue; // the receive buffer is full: read no more from it now
                }
            }
            if c.closed {
                // The peer closed its end: a reset after it (the peer is gone, a write
                // reached nobody) makes later sends fail, as on the controller.
                if matches!(c.stream.take_error(), Ok(Some(_)) | Err(_)) {
                    fail_send(
                        machine,
                        c,
                        name,
                        "the server reset the connection",
                        on_activity,
                    );
                }
                continue;
            }
            match c.stream.read(&mut self.buf) {
                Ok(0) => {
                    busy = true;
                    c.closed = true;
                    on_activity(Activity::PeerClosed { socket_name: name });
                    machine.handle_peer_closed(name);
                }
                Ok(n) => {
                    busy = true;
                    let bytes = &self.buf[..n];
                    on_activity(Activity::Received {
                        socket_name: name,
                        bytes,
                    });
                    let taken = machine.handle_received(name, bytes);
                    c.backlog.extend_from_slice(&bytes[taken..]);
                }
                Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::Interrupted) => {}
                Err(_) => {
                    busy = true;
                    c.closed = true;
                    on_activity(Activity::PeerClosed { socket_name: name });
                    machine.handle_peer_closed(name);
                }
            }
        }
        busy
    }
}

/// Marks a connection broken: the machine's later sends on it return `False`.
fn fail_send(
    machine: &mut Machine,
    c: &mut Conn,
    name: &str,
    reason: &str,
    on_activity: &mut impl FnMut(Activity<'_>),
) {
    c.broken = true;
    c.closed = true;
    c.unsent = Vec::new();
    on_activity(Activity::SendFailed {
        socket_name: name,
        reason,
    });
    machine.handle_send_failed(name);
}

/// Writes as much of the queue as the server takes now, without blocking; an error
/// (the reason) if the write failed or the queue passed [`MAX_UNSENT`].
fn flush(c: &mut Conn) -> Result<(), String> {
    let mut written = 0;
    let result = loop {
        if written == c.unsent.len() {
            break Ok(());
        }
        match c.stream.write(&c.unsent[written..]) {
            Ok(0) => break Err("the server stopped taking bytes".to_string()),
            Ok(n) => written += n,
            Err(e) if e.kind() == ErrorKind::WouldBlock => break Ok(()),
            Err(e) if e.kind() == ErrorKind::Interrupted => {}
            Err(e) => break Err(format!("a write failed ({e})")),
        }
    };
    c.unsent.drain(..written);
    result?;
    if c.unsent.len() > MAX_UNSENT {
        return Err(format!(
            "the server left more than {MAX_UNSENT} bytes unread"
        ));
    }
    Ok(())
}

/// Runs `machine` with a new [`Driver`]: see [`Driver::run`].
///
/// ```no_run
/// use urscript_interp::{drive, Config, Machine, Program};
/// let program = Program::parse(&std::fs::read_to_string("prog.script")?)?;
/// let mut machine = Machine::new(program, Config::default());
/// let outcome = drive::run_tcp(&mut machine, &drive::Options::default(), |a| println!("{a:?}"))?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn run_tcp(
    machine: &mut Machine,
    options: &Options,
    on_activity: impl FnMut(Activity<'_>),
) -> Result<Outcome, RuntimeError> {
    Driver::new(options.clone()).run(machine, on_activity)
}

/// Connects to `host:port` as `socket_open` does (each resolved address in turn, at most
/// `timeout` each), returning a non-blocking stream with Nagle off; the error is the
/// operating system's reason for the last address tried.
pub fn connect_stream(host: &str, port: u16, timeout: Duration) -> std::io::Result<TcpStream> {
    let mut last = std::io::Error::new(ErrorKind::InvalidInput, "no address");
    for addr in (host, port).to_socket_addrs()? {
        match TcpStream::connect_timeout(&addr, timeout) {
            Ok(s) => {
                s.set_nonblocking(true)?;
                let _ = s.set_nodelay(true);
                return Ok(s);
            }
            Err(e) => last = e,
        }
    }
    Err(last)
}

/// Why a connection failed, in words: what it usually means, and the OS reason.
///
/// ```
/// use std::io::{Error, ErrorKind};
/// let e = Error::from(ErrorKind::ConnectionRefused);
/// let why = urscript_interp::drive::describe_connect_error("10.0.0.5", 5000, &e);
/// assert!(why.starts_with("socket_open(\"10.0.0.5\", 5000) failed: connection refused"));
/// ```
pub fn describe_connect_error(host: &str, port: u16, e: &std::io::Error) -> String {
    use std::io::ErrorKind as K;
    let hint = match e.kind() {
        K::ConnectionRefused => {
            "connection refused: nothing listens on that port (is the server running?)"
        }
        K::TimedOut => "timed out: no answer from that host (wrong address, firewall or cable?)",
        K::InvalidInput => "not a valid address",
        _ if e.to_string().contains("lookup") || e.to_string().contains("resolve") => {
            "unknown host name"
        }
        _ => "cannot connect",
    };
    format!("socket_open(\"{host}\", {port}) failed: {hint} ({e})")
}
