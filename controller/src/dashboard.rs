//! The dashboard server (port 29999): one [`Dashboard`] per connection, one line in,
//! one [`Reply`] out, over the shared [`Controller`].

use std::time::Duration;

use crate::state::{Controller, OperationalMode, Refused};

/// The longest command line answered, in bytes; a longer one gets
/// [`Dashboard::line_too_long`] (the adapter discards it up to its newline).
pub const MAX_LINE: usize = 4096;

/// The greeting sent when a client connects.
pub const GREETING: &str = "Connected: Universal Robots Dashboard Server";

/// The reply to every remote-only command while the pendant is in local control.
pub const LOCAL_CONTROL: &str = "Command is not allowed due to safety reasons, please switch robot to Remote Control mode and reconnect to port 29999";

/// The reply to `unlock protective stop` within the hold time.
pub const UNLOCK_TOO_EARLY: &str = "Cannot unlock protective stop until 5s after occurrence. Always inspect cause of protective stop before unlocking";

/// What to send back for one line: each line is sent followed by `"\n"`; after them,
/// close the connection when `close` is set.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Reply {
    /// The lines to send, without their `"\n"`.
    pub lines: Vec<String>,
    /// Close the connection after sending (`quit`, `shutdown`).
    pub close: bool,
}

impl Reply {
    fn line(text: impl Into<String>) -> Self {
        Reply {
            lines: vec![text.into()],
            close: false,
        }
    }

    fn closing(text: impl Into<String>) -> Self {
        Reply {
            lines: vec![text.into()],
            close: true,
        }
    }

    /// The bytes to write: every line followed by `"\n"`, in one buffer (clients such as
    /// ur_rtde read a reply with one `read`).
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::new();
        for l in &self.lines {
            out.extend_from_slice(l.as_bytes());
            out.push(b'\n');
        }
        out
    }
}

/// One dashboard connection. It holds no state of its own yet beyond the count of
/// commands answered; the controller's state is shared by every connection.
#[derive(Debug, Clone, Default)]
pub struct Dashboard {
    commands: u64,
}

/// `text` cut to at most `max` bytes on a character boundary.
fn cut(text: &str, max: usize) -> &str {
    if text.len() <= max {
        return text;
    }
    let mut end = max;
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    &text[..end]
}

/// The reply for a refusal by local control, else `other`.
fn refused(e: Refused, other: impl FnOnce() -> String) -> Reply {
    match e {
        Refused::LocalControl => Reply::line(LOCAL_CONTROL),
        _ => Reply::line(other()),
    }
}

/// The model as `get robot model` prints it: the e-Series arms without their `e`
/// (`UR5`), as the controller documents (UR3, UR5, UR10, UR16, UR20, UR30).
fn model_name(controller: &Controller) -> String {
    let name = controller.config().model.name();
    name.strip_suffix('e').unwrap_or(name).to_string()
}

/// The file name of a path (`/programs/a/pick.urp` -> `pick.urp`).
fn file_name(path: &str) -> &str {
    path.rsplit('/').next().unwrap_or(path)
}

impl Dashboard {
    /// A new connection.
    pub fn new() -> Self {
        Dashboard::default()
    }

    /// The greeting to send first.
    pub fn greeting() -> Reply {
        Reply::line(GREETING)
    }

    /// How many lines this connection answered.
    pub fn commands(&self) -> u64 {
        self.commands
    }

    /// The reply to a line longer than [`MAX_LINE`] bytes (`start`: its first bytes).
    pub fn line_too_long(&mut self, start: &str) -> Reply {
        self.commands += 1;
        Reply::line(format!(
            "could not understand: '{}...' (a command line is at most {MAX_LINE} bytes)",
            cut(start, 40)
        ))
    }

    /// Answer one command line (without its `"\n"`; a trailing `"\r"` and surrounding
    /// blanks are ignored) at time `now`: [`DashboardCommand::parse`], then
    /// [`answer`](Self::answer).
    pub fn handle_line(&mut self, controller: &mut Controller, line: &str, now: Duration) -> Reply {
        if line.len() > MAX_LINE {
            controller.handle_timeout(now);
            return self.line_too_long(line);
        }
        let command = DashboardCommand::parse(line, controller.config().major());
        self.answer(controller, &command, now)
    }

