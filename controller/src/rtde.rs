//! The RTDE server (Real-Time Data Exchange, port 30004), sans-IO: one [`RtdeSession`]
//! per client connection, fed the bytes received, drained of the bytes to send, and
//! stepped with the controller's [`Status`] and the time.
//!
//! Written from UR's "Real-Time Data Exchange (RTDE) Guide". Every packet is
//! `u16 size` (big-endian, the 3-byte header included), `u8 type`, then the payload;
//! every number is big-endian.
//!
//! | type | name | client sends | server answers |
//! |---|---|---|---|
//! | `V` 86 | REQUEST_PROTOCOL_VERSION | `u16` version | `u8` accepted (1 for versions 1 and 2, else 0) |
//! | `v` 118 | GET_URCONTROL_VERSION | nothing (a payload is ignored) | `u32` major, minor, bugfix, build ([`Config::polyscope`]) |
//! | `M` 77 | TEXT_MESSAGE | v1: `u8` level, text; v2: `u8` length, text, `u8` length, source, `u8` level | nothing ([`RtdeEvent::TextMessage`]) |
//! | `O` 79 | CONTROL_PACKAGE_SETUP_OUTPUTS | v2: `f64` frequency, then names; v1: names | v2: `u8` recipe id, types; v1: types |
//! | `I` 73 | CONTROL_PACKAGE_SETUP_INPUTS | names | `u8` recipe id, types |
//! | `S` 83 | CONTROL_PACKAGE_START | nothing | `u8` accepted |
//! | `P` 80 | CONTROL_PACKAGE_PAUSE | nothing | `u8` accepted (always 1) |
//! | `U` 85 | DATA_PACKAGE | `u8` recipe id, the input values | the outputs, while started: v2 `u8` recipe id then values; v1 values only |
//!
//! Names are comma-separated (one trailing comma is allowed, as `ur_rtde` sends it),
//! types likewise (`DOUBLE,VECTOR6D,NOT_FOUND`). Text
//! levels: 0 exception, 1 error, 2 warning, 3 info ([`RtdeTextLevel`]). Until the client
//! negotiates a version the session speaks protocol 1.
//!
//! # Fields
//!
//! The field names, their types, the controller versions that gate them and how each
//! output is read are the one table of [`urscript_interp::rtde_fields`], which the
//! interpreter's `get_rtde_value` and `rtde_set_watchdog` use as well. [`rtde_output_type`]
//! and [`rtde_input_type`] give a name's type for a controller version. Outputs are read
//! from [`Status`] (its [`RtdeSource`] implementation); `actual_execution_time` is 0.3
//! (ms). Register names are spelled exactly (`input_int_register_5`; `_05`, `_+5` are
//! `NOT_FOUND`), as the table's one name rule says.
//!
//! # Setup, ownership and recipes
//!
//! - An output setup with a name the controller does not know answers the type list
//!   with `NOT_FOUND` at that place and recipe id 0: no recipe is made. The same for a
//!   v2 frequency outside `(0, max]` (500 Hz on e-Series, `Config::major() >= 5`, 125 Hz
//!   on CB3), reported as [`RtdeError::Frequency`].
//! - An input setup answers `IN_USE` for a field another session owns (the shared
//!   [`InputRegistry`]), `NOT_FOUND` for unknown names; either makes recipe id 0 and
//!   claims nothing. A successful input setup claims its fields for the session until
//!   [`RtdeSession::close`]. A session may set the same field up in several recipes.
//! - Output and input recipe ids count separately from 1 in each session (v2). In v1
//!   there is one output recipe: a new setup replaces it. At most
//!   [`RTDE_MAX_OUTPUT_RECIPES`] output and [`RTDE_MAX_INPUT_RECIPES`] input recipes per session,
//!   [`RTDE_MAX_FIELDS`] fields per recipe, a data package within [`RTDE_MAX_PACKET_SIZE`]:
//!   beyond, recipe id 0 (an empty type list for too many names or a payload not UTF-8).
//! - Setups are accepted while started as well. START answers 1 when the session has
//!   at least one recipe (output or input), else 0; PAUSE always answers 1.
//! - Input DATA_PACKAGEs are accepted whether started or not (`ur_rtde`'s
//!   `RTDEIOInterface` writes its inputs without ever sending START). Masks and values latch
//!   per session: a recipe carrying `standard_digital_output` without its mask uses the
//!   last mask this session sent (0 at first), and likewise for the speed slider, the
//!   configurable and tool outputs, the analog outputs and the payload.
//!
//! # Timing
//!
//! [`RtdeSession::on_step`] emits, while started, one DATA_PACKAGE per output recipe
//! whose time has come: the first at the first step after START, then every
//! `1/frequency` seconds, computed in whole nanoseconds from `now` so that calling it
//! every 2 ms gives exactly 500 packages a second at 500 Hz and 125 at 125 Hz. When the
//! caller falls behind, one package is sent and the missed ones are skipped, as the
//! controller does when it lacks time. Protocol 1 recipes run at the controller's full
//! rate.
//!
//! # Errors and bounds
//!
//! A packet whose size is below 3 (the header's own) cannot be framed past:
//! [`RtdeSession::handle_received`] returns the error and the caller should close the
//! connection (every later call returns the same error). Other faults (an unknown type,
//! a payload of the wrong length, a data package for no recipe) skip that one packet,
//! queue [`RtdeEvent::Error`] and send the client an error text message. The input
//! buffer holds at most one incomplete packet ([`RTDE_MAX_PACKET_SIZE`] bytes); events are
//! kept up to [`RTDE_MAX_EVENTS`] (the oldest dropped first). Data packages are not queued
//! while the outbox holds [`RTDE_MAX_OUTBOX`] bytes or more (counted by
//! [`RtdeSession::skipped_packages`]); a reply that finds it that full is
//! [`RtdeError::OutboxFull`], fatal.

use std::collections::{BTreeMap, VecDeque};
use std::fmt;
use std::time::Duration;

use crate::state::{Config, ProgramState};
use crate::status::{Inputs, Status};
use urscript_interp::kinematics::Dh;
use urscript_interp::rtde_fields::{Direction, Field, Input, RtdeSource};

