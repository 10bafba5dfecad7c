//! A virtual Universal Robots controller that unmodified clients drive. Every interface
//! is sans-IO like the rest of the workspace (time is an input, bytes in and out); the
//! one module with sockets and threads, [`net`] (feature `net`, on by default), serves
//! them all on the controller's ports, in-process for a driver's tests or as
//! `ursock controller`.
//!
//! - [`Controller`]: the **dashboard server**'s state machine (robot mode, safety status,
//!   the loaded program and its state, operational mode, remote control, what the
//!   controller says about itself) and [`Dashboard`], its command lines and replies.
//! - [`Cell`]: the controller, the arm and the program running on it, in time; one
//!   [`Status`] per step for every stream.
//! - [`primary`], [`realtime`], [`rtde`], [`script_intake`], [`urp`]: the other interfaces
//!   (below).
//! - [`net::Server`]: all of it on TCP.
//!
//! ```
//! use std::time::Duration;
//! use urscript_controller::{Config, Controller, Dashboard};
//!
//! let mut controller = Controller::new(Config::default());
//! let mut dashboard = Dashboard::new();
//! let t = Duration::from_secs(0);
//! assert_eq!(Dashboard::greeting().lines, ["Connected: Universal Robots Dashboard Server"]);
//! assert_eq!(dashboard.handle_line(&mut controller, "power on", t).lines, ["Powering on"]);
//! let later = t + Duration::from_secs(2);
//! assert_eq!(dashboard.handle_line(&mut controller, "robotmode", later).lines, ["Robotmode: IDLE"]);
//! ```
//!
//! # Transitions and their timing ([`Timing`])
//!
//! - `power on`: POWER_OFF -> BOOTING -> POWER_ON -> IDLE (0.1 s + 0.1 s by default).
//!   Under an emergency stop, a violation or a fault the command is answered but power
//!   stays off.
//! - `brake release`: IDLE -> RUNNING after 0.2 s; from POWER_OFF it powers on first
//!   (as UR's ROS driver documents: "if the robot is currently powered off, it will get
//!   powered on on the fly").
//! - A protective stop ([`Controller::protective_stop`]) pauses a playing loaded program,
//!   ends one a client sent (URSim does: UR's client library waits for its
//!   `PROGRAM_XXX_STOPPED`), and holds 5 s: `unlock protective stop` before that gets the controller's refusal text.
//!   The primary interface's `set unlock protective stop` releases it at once: UR
//!   documents the hold for the dashboard command, and UR's client library, tested
//!   against URSim, unlocks through the primary interface right after a stop and
//!   expects the stop gone within 5 s ([`Controller::request_unlock_protective_stop`]).
//! - `play` needs a loaded program, RUNNING and a safety that allows motion; `pause` only
//!   from PLAYING; `stop` needs a loaded program (stopping a stopped one answers
//!   `Stopped`, undocumented: chosen so that clients that stop defensively go on);
//!   otherwise `Failed to execute: ...`.
//! - `load` and `load installation` are refused (`Error while loading program: NAME`,
//!   `Failed to load installation: NAME`) while a program plays or is paused, in
//!   AUTOMATIC operational mode, where UR documents that only playing is allowed, and for
//!   a file that exists but is not a `.urp` (`.installation`); a missing file is
//!   `File not found: NAME`.
//! - `restart safety`: BOOTING for 0.5 s, then POWER_OFF with the safety NORMAL.
//! - In local control ([`Config::remote_control`] false) every command that acts (load,
//!   play, stop, pause, shutdown, power, brakes, unlock, restart safety, operational
//!   mode, load installation) gets the controller's refusal; queries still answer.
//!   With the remote control setting off ([`Config::remote_control_enabled`] false, a new
//!   robot's and URSim's state, which UR's client library's tests expect) every command
//!   is accepted and `is in remote control` answers false.
//!
//! This state machine keeps the program state (PLAYING until stop or pause); the
//! [`net`] server runs the loaded `.urp`'s program, translated by [`urp`], on the
//! interpreter.
//!
//! # Primary, secondary and realtime interfaces
//!
//! [`primary`] writes what ports 30001/30002 send (the version message, the 10 Hz robot
//! state message with its sub-packages, robot messages such as `PROGRAM_XXX_STARTED`),
//! [`realtime`] the port 30003 package, both from a [`Status`] and the [`Config`], in
//! the e-Series (5.x) or CB3 (3.x) layout after [`Config::major`]. [`script_intake`]
//! cuts what clients write on those ports into programs, secondary programs, bare lines
//! and commands, within fixed bounds.
//!
//! # PolyScope programs ([`urp`])
//!
//! [`read_urp`] reads a `.urp` (gzip-compressed XML, as PolyScope 3.x and 5.x save it)
//! and translates its program tree into URScript that `urscript_interp` runs, within
//! documented bounds (file and inflated size, element count, nesting). UR's External
//! Control URCap node becomes a place in the program, with the host and port the URCap
//! would ask (set from the installation: [`read_external_control_settings`]);
//! [`translate_with`] splices in the script fetched from there.
//!
//! # Where the reply texts come from, and the choices where sources disagree
//!
//! Sources: UR's dashboard server pages (the CB3 page "Dashboard Server, port 29999",
//! and the e-Series 5.x command table as quoted by several clients), and the clients that
//! parse the replies: UR's `Universal_Robots_Client_Library` (`dashboard_client_
//! implementation_g5.cpp`, whose tests run against URSim), UR's ROS 2 driver
//! (`dashboard_client_ros.cpp`) and `ur_rtde` (`dashboard_client.cpp`).
//!
//! - `set operational mode M`: UR's page documents `Setting operational mode: M`; UR's
//!   client library (tested against URSim) and UR's drivers expect
//!   `Operational mode 'M' is set`. The controller's observed text is used, with `M`
//!   as the client sent it.
//! - `clear operational mode`: the page's summary reads "operational mode is no longer
//!   controlled by Dashboard Server"; the controller says `No longer controlling the
//!   operational mode. Current operational mode: 'NONE'.` (URSim, and the client
//!   library's pattern), which is used. UR's ROS driver's pattern accepts only MANUAL or
//!   AUTOMATIC there; this controller reports the cleared mode as NONE, as
//!   `get operational mode` does afterwards on URSim.
//! - `generate flight report`: documented as returning the report id; UR's client
//!   library expects `Flight Report generated with id: ID`, which is used. Nothing is
//!   generated, and `generate support file DIR` names a file it does not write.
//! - `isProgramSaved`: `true NAME.urp` / `false NAME`, lowercase as documented (ur_rtde
//!   looks for `True` and so always reads false). With no program: `false <unnamed>`.
//! - `programState`: `STATE NAME` with the file name of the loaded program, or
//!   `STOPPED <unnamed>` with none (as URSim and real controllers answer).
//! - `running`: `Program running: true|false` (e-Series; the CB3 page's `Robot running:
//!   True` is older).
//! - `get robot model`: `UR5` for a UR5e (the e-Series documents UR3, UR5, UR10, UR16).
//! - `setUserRole` / `getUserRole`: CB3 only; a 5.x controller answers them as unknown
//!   commands (UR's client library refuses them on e-Series), a 3.x one (`--polyscope
//!   3.15.0`) with the CB3 texts.
//! - `unlock protective stop` with no protective stop: answered `Protective stop
//!   releasing`, nothing changes (undocumented).
//! - Unknown commands: `could not understand: 'LINE'`. Lines longer than [`MAX_LINE`]
//!   bytes get the same shape with the first 40 bytes and a note.
//! - Command words match in any case (`polyscopeVersion`, `PolyscopeVersion`); their
//!   arguments keep theirs.
//!
//! # RTDE (port 30004)
//!
//! [`RtdeSession`] serves one Real-Time Data Exchange client: protocol versions 1 and
//! 2, output recipes streamed from the step's [`Status`] at the frequency asked, input
//! recipes decoded into [`Inputs`] for the cell to apply, input ownership shared
//! between clients through an [`InputRegistry`]. The [`rtde`] module's documentation
//! lists the fields, the choices and the bounds.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod cell;
mod dashboard;
mod lines;
#[cfg(feature = "net")]
pub mod net;
mod operator;
pub mod primary;
pub mod realtime;
mod reason;
pub mod rtde;
pub mod script_intake;
mod state;
mod status;
pub mod urp;

