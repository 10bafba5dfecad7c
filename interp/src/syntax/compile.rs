//! From the syntax tree to the bytecode each thread runs. A stack machine: every thread
//! keeps its own value stack and call frames, so any thread can stop at a call that
//! consumes time (`sync()`, a blocking read) and resume later where it was.

use std::collections::{HashMap, HashSet};

use crate::builtins::{self, Builtin};
use crate::error::{ControllerCode, ParseError, ParseErrorKind};
use crate::syntax::parser::{Access, BinOp, Expr, FuncDef, ParamDefault, Scope, Stmt, StmtKind};
use crate::value::{Value, MAX_STRUCT_MEMBERS};

/// Index of a name in [`Program::names`].
pub(crate) type Sym = u32;

/// A place in the source: 1-based line and column.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(crate) struct Pos {
    pub line: u32,
    pub col: u32,
}

/// One call in the program, resolved once by the compiler.
#[derive(Debug, Clone)]
pub(crate) struct CallSite {
    /// The function's name.
    pub name: Sym,
    /// Its built-in entry, if it is one (and the program does not define it).
    pub builtin: Option<&'static Builtin>,
    /// Arguments on the stack: positional, then named.
    pub argc: u16,
    /// How many of them are positional.
    pub positional: u16,
    /// The names of the named ones, in order.
    pub kwnames: Vec<Sym>,
    /// For each argument, the parameter it fills (checked at compile time); empty for a
    /// function that is neither defined nor built in (a stub takes anything).
    pub slots: Vec<u8>,
    /// `x = f(...)`: the variable the statement assigns the result to.
    pub assigned: Option<Sym>,
    /// Where the call is.
    pub at: Pos,
    /// A function the program defines.
    pub user: bool,
}

/// One step of an assignment's target (`s.a[i].b = v`) after the variable.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum PathStep {
    /// `[i]`: the index is on the stack (in the path's order, under the value).
    Index,
    /// `.name`.
    Member(Sym),
}

/// The longest method name of a call `h.a.b.m(...)`, dots included: 1 KiB, far past any
/// XML-RPC method a URCap calls, and a bound on what the members before the call add.
pub(crate) const MAX_METHOD_NAME: usize = 1024;

/// A remote procedure call `handle.name(args...)`, resolved by the compiler.
#[derive(Debug, Clone)]
pub(crate) struct MethodSite {
    /// The method's name.
    pub name: Sym,
    /// Arguments on the stack (above the handle).
    pub argc: u16,
    /// Where the call is.
    pub at: Pos,
}

#[derive(Debug, Clone, Copy)]
pub(crate) enum Op {
    /// A statement starts: counts toward the per-step budget.
    Stmt,
    Const(u32),
    Load(Sym),
    Store(Sym, Scope),
    /// Stack: indices (1 or 2), value.
    StoreIndex(Sym, Scope, u8),
    Index,
    /// `name[i]` without copying the whole list: stack holds the index.
    LoadIndex(Sym),
    MakeList(u32),
    MakePose(u32),
    /// `struct(...)`: the member values are on the stack, their names are
    /// [`Program::shapes`]`[i]`.
    MakeStruct(u32),
    /// `value.name`: the struct is on the stack.
    Member(Sym),
    /// `var.name` without copying the whole struct: the variable, the member.
    LoadMember(Sym, Sym),
    /// `name<path> = v` with a member in the path ([`Program::paths`]`[i]`): the path's
    /// indices, then the value, are on the stack.
    StorePath(Sym, u32),
    /// `handle.name(args)`: the handle then the arguments are on the stack;
    /// [`Program::methods`]`[i]`.
    Method(u32),
    Neg,
    Not,
    Bin(BinOp),
    Jump(u32),
    JumpIfFalse(u32),
    /// `and`: a false left side is the result.
    JumpIfFalseKeep(u32),
    /// `or`: a true left side is the result.
    JumpIfTrueKeep(u32),
    /// The right side of `and`/`or` must be a bool.
    CheckBool,
    /// Call a user function: its id, its call site.
    Call(u32, u32),
    /// Call a built-in (or a stub): its call site.
    Native(u32),
    Return,
    ReturnNone,
    Pop,
    Halt,
    Run(u32),
    Join,
    Kill,
    EnterCritical,
    ExitCritical,
}

#[derive(Debug, Clone)]
pub(crate) struct Func {
    pub name: String,
    pub params: Vec<(Sym, Option<ParamDefault<Sym>>)>,
    pub ops: Vec<Op>,
    /// Where each op comes from.
    pub lines: Vec<Pos>,
    pub is_thread: bool,
    /// The program's own body: plain assignments make globals.
    pub program_scope: bool,
}

/// Definitions run before a program, as a URCap's installation preamble is (see
/// [`Program::parse_with_preamble`]). Several texts may be added; they run in the order
/// added. At most [`Preamble::MAX_STATEMENTS`] top-level statements in all.
#[derive(Debug, Clone, Default)]
pub struct Preamble {
    stmts: Vec<Stmt>,
}

impl Preamble {
    /// The most top-level statements (definitions included) a preamble holds.
    pub const MAX_STATEMENTS: usize = 100_000;

    /// Parses `text` and appends its statements. A syntax error names its line and
    /// column in `text`; nothing of `text` is added then.
    pub fn add(&mut self, text: &str) -> Result<(), ParseError> {
        let toks = crate::syntax::lexer::lex(text)?;
        let stmts = crate::syntax::parser::Parser::new(toks).program()?;
        if self.stmts.len().saturating_add(stmts.len()) > Self::MAX_STATEMENTS {
            return Err(ParseError::new(
                1,
                1,
                format!(
                    "the preamble would hold more than {} statements",
                    Self::MAX_STATEMENTS
                ),
            ));
        }
        self.stmts.extend(stmts);
        Ok(())
    }