/// The largest packet, in bytes, the header included: every size the header's `uint16`
/// can give. A controller takes setups this large (UR's Client Library sets up all 406
/// PolyScope 5 outputs in one 9184-byte packet), so none is refused for its size; the
/// session buffers at most one such packet. Replies and data packages are bounded to
/// it by refusing recipes whose package would be larger.
pub const RTDE_MAX_PACKET_SIZE: usize = u16::MAX as usize;
/// The most fields in one recipe: five times the 406 outputs PolyScope 5 names, so any
/// recipe of real names fits; it bounds the per-field tables of a setup (its type list
/// reply stays within a packet: 2048 `NOT_FOUND,` are 20 KiB).
pub const RTDE_MAX_FIELDS: usize = 2048;
/// The most output recipes one session may set up.
pub const RTDE_MAX_OUTPUT_RECIPES: usize = 16;
/// The most input recipes one session may set up.
pub const RTDE_MAX_INPUT_RECIPES: usize = 64;
/// The most events kept for [`RtdeSession::poll_event`]; older ones are dropped.
pub const RTDE_MAX_EVENTS: usize = 1024;
/// While the outbox holds this many bytes, no data package is added.
pub const RTDE_MAX_OUTBOX: usize = 1 << 20;

/// REQUEST_PROTOCOL_VERSION, `V`.
pub const RTDE_REQUEST_PROTOCOL_VERSION: u8 = b'V';
/// GET_URCONTROL_VERSION, `v`.
pub const RTDE_GET_URCONTROL_VERSION: u8 = b'v';
/// TEXT_MESSAGE, `M`.
pub const RTDE_TEXT_MESSAGE: u8 = b'M';
/// DATA_PACKAGE, `U`.
pub const RTDE_DATA_PACKAGE: u8 = b'U';
/// CONTROL_PACKAGE_SETUP_OUTPUTS, `O`.
pub const RTDE_SETUP_OUTPUTS: u8 = b'O';
/// CONTROL_PACKAGE_SETUP_INPUTS, `I`.
pub const RTDE_SETUP_INPUTS: u8 = b'I';
/// CONTROL_PACKAGE_START, `S`.
pub const RTDE_START: u8 = b'S';
/// CONTROL_PACKAGE_PAUSE, `P`.
pub const RTDE_PAUSE: u8 = b'P';

pub use urscript_interp::rtde_fields::{RtdeType, RtdeValue};

/// A big-endian reader that never panics: every read is `None` past the end.
struct Reader<'a>(&'a [u8]);

impl<'a> Reader<'a> {
    fn u8(&mut self) -> Option<u8> {
        let (&b, rest) = self.0.split_first()?;
        self.0 = rest;
        Some(b)
    }
    fn bytes(&mut self, n: usize) -> Option<&'a [u8]> {
        if n > self.0.len() {
            return None;
        }
        let (head, rest) = self.0.split_at(n);
        self.0 = rest;
        Some(head)
    }
}

/// The level of a text message.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum RtdeTextLevel {
    /// 0.
    Exception,
    /// 1.
    Error,
    /// 2.
    Warning,
    /// 3.
    Info,
}

impl RtdeTextLevel {
    /// Its code on the wire.
    pub fn code(self) -> u8 {
        match self {
            RtdeTextLevel::Exception => 0,
            RtdeTextLevel::Error => 1,
            RtdeTextLevel::Warning => 2,
            RtdeTextLevel::Info => 3,
        }
    }
}

/// A fault in what the client sent. The framing error [`RtdeError::SizeTooSmall`]
/// and [`RtdeError::OutboxFull`] and [`RtdeError::Closed`]
/// are fatal: [`RtdeSession::handle_received`] returns them. The others skip one packet
/// and are reported as [`RtdeEvent::Error`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum RtdeError {
    /// A packet header gave a size below 3 (the header's own size).
    SizeTooSmall {
        /// The size given.
        size: u16,
    },
    /// A packet type the server does not know.
    UnknownType {
        /// The type byte.
        packet_type: u8,
    },
    /// A payload of the wrong length or shape for its type.
    BadPayload {
        /// The packet type.
        packet_type: u8,
        /// What was wrong.
        reason: &'static str,
    },
    /// A setup listed more than [`RTDE_MAX_FIELDS`] fields, or a recipe's data package
    /// would be larger than [`RTDE_MAX_PACKET_SIZE`] (2048 fields of six doubles are).
    TooManyFields {
        /// How many.
        count: usize,
    },
    /// The session already has its most recipes of that kind.
    TooManyRecipes,
    /// A v2 output frequency outside `(0, max]`.
    Frequency {
        /// The frequency asked, in Hz (its bits, to keep `Eq`: `f64::from_bits`).
        bits: u64,
        /// The controller's maximum, in Hz.
        max: u32,
    },
    /// An input data package arrived before any input recipe was set up.
    NoInputRecipe,
    /// An input data package named a recipe id that does not exist.
    NoSuchRecipe {
        /// The id.
        recipe: u8,
    },
    /// An input data package's length did not match its recipe.
    DataLength {
        /// The recipe id.
        recipe: u8,
        /// The payload length the recipe needs (with the id byte).
        expected: usize,
        /// The payload length received.
        got: usize,
    },
    /// The outbox held [`RTDE_MAX_OUTBOX`] bytes or more when a reply was due: the caller
    /// does not drain it (or the client does not read).
    OutboxFull,
    /// The session was closed.
    Closed,
}

impl RtdeError {
    /// Whether the connection cannot go on.
    pub fn is_fatal(&self) -> bool {
        matches!(
            self,
            RtdeError::SizeTooSmall { .. } | RtdeError::OutboxFull | RtdeError::Closed
        )
    }
}

impl fmt::Display for RtdeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RtdeError::SizeTooSmall { size } => {
                write!(f, "packet size {size} is below the 3-byte header")
            }
            RtdeError::UnknownType { packet_type } => {
                write!(f, "unknown package type {packet_type}")
            }
            RtdeError::BadPayload {
                packet_type,
                reason,
            } => write!(f, "bad payload for package type {packet_type}: {reason}"),
            RtdeError::TooManyFields { count } => {
                write!(f, "a recipe of {count} fields is too large")
            }
            RtdeError::TooManyRecipes => f.write_str("too many recipes"),
            RtdeError::Frequency { bits, max } => write!(
                f,
                "output frequency {} Hz is not within (0, {max}]",
                f64::from_bits(*bits)
            ),
            RtdeError::NoInputRecipe => f.write_str("data package before any input setup"),
            RtdeError::NoSuchRecipe { recipe } => write!(f, "no input recipe {recipe}"),
            RtdeError::DataLength {
                recipe,
                expected,
                got,
            } => write!(
                f,
                "data package for recipe {recipe} has {got} bytes, {expected} expected"
            ),
            RtdeError::OutboxFull => f.write_str("the outbox is full"),
            RtdeError::Closed => f.write_str("the session is closed"),
        }
    }
}

