//! [`Cell`]: the controller's state machine, the arm and the program that runs on it, in
//! time. Sans-IO like the rest of the crate: the caller feeds programs and client inputs,
//! advances time ([`Cell::advance`]), takes the events ([`Cell::poll_event`]) and reads
//! one [`Status`] per step for the streams. The network (the program's own sockets, the
//! clients' connections) is the caller's.
//!
//! # Programs
//! - A program sent over the primary, secondary or realtime interface ([`Cell::submit`])
//!   replaces the one running (as on the controller, whose new program stops the old
//!   one) and runs at once if the arm is RUNNING and the safety allows motion; otherwise
//!   it is refused with the reason. A `sec` program ([`Submitted::Secondary`]) runs beside
//!   the main program: it may not move the arm; what it sets becomes the arm's; it may
//!   use sockets and XML-RPC, briefly ([`secondary`]).
//! - `play` of a loaded `.urp` asks the caller for its text ([`CellEvent::NeedProgram`]);
//!   the caller reads and translates the file and gives the script back
//!   ([`Cell::start_loaded`]).
//! - `pause` freezes the program's time; `play` resumes it; `stop` (or power off, a
//!   safety stop that cuts power) stops it: its sockets close, the arm keeps its state.
//! - The arm keeps joints, outputs and registers from one program to the next
//!   ([`urscript_interp::Machine::with_arm`]).
//!
//! # Interpreter mode (port 30020)
//! [`Cell::interpreter_line`] takes one line of an interpreter client (e-Series,
//! PolyScope 5.10+) and answers it as [`urscript_interp::interpreter`] documents: the
//! running program compiles and queues the statement (`ack: <id>: <statement>`), or a
//! command is answered at once (`state: <n>: <command>`). As the manual says, the socket
//! takes statements whenever a program runs (those sent before the program calls
//! `interpreter_mode()` wait in the queue); with no program running a statement is
//! `discard: program not running: <statement>` and the state commands answer 0 (each
//! program has its own interpreter: its ids start at 1). A line held behind a
//! `clear_interpreter()` is answered later, to the connection that sent it
//! ([`Cell::interpreter_replies`]); if the program stops first, it is answered
//! `discard: program not running`.

use std::collections::VecDeque;
use std::time::Duration;

use urscript_interp::interpreter::{self, Command, Discard};
use urscript_interp::kinematics;
use urscript_interp::{
    Arm, ControllerCode, Effect, Event, Machine, Preamble, Program, RuntimeError, State,
};

use crate::{RobotMode, SafetyStatus, StopReason};

use crate::state::{Controller, ProgramState};
use crate::status::{Inputs, Status};

pub(crate) mod secondary;

/// The most events waiting for the caller; past it the oldest go first (a caller that
/// never polls does not grow the cell).
pub const MAX_EVENTS: usize = 4096;

/// What came in over the primary, secondary or realtime interface.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Submitted {
    /// A program (`def ... end`, or bare lines): replaces the running one.
    Program(String),
    /// A secondary program (`sec ... end`): runs beside the main program.
    Secondary(String),
}

/// A program compiled ahead of its start: parsed and checked (every name defined or
/// built in), or refused with the controller's reason. Compiling a large program takes
/// time; a caller with a real-time loop compiles on another thread
/// ([`Cell::compiler`]) and hands the result over ([`Cell::start_compiled`],
/// [`Cell::run_secondary_compiled`], [`Cell::start_loaded_compiled`]).
pub struct Compiled {
    machine: Result<Machine, CellEvent>,
    entry: Option<String>,
}

impl std::fmt::Debug for Compiled {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Compiled")
            .field("entry", &self.entry)
            .field("refused", &self.machine.as_ref().err())
            .finish_non_exhaustive()
    }
}

impl Compiled {
    /// A program refused for `why` before it was compiled.
    pub(crate) fn refused(why: String) -> Compiled {
        Compiled {
            machine: Err(CellEvent::Refused {
                line: 0,
                column: 0,
                text: why,
                code: None,
            }),
            entry: None,
        }
    }
}

/// What compiling a program needs (the interpreter's configuration and the
/// installation's URCap preamble), apart from the cell: it can go to another thread.
#[derive(Debug, Clone)]
pub struct Compiler {
    config: urscript_interp::Config,
    preamble: Preamble,
}