    /// No statement added.
    pub fn is_empty(&self) -> bool {
        self.stmts.is_empty()
    }
}

/// A parsed and compiled program, ready to run in a [`Machine`](crate::Machine).
///
/// ```
/// use urscript_interp::Program;
/// let p = Program::parse("def prog():\n  textmsg(\"hi\")\nend\n").unwrap();
/// assert_eq!(p.entry_name(), Some("prog"));
/// assert_eq!(p.called_builtins(), ["textmsg"]);
/// ```
#[derive(Debug, Clone)]
pub struct Program {
    pub(crate) names: Vec<String>,
    pub(crate) consts: Vec<Value>,
    pub(crate) funcs: Vec<Func>,
    /// Every call, by [`Op::Call`]/[`Op::Native`] index.
    pub(crate) sites: Vec<CallSite>,
    /// Names called that are not user functions, with the first line calling each.
    pub(crate) natives: Vec<(Sym, u32)>,
    /// The first variable read that no assignment can give a value (see
    /// [`unknown_variable`]): the controller refuses such a program before it runs.
    pub(crate) unknown_variable: Option<(String, Pos)>,
    /// The member names of each `struct(...)`, by [`Op::MakeStruct`] index.
    pub(crate) shapes: Vec<Vec<Sym>>,
    /// The targets of member assignments, by [`Op::StorePath`] index.
    pub(crate) paths: Vec<Vec<PathStep>>,
    /// Every `handle.name(...)`, by [`Op::Method`] index.
    pub(crate) methods: Vec<MethodSite>,
    entry: Option<String>,
    /// Each name's index in `names` (kept for [`Program::interpret`]).
    pub(crate) name_ids: HashMap<String, Sym>,
    /// Each `def`/`thread`'s id in `funcs` (kept for [`Program::interpret`]).
    pub(crate) func_ids: HashMap<String, u32>,
}

/// How long a [`Program`]'s tables were: what [`Program::truncate`] goes back to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Sizes {
    pub names: usize,
    pub consts: usize,
    pub funcs: usize,
    pub sites: usize,
}

/// What [`Program::interpret`] added: the statement's function and its call sites.
#[derive(Debug, Clone)]
pub(crate) struct Interpreted {
    /// The function that runs the line's statements (in the program's scope).
    pub func: u32,
    /// The call sites the line added (`sites[first_site..]`).
    pub first_site: usize,
}

impl Program {
    /// Parses and compiles a whole program. Nothing runs yet.
    ///
    /// A file that is one top-level `def` (optionally followed by a call of it, the form
    /// drivers send to the controller) runs that function as the program; otherwise the
    /// top-level statements run, with the `def`s and `thread`s available to them.
    ///
    /// A program over 16 MiB is refused before it is read, and an expression nested more
    /// than 128 levels deep (operators, indices, calls; see the crate docs' "Bounds") is
    /// a syntax error. A lone `\r` ends a line, as `\n` and `\r\n` do.
    ///
    /// ```
    /// use urscript_interp::Program;
    /// let e = Program::parse("x = 1\nfor i in y:\n").unwrap_err();
    /// assert_eq!(e.to_string(), "line 2, column 1: `for` loops are not URScript (use `while`)");
    /// ```
    pub fn parse(src: &str) -> Result<Program, ParseError> {
        Self::parse_with_preamble(&Preamble::default(), src)
    }

    /// [`parse`](Self::parse) of a program that runs after a [`Preamble`] (the
    /// definitions a URCap adds to the installation), as PolyScope puts the preamble at
    /// the top of the program: a program that is one `def` gets the preamble's
    /// statements first in that `def`; a program of top-level statements gets them
    /// before its first. The preamble's functions can then be called and its variables
    /// read as the program's own.
    ///
    /// ```
    /// use urscript_interp::{Preamble, Program};
    /// let mut urcap = Preamble::default();
    /// urcap.add("gripper_width = 85\ndef gripper_open():\n  textmsg(\"open\")\nend\n").unwrap();
    /// let p = Program::parse_with_preamble(&urcap, "def prog():\n  gripper_open()\nend\n").unwrap();
    /// assert_eq!(p.entry_name(), Some("prog"));
    /// assert!(Program::parse("def prog():\n  gripper_open()\nend\n").unwrap().called_builtins() == ["gripper_open"]);
    /// ```
    pub fn parse_with_preamble(preamble: &Preamble, src: &str) -> Result<Program, ParseError> {
        let toks = crate::syntax::lexer::lex(src)?;
        let stmts = crate::syntax::parser::Parser::new(toks).program()?;
        let c = Compiler {
            markers: step_markers(src),
            ..Compiler::default()
        };
        c.program(stmts, &preamble.stmts)
    }

    /// [`parse`](Self::parse) of a program read as bytes: text that is not UTF-8 is a
    /// syntax error at the line and column of the first invalid byte.
    ///
    /// ```
    /// use urscript_interp::Program;
    /// let e = Program::parse_bytes(b"x = 1\ny = \"caf\xe9\"\n").unwrap_err();
    /// assert_eq!(e.to_string(), "line 2, column 9: invalid UTF-8 (byte 0xe9): a program is UTF-8 text");
    /// assert!(Program::parse_bytes(b"x = 1\r").is_ok());
    /// ```
    pub fn parse_bytes(src: &[u8]) -> Result<Program, ParseError> {
        crate::syntax::lexer::check_size(src.len())?;
        match std::str::from_utf8(src) {
            Ok(text) => Self::parse(text),
            Err(e) => {
                let at = e.valid_up_to();
                let valid = std::str::from_utf8(&src[..at]).unwrap_or_default();
                let (line, col) = crate::syntax::lexer::position_of(valid, at);
                let byte = src.get(at).copied().unwrap_or(0);
                Err(ParseError::new(
                    line,
                    col,
                    format!("invalid UTF-8 (byte {byte:#04x}): a program is UTF-8 text"),
                ))
            }
        }
    }

