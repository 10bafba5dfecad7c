//! `ursock robot`: a virtual robot running a URScript program against real servers.
//!
//! The program (a `--script` file or `-e` lines) is run by `urscript-interp`: parsed whole
//! first (a syntax error names line and column, and nothing is sent), then run by its
//! sans-IO [`Machine`] in real time. This module is the driver: it connects the sockets
//! the program opens (`std::net`, non-blocking), writes what it sends, feeds it what the
//! servers send, and prints each socket call with its result, `textmsg`/`popup` text and
//! stubbed calls, with the read-failure diagnosis of [`crate::diagnose`].
//!
//! The old one-call-per-line scripts are URScript statements and run unchanged.

use std::collections::{HashMap, VecDeque};
use std::io::{ErrorKind, Read};
use std::net::{Shutdown, TcpStream};
use std::time::{Duration, Instant};

use urscript_interp::{Config, Event, Machine, Program, State, Stub};
use urscript_socket::robot::{ReadCall, DEFAULT_SOCKET_NAME};

use crate::out;
use crate::show::{text_and_hex, JsonBytes};

/// How `ursock robot` runs and what it prints besides each call and its result.
pub struct Options {
    /// The bytes sent and received, with relative times.
    pub trace: bool,
    /// One JSON object per line instead of text.
    pub json: bool,
    /// End the program after this long (a success if nothing failed before).
    pub max_time: Option<Duration>,
    /// The controller's step: 2 ms (e-Series), 8 ms (CB3).
    pub step_time: Duration,
    /// Functions replaced by a no-op or a value.
    pub stubs: Vec<(String, Stub)>,
}

/// Data that a read finds this long before it ends, with no send since the previous read
/// on that socket timed out, was waiting: that read's late reply (a pending read ends as
/// soon as its bytes arrive, so bytes older than this were there before it started).
const LATE_WINDOW: Duration = Duration::from_millis(50);

/// Keeps the first bytes of a read's input for [`crate::diagnose::diagnose`].
const WINDOW: usize = 4096;

/// How long a `socket_open` may take to connect before it returns False.
const CONNECT_TIMEOUT: Duration = Duration::from_secs(2);

/// The longest sleep between two rounds of reading the sockets.
const POLL_INTERVAL: Duration = Duration::from_millis(1);

fn trace_event(json: bool, name: &str, tx: bool, bytes: &[u8]) {
    let (arrow, tag) = if tx { ("->", "tx") } else { ("<-", "rx") };
    if json {
        let ev = serde_json::json!({
            "t": out::elapsed_secs(),
            "event": tag,
            "socket": name,
            "len": bytes.len(),
            "bytes": JsonBytes::new(bytes),
        });
        outln!("{ev}");
    } else {
        outln!(
            "    {} {name} {arrow} {}",
            out::stamp(),
            text_and_hex(bytes, "        ")
        );
    }
}

/// `socket_open("host", port, "socket_0")` for a `--connect HOST:PORT` argument.
fn split_host_port(addr: &str) -> Result<(String, u16), String> {
    let (host, port) = addr.rsplit_once(':').ok_or_else(|| {
        format!("--connect {addr:?}: no port (give HOST:PORT, like 192.168.0.10:30000)")
    })?;
    let port = port
        .parse::<u16>()
        .map_err(|_| format!("--connect {addr:?}: {port:?} is not a port (0-65535)"))?;
    let host = host
        .trim_start_matches('[')
        .trim_end_matches(']')
        .to_string();
    Ok((host, port))
}

/// Why a connection failed, in words: the OS reason plus what it usually means.
fn open_failure(host: &str, port: u16, e: &std::io::Error) -> String {
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

fn connect(host: &str, port: u16) -> std::io::Result<TcpStream> {
    urscript_interp::drive::connect_stream(host, port, CONNECT_TIMEOUT)
}

/// One open connection of the program.
struct Conn {
    stream: TcpStream,
    /// Bytes read but not yet accepted by the socket's receive buffer.
    backlog: Vec<u8>,
    closed: bool,
    /// A write failed or the peer reset the connection: sends return False.
    broken: bool,
    /// What the server sent since the last read on this socket ended (for the diagnosis).
    seen: Vec<u8>,
    /// When the first of `seen` arrived.
    first_at: Option<Instant>,
    /// The previous read on this socket timed out: (its call, its line, a send since).
    timed_out: Option<(ReadCall, u32, bool)>,
}

/// A call traced by the machine: `name(args) -> result`, split.
struct Traced<'a> {
    call: &'a str,
    name: &'a str,
    result: &'a str,
}

