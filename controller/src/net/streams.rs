//! The controller's real-time loop: one thread that runs the cell step by step (2 ms
//! e-Series, 8 ms CB3), services the running program's own sockets through the
//! interpreter's driver, and serves the streaming interfaces from one [`Status`] per
//! step: primary (30001) and secondary (30002) at 10 Hz with the robot messages on the
//! primary, realtime (30003) every step, RTDE (30004) at each client's frequency.
//!
//! Every client socket is non-blocking and owned by this thread. What a client does not
//! read waits in its queue; past [`MAX_BACKLOG`] bytes new state packages are skipped
//! for it (it sees a gap, as a client of a real controller that falls behind does) and
//! past [`MAX_QUEUE`] it is disconnected: a client that never reads slows nothing down.
//!
//! So a client that never reads holds at most [`MAX_BACKLOG`] bytes and one package
//! (realtime, secondary, RTDE data: packages are skipped, and after [`MAX_STALL`] of
//! taking nothing it is dropped), or at most [`MAX_QUEUE`] bytes and one message
//! before it is dropped (what it must get: the primary's robot messages and version
//! message, RTDE replies). What a client sends is read [`READ_CHUNK`] bytes at a time into one buffer
//! of the loop, at most [`MAX_READS_PER_STEP`] reads a step, and kept only as far as its
//! intake or RTDE session bounds allow.

use std::collections::VecDeque;
use std::io::{ErrorKind, Read, Write};
use std::net::{Shutdown, TcpListener, TcpStream};
use std::sync::{mpsc, Arc};
use std::time::Duration;

use urscript_interp::drive::{connect_stream, describe_connect_error, Activity, Driver, Options};
use urscript_interp::{Event as ProgramEvent, MessageKind};

use super::{ServerEvent as Event, Shared};
use crate::primary::{self, RobotMessage};
use crate::realtime;
use crate::rtde::{InputRegistry, RtdeEvent, RtdeSession};
use crate::script_intake::{Command, Intake, ScriptIntake};
use crate::{CellEvent, Ended, Status, Submitted};

/// Clients of the streaming interfaces served at once (all four together); more are
/// accepted and closed at once. They cost no thread; the bound caps the memory their
/// queues may take (`MAX_CLIENTS` x [`MAX_QUEUE`]) and the work of one step.
pub const MAX_CLIENTS: usize = 64;
/// Queued bytes past which a client's state packages are skipped: about 200 realtime
/// packages (0.4 s at 500 Hz), on top of what the kernel's socket buffers hold.
pub const MAX_BACKLOG: usize = 256 * 1024;
/// Queued bytes past which a client is disconnected: sixteen times the backlog, room
/// for bursts of robot messages and RTDE replies to a client that reads late.
pub const MAX_QUEUE: usize = 4 * 1024 * 1024;
/// How long a client may take no byte at all while its packages are being skipped
/// (its queue past [`MAX_BACKLOG`]) before it is dropped ("the client stopped
/// reading"): a client that reads, however slowly, stays; one that has stopped frees
/// its slot among the [`MAX_CLIENTS`]. By then it has missed the kernel's buffers, the
/// backlog and 5 s more of packages, so it could not have gone on anyway. UR does not
/// document a limit; 5 s is our choice, longer than any pause of a working client.
pub const MAX_STALL: Duration = Duration::from_secs(5);
/// Bytes read from one client at a time (the loop's one read buffer).
pub const READ_CHUNK: usize = 64 * 1024;
/// The running program's connects (`socket_open`, an XML-RPC call) in progress at once.
/// Each runs in a thread of its own (`connect`), so a server that does not answer (a
/// dropped SYN waits out the connect timeout, 2 s, per address) holds up only the
/// program thread that waits for it, never the loop and with it every stream and the
/// dashboard. More wait their turn (at most one per program thread); those of a program
/// that ended are dropped. Eight is more than programs open at once.
pub const MAX_CONNECTING: usize = 8;
/// Reads of one client in one step, at most: 1 MiB a step (500 MiB/s at 2 ms steps) is
/// more than any client sends, and a peer that floods faster than the loop reads cannot
/// keep the loop reading instead of stepping. The rest waits in the kernel for the next
/// step.
pub const MAX_READS_PER_STEP: usize = 16;

