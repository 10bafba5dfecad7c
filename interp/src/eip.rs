//! The controller's Flexible EtherNet/IP Adapter (e-Series 5.x manual, chapter "Flexible
//! Ethernet/IP Adapter", PolyScope 5.16 and later), on the virtual controller: the
//! assemblies a program configures through the adapter's local XML-RPC service
//! (`http://127.0.0.1:40000/RPC2`: `add_configuration`, `is_instance_connected`), the
//! reader and writer handles of `eip_reader_factory`/`eip_writer_factory`, their
//! `define_*` layouts, `read`, `write`, `clear`, watchdog and `close`.
//!
//! There is no EtherNet/IP on the wire: the scanner (a PLC, a CNC machine) is the test.
//! What the PLC last sent to the robot is [`World::eip_from_plc`](crate::World::eip_from_plc),
//! whether a scanner is connected is [`World::eip_connected`](crate::World::eip_connected)
//! (both settable, also with `--set`), and what the robot wrote for the PLC is
//! [`Arm::eip_to_plc`](crate::Arm::eip_to_plc).
//!
//! ## Choices where the manual is silent
//! - Byte order: little-endian, as CIP (EtherNet/IP's object layer) encodes its data;
//!   `float32` is IEEE 754 single precision.
//! - A handle reads or writes the instance's first `data_size` bytes; a PLC→Robot
//!   instance shorter than that reads as zeros past its end. Opening a writer on an
//!   instance creates its memory (zeros) if no writer or configuration made it yet; a
//!   second writer on the same instance shares that memory (grown to the larger size).
//! - Overlaps: a numeric field or array may not overlap another numeric field, array or
//!   string; a bit may not overlap another bit (a bit may lie inside a numeric field, as
//!   the manual allows); a string overlaps nothing. A label may be defined once per
//!   handle. A field past `data_size` is an error.
//! - `write`: an int field takes an int (or a float without a fraction) in its type's
//!   range; a `float32` field a number; a bit `True`/`False` (or the ints 0 and 1); an
//!   array a list of at most its length (the elements after the list are set to zero); a
//!   string at most `length - 1` bytes (the rest, the terminating zero included, is set
//!   to zero). Every label is checked before any is written (the manual: all labels of
//!   one `write` reach the instance together).
//! - `read` of a bit gives a bool, of an int field an int, of `float32` a float, of an
//!   array a list, of a string its bytes up to the first zero.
//! - Watchdog: a scanner that is connected ([`World::eip_connected`](crate::World::eip_connected))
//!   sends at its rate, so the watchdog never times out; without one it times out
//!   `1 / frequency` s after it was started (or after the scanner went away). Action 1
//!   and 2 then trigger a protective stop as `protective_stop()` does (the program is
//!   paused by a controller that runs it); action 2 also stops the program here, with a
//!   runtime error naming the instance. It is checked once per step.
//! - `is_instance_connected(id)`: True when a scanner is connected and the PLC→Robot
//!   instance was configured by `add_configuration`.
//!
//! ## Bounds
//! An instance is at most [`MAX_DATA_SIZE`] bytes, at most [`MAX_INSTANCES`] instances
//! exist, a program opens at most [`MAX_HANDLES`] handles, a handle holds at most
//! [`MAX_LABELS`] labels of at most [`MAX_LABEL_LEN`] bytes each, and an array at most
//! `MAX_DATA_SIZE` elements: past any of them the call is a runtime error.

use std::collections::BTreeMap;

use crate::error::{Fault, RuntimeErrorKind as K};
use crate::value::{Value, MAX_STRUCT_MEMBERS};

/// The most bytes of an instance (the manual recommends at most 500).
pub const MAX_DATA_SIZE: usize = 4096;
/// The most instances the adapter holds (configured or written).
pub const MAX_INSTANCES: usize = 64;
/// The most handles one program opens (closed ones count: a closed handle cannot be
/// opened again).
pub const MAX_HANDLES: usize = 64;
/// The most labels one handle defines.
pub const MAX_LABELS: usize = 256;
/// The longest label.
pub const MAX_LABEL_LEN: usize = 64;

/// UR's built-in assembly instances, which `add_configuration` may not replace.
const BUILT_IN_INSTANCES: [i32; 2] = [100, 112];

/// The adapter's state that outlives a program (its service runs beside the controller):
/// the configured assemblies and what the robot wrote for the PLC.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct Adapter {
    /// Robot→PLC instance data, by instance id.
    pub to_plc: BTreeMap<i32, Vec<u8>>,
    /// Instances configured by `add_configuration`: id → (size, PLC→Robot).
    pub configured: BTreeMap<i32, (usize, bool)>,
}

/// A numeric field's type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Num {
    U8,
    U16,
    I16,
    I32,
    F32,
}

impl Num {
    fn size(self) -> usize {
        match self {
            Num::U8 => 1,
            Num::U16 | Num::I16 => 2,
            Num::I32 | Num::F32 => 4,
        }
    }

