//! The one report stream of `ursock`: every JSON line any subcommand prints is one
//! [`Event`], serialised by serde with an `"event"` key naming the variant.
//!
//! One time field everywhere (`t`: seconds since the command started, rounded to the
//! microsecond, see [`now`]), one byte representation ([`Bytes`], serialised as
//! [`JsonBytes`]) and one representation of URScript values ([`Value`]). The schema is
//! documented in `docs/json-events.md` and written as data in
//! `docs/json-events.schema.json`, which `tests/json_schema.rs` checks every line against.
//!
//! The human views (`listen`'s lines and TUI, `read`'s lines) are rendered from the same
//! event values.

use serde::ser::{SerializeMap, SerializeSeq};
use serde::{Serialize, Serializer};
use urscript_socket::format::Message;
use urscript_socket::robot::ReadResult;
use urscript_socket::to_str::{write_list, write_scalar, Scalar, Value as UrValue};
use urscript_socket::var::VarMessage;

use crate::show::JsonBytes;

/// Seconds since the command started ([`crate::out::start_clock`]), rounded to the
/// microsecond: the `t` of every event.
pub fn now() -> f64 {
    crate::out::elapsed_secs()
}

/// Raw bytes, serialised as [`JsonBytes`]: `{"encoding":"utf-8","text":"café"}` when
/// valid UTF-8, else `{"encoding":"hex","hex":"636166e9"}`.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Bytes(pub Vec<u8>);

impl Serialize for Bytes {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        JsonBytes::new(&self.0).serialize(s)
    }
}

impl From<&[u8]> for Bytes {
    fn from(b: &[u8]) -> Self {
        Bytes(b.to_vec())
    }
}

impl From<Vec<u8>> for Bytes {
    fn from(b: Vec<u8>) -> Self {
        Bytes(b)
    }
}

/// A URScript value in JSON: int/float as a number (non-finite as `null`), bool as a
/// bool, string as [`Bytes`], list as an array, pose as `{"pose":[6 numbers]}`, a read
/// result `[n, v1, ...]` as `{"count":n,"values":[...]}`, nothing as `null`.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    Int(i64),
    Float(f64),
    Bool(bool),
    String(Vec<u8>),
    List(Vec<Value>),
    Pose([f64; 6]),
    /// A read result `[count, values...]`.
    Read {
        count: usize,
        values: Vec<Value>,
    },
    /// No value (a call that returns nothing).
    None,
}

fn float<S: Serializer>(v: f64, s: S) -> Result<S::Ok, S::Error> {
    if v.is_finite() {
        s.serialize_f64(v)
    } else {
        s.serialize_none()
    }
}

struct Floats<'a>(&'a [f64]);

impl Serialize for Floats<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut seq = s.serialize_seq(Some(self.0.len()))?;
        for v in self.0 {
            seq.serialize_element(&Value::Float(*v))?;
        }
        seq.end()
    }
}

impl Serialize for Value {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Value::Int(v) => s.serialize_i64(*v),
            Value::Float(v) => float(*v, s),
            Value::Bool(b) => s.serialize_bool(*b),
            Value::String(b) => JsonBytes::new(b).serialize(s),
            Value::List(l) => l.serialize(s),
            Value::Pose(p) => {
                let mut m = s.serialize_map(Some(1))?;
                m.serialize_entry("pose", &Floats(p))?;
                m.end()
            }
            Value::Read { count, values } => {
                let mut m = s.serialize_map(Some(2))?;
                m.serialize_entry("count", count)?;
                m.serialize_entry("values", values)?;
                m.end()
            }
            Value::None => s.serialize_none(),
        }
    }
}

impl Value {
    /// An interpreter value.
    pub fn from_interp(v: &urscript_interp::Value) -> Self {
        use urscript_interp::Value as V;
        match v {
            V::Int(i) => Value::Int((*i).into()),
            V::Float(f) => Value::Float(*f),
            V::Bool(b) => Value::Bool(*b),
            V::Str(s) => Value::String(s.clone()),
            V::List(items) => Value::List(items.iter().map(Value::from_interp).collect()),
            V::Pose(p) => Value::Pose(*p),
            V::Thread(id) => Value::Int((*id).into()),
            V::Struct(_) | V::Rpc(_) | V::Eip(_) => Value::String(v.to_str_bytes()),
            V::None => Value::None,
        }
    }
}