    /// Carries out one command at time `now` and says what to reply.
    pub fn answer(
        &mut self,
        controller: &mut Controller,
        command: &DashboardCommand,
        now: Duration,
    ) -> Reply {
        self.commands += 1;
        controller.handle_timeout(now);
        match command.group() {
            Group::Program => program_command(controller, command, now),
            Group::PowerAndSafety => power_and_safety(controller, command, now),
            Group::Operator => operator_command(controller, command),
            Group::About => about(controller, command),
        }
    }
}

/// The dashboard's commands by what they act on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Group {
    /// Programs and installations: load, play, pause, stop, their state; the connection
    /// and the controller (`quit`, `shutdown`).
    Program,
    /// Power, brakes, safety, operational mode, remote control; the robot mode.
    PowerAndSafety,
    /// What the operator sees: popups, the log.
    Operator,
    /// The controller itself: versions, serial number, model, user role, reports; and
    /// the lines not understood.
    About,
}

impl DashboardCommand {
    fn group(&self) -> Group {
        use DashboardCommand as C;
        match self {
            C::LoadInstallation(_)
            | C::Load(_)
            | C::Play
            | C::Stop
            | C::Pause
            | C::Quit
            | C::Shutdown
            | C::Running
            | C::GetLoadedProgram
            | C::IsProgramSaved
            | C::ProgramState => Group::Program,
            C::RobotMode
            | C::PowerOn
            | C::PowerOff
            | C::BrakeRelease
            | C::SafetyStatus
            | C::SafetyMode
            | C::UnlockProtectiveStop
            | C::CloseSafetyPopup
            | C::RestartSafety
            | C::ClearOperationalMode
            | C::SetOperationalMode(_)
            | C::GetOperationalMode
            | C::IsInRemoteControl => Group::PowerAndSafety,
            C::Popup(_) | C::ClosePopup | C::AddToLog(_) | C::SaveLog => Group::Operator,
            C::PolyscopeVersion
            | C::Version
            | C::SetUserRole(_)
            | C::GetUserRole
            | C::GetSerialNumber
            | C::GetRobotModel
            | C::GenerateFlightReport(_)
            | C::GenerateSupportFile(_)
            | C::Unknown(_) => Group::About,
        }
    }
}

/// Why a command reached a group's function that does not answer it.
fn misrouted(command: &DashboardCommand) -> Reply {
    Reply::line(format!("could not understand: '{command}'"))
}

/// `load`, `load installation`, `play`, `pause`, `stop`, their state; `quit`, `shutdown`.
fn program_command(
    controller: &mut Controller,
    command: &DashboardCommand,
    now: Duration,
) -> Reply {
    use DashboardCommand as C;
    match command {
        C::LoadInstallation(name) => match controller.load_installation(name) {
            Ok(()) => Reply::line(format!("Loading installation: {name}")),
            Err(e) => refused(e, || match e {
                Refused::NotFound => format!("File not found: {name}"),
                _ => format!("Failed to load installation: {name}"),
            }),
        },
        C::Load(name) => match controller.load(name) {
            Ok(()) => Reply::line(format!("Loading program: {name}")),
            Err(e) => refused(e, || match e {
                Refused::NotFound => format!("File not found: {name}"),
                _ => format!("Error while loading program: {name}"),
            }),
        },
        C::Play => match controller.play(now) {
            Ok(()) => Reply::line("Starting program"),
            Err(e) => refused(e, || "Failed to execute: play".into()),
        },
        C::Stop => match controller.stop(now) {
            Ok(()) => Reply::line("Stopped"),
            Err(e) => refused(e, || "Failed to execute: stop".into()),
        },
        C::Pause => match controller.pause(now) {
            Ok(()) => Reply::line("Pausing program"),
            Err(e) => refused(e, || "Failed to execute: pause".into()),
        },
        C::Quit => Reply::closing("Disconnected"),
        C::Shutdown => match controller.shutdown(now) {
            Ok(()) => Reply::closing("Shutting down"),
            Err(e) => refused(e, || "Failed to execute: shutdown".into()),
        },
        C::Running => {
            let playing = controller.program_state() == crate::ProgramState::Playing;
            Reply::line(format!("Program running: {playing}"))
        }
        C::GetLoadedProgram => Reply::line(match controller.loaded_program() {
            Some((_, path)) => format!("Loaded program: {path}"),
            None => "No program loaded".into(),
        }),
        C::IsProgramSaved => Reply::line(match controller.loaded_program() {
            Some((_, path)) => format!("true {}", file_name(path)),
            None => "false <unnamed>".into(),
        }),
        C::ProgramState => {
            let name = controller
                .loaded_program()
                .map_or("<unnamed>", |(_, path)| file_name(path));
            Reply::line(format!("{} {name}", controller.program_state()))
        }
        _ => misrouted(command),
    }
}