/// Which interface a client is on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Service {
    Primary,
    Secondary,
    Realtime,
    Rtde,
}

impl Service {
    pub(crate) fn name(self) -> &'static str {
        match self {
            Service::Primary => "primary",
            Service::Secondary => "secondary",
            Service::Realtime => "realtime",
            Service::Rtde => "rtde",
        }
    }
}

struct Client {
    conn: u64,
    service: Service,
    stream: TcpStream,
    intake: ScriptIntake,
    rtde: Option<RtdeSession>,
    queue: Vec<u8>,
    rx: u64,
    tx: u64,
    gone: Option<&'static str>,
    /// Controller time of the last flush that wrote something (or found nothing to
    /// write).
    last_write: Duration,
}

impl Client {
    /// Queues a state package unless the client is behind; drops a client that took
    /// nothing for [`MAX_STALL`] while behind.
    fn offer(&mut self, bytes: &[u8], now: Duration) {
        if self.queue.len() <= MAX_BACKLOG {
            self.queue.extend_from_slice(bytes);
        } else if now.saturating_sub(self.last_write) > MAX_STALL {
            self.gone = Some("the client stopped reading");
        }
    }

    /// Queues bytes the client must get (a message, a reply).
    fn push(&mut self, bytes: &[u8]) {
        self.queue.extend_from_slice(bytes);
        if self.queue.len() > MAX_QUEUE {
            self.gone = Some("the client stopped reading");
        }
    }

    fn flush(&mut self, now: Duration) {
        let mut written = 0;
        while written < self.queue.len() {
            match self.stream.write(&self.queue[written..]) {
                Ok(0) => {
                    self.gone = Some("write failed");
                    break;
                }
                Ok(n) => written += n,
                Err(e) if e.kind() == ErrorKind::WouldBlock => break,
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(_) => {
                    self.gone = Some("write failed");
                    break;
                }
            }
        }
        self.tx += written as u64;
        self.queue.drain(..written);
        if written > 0 || self.queue.is_empty() {
            self.last_write = now;
        }
    }
}

/// The listeners of the streaming interfaces (each may be absent).
pub(crate) struct Listeners {
    pub(crate) primary: Option<TcpListener>,
    pub(crate) secondary: Option<TcpListener>,
    pub(crate) realtime: Option<TcpListener>,
    pub(crate) rtde: Option<TcpListener>,
}

/// Runs the loop until the server stops.
pub(crate) fn run(shared: &Arc<Shared>, listeners: Listeners) {
    let (done_tx, done_rx) = mpsc::channel();
    let mut lp = Loop {
        clients: Vec::new(),
        driver: Driver::new(Options::default()),
        connects: Connects {
            timeout: Options::default().connect_timeout,
            generation: 0,
            waiting: VecDeque::new(),
            in_flight: 0,
            done_tx,
            done_rx,
        },
        registry: InputRegistry::new(),
        next_state: Duration::ZERO,
        safety: None,
        state_key: None,
        buf: vec![0u8; READ_CHUNK],
        frame: Vec::new(),
    };
    let listeners = [
        (listeners.primary, Service::Primary),
        (listeners.secondary, Service::Secondary),
        (listeners.realtime, Service::Realtime),
        (listeners.rtde, Service::Rtde),
    ];
    for (l, _) in &listeners {
        if let Some(l) = l {
            let _ = l.set_nonblocking(true);
        }
    }
    let step = {
        let cell = shared.cell.lock().unwrap_or_else(|p| p.into_inner());
        cell.step_time()
    };
    // The controller's clock counts whole steps: each round runs at the last step
    // boundary at or before the controller's time, so that the streams' timestamps are
    // whole steps and RTDE's schedule (kept in the same steps) sends at every step that
    // is due however late the thread woke. A stall of the host is held back, not run
    // through (see `clock`): what the clients sent meanwhile is read at the step after
    // the last one.
    let mut last: Option<Duration> = None;
    while !shared.stopped() {
        let tick = step_boundary(shared.clock.tick(), step);
        if let Some(last) = last.filter(|l| tick <= *l) {
            // Woke before the next boundary (a spurious wake-up): sleep on.
            std::thread::sleep((last + step).saturating_sub(shared.now()).min(step));
            continue;
        }
        for (l, service) in &listeners {
            if let Some(l) = l {
                lp.accept(shared, l, *service);
            }
        }
        lp.read_clients(shared);
        lp.step(shared, tick);
        for c in &mut lp.clients {
            c.flush(tick);
        }
        lp.drop_gone(shared);
        last = Some(tick);
        let next = tick + step;
        let now = shared.now();
        if next > now {
            std::thread::sleep((next - now).min(step));
        }
    }
}

