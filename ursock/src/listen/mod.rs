//! `ursock listen`: the socket debug assistant a robot connects to.
//!
//! One tokio current-thread runtime serves every connection: per connection a reader task
//! (decoding, replies) and a writer task fed by a byte-bounded queue, so a robot that
//! never reads can only fill its own queue (then it is dropped) and never delays another.
//! Both tasks end when the connection ends. Operator input comes from one stdin thread.
//! Limits (`--max-connections`, `--max-vars`, `--max-queue`) bound what a peer can make
//! the listener hold; accept errors (out of descriptors) back off and are said once.

mod dump;
pub mod out;

/// The human view of any report event (shared with `controller`).
pub(crate) use out::human;
mod rules;
mod snippets;
mod spec;
mod tui;

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::tcp::OwnedWriteHalf;
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::{mpsc, Notify};
use urscript_socket::robot::ReadCall;
use urscript_socket::var::{encode_var_reply, parse_var_message, VarMessage};
use urscript_socket::RecvBuffer;

use urscript_socket::format::{Format, Message};

use crate::diagnose;
use crate::formats::{drain, DecodeFormat};
use crate::report::{self, now, Bytes, Event, TypedMessage};
use crate::vars::{self, SetOutcome, Vars};
use out::{Kind, Out};
use spec::Reply;

pub const DEFAULT_MAX_CONNECTIONS: usize = 64;
/// Seconds without a byte after which a connection may be evicted when the table is full.
pub const DEFAULT_EVICT_IDLE_SECS: f64 = 5.0;
/// Connections from one address at once.
pub const DEFAULT_MAX_PER_ADDRESS: usize = 16;
pub const DEFAULT_MAX_VARS: usize = 1024;
pub const DEFAULT_MAX_QUEUE: usize = 1024 * 1024;
pub const DEFAULT_WRITE_TIMEOUT_SECS: f64 = 30.0;
pub const DEFAULT_SHOW_MAX: usize = 1024;

/// The robot's default read timeout (`socket_read_*`, and always for `socket_get_var`).
const ROBOT_READ_TIMEOUT: Duration = Duration::from_secs(2);

/// Receive buffer per connection; above every decoder's bound (4096), so a too-long
/// message is the decoder's error, never a full buffer.
const RX_CAPACITY: usize = 16 * 1024;
const READ_CHUNK: usize = 8 * 1024;

/// `ursock listen`'s options.
#[derive(clap::Args)]
pub struct ListenOptions {
    /// Address to bind.
    #[arg(long, default_value = "0.0.0.0")]
    pub bind: String,
    /// Port to listen on (0 picks a free one).
    #[arg(long)]
    pub port: u16,
    /// How to decode what robots send. Without it chunks are shown raw, SET/GET lines
    /// are still answered and `--reply` answers each chunk received.
    #[arg(long, value_enum)]
    pub decode: Option<DecodeFormat>,
    /// Delimiter for `--decode delimiter` (escapes `\r \n \t \0 \\ \xHH` are interpreted).
    #[arg(long, default_value = "\\n")]
    pub delimiter: String,
    /// Reply to each decoded message (or each chunk without --decode), e.g.
    /// `floats 0.1 0.2 0.3`, `line OK`, `int32 1 2`, `bytes 2 3`, `string >ok<`,
    /// `text OK\r\n`, `hex 02 06 03`. GET lines are always answered from SET
    /// (without --decode and with line, var, delimiter, stx-etx); an unknown variable
    /// is answered 0 and said so.
    #[arg(long, allow_hyphen_values = true)]
    pub reply: Option<String>,
    /// Replies from a file of rules, one `PATTERN => REPLY` a line (`*` and `?` are
    /// wildcards; first match wins; no match falls back to --reply).
    #[arg(long)]
    pub rules: Option<PathBuf>,
    /// The read the robot does on replies (`ascii-float:N`, `binary-integer:N`,
    /// `byte-list:N`, `line`): each reply is checked against it and a warning says
    /// why the robot's read would fail. Without it, number-like text replies are
    /// checked as a `socket_read_ascii_float`.
    #[arg(long)]
    pub robot_reads: Option<String>,
    /// Exit after this many robots have connected and left (0: exit right after
    /// binding, which checks the options and the port).
    #[arg(long)]
    pub exit_after: Option<usize>,
    /// Connections served at once. When they are all taken, a new connection evicts the
    /// one idle longest (nothing received for the longest time), if it has been idle at
    /// least --evict-idle seconds; otherwise the new one is accepted and closed at once
    /// (said once per episode).
    #[arg(long, default_value_t = DEFAULT_MAX_CONNECTIONS)]
    pub max_connections: usize,
    /// Seconds without a byte after which a connection may be evicted for a new one when
    /// every slot is taken (0: never evict; refuse the new one instead).
    #[arg(long, value_name = "SECONDS", default_value_t = DEFAULT_EVICT_IDLE_SECS)]
    pub evict_idle: f64,
    /// Connections from one address at once (0: no limit), so one host cannot take every
    /// slot: a new one from an address at its limit evicts that address's connection idle
    /// longest if it has been idle at least --evict-idle seconds, else it is accepted and
    /// closed at once.
    #[arg(long, default_value_t = DEFAULT_MAX_PER_ADDRESS)]
    pub max_per_address: usize,
    /// Variables the server keeps (names at most 128 bytes); SET of a new name beyond
    /// it is refused and said. One connection may create at most half of them, so a
    /// flood of new names from one robot leaves room for the others.
    #[arg(long, default_value_t = DEFAULT_MAX_VARS)]
    pub max_vars: usize,
    /// Bytes of replies queued for one robot; a robot that lets more pile up is not
    /// reading and is dropped (others are unaffected).
    #[arg(long, default_value_t = DEFAULT_MAX_QUEUE)]
    pub max_queue: usize,
    /// Seconds a reply may wait, from being queued, to be written before the robot is
    /// taken as not reading and dropped (0: no limit).
    #[arg(long, default_value_t = DEFAULT_WRITE_TIMEOUT_SECS)]
    pub write_timeout: f64,
    /// Bytes of one chunk shown in its hex dump (rows of 16 with offsets); JSON events
    /// and counters always carry the whole chunk.
    #[arg(long, default_value_t = DEFAULT_SHOW_MAX)]
    pub show_max: usize,
    /// Append the whole session (every line, or every JSON event) to FILE; an existing
    /// FILE is kept and added to, never overwritten. Times as on screen (local, or
    /// UTC with --utc).
    #[arg(long)]
    pub log: Option<PathBuf>,
    /// One JSON event per line on stdout (listening, connect, rx, decoded, tx, close,
    /// diagnosis, error...; every field in docs/json-events.md); bytes as
    /// {"encoding":"utf-8","text":...} when valid UTF-8, else {"encoding":"hex","hex":...}.
    #[arg(long)]
    pub json: bool,
    /// Only connects, closes and problems; no traffic lines.
    #[arg(long, short)]
    pub quiet: bool,
    /// A terminal UI: the connections (Up/Down selects), the selected one's traffic
    /// decoded as it arrives (a scrollback of 2000 lines per robot: PgUp/PgDn/Home/End,
    /// the mouse wheel after F12),
    /// and an input line sending a reply spec or $snippet to it (Enter) or to every robot
    /// (Alt+Enter); F2..F9 send snippets 1..8; F1 or ? shows every key and command; Esc
    /// quits.
    #[arg(long)]
    pub tui: bool,
    /// Wall-clock times in UTC (JSON `time` ends in `Z`) instead of the local time zone
    /// (`TZ`, else /etc/localtime; JSON `time` is RFC 3339 with the local offset).
    #[arg(long)]
    pub utc: bool,
    /// Named replies, one `NAME = REPLY-SPEC` a line (`#` comments), checked at start:
    /// `$NAME` or `$N` sends one (`@2 $pose`, `@* $pose`), `every SECONDS $NAME` sends it
    /// periodically, F2..F9 in --tui send the first eight to the selected robot.
    #[arg(long, value_name = "FILE")]
    pub snippets: Option<PathBuf>,
    /// Also run a URScript program on a virtual robot (a UR5e, as `ursock robot` runs
    /// one) connected to this listener: `socket_0` is opened to it before the program
    /// runs, as `ursock robot --connect` does. Its calls, messages, outputs and moves
    /// (a line when each starts and ends: function, target, how it ended, how long it
    /// took) are shown with the traffic (--json: `call`, `move_start`, `move_end`,
    /// `output`, `end` events); in --tui in the status pane.
    #[arg(long, value_name = "FILE")]
    pub robot: Option<PathBuf>,
}

