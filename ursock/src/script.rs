//! `ursock robot`: a virtual robot running socket calls written as URScript, one per line.
//!
//! The subset: `[name =] function(arg, ..., key=arg)` with string literals (no escapes,
//! as in URScript), numbers, `True`/`False`, lists `[...]` and poses `p[...]`, variables
//! assigned earlier, `#` comments. List and pose literals are read by the library's
//! `to_str` parser.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use urscript_socket::robot::{
    Direction, Policy, ReadCall, ReadResult, RobotError, Timeout, VirtualRobot, DEFAULT_SOCKET_NAME,
};
use urscript_socket::to_str::{parse_value, Scalar, Value};

use crate::out;
use crate::show::{text_and_hex, JsonBytes};

/// An argument value.
#[derive(Debug, Clone)]
enum Arg {
    Str(Vec<u8>),
    Num(f64),
    Bool(bool),
    /// A list or pose literal, kept as text and read with `to_str::parse_value`.
    Bracketed(String),
    /// The result of an earlier read.
    Result(Box<ReadResult>),
}

struct Call {
    target: Option<String>,
    function: String,
    positional: Vec<Arg>,
    named: Vec<(String, Arg)>,
}

/// Splits a line into a call. Errors are messages without the line number.
fn parse_line(line: &str, vars: &HashMap<String, ReadResult>) -> Result<Option<Call>, String> {
    let code = strip_comment(line).trim();
    if code.is_empty() {
        return Ok(None);
    }
    let (target, rest) = match code.find('=') {
        Some(eq) if is_ident(code[..eq].trim()) && !code[..eq].contains('(') => {
            (Some(code[..eq].trim().to_string()), code[eq + 1..].trim())
        }
        _ => (None, code),
    };
    let open = rest
        .find('(')
        .ok_or_else(|| format!("expected a call like `f(...)`, found `{rest}`"))?;
    let function = rest[..open].trim().to_string();
    if !is_ident(&function) {
        return Err(format!("`{function}` is not a function name"));
    }
    let inner = rest[open + 1..]
        .strip_suffix(')')
        .ok_or_else(|| format!("missing `)` at the end of `{rest}`"))?;
    let mut call = Call {
        target,
        function,
        positional: Vec::new(),
        named: Vec::new(),
    };
    for raw in split_args(inner)? {
        let raw = raw.trim();
        if raw.is_empty() {
            return Err("empty argument".into());
        }
        match raw.find('=') {
            Some(eq) if is_ident(raw[..eq].trim()) && !raw.starts_with('"') => {
                call.named.push((
                    raw[..eq].trim().to_string(),
                    parse_arg(raw[eq + 1..].trim(), vars)?,
                ));
            }
            _ => call.positional.push(parse_arg(raw, vars)?),
        }
    }
    Ok(Some(call))
}