/// The last multiple of `step` at or before `t`.
fn step_boundary(t: Duration, step: Duration) -> Duration {
    let step = step.as_nanos().max(1);
    let n = t.as_nanos();
    Duration::from_nanos(u64::try_from(n - n % step).unwrap_or(u64::MAX))
}

/// A connect the program asked for, not started yet.
struct ConnectRequest {
    generation: u64,
    socket_name: String,
    host: String,
    port: u16,
}

/// A connect's outcome, from its thread.
struct Connected {
    generation: u64,
    socket_name: String,
    result: Result<TcpStream, String>,
}

/// The program's connects, each in a thread of its own (see [`MAX_CONNECTING`]).
struct Connects {
    timeout: Duration,
    /// Counts the programs: an outcome for an earlier one is dropped.
    generation: u64,
    waiting: VecDeque<ConnectRequest>,
    in_flight: usize,
    done_tx: mpsc::Sender<Connected>,
    done_rx: mpsc::Receiver<Connected>,
}

impl Connects {
    /// A program started or ended: what its connects bring is no one's.
    fn next_program(&mut self) {
        self.generation += 1;
        self.waiting.clear();
    }

    /// Hands the finished connects to the program, and starts waiting ones.
    fn service(&mut self, driver: &mut Driver, mut machine: Option<&mut urscript_interp::Machine>) {
        while let Ok(done) = self.done_rx.try_recv() {
            self.in_flight = self.in_flight.saturating_sub(1);
            match machine.as_deref_mut() {
                Some(m) if done.generation == self.generation => {
                    driver.adopt(m, &done.socket_name, done.result);
                }
                _ => {
                    if let Ok(stream) = done.result {
                        let _ = stream.shutdown(Shutdown::Both);
                    }
                }
            }
        }
        while self.in_flight < MAX_CONNECTING {
            let Some(r) = self.waiting.pop_front() else {
                break;
            };
            let tx = self.done_tx.clone();
            let timeout = self.timeout;
            let name = r.socket_name.clone();
            let spawned = std::thread::Builder::new()
                .name("connect".into())
                .spawn(move || {
                    let result = connect_stream(&r.host, r.port, timeout)
                        .map_err(|e| describe_connect_error(&r.host, r.port, &e));
                    let _ = tx.send(Connected {
                        generation: r.generation,
                        socket_name: r.socket_name,
                        result,
                    });
                });
            match spawned {
                Ok(_) => self.in_flight += 1,
                Err(e) => {
                    if let Some(m) = machine.as_deref_mut() {
                        driver.adopt(m, &name, Err(format!("cannot start a thread: {e}")));
                    }
                }
            }
        }
    }
}

struct Loop {
    clients: Vec<Client>,
    driver: Driver,
    connects: Connects,
    /// Which RTDE client owns which input field.
    registry: InputRegistry,
    next_state: Duration,
    /// The safety status the primary clients were last told of.
    safety: Option<crate::SafetyStatus>,
    /// The modes of the last state message.
    state_key: Option<(crate::RobotMode, crate::SafetyStatus, crate::ProgramState)>,
    buf: Vec<u8>,
    frame: Vec<u8>,
}