struct Shared {
    out: Out,
    decode: Option<DecodeFormat>,
    delimiter: Vec<u8>,
    reply: Option<Reply>,
    rules: Vec<rules::Rule>,
    snippets: Vec<snippets::Snippet>,
    /// Periodic sends (`every`), by job number; at most [`MAX_PERIODIC`].
    periodic: Mutex<BTreeMap<u64, Periodic>>,
    next_job: AtomicU64,
    robot_reads: Option<ReadCall>,
    max_connections: usize,
    /// Idle time after which a connection may be evicted (`None`: never).
    evict_idle: Option<Duration>,
    max_per_address: usize,
    /// Open connections per peer address.
    per_address: Mutex<std::collections::HashMap<std::net::IpAddr, usize>>,
    max_queue: usize,
    write_timeout: Duration,
    exit_after: Option<usize>,
    vars: Mutex<Vars>,
    conns: Mutex<BTreeMap<u64, Arc<Conn>>>,
    closed: AtomicU64,
    /// Connections accepted and not yet ended (counted at accept, before the task runs).
    open: AtomicUsize,
    exit: Notify,
}

/// What the writer task shares with the rest (never the queue's sender, so the queue
/// closes when the connection is forgotten).
/// Periodic sends running at once (`every`).
pub const MAX_PERIODIC: usize = 16;
/// The shortest period of `every` (a robot polling faster is better served by --reply).
pub const MIN_PERIOD: Duration = Duration::from_millis(10);
/// The longest period of `every`: a day (far longer ones would overflow the timer's
/// deadline arithmetic).
pub const MAX_PERIOD: Duration = Duration::from_secs(86_400);

/// One `every` job: what it sends, and the task to stop.
struct Periodic {
    what: String,
    task: tokio::task::AbortHandle,
}

struct Stats {
    queued: AtomicUsize,
    rx_bytes: AtomicU64,
    tx_bytes: AtomicU64,
    /// When the last byte came from the robot (or it connected).
    last_rx: Mutex<Instant>,
    close: Notify,
    reason: Mutex<Option<String>>,
}

impl Stats {
    /// Ends the connection; the first reason given is the one reported.
    fn kill(&self, reason: String) {
        let mut r = self.reason.lock().unwrap_or_else(|p| p.into_inner());
        if r.is_none() {
            *r = Some(reason);
        }
        self.close.notify_one();
    }

    fn reason(&self) -> Option<String> {
        self.reason
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .clone()
    }
}

struct Conn {
    id: u64,
    peer: String,
    since: Instant,
    /// Replies for the writer, each with the moment it was queued.
    tx: mpsc::UnboundedSender<(Instant, Vec<u8>)>,
    stats: Arc<Stats>,
    /// The last reply was a float tuple followed by LF (left in the robot's buffer).
    after_tuple_lf: AtomicBool,
    refused_sets: AtomicU64,
    /// Variable names this connection created (bounded by `Vars::quota`).
    created_vars: Mutex<usize>,
    /// When the robot's last message came, if no reply has been sent since: a reply more
    /// than [`ROBOT_READ_TIMEOUT`] later finds the robot's read already timed out.
    waiting_since: Mutex<Option<Instant>>,
}

/// A decoded message, owned, with what rules match against.
struct Decoded {
    shown: String,
    raw: Vec<u8>,
    is_text: bool,
    typed: TypedMessage,
}

/// `text_kind`: what a text message is called (`line`, `frame`, `string`).
fn own(m: &Message<'_>, text_kind: &'static str) -> Decoded {
    let typed = TypedMessage::new(m, text_kind);
    match m {
        Message::Text(t) => Decoded {
            shown: crate::show::quoted(t),
            raw: t.to_vec(),
            is_text: true,
            typed,
        },
        other => {
            let shown = crate::show::message_text(other);
            Decoded {
                raw: shown.clone().into_bytes(),
                shown,
                is_text: false,
                typed,
            }
        }
    }
}