impl std::error::Error for RtdeError {}

/// Something a session did or received, for the caller to log or act on.
#[derive(Debug, Clone, PartialEq)]
// `Inputs` is applied by value as it comes, one event per input package; boxing it
// would cost an allocation per package for no gain.
#[allow(clippy::large_enum_variant)]
pub enum RtdeEvent {
    /// The client asked for a protocol version.
    ProtocolVersion {
        /// The version asked.
        requested: u16,
        /// Whether it was accepted.
        accepted: bool,
    },
    /// The client set up an output recipe (`recipe` 0: refused).
    OutputSetup {
        /// The recipe id answered, 0 when refused.
        recipe: u8,
        /// The frequency in Hz (protocol 1: the controller's full rate).
        frequency: f64,
        /// The names asked.
        fields: Vec<String>,
        /// The types answered (`NOT_FOUND` included).
        types: Vec<String>,
    },
    /// The client set up an input recipe (`recipe` 0: refused).
    InputSetup {
        /// The recipe id answered, 0 when refused.
        recipe: u8,
        /// The names asked.
        fields: Vec<String>,
        /// The types answered (`NOT_FOUND`, `IN_USE` included).
        types: Vec<String>,
    },
    /// The client asked to start.
    Started {
        /// Whether it was accepted (it needs a recipe).
        accepted: bool,
    },
    /// The client paused.
    Paused,
    /// The client sent an input data package: apply `inputs` at the next step.
    Inputs {
        /// The recipe id.
        recipe: u8,
        /// What to apply.
        inputs: Inputs,
        /// Fields accepted that [`Inputs`] has no place for (`external_force_torque`),
        /// with their values.
        unapplied: Vec<(String, RtdeValue)>,
    },
    /// The client sent a text message.
    TextMessage {
        /// The level (0 exception, 1 error, 2 warning, 3 info; any byte as sent).
        level: u8,
        /// The text (lossy UTF-8).
        message: String,
        /// The source (protocol 2; empty in 1).
        source: String,
    },
    /// A fault in what the client sent (the packet was skipped, or the connection must
    /// close when [`RtdeError::is_fatal`]).
    Error(RtdeError),
}

/// The field `name` in `direction` if the controller of `version` has it.
fn lookup(name: &str, direction: Direction, version: [u32; 4]) -> Option<Field> {
    Field::lookup(name, direction).filter(|f| f.since().allows(version))
}

/// The controller version `[major, minor, bugfix, build]` of [`Config::polyscope`]
/// (`5.21.0` -> `[5, 21, 0, 0]`; a part that is not a number reads 0).
pub fn rtde_controller_version(config: &Config) -> [u32; 4] {
    let mut v = [0u32; 4];
    for (slot, part) in v.iter_mut().zip(config.polyscope.split('.')) {
        *slot = part.trim().parse().unwrap_or(0);
    }
    if v[0] == 0 {
        v[0] = config.major();
    }
    v
}

/// The type of output field `name` on the controller `config` describes, or `None`
/// when it does not know it (the setup answers `NOT_FOUND`).
pub fn rtde_output_type(name: &str, config: &Config) -> Option<RtdeType> {
    lookup(name, Direction::Output, rtde_controller_version(config)).map(Field::rtde_type)
}

/// The type of input field `name` on the controller `config` describes, or `None`.
pub fn rtde_input_type(name: &str, config: &Config) -> Option<RtdeType> {
    lookup(name, Direction::Input, rtde_controller_version(config)).map(Field::rtde_type)
}

/// The highest output frequency of the controller: 500 Hz on e-Series (major 5 and
/// later), 125 Hz on CB3.
pub fn rtde_max_frequency(config: &Config) -> u32 {
    if config.major() >= 5 {
        500
    } else {
        125
    }
}

/// Which session owns each input field, shared by every session of one controller: a
/// field set up by one client answers `IN_USE` to the others until the owner's
/// [`RtdeSession::close`]. Plain data: the caller keeps it where its sessions are
/// (behind its own lock if they run on several threads).
#[derive(Debug, Default, Clone)]
pub struct InputRegistry {
    owners: BTreeMap<Field, u64>,
    next_session: u64,
}

impl InputRegistry {
    /// An empty registry.
    pub fn new() -> Self {
        InputRegistry::default()
    }

    /// How many input fields are owned.
    pub fn owned(&self) -> usize {
        self.owners.len()
    }

    /// The id of the session that owns input field `name`, if any.
    pub fn owner(&self, name: &str) -> Option<u64> {
        let f = Field::lookup(name, Direction::Input)?;
        self.owners.get(&f).copied()
    }

    fn release(&mut self, session: u64) {
        self.owners.retain(|_, owner| *owner != session);
    }
}

struct OutputRecipe {
    id: u8,
    fields: Vec<Field>,
    /// Nanoseconds between packages.
    period: u128,
    /// When the next package is due (nanoseconds); `None` until the first step after
    /// RTDE_START.
    due: Option<u128>,
}

struct InputRecipe {
    id: u8,
    fields: Vec<(Field, RtdeType, String)>,
    /// The payload length of its data packages, the id byte included.
    len: usize,
}

/// The values that latch per session between input packages (masks and the parts of
/// grouped outputs).
#[derive(Debug, Clone, Default)]
struct Latched {
    speed_mask: u32,
    speed_fraction: f64,
    standard_do: (u8, u8),
    configurable_do: (u8, u8),
    tool_do: (u8, u8),
    analog_mask: u8,
    analog_types: u8,
    analog: [f64; 2],
    payload_mass: f64,
    payload_cog: [f64; 3],
    payload_inertia: Option<[f64; 6]>,
}

