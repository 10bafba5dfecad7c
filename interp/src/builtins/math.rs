//! Math: trigonometry, powers, rounding, norms, bit lists, `random`, and the matrix
//! functions on lists of lists (`inv`, `transpose`; `inv` of a pose is `pose_inv`).

use super::{builtin, float_list, Args, Builtin, Domain, Out};
use crate::error::Fault;
use crate::runtime::Runtime;
use crate::value::Value;

const D: Domain = Domain::Math;

pub(super) const TABLE: &[Builtin] = &[
    builtin!(
        sin(f: f64) => |c, x, f| unary(c, x, Unary::Sin, f),
        "The sine of f (radians).",
    ),
    builtin!(
        cos(f: f64) => |c, x, f| unary(c, x, Unary::Cos, f),
        "The cosine of f (radians).",
    ),
    builtin!(
        tan(f: f64) => |c, x, f| unary(c, x, Unary::Tan, f),
        "The tangent of f (radians).",
    ),
    builtin!(
        atan(f: f64) => |c, x, f| unary(c, x, Unary::Atan, f),
        "The arc tangent of f.",
    ),
    builtin!(
        d2r(d: f64) => |c, x, d| unary(c, x, Unary::D2r, d),
        "Degrees to radians.",
    ),
    builtin!(
        r2d(r: f64) => |c, x, r| unary(c, x, Unary::R2d, r),
        "Radians to degrees.",
    ),
    builtin!(
        asin(f: f64) => |c, x, f| unary(c, x, Unary::Asin, f),
        "The arc sine of f (-1..1).",
    ),
    builtin!(
        acos(f: f64) => |c, x, f| unary(c, x, Unary::Acos, f),
        "The arc cosine of f (-1..1).",
    ),
    builtin!(
        sqrt(f: f64) => |c, x, f| unary(c, x, Unary::Sqrt, f),
        "The square root of f (f >= 0).",
    ),
    builtin!(
        atan2(x: f64, y: f64) => atan2,
        "The arc tangent of x/y (the manual's names: the first argument over the second), in the right quadrant.",
    ),
    builtin!(
        pow(base: f64, exponent: f64) => pow,
        "base to the power exponent.",
    ),
    builtin!(
        log(b: f64, f: f64) => log,
        "The logarithm of f in base b.",
    ),
    builtin!(
        floor(f: f64) => |c, x, f| round(c, x, Round::Floor, f),
        "The largest int not above f.",
    ),
    builtin!(
        ceil(f: f64) => |c, x, f| round(c, x, Round::Ceil, f),
        "The smallest int not below f.",
    ),
    builtin!(
        norm(a: &Value) => norm,
        "The absolute value of a number, the Euclidean norm of a list or pose.",
    ),
    builtin!(
        normalize(v: &Value) => normalize,
        "The unit vector in the direction of a list of numbers (not all zero).",
    ),
    builtin!(
        inv(m: &Value) => inv,
        "The inverse of a square non-singular matrix (a list of lists), or of a pose.",
    ),
    builtin!(
        transpose(m: &Value) => transpose,
        "The transpose of a matrix (a list of lists; a list is a 1-row matrix).",
    ),
    builtin!(
        binary_list_to_integer(l: &Value) => binary_list_to_integer,
        "The int whose bits (least significant first) are the list's bools.",
    ),
    builtin!(
        integer_to_binary_list(x: i32) => integer_to_binary_list,
        "The 32 bits of x as bools, least significant first.",
    ),
    builtin!(
        random() => random,
        "A number in [0, 1) from a fixed-seed generator (runs are reproducible).",
    ),
];

/// The functions of one number to one number.
#[derive(Clone, Copy)]
enum Unary {
    Sin,
    Cos,
    Tan,
    Atan,
    D2r,
    R2d,
    Asin,
    Acos,
    Sqrt,
}

fn unary(_: &mut Runtime, a: &mut Args, f: Unary, x: f64) -> Result<Out, Fault> {
    let r = match f {
        Unary::Sin => x.sin(),
        Unary::Cos => x.cos(),
        Unary::Tan => x.tan(),
        Unary::Atan => x.atan(),
        Unary::D2r => x.to_radians(),
        Unary::R2d => x.to_degrees(),
        Unary::Asin => x.asin(),
        Unary::Acos => x.acos(),
        Unary::Sqrt => x.sqrt(),
    };
    if r.is_nan() && !x.is_nan() {
        return Err(Fault::from(format!(
            "`{}`: {x} is outside its domain",
            a.name
        )));
    }
    Ok(Out::Value(Value::Float(r)))
}

fn atan2(_: &mut Runtime, _: &mut Args, x: f64, y: f64) -> Result<Out, Fault> {
    Ok(Out::Value(Value::Float(x.atan2(y))))
}

fn pow(_: &mut Runtime, _: &mut Args, base: f64, exponent: f64) -> Result<Out, Fault> {
    Ok(Out::Value(Value::Float(base.powf(exponent))))
}

fn log(_: &mut Runtime, _: &mut Args, base: f64, x: f64) -> Result<Out, Fault> {
    if base <= 0.0 || base == 1.0 || x <= 0.0 {
        return Err(Fault::from(format!("`log`: log({base}, {x}) is undefined")));
    }
    Ok(Out::Value(Value::Float(x.ln() / base.ln())))
}