pub fn listen(opts: ListenOptions) -> Result<(), String> {
    let reply = match &opts.reply {
        Some(s) => Some(spec::parse(s).map_err(|e| format!("--reply: {e}"))?),
        None => None,
    };
    let rules = match &opts.rules {
        Some(p) => rules::load(p)?,
        None => Vec::new(),
    };
    let snippets = match &opts.snippets {
        Some(p) => snippets::load(p)?,
        None => Vec::new(),
    };
    let robot_reads = match &opts.robot_reads {
        Some(s) => Some(diagnose::parse_robot_reads(s)?),
        None => None,
    };
    let robot_program = match &opts.robot {
        Some(path) => Some(
            std::fs::read_to_string(path)
                .map_err(|e| format!("--robot {}: {e}", path.display()))?,
        ),
        None => None,
    };
    let delimiter = crate::formats::delimiter(&opts.delimiter)?;
    if let Some(format) = opts.decode {
        format.decoder(&delimiter)?;
    }
    if opts.max_connections == 0 {
        return Err("--max-connections must be at least 1".into());
    }
    let log = match &opts.log {
        Some(p) => {
            // Appended to: a second session never erases the first one's record.
            Some(
                std::fs::OpenOptions::new()
                    .create(true)
                    .append(true)
                    .open(p)
                    .map_err(|e| format!("--log {}: {e}", p.display()))?,
            )
        }
        None => None,
    };
    let std_listener = std::net::TcpListener::bind((opts.bind.as_str(), opts.port))
        .map_err(|e| format!("cannot listen on {}:{}: {e}", opts.bind, opts.port))?;
    let addr = std_listener.local_addr().map_err(|e| e.to_string())?;
    std_listener
        .set_nonblocking(true)
        .map_err(|e| e.to_string())?;
    if opts.tui && opts.json {
        return Err("--tui and --json: choose one (the log can still be JSON-free --log)".into());
    }
    let out = Out::new(opts.json, opts.quiet, log, opts.tui, opts.show_max).with_utc(opts.utc);
    let listening = Event::Listening(report::Listening {
        t: now(),
        addr: addr.to_string(),
        service: None,
    });
    if opts.json {
        out.stdout_line(&out.json_line(&listening, jiff::Timestamp::now()));
    } else {
        out.stdout_line(&out::human(&listening, opts.show_max).join("\n"));
    }
    for (what, r) in reply.iter().map(|r| ("--reply".to_string(), r)).chain(
        rules
            .iter()
            .map(|r| (format!("--rules line {}", r.line), &r.reply)),
    ) {
        for w in diagnose::reply(&r.sent(), robot_reads.as_ref(), false) {
            out.emit(
                Kind::Warn,
                Event::Diagnosis(report::Diagnosis {
                    t: now(),
                    conn: None,
                    source: Some(what.clone()),
                    text: w,
                    late_seconds: None,
                }),
            );
        }
    }
    if opts.exit_after == Some(0) {
        // "Exit after 0 robots have come and gone": satisfied at once. Checks the options
        // and that the port can be bound.
        return Ok(());
    }
    let shared = Arc::new(Shared {
        out,
        decode: opts.decode,
        delimiter,
        reply,
        rules,
        snippets,
        periodic: Mutex::new(BTreeMap::new()),
        next_job: AtomicU64::new(0),
        robot_reads,
        max_connections: opts.max_connections,
        evict_idle: (opts.evict_idle > 0.0)
            .then(|| Duration::try_from_secs_f64(opts.evict_idle).unwrap_or(Duration::MAX)),
        max_per_address: opts.max_per_address,
        per_address: Mutex::new(std::collections::HashMap::new()),
        max_queue: opts.max_queue.max(1),
        write_timeout: if opts.write_timeout > 0.0 && opts.write_timeout.is_finite() {
            Duration::try_from_secs_f64(opts.write_timeout).unwrap_or(Duration::MAX)
        } else {
            Duration::MAX
        },
        exit_after: opts.exit_after,
        vars: Mutex::new(Vars::new(opts.max_vars)),
        conns: Mutex::new(BTreeMap::new()),
        closed: AtomicU64::new(0),
        open: AtomicUsize::new(0),
        exit: Notify::new(),
    });
    if let Some(text) = robot_program {
        spawn_robot(&shared, text, addr)?;
    }
    let (cmd_tx, cmd_rx) = mpsc::channel::<Result<String, String>>(16);
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .map_err(|e| format!("cannot start the runtime: {e}"))?;
    if opts.tui {
        // The runtime serves robots on its own thread; this one draws and reads keys.
        let s = Arc::clone(&shared);
        let done = Arc::new(AtomicBool::new(false));
        let d = Arc::clone(&done);
        std::thread::spawn(move || {
            let _ = rt.block_on(run(s, std_listener, cmd_rx));
            d.store(true, Ordering::Relaxed);
        });
        let r = tui::run(&shared, &cmd_tx, &done);
        shared.out.flush_log();
        return r;
    }
    spawn_stdin(cmd_tx);
    let r = rt.block_on(run(Arc::clone(&shared), std_listener, cmd_rx));
    shared.out.flush_log();
    r
}

/// Runs `program` on a virtual robot in a thread of its own, `socket_0` opened to the
/// listener at `addr` (the loopback address when it listens on every interface); its
/// events are said as listen's own.
fn spawn_robot(
    shared: &Arc<Shared>,
    program: String,
    addr: std::net::SocketAddr,
) -> Result<(), String> {
    let ip = match addr.ip() {
        std::net::IpAddr::V4(ip) if ip.is_unspecified() => std::net::Ipv4Addr::LOCALHOST.into(),
        std::net::IpAddr::V6(ip) if ip.is_unspecified() => std::net::Ipv6Addr::LOCALHOST.into(),
        ip => ip,
    };
    let target = std::net::SocketAddr::new(ip, addr.port()).to_string();
    let s = Arc::clone(shared);
    let sink: crate::script::Sink = Box::new(move |event: Event| {
        let kind = match &event {
            Event::Call(_) | Event::Tx(_) | Event::Rx(_) => Kind::Traffic,
            Event::Error(_) => Kind::Warn,
            _ => Kind::Note,
        };
        s.out.emit(kind, event);
    });
    let opts = crate::script::Options {
        trace: false,
        json: false,
        max_time: None,
        step_time: Duration::from_millis(2),
        model: urscript_interp::kinematics::Model::Ur5e,
        stubs: Vec::new(),
        preamble: urscript_interp::Preamble::default(),
        arm: urscript_interp::Arm::default(),
        fail_on: crate::script::FailOn::default(),
        virtual_time: false,
    };
    std::thread::Builder::new()
        .name("robot".into())
        .spawn(move || {
            // Every outcome (an error too) was given to the sink as an event.
            let _ = crate::script::run_into(&program, Some(&target), opts, sink);
        })
        .map(|_| ())
        .map_err(|e| format!("--robot: cannot start its thread: {e}"))
}

/// The longest line typed on stdin that is read as a command: a longer one is reported
/// and skipped to its newline (an endless line cannot grow the process).
pub const MAX_STDIN_LINE: usize = 1024 * 1024;

/// Lines typed on stdin, handed to the runtime: `Ok(line)`, or `Err(why)` for a line that
/// is not a command (not UTF-8, longer than [`MAX_STDIN_LINE`]); later lines go on
/// working. Ends at end of input.
fn spawn_stdin(tx: mpsc::Sender<Result<String, String>>) {
    std::thread::spawn(move || {
        let stdin = std::io::stdin();
        let mut lines = StdinLines::default();
        let mut lock = stdin.lock();
        loop {
            use std::io::BufRead;
            let chunk = match lock.fill_buf() {
                Ok([]) | Err(_) => {
                    if let Some(last) = lines.finish() {
                        let _ = tx.blocking_send(last);
                    }
                    return;
                }
                Ok(c) => c,
            };
            let n = chunk.len();
            let ready = lines.push(chunk);
            lock.consume(n);
            for item in ready {
                if tx.blocking_send(item).is_err() {
                    return;
                }
            }
        }
    });
}

/// Splits typed bytes into command lines, bounded by [`MAX_STDIN_LINE`].
#[derive(Default)]
struct StdinLines {
    line: Vec<u8>,
    /// The line in progress went over the bound: skip to its newline.
    skipping: bool,
    number: u64,
}

impl StdinLines {
    fn push(&mut self, mut bytes: &[u8]) -> Vec<Result<String, String>> {
        let mut out = Vec::new();
        while !bytes.is_empty() {
            let end = bytes.iter().position(|&b| b == b'\n');
            let part = &bytes[..end.unwrap_or(bytes.len())];
            bytes = end.map_or(&[][..], |i| &bytes[i + 1..]);
            if !self.skipping {
                if self.line.len() + part.len() > MAX_STDIN_LINE {
                    self.number += 1;
                    out.push(Err(format!(
                        "typed line {}: longer than {MAX_STDIN_LINE} bytes, skipped",
                        self.number
                    )));
                    self.line.clear();
                    self.skipping = true;
                } else {
                    self.line.extend_from_slice(part);
                }
            }
            if end.is_some() {
                if self.skipping {
                    self.skipping = false;
                } else {
                    out.push(self.take());
                }
            }
        }
        out
    }

    /// The end of input: the unfinished last line, if any.
    fn finish(&mut self) -> Option<Result<String, String>> {
        (!self.line.is_empty() && !self.skipping).then(|| self.take())
    }

    fn take(&mut self) -> Result<String, String> {
        self.number += 1;
        let bytes = std::mem::take(&mut self.line);
        String::from_utf8(bytes)
            .map(|l| l.trim_end_matches('\r').to_string())
            .map_err(|e| {
                let at = e.utf8_error().valid_up_to();
                format!(
                    "typed line {}: not UTF-8 text (byte 0x{:02X} at column {}), ignored; type \\xHH for a raw byte",
                    self.number,
                    e.as_bytes()[at],
                    at + 1
                )
            })
    }
}

