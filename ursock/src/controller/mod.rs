//! `ursock controller`: a virtual UR controller that unmodified clients drive.
//!
//! - The dashboard server (29999): one thread per connection (at most
//!   [`MAX_CONNECTIONS`]), every line a command, every reply written in one piece ending
//!   in `"\n"`.
//! - The primary (30001), secondary (30002), realtime (30003) and RTDE (30004)
//!   interfaces, and the program running on the virtual arm: one real-time thread
//!   ([`streams`]).
//!
//! Every interface reads and changes one [`Cell`] (the controller's state machine, the
//! arm and its program); its clock is the time since the start.

mod clock;
mod streams;
mod urp;

use std::io::{BufRead, ErrorKind, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use urscript_controller::{
    Cell, Config, Controller, Dashboard, Model, Programs, Reply, SafetyStatus, MAX_LINE,
};

use crate::report::{self, Event};

/// Connections served at once; more are accepted and closed at once.
pub const MAX_CONNECTIONS: usize = 16;

/// A write that cannot finish in this time (a client that stopped reading) ends the
/// connection.
const WRITE_TIMEOUT: Duration = Duration::from_secs(10);

/// `ursock controller` options.
#[derive(clap::Args, Debug)]
pub struct ControllerOptions {
    /// Address to bind.
    #[arg(long, default_value = "127.0.0.1")]
    pub bind: String,
    /// The dashboard server's port (0 picks a free one).
    #[arg(long, default_value_t = 29999)]
    pub dashboard_port: u16,
    /// The primary interface's port (state at 10 Hz, robot messages, programs in);
    /// 0 picks a free one; `--no-streams` serves none of the four.
    #[arg(long, default_value_t = 30001)]
    pub primary_port: u16,
    /// The secondary interface's port (state at 10 Hz, programs in).
    #[arg(long, default_value_t = 30002)]
    pub secondary_port: u16,
    /// The realtime interface's port (one package per step, programs in).
    #[arg(long, default_value_t = 30003)]
    pub realtime_port: u16,
    /// The RTDE interface's port.
    #[arg(long, default_value_t = 30004)]
    pub rtde_port: u16,
    /// Serve only the dashboard server.
    #[arg(long)]
    pub no_streams: bool,
    /// Where the External Control URCap's node of a `.urp` program fetches its script
    /// when the program plays (`HOST` or `HOST:PORT`, port 50002 by default), as the
    /// URCap does with `request_program`.
    #[arg(long, value_name = "HOST[:PORT]")]
    pub urcap_host: Option<String>,
    /// The arm model: ur3, ur5, ur10 (CB3), ur3e, ur5e, ur10e, ur16e, ur20, ur30.
    #[arg(long, default_value = "ur5e")]
    pub model: String,
    /// The PolyScope version the controller reports (`5.21.0`, or with its build number
    /// `5.21.0.1234567`; a 3.x version answers CB3's user-role commands).
    #[arg(long, default_value = "5.21.0")]
    pub polyscope: String,
    /// The serial number `get serial number` answers.
    #[arg(long, default_value = "20235500001")]
    pub serial: String,
    /// Where `load NAME.urp` and `load installation NAME` find files (NAME relative to
    /// DIR, or absolute inside it). Without it every load answers `File not found`.
    #[arg(long, value_name = "DIR")]
    pub programs: Option<PathBuf>,
    /// Start in local control: every command that acts is refused, as on a pendant not
    /// switched to remote control. (Standard input takes operator commands: `protective
    /// stop`, `emergency stop`, `release`, `local`, `remote`, `state`, `help`, ...)
    #[arg(long)]
    pub local: bool,
    /// One JSON event per line (docs/json-events.md): `listening`, then `connect`,
    /// `dashboard` (each command and its reply) and `close` for every client.
    #[arg(long)]
    pub json: bool,
}

/// Programs in a directory of this machine: a name is found when it names a file inside
/// the directory (after resolving `..` and links).
struct DirPrograms {
    root: PathBuf,
}

impl Programs for DirPrograms {
    fn find(&self, name: &str) -> Option<String> {
        if name.is_empty() || name.contains('\0') {
            return None;
        }
        let path = Path::new(name);
        let candidate = if path.is_absolute() {
            path.to_path_buf()
        } else {
            self.root.join(path)
        };
        let real = candidate.canonicalize().ok()?;
        (real.starts_with(&self.root) && real.is_file()).then(|| real.display().to_string())
    }
}

fn valid_version(v: &str) -> bool {
    let parts: Vec<&str> = v.split('.').collect();
    (3..=4).contains(&parts.len())
        && parts
            .iter()
            .all(|p| !p.is_empty() && p.len() <= 9 && p.bytes().all(|b| b.is_ascii_digit()))
}

struct Shared {
    cell: Mutex<Cell>,
    /// The controller's configuration (a copy: it never changes).
    config: Config,
    /// Controller time: wall time less what the host took from the real-time loop.
    clock: clock::Clock,
    json: bool,
    active: AtomicUsize,
    next_conn: AtomicU64,
    /// `--programs`: where `.urp` files are.
    urcap_host: Option<(String, u16)>,
}

impl Shared {
    fn now(&self) -> Duration {
        self.clock.now()
    }

    fn config(&self) -> &Config {
        &self.config
    }

    fn lock_cell(&self) -> std::sync::MutexGuard<'_, Cell> {
        self.cell.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// A new connection number, shared by every interface.
    fn next_conn(&self) -> u64 {
        self.next_conn.fetch_add(1, Ordering::SeqCst)
    }

    /// A line for people; nothing with `--json`.
    fn say(&self, human: impl FnOnce() -> String) {
        if !self.json {
            crate::out::line(&human());
        }
    }

    /// An event: its JSON line, or its lines for people (`[#conn]` in front).
    fn emit(&self, event: Event) {
        if self.json {
            crate::out::line(&event.to_json());
            return;
        }
        let prefix = event.conn().map(|c| format!("[#{c}] ")).unwrap_or_default();
        for l in crate::listen::human(&event, usize::MAX) {
            crate::out::line(&format!("{prefix}{l}"));
        }
    }
}

/// Runs the controller until `shutdown`.
pub fn run(opts: ControllerOptions) -> Result<(), String> {
    let model: Model = opts.model.parse().map_err(|e| format!("--model: {e}"))?;
    if !valid_version(&opts.polyscope) {
        return Err(format!(
            "--polyscope {}: give a version like 5.21.0 or 5.21.0.1234567",
            opts.polyscope
        ));
    }
    if opts.serial.is_empty() || opts.serial.len() > 64 || opts.serial.contains(char::is_whitespace)
    {
        return Err(format!(
            "--serial {:?}: give one word, like 20235500001",
            opts.serial
        ));
    }
    let config = Config {
        model,
        polyscope: opts.polyscope.clone(),
        serial: opts.serial.clone(),
        remote_control: !opts.local,
        ..Config::default()
    };
    let mut controller = Controller::new(config);
    if let Some(dir) = &opts.programs {
        let root = dir
            .canonicalize()
            .map_err(|e| format!("--programs {}: {e}", dir.display()))?;
        if !root.is_dir() {
            return Err(format!("--programs {}: not a directory", dir.display()));
        }
        controller = controller.with_programs(Box::new(DirPrograms { root }));
    }
    let bind = |port: u16, service: &'static str| -> Result<(TcpListener, String), String> {
        let l = TcpListener::bind((opts.bind.as_str(), port))
            .map_err(|e| format!("cannot listen on {}:{port} ({service}): {e}", opts.bind))?;
        let addr = l
            .local_addr()
            .map(|a| a.to_string())
            .unwrap_or_else(|_| format!("{}:{port}", opts.bind));
        Ok((l, addr))
    };
    let urcap_host = match &opts.urcap_host {
        None => None,
        Some(h) => Some(urp::parse_host(h).map_err(|e| format!("--urcap-host {h}: {e}"))?),
    };
    let (listener, addr) = bind(opts.dashboard_port, "dashboard")?;
    let mut bound = vec![(addr, "dashboard")];
    let listeners = if opts.no_streams {
        None
    } else {
        let (primary, a1) = bind(opts.primary_port, "primary")?;
        let (secondary, a2) = bind(opts.secondary_port, "secondary")?;
        let (realtime, a3) = bind(opts.realtime_port, "realtime")?;
        let (rtde, a4) = bind(opts.rtde_port, "rtde")?;
        bound.extend([
            (a1, "primary"),
            (a2, "secondary"),
            (a3, "realtime"),
            (a4, "rtde"),
        ]);
        Some(streams::Listeners {
            primary: Some(primary),
            secondary: Some(secondary),
            realtime: Some(realtime),
            rtde: Some(rtde),
        })
    };
    let config = controller.config().clone();
    let interp = Cell::interp_config(&controller);
    let cell = Cell::new(controller, interp);
    let step = cell.step_time();
    let shared = Arc::new(Shared {
        cell: Mutex::new(cell),
        config,
        clock: clock::Clock::new(step),
        json: opts.json,
        active: AtomicUsize::new(0),
        next_conn: AtomicU64::new(1),
        urcap_host,
    });
    for (addr, service) in bound {
        if opts.json {
            let event = Event::Listening(report::Listening {
                t: report::now(),
                addr,
                service: Some(service),
            });
            crate::out::line(&event.to_json());
        } else {
            crate::out::line(&format!("listening on {addr} ({service})"));
        }
    }
    {
        let shared = Arc::clone(&shared);
        let _ = std::thread::Builder::new()
            .name("operator".into())
            .spawn(move || operator(&shared));
    }
    if let Some(listeners) = listeners {
        let shared = Arc::clone(&shared);
        std::thread::Builder::new()
            .name("controller".into())
            .spawn(move || streams::run(&shared, listeners))
            .map_err(|e| format!("cannot start the controller's thread: {e}"))?;
    }
    loop {
        let (stream, peer) = match listener.accept() {
            Ok(s) => s,
            Err(e) if e.kind() == ErrorKind::Interrupted => continue,
            Err(e) => {
                // Out of descriptors and the like: say so, wait a little, go on.
                crate::out::note(&format!("accept failed: {e}"));
                std::thread::sleep(Duration::from_millis(100));
                continue;
            }
        };
        if shared.active.load(Ordering::SeqCst) >= MAX_CONNECTIONS {
            crate::out::note(&format!(
                "{peer}: refused, {MAX_CONNECTIONS} connections are already open"
            ));
            drop(stream);
            continue;
        }
        shared.active.fetch_add(1, Ordering::SeqCst);
        let conn = shared.next_conn();
        let spawned = std::thread::Builder::new()
            .name(format!("dashboard-{conn}"))
            .spawn({
                let shared = Arc::clone(&shared);
                move || {
                    serve(stream, conn, peer.to_string(), &shared);
                    shared.active.fetch_sub(1, Ordering::SeqCst);
                }
            });
        if let Err(e) = spawned {
            shared.active.fetch_sub(1, Ordering::SeqCst);
            crate::out::note(&format!("{peer}: cannot start a thread: {e}"));
        }
    }
}