impl Loop {
    fn accept(&mut self, shared: &Shared, listener: &TcpListener, service: Service) {
        loop {
            let (stream, peer) = match listener.accept() {
                Ok(s) => s,
                Err(e) if e.kind() == ErrorKind::Interrupted => continue,
                Err(_) => return, // WouldBlock, or out of descriptors: next round
            };
            if self.clients.len() >= MAX_CLIENTS {
                shared.emit(Event::Note(format!(
                    "{peer}: {} refused, {MAX_CLIENTS} stream clients are already connected",
                    service.name()
                )));
                continue;
            }
            let _ = stream.set_nonblocking(true);
            let _ = stream.set_nodelay(true);
            let conn = shared.next_conn();
            shared.emit(Event::Connect {
                conn,
                service: service.name(),
                peer: peer.to_string(),
            });
            let mut client = Client {
                conn,
                service,
                stream,
                intake: ScriptIntake::new(),
                rtde: (service == Service::Rtde)
                    .then(|| RtdeSession::new(shared.config(), &mut self.registry)),
                queue: Vec::new(),
                rx: 0,
                tx: 0,
                gone: None,
                last_write: shared.now(),
            };
            if matches!(service, Service::Primary | Service::Secondary) {
                self.frame.clear();
                primary::encode_version(&mut self.frame, shared.config());
                client.push(&self.frame);
            }
            self.clients.push(client);
        }
    }

    fn read_clients(&mut self, shared: &Shared) {
        // The buffer is lent out while `received` (which needs `&mut self`) runs: no
        // copy of the bytes per read.
        let mut buf = std::mem::take(&mut self.buf);
        for i in 0..self.clients.len() {
            for _ in 0..MAX_READS_PER_STEP {
                let c = &mut self.clients[i];
                if c.gone.is_some() {
                    break;
                }
                let n = match c.stream.read(&mut buf) {
                    Ok(0) => {
                        c.gone = Some("client closed");
                        break;
                    }
                    Ok(n) => n,
                    Err(e) if e.kind() == ErrorKind::Interrupted => continue,
                    Err(e) if e.kind() == ErrorKind::WouldBlock => break,
                    Err(_) => {
                        c.gone = Some("read failed");
                        break;
                    }
                };
                c.rx += n as u64;
                self.received(shared, i, &buf[..n]);
                if n < buf.len() {
                    break;
                }
            }
        }
        self.buf = buf;
    }

    /// Bytes from client `i`.
    fn received(&mut self, shared: &Shared, i: usize, bytes: &[u8]) {
        let now = shared.now();
        let (conn, service) = (self.clients[i].conn, self.clients[i].service);
        if service == Service::Rtde {
            let c = &mut self.clients[i];
            let Some(session) = c.rtde.as_mut() else {
                return;
            };
            if let Err(e) = session.handle_received(&mut self.registry, bytes) {
                if e.is_fatal() {
                    c.gone = Some("RTDE protocol error");
                }
            }
            let mut inputs = Vec::new();
            while let Some(e) = session.poll_event() {
                match e {
                    RtdeEvent::Inputs { inputs: set, .. } => inputs.push(set),
                    other => {
                        let (what, text) = rtde_event(&other);
                        shared.emit(client_event(conn, service, what, text));
                    }
                }
            }
            let out = session.take_outbox();
            c.push(&out);
            if !inputs.is_empty() {
                let mut cell = shared.lock_cell();
                for set in &inputs {
                    cell.apply(set);
                }
            }
            return;
        }
        let items = self.clients[i].intake.push(bytes);
        for item in items {
            match item {
                Ok(Intake::Program { name, source }) => {
                    shared.emit(client_event(conn, service, "program", name));
                    shared.lock_cell().submit(Submitted::Program(source), now);
                }
                Ok(Intake::Secondary { name, source }) => {
                    shared.emit(client_event(conn, service, "secondary", name));
                    shared.lock_cell().submit(Submitted::Secondary(source), now);
                }
                Ok(Intake::Line(line)) => {
                    shared.emit(client_event(conn, service, "line", line.clone()));
                    shared
                        .lock_cell()
                        .submit(Submitted::Program(format!("{line}\n")), now);
                }
                Ok(Intake::Command(cmd)) => {
                    shared.emit(client_event(conn, service, "command", format!("{cmd:?}")));
                    let mut cell = shared.lock_cell();
                    let c = cell.controller();
                    let _ = match cmd {
                        Command::PowerOn => c.power_on(now),
                        Command::PowerOff => c.power_off(now),
                        Command::BrakeRelease => c.brake_release(now),
                        Command::UnlockProtectiveStop => c.request_unlock_protective_stop(now),
                        Command::StopProgram => c.stop(now),
                        Command::SetSpeed(f) => {
                            cell.apply(&crate::Inputs {
                                speed_slider_fraction: Some(f),
                                ..Default::default()
                            });
                            Ok(())
                        }
                    };
                }
                Err(e) => shared.emit(client_event(conn, service, "refused", e.to_string())),
            }
        }
    }