/// Power, brakes, safety, operational mode, remote control, the robot mode.
fn power_and_safety(
    controller: &mut Controller,
    command: &DashboardCommand,
    now: Duration,
) -> Reply {
    use DashboardCommand as C;
    match command {
        C::RobotMode => Reply::line(format!("Robotmode: {}", controller.robot_mode(now))),
        C::PowerOn => match controller.power_on(now) {
            Err(Refused::LocalControl) => Reply::line(LOCAL_CONTROL),
            // Under an emergency stop or a fault the command is taken but power
            // stays off, as `robotmode` then shows.
            _ => Reply::line("Powering on"),
        },
        C::PowerOff => match controller.power_off(now) {
            Err(Refused::LocalControl) => Reply::line(LOCAL_CONTROL),
            _ => Reply::line("Powering off"),
        },
        C::BrakeRelease => match controller.brake_release(now) {
            Err(Refused::LocalControl) => Reply::line(LOCAL_CONTROL),
            _ => Reply::line("Brake releasing"),
        },
        C::SafetyStatus => Reply::line(format!("Safetystatus: {}", controller.safety_status(now))),
        C::SafetyMode => {
            let s = controller.safety_status(now);
            Reply::line(format!("Safetymode: {}", s.safety_mode_name()))
        }
        C::UnlockProtectiveStop => match controller.unlock_protective_stop(now) {
            Ok(()) => Reply::line("Protective stop releasing"),
            Err(e) => refused(e, || UNLOCK_TOO_EARLY.into()),
        },
        C::CloseSafetyPopup => Reply::line("closing safety popup"),
        C::RestartSafety => match controller.restart_safety(now) {
            Ok(()) => Reply::line("Restarting safety"),
            Err(e) => refused(e, || "Failed to execute: restart safety".into()),
        },
        C::ClearOperationalMode => match controller.clear_operational_mode() {
            Ok(()) => Reply::line(
                "No longer controlling the operational mode. Current operational mode: 'NONE'.",
            ),
            Err(e) => refused(e, String::new),
        },
        C::SetOperationalMode(mode) => match OperationalMode::parse(mode) {
            Some(m) => match controller.set_operational_mode(m) {
                Ok(()) => Reply::line(format!("Operational mode '{mode}' is set")),
                Err(e) => refused(e, String::new),
            },
            None => Reply::line(format!("Failed setting operational mode: {mode}")),
        },
        C::GetOperationalMode => {
            Reply::line(controller.operational_mode().map_or("NONE", |m| m.name()))
        }
        C::IsInRemoteControl => Reply::line(controller.remote_control().to_string()),
        _ => misrouted(command),
    }
}

/// Popups and the log.
fn operator_command(controller: &mut Controller, command: &DashboardCommand) -> Reply {
    use DashboardCommand as C;
    match command {
        C::Popup(text) => {
            controller.set_popup(Some(text.clone()));
            Reply::line("showing popup")
        }
        C::ClosePopup => {
            controller.set_popup(None);
            Reply::line("closing popup")
        }
        C::AddToLog(text) if text.is_empty() => Reply::line("No log message to add"),
        C::AddToLog(text) => {
            controller.add_to_log(text.clone());
            Reply::line("Added log message")
        }
        C::SaveLog => Reply::line("Log saved to disk"),
        _ => misrouted(command),
    }
}