fn is_ident(s: &str) -> bool {
    let mut chars = s.chars();
    matches!(chars.next(), Some(c) if c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
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

/// Splits on commas outside strings and brackets.
fn split_args(s: &str) -> Result<Vec<&str>, String> {
    let (mut out, mut depth, mut in_str, mut start) = (Vec::new(), 0i32, false, 0);
    for (i, c) in s.char_indices() {
        match c {
            '"' => in_str = !in_str,
            '[' if !in_str => depth += 1,
            ']' if !in_str => depth -= 1,
            ',' if !in_str && depth == 0 => {
                out.push(&s[start..i]);
                start = i + 1;
            }
            _ => {}
        }
    }
    if in_str {
        return Err("unterminated string literal".into());
    }
    if depth != 0 {
        return Err("unbalanced brackets".into());
    }
    if !s.trim().is_empty() {
        out.push(&s[start..]);
    }
    Ok(out)
}

fn parse_arg(raw: &str, vars: &HashMap<String, ReadResult>) -> Result<Arg, String> {
    if let Some(body) = raw.strip_prefix('"') {
        let text = body
            .strip_suffix('"')
            .ok_or_else(|| format!("bad string literal {raw}"))?;
        return Ok(Arg::Str(text.as_bytes().to_vec()));
    }
    if raw.starts_with('[') || raw.starts_with("p[") {
        parse_value(raw.as_bytes()).map_err(|e| format!("bad list or pose `{raw}`: {e}"))?;
        return Ok(Arg::Bracketed(raw.to_string()));
    }
    match raw {
        "True" => return Ok(Arg::Bool(true)),
        "False" => return Ok(Arg::Bool(false)),
        _ => {}
    }
    if let Some(v) = vars.get(raw) {
        return Ok(Arg::Result(Box::new(v.clone())));
    }
    raw.parse::<f64>()
        .map(Arg::Num)
        .map_err(|_| format!("`{raw}` is not a literal or a known variable"))
}

/// Binds positional and named arguments to a function's parameter list.
struct Args {
    values: Vec<Option<Arg>>,
    names: &'static [&'static str],
}

impl Args {
    fn bind(call: &Call, names: &'static [&'static str]) -> Result<Self, String> {
        if call.positional.len() > names.len() {
            return Err(format!(
                "{} takes at most {} arguments",
                call.function,
                names.len()
            ));
        }
        let mut values: Vec<Option<Arg>> = vec![None; names.len()];
        for (slot, a) in values.iter_mut().zip(&call.positional) {
            *slot = Some(a.clone());
        }
        for (k, v) in &call.named {
            let i = names
                .iter()
                .position(|n| n == k)
                .ok_or_else(|| format!("{} has no parameter `{k}`", call.function))?;
            values[i] = Some(v.clone());
        }
        Ok(Args { values, names })
    }

    fn get(&self, i: usize) -> Option<&Arg> {
        self.values.get(i).and_then(Option::as_ref)
    }

    fn str_or(&self, i: usize, default: &str) -> Result<Vec<u8>, String> {
        match self.get(i) {
            None => Ok(default.as_bytes().to_vec()),
            Some(Arg::Str(s)) => Ok(s.clone()),
            Some(_) => Err(format!("`{}` must be a string", self.names[i])),
        }
    }

    fn name_or_default(&self, i: usize) -> Result<String, String> {
        Ok(String::from_utf8_lossy(&self.str_or(i, DEFAULT_SOCKET_NAME)?).into_owned())
    }

    fn num(&self, i: usize) -> Result<f64, String> {
        match self.get(i) {
            Some(Arg::Num(v)) => Ok(*v),
            Some(_) => Err(format!("`{}` must be a number", self.names[i])),
            None => Err(format!("missing argument `{}`", self.names[i])),
        }
    }

    fn int(&self, i: usize) -> Result<i64, String> {
        let v = self.num(i)?;
        if v.fract() != 0.0 || !(-2147483648.0..=2147483647.0).contains(&v) {
            return Err(format!("`{}` must be an int32", self.names[i]));
        }
        Ok(v as i64)
    }

    fn bool_or(&self, i: usize, default: bool) -> Result<bool, String> {
        match self.get(i) {
            None => Ok(default),
            Some(Arg::Bool(b)) => Ok(*b),
            Some(_) => Err(format!("`{}` must be True or False", self.names[i])),
        }
    }

    fn timeout(&self, i: usize) -> Result<Timeout, String> {
        match self.get(i) {
            None => Ok(Timeout::default()),
            Some(Arg::Num(s)) => Ok(Timeout::from_secs_f64(*s)),
            Some(_) => Err("`timeout` must be a number of seconds".into()),
        }
    }
}

/// What `ursock robot` prints besides each call and its result.
pub struct Options {
    /// The bytes sent and received, with relative times.
    pub trace: bool,
    /// One JSON object per line instead of text.
    pub json: bool,
}

/// What the server sent during the current read, for its diagnosis.
#[derive(Default)]
struct Received {
    bytes: Vec<u8>,
    first_at: Option<Instant>,
}

/// Per socket: a read that timed out, for the late-reply note of the next read.
struct TimedOut {
    call: ReadCall,
    line: usize,
    sent_since: bool,
}

/// Data that a read finds within this many milliseconds of its start, with no send since
/// the previous read on that socket timed out, was waiting: that read's late reply (no
/// new request could have been answered). Generous, so a loaded machine does not miss it.
const LATE_WINDOW_MS: u128 = 50;

/// Keeps the first bytes of a read's input for [`crate::diagnose::diagnose`].
const WINDOW: usize = 4096;

