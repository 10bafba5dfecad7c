//! The virtual controller on TCP: every interface of the crate served on the controller's
//! ports, in-process ([`Server::start`]), for a driver's tests or for `ursock controller`.
//! This is the crate's one module with sockets, threads and files (feature `net`, on by
//! default); everything it serves is the sans-IO code of the other modules.
//!
//! - The dashboard server: one thread per connection (at most [`MAX_CONNECTIONS`]), every
//!   line a command, every reply written in one piece ending in `"\n"`.
//! - Primary, secondary, realtime and RTDE, and the program running on the arm: one
//!   real-time thread that owns the [`Cell`] and steps it at the controller's step (2 ms
//!   e-Series, 8 ms CB3). See [`streams`](self) for its bounds. The other threads act on
//!   the cell only by requests the loop runs between its steps ([`owner`](self)).
//! - The interpreter socket (30020): one thread per connection (at most
//!   [`MAX_INTERPRETER_CONNECTIONS`]), each line a statement or command for the running
//!   program's interpreter mode, each reply one line. See [`interpreter`](self) for the
//!   wire behaviour.
//! - `.urp` programs are read, translated and their External Control scripts fetched in a
//!   thread of their own when they play.
//!
//! What happens is reported as [`ServerEvent`]s to the callback given to
//! [`Server::start`], from the server's threads, the real-time loop among them: the
//! callback must not block (queue the event, as `ursock controller` does) and must not
//! call [`Server::with_cell`] (the loop would wait for itself). A dashboard
//! `shutdown` (unless [`ServerOptions::allow_shutdown`] is off: then it is refused as
//! the controller refuses a command, `Failed to execute: shutdown`) ends the running
//! program, closes every client (each with its [`ServerEvent::Close`]) and stops the
//! server; [`ServerEvent::Shutdown`] is the last event.
//!
//! # Bounds
//!
//! Whatever its peers and programs do, the server neither panics, nor stops serving, nor
//! grows without bound (the test `tests/hostile_net.rs` attacks every port). Each bound:
//!
//! - Threads: at most [`MAX_SERVER_THREADS`]: the real-time loop, the dashboard's and the
//!   interpreter's accepting threads, one per dashboard connection ([`MAX_CONNECTIONS`]),
//!   one per interpreter connection ([`MAX_INTERPRETER_CONNECTIONS`]), one per connect
//!   of the running program in progress ([`MAX_CONNECTING`]: a connect never blocks the
//!   real-time loop), one per connect of a secondary program ([`MAX_SECONDARY_CONNECTING`]),
//!   one reading (and compiling) a played `.urp` program (the cell asks for one
//!   program at a time), and one compiling the programs stream clients send.
//! - Connections past a limit ([`MAX_CONNECTIONS`], [`MAX_INTERPRETER_CONNECTIONS`],
//!   [`MAX_CLIENTS`]): a newcomer evicts the connection of that limit idle longest if it
//!   has been idle [`EVICT_IDLE`], else it is accepted and closed at once, so the
//!   kernel's listen backlog (the standard library's 128, capped by the system) drains
//!   however many peers knock; the stream listeners are drained every step. Idle: no
//!   byte received from it (dashboard, interpreter); no byte received from it and none
//!   written to it (stream clients: a reader that takes its packages is active; a
//!   socket that neither sends nor reads is idle).
//! - Dashboard connection: the line read so far, at most [`MAX_LINE`] bytes (a longer
//!   one is answered and skipped to its newline); a reply not taken within
//!   [`WRITE_TIMEOUT`] ends it. An idle client holds its slot while there is room (on
//!   the robot a dashboard client may stay connected for hours).
//! - Interpreter connection: the line so far, at most 64 KiB
//!   ([`urscript_interp::interpreter::MAX_LINE`]); the same write timeout; the lines
//!   the program holds are bounded by [`urscript_interp::interpreter::MAX_UNEXECUTED`].
//! - Stream clients (primary, secondary, realtime, RTDE): at most [`MAX_CLIENTS`] in
//!   all; per client the bytes queued for it ([`MAX_BACKLOG`], [`MAX_QUEUE`]), its
//!   script intake ([`crate::script_intake::MAX_LINE`], [`crate::script_intake::MAX_PROGRAM`])
//!   or its RTDE session ([`crate::rtde::RTDE_MAX_PACKET_SIZE`],
//!   [`crate::rtde::RTDE_MAX_OUTBOX`], [`crate::rtde::RTDE_MAX_EVENTS`], the recipe
//!   counts). See [`streams`](self) for who is dropped when.
//! - The work of one step of the real-time loop: each stream client's fair share of
//!   [`STEP_READ_BUDGET`] bytes read (at least [`MIN_READ_SHARE`]), of
//!   [`STEP_ITEM_BUDGET`] script items done (at least [`MIN_ITEM_SHARE`]; the rest wait
//!   in its queue, at most what one read completed, and it is not read meanwhile; at
//!   most [`STEP_START_BUDGET`] programs of all clients started), of
//!   [`STEP_OUTPUT_BUDGET`] bytes of RTDE data packages made (at least
//!   [`MIN_OUTPUT_SHARE`]); superseded programs, speeds and RTDE inputs of one step
//!   coalesced. So floods on any port leave a well-behaved 500 Hz RTDE client its rate
//!   (`tests/hostile_load.rs`).
//! - Events: at most [`MAX_EVENTS_PER_INTERVAL`] per client and for the running program
//!   per [`EVENT_INTERVAL`], the rest counted in one [`ServerEvent::Suppressed`].
//! - A `shutdown` waits at most [`SHUTDOWN_WAIT`] for the loop and for the connections
//!   it closes.
//! - The running program: the interpreter's bounds (value size, call depth, threads,
//!   statements per step, sockets open: see `urscript_interp`'s crate documentation),
//!   each a runtime error reported to the primary clients; what its sockets leave
//!   unsent, [`urscript_interp::drive::MAX_UNSENT`] per socket.
//! - A played `.urp`: its file at most [`MAX_FILE`] bytes, an External Control script
//!   at most [`MAX_FETCHED`] bytes fetched within 10 s.
//! - The cell's events between two steps: [`crate::MAX_EVENTS`].
//!
//! ```no_run
//! use urscript_controller::net::{Ports, Server, ServerOptions};
//! let server = Server::start(
//!     ServerOptions { ports: Ports::any(), ..ServerOptions::default() },
//!     |event| eprintln!("{event:?}"),
//! )?;
//! let dashboard = server.addr("dashboard").unwrap();
//! // ... drive it as a client would: std::net::TcpStream::connect(dashboard) ...
//! server.stop();
//! # Ok::<(), std::io::Error>(())
//! ```