    fn name(self) -> &'static str {
        match self {
            Num::U8 => "uint8",
            Num::U16 => "uint16",
            Num::I16 => "int16",
            Num::I32 => "int32",
            Num::F32 => "float32",
        }
    }

    fn from_name(s: &str) -> Option<Num> {
        Some(match s {
            "uint8" => Num::U8,
            "uint16" => Num::U16,
            "int16" => Num::I16,
            "int32" => Num::I32,
            "float32" => Num::F32,
            _ => return None,
        })
    }

    fn read(self, b: &[u8]) -> Value {
        let mut w = [0u8; 4];
        w[..b.len().min(4)].copy_from_slice(&b[..b.len().min(4)]);
        match self {
            Num::U8 => Value::Int(i32::from(w[0])),
            Num::U16 => Value::Int(i32::from(u16::from_le_bytes([w[0], w[1]]))),
            Num::I16 => Value::Int(i32::from(i16::from_le_bytes([w[0], w[1]]))),
            Num::I32 => Value::Int(i32::from_le_bytes(w)),
            Num::F32 => Value::Float(f64::from(f32::from_le_bytes(w))),
        }
    }

    /// The bytes of `v` in this type, or why it does not fit.
    fn encode(self, v: &Value) -> Result<Vec<u8>, String> {
        if self == Num::F32 {
            let x = v
                .as_f64()
                .filter(|_| !matches!(v, Value::Bool(_)))
                .ok_or_else(|| format!("a float32 needs a number, got {}", v.type_name()))?;
            if x.is_finite() && x.abs() > f64::from(f32::MAX) {
                return Err(format!("{x} is outside the range of a float32"));
            }
            #[allow(clippy::cast_possible_truncation)]
            return Ok((x as f32).to_le_bytes().to_vec());
        }
        let x: i64 = match v {
            Value::Int(i) => i64::from(*i),
            Value::Float(f) if f.fract() == 0.0 && f.abs() < 1e12 => *f as i64,
            other => {
                return Err(format!(
                    "a {} needs an int, got {} {}",
                    self.name(),
                    other.type_name(),
                    other.to_source()
                ))
            }
        };
        let fits = match self {
            Num::U8 => u8::try_from(x).map(|b| vec![b]).ok(),
            Num::U16 => u16::try_from(x).map(|n| n.to_le_bytes().to_vec()).ok(),
            Num::I16 => i16::try_from(x).map(|n| n.to_le_bytes().to_vec()).ok(),
            Num::I32 => i32::try_from(x).map(|n| n.to_le_bytes().to_vec()).ok(),
            Num::F32 => None,
        };
        fits.ok_or_else(|| format!("{x} is outside the range of a {}", self.name()))
    }
}

/// What a label names in the instance.
#[derive(Debug, Clone, PartialEq)]
enum Field {
    /// A number, or `len` numbers (an array) when `len` is given.
    Num {
        ty: Num,
        offset: usize,
        len: Option<usize>,
    },
    /// Bit `bit` of the `width`-byte word at `offset`.
    Bit {
        offset: usize,
        bit: usize,
        width: usize,
    },
    /// A zero-terminated string of at most `len - 1` bytes.
    Str { offset: usize, len: usize },
}

impl Field {
    /// The bytes the field covers.
    fn bytes(&self) -> std::ops::Range<usize> {
        match *self {
            Field::Num { ty, offset, len } => offset..offset + ty.size() * len.unwrap_or(1),
            Field::Bit { offset, bit, .. } => {
                let at = offset + bit / 8;
                at..at + 1
            }
            Field::Str { offset, len } => offset..offset + len,
        }
    }

    /// The absolute bit a bit field is (byte * 8 + bit; little-endian words).
    fn bit_index(&self) -> Option<usize> {
        match *self {
            Field::Bit { offset, bit, .. } => Some(offset * 8 + bit),
            _ => None,
        }
    }

    fn overlaps(&self, other: &Field) -> bool {
        let (a, b) = (self.bytes(), other.bytes());
        let bytes_meet = a.start < b.end && b.start < a.end;
        match (self, other) {
            (Field::Bit { .. }, Field::Bit { .. }) => self.bit_index() == other.bit_index(),
            (Field::Bit { .. }, Field::Num { .. }) | (Field::Num { .. }, Field::Bit { .. }) => {
                false
            }
            _ => bytes_meet,
        }
    }
}

/// The watchdog of a reader handle.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Watchdog {
    /// Minimum communication frequency (Hz), 0 < f <= 10.
    frequency: f64,
    /// 0 ignore, 1 pause, 2 stop.
    action: i32,
    running: bool,
    /// The step from which the time without data counts.
    since: u64,
    /// It timed out and acted (once per time-out).
    fired: bool,
}

/// One handle of `eip_reader_factory`/`eip_writer_factory`.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Handle {
    instance: i32,
    size: usize,
    writer: bool,
    closed: bool,
    labels: Vec<(String, Field)>,
    watchdog: Option<Watchdog>,
}

