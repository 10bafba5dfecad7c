//! PolyScope programs (`.urp`) read and translated into URScript, as the controller does
//! when a dashboard client says `load NAME.urp` and `play`.
//!
//! A `.urp` is a gzip-compressed XML document that PolyScope writes (CB3 3.x and e-Series
//! 5.x): `<URProgram name=... installation=...>` whose `<children>` hold the program's
//! sections (`<MainProgram>`, `<SpecialSequence type="BeforeStart">`, sub programs) and,
//! inside each `<children>`, the program nodes. Some files in the wild (UR's own test
//! programs for URSim) are saved uncompressed; a document that starts with `<` (after
//! blanks or a byte-order mark) is read as such.
//!
//! [`read_urp`] reads and translates in one pass; nothing here does I/O. The one node that
//! needs the network, UR's External Control URCap node, is kept as a place in the
//! program: [`UrpProgram::external_control`] lists where, with the host and port the
//! URCap would ask, and [`translate_with`] splices in the script a caller fetched
//! (`request_program\n` to that host and port, as the URCap does at play time).
//!
//! # Bounds
//!
//! A `.urp` is input: whatever it holds, reading it neither panics nor takes unbounded
//! memory or time. Every bound is an error ([`UrpError`]):
//!
//! | what | bound | error |
//! |---|---|---|
//! | the file as given | [`MAX_URP_BYTES`] (16 MiB) | [`UrpError::TooLarge`] |
//! | the XML after gunzip (a gzip bomb stops at the bound, never inflated further) | [`MAX_XML_BYTES`] (64 MiB) | [`UrpError::TooLarge`] |
//! | XML elements | [`MAX_ELEMENTS`] (250 000) | [`UrpError::TooManyElements`] |
//! | nesting of XML elements (each program level is about two: the node and its `<children>`) | [`MAX_DEPTH`] (128) | [`UrpError::TooDeep`] |
//! | attributes on one element | [`MAX_ATTRIBUTES`] (256) | [`UrpError::Xml`] |
//! | an XStream `reference="..."` attribute; chains of them | 4096 bytes; 64 hops | [`UrpError::Invalid`] |
//! | an element or attribute name | [`MAX_NAME_BYTES`] (256) | [`UrpError::Xml`] |
//! | the parsed document's memory (estimated as it is read) | [`MAX_TREE_BYTES`] (128 MiB) | [`UrpError::TooLarge`] |
//! | program nodes translated (each use of a referenced node counts) | [`MAX_NODES_TRANSLATED`] (250 000) | [`UrpError::Invalid`] |
//! | nesting of program nodes as translated (references followed) | [`MAX_DEPTH`] (128) | [`UrpError::Invalid`] |
//! | the translated script, with the External Control nodes' records; and the script with their fetched scripts ([`translate_with`]) | [`MAX_SCRIPT_BYTES`] (16 MiB, the interpreter's program limit) | [`UrpError::TooLarge`] |
//! | External Control nodes | [`MAX_EXTERNAL_CONTROL_NODES`] (10 000) | [`UrpError::Invalid`] |
//! | a host name in a node's data or an installation | [`MAX_HOST_BYTES`] (255) | [`UrpError::Invalid`] |
//!
//! The work is linear in the document: each reference is read once, siblings are
//! indexed by name, sub programs by node. The decompressed XML is dropped before the
//! translation; at most [`MAX_URP_BYTES`] + [`MAX_XML_BYTES`] + [`MAX_TREE_BYTES`] are
//! held while reading, then the tree and at most twice [`MAX_SCRIPT_BYTES`] (the script
//! and its parts) while translating. The tree's bound is an estimate that leaves out the
//! allocator's own overhead: a file of 256-attribute elements stopped at it peaked at
//! 265 MB resident. A reply spliced in
//! by [`translate_with`] is split without a record per line; its header and control loop
//! (each at most [`MAX_SCRIPT_BYTES`]) are written at each node until the script is over
//! its bound.
//!
//! The translation recurses once per program level, bounded by [`MAX_DEPTH`] (a
//! reference back to an enclosing node is caught there); sub programs are translated
//! from a work list, not recursively. `urscript_interp` has its own bounds (16 MiB of
//! program text, 64 nested blocks), which a program near these bounds can pass:
//! `Program::parse` then refuses it with a syntax error.
//!
//! # Node types translated
//!
//! | node | URScript |
//! |---|---|
//! | `MainProgram` | the body of `def NAME():`; `runOnlyOnce="false"` wraps it in `while (True):` |
//! | `SpecialSequence type="BeforeStart"` | its nodes, before the main program |
//! | `InitVariablesNode` | its `<variables>` (`<variable name>` with `<expression>`: `global NAME = EXPR`) and its nodes, if any, first |
//! | `Thread name=... runOnlyOnce=...` (the root's) | `thread NAME():` with its nodes in `while (True):` (without it when `runOnlyOnce="true"`), then `threadId_NAME = run NAME()` after the `BeforeStart` nodes, before the main program |
//! | `Timer action="Start|Stop|Reset"` (`<variable>`) | `NAME_is_counting = True` / `False`, `NAME = 0`; at the program's top `global NAME = 0`, `global NAME_is_counting = False` and `Timer_Thread`, which adds `get_steptime()` to each counting timer every cycle |
//! | `SafeHome speed acceleration` (PolyScope 5's Home) | `movej(DEFAULT_HOME_JOINTS, a, v)`: the node does not hold the home position and no installation is read, so PolyScope's default home ([`DEFAULT_HOME_JOINTS`]); `positionOptionType` other than `SPEED_AND_ACCELERATION` is refused |
//! | `SuppressedNode` | nothing (PolyScope leaves a suppressed node out of the script) |
//! | `Script type="Line"` (`<expression>`) / `type="File"` (`<cachedContents>`) | the line, or the file's lines as PolyScope cached them |
//! | `Wait type="Sleep"` (`<waitTime>`) | `sleep(t)` |
//! | `Wait type="DigitalInput"` (`<pin referencedName="digital_in[N]"/>`, `<digitalValue>`) | `while (not(get_standard_digital_in(N) == True)): sync() end` (also `configurable_in[N]`, `tool_in[N]`) |
//! | `Wait type="AnalogInput"` (`<pin>`, `<analogComparison>` 0 less / 1 greater, `<analogValue>`) | a `while` on `get_standard_analog_in(N)` |
//! | `Wait type="Expression"` / `"Condition"` (`<expression>`) | `while (not(EXPR)): sync() end` |
//! | `Popup type="Message|Warning|Error" message=... haltProgram=...` | `popup(msg, title, warning, error, blocking=True)`, then `halt` when asked |
//! | `Set type="DigitalOutput"` (`<pin referencedName="digital_out[N]"/>`, `<digitalValue>`) | `set_standard_digital_out(N, True)` (also `configurable_out[N]`, `tool_out[N]`) |
//! | `Set type="AnalogOutput"` (`<pin referencedName="analog_out[N]"/>`, `<analogValue>`) | `set_standard_analog_out(N, value)` (the value as stored) |
//! | `Set type="Expression"` (`<pin>` or `<variable>`, `<expression>`) | the output set to the expression, or `global NAME = EXPR` |
//! | `Set type="NoAction"` | nothing (a `Set` that sets a TCP or payload is refused) |
//! | `Move motionType="MoveJ|MoveL|MoveP" speed acceleration [blendRadius]` with `Waypoint type="Fixed"` | `movej(q, a, v[, r])`; `movel`/`movep` to the waypoint's stored pose, or else the TCP pose of its joint angles through its TCP offset (`get_forward_kin(q, tcp)`); a waypoint's `<motionParameters>` (`jointSpeed`, `cartesianSpeed`, ..., `blendRadius`) win over the Move's |
//! | `Waypoint type="Variable"` (`<variable>`) | the move to that variable's value |
//! | other nodes inside a `Move` | translated in place, between its waypoints |
//! | `Loop type="Forever"` / `"Counting"` (`count`) / `"While"` (`<expression>`) | `while (True):` / a counter `Loop_K` / `while (EXPR):` |
//! | `If type="If|ElseIf|Else"` (`<expression>`) | `if`/`elif`/`else` chains: an `If` and the `ElseIf`/`Else` siblings that follow it |
//! | `Assignment` (`<variable name>`, `<expression>`) | `global NAME = EXPR` (PolyScope's own form) |
//! | `Assignment valueSource="Operator" message valueType="Boolean|Integer|Float|String"` | `global NAME = request_boolean_from_primary_client(message)` (`_integer_`, `_float_`, `_string_`) |
//! | `Loop type="While" checkContinuously="true"` | PolyScope's watched loop: `thread Thread_while_K():` (its nodes in `while (True):`, written at the program's top), and `if (EXPR):` `global thread_handler_K = run Thread_while_K()`, `while (EXPR): sync() end`, `kill thread_handler_K` |
//! | `If checkContinuously="true"` (no `ElseIf`/`Else`) | PolyScope's watched If: `thread Thread_if_K():` (its nodes, then `thread_flag_K = 1`, at the program's top), started if `EXPR`, killed (`thread_flag_K = 2`) when `EXPR` turns false before it is done |
//! | `Comment comment=...` | a `#` comment |
//! | `Folder` | its nodes |
//! | `Halt` | `halt` |
//! | `CallSubProgram` with `<subprogram name=...>` (or an XStream `reference` to one) | `NAME()`, and `def NAME():` with the sub program's nodes, before the main program |
//! | `Contributed` of the External Control URCap (`strategyClass` containing `externalcontrol`) | the fetched script ([`translate_with`]) |
//!
//! Expressions are the `<expression>`'s tokens in order: `<ExpressionChar character="c"/>`
//! (PolyScope's `≟`, `≠`, `≤`, `≥` and `≔` become `==`, `!=`, `<=`, `>=` and `=`),
//! `<ExpressionToken token=" and "/>`, `<ExpressionVariable>` (the name of the variable
//! its child refers to, as 5.x saves it: `<ProgramVariable reference=".../variable"/>`;
//! or its `name`/`referencedName` attribute), `<ExpressionIO><pin referencedName=.../>`
//! (a pin `kind[N]` read as a Wait reads it, `get_standard_digital_in(N)`; any other
//! name is a signal the installation defines, read as PolyScope reads a Modbus signal:
//! `modbus_get_signal_status("NAME", False)`), `<ExpressionGeomFeature><feature
//! referencedName="Plane_1"/>` (a feature used as a value: its name, the pose variable
//! PolyScope defines from the installation's features; the installation's features are
//! not read, so a program using one needs it defined, e.g. by `--preamble` with `global
//! Plane_1 = p[...]`, else it stops with `compile_error_name_not_found:Plane_1`), or plain
//! text inside `<expression>`.
//!
//! Any other node is [`UrpError::UnknownNode`], never dropped (other URCaps' nodes
//! included: `Contributed (Gripper)`); a known node in a form not translated (a
//! `Relative` waypoint, a `Loop type="Forever"` or `"Counting"` checked continuously, an
//! `If` checked continuously with `ElseIf`/`Else`) is [`UrpError::Unsupported`]. Not translated, by choice: `<kinematics>`
//! (the calibration the waypoints were taught with: the arm model's own kinematics are
//! used), a waypoint's `<Kinematics>`, `<BaseToFeature>`, `<outputFlangePose>` and
//! `<poseInFeatureCoordinates>`, and a Move's `<feature>` and `<tcp>`: waypoints are
//! taken in the base frame, with the TCP that is active.
//!
//! # What the forms come from
//!
//! Checked against `.urp` files PolyScope saved (UR's URSim test programs, 3.x and 5.x,
//! and published programs last saved by 5.11): the document's frame, `InitVariablesNode`,
//! `SpecialSequence`, `MainProgram runOnlyOnce`, `Wait type="Sleep"`, `Script
//! type="Line"`, `Assignment` with its `<variable>` (named, or a reference),
//! `ExpressionChar`/`ExpressionToken`/`ExpressionVariable` tokens, `If`/`Else` siblings,
//! `Loop type="Forever"|"While"`, `Popup`, `Comment`, `CallSubProgram`/`subprogram` and
//! the root's `SubProgram` references, and URCap `Contributed` nodes. From documents
//! describing the format and tools that write `.urp` files: `Move`/`Waypoint`,
//! `Wait type="DigitalInput"`, `Set type="DigitalOutput"`, `Halt`, `Script type="File"`.
//! The other forms (`Loop type="Counting"`, `ElseIf`, `Set type="AnalogOutput"|
//! "Expression"`, `Wait type="AnalogInput"|"Expression"`, `Folder`) follow the same
//! conventions but were not seen in a saved file.
//!
//! From `.urp` files in UR's own public repositories (3.x and 5.x, last saved by up to
//! 5.21): `Thread` (`name`, `runOnlyOnce`, `trackProgramExecution`, which changes no
//! script), `Timer action` with its `<variable>`, `SafeHome` (speed and acceleration
//! only: the position is the installation's), `SuppressedNode`, `InitVariablesNode`'s
//! `<variables>`, operator assignments, `ExpressionIO` tokens naming Modbus signals, and
//! `Loop type="While" checkContinuously="true"`. The scripts for them follow the form
//! PolyScope's exported scripts show (`thread Thread_1():` ... `threadId_Thread_1 = run
//! Thread_1()`; `Timer_Thread` counting `NAME_is_counting` timers with
//! `get_steptime()`; `Thread_if_K`/`thread_flag_K`/`thread_handler_K` for a condition
//! checked continuously); the threads of nodes checked continuously are written at the
//! program's top level rather than in place (a choice: in place, one inside a `Thread`
//! or sub program would declare a thread inside a function). Where a `runOnlyOnce="true"`
//! thread's script was not seen, its nodes run once, unlooped.
//!
//! String literals: URScript has no escapes, so a message with `"` is written between
//! `'`; one with both quote characters has its `"` written as `'`.