/// URScript notation (`[2, 1.5, nan]`, `p[0, 0, 0.1, 0, 0, 0]`, `"text"`, `True`), floats
/// by the robot's `to_str` rules; a read result as `[count, values...]`, no value as `None`.
impl std::fmt::Display for Value {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        fn list<'v>(
            f: &mut std::fmt::Formatter<'_>,
            items: impl Iterator<Item = &'v Value>,
        ) -> std::fmt::Result {
            f.write_str("[")?;
            for (i, v) in items.enumerate() {
                if i > 0 {
                    f.write_str(", ")?;
                }
                write!(f, "{v}")?;
            }
            f.write_str("]")
        }
        match self {
            Value::Int(i) => write!(f, "{i}"),
            Value::Float(v) => write_scalar(Scalar::Float(*v), f),
            Value::Bool(b) => write_scalar(Scalar::Bool(*b), f),
            Value::String(b) => f.write_str(&crate::show::quoted(b)),
            Value::List(l) => list(f, l.iter()),
            Value::Pose(p) => {
                f.write_str("p")?;
                write_list(p.iter().map(|&v| Scalar::Float(v)), f)
            }
            Value::Read { count, values } => {
                let count = Value::Int(i64::try_from(*count).unwrap_or(i64::MAX));
                list(f, std::iter::once(&count).chain(values))
            }
            Value::None => f.write_str("None"),
        }
    }
}

impl From<Scalar> for Value {
    fn from(v: Scalar) -> Self {
        match v {
            Scalar::Int(i) => Value::Int(i.into()),
            Scalar::Float(f) => Value::Float(f),
            Scalar::Bool(b) => Value::Bool(b),
        }
    }
}

impl From<&ReadResult> for Value {
    fn from(r: &ReadResult) -> Self {
        match r {
            ReadResult::Floats(t) => Value::Read {
                count: t.count(),
                values: t.values().iter().map(|&v| Value::Float(v)).collect(),
            },
            ReadResult::Ints(l) => Value::Read {
                count: l.count(),
                values: l.values().iter().map(|&v| Value::Int(v.into())).collect(),
            },
            ReadResult::Text(t) => Value::String(t.clone()),
            ReadResult::Int(v) => Value::Int((*v).into()),
        }
    }
}

/// A decoded message, typed (`{"type":"set","name":"A","value":-3}`): the shape
/// `decode --json` prints and `listen --json`'s `decoded` events carry. Non-finite
/// floats are `null`.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "type", rename_all = "lowercase")]
pub enum TypedMessage {
    Int32 {
        value: i32,
    },
    Byte {
        value: u8,
    },
    Line {
        value: Bytes,
    },
    Frame {
        value: Bytes,
    },
    String {
        value: Bytes,
    },
    Set {
        name: String,
        value: i32,
    },
    Get {
        name: String,
    },
    Int {
        value: i32,
    },
    Float {
        value: Value,
    },
    Bool {
        value: bool,
    },
    Pose {
        #[serde(serialize_with = "pose_array")]
        value: [f64; 6],
    },
    List {
        value: Vec<Value>,
    },
    /// Messages of formats without a typed form here (float tuples, var replies, lists
    /// of several ints): their URScript text.
    Text {
        text: String,
    },
}

fn pose_array<S: Serializer>(p: &[f64; 6], s: S) -> Result<S::Ok, S::Error> {
    Floats(p).serialize(s)
}

impl TypedMessage {
    /// `text_kind` names a text message (`line`, `frame`, `string`).
    pub fn new(m: &Message<'_>, text_kind: &str) -> Self {
        match m {
            Message::Int32(v) if v.len() == 1 => TypedMessage::Int32 {
                value: v.get(0).unwrap_or(0),
            },
            Message::Bytes([b]) => TypedMessage::Byte { value: *b },
            Message::Text(t) => {
                let value = Bytes(t.to_vec());
                match text_kind {
                    "frame" => TypedMessage::Frame { value },
                    "string" => TypedMessage::String { value },
                    _ => TypedMessage::Line { value },
                }
            }
            Message::Var(VarMessage::Set { name, value }) => TypedMessage::Set {
                name: (*name).to_string(),
                value: *value,
            },
            Message::Var(VarMessage::Get { name }) => TypedMessage::Get {
                name: (*name).to_string(),
            },
            Message::Value(UrValue::Scalar(Scalar::Int(v))) => TypedMessage::Int { value: *v },
            Message::Value(UrValue::Scalar(Scalar::Float(v))) => TypedMessage::Float {
                value: Value::Float(*v),
            },
            Message::Value(UrValue::Scalar(Scalar::Bool(v))) => TypedMessage::Bool { value: *v },
            Message::Value(UrValue::Pose(p)) => TypedMessage::Pose { value: *p },
            Message::Value(UrValue::List(l)) => TypedMessage::List {
                value: l.iter().map(Value::from).collect(),
            },
            other => TypedMessage::Text {
                text: other.to_string(),
            },
        }
    }

