//! `ursock client HOST:PORT`: the PC as the TCP client of a device (a camera, a PLC, a
//! server a robot program runs): what the user types is sent, what comes back is shown
//! with `listen`'s rendering (length, hex and text per chunk; `--json` events).
//!
//! Typed lines (and `--send` texts): `hex 01 02 03` (or `hex: 01 02`) sends those bytes
//! as they are; anything else is text with `\r \n \t \0 \\ \xHH` escapes, followed by the
//! `--eol` line end (LF by default).

use std::io::{BufRead, Read, Write};
use std::net::{Shutdown, TcpStream, ToSocketAddrs};
use std::path::PathBuf;
use std::sync::mpsc::{self, RecvTimeoutError};
use std::time::{Duration, Instant};

use crate::listen::out::{Kind, Out};
use crate::report::{self, now, Event};

/// Bytes of one typed line read from stdin; a longer line is refused, not buffered.
const MAX_LINE: usize = 64 * 1024;
/// Bytes of a `--file`.
const MAX_FILE: u64 = 16 * 1024 * 1024;

/// `ursock client`'s options.
#[derive(clap::Args)]
pub struct ClientOptions {
    /// The device to connect to, HOST:PORT (`192.168.0.10:50000`, `[::1]:30000`).
    pub addr: String,
    /// Send TEXT (repeatable, in order) instead of reading stdin: `hex 01 02` for bytes,
    /// else text with escapes and the --eol line end.
    #[arg(long, value_name = "TEXT", allow_hyphen_values = true)]
    pub send: Vec<String>,
    /// Send FILE's bytes as they are (after the --send texts) instead of reading stdin.
    #[arg(long, value_name = "FILE")]
    pub file: Option<PathBuf>,
    /// Send the last message again every SECONDS (the last typed line, or the
    /// --send/--file messages in turn); runs until --max-time, the device closes, or
    /// (typing) the end of stdin.
    #[arg(long, value_name = "SECONDS", allow_hyphen_values = true)]
    pub every: Option<f64>,
    /// End after SECONDS.
    #[arg(long, value_name = "SECONDS", allow_hyphen_values = true)]
    pub max_time: Option<f64>,
    /// Seconds to keep showing what comes back after the last message was sent (or
    /// stdin ended) before quitting.
    #[arg(
        long,
        value_name = "SECONDS",
        default_value_t = 0.5,
        allow_hyphen_values = true
    )]
    pub wait: f64,
    /// The line end after a text message: lf, crlf, cr or none.
    #[arg(long, value_name = "EOL", default_value = "lf")]
    pub eol: String,
    /// Seconds to wait for the connection.
    #[arg(
        long,
        value_name = "SECONDS",
        default_value_t = 5.0,
        allow_hyphen_values = true
    )]
    pub connect_timeout: f64,
    /// One JSON event per line (connect, tx, rx, close, note, error), as `listen --json`.
    #[arg(long)]
    pub json: bool,
    /// Bytes of one chunk shown in its hex dump.
    #[arg(long, default_value_t = 256)]
    pub show_max: usize,
    /// Append the whole session to FILE (times as on screen: local, or UTC with --utc).
    #[arg(long, value_name = "FILE")]
    pub log: Option<PathBuf>,
    /// Wall-clock times in UTC (JSON `time` ends in `Z`) instead of the local time zone,
    /// as `listen --utc`.
    #[arg(long)]
    pub utc: bool,
}

/// A duration from a user's seconds: above 0, and a time too long for the clock is none.
fn seconds(what: &str, s: f64) -> Result<Option<Duration>, String> {
    if s.is_nan() || s <= 0.0 {
        return Err(format!("{what} {s}: give a number of seconds above 0"));
    }
    Ok(Duration::try_from_secs_f64(s).ok())
}

/// The bytes of one typed line or `--send` text.
pub fn message(line: &str, eol: &[u8]) -> Result<Vec<u8>, String> {
    let trimmed = line.trim_start();
    for prefix in ["hex:", "hex "] {
        if let Some(rest) = trimmed.strip_prefix(prefix) {
            return crate::typed::hex(rest.split_whitespace());
        }
    }
    let mut bytes = crate::typed::unescape(line)?;
    bytes.extend_from_slice(eol);
    Ok(bytes)
}