/// One RTDE client connection, sans-IO.
///
/// Feed it what the client sent ([`RtdeSession::handle_received`]), call
/// [`RtdeSession::on_step`] every controller step, write out what
/// [`RtdeSession::take_outbox`] returns, and poll its events; [`RtdeSession::close`]
/// when the connection ends.
///
/// ```
/// use std::time::Duration;
/// use urscript_controller::{Config, InputRegistry, RtdeEvent, RtdeSession, Status};
///
/// let config = Config::default(); // PolyScope 5.23: e-Series, 500 Hz
/// let mut registry = InputRegistry::new();
/// let mut session = RtdeSession::new(&config, &mut registry);
///
/// fn packet(ty: u8, payload: &[u8]) -> Vec<u8> {
///     let mut p = ((payload.len() + 3) as u16).to_be_bytes().to_vec();
///     p.push(ty);
///     p.extend_from_slice(payload);
///     p
/// }
/// // Protocol 2, then an output recipe of `timestamp` at 125 Hz, then start.
/// session.handle_received(&mut registry, &packet(b'V', &2u16.to_be_bytes()))?;
/// let mut setup = 125.0f64.to_be_bytes().to_vec();
/// setup.extend_from_slice(b"timestamp");
/// session.handle_received(&mut registry, &packet(b'O', &setup))?;
/// session.handle_received(&mut registry, &packet(b'S', &[]))?;
/// let replies = session.take_outbox();
/// assert_eq!(replies, [
///     packet(b'V', &[1]),
///     packet(b'O', b"\x01DOUBLE"),
///     packet(b'S', &[1]),
/// ].concat());
///
/// // One data package every 8 ms.
/// let status = Status { time: 1.5, ..Status::default() };
/// for step in 0..8 {
///     session.on_step(&status, Duration::from_millis(2 * step));
/// }
/// let mut data = vec![1u8];
/// data.extend_from_slice(&1.5f64.to_be_bytes());
/// assert_eq!(session.take_outbox(), [packet(b'U', &data), packet(b'U', &data)].concat());
///
/// assert!(matches!(session.poll_event(), Some(RtdeEvent::ProtocolVersion { accepted: true, .. })));
/// session.close(&mut registry);
/// # Ok::<(), urscript_controller::RtdeError>(())
/// ```
pub struct RtdeSession {
    id: u64,
    version: [u32; 4],
    max_hz: u32,
    protocol: u16,
    inbuf: Vec<u8>,
    outbox: Vec<u8>,
    events: VecDeque<RtdeEvent>,
    outputs: Vec<OutputRecipe>,
    inputs: Vec<InputRecipe>,
    next_output: u8,
    next_input: u8,
    started: bool,
    fatal: Option<RtdeError>,
    latched: Latched,
    skipped: u64,
    dropped_events: u64,
}

impl fmt::Debug for RtdeSession {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("RtdeSession")
            .field("id", &self.id)
            .field("protocol", &self.protocol)
            .field("started", &self.started)
            .field("output_recipes", &self.outputs.len())
            .field("input_recipes", &self.inputs.len())
            .field("fatal", &self.fatal)
            .finish_non_exhaustive()
    }
}

/// The bytes of one packet.
#[cfg(test)]
fn packet(ty: u8, payload: &[u8]) -> Vec<u8> {
    let mut p = Vec::with_capacity(payload.len() + 3);
    push_packet(&mut p, ty, payload);
    p
}

fn push_packet(out: &mut Vec<u8>, ty: u8, payload: &[u8]) {
    let size = u16::try_from(payload.len() + 3).unwrap_or(u16::MAX);
    out.extend_from_slice(&size.to_be_bytes());
    out.push(ty);
    out.extend_from_slice(payload);
}

/// `text` cut to at most `max` bytes on a character boundary.
fn cut(text: &str, max: usize) -> &str {
    if text.len() <= max {
        return text;
    }
    let mut end = max;
    while end > 0 && !text.is_char_boundary(end) {
        end -= 1;
    }
    text.get(..end).unwrap_or("")
}

impl RtdeSession {
    /// A new session for a client of the controller `config` describes (its version
    /// answers GET_URCONTROL_VERSION and decides the fields and the maximum
    /// frequency), with an id from `registry`.
    pub fn new(config: &Config, registry: &mut InputRegistry) -> Self {
        registry.next_session = registry.next_session.wrapping_add(1);
        RtdeSession {
            id: registry.next_session,
            version: rtde_controller_version(config),
            max_hz: rtde_max_frequency(config),
            protocol: 1,
            inbuf: Vec::new(),
            outbox: Vec::new(),
            events: VecDeque::new(),
            outputs: Vec::new(),
            inputs: Vec::new(),
            next_output: 1,
            next_input: 1,
            started: false,
            fatal: None,
            latched: Latched::default(),
            skipped: 0,
            dropped_events: 0,
        }
    }

    /// The session's id (the owner [`InputRegistry::owner`] names).
    pub fn id(&self) -> u64 {
        self.id
    }

    /// The protocol version in use (1 until the client negotiates 2).
    pub fn protocol_version(&self) -> u16 {
        self.protocol
    }

    /// Whether data synchronisation is started.
    pub fn is_started(&self) -> bool {
        self.started
    }

    /// How many output recipes are set up.
    pub fn output_recipes(&self) -> usize {
        self.outputs.len()
    }

    /// How many input recipes are set up.
    pub fn input_recipes(&self) -> usize {
        self.inputs.len()
    }

    /// The fatal error that ended the session, if any.
    pub fn fatal_error(&self) -> Option<&RtdeError> {
        self.fatal.as_ref()
    }

    /// How many data packages were not queued because the outbox was full.
    pub fn skipped_packages(&self) -> u64 {
        self.skipped
    }

    /// How many events were dropped because nobody polled them.
    pub fn dropped_events(&self) -> u64 {
        self.dropped_events
    }

    /// The bytes waiting to be sent.
    pub fn outbox(&self) -> &[u8] {
        &self.outbox
    }

    /// Take the bytes to send, emptying the outbox.
    pub fn take_outbox(&mut self) -> Vec<u8> {
        std::mem::take(&mut self.outbox)
    }

    /// The next event, oldest first.
    pub fn poll_event(&mut self) -> Option<RtdeEvent> {
        self.events.pop_front()
    }