    /// The message's `type`.
    pub fn kind(&self) -> &'static str {
        match self {
            TypedMessage::Int32 { .. } => "int32",
            TypedMessage::Byte { .. } => "byte",
            TypedMessage::Line { .. } => "line",
            TypedMessage::Frame { .. } => "frame",
            TypedMessage::String { .. } => "string",
            TypedMessage::Set { .. } => "set",
            TypedMessage::Get { .. } => "get",
            TypedMessage::Int { .. } => "int",
            TypedMessage::Float { .. } => "float",
            TypedMessage::Bool { .. } => "bool",
            TypedMessage::Pose { .. } => "pose",
            TypedMessage::List { .. } => "list",
            TypedMessage::Text { .. } => "text",
        }
    }

    /// The message as one JSON line (what `decode --json` prints).
    pub fn to_json(&self) -> String {
        serde_json::to_string(self).unwrap_or_default()
    }
}

fn is_none<T>(o: &Option<T>) -> bool {
    o.is_none()
}

// ---- robot events ----

/// How a robot call ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CallOutcome {
    Returned,
    TimedOut,
    Stubbed,
    /// It returned its failure value (`False`); `why` says why.
    Failed,
}

/// `robot`: one socket (or stubbed) call and what it returned.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Call {
    pub t: f64,
    /// The script line of the call.
    pub line: u32,
    /// The column of the call's name.
    pub column: u32,
    /// The function name (`socket_read_ascii_float`).
    pub call: String,
    /// The call as URScript with its evaluated arguments, with `x = ` in front when the
    /// statement assigns it (`x = socket_read_ascii_float(2, "socket_0")`).
    pub source: String,
    /// The socket name, when the call has one.
    pub socket: Option<String>,
    pub args: Vec<Value>,
    pub result: Value,
    pub outcome: CallOutcome,
    /// Whether the result is the call's failure sentinel (`[0, nan...]`, `""`, `0`).
    pub sentinel: bool,
    /// Why the call failed or returned its sentinel, when known.
    pub why: Option<String>,
    /// For people: the result as URScript with ` (timeout)`/` (stub)` after it; `None`
    /// when the call returns nothing.
    #[serde(skip)]
    pub shown_result: Option<String>,
    /// For people: the note said on stderr about this call (`why: ...`).
    #[serde(skip)]
    pub note: Option<String>,
}

/// What kind of text a robot program showed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum MessageKind {
    Textmsg,
    Popup,
    Varmsg,
    /// The controller's own warning in the program's log (a blend radius reduced).
    Warning,
}

/// `robot`: `textmsg`, `popup` or `varmsg` text.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ProgramMessage {
    pub t: f64,
    pub line: u32,
    pub kind: MessageKind,
    pub text: String,
    /// The call that showed it, as URScript with its evaluated arguments.
    pub source: String,
}

/// Bytes sent (`tx`) or received (`rx`). `robot` names the socket; `listen` gives the
/// connection number (and for `tx`, the reply's origin and format).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Traffic {
    pub t: f64,
    #[serde(skip_serializing_if = "is_none")]
    pub socket: Option<String>,
    #[serde(skip_serializing_if = "is_none")]
    pub conn: Option<u64>,
    pub len: usize,
    pub bytes: Bytes,
    /// `listen` `tx`: what sent it (`reply`, `rule`, `var`, `operator`).
    #[serde(skip_serializing_if = "is_none")]
    pub origin: Option<String>,
    /// `listen` `tx`: the reply spec's format (`line`, `floats`...).
    #[serde(skip_serializing_if = "is_none")]
    pub format: Option<String>,
}