/// Versions, serial number, model, user role, reports; a line not understood.
fn about(controller: &mut Controller, command: &DashboardCommand) -> Reply {
    use DashboardCommand as C;
    match command {
        C::PolyscopeVersion => {
            let c = controller.config();
            Reply::line(format!(
                "URSoftware {} ({})",
                c.full_version(),
                c.build_date
            ))
        }
        C::Version => Reply::line(controller.config().full_version()),
        C::SetUserRole(role) => {
            let known = ["programmer", "operator", "none", "locked", "restricted"];
            Reply::line(if known.iter().any(|k| k.eq_ignore_ascii_case(role)) {
                format!("Setting user role: {role}")
            } else {
                format!("Failed setting user role: {role}")
            })
        }
        C::GetUserRole => Reply::line("PROGRAMMER"),
        C::GetSerialNumber => Reply::line(controller.config().serial.clone()),
        C::GetRobotModel => Reply::line(model_name(controller)),
        C::GenerateFlightReport(kind) => {
            let kind = if kind.is_empty() { "system" } else { kind };
            if !["controller", "software", "system"]
                .iter()
                .any(|k| k.eq_ignore_ascii_case(kind))
            {
                return Reply::line(format!(
                    "Error: report type '{}' is not one of controller, software, system",
                    cut(kind, 64)
                ));
            }
            let id = controller.next_report();
            Reply::line(format!("Flight Report generated with id: {id:08x}"))
        }
        C::GenerateSupportFile(dir) => {
            let id = controller.next_report();
            let serial = controller.config().serial.clone();
            let dir = dir.trim_end_matches('/');
            let file = format!("ur_{serial}_support_file_{id:04}.zip");
            Reply::line(if dir.is_empty() || dir == "." {
                format!("Completed successfully: {file}")
            } else {
                format!("Completed successfully: {dir}/{file}")
            })
        }
        C::Unknown(line) => Reply::line(format!("could not understand: '{line}'")),

        _ => misrouted(command),
    }
}

/// One dashboard command line, parsed ([`DashboardCommand::parse`]); its
/// [`Display`](std::fmt::Display) is the line again, in the words UR's documentation
/// spells. An argument is the rest of the line after the command's words and one space,
/// trimmed (empty when there is none); each command keeps it as given (case included).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum DashboardCommand {
    /// `load installation NAME`.
    LoadInstallation(String),
    /// `load PROGRAM`.
    Load(String),
    /// `play`.
    Play,
    /// `stop`.
    Stop,
    /// `pause`.
    Pause,
    /// `quit`: the connection closes.
    Quit,
    /// `shutdown`.
    Shutdown,
    /// `running`.
    Running,
    /// `robotmode`.
    RobotMode,
    /// `get loaded program`.
    GetLoadedProgram,
    /// `popup TEXT`.
    Popup(String),
    /// `close popup`.
    ClosePopup,
    /// `addToLog TEXT`.
    AddToLog(String),
    /// `isProgramSaved`.
    IsProgramSaved,
    /// `programState`.
    ProgramState,
    /// `PolyscopeVersion`.
    PolyscopeVersion,
    /// `version`.
    Version,
    /// `setUserRole ROLE` (CB3 only).
    SetUserRole(String),
    /// `getUserRole` (CB3 only).
    GetUserRole,
    /// `power on`.
    PowerOn,
    /// `power off`.
    PowerOff,
    /// `brake release`.
    BrakeRelease,
    /// `safetystatus`.
    SafetyStatus,
    /// `safetymode`.
    SafetyMode,
    /// `unlock protective stop`.
    UnlockProtectiveStop,
    /// `close safety popup`.
    CloseSafetyPopup,
    /// `restart safety`.
    RestartSafety,
    /// `clear operational mode`.
    ClearOperationalMode,
    /// `set operational mode MODE`.
    SetOperationalMode(String),
    /// `get operational mode`.
    GetOperationalMode,
    /// `is in remote control`.
    IsInRemoteControl,
    /// `get serial number`.
    GetSerialNumber,
    /// `get robot model`.
    GetRobotModel,
    /// `generate flight report [KIND]`.
    GenerateFlightReport(String),
    /// `generate support file [DIR]`.
    GenerateSupportFile(String),
    /// `saveLog`.
    SaveLog,
    /// Anything else: the line, trimmed. Answered `could not understand: 'LINE'`.
    Unknown(String),
}

