//! Conveyor tracking and its encoders (the conveyor part of the manual's motion chapter).
//!
//! There is **no conveyor**: nothing makes an encoder tick. An encoder counts what
//! `encoder_set_tick_count` (or the deprecated `set_conveyor_tick_count`) tells it, and
//! pulse decoding counts no pulses (it stays at 0). Tracking a conveyor is recorded but
//! moves nothing, since the tick count only changes when the program sets it.
//!
//! - `encoder_enable_pulse_decode`, `encoder_enable_set_tick_count`, `conveyor_pulse_decode`
//!   enable an encoder (0 or 1; `conveyor_pulse_decode` is encoder 0) and zero its count.
//! - `encoder_get_tick_count(i)`: the count as a float, or as an int with `opt="raw"`.
//! - `encoder_unwind_delta_tick_count(i, d)`: `d` unwound by the encoder's range when it is
//!   more than half of it; None if the encoder is not enabled.
//! - `track_conveyor_linear`, `track_conveyor_circular`, `stop_conveyor_tracking`.

use super::{opt, req, Args, Builtin, Default, Domain, Out};
use crate::error::Fault;
use crate::runtime::{Encoder, Runtime};
use crate::value::Value;

const D: Domain = Domain::Motion;

pub(super) const TABLE: &[Builtin] = &[
    Builtin::new(
        "encoder_enable_pulse_decode",
        D,
        &[
            req("encoder_index"),
            req("decoder_type"),
            req("A"),
            req("B"),
        ],
        "Enables encoder 0/1 on pulse inputs A, B (8-11); no pulses arrive, it stays at 0.",
        enable,
    ),
    Builtin::new(
        "encoder_enable_set_tick_count",
        D,
        &[req("encoder_index"), req("range_id")],
        "Enables encoder 0/1 fed by encoder_set_tick_count, with range_id 0-4.",
        enable,
    ),
    Builtin::new(
        "conveyor_pulse_decode",
        D,
        &[req("type"), req("A"), opt("B", Default::Absent)],
        "Deprecated form of encoder_enable_pulse_decode for encoder 0 (inputs 0-3).",
        enable,
    ),
    Builtin::new(
        "encoder_get_tick_count",
        D,
        &[req("encoder_index"), opt("opt", Default::Str(""))],
        "The encoder's tick count: a float, or the raw int with opt=\"raw\".",
        get_ticks,
    ),
    Builtin::new(
        "get_conveyor_tick_count",
        D,
        &[],
        "Deprecated: encoder 0's tick count (a float).",
        get_ticks,
    ),
    Builtin::new(
        "encoder_set_tick_count",
        D,
        &[req("encoder_index"), req("count")],
        "Sets the tick count of an encoder enabled by encoder_enable_set_tick_count.",
        set_ticks,
    ),
    Builtin::new(
        "set_conveyor_tick_count",
        D,
        &[
            req("tick_count"),
            opt("absolute_encoder_resolution", Default::Int(0)),
        ],
        "Deprecated: sets encoder 0's tick count, with its range (0-4).",
        set_ticks,
    ),
    Builtin::new(
        "encoder_unwind_delta_tick_count",
        D,
        &[req("encoder_index"), req("delta_tick_count")],
        "The delta unwound by the encoder's range if it wrapped (None if not enabled).",
        unwind,
    ),
    Builtin::new(
        "track_conveyor_linear",
        D,
        &[
            req("direction"),
            req("ticks_per_meter"),
            opt("encoder_index", Default::Int(0)),
        ],
        "Tracks a linear conveyor on the encoder (recorded; no conveyor moves here).",
        track,
    ),
    Builtin::new(
        "track_conveyor_circular",
        D,
        &[
            req("center"),
            req("ticks_per_revolution"),
            opt("rotate_tool", Default::Bool(false)),
            opt("encoder_index", Default::Int(0)),
        ],
        "Tracks a circular conveyor on the encoder (recorded; no conveyor moves here).",
        track,
    ),
    Builtin::new(
        "stop_conveyor_tracking",
        D,
        &[opt("a", Default::Float(20.0))],
        "Stops conveyor tracking; the joints' speeds are zero.",
        stop,
    ),
];

/// The number of ticks of range `id` (0-4).
fn range_len(id: i32) -> f64 {
    match id {
        1 => 256.0,
        2 => 65_536.0,
        3 => 16_777_216.0,
        _ => 4_294_967_296.0,
    }
}