impl Compiler {
    /// Compiles a program a client sent (no preamble: the controller adds none).
    pub fn program(&self, text: &str) -> Compiled {
        compile(text, None, &self.config)
    }

    /// Compiles the script of a loaded `.urp` program, after the URCap preamble as
    /// PolyScope writes it.
    pub fn loaded(&self, text: &str) -> Compiled {
        compile(text, Some(&self.preamble), &self.config)
    }
}

/// Parses `text` (after `preamble`, if given) and checks it as a program's start does.
fn compile(text: &str, preamble: Option<&Preamble>, config: &urscript_interp::Config) -> Compiled {
    let program = match parse(text, preamble) {
        Ok(p) => p,
        Err(refused) => {
            return Compiled {
                machine: Err(refused),
                entry: None,
            }
        }
    };
    let entry = program.entry_name().map(str::to_string);
    let machine = Machine::with_arm(program, config.clone(), Arm::default());
    // A program that does not compile (a name neither defined nor built in) is refused.
    let machine = match machine.state() {
        State::Error(e) => Err(CellEvent::Refused {
            line: e.line(),
            column: e.column(),
            text: e.message().to_string(),
            code: e.code().cloned(),
        }),
        _ => Ok(machine),
    };
    Compiled { machine, entry }
}

/// How a program ended.
#[derive(Debug, Clone, PartialEq)]
pub enum Ended {
    /// It ran to its end.
    Finished,
    /// `halt` ran.
    Halted,
    /// A client stopped it (`stop`, power off, a safety stop) or a new program replaced it.
    Stopped,
    /// A runtime error stopped it (the controller's runtime exception).
    Error(RuntimeError),
}

/// What the caller must do or show.
#[derive(Debug, Clone, PartialEq)]
pub enum CellEvent {
    /// A program started.
    ProgramStarted {
        /// Its name (`def NAME()`, or the `.urp` file).
        name: String,
    },
    /// The program ended.
    ProgramEnded {
        /// Its name.
        name: String,
        /// How.
        how: Ended,
        /// Why.
        reason: StopReason,
    },
    /// A program was not run: it does not compile, or the arm cannot move now. The
    /// controller reports this as a runtime exception (syntax errors) or a message.
    Refused {
        /// The line and column of a syntax error, 0 when the reason is not in the text.
        line: u32,
        /// The column.
        column: u32,
        /// The controller's text (`syntax_error_on_line:3:...`) or the reason.
        text: String,
        /// The controller's code when it is all the controller says on its primary
        /// interface (`compile_error_name_not_found:NAME:`); `text` explains it.
        code: Option<ControllerCode>,
    },
    /// `play` of the loaded `.urp` file at this path: read and translate it, then call
    /// [`Cell::start_loaded`] (or [`Cell::refuse_loaded`]).
    NeedProgram {
        /// The loaded program's name, as given to `load`.
        name: String,
        /// Its path, as the [`Programs`](crate::Programs) gave it.
        path: String,
    },
    /// An event of the running program: a message to show (`textmsg`, `popup`), a call
    /// record, or a socket that needs the network (`Connect`, `Transmit`, `Close`: give
    /// those to a driver, e.g. [`urscript_interp::drive::Driver::handle_event`]).
    Program(Event),
    /// A socket event of the secondary program waiting for the network (`Connect`,
    /// `Transmit`, `Close`): give it to a driver of its own, with
    /// [`Cell::secondary_machine_mut`].
    Secondary(Event),
    /// The secondary program that used the network ended: close what its driver holds.
    SecondaryEnded,
}

/// The program running now.
struct Running {
    name: String,
    machine: Machine,
    /// Controller time at which program time 0 was.
    origin: Duration,
    /// When the current pause began.
    paused_at: Option<Duration>,
}

