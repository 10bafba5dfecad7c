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

use super::{builtin, Args, Builtin, Domain, Out};
use crate::error::Fault;
use crate::native::index;
use crate::runtime::{Encoder, Runtime};
use crate::value::Value;

const D: Domain = Domain::Motion;

pub(super) const TABLE: &[Builtin] = &[
    builtin!(
        encoder_enable_pulse_decode(encoder_index: i32, decoder_type: i32, A: i32, B: i32)
            => pulse_decode,
        "Enables encoder 0/1 on pulse inputs A, B (8-11); no pulses arrive, it stays at 0.",
    ),
    builtin!(
        encoder_enable_set_tick_count(encoder_index: i32, range_id: i32) => enable_set_tick_count,
        "Enables encoder 0/1 fed by encoder_set_tick_count, with range_id 0-4.",
    ),
    builtin!(
        conveyor_pulse_decode(r#type: i32, A: i32, B: &Value = Absent)
            => |c, x, t, _, _| conveyor_pulse_decode(c, x, t),
        "Deprecated form of encoder_enable_pulse_decode for encoder 0 (inputs 0-3).",
    ),
    builtin!(
        encoder_get_tick_count(encoder_index: i32, opt: &[u8] = Str("")) => get_tick_count,
        "The encoder's tick count: a float, or the raw int with opt=\"raw\".",
    ),
    builtin!(
        get_conveyor_tick_count() => |c, _| ticks(c, 0, false),
        "Deprecated: encoder 0's tick count (a float).",
    ),
    builtin!(
        encoder_set_tick_count(encoder_index: i32, count: f64) => set_tick_count,
        "Sets the tick count of an encoder enabled by encoder_enable_set_tick_count.",
    ),
    builtin!(
        set_conveyor_tick_count(tick_count: i32, absolute_encoder_resolution: i32 = Int(0))
            => set_conveyor_tick_count,
        "Deprecated: sets encoder 0's tick count, with its range (0-4).",
    ),
    builtin!(
        encoder_unwind_delta_tick_count(encoder_index: i32, delta_tick_count: f64) => unwind,
        "The delta unwound by the encoder's range if it wrapped (None if not enabled).",
    ),
    builtin!(
        track_conveyor_linear(direction: [f64; 6], ticks_per_meter: f64, encoder_index: i32 = Int(0))
            => |c, x, _, _, k| track(c, x, k),
        "Tracks a linear conveyor on the encoder (recorded; no conveyor moves here).",
    ),
    builtin!(
        track_conveyor_circular(
            center: [f64; 6],
            ticks_per_revolution: f64,
            rotate_tool: bool = Bool(false),
            encoder_index: i32 = Int(0),
        ) => |c, x, _, _, _, k| track(c, x, k),
        "Tracks a circular conveyor on the encoder (recorded; no conveyor moves here).",
    ),
    builtin!(
        stop_conveyor_tracking(a: f64 = Float(20.0)) => |c, _, _| stop(c),
        "Stops conveyor tracking; the joints' speeds are zero.",
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

fn range_id(a: &Args, id: i32) -> Result<i32, Fault> {
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

/// The encoder a pulse decoder of type `t` (0: none, 1-4: A/B quadrature or pulses)
/// enables: mode 0 without a decoder, 1 with one; no pulses arrive, so its count stays 0.
fn pulse_encoder(t: i32) -> Encoder {
    Encoder {
        mode: if t == 0 { 0 } else { 1 },
        ..Encoder::default()
    }
}

fn pulse_decode(
    c: &mut Runtime,
    a: &mut Args,
    encoder_index: i32,
    t: i32,
    pin_a: i32,
    pin_b: i32,
) -> Result<Out, Fault> {
    let k = index(a, encoder_index, 2, "encoder")?;
    if !(0..=4).contains(&t) {
        return Err(Fault::from(format!(
            "`encoder_enable_pulse_decode`: decoder type {t} is not 0-4"
        )));
    }
    for pin in [pin_a, pin_b] {
        if t != 0 && !(8..=11).contains(&pin) {
            return Err(Fault::from(format!(
                "`encoder_enable_pulse_decode`: pin {pin} is not 8-11"
            )));
        }
    }
    c.arm.encoders[k] = pulse_encoder(t);
    Ok(Out::Value(Value::None))
}

fn conveyor_pulse_decode(c: &mut Runtime, _: &mut Args, t: i32) -> Result<Out, Fault> {
    if !(0..=4).contains(&t) {
        return Err(Fault::from(format!(
            "`conveyor_pulse_decode`: type {t} is not 0-4"
        )));
    }
    c.arm.encoders[0] = pulse_encoder(t);
    Ok(Out::Value(Value::None))
}

fn enable_set_tick_count(
    c: &mut Runtime,
    a: &mut Args,
    encoder_index: i32,
    range: i32,
) -> Result<Out, Fault> {
    let k = index(a, encoder_index, 2, "encoder")?;
    let id = range_id(a, range)?;
    c.arm.encoders[k] = Encoder {
        mode: 2,
        range_id: id,
        ticks: 0,
    };
    Ok(Out::Value(Value::None))
}

fn get_tick_count(
    c: &mut Runtime,
    a: &mut Args,
    encoder_index: i32,
    opt: &[u8],
) -> Result<Out, Fault> {
    let k = index(a, encoder_index, 2, "encoder")?;
    ticks(c, k, opt == b"raw")
}

/// Encoder `k`'s tick count: a float, or an int if `raw`.
fn ticks(c: &Runtime, k: usize, raw: bool) -> Result<Out, Fault> {
    let ticks = c.arm.encoders[k].ticks;
    Ok(Out::Value(if raw {
        Value::Int(ticks as i32)
    } else {
        Value::Float(ticks as f64)
    }))
}

fn set_conveyor_tick_count(
    c: &mut Runtime,
    a: &mut Args,
    ticks: i32,
    resolution: i32,
) -> Result<Out, Fault> {
    let id = range_id(a, resolution)?;
    c.arm.encoders[0] = Encoder {
        mode: 2,
        range_id: id,
        ticks: wrap(id, i64::from(ticks)),
    };
    Ok(Out::Value(Value::None))
}

fn set_tick_count(
    c: &mut Runtime,
    a: &mut Args,
    encoder_index: i32,
    count: f64,
) -> Result<Out, Fault> {
    let k = index(a, encoder_index, 2, "encoder")?;
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

fn unwind(c: &mut Runtime, a: &mut Args, encoder_index: i32, delta: f64) -> Result<Out, Fault> {
    let k = index(a, encoder_index, 2, "encoder")?;
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

fn track(c: &mut Runtime, a: &mut Args, encoder_index: i32) -> Result<Out, Fault> {
    let k = index(a, encoder_index, 2, "encoder")?;
    c.arm.conveyor = Some(k);
    Ok(Out::Value(Value::None))
}

fn stop(c: &mut Runtime) -> Result<Out, Fault> {
    c.arm.conveyor = None;
    c.arm.qd = [0.0; 6];
    Ok(Out::Value(Value::None))
}
