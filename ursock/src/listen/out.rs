//! Where `listen` says things: stdout (text or one JSON event per line), stderr for
//! problems, and the `--log FILE` copy of the whole session.
//!
//! A closed stdout (`ursock listen | head`) ends the program quietly, as Unix tools do:
//! nothing here panics on a failed write.

use std::collections::{BTreeMap, VecDeque};
use std::fs::File;
use std::io::{BufWriter, ErrorKind, Write};
use std::sync::Mutex;
use std::time::{Instant, SystemTime, UNIX_EPOCH};

use serde_json::{json, Map, Value};

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

/// What the terminal UI shows: each connection's lines and the general ones, bounded.
#[derive(Default)]
pub struct Screen {
    pub per_conn: BTreeMap<u64, VecDeque<String>>,
    pub general: VecDeque<String>,
}

/// Lines kept per connection, general lines kept, connections whose lines are kept.
const SCREEN_LINES: usize = 1000;
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
                if q.len() >= SCREEN_LINES {
                    q.pop_front();
                }
                q.push_back(l.to_string());
            }
        }
        if general || conn.is_none() {
            if self.general.len() >= SCREEN_GENERAL {
                self.general.pop_front();
            }
            let prefix = conn.map(|id| format!("[#{id}] ")).unwrap_or_default();
            self.general
                .push_back(format!("{prefix}{}", line.lines().next().unwrap_or("")));
        }
    }
}

pub struct Out {
    /// With `--tui`: lines go to the screen, not to stdout/stderr.
    pub screen: Option<Mutex<Screen>>,
    json: bool,
    quiet: bool,
    has_log: bool,
    start: Instant,
    log: Mutex<Option<BufWriter<File>>>,
    /// Serialises stdout writes so lines from several connections never interleave.
    stdout: Mutex<()>,
}

impl Out {
    pub fn new(json: bool, quiet: bool, log: Option<File>, tui: bool) -> Self {
        Out {
            screen: tui.then(|| Mutex::new(Screen::default())),
            json,
            quiet,
            has_log: log.is_some(),
            start: Instant::now(),
            log: Mutex::new(log.map(BufWriter::new)),
            stdout: Mutex::new(()),
        }
    }

    pub fn is_json(&self) -> bool {
        self.json
    }

    /// Whether traffic lines go anywhere (`--quiet` without `--log` drops them): callers
    /// skip formatting hex dumps nobody will see.
    pub fn traffic_wanted(&self) -> bool {
        !self.quiet || self.screen.is_some() || self.has_log
    }

    /// Seconds since the listener started.
    pub fn rel(&self) -> f64 {
        self.start.elapsed().as_secs_f64()
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
            let _ = writeln!(w, "{line}");
            let _ = w.flush();
        }
    }

    pub fn flush_log(&self) {
        let mut log = self.log.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(w) = log.as_mut() {
            let _ = w.flush();
        }
    }

    /// One event: `text` for people, `event` (an object) for `--json`. Both carry the
    /// connection number and the relative and wall-clock time.
    pub fn emit(&self, kind: Kind, conn: Option<u64>, text: &str, event: Value) {
        if kind == Kind::Traffic && !self.traffic_wanted() {
            return;
        }
        let rel = self.rel();
        let now = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .unwrap_or_default();
        let human = match conn {
            Some(id) => format!("[#{id}] +{rel:.3}s {} {text}", wall_clock(now)),
            None => format!("+{rel:.3}s {} {text}", wall_clock(now)),
        };
        let mut obj = match event {
            Value::Object(m) => m,
            other => {
                let mut m = Map::new();
                m.insert("value".into(), other);
                m
            }
        };
        obj.insert("t".into(), json!((rel * 1e6).round() / 1e6));
        obj.insert("time".into(), json!(iso_time(now)));
        if let Some(id) = conn {
            obj.insert("conn".into(), json!(id));
        }
        if kind == Kind::Warn && !obj.contains_key("message") {
            obj.insert("message".into(), json!(text));
        }
        let json_line = Value::Object(obj).to_string();
        self.log_line(if self.json { &json_line } else { &human });
        if let Some(screen) = &self.screen {
            let short = format!("+{rel:.3}s {} {text}", wall_clock(now));
            let mut sc = screen.lock().unwrap_or_else(|p| p.into_inner());
            sc.push(conn, short, kind != Kind::Traffic);
            return;
        }
        if kind == Kind::Warn {
            self.stderr_line(&format!("ursock: {human}"));
        }
        if self.json {
            if kind != Kind::Traffic || !self.quiet {
                self.stdout_line(&json_line);
            }
        } else if kind == Kind::Note || (kind == Kind::Traffic && !self.quiet) {
            self.stdout_line(&human);
        }
    }
}

/// `HH:MM:SS.mmm` UTC.
pub fn wall_clock(since_epoch: std::time::Duration) -> String {
    let secs = since_epoch.as_secs();
    let ms = since_epoch.subsec_millis();
    let day = secs % 86_400;
    format!(
        "{:02}:{:02}:{:02}.{ms:03}",
        day / 3600,
        day / 60 % 60,
        day % 60
    )
}

/// `2026-11-22T20:59:01.123Z`.
pub fn iso_time(since_epoch: std::time::Duration) -> String {
    let days = (since_epoch.as_secs() / 86_400) as i64;
    // Howard Hinnant's days-to-civil.
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!("{y:04}-{m:02}-{d:02}T{}Z", wall_clock(since_epoch))
}

/// Raw bytes for JSON: the text when valid UTF-8, otherwise hex; `encoding` says which.
pub fn bytes_json(bytes: &[u8]) -> (Value, &'static str) {
    match std::str::from_utf8(bytes) {
        Ok(s) => (json!(s), "utf8"),
        Err(_) => (json!(crate::show::hex(bytes)), "hex"),
    }
}