/// The virtual controller in time. See the module docs.
pub struct Cell {
    controller: Controller,
    interp: urscript_interp::Config,
    /// The arm while no program runs. A running program holds the arm (its machine's);
    /// this one is then a stale default until the program ends and hands it back.
    arm: Arm,
    running: Option<Running>,
    events: VecDeque<CellEvent>,
    /// The speed slider (0..1), as an RTDE client set it.
    speed_fraction: f64,
    /// The time of the last `advance`.
    now: Duration,
    /// `NeedProgram` asked and not answered yet.
    awaiting_load: bool,
    /// The installation's URCap preamble, written into the `.urp` programs played.
    preamble: Preamble,
    /// The interpreter connections whose lines the program holds (behind a
    /// `clear_interpreter()`), in the order it will answer them, with the lines (at most
    /// [`interpreter::MAX_UNEXECUTED`]).
    held: VecDeque<(u64, String)>,
    /// Answers to held lines, for their connections (at most
    /// [`interpreter::MAX_UNEXECUTED`]; the oldest go first past it).
    deferred: VecDeque<(u64, interpreter::Reply)>,
    /// The secondary program waiting for the network, if one is.
    secondary: Option<secondary::Secondary>,
    /// The secondary programs sent while one waits (at most
    /// [`secondary::MAX_SECONDARY_QUEUED`]).
    secondary_queue: VecDeque<Compiled>,

    /// Why the program state is about to leave PLAYING, as the client that acted said
    /// ([`Cell::set_stop_cause`]) or the cell itself knows; used by the next pause or
    /// stop.
    cause: Option<StopReason>,
    /// Why the program last paused or stopped ([`Cell::take_stop_reason`]).
    reason: Option<StopReason>,
}

impl std::fmt::Debug for Cell {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Cell")
            .field("controller", &self.controller)
            .field("program", &self.running.as_ref().map(|r| &r.name))
            .field("now", &self.now)
            .finish_non_exhaustive()
    }
}

impl Cell {
    /// A cell around `controller`; programs run with `interp` (its model and step time
    /// should be the controller's: [`Cell::interp_config`] makes one).
    pub fn new(controller: Controller, interp: urscript_interp::Config) -> Self {
        let mut arm = Arm::default();
        // The controller has an RTDE server: the programs' RTDE watchdogs act.
        arm.world.rtde_watchdogs = true;
        Cell {
            controller,
            interp,
            arm,
            running: None,
            events: VecDeque::new(),
            speed_fraction: 1.0,
            now: Duration::ZERO,
            awaiting_load: false,
            preamble: Preamble::default(),
            held: VecDeque::new(),
            deferred: VecDeque::new(),
            secondary: None,
            secondary_queue: VecDeque::new(),

            cause: None,
            reason: None,
        }
    }

    /// A client just paused or stopped the program (a dashboard `stop`, a primary
    /// client's `power off`...): the pause or stop that follows is said with `cause`.
    pub fn set_stop_cause(&mut self, cause: StopReason) {
        self.cause = Some(cause);
    }

    /// Why the program last paused or stopped: once, then the reason the controller's
    /// state shows now (a safety stop, the power off) if no other is known.
    pub fn take_stop_reason(&mut self) -> StopReason {
        match self.reason.take().or_else(|| self.cause.take()) {
            Some(r) => r,
            None => self.state_reason(),
        }
    }

    /// The reason the controller's state shows: a safety stop, the arm powered off, else
    /// the controller's own.
    fn state_reason(&mut self) -> StopReason {
        let now = self.now;
        let safety = self.controller.safety_status(now);
        if !matches!(safety, SafetyStatus::Normal | SafetyStatus::Reduced) {
            return StopReason::Safety(safety);
        }
        if self.controller.robot_mode(now) == RobotMode::PowerOff {
            return StopReason::PowerOff;
        }
        StopReason::Controller
    }

    /// The reason of a pause or stop happening now: the cause given, else the state's.
    fn stop_reason_now(&mut self) -> StopReason {
        let reason = match self.cause.take() {
            Some(c) => c,
            None => self.state_reason(),
        };
        self.reason = Some(reason);
        reason
    }

    /// One line (without its `\n`) from interpreter client `conn`, at `now`: the reply to
    /// write back, or `None` when the program holds the line behind a
    /// `clear_interpreter()` (its reply comes from [`Cell::interpreter_replies`]). See the
    /// module docs.
    pub fn interpreter_line(
        &mut self,
        conn: u64,
        line: &[u8],
        now: Duration,
    ) -> Option<interpreter::Reply> {
        self.advance(now);
        let Some(r) = &mut self.running else {
            let text = String::from_utf8_lossy(line);
            let text = text.strip_suffix('\r').unwrap_or(&text);
            return Some(match Command::parse(text) {
                Some(command) => interpreter::Reply::State { value: 0, command },
                None => interpreter::Reply::Discard {
                    reason: Discard::NotRunning,
                    statement: text.to_string(),
                },
            });
        };
        let reply = r.machine.interpreter_line(line);
        if reply.is_none() {
            let text = String::from_utf8_lossy(line);
            let text = text.strip_suffix('\r').unwrap_or(&text).to_string();
            self.held.push_back((conn, text));
        }
        reply
    }