/// The handles a program opened (the program's own, gone with it).
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct Handles {
    list: Vec<Handle>,
}

/// What a watchdog that timed out asks of the controller.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Trip {
    /// A protective stop (action 1: the program is paused by its controller).
    Pause,
    /// A protective stop and the program stopped, with this message.
    Stop(String),
}

fn parse_instance(fname: &str, name: &[u8]) -> Result<i32, Fault> {
    let text = String::from_utf8_lossy(name);
    text.trim()
        .parse::<i32>()
        .ok()
        .filter(|i| *i >= 0)
        .ok_or_else(|| {
            Fault::from(format!(
                "`{fname}`: instance_name must be an instance id such as \"111\", got \"{}\"",
                text.chars().take(40).collect::<String>()
            ))
        })
}

impl Handles {
    /// `eip_reader_factory` (`writer` false) or `eip_writer_factory`: a new handle on
    /// instance `name` of `data_size` bytes.
    pub fn open(
        &mut self,
        adapter: &mut Adapter,
        writer: bool,
        name: &[u8],
        data_size: i32,
    ) -> Result<Value, Fault> {
        let fname = if writer {
            "eip_writer_factory"
        } else {
            "eip_reader_factory"
        };
        let instance = parse_instance(fname, name)?;
        let size = usize::try_from(data_size)
            .ok()
            .filter(|n| (1..=MAX_DATA_SIZE).contains(n))
            .ok_or_else(|| {
                Fault::from(format!(
                    "`{fname}`: data_size must be 1-{MAX_DATA_SIZE} bytes, got {data_size}"
                ))
            })?;
        if self.list.len() >= MAX_HANDLES {
            return Err(Fault::new(
                K::Limit,
                format!("`{fname}`: a program opens at most {MAX_HANDLES} EtherNet/IP handles"),
            ));
        }
        if writer {
            if !adapter.to_plc.contains_key(&instance) && adapter.to_plc.len() >= MAX_INSTANCES {
                return Err(Fault::new(
                    K::Limit,
                    format!("`{fname}`: the adapter holds at most {MAX_INSTANCES} instances"),
                ));
            }
            let mem = adapter.to_plc.entry(instance).or_default();
            if mem.len() < size {
                mem.resize(size, 0);
            }
        }
        self.list.push(Handle {
            instance,
            size,
            writer,
            closed: false,
            labels: Vec::new(),
            watchdog: None,
        });
        let id = u32::try_from(self.list.len() - 1).unwrap_or(u32::MAX);
        Ok(Value::Eip(id))
    }