mod client_event;
mod clock;
mod compile;
mod owner;
mod priority;
mod ready;
pub use client_event::ClientEvent;
pub use clock::MAX_CATCH_UP;
pub use owner::MAX_REQUESTS;
pub use priority::{Realtime, Scheduling, FIFO_PRIORITY, NICE};
mod fetch;
mod interpreter;
mod streams;

use std::io::{ErrorKind, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::Duration;

use urscript_interp::{CallRecord, Message};

use crate::lines::{Event, LineReader};
use crate::{Cell, Config, Controller, Dashboard, DashboardCommand, Programs, Reply, MAX_LINE};

pub use fetch::{parse_host, MAX_FETCHED, MAX_FILE};
pub use interpreter::{MAX_INTERPRETER_CONNECTIONS, POLL as INTERPRETER_POLL};
pub use streams::{
    EVENT_INTERVAL, IDLE_POLL, MAX_BACKLOG, MAX_CLIENTS, MAX_CONNECTING, MAX_EVENTS_PER_INTERVAL,
    MAX_QUEUE, MAX_SECONDARY_CONNECTING, MAX_STALL, MIN_ITEM_SHARE, MIN_OUTPUT_SHARE,
    MIN_READ_SHARE, READ_CHUNK, STEP_ITEM_BUDGET, STEP_OUTPUT_BUDGET, STEP_READ_BUDGET,
    STEP_START_BUDGET,
};

/// Dashboard connections served at once; more are accepted and closed at once. Each is
/// a thread; UR's clients open one or two, and a cell a few more, so 16 leaves room
/// while bounding the threads and descriptors a flood of peers can take.
pub const MAX_CONNECTIONS: usize = 16;

/// The most threads a [`Server`] runs at once: the real-time loop, two accepting
/// threads, [`MAX_CONNECTIONS`] dashboard and [`MAX_INTERPRETER_CONNECTIONS`]
/// interpreter connections, [`MAX_CONNECTING`] connects of the program,
/// [`MAX_SECONDARY_CONNECTING`] of the secondary program waiting for the network, one reading
/// a played `.urp` program, and one compiling the programs clients send.
pub const MAX_SERVER_THREADS: usize = 3
    + MAX_CONNECTIONS
    + MAX_INTERPRETER_CONNECTIONS
    + MAX_CONNECTING
    + MAX_SECONDARY_CONNECTING
    + 2;

/// How long a connection must have been idle to be evicted for a newcomer when its
/// interface's limit ([`MAX_CONNECTIONS`], [`MAX_INTERPRETER_CONNECTIONS`],
/// [`MAX_CLIENTS`]) is reached: the newcomer evicts the connection idle longest if it
/// has been idle this long, else it is closed at once. Idle means nothing received from
/// it (a dashboard or interpreter client), nothing received from it and nothing written
/// to it (a stream client: a reader taking its packages is active). Two seconds is more
/// than the pause between a working client's commands or packages (primary and
/// secondary state comes at 10 Hz) and short enough that silent sockets lock nobody
/// out for long.
pub const EVICT_IDLE: Duration = Duration::from_secs(2);

/// How long a `shutdown` waits for the real-time loop and the other connections to
/// close before the server stops anyway (a thread stuck in a write ends within
/// [`WRITE_TIMEOUT`] regardless).
pub const SHUTDOWN_WAIT: Duration = Duration::from_secs(2);

/// A dashboard or interpreter reply that cannot be written in this time (a client that
/// stopped reading) ends the connection: long enough for a client that is merely slow,
/// short enough that a deaf one frees its thread.
pub const WRITE_TIMEOUT: Duration = Duration::from_secs(10);

/// The ports to serve on; `Some(0)` picks a free one, `None` serves nothing there.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Ports {
    /// Dashboard server (29999).
    pub dashboard: Option<u16>,
    /// Primary interface (30001).
    pub primary: Option<u16>,
    /// Secondary interface (30002).
    pub secondary: Option<u16>,
    /// Realtime interface (30003).
    pub realtime: Option<u16>,
    /// RTDE (30004).
    pub rtde: Option<u16>,
    /// The interpreter socket (30020), served only when the controller has interpreter
    /// mode ([`Config::has_interpreter_mode`]: PolyScope 5.10 and later).
    pub interpreter: Option<u16>,
}

impl Ports {
    /// The controller's own ports.
    pub const STANDARD: Ports = Ports {
        dashboard: Some(29999),
        primary: Some(30001),
        secondary: Some(30002),
        realtime: Some(30003),
        rtde: Some(30004),
        interpreter: Some(30020),
    };

    /// Every interface on a free port (for tests that run side by side).
    pub fn any() -> Ports {
        Ports {
            dashboard: Some(0),
            primary: Some(0),
            secondary: Some(0),
            realtime: Some(0),
            rtde: Some(0),
            interpreter: Some(0),
        }
    }
}

impl Default for Ports {
    fn default() -> Self {
        Ports::STANDARD
    }
}