use std::collections::HashMap;
use std::fmt;
use std::io::Read;

use quick_xml::events::Event;
use quick_xml::Reader;

/// The largest `.urp` file read (16 MiB), compressed.
pub const MAX_URP_BYTES: usize = 16 << 20;
/// The largest XML document read after decompression (64 MiB).
pub const MAX_XML_BYTES: usize = 64 << 20;
/// The most XML elements in one document (a waypoint is about 15): with the document
/// size bound, this bounds the parsed tree's memory to some tens of MiB.
pub const MAX_ELEMENTS: usize = 250_000;
/// The deepest nesting of XML elements, and of program nodes as translated (a node
/// reached through a reference counts where it is used).
pub const MAX_DEPTH: usize = 128;
/// The most memory the parsed document may take, as estimated while it is read: each
/// element's record, name and index entries, each attribute's record, name and value,
/// text. About twice what [`MAX_ELEMENTS`] elements of a saved program's shape take, so
/// that only a document built to be large reaches it.
pub const MAX_TREE_BYTES: usize = 128 << 20;
/// The longest element or attribute name (PolyScope's are under 40 bytes); with
/// [`MAX_DEPTH`] it bounds a node's path, which errors and records carry.
pub const MAX_NAME_BYTES: usize = 256;
/// The largest translated script: the interpreter's own program text limit (16 MiB),
/// which a longer script could not pass. It bounds [`read_urp`]'s script (with the
/// External Control nodes' records) and [`translate_with`]'s, where each External
/// Control node gets its own copy of the fetched control loop.
pub const MAX_SCRIPT_BYTES: usize = 16 << 20;
/// The most External Control nodes in one program (each place it is used, references
/// included): far more than a program uses (once or a few times); with
/// [`MAX_HOST_BYTES`] it bounds the copies of the host the nodes keep to 2.5 MB.
pub const MAX_EXTERNAL_CONTROL_NODES: usize = 10_000;
/// The most program nodes translated: each place a node is used counts, so references
/// that repeat nodes cannot multiply the work.
pub const MAX_NODES_TRANSLATED: usize = MAX_ELEMENTS;
/// The longest host name taken from a program or an installation (a DNS name is at most
/// 253 bytes).
pub const MAX_HOST_BYTES: usize = 255;
/// The External Control URCap's default host when the installation sets none.
pub const EXTERNAL_CONTROL_DEFAULT_HOST: &str = "192.168.56.1";
/// The External Control URCap's default port (the ROS driver's script sender).
pub const EXTERNAL_CONTROL_DEFAULT_PORT: u16 = 50002;

/// The joint angles a Home (`SafeHome`) node moves to: PolyScope's default home
/// position (the arm upright: shoulder and wrist 1 at -90°), as the translator reads no
/// installation.
pub const DEFAULT_HOME_JOINTS: [f64; 6] = [
    0.0,
    -std::f64::consts::FRAC_PI_2,
    0.0,
    -std::f64::consts::FRAC_PI_2,
    0.0,
    0.0,
];

const MAX_REFERENCE_HOPS: usize = 64;
const MAX_REFERENCE_LEN: usize = 4096;
/// The most attributes on one element.
pub const MAX_ATTRIBUTES: usize = 256;

/// The External Control URCap's settings in an installation: where its nodes ask for
/// their script.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ExternalControlSettings {
    /// `host_ip` ([`EXTERNAL_CONTROL_DEFAULT_HOST`] when not set).
    pub host: String,
    /// `port_nr` ([`EXTERNAL_CONTROL_DEFAULT_PORT`] when not set).
    pub port: u16,
    /// Whether the installation has the URCap's contribution at all.
    pub installed: bool,
}

impl Default for ExternalControlSettings {
    fn default() -> Self {
        ExternalControlSettings {
            host: EXTERNAL_CONTROL_DEFAULT_HOST.to_string(),
            port: EXTERNAL_CONTROL_DEFAULT_PORT,
            installed: false,
        }
    }
}

/// Reads the External Control URCap's settings from an `.installation` (gzip-compressed
/// or plain XML, with the same bounds as [`read_urp`]): the `<Contributed>` element whose
/// `ownerId` or `id` names `externalcontrol`, and its `<data key="host_ip">` and
/// `<data key="port_nr">`. Without that element: the URCap's defaults, `installed` false.
///
/// ```
/// use urscript_controller::urp::read_external_control_settings;
/// let installation = br#"<Installation><Contributions><URCaps>
///   <Contributed ownerId="com.fzi.externalcontrol" id="com.fzi.externalcontrol.impl.ExternalControlInstallationNodeService">
///     <data key="host_ip" value="10.0.0.2"/>
///   </Contributed>
/// </URCaps></Contributions></Installation>"#;
/// let settings = read_external_control_settings(installation).unwrap();
/// assert_eq!((settings.host.as_str(), settings.port, settings.installed), ("10.0.0.2", 50002, true));
/// ```
pub fn read_external_control_settings(
    installation: &[u8],
) -> Result<ExternalControlSettings, UrpError> {
    let doc = parse_xml(&inflate(installation)?)?;
    if doc.name(0) != "Installation" {
        return Err(UrpError::NotAnInstallation {
            root: doc.name(0).to_string(),
        });
    }
    let mut settings = ExternalControlSettings::default();
    let found = (0..doc.elems.len()).find(|&id| {
        doc.name(id) == "Contributed"
            && ["ownerId", "id"].iter().any(|k| {
                doc.attr(id, k)
                    .is_some_and(|v| v.to_ascii_lowercase().contains("externalcontrol"))
            })
    });
    if let Some(id) = found {
        settings.installed = true;
        for &d in &doc.elems[id].children {
            match (doc.attr(d, "key"), doc.attr(d, "value")) {
                (Some("host_ip"), Some(v)) if !v.is_empty() => {
                    settings.host = host_name(v).map_err(|m| invalid(&doc, d, m))?
                }
                (Some("port_nr"), Some(v)) if !v.is_empty() => {
                    settings.port = v
                        .trim()
                        .parse::<u16>()
                        .map_err(|_| invalid(&doc, d, format!("port_nr `{v}` is not a port")))?;
                }
                _ => {}
            }
        }
    }
    Ok(settings)
}

/// What the External Control URCap sends its host (then it reads the reply).
pub const EXTERNAL_CONTROL_REQUEST: &[u8] = b"request_program\n";

/// Why fetching an External Control node's script failed: the URCap writes a different
/// popup for each.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum FetchError {
    /// No connection (refused, unreachable, the URCap's 5 s connect timeout), with the
    /// reason as the popup shows it.
    Connect(String),
    /// Connected, but a read of the reply (its first line, or the rest of a line that
    /// started) did not come within the URCap's 500 ms read timeout.
    Timeout,
    /// The reply is longer than the fetcher reads (`limit` bytes): the play fails
    /// ([`UrpError::TooLarge`]), where the URCap has no bound.
    TooLarge {
        /// The bound in bytes.
        limit: usize,
    },
}

/// Why a `.urp` could not be read or translated.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum UrpError {
    /// The input, or what it inflates to, is over a bound.
    TooLarge {
        /// What was too large (`"file"`, `"XML after gunzip"`).
        what: &'static str,
        /// The bound in bytes.
        limit: usize,
    },
    /// Neither a gzip stream nor an XML document.
    NotGzip,
    /// The gzip stream is corrupt or truncated.
    Gzip {
        /// The decompressor's message.
        message: String,
    },
    /// The XML is malformed (or truncated).
    Xml {
        /// The byte offset in the (decompressed) XML.
        offset: u64,
        /// What was wrong.
        message: String,
    },
    /// More than [`MAX_ELEMENTS`] elements.
    TooManyElements {
        /// The bound.
        limit: usize,
        /// The byte offset of the element over the bound.
        offset: u64,
    },
    /// Elements nested deeper than [`MAX_DEPTH`].
    TooDeep {
        /// The bound.
        limit: usize,
        /// The byte offset of the element over the bound.
        offset: u64,
    },
    /// The document's root is not `<URProgram>`.
    NotAProgram {
        /// The root element's name.
        root: String,
    },
    /// The document's root is not `<Installation>` ([`read_external_control_settings`]).
    NotAnInstallation {
        /// The root element's name.
        root: String,
    },
    /// A program node this translator does not know.
    UnknownNode {
        /// The node's element name (for a URCap node, `Contributed` with its node type).
        name: String,
        /// Its path in the document (`URProgram/children/MainProgram/children/Foo[2]`).
        path: String,
    },
    /// A known node in a form that is not translated.
    Unsupported {
        /// The node's path.
        path: String,
        /// What is not supported.
        what: String,
    },
    /// A known node with a missing or malformed part.
    Invalid {
        /// The node's path.
        path: String,
        /// What was wrong.
        message: String,
    },
}

impl fmt::Display for UrpError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            UrpError::TooLarge { what, limit } => {
                write!(f, "the {what} is larger than {limit} bytes")
            }
            UrpError::NotGzip => f.write_str("not a .urp: neither gzip nor XML"),
            UrpError::Gzip { message } => write!(f, "corrupt gzip stream: {message}"),
            UrpError::Xml { offset, message } => {
                write!(f, "malformed XML at byte {offset}: {message}")
            }
            UrpError::TooManyElements { limit, offset } => {
                write!(f, "more than {limit} XML elements (at byte {offset})")
            }
            UrpError::TooDeep { limit, offset } => {
                write!(f, "XML nested deeper than {limit} (at byte {offset})")
            }
            UrpError::NotAProgram { root } => {
                write!(
                    f,
                    "not a PolyScope program: the root is <{root}>, not <URProgram>"
                )
            }
            UrpError::NotAnInstallation { root } => {
                write!(
                    f,
                    "not an installation: the root is <{root}>, not <Installation>"
                )
            }
            UrpError::UnknownNode { name, path } => {
                write!(f, "unknown program node <{name}> at {path}")
            }
            UrpError::Unsupported { path, what } => write!(f, "{path}: not supported: {what}"),
            UrpError::Invalid { path, message } => write!(f, "{path}: {message}"),
        }
    }
}