    /// `handle.method(args)`. `from_plc`: what the PLC last sent, by instance;
    /// `step`: the step now.
    pub fn call(
        &mut self,
        adapter: &mut Adapter,
        from_plc: &BTreeMap<i32, Vec<u8>>,
        id: u32,
        method: &str,
        args: &[Value],
        step: u64,
    ) -> Result<Value, Fault> {
        let Some(h) = self.list.get_mut(id as usize) else {
            return Err(Fault::new(
                K::Internal,
                "an EtherNet/IP handle of no program",
            ));
        };
        let what = if h.writer { "writer" } else { "reader" };
        let err = |msg: String| Fault::from(format!("EtherNet/IP {what} `.{method}`: {msg}"));
        if h.closed {
            return Err(err(format!(
                "the handle on instance {} is closed",
                h.instance
            )));
        }
        let arity = |n: std::ops::RangeInclusive<usize>| {
            if n.contains(&args.len()) {
                Ok(())
            } else {
                Err(Fault::new(
                    K::Type,
                    format!(
                        "EtherNet/IP {what} `.{method}` takes {} arguments, got {}",
                        if n.start() == n.end() {
                            n.start().to_string()
                        } else {
                            format!("{}-{}", n.start(), n.end())
                        },
                        args.len()
                    ),
                ))
            }
        };
        let int = |i: usize, name: &str| -> Result<usize, Fault> {
            match &args[i] {
                Value::Int(x) if *x >= 0 => Ok(*x as usize),
                Value::Float(x) if x.fract() == 0.0 && *x >= 0.0 && *x < 1e9 => Ok(*x as usize),
                v => Err(err(format!(
                    "{name} must be a non-negative int, got {}",
                    v.to_source()
                ))),
            }
        };
        let label = |i: usize| -> Result<String, Fault> {
            match &args[i] {
                Value::Str(s) if !s.is_empty() && s.len() <= MAX_LABEL_LEN => {
                    Ok(String::from_utf8_lossy(s).into_owned())
                }
                v => Err(err(format!(
                    "data_name must be a string of 1-{MAX_LABEL_LEN} bytes, got {}",
                    v.to_source()
                ))),
            }
        };
        if let Some(rest) = method.strip_prefix("define_") {
            let field = if rest == "bit" {
                arity(3..=4)?;
                let offset = int(0, "offset")?;
                let bit = int(1, "bit_number")?;
                let width = if args.len() == 4 {
                    int(3, "bitfield_width")?
                } else {
                    1
                };
                if ![1, 2, 4].contains(&width) {
                    return Err(err(format!(
                        "bitfield_width must be 1, 2 or 4, got {width}"
                    )));
                }
                if bit >= width * 8 {
                    return Err(err(format!(
                        "bit_number {bit} is not a bit of a {width}-byte field (0-{})",
                        width * 8 - 1
                    )));
                }
                (
                    Field::Bit { offset, bit, width },
                    label(2)?,
                    offset..offset + width,
                )
            } else if rest == "string" {
                arity(3..=3)?;
                let offset = int(0, "offset")?;
                let len = int(1, "length")?;
                if len == 0 {
                    return Err(err("a string's length must be at least 1".into()));
                }
                (Field::Str { offset, len }, label(2)?, offset..offset + len)
            } else if let Some(ty) = rest.strip_suffix("_array").and_then(Num::from_name) {
                arity(3..=3)?;
                let offset = int(0, "offset")?;
                let len = int(1, "length")?.min(MAX_DATA_SIZE + 1);
                if len == 0 {
                    return Err(err("an array's length must be at least 1".into()));
                }
                let end = offset + ty.size() * len;
                (
                    Field::Num {
                        ty,
                        offset,
                        len: Some(len),
                    },
                    label(2)?,
                    offset..end,
                )
            } else if let Some(ty) = Num::from_name(rest) {
                arity(2..=2)?;
                let offset = int(0, "offset")?;
                (
                    Field::Num {
                        ty,
                        offset,
                        len: None,
                    },
                    label(1)?,
                    offset..offset + ty.size(),
                )
            } else {
                return Err(unknown(what, method));
            };
            let (field, name, span) = field;
            if span.end > h.size {
                return Err(err(format!(
                    "\"{name}\" (bytes {}-{}) is past the instance's {} bytes",
                    span.start,
                    span.end.saturating_sub(1),
                    h.size
                )));
            }
            if h.labels.iter().any(|(n, _)| *n == name) {
                return Err(err(format!("the label \"{name}\" is already defined")));
            }
            if let Some((other, _)) = h.labels.iter().find(|(_, f)| f.overlaps(&field)) {
                return Err(err(format!("\"{name}\" overlaps \"{other}\"")));
            }
            if h.labels.len() >= MAX_LABELS {
                return Err(Fault::new(
                    K::Limit,
                    format!("EtherNet/IP {what}: a handle holds at most {MAX_LABELS} labels"),
                ));
            }
            h.labels.push((name, field));
            return Ok(Value::None);
        }
        match method {
            "read" => {
                arity(1..=1)?;
                if h.writer {
                    return Err(err(
                        "a writer handle is write only (read the PLC's data with an eip_reader_factory handle)"
                            .into(),
                    ));
                }
                let empty = Vec::new();
                let data = from_plc.get(&h.instance).unwrap_or(&empty);
                let read_one = |name: &[u8]| -> Result<Value, Fault> {
                    let name = String::from_utf8_lossy(name);
                    let (_, f) = h
                        .labels
                        .iter()
                        .find(|(n, _)| *n == name)
                        .ok_or_else(|| err(format!("no label \"{name}\" is defined")))?;
                    Ok(read_field(f, data))
                };
                match &args[0] {
                    Value::Str(s) => read_one(s),
                    Value::List(names) => {
                        if names.len() > MAX_STRUCT_MEMBERS {
                            return Err(err(format!(
                                "at most {MAX_STRUCT_MEMBERS} labels in one read"
                            )));
                        }
                        let mut members: Vec<(String, Value)> = Vec::new();
                        for n in names {
                            let Value::Str(s) = n else {
                                return Err(err(format!(
                                    "data_names must be strings, got {}",
                                    n.to_source()
                                )));
                            };
                            let v = read_one(s)?;
                            let key = String::from_utf8_lossy(s).into_owned();
                            match members.iter_mut().find(|(k, _)| *k == key) {
                                Some(m) => m.1 = v,
                                None => members.push((key, v)),
                            }
                        }
                        Ok(Value::Struct(members))
                    }
                    v => Err(err(format!(
                        "data_names must be a string or a list of strings, got {}",
                        v.to_source()
                    ))),
                }
            }
            "write" => {
                arity(1..=1)?;
                if !h.writer {
                    return Err(err("a reader handle is read only".into()));
                }
                let Value::Struct(members) = &args[0] else {
                    return Err(err(format!(
                        "data_struct must be a struct of labels and values, got {}",
                        args[0].to_source()
                    )));
                };
                // Check every label first: all are written together or none.
                let mut writes: Vec<(&Field, &Value)> = Vec::with_capacity(members.len());
                for (name, v) in members {
                    let (_, f) = h
                        .labels
                        .iter()
                        .find(|(n, _)| n == name)
                        .ok_or_else(|| err(format!("no label \"{name}\" is defined")))?;
                    check_write(f, v).map_err(|e| {
                        Fault::new(
                            K::Argument,
                            format!("EtherNet/IP writer `.write`: \"{name}\": {e}"),
                        )
                    })?;
                    writes.push((f, v));
                }
                let mem = adapter.to_plc.entry(h.instance).or_default();
                if mem.len() < h.size {
                    mem.resize(h.size, 0);
                }
                for (f, v) in writes {
                    write_field(f, v, mem);
                }
                Ok(Value::None)
            }
            "clear" => {
                arity(0..=0)?;
                if !h.writer {
                    return Err(err("only a writer handle clears its memory".into()));
                }
                if let Some(mem) = adapter.to_plc.get_mut(&h.instance) {
                    let n = h.size.min(mem.len());
                    mem[..n].fill(0);
                }
                Ok(Value::None)
            }
            "set_watchdog" => {
                arity(2..=2)?;
                if h.writer {
                    return Err(err("a watchdog can only be set on a reader handle".into()));
                }
                let frequency = args[0]
                    .as_f64()
                    .filter(|f| *f > 0.0 && *f <= 10.0)
                    .ok_or_else(|| {
                        err(format!(
                            "frequency must be above 0 and at most 10 Hz, got {}",
                            args[0].to_source()
                        ))
                    })?;
                let action = match &args[1] {
                    Value::Int(a @ 0..=2) => *a,
                    v => {
                        return Err(err(format!(
                            "action must be 0 (ignore), 1 (pause) or 2 (stop), got {}",
                            v.to_source()
                        )))
                    }
                };
                h.watchdog = Some(Watchdog {
                    frequency,
                    action,
                    running: true,
                    since: step,
                    fired: false,
                });
                Ok(Value::None)
            }
            "start_watchdog" | "stop_watchdog" => {
                arity(0..=0)?;
                let Some(w) = h.watchdog.as_mut() else {
                    return Err(err("no watchdog is registered (set_watchdog)".into()));
                };
                let start = method == "start_watchdog";
                if start && !w.running {
                    w.since = step;
                    w.fired = false;
                }
                w.running = start;
                Ok(Value::None)
            }
            "close" => {
                arity(0..=0)?;
                h.closed = true;
                h.labels = Vec::new();
                h.watchdog = None;
                Ok(Value::None)
            }
            _ => Err(unknown(what, method)),
        }
    }

