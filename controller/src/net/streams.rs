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
//! message, RTDE replies).
//!
//! The work of one step is budgeted, so that no client's flood holds the loop past its
//! step: a client's bytes are read at most once a step, at most its fair share of
//! [`STEP_READ_BUDGET`] (at least [`MIN_READ_SHARE`]), and kept only as far as its
//! intake or RTDE session bounds allow; the script items they complete (lines,
//! commands, programs) wait in the client's queue and at most its fair share of
//! [`STEP_ITEM_BUDGET`] (at least [`MIN_ITEM_SHARE`]) of them are done a step, the
//! client not read again until its queue is empty, and at most [`STEP_START_BUDGET`]
//! programs of all clients are handed a step to the thread that compiles them (the
//! clients take turns being first; see [`compile`](super::compile): the loop never
//! compiles, the client's later items wait for its program to start). Within one step's items of one
//! client only the last program (or bare line) starts, as the others would be stopped
//! before their first step, and only the last `set speed` is applied; of one step's
//! RTDE input packages of one recipe only the last is applied. A client's RTDE data
//! packages are made within its fair share of [`STEP_OUTPUT_BUDGET`] (at least
//! [`MIN_OUTPUT_SHARE`]), and not at all while its queue is past [`MAX_BACKLOG`]. The
//! fair shares are over the clients that sent something the step before (reads), over
//! the clients (items), over the RTDE clients (output). Events are
//! reported at most [`MAX_EVENTS_PER_INTERVAL`] per client (and for the running
//! program) per [`EVENT_INTERVAL`]; the others are counted and reported as one
//! [`ServerEvent::Suppressed`](super::ServerEvent::Suppressed) at the interval's end.
//!
//! When [`MAX_CLIENTS`] are connected, a newcomer evicts the longest idle client if it
//! has been idle at least [`EVICT_IDLE`](super::EVICT_IDLE): idle means no byte received
//! from it and no byte written to it (taken by it). A reader that takes its packages is
//! active; a socket that neither sends nor reads is idle.

use std::collections::VecDeque;
use std::io::{ErrorKind, Read, Write};
use std::net::{Shutdown, TcpListener, TcpStream};
use std::sync::{mpsc, Arc};
use std::time::Duration;

use urscript_interp::drive::{connect_stream, describe_connect_error, Activity, Driver, Options};
use urscript_interp::{Event as ProgramEvent, MessageKind};

use super::compile::{Compiles, Job};
use super::owner::{Owner, Request};
use super::{ClientEvent, Lateness, ServerEvent as Event, Shared, EVICT_IDLE};
use crate::primary::{self, RobotMessage};
use crate::realtime;
use crate::rtde::{InputRegistry, RtdeEvent, RtdeSession};
use crate::script_intake::{Command, Intake, IntakeError, ScriptIntake};
use crate::{CellEvent, Ended, Status};

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

