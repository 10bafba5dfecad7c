//! Playing a loaded `.urp` program: read the file, translate it to URScript, and fetch
//! the External Control URCap's script as the URCap does at play time. The host is
//! `--urcap-host` if given, else the URCap's settings in the program's installation file
//! beside it, else the URCap's default.
//!
//! # The fetch, as the URCap does it
//!
//! The URCap (`RequestProgram.java` in UR's `Universal_Robots_ExternalControl_URCap`)
//! connects with a 5 s timeout, sends `request_program\n`, sets a 500 ms socket timeout
//! and reads one line with `BufferedReader.readLine` (blocking). It then reads more lines
//! only while `ready()` says bytes are already there: it never waits for more. A line
//! that started arrives whole: `readLine` waits for its end (`\n`, `\r` or `\r\n`), for
//! the host to close, or for the 500 ms timeout. A read timeout anywhere makes the node's
//! script the URCap's "Timeout while reading requested program" popup; a closed
//! connection before the first byte gives the line `null`.
//!
//! This module does the same ([`Reply`]): the program starts as soon as the lines the
//! host sent are in, whether the host closes the connection (as the ROS 1 driver did)
//! or keeps it open (UR's Client Library's `ScriptSender`). A reply the host writes in
//! two parts with a pause between gets, as on a robot, only what had arrived when the
//! first line was read. Bounds the URCap does not have: at most [`MAX_FETCHED`] bytes
//! (more fails the play), and [`FETCH_LIMIT`] for the whole fetch (then it ends as a read
//! timeout does).

use std::io::{ErrorKind, Read, Write};
use std::net::TcpStream;
use std::path::Path;
use std::time::{Duration, Instant};

use crate::urp::{
    read_external_control_settings, read_urp, translate_with, ExternalControlNode, FetchError,
    EXTERNAL_CONTROL_DEFAULT_PORT, EXTERNAL_CONTROL_REQUEST,
};

use super::Shared;

/// The largest `.urp` or `.installation` file read.
pub const MAX_FILE: u64 = 64 * 1024 * 1024;
/// The most bytes of script read from an External Control host.
pub const MAX_FETCHED: usize = 16 * 1024 * 1024;
/// How long connecting to the External Control host may take (the URCap's 5 s).
const CONNECT_TIMEOUT: Duration = Duration::from_secs(5);
/// How long one read of the reply may wait (the URCap's socket timeout, 500 ms): the
/// first line, and the rest of a line once it started, must come within it.
const READ_TIMEOUT: Duration = Duration::from_millis(500);
/// The longest a whole fetch may take, however slowly the host sends: past it the fetch
/// ends as a read timeout does. (The URCap's only bound is each read's 500 ms.)
const FETCH_LIMIT: Duration = Duration::from_secs(10);

/// Reads `HOST` or `HOST:PORT` (the External Control URCap's port 50002 by default).
pub fn parse_host(text: &str) -> Result<(String, u16), String> {
    match text.rsplit_once(':') {
        Some((host, port)) if !host.is_empty() && !host.contains(':') => {
            let port = port
                .parse::<u16>()
                .map_err(|_| format!("{port:?} is not a port number"))?;
            Ok((host.to_string(), port))
        }
        _ if !text.is_empty() => Ok((text.to_string(), EXTERNAL_CONTROL_DEFAULT_PORT)),
        _ => Err("give a host name or address".into()),
    }
}

