//! What a client of the primary, secondary, realtime, RTDE or interpreter interface did,
//! as [`ServerEvent::Client`](super::ServerEvent::Client) reports it: typed, with its
//! kind ([`ClientEvent::what`]) and its text (`Display`) for the views that print it.

use std::fmt;

use urscript_interp::interpreter::Reply;

use crate::rtde::{RtdeError, RtdeEvent};
use crate::script_intake::{Command, IntakeError};

/// One thing a client sent or asked, or what was answered to it.
///
/// [`ClientEvent::what`] names its kind (the `what` of `ursock controller`'s `client`
/// events); its `Display` is the text printed with it.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum ClientEvent {
    /// A primary, secondary or realtime client sent a `def NAME():` program; it starts.
    Program {
        /// The name after `def`.
        name: String,
    },
    /// A client sent a `sec NAME():` secondary program; it runs beside the program.
    Secondary {
        /// The name after `sec`.
        name: String,
    },
    /// A client sent a bare statement (run as a program of its own).
    Line(String),
    /// A client sent a command line (`power on`, `set speed 0.5`...).
    Command(Command),
    /// What a client sent was dropped (a line or program past its bound).
    Refused(IntakeError),
    /// An RTDE client asked for a protocol version.
    Protocol {
        /// The version asked.
        requested: u16,
        /// Whether it was accepted.
        accepted: bool,
    },
    /// An RTDE client set up an output recipe.
    Outputs {
        /// The recipe id answered, 0 when refused.
        recipe: u8,
        /// The frequency in Hz.
        frequency: f64,
        /// The names asked.
        fields: Vec<String>,
        /// The types answered, one per name (`NOT_FOUND` included).
        types: Vec<String>,
    },
    /// An RTDE client set up an input recipe.
    Inputs {
        /// The recipe id answered, 0 when refused.
        recipe: u8,
        /// The names asked.
        fields: Vec<String>,
        /// The types answered, one per name (`NOT_FOUND`, `IN_USE` included).
        types: Vec<String>,
    },
    /// An RTDE client asked to start its outputs.
    Start {
        /// Whether it was accepted (it needs an output recipe).
        accepted: bool,
    },
    /// An RTDE client paused its outputs.
    Pause,
    /// An RTDE client sent a text message.
    Text {
        /// The level (0 exception, 1 error, 2 warning, 3 info; any byte as sent).
        level: u8,
        /// The text.
        message: String,
        /// The source (empty in protocol 1).
        source: String,
    },
    /// A fault in what an RTDE client sent.
    RtdeError(RtdeError),
    /// The interpreter socket's reply to a line, as written (without its `\n`).
    Reply(Reply),
}

impl ClientEvent {
    /// Its kind: `program`, `secondary`, `line`, `command`, `refused` (primary,
    /// secondary, realtime); `protocol`, `outputs`, `inputs`, `start`, `pause`, `text`,
    /// `error` (RTDE); `reply` (interpreter).
    pub fn what(&self) -> &'static str {
        match self {
            ClientEvent::Program { .. } => "program",
            ClientEvent::Secondary { .. } => "secondary",
            ClientEvent::Line(_) => "line",
            ClientEvent::Command(_) => "command",
            ClientEvent::Refused(_) => "refused",
            ClientEvent::Protocol { .. } => "protocol",
            ClientEvent::Outputs { .. } => "outputs",
            ClientEvent::Inputs { .. } => "inputs",
            ClientEvent::Start { .. } => "start",
            ClientEvent::Pause => "pause",
            ClientEvent::Text { .. } => "text",
            ClientEvent::RtdeError(_) => "error",
            ClientEvent::Reply(_) => "reply",
        }
    }

    /// An RTDE session's event as a client event; `None` for an input data package
    /// (applied to the cell, not reported).
    pub(crate) fn from_rtde(e: RtdeEvent) -> Option<ClientEvent> {
        Some(match e {
            RtdeEvent::ProtocolVersion {
                requested,
                accepted,
            } => ClientEvent::Protocol {
                requested,
                accepted,
            },
            RtdeEvent::OutputSetup {
                recipe,
                frequency,
                fields,
                types,
            } => ClientEvent::Outputs {
                recipe,
                frequency,
                fields,
                types,
            },
            RtdeEvent::InputSetup {
                recipe,
                fields,
                types,
            } => ClientEvent::Inputs {
                recipe,
                fields,
                types,
            },
            RtdeEvent::Started { accepted } => ClientEvent::Start { accepted },
            RtdeEvent::Paused => ClientEvent::Pause,
            RtdeEvent::TextMessage {
                level,
                message,
                source,
            } => ClientEvent::Text {
                level,
                message,
                source,
            },
            RtdeEvent::Error(e) => ClientEvent::RtdeError(e),
            RtdeEvent::Inputs { .. } => return None,
        })
    }
}