async fn run(
    shared: Arc<Shared>,
    std_listener: std::net::TcpListener,
    mut cmds: mpsc::Receiver<Result<String, String>>,
) -> Result<(), String> {
    let listener = TcpListener::from_std(std_listener).map_err(|e| e.to_string())?;
    let mut next_id = 0u64;
    let mut stdin_open = true;
    // Accept-error episode: (first failure, failures, current delay).
    let mut failing: Option<(Instant, u64, Duration)> = None;
    // Over-limit episode: connections refused since the last accepted one.
    let mut refused: u64 = 0;
    loop {
        tokio::select! {
            r = listener.accept() => match r {
                Ok((stream, peer)) => {
                    if let Some((since, n, _)) = failing.take() {
                        shared.out.emit(Kind::Warn, Event::AcceptRecovered(report::AcceptRecovered {
                            t: now(),
                            failures: n,
                            seconds: since.elapsed().as_secs_f64(),
                        }));
                    }
                    // One host may not take every slot.
                    let ip = peer.ip();
                    let from_ip = shared
                        .per_address
                        .lock()
                        .unwrap_or_else(|p| p.into_inner())
                        .get(&ip)
                        .copied()
                        .unwrap_or(0);
                    // At the address's limit, its connection idle longest may make room.
                    let at_address_limit =
                        shared.max_per_address > 0 && from_ip >= shared.max_per_address;
                    if at_address_limit && !evict_idlest(&shared, Some(ip)) {
                        shared.out.emit(Kind::Warn, Event::RefusedAddress(report::RefusedAddress {
                            t: now(),
                            peer: peer.to_string(),
                            open_from_address: from_ip,
                            max_per_address: shared.max_per_address,
                        }));
                        drop(stream);
                        continue;
                    }
                    let open = shared.open.load(Ordering::Relaxed);
                    if open >= shared.max_connections
                        && !at_address_limit
                        && !evict_idlest(&shared, None)
                    {
                        if refused == 0 {
                            shared.out.emit(Kind::Warn, Event::Refused(report::Refused {
                                t: now(),
                                peer: peer.to_string(),
                                open,
                                max_connections: shared.max_connections,
                            }));
                        }
                        refused += 1;
                        drop(stream);
                        continue;
                    }
                    if refused > 0 {
                        shared.out.emit(Kind::Warn, Event::RefusalsEnded(report::RefusalsEnded {
                            t: now(),
                            refused,
                            max_connections: shared.max_connections,
                        }));
                        refused = 0;
                    }
                    next_id += 1;
                    shared.open.fetch_add(1, Ordering::Relaxed);
                    *shared
                        .per_address
                        .lock()
                        .unwrap_or_else(|p| p.into_inner())
                        .entry(ip)
                        .or_insert(0) += 1;
                    let s = Arc::clone(&shared);
                    tokio::spawn(serve(s, next_id, stream, peer.to_string()));
                }
                Err(e) => {
                    let (since, n, delay) = failing.unwrap_or((Instant::now(), 0, Duration::from_millis(50)));
                    if n == 0 {
                        shared.out.emit(Kind::Warn, Event::AcceptError(report::AcceptError {
                            t: now(),
                            text: format!("accept failed: {e}; retrying with back-off (100 ms doubling to 1 s), quiet until it recovers"),
                        }));
                    }
                    let delay = (delay * 2).min(Duration::from_secs(1));
                    failing = Some((since, n + 1, delay));
                    tokio::time::sleep(delay).await;
                }
            },
            cmd = cmds.recv(), if stdin_open => match cmd {
                Some(Ok(line)) => operator(&shared, &line),
                Some(Err(why)) => shared.out.emit(
                    Kind::Warn,
                    Event::Error(report::Error { t: now(), line: None, column: None, text: why, code: None }),
                ),
                None => stdin_open = false,
            },
            _ = shared.exit.notified() => break,
        }
    }
    Ok(())
}

/// Every slot is taken: evicts the connection idle longest, if it has been idle at least
/// `evict_idle`, and says so; false if none may go (the new connection is refused).
fn evict_idlest(shared: &Shared, from: Option<std::net::IpAddr>) -> bool {
    let Some(min_idle) = shared.evict_idle else {
        return false;
    };
    let victim = shared
        .conns
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .values()
        .filter(|c| c.stats.reason().is_none())
        .filter(|c| {
            from.is_none_or(|ip| {
                c.peer.parse::<std::net::SocketAddr>().ok().map(|a| a.ip()) == Some(ip)
            })
        })
        .map(|c| {
            let last = *c.stats.last_rx.lock().unwrap_or_else(|p| p.into_inner());
            (last.elapsed(), Arc::clone(c))
        })
        .max_by_key(|(idle, _)| *idle);
    match victim {
        Some((idle, c)) if idle >= min_idle => {
            c.stats.kill(format!(
                "evicted: every slot was taken and it was the longest idle ({:.1} s without a byte)",
                idle.as_secs_f64()
            ));
            shared.out.emit(
                Kind::Warn,
                Event::Evicted(report::Evicted {
                    t: now(),
                    conn: c.id,
                    peer: c.peer.clone(),
                    idle: (idle.as_secs_f64() * 1e3).round() / 1e3,
                }),
            );
            true
        }
        _ => false,
    }
}

/// Who a typed send goes to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Target {
    /// `@N`: connection N.
    One(u64),
    /// `@*` or `all`: every connected robot.
    All,
    /// No prefix: the only connected robot (several: an error naming them).
    Only,
}

/// Splits `@N BODY`, `@* BODY`, `all BODY` or `BODY`.
fn split_target(line: &str) -> Result<(Target, &str), String> {
    if let Some(rest) = line.strip_prefix("all ") {
        return Ok((Target::All, rest.trim_start()));
    }
    let Some(rest) = line.strip_prefix('@') else {
        return Ok((Target::Only, line));
    };
    let (n, body) = rest.split_once(char::is_whitespace).unwrap_or((rest, ""));
    let body = body.trim_start();
    if n == "*" {
        return Ok((Target::All, body));
    }
    n.parse::<u64>()
        .map(|n| (Target::One(n), body))
        .map_err(|_| format!("@{n}: expected a connection number or *, e.g. @2 floats 1 2 3"))
}

/// The lines of `help` (and of the terminal UI's help pane, after its keys).
pub(crate) fn help_lines() -> Vec<String> {
    vec![
        format!("REPLY-SPEC        send to the only robot; formats: {}", spec::formats()),
        "                  e.g. floats 1 2 3 | line OK | text OK\\r\\n | hex 02 41 03".into(),
        "@N REPLY-SPEC     send to connection N".into(),
        "@* REPLY-SPEC     send to every connected robot (also: all REPLY-SPEC); a line names each robot and what became of its copy".into(),
        "$NAME or $N       send a --snippets snippet (by name or number), e.g. @2 $pose, @* $pose".into(),
        "snippets          list the snippets with their numbers".into(),
        format!("every SECONDS [@N|@*] $NAME|SPEC   send it periodically ({} to {} s apart, at most {MAX_PERIODIC} at once)", MIN_PERIOD.as_secs_f64(), MAX_PERIOD.as_secs_f64()),
        "every             list the periodic sends; every off [J]: stop all of them, or job J".into(),
        "list              the connections and the number of variables".into(),
        "close N           close connection N".into(),
        "help              this".into(),
    ]
}