    /// The name of the top-level `def` that is the program, if the file is one.
    pub fn entry_name(&self) -> Option<&str> {
        self.entry.as_deref()
    }

    /// The lengths of the tables now.
    pub(crate) fn sizes(&self) -> Sizes {
        Sizes {
            names: self.names.len(),
            consts: self.consts.len(),
            funcs: self.funcs.len(),
            sites: self.sites.len(),
        }
    }

    /// Forgets everything added after `to` was taken (interpreter mode's clear): names,
    /// constants, functions and call sites.
    pub(crate) fn truncate(&mut self, to: Sizes) {
        self.names.truncate(to.names);
        self.consts.truncate(to.consts);
        self.funcs.truncate(to.funcs);
        self.sites.truncate(to.sites);
        let (n, f) = (to.names as Sym, to.funcs as u32);
        self.natives.retain(|(s, _)| *s < n);
        self.name_ids.retain(|_, s| *s < n);
        self.func_ids.retain(|_, id| *id < f);
    }

    /// Compiles one interpreter-mode line (already parsed) into the program: its `def`s
    /// and `thread`s become functions of the program, its other statements one new
    /// function that runs in the program's scope (plain assignments make globals). A
    /// compile error leaves the program as it was.
    ///
    /// A read of a name the program never mentioned (not assigned in the line, not a
    /// function, not a built-in) is `compile_error_name_not_found`, as for a program.
    pub(crate) fn interpret(&mut self, stmts: Vec<Stmt>) -> Result<Interpreted, ParseError> {
        let before = self.sizes();
        let natives_before = self.natives.len();
        let native_set = self.natives.iter().map(|(s, _)| *s).collect();
        let mut c = Compiler {
            names: std::mem::take(&mut self.names),
            name_ids: std::mem::take(&mut self.name_ids),
            consts: std::mem::take(&mut self.consts),
            funcs: std::mem::take(&mut self.funcs),
            func_ids: std::mem::take(&mut self.func_ids),
            sites: std::mem::take(&mut self.sites),
            natives: std::mem::take(&mut self.natives),
            native_set,
            ..Compiler::default()
        };
        let result = c.interpreted(stmts);
        self.names = c.names;
        self.name_ids = c.name_ids;
        self.consts = c.consts;
        self.funcs = c.funcs;
        self.func_ids = c.func_ids;
        self.sites = c.sites;
        self.natives = c.natives;
        match result {
            Ok(func) => Ok(Interpreted {
                func,
                first_site: before.sites,
            }),
            Err(e) => {
                self.truncate(before);
                self.natives.truncate(natives_before);
                Err(e)
            }
        }
    }

    /// Every function the program calls that it does not define (built-ins, or names to
    /// stub), in order of first call.
    pub fn called_builtins(&self) -> Vec<&str> {
        self.natives
            .iter()
            .map(|(s, _)| self.names[*s as usize].as_str())
            .collect()
    }

    /// Like [`called_builtins`](Self::called_builtins) with the first line calling each.
    pub fn called_builtins_with_lines(&self) -> Vec<(&str, u32)> {
        self.natives
            .iter()
            .map(|(s, l)| (self.names[*s as usize].as_str(), *l))
            .collect()
    }
}

/// The names a body assigns (`x = ...`, `global x`, `local x`; not `x[i] = ...`, which
/// needs `x` to exist), into `assigned`; the names it declares `global`, into `globals`.
/// Nested `def`s were moved out of the tree by [`Compiler::collect`], so their bodies are
/// not seen here.
fn assignments(body: &[Stmt], assigned: &mut HashSet<String>, globals: &mut HashSet<String>) {
    for s in body {
        match &s.kind {
            StmtKind::Assign {
                scope,
                name,
                indices,
                ..
            } => {
                if *scope == Scope::Global {
                    globals.insert(name.clone());
                }
                if indices.is_empty() || *scope != Scope::Auto {
                    assigned.insert(name.clone());
                }
            }
            StmtKind::If {
                branches,
                otherwise,
            } => {
                for (_, b) in branches {
                    assignments(b, assigned, globals);
                }
                assignments(otherwise, assigned, globals);
            }
            StmtKind::While(_, b) => assignments(b, assigned, globals),
            _ => {}
        }
    }
}

/// The first `return` outside any `def` in `body` (in an `if` or `while` too).
fn top_level_return(body: &[Stmt]) -> Option<Pos> {
    body.iter().find_map(|s| match &s.kind {
        StmtKind::Return(_) => Some(pos_of(s)),
        StmtKind::If {
            branches,
            otherwise,
        } => branches
            .iter()
            .find_map(|(_, b)| top_level_return(b))
            .or_else(|| top_level_return(otherwise)),
        StmtKind::While(_, b) => top_level_return(b),
        _ => None,
    })
}