/// Whether a command takes an argument.
#[derive(Clone, Copy)]
enum Arg {
    /// Only the words: anything after them makes the line unknown.
    None,
    /// The rest of the line (possibly empty).
    Rest,
}

/// The words of every command, in the order a line is tried against them (`load
/// installation` before `load`). Where the software version drops a command, the e-Series
/// (major 5 and later) answers it as unknown.
const COMMANDS: &[(&str, Arg)] = &[
    ("load installation", Arg::Rest),
    ("load", Arg::Rest),
    ("play", Arg::None),
    ("stop", Arg::None),
    ("pause", Arg::None),
    ("quit", Arg::None),
    ("shutdown", Arg::None),
    ("running", Arg::None),
    ("robotmode", Arg::None),
    ("get loaded program", Arg::None),
    ("popup", Arg::Rest),
    ("close popup", Arg::None),
    ("addToLog", Arg::Rest),
    ("isProgramSaved", Arg::None),
    ("programState", Arg::None),
    ("PolyscopeVersion", Arg::None),
    ("version", Arg::None),
    ("setUserRole", Arg::Rest),
    ("getUserRole", Arg::None),
    ("power on", Arg::None),
    ("power off", Arg::None),
    ("brake release", Arg::None),
    ("safetystatus", Arg::None),
    ("safetymode", Arg::None),
    ("unlock protective stop", Arg::None),
    ("close safety popup", Arg::None),
    ("restart safety", Arg::None),
    ("clear operational mode", Arg::None),
    ("set operational mode", Arg::Rest),
    ("get operational mode", Arg::None),
    ("is in remote control", Arg::None),
    ("get serial number", Arg::None),
    ("get robot model", Arg::None),
    ("generate flight report", Arg::Rest),
    ("generate support file", Arg::Rest),
    ("saveLog", Arg::None),
];

/// If `line` starts with the command `name` (any case) followed by the end or a space,
/// the rest after that space, trimmed (`Some("")` when none).
fn rest_after<'a>(line: &'a str, name: &str) -> Option<&'a str> {
    let head = line.get(..name.len())?;
    if !head.eq_ignore_ascii_case(name) {
        return None;
    }
    let rest = &line[name.len()..];
    if rest.is_empty() {
        Some("")
    } else {
        rest.strip_prefix(' ').map(str::trim)
    }
}

impl DashboardCommand {
    /// Parses one command line (without its `"\n"`; surrounding blanks, a trailing
    /// `"\r"` among them, are ignored) for a controller of software version `major`
    /// (`setUserRole` and `getUserRole` are CB3's: unknown from 5 on). Command words
    /// match in any case.
    ///
    /// ```
    /// use urscript_controller::DashboardCommand as C;
    /// assert_eq!(C::parse("load pick.urp\r", 5), C::Load("pick.urp".into()));
    /// assert_eq!(C::parse("POWER ON", 5), C::PowerOn);
    /// assert_eq!(C::parse("play now", 5), C::Unknown("play now".into()));
    /// assert_eq!(C::parse("getUserRole", 5), C::Unknown("getUserRole".into()));
    /// assert_eq!(C::parse("getUserRole", 3), C::GetUserRole);
    /// ```
    pub fn parse(line: &str, major: u32) -> DashboardCommand {
        let line = line.trim_matches(|c: char| c.is_ascii_whitespace());
        for (name, arg) in COMMANDS {
            let Some(rest) = rest_after(line, name) else {
                continue;
            };
            if matches!(arg, Arg::None) && !rest.is_empty() {
                continue;
            }
            if let Some(command) = Self::from_words(name, rest, major) {
                return command;
            }
        }
        DashboardCommand::Unknown(line.to_string())
    }