impl std::error::Error for UrpError {}

/// Where a program runs UR's External Control URCap node, and whom it asks.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ExternalControlNode {
    /// Which External Control node in the program (0 first, in document order).
    pub index: usize,
    /// The node's path in the document.
    pub path: String,
    /// The host the URCap connects to: the node's `host_ip` data if it has one (the
    /// URCap keeps it in the installation), else [`EXTERNAL_CONTROL_DEFAULT_HOST`].
    /// Set it from the installation ([`UrpProgram::set_external_control_host`]).
    pub host: String,
    /// The port: the node's `port_nr` data, else [`EXTERNAL_CONTROL_DEFAULT_PORT`].
    pub port: u16,
    /// The node's data model (`key`, `value`) as saved (`maxlostpackages`,
    /// `gain_servo_j`, ...).
    pub data: Vec<(String, String)>,
}

/// A `.urp` read and translated.
#[derive(Debug, Clone, PartialEq)]
pub struct UrpProgram {
    /// The program's name (`URProgram name`).
    pub name: String,
    /// The installation it was saved with (`URProgram installation`).
    pub installation: String,
    /// The PolyScope version that created it (`createdIn`), if given.
    pub created_in: Option<String>,
    /// The URScript program: `def NAME():` ... `end`. Each External Control node is a
    /// comment line here; [`translate_with`] gives the program with their scripts (from
    /// the translation as read: changing this text does not change what it gives).
    pub script: String,
    /// The External Control nodes, in document order.
    pub external_control: Vec<ExternalControlNode>,
    segments: Vec<Segment>,
}

#[derive(Debug, Clone, PartialEq)]
enum Segment {
    Text(String),
    External { index: usize, indent: usize },
}

impl UrpProgram {
    /// Sets every External Control node's host and port (as the installation's External
    /// Control settings give them: [`read_external_control_settings`]).
    pub fn set_external_control_host(&mut self, host: &str, port: u16) {
        for node in &mut self.external_control {
            node.host = host.to_string();
            node.port = port;
        }
    }
}

/// Reads a `.urp` (gzip-compressed or plain XML) and translates it.
///
/// ```
/// use std::io::Write;
/// let xml = r#"<URProgram name="hello" installation="default">
///   <children>
///     <MainProgram runOnlyOnce="true">
///       <children>
///         <Wait type="Sleep"><waitTime>0.5</waitTime></Wait>
///         <Halt/>
///       </children>
///     </MainProgram>
///   </children>
/// </URProgram>"#;
/// let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
/// gz.write_all(xml.as_bytes()).unwrap();
/// let program = urscript_controller::read_urp(&gz.finish().unwrap()).unwrap();
/// assert_eq!(program.name, "hello");
/// assert_eq!(program.script, "def hello():\n  sleep(0.5)\n  halt\nend\n");
/// urscript_interp::Program::parse(&program.script).unwrap();
///
/// assert!(matches!(
///     urscript_controller::read_urp(b"PK\x03\x04"),
///     Err(urscript_controller::UrpError::NotGzip)
/// ));
/// ```
pub fn read_urp(bytes: &[u8]) -> Result<UrpProgram, UrpError> {
    let doc = parse_xml(&inflate(bytes)?)?;
    translate(&doc)
}

/// The program's script with each External Control node's script spliced in, as the
/// URCap builds it at play time.
///
/// The URCap asks its host once per program build (`request_program\n`) and reads the
/// reply line by line until no more is buffered (the host closes the connection after
/// sending; `fetch` returns everything received). It prefixes each line with a space,
/// then splits the reply: the lines from `# HEADER_BEGIN` to `# HEADER_END` are the
/// header, written once, before the first node's script; the lines after the header
/// are the control loop, written at every External Control node. A reply without
/// `# HEADER_END` is all control loop. `fetch` is called at most once, with the node
/// that comes first in the script, and sees the node's `host` and `port` as they are
/// now ([`UrpProgram::set_external_control_host`]). When it fails, every node gets what
/// the URCap writes then: a blocking error popup titled `Receive program failed` that
/// names the host ([`FetchError`] says which of its two texts), and `sync()`.
///
/// `fetch` may do the I/O itself; a sans-IO caller fetches first (the host and port are
/// in [`UrpProgram::external_control`], the request is [`EXTERNAL_CONTROL_REQUEST`]) and
/// passes a closure that returns what it got.
///
/// ```
/// use std::io::Write;
/// let xml = r#"<URProgram name="ec" installation="default"><children>
///   <MainProgram runOnlyOnce="true"><children>
///     <Contributed strategyClass="com.fzi.externalcontrol.ExternalControlNode"
///                  strategyProgramNodeType="External Control"><dataModel/></Contributed>
///   </children></MainProgram>
/// </children></URProgram>"#;
/// let program = urscript_controller::read_urp(xml.as_bytes()).unwrap();
/// assert_eq!(program.external_control[0].port, 50002);
/// let script = urscript_controller::translate_with(&program, |node| {
///     assert_eq!(node.host, "192.168.56.1");
///     Ok("textmsg(\"driven\")\n".to_string())
/// })
/// .unwrap();
/// assert_eq!(script, "def ec():\n   textmsg(\"driven\")\nend\n");
/// ```
pub fn translate_with(
    program: &UrpProgram,
    mut fetch: impl FnMut(&ExternalControlNode) -> Result<String, FetchError>,
) -> Result<String, UrpError> {
    let mut fetched: Option<Split> = None;
    let mut header_written = false;
    let mut out = String::new();
    for segment in &program.segments {
        match segment {
            Segment::Text(text) => push_bounded(&mut out, text, 0, 0)?,
            Segment::External { index, indent } => {
                let node =
                    program
                        .external_control
                        .get(*index)
                        .ok_or_else(|| UrpError::Invalid {
                            path: String::from("URProgram"),
                            message: format!("External Control node {index} is not listed"),
                        })?;
                if fetched.is_none() {
                    let split = match fetch(node) {
                        Ok(text) => Split::new(&text)?,
                        Err(FetchError::TooLarge { limit }) => {
                            return Err(UrpError::TooLarge {
                                what: "External Control reply",
                                limit,
                            })
                        }
                        Err(FetchError::Timeout) => Split::popup(&format!(
                            "Timeout while reading requested program from {}:{}",
                            node.host, node.port
                        ))?,
                        Err(FetchError::Connect(reason)) => Split::popup(&format!(
                            "The connection to the remote PC at {}:{} could not be established. Reason: {}",
                            node.host, node.port, reason
                        ))?,
                    };
                    fetched = Some(split);
                }
                let Some(split) = &fetched else { continue };
                if !header_written {
                    push_bounded(&mut out, &split.header, split.header_lines, *indent)?;
                    header_written = true;
                }
                push_bounded(&mut out, &split.control, split.control_lines, *indent)?;
            }
        }
    }
    Ok(out)
}

/// The fetched reply as the URCap splits it: header and control loop, each line
/// prefixed with a space and ended with `\n`, and how many lines each has.
struct Split {
    header: String,
    header_lines: usize,
    control: String,
    control_lines: usize,
}

impl Split {
    /// Splits `reply` as the URCap does: read one line at a time (ended by `\n`, `\r`
    /// or `\r\n`) and prefixed with a space; the lines from `# HEADER_BEGIN` to
    /// `# HEADER_END` are the header, those after it the control loop; without
    /// `# HEADER_END` all of it is control loop. An empty reply is the URCap's `null`.
    fn new(reply: &str) -> Result<Split, UrpError> {
        Split::with_prefix(reply, " ")
    }

    /// What the URCap writes when the fetch failed: a blocking error popup, `sync()`
    /// (its own lines, not prefixed).
    fn popup(text: &str) -> Result<Split, UrpError> {
        Split::with_prefix(
            &format!(
                "popup({}, \"Receive program failed\", False, True, blocking=True)\nsync()",
                string_literal(text)
            ),
            "",
        )
    }

    fn with_prefix(reply: &str, prefix: &str) -> Result<Split, UrpError> {
        // The URCap matches `\p{Zs}*# HEADER_BEGIN\p{Zs}*`: only space separators around.
        let zs = |c: char| {
            matches!(
                c,
                ' ' | '\u{a0}' | '\u{1680}' | '\u{2000}'
                    ..='\u{200a}' | '\u{202f}' | '\u{205f}' | '\u{3000}'
            )
        };
        let marker = |line: &str, name: &str| line.trim_matches(zs) == name;
        // First pass: does a header end?
        let mut in_header = false;
        let mut header_end = false;
        for line in reply_lines(reply) {
            if marker(line, "# HEADER_BEGIN") {
                in_header = true;
            } else if marker(line, "# HEADER_END") && in_header {
                header_end = true;
                break;
            }
        }
        let mut split = Split {
            header: String::new(),
            header_lines: 0,
            control: String::new(),
            control_lines: 0,
        };
        let mut in_header = false;
        let mut after_header = false;
        for line in reply_lines(reply) {
            let to_header = if !header_end {
                false
            } else if marker(line, "# HEADER_BEGIN") {
                in_header = true;
                true
            } else if marker(line, "# HEADER_END") && in_header {
                in_header = false;
                after_header = true;
                true
            } else if in_header {
                true
            } else if after_header {
                false
            } else {
                continue; // before the header: the URCap drops it
            };
            let (text, lines) = if to_header {
                (&mut split.header, &mut split.header_lines)
            } else {
                (&mut split.control, &mut split.control_lines)
            };
            if text.len() + prefix.len() + line.len() + 1 > MAX_SCRIPT_BYTES {
                return Err(script_too_large());
            }
            text.push_str(prefix);
            text.push_str(line);
            text.push('\n');
            *lines += 1;
        }
        Ok(split)
    }
}

/// The reply's lines as the URCap reads them (ended by `\n`, `\r` or `\r\n`); an empty
/// reply is the one line `null` (the URCap's `readLine` of a connection closed at once).
fn reply_lines(reply: &str) -> impl Iterator<Item = &str> {
    let mut rest = if reply.is_empty() { "null" } else { reply };
    std::iter::from_fn(move || {
        if rest.is_empty() {
            return None;
        }
        let end = rest.find(['\n', '\r']).unwrap_or(rest.len());
        let line = &rest[..end];
        rest = &rest[end..];
        if rest.starts_with("\r\n") {
            rest = &rest[2..];
        } else if !rest.is_empty() {
            rest = &rest[1..];
        }
        Some(line)
    })
}

fn script_too_large() -> UrpError {
    UrpError::TooLarge {
        what: "translated script",
        limit: MAX_SCRIPT_BYTES,
    }
}

/// Appends `text` (`lines` lines, each ended by `\n`) to `out`, each line indented
/// `indent` levels of two spaces, if the result stays within [`MAX_SCRIPT_BYTES`].
fn push_bounded(out: &mut String, text: &str, lines: usize, indent: usize) -> Result<(), UrpError> {
    let grown = lines
        .checked_mul(2 * indent)
        .and_then(|pad| pad.checked_add(text.len()))
        .and_then(|n| n.checked_add(out.len()));
    if grown.is_none_or(|n| n > MAX_SCRIPT_BYTES) {
        return Err(script_too_large());
    }
    if indent == 0 {
        out.push_str(text);
    } else {
        push_indented(out, text, indent);
    }
    Ok(())
}

