//! Math: trigonometry, powers, rounding, norms, bit lists, `random`.

use super::{req, Args, Builtin, Domain, Out};
use crate::controller::Controller;
use crate::error::Fault;
use crate::value::Value;

const D: Domain = Domain::Math;
const F: &[super::Param] = &[req("f")];

pub(super) const TABLE: &[Builtin] = &[
    Builtin::new("sin", D, F, "The sine of f (radians).", unary),
    Builtin::new("cos", D, F, "The cosine of f (radians).", unary),
    Builtin::new("tan", D, F, "The tangent of f (radians).", unary),
    Builtin::new("atan", D, F, "The arc tangent of f.", unary),
    Builtin::new("d2r", D, &[req("d")], "Degrees to radians.", unary),
    Builtin::new("r2d", D, &[req("r")], "Radians to degrees.", unary),
    Builtin::new("asin", D, F, "The arc sine of f (-1..1).", unary),
    Builtin::new("acos", D, F, "The arc cosine of f (-1..1).", unary),
    Builtin::new("sqrt", D, F, "The square root of f (f >= 0).", unary),
    Builtin::new(
        "atan2",
        D,
        &[req("y"), req("x")],
        "The arc tangent of y/x, in the right quadrant.",
        atan2,
    ),
    Builtin::new(
        "pow",
        D,
        &[req("base"), req("exponent")],
        "base to the power exponent.",
        pow,
    ),
    Builtin::new(
        "log",
        D,
        &[req("b"), req("f")],
        "The logarithm of f in base b.",
        log,
    ),
    Builtin::new("floor", D, F, "The largest int not above f.", round),
    Builtin::new("ceil", D, F, "The smallest int not below f.", round),
    Builtin::new(
        "norm",
        D,
        &[req("a")],
        "The absolute value of a number, the Euclidean norm of a list or pose.",
        norm,
    ),
    Builtin::new(
        "binary_list_to_integer",
        D,
        &[req("l")],
        "The int whose bits (least significant first) are the list's bools.",
        binary_list_to_integer,
    ),
    Builtin::new(
        "integer_to_binary_list",
        D,
        &[req("x")],
        "The 32 bits of x as bools, least significant first.",
        integer_to_binary_list,
    ),
    Builtin::new(
        "random",
        D,
        &[],
        "A number in [0, 1) from a fixed-seed generator (runs are reproducible).",
        random,
    ),
];

fn unary(_: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
    let x = a.num(0)?;
    let r = match a.name {
        "sin" => x.sin(),
        "cos" => x.cos(),
        "tan" => x.tan(),
        "atan" => x.atan(),
        "d2r" => x.to_radians(),
        "r2d" => x.to_degrees(),
        "asin" => x.asin(),
        "acos" => x.acos(),
        _ => x.sqrt(),
    };
    if r.is_nan() && !x.is_nan() {
        return Err(Fault::from(format!(
            "`{}`: {x} is outside its domain",
            a.name
        )));
    }
    Ok(Out::Value(Value::Float(r)))
}

fn atan2(_: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(Value::Float(a.num(0)?.atan2(a.num(1)?))))
}

fn pow(_: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(Value::Float(a.num(0)?.powf(a.num(1)?))))
}

fn log(_: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
    let (base, x) = (a.num(0)?, a.num(1)?);
    if base <= 0.0 || base == 1.0 || x <= 0.0 {
        return Err(Fault::from(format!("`log`: log({base}, {x}) is undefined")));
    }
    Ok(Out::Value(Value::Float(x.ln() / base.ln())))
}

fn round(_: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
    let x = a.num(0)?;
    let r = if a.name == "floor" {
        x.floor()
    } else {
        x.ceil()
    };
    if !(f64::from(i32::MIN)..=f64::from(i32::MAX)).contains(&r) {
        return Err(Fault::from(format!(
            "`{}`: {x} does not fit an int",
            a.name
        )));
    }
    Ok(Out::Value(Value::Int(r as i32)))
}

fn norm(_: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
    let n = match &a.v[0] {
        Value::Int(x) => f64::from(*x).abs(),
        Value::Float(x) => x.abs(),
        Value::Pose(p) => p.iter().map(|x| x * x).sum::<f64>().sqrt(),
        Value::List(items) => {
            let mut sum = 0.0;
            for x in items {
                let x = x.as_f64().ok_or_else(|| {
                    format!("type error: `norm` of a list with a {}", x.type_name())
                })?;
                sum += x * x;
            }
            sum.sqrt()
        }
        other => {
            return Err(Fault::type_error(format!(
                "type error: `norm` of a {}",
                other.type_name()
            )))
        }
    };
    Ok(Out::Value(Value::Float(n)))
}

fn binary_list_to_integer(_: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
    let Value::List(items) = &a.v[0] else {
        return Err(Fault::type_error(
            "type error: `binary_list_to_integer` needs a list of bools",
        ));
    };
    if items.len() > 32 {
        return Err(Fault::from(format!(
            "`binary_list_to_integer`: at most 32 bits, got {}",
            items.len()
        )));
    }
    let mut out: u32 = 0;
    for (k, x) in items.iter().enumerate() {
        let bit = match x {
            Value::Bool(b) => *b,
            Value::Int(i) => *i != 0,
            other => {
                return Err(Fault::type_error(format!(
                    "type error: `binary_list_to_integer` needs bools, got {}",
                    other.type_name()
                )))
            }
        };
        if bit {
            out |= 1 << k;
        }
    }
    Ok(Out::Value(Value::Int(out as i32)))
}

fn integer_to_binary_list(_: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
    let x = a.int(0)? as u32;
    Ok(Out::Value(Value::List(
        (0..32).map(|k| Value::Bool(x >> k & 1 == 1)).collect(),
    )))
}

fn random(c: &mut Controller, _: &mut Args) -> Result<Out, Fault> {
    // A fixed-seed xorshift: runs are reproducible.
    let mut x = c.arm.random_state;
    x ^= x << 13;
    x ^= x >> 7;
    x ^= x << 17;
    c.arm.random_state = x;
    Ok(Out::Value(Value::Float(
        (x >> 11) as f64 / (1u64 << 53) as f64,
    )))
}