/// Splits `f(a, "x)", b) -> r` at the `)` that closes the call (strings have no escapes).
fn split_traced(text: &str) -> Option<Traced<'_>> {
    let open = text.find('(')?;
    let (mut depth, mut in_str) = (0i32, false);
    for (i, c) in text.char_indices().skip(open) {
        match c {
            '"' => in_str = !in_str,
            '(' | '[' if !in_str => depth += 1,
            ')' | ']' if !in_str => {
                depth -= 1;
                if depth == 0 && c == ')' {
                    let result = text[i + 1..].strip_prefix(" -> ")?;
                    return Some(Traced {
                        call: &text[..=i],
                        name: &text[..open],
                        result,
                    });
                }
            }
            _ => {}
        }
    }
    None
}

/// The top-level arguments of a traced call, split on commas outside strings/brackets.
fn call_args(call: &str) -> Vec<&str> {
    let Some(inner) = call.find('(').and_then(|o| call[o + 1..].strip_suffix(')')) else {
        return Vec::new();
    };
    let (mut out, mut depth, mut in_str, mut start) = (Vec::new(), 0i32, false, 0);
    for (i, c) in inner.char_indices() {
        match c {
            '"' => in_str = !in_str,
            '[' | '(' if !in_str => depth += 1,
            ']' | ')' if !in_str => depth -= 1,
            ',' if !in_str && depth == 0 => {
                out.push(inner[start..i].trim());
                start = i + 1;
            }
            _ => {}
        }
    }
    if !inner.trim().is_empty() {
        out.push(inner[start..].trim());
    }
    out
}

/// Argument `key` of a traced call: by keyword, else at position `pos`.
fn arg<'a>(args: &[&'a str], key: &str, pos: usize) -> Option<&'a str> {
    let positional: Vec<&str> = args
        .iter()
        .copied()
        .filter(|a| !is_keyword_arg(a))
        .collect();
    args.iter()
        .find_map(|a| {
            a.split_once('=')
                .filter(|(k, _)| k.trim() == key && is_keyword_arg(a))
                .map(|(_, v)| v.trim())
        })
        .or_else(|| positional.get(pos).copied())
}

fn is_keyword_arg(a: &str) -> bool {
    a.split_once('=').is_some_and(|(k, _)| {
        let k = k.trim();
        !k.is_empty() && k.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
    })
}

fn unquote(s: &str) -> String {
    s.strip_prefix('"')
        .and_then(|s| s.strip_suffix('"'))
        .unwrap_or(s)
        .to_string()
}

/// The socket a traced socket call used, and the read it made (for the diagnosis).
fn socket_and_read(name: &str, args: &[&str]) -> (String, Option<ReadCall>) {
    let number = || {
        arg(args, "number", 0)
            .and_then(|n| n.parse::<usize>().ok())
            .unwrap_or(1)
    };
    let sock_pos = match name {
        "socket_read_line" | "socket_read_string" | "socket_close" => 0,
        "socket_open" => 2,
        "socket_set_var" => 2,
        _ => 1,
    };
    let socket = arg(args, "socket_name", sock_pos)
        .map(unquote)
        .unwrap_or_else(|| DEFAULT_SOCKET_NAME.to_string());
    let read = match name {
        "socket_read_ascii_float" => Some(ReadCall::AsciiFloat { number: number() }),
        "socket_read_binary_integer" => Some(ReadCall::BinaryInteger { number: number() }),
        "socket_read_byte_list" => Some(ReadCall::ByteList { number: number() }),
        "socket_read_line" => Some(ReadCall::Line),
        "socket_read_string" => Some(ReadCall::String {
            prefix: arg(args, "prefix", 1)
                .map(unquote)
                .unwrap_or_default()
                .into_bytes(),
            suffix: arg(args, "suffix", 2)
                .map(unquote)
                .unwrap_or_default()
                .into_bytes(),
            interpret_escape: arg(args, "interpret_escape", 3) == Some("True"),
        }),
        _ => None,
    };
    (socket, read)
}