fn push_indented(out: &mut String, text: &str, indent: usize) {
    for line in text.lines() {
        for _ in 0..indent {
            out.push_str("  ");
        }
        out.push_str(line);
        out.push('\n');
    }
}

/// `text` as a host name: at most [`MAX_HOST_BYTES`] bytes.
fn host_name(text: &str) -> Result<String, String> {
    if text.len() > MAX_HOST_BYTES {
        return Err(format!(
            "a host name of {} bytes (at most {MAX_HOST_BYTES})",
            text.len()
        ));
    }
    Ok(text.to_string())
}

// ---------------------------------------------------------------------------------------
// gunzip and XML

fn inflate(bytes: &[u8]) -> Result<Vec<u8>, UrpError> {
    if bytes.len() > MAX_URP_BYTES {
        return Err(UrpError::TooLarge {
            what: "file",
            limit: MAX_URP_BYTES,
        });
    }
    if bytes.starts_with(&[0x1f, 0x8b]) {
        let mut xml = Vec::new();
        let limit = (MAX_XML_BYTES as u64).saturating_add(1);
        // Members one after another inflate to their concatenation, as gunzip does.
        flate2::read::MultiGzDecoder::new(bytes)
            .take(limit)
            .read_to_end(&mut xml)
            .map_err(|e| UrpError::Gzip {
                message: e.to_string(),
            })?;
        if xml.len() > MAX_XML_BYTES {
            return Err(UrpError::TooLarge {
                what: "XML after gunzip",
                limit: MAX_XML_BYTES,
            });
        }
        return Ok(xml);
    }
    let text = bytes.strip_prefix(b"\xef\xbb\xbf").unwrap_or(bytes);
    match text.iter().find(|b| !b.is_ascii_whitespace()) {
        Some(b'<') => Ok(text.to_vec()),
        _ => Err(UrpError::NotGzip),
    }
}

#[derive(Debug)]
struct Elem {
    name: String,
    attrs: Vec<(String, String)>,
    text: String,
    children: Vec<usize>,
    parent: Option<usize>,
    /// Its position among its parent's children of its name, from 1 (XStream's `Name[k]`).
    nth: u32,
}

#[derive(Debug)]
struct Doc {
    elems: Vec<Elem>,
    /// (parent, name, k) -> the parent's k-th child of that name, so that following a
    /// reference costs the same whatever the number of siblings.
    named: HashMap<(usize, u32, u32), usize>,
    /// Element names, numbered (the keys of `named`).
    name_ids: HashMap<String, u32>,
    /// Element -> where its `reference` attribute points (one hop), or why it does not.
    links: HashMap<usize, Result<usize, String>>,
}

fn xml_err(offset: u64, message: impl Into<String>) -> UrpError {
    UrpError::Xml {
        offset,
        message: message.into(),
    }
}

/// What the parsed tree costs besides its strings' bytes, as [`MAX_TREE_BYTES`] counts
/// it: an element's record, its entry in its parent's children and in the sibling index
/// (a hash map entry, counted twice for the map's spare room).
const ELEMENT_COST: usize = std::mem::size_of::<Elem>()
    + std::mem::size_of::<usize>()
    + 2 * std::mem::size_of::<((usize, u32, u32), usize)>();
/// An attribute's record (its name and value are counted by their length).
const ATTRIBUTE_COST: usize = std::mem::size_of::<(String, String)>();

/// The estimated memory of the tree being built, checked against [`MAX_TREE_BYTES`].
struct TreeBudget {
    used: usize,
}

impl TreeBudget {
    fn charge(&mut self, bytes: usize) -> Result<(), UrpError> {
        self.used = self.used.saturating_add(bytes);
        if self.used > MAX_TREE_BYTES {
            return Err(UrpError::TooLarge {
                what: "parsed document (estimated memory)",
                limit: MAX_TREE_BYTES,
            });
        }
        Ok(())
    }
}

fn parse_xml(xml: &[u8]) -> Result<Doc, UrpError> {
    let mut budget = TreeBudget { used: 0 };
    let mut reader = Reader::from_reader(xml);
    let mut elems: Vec<Elem> = Vec::new();
    let mut named = HashMap::new();
    let mut name_ids: HashMap<String, u32> = HashMap::new();
    let mut stack: Vec<usize> = Vec::new();
    // For each open element, how many children of each name it has had so far.
    let mut counts: Vec<HashMap<u32, u32>> = Vec::new();
    let mut root_done = false;
    loop {
        let at = reader.buffer_position();
        let event = reader
            .read_event()
            .map_err(|e| xml_err(reader.error_position(), e.to_string()))?;
        match event {
            Event::Start(ref e) | Event::Empty(ref e) => {
                if root_done {
                    return Err(xml_err(at, "a second root element"));
                }
                if stack.len() >= MAX_DEPTH {
                    return Err(UrpError::TooDeep {
                        limit: MAX_DEPTH,
                        offset: at,
                    });
                }
                if elems.len() >= MAX_ELEMENTS {
                    return Err(UrpError::TooManyElements {
                        limit: MAX_ELEMENTS,
                        offset: at,
                    });
                }
                if e.name().as_ref().len() > MAX_NAME_BYTES {
                    return Err(xml_err(
                        at,
                        format!("an element name longer than {MAX_NAME_BYTES} bytes"),
                    ));
                }
                let name = std::str::from_utf8(e.name().as_ref())
                    .map_err(|_| xml_err(at, "an element name is not UTF-8"))?
                    .to_string();
                budget.charge(ELEMENT_COST + name.len())?;
                let mut attrs = Vec::new();
                for attr in e.attributes() {
                    if attrs.len() >= MAX_ATTRIBUTES {
                        return Err(xml_err(
                            at,
                            format!("more than {MAX_ATTRIBUTES} attributes on <{name}>"),
                        ));
                    }
                    let attr = attr.map_err(|err| xml_err(at, err.to_string()))?;
                    if attr.key.as_ref().len() > MAX_NAME_BYTES {
                        return Err(xml_err(
                            at,
                            format!("an attribute name longer than {MAX_NAME_BYTES} bytes"),
                        ));
                    }
                    let key = std::str::from_utf8(attr.key.as_ref())
                        .map_err(|_| xml_err(at, "an attribute name is not UTF-8"))?
                        .to_string();
                    let value = attr
                        .normalized_value(quick_xml::XmlVersion::Implicit1_0)
                        .map_err(|err| xml_err(at, format!("attribute `{key}`: {err}")))?
                        .into_owned();
                    budget.charge(ATTRIBUTE_COST + key.len() + value.len())?;
                    attrs.push((key, value));
                }
                let id = elems.len();
                let parent = stack.last().copied();
                let name_id = match name_ids.get(name.as_str()) {
                    Some(&n) => n,
                    None => {
                        budget.charge(name.len() + ELEMENT_COST)?;
                        // At most one name per element: fits, as MAX_ELEMENTS does.
                        let n = u32::try_from(name_ids.len()).unwrap_or(u32::MAX);
                        name_ids.insert(name.clone(), n);
                        n
                    }
                };
                let nth = match counts.last_mut() {
                    Some(c) => {
                        let n = c.entry(name_id).or_insert(0);
                        *n += 1;
                        *n
                    }
                    None => 1,
                };
                if let Some(p) = parent {
                    elems[p].children.push(id);
                    named.insert((p, name_id, nth), id);
                }
                elems.push(Elem {
                    name,
                    attrs,
                    text: String::new(),
                    children: Vec::new(),
                    parent,
                    nth,
                });
                if matches!(event, Event::Start(_)) {
                    stack.push(id);
                    counts.push(HashMap::new());
                } else if stack.is_empty() {
                    root_done = true;
                }
            }
            Event::End(_) => {
                stack.pop();
                counts.pop();
                if stack.is_empty() {
                    root_done = true;
                }
            }
            Event::Text(t) => {
                let text = t.decode().map_err(|e| xml_err(at, e.to_string()))?;
                budget.charge(text.len())?;
                push_text(&mut elems, &stack, &text, at)?;
            }
            Event::CData(t) => {
                let text = t.decode().map_err(|e| xml_err(at, e.to_string()))?;
                budget.charge(text.len())?;
                push_text(&mut elems, &stack, &text, at)?;
            }
            Event::GeneralRef(r) => {
                let ch = match r
                    .resolve_char_ref()
                    .map_err(|e| xml_err(at, e.to_string()))?
                {
                    Some(c) => c,
                    None => match r.as_ref() {
                        b"lt" => '<',
                        b"gt" => '>',
                        b"amp" => '&',
                        b"quot" => '"',
                        b"apos" => '\'',
                        other => {
                            return Err(xml_err(
                                at,
                                format!("unknown entity &{};", String::from_utf8_lossy(other)),
                            ))
                        }
                    },
                };
                budget.charge(4)?;
                push_text(&mut elems, &stack, ch.encode_utf8(&mut [0; 4]), at)?;
            }
            Event::Eof => {
                if let Some(&open) = stack.last() {
                    return Err(xml_err(
                        at,
                        format!("the document ends inside <{}>", elems[open].name),
                    ));
                }
                if elems.is_empty() {
                    return Err(xml_err(at, "no root element"));
                }
                break;
            }
            Event::Decl(_) | Event::PI(_) | Event::Comment(_) | Event::DocType(_) => {}
        }
    }
    let mut doc = Doc {
        elems,
        named,
        name_ids,
        links: HashMap::new(),
    };
    doc.link();
    Ok(doc)
}

fn push_text(elems: &mut [Elem], stack: &[usize], text: &str, at: u64) -> Result<(), UrpError> {
    match stack.last() {
        Some(&top) => elems[top].text.push_str(text),
        None if text.trim().is_empty() => {}
        None => return Err(xml_err(at, "text outside the root element")),
    }
    Ok(())
}

impl Doc {
    fn attr(&self, id: usize, key: &str) -> Option<&str> {
        self.elems[id]
            .attrs
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }

    fn name(&self, id: usize) -> &str {
        &self.elems[id].name
    }

    fn child(&self, id: usize, name: &str) -> Option<usize> {
        self.elems[id]
            .children
            .iter()
            .copied()
            .find(|&c| self.elems[c].name == name)
    }

    /// The element's path: names from the root, `Name[k]` for the k-th of its name.
    fn path(&self, id: usize) -> String {
        let mut parts = Vec::new();
        let mut cur = Some(id);
        while let Some(c) = cur {
            let e = &self.elems[c];
            if e.nth > 1 {
                parts.push(format!("{}[{}]", e.name, e.nth));
            } else {
                parts.push(e.name.clone());
            }
            cur = e.parent;
        }
        parts.reverse();
        parts.join("/")
    }

    /// Where one XStream `reference="..."` points (a path relative to the element: `..`,
    /// `Name`, `Name[k]`), one hop.
    fn step(&self, id: usize, reference: &str) -> Result<usize, String> {
        if reference.len() > MAX_REFERENCE_LEN {
            return Err(format!("a reference longer than {MAX_REFERENCE_LEN} bytes"));
        }
        let bad = |why: &str| format!("reference `{reference}` {why}");
        let mut at = id;
        for seg in reference.split('/') {
            at = match seg {
                "" | "." => at,
                ".." => self.elems[at]
                    .parent
                    .ok_or_else(|| bad("leaves the document"))?,
                _ => {
                    let (name, k) = match seg.split_once('[') {
                        Some((n, rest)) => {
                            let k = rest
                                .strip_suffix(']')
                                .and_then(|k| k.parse::<u32>().ok())
                                .filter(|&k| k >= 1)
                                .ok_or_else(|| bad("has a malformed index"))?;
                            (n, k)
                        }
                        None => (seg, 1),
                    };
                    self.name_ids
                        .get(name)
                        .and_then(|&n| self.named.get(&(at, n, k)))
                        .copied()
                        .ok_or_else(|| bad("does not resolve"))?
                }
            };
        }
        Ok(at)
    }