    fn event(&mut self, e: RtdeEvent) {
        if self.events.len() >= RTDE_MAX_EVENTS {
            self.events.pop_front();
            self.dropped_events += 1;
        }
        self.events.push_back(e);
    }

    /// Queue a reply packet; fatal when the outbox is over its bound.
    fn reply(&mut self, ty: u8, payload: &[u8]) -> Result<(), RtdeError> {
        if self.outbox.len() >= RTDE_MAX_OUTBOX {
            return Err(RtdeError::OutboxFull);
        }
        push_packet(&mut self.outbox, ty, payload);
        Ok(())
    }

    /// Send the client a text message in its protocol version's layout: v1 the level
    /// then the text (at most [`RTDE_MAX_PACKET_SIZE`] bytes); v2 the text's length, the
    /// text, the source's length, the source and the level (each cut to 255 bytes on a
    /// character boundary). Not queued while the outbox holds [`RTDE_MAX_OUTBOX`] bytes.
    pub fn send_text(&mut self, level: RtdeTextLevel, message: &str, source: &str) {
        if self.outbox.len() >= RTDE_MAX_OUTBOX {
            return;
        }
        let mut p = Vec::new();
        if self.protocol >= 2 {
            let m = cut(message, 255);
            let s = cut(source, 255);
            p.push(m.len() as u8);
            p.extend_from_slice(m.as_bytes());
            p.push(s.len() as u8);
            p.extend_from_slice(s.as_bytes());
            p.push(level.code());
        } else {
            p.push(level.code());
            p.extend_from_slice(cut(message, RTDE_MAX_PACKET_SIZE - 4).as_bytes());
        }
        push_packet(&mut self.outbox, RTDE_TEXT_MESSAGE, &p);
    }

    /// A non-fatal fault: an event, and an error text message to the client.
    fn fault(&mut self, e: RtdeError) {
        self.send_text(RtdeTextLevel::Error, &e.to_string(), "RTDE");
        self.event(RtdeEvent::Error(e));
    }

    /// Feed bytes received from the client, in pieces of any size: every complete
    /// packet is answered into the outbox, events are queued. Returns a fatal error
    /// (also queued as an event, and returned again by every later call) when the
    /// stream cannot be read on: the caller should close the connection.
    pub fn handle_received(
        &mut self,
        registry: &mut InputRegistry,
        mut bytes: &[u8],
    ) -> Result<(), RtdeError> {
        if let Some(e) = &self.fatal {
            return Err(e.clone());
        }
        while !bytes.is_empty() {
            let want = if self.inbuf.len() < 3 {
                3 - self.inbuf.len()
            } else {
                let size = self.header_size();
                size.saturating_sub(self.inbuf.len())
            };
            let n = want.min(bytes.len());
            let (head, rest) = bytes.split_at(n);
            self.inbuf.extend_from_slice(head);
            bytes = rest;
            if self.inbuf.len() == 3 {
                let size = self.header_size();
                if size < 3 {
                    let e = RtdeError::SizeTooSmall { size: size as u16 };
                    return Err(self.die(e));
                }
            }
            if self.inbuf.len() >= 3 && self.inbuf.len() == self.header_size() {
                let p = std::mem::take(&mut self.inbuf);
                let ty = p.get(2).copied().unwrap_or(0);
                let payload = p.get(3..).unwrap_or(&[]);
                if let Err(e) = self.handle_packet(registry, ty, payload) {
                    return Err(self.die(e));
                }
                self.inbuf = p;
                self.inbuf.clear();
            }
        }
        Ok(())
    }

    fn die(&mut self, e: RtdeError) -> RtdeError {
        self.fatal = Some(e.clone());
        self.started = false;
        self.inbuf.clear();
        self.event(RtdeEvent::Error(e.clone()));
        e
    }

    fn header_size(&self) -> usize {
        match self.inbuf.first_chunk::<2>() {
            Some(b) => usize::from(u16::from_be_bytes(*b)),
            None => 0,
        }
    }

    fn handle_packet(
        &mut self,
        registry: &mut InputRegistry,
        ty: u8,
        payload: &[u8],
    ) -> Result<(), RtdeError> {
        match ty {
            RTDE_REQUEST_PROTOCOL_VERSION => {
                let requested = match payload.first_chunk::<2>() {
                    Some(b) if payload.len() == 2 => u16::from_be_bytes(*b),
                    _ => {
                        self.event(RtdeEvent::Error(RtdeError::BadPayload {
                            packet_type: ty,
                            reason: "a protocol version is a u16",
                        }));
                        return self.reply(ty, &[0]);
                    }
                };
                let accepted = requested == 1 || requested == 2;
                if accepted {
                    self.protocol = requested;
                }
                self.event(RtdeEvent::ProtocolVersion {
                    requested,
                    accepted,
                });
                self.reply(ty, &[u8::from(accepted)])
            }
            RTDE_GET_URCONTROL_VERSION => {
                let mut p = Vec::with_capacity(16);
                for v in self.version {
                    p.extend_from_slice(&v.to_be_bytes());
                }
                self.reply(ty, &p)
            }
            RTDE_TEXT_MESSAGE => {
                self.text_message(payload);
                Ok(())
            }
            RTDE_SETUP_OUTPUTS => self.setup_outputs(payload),
            RTDE_SETUP_INPUTS => self.setup_inputs(registry, payload),
            RTDE_START => {
                let accepted = !(self.outputs.is_empty() && self.inputs.is_empty());
                if accepted {
                    self.started = true;
                    for r in &mut self.outputs {
                        r.due = None;
                    }
                }
                self.event(RtdeEvent::Started { accepted });
                self.reply(ty, &[u8::from(accepted)])
            }
            RTDE_PAUSE => {
                self.started = false;
                self.event(RtdeEvent::Paused);
                self.reply(ty, &[1])
            }
            RTDE_DATA_PACKAGE => {
                self.input_data(payload);
                Ok(())
            }
            other => {
                self.fault(RtdeError::UnknownType { packet_type: other });
                Ok(())
            }
        }
    }