    /// The replies to `conn`'s held lines that are ready, oldest first.
    pub fn interpreter_replies(&mut self, conn: u64) -> Vec<interpreter::Reply> {
        let mut out = Vec::new();
        self.deferred.retain(|(c, r)| {
            if *c == conn {
                out.push(r.clone());
                false
            } else {
                true
            }
        });
        out
    }

    /// The running program's interpreter-mode numbers (`None`: no program runs).
    pub fn interpreter_status(&self) -> Option<interpreter::Status> {
        self.running
            .as_ref()
            .map(|r| r.machine.interpreter_status())
    }

    fn defer(&mut self, conn: u64, reply: interpreter::Reply) {
        if self.deferred.len() >= interpreter::MAX_UNEXECUTED {
            self.deferred.pop_front();
        }
        self.deferred.push_back((conn, reply));
    }

    /// The installation's URCap preamble: PolyScope writes it at the top of every
    /// program it generates, so it runs before each `.urp` program played here. A
    /// script a client sends (primary/secondary/realtime) gets none, as on the
    /// controller.
    pub fn set_preamble(&mut self, preamble: Preamble) {
        self.preamble = preamble;
    }

    /// The interpreter configuration of a controller: its model, and the step of its
    /// generation (2 ms for e-Series, PolyScope 5; 8 ms for CB3, PolyScope 3).
    pub fn interp_config(controller: &Controller) -> urscript_interp::Config {
        let mut c = if controller.config().major() >= 5 {
            urscript_interp::Config::default()
        } else {
            urscript_interp::Config::cb3()
        };
        c.model = controller.config().model;
        c
    }

    /// The controller's state machine (for the dashboard server).
    pub fn controller(&mut self) -> &mut Controller {
        &mut self.controller
    }

    /// The name of the program running (or paused), if one is.
    pub fn program(&self) -> Option<&str> {
        self.running.as_ref().map(|r| r.name.as_str())
    }

    /// Whether nothing in the cell needs time to pass step by step: no program running,
    /// paused, playing or being loaded, no secondary program waiting for the network, and
    /// no event waiting. What the controller's
    /// state machine does with time alone (power-on, brake release, a stop's hold) is
    /// worked out from the time at the next [`Cell::advance`], however far it jumps.
    pub fn is_idle(&self) -> bool {
        self.running.is_none()
            && self.secondary.is_none()
            && !self.awaiting_load
            && self.events.is_empty()
            && self.controller.program_state() == ProgramState::Stopped
    }

    /// The step length.
    pub fn step_time(&self) -> Duration {
        self.interp.step_time
    }

    /// The arm: the running program's, else the cell's.
    fn arm(&self) -> &Arm {
        match &self.running {
            Some(r) => r.machine.arm(),
            None => &self.arm,
        }
    }

    /// The arm: the running program's, else the cell's. For a test or an operator to
    /// set its joints at rest or what it senses (`arm.world`: inputs, forces,
    /// temperatures, the operator's answers); a running program sees a change at its
    /// next step.
    pub fn arm_mut(&mut self) -> &mut Arm {
        match &mut self.running {
            Some(r) => r.machine.arm_mut(),
            None => &mut self.arm,
        }
    }

    /// The operator moves the arm by hand to joints `q` (rad, each within ±2π), as in
    /// freedrive: while the running program is in `teach_mode()` or `freedrive_mode()`,
    /// or while no program runs (the operator holds the freedrive button). The arm is at
    /// rest there; the program and every stream see the new joints at its next step.
    /// Refused (with the reason) while a program runs outside those modes, or for joints
    /// outside their range.
    pub fn move_by_hand(&mut self, q: [f64; 6]) -> Result<(), String> {
        if self.running.is_some() && !self.arm().hand_guided() {
            return Err(
                "the arm moves by hand only in teach or freedrive mode: the running \
                 program is in neither (teach_mode(), freedrive_mode())"
                    .to_string(),
            );
        }
        self.arm_mut().move_by_hand(q)
    }

    fn push(&mut self, e: CellEvent) {
        if self.events.len() >= MAX_EVENTS {
            self.events.pop_front();
        }
        self.events.push_back(e);
    }

