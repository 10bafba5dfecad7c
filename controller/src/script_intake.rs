//! What a client writes to ports 30001, 30002 and 30003: URScript, cut into what the
//! controller does with it. [`ScriptIntake`] is a bounded, incremental parser: feed it
//! bytes as they arrive ([`ScriptIntake::push`]) and it yields, line by line:
//!
//! - [`Intake::Program`]: a whole `def NAME():` ... `end` program. The controller stops
//!   what runs and runs it.
//! - [`Intake::Secondary`]: a `sec NAME():` ... `end` secondary program, run beside the
//!   main program (no motion).
//! - [`Intake::Line`]: a bare statement outside any program, a one-line script; a bare
//!   block (`if x:` ... `end` at the top level) comes whole, as one script.
//! - [`Intake::Command`]: a whole line that is one of the interface's commands, which
//!   UR's client library sends on the primary port: `power on`, `power off`,
//!   `set robotmode run` (brake release; `brake release` is accepted as well),
//!   `set unlock protective stop`, `stop program`, and `set speed` with the slider
//!   fraction (`set speed0.5` or `set speed 0.5`).
//!
//! Where a unit ends is the interpreter's call ([`urscript_interp::TopLevel`]): its
//! lexer reads each line, so words in strings and comments (`textmsg("end")`, `# end`)
//! open and close nothing, and a unit ends with the line that closes the last block it
//! opened (`def`, `sec`, `thread`, `if`, `while`, each closed by `end`; `if x: y() end`
//! on one line opens and closes one). The lines themselves are cut by the core's
//! [`LineDecoder`](urscript_socket::line::LineDecoder): a line ends at `\n` and one `\r` before it is dropped. Lines with no
//! code (blanks, comments, `$` step markers) outside a program are skipped.
//!
//! # Bounds
//!
//! A line may hold [`MAX_LINE`] bytes (a `\r` before its `\n` included) and a program [`MAX_PROGRAM`] bytes. Past either,
//! the parser yields [`IntakeError`] once, drops the line up to its `\n`, and, for a
//! program, drops the rest of the program (still counting its blocks) up to its closing
//! `end`: what follows is read afresh.
//!
//! ```
//! use urscript_controller::script_intake::{Command, Intake, ScriptIntake};
//!
//! let mut intake = ScriptIntake::new();
//! let mut got = intake.push(b"def move():\n  if True:\n    textmsg(\"end\")\n  end\nend\npower on\n");
//! assert_eq!(got.len(), 2);
//! assert!(matches!(&got[0], Ok(Intake::Program { name, .. }) if name == "move"));
//! assert_eq!(got.remove(1), Ok(Intake::Command(Command::PowerOn)));
//! ```

use std::fmt;

use urscript_interp::{TopLevel, UnitKind};

use crate::lines::{Event, LineReader};

/// The longest line accepted, in bytes (without its `\n`): 64 KiB.
pub const MAX_LINE: usize = 64 * 1024;
/// The longest program accepted (`def`/`sec`/bare block, its lines and `\n`s): 4 MiB.
pub const MAX_PROGRAM: usize = 4 * 1024 * 1024;

/// A command line of the primary/secondary/realtime interfaces.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Command {
    /// `power on`.
    PowerOn,
    /// `power off`.
    PowerOff,
    /// `set robotmode run` or `brake release`.
    BrakeRelease,
    /// `set unlock protective stop`.
    UnlockProtectiveStop,
    /// `stop program`.
    StopProgram,
    /// `set speed F`: the speed slider fraction (clamped to 0..1 by the caller).
    SetSpeed(f64),
}

/// One thing the controller does with what a client sent.
#[derive(Debug, Clone, PartialEq)]
pub enum Intake {
    /// A `def NAME():` ... `end` program, its source with a `\n` after each line.
    Program {
        /// The name after `def`.
        name: String,
        /// The whole source.
        source: String,
    },
    /// A `sec NAME():` ... `end` secondary program.
    Secondary {
        /// The name after `sec`.
        name: String,
        /// The whole source.
        source: String,
    },
    /// A bare statement (or a top-level block), without its line end.
    Line(String),
    /// A command line.
    Command(Command),
}

/// What went wrong with some input. The parser has recovered when it says so.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum IntakeError {
    /// A line longer than [`MAX_LINE`]: dropped up to its `\n` (with its program, if in
    /// one).
    LineTooLong,
    /// A program longer than [`MAX_PROGRAM`]: dropped up to its closing `end`.
    ProgramTooLong {
        /// The program's name, empty for a bare block.
        name: String,
    },
}

impl fmt::Display for IntakeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            IntakeError::LineTooLong => write!(f, "line longer than {MAX_LINE} bytes dropped"),
            IntakeError::ProgramTooLong { name } => {
                write!(
                    f,
                    "program `{name}` longer than {MAX_PROGRAM} bytes dropped"
                )
            }
        }
    }
}