    /// The command of the words `name` (an entry of [`COMMANDS`]) with argument `arg`;
    /// `None` for one the software version `major` does not know.
    fn from_words(name: &str, arg: &str, major: u32) -> Option<DashboardCommand> {
        use DashboardCommand as C;
        let arg = arg.to_string();
        Some(match name {
            "load installation" => C::LoadInstallation(arg),
            "load" => C::Load(arg),
            "play" => C::Play,
            "stop" => C::Stop,
            "pause" => C::Pause,
            "quit" => C::Quit,
            "shutdown" => C::Shutdown,
            "running" => C::Running,
            "robotmode" => C::RobotMode,
            "get loaded program" => C::GetLoadedProgram,
            "popup" => C::Popup(arg),
            "close popup" => C::ClosePopup,
            "addToLog" => C::AddToLog(arg),
            "isProgramSaved" => C::IsProgramSaved,
            "programState" => C::ProgramState,
            "PolyscopeVersion" => C::PolyscopeVersion,
            "version" => C::Version,
            // CB3's user roles; the e-Series has none (its operational mode replaced
            // them) and answers these as unknown commands.
            "setUserRole" if major < 5 => C::SetUserRole(arg),
            "getUserRole" if major < 5 => C::GetUserRole,
            "power on" => C::PowerOn,
            "power off" => C::PowerOff,
            "brake release" => C::BrakeRelease,
            "safetystatus" => C::SafetyStatus,
            "safetymode" => C::SafetyMode,
            "unlock protective stop" => C::UnlockProtectiveStop,
            "close safety popup" => C::CloseSafetyPopup,
            "restart safety" => C::RestartSafety,
            "clear operational mode" => C::ClearOperationalMode,
            "set operational mode" => C::SetOperationalMode(arg),
            "get operational mode" => C::GetOperationalMode,
            "is in remote control" => C::IsInRemoteControl,
            "get serial number" => C::GetSerialNumber,
            "get robot model" => C::GetRobotModel,
            "generate flight report" => C::GenerateFlightReport(arg),
            "generate support file" => C::GenerateSupportFile(arg),
            "saveLog" => C::SaveLog,
            _ => return None,
        })
    }

    /// The command's words (as [`COMMANDS`] spells them) and its argument, if it takes
    /// one; `None` for [`Unknown`](Self::Unknown).
    fn words(&self) -> Option<(&'static str, Option<&str>)> {
        use DashboardCommand as C;
        Some(match self {
            C::LoadInstallation(a) => ("load installation", Some(a)),
            C::Load(a) => ("load", Some(a)),
            C::Play => ("play", None),
            C::Stop => ("stop", None),
            C::Pause => ("pause", None),
            C::Quit => ("quit", None),
            C::Shutdown => ("shutdown", None),
            C::Running => ("running", None),
            C::RobotMode => ("robotmode", None),
            C::GetLoadedProgram => ("get loaded program", None),
            C::Popup(a) => ("popup", Some(a)),
            C::ClosePopup => ("close popup", None),
            C::AddToLog(a) => ("addToLog", Some(a)),
            C::IsProgramSaved => ("isProgramSaved", None),
            C::ProgramState => ("programState", None),
            C::PolyscopeVersion => ("PolyscopeVersion", None),
            C::Version => ("version", None),
            C::SetUserRole(a) => ("setUserRole", Some(a)),
            C::GetUserRole => ("getUserRole", None),
            C::PowerOn => ("power on", None),
            C::PowerOff => ("power off", None),
            C::BrakeRelease => ("brake release", None),
            C::SafetyStatus => ("safetystatus", None),
            C::SafetyMode => ("safetymode", None),
            C::UnlockProtectiveStop => ("unlock protective stop", None),
            C::CloseSafetyPopup => ("close safety popup", None),
            C::RestartSafety => ("restart safety", None),
            C::ClearOperationalMode => ("clear operational mode", None),
            C::SetOperationalMode(a) => ("set operational mode", Some(a)),
            C::GetOperationalMode => ("get operational mode", None),
            C::IsInRemoteControl => ("is in remote control", None),
            C::GetSerialNumber => ("get serial number", None),
            C::GetRobotModel => ("get robot model", None),
            C::GenerateFlightReport(a) => ("generate flight report", Some(a)),
            C::GenerateSupportFile(a) => ("generate support file", Some(a)),
            C::SaveLog => ("saveLog", None),
            C::Unknown(_) => return None,
        })
    }
}