    /// The next event, oldest first.
    pub fn poll_event(&mut self) -> Option<CellEvent> {
        self.events.pop_front()
    }

    /// A program (or secondary program) arrived at `now`; it is compiled here (see
    /// [`Cell::compiler`] to compile elsewhere).
    pub fn submit(&mut self, submitted: Submitted, now: Duration) {
        match submitted {
            Submitted::Program(text) => {
                let program = compile(&text, None, &self.interp);
                self.start_compiled(program, now);
            }
            Submitted::Secondary(text) => {
                let program = compile(&text, None, &self.interp);
                self.run_secondary_compiled(program, now);
            }
        }
    }

    /// What compiling a program needs, to compile on another thread.
    pub fn compiler(&self) -> Compiler {
        Compiler {
            config: self.interp.clone(),
            preamble: self.preamble.clone(),
        }
    }

    /// A program a client sent, compiled ([`Compiler::program`]), arrived at `now`:
    /// it replaces the running one, as [`Cell::submit`] says.
    pub fn start_compiled(&mut self, program: Compiled, now: Duration) {
        self.advance(now);
        self.start(program, None, now);
    }

    /// A secondary program, compiled ([`Compiler::program`]), arrived at `now`.
    pub fn run_secondary_compiled(&mut self, program: Compiled, now: Duration) {
        self.advance(now);
        self.run_secondary(program, now);
    }

    /// The text of the loaded `.urp` program that [`CellEvent::NeedProgram`] asked for.
    pub fn start_loaded(&mut self, script: String, now: Duration) {
        let program = compile(&script, Some(&self.preamble), &self.interp);
        self.start_loaded_compiled(program, now);
    }

    /// The loaded `.urp` program that [`CellEvent::NeedProgram`] asked for, compiled
    /// ([`Compiler::loaded`]).
    pub fn start_loaded_compiled(&mut self, program: Compiled, now: Duration) {
        self.awaiting_load = false;
        if self.controller.program_state() != ProgramState::Playing || self.running.is_some() {
            return; // stopped (or started otherwise) meanwhile
        }
        let name = self
            .controller
            .loaded_program()
            .map(|(n, _)| n.to_string())
            .unwrap_or_default();
        self.start(program, Some(name), now);
    }

    /// The loaded program could not be read or translated: it does not play.
    pub fn refuse_loaded(&mut self, why: String, now: Duration) {
        // Time runs to `now` while the answer is still awaited: the program that is
        // PLAYING without its text must not ask for it again.
        self.advance(now);
        self.awaiting_load = false;
        if self.running.is_none() {
            self.controller.program_ended();
        }
        self.push(CellEvent::Refused {
            line: 0,
            column: 0,
            text: why,
            code: None,
        });
    }

    fn start(&mut self, program: Compiled, file: Option<String>, now: Duration) {
        // A program that does not parse or compile is refused before it replaces
        // anything: the running program goes on. A driver that sends `def f(): ... end`
        // and then `f()` gets its program run to the end and the call refused.
        let Compiled { machine, entry } = program;
        let mut machine = match machine {
            Ok(m) => m,
            Err(refused) => {
                if file.is_some() {
                    self.controller.program_ended();
                }
                self.push(refused);
                return;
            }
        };
        if !self.controller.ready_for_program(now) {
            if file.is_some() {
                self.controller.program_ended();
            }
            let mode = self.controller.robot_mode(now);
            let safety = self.controller.safety_status(now);
            self.push(CellEvent::Refused {
                line: 0,
                column: 0,
                text: format!(
                    "the program was not started: the robot is {mode} with safety {safety} (power on and release the brakes first)"
                ),
                code: None,
            });
            return;
        }
        if self.running.is_some() {
            self.cause = Some(StopReason::Replaced);
        }
        self.end_running(Ended::Stopped);
        let name = file.or(entry).unwrap_or_else(|| "<script>".to_string());
        *machine.arm_mut() = std::mem::take(&mut self.arm);
        if self.controller.loaded_program().is_none() || !self.awaiting_or_playing_file(&name) {
            self.controller.script_started();
        }
        self.running = Some(Running {
            name: name.clone(),
            machine,
            origin: now,
            paused_at: None,
        });
        self.push(CellEvent::ProgramStarted { name });
        // Its first statements run at once, as on the controller.
        self.run_program(now);
    }

