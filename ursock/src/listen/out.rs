//! Where `listen` says things: stdout (text or one JSON event per line), stderr for
//! problems, and the `--log FILE` copy of the whole session.
//!
//! A closed stdout (`ursock listen | head`) ends the program quietly, as Unix tools do:
//! nothing here panics on a failed write.

use std::collections::{BTreeMap, VecDeque};
use std::fs::File;
use std::io::{BufWriter, ErrorKind, Write};
use std::sync::Mutex;

use crate::report::{EndOutcome, Event};

/// How a line is routed.
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// Traffic and decodes: stdout (left out with `--quiet`).
    Traffic,
    /// Connects, closes, notes: stdout.
    Note,
    /// Problems: stderr (and the JSON stream with `--json`).
    Warn,
}

/// What the terminal UI shows: each connection's lines (its scrollback) and the general
/// ones, bounded.
#[derive(Default)]
pub struct Screen {
    pub per_conn: BTreeMap<u64, Scrollback>,
    pub general: VecDeque<String>,
}

/// One connection's lines: the newest [`SCREEN_LINES`] lines and at most
/// [`SCREEN_BYTES`] bytes of them (older ones are dropped first), and how many were
/// ever added, so a view scrolled back can say how many arrived below it.
#[derive(Default)]
pub struct Scrollback {
    pub lines: VecDeque<String>,
    bytes: usize,
    /// Lines ever added; the line `lines[i]` is number `total - lines.len() + i`.
    pub total: u64,
}

impl Scrollback {
    pub(crate) fn push(&mut self, line: String) {
        while !self.lines.is_empty()
            && (self.lines.len() >= SCREEN_LINES || self.bytes + line.len() > SCREEN_BYTES)
        {
            if let Some(old) = self.lines.pop_front() {
                self.bytes -= old.len();
            }
        }
        self.bytes += line.len();
        self.lines.push_back(line);
        self.total += 1;
    }

    /// The number of the oldest line still kept.
    pub fn first(&self) -> u64 {
        self.total - self.lines.len() as u64
    }
}

/// Scrollback per connection: lines kept, and bytes kept (whichever bound is hit first
/// drops the oldest lines); general (status) lines kept; connections whose lines are
/// kept (the lowest-numbered go first). At most 256 × 256 KiB = 64 MiB of lines.
pub const SCREEN_LINES: usize = 2000;
pub const SCREEN_BYTES: usize = 256 * 1024;
const SCREEN_GENERAL: usize = 200;
const SCREEN_CONNS: usize = 256;

impl Screen {
    fn push(&mut self, conn: Option<u64>, line: String, general: bool) {
        if let Some(id) = conn {
            if !self.per_conn.contains_key(&id) && self.per_conn.len() >= SCREEN_CONNS {
                let oldest = self.per_conn.keys().next().copied();
                if let Some(o) = oldest {
                    self.per_conn.remove(&o);
                }
            }
            let q = self.per_conn.entry(id).or_default();
            for l in line.lines() {
                q.push(l.to_string());
            }
        }
        if general || conn.is_none() {
            let prefix = conn.map(|id| format!("[#{id}] ")).unwrap_or_default();
            for l in line.lines() {
                if self.general.len() >= SCREEN_GENERAL {
                    self.general.pop_front();
                }
                self.general.push_back(format!("{prefix}{l}"));
            }
        }
    }
}

#[cfg(test)]
mod screen_tests {
    use super::*;

    #[test]
    fn scrollback_keeps_the_newest_lines_within_both_bounds() {
        let mut s = Scrollback::default();
        for i in 0..SCREEN_LINES + 5 {
            s.push(format!("{i}"));
        }
        assert_eq!(s.lines.len(), SCREEN_LINES);
        assert_eq!(s.total, (SCREEN_LINES + 5) as u64);
        assert_eq!(s.first(), 5);
        assert_eq!(s.lines.front().map(String::as_str), Some("5"));
        let big = "x".repeat(SCREEN_BYTES / 3);
        for _ in 0..4 {
            s.push(big.clone());
        }
        assert_eq!(s.lines.len(), 3, "three fit in the byte bound");
        assert!(s.bytes <= SCREEN_BYTES);
        // A line larger than the whole bound is still kept, alone.
        s.push("y".repeat(SCREEN_BYTES + 1));
        assert_eq!(s.lines.len(), 1);
        assert_eq!(s.first() + 1, s.total);
    }
}