/// Every variable a body reads, with the line and column of the read, in source order
/// (`x[i] = v` reads `x`).
fn reads<'a>(body: &'a [Stmt], out: &mut Vec<(&'a str, (u32, u32))>) {
    fn expr<'a>(e: &'a Expr, out: &mut Vec<(&'a str, (u32, u32))>) {
        match e {
            Expr::Name(n, at) => out.push((n, *at)),
            Expr::Lit(_) | Expr::Run(..) => {}
            Expr::List(items) | Expr::Pose(items) => items.iter().for_each(|i| expr(i, out)),
            Expr::Index(b, i) => {
                expr(b, out);
                expr(i, out);
            }
            Expr::Call { args, kwargs, .. } => {
                args.iter().for_each(|a| expr(a, out));
                kwargs.iter().for_each(|(_, v)| expr(v, out));
            }
            Expr::Unary(_, i) => expr(i, out),
            Expr::Binary(_, l, r) => {
                expr(l, out);
                expr(r, out);
            }
            Expr::Member(b, _, _) => expr(b, out),
            Expr::Method { target, args, .. } => {
                expr(target, out);
                args.iter().for_each(|a| expr(a, out));
            }
        }
    }
    for s in body {
        match &s.kind {
            StmtKind::Assign {
                scope,
                name,
                indices,
                value,
            } => {
                if !indices.is_empty() && *scope == Scope::Auto {
                    out.push((name, (s.line, s.col)));
                }
                indices.iter().for_each(|i| expr(i, out));
                if let Some(v) = value {
                    expr(v, out);
                }
            }
            StmtKind::AssignPath { name, path, value } => {
                out.push((name, (s.line, s.col)));
                for a in path {
                    if let Access::Index(i) = a {
                        expr(i, out);
                    }
                }
                expr(value, out);
            }
            StmtKind::Expr(e) | StmtKind::Join(e) | StmtKind::Kill(e) => expr(e, out),
            StmtKind::Return(Some(e)) => expr(e, out),
            StmtKind::If {
                branches,
                otherwise,
            } => {
                for (c, b) in branches {
                    expr(c, out);
                    reads(b, out);
                }
                reads(otherwise, out);
            }
            StmtKind::While(c, b) => {
                expr(c, out);
                reads(b, out);
            }
            _ => {}
        }
    }
}

/// The first read (in line and column order) of a variable that nothing can have given a
/// value, as the controller's compiler refuses it (`compile_error_name_not_found`).
///
/// Conservative: a read is known if its name is assigned anywhere in the program's own
/// body (a global: globals are program-wide, so a `def` may read one assigned after it,
/// and order within a body is not checked, so a branch or a loop may assign it), is
/// declared `global` (or `local`) anywhere in its function, is a parameter or assigned
/// anywhere in its own function, or names a function of the program or a built-in. The
/// body of the file's one `def` (the program drivers send) counts as the program's
/// body, as the interpreter runs it.
fn unknown_variable(
    main: &[Stmt],
    defs: &[FuncDef],
    is_function: impl Fn(&str) -> bool,
) -> Option<(String, Pos)> {
    let mut globals = HashSet::new();
    let mut main_assigned = HashSet::new();
    assignments(main, &mut main_assigned, &mut globals);
    globals.extend(main_assigned);
    let mut locals: Vec<HashSet<String>> = Vec::with_capacity(defs.len());
    for d in defs {
        let mut l: HashSet<String> = d.params.iter().map(|(n, _)| n.clone()).collect();
        assignments(&d.body, &mut l, &mut globals);
        locals.push(l);
    }
    let mut first: Option<(String, (u32, u32))> = None;
    let none = HashSet::new();
    let bodies =
        std::iter::once((main, &none)).chain(defs.iter().map(|d| &d.body[..]).zip(&locals));
    let mut rs = Vec::new();
    for (body, local) in bodies {
        rs.clear();
        reads(body, &mut rs);
        for &(n, at) in &rs {
            if local.contains(n) || globals.contains(n) || is_function(n) {
                continue;
            }
            if first.as_ref().is_none_or(|(_, f)| at < *f) {
                first = Some((n.to_string(), at));
            }
        }
    }
    first.map(|(n, (line, col))| (n, Pos { line, col }))
}

#[derive(Default)]
struct Compiler {
    names: Vec<String>,
    name_ids: HashMap<String, Sym>,
    consts: Vec<Value>,
    funcs: Vec<Func>,
    func_ids: HashMap<String, u32>,
    sites: Vec<CallSite>,
    shapes: Vec<Vec<Sym>>,
    paths: Vec<Vec<PathStep>>,
    methods: Vec<MethodSite>,
    natives: Vec<(Sym, u32)>,
    /// The names in `natives`, to find them in constant time.
    native_set: HashSet<Sym>,
    // Current function being compiled.
    ops: Vec<Op>,
    lines: Vec<Pos>,
    pos: Pos,
    /// Per open loop: its start and the `break` jumps to patch.
    loops: Vec<(u32, Vec<usize>)>,
    /// The id [`Compiler::collect`] gives the first definition it finds, minus one
    /// (0 for a program, whose function 0 is the program itself).
    func_base: u32,
    /// PolyScope's step markers in the program text: `$ N ...` lines, as (N, line).
    markers: Vec<(i64, u32)>,
    /// In the function being compiled: each statement's line and first op.
    stmt_starts: Vec<(u32, u32)>,
    /// In the function being compiled: `jump_to_label(N)` jumps to patch (op, N, where).
    label_jumps: Vec<(usize, i64, Pos)>,
}

/// The step markers of a program text: each line that starts (after blanks) with `$` and
/// a whole number, as (number, line); lines counted as the lexer counts them.
fn step_markers(src: &str) -> Vec<(i64, u32)> {
    let text = src.replace("\r\n", "\n").replace('\r', "\n");
    let mut out = Vec::new();
    for (i, l) in text.split('\n').enumerate() {
        let Some(rest) = l
            .trim_start_matches([' ', '\t', '\u{feff}'])
            .strip_prefix('$')
        else {
            continue;
        };
        let digits: String = rest
            .trim_start_matches([' ', '\t'])
            .chars()
            .take_while(|c| c.is_ascii_digit())
            .take(18)
            .collect();
        if let (Ok(n), Ok(line)) = (digits.parse::<i64>(), u32::try_from(i + 1)) {
            out.push((n, line));
        }
    }
    out
}

