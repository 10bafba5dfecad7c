//! `ursock controller`: a virtual UR controller that unmodified clients drive. The
//! server is the library's ([`urscript_controller::net::Server`]): this module reads the
//! options, prints its events (human lines or `--json`), and takes the operator's
//! commands on standard input.
//!
//! The server's threads (its real-time loop among them) never wait for standard output:
//! each event is queued (at most [`OUTPUT_QUEUE`]) for a writer thread; when the queue
//! is full (nobody reads the output) the event is dropped and counted, and a `dropped`
//! event says how many once output resumes. A dashboard `shutdown`, SIGTERM or SIGINT
//! ends the process with status 0 after the `stopped` event, the last one.
//!
//! Once every port listens, `--ready-file` is written (atomically: a temporary file
//! renamed) and a `ready` event follows the `listening` ones. The exit statuses are
//! [`exit`]'s.

use std::io::{BufRead, Read};
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{mpsc, Arc};
use std::time::Duration;

use urscript_controller::net::{
    parse_host, Ports, Profile, Realtime, Server, ServerEvent, ServerOptions,
};
use urscript_controller::{
    operator_help, Config, Model, OperatorCommand, OperatorError, StopReason, MAX_LINE,
};

use crate::report::{self, Event};

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
    /// The interpreter socket's port (interpreter mode: a program that called
    /// `interpreter_mode()` runs the statements sent here, one per line, and answers each
    /// line `ack: ID: ...`, `discard: REASON: ...` or `state: N: ...`). Served for
    /// PolyScope 5.10 and later only, as on the controller.
    #[arg(long, default_value_t = 30020)]
    pub interpreter_port: u16,
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
    #[arg(long, default_value = "5.23.0")]
    pub polyscope: String,
    /// The serial number `get serial number` answers.
    #[arg(long, default_value = "20235500001", conflicts_with = "ursim")]
    pub serial: String,
    /// Where `load NAME.urp` and `load installation NAME` find files (NAME relative to
    /// DIR, or absolute inside it). Without it every load answers `File not found`.
    #[arg(long, value_name = "DIR")]
    pub programs: Option<PathBuf>,
    /// Start in local control: every command that acts is refused, as on a pendant not
    /// switched to remote control. (Standard input takes operator commands: `protective
    /// stop`, `emergency stop`, `release`, `local`, `remote`, `speed F`, `freedrive
    /// [q...]`, `state`, `help`, ...)
    #[arg(long)]
    pub local: bool,
    /// The pendant's remote control setting is off, as on a new robot and on URSim:
    /// every command is accepted, `is in remote control` answers false, and the
    /// operator's `local`/`remote` change nothing.
    #[arg(long, conflicts_with = "local")]
    pub remote_control_disabled: bool,
    /// Answer as URSim does, as UR's client libraries' CI runs it: programs are also
    /// found at `/ursim/programs/NAME` (NAME in `--programs DIR`), `default.installation`
    /// always loads, the remote control setting is off (as `--remote-control-disabled`)
    /// and `get serial number` answers 20175599999. Without `--programs`, the programs
    /// shipped with ursock: `default.installation`, `external_control.urp` (the External
    /// Control URCap's node; its host is `--urcap-host`, else 192.168.56.1:50002) and
    /// `wait.urp` (waits a second, over and over).
    #[arg(long, conflicts_with = "local")]
    pub ursim: bool,
    /// A URCap's installation preamble, written (as PolyScope does) at the top of every
    /// `.urp` program played; scripts clients send get none. Repeatable, in order.
    #[arg(long, value_name = "FILE")]
    pub preamble: Vec<PathBuf>,
    /// The arm from the start: its joints `q=[...]` and what it senses:
    /// `digital_in[3]=True`, `tcp_force=[...]`,
    /// `joint_temp[0]=41`... (`ursock robot --set help` lists every name). Repeatable.
    #[arg(long, value_name = "NAME=VALUE")]
    pub set: Vec<String>,
    /// One JSON event per line (docs/json-events.md): `listening`, then `connect`,
    /// `dashboard` (each command and its reply) and `close` for every client.
    #[arg(long)]
    pub json: bool,
    /// Refuse the dashboard's `shutdown` (answered `Failed to execute: shutdown`, or the
    /// local-control reply in local control) instead of ending the process; every other
    /// command is served as before.
    #[arg(long)]
    pub no_shutdown: bool,
    /// Real-time scheduling of the stepping thread: `auto` asks for SCHED_FIFO (priority
    /// 10), else nice -10, and for memory locked as touched (mlockall), and runs with
    /// whatever the host grants (said once: the `scheduling` event); `off` asks nothing.
    #[arg(long, default_value = "auto", value_parser = ["auto", "off"])]
    pub realtime: String,
    /// Once every port listens, write FILE (atomically: written beside it, then
    /// renamed) with each service's address as a JSON object, e.g.
    /// `{"dashboard":"127.0.0.1:29999","rtde":"127.0.0.1:30004"}`.
    #[arg(long, value_name = "FILE")]
    pub ready_file: Option<PathBuf>,
}