/// How wall-clock times are written: the system's local time zone (the default: `TZ`,
/// else `/etc/localtime`, read by `jiff`), or UTC (`--utc`).
#[derive(Clone, Debug)]
pub enum Clock {
    Local(jiff::tz::TimeZone),
    Utc,
}

impl Clock {
    /// The local zone, or UTC when asked (or when the system's zone cannot be read: then
    /// the stamps end in `Z`, so they never claim an offset that was not known).
    pub fn new(utc: bool) -> Clock {
        if utc {
            return Clock::Utc;
        }
        match jiff::tz::TimeZone::try_system() {
            Ok(tz) => Clock::Local(tz),
            Err(_) => Clock::Utc,
        }
    }

    /// RFC 3339 with milliseconds: `2026-11-23T22:40:01.123+01:00` in local time,
    /// `2026-11-23T21:40:01.123Z` in UTC.
    pub fn rfc3339(&self, at: jiff::Timestamp) -> String {
        match self {
            Clock::Local(tz) => format!("{:.3}", at.display_with_offset(tz.to_offset(at))),
            Clock::Utc => format!("{at:.3}"),
        }
    }

    /// The time of day, `HH:MM:SS.mmm`, in the same zone as [`Clock::rfc3339`].
    pub fn time_of_day(&self, at: jiff::Timestamp) -> String {
        let offset = match self {
            Clock::Local(tz) => tz.to_offset(at),
            Clock::Utc => jiff::tz::Offset::UTC,
        };
        offset.to_datetime(at).strftime("%H:%M:%S%.3f").to_string()
    }
}

pub struct Out {
    /// The zone of the wall-clock times (`--utc`).
    pub clock: Clock,
    /// With `--tui`: lines go to the screen, not to stdout/stderr.
    pub screen: Option<Mutex<Screen>>,
    json: bool,
    quiet: bool,
    /// Bytes of one chunk shown in its hex dump (`--show-max`).
    show_max: usize,
    has_log: bool,
    log: Mutex<Option<BufWriter<File>>>,
    /// Serialises stdout writes so lines from several connections never interleave.
    stdout: Mutex<()>,
}

impl Out {
    pub fn new(json: bool, quiet: bool, log: Option<File>, tui: bool, show_max: usize) -> Self {
        Out {
            clock: Clock::new(false),
            show_max,
            screen: tui.then(|| Mutex::new(Screen::default())),
            json,
            quiet,
            has_log: log.is_some(),
            log: Mutex::new(log.map(BufWriter::new)),
            stdout: Mutex::new(()),
        }
    }

    /// Wall-clock times in UTC (`--utc`) instead of the local zone.
    pub fn with_utc(mut self, utc: bool) -> Self {
        self.clock = Clock::new(utc);
        self
    }

    /// Whether traffic lines go anywhere (`--quiet` without `--log` drops them): callers
    /// skip formatting hex dumps nobody will see.
    pub fn traffic_wanted(&self) -> bool {
        !self.quiet || self.screen.is_some() || self.has_log
    }

    /// Writes one line to stdout. A closed pipe ends the program quietly.
    pub fn stdout_line(&self, line: &str) {
        if let Some(screen) = &self.screen {
            let mut sc = screen.lock().unwrap_or_else(|p| p.into_inner());
            sc.push(None, line.to_string(), true);
            return;
        }
        let _guard = self.stdout.lock().unwrap_or_else(|p| p.into_inner());
        let mut out = std::io::stdout().lock();
        let r = out
            .write_all(line.as_bytes())
            .and_then(|_| out.write_all(b"\n"))
            .and_then(|_| out.flush());
        if let Err(e) = r {
            if e.kind() == ErrorKind::BrokenPipe {
                self.flush_log();
                std::process::exit(0);
            }
        }
    }