impl std::fmt::Display for DashboardCommand {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match (self, self.words()) {
            (DashboardCommand::Unknown(line), _) => f.write_str(line),
            (_, Some((name, Some(arg)))) if !arg.is_empty() => write!(f, "{name} {arg}"),
            (_, Some((name, _))) => f.write_str(name),
            (_, None) => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sample argument for the commands that take one.
    fn sample(name: &str) -> &'static str {
        match name {
            "load installation" => "default.installation",
            "load" => "sub/pick.urp",
            "popup" => "Hello there",
            "addToLog" => "a Message",
            "setUserRole" => "operator",
            "set operational mode" => "automatic",
            "generate flight report" => "software",
            "generate support file" => "reports/",
            _ => "",
        }
    }

    #[test]
    fn every_command_round_trips() {
        for major in [3, 5] {
            let mut known = 0;
            for (name, arg) in COMMANDS {
                let cb3_only = matches!(*name, "setUserRole" | "getUserRole");
                let line = match arg {
                    Arg::Rest => format!("{name} {}", sample(name)),
                    Arg::None => name.to_string(),
                };
                let command = DashboardCommand::parse(&line, major);
                if cb3_only && major >= 5 {
                    assert_eq!(command, DashboardCommand::Unknown(line.clone()));
                    continue;
                }
                assert!(command.words().is_some(), "{line:?} -> {command:?}");
                assert_eq!(command.to_string(), line.trim_end(), "{command:?}");
                assert_eq!(
                    DashboardCommand::parse(&command.to_string(), major),
                    command
                );
                // Any case, surrounding blanks and a CR.
                let shouted = format!("  {}\r", name.to_ascii_uppercase());
                if matches!(arg, Arg::None) {
                    assert_eq!(DashboardCommand::parse(&shouted, major), command);
                }
                known += 1;
            }
            assert_eq!(known, COMMANDS.len() - if major >= 5 { 2 } else { 0 });
        }
    }

    /// Every command reaches the function of its group, which answers it (none is
    /// answered as not understood), on a CB3 and an e-Series controller.
    #[test]
    fn every_command_is_answered_by_its_group() {
        for major in [3, 5] {
            for (name, arg) in COMMANDS {
                let line = match arg {
                    Arg::Rest => format!("{name} {}", sample(name)),
                    Arg::None => name.to_string(),
                };
                let command = DashboardCommand::parse(&line, major);
                if matches!(command, DashboardCommand::Unknown(_)) {
                    continue;
                }
                let config = crate::Config {
                    polyscope: if major == 3 { "3.15.8" } else { "5.21.0" }.into(),
                    ..crate::Config::default()
                };
                let mut controller = Controller::new(config);
                let reply = Dashboard::new().answer(&mut controller, &command, Duration::ZERO);
                assert_ne!(reply, misrouted(&command), "{line:?}");
            }
        }
    }

    #[test]
    fn arguments_keep_their_case_and_lose_their_blanks() {
        use DashboardCommand as C;
        assert_eq!(
            C::parse("LOAD   Sub/Pick.urp  ", 5),
            C::Load("Sub/Pick.urp".into())
        );
        assert_eq!(C::parse("load", 5), C::Load(String::new()));
        assert_eq!(
            C::parse("load installation", 5),
            C::LoadInstallation(String::new())
        );
        assert_eq!(C::parse("popup", 5).to_string(), "popup");
        assert_eq!(C::parse("addtolog x", 5), C::AddToLog("x".into()));
    }

    #[test]
    fn unknown_commands_stay_unknown() {
        use DashboardCommand as C;
        for line in [
            "",
            "hello",
            "play now",
            "power",
            "power onn",
            "loadx",
            "load\tpick.urp",
            "close safety",
            "é",
            "\u{0}",
        ] {
            let command = C::parse(line, 5);
            assert_eq!(command, C::Unknown(line.trim().to_string()), "{line:?}");
            assert_eq!(command.to_string(), line.trim());
        }
        assert_eq!(C::parse("  hello \r", 5), C::Unknown("hello".into()));
    }
}