fn trace_event(json: bool, name: &str, dir: Direction, bytes: &[u8]) {
    let (arrow, tag) = match dir {
        Direction::RobotToServer => ("->", "tx"),
        Direction::ServerToRobot => ("<-", "rx"),
    };
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

/// Runs `script` (the text of a file or `-e` lines) against a virtual robot; `connect`
/// opens `socket_0` first. Prints each call and its result; returns an error naming the
/// line for unsupported script. As on the controller, a failed `socket_open` and a send
/// to a server that has gone return False and the program goes on; the reason is said
/// on stderr (and in `--log`).
pub fn run(script: &str, connect: Option<&str>, opts: Options) -> Result<(), String> {
    let mut robot = VirtualRobot::new(Policy::default());
    let received: Arc<Mutex<Received>> = Arc::default();
    {
        let received = Arc::clone(&received);
        let (trace, json) = (opts.trace, opts.json);
        robot.set_observer(move |name, dir, bytes| {
            if dir == Direction::ServerToRobot {
                let mut r = received.lock().unwrap_or_else(|p| p.into_inner());
                r.first_at.get_or_insert_with(Instant::now);
                let room = WINDOW.saturating_sub(r.bytes.len());
                r.bytes.extend_from_slice(&bytes[..bytes.len().min(room)]);
            }
            if trace {
                trace_event(json, name, dir, bytes);
            }
        });
    }
    let report = |line: usize,
                  shown: &str,
                  call: &str,
                  result: serde_json::Value,
                  text: &str,
                  sentinel: bool,
                  why: Option<String>| {
        if opts.json {
            let ev = crate::offline::ReadJson {
                t: Some(out::elapsed_secs()),
                line: Some(line),
                call: call.to_string(),
                result,
                sentinel,
                why,
            };
            outln!("{}", serde_json::to_string(&ev).unwrap_or_default());
        } else {
            if text.is_empty() {
                outln!("{shown}");
            } else {
                outln!("{shown} -> {text}");
            }
            if let Some(w) = why {
                out::note(&format!("line {line}: why: {w}"));
            }
        }
    };
    if let Some(addr) = connect {
        let (host, port) = split_host_port(addr)?;
        let shown = format!("socket_open(\"{host}\", {port}, \"{DEFAULT_SOCKET_NAME}\")");
        match open_or_reason(&mut robot, (host.as_str(), port), DEFAULT_SOCKET_NAME)
            .map_err(|e| e.to_string())?
        {
            Ok(()) => report(0, &shown, "socket_open", true.into(), "True", false, None),
            Err(e) => {
                let reason = open_failure(&host, port, &e);
                let why = opts.json.then(|| reason.clone());
                report(0, &shown, "socket_open", false.into(), "False", true, why);
                return Err(reason);
            }
        }
    }
    let mut vars: HashMap<String, ReadResult> = HashMap::new();
    let mut timed_out: HashMap<String, TimedOut> = HashMap::new();
    // What a read left in the socket's buffer for the next one (the LF after `)`), per
    // socket, as far as the CLI can tell from the bytes it saw.
    let mut carry: HashMap<String, Vec<u8>> = HashMap::new();
    for (n, line) in script.lines().enumerate() {
        let lineno = n + 1;
        let call = match parse_line(line, &vars).map_err(|e| format!("line {lineno}: {e}"))? {
            Some(c) => c,
            None => continue,
        };
        let shown = strip_comment(line).trim().to_string();
        *received.lock().unwrap_or_else(|p| p.into_inner()) = Received::default();
        let started = Instant::now();
        let outcome = execute(&mut robot, &call).map_err(|e| format!("line {lineno}: {e}"))?;
        let f = call.function.as_str();
        match outcome {
            Outcome::Sent => report(lineno, &shown, f, serde_json::Value::Null, "", false, None),
            Outcome::Printed(text) => {
                let result = match text.as_str() {
                    "True" => true.into(),
                    "False" => false.into(),
                    t => t.into(),
                };
                if f.starts_with("socket_send") {
                    for t in timed_out.values_mut() {
                        t.sent_since = true;
                    }
                }
                report(lineno, &shown, f, result, &text, false, None)
            }
            Outcome::Failed(reason) => {
                // In JSON the reason is the event's `why`; in text, a note on stderr.
                let why = opts.json.then(|| reason.clone());
                report(lineno, &shown, f, false.into(), "False", false, why);
                if !opts.json {
                    out::note(&format!("line {lineno}: {reason}"));
                }
            }
            Outcome::Result(r, socket, read) => {
                let mut why = None;
                let got = std::mem::take(&mut *received.lock().unwrap_or_else(|p| p.into_inner()));
                if let Some(read) = &read {
                    let mut seen = carry.remove(&socket).unwrap_or_default();
                    seen.extend_from_slice(&got.bytes);
                    let binary = matches!(
                        read,
                        ReadCall::BinaryInteger { .. } | ReadCall::ByteList { .. }
                    );
                    if binary || crate::offline::failed(read, &r) {
                        why = crate::diagnose::diagnose(read, &seen);
                    }
                    if let Some(t) = timed_out.remove(&socket) {
                        let waiting = got.first_at.is_some_and(|at| {
                            at.duration_since(started).as_millis() < LATE_WINDOW_MS
                        });
                        if waiting && !t.sent_since {
                            let late = crate::diagnose::late_reply(&t.call, t.line);
                            why = Some(match why {
                                Some(w) => format!("{late}; {w}"),
                                None => late,
                            });
                        }
                    }
                    if r.is_sentinel() {
                        timed_out.insert(
                            socket.clone(),
                            TimedOut {
                                call: read.clone(),
                                line: lineno,
                                sent_since: false,
                            },
                        );
                    } else if let Some(rest) = leftover(read, &seen) {
                        carry.insert(socket.clone(), rest.to_vec());
                    }
                }
                report(
                    lineno,
                    &shown,
                    f,
                    crate::offline::result_json(&r),
                    &crate::show::read_result(&r),
                    r.is_sentinel(),
                    why,
                );
                if let Some(t) = &call.target {
                    vars.insert(t.clone(), *r);
                }
            }
        }
    }
    Ok(())
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

enum Outcome {
    Sent,
    Printed(String),
    /// A socket_open or send that returns False on the robot, and why.
    Failed(String),
    /// A read's result, its socket name and the read call (`None` for get_var).
    Result(Box<ReadResult>, String, Option<ReadCall>),
}

fn value_text(arg: &Arg) -> Result<Vec<u8>, String> {
    let mut out = Vec::new();
    let encode = |v: &Value<'_>, out: &mut Vec<u8>| {
        urscript_socket::to_str::encode_value(v, out).map_err(|e| e.to_string())
    };
    match arg {
        Arg::Str(s) => {
            out.extend_from_slice(s);
        }
        Arg::Num(v) if v.fract() == 0.0 && v.abs() < 2147483648.0 => {
            encode(&Value::Scalar(Scalar::Int(*v as i32)), &mut out)?;
        }
        Arg::Num(v) => {
            encode(&Value::Scalar(Scalar::Float(*v)), &mut out)?;
        }
        Arg::Bool(b) => {
            encode(&Value::Scalar(Scalar::Bool(*b)), &mut out)?;
        }
        Arg::Bracketed(text) => {
            let v = parse_value(text.as_bytes()).map_err(|e| e.to_string())?;
            encode(&v, &mut out)?;
        }
        Arg::Result(r) => {
            out.extend_from_slice(r.to_urscript().as_bytes());
        }
    }
    Ok(out)
}

fn execute(robot: &mut VirtualRobot, call: &Call) -> Result<Outcome, String> {
    let e = |e: RobotError| match e {
        RobotError::Encode(x) => format!("cannot send: {}", crate::messages::encode_error(x)),
        other => other.to_string(),
    };
    let f = call.function.as_str();
    Ok(match f {
        "socket_open" => {
            let a = Args::bind(call, &["address", "port", "socket_name"])?;
            let host = String::from_utf8_lossy(&a.str_or(0, "")?).into_owned();
            let port = a.int(1)?;
            let port = u16::try_from(port).map_err(|_| "port must be 0..=65535".to_string())?;
            match open_or_reason(robot, (host.as_str(), port), &a.name_or_default(2)?).map_err(e)? {
                Ok(()) => Outcome::Printed("True".into()),
                Err(err) => Outcome::Failed(open_failure(&host, port, &err)),
            }
        }
        "socket_close" => {
            let a = Args::bind(call, &["socket_name"])?;
            robot.socket_close(&a.name_or_default(0)?);
            Outcome::Sent
        }
        "socket_send_string" | "socket_send_line" => {
            let a = Args::bind(call, &["str", "socket_name"])?;
            let text = value_text(a.get(0).ok_or("missing argument `str`")?)?;
            let name = a.name_or_default(1)?;
            sent(f, if f == "socket_send_line" {
                robot.socket_send_line(&text, &name)
            } else {
                robot.socket_send_string(&text, &name)
            })?
        }
        "socket_send_byte" => {
            let a = Args::bind(call, &["value", "socket_name"])?;
            let v = u8::try_from(a.int(0)?).map_err(|_| "`value` must be 0..=255".to_string())?;
            sent(f, robot.socket_send_byte(v, &a.name_or_default(1)?))?
        }
        "socket_send_int" => {
            let a = Args::bind(call, &["value", "socket_name"])?;
            sent(f, robot.socket_send_int(a.int(0)? as i32, &a.name_or_default(1)?))?
        }
        "socket_set_var" => {
            let a = Args::bind(call, &["name", "value", "socket_name"])?;
            let name = String::from_utf8_lossy(&a.str_or(0, "")?).into_owned();
            match sent(f, robot.socket_set_var(&name, a.int(1)? as i32, &a.name_or_default(2)?))? {
                Outcome::Printed(_) => Outcome::Sent,
                other => other,
            }
        }
        "socket_get_var" => {
            let a = Args::bind(call, &["name", "socket_name"])?;
            let name = String::from_utf8_lossy(&a.str_or(0, "")?).into_owned();
            let socket = a.name_or_default(1)?;
            let v = robot.socket_get_var(&name, &socket).map_err(e)?;
            Outcome::Result(Box::new(ReadResult::Int(v)), socket, None)
        }
        "socket_read_ascii_float" | "socket_read_binary_integer" | "socket_read_byte_list" => {
            let a = Args::bind(call, &["number", "socket_name", "timeout"])?;
            let number = usize::try_from(a.int(0)?).unwrap_or(0);
            let read = match f {
                "socket_read_ascii_float" => ReadCall::AsciiFloat { number },
                "socket_read_binary_integer" => ReadCall::BinaryInteger { number },
                _ => ReadCall::ByteList { number },
            };
            let socket = a.name_or_default(1)?;
            let r = robot.read(read.clone(), &socket, a.timeout(2)?).map_err(e)?;
            Outcome::Result(Box::new(r), socket, Some(read))
        }
        "socket_read_line" => {
            let a = Args::bind(call, &["socket_name", "timeout"])?;
            let socket = a.name_or_default(0)?;
            let r = robot.read(ReadCall::Line, &socket, a.timeout(1)?).map_err(e)?;
            Outcome::Result(Box::new(r), socket, Some(ReadCall::Line))
        }
        "socket_read_string" => {
            let a = Args::bind(call, &["socket_name", "prefix", "suffix", "interpret_escape", "timeout"])?;
            let read = ReadCall::String {
                prefix: a.str_or(1, "")?,
                suffix: a.str_or(2, "")?,
                interpret_escape: a.bool_or(3, false)?,
            };
            let socket = a.name_or_default(0)?;
            let r = robot.read(read.clone(), &socket, a.timeout(4)?).map_err(e)?;
            Outcome::Result(Box::new(r), socket, Some(read))
        }
        "sleep" => {
            let a = Args::bind(call, &["t"])?;
            let t = a.num(0)?;
            if !(0.0..=3600.0).contains(&t) {
                return Err("sleep takes 0 to 3600 seconds".into());
            }
            std::thread::sleep(Duration::from_secs_f64(t));
            Outcome::Sent
        }
        "textmsg" => {
            let mut text = Vec::new();
            for arg in &call.positional {
                text.extend(value_text(arg)?);
            }
            Outcome::Printed(String::from_utf8_lossy(&text).into_owned())
        }
        other => {
            return Err(format!(
                "unsupported call `{other}` (supported: socket_open, socket_close, socket_send_string, \
                 socket_send_line, socket_send_byte, socket_send_int, socket_set_var, socket_get_var, \
                 socket_read_ascii_float, socket_read_binary_integer, socket_read_byte_list, \
                 socket_read_line, socket_read_string, sleep, textmsg)"
            ))
        }
    })
}

/// A send's outcome as the robot program sees it: True, or False with the reason when
/// the connection failed (the server closed it, a reset...). Misuse stays an error.
fn sent(function: &str, r: Result<bool, RobotError>) -> Result<Outcome, String> {
    match r {
        Ok(true) => Ok(Outcome::Printed("True".into())),
        Ok(false) => Ok(Outcome::Failed(format!(
            "{function}: the connection is broken (a write failed); the server has probably closed it"
        ))),
        Err(RobotError::Io(e)) => Ok(Outcome::Failed(format!(
            "{function}: the connection failed ({e}); the server has probably closed it"
        ))),
        Err(e) => Err(e.to_string()),
    }
}

/// `socket_open` with the operating system's reason when it returns False.
fn open_or_reason(
    robot: &mut VirtualRobot,
    address: (&str, u16),
    socket_name: &str,
) -> Result<Result<(), std::io::Error>, RobotError> {
    if robot.socket_open(address, socket_name)? {
        return Ok(Ok(()));
    }
    Ok(Err(match robot.last_open_error() {
        Some(e) => std::io::Error::new(e.kind(), e.to_string()),
        None => std::io::Error::other("connection failed"),
    }))
}
