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

/// If `line` starts with the command `name` (any case) followed by the end or a space,
/// the rest after that space (`Some("")` when none).
fn command<'a>(line: &'a str, name: &str) -> Option<&'a str> {
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
    /// blanks are ignored) at time `now`.
    pub fn handle_line(&mut self, controller: &mut Controller, line: &str, now: Duration) -> Reply {
        self.commands += 1;
        controller.handle_timeout(now);
        if line.len() > MAX_LINE {
            return Reply::line(format!(
                "could not understand: '{}...' (a command line is at most {MAX_LINE} bytes)",
                cut(line, 40)
            ));
        }
        let line = line.trim_matches(|c: char| c.is_ascii_whitespace());
        let major = controller.config().major();

        // Commands of several words first, so `load installation` is not `load`.
        if let Some(name) = command(line, "load installation") {
            return match controller.load_installation(name) {
                Ok(()) => Reply::line(format!("Loading installation: {name}")),
                Err(e) => refused(e, || match e {
                    Refused::NotFound => format!("File not found: {name}"),
                    _ => format!("Failed to load installation: {name}"),
                }),
            };
        }
        if let Some(name) = command(line, "load") {
            return match controller.load(name) {
                Ok(()) => Reply::line(format!("Loading program: {name}")),
                Err(e) => refused(e, || match e {
                    Refused::NotFound => format!("File not found: {name}"),
                    _ => format!("Error while loading program: {name}"),
                }),
            };
        }
        if command(line, "play") == Some("") {
            return match controller.play(now) {
                Ok(()) => Reply::line("Starting program"),
                Err(e) => refused(e, || "Failed to execute: play".into()),
            };
        }
        if command(line, "stop") == Some("") {
            return match controller.stop(now) {
                Ok(()) => Reply::line("Stopped"),
                Err(e) => refused(e, || "Failed to execute: stop".into()),
            };
        }
        if command(line, "pause") == Some("") {
            return match controller.pause(now) {
                Ok(()) => Reply::line("Pausing program"),
                Err(e) => refused(e, || "Failed to execute: pause".into()),
            };
        }
        if command(line, "quit") == Some("") {
            return Reply::closing("Disconnected");
        }
        if command(line, "shutdown") == Some("") {
            return match controller.shutdown(now) {
                Ok(()) => Reply::closing("Shutting down"),
                Err(e) => refused(e, || "Failed to execute: shutdown".into()),
            };
        }
        if command(line, "running") == Some("") {
            let playing = controller.program_state() == crate::ProgramState::Playing;
            return Reply::line(format!("Program running: {playing}"));
        }
        if command(line, "robotmode") == Some("") {
            return Reply::line(format!("Robotmode: {}", controller.robot_mode(now)));
        }
        if command(line, "get loaded program") == Some("") {
            return Reply::line(match controller.loaded_program() {
                Some((_, path)) => format!("Loaded program: {path}"),
                None => "No program loaded".into(),
            });
        }
        if let Some(text) = command(line, "popup") {
            controller.set_popup(Some(text.to_string()));
            return Reply::line("showing popup");
        }
        if command(line, "close popup") == Some("") {
            controller.set_popup(None);
            return Reply::line("closing popup");
        }
        if let Some(text) = command(line, "addToLog") {
            if text.is_empty() {
                return Reply::line("No log message to add");
            }
            controller.add_to_log(text.to_string());
            return Reply::line("Added log message");
        }
        if command(line, "isProgramSaved") == Some("") {
            return Reply::line(match controller.loaded_program() {
                Some((_, path)) => format!("true {}", file_name(path)),
                None => "false <unnamed>".into(),
            });
        }
        if command(line, "programState") == Some("") {
            let name = controller
                .loaded_program()
                .map_or("<unnamed>", |(_, path)| file_name(path));
            return Reply::line(format!("{} {name}", controller.program_state()));
        }
        if command(line, "PolyscopeVersion") == Some("") {
            let c = controller.config();
            return Reply::line(format!(
                "URSoftware {} ({})",
                c.full_version(),
                c.build_date
            ));
        }
        if command(line, "version") == Some("") {
            return Reply::line(controller.config().full_version());
        }
        if major < 5 {
            // CB3's user roles; the e-Series has none (its operational mode replaced
            // them) and answers these as unknown commands.
            if let Some(role) = command(line, "setUserRole") {
                let known = ["programmer", "operator", "none", "locked", "restricted"];
                return Reply::line(if known.iter().any(|k| k.eq_ignore_ascii_case(role)) {
                    format!("Setting user role: {role}")
                } else {
                    format!("Failed setting user role: {role}")
                });
            }
            if command(line, "getUserRole") == Some("") {
                return Reply::line("PROGRAMMER");
            }
        }
        if command(line, "power on") == Some("") {
            return match controller.power_on(now) {
                Err(Refused::LocalControl) => Reply::line(LOCAL_CONTROL),
                // Under an emergency stop or a fault the command is taken but power
                // stays off, as `robotmode` then shows.
                _ => Reply::line("Powering on"),
            };
        }
        if command(line, "power off") == Some("") {
            return match controller.power_off(now) {
                Err(Refused::LocalControl) => Reply::line(LOCAL_CONTROL),
                _ => Reply::line("Powering off"),
            };
        }
        if command(line, "brake release") == Some("") {
            return match controller.brake_release(now) {
                Err(Refused::LocalControl) => Reply::line(LOCAL_CONTROL),
                _ => Reply::line("Brake releasing"),
            };
        }
        if command(line, "safetystatus") == Some("") {
            return Reply::line(format!("Safetystatus: {}", controller.safety_status(now)));
        }
        if command(line, "safetymode") == Some("") {
            let s = controller.safety_status(now);
            return Reply::line(format!("Safetymode: {}", s.safety_mode_name()));
        }
        if command(line, "unlock protective stop") == Some("") {
            return match controller.unlock_protective_stop(now) {
                Ok(()) => Reply::line("Protective stop releasing"),
                Err(e) => refused(e, || UNLOCK_TOO_EARLY.into()),
            };
        }
        if command(line, "close safety popup") == Some("") {
            return Reply::line("closing safety popup");
        }
        if command(line, "restart safety") == Some("") {
            return match controller.restart_safety(now) {
                Ok(()) => Reply::line("Restarting safety"),
                Err(e) => refused(e, || "Failed to execute: restart safety".into()),
            };
        }
        if command(line, "clear operational mode") == Some("") {
            return match controller.clear_operational_mode() {
                Ok(()) => Reply::line(
                    "No longer controlling the operational mode. Current operational mode: 'NONE'.",
                ),
                Err(e) => refused(e, String::new),
            };
        }
        if let Some(mode) = command(line, "set operational mode") {
            return match OperationalMode::parse(mode) {
                Some(m) => match controller.set_operational_mode(m) {
                    Ok(()) => Reply::line(format!("Operational mode '{mode}' is set")),
                    Err(e) => refused(e, String::new),
                },
                None => Reply::line(format!("Failed setting operational mode: {mode}")),
            };
        }
        if command(line, "get operational mode") == Some("") {
            return Reply::line(controller.operational_mode().map_or("NONE", |m| m.name()));
        }
        if command(line, "is in remote control") == Some("") {
            return Reply::line(controller.remote_control().to_string());
        }
        if command(line, "get serial number") == Some("") {
            return Reply::line(controller.config().serial.clone());
        }
        if command(line, "get robot model") == Some("") {
            return Reply::line(model_name(controller));
        }
        if let Some(kind) = command(line, "generate flight report") {
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
            return Reply::line(format!("Flight Report generated with id: {id:08x}"));
        }
        if let Some(dir) = command(line, "generate support file") {
            let id = controller.next_report();
            let serial = controller.config().serial.clone();
            let dir = dir.trim_end_matches('/');
            let file = format!("ur_{serial}_support_file_{id:04}.zip");
            return Reply::line(if dir.is_empty() || dir == "." {
                format!("Completed successfully: {file}")
            } else {
                format!("Completed successfully: {dir}/{file}")
            });
        }
        if command(line, "saveLog") == Some("") {
            return Reply::line("Log saved to disk");
        }
        Reply::line(format!("could not understand: '{line}'"))
    }
}
