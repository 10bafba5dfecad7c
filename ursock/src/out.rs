//! Standard output that never panics, relative timestamps, and an optional session log.
//!
//! `println!` panics when stdout is a closed pipe (`ursock demo | head -1`). Every line
//! `ursock` prints goes through [`line()`] instead: a closed pipe ends the process quietly
//! with status 0, as `head`, `grep` and other Unix tools do; any other write error is one
//! line on stderr and status 1.

use std::fs::File;
use std::io::{ErrorKind, Write};
use std::sync::{Mutex, OnceLock};
use std::time::Instant;

/// Writes one line to stdout (and to the `--log` file, if one is open).
pub fn line(text: &str) {
    log(text);
    let mut out = std::io::stdout().lock();
    let r = out
        .write_all(text.as_bytes())
        .and_then(|()| out.write_all(b"\n"))
        .and_then(|()| out.flush());
    if let Err(e) = r {
        failed(&e);
    }
}

/// Writes raw bytes to stdout (no newline), with the same closed-pipe handling.
pub fn bytes(data: &[u8]) {
    let mut out = std::io::stdout().lock();
    if let Err(e) = out.write_all(data).and_then(|()| out.flush()) {
        failed(&e);
    }
}

/// A closed pipe is the reader saying "enough": exit quietly. Anything else is an error.
pub fn failed(e: &std::io::Error) -> ! {
    if e.kind() == ErrorKind::BrokenPipe {
        std::process::exit(0);
    }
    let _ = writeln!(std::io::stderr(), "ursock: stdout: {e}");
    std::process::exit(1);
}

/// `println!` through [`line()`]: never panics on a closed stdout.
#[macro_export]
macro_rules! outln {
    () => { $crate::out::line("") };
    ($($arg:tt)*) => { $crate::out::line(&format!($($arg)*)) };
}

/// One line on stderr (and in the `--log` file): `ursock: {text}`.
pub fn note(text: &str) {
    log(&format!("ursock: {text}"));
    let _ = writeln!(std::io::stderr(), "ursock: {text}");
}

fn start() -> Instant {
    static START: OnceLock<Instant> = OnceLock::new();
    *START.get_or_init(Instant::now)
}

/// Starts the clock that [`stamp`] counts from (the first call wins).
pub fn start_clock() {
    let _ = start();
}

/// Seconds since [`start_clock`], as `+0.003s`, for prefixing trace and read lines.
pub fn stamp() -> String {
    format!("+{:.3}s", elapsed_secs())
}

/// Seconds since [`start_clock`], rounded to the microsecond (the `t` of JSON events).
pub fn elapsed_secs() -> f64 {
    (start().elapsed().as_secs_f64() * 1e6).round() / 1e6
}

static LOG: Mutex<Option<File>> = Mutex::new(None);

/// Copies every later [`line()`] and [`note`] to `path` (created or truncated).
pub fn open_log(path: &std::path::Path) -> Result<(), String> {
    let f = File::create(path).map_err(|e| format!("--log {}: {e}", path.display()))?;
    *LOG.lock().unwrap_or_else(|p| p.into_inner()) = Some(f);
    Ok(())
}

fn log(text: &str) {
    let mut guard = LOG.lock().unwrap_or_else(|p| p.into_inner());
    if let Some(f) = guard.as_mut() {
        if let Err(e) = writeln!(f, "{text}") {
            // A full disk must not stop the session: stop logging, say so once.
            *guard = None;
            let _ = writeln!(
                std::io::stderr(),
                "ursock: --log: write failed ({e}), log closed"
            );
        }
    }
}