impl Traffic {
    /// Bytes on a robot socket.
    pub fn socket(t: f64, socket: &str, bytes: &[u8]) -> Self {
        Traffic {
            t,
            socket: Some(socket.to_string()),
            conn: None,
            len: bytes.len(),
            bytes: Bytes(bytes.to_vec()),
            origin: None,
            format: None,
        }
    }
}

/// `robot`: the server closed a socket.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PeerClosed {
    pub t: f64,
    pub socket: String,
}

/// A remark that is not an error.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Note {
    pub t: f64,
    pub text: String,
}

/// An error: a script's (with its line and column when known) or an operator's.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Error {
    pub t: f64,
    pub line: Option<u32>,
    pub column: Option<u32>,
    pub text: String,
    /// The controller's error code when the error has one (`compile_error_name_not_found`);
    /// `text` is then the message without it.
    #[serde(skip_serializing_if = "is_none")]
    pub code: Option<String>,
}

/// How a robot program ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum EndOutcome {
    Finished,
    Halted,
    MaxTime,
    /// The arm made a protective stop: the program was paused there, and not resumed.
    ProtectiveStop,
    Error,
}

/// `robot`: the program ended.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct End {
    pub t: f64,
    pub outcome: EndOutcome,
    /// `robot`: the arm when the program ended.
    #[serde(skip_serializing_if = "is_none")]
    pub arm: Option<ArmState>,
}

/// The arm's state: where it is and its outputs.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ArmState {
    /// Joints (rad).
    #[serde(serialize_with = "pose_array")]
    pub joints: [f64; 6],
    /// Tool pose (base frame).
    #[serde(serialize_with = "pose_array")]
    pub pose: [f64; 6],
    /// Digital outputs: standard 0-7, then configurable 0-7.
    pub digital_out: Vec<bool>,
    /// Tool digital outputs 0-1.
    pub tool_out: [bool; 2],
    /// Standard analog outputs 0-1.
    pub analog_out: Vec<Value>,
}

/// `robot`, `controller`: a move (or a servo/speed stream) started.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MoveStart {
    pub t: f64,
    /// Program time it started (s).
    #[serde(serialize_with = "secs")]
    pub at: f64,
    pub line: u32,
    /// `movej`, `movel`, `servoj`...
    pub function: String,
    /// Target joints (rad); `None` for a speed stream.
    #[serde(serialize_with = "opt_array")]
    pub target_joints: Option<[f64; 6]>,
    /// Target tool pose (base frame); `None` for a speed stream.
    #[serde(serialize_with = "opt_array")]
    pub target_pose: Option<[f64; 6]>,
    /// The speeds a speed stream started with.
    #[serde(serialize_with = "opt_array")]
    pub speed: Option<[f64; 6]>,
    #[serde(serialize_with = "num")]
    pub acceleration: f64,
    #[serde(serialize_with = "num")]
    pub velocity: f64,
    /// The time argument `t` (s), 0 if not given.
    #[serde(serialize_with = "num")]
    pub time: f64,
    #[serde(serialize_with = "num")]
    pub blend_radius: f64,
}

/// `robot`, `controller`: the move a `move_start` reported ended.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MoveEnd {
    pub t: f64,
    /// Program time it ended (s).
    #[serde(serialize_with = "secs")]
    pub at: f64,
    pub line: u32,
    pub function: String,
    /// `reached`, `blended`, `stopped`, `protective_stop`, `replaced`, `halted`.
    pub outcome: String,
    /// How long it took (s, program time).
    #[serde(serialize_with = "secs")]
    pub took: f64,
    /// Commands it was (a stream's sample count; 1 for a move).
    pub samples: u64,
    /// Where the arm ended: joints (rad) and tool pose.
    #[serde(serialize_with = "pose_array")]
    pub joints: [f64; 6],
    #[serde(serialize_with = "pose_array")]
    pub pose: [f64; 6],
    /// For people: the move's target as its start gave it.
    #[serde(skip)]
    pub target: Option<String>,
}

/// `robot`, `controller`: a program changed an output.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Output {
    pub t: f64,
    pub line: u32,
    pub function: String,
    pub pin: i64,
    /// `true`/`false` for a digital output, a number for an analog one.
    pub value: Value,
}

