//! `ursock listen`: the socket debug assistant a robot connects to.
//!
//! One tokio current-thread runtime serves every connection: per connection a reader task
//! (decoding, replies) and a writer task fed by a byte-bounded queue, so a robot that
//! never reads can only fill its own queue (then it is dropped) and never delays another.
//! Both tasks end when the connection ends. Operator input comes from one stdin thread.
//! Limits (`--max-connections`, `--max-vars`, `--max-queue`) bound what a peer can make
//! the listener hold; accept errors (out of descriptors) back off and are said once.

mod diagnose;
mod dump;
mod out;
mod rules;
mod spec;
mod tui;
mod vars;

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use serde_json::{json, Value};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::tcp::OwnedWriteHalf;
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::{mpsc, Notify};
use urscript_socket::line::LineDecoder;
use urscript_socket::robot::ReadCall;
use urscript_socket::var::{
    encode_var_reply, parse_var_message, VarMessage, DEFAULT_MAX_VAR_LINE_LEN,
};
use urscript_socket::RecvBuffer;

use crate::formats::{AnyDecoder, DecodeFormat};
use crate::show::Message;
use out::{bytes_json, Kind, Out};
use spec::Reply;
use vars::{SetOutcome, Vars};

pub const DEFAULT_MAX_CONNECTIONS: usize = 64;
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

pub struct ListenOptions {
    pub bind: String,
    pub port: u16,
    pub decode: Option<DecodeFormat>,
    pub delimiter: Vec<u8>,
    pub reply: Option<String>,
    pub exit_after: Option<usize>,
    pub max_connections: usize,
    pub max_vars: usize,
    pub max_queue: usize,
    pub write_timeout: f64,
    pub show_max: usize,
    pub robot_reads: Option<String>,
    pub rules: Option<PathBuf>,
    pub log: Option<PathBuf>,
    pub json: bool,
    pub quiet: bool,
    pub tui: bool,
}