/// One typed line: `list`, `close N`, `help`, `snippets`, `every ...`, `[@N|@*] BODY`
/// where BODY is a reply spec or `$SNIPPET`.
fn operator(shared: &Arc<Shared>, line: &str) {
    let line = line.trim();
    if line.is_empty() {
        return;
    }
    let error = |text: String| {
        shared.out.emit(
            Kind::Warn,
            Event::Error(report::Error {
                t: now(),
                line: None,
                column: None,
                text,
                code: None,
            }),
        )
    };
    let note = |text: String| {
        shared
            .out
            .emit(Kind::Note, Event::Note(report::Note { t: now(), text }))
    };
    let conns: Vec<Arc<Conn>> = shared
        .conns
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .values()
        .cloned()
        .collect();
    if line == "help" {
        shared.out.emit(
            Kind::Note,
            Event::Help(report::Note {
                t: now(),
                text: help_lines().join("\n"),
            }),
        );
        return;
    }
    if line == "snippets" {
        if shared.snippets.is_empty() {
            note("no snippets loaded (start with --snippets FILE)".into());
        } else {
            let lines: Vec<String> = shared
                .snippets
                .iter()
                .enumerate()
                .map(|(i, s)| format!("${} {} = {}", i + 1, s.name, s.spec))
                .collect();
            note(lines.join("\n"));
        }
        return;
    }
    if line == "list" {
        let variables = shared.vars.lock().unwrap_or_else(|p| p.into_inner()).len();
        let connections = conns
            .iter()
            .map(|c| report::ConnInfo {
                conn: c.id,
                peer: c.peer.clone(),
                rx: c.stats.rx_bytes.load(Ordering::Relaxed),
                tx: c.stats.tx_bytes.load(Ordering::Relaxed),
                seconds: c.since.elapsed().as_secs_f64(),
            })
            .collect();
        shared.out.emit(
            Kind::Note,
            Event::List(report::List {
                t: now(),
                connections,
                variables,
            }),
        );
        return;
    }
    if let Some(n) = line.strip_prefix("close ") {
        let n = n.trim().trim_start_matches('#').trim_start_matches('@');
        match n
            .parse::<u64>()
            .ok()
            .and_then(|n| conns.iter().find(|c| c.id == n))
        {
            Some(c) => c.stats.kill("closed by the operator".into()),
            None => error(format!("close {n}: no such connection (see `list`)")),
        }
        return;
    }
    if line == "every" || line.starts_with("every ") {
        if let Err(e) = every(shared, line["every".len()..].trim(), &conns) {
            error(e);
        }
        return;
    }
    let (target, body) = match split_target(line) {
        Ok(t) => t,
        Err(e) => return error(e),
    };
    let reply = match body_reply(shared, body) {
        Ok(r) => r,
        Err(e) => return error(format!("{e}; nothing sent")),
    };
    match resolve(&conns, target, body) {
        Ok(Some(conn)) => {
            let _ = send(shared, conn, &reply, "operator");
        }
        Ok(None) => note(send_all(shared, &conns, &reply, "operator")),
        Err(e) => error(format!("{e}; nothing sent")),
    }
}

/// A body: `$SNIPPET` or a reply spec.
fn body_reply(shared: &Shared, body: &str) -> Result<Reply, String> {
    match body.strip_prefix('$') {
        Some(key) => snippets::find(&shared.snippets, key.trim()).map(|s| s.reply.clone()),
        None => spec::parse(body),
    }
}

/// The one connection a target names (`None`: every one, for [`Target::All`]).
fn resolve<'a>(
    conns: &'a [Arc<Conn>],
    target: Target,
    body: &str,
) -> Result<Option<&'a Arc<Conn>>, String> {
    match target {
        Target::All if conns.is_empty() => Err("no robot connected".into()),
        Target::All => Ok(None),
        Target::One(n) => match conns.iter().find(|c| c.id == n) {
            Some(c) => Ok(Some(c)),
            None => {
                let ids: Vec<String> = conns.iter().map(|c| format!("#{}", c.id)).collect();
                Err(format!(
                    "no connection #{n} (connected: {})",
                    if ids.is_empty() {
                        "none".into()
                    } else {
                        ids.join(" ")
                    }
                ))
            }
        },
        Target::Only => match conns {
            [] => Err("no robot connected".into()),
            [c] => Ok(Some(c)),
            many => {
                let ids: Vec<String> = many.iter().map(|c| format!("@{}", c.id)).collect();
                Err(format!(
                    "{} robots connected ({}): say which, e.g. {} {body}, or @* {body} for all",
                    many.len(),
                    ids.join(" "),
                    ids[0]
                ))
            }
        },
    }
}

/// Sends to every connection in `conns`; the summary names each robot and what became
/// of its copy.
fn send_all(shared: &Shared, conns: &[Arc<Conn>], reply: &Reply, origin: &str) -> String {
    let mut sent = Vec::new();
    let mut failed = Vec::new();
    for c in conns {
        match send(shared, c, reply, origin) {
            Ok(()) => sent.push(format!("#{}", c.id)),
            Err(e) => failed.push(format!("#{}: {e}", c.id)),
        }
    }
    let mut text = format!(
        "sent {} bytes to {} of {} robots",
        reply.bytes.len(),
        sent.len(),
        conns.len()
    );
    if !sent.is_empty() {
        text.push_str(&format!(" ({})", sent.join(" ")));
    }
    if !failed.is_empty() {
        text.push_str(&format!("; not sent to {}", failed.join("; ")));
    }
    text
}

/// `every`: list, `off [J]`, or `SECONDS [@N|@*] BODY` (a new periodic send).
fn every(shared: &Arc<Shared>, args: &str, conns: &[Arc<Conn>]) -> Result<(), String> {
    let note = |text: String| {
        shared
            .out
            .emit(Kind::Note, Event::Note(report::Note { t: now(), text }))
    };
    let mut jobs = shared.periodic.lock().unwrap_or_else(|p| p.into_inner());
    jobs.retain(|_, j| !j.task.is_finished());
    if args.is_empty() {
        if jobs.is_empty() {
            note("no periodic sends (every SECONDS $NAME starts one)".into());
        } else {
            let lines: Vec<String> = jobs
                .iter()
                .map(|(n, j)| format!("job {n}: {}", j.what))
                .collect();
            note(lines.join("\n"));
        }
        return Ok(());
    }
    if let Some(which) = args.strip_prefix("off") {
        let which = which.trim();
        if which.is_empty() {
            let n = jobs.len();
            for (_, j) in std::mem::take(&mut *jobs) {
                j.task.abort();
            }
            note(format!("stopped {n} periodic sends"));
            return Ok(());
        }
        let job = which
            .parse::<u64>()
            .ok()
            .and_then(|n| jobs.remove(&n).map(|j| (n, j)))
            .ok_or_else(|| format!("every off {which}: no such job (`every` lists them)"))?;
        job.1.task.abort();
        note(format!("stopped job {}: {}", job.0, job.1.what));
        return Ok(());
    }
    let usage = "expected every SECONDS [@N|@*] $NAME (or a reply spec), e.g. every 0.5 $pose";
    let (secs, rest) = args.split_once(char::is_whitespace).ok_or(usage)?;
    let seconds = secs
        .parse::<f64>()
        .ok()
        .filter(|s| s.is_finite())
        .ok_or_else(|| format!("every {secs}: not a number of seconds; {usage}"))?;
    let (min, max) = (MIN_PERIOD.as_secs_f64(), MAX_PERIOD.as_secs_f64());
    if !(min..=max).contains(&seconds) {
        return Err(format!(
            "every {secs}: the period must be {min} to {max} s; nothing started"
        ));
    }
    let period = Duration::from_secs_f64(seconds);
    let (target, body) = split_target(rest.trim())?;
    let reply = body_reply(shared, body).map_err(|e| format!("{e}; nothing started"))?;
    // No prefix: the robot connected now, for the job's whole life.
    let target = match resolve(conns, target, body) {
        Ok(Some(c)) => Target::One(c.id),
        Ok(None) => Target::All,
        Err(e) => return Err(format!("{e}; nothing started")),
    };
    if jobs.len() >= MAX_PERIODIC {
        return Err(format!(
            "{MAX_PERIODIC} periodic sends already run (`every off` stops them); nothing started"
        ));
    }
    let job = shared.next_job.fetch_add(1, Ordering::Relaxed) + 1;
    let to = match target {
        Target::One(n) => format!("#{n}"),
        _ => "every robot".into(),
    };
    let what = format!("every {} s to {to}: {body}", period.as_secs_f64());
    let task =
        tokio::spawn(periodic(Arc::clone(shared), job, target, reply, period)).abort_handle();
    jobs.insert(
        job,
        Periodic {
            what: what.clone(),
            task,
        },
    );
    drop(jobs);
    note(format!(
        "job {job} started: {what} (every off {job} stops it)"
    ));
    Ok(())
}