fn err(at: Pos, msg: String) -> ParseError {
    ParseError::with_kind(ParseErrorKind::Compile, at.line, at.col, msg)
}

fn pos_of(s: &Stmt) -> Pos {
    Pos {
        line: s.line,
        col: s.col,
    }
}

impl Compiler {
    fn sym(&mut self, name: &str) -> Sym {
        if let Some(&s) = self.name_ids.get(name) {
            return s;
        }
        let s = self.names.len() as Sym;
        self.names.push(name.to_string());
        self.name_ids.insert(name.to_string(), s);
        s
    }

    fn emit(&mut self, op: Op) -> usize {
        self.ops.push(op);
        self.lines.push(self.pos);
        self.ops.len() - 1
    }

    fn here(&self) -> u32 {
        self.ops.len() as u32
    }

    fn patch(&mut self, at: usize, target: u32) {
        match &mut self.ops[at] {
            Op::Jump(t) | Op::JumpIfFalse(t) | Op::JumpIfFalseKeep(t) | Op::JumpIfTrueKeep(t) => {
                *t = target
            }
            _ => {}
        }
    }

    /// Gives every `def`/`thread`, at any depth, its id (ids from 1; 0 is the program).
    /// Each is moved out of the tree (its `Def` statement keeps an empty body), so nested
    /// definitions are never copied once per level.
    fn collect(&mut self, stmts: &mut [Stmt], out: &mut Vec<FuncDef>) -> Result<(), ParseError> {
        for s in stmts {
            let at = pos_of(s);
            match &mut s.kind {
                StmtKind::Def(f) => {
                    if self.func_ids.contains_key(&f.name) {
                        return Err(err(at, format!("`{}` is defined twice", f.name)));
                    }
                    self.func_ids
                        .insert(f.name.clone(), self.func_base.max(1) + out.len() as u32);
                    let mut body = std::mem::take(&mut f.body);
                    let i = out.len();
                    out.push(FuncDef {
                        name: f.name.clone(),
                        params: f.params.clone(),
                        body: Vec::new(),
                        is_thread: f.is_thread,
                        line: f.line,
                    });
                    self.collect(&mut body, out)?;
                    out[i].body = body;
                }
                StmtKind::If {
                    branches,
                    otherwise,
                } => {
                    for (_, b) in branches.iter_mut() {
                        self.collect(b, out)?;
                    }
                    self.collect(otherwise, out)?;
                }
                StmtKind::While(_, b) => self.collect(b, out)?,
                _ => {}
            }
        }
        Ok(())
    }

    fn program(mut self, mut stmts: Vec<Stmt>, preamble: &[Stmt]) -> Result<Program, ParseError> {
        // The form drivers send: one `def` (and perhaps threads/defs), perhaps followed
        // by a call of it.
        let defs: Vec<&FuncDef> = stmts
            .iter()
            .filter_map(|s| match &s.kind {
                StmtKind::Def(f) if !f.is_thread => Some(f),
                _ => None,
            })
            .collect();
        let others: Vec<&Stmt> = stmts
            .iter()
            .filter(|s| !matches!(s.kind, StmtKind::Def(_)))
            .collect();
        let entry: Option<String> = match (defs.as_slice(), others.as_slice()) {
            (ds, []) if !ds.is_empty() => ds.last().map(|d| d.name.clone()),
            (ds, [one]) => match &one.kind {
                StmtKind::Expr(Expr::Call {
                    name, args, kwargs, ..
                }) if args.is_empty()
                    && kwargs.is_empty()
                    && ds.iter().any(|d| d.name == *name && d.params.is_empty()) =>
                {
                    Some(name.clone())
                }
                _ => None,
            },
            _ => None,
        };
        if !preamble.is_empty() {
            // PolyScope writes the preamble at the top of the program's body.
            let body = match &entry {
                Some(name) => stmts.iter_mut().find_map(|s| match &mut s.kind {
                    StmtKind::Def(f) if !f.is_thread && f.name == *name => Some(&mut f.body),
                    _ => None,
                }),
                None => Some(&mut stmts),
            };
            if let Some(body) = body {
                body.splice(0..0, preamble.iter().cloned());
            }
        }
        let mut defs = Vec::new();
        self.collect(&mut stmts, &mut defs)?;
        let main_body: Vec<Stmt> = match &entry {
            Some(name) => defs
                .iter()
                .find(|d| d.name == *name)
                .map(|d| d.body.clone())
                .unwrap_or_default(),
            None => stmts,
        };
        // The program itself is function 0.
        self.declare(entry.clone().unwrap_or_else(|| "<program>".into()), &defs);
        let unknown_variable = unknown_variable(&main_body, &defs, |n| {
            self.func_ids.contains_key(n) || builtins::lookup(n).is_some()
        });
        self.function(0, &main_body, 1)?;
        for (i, d) in defs.iter().enumerate() {
            // The entry def's body is the program; compiled once, as function 0.
            self.function(i + 1, &d.body, d.line)?;
        }
        Ok(Program {
            names: self.names,
            consts: self.consts,
            funcs: self.funcs,
            sites: self.sites,
            natives: self.natives,
            unknown_variable,
            shapes: self.shapes,
            paths: self.paths,
            methods: self.methods,
            entry,
            name_ids: self.name_ids,
            func_ids: self.func_ids,
        })
    }

