//! The interpreter's errors, typed: a program that does not parse or compile
//! ([`ParseError`], with its [`ParseErrorKind`]), and a program that fails while it runs
//! ([`RuntimeError`], with its [`RuntimeErrorKind`]). Each names the line and column.

use std::fmt;

/// The code UR's controller gives a program it refuses: what the text of its runtime
/// exception starts with (URSim sends `compile_error_name_not_found:txtmsg:` and
/// `syntax_error_on_line:2:end:`). [`Display`](fmt::Display) writes that text.
///
/// ```
/// use urscript_interp::{ControllerCode, Program};
/// let e = Program::parse("x = (1 +\n").unwrap_err();
/// assert_eq!(e.code(), ControllerCode::SyntaxErrorOnLine { line: 2 });
/// assert_eq!(e.code().to_string(), "syntax_error_on_line:2:");
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum ControllerCode {
    /// `compile_error_name_not_found:NAME:`: a name that is neither defined, built in,
    /// stubbed, nor assigned where it is read.
    NameNotFound {
        /// The name.
        name: String,
    },
    /// `syntax_error_on_line:LINE:`: the text does not parse (or does not compile for a
    /// reason with no code of its own).
    SyntaxErrorOnLine {
        /// The 1-based line.
        line: u32,
    },
}

impl fmt::Display for ControllerCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ControllerCode::NameNotFound { name } => {
                write!(f, "compile_error_name_not_found:{name}:")
            }
            ControllerCode::SyntaxErrorOnLine { line } => write!(f, "syntax_error_on_line:{line}:"),
        }
    }
}

/// Which stage refused the program.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum ParseErrorKind {
    /// The text is not URScript: a token or construct out of place, or one this
    /// interpreter does not support (named).
    Syntax,
    /// It parses, but the controller would refuse to compile it: a call with the wrong
    /// arguments, `break` outside a loop, a function defined twice, `run` of a
    /// function...
    Compile,
}

/// The program text is not URScript this interpreter accepts, found before anything
/// runs. Displayed as `line L, column C: what`.
///
/// ```
/// use urscript_interp::{ParseErrorKind, Program};
/// let e = Program::parse("x = (1 +\n").unwrap_err();
/// assert_eq!((e.line(), e.kind()), (2, ParseErrorKind::Syntax));
/// let e = Program::parse("x = 1\n  socket_open(\"h\")\n").unwrap_err();
/// assert_eq!((e.line(), e.column(), e.kind()), (2, 3, ParseErrorKind::Compile));
/// assert_eq!(e.message(), "`socket_open` needs argument `port`");
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ParseError {
    kind: ParseErrorKind,
    line: u32,
    column: u32,
    message: String,
    code: Option<ControllerCode>,
}

impl ParseError {
    pub(crate) fn new(line: u32, column: u32, message: String) -> Self {
        Self::with_kind(ParseErrorKind::Syntax, line, column, message)
    }

    pub(crate) fn with_kind(kind: ParseErrorKind, line: u32, column: u32, message: String) -> Self {
        ParseError {
            kind,
            line,
            column,
            message,
            code: None,
        }
    }

    /// The same error with the controller's `code` for it.
    pub(crate) fn with_code(mut self, code: ControllerCode) -> Self {
        self.code = Some(code);
        self
    }

    /// The controller's code for this error: its own where it has one
    /// ([`NameNotFound`](ControllerCode::NameNotFound)), else
    /// [`SyntaxErrorOnLine`](ControllerCode::SyntaxErrorOnLine) at its line, as the
    /// controller refuses a program that does not parse.
    pub fn code(&self) -> ControllerCode {
        self.code
            .clone()
            .unwrap_or(ControllerCode::SyntaxErrorOnLine { line: self.line })
    }

    /// Syntax or compile error.
    pub fn kind(&self) -> ParseErrorKind {
        self.kind
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

/// What kind of failure stopped a running program.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum RuntimeErrorKind {
    /// A value of the wrong type for an operator, a condition or an argument.
    Type,
    /// An index outside a list or pose.
    Index,
    /// Integer division (or remainder) by zero.
    DivisionByZero,
    /// A variable read before it was assigned.
    UnknownVariable,
    /// A function that is neither defined, built in, nor stubbed.
    UnknownFunction,
    /// A built-in refused an argument's value (a port out of range, `asin(2)`...).
    Argument,
    /// A bound of the machine: threads, call depth.
    Limit,
    /// A struct has no member of that name (`s.c` of `struct(a=1, b=2)`).
    UnknownMember,
    /// An XML-RPC call (`handle.name(...)` on an `rpc_factory` handle) failed: no
    /// connection, a fault from the server, a malformed or missing reply.
    RemoteCall,
    /// A bug of the interpreter (please report it).
    Internal,
}

/// The program failed while running. Displayed as `line N: what`; [`column`](Self::column)
/// points at the call or the statement.
///
/// ```
/// use std::time::Duration;
/// use urscript_interp::{Config, Machine, Program, RuntimeErrorKind, State};
/// let mut m = Machine::new(Program::parse("x = [1, 2]\ny = x[5]\n").unwrap(), Config::default());
/// m.run_until(Duration::ZERO);
/// let State::Error(e) = m.state() else { panic!() };
/// assert_eq!((e.line(), e.kind()), (2, RuntimeErrorKind::Index));
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RuntimeError {
    kind: RuntimeErrorKind,
    line: u32,
    column: u32,
    message: String,
    code: Option<ControllerCode>,
}

impl RuntimeError {
    /// A bug of the interpreter, at `line`.
    pub(crate) fn internal(line: u32, message: impl Into<String>) -> Self {
        RuntimeError {
            kind: RuntimeErrorKind::Internal,
            line,
            column: 1,
            message: message.into(),
            code: None,
        }
    }