    /// Follows XStream `reference="..."` attributes to the element they name. Each
    /// reference is read once ([`Doc::link`]); a chain is at most
    /// [`MAX_REFERENCE_HOPS`] long.
    fn resolve(&self, id: usize) -> Result<usize, UrpError> {
        let mut cur = id;
        for _ in 0..MAX_REFERENCE_HOPS {
            match self.links.get(&cur) {
                None => return Ok(cur),
                Some(Ok(next)) => cur = *next,
                Some(Err(message)) => {
                    return Err(UrpError::Invalid {
                        path: self.path(cur),
                        message: message.clone(),
                    })
                }
            }
        }
        Err(UrpError::Invalid {
            path: self.path(id),
            message: format!("more than {MAX_REFERENCE_HOPS} chained references"),
        })
    }

    /// Reads every `reference` attribute once: the cost of references is linear in the
    /// document, however many elements name the same one.
    fn link(&mut self) {
        let mut links = HashMap::new();
        for id in 0..self.elems.len() {
            if let Some(r) = self.attr(id, "reference") {
                links.insert(id, self.step(id, r));
            }
        }
        self.links = links;
    }
}

// ---------------------------------------------------------------------------------------
// translation

struct Translator<'a> {
    doc: &'a Doc,
    segments: Vec<Segment>,
    indent: usize,
    externals: Vec<ExternalControlNode>,
    /// Sub programs: (resolved node, function name), in the order first met.
    subprograms: Vec<(usize, String)>,
    subprogram_index: HashMap<usize, usize>,
    subprogram_names: std::collections::HashSet<String>,
    loops: usize,
    /// Timer variables, in the order first met (each at most once).
    timers: Vec<String>,
    /// Threads of loops checked continuously, written at the program's top level.
    hoisted: Vec<Segment>,
    /// How many such threads so far (their names' numbers).
    watched: usize,
    /// The program's threads: (name, node), to check against the other definitions.
    thread_names: Vec<(String, usize)>,
    /// Bytes of script written, with the External Control nodes' records: at most
    /// [`MAX_SCRIPT_BYTES`]; past it nothing more is kept and the translation fails.
    written: usize,
    /// Program nodes translated so far (at most [`MAX_NODES_TRANSLATED`]).
    visited: usize,
    /// Program nodes being translated, one inside the other (at most [`MAX_DEPTH`]).
    nesting: usize,
}

fn invalid(doc: &Doc, id: usize, message: impl Into<String>) -> UrpError {
    UrpError::Invalid {
        path: doc.path(id),
        message: message.into(),
    }
}

fn unsupported(doc: &Doc, id: usize, what: impl Into<String>) -> UrpError {
    UrpError::Unsupported {
        path: doc.path(id),
        what: what.into(),
    }
}

fn unknown(doc: &Doc, id: usize) -> UrpError {
    UrpError::UnknownNode {
        name: doc.name(id).to_string(),
        path: doc.path(id),
    }
}

/// A URScript name from a PolyScope name: letters, digits and `_`, not starting with a
/// digit.
fn identifier(name: &str) -> String {
    let mut out: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    if out.is_empty() || out.starts_with(|c: char| c.is_ascii_digit()) {
        out.insert(0, 'P');
    }
    out
}

/// PolyScope's expression editor writes comparison and assignment with its own symbols
/// (`≟` for `==`); the script has URScript's.
fn operator(c: &str) -> &str {
    match c {
        "\u{225f}" => "==",
        "\u{2260}" => "!=",
        "\u{2264}" => "<=",
        "\u{2265}" => ">=",
        "\u{2254}" => "=",
        other => other,
    }
}

fn string_literal(s: &str) -> String {
    let s: String = s
        .chars()
        .map(|c| if c == '\n' || c == '\r' { ' ' } else { c })
        .collect();
    if !s.contains('"') {
        format!("\"{s}\"")
    } else if !s.contains('\'') {
        format!("'{s}'")
    } else {
        format!("\"{}\"", s.replace('"', "'"))
    }
}

fn translate(doc: &Doc) -> Result<UrpProgram, UrpError> {
    if doc.name(0) != "URProgram" {
        return Err(UrpError::NotAProgram {
            root: doc.name(0).to_string(),
        });
    }
    let name = doc.attr(0, "name").unwrap_or("Program").to_string();
    let installation = doc.attr(0, "installation").unwrap_or("default").to_string();
    let created_in = doc.attr(0, "createdIn").map(str::to_string);
    let mut tr = Translator {
        doc,
        segments: Vec::new(),
        indent: 1,
        externals: Vec::new(),
        subprograms: Vec::new(),
        subprogram_index: HashMap::new(),
        subprogram_names: std::collections::HashSet::new(),
        loops: 0,
        timers: Vec::new(),
        hoisted: Vec::new(),
        watched: 0,
        thread_names: Vec::new(),
        written: 0,
        visited: 0,
        nesting: 0,
    };

    let mut init = Vec::new();
    let mut before = Vec::new();
    let mut main = None;
    let mut threads = Vec::new();
    if let Some(children) = doc.child(0, "children") {
        for &c in &doc.elems[children].children {
            match doc.name(c) {
                "InitVariablesNode" => init.push(c),
                "SpecialSequence" => match doc.attr(c, "type") {
                    Some("BeforeStart") => before.push(c),
                    other => {
                        return Err(unsupported(
                            doc,
                            c,
                            format!("special sequence type {}", other.unwrap_or("(none)")),
                        ))
                    }
                },
                "MainProgram" => {
                    if main.replace(c).is_some() {
                        return Err(invalid(doc, c, "a second MainProgram"));
                    }
                }
                "SubProgram" => {
                    let sub = doc.resolve(c)?;
                    tr.subprogram_name(sub)?;
                }
                "Thread" => threads.push(c),
                _ => return Err(unknown(doc, c)),
            }
        }
    }
    for &c in &init {
        tr.init_variables(c)?;
        tr.children_of(c)?;
    }
    for &c in &before {
        tr.children_of(c)?;
    }
    tr.threads(&threads)?;
    let Some(main) = main else {
        return Err(invalid(doc, 0, "the program has no MainProgram"));
    };
    let forever = doc.attr(main, "runOnlyOnce") == Some("false");
    if forever {
        tr.line("while (True):");
        tr.indent += 1;
    }
    tr.children_of(main)?;
    if forever {
        tr.indent -= 1;
        tr.line("end");
    }
    let body = std::mem::take(&mut tr.segments);

    // Sub programs, from a work list (a sub program may call others, or itself).
    let mut defs = Vec::new();
    let mut next = 0;
    while next < tr.subprograms.len() {
        let (sub, fname) = tr.subprograms[next].clone();
        next += 1;
        tr.indent = 1;
        tr.line(&format!("def {fname}():"));
        tr.indent = 2;
        tr.children_of(sub)?;
        tr.indent = 1;
        tr.line("end");
        defs.append(&mut tr.segments);
    }

    let mut segments = vec![Segment::Text(format!("def {}():\n", identifier(&name)))];
    segments.extend(defs);
    // Every thread's name is its own: not a sub program's, nor one the translation
    // writes (sub programs met only inside threads are named after the threads are).
    for (thread, node) in &tr.thread_names {
        let generated = (thread == "Timer_Thread" && !tr.timers.is_empty())
            || (1..=tr.watched).any(|k| {
                *thread == format!("Thread_while_{k}") || *thread == format!("Thread_if_{k}")
            });
        if generated || tr.subprogram_names.contains(thread) {
            return Err(invalid(
                doc,
                *node,
                format!("the thread {thread} has the name of another definition"),
            ));
        }
    }
    for (sub, fname) in &tr.subprograms {
        if (fname == "Timer_Thread" && !tr.timers.is_empty())
            || (1..=tr.watched).any(|k| {
                *fname == format!("Thread_while_{k}") || *fname == format!("Thread_if_{k}")
            })
        {
            return Err(invalid(
                doc,
                *sub,
                format!("the sub program {fname} has the name of a thread"),
            ));
        }
    }
    segments.append(&mut tr.hoisted);
    if !tr.timers.is_empty() {
        tr.timer_thread();
        segments.append(&mut tr.segments);
    }
    segments.extend(body);
    segments.push(Segment::Text(String::from("end\n")));
    tr.within_bounds()?;
    let segments = merge(segments);
    let mut script = String::new();
    for s in &segments {
        match s {
            Segment::Text(t) => push_bounded(&mut script, t, 0, 0)?,
            Segment::External { index, indent } => {
                let node = &tr.externals[*index];
                let comment = format!(
                    "# External Control node {index}: the script from {}:{} goes here\n",
                    node.host, node.port
                );
                push_bounded(&mut script, &comment, 1, *indent)?;
            }
        }
    }
    Ok(UrpProgram {
        name,
        installation,
        created_in,
        script,
        external_control: tr.externals,
        segments,
    })
}

fn merge(segments: Vec<Segment>) -> Vec<Segment> {
    let mut out: Vec<Segment> = Vec::new();
    for s in segments {
        match (out.last_mut(), s) {
            (Some(Segment::Text(a)), Segment::Text(b)) => a.push_str(&b),
            (_, s) => out.push(s),
        }
    }
    out
}

fn parse_f64(doc: &Doc, id: usize, what: &str, text: &str) -> Result<f64, UrpError> {
    text.trim()
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| invalid(doc, id, format!("{what} `{}` is not a number", text.trim())))
}

/// A number as URScript source (always with a decimal point or exponent).
fn num(v: f64) -> String {
    let s = format!("{v:?}");
    if s.contains(['.', 'e', 'E']) {
        s
    } else {
        format!("{s}.0")
    }
}

fn vector6(doc: &Doc, id: usize, what: &str, text: &str) -> Result<[f64; 6], UrpError> {
    let parts: Vec<&str> = text.split(',').collect();
    if parts.len() != 6 {
        return Err(invalid(
            doc,
            id,
            format!("{what} `{text}` does not have 6 values"),
        ));
    }
    let mut out = [0.0; 6];
    for (o, p) in out.iter_mut().zip(parts) {
        *o = parse_f64(doc, id, what, p)?;
    }
    Ok(out)
}

fn list(v: &[f64; 6]) -> String {
    let items: Vec<String> = v.iter().map(|&x| num(x)).collect();
    format!("[{}]", items.join(", "))
}

/// The `<pin>` of node `id`, resolved, and its name.
fn pin_name(doc: &Doc, id: usize) -> Result<(usize, &str), UrpError> {
    let p = doc
        .child(id, "pin")
        .ok_or_else(|| invalid(doc, id, "no <pin>"))?;
    let p = doc.resolve(p)?;
    let name = doc
        .attr(p, "referencedName")
        .or_else(|| doc.attr(p, "name"))
        .ok_or_else(|| invalid(doc, p, "the pin has no name"))?;
    Ok((p, name))
}

/// A pin reference `digital_out[3]`: (`digital_out`, 3).
fn pin(doc: &Doc, id: usize) -> Result<(String, u32), UrpError> {
    let (p, name) = pin_name(doc, id)?;
    let bad = || invalid(doc, p, format!("pin `{name}` is not of the form kind[N]"));
    let (kind, rest) = name.split_once('[').ok_or_else(bad)?;
    let n = rest
        .strip_suffix(']')
        .and_then(|n| n.trim().parse::<u32>().ok())
        .ok_or_else(bad)?;
    Ok((kind.to_string(), n))
}

fn bool_text(doc: &Doc, id: usize, what: &str, text: &str) -> Result<&'static str, UrpError> {
    match text.trim() {
        "1" | "true" | "True" | "HIGH" => Ok("True"),
        "0" | "false" | "False" | "LOW" => Ok("False"),
        other => Err(invalid(doc, id, format!("{what} `{other}` is not 0/1"))),
    }
}