struct Shared {
    out: Out,
    decode: Option<DecodeFormat>,
    delimiter: Vec<u8>,
    reply: Option<Reply>,
    rules: Vec<rules::Rule>,
    robot_reads: Option<ReadCall>,
    max_connections: usize,
    max_queue: usize,
    show_max: usize,
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
struct Stats {
    queued: AtomicUsize,
    rx_bytes: AtomicU64,
    tx_bytes: AtomicU64,
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
    /// When the robot's last message came, if no reply has been sent since: a reply more
    /// than [`ROBOT_READ_TIMEOUT`] later finds the robot's read already timed out.
    waiting_since: Mutex<Option<Instant>>,
}

/// A decoded message, owned, with what rules match against.
struct Decoded {
    kind: &'static str,
    shown: String,
    raw: Vec<u8>,
    is_text: bool,
    json: Value,
}

fn own(m: &Message<'_>) -> Decoded {
    match m {
        Message::Text(kind, t) => Decoded {
            kind,
            shown: dump::text(t),
            raw: t.to_vec(),
            is_text: true,
            json: {
                let (v, enc) = bytes_json(t);
                json!({"type": kind, "value": v, "encoding": enc})
            },
        },
        other => {
            let shown = other.text();
            let kind = match other {
                Message::Int(_) => "int32",
                Message::Byte(_) => "byte",
                Message::Var(VarMessage::Set { .. }) => "set",
                Message::Var(VarMessage::Get { .. }) => "get",
                _ => "value",
            };
            let json = match other {
                Message::Int(v) => json!({"type": kind, "value": v}),
                Message::Byte(b) => json!({"type": kind, "value": b}),
                _ => json!({"type": kind, "text": shown}),
            };
            Decoded {
                kind,
                raw: shown.clone().into_bytes(),
                shown,
                is_text: false,
                json,
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
    let robot_reads = match &opts.robot_reads {
        Some(s) => Some(diagnose::parse_robot_reads(s)?),
        None => None,
    };
    if let Some(format) = opts.decode {
        AnyDecoder::new(format, &opts.delimiter)?;
    }
    if opts.max_connections == 0 {
        return Err("--max-connections must be at least 1".into());
    }
    let log = match &opts.log {
        Some(p) => {
            Some(std::fs::File::create(p).map_err(|e| format!("--log {}: {e}", p.display()))?)
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
    let out = Out::new(opts.json, opts.quiet, log, opts.tui);
    if opts.json {
        out.stdout_line(&json!({"event": "listening", "addr": addr.to_string()}).to_string());
    } else {
        out.stdout_line(&format!("listening on {addr}"));
    }
    for (what, r) in reply.iter().map(|r| ("--reply".to_string(), r)).chain(
        rules
            .iter()
            .map(|r| (format!("--rules line {}", r.line), &r.reply)),
    ) {
        for w in diagnose::content(r, robot_reads.as_ref()) {
            out.emit(
                Kind::Warn,
                None,
                &format!("{what}: warning: {w}"),
                json!({"event": "diagnosis", "message": w, "source": what}),
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
        delimiter: opts.delimiter,
        reply,
        rules,
        robot_reads,
        max_connections: opts.max_connections,
        max_queue: opts.max_queue.max(1),
        show_max: opts.show_max,
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
    let (cmd_tx, cmd_rx) = mpsc::channel::<String>(16);
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

/// Lines typed on stdin, handed to the runtime. Ends at end of input.
fn spawn_stdin(tx: mpsc::Sender<String>) {
    std::thread::spawn(move || {
        use std::io::BufRead;
        let stdin = std::io::stdin();
        let mut line = String::new();
        loop {
            line.clear();
            match stdin.lock().read_line(&mut line) {
                Ok(0) | Err(_) => return,
                Ok(_) => {
                    if tx
                        .blocking_send(line.trim_end_matches(['\n', '\r']).to_string())
                        .is_err()
                    {
                        return;
                    }
                }
            }
        }
    });
}

async fn run(
    shared: Arc<Shared>,
    std_listener: std::net::TcpListener,
    mut cmds: mpsc::Receiver<String>,
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
                        shared.out.emit(Kind::Warn, None,
                            &format!("accepting again: recovered after {n} failed accepts in {:.1} s", since.elapsed().as_secs_f64()),
                            json!({"event": "accept-recovered", "failures": n}));
                    }
                    let open = shared.open.load(Ordering::Relaxed);
                    if open >= shared.max_connections {
                        if refused == 0 {
                            shared.out.emit(Kind::Warn, None,
                                &format!("refused connection from {peer}: {open} connections open (--max-connections {}); further refusals are counted", shared.max_connections),
                                json!({"event": "refused", "peer": peer.to_string(), "open": open}));
                        }
                        refused += 1;
                        drop(stream);
                        continue;
                    }
                    if refused > 0 {
                        shared.out.emit(Kind::Warn, None,
                            &format!("accepting again: {refused} connections were refused while {} were open", shared.max_connections),
                            json!({"event": "refusals-ended", "refused": refused}));
                        refused = 0;
                    }
                    next_id += 1;
                    shared.open.fetch_add(1, Ordering::Relaxed);
                    let s = Arc::clone(&shared);
                    tokio::spawn(serve(s, next_id, stream, peer.to_string()));
                }
                Err(e) => {
                    let (since, n, delay) = failing.unwrap_or((Instant::now(), 0, Duration::from_millis(50)));
                    if n == 0 {
                        shared.out.emit(Kind::Warn, None,
                            &format!("accept failed: {e}; retrying with back-off (100 ms doubling to 1 s), quiet until it recovers"),
                            json!({"event": "accept-error", "error": e.to_string()}));
                    }
                    let delay = (delay * 2).min(Duration::from_secs(1));
                    failing = Some((since, n + 1, delay));
                    tokio::time::sleep(delay).await;
                }
            },
            cmd = cmds.recv(), if stdin_open => match cmd {
                Some(line) => operator(&shared, &line),
                None => stdin_open = false,
            },
            _ = shared.exit.notified() => break,
        }
    }
    Ok(())
}

/// One typed line: `list`, `close N`, `help`, `[@N] REPLY-SPEC`.
fn operator(shared: &Shared, line: &str) {
    let line = line.trim();
    if line.is_empty() {
        return;
    }
    let note = |text: String, ev: Value| shared.out.emit(Kind::Note, None, &text, ev);
    let conns: Vec<Arc<Conn>> = shared
        .conns
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .values()
        .cloned()
        .collect();
    if line == "help" {
        note(
            format!(
                "type a reply spec ({}), `@N SPEC` for connection N, `list`, `close N`",
                spec::FORMATS
            ),
            json!({"event": "help"}),
        );
        return;
    }
    if line == "list" {
        let nvars = shared.vars.lock().unwrap_or_else(|p| p.into_inner()).len();
        if conns.is_empty() {
            note(
                format!("no robot connected; {nvars} variables"),
                json!({"event": "list", "connections": [], "variables": nvars}),
            );
        } else if !shared.out.is_json() {
            note(
                format!("{} connected; {nvars} variables", conns.len()),
                Value::Null,
            );
        }
        let mut all = Vec::new();
        for c in &conns {
            let (rx, tx) = (
                c.stats.rx_bytes.load(Ordering::Relaxed),
                c.stats.tx_bytes.load(Ordering::Relaxed),
            );
            all.push(json!({"conn": c.id, "peer": c.peer, "rx": rx, "tx": tx, "seconds": c.since.elapsed().as_secs_f64()}));
            if !shared.out.is_json() {
                note(
                    format!(
                        "#{} {}  rx {rx} B  tx {tx} B  connected {:.1} s",
                        c.id,
                        c.peer,
                        c.since.elapsed().as_secs_f64()
                    ),
                    Value::Null,
                );
            }
        }
        if shared.out.is_json() && !conns.is_empty() {
            note(String::new(), json!({"event": "list", "connections": all}));
        }
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
            None => shared.out.emit(
                Kind::Warn,
                None,
                &format!("close {n}: no such connection (see `list`)"),
                json!({"event": "error"}),
            ),
        }
        return;
    }
    let (target, spec_text) = match line.strip_prefix('@') {
        Some(rest) => {
            let (n, s) = rest.split_once(char::is_whitespace).unwrap_or((rest, ""));
            match n.parse::<u64>() {
                Ok(n) => (Some(n), s),
                Err(_) => {
                    shared.out.emit(
                        Kind::Warn,
                        None,
                        &format!("@{n}: expected a connection number, e.g. @2 floats 1 2 3"),
                        json!({"event": "error"}),
                    );
                    return;
                }
            }
        }
        None => (None, line),
    };
    let reply = match spec::parse(spec_text) {
        Ok(r) => r,
        Err(e) => {
            shared.out.emit(
                Kind::Warn,
                None,
                &format!("{e}; nothing sent"),
                json!({"event": "error"}),
            );
            return;
        }
    };
    let conn = match target {
        Some(n) => match conns.iter().find(|c| c.id == n) {
            Some(c) => c,
            None => {
                let ids: Vec<String> = conns.iter().map(|c| format!("#{}", c.id)).collect();
                shared.out.emit(
                    Kind::Warn,
                    None,
                    &format!(
                        "no connection #{n} (connected: {}); nothing sent",
                        if ids.is_empty() {
                            "none".into()
                        } else {
                            ids.join(" ")
                        }
                    ),
                    json!({"event": "error"}),
                );
                return;
            }
        },
        None => {
            match conns.as_slice() {
                [] => {
                    shared.out.emit(
                        Kind::Warn,
                        None,
                        "no robot connected: nothing sent",
                        json!({"event": "error"}),
                    );
                    return;
                }
                [c] => c,
                many => {
                    let ids: Vec<String> = many.iter().map(|c| format!("@{}", c.id)).collect();
                    shared.out.emit(Kind::Warn, None,
                    &format!("{} robots connected ({}): say which, e.g. {} {spec_text}; nothing sent", many.len(), ids.join(" "), ids[0]),
                    json!({"event": "error"}));
                    return;
                }
            }
        }
    };
    send(shared, conn, &reply, "operator");
}

/// Queues `reply` for `conn`'s writer, showing it and saying what the robot's read will
/// make of it. A queue over `--max-queue` bytes means the robot is not reading: dropped.
fn send(shared: &Shared, conn: &Conn, reply: &Reply, origin: &str) {
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
            Some(conn.id),
            &format!("warning: {text}"),
            json!({"event": "diagnosis", "message": text, "late_seconds": w.as_secs_f64()}),
        );
    }
    // `--reply` and rules were checked once at start; what the operator types, each time.
    let warnings = if origin == "operator" {
        diagnose::diagnose(reply, shared.robot_reads.as_ref(), after_lf)
    } else {
        diagnose::leftover_lf(reply, shared.robot_reads.as_ref(), after_lf)
            .into_iter()
            .collect()
    };
    for w in warnings {
        shared.out.emit(
            Kind::Warn,
            Some(conn.id),
            &format!("warning: {w}"),
            json!({"event": "diagnosis", "message": w}),
        );
    }
    let len = reply.bytes.len();
    let queued = conn.stats.queued.load(Ordering::Relaxed);
    if queued + len > shared.max_queue {
        conn.stats.kill(format!(
            "the robot is not reading: {queued} bytes of replies still queued (--max-queue {}); dropped",
            shared.max_queue
        ));
        return;
    }
    conn.stats.queued.fetch_add(len, Ordering::Relaxed);
    if conn.tx.send((Instant::now(), reply.bytes.clone())).is_err() {
        conn.stats.queued.fetch_sub(len, Ordering::Relaxed);
        return;
    }
    conn.after_tuple_lf.store(
        diagnose::ends_with_tuple_and_lf(&reply.bytes),
        Ordering::Relaxed,
    );
    if !shared.out.traffic_wanted() {
        return;
    }
    let (data, enc) = bytes_json(&reply.bytes);
    shared.out.emit(
        Kind::Traffic,
        Some(conn.id),
        &format!("-> {:<4} {}", len, dump::chunk(&reply.bytes, "      ", shared.show_max)),
        json!({"event": "tx", "origin": origin, "format": reply.format, "len": len, "data": data, "encoding": enc}),
    );
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
        waiting_since: Mutex::new(None),
    });
    shared
        .conns
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .insert(id, Arc::clone(&conn));
    shared.out.emit(
        Kind::Note,
        Some(id),
        &format!("connected from {peer}"),
        json!({"event": "connect", "peer": peer}),
    );
    let mut writer_task = tokio::spawn(writer(wr, rx, Arc::clone(&stats), shared.write_timeout));