/// Whom the server answers as where a robot and UR's simulator differ.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Profile {
    /// A robot: what [`ServerOptions::config`] says, programs named relative to the
    /// programs directory or by their path on this machine.
    #[default]
    Robot,
    /// URSim, as UR's client libraries' CI runs it (`ursock controller --ursim`):
    /// - programs are also named by URSim's paths, [`URSIM_PROGRAMS`]`/NAME` for
    ///   `NAME` in the programs directory, and `get loaded program` shows that path;
    /// - `default.installation`, the installation PolyScope starts with, is always
    ///   there to load, a file of that name in the programs directory or not;
    /// - the remote control setting is off: every command is accepted and `is in remote
    ///   control` answers false ([`Config::remote_control_enabled`]);
    /// - `get serial number` answers [`URSIM_SERIAL`].
    Ursim,
}

/// Where URSim keeps its programs (the directory UR's client library's CI mounts its
/// test programs on, and the path its tests load by).
pub const URSIM_PROGRAMS: &str = "/ursim/programs";

/// The serial number [`Profile::Ursim`] answers: the example of UR's dashboard server
/// page ("Serial number like 20175599999"); it begins with `20` as UR's client library
/// requires of every serial number.
pub const URSIM_SERIAL: &str = "20175599999";

/// How a [`Server`] runs.
#[derive(Debug, Clone)]
pub struct ServerOptions {
    /// The address to bind (default `127.0.0.1`).
    pub bind: String,
    /// The ports.
    pub ports: Ports,
    /// What the controller says about itself (model, version, serial, remote control).
    pub config: Config,
    /// Where `load NAME.urp` finds programs and installations; `None`: nowhere.
    pub programs: Option<PathBuf>,
    /// Where External Control URCap nodes fetch their script; `None`: the installation's
    /// URCap settings, else the URCap's default.
    pub urcap_host: Option<(String, u16)>,
    /// A robot's answers or URSim's ([`Profile`]).
    pub profile: Profile,
    /// Whether the dashboard's `shutdown` is obeyed (default); when not, it is answered
    /// as a controller that may not shut down answers it, and nothing else changes.
    pub allow_shutdown: bool,
    /// Whether the real-time loop asks for real-time scheduling ([`Realtime::Auto`]).
    pub realtime: Realtime,
}

impl Default for ServerOptions {
    fn default() -> Self {
        ServerOptions {
            bind: "127.0.0.1".into(),
            ports: Ports::STANDARD,
            config: Config::default(),
            programs: None,
            urcap_host: None,
            profile: Profile::Robot,
            allow_shutdown: true,
            realtime: Realtime::Auto,
        }
    }
}

/// What happened, reported to the callback of [`Server::start`]. `conn` numbers every
/// client of every interface, from 1.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum ServerEvent {
    /// A server listens (`service`: `dashboard`, `primary`, `secondary`, `realtime`,
    /// `rtde`, `interpreter`).
    Listening {
        /// The interface.
        service: &'static str,
        /// Its address.
        addr: SocketAddr,
    },
    /// A client connected.
    Connect {
        /// The client's number.
        conn: u64,
        /// The interface.
        service: &'static str,
        /// Its address.
        peer: String,
    },
    /// A client's connection ended.
    Close {
        /// The client's number.
        conn: u64,
        /// Why.
        reason: String,
        /// Bytes received from it.
        rx: u64,
        /// Bytes sent to it.
        tx: u64,
    },
    /// A dashboard command and its reply.
    Dashboard {
        /// The client.
        conn: u64,
        /// The command line as received (one too long cut, ending in `...`).
        command: String,
        /// The reply lines.
        reply: Vec<String>,
    },
    /// What a primary, secondary, realtime or RTDE client did, or the interpreter
    /// socket's reply to its client.
    Client {
        /// The client.
        conn: u64,
        /// Its interface (`primary`, `secondary`, `realtime`, `rtde`, `interpreter`).
        service: &'static str,
        /// What it did: a program, a line, a command, an RTDE request, a reply
        /// ([`ClientEvent::what`] names its kind, its `Display` is its text).
        event: ClientEvent,
    },
    /// A program started, ended or was refused.
    Program {
        /// `started`, `finished`, `halted`, `stopped`, `error`, `refused`.
        what: &'static str,
        /// Its name (empty when refused).
        name: String,
        /// Where the error is.
        line: Option<u32>,
        /// Its column.
        column: Option<u32>,
        /// The error or the reason.
        text: Option<String>,
        /// Why a program that ended stopped (`None` for `started` and `refused`).
        reason: Option<crate::StopReason>,
    },
    /// `textmsg`, `popup` or `varmsg` of the running program.
    Message(Message),
    /// A socket call of the running program.
    Call(Box<CallRecord>),
    /// A move (or servo/speed stream) of the running program started.
    MoveStart(Box<urscript_interp::MoveStart>),
    /// It ended, and how.
    MoveEnd(Box<urscript_interp::MoveEnd>),
    /// The running program changed an output.
    Output(urscript_interp::OutputWrite),
    /// Bytes the program sent on one of its sockets.
    Tx {
        /// The socket's name.
        socket: String,
        /// The bytes.
        bytes: Vec<u8>,
    },
    /// Bytes a server sent to the program.
    Rx {
        /// The socket's name.
        socket: String,
        /// The bytes.
        bytes: Vec<u8>,
    },
    /// Something to say (an accept that failed, a peer that closed the program's socket).
    Note(String),
    /// Events not reported: past [`MAX_EVENTS_PER_INTERVAL`] in one [`EVENT_INTERVAL`]
    /// (a flood), or a program or `set speed` superseded by a later one of the same step.
    Suppressed {
        /// The client whose events they were; `None`: the running program's.
        conn: Option<u64>,
        /// How many.
        count: u64,
        /// Over how long (from the interval's start to its report).
        interval: Duration,
    },
    /// What scheduling the real-time loop's thread got: once, after the
    /// [`ServerEvent::Listening`] events, before [`Server::start`] returns.
    Scheduling(Scheduling),
    /// The real-time loop fell behind its steps (at most one report per
    /// [`EVENT_INTERVAL`], and at once when it held time back): every step was still
    /// computed and every package sent, late, except the time `lateness.held`.
    Late {
        /// The lateness over the interval.
        lateness: Lateness,
        /// Over how long (from the interval's start to its report, controller time).
        interval: Duration,
    },
    /// The robot mode, the safety status or the program state changed (seen at the
    /// end of a real-time step; not said for the state the controller starts in).
    State {
        /// The robot mode now.
        robot_mode: crate::RobotMode,
        /// The safety status now.
        safety: crate::SafetyStatus,
        /// The program state now.
        program: crate::ProgramState,
        /// Why, when the program state became PAUSED or STOPPED.
        reason: Option<crate::StopReason>,
    },
    /// A dashboard client said `shutdown`: its program has ended and every client has
    /// been closed (their events came first); the server has stopped. The last event.
    Shutdown,
}