/// Connects in progress for the secondary program waiting for the network (threads of
/// their own, as [`MAX_CONNECTING`]): 2, as UR allows only quick calls there (a socket
/// and an XML-RPC server at once); more wait their turn.
pub const MAX_SECONDARY_CONNECTING: usize = 2;
/// Bytes read from the stream clients in one step, each client reading at most its
/// fair share (this over the number of clients that sent something the step before, at
/// least [`MIN_READ_SHARE`]) in one read: 2 MB/s at 2 ms steps (0.5 MB/s at CB3's
/// 8 ms), more than clients send (a 100 KiB driver script comes in 50 ms, the largest
/// program, 4 MiB, in two seconds), while a flood of small RTDE packages or script
/// lines cannot keep the loop parsing instead of stepping (a slow host's debug build
/// included). The rest waits in the kernel for the next step.
pub const STEP_READ_BUDGET: usize = 4 * 1024;
/// The least a client may read in one step however many clients send: 512 bytes, 256
/// KB/s at 2 ms steps, more than a client streaming a large RTDE input recipe at 500 Hz
/// sends; with [`MAX_CLIENTS`] flooding the loop reads at most 32 KiB a step.
pub const MIN_READ_SHARE: usize = 512;
/// Bytes of RTDE data packages made for the RTDE clients in one step, each client's
/// fair share this over their number, at least [`MIN_OUTPUT_SHARE`]: a client whose
/// packages of one step took more than its share gets none until its share has paid
/// for them (it sees a gap, as a client that falls behind does). 128 KiB a step is
/// 64 MB/s at 2 ms steps, ten times what one client of the largest recipe at 500 Hz
/// takes, while many clients of many large recipes cannot keep the loop encoding.
pub const STEP_OUTPUT_BUDGET: usize = 128 * 1024;
/// The least share of [`STEP_OUTPUT_BUDGET`] an RTDE client gets a step: 1 KiB, a
/// recipe of some 100 doubles every step.
pub const MIN_OUTPUT_SHARE: usize = 1024;
/// Script items (lines, commands, programs) of all stream clients done in one step,
/// each client doing at most its fair share (this over the number of clients, at least
/// [`MIN_ITEM_SHARE`]); the others wait in its queue, which holds at most what one read
/// completed. 64 a step is 32 000 a second at 2 ms steps, while at most one program
/// per client a step starts.
pub const STEP_ITEM_BUDGET: usize = 64;
/// The least number of script items a client may have done in one step.
pub const MIN_ITEM_SHARE: usize = 2;
/// Programs (and secondary programs) of the stream clients handed to the compiling
/// thread in one step, all clients together: 1000 a second at 2 ms steps, more than a
/// controller compiles, while many clients' floods of lines cannot keep the compiling
/// thread busy for one. A program past it waits in its client's queue for the next
/// step; the clients take turns being first.
pub const STEP_START_BUDGET: usize = 2;
/// The interval over which events are counted for [`MAX_EVENTS_PER_INTERVAL`].
pub const EVENT_INTERVAL: Duration = Duration::from_secs(1);
/// Events reported per client (and for the running program: its messages, socket calls
/// and bytes) per [`EVENT_INTERVAL`]; the others are counted and reported as one
/// [`ServerEvent::Suppressed`](super::ServerEvent::Suppressed). 5000 a second is ten a
/// step at 2 ms: a client or program that speaks every step is reported in full, while
/// a flood costs the log (and whoever reads it) 5000 lines a second, not a million.
pub const MAX_EVENTS_PER_INTERVAL: u64 = 5000;

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
    /// Controller time of the last byte received from it or written to it.
    last_active: Duration,
    /// Script items read and not done yet (at most what one read completed).
    pending: VecDeque<Result<Intake, IntakeError>>,
    /// Its program is being compiled: its later items wait (and it is not read).
    compiling: bool,
    /// Its events this interval.
    events: EventBudget,
    /// Bytes of RTDE data packages it may still be given (its share of
    /// [`STEP_OUTPUT_BUDGET`] each step, less what it was given; at most one share).
    credit: i64,
}

/// Events reported in the current [`EVENT_INTERVAL`] and those suppressed.
#[derive(Debug, Clone, Copy)]
pub(crate) struct EventBudget {
    since: Duration,
    reported: u64,
    suppressed: u64,
}

impl EventBudget {
    pub(crate) fn new(now: Duration) -> Self {
        EventBudget {
            since: now,
            reported: 0,
            suppressed: 0,
        }
    }

    /// Whether one more event may be reported now (else it is counted as suppressed).
    pub(crate) fn allow(&mut self) -> bool {
        if self.reported < MAX_EVENTS_PER_INTERVAL {
            self.reported += 1;
            true
        } else {
            self.suppressed += 1;
            false
        }
    }

    /// Counts events not reported for another reason (superseded within a step).
    fn skip(&mut self, n: u64) {
        self.suppressed += n;
    }