    /// The body of [`Program::interpret`]: the line's function gets the next id, its
    /// definitions the ones after.
    fn interpreted(&mut self, mut stmts: Vec<Stmt>) -> Result<u32, ParseError> {
        let id = self.funcs.len();
        self.func_base = id as u32 + 1;
        let mut defs = Vec::new();
        self.collect(&mut stmts, &mut defs)?;
        if let Some(at) = top_level_return(&stmts) {
            return Err(err(
                at,
                "`return` outside a function: an interpreted statement is not a function".into(),
            ));
        }
        let known = |n: &str| {
            self.name_ids.contains_key(n)
                || self.func_ids.contains_key(n)
                || builtins::lookup(n).is_some()
        };
        if let Some((name, at)) = unknown_variable(&stmts, &defs, known) {
            return Err(err(
                at,
                format!("compile_error_name_not_found:{name}: `{name}` is never assigned"),
            )
            .with_code(ControllerCode::NameNotFound { name }));
        }
        self.declare("<interpreter>".into(), &defs);
        self.function(id, &stmts, 1)?;
        for (i, d) in defs.iter().enumerate() {
            self.function(id + 1 + i, &d.body, d.line)?;
        }
        Ok(id as u32)
    }

    /// Adds the functions to compile: a body run in the program's scope (`name`: the
    /// program, or an interpreted line), then each of `defs`, in order, their ids next.
    fn declare(&mut self, name: String, defs: &[FuncDef]) {
        self.funcs.push(Func {
            name,
            params: Vec::new(),
            ops: Vec::new(),
            lines: Vec::new(),
            is_thread: false,
            program_scope: true,
        });
        for d in defs {
            let params = d
                .params
                .iter()
                .map(|(n, v)| {
                    let d = v.as_ref().map(|d| d.map_names(&mut |g| self.sym(g)));
                    (self.sym(n), d)
                })
                .collect::<Vec<_>>();
            self.funcs.push(Func {
                name: d.name.clone(),
                params,
                ops: Vec::new(),
                lines: Vec::new(),
                is_thread: d.is_thread,
                program_scope: false,
            });
        }
    }

    fn function(&mut self, id: usize, body: &[Stmt], line: u32) -> Result<(), ParseError> {
        self.ops.clear();
        self.lines.clear();
        self.loops.clear();
        self.stmt_starts.clear();
        self.label_jumps.clear();
        self.pos = Pos { line, col: 1 };
        self.block(body)?;
        self.patch_label_jumps()?;
        self.pos = body.last().map_or(self.pos, |s| Pos {
            line: s.line,
            col: 1,
        });
        self.emit(Op::ReturnNone);
        self.funcs[id].ops = std::mem::take(&mut self.ops);
        self.funcs[id].lines = std::mem::take(&mut self.lines);
        Ok(())
    }

    /// `jump_to_label(N)` (PolyScope writes it to start a program at a selected node):
    /// a jump to the first statement after the step marker `$ N` in the same function,
    /// the one on the nearest line below the marker. No such marker or statement is a
    /// compile error. The manual does not describe it; this is this interpreter's reading
    /// of PolyScope's programs.
    fn patch_label_jumps(&mut self) -> Result<(), ParseError> {
        for (op, n, at) in std::mem::take(&mut self.label_jumps) {
            let target = self
                .markers
                .iter()
                .filter(|(m, _)| *m == n)
                .find_map(|(_, mline)| {
                    self.stmt_starts
                        .iter()
                        .filter(|(l, _)| l > mline)
                        .min_by_key(|(l, _)| *l)
                        .map(|(_, o)| *o)
                })
                .ok_or_else(|| {
                    err(
                        at,
                        format!(
                            "`jump_to_label({n})`: no step marker `$ {n}` followed by a statement in this function"
                        ),
                    )
                })?;
            if let Some(o) = self.ops.get_mut(op) {
                *o = Op::Jump(target);
            }
        }
        Ok(())
    }

    fn block(&mut self, body: &[Stmt]) -> Result<(), ParseError> {
        for s in body {
            self.stmt(s)?;
        }
        Ok(())
    }