/// A result as JSON: `[n, a, b]` as `{"count": n, "values": [a, b]}` (nan as null),
/// strings as text, ints, bools.
fn result_json(result: &str) -> serde_json::Value {
    if let Some(inner) = result.strip_prefix('[').and_then(|r| r.strip_suffix(']')) {
        let items: Vec<serde_json::Value> = inner
            .split(',')
            .map(|x| {
                let x = x.trim();
                x.parse::<i64>()
                    .map(serde_json::Value::from)
                    .or_else(|_| x.parse::<f64>().map(serde_json::Value::from))
                    .unwrap_or(serde_json::Value::Null)
            })
            .collect();
        let count = items.first().cloned().unwrap_or_default();
        return serde_json::json!({ "count": count, "values": items.get(1..).unwrap_or_default() });
    }
    if result.starts_with('"') {
        return serde_json::to_value(JsonBytes::new(unquote(result).as_bytes()))
            .unwrap_or_default();
    }
    match result {
        "True" => true.into(),
        "False" => false.into(),
        "None" => serde_json::Value::Null,
        r => r
            .parse::<i64>()
            .map(serde_json::Value::from)
            .or_else(|_| r.parse::<f64>().map(serde_json::Value::from))
            .unwrap_or_else(|_| r.into()),
    }
}

/// A read's result is its sentinel (`[0, ...]`, `""`) or fewer floats than asked.
fn read_failed(read: &ReadCall, result: &str) -> bool {
    let count = result
        .strip_prefix('[')
        .and_then(|r| r.split([',', ']']).next())
        .and_then(|c| c.trim().parse::<usize>().ok());
    match (read, count) {
        (ReadCall::AsciiFloat { number }, Some(c)) => c < *number,
        (_, Some(c)) => c == 0,
        (_, None) => result == "\"\"",
    }
}

/// The bytes a successful read left buffered, from what it saw: the read consumes
/// through `)` (floats), through LF (lines) or exactly its bytes (binary). `None` where
/// the CLI cannot tell (strings).
fn leftover<'a>(read: &ReadCall, seen: &'a [u8]) -> Option<&'a [u8]> {
    let end = match read {
        ReadCall::AsciiFloat { .. } => {
            let open = seen.iter().position(|&b| b == b'(')?;
            open + seen[open..].iter().position(|&b| b == b')')? + 1
        }
        ReadCall::Line => seen.iter().position(|&b| b == b'\n')? + 1,
        ReadCall::BinaryInteger { number } => number * 4,
        ReadCall::ByteList { number } => *number,
        _ => return None,
    };
    seen.get(end..).filter(|rest| !rest.is_empty())
}

/// The variable the line `line` assigns the call of `name` to, when the line is just
/// that (`x = name(...)`): printed in front of the call, as the old one-call-per-line
/// output showed it.
fn assigned_to<'a>(source: &[&'a str], line: u32, name: &str) -> Option<&'a str> {
    let text = source.get((line as usize).checked_sub(1)?)?;
    let code = strip_comment(text).trim();
    let (target, rest) = code.split_once('=')?;
    let target = target.trim();
    let target = target
        .strip_prefix("local ")
        .or_else(|| target.strip_prefix("global "))
        .map_or(target, str::trim);
    let call = rest.trim();
    (!target.is_empty()
        && target
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_')
        && !rest.starts_with('=')
        && call.starts_with(name)
        && call[name.len()..].trim_start().starts_with('(')
        && split_traced(&format!("{call} -> x")).is_some_and(|t| t.call.len() == call.len()))
    .then_some(target)
}

fn strip_comment(line: &str) -> &str {
    let mut in_str = false;
    for (i, c) in line.char_indices() {
        match c {
            '"' => in_str = !in_str,
            '#' if !in_str => return &line[..i],
            _ => {}
        }
    }
    line
}