/// The task of one `every` job: sends at each period until stopped, or until its one
/// robot is gone or dropped (then it says so and ends).
async fn periodic(shared: Arc<Shared>, job: u64, target: Target, reply: Reply, period: Duration) {
    let mut tick = tokio::time::interval(period);
    // A late tick is not made up for with a burst.
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    // The first send gets the full diagnosis of a typed one; later ones only what changes.
    let mut origin = "operator";
    let end = loop {
        tick.tick().await;
        let conns: Vec<Arc<Conn>> = shared
            .conns
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .values()
            .cloned()
            .collect();
        match target {
            Target::One(n) => match conns.iter().find(|c| c.id == n) {
                Some(c) => {
                    if let Err(e) = send(&shared, c, &reply, origin) {
                        break format!("job {job} stopped: #{n}: {e}");
                    }
                }
                None => break format!("job {job} stopped: connection #{n} is gone"),
            },
            _ => {
                for c in &conns {
                    let _ = send(&shared, c, &reply, origin);
                }
            }
        }
        origin = "periodic";
    };
    shared
        .periodic
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .remove(&job);
    shared.out.emit(
        Kind::Note,
        Event::Note(report::Note {
            t: now(),
            text: end,
        }),
    );
}

/// Queues `reply` for `conn`'s writer, showing it and saying what the robot's read will
/// make of it. A queue over `--max-queue` bytes means the robot is not reading: dropped.
/// `Err` says why nothing was queued (the error or the drop is also emitted).
fn send(shared: &Shared, conn: &Conn, reply: &Reply, origin: &str) -> Result<(), String> {
    let after_lf = conn.after_tuple_lf.load(Ordering::Relaxed);
    let waited = conn
        .waiting_since
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .take()
        .map(|t| t.elapsed());
    if let Some(w) = waited.filter(|w| *w > ROBOT_READ_TIMEOUT) {
        let text = format!(
            "this reply comes {:.1} s after the robot's last message: a read with the default \
             2 s timeout (always for socket_get_var) has already returned its sentinel \
             ([0, nan...], [0, -1...], \"\", 0), and this reply will be seen by the robot's \
             NEXT read; answer faster, or give the read a longer timeout=",
            w.as_secs_f64()
        );
        shared.out.emit(
            Kind::Warn,
            Event::Diagnosis(report::Diagnosis {
                t: now(),
                conn: Some(conn.id),
                source: None,
                text,
                late_seconds: Some(w.as_secs_f64()),
            }),
        );
    }
    if let Some(why) = conn.stats.reason() {
        return Err(format!("closing ({why})"));
    }
    // `--reply` and rules were checked once at start; what the operator types, each time.
    let warnings = if origin == "operator" {
        diagnose::reply(&reply.sent(), shared.robot_reads.as_ref(), after_lf)
    } else {
        diagnose::leftover_lf(&reply.sent(), shared.robot_reads.as_ref(), after_lf)
            .into_iter()
            .collect()
    };
    for w in warnings {
        shared.out.emit(
            Kind::Warn,
            Event::Diagnosis(report::Diagnosis {
                t: now(),
                conn: Some(conn.id),
                source: None,
                text: w,
                late_seconds: None,
            }),
        );
    }
    let len = reply.bytes.len();
    if len > shared.max_queue {
        // Too big for the queue whatever the robot does: refused up front, the robot stays.
        shared.out.emit(
            Kind::Warn,
            Event::Error(report::Error {
                t: now(),
                line: None,
                column: None,
                text: format!(
                    "[#{}] reply of {len} bytes not sent: larger than --max-queue {} (raise it to send it)",
                    conn.id, shared.max_queue
                ),
                code: None,
            }),
        );
        return Err(format!("larger than --max-queue {}", shared.max_queue));
    }
    let queued = conn.stats.queued.load(Ordering::Relaxed);
    if queued + len > shared.max_queue {
        let why = format!(
            "the robot is not reading: {queued} bytes of replies still queued (--max-queue {}); dropped",
            shared.max_queue
        );
        conn.stats.kill(why.clone());
        return Err(why);
    }
    conn.stats.queued.fetch_add(len, Ordering::Relaxed);
    if conn.tx.send((Instant::now(), reply.bytes.clone())).is_err() {
        conn.stats.queued.fetch_sub(len, Ordering::Relaxed);
        return Err("the connection is closed".into());
    }
    conn.after_tuple_lf.store(
        diagnose::ends_with_tuple_and_lf(&reply.bytes),
        Ordering::Relaxed,
    );
    if !shared.out.traffic_wanted() {
        return Ok(());
    }
    shared.out.emit(
        Kind::Traffic,
        Event::Tx(report::Traffic {
            t: now(),
            socket: None,
            conn: Some(conn.id),
            len,
            bytes: Bytes(reply.bytes.clone()),
            origin: Some(origin.to_string()),
            format: Some(reply.format.clone()),
        }),
    );
    Ok(())
}

/// Writes queued replies in order. A reply still not handed to the kernel `stall` after
/// it was queued means the robot reads too slowly or not at all: the connection is
/// dropped (a slow trickle of reads does not keep it alive).
async fn writer(
    mut wr: OwnedWriteHalf,
    mut rx: mpsc::UnboundedReceiver<(Instant, Vec<u8>)>,
    stats: Arc<Stats>,
    stall: Duration,
) {
    while let Some((queued_at, bytes)) = rx.recv().await {
        let left = stall.saturating_sub(queued_at.elapsed());
        let r = if stall == Duration::MAX {
            wr.write_all(&bytes).await
        } else {
            match tokio::time::timeout(left, wr.write_all(&bytes)).await {
                Ok(r) => r,
                Err(_) => {
                    stats.kill(format!(
                        "the robot is not reading: a reply queued {:.1} s ago is still not \
                         written (--write-timeout {:.1}); dropped",
                        queued_at.elapsed().as_secs_f64(),
                        stall.as_secs_f64()
                    ));
                    return;
                }
            }
        };
        match r {
            Ok(()) => {
                stats
                    .tx_bytes
                    .fetch_add(bytes.len() as u64, Ordering::Relaxed);
                stats.queued.fetch_sub(bytes.len(), Ordering::Relaxed);
            }
            Err(e) => {
                stats.kill(format!("write failed: {e}"));
                return;
            }
        }
    }
    let _ = wr.shutdown().await;
}