fn eol(name: &str) -> Result<&'static [u8], String> {
    Ok(match name {
        "lf" => b"\n",
        "crlf" => b"\r\n",
        "cr" => b"\r",
        "none" => b"",
        other => return Err(format!("--eol {other:?}: give lf, crlf, cr or none")),
    })
}

/// What the main loop waits for.
enum Input {
    /// A typed line's bytes (or the error to show for it).
    Line(Result<Vec<u8>, String>),
    /// Stdin ended.
    StdinEnd,
    /// Bytes from the device.
    Rx(Vec<u8>),
    /// The device closed (or the read failed: the reason).
    Closed(String),
}

/// What the options ask for, checked before connecting.
struct Plan {
    eol: &'static [u8],
    /// Send the last message again this often.
    every: Option<Duration>,
    max_time: Option<Duration>,
    /// How long to show replies after the last send (or the end of stdin).
    wait: Duration,
    connect_timeout: Duration,
    /// The `--send` texts and the `--file` bytes, in order (empty: read stdin).
    scripted: Vec<Vec<u8>>,
    log: Option<std::fs::File>,
}

impl Plan {
    fn of(opts: &ClientOptions) -> Result<Plan, String> {
        let eol = eol(&opts.eol)?;
        let endless = |d: Option<Duration>| d.unwrap_or(Duration::MAX);
        let every = opts
            .every
            .map(|s| seconds("--every", s))
            .transpose()?
            .map(endless);
        let max_time = opts
            .max_time
            .map(|s| seconds("--max-time", s))
            .transpose()?
            .map(endless);
        // 0 quits at once; a time too long for the clock never does.
        let wait = if opts.wait == 0.0 {
            Duration::ZERO
        } else {
            seconds("--wait", opts.wait)?.unwrap_or(Duration::MAX)
        };
        let connect_timeout = seconds("--connect-timeout", opts.connect_timeout)?
            .unwrap_or(Duration::from_secs(3600))
            .max(Duration::from_millis(1));
        let mut scripted = opts
            .send
            .iter()
            .map(|s| message(s, eol).map_err(|e| format!("--send: {e}")))
            .collect::<Result<Vec<_>, _>>()?;
        if let Some(path) = &opts.file {
            scripted.push(read_file(path)?);
        }
        let log = match &opts.log {
            Some(p) => Some(
                std::fs::OpenOptions::new()
                    .create(true)
                    .append(true)
                    .open(p)
                    .map_err(|e| format!("--log {}: {e}", p.display()))?,
            ),
            None => None,
        };
        Ok(Plan {
            eol,
            every,
            max_time,
            wait,
            connect_timeout,
            scripted,
            log,
        })
    }
}

/// A `--file`'s bytes: at most [`MAX_FILE`], not empty.
fn read_file(path: &std::path::Path) -> Result<Vec<u8>, String> {
    let f = std::fs::File::open(path).map_err(|e| format!("--file {}: {e}", path.display()))?;
    let mut bytes = Vec::new();
    f.take(MAX_FILE + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| format!("--file {}: {e}", path.display()))?;
    if bytes.len() as u64 > MAX_FILE {
        return Err(format!(
            "--file {}: larger than {MAX_FILE} bytes",
            path.display()
        ));
    }
    if bytes.is_empty() {
        return Err(format!("--file {}: empty, nothing to send", path.display()));
    }
    Ok(bytes)
}

/// Connects to the first of `addr`'s addresses that answers.
fn connect(addr: &str, timeout: Duration) -> Result<TcpStream, String> {
    let addrs: Vec<_> = addr
        .to_socket_addrs()
        .map_err(|e| format!("{addr}: {e} (give HOST:PORT)"))?
        .collect();
    let mut last_err = format!("{addr}: no address");
    for a in &addrs {
        match TcpStream::connect_timeout(a, timeout) {
            Ok(s) => {
                let _ = s.set_nodelay(true);
                return Ok(s);
            }
            Err(e) => last_err = format!("cannot connect to {a}: {e}"),
        }
    }
    Err(last_err)
}