/// Programs in a directory of this machine: a name is found when it names a file inside
/// the directory (after resolving `..` and links). With [`Profile::Ursim`], also by
/// [`URSIM_PROGRAMS`]`/NAME`, shown so, and `default.installation` is always found.
#[derive(Debug, Clone)]
pub struct DirPrograms {
    root: PathBuf,
    profile: Profile,
}

/// The installation PolyScope starts with.
const DEFAULT_INSTALLATION: &str = "default.installation";

impl DirPrograms {
    /// Programs under `dir` (which must exist).
    pub fn new(dir: &Path) -> std::io::Result<Self> {
        Self::with_profile(dir, Profile::Robot)
    }

    /// Programs under `dir` (which must exist), named and shown as `profile` does.
    pub fn with_profile(dir: &Path, profile: Profile) -> std::io::Result<Self> {
        let root = dir.canonicalize()?;
        if !root.is_dir() {
            return Err(std::io::Error::new(
                ErrorKind::NotADirectory,
                format!("{} is not a directory", dir.display()),
            ));
        }
        Ok(DirPrograms { root, profile })
    }

    /// The file on this machine a path [`Programs::find`] gave names.
    pub fn file(&self, shown: &str) -> PathBuf {
        match self.ursim_relative(shown) {
            Some(rest) => self.root.join(rest),
            None => PathBuf::from(shown),
        }
    }

    /// `NAME` of `/ursim/programs/NAME`, with the URSim profile.
    fn ursim_relative<'a>(&self, name: &'a str) -> Option<&'a str> {
        if self.profile != Profile::Ursim {
            return None;
        }
        name.strip_prefix(URSIM_PROGRAMS)?.strip_prefix('/')
    }
}

impl Programs for DirPrograms {
    fn find(&self, name: &str) -> Option<String> {
        if name.is_empty() || name.contains('\0') {
            return None;
        }
        let relative = self.ursim_relative(name);
        let path = Path::new(relative.unwrap_or(name));
        let candidate = if path.is_absolute() {
            path.to_path_buf()
        } else {
            self.root.join(path)
        };
        let found = candidate
            .canonicalize()
            .ok()
            .filter(|real| real.starts_with(&self.root) && real.is_file());
        if self.profile == Profile::Ursim {
            let inside = match &found {
                Some(real) => real.strip_prefix(&self.root).ok()?.to_path_buf(),
                None if relative.unwrap_or(name) == DEFAULT_INSTALLATION => {
                    PathBuf::from(DEFAULT_INSTALLATION)
                }
                None => return None,
            };
            return Some(format!("{URSIM_PROGRAMS}/{}", inside.display()));
        }
        found.map(|real| real.display().to_string())
    }
}

type Sink = dyn Fn(ServerEvent) + Send + Sync;

/// How far the real-time loop fell behind its steps. It computes every step and sends
/// every package, late if it must (a loaded or stalled host), and holds back only a
/// stall longer than [`MAX_CATCH_UP`] (see the controller's README, "Bounds").
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct Lateness {
    /// Steps computed a whole step or more after their time.
    pub late_steps: u64,
    /// The most a step was computed after its time.
    pub worst: Duration,
    /// Stalls past [`MAX_CATCH_UP`]: controller time that did not pass (no step
    /// computed, no package sent for it; the controller's time lags the wall clock by it).
    pub held: Duration,
    /// How many such stalls.
    pub holds: u64,
}

impl Lateness {
    /// Adds `other` to the totals.
    pub(crate) fn add(&mut self, other: &Lateness) {
        self.late_steps = self.late_steps.saturating_add(other.late_steps);
        self.worst = self.worst.max(other.worst);
        self.held = self.held.saturating_add(other.held);
        self.holds = self.holds.saturating_add(other.holds);
    }
}

/// What the server's threads share.
pub(crate) struct Shared {
    /// The cell while no loop owns it: before the real-time loop starts, after it ends
    /// (see [`owner`]).
    parked: Mutex<Option<Cell>>,
    /// Requests to the loop that owns the cell, at most [`MAX_REQUESTS`] waiting.
    requests: owner::Requests,
    config: Config,
    /// Controller time: wall time less what the host took from the real-time loop.
    clock: clock::Clock,
    /// The real-time loop's lateness since the start.
    lateness: Mutex<Lateness>,
    /// The real-time loop's thread, to wake it when it sleeps idle.
    loop_thread: Mutex<Option<std::thread::Thread>>,
    next_conn: AtomicU64,
    urcap_host: Option<(String, u16)>,
    /// The programs folder, canonical: a played program and its installation are read
    /// only inside it.
    programs: Option<PathBuf>,
    /// How loaded programs' paths name files in it.
    program_names: Option<DirPrograms>,
    stop: AtomicBool,
    /// A `shutdown` was obeyed: the loop closes its clients and ends.
    shutting_down: AtomicBool,
    /// The real-time loop has ended (after a `shutdown`).
    loop_done: AtomicBool,
    allow_shutdown: bool,
    /// The dashboard and interpreter connections open.
    conns: Mutex<Vec<Slot>>,
    /// The commands of dashboard and interpreter connections acted on in this window.
    commands: CommandBudget,
    sink: Box<Sink>,
}

