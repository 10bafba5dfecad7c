//! Running a [`Machine`] in real time against real TCP servers (`std::net`), for a CLI or
//! an integration test.
//!
//! [`run_tcp`] is a small poll loop: program time is the real time since the start
//! (`Instant`), `socket_open` connects with a blocking `TcpStream::connect_timeout` (the
//! program does not advance meanwhile), sends are written out at once, and received bytes
//! are read from non-blocking sockets each round. Between rounds the loop sleeps until the
//! machine's next timeout, at most [`Options::poll_interval`].

use std::collections::HashMap;
use std::io::{ErrorKind, Read, Write};
use std::net::{Shutdown, TcpStream, ToSocketAddrs};
use std::time::{Duration, Instant};

use crate::error::RuntimeError;
use crate::machine::{Event, Machine, State};

/// How [`run_tcp`] runs.
#[derive(Debug, Clone)]
pub struct Options {
    /// End a program that runs longer than this (it counts as a success).
    pub max_time: Option<Duration>,
    /// How long `socket_open` may take to connect before it returns `False`.
    pub connect_timeout: Duration,
    /// The longest sleep between two rounds of reading the sockets.
    pub poll_interval: Duration,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            max_time: None,
            connect_timeout: Duration::from_secs(2),
            poll_interval: Duration::from_millis(1),
        }
    }
}

/// What [`run_tcp`] reports as it runs: the machine's events, and what the servers sent
/// (for a `--trace` that shows both directions).
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
}

/// How a program run by [`run_tcp`] ended without error.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// The program ended.
    Finished,
    /// `halt` ran.
    Halted,
    /// [`Options::max_time`] passed first.
    MaxTime,
}

struct Conn {
    stream: TcpStream,
    /// Bytes read but not yet accepted by the socket's receive buffer.
    backlog: Vec<u8>,
    closed: bool,
}

/// What a peer sent or did in one round.
enum Received {
    Bytes(Vec<u8>),
    Closed,
}

/// Runs `machine` against real servers until it ends, fails, or `max_time` passes.
/// `on_activity` sees every event first, and every read from a server (print them, log
/// them); a runtime error is the `Err`.
/// The machine stays with the caller, to read its globals or arm state afterwards.
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
    mut on_activity: impl FnMut(Activity<'_>),
) -> Result<Outcome, RuntimeError> {
    let start = Instant::now();
    let mut conns: HashMap<String, Conn> = HashMap::new();
    let mut buf = vec![0u8; 16 * 1024];
    loop {
        let now = start.elapsed();
        if options.max_time.is_some_and(|m| now >= m) {
            return Ok(Outcome::MaxTime);
        }
        machine.run_until(now);
        while let Some(event) = machine.poll_event() {
            on_activity(Activity::Event(&event));
            match event {
                Event::Connect {
                    socket_name,
                    host,
                    port,
                } => {
                    let result = connect(&host, port, options.connect_timeout);
                    match result {
                        Ok(stream) => {
                            conns.insert(
                                socket_name.clone(),
                                Conn {
                                    stream,
                                    backlog: Vec::new(),
                                    closed: false,
                                },
                            );
                            machine.handle_connected(&socket_name, Ok(()));
                        }
                        Err(e) => machine.handle_connected(&socket_name, Err(e)),
                    }
                }
                Event::Transmit { socket_name, bytes } => {
                    if let Some(c) = conns.get_mut(&socket_name) {
                        if write_all(&mut c.stream, &bytes).is_err() {
                            c.closed = true;
                            on_activity(Activity::PeerClosed {
                                socket_name: &socket_name,
                            });
                            machine.handle_send_failed(&socket_name);
                        }
                    }
                }
                Event::Close { socket_name } => {
                    if let Some(c) = conns.remove(&socket_name) {
                        let _ = c.stream.shutdown(Shutdown::Both);
                    }
                }
                Event::Message(_) | Event::Call { .. } => {}
            }
        }
        match machine.state() {
            State::Running => {}
            State::Finished => return Ok(Outcome::Finished),
            State::Halted => return Ok(Outcome::Halted),
            State::Error(e) => return Err(e.clone()),
        }
        let mut got_any = false;
        for (name, c) in conns.iter_mut() {
            if !c.backlog.is_empty() {
                let n = machine.handle_received(name, &c.backlog);
                c.backlog.drain(..n);
                if !c.backlog.is_empty() {
                    continue; // the receive buffer is full: read no more from it now
                }
            }
            if c.closed {
                continue;
            }
            match read_some(&mut c.stream, &mut buf) {
                None => {}
                Some(Received::Bytes(bytes)) => {
                    got_any = true;
                    on_activity(Activity::Received {
                        socket_name: name,
                        bytes: &bytes,
                    });
                    let n = machine.handle_received(name, &bytes);
                    c.backlog.extend_from_slice(&bytes[n..]);
                }
                Some(Received::Closed) => {
                    got_any = true;
                    c.closed = true;
                    on_activity(Activity::PeerClosed { socket_name: name });
                    machine.handle_peer_closed(name);
                }
            }
        }
        if !got_any {
            let now = start.elapsed();
            let mut wait = options.poll_interval;
            if let Some(t) = machine.poll_timeout() {
                wait = wait.min(t.saturating_sub(now));
            }
            if let Some(m) = options.max_time {
                wait = wait.min(m.saturating_sub(now));
            }
            if !wait.is_zero() {
                std::thread::sleep(wait);
            }
        }
    }
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

fn connect(host: &str, port: u16, timeout: Duration) -> Result<TcpStream, String> {
    connect_stream(host, port, timeout).map_err(|e| format!("{host}:{port}: {e}"))
}

/// Writes all of `bytes` to a non-blocking stream, waiting briefly while its send buffer
/// is full.
pub fn write_all(stream: &mut TcpStream, mut bytes: &[u8]) -> std::io::Result<()> {
    while !bytes.is_empty() {
        match stream.write(bytes) {
            Ok(0) => return Err(ErrorKind::WriteZero.into()),
            Ok(n) => bytes = &bytes[n..],
            Err(e) if e.kind() == ErrorKind::WouldBlock => {
                std::thread::sleep(Duration::from_micros(100))
            }
            Err(e) if e.kind() == ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(())
}

fn read_some(stream: &mut TcpStream, buf: &mut [u8]) -> Option<Received> {
    match stream.read(buf) {
        Ok(0) => Some(Received::Closed),
        Ok(n) => Some(Received::Bytes(buf[..n].to_vec())),
        Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::Interrupted) => None,
        Err(_) => Some(Received::Closed),
    }
}
