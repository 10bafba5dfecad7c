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
//! Blocks are counted line by line: a line whose first word is `def`, `sec`, `thread`,
//! `if`, `while` or `for` opens one, a line whose first word is `end` closes one (a line
//! may only start with such a word outside a string or a comment, so `textmsg("end")`
//! and `# end` close nothing). The program ends with the `end` that brings the count back
//! to zero. Lines end at `\n`; a `\r` before it is dropped; blank and comment-only lines
//! outside a program are skipped.
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

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum BlockKind {
    Def,
    Sec,
    Bare,
}

#[derive(Debug, Clone)]
struct Block {
    kind: BlockKind,
    name: String,
    source: String,
    depth: usize,
    /// Over the bound: counting blocks to the end, keeping nothing.
    dropping: bool,
}

/// The incremental parser. See the [module](self) documentation.
#[derive(Debug, Clone, Default)]
pub struct ScriptIntake {
    line: Vec<u8>,
    /// The current line went over [`MAX_LINE`]: skip to its `\n`.
    skipping: bool,
    block: Option<Block>,
}

/// How a line's first word affects the block count.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Word {
    Opens,
    Closes,
    Other,
}

/// The code of a line: up to a `#` outside a string.
fn code_of(line: &str) -> &str {
    let mut quote: Option<char> = None;
    let mut escaped = false;
    for (i, c) in line.char_indices() {
        match quote {
            Some(q) => {
                if escaped {
                    escaped = false;
                } else if c == '\\' {
                    escaped = true;
                } else if c == q {
                    quote = None;
                }
            }
            None => match c {
                '"' | '\'' => quote = Some(c),
                '#' => return &line[..i],
                _ => {}
            },
        }
    }
    line
}

/// The leading identifier of a trimmed code line.
fn first_word(code: &str) -> &str {
    let end = code
        .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
        .unwrap_or(code.len());
    &code[..end]
}

fn classify(code: &str) -> Word {
    match first_word(code.trim_start()) {
        "def" | "sec" | "thread" | "if" | "while" | "for" => Word::Opens,
        "end" => Word::Closes,
        _ => Word::Other,
    }
}

/// The name after `def `/`sec ` in a trimmed code line.
fn block_name(code: &str) -> String {
    let rest = code.trim_start();
    let rest = rest.get(3..).unwrap_or("").trim_start();
    first_word(rest).to_string()
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
        !self.line.is_empty() || self.skipping || self.block.is_some()
    }

    /// Feeds bytes; returns what they completed, in order. Any split of the same bytes
    /// into `push` calls yields the same sequence.
    pub fn push(&mut self, bytes: &[u8]) -> Vec<Result<Intake, IntakeError>> {
        let mut out = Vec::new();
        let mut rest = bytes;
        while !rest.is_empty() {
            let (chunk, newline) = match rest.iter().position(|&b| b == b'\n') {
                Some(i) => (&rest[..i], Some(i)),
                None => (rest, None),
            };
            if !self.skipping {
                if self.line.len() + chunk.len() > MAX_LINE {
                    self.line.clear();
                    self.skipping = true;
                    out.push(Err(IntakeError::LineTooLong));
                    if let Some(b) = &mut self.block {
                        if !b.dropping {
                            b.dropping = true;
                            b.source = String::new();
                        }
                    }
                } else {
                    self.line.extend_from_slice(chunk);
                }
            }
            match newline {
                Some(i) => {
                    rest = &rest[i + 1..];
                    if self.skipping {
                        // The dropped line neither opens nor closes a block.
                        self.skipping = false;
                    } else {
                        let mut line = std::mem::take(&mut self.line);
                        if line.last() == Some(&b'\r') {
                            line.pop();
                        }
                        let text = String::from_utf8_lossy(&line).into_owned();
                        self.complete_line(text, &mut out);
                    }
                }
                None => rest = &[],
            }
        }
        out
    }

    fn complete_line(&mut self, line: String, out: &mut Vec<Result<Intake, IntakeError>>) {
        let code = code_of(&line);
        let word = classify(code);
        match &mut self.block {
            Some(b) => {
                match word {
                    Word::Opens => b.depth += 1,
                    Word::Closes => b.depth = b.depth.saturating_sub(1),
                    Word::Other => {}
                }
                if !b.dropping {
                    if b.source.len() + line.len() + 1 > MAX_PROGRAM {
                        b.dropping = true;
                        b.source = String::new();
                        out.push(Err(IntakeError::ProgramTooLong {
                            name: b.name.clone(),
                        }));
                    } else {
                        b.source.push_str(&line);
                        b.source.push('\n');
                    }
                }
                if b.depth == 0 {
                    if let Some(b) = self.block.take() {
                        if !b.dropping {
                            out.push(Ok(match b.kind {
                                BlockKind::Def => Intake::Program {
                                    name: b.name,
                                    source: b.source,
                                },
                                BlockKind::Sec => Intake::Secondary {
                                    name: b.name,
                                    source: b.source,
                                },
                                BlockKind::Bare => {
                                    let mut s = b.source;
                                    if s.ends_with('\n') {
                                        s.pop();
                                    }
                                    Intake::Line(s)
                                }
                            }));
                        }
                    }
                }
            }
            None => {
                if code.trim().is_empty() {
                    return;
                }
                if let Some(c) = command(code) {
                    out.push(Ok(Intake::Command(c)));
                    return;
                }
                if word != Word::Opens {
                    // A stray `end` at the top level is passed on as a line: the
                    // controller reports it as a syntax error.
                    out.push(Ok(Intake::Line(line)));
                    return;
                }
                let first = first_word(code.trim_start());
                let kind = match first {
                    "def" => BlockKind::Def,
                    "sec" => BlockKind::Sec,
                    _ => BlockKind::Bare,
                };
                let name = if kind == BlockKind::Bare {
                    String::new()
                } else {
                    block_name(code)
                };
                let mut source = line;
                source.push('\n');
                self.block = Some(Block {
                    kind,
                    name,
                    source,
                    depth: 1,
                    dropping: false,
                });
            }
        }
    }
}