/// The dashboard's and the interpreter socket's commands acted on in one window of
/// [`COMMAND_WINDOW`], all connections together: at most [`COMMAND_BUDGET`]. Each
/// command locks the cell the real-time loop steps; connections flooding commands from
/// their own threads would otherwise take the loop's CPU and lock (16 dashboard clients
/// sending `robotmode` as fast as they could held a 500 Hz RTDE reader to a quarter of
/// its rate). A command past the budget waits for the next window.
struct CommandBudget {
    /// The window the count is for (controller time / [`COMMAND_WINDOW`]).
    window: AtomicU64,
    /// Commands taken in it.
    used: AtomicU64,
}

/// The window of [`COMMAND_BUDGET`]: one e-Series step.
pub const COMMAND_WINDOW: Duration = Duration::from_millis(2);
/// Dashboard and interpreter commands acted on per [`COMMAND_WINDOW`], all connections
/// together: 16 000 a second, thousands of times what UR's clients send (a driver sends
/// a few dashboard commands a second; an interpreter client one statement per motion).
pub const COMMAND_BUDGET: u64 = 32;

/// A dashboard or interpreter connection, for eviction and shutdown.
struct Slot {
    conn: u64,
    service: &'static str,
    /// A handle to close it with.
    stream: TcpStream,
    activity: Arc<Activity>,
}

/// What a connection's thread tells the accepting thread: when it last received a byte;
/// and why another thread closed it.
pub(crate) struct Activity {
    /// Controller time of the last byte received, in nanoseconds.
    last_rx: AtomicU64,
    closed_by: Mutex<Option<&'static str>>,
}

impl Activity {
    fn new(now: Duration) -> Self {
        Activity {
            last_rx: AtomicU64::new(nanos(now)),
            closed_by: Mutex::new(None),
        }
    }

    /// Bytes came from the client.
    pub(crate) fn touch(&self, shared: &Shared) {
        self.last_rx.store(nanos(shared.now()), Ordering::SeqCst);
    }

    fn idle(&self, now: Duration) -> Duration {
        now.saturating_sub(Duration::from_nanos(self.last_rx.load(Ordering::SeqCst)))
    }

    fn close_for(&self, reason: &'static str) {
        *self.closed_by.lock().unwrap_or_else(|p| p.into_inner()) = Some(reason);
    }

    /// Why another thread closed the connection, if it did.
    pub(crate) fn closed_by(&self) -> Option<&'static str> {
        *self.closed_by.lock().unwrap_or_else(|p| p.into_inner())
    }
}

fn nanos(d: Duration) -> u64 {
    u64::try_from(d.as_nanos()).unwrap_or(u64::MAX)
}

impl Shared {
    pub(crate) fn now(&self) -> Duration {
        self.clock.now()
    }

    pub(crate) fn config(&self) -> &Config {
        &self.config
    }

    /// The file a loaded program's path names.
    pub(crate) fn program_file(&self, path: &str) -> PathBuf {
        match &self.program_names {
            Some(p) => p.file(path),
            None => PathBuf::from(path),
        }
    }

    /// Wakes the real-time loop if it sleeps (idle, or until its next step).
    pub(crate) fn wake_loop(&self) {
        if let Some(t) = self
            .loop_thread
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .as_ref()
        {
            t.unpark();
        }
    }

    pub(crate) fn next_conn(&self) -> u64 {
        self.next_conn.fetch_add(1, Ordering::SeqCst)
    }

    pub(crate) fn emit(&self, event: ServerEvent) {
        (self.sink)(event);
    }

    pub(crate) fn stopped(&self) -> bool {
        self.stop.load(Ordering::SeqCst)
    }

    /// Waits until a dashboard or interpreter command may be acted on
    /// ([`COMMAND_BUDGET`] per [`COMMAND_WINDOW`]); at once if the server stops.
    pub(crate) fn command_turn(&self) {
        loop {
            let window = u64::try_from(self.now().as_nanos() / COMMAND_WINDOW.as_nanos())
                .unwrap_or(u64::MAX);
            let seen = self.commands.window.load(Ordering::SeqCst);
            if seen != window {
                if self
                    .commands
                    .window
                    .compare_exchange(seen, window, Ordering::SeqCst, Ordering::SeqCst)
                    .is_ok()
                {
                    self.commands.used.store(0, Ordering::SeqCst);
                }
                continue;
            }
            if self.commands.used.fetch_add(1, Ordering::SeqCst) < COMMAND_BUDGET || self.stopped()
            {
                return;
            }
            std::thread::sleep(COMMAND_WINDOW / 4);
        }
    }

    pub(crate) fn shutting_down(&self) -> bool {
        self.shutting_down.load(Ordering::SeqCst)
    }

    pub(crate) fn loop_ended(&self) {
        self.loop_done.store(true, Ordering::SeqCst);
    }

    fn lock_conns(&self) -> MutexGuard<'_, Vec<Slot>> {
        self.conns.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// After a `shutdown` from connection `conn`: waits (at most [`SHUTDOWN_WAIT`]) for
    /// the real-time loop to end its program and close its clients, then closes every
    /// other dashboard and interpreter connection and waits for them to go.
    fn close_all_for_shutdown(&self, conn: u64) {
        let start = std::time::Instant::now();
        while !self.loop_done.load(Ordering::SeqCst) && start.elapsed() < SHUTDOWN_WAIT {
            std::thread::sleep(Duration::from_millis(1));
        }
        for slot in self.lock_conns().iter().filter(|s| s.conn != conn) {
            slot.activity.close_for("the controller shut down");
            let _ = slot.stream.shutdown(std::net::Shutdown::Both);
        }
        while self.lock_conns().iter().any(|s| s.conn != conn) && start.elapsed() < SHUTDOWN_WAIT {
            std::thread::sleep(Duration::from_millis(1));
        }
    }
}

/// A virtual controller serving its interfaces over TCP. See the module docs. Dropping it
/// stops it.
pub struct Server {
    shared: Arc<Shared>,
    addrs: Vec<(&'static str, SocketAddr)>,
    threads: Vec<JoinHandle<()>>,
}

impl std::fmt::Debug for Server {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Server")
            .field("addrs", &self.addrs)
            .finish()
    }
}