async fn serve(shared: Arc<Shared>, id: u64, stream: TcpStream, peer: String) {
    let _ = stream.set_nodelay(true);
    let (mut rd, wr) = stream.into_split();
    let (tx, rx) = mpsc::unbounded_channel();
    let stats = Arc::new(Stats {
        queued: AtomicUsize::new(0),
        rx_bytes: AtomicU64::new(0),
        tx_bytes: AtomicU64::new(0),
        last_rx: Mutex::new(Instant::now()),
        close: Notify::new(),
        reason: Mutex::new(None),
    });
    let conn = Arc::new(Conn {
        id,
        peer: peer.clone(),
        since: Instant::now(),
        tx,
        stats: Arc::clone(&stats),
        after_tuple_lf: AtomicBool::new(false),
        refused_sets: AtomicU64::new(0),
        created_vars: Mutex::new(0),
        waiting_since: Mutex::new(None),
    });
    shared
        .conns
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .insert(id, Arc::clone(&conn));
    shared.out.emit(
        Kind::Note,
        Event::Connect(report::Connect {
            t: now(),
            conn: id,
            peer: peer.clone(),
            service: None,
        }),
    );
    let mut writer_task = tokio::spawn(writer(wr, rx, Arc::clone(&stats), shared.write_timeout));

    // Without --decode, lines are still split (silently) so SET/GET are answered; with
    // `--decode var` too, so a malformed variable line can be shown and explained.
    let mut decoder = match shared.decode {
        Some(f) if f != DecodeFormat::Var => f.decoder(&shared.delimiter).ok(),
        _ => None,
    }
    .map_or_else(|| Format::Line.decoder(), Ok)
    .expect("the line decoder takes no arguments");
    let text_kind = shared.decode.map_or("line", DecodeFormat::text_kind);
    let mut rx_buf = RecvBuffer::with_capacity(RX_CAPACITY);
    let mut chunk = vec![0u8; READ_CHUNK];
    let mut peer_closed = false;
    loop {
        // Fairness: while half the reply queue is waiting, read no more requests and let
        // the writer run, so a robot that sends many requests before reading (and does
        // read) is answered, never dropped as "not reading". One that never reads is
        // caught by --write-timeout.
        while stats.queued.load(Ordering::Relaxed) > shared.max_queue / 2
            && stats.reason().is_none()
        {
            tokio::time::sleep(Duration::from_millis(1)).await;
        }
        let n = tokio::select! {
            _ = stats.close.notified() => break,
            r = rd.read(&mut chunk) => match r {
                Ok(n) => n,
                Err(e) => {
                    if e.kind() == std::io::ErrorKind::ConnectionReset {
                        // A robot program that stops with replies unread resets the socket.
                        stats.kill("robot reset the connection".into());
                    } else {
                        stats.kill(format!("read error: {e}"));
                    }
                    break;
                }
            },
        };
        if n > 0 {
            stats.rx_bytes.fetch_add(n as u64, Ordering::Relaxed);
            *stats.last_rx.lock().unwrap_or_else(|p| p.into_inner()) = Instant::now();
            *conn.waiting_since.lock().unwrap_or_else(|p| p.into_inner()) = Some(Instant::now());
        }
        if n > 0 && shared.out.traffic_wanted() {
            shared.out.emit(
                Kind::Traffic,
                Event::Rx(report::Traffic {
                    t: now(),
                    socket: None,
                    conn: Some(id),
                    len: n,
                    bytes: Bytes(chunk[..n].to_vec()),
                    origin: None,
                    format: None,
                }),
            );
        }
        let eof = n == 0;
        let mut decoded: Vec<Decoded> = Vec::new();
        let mut errors: Vec<String> = Vec::new();
        let mut taken = 0;
        loop {
            let got = rx_buf.extend(&chunk[taken..n]);
            taken += got;
            let before = decoded.len() + errors.len();
            drain(
                &mut decoder,
                &mut rx_buf,
                eof && taken >= n,
                &mut |m| match m {
                    Ok(msg) => decoded.push(own(&msg, text_kind)),
                    Err(e) => errors.push(e.to_string()),
                },
            );
            if taken >= n {
                break;
            }
            if got == 0 && decoded.len() + errors.len() == before {
                // Cannot happen with the bounds above; never spin if it does.
                errors.push(format!(
                    "receive buffer full ({RX_CAPACITY} bytes) with no complete message: dropped"
                ));
                rx_buf.clear();
            }
        }
        handle_chunk(&shared, &conn, decoded, errors, n > 0 && rx_buf.is_empty());
        if eof {
            peer_closed = true;
            break;
        }
    }
    shared
        .conns
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .remove(&id);
    shared.open.fetch_sub(1, Ordering::Relaxed);
    if let Ok(addr) = peer.parse::<std::net::SocketAddr>() {
        let mut per = shared.per_address.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(n) = per.get_mut(&addr.ip()) {
            *n = n.saturating_sub(1);
            if *n == 0 {
                per.remove(&addr.ip());
            }
        }
    }
    let killed = stats.reason();
    let refused_sets = conn.refused_sets.load(Ordering::Relaxed);
    drop(conn);
    // A killed connection stops at once; a closing one gets 1 s to flush its replies.
    let flushed = killed.is_none()
        && tokio::time::timeout(Duration::from_secs(1), &mut writer_task)
            .await
            .is_ok();
    if !flushed {
        writer_task.abort();
    }
    let reason = killed.unwrap_or_else(|| {
        if peer_closed {
            "robot closed".into()
        } else {
            "closed".into()
        }
    });
    let (rx, tx) = (
        stats.rx_bytes.load(Ordering::Relaxed),
        stats.tx_bytes.load(Ordering::Relaxed),
    );
    let kind = if reason.contains("not reading")
        || reason.contains("error")
        || reason.contains("failed")
    {
        Kind::Warn
    } else {
        Kind::Note
    };
    shared.out.emit(
        kind,
        Event::Close(report::Close {
            t: now(),
            conn: id,
            reason,
            rx,
            tx,
            refused_sets,
        }),
    );
    let closed = shared.closed.fetch_add(1, Ordering::Relaxed) + 1;
    if shared.exit_after.is_some_and(|n| closed >= n as u64) {
        shared.exit.notify_one();
    }
}

