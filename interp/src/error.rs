//! The two errors of the interpreter: a program that does not parse, and a program that
//! fails while it runs.

use std::fmt;

/// The program text is not URScript this interpreter accepts: a syntax error, or a
/// construct not supported, named. Displayed as `line L, column C: what`.
///
/// ```
/// use urscript_interp::Program;
/// let e = Program::parse("x = (1 +\n").unwrap_err();
/// assert_eq!(e.line(), 2);
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ParseError {
    line: u32,
    column: u32,
    message: String,
}

impl ParseError {
    pub(crate) fn new(line: u32, column: u32, message: String) -> Self {
        ParseError {
            line,
            column,
            message,
        }
    }

    /// 1-based line of the offending token.
    pub fn line(&self) -> u32 {
        self.line
    }

    /// 1-based column (in characters) of the offending token.
    pub fn column(&self) -> u32 {
        self.column
    }

    /// What was wrong, without the position.
    pub fn message(&self) -> &str {
        &self.message
    }
}

impl fmt::Display for ParseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "line {}, column {}: {}",
            self.line, self.column, self.message
        )
    }
}

impl std::error::Error for ParseError {}

/// The program failed while running (index out of range, type error, unknown variable or
/// function, integer division by zero, a thread that never consumes time...). Displayed as
/// `line N: what`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RuntimeError {
    line: u32,
    message: String,
}

impl RuntimeError {
    pub(crate) fn new(line: u32, message: impl Into<String>) -> Self {
        RuntimeError {
            line,
            message: message.into(),
        }
    }

    /// 1-based line of the statement that failed.
    pub fn line(&self) -> u32 {
        self.line
    }

    /// What was wrong, without the line.
    pub fn message(&self) -> &str {
        &self.message
    }
}

impl fmt::Display for RuntimeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "line {}: {}", self.line, self.message)
    }
}

impl std::error::Error for RuntimeError {}
