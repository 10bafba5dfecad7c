//! The operator: what happens at the robot that no dashboard command causes (a
//! collision, the emergency stop button, the pendant's remote/local switch, the speed
//! slider, the arm moved by hand). One command is one line of text; [`OPERATOR_COMMANDS`]
//! lists them once, for the parser, the help and the documentation.

use core::fmt;
use core::str::FromStr;
use std::time::Duration;

use crate::{Cell, Inputs, SafetyStatus};

/// Each command's words and what it does, in the order help lists them.
pub const OPERATOR_COMMANDS: &[(&str, &str)] = &[
    ("protective stop", "a protective stop (a collision)"),
    ("emergency stop", "the robot's emergency stop button"),
    ("system emergency stop", "the cell's emergency stop"),
    ("safeguard stop", "a safeguard stop (a light curtain)"),
    ("fault", "a fault"),
    ("violation", "a safety violation"),
    ("release", "the stop is released"),
    ("local", "the pendant switched to local control"),
    ("remote", "the pendant switched to remote control"),
    ("speed F", "the speed slider at F (0-1)"),
    (
        "freedrive [q0, q1, q2, q3, q4, q5]",
        "the joints moved by hand (rad): in teach/freedrive mode or with no program running",
    ),
    ("state", "the controller's state"),
    ("help", "this list"),
];

/// One operator command.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum OperatorCommand {
    /// `protective stop`.
    ProtectiveStop,
    /// `emergency stop`, `system emergency stop`, `safeguard stop`, `fault`, `violation`:
    /// the safety status the event sets.
    Safety(SafetyStatus),
    /// `release`: the stop is released.
    Release,
    /// `local` (false) or `remote` (true).
    RemoteControl(bool),
    /// `speed F`: the speed slider's fraction, 0-1.
    Speed(f64),
    /// `freedrive [q0, ..., q5]`: joint positions in rad.
    Freedrive([f64; 6]),
    /// `state`: nothing changes; the state is said.
    State,
    /// `help`.
    Help,
}

/// A line that is no operator command: what is wrong with it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum OperatorError {
    /// No command has these words (the line, in lower case).
    Unknown(String),
    /// A command's argument is not what it takes: why.
    BadArgument(String),
}

impl fmt::Display for OperatorError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Unknown(cmd) => write!(f, "unknown command {cmd:?}; {}", operator_help()),
            Self::BadArgument(why) => f.write_str(why),
        }
    }
}

impl std::error::Error for OperatorError {}

impl FromStr for OperatorCommand {
    type Err = OperatorError;

    /// Words in any case, surrounding white space ignored.
    fn from_str(line: &str) -> Result<Self, Self::Err> {
        let cmd = line.trim().to_ascii_lowercase();
        let command = match cmd.as_str() {
            "protective stop" => Self::ProtectiveStop,
            "emergency stop" => Self::Safety(SafetyStatus::RobotEmergencyStop),
            "system emergency stop" => Self::Safety(SafetyStatus::SystemEmergencyStop),
            "safeguard stop" => Self::Safety(SafetyStatus::SafeguardStop),
            "fault" => Self::Safety(SafetyStatus::Fault),
            "violation" => Self::Safety(SafetyStatus::Violation),
            "release" => Self::Release,
            "local" => Self::RemoteControl(false),
            "remote" => Self::RemoteControl(true),
            "state" => Self::State,
            "help" => Self::Help,
            _ => {
                if let Some(rest) = cmd.strip_prefix("speed ") {
                    match rest.trim().parse::<f64>() {
                        Ok(f) if (0.0..=1.0).contains(&f) => Self::Speed(f),
                        _ => {
                            return Err(OperatorError::BadArgument(format!(
                                "speed {:?} is not a fraction 0-1",
                                rest.trim()
                            )))
                        }
                    }
                } else if let Some(rest) = cmd.strip_prefix("freedrive ") {
                    Self::Freedrive(parse_joints(rest)?)
                } else {
                    return Err(OperatorError::Unknown(cmd));
                }
            }
        };
        Ok(command)
    }
}

/// The commands in one line, for a help or an error message.
pub fn operator_help() -> String {
    let words: Vec<&str> = OPERATOR_COMMANDS.iter().map(|(w, _)| *w).collect();
    format!("operator commands: {}", words.join(", "))
}

/// Six joint positions (rad) as the operator types them: `[q0, ..., q5]` (brackets and
/// commas optional).
fn parse_joints(text: &str) -> Result<[f64; 6], OperatorError> {
    let cleaned = text.trim().trim_start_matches('[').trim_end_matches(']');
    let parts: Vec<&str> = cleaned
        .split(|c: char| c == ',' || c.is_whitespace())
        .filter(|p| !p.is_empty())
        .collect();
    if parts.len() != 6 {
        return Err(OperatorError::BadArgument(format!(
            "give 6 joint positions (rad), not {}",
            parts.len()
        )));
    }
    let mut q = [0.0; 6];
    for (slot, p) in q.iter_mut().zip(parts) {
        *slot = p
            .parse()
            .map_err(|_| OperatorError::BadArgument(format!("{p:?} is not a number of radians")))?;
    }
    Ok(q)
}

impl OperatorCommand {
    /// Does it to the cell at controller time `now`. `Err` (with the reason) when the
    /// cell refuses it (the arm moved by hand while a program runs outside
    /// teach/freedrive mode, joints out of range); nothing changed then.
    pub fn apply(self, cell: &mut Cell, now: Duration) -> Result<(), String> {
        match self {
            Self::ProtectiveStop => cell.controller().protective_stop(now),
            Self::Safety(status) => cell.controller().safety_event(now, status),
            Self::Release => cell.controller().release_stop(now),
            Self::RemoteControl(remote) => cell.controller().set_remote_control(remote),
            Self::Speed(f) => cell.apply(&Inputs {
                speed_slider_fraction: Some(f),
                ..Default::default()
            }),
            Self::Freedrive(q) => cell.move_by_hand(q)?,
            Self::State | Self::Help => {}
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_listed_command_parses() {
        for (words, _) in OPERATOR_COMMANDS {
            let line = words
                .replace(" F", " 0.5")
                .replace("[q0, q1, q2, q3, q4, q5]", "[0, -1.57, 0, -1.57, 0, 0]");
            assert!(line.parse::<OperatorCommand>().is_ok(), "{line}");
            assert!(
                line.to_uppercase().parse::<OperatorCommand>().is_ok(),
                "{line}"
            );
        }
    }

    #[test]
    fn bad_lines_say_what_is_wrong() {
        let e = |l: &str| l.parse::<OperatorCommand>().unwrap_err().to_string();
        assert!(e("jump").starts_with("unknown command \"jump\"; operator commands: "));
        assert_eq!(e("speed 1.5"), "speed \"1.5\" is not a fraction 0-1");
        assert_eq!(e("speed nan"), "speed \"nan\" is not a fraction 0-1");
        assert_eq!(e("freedrive 1 2 3"), "give 6 joint positions (rad), not 3");
        assert_eq!(
            e("freedrive [1, 2, x, 4, 5, 6]"),
            "\"x\" is not a number of radians"
        );
        assert_eq!(
            "freedrive 0 1 2 3 4 5".parse::<OperatorCommand>(),
            Ok(OperatorCommand::Freedrive([0.0, 1.0, 2.0, 3.0, 4.0, 5.0]))
        );
    }
}