    /// The first step at which a running watchdog times out, when no scanner is
    /// connected (the machine wakes for it).
    pub fn next_deadline(&self, connected: bool, step_time: f64) -> Option<u64> {
        if connected {
            return None;
        }
        self.list
            .iter()
            .filter_map(|h| h.watchdog.filter(|w| w.running && !w.fired))
            .map(|w| {
                w.since
                    .saturating_add(timeout_steps(w.frequency, step_time))
            })
            .min()
    }

    /// Checks the watchdogs at `step`: a connected scanner feeds them; without one, a
    /// watchdog whose time is up acts (once per time-out).
    pub fn check(&mut self, connected: bool, step: u64, step_time: f64) -> Option<Trip> {
        let mut trip = None;
        for h in &mut self.list {
            let Some(w) = h.watchdog.as_mut().filter(|w| w.running) else {
                continue;
            };
            if connected {
                w.since = step;
                w.fired = false;
                continue;
            }
            if w.fired
                || step
                    < w.since
                        .saturating_add(timeout_steps(w.frequency, step_time))
            {
                continue;
            }
            w.fired = true;
            match w.action {
                1 => trip = trip.or(Some(Trip::Pause)),
                2 => {
                    trip = Some(Trip::Stop(format!(
                        "EtherNet/IP watchdog: no data from the scanner on instance {} for more than {} s: protective stop, program stopped",
                        h.instance,
                        1.0 / w.frequency
                    )))
                }
                _ => {}
            }
        }
        trip
    }
}

/// Steps in `1 / frequency` s (at least one).
fn timeout_steps(frequency: f64, step_time: f64) -> u64 {
    let steps = (1.0 / frequency / step_time.max(1e-9)).ceil();
    if (1.0..1e15).contains(&steps) {
        steps as u64
    } else {
        1
    }
}

fn unknown(what: &str, method: &str) -> Fault {
    Fault::new(
        K::Type,
        format!(
            "an EtherNet/IP {what} handle has no method `.{method}` (define_uint8/uint16/int16/int32/float32[_array], define_bit, define_string, read, write, clear, set_watchdog, start_watchdog, stop_watchdog, close)"
        ),
    )
}

fn byte(data: &[u8], i: usize) -> u8 {
    data.get(i).copied().unwrap_or(0)
}