/// Reads the device on a thread of its own: its bytes, then why it ended.
fn spawn_reader(mut reader: TcpStream, to_main: mpsc::Sender<Input>) {
    std::thread::spawn(move || {
        let mut buf = vec![0u8; 64 * 1024];
        loop {
            match reader.read(&mut buf) {
                Ok(0) => {
                    let _ = to_main.send(Input::Closed("the device closed".into()));
                    return;
                }
                Ok(n) => {
                    if to_main.send(Input::Rx(buf[..n].to_vec())).is_err() {
                        return;
                    }
                }
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => {
                    let _ = to_main.send(Input::Closed(format!("read failed: {e}")));
                    return;
                }
            }
        }
    });
}

/// Reads typed lines from stdin on a thread of its own (each at most [`MAX_LINE`]
/// bytes), then says that stdin ended.
fn spawn_stdin(to_main: mpsc::Sender<Input>, eol: &'static [u8]) {
    std::thread::spawn(move || {
        let stdin = std::io::stdin();
        let mut lock = stdin.lock();
        let mut line = Vec::new();
        loop {
            line.clear();
            match (&mut lock)
                .take(MAX_LINE as u64 + 1)
                .read_until(b'\n', &mut line)
            {
                Ok(0) | Err(_) => break,
                Ok(_) => {}
            }
            let msg = if line.len() > MAX_LINE && line.last() != Some(&b'\n') {
                // Skip the rest of the over-long line.
                let mut rest = Vec::new();
                let _ = lock.read_until(b'\n', &mut rest);
                Some(Err(format!("typed line over {MAX_LINE} bytes, not sent")))
            } else {
                let text = String::from_utf8_lossy(&line);
                let text = text.trim_end_matches(['\n', '\r']);
                (!text.trim().is_empty()).then(|| message(text, eol))
            };
            if let Some(msg) = msg {
                if to_main.send(Input::Line(msg)).is_err() {
                    return;
                }
            }
        }
        let _ = to_main.send(Input::StdinEnd);
    });
}

/// One connection to the device: what was sent and received, and what is due.
struct Session {
    writer: TcpStream,
    out: Out,
    sent: u64,
    received: u64,
    /// The last typed message (sent again by `--every`).
    last: Option<Vec<u8>>,
    /// The scripted message `--every` sends next.
    next_scripted: usize,
    /// When the next periodic send is due.
    next_every: Option<Instant>,
    /// When to quit for want of anything to do.
    quit_at: Option<Instant>,
}

/// `d` from now (none for a time too long for the clock).
fn after(d: Duration) -> Option<Instant> {
    Instant::now().checked_add(d)
}

impl Session {
    fn send(&mut self, bytes: &[u8]) -> Result<(), String> {
        self.writer
            .write_all(bytes)
            .map_err(|e| format!("send failed: {e}"))?;
        self.sent += bytes.len() as u64;
        self.out.emit(
            Kind::Traffic,
            Event::Tx(report::Traffic {
                t: now(),
                socket: None,
                conn: Some(1),
                len: bytes.len(),
                bytes: report::Bytes(bytes.to_vec()),
                origin: Some("operator".into()),
                format: None,
            }),
        );
        Ok(())
    }

    fn show_received(&mut self, bytes: Vec<u8>) {
        self.received += bytes.len() as u64;
        self.out.emit(
            Kind::Traffic,
            Event::Rx(report::Traffic {
                t: now(),
                socket: None,
                conn: Some(1),
                len: bytes.len(),
                bytes: report::Bytes(bytes),
                origin: None,
                format: None,
            }),
        );
    }

