//! `ursock robot`: a virtual robot running a URScript program against real servers.
//!
//! The program (a `--script` file or `-e` lines) is run by `urscript-interp`: parsed and
//! compiled whole first (an error names line and column, and nothing is sent), then run
//! in real time by the interpreter's one driver ([`Driver`]). This module only watches:
//! it turns the machine's typed events ([`CallRecord`], [`Message`]) and the driver's
//! activity (bytes per socket, closed peers, failed writes) into [`report`] events,
//! printed for people or as JSON lines, and adds the read-failure diagnosis of
//! [`crate::diagnose`] from the bytes each socket received.
//!
//! The old one-call-per-line scripts are URScript statements and run unchanged.

use std::collections::HashMap;
use std::time::Duration;

use urscript_interp::drive::{self, Activity, Driver};
use urscript_interp::{
    CallRecord, Config, Event, Machine, Message, MessageKind, Outcome, Program, Stub,
};
use urscript_socket::robot::{ReadCall, ReadResult, DEFAULT_SOCKET_NAME};

use crate::out;
use crate::report;

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
    /// The arm (its kinematics).
    pub model: urscript_interp::kinematics::Model,
    /// Functions replaced by a no-op or a value.
    pub stubs: Vec<(String, Stub)>,
    /// URCap preambles run before the program (`--preamble FILE`).
    pub preamble: urscript_interp::Preamble,
    /// The arm at the start: its joints and what it senses (`--set NAME=VALUE`).
    pub arm: urscript_interp::Arm,
    /// What else fails the run (`--fail-on`).
    pub fail_on: FailOn,
    /// Virtual time while no connection is open (`--virtual-time`).
    pub virtual_time: bool,
}

/// What makes `ursock robot` exit 1 besides a compile or runtime error and a protective
/// stop, which always do (`--fail-on halt,error-popup,popup`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FailOn {
    /// The program ran `halt`.
    pub halt: bool,
    /// The program showed a popup with `error=True`.
    pub error_popup: bool,
    /// The program showed any popup.
    pub popup: bool,
}

impl FailOn {
    /// The union of `--fail-on` values: comma-separated `halt`, `error-popup`, `popup`,
    /// `protective-stop` (always on; accepted to say so).
    pub fn parse(args: &[String]) -> Result<Self, String> {
        let mut f = FailOn::default();
        for word in args.iter().flat_map(|a| a.split(',')).map(str::trim) {
            match word {
                "halt" => f.halt = true,
                "error-popup" => f.error_popup = true,
                "popup" => f.popup = true,
                "protective-stop" | "error" => {}
                other => {
                    return Err(format!(
                        "--fail-on {other:?}: give halt, error-popup, popup or protective-stop (comma-separated)"
                    ))
                }
            }
        }
        Ok(f)
    }
}

/// A runtime error's message for people, and the controller's code in front of it if it
/// has one: `compile_error_name_not_found:x: text` is (`compile_error_name_not_found`,
/// `text`).
pub(crate) fn split_code(message: &str) -> (Option<String>, String) {
    let Some((code, rest)) = message.split_once(':') else {
        return (None, message.to_string());
    };
    let is_code = code.contains('_')
        && code
            .bytes()
            .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'_');
    if !is_code {
        return (None, message.to_string());
    }
    // `compile_error_name_not_found:NAME: ...`: the name is in the text too.
    let rest = match rest.split_once(':') {
        Some((name, text))
            if !name.is_empty() && name.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'_') =>
        {
            text
        }
        _ => rest,
    };
    (Some(code.to_string()), rest.trim_start().to_string())
}

/// The URCap preambles of `--preamble FILE...`, in order; an error names the file and
/// the line and column.
pub fn read_preambles(paths: &[std::path::PathBuf]) -> Result<urscript_interp::Preamble, String> {
    let mut preamble = urscript_interp::Preamble::default();
    for path in paths {
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("--preamble {}: {e}", path.display()))?;
        preamble
            .add(&text)
            .map_err(|e| format!("--preamble {}: {e}", path.display()))?;
    }
    Ok(preamble)
}