    fn stderr_line(&self, line: &str) {
        let mut err = std::io::stderr().lock();
        let _ = writeln!(err, "{line}");
    }

    fn log_line(&self, line: &str) {
        let mut log = self.log.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(w) = log.as_mut() {
            if let Err(e) = writeln!(w, "{line}").and_then(|()| w.flush()) {
                // A full disk must not stop the session: stop logging, say so once.
                *log = None;
                let _ = writeln!(
                    std::io::stderr(),
                    "ursock: --log: write failed ({e}), log closed; the session goes on"
                );
            }
        }
    }

    pub fn flush_log(&self) {
        let mut log = self.log.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(w) = log.as_mut() {
            let _ = w.flush();
        }
    }

    /// The event's JSON line: the event, then the wall-clock `time`. A `move_start` (of
    /// `--robot`) has a `time` of its own, the move's time argument: it is written
    /// without the wall-clock time.
    pub fn json_line(&self, event: &Event, now: jiff::Timestamp) -> String {
        if matches!(event, Event::MoveStart(_)) {
            return event.to_json();
        }
        #[derive(serde::Serialize)]
        struct Stamped<'a> {
            #[serde(flatten)]
            event: &'a Event,
            time: String,
        }
        serde_json::to_string(&Stamped {
            event,
            time: self.clock.rfc3339(now),
        })
        .unwrap_or_default()
    }

    /// One event: the JSON line with `--json`, else its human lines ([`human`]), each
    /// prefixed by the connection, the event's `t` and the wall-clock time.
    pub fn emit(&self, kind: Kind, event: Event) {
        if kind == Kind::Traffic && !self.traffic_wanted() {
            return;
        }
        let rel = event.t();
        let conn = event.conn();
        let now = jiff::Timestamp::now();
        let lines = human(&event, self.show_max);
        let stamp = format!("+{rel:.3}s {}", self.clock.time_of_day(now));
        let stamped: Vec<String> = lines.iter().map(|l| format!("{stamp} {l}")).collect();
        let with_conn = |l: &String| match conn {
            Some(id) => format!("[#{id}] {l}"),
            None => l.clone(),
        };
        let json_line = self.json.then(|| self.json_line(&event, now));
        match &json_line {
            Some(j) => self.log_line(j),
            None => {
                for l in &stamped {
                    self.log_line(&with_conn(l));
                }
            }
        }
        if let Some(screen) = &self.screen {
            let mut sc = screen.lock().unwrap_or_else(|p| p.into_inner());
            for l in stamped {
                sc.push(conn, l, kind != Kind::Traffic);
            }
            return;
        }
        if kind == Kind::Warn {
            for l in &stamped {
                self.stderr_line(&format!("ursock: {}", with_conn(l)));
            }
        }
        if let Some(j) = json_line {
            if kind != Kind::Traffic || !self.quiet {
                self.stdout_line(&j);
            }
        } else if kind == Kind::Note || (kind == Kind::Traffic && !self.quiet) {
            for l in &stamped {
                self.stdout_line(&with_conn(l));
            }
        }
    }
}