    fn awaiting_or_playing_file(&self, name: &str) -> bool {
        self.controller
            .loaded_program()
            .is_some_and(|(n, _)| n == name)
            && self.controller.program_state() == ProgramState::Playing
            && !self.controller.runs_script()
    }

    fn end_running(&mut self, how: Ended) {
        if let Some(r) = self.running.take() {
            let reason = match how {
                Ended::Finished => StopReason::EndOfProgram,
                Ended::Halted => StopReason::Halt,
                Ended::Error(_) => StopReason::RuntimeError,
                Ended::Stopped => self.stop_reason_now(),
            };
            self.reason = Some(reason);
            let mut machine = r.machine;
            while let Some(e) = machine.poll_event() {
                self.push(CellEvent::Program(e));
            }
            // Its sockets close with it.
            for socket_name in machine.open_sockets() {
                self.push(CellEvent::Program(Event::Close { socket_name }));
            }
            let mut arm = machine.into_arm();
            arm.qd = [0.0; 6];
            arm.tcp_speed = [0.0; 6];
            self.arm = arm;
            // Lines held behind a clear that never ran: no program runs for them now.
            while let Some((conn, statement)) = self.held.pop_front() {
                let reply = interpreter::Reply::Discard {
                    reason: Discard::NotRunning,
                    statement,
                };
                self.defer(conn, reply);
            }
            self.push(CellEvent::ProgramEnded {
                name: r.name,
                how,
                reason,
            });
        }
    }

    /// Runs time forward to `now`: the state machine's transitions, then the program's
    /// steps (not while paused), reacting to what clients did to the program state.
    pub fn advance(&mut self, now: Duration) {
        let now = now.max(self.now);
        // A pause or a play happened after the last advance: program time stops (or
        // goes on) from there, not from now.
        let prev = self.now;
        self.now = now;
        self.controller.handle_timeout(now);
        let state = self.controller.program_state();
        match (&mut self.running, state) {
            (Some(_), ProgramState::Stopped) => {
                self.end_running(Ended::Stopped);
            }
            (Some(r), ProgramState::Paused) => {
                if r.paused_at.is_none() {
                    r.paused_at = Some(prev);
                    self.stop_reason_now();
                }
            }
            (Some(r), ProgramState::Playing) => {
                if let Some(at) = r.paused_at.take() {
                    r.origin += prev.saturating_sub(at);
                }
                self.run_program(now);
            }
            (None, ProgramState::Playing) => {
                if !self.awaiting_load && !self.controller.runs_script() {
                    if let Some((name, path)) = self.controller.loaded_program() {
                        let (name, path) = (name.to_string(), path.to_string());
                        self.awaiting_load = true;
                        self.push(CellEvent::NeedProgram { name, path });
                    }
                } else if self.controller.runs_script() {
                    // A script program's state with no program behind it.
                    self.controller.program_ended();
                }
            }
            (None, _) => {}
        }
        self.advance_secondary(now);
    }

    fn run_program(&mut self, now: Duration) {
        let speed_fraction = self.speed_fraction;
        let Some(r) = &mut self.running else { return };
        // The speed slider scales the program's motion from the step it changed in.
        r.machine.arm_mut().speed_fraction = speed_fraction;
        r.machine.run_until(now.saturating_sub(r.origin));
        let mut stopped = false;
        let effects = r.machine.take_effects();
        if effects.contains(&Effect::ProtectiveStop) {
            // `protective_stop()`: a loaded program pauses, one a client sent ends
            // (`Controller::protective_stop`).
            self.controller.protective_stop(now);
            r.paused_at = Some(now);
            stopped = self.controller.program_state() == ProgramState::Stopped;
            self.reason = Some(StopReason::Safety(SafetyStatus::ProtectiveStop));
        }
        if effects.contains(&Effect::Pause) {
            // An RTDE watchdog with the action "pause": the program pauses.
            self.controller.pause_program(now);
            r.paused_at.get_or_insert(now);
            self.reason = Some(StopReason::RtdeWatchdog);
        }
        let mut out = Vec::new();
        while let Some(e) = r.machine.poll_event() {
            out.push(e);
        }
        let mut replies = Vec::new();
        while let Some(reply) = r.machine.poll_interpreter_reply() {
            replies.push(reply);
        }
        let powerdown = effects.contains(&Effect::PowerOff);
        let end = match r.machine.state() {
            State::Running if stopped => Some(Ended::Stopped),
            State::Running => None,
            State::Finished => Some(Ended::Finished),
            State::Halted => Some(Ended::Halted),
            State::Error(e) => Some(Ended::Error(e.clone())),
        };
        for e in out {
            self.push(CellEvent::Program(e));
        }
        for reply in replies {
            if let Some((conn, _)) = self.held.pop_front() {
                self.defer(conn, reply);
            }
        }
        if let Some(how) = end {
            self.end_running(how);
            self.controller.program_ended();
        }
        if powerdown {
            // `powerdown()`: the arm powers off (the virtual controller itself stays up
            // for its clients).
            self.controller.powerdown(now);
            self.cause = Some(StopReason::Powerdown);
        }
    }

