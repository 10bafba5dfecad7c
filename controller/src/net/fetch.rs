//! Playing a loaded `.urp` program: read the file, translate it to URScript, and fetch
//! each External Control URCap node's script as the URCap does at play time (connect to
//! its host, send `request_program\n`, read the reply until the host closes). The host is
//! `--urcap-host` if given, else the URCap's settings in the program's installation file
//! beside it, else the URCap's default.

use std::io::{Read, Write};
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
/// How long the host may stay silent: before its first bytes (the URCap's read
/// timeout), and after them, when the reply counts as complete (the URCap reads until
/// nothing more is buffered).
const QUIET: Duration = Duration::from_millis(500);
/// The longest a whole fetch may take.
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

fn read_bounded(path: &Path) -> Result<Vec<u8>, String> {
    let file = std::fs::File::open(path).map_err(|e| format!("cannot open it: {e}"))?;
    let mut bytes = Vec::new();
    file.take(MAX_FILE + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| format!("cannot read it: {e}"))?;
    if bytes.len() as u64 > MAX_FILE {
        return Err(format!("larger than {MAX_FILE} bytes"));
    }
    Ok(bytes)
}

/// The URScript of the program file at `path`.
pub(crate) fn load(shared: &Shared, path: &str) -> Result<String, String> {
    let path = Path::new(path);
    let bytes = read_bounded(path)?;
    let mut program = read_urp(&bytes).map_err(|e| e.to_string())?;
    if !program.external_control.is_empty() {
        let (host, port) = match &shared.urcap_host {
            Some((h, p)) => (h.clone(), *p),
            None => {
                // The installation the program was saved with, beside it.
                let name = format!("{}.installation", program.installation);
                let installation = path.parent().map(|d| d.join(&name));
                match installation.filter(|p| p.is_file()) {
                    Some(p) => {
                        let s = read_external_control_settings(&read_bounded(&p)?)
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

/// What the External Control URCap does at play time: `request_program\n` to the host,
/// the reply read until the host closes (or stays quiet, or the bounds are reached).
fn request_program(node: &ExternalControlNode) -> Result<String, FetchError> {
    let mut stream = urscript_interp::drive::connect_stream(&node.host, node.port, CONNECT_TIMEOUT)
        .map_err(|e| FetchError::Connect(e.to_string()))?;
    let _ = stream.set_nonblocking(false);
    let _ = stream.set_read_timeout(Some(QUIET));
    stream
        .write_all(EXTERNAL_CONTROL_REQUEST)
        .map_err(|e| FetchError::Connect(e.to_string()))?;
    let start = Instant::now();
    let mut reply = Vec::new();
    let mut buf = [0u8; 16 * 1024];
    loop {
        match stream.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => {
                reply.extend_from_slice(&buf[..n]);
                if reply.len() > MAX_FETCHED {
                    break; // the bound: what came so far
                }
            }
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) =>
            {
                if reply.is_empty() {
                    return Err(FetchError::Timeout);
                }
                break; // quiet with a reply in hand: it is complete
            }
            Err(e) => return Err(FetchError::Connect(e.to_string())),
        }
        if start.elapsed() > FETCH_LIMIT {
            break;
        }
    }
    Ok(String::from_utf8_lossy(&reply).into_owned())
}