/// What one read brought: show decodes, answer variables, apply rules and `--reply`.
/// `whole`: the chunk ended on a message boundary (nothing partial buffered).
fn handle_chunk(
    shared: &Shared,
    conn: &Conn,
    decoded: Vec<Decoded>,
    errors: Vec<String>,
    whole: bool,
) {
    let raw_mode = shared.decode.is_none();
    let mut other_content = !whole;
    let mut replied = false;
    for e in errors {
        if !raw_mode {
            shared.out.emit(
                Kind::Traffic,
                Event::DecodeError(report::DecodeError {
                    t: now(),
                    conn: conn.id,
                    text: e,
                    message: None,
                }),
            );
        }
    }
    for d in decoded {
        let is_var = d.is_text && handle_var(shared, conn, &d);
        if is_var {
            continue;
        }
        if shared.decode == Some(DecodeFormat::Var) {
            shared.out.emit(
                Kind::Traffic,
                Event::DecodeError(report::DecodeError {
                    t: now(),
                    conn: conn.id,
                    text: format!(
                        "not a variable message: {} (expected `SET name int` or `GET name`)",
                        d.shown
                    ),
                    message: Some(d.typed.clone()),
                }),
            );
        } else if !raw_mode {
            shared.out.emit(
                Kind::Traffic,
                Event::Decoded(report::Decoded {
                    t: now(),
                    conn: Some(conn.id),
                    message: d.typed.clone(),
                    text: d.shown.clone(),
                }),
            );
        }
        other_content = true;
        if let Some(rule) = rules::find(&shared.rules, &d.raw) {
            shared.out.emit(
                Kind::Traffic,
                Event::Rule(report::Rule {
                    t: now(),
                    conn: conn.id,
                    line: rule.line,
                    pattern: rule.pattern.clone(),
                }),
            );
            let _ = send(shared, conn, &rule.reply, "rule");
            replied = true;
        } else if !raw_mode {
            if let Some(r) = &shared.reply {
                let _ = send(shared, conn, r, "reply");
                replied = true;
            }
        }
    }
    // Without --decode, --reply answers each chunk that brought more than SET/GET lines.
    if raw_mode && other_content && !replied {
        if let Some(r) = &shared.reply {
            let _ = send(shared, conn, r, "reply");
        }
    }
}

/// `SET`/`GET` in a text message: stored / answered from the shared table. Returns
/// whether the message was a variable message (well-formed or not).
fn handle_var(shared: &Shared, conn: &Conn, d: &Decoded) -> bool {
    let id = conn.id;
    match parse_var_message(&d.raw) {
        Ok(VarMessage::Set { name, value }) => {
            shared.out.emit(
                Kind::Traffic,
                Event::Decoded(report::Decoded {
                    t: now(),
                    conn: Some(id),
                    message: TypedMessage::Set {
                        name: name.to_string(),
                        value,
                    },
                    text: format!("SET {name} {value}"),
                }),
            );
            // SET expects no reply: the robot is not waiting in a read for one.
            *conn.waiting_since.lock().unwrap_or_else(|p| p.into_inner()) = None;
            let outcome = shared.vars.lock().unwrap_or_else(|p| p.into_inner()).set(
                name,
                value,
                &mut conn.created_vars.lock().unwrap_or_else(|p| p.into_inner()),
            );
            match outcome {
                SetOutcome::Stored => {}
                SetOutcome::Full(max) => {
                    if conn.refused_sets.fetch_add(1, Ordering::Relaxed) == 0 {
                        shared.out.emit(Kind::Warn, Event::VarRefused(report::VarRefused {
                            t: now(),
                            conn: id,
                            name: name.to_string(),
                            text: format!("SET {name} refused: the variable table is full ({max} names, --max-vars); further refusals on this connection are counted"),
                        }));
                    }
                }
                SetOutcome::Quota(quota) => {
                    if conn.refused_sets.fetch_add(1, Ordering::Relaxed) == 0 {
                        shared.out.emit(Kind::Warn, Event::VarRefused(report::VarRefused {
                            t: now(),
                            conn: id,
                            name: name.to_string(),
                            text: format!("SET {name} refused: this connection has created {quota} names, its share (half of --max-vars); a GET of it is answered 0; further refusals on this connection are counted"),
                        }));
                    }
                }
                SetOutcome::NameTooLong(len) => {
                    if conn.refused_sets.fetch_add(1, Ordering::Relaxed) == 0 {
                        shared.out.emit(Kind::Warn, Event::VarRefused(report::VarRefused {
                            t: now(),
                            conn: id,
                            name: name.to_string(),
                            text: format!("SET refused: a {len}-byte name (at most {}); further refusals on this connection are counted", vars::MAX_NAME_LEN),
                        }));
                    }
                }
            }
            true
        }
        Ok(VarMessage::Get { name }) => {
            shared.out.emit(
                Kind::Traffic,
                Event::Decoded(report::Decoded {
                    t: now(),
                    conn: Some(id),
                    message: TypedMessage::Get {
                        name: name.to_string(),
                    },
                    text: format!("GET {name}"),
                }),
            );
            let value = shared
                .vars
                .lock()
                .unwrap_or_else(|p| p.into_inner())
                .get(name);
            if value.is_none() {
                // Shown with the traffic it explains (a robot polling at 500 Hz must not
                // flood a --quiet listener).
                shared.out.emit(
                    Kind::Traffic,
                    Event::UnknownVariable(report::UnknownVariable {
                        t: now(),
                        conn: id,
                        name: name.to_string(),
                        answered: 0,
                    }),
                );
            }
            let mut bytes = Vec::new();
            if encode_var_reply(name, value.unwrap_or(0), &mut bytes).is_ok() {
                let _ = send(
                    shared,
                    conn,
                    &Reply {
                        format: "var-reply".into(),
                        bytes,
                    },
                    "var",
                );
            }
            true
        }
        Err(_) => {
            let starts = d.raw.starts_with(b"GET ") || d.raw.starts_with(b"SET ");
            if starts && !d.raw.is_ascii() {
                shared.out.emit(Kind::Warn, Event::VarInvalid(report::VarInvalid {
                    t: now(),
                    conn: id,
                    message: d.typed.clone(),
                    text: format!("{}: a variable name with non-ASCII bytes; the controller's names are ASCII identifiers, so this is not answered (the robot's socket_get_var returns 0 after 2 s)", d.shown),
                }));
                return true;
            }
            if starts {
                shared.out.emit(Kind::Warn, Event::VarInvalid(report::VarInvalid {
                    t: now(),
                    conn: id,
                    message: d.typed.clone(),
                    text: format!("{}: malformed variable message (expected `SET name int` or `GET name`); not answered", d.shown),
                }));
                return true;
            }
            false
        }
    }
}

#[cfg(test)]
mod stdin_tests {
    use super::*;

    #[test]
    fn typed_lines_are_bounded_and_a_bad_one_stops_nothing() {
        let mut l = StdinLines::default();
        let mut got = l.push(b"a\r\nb\xE9c\n");
        got.extend(l.push(b"par"));
        got.extend(l.push(b"tial\n"));
        assert_eq!(got[0], Ok("a".to_string()));
        assert!(got[1]
            .as_ref()
            .unwrap_err()
            .contains("byte 0xE9 at column 2"));
        assert_eq!(got[2], Ok("partial".to_string()));
        // An endless line: reported once, its bytes dropped, the next line read.
        let big = vec![b'x'; MAX_STDIN_LINE / 2];
        let mut got = Vec::new();
        for _ in 0..5 {
            got.extend(l.push(&big));
        }
        assert!(l.line.len() <= MAX_STDIN_LINE);
        got.extend(l.push(b"more\nnext\n"));
        assert_eq!(got.len(), 2, "{got:?}");
        assert!(got[0].as_ref().unwrap_err().contains("longer than"));
        assert_eq!(got[1], Ok("next".to_string()));
        // The last line without a newline still counts at the end of input.
        l.push(b"last");
        assert_eq!(l.finish(), Some(Ok("last".to_string())));
    }
}