/// Reads the regular file at `path` if it is inside the programs folder `root` (a
/// canonical path): symbolic links and `..` resolved first, anything else (a FIFO, a
/// device, a directory) refused before it is opened, and checked again on the opened
/// handle, which is opened without blocking (`O_NONBLOCK`: a FIFO swapped in meanwhile
/// cannot hold the open) and without following a link swapped in for the file
/// (`O_NOFOLLOW`). At most [`MAX_FILE`] bytes; a regular file's reads do not wait.
fn read_inside(root: &Path, path: &Path) -> Result<Vec<u8>, String> {
    let real = path
        .canonicalize()
        .map_err(|e| format!("cannot open it: {e}"))?;
    if !real.starts_with(root) {
        return Err(format!(
            "{} is outside the programs folder {}",
            real.display(),
            root.display()
        ));
    }
    let before = std::fs::symlink_metadata(&real).map_err(|e| format!("cannot open it: {e}"))?;
    if !before.is_file() {
        return Err(format!("{} is not a regular file", real.display()));
    }
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(libc::O_NONBLOCK | libc::O_NOFOLLOW);
    }
    let file = options
        .open(&real)
        .map_err(|e| format!("cannot open it: {e}"))?;
    let meta = file
        .metadata()
        .map_err(|e| format!("cannot read it: {e}"))?;
    if !meta.is_file() {
        return Err(format!("{} is not a regular file", real.display()));
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if (meta.dev(), meta.ino()) != (before.dev(), before.ino()) {
            return Err(format!("{} changed while it was opened", real.display()));
        }
    }
    #[cfg(target_os = "linux")]
    {
        // Where the handle really is (a directory on the way swapped for a link would
        // have led elsewhere).
        use std::os::fd::AsRawFd;
        let fd = format!("/proc/self/fd/{}", file.as_raw_fd());
        if let Ok(opened) = std::fs::read_link(fd) {
            if !opened.starts_with(root) {
                return Err(format!(
                    "{} is outside the programs folder {}",
                    opened.display(),
                    root.display()
                ));
            }
        }
    }
    let mut bytes = Vec::new();
    file.take(MAX_FILE + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| format!("cannot read it: {e}"))?;
    if bytes.len() as u64 > MAX_FILE {
        return Err(format!("larger than {MAX_FILE} bytes"));
    }
    Ok(bytes)
}

/// The URScript of the program file at `path`, which must be a regular file inside the
/// programs folder, as must the installation it names (when it exists).
pub(crate) fn load(shared: &Shared, path: &str) -> Result<String, String> {
    let Some(root) = shared.programs.as_deref() else {
        return Err("no programs folder".into());
    };
    let path = Path::new(path);
    let bytes = read_inside(root, path)?;
    let mut program = read_urp(&bytes).map_err(|e| e.to_string())?;
    if !program.external_control.is_empty() {
        let (host, port) = match &shared.urcap_host {
            Some((h, p)) => (h.clone(), *p),
            None => {
                // The installation the program was saved with, beside it (a relative
                // name may reach elsewhere in the programs folder, never out of it).
                let name = format!("{}.installation", program.installation);
                let installation = path.parent().map(|d| d.join(&name));
                match installation.filter(|p| std::fs::symlink_metadata(p).is_ok()) {
                    Some(p) => {
                        let bytes = read_inside(root, &p)
                            .map_err(|e| format!("the installation {name}: {e}"))?;
                        let s = read_external_control_settings(&bytes)
                            .map_err(|e| format!("{name}: {e}"))?;
                        (s.host, s.port)
                    }
                    None => {
                        let node = &program.external_control[0];
                        (node.host.clone(), node.port)
                    }
                }
            }
        };
        program.set_external_control_host(&host, port);
    }
    translate_with(&program, request_program).map_err(|e| e.to_string())
}

/// What the External Control URCap does at play time, read from its source
/// (`RequestProgram.java`): connect (5 s timeout), send `request_program\n`, read one
/// line, waiting up to 500 ms; then more lines only while bytes are already there
/// (`BufferedReader.ready()`). The lines come back joined, each ending in `\n`; a first
/// line that never started (the host closed at once) is the empty text.
fn request_program(node: &ExternalControlNode) -> Result<String, FetchError> {
    let stream = urscript_interp::drive::connect_stream(&node.host, node.port, CONNECT_TIMEOUT)
        .map_err(|e| FetchError::Connect(e.to_string()))?;
    let mut reply = Reply::new(stream)?;
    reply.send(EXTERNAL_CONTROL_REQUEST)?;
    reply.read_program()
}

/// The reply as the URCap's `BufferedReader` sees it: bytes received so far, where the
/// next line starts, whether a `\r` just ended a line (a `\n` right after it belongs to
/// it), and whether the host closed.
struct Reply {
    stream: TcpStream,
    /// Every byte received, at most [`MAX_FETCHED`].
    bytes: Vec<u8>,
    /// Where the next line starts in `bytes`.
    next: usize,
    /// The last line ended in `\r`: a `\n` that follows is skipped, not an empty line.
    skip_lf: bool,
    /// The host closed its side.
    eof: bool,
    /// [`FETCH_LIMIT`] from the request.
    deadline: Instant,
}