    /// Sends, receives and repeats until the plan's end; why it ended.
    fn run(&mut self, plan: &Plan, rx: &mpsc::Receiver<Input>) -> Result<String, String> {
        let typing = plan.scripted.is_empty();
        let deadline = plan.max_time.and_then(after);
        if !typing {
            for m in &plan.scripted {
                self.send(m)?;
            }
            match plan.every {
                Some(d) => self.next_every = after(d),
                None => self.quit_at = after(plan.wait),
            }
        }
        loop {
            let now_i = Instant::now();
            if deadline.is_some_and(|d| now_i >= d) {
                return Ok("--max-time passed".into());
            }
            if self.quit_at.is_some_and(|q| now_i >= q) {
                return Ok(if typing {
                    "stdin ended".into()
                } else {
                    "everything sent".into()
                });
            }
            if let Some(due) = self.next_every.filter(|d| now_i >= *d) {
                if typing {
                    if let Some(m) = self.last.clone() {
                        self.send(&m)?;
                    }
                } else if let Some(m) = plan.scripted.get(self.next_scripted) {
                    self.send(m)?;
                    self.next_scripted = (self.next_scripted + 1) % plan.scripted.len();
                }
                self.next_every = plan
                    .every
                    .and_then(|d| due.checked_add(d))
                    .map(|n| n.max(now_i));
                continue;
            }
            let wake = [deadline, self.quit_at, self.next_every]
                .into_iter()
                .flatten()
                .min();
            let got = match wake {
                Some(w) => rx.recv_timeout(w.saturating_duration_since(now_i)),
                None => rx.recv().map_err(|_| RecvTimeoutError::Disconnected),
            };
            match got {
                Ok(Input::Rx(bytes)) => self.show_received(bytes),
                Ok(Input::Line(Ok(bytes))) => {
                    self.send(&bytes)?;
                    self.last = Some(bytes);
                    if let Some(d) = plan.every {
                        self.next_every = after(d);
                    }
                }
                Ok(Input::Line(Err(e))) => self.out.emit(Kind::Warn, Event::error(None, None, e)),
                Ok(Input::StdinEnd) => {
                    // Replies to the last line may still be on their way.
                    if plan.every.is_none() {
                        self.quit_at = after(plan.wait);
                    } else {
                        return Ok("stdin ended".into());
                    }
                }
                Ok(Input::Closed(why)) => return Ok(why),
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => return Ok("nothing more to send".into()),
            }
        }
    }
}

/// Runs the client; `Err` is the one line `main` prints before exiting 1.
pub fn run(opts: ClientOptions) -> Result<(), String> {
    let mut plan = Plan::of(&opts)?;
    let stream = connect(&opts.addr, plan.connect_timeout)?;
    let peer = stream
        .peer_addr()
        .map(|a| a.to_string())
        .unwrap_or_else(|_| opts.addr.clone());
    let out = Out::new(opts.json, false, plan.log.take(), false, opts.show_max).with_utc(opts.utc);
    // The JSON `connect` event names the peer; people read which way it went.
    out.emit(
        Kind::Note,
        if opts.json {
            Event::Connect(report::Connect {
                t: now(),
                conn: 1,
                peer: peer.clone(),
                service: None,
            })
        } else {
            Event::note(format!("connected to {peer}"))
        },
    );
    let (tx, rx) = mpsc::channel::<Input>();
    spawn_reader(stream.try_clone().map_err(|e| e.to_string())?, tx.clone());
    if plan.scripted.is_empty() {
        spawn_stdin(tx, plan.eol);
    } else {
        drop(tx);
    }
    let mut session = Session {
        writer: stream,
        out,
        sent: 0,
        received: 0,
        last: None,
        next_scripted: 0,
        next_every: None,
        quit_at: None,
    };
    let reason = session.run(&plan, &rx)?;
    let _ = session.writer.shutdown(Shutdown::Both);
    session.out.emit(
        Kind::Note,
        Event::Close(report::Close {
            t: now(),
            conn: 1,
            reason,
            rx: session.received,
            tx: session.sent,
            refused_sets: 0,
        }),
    );
    session.out.flush_log();
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn typed_messages() {
        assert_eq!(message("shoot", b"\n").unwrap(), b"shoot\n");
        assert_eq!(message(r"T1\r", b"").unwrap(), b"T1\r");
        assert_eq!(message("hex 02 41 03", b"\n").unwrap(), [2, 0x41, 3]);
        assert_eq!(message("hex: 0x01,0x02", b"\n").unwrap(), [1, 2]);
        assert!(message("hex zz", b"\n").is_err());
        assert!(message(r"bad\q", b"\n").is_err());
        assert!(eol("crlf").is_ok() && eol("x").is_err());
        assert!(seconds("--every", 0.0).is_err());
        assert!(seconds("--every", f64::NAN).is_err());
        assert_eq!(seconds("--every", 1e300).unwrap(), None);
    }
}
