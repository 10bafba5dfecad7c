//! Recursive-descent parser from tokens to the syntax tree. Expressions use precedence
//! climbing with URScript's levels, lowest first: `or`, `xor`, `and`, `not`, comparisons
//! (`== != < <= > >=`), `+ -`, `* / %`, unary `-`, then indexing and calls.

use crate::error::ParseError;
use crate::syntax::lexer::{Tok, Token};
use crate::value::{Value, DEFAULT_MAX_VALUE_SIZE, MAX_VALUE_DEPTH};

/// Nesting bound of blocks, brackets and unary operators (the parser's own recursion), so
/// hostile input cannot overflow the stack.
pub(crate) const MAX_DEPTH: usize = 64;

/// The deepest expression tree the parser builds: every operator, index, call, list and
/// unary operator is one level over its operands, and a left-associative chain counts
/// each link (`1 + 1 + 1` is 3 levels). Everything recursive over a tree (compiling,
/// cloning, dropping it) stays within this bound.
pub(crate) const MAX_EXPR_DEPTH: u32 = 128;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum BinOp {
    Or,
    Xor,
    And,
    Eq,
    Ne,
    Lt,
    Le,
    Gt,
    Ge,
    Add,
    Sub,
    Mul,
    Div,
    Rem,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum UnOp {
    Neg,
    Not,
}

#[derive(Debug, Clone)]
pub(crate) enum Expr {
    Lit(Value),
    /// A variable, with the line and column of its name.
    Name(String, (u32, u32)),
    List(Vec<Expr>),
    Pose(Vec<Expr>),
    Index(Box<Expr>, Box<Expr>),
    Call {
        name: String,
        args: Vec<Expr>,
        kwargs: Vec<(String, Expr)>,
        /// Line and column of the name.
        at: (u32, u32),
    },
    Unary(UnOp, Box<Expr>),
    Binary(BinOp, Box<Expr>, Box<Expr>),
    /// `run name()`, with the line and column of the name.
    Run(String, (u32, u32)),
    /// `base.name`: a struct's member, with the line and column of the name.
    Member(Box<Expr>, String, (u32, u32)),
    /// `handle.name(args...)`: a remote procedure call on an `rpc_factory` handle, with
    /// the line and column of the method's name.
    Method {
        target: Box<Expr>,
        method: String,
        args: Vec<Expr>,
        at: (u32, u32),
    },
}

/// One step of an assignment's target after the variable: `[i]` or `.name`.
#[derive(Debug, Clone)]
pub(crate) enum Access {
    Index(Expr),
    Member(String),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Scope {
    Auto,
    Local,
    Global,
}

/// A parameter's default: a constant, or the name of a variable read when the function
/// is called without that argument (`def f(hz=DEFAULT_HZ):`, as OnRobot's URCap writes),
/// or a list or pose literal whose items are such defaults (`def f(poses=[ZERO_POSE]):`,
/// OnRobot's FT URCap preamble). UR's manual shows only constant defaults and says
/// nothing of names; a name is taken here and looked up among the globals at each call
/// (not when the `def` is read).
#[derive(Debug, Clone)]
pub(crate) enum ParamDefault<N = String> {
    Const(Value),
    Var(N),
    /// A list literal with at least one name among its items (at any depth).
    List(Vec<ParamDefault<N>>),
    /// A pose literal with at least one name among its six items.
    Pose(Vec<ParamDefault<N>>),
}

impl<N> ParamDefault<N> {
    /// The same default with its names mapped by `f`.
    pub(crate) fn map_names<M>(&self, f: &mut impl FnMut(&N) -> M) -> ParamDefault<M> {
        match self {
            ParamDefault::Const(v) => ParamDefault::Const(v.clone()),
            ParamDefault::Var(n) => ParamDefault::Var(f(n)),
            ParamDefault::List(items) => {
                ParamDefault::List(items.iter().map(|d| d.map_names(f)).collect())
            }
            ParamDefault::Pose(items) => {
                ParamDefault::Pose(items.iter().map(|d| d.map_names(f)).collect())
            }
        }
    }
}

/// A parameter default from its expression: a constant, a variable name, or a list or
/// pose literal of those; `None` for anything else.
fn param_default(e: &Expr) -> Option<ParamDefault> {
    if let Some(v) = const_value(e) {
        return Some(ParamDefault::Const(v));
    }
    match e {
        Expr::Name(var, _) => Some(ParamDefault::Var(var.clone())),
        Expr::List(items) => items
            .iter()
            .map(param_default)
            .collect::<Option<_>>()
            .map(ParamDefault::List),
        Expr::Pose(items) => items
            .iter()
            .map(param_default)
            .collect::<Option<_>>()
            .map(ParamDefault::Pose),
        _ => None,
    }
}

#[derive(Debug, Clone)]
pub(crate) struct FuncDef {
    pub name: String,
    pub params: Vec<(String, Option<ParamDefault>)>,
    pub body: Vec<Stmt>,
    pub is_thread: bool,
    pub line: u32,
}

#[derive(Debug, Clone)]
pub(crate) enum StmtKind {
    Assign {
        scope: Scope,
        name: String,
        indices: Vec<Expr>,
        value: Option<Expr>,
    },
    /// `name.m = v`, `name[i].m = v`, `name.m[i] = v`: a target with at least one
    /// member step (a target of indices only is an [`StmtKind::Assign`]).
    AssignPath {
        name: String,
        path: Vec<Access>,
        value: Expr,
    },
    Expr(Expr),
    If {
        branches: Vec<(Expr, Vec<Stmt>)>,
        otherwise: Vec<Stmt>,
    },
    While(Expr, Vec<Stmt>),
    Break,
    Continue,
    Return(Option<Expr>),
    Halt,
    Def(FuncDef),
    Join(Expr),
    Kill(Expr),
    EnterCritical,
    ExitCritical,
}

#[derive(Debug, Clone)]
pub(crate) struct Stmt {
    pub kind: StmtKind,
    pub line: u32,
    pub col: u32,
}

/// Words that cannot be variable names.
const KEYWORDS: &[&str] = &[
    "def",
    "sec",
    "thread",
    "end",
    "if",
    "elif",
    "else",
    "while",
    "return",
    "break",
    "continue",
    "halt",
    "run",
    "join",
    "kill",
    "global",
    "local",
    "and",
    "or",
    "xor",
    "not",
    "True",
    "False",
    "enter_critical",
    "exit_critical",
];

/// Words of URScript (or of Python-like languages) this interpreter does not support.
const UNSUPPORTED: &[(&str, &str)] = &[
    ("for", "`for` loops are not URScript (use `while`)"),
    ("lambda", "`lambda` is not URScript"),
    ("import", "`import` is not URScript"),
];

pub(crate) struct Parser {
    toks: Vec<Token>,
    pos: usize,
    depth: usize,
}

impl Parser {
    pub fn new(toks: Vec<Token>) -> Self {
        Parser {
            toks,
            pos: 0,
            depth: 0,
        }
    }

    fn peek(&self) -> &Token {
        // The lexer always ends the list with Eof, and `bump` never passes it.
        &self.toks[self.pos.min(self.toks.len() - 1)]
    }

    fn peek_at(&self, n: usize) -> &Tok {
        &self.toks[(self.pos + n).min(self.toks.len() - 1)].kind
    }

    fn bump(&mut self) -> Token {
        let t = self.peek().clone();
        if t.kind != Tok::Eof {
            self.pos += 1;
        }
        t
    }

    fn err_here(&self, what: impl Into<String>) -> ParseError {
        let t = self.peek();
        ParseError::new(t.line, t.col, what.into())
    }

    fn expected(&self, what: &str) -> ParseError {
        let t = self.peek();
        self.err_here(format!("expected {what}, found {}", t.kind.describe()))
    }

    fn eat(&mut self, kind: &Tok) -> bool {
        if &self.peek().kind == kind {
            self.bump();
            true
        } else {
            false
        }
    }

    fn expect(&mut self, kind: &Tok, what: &str) -> Result<(), ParseError> {
        if self.eat(kind) {
            Ok(())
        } else {
            Err(self.expected(what))
        }
    }

    fn is_word(&self, word: &str) -> bool {
        matches!(&self.peek().kind, Tok::Ident(w) if w == word)
    }

    fn eat_word(&mut self, word: &str) -> bool {
        if self.is_word(word) {
            self.bump();
            true
        } else {
            false
        }
    }

    fn name(&mut self, what: &str) -> Result<String, ParseError> {
        match &self.peek().kind {
            Tok::Ident(w) if !KEYWORDS.contains(&w.as_str()) => {
                let w = w.clone();
                self.bump();
                Ok(w)
            }
            Tok::Ident(w) => Err(self.err_here(format!("expected {what}, found keyword `{w}`"))),
            _ => Err(self.expected(what)),
        }
    }

    fn skip_newlines(&mut self) {
        while self.eat(&Tok::Newline) {}
    }

    fn end_of_statement(&mut self) -> Result<(), ParseError> {
        if self.eat(&Tok::Newline) || self.peek().kind == Tok::Eof {
            return Ok(());
        }
        // `if x: y = 1 end` style: a block keyword may follow on the same line.
        if ["end", "elif", "else"].iter().any(|w| self.is_word(w)) {
            return Ok(());
        }
        // Statements side by side on one line, as the controller accepts them
        // (`socket_send_line("x") textmsg("y")`, `w = -0.2 f(w)`): a name (or a variable
        // named `p`, indexed) that cannot continue the expression starts the next one.
        if matches!(self.peek().kind, Tok::Ident(_) | Tok::PoseOpen) {
            return Ok(());
        }
        Err(self.expected("end of line"))
    }

    fn enter(&mut self) -> Result<(), ParseError> {
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            return Err(self.err_here("program nested too deeply"));
        }
        Ok(())
    }

    /// The whole program: statements to the end.
    pub fn program(&mut self) -> Result<Vec<Stmt>, ParseError> {
        let mut out = Vec::new();
        self.skip_newlines();
        while self.peek().kind != Tok::Eof {
            if ["end", "elif", "else"].iter().any(|w| self.is_word(w)) {
                let t = self.peek().kind.describe();
                return Err(self.err_here(format!("{t} without an open block")));
            }
            out.push(self.statement()?);
            self.skip_newlines();
        }
        Ok(out)
    }

    /// Statements until one of `stops` (not consumed).
    fn block(&mut self, stops: &[&str]) -> Result<Vec<Stmt>, ParseError> {
        self.enter()?;
        let mut out = Vec::new();
        self.skip_newlines();
        while !stops.iter().any(|w| self.is_word(w)) {
            if self.peek().kind == Tok::Eof {
                let list = stops.join("`/`");
                return Err(self.err_here(format!("expected `{list}` before the end of program")));
            }
            out.push(self.statement()?);
            self.skip_newlines();
        }
        self.depth -= 1;
        Ok(out)
    }

    fn statement(&mut self) -> Result<Stmt, ParseError> {
        let (line, col) = (self.peek().line, self.peek().col);
        let kind = self.statement_kind()?;
        Ok(Stmt { kind, line, col })
    }

    fn statement_kind(&mut self) -> Result<StmtKind, ParseError> {
        let word = match &self.peek().kind {
            Tok::Ident(w) => w.clone(),
            // `p[i] = v`: an element of a variable named `p` (not a pose literal).
            Tok::PoseOpen => {
                let save = (self.pos, self.depth);
                self.bump();
                if let Ok(first) = self.expr() {
                    if self.eat(&Tok::RBracket) {
                        if let Ok(mut indices) = self.target_indices() {
                            if self.eat(&Tok::Assign) {
                                indices.insert(0, first);
                                let value = self.expr()?;
                                self.end_of_statement()?;
                                return Ok(StmtKind::Assign {
                                    scope: Scope::Auto,
                                    name: "p".into(),
                                    indices,
                                    value: Some(value),
                                });
                            }
                        }
                    }
                }
                (self.pos, self.depth) = save;
                let e = self.expr()?;
                return Err(self.not_a_statement(e));
            }
            _ => {
                let e = self.expr()?;
                return Err(self.not_a_statement(e));
            }
        };
        if let Some((_, why)) = UNSUPPORTED.iter().find(|(w, _)| *w == word) {
            return Err(self.err_here(*why));
        }
        match word.as_str() {
            "def" | "sec" | "thread" => {
                let line = self.bump().line;
                let f = self.func(word == "thread", line)?;
                Ok(StmtKind::Def(f))
            }
            "if" => self.if_stmt(),
            "while" => {
                self.bump();
                let cond = self.expr()?;
                self.expect(&Tok::Colon, "`:` after the `while` condition")?;
                let body = self.block(&["end"])?;
                self.bump();
                self.end_of_statement()?;
                Ok(StmtKind::While(cond, body))
            }
            "break" | "continue" | "halt" | "enter_critical" | "exit_critical" => {
                self.bump();
                self.end_of_statement()?;
                Ok(match word.as_str() {
                    "break" => StmtKind::Break,
                    "continue" => StmtKind::Continue,
                    "halt" => StmtKind::Halt,
                    "enter_critical" => StmtKind::EnterCritical,
                    _ => StmtKind::ExitCritical,
                })
            }
            "return" => {
                self.bump();
                let value =
                    if matches!(self.peek().kind, Tok::Newline | Tok::Eof) || self.is_word("end") {
                        None
                    } else {
                        Some(self.expr()?)
                    };
                self.end_of_statement()?;
                Ok(StmtKind::Return(value))
            }
            "join" | "kill" => {
                self.bump();
                let e = self.expr()?;
                self.end_of_statement()?;
                Ok(if word == "join" {
                    StmtKind::Join(e)
                } else {
                    StmtKind::Kill(e)
                })
            }
            "global" | "local" => {
                self.bump();
                let scope = if word == "global" {
                    Scope::Global
                } else {
                    Scope::Local
                };
                let name = self.name("a variable name")?;
                let indices = self.target_indices()?;
                let value = if self.eat(&Tok::Assign) {
                    Some(self.expr()?)
                } else {
                    None
                };
                self.end_of_statement()?;
                Ok(StmtKind::Assign {
                    scope,
                    name,
                    indices,
                    value,
                })
            }
            "end" | "elif" | "else" => {
                Err(self.err_here(format!("`{word}` without an open block")))
            }
            _ => {
                // An assignment `name = v`, `name[i] = v`, or an expression statement.
                if !KEYWORDS.contains(&word.as_str()) {
                    let save = (self.pos, self.depth);
                    self.bump();
                    if let Ok(path) = self.target_path() {
                        if self.eat(&Tok::Assign) {
                            let value = self.expr()?;
                            self.end_of_statement()?;
                            if path.iter().any(|a| matches!(a, Access::Member(_))) {
                                return Ok(StmtKind::AssignPath {
                                    name: word,
                                    path,
                                    value,
                                });
                            }
                            let indices = path
                                .into_iter()
                                .filter_map(|a| match a {
                                    Access::Index(e) => Some(e),
                                    Access::Member(_) => None,
                                })
                                .collect();
                            return Ok(StmtKind::Assign {
                                scope: Scope::Auto,
                                name: word,
                                indices,
                                value: Some(value),
                            });
                        }
                    }
                    (self.pos, self.depth) = save;
                }
                let e = self.expr()?;
                if self.peek().kind == Tok::Assign {
                    return Err(self.err_here("cannot assign to this expression"));
                }
                if !matches!(e, Expr::Call { .. } | Expr::Run(..) | Expr::Method { .. }) {
                    return Err(self.not_a_statement(e));
                }
                self.end_of_statement()?;
                Ok(StmtKind::Expr(e))
            }
        }
    }

    fn not_a_statement(&self, _e: Expr) -> ParseError {
        self.err_here(format!(
            "expected a statement (a call or an assignment), found an expression before {}",
            self.peek().kind.describe()
        ))
    }

    /// `[i]`, `.name`, in any order and number, after an assignment's variable.
    fn target_path(&mut self) -> Result<Vec<Access>, ParseError> {
        let mut out = Vec::new();
        loop {
            match self.peek().kind {
                Tok::LBracket => {
                    self.bump();
                    out.push(Access::Index(self.expr()?));
                    // `m[i, j] = v`: the entry at row `i`, column `j`, as `m[i][j] = v`.
                    if self.eat(&Tok::Comma) {
                        out.push(Access::Index(self.expr()?));
                        if self.peek().kind == Tok::Comma {
                            return Err(
                                self.err_here("a matrix entry takes two indices, `m[row, column]`")
                            );
                        }
                    }
                    self.expect(&Tok::RBracket, "`]`")?;
                }
                Tok::Dot => {
                    self.bump();
                    out.push(Access::Member(self.member_name()?));
                }
                _ => return Ok(out),
            }
            if out.len() > MAX_DEPTH {
                return Err(self.err_here("assignment target nested too deeply"));
            }
        }
    }

    /// The name after a `.`: any identifier, a URScript keyword included (the manual's
    /// own `time().sec`: after a `.` a word can only be a member).
    fn member_name(&mut self) -> Result<String, ParseError> {
        self.word("a member name after `.`")
    }

    /// Any identifier, keywords included: where the grammar allows only a name (after
    /// `.`, before `=` in an argument list) a keyword cannot start anything else.
    fn word(&mut self, what: &str) -> Result<String, ParseError> {
        match &self.peek().kind {
            Tok::Ident(w) => {
                let w = w.clone();
                self.bump();
                Ok(w)
            }
            _ => Err(self.expected(what)),
        }
    }

    /// `[i]` or `[i][j]` after an assignment target.
    fn target_indices(&mut self) -> Result<Vec<Expr>, ParseError> {
        let mut out = Vec::new();
        while self.peek().kind == Tok::LBracket {
            self.bump();
            out.push(self.expr()?);
            self.expect(&Tok::RBracket, "`]`")?;
        }
        Ok(out)
    }

    fn if_stmt(&mut self) -> Result<StmtKind, ParseError> {
        self.bump();
        let mut branches = Vec::new();
        let cond = self.expr()?;
        self.expect(&Tok::Colon, "`:` after the `if` condition")?;
        let body = self.block(&["end", "elif", "else"])?;
        branches.push((cond, body));
        let mut otherwise = Vec::new();
        loop {
            if self.eat_word("elif") {
                let cond = self.expr()?;
                self.expect(&Tok::Colon, "`:` after the `elif` condition")?;
                let body = self.block(&["end", "elif", "else"])?;
                branches.push((cond, body));
            } else if self.eat_word("else") {
                self.expect(&Tok::Colon, "`:` after `else`")?;
                otherwise = self.block(&["end"])?;
            } else {
                self.bump(); // `end`
                break;
            }
        }
        self.end_of_statement()?;
        Ok(StmtKind::If {
            branches,
            otherwise,
        })
    }

    fn func(&mut self, is_thread: bool, line: u32) -> Result<FuncDef, ParseError> {
        let name = self.name("a function name")?;
        self.expect(&Tok::LParen, "`(` after the function name")?;
        let mut params = Vec::new();
        let mut seen_default = false;
        if !self.eat(&Tok::RParen) {
            loop {
                let p = self.name("a parameter name")?;
                let default = if self.eat(&Tok::Assign) {
                    seen_default = true;
                    let t = self.peek().clone();
                    let e = self.expr()?;
                    let d = param_default(&e).ok_or_else(|| {
                        ParseError::new(
                            t.line,
                            t.col,
                            format!(
                                "the default of parameter `{p}` must be a constant, a variable name, or a list or pose of those"
                            ),
                        )
                    })?;
                    let ParamDefault::Const(v) = d else {
                        // Names are read at each call; the value is checked then.
                        params.push((p, Some(d)));
                        if self.eat(&Tok::RParen) {
                            break;
                        }
                        self.expect(&Tok::Comma, "`,` or `)` in the parameter list")?;
                        continue;
                    };
                    // The value bounds hold for defaults too (no list literal in the
                    // program escapes them).
                    let (depth, size) = v.measure(DEFAULT_MAX_VALUE_SIZE);
                    if depth > MAX_VALUE_DEPTH || size > DEFAULT_MAX_VALUE_SIZE {
                        return Err(ParseError::new(
                            t.line,
                            t.col,
                            format!(
                                "the default of parameter `{p}` is over the value bounds ({MAX_VALUE_DEPTH} levels of lists, {DEFAULT_MAX_VALUE_SIZE} elements)"
                            ),
                        ));
                    }
                    Some(ParamDefault::Const(v))
                } else {
                    if seen_default {
                        return Err(self.err_here(format!(
                            "parameter `{p}` without a default follows one with a default"
                        )));
                    }
                    None
                };
                params.push((p, default));
                if self.eat(&Tok::RParen) {
                    break;
                }
                self.expect(&Tok::Comma, "`,` or `)` in the parameter list")?;
            }
        }
        if is_thread && !params.is_empty() {
            return Err(self.err_here("a thread takes no parameters"));
        }
        self.expect(&Tok::Colon, "`:` after the parameter list")?;
        let body = self.block(&["end"])?;
        self.bump();
        self.end_of_statement()?;
        Ok(FuncDef {
            name,
            params,
            body,
            is_thread,
            line,
        })
    }

    /// Only line ends may follow (after a constant).
    pub fn end_of_constant(&mut self) -> Result<(), ParseError> {
        self.skip_newlines();
        if self.peek().kind == Tok::Eof {
            Ok(())
        } else {
            Err(self.expected("the end of the value"))
        }
    }

    pub fn expr(&mut self) -> Result<Expr, ParseError> {
        self.expr_h().map(|(e, _)| e)
    }

    /// An expression and the depth of its tree.
    fn expr_h(&mut self) -> Result<(Expr, u32), ParseError> {
        self.enter()?;
        let e = self.binary(0)?;
        self.depth -= 1;
        Ok(e)
    }

    /// One level over operands of depth `h`, at `(line, col)`: an error past
    /// [`MAX_EXPR_DEPTH`].
    fn over(&self, h: u32, line: u32, col: u32) -> Result<u32, ParseError> {
        let h = h.saturating_add(1);
        if h > MAX_EXPR_DEPTH {
            return Err(ParseError::new(
                line,
                col,
                format!(
                    "expression nested too deeply (more than {MAX_EXPR_DEPTH} levels of operators, indices and calls)"
                ),
            ));
        }
        Ok(h)
    }

    /// Precedence climbing over the levels: 0 or, 1 xor, 2 and, 3 not (unary),
    /// 4 comparisons, 5 + -, 6 * / %; operators of level `min` and above.
    fn binary(&mut self, min: u8) -> Result<(Expr, u32), ParseError> {
        let (mut lhs, mut h) = if min <= 3 && self.is_word("not") {
            let t = self.bump();
            self.enter()?;
            let (e, he) = self.binary(3)?;
            self.depth -= 1;
            let h = self.over(he, t.line, t.col)?;
            (Expr::Unary(UnOp::Not, Box::new(e)), h)
        } else {
            self.unary()?
        };
        loop {
            let (level, op) = match &self.peek().kind {
                Tok::Ident(w) if w == "or" => (0, BinOp::Or),
                Tok::Ident(w) if w == "xor" => (1, BinOp::Xor),
                Tok::Ident(w) if w == "and" => (2, BinOp::And),
                Tok::Eq => (4, BinOp::Eq),
                Tok::Ne => (4, BinOp::Ne),
                Tok::Lt => (4, BinOp::Lt),
                Tok::Le => (4, BinOp::Le),
                Tok::Gt => (4, BinOp::Gt),
                Tok::Ge => (4, BinOp::Ge),
                Tok::Plus => (5, BinOp::Add),
                Tok::Minus => (5, BinOp::Sub),
                Tok::Star => (6, BinOp::Mul),
                Tok::Slash => (6, BinOp::Div),
                Tok::Percent => (6, BinOp::Rem),
                _ => return Ok((lhs, h)),
            };
            if level < min {
                return Ok((lhs, h));
            }
            let t = self.bump();
            // A line ending in an operator continues on the next one (UR's own
            // External Control script splits `elif a or` / `b:` that way).
            self.skip_newlines();
            let (rhs, hr) = self.binary(level + 1)?;
            h = self.over(h.max(hr), t.line, t.col)?;
            lhs = Expr::Binary(op, Box::new(lhs), Box::new(rhs));
        }
    }

    fn unary(&mut self) -> Result<(Expr, u32), ParseError> {
        // An operand must follow: a line end here does not end the statement, as on the
        // controller, whose grammar is not line-based (`x = # comment` then the value on
        // the next line parses; UR's ur_rtde control script relies on it).
        self.skip_newlines();
        if self.peek().kind == Tok::Minus {
            let t = self.bump();
            if *self.peek_at(0) == Tok::IntMinMagnitude {
                // `-2147483648`: `i32::MIN`, whose magnitude alone does not fit 32 bits.
                self.bump();
                return Ok((Expr::Lit(Value::Int(i32::MIN)), 1));
            }
            self.enter()?;
            let (e, he) = self.unary()?;
            self.depth -= 1;
            return Ok(match e {
                Expr::Lit(Value::Int(v)) => (Expr::Lit(Value::Int(v.wrapping_neg())), he),
                Expr::Lit(Value::Float(v)) => (Expr::Lit(Value::Float(-v)), he),
                e => (
                    Expr::Unary(UnOp::Neg, Box::new(e)),
                    self.over(he, t.line, t.col)?,
                ),
            });
        }
        if self.eat(&Tok::Plus) {
            self.enter()?;
            let e = self.unary()?;
            self.depth -= 1;
            return Ok(e);
        }
        self.postfix()
    }

    fn postfix(&mut self) -> Result<(Expr, u32), ParseError> {
        let (mut e, mut h) = self.primary()?;
        loop {
            match self.peek().kind {
                Tok::LBracket => {
                    let t = self.bump();
                    let (i, hi) = self.expr_h()?;
                    h = self.over(h.max(hi), t.line, t.col)?;
                    e = Expr::Index(Box::new(e), Box::new(i));
                    // `m[i, j]`: a matrix entry (UR's manual, "Matrix and array
                    // expressions"), row `i` then column `j`, read as `m[i][j]`.
                    if self.eat(&Tok::Comma) {
                        let (j, hj) = self.expr_h()?;
                        h = self.over(h.max(hj), t.line, t.col)?;
                        e = Expr::Index(Box::new(e), Box::new(j));
                        if self.peek().kind == Tok::Comma {
                            return Err(
                                self.err_here("a matrix entry takes two indices, `m[row, column]`")
                            );
                        }
                    }
                    self.expect(&Tok::RBracket, "`]` after the index")?;
                }
                Tok::Dot => {
                    let t = self.bump();
                    let at = (self.peek().line, self.peek().col);
                    let name = self.member_name()?;
                    if self.peek().kind == Tok::LParen {
                        self.bump();
                        let (args, ha) =
                            self.items(&Tok::RParen, "`,` or `)` in the argument list")?;
                        h = self.over(h.max(ha), t.line, t.col)?;
                        e = Expr::Method {
                            target: Box::new(e),
                            method: name,
                            args,
                            at,
                        };
                    } else {
                        h = self.over(h, t.line, t.col)?;
                        e = Expr::Member(Box::new(e), name, at);
                    }
                }
                _ => return Ok((e, h)),
            }
        }
    }

    /// Items up to `close`, and the depth of the deepest.
    fn items(&mut self, close: &Tok, what: &str) -> Result<(Vec<Expr>, u32), ParseError> {
        let mut items = Vec::new();
        let mut h = 0;
        if self.eat(close) {
            return Ok((items, h));
        }
        loop {
            let (e, he) = self.expr_h()?;
            items.push(e);
            h = h.max(he);
            if self.eat(close) {
                return Ok((items, h));
            }
            self.expect(&Tok::Comma, what)?;
            if self.eat(close) {
                return Ok((items, h));
            }
        }
    }

    fn primary(&mut self) -> Result<(Expr, u32), ParseError> {
        let t = self.peek().clone();
        match t.kind {
            Tok::Int(v) => {
                self.bump();
                Ok((Expr::Lit(Value::Int(v)), 1))
            }
            Tok::IntMinMagnitude => {
                Err(self.err_here("integer literal `2147483648` does not fit 32 bits"))
            }
            Tok::Float(v) => {
                self.bump();
                Ok((Expr::Lit(Value::Float(v)), 1))
            }
            Tok::Str(s) => {
                self.bump();
                Ok((Expr::Lit(Value::Str(s.into_bytes())), 1))
            }
            Tok::LParen => {
                self.bump();
                let e = self.expr_h()?;
                self.expect(&Tok::RParen, "`)`")?;
                Ok(e)
            }
            Tok::LBracket => {
                self.bump();
                let (items, h) = self.items(&Tok::RBracket, "`,` or `]` in the list")?;
                Ok((Expr::List(items), self.over(h, t.line, t.col)?))
            }
            Tok::PoseOpen => {
                self.bump();
                let (items, h) = self.items(&Tok::RBracket, "`,` or `]` in the pose")?;
                let h = self.over(h.max(1), t.line, t.col)?;
                match items.len() {
                    6 => Ok((Expr::Pose(items), h)),
                    // `p[i]`: a variable named `p`, indexed.
                    1 => {
                        let mut it = items.into_iter();
                        let i = it.next().unwrap_or(Expr::Lit(Value::Int(0)));
                        Ok((
                            Expr::Index(
                                Box::new(Expr::Name("p".into(), (t.line, t.col))),
                                Box::new(i),
                            ),
                            h,
                        ))
                    }
                    n => Err(ParseError::new(
                        t.line,
                        t.col,
                        format!("a pose has 6 values, this one has {n}"),
                    )),
                }
            }
            Tok::Ident(ref w) => {
                match w.as_str() {
                    "True" => {
                        self.bump();
                        return Ok((Expr::Lit(Value::Bool(true)), 1));
                    }
                    "False" => {
                        self.bump();
                        return Ok((Expr::Lit(Value::Bool(false)), 1));
                    }
                    "run" => {
                        self.bump();
                        let at = (self.peek().line, self.peek().col);
                        let name = self.name("a thread name after `run`")?;
                        self.expect(&Tok::LParen, "`(` after the thread name")?;
                        self.expect(&Tok::RParen, "`)`: a thread takes no arguments")?;
                        return Ok((Expr::Run(name, at), 1));
                    }
                    _ => {}
                }
                if let Some((_, why)) = UNSUPPORTED.iter().find(|(u, _)| u == w) {
                    return Err(self.err_here(*why));
                }
                let name_at = (t.line, t.col);
                let name = self.name("an expression")?;
                if self.peek().kind != Tok::LParen {
                    return Ok((Expr::Name(name, name_at), 1));
                }
                self.bump();
                let mut args = Vec::new();
                let mut kwargs: Vec<(String, Expr)> = Vec::new();
                let mut h = 0;
                if !self.eat(&Tok::RParen) {
                    loop {
                        let is_kw = matches!(self.peek().kind, Tok::Ident(_))
                            && *self.peek_at(1) == Tok::Assign;
                        if is_kw {
                            // `struct(sec=1)`: a member named like a keyword.
                            let k = self.word("an argument name")?;
                            self.bump();
                            let (v, hv) = self.expr_h()?;
                            h = h.max(hv);
                            if kwargs.iter().any(|(n, _)| *n == k) {
                                return Err(self.err_here(format!("argument `{k}` given twice")));
                            }
                            kwargs.push((k, v));
                        } else {
                            if !kwargs.is_empty() {
                                return Err(self
                                    .err_here("a positional argument cannot follow a named one"));
                            }
                            let (a, ha) = self.expr_h()?;
                            h = h.max(ha);
                            args.push(a);
                        }
                        if self.eat(&Tok::RParen) {
                            break;
                        }
                        self.expect(&Tok::Comma, "`,` or `)` in the argument list")?;
                    }
                }
                let h = self.over(h, t.line, t.col)?;
                Ok((
                    Expr::Call {
                        name,
                        args,
                        kwargs,
                        at: (t.line, t.col),
                    },
                    h,
                ))
            }
            _ => Err(self.expected("an expression")),
        }
    }
}

/// The value of a constant expression (a parameter default): literals, negated numbers,
/// lists and poses of constants.
pub(crate) fn const_value(e: &Expr) -> Option<Value> {
    match e {
        Expr::Lit(v) => Some(v.clone()),
        Expr::Unary(UnOp::Neg, inner) => match const_value(inner)? {
            Value::Int(v) => Some(Value::Int(v.wrapping_neg())),
            Value::Float(v) => Some(Value::Float(-v)),
            _ => None,
        },
        Expr::List(items) => items
            .iter()
            .map(const_value)
            .collect::<Option<_>>()
            .map(Value::List),
        Expr::Pose(items) => {
            let mut p = [0.0; 6];
            for (slot, e) in p.iter_mut().zip(items) {
                *slot = const_value(e)?.as_f64()?;
            }
            Some(Value::Pose(p))
        }
        _ => None,
    }
}