    fn text_message(&mut self, payload: &[u8]) {
        let parsed = if self.protocol >= 2 {
            let mut r = Reader(payload);
            (|| {
                let n = usize::from(r.u8()?);
                let m = r.bytes(n)?;
                let n = usize::from(r.u8()?);
                let s = r.bytes(n)?;
                let level = r.u8()?;
                r.0.is_empty().then_some((level, m, s))
            })()
        } else {
            payload.split_first().map(|(level, m)| (*level, m, &[][..]))
        };
        match parsed {
            Some((level, m, s)) => self.event(RtdeEvent::TextMessage {
                level,
                message: String::from_utf8_lossy(m).into_owned(),
                source: String::from_utf8_lossy(s).into_owned(),
            }),
            None => self.fault(RtdeError::BadPayload {
                packet_type: RTDE_TEXT_MESSAGE,
                reason: "text message lengths do not match its size",
            }),
        }
    }

    /// Split a setup's names, or the error that refuses it.
    fn names(payload: &[u8]) -> Result<Vec<String>, RtdeError> {
        let text = std::str::from_utf8(payload).map_err(|_| RtdeError::BadPayload {
            packet_type: RTDE_SETUP_OUTPUTS,
            reason: "names are not UTF-8",
        })?;
        // A trailing comma ends the list (ur_rtde sends `a,b,c,`); an empty list or an
        // empty name elsewhere stays a name, NOT_FOUND.
        let text = text.strip_suffix(',').unwrap_or(text);
        let count = text.split(',').count();
        if count > RTDE_MAX_FIELDS {
            return Err(RtdeError::TooManyFields { count });
        }
        Ok(text.split(',').map(str::to_string).collect())
    }

    fn setup_outputs(&mut self, payload: &[u8]) -> Result<(), RtdeError> {
        let v2 = self.protocol >= 2;
        let (frequency, names) = if v2 {
            match payload.split_first_chunk::<8>() {
                Some((f, rest)) => (f64::from_be_bytes(*f), rest),
                None => {
                    self.fault(RtdeError::BadPayload {
                        packet_type: RTDE_SETUP_OUTPUTS,
                        reason: "a v2 output setup starts with a f64 frequency",
                    });
                    return self.reply(RTDE_SETUP_OUTPUTS, &[0]);
                }
            }
        } else {
            (f64::from(self.max_hz), payload)
        };
        let names = match Self::names(names) {
            Ok(n) => n,
            Err(e) => {
                self.fault(e);
                return self.reply(RTDE_SETUP_OUTPUTS, if v2 { &[0] } else { &[] });
            }
        };
        let mut fields = Vec::with_capacity(names.len());
        let mut types = Vec::with_capacity(names.len());
        // The data package: its recipe id, then the fields.
        let mut len = 1usize;
        for n in &names {
            match lookup(n, Direction::Output, self.version) {
                Some(out) => {
                    let ty = out.rtde_type();
                    len += ty.size();
                    fields.push(out);
                    types.push(ty.name().to_string());
                }
                None => types.push("NOT_FOUND".to_string()),
            }
        }
        let mut ok = fields.len() == names.len();
        if ok && len + 3 > RTDE_MAX_PACKET_SIZE {
            self.fault(RtdeError::TooManyFields { count: names.len() });
            ok = false;
        }
        let max = f64::from(self.max_hz);
        if ok && !(frequency > 0.0 && frequency <= max) {
            self.fault(RtdeError::Frequency {
                bits: frequency.to_bits(),
                max: self.max_hz,
            });
            ok = false;
        }
        if ok && v2 && self.outputs.len() >= RTDE_MAX_OUTPUT_RECIPES {
            self.fault(RtdeError::TooManyRecipes);
            ok = false;
        }
        let mut id = 0;
        if ok {
            // Whole nanoseconds: 500 Hz is 2 000 000, 125 Hz 8 000 000.
            let period = (1e9 / frequency).round().max(1.0) as u128;
            if v2 {
                id = self.next_output;
                self.next_output = self.next_output.wrapping_add(1).max(1);
            } else {
                id = 1;
                self.outputs.clear();
            }
            self.outputs.push(OutputRecipe {
                id,
                fields,
                period,
                due: None,
            });
        }
        let joined = types.join(",");
        self.event(RtdeEvent::OutputSetup {
            recipe: id,
            frequency,
            fields: names,
            types,
        });
        let mut p = Vec::with_capacity(joined.len() + 1);
        if v2 {
            p.push(id);
        }
        p.extend_from_slice(joined.as_bytes());
        self.reply(RTDE_SETUP_OUTPUTS, &p)
    }

    fn setup_inputs(
        &mut self,
        registry: &mut InputRegistry,
        payload: &[u8],
    ) -> Result<(), RtdeError> {
        let names = match Self::names(payload) {
            Ok(n) => n,
            Err(e) => {
                let e = match e {
                    RtdeError::BadPayload { reason, .. } => RtdeError::BadPayload {
                        packet_type: RTDE_SETUP_INPUTS,
                        reason,
                    },
                    e => e,
                };
                self.fault(e);
                return self.reply(RTDE_SETUP_INPUTS, &[0]);
            }
        };
        let mut fields = Vec::with_capacity(names.len());
        let mut types = Vec::with_capacity(names.len());
        let mut ok = true;
        let mut len = 1usize;
        for n in &names {
            match lookup(n, Direction::Input, self.version) {
                Some(f) => match registry.owners.get(&f) {
                    Some(owner) if *owner != self.id => {
                        types.push("IN_USE".to_string());
                        ok = false;
                    }
                    _ => {
                        let ty = f.rtde_type();
                        types.push(ty.name().to_string());
                        len += ty.size();
                        fields.push((f, ty, f.to_string()));
                    }
                },
                None => {
                    types.push("NOT_FOUND".to_string());
                    ok = false;
                }
            }
        }
        if ok && len + 3 > RTDE_MAX_PACKET_SIZE {
            self.fault(RtdeError::TooManyFields { count: names.len() });
            ok = false;
        }
        if ok && self.inputs.len() >= RTDE_MAX_INPUT_RECIPES {
            self.fault(RtdeError::TooManyRecipes);
            ok = false;
        }
        let mut id = 0;
        if ok {
            id = self.next_input;
            self.next_input = self.next_input.wrapping_add(1).max(1);
            for (f, _, _) in &fields {
                registry.owners.insert(*f, self.id);
            }
            self.inputs.push(InputRecipe { id, fields, len });
        }
        let joined = types.join(",");
        self.event(RtdeEvent::InputSetup {
            recipe: id,
            fields: names,
            types,
        });
        let mut p = Vec::with_capacity(joined.len() + 1);
        p.push(id);
        p.extend_from_slice(joined.as_bytes());
        self.reply(RTDE_SETUP_INPUTS, &p)
    }