/// Control characters of a result made visible (`\r`, `\n`, `\t`, `\xHH`), as the
/// robot's strings are shown elsewhere in `ursock`.
fn visible(text: &str) -> std::borrow::Cow<'_, str> {
    if !text.chars().any(char::is_control) {
        return text.into();
    }
    let mut out = String::with_capacity(text.len() + 8);
    for c in text.chars() {
        match c {
            '\r' => out.push_str("\\r"),
            '\n' => out.push_str("\\n"),
            '\t' => out.push_str("\\t"),
            c if c.is_control() => out.push_str(&format!("\\x{:02X}", c as u32)),
            c => out.push(c),
        }
    }
    out.into()
}

/// Prints one call: text (`shown -> result`, the reason on stderr) or one JSON object.
fn report(json: bool, line: u32, shown: &str, call: &str, result: &str, why: Option<String>) {
    if json {
        let sentinel = result.starts_with("[0,") || result == "\"\"";
        let ev = crate::offline::ReadJson {
            t: Some(out::elapsed_secs()),
            line: Some(line as usize),
            call: call.to_string(),
            result: result_json(result),
            sentinel,
            why,
        };
        outln!("{}", serde_json::to_string(&ev).unwrap_or_default());
    } else {
        if result.is_empty() || result == "None" {
            outln!("{}", visible(shown));
        } else {
            outln!("{} -> {}", visible(shown), visible(result));
        }
        if let Some(w) = why {
            out::note(&format!("line {line}: {w}"));
        }
    }
}

const SEND_FUNCTIONS: &[&str] = &[
    "socket_send_string",
    "socket_send_line",
    "socket_send_byte",
    "socket_send_bytes",
    "socket_send_int",
    "socket_set_var",
];