/// The arm of `--set NAME=VALUE...`: its joints (`q`) and its world (`None` for `--set
/// help`, after printing the names).
pub fn arm_from_settings(settings: &[String]) -> Result<Option<urscript_interp::Arm>, String> {
    if settings.iter().any(|s| s == "help") {
        let names = urscript_interp::ARM_SETTINGS
            .iter()
            .chain(urscript_interp::WORLD_SETTINGS);
        for (name, what) in names {
            out::line(&format!("{name:18} {what}"));
        }
        return Ok(None);
    }
    let mut arm = urscript_interp::Arm::default();
    for s in settings {
        arm.set(s).map_err(|e| format!("--set {e}"))?;
    }
    Ok(Some(arm))
}

/// How long a `socket_open` may take to connect before it returns False.
const CONNECT_TIMEOUT: Duration = Duration::from_secs(2);

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

/// What the CLI remembers of one socket, for the diagnosis of its reads: the previous
/// read on it timed out (its call, its line, and whether the program sent since).
#[derive(Default)]
struct Seen {
    timed_out: Option<(ReadCall, u32, bool)>,
}

/// Control characters made visible (`\r`, `\n`, `\t`, `\xHH`), as the robot's strings
/// are shown elsewhere in `ursock`.
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

/// Where a run's events go: every event to a caller's function (`ursock listen --robot`
/// shows them among its own).
pub type Sink = Box<dyn FnMut(report::Event) + Send>;

/// The printer: every event goes through [`Printer::emit`], as JSON or for people, or to
/// a [`Sink`].
struct Printer {
    json: bool,
    sink: Option<Sink>,
    /// The last note said for each line: a polling loop says it once until it changes.
    last_why: HashMap<u32, String>,
}

impl Printer {
    /// Every event is wanted (JSON lines, or a sink), not only the lines people read.
    fn all(&self) -> bool {
        self.json || self.sink.is_some()
    }

    fn emit(&mut self, event: report::Event) {
        if let Some(sink) = &mut self.sink {
            sink(event);
            return;
        }
        if self.json {
            outln!("{}", event.to_json());
            return;
        }
        match &event {
            report::Event::Call(c) => {
                let shown = visible(&c.source);
                match &c.shown_result {
                    None => outln!("{shown}"),
                    Some(r) => outln!("{shown} -> {}", visible(r)),
                }
                // A loop polling with a timeout would repeat the same note at every turn:
                // a note is said again only when it changes.
                match &c.note {
                    Some(w) if self.last_why.get(&c.line) == Some(w) => {}
                    Some(w) => {
                        self.last_why.insert(c.line, w.clone());
                        out::note(&format!("line {}: {w}", c.line));
                    }
                    None => {
                        self.last_why.remove(&c.line);
                    }
                }
            }
            report::Event::Message(m) => outln!("{} -> {}", visible(&m.source), visible(&m.text)),
            report::Event::Tx(t) | report::Event::Rx(t) => {
                let (arrow, name) = match &event {
                    report::Event::Tx(_) => ("->", t.socket.as_deref().unwrap_or("")),
                    _ => ("<-", t.socket.as_deref().unwrap_or("")),
                };
                outln!(
                    "    {} {name} {arrow} {}",
                    out::stamp(),
                    crate::show::text_and_hex(&t.bytes.0, "        ")
                );
            }
            report::Event::Note(n) => out::note(&n.text),
            report::Event::MoveEnd(m) => outln!("{}", move_end_line(m)),
            report::Event::Output(o) => outln!("{}", output_line(o)),
            _ => {}
        }
    }
}

/// A move's end for people: `line 3: movel -> p[...]: reached in 1.2 s`, with the
/// sample count of a stream (` x250`) and where the arm stopped if it did not arrive.
pub(crate) fn move_end_line(m: &report::MoveEnd) -> String {
    let mut line = format!("line {}: {}", m.line, m.function);
    if m.samples > 1 {
        line.push_str(&format!(" x{}", m.samples));
    }
    // A stream's first target says little: where it ended is shown instead.
    let stream = m.samples > 1;
    if let Some(target) = m.target.as_ref().filter(|_| !stream) {
        line.push_str(&format!(" -> {target}"));
    }
    line.push_str(&format!(
        ": {} in {} s",
        m.outcome.replace('_', " "),
        short(m.took)
    ));
    if stream || m.target.is_none() || !matches!(m.outcome.as_str(), "reached" | "blended") {
        line.push_str(&format!(" at {}", six("", &m.joints)));
    }
    line
}