impl Reply {
    fn new(stream: TcpStream) -> Result<Self, FetchError> {
        let io = |e: std::io::Error| FetchError::Connect(e.to_string());
        stream.set_nonblocking(false).map_err(io)?;
        stream.set_read_timeout(Some(READ_TIMEOUT)).map_err(io)?;
        Ok(Reply {
            stream,
            bytes: Vec::new(),
            next: 0,
            skip_lf: false,
            eof: false,
            deadline: Instant::now() + FETCH_LIMIT,
        })
    }

    fn send(&mut self, request: &[u8]) -> Result<(), FetchError> {
        self.stream
            .write_all(request)
            .map_err(|e| FetchError::Connect(e.to_string()))
    }

    /// The first line (blocking), then the lines that are there at once.
    fn read_program(&mut self) -> Result<String, FetchError> {
        let mut text = String::new();
        let Some(first) = self.line()? else {
            return Ok(text); // `readLine` gave null: the URCap writes " null"
        };
        text.push_str(&first);
        text.push('\n');
        while self.ready()? {
            // `ready` saw a byte that is not a skipped `\n`: a line (maybe partial, which
            // `line` waits for) is there.
            let line = self.line()?.unwrap_or_default();
            text.push_str(&line);
            text.push('\n');
        }
        Ok(text)
    }

    /// Drops a `\n` that ends the line a `\r` ended, once it is here.
    fn skip_lf(&mut self) {
        if self.skip_lf && self.next < self.bytes.len() {
            if self.bytes[self.next] == b'\n' {
                self.next += 1;
            }
            self.skip_lf = false;
        }
    }

    /// `BufferedReader.readLine`: the next line without its end (`\n`, `\r` or `\r\n`),
    /// waiting for its end, for the host to close (the partial line), or up to
    /// [`READ_TIMEOUT`] for each read; `None` when the host closed before a byte of it.
    fn line(&mut self) -> Result<Option<String>, FetchError> {
        let mut scanned = self.next;
        loop {
            self.skip_lf();
            scanned = scanned.max(self.next);
            let rest = &self.bytes[scanned..];
            if let Some(k) = rest.iter().position(|&b| b == b'\n' || b == b'\r') {
                let end = scanned + k;
                let line = String::from_utf8_lossy(&self.bytes[self.next..end]).into_owned();
                self.skip_lf = self.bytes[end] == b'\r';
                self.next = end + 1;
                return Ok(Some(line));
            }
            scanned = self.bytes.len();
            if self.eof {
                if self.next == self.bytes.len() {
                    return Ok(None);
                }
                let line = String::from_utf8_lossy(&self.bytes[self.next..]).into_owned();
                self.next = self.bytes.len();
                return Ok(Some(line));
            }
            self.receive(true)?;
        }
    }

    /// `BufferedReader.ready`: a byte is buffered or can be read without waiting.
    fn ready(&mut self) -> Result<bool, FetchError> {
        self.skip_lf();
        if self.next == self.bytes.len() && !self.eof {
            self.receive(false)?;
            self.skip_lf();
        }
        Ok(self.next < self.bytes.len())
    }

    /// Reads what the host sent: waiting up to [`READ_TIMEOUT`] (`wait`), or only what
    /// is there already.
    fn receive(&mut self, wait: bool) -> Result<(), FetchError> {
        if Instant::now() >= self.deadline {
            return Err(FetchError::Timeout);
        }
        let io = |e: std::io::Error| FetchError::Connect(e.to_string());
        self.stream.set_nonblocking(!wait).map_err(io)?;
        let mut buf = [0u8; 16 * 1024];
        let got = loop {
            match self.stream.read(&mut buf) {
                Err(e) if e.kind() == ErrorKind::Interrupted => continue,
                other => break other,
            }
        };
        match got {
            Ok(0) => self.eof = true,
            Ok(n) => {
                if self.bytes.len() + n > MAX_FETCHED {
                    return Err(FetchError::TooLarge { limit: MAX_FETCHED });
                }
                self.bytes.extend_from_slice(&buf[..n]);
            }
            Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {
                if wait {
                    return Err(FetchError::Timeout);
                }
            }
            Err(e) => return Err(FetchError::Connect(e.to_string())),
        }
        Ok(())
    }
}