    /// One step: the cell runs to `now`, the program's sockets are serviced, and every
    /// stream gets what is due.
    fn step(&mut self, shared: &Arc<Shared>, now: Duration) {
        let mut messages: Vec<RobotMessage> = Vec::new();
        let status = {
            let mut cell = shared.lock_cell();
            cell.advance(now);
            let emit = |e: Event| shared.emit(e);
            while let Some(event) = cell.poll_event() {
                match event {
                    CellEvent::Program(e) => {
                        match &e {
                            ProgramEvent::Message(m) => {
                                emit(Event::Message(m.clone()));
                                messages.push(robot_message(m));
                            }
                            ProgramEvent::Call(c) => {
                                emit(Event::Call(c.clone()));
                            }
                            ProgramEvent::MoveStart(m) => emit(Event::MoveStart(m.clone())),
                            ProgramEvent::MoveEnd(m) => emit(Event::MoveEnd(m.clone())),
                            ProgramEvent::Output(o) => emit(Event::Output(o.clone())),
                            _ => {}
                        }
                        match cell.machine_mut() {
                            // A connect must not block the loop: a thread makes it.
                            Some(_) if matches!(e, ProgramEvent::Connect { .. }) => {
                                if let ProgramEvent::Connect {
                                    socket_name,
                                    host,
                                    port,
                                } = e
                                {
                                    self.connects.waiting.push_back(ConnectRequest {
                                        generation: self.connects.generation,
                                        socket_name,
                                        host,
                                        port,
                                    });
                                }
                            }
                            Some(m) => self.driver.handle_event(m, e, &mut |a| show(&emit, a)),
                            // The program has ended: what it sent last still goes
                            // out, then its sockets close.
                            None => self.driver.handle_event_after_end(e),
                        }
                    }
                    CellEvent::ProgramStarted { name } => {
                        self.connects.next_program();
                        emit(program_event("started", &name, None, None, None));
                        messages.push(RobotMessage::program_started(&name));
                    }
                    CellEvent::ProgramEnded { name, how } => {
                        let (what, line, column, text) = match &how {
                            Ended::Finished => ("finished", None, None, None),
                            Ended::Halted => ("halted", None, None, None),
                            Ended::Stopped => ("stopped", None, None, None),
                            Ended::Error(e) => (
                                "error",
                                Some(e.line()),
                                Some(e.column()),
                                Some(e.message().to_string()),
                            ),
                        };
                        emit(program_event(what, &name, line, column, text.clone()));
                        if let Ended::Error(e) = &how {
                            messages.push(RobotMessage::RuntimeException {
                                line: i32::try_from(e.line()).unwrap_or(i32::MAX),
                                column: i32::try_from(e.column()).unwrap_or(i32::MAX),
                                text: controller_text(e.message()).to_string(),
                            });
                        }
                        messages.push(RobotMessage::program_stopped(&name));
                        self.driver.close_all();
                        self.connects.next_program();
                    }
                    CellEvent::Refused { line, column, text } => {
                        let at = (line > 0).then_some(line);
                        emit(program_event(
                            "refused",
                            "",
                            at,
                            at.map(|_| column),
                            Some(text.clone()),
                        ));
                        messages.push(if line > 0 {
                            RobotMessage::RuntimeException {
                                line: i32::try_from(line).unwrap_or(i32::MAX),
                                column: i32::try_from(column).unwrap_or(i32::MAX),
                                text,
                            }
                        } else {
                            RobotMessage::text(&text)
                        });
                    }
                    CellEvent::NeedProgram { name, path } => {
                        // Reading, translating and fetching External Control scripts
                        // take time: the streams go on meanwhile.
                        let shared = Arc::clone(shared);
                        let spawned = std::thread::Builder::new()
                            .name("load-program".into())
                            .spawn(move || {
                                let result = super::fetch::load(
                                    &shared,
                                    &shared.program_file(&path).to_string_lossy(),
                                );
                                let now = shared.now();
                                let mut cell = shared.lock_cell();
                                match result {
                                    Ok(script) => cell.start_loaded(script, now),
                                    Err(why) => cell.refuse_loaded(format!("{name}: {why}"), now),
                                }
                            });
                        if let Err(e) = spawned {
                            cell.refuse_loaded(format!("cannot start a thread: {e}"), now);
                        }
                    }
                }
            }
            self.connects.service(&mut self.driver, cell.machine_mut());
            if let Some(m) = cell.machine_mut() {
                self.driver.poll_sockets(m, &mut |a| show(&emit, a));
            }
            let mut status = cell.status();
            // The step's time (the dashboard's thread may have advanced the cell to the
            // wall clock since this step's boundary).
            status.time = now.as_secs_f64();
            status
        };
        // A change of the safety status reaches the primary clients as the controller's
        // safety mode message; a protective stop also as an error code of level
        // WARNING (2), which UR's client library treats as a failed script unless told
        // to ignore warnings. The code (209, argument 0) is our choice: UR does not
        // document the code a protective stop reports.
        // They go before the `PROGRAM_XXX_STOPPED` of a program the stop ended this step.
        if self.safety.is_some_and(|s| s != status.safety) {
            let mut safety = vec![RobotMessage::SafetyMode {
                code: 0,
                argument: 0,
                safety: status.safety,
                report_data_type: 0,
                report_data: 0,
            }];
            if status.safety == crate::SafetyStatus::ProtectiveStop {
                safety.push(RobotMessage::ErrorCode {
                    code: 209,
                    argument: 0,
                    report_level: 2,
                    data_type: 0,
                    data: 0,
                    text: "Protective stop".into(),
                });
            }
            let at = messages
                .iter()
                .position(|m| {
                    matches!(m, RobotMessage::Key { title, .. } if title == primary::PROGRAM_STOPPED)
                })
                .unwrap_or(messages.len());
            messages.splice(at..at, safety);
        }
        self.safety = Some(status.safety);
        self.stream(shared, &status, &messages, now);
    }