/// What one connection counted.
struct Counts {
    rx: u64,
    tx: u64,
}

fn send(stream: &mut TcpStream, reply: &Reply, counts: &mut Counts) -> bool {
    let bytes = reply.to_bytes();
    let ok = stream
        .write_all(&bytes)
        .and_then(|()| stream.flush())
        .is_ok();
    if ok {
        counts.tx += bytes.len() as u64;
    }
    ok
}

fn serve(mut stream: TcpStream, conn: u64, peer: String, shared: &Shared) {
    let _ = stream.set_nodelay(true);
    let _ = stream.set_write_timeout(Some(WRITE_TIMEOUT));
    shared.emit(Event::Connect(report::Connect {
        t: report::now(),
        conn,
        peer,
        service: Some("dashboard"),
    }));
    let mut counts = Counts { rx: 0, tx: 0 };
    let reason = session(&mut stream, conn, shared, &mut counts);
    shared.emit(Event::Close(report::Close {
        t: report::now(),
        conn,
        reason: reason.to_string(),
        rx: counts.rx,
        tx: counts.tx,
        refused_sets: 0,
    }));
}

/// Answer one command line; `Err(reason)` when the connection ends.
fn answer(
    stream: &mut TcpStream,
    conn: u64,
    shared: &Shared,
    dashboard: &mut Dashboard,
    line: &[u8],
    too_long: bool,
    counts: &mut Counts,
) -> Result<(), &'static str> {
    let text = String::from_utf8_lossy(line);
    let text = text.strip_suffix('\r').unwrap_or(&text);
    let (reply, shut_down) = {
        let mut cell = shared.lock_cell();
        let now = shared.now();
        cell.advance(now);
        let c = cell.controller();
        let reply = if too_long {
            dashboard.line_too_long(text)
        } else {
            dashboard.handle_line(c, text, now)
        };
        (reply, c.is_shut_down())
    };
    let shown = if too_long {
        format!("{}...", text.chars().take(40).collect::<String>())
    } else {
        text.to_string()
    };
    shared.emit(Event::Dashboard(report::Dashboard {
        t: report::now(),
        conn,
        command: shown,
        reply: reply.lines.clone(),
    }));
    if !send(stream, &reply, counts) {
        return Err("write failed: the client is not reading");
    }
    if shut_down {
        let _ = stream.shutdown(std::net::Shutdown::Both);
        shared.say(|| "shutdown: the controller turned off".into());
        std::process::exit(0);
    }
    if reply.close {
        return Err("quit");
    }
    Ok(())
}