fn num<S: Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
    float(*v, s)
}

fn secs<S: Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
    float((v * 1e6).round() / 1e6, s)
}

fn opt_array<S: Serializer>(v: &Option<[f64; 6]>, s: S) -> Result<S::Ok, S::Error> {
    match v {
        Some(a) => Floats(a).serialize(s),
        None => s.serialize_none(),
    }
}

// ---- read ----

/// `read`: one read's result.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Read {
    pub t: f64,
    pub call: String,
    pub result: Value,
    pub sentinel: bool,
    pub why: Option<String>,
}

// ---- listen ----

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Listening {
    pub t: f64,
    pub addr: String,
    /// `controller`: which of its servers listens there (`dashboard`, `primary`,
    /// `secondary`, `realtime`, `rtde`, `interpreter`).
    #[serde(skip_serializing_if = "is_none")]
    pub service: Option<&'static str>,
}

/// `controller`: one dashboard command and the reply lines it got.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Dashboard {
    pub t: f64,
    pub conn: u64,
    /// The command line as received (a too-long one cut, with `...`).
    pub command: String,
    /// The reply, one string per line sent (without the newline).
    pub reply: Vec<String>,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Connect {
    pub t: f64,
    pub conn: u64,
    pub peer: String,
    /// `controller`: the server the client connected to.
    #[serde(skip_serializing_if = "is_none")]
    pub service: Option<&'static str>,
}

/// `controller`: a program started, ended, or was refused.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Program {
    pub t: f64,
    /// `started`, `finished`, `halted`, `stopped`, `error` or `refused`.
    pub what: &'static str,
    /// The program's name (`def NAME()`, or the `.urp` file); empty when refused.
    pub name: String,
    /// Where the error is (runtime error or syntax error), when it is in the text.
    #[serde(skip_serializing_if = "is_none")]
    pub line: Option<u32>,
    #[serde(skip_serializing_if = "is_none")]
    pub column: Option<u32>,
    /// The error or the reason.
    #[serde(skip_serializing_if = "is_none")]
    pub text: Option<String>,
    /// Why a program that ended stopped (`finished`, `halted`, `stopped`, `error`):
    /// `end_of_program`, `halt`, `runtime_error` (the message is `text`), `replaced`,
    /// `dashboard_stop`, `protective_stop`... ([`urscript_controller::StopReason`]).
    #[serde(skip_serializing_if = "is_none")]
    pub reason: Option<&'static str>,
}

/// `controller`: what a client of the primary, secondary or realtime interface sent
/// (a program, a secondary program, a line, a command), what an RTDE client did, or
/// the interpreter socket's reply. Made from the server's typed
/// [`urscript_controller::net::ClientEvent`]: `what` is its kind, `text` its `Display`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Client {
    pub t: f64,
    pub conn: u64,
    /// `primary`, `secondary`, `realtime`, `rtde` or `interpreter`.
    pub service: &'static str,
    /// `program`, `secondary`, `line`, `command`, `refused` (primary/secondary/realtime);
    /// `protocol`, `outputs`, `inputs`, `start`, `pause`, `text`, `error` (RTDE);
    /// `reply` (interpreter).
    pub what: &'static str,
    /// Its text: the program's name, the line, the command, the recipe's fields.
    pub text: String,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Close {
    pub t: f64,
    pub conn: u64,
    pub reason: String,
    /// Bytes received and sent on the connection.
    pub rx: u64,
    pub tx: u64,
    /// SETs refused because the variable table was full.
    pub refused_sets: u64,
}

/// A message decoded from what a robot sent.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Decoded {
    pub t: f64,
    /// `listen`: the connection; `decode` (standard input) has none.
    #[serde(skip_serializing_if = "is_none")]
    pub conn: Option<u64>,
    pub message: TypedMessage,
    /// The message as `listen` shows it (URScript notation, text quoted).
    pub text: String,
}

/// Input that did not decode (or a message that is not what `--decode` expects).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DecodeError {
    pub t: f64,
    pub conn: u64,
    pub text: String,
    pub message: Option<TypedMessage>,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Rule {
    pub t: f64,
    pub conn: u64,
    /// The rule's line in the `--rules` file.
    pub line: usize,
    pub pattern: String,
}