    /// When the cell next has something to do by itself: the program's next step or
    /// the state machine's next transition.
    pub fn poll_timeout(&self) -> Option<Duration> {
        let program = self.running.as_ref().and_then(|r| {
            if r.paused_at.is_some() {
                None
            } else {
                r.machine.poll_timeout().map(|t| t + r.origin)
            }
        });
        let secondary = self
            .secondary
            .as_ref()
            .and_then(|s| s.machine.poll_timeout().map(|t| t + s.origin));
        [program, secondary, self.controller.poll_timeout()]
            .into_iter()
            .flatten()
            .min()
    }

    /// The running program's machine, for a driver that gives it what its sockets did
    /// ([`Machine::handle_connected`], [`Machine::handle_received`], ...).
    pub fn machine_mut(&mut self) -> Option<&mut Machine> {
        self.running.as_mut().map(|r| &mut r.machine)
    }

    /// Applies what a client wrote (RTDE inputs): outputs, input registers, the speed
    /// slider, the payload.
    pub fn apply(&mut self, inputs: &Inputs) {
        if let Some(f) = inputs.speed_slider_fraction {
            if f.is_finite() {
                self.speed_fraction = f.clamp(0.0, 1.0);
            }
        }
        let speed_fraction = self.speed_fraction;
        let arm = self.arm_mut();
        arm.speed_fraction = speed_fraction;
        // Each RTDE input field written counts as an update for the programs' RTDE
        // watchdogs, under its RTDE name (the keys stay RTDE's bounded set of names).
        for name in &inputs.fields {
            *arm.world
                .rtde_input_updates
                .entry(name.clone())
                .or_default() += 1;
        }
        let masked = |out: &mut [bool], (mask, values): (u8, u8)| {
            for (i, o) in out.iter_mut().enumerate().take(8) {
                if mask & (1 << i) != 0 {
                    *o = values & (1 << i) != 0;
                }
            }
        };
        if let Some(mv) = inputs.standard_digital_outputs {
            masked(&mut arm.digital_out[0..8], mv);
        }
        if let Some(mv) = inputs.configurable_digital_outputs {
            masked(&mut arm.digital_out[8..16], mv);
        }
        if let Some(mv) = inputs.tool_digital_outputs {
            masked(&mut arm.digital_out[16..18], mv);
            masked(&mut arm.tool_out, mv);
        }
        if let Some((mask, types, values)) = inputs.standard_analog_outputs {
            for (i, value) in values.into_iter().enumerate() {
                if mask & (1 << i) != 0 && value.is_finite() {
                    let voltage = types & (1 << i) != 0;
                    arm.analog_out_domain[i] = i32::from(voltage);
                    // RTDE carries the output as a fraction of its range, as
                    // `set_standard_analog_out` does.
                    arm.analog_out[i] = value.clamp(0.0, 1.0);
                }
            }
        }
        for &(i, v) in &inputs.bool_registers {
            if let Some(r) = arm.world.input_bool_regs.get_mut(i) {
                *r = v;
            }
        }
        for &(i, v) in &inputs.int_registers {
            if let Some(r) = arm.world.input_int_regs.get_mut(i) {
                *r = v;
            }
        }
        for &(i, v) in &inputs.double_registers {
            if let Some(r) = arm.world.input_float_regs.get_mut(i) {
                *r = v;
            }
        }
        if let Some((mass, cog, inertia)) = inputs.payload {
            if mass.is_finite() && mass >= 0.0 {
                arm.payload_mass = mass;
                arm.payload_cog = cog;
                if let Some(i) = inertia {
                    arm.payload_inertia = i;
                }
            }
        }
    }