    /// At an interval's end: the count of events suppressed in it, and its length.
    pub(crate) fn roll(&mut self, now: Duration) -> Option<(u64, Duration)> {
        let took = now.saturating_sub(self.since);
        if took < EVENT_INTERVAL {
            return None;
        }
        let suppressed = std::mem::take(&mut self.suppressed);
        self.since = now;
        self.reported = 0;
        (suppressed > 0).then_some((suppressed, took))
    }
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
        if written > 0 {
            self.last_active = now;
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

/// Runs the loop until the server stops, owning the cell meanwhile and serving the
/// `requests` other threads send it; `first` is the controller's status before any
/// client acted: its robot mode, safety status and program state are not changes.
pub(crate) fn run(
    shared: &Arc<Shared>,
    listeners: Listeners,
    requests: mpsc::Receiver<Box<dyn Request>>,
    first: &Status,
) {
    let Some(cell) = shared.take_cell() else {
        shared.loop_ended();
        return;
    };
    let step = cell.step_time();
    let cell_compiler = cell.compiler();
    let mut lp = Loop {
        owner: Owner::new(cell, requests),
        clients: Vec::new(),
        driver: Driver::new(Options::default()),
        connects: Connects::new(MAX_CONNECTING),
        secondary_driver: Driver::new(Options::default()),
        secondary_connects: Connects::new(MAX_SECONDARY_CONNECTING),
        registry: InputRegistry::new(),
        next_state: Duration::ZERO,
        safety: first.safety,
        state_key: (first.robot_mode, first.safety, first.program_state),
        buf: vec![0u8; READ_CHUNK],
        frame: Vec::new(),
        program_events: EventBudget::new(shared.now()),
        senders: 0,
        starts_left: 0,
        compiles: Compiles::start(cell_compiler),
        turn: 0,
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
    // Every step is computed, at its own time (a multiple of the step), however late
    // the thread woke: late steps run back to back until the loop is on time, so the
    // streams' timestamps are consecutive and RTDE's schedule (kept in the same steps)
    // sends every package that is due. Only a stall past `MAX_CATCH_UP` is held back
    // (see `clock`); lateness is counted and reported.
    let mut last: Option<Duration> = None;
    // The last step computed (kept while idle).
    let mut prev: Option<Duration> = None;
    let mut late = LateReport::new(shared.now());
    *shared.loop_thread.lock().unwrap_or_else(|p| p.into_inner()) = Some(std::thread::current());
    while !shared.stopped() {
        // What other threads asked of the cell since the last turn (a request wakes the
        // loop when it sleeps).
        lp.owner.serve(shared);
        // Idle (no stream client, nothing in the cell that needs steps): one step every
        // `IDLE_POLL` (to accept clients and say state changes), or at once after a
        // request; the steps start again from then.
        let idle = lp.is_idle(shared);
        let due = match last {
            Some(l) => l + step,
            None => {
                let b = step_boundary(shared.now(), step);
                prev.map_or(b, |p| b.max(p + step))
            }
        };
        let (now, held) = shared.clock.catch_up(due);
        if now < due {
            // Woke before the step's time (a request, or early): sleep on.
            std::thread::park_timeout((due - now).min(step));
            continue;
        }
        let tick = due;
        late.record(now - tick, held, step);
        let pending = super::ready::pending(listeners.each_ref().map(|(l, _)| l.as_ref()));
        for ((l, service), pending) in listeners.iter().zip(pending) {
            if let (Some(l), true) = (l, pending) {
                lp.accept(shared, l, *service);
            }
        }
        lp.take_compiled(tick);
        lp.read_clients(shared, tick);
        // Read before the step: the shutdown stopped the program under the cell's lock
        // before it set the flag, so this step ends the program and reports it.
        let closing = shared.shutting_down();
        lp.step(shared, tick);
        for c in &mut lp.clients {
            c.flush(tick);
        }
        lp.drop_gone(shared);
        lp.report_suppressed(shared, tick);
        late.report(shared, tick);
        if closing {
            // The controller shut down: the step above ended its program; every
            // client is closed, then the loop ends.
            for c in &mut lp.clients {
                c.gone = Some("the controller shut down");
            }
            lp.drop_gone(shared);
            lp.driver.close_all();
            lp.owner.park(shared);
            shared.loop_ended();
            return;
        }
        prev = Some(tick);
        if idle && lp.clients.is_empty() {
            last = None;
            std::thread::park_timeout(IDLE_POLL);
            continue;
        }
        last = Some(tick);
        let next = tick + step;
        let now = shared.now();
        if next > now {
            std::thread::park_timeout((next - now).min(step));
        }
    }
    lp.owner.park(shared);
}

/// How long the idle loop (no stream client, nothing in the cell that needs steps)
/// sleeps between its steps: a client that connects to an idle controller waits at most
/// this for its first package, a change of state with time alone (power-on, brake
/// release) is said at most this late, and an idle controller steps 50 times a second
/// instead of 500 (a dashboard or interpreter command, or the operator, wakes it at
/// once).
pub const IDLE_POLL: Duration = Duration::from_millis(20);

/// The loop's lateness over the current report interval.
struct LateReport {
    /// The interval's lateness.
    now: Lateness,
    /// The interval's start (controller time).
    since: Duration,
}

impl LateReport {
    fn new(now: Duration) -> Self {
        LateReport {
            now: Lateness::default(),
            since: now,
        }
    }

    /// A step computed `late` after its time, after `held` was held back.
    fn record(&mut self, late: Duration, held: Duration, step: Duration) {
        if late >= step {
            self.now.late_steps += 1;
        }
        self.now.worst = self.now.worst.max(late);
        if !held.is_zero() {
            self.now.held = self.now.held.saturating_add(held);
            self.now.holds += 1;
        }
    }

    /// Adds the interval's lateness to the totals ([`super::Server::lateness`]) at the
    /// end of each [`EVENT_INTERVAL`], and reports it as an event when it had late
    /// steps, at once after a stall was held back.
    fn report(&mut self, shared: &Shared, now: Duration) {
        let interval = now.saturating_sub(self.since);
        if self.now.holds == 0 && interval < EVENT_INTERVAL {
            return;
        }
        shared
            .lateness
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .add(&self.now);
        if self.now.late_steps > 0 || self.now.holds > 0 {
            shared.emit(Event::Late {
                lateness: self.now,
                interval,
            });
        }
        *self = LateReport::new(now);
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
    /// The most connects in progress at once.
    limit: usize,
    timeout: Duration,
    /// Counts the programs: an outcome for an earlier one is dropped.
    generation: u64,
    waiting: VecDeque<ConnectRequest>,
    in_flight: usize,
    done_tx: mpsc::Sender<Connected>,
    done_rx: mpsc::Receiver<Connected>,
}

impl Connects {
    fn new(limit: usize) -> Self {
        let (done_tx, done_rx) = mpsc::channel();
        Connects {
            limit,
            timeout: Options::default().connect_timeout,
            generation: 0,
            waiting: VecDeque::new(),
            in_flight: 0,
            done_tx,
            done_rx,
        }
    }

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
        while self.in_flight < self.limit {
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
    /// The cell, owned by the loop while it runs, and the requests other threads send it.
    owner: Owner,
    clients: Vec<Client>,
    driver: Driver,
    connects: Connects,
    /// The sockets of the secondary program waiting for the network (its own: its
    /// socket names are not the main program's).
    secondary_driver: Driver,
    secondary_connects: Connects,
    /// Which RTDE client owns which input field.
    registry: InputRegistry,
    next_state: Duration,
    /// The safety status the primary clients were last told of.
    safety: crate::SafetyStatus,
    /// The modes of the last state message.
    state_key: (crate::RobotMode, crate::SafetyStatus, crate::ProgramState),
    buf: Vec<u8>,
    frame: Vec<u8>,
    /// The running program's events (messages, socket calls and bytes) this interval.
    program_events: EventBudget,
    /// Clients that sent something in the last step (the read budget's shares).
    senders: usize,
    /// Programs that may still be handed to the compiling thread this step
    /// ([`STEP_START_BUDGET`]).
    starts_left: usize,
    /// The compiling thread.
    compiles: Compiles,
    /// Counts the steps: the client served first.
    turn: usize,
}

impl Loop {
    /// Whether the loop may sleep: no stream client, no program connect pending, no
    /// shutdown to carry out, and nothing in the cell that needs steps.
    fn is_idle(&self, shared: &Shared) -> bool {
        self.clients.is_empty()
            && self.connects.waiting.is_empty()
            && self.connects.in_flight == 0
            && self.secondary_connects.waiting.is_empty()
            && self.secondary_connects.in_flight == 0
            && !shared.shutting_down()
            && !self.compiles.busy()
            && self.owner.cell.is_idle()
    }

    fn accept(&mut self, shared: &Shared, listener: &TcpListener, service: Service) {
        loop {
            let (stream, peer) = match listener.accept() {
                Ok(s) => s,
                Err(e) if e.kind() == ErrorKind::Interrupted => continue,
                Err(_) => return, // WouldBlock, or out of descriptors: next round
            };
            let now = shared.now();
            if self.clients.len() >= MAX_CLIENTS && !self.evict_idlest(shared, now) {
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
                last_write: now,
                last_active: now,
                pending: VecDeque::new(),
                compiling: false,
                events: EventBudget::new(now),
                credit: 0,
            };
            if matches!(service, Service::Primary | Service::Secondary) {
                self.frame.clear();
                primary::encode_version(&mut self.frame, shared.config());
                client.push(&self.frame);
            }
            self.clients.push(client);
        }
    }

    /// Every slot is taken: closes the client idle longest, if it has been idle at
    /// least [`EVICT_IDLE`]; false if none may go.
    fn evict_idlest(&mut self, shared: &Shared, now: Duration) -> bool {
        let idlest = self
            .clients
            .iter()
            .enumerate()
            .filter(|(_, c)| c.gone.is_none())
            .min_by_key(|(_, c)| c.last_active)
            .map(|(i, c)| (i, now.saturating_sub(c.last_active)));
        match idlest {
            Some((i, idle)) if idle >= EVICT_IDLE => {
                self.clients[i].gone =
                    Some("evicted: every slot was taken and it was idle longest");
                shared.emit(Event::Note(format!(
                    "conn {}: evicted for a new client after {:.1} s idle",
                    self.clients[i].conn,
                    idle.as_secs_f64()
                )));
                self.drop_gone(shared);
                true
            }
            _ => false,
        }
    }

    /// Each client's turn: its waiting script items first (its share of
    /// [`STEP_ITEM_BUDGET`]); with none waiting, one read of at most its share of
    /// [`STEP_READ_BUDGET`].
    fn read_clients(&mut self, shared: &Shared, now: Duration) {
        let n = self.senders.max(1);
        self.senders = 0;
        let read_share = (STEP_READ_BUDGET / n).clamp(MIN_READ_SHARE, READ_CHUNK);
        let item_share = (STEP_ITEM_BUDGET / n).max(MIN_ITEM_SHARE);
        // The buffer is lent out while `received` (which needs `&mut self`) runs: no
        // copy of the bytes per read.
        let mut buf = std::mem::take(&mut self.buf);
        self.starts_left = STEP_START_BUDGET;
        let count = self.clients.len();
        self.turn = self.turn.wrapping_add(1);
        let first = self.turn % count.max(1);
        for i in (first..count).chain(0..first) {
            if self.clients[i].compiling {
                continue;
            }
            if !self.clients[i].pending.is_empty() {
                self.do_items(shared, i, item_share, now);
                continue;
            }
            let c = &mut self.clients[i];
            if c.gone.is_some() {
                continue;
            }
            let Some(into) = buf.get_mut(..read_share) else {
                continue;
            };
            let n = loop {
                match c.stream.read(into) {
                    Ok(n) => break n,
                    Err(e) if e.kind() == ErrorKind::Interrupted => {}
                    Err(e) if e.kind() == ErrorKind::WouldBlock => break usize::MAX,
                    Err(_) => {
                        c.gone = Some("read failed");
                        break usize::MAX;
                    }
                }
            };
            if n == 0 {
                c.gone = Some("client closed");
            }
            if n == 0 || n == usize::MAX {
                continue;
            }
            c.rx += n as u64;
            c.last_active = now;
            self.senders += 1;
            if let Some(bytes) = buf.get(..n) {
                self.received(shared, i, bytes, now);
            }
            self.do_items(shared, i, item_share, now);
        }
        self.buf = buf;
    }

    /// Bytes from client `i`: an RTDE session's packets handled, a script client's
    /// items queued.
    fn received(&mut self, shared: &Shared, i: usize, bytes: &[u8], now: Duration) {
        let c = &mut self.clients[i];
        let (conn, service) = (c.conn, c.service);
        let Some(session) = c.rtde.as_mut() else {
            c.pending.extend(c.intake.push(bytes));
            return;
        };
        if let Err(e) = session.handle_received(&mut self.registry, bytes) {
            if e.is_fatal() {
                c.gone = Some("RTDE protocol error");
            }
        }
        // Of one recipe's input packages only the last matters.
        let mut inputs: Vec<(u8, crate::Inputs)> = Vec::new();
        while let Some(e) = session.poll_event() {
            match e {
                RtdeEvent::Inputs {
                    recipe,
                    inputs: set,
                    ..
                } => match inputs.iter_mut().find(|(r, _)| *r == recipe) {
                    Some(slot) => slot.1 = set,
                    None => inputs.push((recipe, set)),
                },
                other => {
                    if let Some(event) = ClientEvent::from_rtde(other) {
                        if c.events.allow() {
                            shared.emit(client_event(conn, service, event));
                        }
                    }
                }
            }
        }
        let out = session.take_outbox();
        c.push(&out);
        let _ = now;
        for (_, set) in &inputs {
            self.owner.cell.apply(set);
        }
    }

    /// Does at most `max` of client `i`'s waiting script items: of them, only the last
    /// program or line starts and only the last `set speed` is applied (the others are
    /// superseded within the step and counted as suppressed events). A program goes to
    /// the compiling thread ([`compile`](super::compile)): the client's items after it
    /// wait until it is back and started ([`Loop::take_compiled`]).
    fn do_items(&mut self, shared: &Shared, i: usize, max: usize, now: Duration) {
        let starts = |it: &Result<Intake, IntakeError>| {
            matches!(it, Ok(Intake::Program { .. } | Intake::Line(_)))
        };
        let secondary =
            |it: &Result<Intake, IntakeError>| matches!(it, Ok(Intake::Secondary { .. }));
        let compiles = |it: &Result<Intake, IntakeError>| starts(it) || secondary(it);
        let c = &mut self.clients[i];
        let mut k = c.pending.len().min(max);
        // One program a batch, its last item: the last program before the first
        // secondary program (the earlier ones superseded), else that secondary program.
        // The items after it wait until it is compiled and started.
        let first_secondary = c.pending.iter().take(k).position(secondary);
        let before = first_secondary.unwrap_or(k);
        if let Some(l) = c.pending.iter().take(before).rposition(starts) {
            k = l + 1;
        } else if let Some(s) = first_secondary {
            k = s + 1;
        }
        // Within the step's budget of programs, and while the compiling queue has room.
        if c.pending.iter().take(k).any(compiles)
            && (self.starts_left == 0 || !self.compiles.has_room())
        {
            k = c.pending.iter().take(k).position(compiles).unwrap_or(0);
        }
        if k == 0 {
            return;
        }
        let batch: Vec<_> = c.pending.drain(..k).collect();
        let speed = |it: &Result<Intake, IntakeError>| {
            matches!(it, Ok(Intake::Command(Command::SetSpeed(_))))
        };
        let last_start = batch.iter().rposition(starts);
        let last_speed = batch.iter().rposition(speed);
        let (conn, service) = (c.conn, c.service);
        for (j, item) in batch.into_iter().enumerate() {
            let c = &mut self.clients[i];
            if (starts(&item) && Some(j) != last_start) || (speed(&item) && Some(j) != last_speed) {
                c.events.skip(1);
                continue;
            }
            let report = c.events.allow();
            let emit = |event: ClientEvent| {
                if report {
                    shared.emit(client_event(conn, service, event));
                }
            };
            let (secondary, text) = match item {
                Ok(Intake::Program { name, source }) => {
                    emit(ClientEvent::Program { name });
                    (false, source)
                }
                Ok(Intake::Secondary { name, source }) => {
                    emit(ClientEvent::Secondary { name });
                    (true, source)
                }
                Ok(Intake::Line(line)) => {
                    let text = format!("{line}\n");
                    emit(ClientEvent::Line(line));
                    (false, text)
                }
                Ok(Intake::Command(cmd)) => {
                    emit(ClientEvent::Command(cmd));
                    self.do_command(cmd, now);
                    continue;
                }
                Err(e) => {
                    emit(ClientEvent::Refused(e));
                    continue;
                }
            };
            // The last item of the batch (see above).
            self.starts_left = self.starts_left.saturating_sub(1);
            self.clients[i].compiling = true;
            self.compiles.send(Job {
                conn,
                secondary,
                text,
            });
        }
    }

    /// Starts the programs compiled since the last step (see [`compile`](super::compile)),
    /// and lets their clients' later items be done.
    fn take_compiled(&mut self, now: Duration) {
        while let Some(done) = self.compiles.take() {
            if let Some(c) = self.clients.iter_mut().find(|c| c.conn == done.conn) {
                c.compiling = false;
            }
            let cell = &mut self.owner.cell;
            if done.secondary {
                cell.run_secondary_compiled(done.program, now);
            } else {
                cell.start_compiled(done.program, now);
            }
        }
    }

    /// A primary client's command (`power on`, `set speed`...).
    fn do_command(&mut self, cmd: Command, now: Duration) {
        let cell = &mut self.owner.cell;
        let c = cell.controller();
        let before = c.program_state();
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
        // A primary client's `stop program` or `power off`.
        let cause = match super::stop_cause(cell.controller(), before, now) {
            Some(crate::StopReason::DashboardStop) => Some(crate::StopReason::ClientStop),
            other => other,
        };
        if let Some(cause) = cause {
            cell.set_stop_cause(cause);
        }
    }

    /// One step: the cell runs to `now`, the program's sockets are serviced, and every
    /// stream gets what is due.
    fn step(&mut self, shared: &Arc<Shared>, now: Duration) {
        let mut messages: Vec<RobotMessage> = Vec::new();
        // The step's events, reported once the cell is unlocked (at most the cell's
        // MAX_EVENTS and what the program's sockets did in one step).
        let deferred = std::cell::RefCell::new(Vec::new());
        let status = {
            let cell = &mut self.owner.cell;
            cell.advance(now);
            let emit = |e: Event| deferred.borrow_mut().push(e);
            // The program's messages, calls and socket bytes, within their budget.
            let budget = std::cell::RefCell::new(&mut self.program_events);
            let emit_program = |e: Event| {
                if budget.borrow_mut().allow() {
                    deferred.borrow_mut().push(e);
                }
            };
            while let Some(event) = cell.poll_event() {
                match event {
                    CellEvent::Program(e) => {
                        match &e {
                            ProgramEvent::Message(m) => {
                                emit_program(Event::Message(m.clone()));
                                messages.push(robot_message(m));
                            }
                            ProgramEvent::Call(c) => {
                                emit_program(Event::Call(c.clone()));
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
                            Some(m) => self
                                .driver
                                .handle_event(m, e, &mut |a| show(&emit_program, a)),
                            // The program has ended: what it sent last still goes
                            // out, then its sockets close.
                            None => self.driver.handle_event_after_end(e),
                        }
                    }
                    CellEvent::Secondary(e) => match (cell.secondary_machine_mut(), e) {
                        (
                            Some(_),
                            ProgramEvent::Connect {
                                socket_name,
                                host,
                                port,
                            },
                        ) => self.secondary_connects.waiting.push_back(ConnectRequest {
                            generation: self.secondary_connects.generation,
                            socket_name,
                            host,
                            port,
                        }),
                        (Some(m), e) => {
                            self.secondary_driver
                                .handle_event(m, e, &mut |a| show(&emit_program, a));
                        }
                        (None, e) => self.secondary_driver.handle_event_after_end(e),
                    },
                    CellEvent::SecondaryEnded => {
                        self.secondary_driver.close_all();
                        self.secondary_connects.next_program();
                    }
                    CellEvent::ProgramStarted { name } => {
                        self.connects.next_program();
                        emit(program_event("started", &name, None, None, None));
                        messages.push(RobotMessage::program_started(&name));
                    }
                    CellEvent::ProgramEnded { name, how, reason } => {
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
                        let mut event = program_event(what, &name, line, column, text.clone());
                        if let Event::Program { reason: r, .. } = &mut event {
                            *r = Some(reason);
                        }
                        emit(event);
                        if let Ended::Error(e) = &how {
                            messages.push(RobotMessage::RuntimeException {
                                line: i32::try_from(e.line()).unwrap_or(i32::MAX),
                                column: i32::try_from(e.column()).unwrap_or(i32::MAX),
                                text: controller_text(e),
                            });
                        }
                        messages.push(RobotMessage::program_stopped(&name));
                        self.driver.close_all();
                        self.connects.next_program();
                    }
                    CellEvent::Refused {
                        line,
                        column,
                        text,
                        code,
                    } => {
                        let at = (line > 0).then_some(line);
                        emit(program_event(
                            "refused",
                            "",
                            at,
                            at.map(|_| column),
                            Some(text.clone()),
                        ));
                        messages.push(if line > 0 {
                            // The code alone where the controller says only its code.
                            RobotMessage::RuntimeException {
                                line: i32::try_from(line).unwrap_or(i32::MAX),
                                column: i32::try_from(column).unwrap_or(i32::MAX),
                                text: code.map_or(text, |c| c.to_string()),
                            }
                        } else {
                            RobotMessage::text(&text)
                        });
                    }
                    CellEvent::NeedProgram { name, path } => {
                        // Reading, translating and fetching External Control scripts
                        // take time: the streams go on meanwhile.
                        let shared = Arc::clone(shared);
                        let compiler = cell.compiler();
                        let spawned = std::thread::Builder::new()
                            .name("load-program".into())
                            .spawn(move || {
                                // Compiled here too: the loop only starts it.
                                let result = super::fetch::load(
                                    &shared,
                                    &shared.program_file(&path).to_string_lossy(),
                                )
                                .map(|script| compiler.loaded(&script));
                                shared.ask(move |cell, now| match result {
                                    Ok(program) => cell.start_loaded_compiled(program, now),
                                    Err(why) => cell.refuse_loaded(format!("{name}: {why}"), now),
                                });
                            });
                        if let Err(e) = spawned {
                            cell.refuse_loaded(format!("cannot start a thread: {e}"), now);
                        }
                    }
                }
            }
            self.connects.service(&mut self.driver, cell.machine_mut());
            if let Some(m) = cell.machine_mut() {
                self.driver.poll_sockets(m, &mut |a| show(&emit_program, a));
            }
            self.secondary_connects
                .service(&mut self.secondary_driver, cell.secondary_machine_mut());
            if let Some(m) = cell.secondary_machine_mut() {
                self.secondary_driver
                    .poll_sockets(m, &mut |a| show(&emit_program, a));
            }
            let mut status = cell.status();
            // The step's time (the dashboard's thread may have advanced the cell to the
            // wall clock since this step's boundary).
            status.time = now.as_secs_f64();
            // A program state that became PAUSED or STOPPED is said with its reason.
            let left = self.state_key.2 != status.program_state
                && matches!(
                    status.program_state,
                    crate::ProgramState::Paused | crate::ProgramState::Stopped
                );
            (status, left.then(|| cell.take_stop_reason()))
        };
        let (status, stop_reason) = status;
        for e in deferred.into_inner() {
            shared.emit(e);
        }
        // A change of the safety status reaches the primary clients as the controller's
        // safety mode message; a protective stop also as an error code of level
        // WARNING (2), which UR's client library treats as a failed script unless told
        // to ignore warnings. The code (209, argument 0) is our choice: UR does not
        // document the code a protective stop reports.
        // They go before the `PROGRAM_XXX_STOPPED` of a program the stop ended this step.
        if self.safety != status.safety {
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
        self.safety = status.safety;
        self.stream(shared, &status, stop_reason, &messages, now);
    }

    fn stream(
        &mut self,
        shared: &Shared,
        status: &Status,
        stop_reason: Option<crate::StopReason>,
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
        let changed = self.state_key != key;
        self.state_key = key;
        if changed {
            shared.emit(super::ServerEvent::State {
                robot_mode: status.robot_mode,
                safety: status.safety,
                program: status.program_state,
                reason: stop_reason,
            });
        }
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
        // while its outbox is full), within its share of the step's output budget.
        let rtde = self
            .clients
            .iter()
            .filter(|c| c.service == Service::Rtde)
            .count()
            .max(1);
        let share =
            i64::try_from((STEP_OUTPUT_BUDGET / rtde).max(MIN_OUTPUT_SHARE)).unwrap_or(i64::MAX);
        for c in self
            .clients
            .iter_mut()
            .filter(|c| c.service == Service::Rtde)
        {
            c.credit = c.credit.saturating_add(share).min(share);
            if c.queue.len() > MAX_BACKLOG || c.credit <= 0 {
                // The package would be skipped, or the client had its share: it is
                // not even made.
                c.offer(&[], now);
            } else if let Some(s) = c.rtde.as_mut() {
                s.on_step(status, now);
                let out = s.take_outbox();
                c.credit = c
                    .credit
                    .saturating_sub(i64::try_from(out.len()).unwrap_or(i64::MAX));
                c.offer(&out, now);
            }
        }
    }

    /// At the end of each client's (and the program's) event interval: how many of its
    /// events were not reported.
    fn report_suppressed(&mut self, shared: &Shared, now: Duration) {
        for c in &mut self.clients {
            if let Some((count, interval)) = c.events.roll(now) {
                shared.emit(Event::Suppressed {
                    conn: Some(c.conn),
                    count,
                    interval,
                });
            }
        }
        if let Some((count, interval)) = self.program_events.roll(now) {
            shared.emit(Event::Suppressed {
                conn: None,
                count,
                interval,
            });
        }
    }

    fn drop_gone(&mut self, shared: &Shared) {
        let mut i = 0;
        while i < self.clients.len() {
            if let Some(reason) = self.clients[i].gone {
                let mut c = self.clients.swap_remove(i);
                if c.events.suppressed > 0 {
                    shared.emit(Event::Suppressed {
                        conn: Some(c.conn),
                        count: c.events.suppressed,
                        interval: shared.now().saturating_sub(c.events.since),
                    });
                }
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
        reason: None,
    }
}

fn client_event(conn: u64, service: Service, event: ClientEvent) -> Event {
    Event::Client {
        conn,
        service: service.name(),
        event,
    }
}

/// The text of the runtime exception a failed program sends: the controller's code when
/// the error has one (`compile_error_name_not_found:NAME:`, without the interpreter's
/// explanation for people), else the interpreter's message.
fn controller_text(e: &urscript_interp::RuntimeError) -> String {
    e.code()
        .map_or_else(|| e.message().to_string(), ToString::to_string)
}