    // Without --decode, lines are still split (silently) so SET/GET are answered.
    let mut decoder = match shared.decode {
        Some(DecodeFormat::Var) => {
            AnyDecoder::Line(LineDecoder::with_max_len(DEFAULT_MAX_VAR_LINE_LEN))
        }
        Some(f) => {
            AnyDecoder::new(f, &shared.delimiter).unwrap_or(AnyDecoder::Line(LineDecoder::new()))
        }
        None => AnyDecoder::Line(LineDecoder::new()),
    };
    let mut rx_buf = RecvBuffer::with_capacity(RX_CAPACITY);
    let mut chunk = vec![0u8; READ_CHUNK];
    let mut peer_closed = false;
    loop {
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
            *conn.waiting_since.lock().unwrap_or_else(|p| p.into_inner()) = Some(Instant::now());
        }
        if n > 0 && shared.out.traffic_wanted() {
            let (data, enc) = bytes_json(&chunk[..n]);
            shared.out.emit(
                Kind::Traffic,
                Some(id),
                &format!(
                    "<- {:<4} {}",
                    n,
                    dump::chunk(&chunk[..n], "      ", shared.show_max)
                ),
                json!({"event": "rx", "len": n, "data": data, "encoding": enc}),
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
            decoder.drain(&mut rx_buf, eof && taken >= n, &mut |m| match m {
                Ok(msg) => decoded.push(own(&msg)),
                Err(e) => errors.push(e.to_string()),
            });
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
    let mut text = format!("closed ({reason}): rx {rx} B, tx {tx} B");
    if refused_sets > 1 {
        text.push_str(&format!(
            ", {refused_sets} SETs refused (variable table full)"
        ));
    }
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
        Some(id),
        &text,
        json!({"event": "close", "reason": reason, "rx": rx, "tx": tx}),
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
                Some(conn.id),
                &format!("   ! {e}"),
                json!({"event": "decode-error", "error": e}),
            );
        }
    }
    for d in decoded {
        let is_var = d.is_text && handle_var(shared, conn, &d);
        if is_var {
            continue;
        }
        if shared.decode == Some(DecodeFormat::Var) {
            shared.out.emit(Kind::Traffic, Some(conn.id),
                &format!("   ! not a variable message: {} (expected `SET name int` or `GET name`)", d.shown),
                json!({"event": "decode-error", "error": "not a variable message", "message": d.json}));
        } else if !raw_mode {
            shared.out.emit(
                Kind::Traffic,
                Some(conn.id),
                &format!("   = {}", d.shown),
                json!({"event": "decoded", "kind": d.kind, "message": d.json}),
            );
        }
        other_content = true;
        if let Some(rule) = rules::find(&shared.rules, &d.raw) {
            shared.out.emit(
                Kind::Traffic,
                Some(conn.id),
                &format!("   rule {} ({}) matched", rule.line, rule.pattern),
                json!({"event": "rule", "line": rule.line, "pattern": rule.pattern}),
            );
            send(shared, conn, &rule.reply, "rule");
            replied = true;
        } else if !raw_mode {
            if let Some(r) = &shared.reply {
                send(shared, conn, r, "reply");
                replied = true;
            }
        }
    }
    // Without --decode, --reply answers each chunk that brought more than SET/GET lines.
    if raw_mode && other_content && !replied {
        if let Some(r) = &shared.reply {
            send(shared, conn, r, "reply");
        }
    }
}