/// Which way `floor` and `ceil` round.
#[derive(Clone, Copy)]
enum Round {
    Floor,
    Ceil,
}

fn round(_: &mut Runtime, a: &mut Args, way: Round, x: f64) -> Result<Out, Fault> {
    let r = match way {
        Round::Floor => x.floor(),
        Round::Ceil => x.ceil(),
    };
    if !(f64::from(i32::MIN)..=f64::from(i32::MAX)).contains(&r) {
        return Err(Fault::from(format!(
            "`{}`: {x} does not fit an int",
            a.name
        )));
    }
    Ok(Out::Value(Value::Int(r as i32)))
}

fn norm(_: &mut Runtime, _: &mut Args, v: &Value) -> Result<Out, Fault> {
    let n = match v {
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

fn binary_list_to_integer(_: &mut Runtime, _: &mut Args, l: &Value) -> Result<Out, Fault> {
    let Value::List(items) = l else {
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

fn integer_to_binary_list(_: &mut Runtime, _: &mut Args, x: i32) -> Result<Out, Fault> {
    let x = x as u32;
    Ok(Out::Value(Value::List(
        (0..32).map(|k| Value::Bool(x >> k & 1 == 1)).collect(),
    )))
}

fn random(c: &mut Runtime, _: &mut Args) -> Result<Out, Fault> {
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

fn normalize(_: &mut Runtime, a: &mut Args, v: &Value) -> Result<Out, Fault> {
    let v = numbers(a, v)?;
    let n = v.iter().map(|x| x * x).sum::<f64>().sqrt();
    if n == 0.0 {
        return Err(Fault::from("`normalize`: the vector is zero"));
    }
    Ok(Out::Value(float_list(
        &v.iter().map(|x| x / n).collect::<Vec<f64>>(),
    )))
}

/// A list of numbers.
fn numbers(a: &Args, v: &Value) -> Result<Vec<f64>, Fault> {
    let Value::List(items) = v else {
        return Err(Fault::type_error(format!(
            "type error: `{}` needs a list of numbers, got {}",
            a.name,
            v.type_name()
        )));
    };
    items
        .iter()
        .map(|x| {
            x.as_f64().ok_or_else(|| {
                Fault::type_error(format!(
                    "type error: `{}` needs numbers, got {}",
                    a.name,
                    x.type_name()
                ))
            })
        })
        .collect()
}

/// `v` as a matrix: a list of equally long lists of numbers (a flat list is one row).
fn matrix(a: &Args, v: &Value) -> Result<Vec<Vec<f64>>, Fault> {
    let Value::List(rows) = v else {
        return Err(Fault::type_error(format!(
            "type error: `{}` needs a matrix, got {}",
            a.name,
            v.type_name()
        )));
    };
    let m: Vec<Vec<f64>> = if rows.iter().all(|r| matches!(r, Value::List(_))) {
        rows.iter()
            .map(|r| numbers(a, r))
            .collect::<Result<_, _>>()?
    } else {
        vec![numbers(a, v)?]
    };
    if m.is_empty() || m.iter().any(|r| r.len() != m[0].len() || r.is_empty()) {
        return Err(Fault::from(format!("`{}`: not a matrix", a.name)));
    }
    Ok(m)
}

fn to_value(m: Vec<Vec<f64>>) -> Value {
    Value::List(m.iter().map(|r| float_list(r)).collect())
}

fn inv(_: &mut Runtime, a: &mut Args, v: &Value) -> Result<Out, Fault> {
    if let Value::Pose(p) = v {
        return Ok(Out::Value(Value::Pose(crate::arm::pose::inv(*p))));
    }
    let mut m = matrix(a, v)?;
    let n = m.len();
    if m[0].len() != n {
        return Err(Fault::from("`inv`: the matrix is not square"));
    }
    // Gauss-Jordan with partial pivoting.
    let mut out: Vec<Vec<f64>> = (0..n)
        .map(|i| (0..n).map(|j| if i == j { 1.0 } else { 0.0 }).collect())
        .collect();
    for col in 0..n {
        let pivot = (col..n)
            .max_by(|&i, &j| m[i][col].abs().total_cmp(&m[j][col].abs()))
            .unwrap_or(col);
        if m[pivot][col].abs() < 1e-12 {
            return Err(Fault::from("`inv`: the matrix is singular"));
        }
        m.swap(col, pivot);
        out.swap(col, pivot);
        let d = m[col][col];
        for j in 0..n {
            m[col][j] /= d;
            out[col][j] /= d;
        }
        for i in 0..n {
            if i != col {
                let f = m[i][col];
                for j in 0..n {
                    m[i][j] -= f * m[col][j];
                    out[i][j] -= f * out[col][j];
                }
            }
        }
    }
    Ok(Out::Value(to_value(out)))
}

fn transpose(_: &mut Runtime, a: &mut Args, v: &Value) -> Result<Out, Fault> {
    let m = matrix(a, v)?;
    let t = (0..m[0].len())
        .map(|j| m.iter().map(|r| r[j]).collect())
        .collect();
    Ok(Out::Value(to_value(t)))
}