fn range_id(a: &Args, i: usize) -> Result<i32, Fault> {
    let id = a.int(i)?;
    if (0..=4).contains(&id) {
        Ok(id)
    } else {
        Err(Fault::from(format!("`{}`: range {id} is not 0-4", a.name)))
    }
}

/// Wraps `ticks` into range `id`.
fn wrap(id: i32, ticks: i64) -> i64 {
    match id {
        0 => i64::from(ticks as i32),
        _ => ticks.rem_euclid(range_len(id) as i64),
    }
}

fn enable(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let (k, enc) = match a.name {
        "conveyor_pulse_decode" => {
            let t = a.int(0)?;
            if !(0..=4).contains(&t) {
                return Err(Fault::from(format!(
                    "`conveyor_pulse_decode`: type {t} is not 0-4"
                )));
            }
            a.int(1)?;
            let mode = if t == 0 { 0 } else { 1 };
            (
                0,
                Encoder {
                    mode,
                    ..Encoder::default()
                },
            )
        }
        "encoder_enable_pulse_decode" => {
            let k = a.index(0, 2, "encoder")?;
            let t = a.int(1)?;
            if !(0..=4).contains(&t) {
                return Err(Fault::from(format!(
                    "`encoder_enable_pulse_decode`: decoder type {t} is not 0-4"
                )));
            }
            for i in [2, 3] {
                let pin = a.int(i)?;
                if t != 0 && !(8..=11).contains(&pin) {
                    return Err(Fault::from(format!(
                        "`encoder_enable_pulse_decode`: pin {pin} is not 8-11"
                    )));
                }
            }
            let mode = if t == 0 { 0 } else { 1 };
            (
                k,
                Encoder {
                    mode,
                    ..Encoder::default()
                },
            )
        }
        _ => {
            let k = a.index(0, 2, "encoder")?;
            let id = range_id(a, 1)?;
            (
                k,
                Encoder {
                    mode: 2,
                    range_id: id,
                    ticks: 0,
                },
            )
        }
    };
    c.arm.encoders[k] = enc;
    Ok(Out::Value(Value::None))
}

fn get_ticks(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let (k, raw) = if a.name == "get_conveyor_tick_count" {
        (0, false)
    } else {
        (a.index(0, 2, "encoder")?, a.bytes(1)? == b"raw")
    };
    let ticks = c.arm.encoders[k].ticks;
    Ok(Out::Value(if raw {
        Value::Int(ticks as i32)
    } else {
        Value::Float(ticks as f64)
    }))
}

fn set_ticks(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    if a.name == "set_conveyor_tick_count" {
        let ticks = a.int(0)?;
        let id = range_id(a, 1)?;
        c.arm.encoders[0] = Encoder {
            mode: 2,
            range_id: id,
            ticks: wrap(id, i64::from(ticks)),
        };
        return Ok(Out::Value(Value::None));
    }
    let k = a.index(0, 2, "encoder")?;
    let count = a.num(1)?;
    let enc = &mut c.arm.encoders[k];
    if enc.mode != 2 {
        return Err(Fault::from(format!(
            "`encoder_set_tick_count`: encoder {k} is not enabled by encoder_enable_set_tick_count"
        )));
    }
    let lo = if enc.range_id == 0 {
        -2_147_483_648.0
    } else {
        0.0
    };
    let hi = lo + range_len(enc.range_id);
    if !(lo..hi).contains(&count) {
        return Err(Fault::from(format!(
            "`encoder_set_tick_count`: {count} is outside encoder {k}'s range [{lo}, {hi})"
        )));
    }
    enc.ticks = count as i64;
    Ok(Out::Value(Value::None))
}

fn unwind(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let k = a.index(0, 2, "encoder")?;
    let delta = a.num(1)?;
    let enc = c.arm.encoders[k];
    if enc.mode == 0 {
        return Ok(Out::Value(Value::None));
    }
    let range = range_len(enc.range_id);
    let d = if delta > range / 2.0 {
        delta - range
    } else if delta < -range / 2.0 {
        delta + range
    } else {
        delta
    };
    Ok(Out::Value(Value::Float(d)))
}

fn track(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    a.six(0)?;
    a.num(1)?;
    let at = if a.name == "track_conveyor_linear" {
        2
    } else {
        a.boolean(2)?;
        3
    };
    let k = a.index(at, 2, "encoder")?;
    c.arm.conveyor = Some(k);
    Ok(Out::Value(Value::None))
}

fn stop(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    a.num(0)?;
    c.arm.conveyor = None;
    c.arm.qd = [0.0; 6];
    Ok(Out::Value(Value::None))
}