    fn stmt(&mut self, s: &Stmt) -> Result<(), ParseError> {
        self.pos = pos_of(s);
        if !matches!(s.kind, StmtKind::Def(_)) {
            let here = self.here();
            self.stmt_starts.push((s.line, here));
        }
        if let StmtKind::Expr(Expr::Call {
            name, args, kwargs, ..
        }) = &s.kind
        {
            if name == "jump_to_label" && kwargs.is_empty() && !self.func_ids.contains_key(name) {
                if let [Expr::Lit(Value::Int(n))] = args.as_slice() {
                    let op = self.emit(Op::Jump(0));
                    self.label_jumps.push((op, i64::from(*n), self.pos));
                    return Ok(());
                }
            }
        }
        // A `while` counts once per iteration instead (below), so even an empty loop
        // meets the per-step statement bound.
        if !matches!(s.kind, StmtKind::Def(_) | StmtKind::While(..)) {
            self.emit(Op::Stmt);
        }
        match &s.kind {
            StmtKind::Assign {
                scope,
                name,
                indices,
                value,
            } => {
                let sym = self.sym(name);
                let Some(value) = value else {
                    // `global x` / `local x` alone declares nothing we need to track.
                    return Ok(());
                };
                if indices.len() > 2 {
                    let at = self.pos;
                    return Err(err(at, "assignment with more than two indices".into()));
                }
                for i in indices {
                    self.expr(i)?;
                }
                match value {
                    Expr::Call {
                        name,
                        args,
                        kwargs,
                        at,
                    } if indices.is_empty() => self.call(name, args, kwargs, *at, Some(sym))?,
                    _ => self.expr(value)?,
                }
                if indices.is_empty() {
                    self.emit(Op::Store(sym, *scope));
                } else {
                    self.emit(Op::StoreIndex(sym, *scope, indices.len() as u8));
                }
            }
            StmtKind::AssignPath { name, path, value } => {
                let sym = self.sym(name);
                let mut steps = Vec::with_capacity(path.len());
                for a in path {
                    match a {
                        Access::Index(i) => {
                            self.expr(i)?;
                            steps.push(PathStep::Index);
                        }
                        Access::Member(m) => {
                            let m = self.sym(m);
                            steps.push(PathStep::Member(m));
                        }
                    }
                }
                self.expr(value)?;
                self.paths.push(steps);
                let id = (self.paths.len() - 1) as u32;
                self.emit(Op::StorePath(sym, id));
            }
            StmtKind::Expr(e) => {
                self.expr(e)?;
                self.emit(Op::Pop);
            }
            StmtKind::If {
                branches,
                otherwise,
            } => {
                let mut ends = Vec::new();
                for (cond, body) in branches {
                    self.expr(cond)?;
                    let skip = self.emit(Op::JumpIfFalse(0));
                    self.block(body)?;
                    ends.push(self.emit(Op::Jump(0)));
                    let h = self.here();
                    self.patch(skip, h);
                }
                self.block(otherwise)?;
                let h = self.here();
                for e in ends {
                    self.patch(e, h);
                }
            }
            StmtKind::While(cond, body) => {
                let start = self.here();
                self.emit(Op::Stmt);
                self.expr(cond)?;
                let exit = self.emit(Op::JumpIfFalse(0));
                self.loops.push((start, Vec::new()));
                self.block(body)?;
                self.pos = pos_of(s);
                self.emit(Op::Jump(start));
                let h = self.here();
                self.patch(exit, h);
                if let Some((_, breaks)) = self.loops.pop() {
                    for b in breaks {
                        self.patch(b, h);
                    }
                }
            }
            StmtKind::Break => {
                if self.loops.is_empty() {
                    return Err(err(pos_of(s), "`break` outside a `while` loop".into()));
                }
                let j = self.emit(Op::Jump(0));
                if let Some((_, breaks)) = self.loops.last_mut() {
                    breaks.push(j);
                }
            }
            StmtKind::Continue => {
                let Some(&(start, _)) = self.loops.last() else {
                    return Err(err(pos_of(s), "`continue` outside a `while` loop".into()));
                };
                self.emit(Op::Jump(start));
            }
            StmtKind::Return(e) => match e {
                Some(e) => {
                    self.expr(e)?;
                    self.emit(Op::Return);
                }
                None => {
                    self.emit(Op::ReturnNone);
                }
            },
            StmtKind::Halt => {
                self.emit(Op::Halt);
            }
            StmtKind::Def(_) => {}
            StmtKind::Join(e) => {
                self.expr(e)?;
                self.emit(Op::Join);
            }
            StmtKind::Kill(e) => {
                self.expr(e)?;
                self.emit(Op::Kill);
            }
            StmtKind::EnterCritical => {
                self.emit(Op::EnterCritical);
            }
            StmtKind::ExitCritical => {
                self.emit(Op::ExitCritical);
            }
        }
        Ok(())
    }

    fn constant(&mut self, v: Value) -> u32 {
        self.consts.push(v);
        (self.consts.len() - 1) as u32
    }

    fn expr(&mut self, e: &Expr) -> Result<(), ParseError> {
        match e {
            Expr::Lit(v) => {
                let c = self.constant(v.clone());
                self.emit(Op::Const(c));
            }
            Expr::Name(n, _) => {
                let s = self.sym(n);
                self.emit(Op::Load(s));
            }
            Expr::List(items) => {
                for i in items {
                    self.expr(i)?;
                }
                self.emit(Op::MakeList(items.len() as u32));
            }
            Expr::Pose(items) => {
                for i in items {
                    self.expr(i)?;
                }
                self.emit(Op::MakePose(items.len() as u32));
            }
            Expr::Index(base, i) => match base.as_ref() {
                Expr::Name(n, _) => {
                    let s = self.sym(n);
                    self.expr(i)?;
                    self.emit(Op::LoadIndex(s));
                }
                _ => {
                    self.expr(base)?;
                    self.expr(i)?;
                    self.emit(Op::Index);
                }
            },
            Expr::Unary(op, inner) => {
                self.expr(inner)?;
                self.emit(match op {
                    crate::syntax::parser::UnOp::Neg => Op::Neg,
                    crate::syntax::parser::UnOp::Not => Op::Not,
                });
            }
            Expr::Binary(BinOp::And, l, r) | Expr::Binary(BinOp::Or, l, r) => {
                let is_and = matches!(e, Expr::Binary(BinOp::And, ..));
                self.expr(l)?;
                let j = self.emit(if is_and {
                    Op::JumpIfFalseKeep(0)
                } else {
                    Op::JumpIfTrueKeep(0)
                });
                self.expr(r)?;
                self.emit(Op::CheckBool);
                let h = self.here();
                self.patch(j, h);
            }
            Expr::Binary(op, l, r) => {
                self.expr(l)?;
                self.expr(r)?;
                self.emit(Op::Bin(*op));
            }
            Expr::Run(name, at) => {
                let at = Pos {
                    line: at.0,
                    col: at.1,
                };
                match self.func_ids.get(name) {
                    Some(&id) if self.funcs[id as usize].is_thread => {
                        self.emit(Op::Run(id));
                    }
                    Some(_) => {
                        return Err(err(
                            at,
                            format!("`run {name}()`: `{name}` is a function, not a thread"),
                        ));
                    }
                    None => {
                        return Err(err(at, format!("`run {name}()`: no thread named `{name}`")))
                    }
                }
            }
            Expr::Call {
                name,
                args,
                kwargs,
                at,
            } => self.call(name, args, kwargs, *at, None)?,
            Expr::Member(base, name, at) => {
                let m = self.sym(name);
                let at = Pos {
                    line: at.0,
                    col: at.1,
                };
                let op = match base.as_ref() {
                    Expr::Name(var, _) => Op::LoadMember(self.sym(var), m),
                    _ => {
                        self.expr(base)?;
                        Op::Member(m)
                    }
                };
                let saved = std::mem::replace(&mut self.pos, at);
                self.emit(op);
                self.pos = saved;
            }
            Expr::Method {
                target,
                method,
                args,
                at,
            } => {
                let at = Pos {
                    line: at.0,
                    col: at.1,
                };
                if args.len() > 255 {
                    return Err(err(at, format!("too many arguments to `.{method}`")));
                }
                // `h.server.getTCP(x)`: the members before the call join the method's
                // name (`server.getTCP`, an XML-RPC method with dots, as URCaps call
                // them); a struct on the way is entered at run time.
                let mut target = &**target;
                let mut dotted = method.clone();
                while let Expr::Member(inner, name, _) = target {
                    if dotted.len() + name.len() + 1 > MAX_METHOD_NAME {
                        return Err(err(
                            at,
                            format!("a method name over {MAX_METHOD_NAME} bytes"),
                        ));
                    }
                    dotted = format!("{name}.{dotted}");
                    target = inner;
                }
                let method = &dotted;
                self.expr(target)?;
                for a in args {
                    self.expr(a)?;
                }
                let name = self.sym(method);
                self.methods.push(MethodSite {
                    name,
                    argc: args.len() as u16,
                    at,
                });
                let id = (self.methods.len() - 1) as u32;
                let saved = std::mem::replace(&mut self.pos, at);
                self.emit(Op::Method(id));
                self.pos = saved;
            }
        }
        Ok(())
    }