fn session(
    stream: &mut TcpStream,
    conn: u64,
    shared: &Shared,
    counts: &mut Counts,
) -> &'static str {
    if !send(stream, &Dashboard::greeting(), counts) {
        return "write failed";
    }
    let mut reader = match stream.try_clone() {
        Ok(r) => r,
        Err(_) => return "cannot read",
    };
    let mut dashboard = Dashboard::new();
    let mut chunk = [0u8; 4096];
    // The line so far (at most MAX_LINE bytes); `discarding`: a too-long line was
    // answered and its rest is skipped up to the next newline.
    let mut line: Vec<u8> = Vec::new();
    let mut discarding = false;
    loop {
        let n = match reader.read(&mut chunk) {
            Ok(0) => return "client closed",
            Ok(n) => n,
            Err(e) if e.kind() == ErrorKind::Interrupted => continue,
            Err(_) => return "read failed",
        };
        counts.rx += n as u64;
        let mut rest = &chunk[..n];
        while !rest.is_empty() {
            let end = rest.iter().position(|&b| b == b'\n');
            let part = &rest[..end.unwrap_or(rest.len())];
            rest = match end {
                Some(i) => &rest[i + 1..],
                None => &[],
            };
            if discarding {
                discarding = end.is_none();
                continue;
            }
            if line.len() + part.len() > MAX_LINE {
                let room = MAX_LINE - line.len();
                line.extend_from_slice(&part[..room.min(64)]);
                let r = answer(stream, conn, shared, &mut dashboard, &line, true, counts);
                line.clear();
                discarding = end.is_none();
                if let Err(reason) = r {
                    return reason;
                }
                continue;
            }
            line.extend_from_slice(part);
            if end.is_some() {
                let r = answer(stream, conn, shared, &mut dashboard, &line, false, counts);
                line.clear();
                if let Err(reason) = r {
                    return reason;
                }
            }
        }
    }
}