    fn stream(
        &mut self,
        shared: &Shared,
        status: &Status,
        messages: &[RobotMessage],
        now: Duration,
    ) {
        let config = shared.config();
        // Robot messages go to the primary clients at once.
        if !messages.is_empty() {
            self.frame.clear();
            for m in messages {
                primary::encode_robot_message(&mut self.frame, m, status.time);
            }
            for c in self
                .clients
                .iter_mut()
                .filter(|c| c.service == Service::Primary)
            {
                c.push(&self.frame);
            }
        }
        // Realtime: every step.
        if self.clients.iter().any(|c| c.service == Service::Realtime) {
            self.frame.clear();
            realtime::encode_realtime(&mut self.frame, status, config);
            for c in self
                .clients
                .iter_mut()
                .filter(|c| c.service == Service::Realtime)
            {
                c.offer(&self.frame, now);
            }
        }
        // Primary and secondary: 10 Hz, and at once when the robot mode, the safety
        // status or the program state changed (a client that acts on a change, e.g.
        // waits for a protective stop to clear, reads it from the robot mode data).
        let key = (status.robot_mode, status.safety, status.program_state);
        let changed = self.state_key.is_some_and(|k| k != key);
        self.state_key = Some(key);
        if now >= self.next_state || changed {
            self.next_state = now + primary::STATE_PERIOD;
            self.frame.clear();
            primary::encode_robot_state(&mut self.frame, status, config);
            for c in self
                .clients
                .iter_mut()
                .filter(|c| matches!(c.service, Service::Primary | Service::Secondary))
            {
                c.offer(&self.frame, now);
            }
        }
        // RTDE: each session at its own frequency (the session skips packages itself
        // while its outbox is full).
        for c in self
            .clients
            .iter_mut()
            .filter(|c| c.service == Service::Rtde)
        {
            if let Some(s) = c.rtde.as_mut() {
                s.on_step(status, now);
                let out = s.take_outbox();
                c.offer(&out, now);
            }
        }
    }