/// A warning about a reply: what the robot's read will make of it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Diagnosis {
    pub t: f64,
    pub conn: Option<u64>,
    /// Where the reply came from when not a connection (`--reply`, `--rules line 3`).
    pub source: Option<String>,
    pub text: String,
    /// For a late reply: seconds since the robot's last message.
    pub late_seconds: Option<f64>,
}

/// A connection refused over `--max-connections` (said once per episode).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Refused {
    pub t: f64,
    pub peer: String,
    pub open: usize,
    pub max_connections: usize,
}

/// `listen`: a connection refused because its address already has
/// `--max-per-address` connections open.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RefusedAddress {
    pub t: f64,
    pub peer: String,
    pub open_from_address: usize,
    pub max_per_address: usize,
}

/// `listen`: every slot was taken; this connection, idle longest, was closed for a new one.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Evicted {
    pub t: f64,
    pub conn: u64,
    pub peer: String,
    /// Seconds since it last sent a byte.
    pub idle: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RefusalsEnded {
    pub t: f64,
    pub refused: u64,
    pub max_connections: usize,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AcceptError {
    pub t: f64,
    pub text: String,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AcceptRecovered {
    pub t: f64,
    pub failures: u64,
    pub seconds: f64,
}

/// One connection in a `list`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ConnInfo {
    pub conn: u64,
    pub peer: String,
    pub rx: u64,
    pub tx: u64,
    pub seconds: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct List {
    pub t: f64,
    pub connections: Vec<ConnInfo>,
    pub variables: usize,
}

/// A SET the variable table refused.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct VarRefused {
    pub t: f64,
    pub conn: u64,
    pub name: String,
    pub text: String,
}

/// A GET of a variable never SET (answered 0).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct UnknownVariable {
    pub t: f64,
    pub conn: u64,
    pub name: String,
    pub answered: i32,
}

/// A `SET`/`GET` line that is not a valid variable message.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct VarInvalid {
    pub t: f64,
    pub conn: u64,
    pub message: TypedMessage,
    pub text: String,
}

/// `controller`: events of a client (or, `conn` null, of the running program) that were
/// not reported: more than the server reports a second (a flood), or a program or
/// speed superseded by a later one of the same step.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Suppressed {
    pub t: f64,
    pub conn: Option<u64>,
    pub count: u64,
    /// Over how many seconds.
    pub seconds: f64,
}

/// `controller`: events not written because standard output did not keep up (its queue
/// was full); said when output resumes.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Dropped {
    pub t: f64,
    pub count: u64,
}

/// `controller`: the scheduling the real-time loop's thread got (once, at the start).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Scheduling {
    pub t: f64,
    /// `SCHED_FIFO 10`, `nice -10` or `normal`.
    pub policy: String,
    /// Whether the process's memory is locked in RAM (as touched).
    pub memory_locked: bool,
    /// What was refused, with the system's error.
    pub refused: Vec<String>,
}

/// `controller`: the real-time loop fell behind its steps (at most once a second, and at
/// once when it held a stall back). Every step was still computed and every package
/// sent, late; only `held_seconds` of controller time did not pass.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Late {
    pub t: f64,
    /// Steps computed a whole step or more after their time.
    pub late_steps: u64,
    /// The most a step was computed after its time, in milliseconds.
    pub worst_ms: f64,
    /// Stalls past the catch-up bound, held back.
    pub holds: u64,
    /// Controller time held back by them, in seconds (no step computed for it).
    pub held_seconds: f64,
    /// Over how many seconds.
    pub seconds: f64,
}

/// `controller`: every port listens (after every `listening` event): each service's
/// address, by service name.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Ready {
    pub t: f64,
    pub addrs: std::collections::BTreeMap<&'static str, String>,
}

/// `controller`: an operator command from standard input and the controller's state
/// after it (or why it was refused).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Operator {
    pub t: f64,
    pub command: String,
    pub text: String,
}

/// `controller`: the robot mode, safety status or program state changed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct State {
    pub t: f64,
    pub robot_mode: String,
    pub safety: String,
    pub program: String,
    /// Why, when the program state became `PAUSED` or `STOPPED`: `dashboard_pause`,
    /// `protective_stop`, `end_of_program`... ([`urscript_controller::StopReason`]).
    #[serde(skip_serializing_if = "is_none")]
    pub reason: Option<&'static str>,
}