pub use cell::secondary::{MAX_SECONDARY_QUEUED, SECONDARY_TIME};
pub use cell::{Cell, CellEvent, Compiled, Compiler, Ended, Submitted, MAX_EVENTS};
pub use dashboard::{
    Dashboard, DashboardCommand, Reply, GREETING, LOCAL_CONTROL, MAX_LINE, UNLOCK_TOO_EARLY,
};
pub use operator::{operator_help, OperatorCommand, OperatorError, OPERATOR_COMMANDS};
pub use reason::StopReason;
pub use rtde::{
    rtde_controller_version, rtde_input_type, rtde_max_frequency, rtde_output_type, InputRegistry,
    RtdeError, RtdeEvent, RtdeSession, RtdeTextLevel, RtdeType, RtdeValue, RTDE_DATA_PACKAGE,
    RTDE_GET_URCONTROL_VERSION, RTDE_MAX_EVENTS, RTDE_MAX_FIELDS, RTDE_MAX_INPUT_RECIPES,
    RTDE_MAX_OUTBOX, RTDE_MAX_OUTPUT_RECIPES, RTDE_MAX_PACKET_SIZE, RTDE_PAUSE,
    RTDE_REQUEST_PROTOCOL_VERSION, RTDE_SETUP_INPUTS, RTDE_SETUP_OUTPUTS, RTDE_START,
    RTDE_TEXT_MESSAGE,
};
pub use state::{
    Config, Controller, OperationalMode, ProgramList, ProgramState, Programs, Refused, RobotMode,
    SafetyStatus, Timing, MAX_LOG,
};
pub use status::{Inputs, Status};
pub use urp::{
    read_external_control_settings, read_urp, translate_with, ExternalControlNode,
    ExternalControlSettings, FetchError, UrpError, UrpProgram,
};
pub use urscript_interp::kinematics::Model;