/// `ursock controller`'s exit statuses (stable: scripts and CI test them).
pub mod exit {
    /// The controller stopped: a dashboard `shutdown`, SIGTERM or SIGINT.
    pub const STOPPED: i32 = 0;
    /// Any other failure (the ready file cannot be written, a thread cannot start).
    pub const FAILED: i32 = 1;
    /// A bad option or value (the status clap gives a usage error).
    pub const BAD_OPTION: i32 = 2;
    /// A port is in use.
    pub const PORT_IN_USE: i32 = 3;
    /// A port cannot be listened on for another reason (the address is not this
    /// machine's, a privileged port).
    pub const CANNOT_LISTEN: i32 = 4;
}

/// Why `ursock controller` could not run: the message and its [`exit`] status.
#[derive(Debug)]
pub struct Failure {
    pub code: i32,
    pub message: String,
}

impl Failure {
    fn bad_option(message: String) -> Self {
        Failure {
            code: exit::BAD_OPTION,
            message,
        }
    }

    fn failed(message: String) -> Self {
        Failure {
            code: exit::FAILED,
            message,
        }
    }
}

/// The URSim profile's programs folder, shipped with `ursock` (`ursock/ursim/programs`,
/// plain XML there): `--ursim` without `--programs` writes them, gzip-compressed as
/// PolyScope saves them, into a folder of its own under the temporary directory, removed
/// when the controller stops.
pub const URSIM_PROGRAM_FILES: [(&str, &[u8]); 3] = [
    (
        "default.installation",
        include_bytes!("../../ursim/programs/default.installation"),
    ),
    (
        "external_control.urp",
        include_bytes!("../../ursim/programs/external_control.urp"),
    ),
    ("wait.urp", include_bytes!("../../ursim/programs/wait.urp")),
];

/// A programs folder written for this process, removed when dropped.
struct TempPrograms(PathBuf);