    /// `struct(name=value, ...)`: named members only, at least one, at most
    /// [`MAX_STRUCT_MEMBERS`] (a name given twice is a syntax error already).
    fn make_struct(
        &mut self,
        args: &[Expr],
        kwargs: &[(String, Expr)],
        at: Pos,
    ) -> Result<(), ParseError> {
        if !args.is_empty() {
            return Err(err(
                at,
                "`struct` takes named members only: struct(name=value, ...)".into(),
            ));
        }
        if kwargs.is_empty() {
            return Err(err(at, "a struct needs at least one member".into()));
        }
        if kwargs.len() > MAX_STRUCT_MEMBERS {
            return Err(err(
                at,
                format!(
                    "a struct has at most {MAX_STRUCT_MEMBERS} members, this one has {}",
                    kwargs.len()
                ),
            ));
        }
        for (_, v) in kwargs {
            self.expr(v)?;
        }
        let names = kwargs.iter().map(|(k, _)| self.sym(k)).collect();
        self.shapes.push(names);
        let id = (self.shapes.len() - 1) as u32;
        let saved = std::mem::replace(&mut self.pos, at);
        self.emit(Op::MakeStruct(id));
        self.pos = saved;
        Ok(())
    }

    /// A call: its arguments, then `Op::Call` (a function of the program) or
    /// `Op::Native` (a built-in, or a name left for a stub), with the arguments checked
    /// against the parameters here, before anything runs.
    fn call(
        &mut self,
        name: &str,
        args: &[Expr],
        kwargs: &[(String, Expr)],
        at: (u32, u32),
        assigned: Option<Sym>,
    ) -> Result<(), ParseError> {
        let at = Pos {
            line: at.0,
            col: at.1,
        };
        if name == "struct" && !self.func_ids.contains_key(name) {
            return self.make_struct(args, kwargs, at);
        }
        let argc = args.len() + kwargs.len();
        if argc > 255 {
            return Err(err(at, format!("too many arguments to `{name}`")));
        }
        for a in args {
            self.expr(a)?;
        }
        for (_, v) in kwargs {
            self.expr(v)?;
        }
        let named: Vec<&str> = kwargs.iter().map(|(k, _)| k.as_str()).collect();
        let kwnames: Vec<Sym> = named.iter().map(|k| self.sym(k)).collect();
        let user = self.func_ids.get(name).copied();
        let builtin = if user.is_some() {
            None
        } else {
            builtins::lookup(name)
        };
        let slots = if let Some(id) = user {
            let f = &self.funcs[id as usize];
            if f.is_thread {
                return Err(err(
                    at,
                    format!("`{name}` is a thread: start it with `run {name}()`"),
                ));
            }
            let names = &self.names;
            let params = f
                .params
                .iter()
                .map(|(p, d)| (names[*p as usize].as_str(), d.is_some()));
            builtins::match_args(name, params, args.len(), &named).map_err(|m| err(at, m))?
        } else if let Some(b) = builtin {
            let params = b
                .params
                .iter()
                .map(|p| (p.name, p.default != builtins::Default::Required));
            builtins::match_args(name, params, args.len(), &named).map_err(|m| err(at, m))?
        } else {
            Vec::new()
        };
        let sym = self.sym(name);
        self.sites.push(CallSite {
            name: sym,
            builtin,
            argc: argc as u16,
            positional: args.len() as u16,
            kwnames,
            slots,
            assigned,
            at,
            user: user.is_some(),
        });
        let site = (self.sites.len() - 1) as u32;
        let saved = std::mem::replace(&mut self.pos, at);
        match user {
            Some(id) => {
                self.emit(Op::Call(id, site));
            }
            None => {
                if self.native_set.insert(sym) {
                    self.natives.push((sym, at.line));
                }
                self.emit(Op::Native(site));
            }
        }
        self.pos = saved;
        Ok(())
    }
}