    /// `fault` at line `line`, column `column`.
    pub(crate) fn at(line: u32, column: u32, fault: Fault) -> Self {
        RuntimeError {
            kind: fault.kind,
            line,
            column,
            message: fault.message,
            code: fault.code,
        }
    }

    /// The controller's code for this error, if it has one: a program that fails the
    /// compile check (a name neither defined, built in, stubbed nor assigned) does not
    /// start, with [`NameNotFound`](ControllerCode::NameNotFound).
    pub fn code(&self) -> Option<&ControllerCode> {
        self.code.as_ref()
    }

    /// What kind of failure.
    pub fn kind(&self) -> RuntimeErrorKind {
        self.kind
    }

    /// 1-based line of the statement that failed.
    pub fn line(&self) -> u32 {
        self.line
    }

    /// 1-based column of the statement or call that failed.
    pub fn column(&self) -> u32 {
        self.column
    }

    /// What was wrong, without the line.
    pub fn message(&self) -> &str {
        &self.message
    }
}

/// A failure inside the machine or a built-in, before it has a place in the program:
/// the machine adds the line and column of the statement or call.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Fault {
    pub kind: RuntimeErrorKind,
    pub message: String,
    /// The controller's code, for a fault of the compile check.
    pub code: Option<ControllerCode>,
}

impl Fault {
    pub fn new(kind: RuntimeErrorKind, message: impl Into<String>) -> Self {
        Fault {
            kind,
            message: message.into(),
            code: None,
        }
    }

    /// The compile check's refusal of `name` (an unknown function or a variable nothing
    /// assigns): the controller's code, then `why`.
    pub fn name_not_found(kind: RuntimeErrorKind, name: &str, why: &str) -> Self {
        let code = ControllerCode::NameNotFound {
            name: name.to_string(),
        };
        Fault {
            kind,
            message: format!("{code} {why}"),
            code: Some(code),
        }
    }

    /// A value of the wrong type.
    pub fn type_error(message: impl Into<String>) -> Self {
        Self::new(RuntimeErrorKind::Type, message)
    }
}

/// A built-in's refusal of an argument's value (a port out of range, `asin(2)`): the
/// kind of every plain message a built-in returns.
impl From<String> for Fault {
    fn from(message: String) -> Self {
        Self::new(RuntimeErrorKind::Argument, message)
    }
}

impl From<&str> for Fault {
    fn from(message: &str) -> Self {
        Self::new(RuntimeErrorKind::Argument, message)
    }
}

impl fmt::Display for RuntimeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "line {}: {}", self.line, self.message)
    }
}

impl std::error::Error for RuntimeError {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_compile_checks_faults_carry_their_code() {
        let f = Fault::name_not_found(
            RuntimeErrorKind::UnknownFunction,
            "rq_open",
            "`rq_open` is neither defined",
        );
        assert_eq!(
            f.message,
            "compile_error_name_not_found:rq_open: `rq_open` is neither defined"
        );
        let e = RuntimeError::at(3, 5, f);
        assert_eq!(
            e.code(),
            Some(&ControllerCode::NameNotFound {
                name: "rq_open".into()
            })
        );
        // Other faults have none, whatever their text says.
        let text = "compile_error_name_not_found:x: no";
        assert_eq!(
            RuntimeError::at(1, 1, Fault::new(RuntimeErrorKind::UnknownFunction, text)).code(),
            None
        );
    }

    #[test]
    fn parse_errors_are_syntax_errors_unless_they_say_otherwise() {
        let e = ParseError::new(4, 2, "expected `:`".into());
        assert_eq!(e.code(), ControllerCode::SyntaxErrorOnLine { line: 4 });
        let e = ParseError::with_kind(ParseErrorKind::Compile, 1, 1, "x".into())
            .with_code(ControllerCode::NameNotFound { name: "y".into() });
        assert_eq!(e.code().to_string(), "compile_error_name_not_found:y:");
    }
}