impl Translator<'_> {
    /// Writes one line at the current indentation; past [`MAX_SCRIPT_BYTES`] in all it
    /// is not kept, and the translation fails at the next node ([`Translator::nodes`]) or at
    /// its end.
    fn line(&mut self, text: &str) {
        let size = text.len() + 2 * self.indent + 1;
        self.written = self.written.saturating_add(size);
        if self.written > MAX_SCRIPT_BYTES {
            return;
        }
        let mut s = String::with_capacity(size);
        for _ in 0..self.indent {
            s.push_str("  ");
        }
        s.push_str(text);
        s.push('\n');
        match self.segments.last_mut() {
            Some(Segment::Text(t)) => t.push_str(&s),
            _ => self.segments.push(Segment::Text(s)),
        }
    }

    fn block(
        &mut self,
        head: &str,
        f: impl FnOnce(&mut Self) -> Result<(), UrpError>,
    ) -> Result<(), UrpError> {
        self.line(head);
        self.indent += 1;
        f(self)?;
        self.indent -= 1;
        self.line("end");
        Ok(())
    }

    /// The function name for a sub program node, registering it on first sight.
    fn subprogram_name(&mut self, sub: usize) -> Result<String, UrpError> {
        if let Some(&k) = self.subprogram_index.get(&sub) {
            return Ok(self.subprograms[k].1.clone());
        }
        let name = self
            .doc
            .attr(sub, "name")
            .ok_or_else(|| invalid(self.doc, sub, "the sub program has no name"))?;
        let fname = identifier(name);
        if !self.subprogram_names.insert(fname.clone()) {
            return Err(invalid(
                self.doc,
                sub,
                format!("two sub programs named {fname}"),
            ));
        }
        self.subprogram_index.insert(sub, self.subprograms.len());
        self.subprograms.push((sub, fname.clone()));
        Ok(fname)
    }

    /// Translates the nodes in `id`'s `<children>`.
    fn children_of(&mut self, id: usize) -> Result<(), UrpError> {
        let Some(children) = self.doc.child(id, "children") else {
            return Ok(());
        };
        self.nodes(&self.doc.elems[children].children)
    }

    /// Whether what was written so far is within [`MAX_SCRIPT_BYTES`].
    fn within_bounds(&self) -> Result<(), UrpError> {
        if self.written > MAX_SCRIPT_BYTES {
            return Err(script_too_large());
        }
        Ok(())
    }

    /// Translates the nodes of `list` (one program level: the recursion goes through
    /// here, so its depth is bounded by [`MAX_DEPTH`], references followed or not).
    fn nodes(&mut self, list: &[usize]) -> Result<(), UrpError> {
        let Some(&first) = list.first() else {
            return Ok(());
        };
        if self.nesting >= MAX_DEPTH {
            return Err(invalid(
                self.doc,
                first,
                format!(
                    "program nodes nested deeper than {MAX_DEPTH} (a reference to an enclosing node?)"
                ),
            ));
        }
        self.nesting += 1;
        let done = self.level(list);
        self.nesting -= 1;
        done
    }

    fn level(&mut self, list: &[usize]) -> Result<(), UrpError> {
        let doc = self.doc;
        let mut i = 0;
        while i < list.len() {
            self.within_bounds()?;
            self.visited += 1;
            if self.visited > MAX_NODES_TRANSLATED {
                return Err(invalid(
                    doc,
                    list[i],
                    format!(
                        "more than {MAX_NODES_TRANSLATED} program nodes to translate (references repeat nodes)"
                    ),
                ));
            }
            let id = doc.resolve(list[i])?;
            if doc.name(id) == "If" {
                // An If and the ElseIf/Else siblings that follow it.
                let mut chain = vec![id];
                if doc.attr(id, "type").unwrap_or("If") != "If" {
                    return Err(invalid(
                        doc,
                        id,
                        "an ElseIf or Else without an If before it",
                    ));
                }
                while let Some(&next) = list.get(i + 1) {
                    let next = doc.resolve(next)?;
                    if doc.name(next) == "If"
                        && matches!(doc.attr(next, "type"), Some("ElseIf" | "Else"))
                    {
                        chain.push(next);
                        i += 1;
                    } else {
                        break;
                    }
                }
                self.if_chain(&chain)?;
            } else {
                self.node(id)?;
            }
            i += 1;
        }
        Ok(())
    }

    fn expression(&self, id: usize) -> Result<String, UrpError> {
        let doc = self.doc;
        let e = doc
            .child(id, "expression")
            .ok_or_else(|| invalid(doc, id, "no <expression>"))?;
        let e = doc.resolve(e)?;
        let mut out = String::new();
        out.push_str(doc.elems[e].text.trim());
        for &t in &doc.elems[e].children {
            let t = doc.resolve(t)?;
            match doc.name(t) {
                "ExpressionChar" => {
                    let c = doc
                        .attr(t, "character")
                        .ok_or_else(|| invalid(doc, t, "no character"))?;
                    out.push_str(operator(c));
                }
                "ExpressionToken" => out.push_str(
                    doc.attr(t, "token")
                        .ok_or_else(|| invalid(doc, t, "no token"))?,
                ),
                "ExpressionVariable" => {
                    let name = match doc
                        .attr(t, "name")
                        .or_else(|| doc.attr(t, "referencedName"))
                    {
                        Some(n) => n.to_string(),
                        // <ProgramVariable reference=".../variable"/> (5.x), or a
                        // variable element of another kind.
                        None => match doc.elems[t].children.first() {
                            Some(&v) => self.named_variable(v)?,
                            None => {
                                return Err(invalid(doc, t, "a variable token names no variable"))
                            }
                        },
                    };
                    out.push_str(&name);
                }
                "ExpressionIO" => out.push_str(&self.io_read(t)?),
                "ExpressionGeomFeature" => out.push_str(&self.feature_name(t)?),
                _ => return Err(unknown(doc, t)),
            }
        }
        if out.trim().is_empty() {
            return Err(invalid(doc, id, "the expression is empty"));
        }
        if out.contains(['\n', '\r']) {
            return Err(invalid(doc, id, "the expression spans lines"));
        }
        Ok(out)
    }

    /// The name of the `<variable>` child of `id` (references followed).
    fn variable_name(&self, id: usize) -> Result<String, UrpError> {
        let doc = self.doc;
        let v = doc
            .child(id, "variable")
            .ok_or_else(|| invalid(doc, id, "no <variable>"))?;
        self.named_variable(v)
    }

    /// An `<ExpressionGeomFeature>` token: the feature it names (`<feature
    /// referencedName="Plane_1"/>`, or a reference to the feature's element), which
    /// PolyScope defines as a pose variable of that name from the installation.
    fn feature_name(&self, id: usize) -> Result<String, UrpError> {
        let doc = self.doc;
        let f = doc
            .child(id, "feature")
            .or_else(|| doc.elems[id].children.first().copied())
            .ok_or_else(|| invalid(doc, id, "a feature token names no feature"))?;
        self.named_variable(f)
    }

    /// The name of a variable element (references followed).
    fn named_variable(&self, v: usize) -> Result<String, UrpError> {
        let doc = self.doc;
        let v = doc.resolve(v)?;
        let name = doc
            .attr(v, "name")
            .or_else(|| doc.attr(v, "referencedName"))
            .ok_or_else(|| invalid(doc, v, "the variable has no name"))?;
        if name.is_empty()
            || name.starts_with(|c: char| c.is_ascii_digit())
            || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
        {
            return Err(invalid(doc, v, format!("`{name}` is not a variable name")));
        }
        Ok(name.to_string())
    }

    fn text_of(&self, id: usize, child: &str) -> Result<String, UrpError> {
        let doc = self.doc;
        let c = doc
            .child(id, child)
            .ok_or_else(|| invalid(doc, id, format!("no <{child}>")))?;
        Ok(doc.elems[c].text.trim().to_string())
    }

    fn node(&mut self, id: usize) -> Result<(), UrpError> {
        let doc = self.doc;
        match doc.name(id) {
            "Comment" => {
                let text = doc.attr(id, "comment").unwrap_or("");
                // Every line of it commented: URScript ends a line at `\r` too.
                for l in text.split(['\n', '\r']).filter(|l| !l.is_empty()) {
                    self.line(&format!("# {l}"));
                }
            }
            "Folder" => {
                if let Some(n) = doc.attr(id, "name") {
                    self.line(&format!("# Folder {}", n.replace(['\n', '\r'], " ")));
                }
                self.children_of(id)?;
            }
            "Halt" => self.line("halt"),
            "Script" => self.script(id)?,
            "Wait" => self.wait(id)?,
            "Popup" => self.popup(id)?,
            "Set" => self.set(id)?,
            "Move" => self.motion(id)?,
            "Loop" => self.loop_node(id)?,
            "Assignment" => {
                let name = self.variable_name(id)?;
                let value = match doc.attr(id, "valueSource") {
                    None | Some("Expression") => self.expression(id)?,
                    Some("Operator") => {
                        // The operator answers at play time: PolyScope asks its primary
                        // client for a value of the assignment's type.
                        let f = match doc.attr(id, "valueType") {
                            Some("Boolean") => "request_boolean_from_primary_client",
                            Some("Integer") => "request_integer_from_primary_client",
                            Some("Float") => "request_float_from_primary_client",
                            Some("String") => "request_string_from_primary_client",
                            Some(other) => {
                                return Err(unsupported(
                                    doc,
                                    id,
                                    format!("an operator assignment of type {other}"),
                                ))
                            }
                            None => {
                                return Err(invalid(
                                    doc,
                                    id,
                                    "an operator assignment without valueType",
                                ))
                            }
                        };
                        let message = doc.attr(id, "message").unwrap_or("");
                        format!("{f}({})", string_literal(message))
                    }
                    Some(other) => {
                        return Err(unsupported(doc, id, format!("an assignment from {other}")))
                    }
                };
                self.line(&format!("global {name} = {value}"));
            }
            "CallSubProgram" => {
                let sub = doc
                    .child(id, "subprogram")
                    .ok_or_else(|| invalid(doc, id, "no <subprogram>"))?;
                let sub = doc.resolve(sub)?;
                let fname = self.subprogram_name(sub)?;
                self.line(&format!("{fname}()"));
            }
            "Contributed" => self.contributed(id)?,
            "Timer" => self.timer(id)?,
            "SafeHome" => self.safe_home(id)?,
            // A node the user suppressed: PolyScope leaves it out of the script.
            "SuppressedNode" => {}
            _ => return Err(unknown(doc, id)),
        }
        Ok(())
    }

    fn script(&mut self, id: usize) -> Result<(), UrpError> {
        let doc = self.doc;
        match doc.attr(id, "type") {
            Some("Line") => {
                let line = self.expression(id)?;
                self.line(&line);
            }
            Some("File") => {
                let Some(c) = doc.child(id, "cachedContents") else {
                    let file = doc
                        .child(id, "file")
                        .map(|f| doc.elems[f].text.trim().to_string());
                    return Err(invalid(
                        doc,
                        id,
                        format!(
                            "the script file {} has no <cachedContents>",
                            file.unwrap_or_else(|| String::from("(unnamed)"))
                        ),
                    ));
                };
                let text = doc.elems[c].text.clone();
                for l in text.lines() {
                    let l = l.trim();
                    if !l.is_empty() {
                        self.line(l);
                    }
                }
            }
            other => {
                return Err(unsupported(
                    doc,
                    id,
                    format!("script type {}", other.unwrap_or("(none)")),
                ))
            }
        }
        Ok(())
    }

    /// An `<ExpressionIO>` token: its `<pin>` read. A pin `kind[N]` is read as a Wait
    /// reads it; any other name is a signal the installation names, which PolyScope
    /// reads as a Modbus signal: `modbus_get_signal_status("NAME", False)`.
    fn io_read(&self, id: usize) -> Result<String, UrpError> {
        let doc = self.doc;
        let (p, name) = pin_name(doc, id)?;
        if name.contains('[') {
            return self.input_call(id);
        }
        if name.is_empty() || name.contains(['"', '\'', '\n', '\r']) {
            return Err(invalid(doc, p, format!("`{name}` is not a signal name")));
        }
        Ok(format!("modbus_get_signal_status(\"{name}\", False)"))
    }

    fn input_call(&self, id: usize) -> Result<String, UrpError> {
        let (kind, n) = pin(self.doc, id)?;
        let f = match kind.as_str() {
            "digital_in" => "get_standard_digital_in",
            "configurable_in" | "config_in" => "get_configurable_digital_in",
            "tool_in" => "get_tool_digital_in",
            "digital_out" => "get_standard_digital_out",
            "configurable_out" | "config_out" => "get_configurable_digital_out",
            "tool_out" => "get_tool_digital_out",
            "analog_in" => "get_standard_analog_in",
            "tool_analog_in" => "get_tool_analog_in",
            _ => {
                return Err(unsupported(
                    self.doc,
                    id,
                    format!("waiting on pin {kind}[{n}]"),
                ))
            }
        };
        Ok(format!("{f}({n})"))
    }

    fn wait(&mut self, id: usize) -> Result<(), UrpError> {
        let doc = self.doc;
        let cond = match doc.attr(id, "type") {
            Some("Sleep") => {
                let t = self.text_of(id, "waitTime")?;
                let t = parse_f64(doc, id, "waitTime", &t)?;
                if t < 0.0 {
                    return Err(invalid(doc, id, "a negative wait time"));
                }
                self.line(&format!("sleep({})", num(t)));
                return Ok(());
            }
            Some("DigitalInput") => {
                let call = self.input_call(id)?;
                let v = self.text_of(id, "digitalValue")?;
                format!("{call} == {}", bool_text(doc, id, "digitalValue", &v)?)
            }
            Some("AnalogInput") => {
                let call = self.input_call(id)?;
                let v = self.text_of(id, "analogValue")?;
                let v = parse_f64(doc, id, "analogValue", &v)?;
                let op = match self.text_of(id, "analogComparison")?.as_str() {
                    "0" | "LESS" | "LessThan" => "<",
                    "1" | "GREATER" | "GreaterThan" => ">",
                    other => return Err(invalid(doc, id, format!("analogComparison `{other}`"))),
                };
                format!("{call} {op} {}", num(v))
            }
            Some("Expression" | "Condition") => self.expression(id)?,
            other => {
                return Err(unsupported(
                    doc,
                    id,
                    format!("wait type {}", other.unwrap_or("(none)")),
                ))
            }
        };
        self.block(&format!("while (not({cond})):"), |t| {
            t.line("sync()");
            Ok(())
        })
    }

    fn popup(&mut self, id: usize) -> Result<(), UrpError> {
        let doc = self.doc;
        let (title, warning, error) = match doc.attr(id, "type").unwrap_or("Message") {
            "Message" => ("Message", "False", "False"),
            "Warning" => ("Warning", "True", "False"),
            "Error" => ("Error", "False", "True"),
            other => return Err(unsupported(doc, id, format!("popup type {other}"))),
        };
        let message = match doc.attr(id, "message") {
            Some(m) => m.to_string(),
            None => doc
                .child(id, "message")
                .map(|m| doc.elems[m].text.clone())
                .unwrap_or_default(),
        };
        self.line(&format!(
            "popup({}, \"{title}\", {warning}, {error}, blocking=True)",
            string_literal(&message)
        ));
        if doc.attr(id, "haltProgram") == Some("true") {
            self.line("halt");
        }
        Ok(())
    }

    fn set(&mut self, id: usize) -> Result<(), UrpError> {
        let doc = self.doc;
        match doc.attr(id, "type") {
            Some("NoAction") => {
                for c in &doc.elems[id].children {
                    if matches!(
                        doc.name(*c),
                        "tcp" | "payload" | "payloadMass" | "centerOfGravity"
                    ) {
                        return Err(unsupported(
                            doc,
                            id,
                            "a Set node that sets the TCP or payload",
                        ));
                    }
                }
            }
            Some("DigitalOutput") => {
                let v = self.text_of(id, "digitalValue")?;
                let v = bool_text(doc, id, "digitalValue", &v)?;
                self.set_digital(id, v)?;
            }
            Some("AnalogOutput") => {
                let (kind, n) = pin(doc, id)?;
                if kind != "analog_out" {
                    return Err(unsupported(
                        doc,
                        id,
                        format!("analog output pin {kind}[{n}]"),
                    ));
                }
                let v = self.text_of(id, "analogValue")?;
                let v = parse_f64(doc, id, "analogValue", &v)?;
                self.line(&format!("set_standard_analog_out({n}, {})", num(v)));
            }
            Some("Expression") => {
                let value = self.expression(id)?;
                if doc.child(id, "pin").is_some() {
                    self.set_digital(id, &value)?;
                } else {
                    let name = self.variable_name(id)?;
                    self.line(&format!("global {name} = {value}"));
                }
            }
            other => {
                return Err(unsupported(
                    doc,
                    id,
                    format!("set type {}", other.unwrap_or("(none)")),
                ))
            }
        }
        Ok(())
    }

    fn set_digital(&mut self, id: usize, value: &str) -> Result<(), UrpError> {
        let (kind, n) = pin(self.doc, id)?;
        let f = match kind.as_str() {
            "digital_out" => "set_standard_digital_out",
            "configurable_out" | "config_out" => "set_configurable_digital_out",
            "tool_out" => "set_tool_digital_out",
            "analog_out" => "set_standard_analog_out",
            _ => {
                return Err(unsupported(
                    self.doc,
                    id,
                    format!("setting pin {kind}[{n}]"),
                ))
            }
        };
        self.line(&format!("{f}({n}, {value})"));
        Ok(())
    }

    fn motion(&mut self, id: usize) -> Result<(), UrpError> {
        let doc = self.doc;
        let kind = doc.attr(id, "motionType").unwrap_or("MoveJ");
        let f = match kind {
            "MoveJ" => "movej",
            "MoveL" => "movel",
            "MoveP" => "movep",
            other => return Err(unsupported(doc, id, format!("motion type {other}"))),
        };
        let joint = kind == "MoveJ";
        let speed = match doc.attr(id, "speed") {
            Some(s) => Some(parse_f64(doc, id, "speed", s)?),
            None => None,
        };
        let accel = match doc.attr(id, "acceleration") {
            Some(s) => Some(parse_f64(doc, id, "acceleration", s)?),
            None => None,
        };
        let shared_blend = match doc.attr(id, "blendRadius") {
            Some(s) => Some(parse_f64(doc, id, "blendRadius", s)?),
            None => None,
        };
        let Some(children) = doc.child(id, "children") else {
            return Ok(());
        };
        for &w in &doc.elems[children].children.clone() {
            let w = doc.resolve(w)?;
            if doc.name(w) != "Waypoint" {
                // PolyScope lets other nodes sit between a Move's waypoints.
                self.nodes(&[w])?;
                continue;
            }
            let variable = match doc.attr(w, "type") {
                None | Some("Fixed") => false,
                Some("Variable") => true,
                Some(other) => return Err(unsupported(doc, w, format!("a {other} waypoint"))),
            };
            let (mut v, mut a, mut r) = (speed, accel, shared_blend);
            if let Some(mp) = doc.child(w, "motionParameters") {
                let get = |key: &str| -> Result<Option<f64>, UrpError> {
                    match doc.attr(mp, key) {
                        Some(s) => Ok(Some(parse_f64(doc, mp, key, s)?)),
                        None => Ok(None),
                    }
                };
                let (vk, ak) = if joint {
                    ("jointSpeed", "jointAcceleration")
                } else {
                    ("cartesianSpeed", "cartesianAcceleration")
                };
                v = get(vk)?.or(v);
                a = get(ak)?.or(a);
                r = get("blendRadius")?.or(r);
            }
            let target = if variable {
                self.variable_name(w)?
            } else {
                self.waypoint_target(w, joint)?
            };
            let mut call = format!("{f}({target}");
            if let Some(a) = a {
                call.push_str(&format!(", a={}", num(a)));
            }
            if let Some(v) = v {
                call.push_str(&format!(", v={}", num(v)));
            }
            if let Some(r) = r.filter(|&r| r > 0.0) {
                call.push_str(&format!(", r={}", num(r)));
            }
            call.push(')');
            if let Some(n) = doc.attr(w, "name") {
                self.line(&format!("# {}", n.replace(['\n', '\r'], " ")));
            }
            self.line(&call);
        }
        Ok(())
    }

    /// The waypoint's target: joint angles for a MoveJ, a pose otherwise.
    fn waypoint_target(&self, w: usize, joint: bool) -> Result<String, UrpError> {
        let doc = self.doc;
        let p = doc
            .child(w, "position")
            .ok_or_else(|| invalid(doc, w, "no <position>"))?;
        let p = doc.resolve(p)?;
        // 5.x: <JointAngles angles=.../> <TCPOffset pose=.../>; older: attributes.
        let joints = match doc
            .child(p, "JointAngles")
            .and_then(|j| doc.attr(j, "angles"))
        {
            Some(a) => Some(vector6(doc, p, "joint angles", a)?),
            None => match doc.attr(p, "joints") {
                Some(a) => Some(vector6(doc, p, "joint angles", a)?),
                None => None,
            },
        };
        if joint {
            let q = joints.ok_or_else(|| invalid(doc, w, "the waypoint has no joint angles"))?;
            return Ok(list(&q));
        }
        if let Some(pose) = doc.attr(p, "pose") {
            return Ok(format!("p{}", list(&vector6(doc, p, "pose", pose)?)));
        }
        let q = joints
            .ok_or_else(|| invalid(doc, w, "the waypoint has neither pose nor joint angles"))?;
        let tcp = match doc.child(p, "TCPOffset").and_then(|t| doc.attr(t, "pose")) {
            Some(t) => vector6(doc, p, "TCP offset", t)?,
            None => [0.0; 6],
        };
        Ok(format!("get_forward_kin({}, p{})", list(&q), list(&tcp)))
    }

    fn loop_node(&mut self, id: usize) -> Result<(), UrpError> {
        let doc = self.doc;
        if doc.attr(id, "checkContinuously") == Some("true") {
            return match doc.attr(id, "type").unwrap_or("Forever") {
                "While" | "Expression" => self.watched_loop(id),
                other => Err(unsupported(
                    doc,
                    id,
                    format!("a {other} Loop checked continuously"),
                )),
            };
        }
        match doc.attr(id, "type").unwrap_or("Forever") {
            "Forever" => self.block("while (True):", |t| t.children_of(id)),
            "Counting" | "XTimes" => {
                let count = match doc.attr(id, "count") {
                    Some(c) => c.to_string(),
                    None => self.text_of(id, "count")?,
                };
                let n = count.trim().parse::<u32>().map_err(|_| {
                    invalid(doc, id, format!("loop count `{count}` is not a count"))
                })?;
                self.loops += 1;
                let var = format!("Loop_{}", self.loops);
                self.line(&format!("{var} = 0"));
                self.block(&format!("while ({var} < {n}):"), |t| {
                    t.children_of(id)?;
                    t.line(&format!("{var} = {var} + 1"));
                    Ok(())
                })
            }
            "While" | "Expression" => {
                let cond = self.expression(id)?;
                self.block(&format!("while ({cond}):"), |t| t.children_of(id))
            }
            other => Err(unsupported(doc, id, format!("loop type {other}"))),
        }
    }

    /// A `Loop type="While" checkContinuously="true"`: PolyScope runs its nodes in a
    /// thread, `Thread_while_K`, looped, while the loop's own thread checks the
    /// condition every cycle and kills the thread when it turns false. The thread is
    /// written at the program's top level (a loop inside a thread or a sub program
    /// would otherwise declare a thread inside a function).
    fn watched_loop(&mut self, id: usize) -> Result<(), UrpError> {
        let cond = self.expression(id)?;
        self.watched += 1;
        let k = self.watched;
        self.hoist(|tr| {
            tr.block(&format!("thread Thread_while_{k}():"), |tr| {
                tr.block("while (True):", |tr| tr.children_of(id))
            })
        })?;
        self.block(&format!("if ({cond}):"), |tr| {
            tr.line(&format!(
                "global thread_handler_{k} = run Thread_while_{k}()"
            ));
            tr.block(&format!("while ({cond}):"), |tr| {
                tr.line("sync()");
                Ok(())
            })?;
            tr.line(&format!("kill thread_handler_{k}"));
            Ok(())
        })
    }

    /// Writes what `f` writes at the program's top level ([`Translator::hoisted`]).
    fn hoist(&mut self, f: impl FnOnce(&mut Self) -> Result<(), UrpError>) -> Result<(), UrpError> {
        let outer = std::mem::take(&mut self.segments);
        let indent = std::mem::replace(&mut self.indent, 1);
        let done = f(self);
        let written = std::mem::replace(&mut self.segments, outer);
        self.indent = indent;
        done?;
        // Merged with the rest of the program's segments at the end: linear.
        self.hoisted.extend(written);
        Ok(())
    }

    /// An `If checkContinuously="true"` (without `ElseIf`/`Else`): PolyScope runs its
    /// nodes in a thread, `Thread_if_K`, that sets `thread_flag_K` to 1 when they are
    /// done; the If's own thread checks the condition every cycle until then, and kills
    /// the thread (flag 2) when it turns false. The thread is written at the program's
    /// top level, as for a While checked continuously.
    fn watched_if(&mut self, id: usize) -> Result<(), UrpError> {
        let cond = self.expression(id)?;
        self.watched += 1;
        let k = self.watched;
        self.hoist(|tr| {
            tr.block(&format!("thread Thread_if_{k}():"), |tr| {
                tr.children_of(id)?;
                tr.line(&format!("thread_flag_{k} = 1"));
                Ok(())
            })
        })?;
        self.line(&format!("global thread_flag_{k} = 0"));
        self.line(&format!("if ({cond}):"));
        self.indent += 1;
        self.line(&format!("global thread_handler_{k} = run Thread_if_{k}()"));
        self.block(&format!("while (thread_flag_{k} == 0):"), |tr| {
            tr.line(&format!("if not({cond}):"));
            tr.line(&format!("  kill thread_handler_{k}"));
            tr.line(&format!("  thread_flag_{k} = 2"));
            tr.line("else:");
            tr.line("  sync()");
            tr.line("end");
            Ok(())
        })?;
        self.indent -= 1;
        self.line("else:");
        self.line(&format!("  thread_flag_{k} = 2"));
        self.line("end");
        Ok(())
    }

    fn if_chain(&mut self, chain: &[usize]) -> Result<(), UrpError> {
        let doc = self.doc;
        if let [only] = chain {
            if doc.attr(*only, "checkContinuously") == Some("true") {
                return self.watched_if(*only);
            }
        }
        let mut seen_else = false;
        for (k, &b) in chain.iter().enumerate() {
            if doc.attr(b, "checkContinuously") == Some("true") {
                return Err(unsupported(
                    doc,
                    b,
                    "an If checked continuously with ElseIf or Else",
                ));
            }
            let head = match (k, doc.attr(b, "type").unwrap_or("If")) {
                _ if seen_else => return Err(invalid(doc, b, "a branch after Else")),
                (0, "If") => format!("if ({}):", self.expression(b)?),
                (_, "ElseIf") if k > 0 => format!("elif ({}):", self.expression(b)?),
                (_, "Else") if k > 0 => {
                    seen_else = true;
                    String::from("else:")
                }
                (_, other) => return Err(invalid(doc, b, format!("an If of type {other} here"))),
            };
            self.line(&head);
            self.indent += 1;
            self.children_of(b)?;
            self.indent -= 1;
        }
        self.line("end");
        Ok(())
    }

    /// An `InitVariablesNode`'s `<variables>`: each `<variable name>` with its
    /// `<expression>`, `global NAME = EXPR`.
    fn init_variables(&mut self, id: usize) -> Result<(), UrpError> {
        let doc = self.doc;
        let Some(vars) = doc.child(id, "variables") else {
            return Ok(());
        };
        for &v in &doc.elems[vars].children.clone() {
            let v = doc.resolve(v)?;
            if doc.name(v) != "variable" {
                return Err(unknown(doc, v));
            }
            let name = self.named_variable(v)?;
            let value = self.expression(v)?;
            self.line(&format!("global {name} = {value}"));
        }
        Ok(())
    }

    /// The program's `Thread` nodes: `thread NAME():`, its nodes in `while (True):`
    /// unless `runOnlyOnce="true"`, then `threadId_NAME = run NAME()` for each, in
    /// document order.
    fn threads(&mut self, threads: &[usize]) -> Result<(), UrpError> {
        let doc = self.doc;
        let mut names = std::collections::HashSet::new();
        let mut started = Vec::new();
        for (k, &t) in threads.iter().enumerate() {
            let t = doc.resolve(t)?;
            let name = match doc.attr(t, "name") {
                Some(n) if !n.trim().is_empty() => identifier(n.trim()),
                Some(_) => return Err(invalid(doc, t, "the thread's name is empty")),
                // PolyScope names its threads Thread_1, Thread_2, ...
                None => format!("Thread_{}", k + 1),
            };
            if !names.insert(name.clone()) || self.subprogram_names.contains(&name) {
                return Err(invalid(
                    doc,
                    t,
                    format!("two threads or sub programs named {name}"),
                ));
            }
            let forever = match doc.attr(t, "runOnlyOnce") {
                None | Some("false") => true,
                Some("true") => false,
                Some(other) => {
                    return Err(invalid(
                        doc,
                        t,
                        format!("runOnlyOnce `{other}` is not true/false"),
                    ))
                }
            };
            self.block(&format!("thread {name}():"), |tr| {
                if forever {
                    tr.block("while (True):", |tr| tr.children_of(t))
                } else {
                    tr.children_of(t)
                }
            })?;
            self.thread_names.push((name.clone(), t));
            started.push(name);
        }
        for name in started {
            self.line(&format!("threadId_{name} = run {name}()"));
        }
        Ok(())
    }

    /// A `Timer action="Start|Stop|Reset"` on its `<variable>`: the variable counts
    /// seconds in a thread while `NAME_is_counting` is `True` ([`Translator::timer_thread`]).
    fn timer(&mut self, id: usize) -> Result<(), UrpError> {
        let doc = self.doc;
        let name = self.variable_name(id)?;
        let line = match doc.attr(id, "action") {
            Some("Start") => format!("{name}_is_counting = True"),
            Some("Stop") => format!("{name}_is_counting = False"),
            Some("Reset") => format!("{name} = 0"),
            Some(other) => return Err(unsupported(doc, id, format!("timer action {other}"))),
            None => return Err(invalid(doc, id, "the timer has no action")),
        };
        if !self.timers.contains(&name) {
            self.timers.push(name);
        }
        self.line(&line);
        Ok(())
    }

    /// The timers' variables and the thread that counts them, as PolyScope writes
    /// them at the top of the program.
    fn timer_thread(&mut self) {
        self.indent = 1;
        let timers = self.timers.clone();
        for t in &timers {
            self.line(&format!("global {t} = 0"));
            self.line(&format!("global {t}_is_counting = False"));
        }
        self.line("thread Timer_Thread():");
        self.indent += 1;
        self.line("while (True):");
        self.indent += 1;
        for t in &timers {
            self.line(&format!("if ({t}_is_counting):"));
            self.line(&format!("  {t} = {t} + get_steptime()"));
            self.line("end");
        }
        self.line("sync()");
        self.indent -= 1;
        self.line("end");
        self.indent -= 1;
        self.line("end");
        self.line("run Timer_Thread()");
    }

    /// PolyScope 5's Home (`SafeHome`) node: a `movej` to the installation's home
    /// position. The node does not hold the position and the translator reads no
    /// installation: it is [`DEFAULT_HOME_JOINTS`], PolyScope's default home.
    fn safe_home(&mut self, id: usize) -> Result<(), UrpError> {
        let doc = self.doc;
        match doc.attr(id, "positionOptionType") {
            None | Some("SPEED_AND_ACCELERATION") => {}
            Some(other) => return Err(unsupported(doc, id, format!("a Home move with {other}"))),
        }
        let get = |key: &str| -> Result<Option<f64>, UrpError> {
            match doc.attr(id, key) {
                Some(v) => {
                    let v = parse_f64(doc, id, key, v)?;
                    if v <= 0.0 {
                        return Err(invalid(doc, id, format!("{key} `{v}` is not positive")));
                    }
                    Ok(Some(v))
                }
                None => Ok(None),
            }
        };
        let mut call = format!("movej({}", list(&DEFAULT_HOME_JOINTS));
        if let Some(a) = get("acceleration")? {
            call.push_str(&format!(", a={}", num(a)));
        }
        if let Some(v) = get("speed")? {
            call.push_str(&format!(", v={}", num(v)));
        }
        call.push(')');
        self.line("# Home");
        self.line(&call);
        Ok(())
    }

    fn contributed(&mut self, id: usize) -> Result<(), UrpError> {
        let doc = self.doc;
        let class = doc.attr(id, "strategyClass").unwrap_or("");
        let kind = doc.attr(id, "strategyProgramNodeType").unwrap_or("");
        if !class.to_ascii_lowercase().contains("externalcontrol") {
            let label = if kind.is_empty() { class } else { kind };
            return Err(UrpError::UnknownNode {
                name: format!("Contributed ({label})"),
                path: doc.path(id),
            });
        }
        let mut data = Vec::new();
        if let Some(m) = doc.child(id, "dataModel") {
            for &d in &doc.elems[m].children {
                if let (Some(k), Some(v)) = (doc.attr(d, "key"), doc.attr(d, "value")) {
                    data.push((k.to_string(), v.to_string()));
                }
            }
        }
        let get = |key: &str| data.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str());
        let host = match get("host_ip") {
            Some(h) => host_name(h).map_err(|m| invalid(doc, id, m))?,
            None => EXTERNAL_CONTROL_DEFAULT_HOST.to_string(),
        };
        let port = match get("port_nr") {
            Some(p) => p.trim().parse::<u16>().map_err(|_| {
                let p: String = p.chars().take(64).collect();
                invalid(doc, id, format!("port_nr `{p}` is not a port"))
            })?,
            None => EXTERNAL_CONTROL_DEFAULT_PORT,
        };
        let index = self.externals.len();
        if index >= MAX_EXTERNAL_CONTROL_NODES {
            return Err(invalid(
                doc,
                id,
                format!("more than {MAX_EXTERNAL_CONTROL_NODES} External Control nodes"),
            ));
        }
        let path = doc.path(id);
        // The record counts with the script.
        let record =
            path.len() + host.len() + data.iter().map(|(k, v)| k.len() + v.len()).sum::<usize>();
        self.written = self.written.saturating_add(record);
        self.within_bounds()?;
        self.externals.push(ExternalControlNode {
            index,
            path,
            host,
            port,
            data,
        });
        self.segments.push(Segment::External {
            index,
            indent: self.indent,
        });
        Ok(())
    }
}