/// The operator's commands on standard input: what happens at the robot that no
/// dashboard command causes (a collision, the emergency stop button, the pendant's
/// remote/local switch).
pub const OPERATOR_HELP: &str = "operator commands: protective stop, emergency stop, \
system emergency stop, safeguard stop, fault, violation, release, local, remote, state, help";

/// Reads operator commands from standard input until its end (lines bounded at
/// `MAX_LINE` bytes).
fn operator(shared: &Shared) {
    let stdin = std::io::stdin();
    let mut input = stdin.lock();
    let mut line = Vec::new();
    loop {
        line.clear();
        match input
            .by_ref()
            .take(MAX_LINE as u64 + 1)
            .read_until(b'\n', &mut line)
        {
            Ok(0) | Err(_) => return,
            Ok(_) => {}
        }
        if line.len() > MAX_LINE && line.last() != Some(&b'\n') {
            // Skip the rest of an overlong line.
            let mut sink = Vec::new();
            while input
                .by_ref()
                .take(MAX_LINE as u64)
                .read_until(b'\n', &mut sink)
                .map(|n| n > 0 && sink.last() != Some(&b'\n'))
                .unwrap_or(false)
            {
                sink.clear();
            }
            crate::out::note("operator: line too long, ignored");
            continue;
        }
        let text = String::from_utf8_lossy(&line);
        let cmd = text.trim().to_ascii_lowercase();
        if cmd.is_empty() {
            continue;
        }
        let now = shared.now();
        let mut cell = shared.lock_cell();
        let c = cell.controller();
        let status = match cmd.as_str() {
            "protective stop" => {
                c.protective_stop(now);
                None
            }
            "emergency stop" => Some(SafetyStatus::RobotEmergencyStop),
            "system emergency stop" => Some(SafetyStatus::SystemEmergencyStop),
            "safeguard stop" => Some(SafetyStatus::SafeguardStop),
            "fault" => Some(SafetyStatus::Fault),
            "violation" => Some(SafetyStatus::Violation),
            "release" => {
                c.release_stop(now);
                None
            }
            "local" => {
                c.set_remote_control(false);
                None
            }
            "remote" => {
                c.set_remote_control(true);
                None
            }
            "state" => None,
            "help" => {
                drop(cell);
                shared.say(|| OPERATOR_HELP.into());
                continue;
            }
            _ => {
                drop(cell);
                crate::out::note(&format!(
                    "operator: unknown command {cmd:?}; {OPERATOR_HELP}"
                ));
                continue;
            }
        };
        if let Some(status) = status {
            c.safety_event(now, status);
        }
        let mode = c.robot_mode(now);
        let safety = c.safety_status(now);
        let program = c.program_state();
        let remote = if c.remote_control() {
            "remote"
        } else {
            "local"
        };
        drop(cell);
        shared.say(|| {
            format!(
                "operator: {cmd}: robot mode {mode}, safety {safety}, program {program}, {remote} control"
            )
        });
    }
}
