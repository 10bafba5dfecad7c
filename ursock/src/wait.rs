//! `ursock wait`: waits until a controller serves its dashboard (its greeting read) and
//! accepts on its RTDE and primary ports, retrying until a timeout. For scripts and CI
//! that start `ursock controller` (or URSim) in the background.

use std::io::Read;
use std::net::{TcpStream, ToSocketAddrs};
use std::time::{Duration, Instant};

/// `ursock wait` options.
#[derive(clap::Args, Debug)]
pub struct WaitOptions {
    /// The controller: `HOST` or `HOST:PORT` (the dashboard server's port, 29999 by
    /// default).
    #[arg(value_name = "HOST[:PORT]")]
    pub host: String,
    /// Give up after SECONDS.
    #[arg(long, value_name = "SECONDS", default_value_t = 30.0)]
    pub timeout: f64,
    /// The RTDE port that must accept once the dashboard greets (0: not checked, as
    /// for `ursock controller --no-streams`).
    #[arg(long, default_value_t = 30004)]
    pub rtde_port: u16,
    /// The primary interface's port that must accept once the dashboard greets (0: not
    /// checked).
    #[arg(long, default_value_t = 30001)]
    pub primary_port: u16,
}

/// How often a refused or failed attempt is retried.
const RETRY: Duration = Duration::from_millis(100);

/// The longest one attempt (a connect, the greeting's read) may wait.
const ATTEMPT: Duration = Duration::from_secs(2);

/// The dashboard server's greeting starts with this (on UR's controllers and URSim).
const GREETING: &str = "Connected: Universal Robots Dashboard Server";

/// The most bytes of a greeting read: the greeting line and a little more.
const MAX_GREETING: u64 = 256;

/// The longest `--timeout`: a day; CI jobs end sooner.
const MAX_TIMEOUT: f64 = 86_400.0;

/// Splits `HOST` or `HOST:PORT` (`[V6]:PORT` for an IPv6 address).
fn host_port(text: &str) -> Result<(String, u16), String> {
    let bad = || format!("{text:?}: give HOST or HOST:PORT");
    if let Some(rest) = text.strip_prefix('[') {
        let (host, after) = rest.split_once(']').ok_or_else(bad)?;
        let port = match after {
            "" => 29999,
            p => p
                .strip_prefix(':')
                .and_then(|p| p.parse().ok())
                .ok_or_else(bad)?,
        };
        return Ok((host.to_string(), port));
    }
    match text.rsplit_once(':') {
        Some((host, port)) if !host.is_empty() && !host.contains(':') => {
            Ok((host.to_string(), port.parse().map_err(|_| bad())?))
        }
        Some(_) if text.parse::<std::net::Ipv6Addr>().is_ok() => Ok((text.to_string(), 29999)),
        Some(_) => Err(bad()),
        None if !text.is_empty() => Ok((text.to_string(), 29999)),
        None => Err(bad()),
    }
}

/// One connection to `host:port` within `limit`.
fn connect(host: &str, port: u16, limit: Duration) -> Result<TcpStream, String> {
    let addrs = (host, port).to_socket_addrs().map_err(|e| e.to_string())?;
    let mut last = "the name has no address".to_string();
    for a in addrs {
        match TcpStream::connect_timeout(&a, limit.max(Duration::from_millis(1))) {
            Ok(s) => return Ok(s),
            Err(e) => last = e.to_string(),
        }
    }
    Err(last)
}

/// Connects to the dashboard server and reads its greeting.
fn greeted(host: &str, port: u16, limit: Duration) -> Result<(), String> {
    let s = connect(host, port, limit)?;
    let _ = s.set_read_timeout(Some(limit.max(Duration::from_millis(1))));
    let mut got = Vec::new();
    let mut r = (&s).take(MAX_GREETING);
    let mut byte = [0u8; 1];
    loop {
        match r.read(&mut byte) {
            Ok(0) => break,
            Ok(_) if byte[0] == b'\n' => break,
            Ok(_) => got.push(byte[0]),
            Err(e) => return Err(format!("no greeting: {e}")),
        }
    }
    let line = String::from_utf8_lossy(&got);
    if line.trim_end().starts_with(GREETING) {
        Ok(())
    } else {
        Err(format!(
            "the greeting was {:?}, not {GREETING:?}",
            line.trim_end()
        ))
    }
}

/// Waits until the controller is ready: exit status 0 and one line saying what
/// answered, or an error naming what did not answer by the timeout.
pub fn run(opts: WaitOptions) -> Result<(), String> {
    let (host, port) = host_port(&opts.host)?;
    if !(opts.timeout > 0.0 && opts.timeout <= MAX_TIMEOUT) {
        return Err(format!(
            "--timeout {}: give seconds above 0, at most {MAX_TIMEOUT}",
            opts.timeout
        ));
    }
    let deadline = Instant::now() + Duration::from_secs_f64(opts.timeout);
    let left = || deadline.saturating_duration_since(Instant::now());
    let mut checks: Vec<(&str, u16)> = vec![("dashboard", port)];
    for (service, p) in [("rtde", opts.rtde_port), ("primary", opts.primary_port)] {
        if p != 0 {
            checks.push((service, p));
        }
    }
    for &(service, p) in &checks {
        loop {
            let limit = left().min(ATTEMPT);
            let tried = if service == "dashboard" {
                greeted(&host, p, limit)
            } else {
                connect(&host, p, limit).map(drop)
            };
            match tried {
                Ok(()) => break,
                Err(e) if left().is_zero() => {
                    return Err(format!(
                        "not ready after {} s: {service} ({host} port {p}): {e}",
                        opts.timeout
                    ));
                }
                Err(_) => std::thread::sleep(RETRY.min(left())),
            }
        }
    }
    let said: Vec<String> = checks
        .iter()
        .map(|(s, p)| format!("{s} {host}:{p}"))
        .collect();
    crate::out::line(&format!("ready: {}", said.join(", ")));
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::host_port;

    #[test]
    fn hosts_and_ports() {
        assert_eq!(host_port("ursim").unwrap(), ("ursim".into(), 29999));
        assert_eq!(
            host_port("10.0.0.2:1234").unwrap(),
            ("10.0.0.2".into(), 1234)
        );
        assert_eq!(host_port("[::1]:29998").unwrap(), ("::1".into(), 29998));
        assert_eq!(host_port("[::1]").unwrap(), ("::1".into(), 29999));
        assert_eq!(host_port("::1").unwrap(), ("::1".into(), 29999));
        for bad in ["", "h:", "h:99999", "[::1", "[::1]x", ":80"] {
            assert!(host_port(bad).is_err(), "{bad}");
        }
    }
}