/// Runs `script` (the text of a file or `-e` lines) as a URScript program against real
/// servers; `connect` opens `socket_0` first. Prints each socket call and its result and
/// the program's messages. As on the controller, a failed `socket_open` and a send to a
/// server that has gone return False and the program goes on; the reason is said on
/// stderr (and in `--log`). A parse error (nothing sent) or a runtime error is the `Err`,
/// naming the line.
pub fn run(script: &str, connect_to: Option<&str>, opts: Options) -> Result<(), String> {
    let program = Program::parse(script).map_err(|e| e.to_string())?;
    let source: Vec<&str> = script.lines().collect();
    let config = Config {
        step_time: opts.step_time,
        stubs: opts.stubs.clone(),
        trace_socket_calls: true,
        trace_all_calls: true,
        ..Config::default()
    };
    let mut machine = Machine::new(program, config);
    let json = opts.json;
    let mut conns: HashMap<String, Conn> = HashMap::new();
    let new_conn = |stream| Conn {
        stream,
        backlog: Vec::new(),
        closed: false,
        broken: false,
        seen: Vec::new(),
        first_at: None,
        timed_out: None,
    };
    if let Some(addr) = connect_to {
        let (host, port) = split_host_port(addr)?;
        let shown = format!("socket_open(\"{host}\", {port}, \"{DEFAULT_SOCKET_NAME}\")");
        match connect(&host, port) {
            Ok(stream) => {
                report(json, 0, &shown, "socket_open", "True", None);
                conns.insert(DEFAULT_SOCKET_NAME.to_string(), new_conn(stream));
                machine.handle_connected(DEFAULT_SOCKET_NAME, Ok(()));
            }
            Err(e) => {
                let reason = open_failure(&host, port, &e);
                let why = json.then(|| reason.clone());
                report(json, 0, &shown, "socket_open", "False", why);
                return Err(reason);
            }
        }
    }
    let start = Instant::now();
    let mut open_failures: HashMap<String, String> = HashMap::new();
    let mut messages: VecDeque<String> = VecDeque::new();
    let mut last_why: HashMap<u32, String> = HashMap::new();
    let mut buf = vec![0u8; 16 * 1024];
    loop {
        let now = start.elapsed();
        if opts.max_time.is_some_and(|m| now >= m) {
            out::note(&format!(
                "--max-time {}s reached: the program was ended",
                opts.max_time.unwrap_or_default().as_secs_f64()
            ));
            return Ok(());
        }
        machine.run_until(now);
        while let Some(event) = machine.poll_event() {
            match event {
                Event::Connect {
                    socket_name,
                    host,
                    port,
                } => match connect(&host, port) {
                    Ok(stream) => {
                        if let Some(old) = conns.insert(socket_name.clone(), new_conn(stream)) {
                            let _ = old.stream.shutdown(Shutdown::Both);
                        }
                        machine.handle_connected(&socket_name, Ok(()));
                    }
                    Err(e) => {
                        let reason = open_failure(&host, port, &e);
                        open_failures.insert(socket_name.clone(), reason.clone());
                        machine.handle_connected(&socket_name, Err(reason));
                    }
                },
                Event::Transmit { socket_name, bytes } => {
                    if opts.trace {
                        trace_event(json, &socket_name, true, &bytes);
                    }
                    if let Some(c) = conns.get_mut(&socket_name) {
                        if let Some(t) = c.timed_out.as_mut() {
                            t.2 = true;
                        }
                        if !c.broken
                            && urscript_interp::drive::write_all(&mut c.stream, &bytes).is_err()
                        {
                            c.closed = true;
                            c.broken = true;
                            machine.handle_send_failed(&socket_name);
                        }
                    }
                }
                Event::Close { socket_name } => {
                    if let Some(c) = conns.remove(&socket_name) {
                        let _ = c.stream.shutdown(Shutdown::Both);
                    }
                }
                Event::Message(text) => messages.push_back(text),
                Event::Call { line, text } => {
                    let Some(t) = split_traced(&text) else {
                        continue;
                    };
                    let is_message = matches!(t.name, "textmsg" | "popup" | "varmsg");
                    let stubbed = t.result.ends_with(" (stub)");
                    if !(t.name.starts_with("socket_") || is_message || stubbed) {
                        continue;
                    }
                    let shown = match assigned_to(&source, line, t.name) {
                        Some(target) => format!("{target} = {}", t.call),
                        None => t.call.to_string(),
                    };
                    let shown = shown.as_str();
                    if is_message {
                        let text = messages.pop_front().unwrap_or_default();
                        if json {
                            report(json, line, shown, t.name, &format!("\"{text}\""), None);
                        } else {
                            report(json, line, shown, t.name, &text, None);
                        }
                        continue;
                    }
                    let args = call_args(t.call);
                    let (socket, read) = socket_and_read(t.name, &args);
                    let mut result = t.result.to_string();
                    let mut why = None;
                    if t.name == "socket_open" {
                        if let Some(reason) = result.strip_prefix("False") {
                            why = Some(open_failures.remove(&socket).unwrap_or_else(|| {
                                reason
                                    .trim()
                                    .trim_matches(|c| c == '(' || c == ')')
                                    .to_string()
                            }));
                            result = "False".into();
                        }
                    } else if SEND_FUNCTIONS.contains(&t.name) && result == "False" {
                        why = Some(if conns.contains_key(&socket) {
                            format!(
                                "{}: the connection is broken (a write failed); the server has probably closed it",
                                t.name
                            )
                        } else {
                            format!("{}: the socket \"{socket}\" is not open", t.name)
                        });
                    } else if t.name == "socket_get_var" {
                        // Its reply line is not the next read's input.
                        if let Some(c) = conns.get_mut(&socket) {
                            match c.seen.iter().position(|&b| b == b'\n') {
                                Some(i) => drop(c.seen.drain(..=i)),
                                None => c.seen.clear(),
                            }
                            if c.seen.is_empty() {
                                c.first_at = None;
                            }
                        }
                    } else if let (Some(read), Some(c)) = (&read, conns.get_mut(&socket)) {
                        let timed_out_now = result.ends_with(" (timeout)");
                        let value = result.trim_end_matches(" (timeout)");
                        let seen = std::mem::take(&mut c.seen);
                        let first_at = c.first_at.take();
                        let binary = matches!(
                            read,
                            ReadCall::BinaryInteger { .. } | ReadCall::ByteList { .. }
                        );
                        if binary || read_failed(read, value) {
                            why =
                                crate::diagnose::diagnose(read, &seen).map(|w| format!("why: {w}"));
                        }
                        if let Some((prev, prev_line, sent_since)) = c.timed_out.take() {
                            let waiting = first_at.is_some_and(|at| at.elapsed() >= LATE_WINDOW);
                            if waiting && !sent_since {
                                let late = crate::diagnose::late_reply(&prev, prev_line as usize);
                                why = Some(match why {
                                    Some(w) => format!("why: {late}; {}", &w[5..]),
                                    None => format!("why: {late}"),
                                });
                            }
                        }
                        if timed_out_now || read_failed(read, value) {
                            c.timed_out = Some((read.clone(), line, false));
                        } else if let Some(rest) = leftover(read, &seen) {
                            c.first_at = Some(Instant::now());
                            c.seen = rest.to_vec();
                        }
                    }
                    if json {
                        let why = why.map(|w| w.trim_start_matches("why: ").to_string());
                        let value = result
                            .trim_end_matches(" (timeout)")
                            .trim_end_matches(" (stub)");
                        report(json, line, shown, t.name, value, why);
                    } else {
                        // A loop polling with a timeout would repeat the same note at
                        // every turn: a note is said again only when it changes.
                        let why = match why {
                            Some(w) if last_why.get(&line) == Some(&w) => None,
                            Some(w) => {
                                last_why.insert(line, w.clone());
                                Some(w)
                            }
                            None => {
                                last_why.remove(&line);
                                None
                            }
                        };
                        report(json, line, shown, t.name, &result, why);
                    }
                }
            }
        }
        match machine.state() {
            State::Running => {}
            State::Finished | State::Halted => return Ok(()),
            State::Error(e) => return Err(e.to_string()),
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
            if c.broken {
                continue;
            }
            if c.closed {
                // The peer closed its end: a reset after it (the peer is gone, a write
                // reached nobody) makes later sends fail, as on the controller.
                if matches!(c.stream.take_error(), Ok(Some(_)) | Err(_)) {
                    c.broken = true;
                    machine.handle_send_failed(name);
                }
                continue;
            }
            match c.stream.read(&mut buf) {
                Ok(0) => {
                    got_any = true;
                    c.closed = true;
                    machine.handle_peer_closed(name);
                }
                Ok(n) => {
                    got_any = true;
                    let bytes = &buf[..n];
                    if opts.trace {
                        trace_event(json, name, false, bytes);
                    }
                    c.first_at.get_or_insert_with(Instant::now);
                    let room = WINDOW.saturating_sub(c.seen.len());
                    c.seen.extend_from_slice(&bytes[..n.min(room)]);
                    let taken = machine.handle_received(name, bytes);
                    c.backlog.extend_from_slice(&bytes[taken..]);
                }
                Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::Interrupted) => {}
                Err(_) => {
                    got_any = true;
                    c.closed = true;
                    machine.handle_peer_closed(name);
                }
            }
        }
        if !got_any {
            let now = start.elapsed();
            let mut wait = POLL_INTERVAL;
            if let Some(t) = machine.poll_timeout() {
                wait = wait.min(t.saturating_sub(now));
            }
            if let Some(m) = opts.max_time {
                wait = wait.min(m.saturating_sub(now));
            }
            if !wait.is_zero() {
                std::thread::sleep(wait);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn traced_calls_split_at_their_closing_paren() {
        let t = split_traced("socket_read_string(\"c\", suffix=\")\") -> \"a -> b\"").unwrap();
        assert_eq!(t.name, "socket_read_string");
        assert_eq!(t.result, "\"a -> b\"");
        assert_eq!(call_args(t.call), ["\"c\"", "suffix=\")\""]);
        let (socket, read) = socket_and_read(t.name, &call_args(t.call));
        assert_eq!(socket, "c");
        assert!(matches!(read, Some(ReadCall::String { suffix, .. }) if suffix == b")"));
    }

    #[test]
    fn control_characters_are_shown_escaped() {
        assert_eq!(visible("\"TRG\r\""), "\"TRG\\r\"");
        assert_eq!(visible("a\u{1}"), "a\\x01");
    }

    #[test]
    fn assignments_of_one_call_show_their_variable() {
        let src = [
            "x = socket_read_ascii_float(3)  # pose",
            "if socket_open(h, 1):",
        ];
        assert_eq!(assigned_to(&src, 1, "socket_read_ascii_float"), Some("x"));
        assert_eq!(assigned_to(&src, 2, "socket_open"), None);
    }
}