impl std::error::Error for IntakeError {}

#[derive(Debug, Clone)]
struct Block {
    kind: UnitKind,
    source: String,
    /// Over the bound: reading on to the unit's end, keeping nothing.
    dropping: bool,
}

/// The incremental parser. See the [module](self) documentation.
pub struct ScriptIntake {
    /// The lines; holds less than one line ([`MAX_LINE`]) and one read between calls.
    lines: LineReader,
    units: TopLevel,
    block: Option<Block>,
}

impl Default for ScriptIntake {
    fn default() -> Self {
        ScriptIntake {
            lines: LineReader::new(MAX_LINE, 0),
            units: TopLevel::new(),
            block: None,
        }
    }
}

impl fmt::Debug for ScriptIntake {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("ScriptIntake")
            .field("pending", &self.is_pending())
            .field("block", &self.block)
            .finish()
    }
}

fn command(line: &str) -> Option<Command> {
    let t = line.trim();
    Some(match t {
        "power on" => Command::PowerOn,
        "power off" => Command::PowerOff,
        "set robotmode run" | "brake release" => Command::BrakeRelease,
        "set unlock protective stop" => Command::UnlockProtectiveStop,
        "stop program" => Command::StopProgram,
        _ => {
            let value = t.strip_prefix("set speed")?.trim();
            let v: f64 = value.parse().ok()?;
            if !v.is_finite() {
                return None;
            }
            Command::SetSpeed(v)
        }
    })
}

impl ScriptIntake {
    /// A parser with nothing pending.
    pub fn new() -> Self {
        ScriptIntake::default()
    }

    /// Whether a partial line or an unfinished program is pending.
    pub fn is_pending(&self) -> bool {
        self.lines.is_pending() || self.block.is_some()
    }

    /// Feeds bytes; returns what they completed, in order. Any split of the same bytes
    /// into `push` calls yields the same sequence.
    pub fn push(&mut self, bytes: &[u8]) -> Vec<Result<Intake, IntakeError>> {
        let mut out = Vec::new();
        let mut rest = bytes;
        let ScriptIntake {
            lines,
            units,
            block,
        } = self;
        // Reading from a slice cannot fail.
        while lines.read_from(&mut rest).unwrap_or(0) > 0 {
            let _ = lines.drain(|event| {
                match event {
                    Event::Line(line) => {
                        let text = String::from_utf8_lossy(line).into_owned();
                        complete_line(units, block, text, &mut out);
                    }
                    Event::TooLong(_) => {
                        out.push(Err(IntakeError::LineTooLong));
                        too_long(block);
                    }
                    Event::LongEnded(_) => {}
                }
                Ok::<(), ()>(())
            });
        }
        out
    }
}

/// The current line went over [`MAX_LINE`]: it is dropped, and with it the program
/// it is in, which is read on to its end (its blocks still counted: the dropped line
/// neither opens nor closes one).
fn too_long(block: &mut Option<Block>) {
    if let Some(b) = block {
        if !b.dropping {
            b.dropping = true;
            b.source = String::new();
        }
    }
}

/// One complete line: a command, part of a unit, or nothing (no code between units).
fn complete_line(
    units: &mut TopLevel,
    block: &mut Option<Block>,
    line: String,
    out: &mut Vec<Result<Intake, IntakeError>>,
) {
    if block.is_none() {
        if let Some(c) = command(&line) {
            out.push(Ok(Intake::Command(c)));
            return;
        }
    }
    let step = units.line(&line);
    let b = match (&mut *block, step.starts) {
        (Some(b), _) => b,
        (None, None) => return,
        (None, Some(kind)) => block.insert(Block {
            kind,
            source: String::new(),
            dropping: false,
        }),
    };
    if !b.dropping {
        if b.source.len() + line.len() + 1 > MAX_PROGRAM {
            b.dropping = true;
            b.source = String::new();
            out.push(Err(IntakeError::ProgramTooLong {
                name: match &b.kind {
                    UnitKind::Def(name) | UnitKind::Sec(name) => name.clone(),
                    _ => String::new(),
                },
            }));
        } else {
            b.source.push_str(&line);
            b.source.push('\n');
        }
    }
    if !step.ends {
        return;
    }
    let Some(b) = block.take() else {
        return;
    };
    if b.dropping {
        return;
    }
    out.push(Ok(match b.kind {
        UnitKind::Def(name) => Intake::Program {
            name,
            source: b.source,
        },
        UnitKind::Sec(name) => Intake::Secondary {
            name,
            source: b.source,
        },
        _ => {
            let mut s = b.source;
            if s.ends_with('\n') {
                s.pop();
            }
            Intake::Line(s)
        }
    }));
}