/// A recipe as its event shows it: `name:TYPE` pairs, comma-separated.
fn write_recipe(f: &mut fmt::Formatter<'_>, fields: &[String], types: &[String]) -> fmt::Result {
    for (i, (name, ty)) in fields.iter().zip(types).enumerate() {
        if i > 0 {
            f.write_str(",")?;
        }
        write!(f, "{name}:{ty}")?;
    }
    Ok(())
}

/// The text printed with the event: the program's name, the line, the command, why it
/// was refused, the recipe, the RTDE message or error, the interpreter's reply.
impl fmt::Display for ClientEvent {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ClientEvent::Program { name } | ClientEvent::Secondary { name } => f.write_str(name),
            ClientEvent::Line(line) => f.write_str(line),
            ClientEvent::Command(c) => write!(f, "{c:?}"),
            ClientEvent::Refused(e) => write!(f, "{e}"),
            ClientEvent::Protocol {
                requested,
                accepted,
            } => write!(
                f,
                "version {requested} {}",
                if *accepted { "accepted" } else { "refused" }
            ),
            ClientEvent::Outputs {
                recipe,
                frequency,
                fields,
                types,
            } => {
                write!(f, "recipe {recipe} at {frequency} Hz: ")?;
                write_recipe(f, fields, types)
            }
            ClientEvent::Inputs {
                recipe,
                fields,
                types,
            } => {
                write!(f, "recipe {recipe}: ")?;
                write_recipe(f, fields, types)
            }
            ClientEvent::Start { accepted: true } => f.write_str("started"),
            ClientEvent::Start { accepted: false } => f.write_str("refused: no recipe"),
            ClientEvent::Pause => f.write_str("paused"),
            ClientEvent::Text {
                level,
                message,
                source,
            } => write!(f, "[{level}] {source}: {message}"),
            ClientEvent::RtdeError(e) => write!(f, "{e}"),
            ClientEvent::Reply(r) => write!(f, "{r}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use urscript_interp::interpreter::{Command as InterpreterCommand, Discard};

    fn names(v: &[&str]) -> Vec<String> {
        v.iter().map(|s| s.to_string()).collect()
    }

    /// Every kind's `what` and text, as `ursock controller` prints them.
    #[test]
    fn each_kind_has_its_what_and_text() {
        let cases = [
            (
                ClientEvent::Program {
                    name: "move_it".into(),
                },
                "program",
                "move_it",
            ),
            (
                ClientEvent::Secondary {
                    name: "io_watch".into(),
                },
                "secondary",
                "io_watch",
            ),
            (
                ClientEvent::Line("set_digital_out(1, True)".into()),
                "line",
                "set_digital_out(1, True)",
            ),
            (ClientEvent::Command(Command::PowerOn), "command", "PowerOn"),
            (
                ClientEvent::Command(Command::SetSpeed(0.25)),
                "command",
                "SetSpeed(0.25)",
            ),
            (
                ClientEvent::Refused(IntakeError::LineTooLong),
                "refused",
                "line longer than 65536 bytes dropped",
            ),
            (
                ClientEvent::Refused(IntakeError::ProgramTooLong { name: "big".into() }),
                "refused",
                "program `big` longer than 4194304 bytes dropped",
            ),
            (
                ClientEvent::Protocol {
                    requested: 2,
                    accepted: true,
                },
                "protocol",
                "version 2 accepted",
            ),
            (
                ClientEvent::Protocol {
                    requested: 3,
                    accepted: false,
                },
                "protocol",
                "version 3 refused",
            ),
            (
                ClientEvent::Outputs {
                    recipe: 1,
                    frequency: 125.0,
                    fields: names(&["timestamp", "actual_q", "nope"]),
                    types: names(&["DOUBLE", "VECTOR6D", "NOT_FOUND"]),
                },
                "outputs",
                "recipe 1 at 125 Hz: timestamp:DOUBLE,actual_q:VECTOR6D,nope:NOT_FOUND",
            ),
            (
                ClientEvent::Outputs {
                    recipe: 2,
                    frequency: 12.5,
                    fields: Vec::new(),
                    types: Vec::new(),
                },
                "outputs",
                "recipe 2 at 12.5 Hz: ",
            ),
            (
                ClientEvent::Inputs {
                    recipe: 0,
                    fields: names(&["speed_slider_mask", "input_int_register_24"]),
                    types: names(&["UINT32", "IN_USE"]),
                },
                "inputs",
                "recipe 0: speed_slider_mask:UINT32,input_int_register_24:IN_USE",
            ),
            (ClientEvent::Start { accepted: true }, "start", "started"),
            (
                ClientEvent::Start { accepted: false },
                "start",
                "refused: no recipe",
            ),
            (ClientEvent::Pause, "pause", "paused"),
            (
                ClientEvent::Text {
                    level: 2,
                    message: "hello".into(),
                    source: "driver".into(),
                },
                "text",
                "[2] driver: hello",
            ),
            (
                ClientEvent::RtdeError(RtdeError::SizeTooSmall { size: 1 }),
                "error",
                "packet size 1 is below the 3-byte header",
            ),
            (
                ClientEvent::Reply(Reply::Ack {
                    id: 4,
                    statement: "x = 1".into(),
                }),
                "reply",
                "ack: 4: x = 1",
            ),
            (
                ClientEvent::Reply(Reply::Discard {
                    reason: Discard::NotRunning,
                    statement: "x = 1".into(),
                }),
                "reply",
                "discard: program not running: x = 1",
            ),
            (
                ClientEvent::Reply(Reply::State {
                    value: 7,
                    command: InterpreterCommand::StateUnexecuted,
                }),
                "reply",
                "state: 7: stateunexecuted",
            ),
        ];
        for (event, what, text) in cases {
            assert_eq!(event.what(), what, "{event:?}");
            assert_eq!(event.to_string(), text, "{event:?}");
        }
    }

    /// Every RTDE event but an input package becomes the client event of its kind.
    #[test]
    fn rtde_events_map_to_their_kind() {
        let e = RtdeEvent::OutputSetup {
            recipe: 1,
            frequency: 500.0,
            fields: names(&["timestamp"]),
            types: names(&["DOUBLE"]),
        };
        assert_eq!(
            ClientEvent::from_rtde(e),
            Some(ClientEvent::Outputs {
                recipe: 1,
                frequency: 500.0,
                fields: names(&["timestamp"]),
                types: names(&["DOUBLE"]),
            })
        );
        assert_eq!(
            ClientEvent::from_rtde(RtdeEvent::Paused),
            Some(ClientEvent::Pause)
        );
        assert_eq!(
            ClientEvent::from_rtde(RtdeEvent::Started { accepted: false }),
            Some(ClientEvent::Start { accepted: false })
        );
        assert_eq!(
            ClientEvent::from_rtde(RtdeEvent::Inputs {
                recipe: 1,
                inputs: crate::Inputs::default(),
                unapplied: Vec::new(),
            }),
            None
        );
    }
}