fn read_field(f: &Field, data: &[u8]) -> Value {
    match *f {
        Field::Num { ty, offset, len } => {
            let one = |at: usize| {
                let b: Vec<u8> = (at..at + ty.size()).map(|i| byte(data, i)).collect();
                ty.read(&b)
            };
            match len {
                None => one(offset),
                Some(n) => Value::List((0..n).map(|k| one(offset + k * ty.size())).collect()),
            }
        }
        Field::Bit { offset, bit, .. } => {
            Value::Bool(byte(data, offset + bit / 8) & (1 << (bit % 8)) != 0)
        }
        Field::Str { offset, len } => {
            let s: Vec<u8> = (offset..offset + len)
                .map(|i| byte(data, i))
                .take_while(|b| *b != 0)
                .collect();
            Value::Str(s)
        }
    }
}

fn check_write(f: &Field, v: &Value) -> Result<(), String> {
    match *f {
        Field::Num { ty, len: None, .. } => ty.encode(v).map(|_| ()),
        Field::Num {
            ty, len: Some(n), ..
        } => {
            let Value::List(items) = v else {
                return Err(format!("an array needs a list, got {}", v.type_name()));
            };
            if items.len() > n {
                return Err(format!(
                    "a list of {} elements for an array of {n}",
                    items.len()
                ));
            }
            items.iter().try_for_each(|x| ty.encode(x).map(|_| ()))
        }
        Field::Bit { .. } => match v {
            Value::Bool(_) | Value::Int(0 | 1) => Ok(()),
            other => Err(format!(
                "a bit needs True or False, got {}",
                other.to_source()
            )),
        },
        Field::Str { len, .. } => match v {
            Value::Str(s) if s.len() < len => Ok(()),
            Value::Str(s) => Err(format!(
                "a string of {} bytes for a field of {len} (at most {} and the terminating zero)",
                s.len(),
                len - 1
            )),
            other => Err(format!(
                "a string field needs a string, got {}",
                other.type_name()
            )),
        },
    }
}

/// Writes a value [`check_write`] accepted.
fn write_field(f: &Field, v: &Value, mem: &mut [u8]) {
    let mut put = |at: usize, bytes: &[u8]| {
        for (k, b) in bytes.iter().enumerate() {
            if let Some(slot) = mem.get_mut(at + k) {
                *slot = *b;
            }
        }
    };
    match (f, v) {
        (
            Field::Num {
                ty,
                offset,
                len: None,
            },
            v,
        ) => {
            if let Ok(b) = ty.encode(v) {
                put(*offset, &b);
            }
        }
        (
            Field::Num {
                ty,
                offset,
                len: Some(n),
            },
            Value::List(items),
        ) => {
            for k in 0..*n {
                let b = items
                    .get(k)
                    .and_then(|x| ty.encode(x).ok())
                    .unwrap_or_else(|| vec![0; ty.size()]);
                put(offset + k * ty.size(), &b);
            }
        }
        (Field::Bit { offset, bit, .. }, v) => {
            let on = matches!(v, Value::Bool(true) | Value::Int(1));
            let at = offset + bit / 8;
            if let Some(b) = mem.get_mut(at) {
                if on {
                    *b |= 1 << (bit % 8);
                } else {
                    *b &= !(1 << (bit % 8));
                }
            }
        }
        (Field::Str { offset, len }, Value::Str(s)) => {
            let mut bytes = s.clone();
            bytes.resize(*len, 0);
            put(*offset, &bytes);
        }
        _ => {}
    }
}

/// The adapter's local XML-RPC service (`http://127.0.0.1:40000/RPC2` as the robot's
/// programs reach it): `add_configuration` and `is_instance_connected`. `None`: not a
/// method of the service (the call fails as a remote fault would).
pub(crate) fn service_call(
    adapter: &mut Adapter,
    connected: bool,
    method: &str,
    args: &[Value],
) -> Result<Value, String> {
    let ints = |n: usize| -> Result<Vec<i32>, String> {
        if args.len() != n {
            return Err(format!(
                "`{method}` takes {n} ints, got {} arguments",
                args.len()
            ));
        }
        args.iter()
            .map(|v| match v {
                Value::Int(i) => Ok(*i),
                other => Err(format!("`{method}` takes ints, got {}", other.to_source())),
            })
            .collect()
    };
    match method {
        "add_configuration" => {
            let a = ints(4)?;
            let (out_id, out_size, in_id, in_size) = (a[0], a[1], a[2], a[3]);
            let ok_size = |n: i32| usize::try_from(n).ok().filter(|n| (1..=MAX_DATA_SIZE).contains(n));
            let (Some(out_size), Some(in_size)) = (ok_size(out_size), ok_size(in_size)) else {
                return Ok(Value::Bool(false));
            };
            if out_id == in_id
                || out_id < 0
                || in_id < 0
                || BUILT_IN_INSTANCES.contains(&out_id)
                || BUILT_IN_INSTANCES.contains(&in_id)
            {
                return Ok(Value::Bool(false));
            }
            let same = |id: i32, size: usize, from_plc: bool| {
                adapter.configured.get(&id) == Some(&(size, from_plc))
            };
            if same(out_id, out_size, false) && same(in_id, in_size, true) {
                return Ok(Value::Bool(true));
            }
            if adapter.configured.contains_key(&out_id) || adapter.configured.contains_key(&in_id)
            {
                return Ok(Value::Bool(false));
            }
            if adapter.configured.len() + 2 > MAX_INSTANCES {
                return Ok(Value::Bool(false));
            }
            adapter.configured.insert(out_id, (out_size, false));
            adapter.configured.insert(in_id, (in_size, true));
            let mem = adapter.to_plc.entry(out_id).or_default();
            if mem.len() < out_size {
                mem.resize(out_size, 0);
            }
            Ok(Value::Bool(true))
        }
        "is_instance_connected" => {
            let a = ints(1)?;
            Ok(Value::Bool(
                connected && matches!(adapter.configured.get(&a[0]), Some((_, true))),
            ))
        }
        _ => Err(format!(
            "the EtherNet/IP adapter's service has no method `{method}` (add_configuration, is_instance_connected)"
        )),
    }
}