impl Server {
    /// Binds every port, then serves them from threads of its own; `on_event` hears what
    /// happens (from those threads). The `Listening` events come first, before this
    /// returns.
    pub fn start(
        options: ServerOptions,
        on_event: impl Fn(ServerEvent) + Send + Sync + 'static,
    ) -> std::io::Result<Server> {
        let mut config = options.config.clone();
        if options.profile == Profile::Ursim {
            config.remote_control_enabled = false;
            config.serial = URSIM_SERIAL.to_string();
        }
        let mut controller = Controller::new(config.clone());
        let mut programs = None;
        let mut program_names = None;
        if let Some(dir) = &options.programs {
            let found = DirPrograms::with_profile(dir, options.profile)?;
            programs = Some(found.root.clone());
            program_names = Some(found.clone());
            controller = controller.with_programs(Box::new(found));
        }
        let bind = |port: u16, service: &str| -> std::io::Result<(TcpListener, SocketAddr)> {
            let l = TcpListener::bind((options.bind.as_str(), port)).map_err(|e| {
                std::io::Error::new(
                    e.kind(),
                    format!("cannot listen on {}:{port} ({service}): {e}", options.bind),
                )
            })?;
            let addr = l.local_addr()?;
            Ok((l, addr))
        };
        let p = options.ports;
        let mut addrs = Vec::new();
        let dashboard = match p.dashboard {
            Some(port) => {
                let (l, a) = bind(port, "dashboard")?;
                addrs.push(("dashboard", a));
                Some(l)
            }
            None => None,
        };
        let mut stream = |port: Option<u16>, service: &'static str| match port {
            Some(port) => {
                let (l, a) = bind(port, service)?;
                addrs.push((service, a));
                Ok::<_, std::io::Error>(Some(l))
            }
            None => Ok(None),
        };
        let listeners = streams::Listeners {
            primary: stream(p.primary, "primary")?,
            secondary: stream(p.secondary, "secondary")?,
            realtime: stream(p.realtime, "realtime")?,
            rtde: stream(p.rtde, "rtde")?,
        };
        let interpreter = match p.interpreter.filter(|_| config.has_interpreter_mode()) {
            Some(port) => {
                let (l, a) = bind(port, "interpreter")?;
                addrs.push(("interpreter", a));
                Some(l)
            }
            None => None,
        };
        let interp = Cell::interp_config(&controller);
        let mut cell = Cell::new(controller, interp);
        // The state the controller starts in: a change the loop sees is measured from
        // it, also one made before the loop's first step (an operator's stop).
        let first = cell.status();
        let (requests, requested) = owner::queue();
        let shared = Arc::new(Shared {
            parked: owner::parking(cell),
            requests,
            config,
            clock: clock::Clock::new(),
            lateness: Mutex::new(Lateness::default()),
            loop_thread: Mutex::new(None),
            program_names,
            next_conn: AtomicU64::new(1),
            urcap_host: options.urcap_host,
            programs,
            stop: AtomicBool::new(false),
            shutting_down: AtomicBool::new(false),
            loop_done: AtomicBool::new(false),
            allow_shutdown: options.allow_shutdown,
            conns: Mutex::new(Vec::new()),
            commands: CommandBudget {
                window: AtomicU64::new(0),
                used: AtomicU64::new(0),
            },
            sink: Box::new(on_event),
        });
        for &(service, addr) in &addrs {
            shared.emit(ServerEvent::Listening { service, addr });
        }
        let mut threads = Vec::new();
        {
            let looping = Arc::clone(&shared);
            let realtime = options.realtime;
            // The loop thread asks for its own scheduling; `start` says what it got
            // before returning, so the event's place among the start-up events is fixed.
            let (granted, scheduling) = std::sync::mpsc::sync_channel(1);
            threads.push(
                std::thread::Builder::new()
                    .name("controller".into())
                    .spawn(move || {
                        let _ = granted.send(priority::apply(realtime));
                        streams::run(&looping, listeners, requested, &first)
                    })?,
            );
            if let Ok(s) = scheduling.recv() {
                shared.emit(ServerEvent::Scheduling(s));
            }
        }
        if let Some(listener) = dashboard {
            let shared = Arc::clone(&shared);
            threads.push(std::thread::Builder::new().name("dashboard".into()).spawn(
                move || {
                    let limits = ("dashboard", "", MAX_CONNECTIONS);
                    accept_each(&shared, &listener, limits, serve)
                },
            )?);
        }
        if let Some(listener) = interpreter {
            let shared = Arc::clone(&shared);
            threads.push(
                std::thread::Builder::new()
                    .name("interpreter".into())
                    .spawn(move || {
                        let limits = (
                            "interpreter",
                            "interpreter ",
                            interpreter::MAX_INTERPRETER_CONNECTIONS,
                        );
                        accept_each(&shared, &listener, limits, interpreter::serve)
                    })?,
            );
        }
        Ok(Server {
            shared,
            addrs,
            threads,
        })
    }

    /// The address an interface listens on (`dashboard`, `primary`, `secondary`,
    /// `realtime`, `rtde`, `interpreter`).
    pub fn addr(&self, service: &str) -> Option<SocketAddr> {
        self.addrs
            .iter()
            .find(|(s, _)| *s == service)
            .map(|&(_, a)| a)
    }

    /// Every interface's address.
    pub fn addrs(&self) -> &[(&'static str, SocketAddr)] {
        &self.addrs
    }

    /// Acts on the controller as the operator or the world would (a protective stop, an
    /// input switching, a temperature): `f` gets the cell and the controller's time.
    /// The real-time loop, which owns the cell while it runs, runs `f` between two of
    /// its steps and this returns its result; not to be called from the event sink
    /// (the loop's own thread).
    pub fn with_cell<F, R>(&self, f: F) -> R
    where
        F: FnOnce(&mut Cell, Duration) -> R + Send + 'static,
        R: Send + 'static,
    {
        self.shared.ask(f)
    }

    /// How late the real-time loop has been since the start (as of the end of the last
    /// [`EVENT_INTERVAL`]).
    pub fn lateness(&self) -> Lateness {
        *self
            .shared
            .lateness
            .lock()
            .unwrap_or_else(|p| p.into_inner())
    }

    /// Whether the server has stopped (a dashboard `shutdown`, or [`Server::stop`]).
    pub fn is_stopped(&self) -> bool {
        self.shared.stopped()
    }

    /// Stops serving: the listeners close and the threads end (dashboard connections
    /// already open end when their client next speaks or leaves).
    pub fn stop(mut self) {
        self.halt();
    }

    /// Shuts the controller down as a dashboard `shutdown` does, whatever the control
    /// mode (for a signal to the process): the running program ends, every client is
    /// closed (their events come first) and the server stops serving. Returns once
    /// that is done, after at most twice [`SHUTDOWN_WAIT`]; emits no
    /// [`ServerEvent::Shutdown`]. While a dashboard `shutdown` is under way it only
    /// waits for the server to stop.
    pub fn shut_down(&self) {
        self.shared.ask(|cell, now| cell.controller().turn_off(now));
        let first = !self.shared.shutting_down.swap(true, Ordering::SeqCst);
        if first {
            // Connection numbers start at 1: every connection is closed.
            self.shared.close_all_for_shutdown(0);
            self.shared.stop.store(true, Ordering::SeqCst);
        } else {
            let start = std::time::Instant::now();
            while !self.shared.stopped() && start.elapsed() < SHUTDOWN_WAIT * 2 {
                std::thread::sleep(Duration::from_millis(1));
            }
        }
        self.wake_accepts();
    }

    /// Wakes the threads blocked in an accept, so they see the stop.
    fn wake_accepts(&self) {
        for service in ["dashboard", "interpreter"] {
            if let Some(a) = self.addr(service) {
                let _ = TcpStream::connect_timeout(&a, Duration::from_millis(200));
            }
        }
    }

    fn halt(&mut self) {
        self.shared.stop.store(true, Ordering::SeqCst);
        self.wake_accepts();
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        self.halt();
    }
}