    /// The controller now, for the streams.
    pub fn status(&mut self) -> Status {
        let now = self.now;
        let robot_mode = self.controller.robot_mode(now);
        let safety = self.controller.safety_status(now);
        let program_state = self.controller.program_state();
        let remote_control = self.controller.remote_control();
        let model = self.controller.config().model;
        let dh = model.dh();
        let speed_fraction = self.speed_fraction;
        let arm = self.arm();
        let pose = kinematics::forward(&dh, arm.q, arm.tcp);
        let bits = |b: &[bool]| {
            b.iter()
                .enumerate()
                .fold(0u64, |acc, (i, &on)| acc | (u64::from(on) << i))
        };
        let mut outputs = bits(&arm.digital_out);
        outputs |= bits(&arm.tool_out) << 16;
        let w = &arm.world;
        let powered = !matches!(
            robot_mode,
            crate::RobotMode::PowerOff
                | crate::RobotMode::Disconnected
                | crate::RobotMode::NoController
        );
        let analog_out = |i: usize| {
            let f = arm.analog_out[i];
            if arm.analog_out_domain[i] == 0 {
                (4.0 + 16.0 * f) / 1000.0 // 4-20 mA, in A
            } else {
                10.0 * f // 0-10 V
            }
        };
        let mut analog_io_types = 0b11; // inputs: voltage
        for i in 0..2 {
            if arm.analog_out_domain[i] != 0 {
                analog_io_types |= 1 << (2 + i);
            }
        }
        Status {
            time: now.as_secs_f64(),
            model,
            robot_mode,
            safety,
            program_state,
            remote_control,
            script_line: 0,
            target_q: arm.q,
            target_qd: arm.qd,
            target_qdd: arm.qdd,
            actual_q: arm.q,
            actual_qd: arm.qd,
            target_current: [0.0; 6],
            actual_current: [0.0; 6],
            target_moment: w.joint_torques,
            joint_temperatures: w.joint_temp,
            joint_voltage: if powered { [48.0; 6] } else { [0.0; 6] },
            actual_tcp_pose: pose,
            actual_tcp_speed: arm.tcp_speed,
            actual_tcp_force: arm.measured_tcp_force(&dh),
            target_tcp_pose: pose,
            target_tcp_speed: arm.tcp_speed,
            tcp_offset: arm.tcp,
            tool_accelerometer: [0.0, 0.0, 9.82],
            speed_fraction,
            speed_scaling: speed_fraction,
            control_mode: arm.control_mode(),
            digital_inputs: bits(&w.digital_in),
            digital_outputs: outputs,
            analog_inputs: [w.analog_in[0], w.analog_in[1]],
            analog_outputs: [analog_out(0), analog_out(1)],
            analog_io_types,
            tool_analog_inputs: [w.analog_in[2], w.analog_in[3]],
            tool_analog_input_types: 0b11,
            tool_output_voltage: 0,
            tool_current: w.tool_current,
            tool_temperature: w.tool_temp,
            io_current: 0.0,
            output_bool_registers: arm.bool_regs,
            output_int_registers: arm.int_regs,
            output_double_registers: arm.float_regs,
            input_bool_registers: w.input_bool_regs,
            input_int_registers: w.input_int_regs,
            input_double_registers: w.input_float_regs,
            payload_mass: arm.payload_mass,
            payload_cog: arm.payload_cog,
            payload_inertia: arm.payload_inertia,
            main_voltage: 48.0,
            robot_voltage: if powered { 48.0 } else { 0.0 },
            robot_current: if powered { 0.5 } else { 0.0 },
            controller_temperature: w.controller_temp,
        }
    }
}

/// Parses a program (after `preamble`, if given); one that does not parse is refused with
/// the controller's `syntax_error_on_line:LINE:...` text.
fn parse(text: &str, preamble: Option<&Preamble>) -> Result<Program, CellEvent> {
    match preamble {
        Some(p) => Program::parse_with_preamble(p, text),
        None => Program::parse(text),
    }
    .map_err(|e| {
        let (text, code) = match e.code() {
            // The code, then what was wrong (the controller names the token).
            code @ ControllerCode::SyntaxErrorOnLine { .. } => {
                (format!("{code}{}", e.message()), None)
            }
            // A code of its own: the interpreter's message, which names it.
            code => (e.message().to_string(), Some(code)),
        };
        CellEvent::Refused {
            line: e.line(),
            column: e.column(),
            text,
            code,
        }
    })
}