/// `SET`/`GET` in a text message: stored / answered from the shared table. Returns
/// whether the message was a variable message (well-formed or not).
fn handle_var(shared: &Shared, conn: &Conn, d: &Decoded) -> bool {
    let id = conn.id;
    match parse_var_message(&d.raw) {
        Ok(VarMessage::Set { name, value }) => {
            shared.out.emit(Kind::Traffic, Some(id), &format!("   = SET {name} {value}"),
                json!({"event": "decoded", "kind": "set", "message": {"type": "set", "name": name, "value": value}}));
            // SET expects no reply: the robot is not waiting in a read for one.
            *conn.waiting_since.lock().unwrap_or_else(|p| p.into_inner()) = None;
            let outcome = shared
                .vars
                .lock()
                .unwrap_or_else(|p| p.into_inner())
                .set(name, value);
            match outcome {
                SetOutcome::Stored => {}
                SetOutcome::Full(max) => {
                    if conn.refused_sets.fetch_add(1, Ordering::Relaxed) == 0 {
                        shared.out.emit(Kind::Warn, Some(id),
                            &format!("SET {name} refused: the variable table is full ({max} names, --max-vars); further refusals on this connection are counted"),
                            json!({"event": "var-refused", "name": name, "max_vars": max}));
                    }
                }
                SetOutcome::NameTooLong(len) => {
                    if conn.refused_sets.fetch_add(1, Ordering::Relaxed) == 0 {
                        shared.out.emit(Kind::Warn, Some(id),
                            &format!("SET refused: a {len}-byte name (at most {}); further refusals on this connection are counted", vars::MAX_NAME_LEN),
                            json!({"event": "var-refused", "name_len": len}));
                    }
                }
            }
            true
        }
        Ok(VarMessage::Get { name }) => {
            shared.out.emit(Kind::Traffic, Some(id), &format!("   = GET {name}"),
                json!({"event": "decoded", "kind": "get", "message": {"type": "get", "name": name}}));
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
                    Some(id),
                    &format!("unknown variable {name} (never SET), answered 0"),
                    json!({"event": "unknown-variable", "name": name, "answered": 0}),
                );
            }
            let mut bytes = Vec::new();
            if encode_var_reply(name, value.unwrap_or(0), &mut bytes).is_ok() {
                send(
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
                shared.out.emit(Kind::Warn, Some(id),
                    &format!("{}: a variable name with non-ASCII bytes; the controller's names are ASCII identifiers, so this is not answered (the robot's socket_get_var returns 0 after 2 s)", d.shown),
                    json!({"event": "var-invalid", "message": d.json}));
                return true;
            }
            if starts {
                shared.out.emit(Kind::Warn, Some(id),
                    &format!("{}: malformed variable message (expected `SET name int` or `GET name`); not answered", d.shown),
                    json!({"event": "var-invalid", "message": d.json}));
                return true;
            }
            false
        }
    }
}