    fn input_data(&mut self, payload: &[u8]) {
        let Some((&id, mut rest)) = payload.split_first() else {
            self.fault(RtdeError::BadPayload {
                packet_type: RTDE_DATA_PACKAGE,
                reason: "a data package starts with its recipe id",
            });
            return;
        };
        if self.inputs.is_empty() {
            self.fault(RtdeError::NoInputRecipe);
            return;
        }
        let Some(recipe) = self.inputs.iter().find(|r| r.id == id) else {
            self.fault(RtdeError::NoSuchRecipe { recipe: id });
            return;
        };
        if payload.len() != recipe.len {
            let e = RtdeError::DataLength {
                recipe: id,
                expected: recipe.len,
                got: payload.len(),
            };
            self.fault(e);
            return;
        }
        let mut values = Vec::with_capacity(recipe.fields.len());
        for (f, ty, name) in &recipe.fields {
            match RtdeValue::decode(*ty, rest) {
                Some((v, r)) => {
                    rest = r;
                    values.push((*f, v, name.clone()));
                }
                None => return, // unreachable: the length was checked
            }
        }
        let (inputs, unapplied) = self.apply(&values);
        self.event(RtdeEvent::Inputs {
            recipe: id,
            inputs,
            unapplied,
        });
    }

    /// Turn one package's values into [`Inputs`], through the latched masks.
    fn apply(
        &mut self,
        values: &[(Field, RtdeValue, String)],
    ) -> (Inputs, Vec<(String, RtdeValue)>) {
        let l = &mut self.latched;
        let mut inputs = Inputs::default();
        let mut unapplied = Vec::new();
        let (mut speed, mut std_do, mut conf_do, mut tool_do, mut analog, mut payload) =
            (false, false, false, false, false, false);
        for (f, v, name) in values {
            inputs.fields.push(name.clone());
            match (f.input(), *v) {
                (Some(Input::SpeedSliderMask), RtdeValue::Uint32(m)) => {
                    l.speed_mask = m;
                    speed = true;
                }
                (Some(Input::SpeedSliderFraction), RtdeValue::Double(x)) => {
                    l.speed_fraction = x;
                    speed = true;
                }
                (Some(Input::StandardDigitalOutputMask), RtdeValue::Uint8(m)) => {
                    l.standard_do.0 = m;
                    std_do = true;
                }
                (Some(Input::StandardDigitalOutput), RtdeValue::Uint8(x)) => {
                    l.standard_do.1 = x;
                    std_do = true;
                }
                (Some(Input::ConfigurableDigitalOutputMask), RtdeValue::Uint8(m)) => {
                    l.configurable_do.0 = m;
                    conf_do = true;
                }
                (Some(Input::ConfigurableDigitalOutput), RtdeValue::Uint8(x)) => {
                    l.configurable_do.1 = x;
                    conf_do = true;
                }
                (Some(Input::ToolDigitalOutputMask), RtdeValue::Uint8(m)) => {
                    l.tool_do.0 = m;
                    tool_do = true;
                }
                (Some(Input::ToolDigitalOutput), RtdeValue::Uint8(x)) => {
                    l.tool_do.1 = x;
                    tool_do = true;
                }
                (Some(Input::StandardAnalogOutputMask), RtdeValue::Uint8(m)) => {
                    l.analog_mask = m;
                    analog = true;
                }
                (Some(Input::StandardAnalogOutputType), RtdeValue::Uint8(t)) => {
                    l.analog_types = t;
                    analog = true;
                }
                (Some(Input::StandardAnalogOutput(0)), RtdeValue::Double(x)) => {
                    l.analog[0] = x;
                    analog = true;
                }
                (Some(Input::StandardAnalogOutput(1)), RtdeValue::Double(x)) => {
                    l.analog[1] = x;
                    analog = true;
                }
                (Some(Input::BitRegisters(0)), RtdeValue::Uint32(bits)) => {
                    inputs
                        .bool_registers
                        .extend((0..32).map(|i| (i, bits >> i & 1 == 1)));
                }
                (Some(Input::BitRegisters(32)), RtdeValue::Uint32(bits)) => {
                    inputs
                        .bool_registers
                        .extend((0..32).map(|i| (32 + i, bits >> i & 1 == 1)));
                }
                (Some(Input::BitRegister(n)), RtdeValue::Bool(b)) => {
                    inputs.bool_registers.push((usize::from(n), b));
                }
                (Some(Input::IntRegister(n)), RtdeValue::Int32(x)) => {
                    inputs.int_registers.push((usize::from(n), x));
                }
                (Some(Input::DoubleRegister(n)), RtdeValue::Double(x)) => {
                    inputs.double_registers.push((usize::from(n), x));
                }
                (Some(Input::Payload), RtdeValue::Double(m)) => {
                    l.payload_mass = m;
                    payload = true;
                }
                (Some(Input::PayloadCog), RtdeValue::Vector3d(c)) => {
                    l.payload_cog = c;
                    payload = true;
                }
                (Some(Input::PayloadInertia), RtdeValue::Vector6d(i)) => {
                    l.payload_inertia = Some(i);
                    payload = true;
                }
                (_, v) => unapplied.push((name.clone(), v)),
            }
        }
        if speed && l.speed_mask & 1 == 1 {
            inputs.speed_slider_fraction = Some(l.speed_fraction);
        }
        if std_do {
            inputs.standard_digital_outputs = Some(l.standard_do);
        }
        if conf_do {
            inputs.configurable_digital_outputs = Some(l.configurable_do);
        }
        if tool_do {
            inputs.tool_digital_outputs = Some(l.tool_do);
        }
        if analog {
            inputs.standard_analog_outputs = Some((l.analog_mask, l.analog_types, l.analog));
        }
        if payload {
            inputs.payload = Some((l.payload_mass, l.payload_cog, l.payload_inertia));
        }
        (inputs, unapplied)
    }