/// A connection's server: its stream, number, peer and what it tells of its activity.
type Serve = fn(TcpStream, u64, String, &Shared, &Activity);

/// Accepts connections on `listener` until the server stops, each served by `serve` in a
/// thread of its own named `SERVICE-CONN`, at most `max` at once: past it a newcomer
/// evicts the connection idle longest if it has been idle [`EVICT_IDLE`], else it is
/// accepted and closed (so the backlog drains). `label` starts the notes (`""` for the
/// dashboard, `"interpreter "`).
pub(super) fn accept_each(
    shared: &Arc<Shared>,
    listener: &TcpListener,
    (service, label, max): (&'static str, &'static str, usize),
    serve: Serve,
) {
    loop {
        let accepted = listener.accept();
        if shared.stopped() || shared.shutting_down() {
            return;
        }
        let (stream, peer) = match accepted {
            Ok(s) => s,
            Err(e) if e.kind() == ErrorKind::Interrupted => continue,
            Err(e) => {
                // Out of descriptors and the like: say so, wait a little, go on.
                shared.emit(ServerEvent::Note(format!("{label}accept failed: {e}")));
                std::thread::sleep(Duration::from_millis(100));
                continue;
            }
        };
        if !make_room(shared, service, label, max) {
            shared.emit(ServerEvent::Note(format!(
                "{peer}: refused, {max} {label}connections are already open"
            )));
            drop(stream);
            continue;
        }
        let Ok(handle) = stream.try_clone() else {
            shared.emit(ServerEvent::Note(format!("{peer}: cannot serve it")));
            continue;
        };
        let conn = shared.next_conn();
        let activity = Arc::new(Activity::new(shared.now()));
        shared.lock_conns().push(Slot {
            conn,
            service,
            stream: handle,
            activity: Arc::clone(&activity),
        });
        let spawned = std::thread::Builder::new()
            .name(format!("{service}-{conn}"))
            .spawn({
                let shared = Arc::clone(shared);
                move || {
                    serve(stream, conn, peer.to_string(), &shared, &activity);
                }
            });
        if let Err(e) = spawned {
            shared.lock_conns().retain(|s| s.conn != conn);
            shared.emit(ServerEvent::Note(format!(
                "{peer}: cannot start a thread: {e}"
            )));
        }
    }
}