/// A move's start for people: `line 3: movel -> p[...] starts (v 0.25, a 1.2)`, with
/// the time argument (`t 2 s`) and blend radius (`r 0.05`) when given, the speeds of a
/// speed stream in place of a target.
pub(crate) fn move_start_line(m: &report::MoveStart) -> String {
    let target = target_text(&m.function, m.target_joints, m.target_pose, m.speed);
    let mut line = format!("line {}: {}", m.line, m.function);
    if let Some(target) = target {
        line.push_str(&format!(" -> {target}"));
    }
    let mut args = vec![
        format!("v {}", short(m.velocity)),
        format!("a {}", short(m.acceleration)),
    ];
    if m.time > 0.0 {
        args.push(format!("t {} s", short(m.time)));
    }
    if m.blend_radius > 0.0 {
        args.push(format!("r {}", short(m.blend_radius)));
    }
    line.push_str(&format!(" starts ({})", args.join(", ")));
    line
}

/// An output change for people: `line 4: set_standard_digital_out(1, True)`.
pub(crate) fn output_line(o: &report::Output) -> String {
    format!("line {}: {}({}, {})", o.line, o.function, o.pin, o.value)
}

/// A number for people: at most 4 decimals, no trailing zeros (`1.5`, `0.0003`, `2`).
fn short(x: f64) -> String {
    let s = format!("{x:.4}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".into()
    } else {
        s.into()
    }
}

/// Six numbers as URScript writes them: `[a, b, ...]`, `p[...]` with `prefix` "p".
fn six(prefix: &str, v: &[f64; 6]) -> String {
    let parts: Vec<String> = v.iter().map(|x| short(*x)).collect();
    format!("{prefix}[{}]", parts.join(", "))
}

/// A move's start as a report event.
pub(crate) fn move_start_event(s: &urscript_interp::MoveStart) -> report::MoveStart {
    report::MoveStart {
        t: report::now(),
        at: s.at.as_secs_f64(),
        line: s.line,
        function: s.function.to_string(),
        target_joints: s.target_q,
        target_pose: s.target_pose,
        speed: s.speed,
        acceleration: s.a,
        velocity: s.v,
        time: s.t,
        blend_radius: s.r,
    }
}

/// A move's target for people: the pose of a tool move, the joints of a joint move,
/// the speeds of a speed stream.
pub(crate) fn move_target(s: &urscript_interp::MoveStart) -> Option<String> {
    target_text(s.function, s.target_q, s.target_pose, s.speed)
}

/// [`move_target`] from a move's function and targets.
fn target_text(
    function: &str,
    q: Option<[f64; 6]>,
    pose: Option<[f64; 6]>,
    speed: Option<[f64; 6]>,
) -> Option<String> {
    let tool = !matches!(function, "movej" | "optimovej" | "servoj" | "speedj");
    match (q, pose, speed) {
        (_, Some(p), _) if tool => Some(six("p", &p)),
        (Some(q), _, _) => Some(six("", &q)),
        (_, _, Some(v)) => Some(format!("speed {}", six("", &v))),
        _ => None,
    }
}

/// A move's end as a report event (`target`: [`move_target`] of its start).
pub(crate) fn move_end_event(
    e: &urscript_interp::MoveEnd,
    target: Option<String>,
) -> report::MoveEnd {
    report::MoveEnd {
        t: report::now(),
        at: e.at.as_secs_f64(),
        line: e.line,
        function: e.function.to_string(),
        outcome: e.outcome.as_str().replace('-', "_"),
        took: e.took.as_secs_f64(),
        samples: e.samples,
        joints: e.q,
        pose: e.pose,
        target,
    }
}

/// An output change as a report event.
pub(crate) fn output_event(o: &urscript_interp::OutputWrite) -> report::Output {
    report::Output {
        t: report::now(),
        line: o.line,
        function: o.function.to_string(),
        pin: o.pin,
        value: match o.value {
            urscript_interp::OutputValue::Digital(b) => report::Value::Bool(b),
            urscript_interp::OutputValue::Analog(x) => report::Value::Float(x),
        },
    }
}