    /// One controller step at `now` (any fixed origin, the same for every call): while
    /// started, a RTDE_DATA_PACKAGE of `status` for every output recipe whose time has come.
    /// Call it every step (2 ms); see the module's notes on timing.
    pub fn on_step(&mut self, status: &Status, now: Duration) {
        if !self.started || self.fatal.is_some() {
            return;
        }
        let now = now.as_nanos();
        let v2 = self.protocol >= 2;
        for i in 0..self.outputs.len() {
            let Some(r) = self.outputs.get_mut(i) else {
                break;
            };
            let due = *r.due.get_or_insert(now);
            if due > now {
                continue;
            }
            let mut next = due.saturating_add(r.period);
            if next <= now {
                next = now.saturating_add(r.period);
            }
            r.due = Some(next);
            if self.outbox.len() >= RTDE_MAX_OUTBOX {
                self.skipped += 1;
                continue;
            }
            let mut p = Vec::with_capacity(64);
            if v2 {
                p.push(r.id);
            }
            for f in &r.fields {
                if let Some(v) = f.read(status) {
                    v.encode(&mut p);
                }
            }
            push_packet(&mut self.outbox, RTDE_DATA_PACKAGE, &p);
        }
    }

    /// The connection ended: release every input field this session owns. Later calls
    /// to [`RtdeSession::handle_received`] return [`RtdeError::Closed`]. Call it for
    /// every session, after a fatal error too: a session dropped without `close` keeps
    /// its fields owned in the registry.
    pub fn close(&mut self, registry: &mut InputRegistry) {
        registry.release(self.id);
        self.started = false;
        if self.fatal.is_none() {
            self.fatal = Some(RtdeError::Closed);
        }
    }
}

/// The controller's status as the RTDE outputs read it.
impl RtdeSource for Status {
    fn time(&self) -> f64 {
        self.time
    }
    fn dh(&self) -> Dh {
        self.model.dh()
    }
    fn robot_mode(&self) -> i32 {
        self.robot_mode.code()
    }
    fn safety_status(&self) -> i32 {
        self.safety.code()
    }
    fn runtime_state(&self) -> u32 {
        match self.program_state {
            ProgramState::Stopped => 1,
            ProgramState::Playing => 2,
            ProgramState::Paused => 4,
        }
    }
    fn script_line(&self) -> u32 {
        self.script_line
    }
    fn target_q(&self) -> [f64; 6] {
        self.target_q
    }
    fn target_qd(&self) -> [f64; 6] {
        self.target_qd
    }
    fn target_qdd(&self) -> [f64; 6] {
        self.target_qdd
    }
    fn actual_q(&self) -> [f64; 6] {
        self.actual_q
    }
    fn actual_qd(&self) -> [f64; 6] {
        self.actual_qd
    }
    fn target_current(&self) -> [f64; 6] {
        self.target_current
    }
    fn actual_current(&self) -> [f64; 6] {
        self.actual_current
    }
    fn target_moment(&self) -> [f64; 6] {
        self.target_moment
    }
    fn joint_temperatures(&self) -> [f64; 6] {
        self.joint_temperatures
    }
    fn joint_voltage(&self) -> [f64; 6] {
        self.joint_voltage
    }
    /// 0.3 ms, a plausible real-time thread time.
    fn actual_execution_time(&self) -> f64 {
        0.3
    }
    fn actual_tcp_pose(&self) -> [f64; 6] {
        self.actual_tcp_pose
    }
    fn actual_tcp_speed(&self) -> [f64; 6] {
        self.actual_tcp_speed
    }
    fn actual_tcp_force(&self) -> [f64; 6] {
        self.actual_tcp_force
    }
    fn target_tcp_pose(&self) -> [f64; 6] {
        self.target_tcp_pose
    }
    fn target_tcp_speed(&self) -> [f64; 6] {
        self.target_tcp_speed
    }
    fn tcp_offset(&self) -> [f64; 6] {
        self.tcp_offset
    }
    fn tool_accelerometer(&self) -> [f64; 3] {
        self.tool_accelerometer
    }
    fn speed_fraction(&self) -> f64 {
        self.speed_fraction
    }
    fn speed_scaling(&self) -> f64 {
        self.speed_scaling
    }
    fn digital_inputs(&self) -> u64 {
        self.digital_inputs
    }
    fn digital_outputs(&self) -> u64 {
        self.digital_outputs
    }
    fn analog_inputs(&self) -> [f64; 2] {
        self.analog_inputs
    }
    fn analog_outputs(&self) -> [f64; 2] {
        self.analog_outputs
    }
    fn analog_io_types(&self) -> u32 {
        self.analog_io_types
    }
    fn tool_analog_inputs(&self) -> [f64; 2] {
        self.tool_analog_inputs
    }
    fn tool_analog_input_types(&self) -> u32 {
        self.tool_analog_input_types
    }
    fn tool_output_voltage(&self) -> i32 {
        self.tool_output_voltage
    }
    fn tool_current(&self) -> f64 {
        self.tool_current
    }
    fn tool_temperature(&self) -> f64 {
        self.tool_temperature
    }
    fn io_current(&self) -> f64 {
        self.io_current
    }
    fn output_bool_registers(&self) -> &[bool] {
        &self.output_bool_registers
    }
    fn output_int_registers(&self) -> &[i32] {
        &self.output_int_registers
    }
    fn output_double_registers(&self) -> &[f64] {
        &self.output_double_registers
    }
    fn input_bool_registers(&self) -> &[bool] {
        &self.input_bool_registers
    }
    fn input_int_registers(&self) -> &[i32] {
        &self.input_int_registers
    }
    fn input_double_registers(&self) -> &[f64] {
        &self.input_double_registers
    }
    fn payload_mass(&self) -> f64 {
        self.payload_mass
    }
    fn payload_cog(&self) -> [f64; 3] {
        self.payload_cog
    }
    fn payload_inertia(&self) -> [f64; 6] {
        self.payload_inertia
    }
    fn main_voltage(&self) -> f64 {
        self.main_voltage
    }
    fn robot_voltage(&self) -> f64 {
        self.robot_voltage
    }
    fn robot_current(&self) -> f64 {
        self.robot_current
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packet_helper_sizes() {
        assert_eq!(packet(b'S', &[1]), [0, 4, b'S', 1]);
    }
}