/// `controller`: the controller stopped (the last event).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Stopped {
    pub t: f64,
    pub reason: String,
}

/// Every event `ursock` reports. Serialised with `"event"` naming the variant in
/// snake_case, then the variant's fields.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "event", rename_all = "snake_case")]
pub enum Event {
    // robot
    Call(Call),
    Message(ProgramMessage),
    Tx(Traffic),
    Rx(Traffic),
    PeerClosed(PeerClosed),
    Note(Note),
    Error(Error),
    End(End),
    MoveStart(MoveStart),
    MoveEnd(MoveEnd),
    Output(Output),
    // read
    Read(Read),
    // listen
    Listening(Listening),
    Connect(Connect),
    Close(Close),
    Decoded(Decoded),
    DecodeError(DecodeError),
    Rule(Rule),
    Diagnosis(Diagnosis),
    Refused(Refused),
    RefusalsEnded(RefusalsEnded),
    AcceptError(AcceptError),
    AcceptRecovered(AcceptRecovered),
    Help(Note),
    List(List),
    VarRefused(VarRefused),
    UnknownVariable(UnknownVariable),
    VarInvalid(VarInvalid),
    RefusedAddress(RefusedAddress),
    Evicted(Evicted),
    // controller
    Dashboard(Dashboard),
    Program(Program),
    Client(Client),
    Suppressed(Suppressed),
    Late(Late),
    Scheduling(Scheduling),
    Dropped(Dropped),
    Ready(Ready),
    Operator(Operator),
    State(State),
    Stopped(Stopped),
}

/// Constructors stamped with [`now`], for the common events.
impl Event {
    /// `note`.
    pub fn note(text: impl Into<String>) -> Self {
        Event::Note(Note {
            t: now(),
            text: text.into(),
        })
    }

    /// `error`, with the program line and column when known.
    pub fn error(line: Option<u32>, column: Option<u32>, text: impl Into<String>) -> Self {
        Event::Error(Error {
            t: now(),
            line,
            column,
            text: text.into(),
            code: None,
        })
    }

    /// `message` (textmsg, popup, varmsg) and the call that showed it.
    pub fn message(line: u32, kind: MessageKind, text: String, source: String) -> Self {
        Event::Message(ProgramMessage {
            t: now(),
            line,
            kind,
            text,
            source,
        })
    }

    /// `tx` on a robot socket.
    pub fn tx(socket: &str, bytes: &[u8]) -> Self {
        Event::Tx(Traffic::socket(now(), socket, bytes))
    }

    /// `rx` on a robot socket.
    pub fn rx(socket: &str, bytes: &[u8]) -> Self {
        Event::Rx(Traffic::socket(now(), socket, bytes))
    }

    /// `peer_closed`.
    pub fn peer_closed(socket: &str) -> Self {
        Event::PeerClosed(PeerClosed {
            t: now(),
            socket: socket.to_string(),
        })
    }

    /// `end`.
    pub fn end(outcome: EndOutcome) -> Self {
        Event::End(End {
            t: now(),
            outcome,
            arm: None,
        })
    }
}

impl Event {
    /// The event as one JSON line.
    pub fn to_json(&self) -> String {
        serde_json::to_string(self).unwrap_or_default()
    }

    /// The event's time.
    pub fn t(&self) -> f64 {
        match self {
            Event::Call(e) => e.t,
            Event::Message(e) => e.t,
            Event::Tx(e) | Event::Rx(e) => e.t,
            Event::PeerClosed(e) => e.t,
            Event::Note(e) | Event::Help(e) => e.t,
            Event::Error(e) => e.t,
            Event::End(e) => e.t,
            Event::MoveStart(e) => e.t,
            Event::MoveEnd(e) => e.t,
            Event::Output(e) => e.t,
            Event::Read(e) => e.t,
            Event::Listening(e) => e.t,
            Event::Connect(e) => e.t,
            Event::Close(e) => e.t,
            Event::Decoded(e) => e.t,
            Event::DecodeError(e) => e.t,
            Event::Rule(e) => e.t,
            Event::Diagnosis(e) => e.t,
            Event::Refused(e) => e.t,
            Event::RefusalsEnded(e) => e.t,
            Event::AcceptError(e) => e.t,
            Event::AcceptRecovered(e) => e.t,
            Event::List(e) => e.t,
            Event::VarRefused(e) => e.t,
            Event::UnknownVariable(e) => e.t,
            Event::VarInvalid(e) => e.t,
            Event::Dashboard(e) => e.t,
            Event::Program(e) => e.t,
            Event::Client(e) => e.t,
            Event::RefusedAddress(e) => e.t,
            Event::Evicted(e) => e.t,
            Event::Suppressed(e) => e.t,
            Event::Late(e) => e.t,
            Event::Scheduling(e) => e.t,
            Event::Dropped(e) => e.t,
            Event::Ready(e) => e.t,
            Event::Operator(e) => e.t,
            Event::State(e) => e.t,
            Event::Stopped(e) => e.t,
        }
    }