/// A call record as a report event: the call as URScript (with `x = ` when the
/// statement assigns it), the typed result, and why it failed (`diagnosis`: what the
/// read's bytes show; else the machine's reason for a `False`).
pub(crate) fn call_event(c: &CallRecord, diagnosis: Option<String>) -> report::Call {
    let source = match &c.assigned_to {
        Some(target) => format!("{target} = {}", c.source()),
        None => c.source(),
    };
    let result = match &c.read {
        Some(r) => report::Value::from(&r.result),
        None => report::Value::from_interp(&c.result),
    };
    let sentinel = c
        .read
        .as_ref()
        .is_some_and(|r| failed_read(&r.call, &r.result));
    let (outcome, suffix) = match &c.outcome {
        Outcome::Returned => (report::CallOutcome::Returned, ""),
        Outcome::TimedOut => (report::CallOutcome::TimedOut, " (timeout)"),
        Outcome::Stubbed => (report::CallOutcome::Stubbed, " (stub)"),
        Outcome::Failed(_) => (report::CallOutcome::Failed, ""),
        _ => (report::CallOutcome::Returned, ""),
    };
    let failure = match &c.outcome {
        Outcome::Failed(w) if w.starts_with(&c.name) => Some(w.clone()),
        Outcome::Failed(w) => Some(format!("{}: {w}", c.name)),
        _ => None,
    };
    let note = match &diagnosis {
        Some(d) => Some(format!("why: {d}")),
        None => failure.clone(),
    };
    let shown_result = match &c.result {
        urscript_interp::Value::None if c.outcome != Outcome::Stubbed => None,
        v => Some(format!("{v}{suffix}")),
    };
    report::Call {
        t: report::now(),
        line: c.line,
        column: c.column,
        call: c.name.clone(),
        source,
        socket: c.socket.clone(),
        args: c
            .args
            .iter()
            .chain(c.kwargs.iter().map(|(_, v)| v))
            .map(report::Value::from_interp)
            .collect(),
        result,
        outcome,
        sentinel,
        note: note.clone(),
        why: diagnosis.or(failure),
        shown_result,
    }
}

/// A read's result is its sentinel, or (floats) fewer values than asked.
fn failed_read(call: &ReadCall, result: &ReadResult) -> bool {
    match (call, result) {
        (ReadCall::AsciiFloat { number }, ReadResult::Floats(t)) => t.count() < *number,
        (ReadCall::GetVar { .. }, _) => false,
        _ => result.is_sentinel(),
    }
}

/// The diagnosis of a read that ended, from what it saw (its record's input): why it
/// failed, and whether it found the late reply of the previous read on its socket.
fn diagnose_read(c: &CallRecord, seen: &mut Seen) -> Option<String> {
    let read = c.read.as_ref()?;
    if matches!(read.call, ReadCall::GetVar { .. }) || matches!(c.outcome, Outcome::Failed(_)) {
        // A variable's reply is not a read's input; a socket that is not open has its
        // reason already.
        return None;
    }
    let failed = failed_read(&read.call, &read.result);
    let binary = matches!(
        read.call,
        ReadCall::BinaryInteger { .. } | ReadCall::ByteList { .. }
    );
    let mut why = if binary || failed {
        crate::diagnose::diagnose(&read.call, &read.input)
    } else {
        None
    };
    // Data already waiting when this read started, with nothing sent since the previous
    // read timed out: the previous read's late reply.
    if let Some((prev, prev_line, sent_since)) = seen.timed_out.take() {
        if read.buffered_at_start > 0 && !sent_since {
            let late = crate::diagnose::late_reply(&prev, prev_line as usize);
            why = Some(match why {
                Some(w) => format!("{late}; {w}"),
                None => late,
            });
        }
    }
    if c.outcome == Outcome::TimedOut || failed {
        seen.timed_out = Some((read.call.clone(), c.line, false));
    }
    why
}

/// A message as a report event, with the call that showed it.
pub(crate) fn message_event(m: &Message) -> report::Event {
    let (kind, name) = match m.kind {
        MessageKind::Textmsg => (report::MessageKind::Textmsg, "textmsg"),
        MessageKind::Varmsg => (report::MessageKind::Varmsg, "varmsg"),
        MessageKind::BlendRadiusReduced { .. } => (report::MessageKind::Warning, "warning"),
        _ => (report::MessageKind::Popup, "popup"),
    };
    let args: Vec<String> = m.args.iter().map(|v| v.to_source()).collect();
    report::Event::message(
        m.line,
        kind,
        m.text.clone(),
        format!("{name}({})", args.join(", ")),
    )
}

/// Runs `script` (the text of a file or `-e` lines) as a URScript program against real
/// servers; `connect` opens `socket_0` first. Prints each socket call and its result and
/// the program's messages. As on the controller, a failed `socket_open` and a send to a
/// server that has gone return False and the program goes on; the reason is said on
/// stderr (and in `--log`). A compile error (nothing sent) or a runtime error is the
/// `Err`, naming the line.
pub fn run(script: &str, connect_to: Option<&str>, opts: Options) -> Result<(), String> {
    let printer = Printer {
        json: opts.json,
        sink: None,
        last_why: HashMap::new(),
    };
    run_with(script, connect_to, opts, printer)
}