/// True if `url` is the adapter's service as the robot reaches it (port 40000 on the
/// controller itself).
pub(crate) fn is_service(url: &crate::rpc::Url) -> bool {
    url.port == 40000 && matches!(url.host.as_str(), "127.0.0.1" | "localhost")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s(x: &str) -> Value {
        Value::Str(x.as_bytes().to_vec())
    }

    #[test]
    fn layouts_read_little_endian_and_refuse_overlaps() {
        let mut a = Adapter::default();
        let mut h = Handles::default();
        let r = h.open(&mut a, false, b"111", 16).unwrap();
        let Value::Eip(id) = r else { panic!() };
        let plc: BTreeMap<i32, Vec<u8>> = [(
            111,
            vec![
                0x34, 0x12, 0xff, 0xff, 0, 0, 0x80, 0x3f, b'h', b'i', 0, b'x', 0b10, 0x02,
            ],
        )]
        .into();
        let mut call = |m: &str, args: &[Value]| h.call(&mut a, &plc, id, m, args, 0);
        call("define_uint16", &[Value::Int(0), s("u")]).unwrap();
        call("define_int16", &[Value::Int(2), s("i")]).unwrap();
        call("define_float32", &[Value::Int(4), s("f")]).unwrap();
        call("define_string", &[Value::Int(8), Value::Int(4), s("name")]).unwrap();
        call("define_bit", &[Value::Int(12), Value::Int(1), s("b1")]).unwrap();
        call(
            "define_bit",
            &[Value::Int(12), Value::Int(9), s("b9"), Value::Int(2)],
        )
        .unwrap();
        assert!(call("define_uint8", &[Value::Int(1), s("x")]).is_err()); // inside "u"
        assert!(call("define_bit", &[Value::Int(13), Value::Int(1), s("b9again")]).is_err());
        assert!(call("define_uint8", &[Value::Int(9), s("y")]).is_err()); // inside the string
        assert!(call("define_int32", &[Value::Int(14), s("past")]).is_err());
        assert!(call("define_uint8", &[Value::Int(12), s("u")]).is_err()); // label taken
                                                                           // A numeric field over bits is allowed.
        call("define_uint16", &[Value::Int(12), s("word")]).unwrap();
        assert_eq!(call("read", &[s("u")]).unwrap(), Value::Int(0x1234));
        assert_eq!(call("read", &[s("i")]).unwrap(), Value::Int(-1));
        assert_eq!(call("read", &[s("f")]).unwrap(), Value::Float(1.0));
        assert_eq!(call("read", &[s("name")]).unwrap(), s("hi"));
        assert_eq!(call("read", &[s("b1")]).unwrap(), Value::Bool(true));
        assert_eq!(call("read", &[s("b9")]).unwrap(), Value::Bool(true));
        assert_eq!(call("read", &[s("word")]).unwrap(), Value::Int(0x0202));
        let both = call("read", &[Value::List(vec![s("u"), s("b1")])]).unwrap();
        assert_eq!(
            both,
            Value::Struct(vec![
                ("u".into(), Value::Int(0x1234)),
                ("b1".into(), Value::Bool(true))
            ])
        );
        assert!(call("write", &[Value::Struct(vec![])]).is_err()); // a reader
        assert!(call("nonsense", &[]).is_err());
    }

    #[test]
    fn writes_are_range_checked_and_all_or_nothing() {
        let mut a = Adapter::default();
        let mut h = Handles::default();
        let Value::Eip(id) = h.open(&mut a, true, b"101", 12).unwrap() else {
            panic!()
        };
        let plc = BTreeMap::new();
        let mut call = |m: &str, args: &[Value]| h.call(&mut a, &plc, id, m, args, 0);
        call(
            "define_uint8_array",
            &[Value::Int(0), Value::Int(4), s("work")],
        )
        .unwrap();
        call("define_bit", &[Value::Int(4), Value::Int(0), s("go")]).unwrap();
        call("define_int16", &[Value::Int(6), s("n")]).unwrap();
        call("define_string", &[Value::Int(8), Value::Int(4), s("s")]).unwrap();
        let w = |members: Vec<(&str, Value)>| {
            Value::Struct(
                members
                    .into_iter()
                    .map(|(k, v)| (k.to_string(), v))
                    .collect(),
            )
        };
        call(
            "write",
            &[w(vec![
                ("work", Value::List(vec![Value::Int(1), Value::Int(2)])),
                ("go", Value::Bool(true)),
                ("n", Value::Int(-2)),
                ("s", s("abc")),
            ])],
        )
        .unwrap();
        assert_eq!(
            a.to_plc[&101],
            vec![1, 2, 0, 0, 1, 0, 0xfe, 0xff, b'a', b'b', b'c', 0]
        );
        let before = a.to_plc[&101].clone();
        let mut call = |m: &str, args: &[Value]| h.call(&mut a, &plc, id, m, args, 0);
        // 300 does not fit a uint8: nothing of this write lands.
        assert!(call(
            "write",
            &[w(vec![
                ("go", Value::Bool(false)),
                ("work", Value::List(vec![Value::Int(300)]))
            ])]
        )
        .is_err());
        assert!(call("write", &[w(vec![("s", s("abcd"))])]).is_err());
        assert!(call("write", &[w(vec![("n", Value::Int(40000))])]).is_err());
        assert!(call("write", &[w(vec![("nope", Value::Int(1))])]).is_err());
        assert!(call("read", &[s("n")]).is_err()); // a writer
        assert_eq!(a.to_plc[&101], before);
        let mut call = |m: &str, args: &[Value]| h.call(&mut a, &plc, id, m, args, 0);
        call("clear", &[]).unwrap();
        call("close", &[]).unwrap();
        assert!(call("clear", &[]).is_err());
        assert_eq!(a.to_plc[&101], vec![0; 12]);
    }

    #[test]
    fn watchdog_times_out_without_a_scanner() {
        let mut a = Adapter::default();
        let mut h = Handles::default();
        let Value::Eip(id) = h.open(&mut a, false, b"111", 4).unwrap() else {
            panic!()
        };
        let plc = BTreeMap::new();
        assert!(h.call(&mut a, &plc, id, "start_watchdog", &[], 0).is_err());
        assert!(h
            .call(
                &mut a,
                &plc,
                id,
                "set_watchdog",
                &[Value::Float(11.0), Value::Int(1)],
                0
            )
            .is_err());
        h.call(
            &mut a,
            &plc,
            id,
            "set_watchdog",
            &[Value::Float(2.5), Value::Int(2)],
            10,
        )
        .unwrap();
        // 1 / 2.5 Hz = 0.4 s = 200 steps.
        assert_eq!(h.next_deadline(false, 0.002), Some(210));
        assert_eq!(h.next_deadline(true, 0.002), None);
        assert_eq!(h.check(false, 209, 0.002), None);
        assert!(matches!(h.check(false, 210, 0.002), Some(Trip::Stop(_))));
        assert_eq!(h.check(false, 211, 0.002), None); // once per time-out
                                                      // A scanner feeds it.
        assert_eq!(h.check(true, 300, 0.002), None);
        assert_eq!(h.next_deadline(false, 0.002), Some(500));
        h.call(&mut a, &plc, id, "stop_watchdog", &[], 301).unwrap();
        assert_eq!(h.next_deadline(false, 0.002), None);
        assert_eq!(h.check(false, 900, 0.002), None);
    }

    #[test]
    fn the_configuration_service() {
        let mut a = Adapter::default();
        let call = |a: &mut Adapter, m: &str, v: &[i32]| {
            service_call(
                a,
                true,
                m,
                &v.iter().map(|i| Value::Int(*i)).collect::<Vec<_>>(),
            )
        };
        assert_eq!(
            call(&mut a, "add_configuration", &[101, 88, 111, 44]),
            Ok(Value::Bool(true))
        );
        assert_eq!(
            call(&mut a, "add_configuration", &[101, 88, 111, 44]),
            Ok(Value::Bool(true))
        );
        assert_eq!(
            call(&mut a, "add_configuration", &[101, 8, 121, 4]),
            Ok(Value::Bool(false))
        );
        assert_eq!(
            call(&mut a, "add_configuration", &[100, 8, 121, 4]),
            Ok(Value::Bool(false))
        );
        assert_eq!(
            call(&mut a, "is_instance_connected", &[111]),
            Ok(Value::Bool(true))
        );
        assert_eq!(
            call(&mut a, "is_instance_connected", &[101]),
            Ok(Value::Bool(false))
        );
        assert_eq!(
            service_call(&mut a, false, "is_instance_connected", &[Value::Int(111)]),
            Ok(Value::Bool(false))
        );
        assert!(call(&mut a, "bogus", &[]).is_err());
        assert_eq!(a.to_plc[&101].len(), 88);
    }
}