/// An event for people: its lines (each gets the time stamp), without the time.
pub fn human(event: &Event, show_max: usize) -> Vec<String> {
    let one = |s: String| vec![s];
    match event {
        Event::Listening(e) => match e.service {
            Some(service) => one(format!("listening on {} ({service})", e.addr)),
            None => one(format!("listening on {}", e.addr)),
        },
        Event::Connect(e) => match e.service {
            Some(service) => one(format!("{service}: connected from {}", e.peer)),
            None => one(format!("connected from {}", e.peer)),
        },
        Event::Program(e) => {
            let mut text = format!("program {:?} {}", e.name, e.what);
            if let Some(line) = e.line {
                text.push_str(&format!(" at line {line}"));
                if let Some(col) = e.column {
                    text.push_str(&format!(", column {col}"));
                }
            }
            if let Some(t) = &e.text {
                text.push_str(&format!(": {t}"));
            }
            if let Some(why) = e.reason.filter(|_| e.what == "stopped") {
                text.push_str(&format!(" ({})", why.replace('_', " ")));
            }
            one(text)
        }
        Event::Client(e) => one(format!("{} {}: {}", e.service, e.what, e.text)),
        Event::Close(e) => {
            let mut text = format!("closed ({}): rx {} B, tx {} B", e.reason, e.rx, e.tx);
            if e.refused_sets > 1 {
                text.push_str(&format!(
                    ", {} SETs refused (variable table full)",
                    e.refused_sets
                ));
            }
            one(text)
        }
        Event::Rx(e) => one(format!(
            "<- {:<4} {}",
            e.len,
            super::dump::chunk(&e.bytes.0, "      ", show_max)
        )),
        Event::Tx(e) => one(format!(
            "-> {:<4} {}",
            e.len,
            super::dump::chunk(&e.bytes.0, "      ", show_max)
        )),
        Event::Decoded(e) => one(format!("   = {}", e.text)),
        Event::DecodeError(e) => one(format!("   ! {}", e.text)),
        Event::Rule(e) => one(format!("   rule {} ({}) matched", e.line, e.pattern)),
        Event::Diagnosis(e) => one(match &e.source {
            Some(source) => format!("{source}: warning: {}", e.text),
            None => format!("warning: {}", e.text),
        }),
        Event::Refused(e) => one(format!(
            "refused connection from {}: {} connections open (--max-connections {}); further refusals are counted",
            e.peer, e.open, e.max_connections
        )),
        Event::RefusalsEnded(e) => one(format!(
            "accepting again: {} connections were refused while {} were open",
            e.refused, e.max_connections
        )),
        Event::AcceptRecovered(e) => one(format!(
            "accepting again: recovered after {} failed accepts in {:.1} s",
            e.failures, e.seconds
        )),
        Event::AcceptError(e) => one(e.text.clone()),
        Event::List(e) => {
            if e.connections.is_empty() {
                return one(format!("no robot connected; {} variables", e.variables));
            }
            let mut lines = vec![format!(
                "{} connected; {} variables",
                e.connections.len(),
                e.variables
            )];
            for c in &e.connections {
                lines.push(format!(
                    "#{} {}  rx {} B  tx {} B  connected {:.1} s",
                    c.conn, c.peer, c.rx, c.tx, c.seconds
                ));
            }
            lines
        }
        Event::UnknownVariable(e) => one(format!(
            "unknown variable {} (never SET), answered {}",
            e.name, e.answered
        )),
        Event::VarRefused(e) => one(e.text.clone()),
        Event::VarInvalid(e) => one(e.text.clone()),
        Event::RefusedAddress(e) => one(format!(
            "refused connection from {}: {} already open from that address (--max-per-address {})",
            e.peer, e.open_from_address, e.max_per_address
        )),
        Event::Evicted(e) => one(format!(
            "evicted (every slot taken, idle longest: {:.1} s without a byte) to make room",
            e.idle
        )),
        Event::Suppressed(e) => one(format!(
            "{} events not reported in {:.1} s (a flood, or superseded within a step)",
            e.count, e.seconds
        )),
        Event::Scheduling(e) => one(if e.refused.is_empty() {
            format!(
                "real-time loop: {}, memory locked: {}",
                e.policy, e.memory_locked
            )
        } else {
            format!(
                "real-time loop: {}, memory locked: {} (refused: {})",
                e.policy,
                e.memory_locked,
                e.refused.join("; ")
            )
        }),
        Event::Late(e) => one(if e.holds > 0 {
            format!(
                "controller LATE: {} steps late in {:.1} s (worst {:.1} ms); {} stall(s) past the catch-up bound held back {:.3} s (no steps computed for it)",
                e.late_steps, e.seconds, e.worst_ms, e.holds, e.held_seconds
            )
        } else {
            format!(
                "controller late: {} steps computed late in {:.1} s (worst {:.1} ms); every package sent",
                e.late_steps, e.seconds, e.worst_ms
            )
        }),
        Event::Dropped(e) => one(format!(
            "{} events not written: standard output did not keep up",
            e.count
        )),
        Event::Ready(e) => one(format!(
            "ready: {}",
            e.addrs
                .iter()
                .map(|(s, a)| format!("{s} {a}"))
                .collect::<Vec<_>>()
                .join(", ")
        )),
        Event::Operator(e) => one(format!("operator: {}: {}", e.command, e.text)),
        Event::State(e) => one(match e.reason {
            Some(why) => format!(
                "state: robot mode {}, safety {}, program {} ({})",
                e.robot_mode,
                e.safety,
                e.program,
                why.replace('_', " ")
            ),
            None => format!(
                "state: robot mode {}, safety {}, program {}",
                e.robot_mode, e.safety, e.program
            ),
        }),
        Event::Stopped(e) => one(format!("stopped: {}", e.reason)),
        Event::Dashboard(e) => std::iter::once(format!("<- {:?}", e.command))
            .chain(e.reply.iter().map(|l| format!("-> {l:?}")))
            .collect(),
        // Multi-line notes (`help`, `snippets`) get one stamped line each.
        Event::Help(e) | Event::Note(e) if e.text.contains('\n') => {
            e.text.lines().map(String::from).collect()
        }
        Event::Help(e) | Event::Note(e) => one(e.text.clone()),
        Event::Error(e) => one(match e.line.filter(|l| *l > 0) {
            Some(line) => format!("line {line}: {}", e.text),
            None => e.text.clone(),
        }),
        Event::Call(e) => {
            let args: Vec<String> = e.args.iter().map(ToString::to_string).collect();
            let mut text = format!(
                "line {}: {}({}) -> {}",
                e.line,
                e.call,
                args.join(", "),
                e.result
            );
            if let Some(why) = &e.why {
                text.push_str(&format!("  (why: {why})"));
            }
            one(text)
        }
        Event::Message(e) => one(e.text.clone()),
        Event::PeerClosed(e) => one(format!("{}: the server closed the connection", e.socket)),
        Event::MoveStart(e) => one(crate::script::move_start_line(e)),
        Event::MoveEnd(e) => one(crate::script::move_end_line(e)),
        Event::Output(e) => one(crate::script::output_line(e)),
        Event::End(e) => one(format!(
            "program ended: {}",
            match e.outcome {
                EndOutcome::Finished => "finished",
                EndOutcome::Halted => "halted",
                EndOutcome::MaxTime => "--max-time passed",
                EndOutcome::ProtectiveStop => "protective stop",
                EndOutcome::Error => "error",
            }
        )),
        Event::Read(e) => one(e.result.to_string()),
    }
}

#[cfg(test)]
mod clock_tests {
    use super::Clock;
    use jiff::tz::{offset, TimeZone};
    use jiff::Timestamp;

    #[test]
    fn stamps_are_rfc3339_with_the_zone_offset() {
        // 2026-11-23T21:40:01.123456Z
        let at = Timestamp::new(1_795_470_001, 123_456_000).unwrap();
        assert_eq!(Clock::Utc.rfc3339(at), "2026-11-23T21:40:01.123Z");
        assert_eq!(Clock::Utc.time_of_day(at), "21:40:01.123");
        let plus = Clock::Local(TimeZone::fixed(offset(5)));
        assert_eq!(plus.rfc3339(at), "2026-11-24T02:40:01.123+05:00");
        assert_eq!(plus.time_of_day(at), "02:40:01.123");
        let minus = Clock::Local(TimeZone::fixed(offset(-8)));
        assert_eq!(minus.rfc3339(at), "2026-11-23T13:40:01.123-08:00");
        // Whole seconds still carry their milliseconds.
        let whole = Timestamp::new(1_795_470_001, 0).unwrap();
        assert_eq!(Clock::Utc.rfc3339(whole), "2026-11-23T21:40:01.000Z");
    }
}