    fn drop_gone(&mut self, shared: &Shared) {
        let mut i = 0;
        while i < self.clients.len() {
            if let Some(reason) = self.clients[i].gone {
                let mut c = self.clients.swap_remove(i);
                if let Some(s) = c.rtde.as_mut() {
                    s.close(&mut self.registry);
                }
                let _ = c.stream.shutdown(Shutdown::Both);
                shared.emit(Event::Close {
                    conn: c.conn,
                    reason: reason.to_string(),
                    rx: c.rx,
                    tx: c.tx,
                });
            } else {
                i += 1;
            }
        }
    }
}

/// What the program's sockets did, as events.
fn show(emit: &impl Fn(Event), a: Activity<'_>) {
    match a {
        Activity::Received { socket_name, bytes } => emit(Event::Rx {
            socket: socket_name.to_string(),
            bytes: bytes.to_vec(),
        }),
        Activity::PeerClosed { socket_name } => emit(Event::Note(format!(
            "the server closed the connection of socket {socket_name:?}"
        ))),
        Activity::SendFailed {
            socket_name,
            reason,
        } => emit(Event::Note(format!("socket {socket_name:?}: {reason}"))),
        Activity::Event(ProgramEvent::Transmit { socket_name, bytes }) => emit(Event::Tx {
            socket: socket_name.to_string(),
            bytes: bytes.clone(),
        }),
        _ => {}
    }
}

fn robot_message(m: &urscript_interp::Message) -> RobotMessage {
    match &m.kind {
        MessageKind::Popup {
            title,
            warning,
            error,
            blocking,
            ..
        } => RobotMessage::Popup {
            request_id: 0,
            requested_type: 0,
            warning: *warning,
            error: *error,
            blocking: *blocking,
            title: title.clone(),
            text: m.text.clone(),
        },
        _ => RobotMessage::text(&m.text),
    }
}

fn program_event(
    what: &'static str,
    name: &str,
    line: Option<u32>,
    column: Option<u32>,
    text: Option<String>,
) -> Event {
    Event::Program {
        what,
        name: name.to_string(),
        line,
        column,
        text,
    }
}

fn client_event(conn: u64, service: Service, what: &'static str, text: String) -> Event {
    Event::Client {
        conn,
        service: service.name(),
        what,
        text,
    }
}

/// An RTDE session's event as a `client` event's `what` and `text`.
fn rtde_event(e: &RtdeEvent) -> (&'static str, String) {
    match e {
        RtdeEvent::ProtocolVersion {
            requested,
            accepted,
        } => (
            "protocol",
            format!(
                "version {requested} {}",
                if *accepted { "accepted" } else { "refused" }
            ),
        ),
        RtdeEvent::OutputSetup {
            recipe,
            frequency,
            fields,
            types,
        } => (
            "outputs",
            format!(
                "recipe {recipe} at {frequency} Hz: {}",
                fields
                    .iter()
                    .zip(types)
                    .map(|(f, t)| format!("{f}:{t}"))
                    .collect::<Vec<_>>()
                    .join(",")
            ),
        ),
        RtdeEvent::InputSetup {
            recipe,
            fields,
            types,
        } => (
            "inputs",
            format!(
                "recipe {recipe}: {}",
                fields
                    .iter()
                    .zip(types)
                    .map(|(f, t)| format!("{f}:{t}"))
                    .collect::<Vec<_>>()
                    .join(",")
            ),
        ),
        RtdeEvent::Started { accepted } => (
            "start",
            if *accepted {
                "started"
            } else {
                "refused: no recipe"
            }
            .to_string(),
        ),
        RtdeEvent::Paused => ("pause", "paused".to_string()),
        RtdeEvent::Inputs { recipe, .. } => ("inputs", format!("recipe {recipe}")),
        RtdeEvent::TextMessage {
            level,
            message,
            source,
        } => ("text", format!("[{level}] {source}: {message}")),
        RtdeEvent::Error(e) => ("error", e.to_string()),
    }
}

/// The controller's own text of an error: the interpreter's message starts with it
/// (`compile_error_name_not_found:NAME:`) and may add an explanation for people after a
/// space, which the controller does not send.
fn controller_text(message: &str) -> &str {
    if message.starts_with("compile_error") || message.starts_with("syntax_error") {
        message.split(' ').next().unwrap_or(message)
    } else {
        message
    }
}