impl Drop for TempPrograms {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Writes [`URSIM_PROGRAM_FILES`], gzip-compressed, into a new folder under the
/// temporary directory.
fn write_ursim_programs() -> std::io::Result<TempPrograms> {
    use std::io::Write;
    let dir = std::env::temp_dir().join(format!("ursock-ursim-programs-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir)?;
    let folder = TempPrograms(dir);
    for (name, xml) in URSIM_PROGRAM_FILES {
        let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
        gz.write_all(xml)?;
        std::fs::write(folder.0.join(name), gz.finish()?)?;
    }
    Ok(folder)
}

/// Events waiting for standard output, at most: a second or so of a busy controller's
/// events (the server reports at most 5000 a second per client and for the program),
/// while a reader that stopped holds no thread of the server and costs at most this
/// many events of memory (each bounded by what it reports: a dashboard line 4 KiB, a
/// client's line 64 KiB, a program's socket bytes as the interpreter bounds them).
pub const OUTPUT_QUEUE: usize = 4096;

/// How long the `stopped` event may wait for standard output before the process ends
/// without it.
const FINAL_WAIT: Duration = Duration::from_secs(2);

/// What the writer thread prints.
enum Queued {
    Event(Event),
    /// The last event: printed, then `done` is told.
    Last(Event, mpsc::Sender<()>),
}

/// The writer thread: prints each queued event; before the next one after events were
/// dropped (or after a pause of 100 ms), a `dropped` event with their count.
fn writer(json: bool, queue: mpsc::Receiver<Queued>, dropped: Arc<AtomicU64>) {
    let say_dropped = || {
        let count = dropped.swap(0, Ordering::SeqCst);
        if count > 0 {
            print(
                json,
                &Event::Dropped(report::Dropped {
                    t: report::now(),
                    count,
                }),
            );
        }
    };
    loop {
        match queue.recv_timeout(Duration::from_millis(100)) {
            Ok(Queued::Event(e)) => {
                say_dropped();
                print(json, &e);
            }
            Ok(Queued::Last(e, done)) => {
                say_dropped();
                print(json, &e);
                let _ = done.send(());
                return;
            }
            Err(mpsc::RecvTimeoutError::Timeout) => say_dropped(),
            Err(mpsc::RecvTimeoutError::Disconnected) => return,
        }
    }
}

fn valid_version(v: &str) -> bool {
    let parts: Vec<&str> = v.split('.').collect();
    (3..=4).contains(&parts.len())
        && parts
            .iter()
            .all(|p| !p.is_empty() && p.len() <= 9 && p.bytes().all(|b| b.is_ascii_digit()))
}

/// A server event as a report event.
fn report_event(e: ServerEvent) -> Option<Event> {
    let t = report::now();
    Some(match e {
        ServerEvent::Listening { service, addr } => Event::Listening(report::Listening {
            t,
            addr: addr.to_string(),
            service: Some(service),
        }),
        ServerEvent::Connect {
            conn,
            service,
            peer,
        } => Event::Connect(report::Connect {
            t,
            conn,
            peer,
            service: Some(service),
        }),
        ServerEvent::Close {
            conn,
            reason,
            rx,
            tx,
        } => Event::Close(report::Close {
            t,
            conn,
            reason,
            rx,
            tx,
            refused_sets: 0,
        }),
        ServerEvent::Dashboard {
            conn,
            command,
            reply,
        } => Event::Dashboard(report::Dashboard {
            t,
            conn,
            command,
            reply,
        }),
        ServerEvent::Client {
            conn,
            service,
            event,
        } => Event::Client(report::Client {
            t,
            conn,
            service,
            what: event.what(),
            text: event.to_string(),
        }),
        ServerEvent::Program {
            what,
            name,
            line,
            column,
            text,
            reason,
        } => Event::Program(report::Program {
            t,
            what,
            name,
            line,
            column,
            text,
            reason: reason.map(StopReason::as_str),
        }),
        ServerEvent::Message(m) => crate::script::message_event(&m),
        ServerEvent::Call(c) => Event::Call(crate::script::call_event(&c, None)),
        ServerEvent::MoveStart(m) => Event::MoveStart(crate::script::move_start_event(&m)),
        ServerEvent::MoveEnd(m) => Event::MoveEnd(crate::script::move_end_event(&m, None)),
        ServerEvent::Output(o) => Event::Output(crate::script::output_event(&o)),
        ServerEvent::Tx { socket, bytes } => Event::tx(&socket, &bytes),
        ServerEvent::Rx { socket, bytes } => Event::rx(&socket, &bytes),
        ServerEvent::Note(text) => Event::note(text),
        ServerEvent::State {
            robot_mode,
            safety,
            program,
            reason,
        } => Event::State(report::State {
            t,
            robot_mode: robot_mode.to_string(),
            safety: safety.to_string(),
            program: program.to_string(),
            reason: reason.map(StopReason::as_str),
        }),
        ServerEvent::Suppressed {
            conn,
            count,
            interval,
        } => Event::Suppressed(report::Suppressed {
            t,
            conn,
            count,
            seconds: (interval.as_secs_f64() * 1e3).round() / 1e3,
        }),
        ServerEvent::Scheduling(s) => Event::Scheduling(report::Scheduling {
            t,
            policy: s.policy,
            memory_locked: s.memory_locked,
            refused: s.refused,
        }),
        ServerEvent::Late { lateness, interval } => Event::Late(report::Late {
            t,
            late_steps: lateness.late_steps,
            worst_ms: (lateness.worst.as_secs_f64() * 1e6).round() / 1e3,
            holds: lateness.holds,
            held_seconds: (lateness.held.as_secs_f64() * 1e3).round() / 1e3,
            seconds: (interval.as_secs_f64() * 1e3).round() / 1e3,
        }),
        _ => return None,
    })
}

/// Prints an event: its JSON line, or its lines for people (`[#conn]` in front).
fn print(json: bool, event: &Event) {
    if json {
        crate::out::line(&event.to_json());
        return;
    }
    let prefix = event.conn().map(|c| format!("[#{c}] ")).unwrap_or_default();
    for l in crate::listen::human(event, usize::MAX) {
        crate::out::line(&format!("{prefix}{l}"));
    }
}

/// Writes `text` to `path` atomically: into a temporary file beside it, then renamed
/// over it, so a reader sees either no file or the whole of it.
fn write_atomically(path: &std::path::Path, text: &str) -> std::io::Result<()> {
    let mut name = path.file_name().unwrap_or_default().to_os_string();
    name.push(format!(".{}.tmp", std::process::id()));
    let tmp = path.with_file_name(name);
    std::fs::write(&tmp, text)?;
    std::fs::rename(&tmp, path).inspect_err(|_| {
        let _ = std::fs::remove_file(&tmp);
    })
}

/// Runs the controller until a dashboard `shutdown`, SIGTERM or SIGINT.
pub fn run(opts: ControllerOptions) -> Result<(), Failure> {
    let model: Model = opts
        .model
        .parse()
        .map_err(|e| Failure::bad_option(format!("--model: {e}")))?;
    if !valid_version(&opts.polyscope) {
        return Err(Failure::bad_option(format!(
            "--polyscope {}: give a version like 5.21.0 or 5.21.0.1234567",
            opts.polyscope
        )));
    }
    if opts.serial.is_empty() || opts.serial.len() > 64 || opts.serial.contains(char::is_whitespace)
    {
        return Err(Failure::bad_option(format!(
            "--serial {:?}: give one word, like 20235500001",
            opts.serial
        )));
    }
    let urcap_host = match &opts.urcap_host {
        None => None,
        Some(h) => {
            Some(parse_host(h).map_err(|e| Failure::bad_option(format!("--urcap-host {h}: {e}")))?)
        }
    };
    let preamble = crate::script::read_preambles(&opts.preamble).map_err(Failure::bad_option)?;
    let Some(arm) = crate::script::arm_from_settings(&opts.set).map_err(Failure::bad_option)?
    else {
        return Ok(());
    };
    let stream = |port: u16| (!opts.no_streams).then_some(port);
    // URSim's programs folder: the one given, else (with --ursim) the shipped one.
    let ursim_programs = match (&opts.programs, opts.ursim) {
        (None, true) => Some(write_ursim_programs().map_err(|e| {
            Failure::failed(format!("cannot write the URSim programs folder: {e}"))
        })?),
        _ => None,
    };
    let programs = match &ursim_programs {
        Some(t) => Some(t.0.clone()),
        None => opts.programs.clone(),
    };
    let options = ServerOptions {
        bind: opts.bind.clone(),
        ports: Ports {
            dashboard: Some(opts.dashboard_port),
            primary: stream(opts.primary_port),
            secondary: stream(opts.secondary_port),
            realtime: stream(opts.realtime_port),
            rtde: stream(opts.rtde_port),
            // Served for PolyScope 5.10+ only (`Config::has_interpreter_mode`).
            interpreter: stream(opts.interpreter_port),
        },
        config: Config {
            model,
            polyscope: opts.polyscope.clone(),
            serial: opts.serial.clone(),
            remote_control: !opts.local,
            remote_control_enabled: !opts.remote_control_disabled,
            ..Config::default()
        },
        programs,
        urcap_host,
        profile: if opts.ursim {
            Profile::Ursim
        } else {
            Profile::Robot
        },
        allow_shutdown: !opts.no_shutdown,
        realtime: if opts.realtime == "off" {
            Realtime::Off
        } else {
            Realtime::Auto
        },
    };
    let json = opts.json;
    // Why the controller stops: a dashboard `shutdown` or a signal.
    let (shutdown_tx, shutdown) = mpsc::channel::<Stop>();
    {
        use signal_hook::consts::{SIGINT, SIGTERM};
        let mut signals = signal_hook::iterator::Signals::new([SIGTERM, SIGINT])
            .map_err(|e| Failure::failed(format!("cannot handle signals: {e}")))?;
        let tx = shutdown_tx.clone();
        std::thread::Builder::new()
            .name("signals".into())
            .spawn(move || {
                if let Some(signal) = signals.forever().next() {
                    let name = if signal == SIGINT {
                        "SIGINT"
                    } else {
                        "SIGTERM"
                    };
                    let _ = tx.send(Stop::Signal(name));
                }
            })
            .map_err(|e| Failure::failed(format!("cannot start the signal thread: {e}")))?;
    }
    let shutdown_tx = std::sync::Mutex::new(shutdown_tx);
    let (queue, queued) = mpsc::sync_channel::<Queued>(OUTPUT_QUEUE);
    let dropped = Arc::new(AtomicU64::new(0));
    {
        let dropped = Arc::clone(&dropped);
        std::thread::Builder::new()
            .name("output".into())
            .spawn(move || writer(json, queued, dropped))
            .map_err(|e| Failure::failed(format!("cannot start the output thread: {e}")))?;
    }
    let sink = queue.clone();
    let server = Server::start(options, move |e| {
        if e == ServerEvent::Shutdown {
            let tx = shutdown_tx.lock().unwrap_or_else(|p| p.into_inner());
            let _ = tx.send(Stop::Shutdown);
            return;
        }
        if let Some(event) = report_event(e) {
            // Never wait for the output: a full queue drops the event, counted.
            if sink.try_send(Queued::Event(event)).is_err() {
                dropped.fetch_add(1, Ordering::SeqCst);
            }
        }
    })
    .map_err(|e| {
        use std::io::ErrorKind;
        match e.kind() {
            ErrorKind::NotFound | ErrorKind::NotADirectory => {
                Failure::bad_option(format!("--programs: {e}"))
            }
            ErrorKind::AddrInUse => Failure {
                code: exit::PORT_IN_USE,
                message: e.to_string(),
            },
            _ => Failure {
                code: exit::CANNOT_LISTEN,
                message: e.to_string(),
            },
        }
    })?;
    server.with_cell(|cell, _| {
        cell.set_preamble(preamble);
        *cell.arm_mut() = arm;
    });
    // Every port listens: the `ready` event follows the `listening` ones (queued from
    // this thread, in order), and the ready file appears.
    let addrs: std::collections::BTreeMap<&'static str, String> = server
        .addrs()
        .iter()
        .map(|&(service, addr)| (service, addr.to_string()))
        .collect();
    if let Some(path) = &opts.ready_file {
        let text = serde_json::to_string(&addrs).unwrap_or_default();
        write_atomically(path, &format!("{text}\n"))
            .map_err(|e| Failure::failed(format!("--ready-file {}: {e}", path.display())))?;
    }
    let _ = queue.try_send(Queued::Event(Event::Ready(report::Ready {
        t: report::now(),
        addrs,
    })));
    let server = std::sync::Arc::new(server);
    {
        let server = std::sync::Arc::clone(&server);
        let out = queue.clone();
        let _ = std::thread::Builder::new()
            .name("operator".into())
            .spawn(move || operator(&server, json, &out));
    }
    let reason = match shutdown.recv() {
        Ok(Stop::Signal(name)) => {
            // As a dashboard `shutdown`: the program ends and every client is closed.
            server.shut_down();
            format!("signal: {name}")
        }
        Ok(Stop::Shutdown) | Err(_) => "shutdown: a dashboard client said shutdown".into(),
    };
    // The last event, after everything the shutdown closed; the process ends with
    // status 0 once it is out (or after FINAL_WAIT if standard output is stuck).
    let (done_tx, done) = mpsc::channel();
    let last = Event::Stopped(report::Stopped {
        t: report::now(),
        reason,
    });
    let mut last = Some(Queued::Last(last, done_tx));
    let start = std::time::Instant::now();
    while let Some(out) = last.take() {
        match queue.try_send(out) {
            Ok(()) => {
                let _ = done.recv_timeout(FINAL_WAIT);
            }
            Err(mpsc::TrySendError::Full(out)) if start.elapsed() < FINAL_WAIT => {
                last = Some(out);
                std::thread::sleep(Duration::from_millis(1));
            }
            Err(_) => {}
        }
    }
    drop(ursim_programs);
    std::process::exit(exit::STOPPED);
}

/// Why the controller stops.
enum Stop {
    /// A dashboard client said `shutdown`.
    Shutdown,
    /// The process got this signal.
    Signal(&'static str),
}

/// Reads operator commands from standard input until its end (lines bounded at
/// `MAX_LINE` bytes).
fn operator(server: &Server, json: bool, out: &mpsc::SyncSender<Queued>) {
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
        let said = match cmd.parse::<OperatorCommand>() {
            Ok(OperatorCommand::Help) => {
                if !json {
                    crate::out::line(&operator_help());
                }
                continue;
            }
            Err(e @ OperatorError::Unknown(_)) => {
                crate::out::note(&format!("operator: {e}"));
                continue;
            }
            Err(OperatorError::BadArgument(why)) => format!("refused: {why}"),
            Ok(command) => server.with_cell(move |cell, now| match command.apply(cell, now) {
                Err(why) => format!("refused: {why}"),
                Ok(()) => {
                    let c = cell.controller();
                    let mode = c.robot_mode(now);
                    let safety = c.safety_status(now);
                    let program = c.program_state();
                    let remote = if c.remote_control() {
                        "remote"
                    } else {
                        "local"
                    };
                    format!(
                        "robot mode {mode}, safety {safety}, program {program}, {remote} control"
                    )
                }
            }),
        };
        let l = server.lateness();
        let said = format!(
            "{said}; loop: {} steps late (worst {:.1} ms), {:.3} s held back in {} stalls",
            l.late_steps,
            l.worst.as_secs_f64() * 1e3,
            l.held.as_secs_f64(),
            l.holds
        );
        let event = Event::Operator(report::Operator {
            t: report::now(),
            command: cmd.clone(),
            text: said,
        });
        // In order with the server's events; the operator's thread may wait for the
        // output.
        let _ = out.send(Queued::Event(event));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use urscript_controller::net::ClientEvent;
    use urscript_controller::script_intake::Command;

    /// A client's typed event becomes the `client` event's `what` and `text`, in its
    /// JSON line and its line for people.
    #[test]
    fn client_events_print_their_kind_and_text() {
        let cases = [
            (
                "primary",
                ClientEvent::Program {
                    name: "pick".into(),
                },
                r#""service":"primary","what":"program","text":"pick"}"#,
                "primary program: pick",
            ),
            (
                "secondary",
                ClientEvent::Command(Command::SetSpeed(0.5)),
                r#""service":"secondary","what":"command","text":"SetSpeed(0.5)"}"#,
                "secondary command: SetSpeed(0.5)",
            ),
            (
                "rtde",
                ClientEvent::Inputs {
                    recipe: 1,
                    fields: vec!["speed_slider_mask".into()],
                    types: vec!["UINT32".into()],
                },
                r#""service":"rtde","what":"inputs","text":"recipe 1: speed_slider_mask:UINT32"}"#,
                "rtde inputs: recipe 1: speed_slider_mask:UINT32",
            ),
        ];
        for (service, event, json_tail, human) in cases {
            let Some(e) = report_event(ServerEvent::Client {
                conn: 3,
                service,
                event,
            }) else {
                panic!("a client event is reported");
            };
            let json = e.to_json();
            assert!(json.starts_with(r#"{"event":"client","t":"#), "{json}");
            assert!(
                json.ends_with(&format!(r#","conn":3,{json_tail}"#)),
                "{json}"
            );
            assert_eq!(crate::listen::human(&e, usize::MAX), [human]);
        }
    }
}