    /// The `listen` connection the event belongs to, if any.
    pub fn conn(&self) -> Option<u64> {
        match self {
            Event::Tx(e) | Event::Rx(e) => e.conn,
            Event::Connect(e) => Some(e.conn),
            Event::Close(e) => Some(e.conn),
            Event::Decoded(e) => e.conn,
            Event::DecodeError(e) => Some(e.conn),
            Event::Rule(e) => Some(e.conn),
            Event::Diagnosis(e) => e.conn,
            Event::VarRefused(e) => Some(e.conn),
            Event::UnknownVariable(e) => Some(e.conn),
            Event::VarInvalid(e) => Some(e.conn),
            Event::Dashboard(e) => Some(e.conn),
            Event::Client(e) => Some(e.conn),
            Event::Evicted(e) => Some(e.conn),
            Event::Suppressed(e) => e.conn,
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_take_the_documented_shapes() {
        let v = Value::List(vec![
            Value::Int(1),
            Value::Float(f64::NAN),
            Value::Bool(true),
            Value::String(b"caf\xE9".to_vec()),
            Value::Pose([1.0, 2.0, 3.0, 0.0, 0.0, f64::INFINITY]),
            Value::Read {
                count: 0,
                values: vec![Value::Float(f64::NAN)],
            },
            Value::None,
        ]);
        assert_eq!(
            serde_json::to_string(&v).unwrap(),
            r#"[1,null,true,{"encoding":"hex","hex":"636166e9"},{"pose":[1.0,2.0,3.0,0.0,0.0,null]},{"count":0,"values":[null]},null]"#
        );
    }

    #[test]
    fn values_print_in_urscript_notation() {
        let v = Value::List(vec![
            Value::Int(-2),
            Value::Float(1.5),
            Value::Float(f64::NAN),
            Value::Bool(true),
            Value::String(b"a\n".to_vec()),
            Value::Pose([0.0, 0.0, 0.1, 0.0, 0.0, 0.0]),
            Value::Read {
                count: 1,
                values: vec![Value::Float(2.0)],
            },
        ]);
        assert_eq!(
            v.to_string(),
            r#"[-2, 1.5, nan, True, "a\n", p[0, 0, 0.1, 0, 0, 0], [1, 2]]"#
        );
    }

    #[test]
    fn events_carry_their_name_first() {
        let e = Event::Call(Call {
            t: 0.5,
            line: 2,
            column: 5,
            call: "socket_read_line".into(),
            source: "x = socket_read_line(\"socket_0\")".into(),
            socket: Some("socket_0".into()),
            args: vec![Value::String(b"socket_0".to_vec())],
            result: Value::String(b"ok".to_vec()),
            outcome: CallOutcome::Returned,
            sentinel: false,
            why: None,
            shown_result: Some("\"ok\"".into()),
            note: None,
        });
        assert_eq!(
            e.to_json(),
            r#"{"event":"call","t":0.5,"line":2,"column":5,"call":"socket_read_line","source":"x = socket_read_line(\"socket_0\")","socket":"socket_0","args":[{"encoding":"utf-8","text":"socket_0"}],"result":{"encoding":"utf-8","text":"ok"},"outcome":"returned","sentinel":false,"why":null}"#
        );
        let e = Event::End(End {
            t: 1.0,
            outcome: EndOutcome::MaxTime,
            arm: None,
        });
        assert_eq!(
            e.to_json(),
            r#"{"event":"end","t":1.0,"outcome":"max_time"}"#
        );
    }
}