/// Whether a newcomer on `service` may be served: fewer than `max` are open, or the one
/// idle longest had been idle [`EVICT_IDLE`] and has been closed (its thread waited for,
/// at most [`SHUTDOWN_WAIT`], so the thread bound holds).
fn make_room(shared: &Shared, service: &'static str, label: &str, max: usize) -> bool {
    let open = |shared: &Shared| {
        shared
            .lock_conns()
            .iter()
            .filter(|s| s.service == service)
            .count()
    };
    if open(shared) < max {
        return true;
    }
    let now = shared.now();
    let evicted = {
        let conns = shared.lock_conns();
        let idlest = conns
            .iter()
            .filter(|s| s.service == service && s.activity.closed_by().is_none())
            .max_by_key(|s| s.activity.idle(now));
        match idlest {
            Some(s) if s.activity.idle(now) >= EVICT_IDLE => {
                s.activity
                    .close_for("evicted: every slot was taken and it was idle longest");
                let _ = s.stream.shutdown(std::net::Shutdown::Both);
                Some((s.conn, s.activity.idle(now)))
            }
            _ => None,
        }
    };
    let Some((conn, idle)) = evicted else {
        return false;
    };
    shared.emit(ServerEvent::Note(format!(
        "conn {conn}: {label}connection evicted for a new one after {:.1} s idle",
        idle.as_secs_f64()
    )));
    let start = std::time::Instant::now();
    while open(shared) >= max {
        if start.elapsed() > SHUTDOWN_WAIT {
            return false;
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    true
}

/// What one connection counted.
pub(crate) struct Counts {
    pub(crate) rx: u64,
    pub(crate) tx: u64,
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

fn serve(mut stream: TcpStream, conn: u64, peer: String, shared: &Shared, activity: &Activity) {
    let _ = stream.set_nodelay(true);
    let _ = stream.set_write_timeout(Some(WRITE_TIMEOUT));
    shared.emit(ServerEvent::Connect {
        conn,
        service: "dashboard",
        peer,
    });
    let mut counts = Counts { rx: 0, tx: 0 };
    let reason = session(&mut stream, conn, shared, activity, &mut counts);
    let shut_down = reason == SHUT_DOWN;
    if shut_down {
        shared.close_all_for_shutdown(conn);
    }
    closed(
        shared,
        conn,
        activity.closed_by().unwrap_or(reason),
        &counts,
    );
    if shut_down {
        shared.stop.store(true, Ordering::SeqCst);
        shared.emit(ServerEvent::Shutdown);
    }
}

/// How a dashboard connection that said `shutdown` ends.
const SHUT_DOWN: &str = "shutdown";

/// A dashboard or interpreter connection has ended: its slot is freed, its close said.
pub(crate) fn closed(shared: &Shared, conn: u64, reason: &str, counts: &Counts) {
    shared.lock_conns().retain(|s| s.conn != conn);
    shared.emit(ServerEvent::Close {
        conn,
        reason: reason.to_string(),
        rx: counts.rx,
        tx: counts.tx,
    });
}

/// Why a client's command paused or stopped the program (its state was `before`), if
/// it did: a shutdown, a power off, else the pause or stop itself (`dashboard` commands).
pub(crate) fn stop_cause(
    c: &mut Controller,
    before: crate::ProgramState,
    now: Duration,
) -> Option<crate::StopReason> {
    use crate::{ProgramState, RobotMode, StopReason};
    let after = c.program_state();
    if after == before || after == ProgramState::Playing {
        return None;
    }
    Some(if c.is_shut_down() {
        StopReason::Shutdown
    } else if c.robot_mode(now) == RobotMode::PowerOff {
        StopReason::PowerOff
    } else if after == ProgramState::Paused {
        StopReason::DashboardPause
    } else {
        StopReason::DashboardStop
    })
}

/// A reply of one line that keeps the connection open.
fn one_line(text: &str) -> Reply {
    Reply {
        lines: vec![text.to_string()],
        close: false,
    }
}

/// Answer one command line, or one longer than [`MAX_LINE`] (`too_long`: `line` holds
/// its first bytes); `Err(reason)` when the connection ends.
fn answer(
    stream: &mut TcpStream,
    conn: u64,
    shared: &Shared,
    dashboard: &mut Dashboard,
    line: &[u8],
    too_long: bool,
    counts: &mut Counts,
) -> Result<(), &'static str> {
    let text = String::from_utf8_lossy(line).into_owned();
    shared.command_turn();
    let allow_shutdown = shared.allow_shutdown;
    let mut session = std::mem::take(dashboard);
    let asked = text.clone();
    let (reply, turned_off, session) = shared.ask(move |cell, now| {
        let text = asked;
        let c = cell.controller();
        let before = c.program_state();
        let reply = if too_long {
            session.line_too_long(&text)
        } else {
            let command = DashboardCommand::parse(&text, c.config().major());
            if command == DashboardCommand::Shutdown && !allow_shutdown {
                // Refused as the controller refuses it: in local control its one reply
                // to every command that acts, else the failure UR's commands answer.
                if c.config().remote_control_enabled && !c.remote_control() {
                    one_line(crate::dashboard::LOCAL_CONTROL)
                } else {
                    one_line("Failed to execute: shutdown")
                }
            } else {
                session.answer(c, &command, now)
            }
        };
        let turned_off = c.is_shut_down();
        if let Some(cause) = stop_cause(c, before, now) {
            cell.set_stop_cause(cause);
        }
        (reply, turned_off, session)
    });
    *dashboard = session;
    // The flag follows the controller's turning off (the loop that sees it finds the
    // program already stopped); the first connection to set it shuts the server down.
    let shut_down = turned_off && !shared.shutting_down.swap(true, Ordering::SeqCst);
    let shown = if too_long {
        format!("{}...", text.chars().take(SHOWN).collect::<String>())
    } else {
        text
    };
    shared.emit(ServerEvent::Dashboard {
        conn,
        command: shown,
        reply: reply.lines.clone(),
    });
    if !send(stream, &reply, counts) {
        return Err("write failed: the client is not reading");
    }
    if shut_down {
        let _ = stream.shutdown(std::net::Shutdown::Both);
        return Err(SHUT_DOWN);
    }
    if reply.close {
        return Err("quit");
    }
    Ok(())
}

/// Characters of a too-long dashboard line shown in its event.
const SHOWN: usize = 40;

fn session(
    stream: &mut TcpStream,
    conn: u64,
    shared: &Shared,
    activity: &Activity,
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
    // A too-long line keeps the bytes of its first SHOWN characters (4 bytes each at
    // most) for its reply and its event.
    let mut lines = LineReader::new(MAX_LINE, SHOWN * 4);
    loop {
        match lines.read_from(&mut reader) {
            Ok(0) => return "client closed",
            Ok(n) => counts.rx += n as u64,
            Err(e) if e.kind() == ErrorKind::Interrupted => continue,
            Err(_) => return "read failed",
        }
        if shared.stopped() {
            return "the server stopped";
        }
        activity.touch(shared);
        let answered = lines.drain(|event| match event {
            Event::Line(line) => answer(stream, conn, shared, &mut dashboard, line, false, counts),
            Event::TooLong(start) => {
                answer(stream, conn, shared, &mut dashboard, start, true, counts)
            }
            Event::LongEnded(_) => Ok(()),
        });
        if let Err(reason) = answered {
            return reason;
        }
    }
}