/// [`run`], every event given to `sink` (those `--json` prints, `move_start` included)
/// instead of printed.
pub fn run_into(
    script: &str,
    connect_to: Option<&str>,
    opts: Options,
    sink: Sink,
) -> Result<(), String> {
    let printer = Printer {
        json: false,
        sink: Some(sink),
        last_why: HashMap::new(),
    };
    run_with(script, connect_to, opts, printer)
}

fn run_with(
    script: &str,
    connect_to: Option<&str>,
    opts: Options,
    mut printer: Printer,
) -> Result<(), String> {
    let all = printer.all();
    let program = match Program::parse_with_preamble(&opts.preamble, script) {
        Ok(p) => p,
        Err(e) => {
            // As docs/json-events.md says: a compile error is an `error` event (with
            // its line and column) and the `end`, nothing else.
            if all {
                printer.emit(report::Event::error(
                    Some(e.line()),
                    Some(e.column()),
                    e.message(),
                ));
                printer.emit(report::Event::end(report::EndOutcome::Error));
            }
            return Err(e.to_string());
        }
    };
    let config = Config {
        step_time: opts.step_time,
        model: opts.model,
        stubs: opts.stubs.clone(),
        trace_socket_calls: true,
        trace_all_calls: false,
        ..Config::default()
    };
    let mut machine = Machine::with_arm(program, config, opts.arm.clone());
    let mut driver = Driver::new(drive::Options {
        max_time: opts.max_time,
        connect_timeout: CONNECT_TIMEOUT,
        virtual_time: opts.virtual_time,
        ..drive::Options::default()
    });
    if let Some(addr) = connect_to {
        let (host, port) = split_host_port(addr)?;
        let opened = driver.connect(&mut machine, DEFAULT_SOCKET_NAME, &host, port);
        printer.emit(report::Event::Call(report::Call {
            t: report::now(),
            line: 0,
            column: 0,
            call: "socket_open".into(),
            source: format!("socket_open(\"{host}\", {port}, \"{DEFAULT_SOCKET_NAME}\")"),
            socket: Some(DEFAULT_SOCKET_NAME.into()),
            args: vec![
                report::Value::String(host.clone().into_bytes()),
                report::Value::Int(port.into()),
                report::Value::String(DEFAULT_SOCKET_NAME.as_bytes().to_vec()),
            ],
            result: report::Value::Bool(opened.is_ok()),
            outcome: if opened.is_ok() {
                report::CallOutcome::Returned
            } else {
                report::CallOutcome::Failed
            },
            sentinel: false,
            why: opened.as_ref().err().cloned(),
            note: None,
            shown_result: Some(if opened.is_ok() { "True" } else { "False" }.into()),
        }));
        opened?;
    }
    let mut seen: HashMap<String, Seen> = HashMap::new();
    let trace = opts.trace;
    // The target of the move under way, for its end's line.
    let mut target: Option<String> = None;
    // The first popup that fails the run (`--fail-on`).
    let mut failing_popup: Option<(u32, String)> = None;
    let result = driver.run(&mut machine, |activity| match activity {
        Activity::Event(Event::Call(c)) => {
            let why = c
                .socket
                .as_ref()
                .and_then(|s| diagnose_read(c, seen.entry(s.clone()).or_default()));
            printer.emit(report::Event::Call(call_event(c, why)));
        }
        Activity::Event(Event::Message(m)) => {
            if let MessageKind::Popup { error, title, .. } = &m.kind {
                if failing_popup.is_none()
                    && (opts.fail_on.popup || (*error && opts.fail_on.error_popup))
                {
                    let what = if *error { "an error popup" } else { "a popup" };
                    failing_popup = Some((
                        m.line,
                        format!(
                            "the program showed {what} {title:?}: {} (--fail-on)",
                            m.text
                        ),
                    ));
                }
            }
            printer.emit(message_event(m));
        }
        Activity::Event(Event::MoveStart(s)) => {
            target = move_target(s);
            if all {
                printer.emit(report::Event::MoveStart(move_start_event(s)));
            }
        }
        Activity::Event(Event::MoveEnd(e)) => {
            printer.emit(report::Event::MoveEnd(move_end_event(e, target.take())));
        }
        Activity::Event(Event::Output(o)) => {
            printer.emit(report::Event::Output(output_event(o)));
        }
        Activity::Event(Event::Transmit { socket_name, bytes }) => {
            if let Some(t) = seen.get_mut(socket_name).and_then(|s| s.timed_out.as_mut()) {
                t.2 = true;
            }
            if trace {
                printer.emit(report::Event::tx(socket_name, bytes));
            }
        }
        Activity::Event(Event::Connect { socket_name, .. }) => {
            // A new connection: nothing seen on it yet.
            seen.remove(socket_name);
        }
        Activity::Received { socket_name, bytes } if trace => {
            printer.emit(report::Event::rx(socket_name, bytes));
        }
        Activity::PeerClosed { socket_name } if all => {
            printer.emit(report::Event::peer_closed(socket_name));
        }
        _ => {}
    });
    let arm = {
        let a = machine.arm();
        report::ArmState {
            joints: a.q,
            pose: urscript_interp::kinematics::forward(&opts.model.dh(), a.q, a.tcp),
            digital_out: a.digital_out[..16].to_vec(),
            tool_out: a.tool_out,
            analog_out: a
                .analog_out
                .iter()
                .map(|x| report::Value::Float(*x))
                .collect(),
        }
    };
    let end = |outcome| {
        report::Event::End(report::End {
            t: report::now(),
            outcome,
            arm: Some(arm.clone()),
        })
    };
    match result {
        Ok(drive::Outcome::MaxTime) => {
            printer.emit(report::Event::note(format!(
                "--max-time {}s reached: the program was ended",
                opts.max_time.unwrap_or_default().as_secs_f64()
            )));
            if all {
                printer.emit(end(report::EndOutcome::MaxTime));
            }
            Ok(())
        }
        Ok(drive::Outcome::ProtectiveStop) => {
            let why = "protective stop: the arm stopped (a move's path left the arm's reach, or protective_stop() ran); a controller pauses the program here until an operator resumes it";
            if all {
                printer.emit(report::Event::error(None, None, why));
                printer.emit(end(report::EndOutcome::ProtectiveStop));
            }
            Err(why.into())
        }
        Ok(o) => {
            let halted = o == drive::Outcome::Halted;
            let failure = match failing_popup {
                Some((line, why)) => Some((Some(line), why)),
                None if halted && opts.fail_on.halt => {
                    Some((None, "the program halted (--fail-on halt)".to_string()))
                }
                None => None,
            };
            if all {
                if let Some((line, why)) = &failure {
                    printer.emit(report::Event::error(*line, None, why.clone()));
                }
                printer.emit(end(if halted {
                    report::EndOutcome::Halted
                } else {
                    report::EndOutcome::Finished
                }));
            }
            match failure {
                Some((Some(line), why)) => Err(format!("line {line}: {why}")),
                Some((None, why)) => Err(why),
                None => Ok(()),
            }
        }
        Err(e) => {
            let (code, text) = split_code(e.message());
            if all {
                let mut event =
                    report::Event::error(Some(e.line()), Some(e.column()), text.clone());
                if let report::Event::Error(err) = &mut event {
                    err.code = code;
                }
                printer.emit(event);
                printer.emit(end(report::EndOutcome::Error));
            }
            Err(if e.line() > 0 {
                format!("line {}: {text}", e.line())
            } else {
                text
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn control_characters_are_shown_escaped() {
        assert_eq!(visible("\"TRG\r\""), "\"TRG\\r\"");
        assert_eq!(visible("a\u{1}"), "a\\x01");
    }

    #[test]
    fn a_read_fails_on_its_sentinel_or_on_fewer_floats_than_asked() {
        let floats = |s: &[u8]| {
            let mut r = urscript_socket::robot::SocketConnection::new("s", Default::default());
            r.receive(s);
            r.start_read(
                ReadCall::AsciiFloat { number: 2 },
                urscript_socket::robot::Timeout::Forever,
                Duration::ZERO,
            )
            .unwrap();
            r.poll_read().unwrap()
        };
        let two = ReadCall::AsciiFloat { number: 2 };
        assert!(!failed_read(&two, &floats(b"(1,2)")));
        assert!(failed_read(&two, &floats(b"(1)")));
        assert!(failed_read(&ReadCall::Line, &ReadCall::Line.sentinel()));
        assert!(!failed_read(
            &ReadCall::GetVar { name: "X".into() },
            &ReadResult::Int(0)
        ));
    }
}
