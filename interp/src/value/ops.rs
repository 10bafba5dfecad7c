//! The binary operators on values, matrix products included.

use super::Value;
use crate::error::{Fault, RuntimeErrorKind as K};
use crate::syntax::parser::BinOp;

/// The binary operators. Ints: 32-bit, wrapping on overflow; `/` of two ints is a float
/// division, `%` of two ints the truncating remainder; both fail on an int 0. A float on
/// either side makes the result a float. Poses add and subtract element-wise; lists of
/// numbers add, subtract, multiply and divide element-wise with a list of the same length
/// or a number (`q + qd * steptime`, `[...] / MULT`, as UR's driver scripts do).
pub(crate) fn binary(op: BinOp, l: Value, r: Value) -> Result<Value, Fault> {
    use Value::{Bool, Float, Int, List, Pose};
    let type_err = |l: &Value, r: &Value, sym: &str| {
        Err(Fault::new(
            K::Type,
            format!(
                "type error: {} {sym} {} ({} {sym} {})",
                l.type_name(),
                r.type_name(),
                l.to_source(),
                r.to_source()
            ),
        ))
    };
    let sym = match op {
        BinOp::Or => "or",
        BinOp::Xor => "xor",
        BinOp::And => "and",
        BinOp::Eq => "==",
        BinOp::Ne => "!=",
        BinOp::Lt => "<",
        BinOp::Le => "<=",
        BinOp::Gt => ">",
        BinOp::Ge => ">=",
        BinOp::Add => "+",
        BinOp::Sub => "-",
        BinOp::Mul => "*",
        BinOp::Div => "/",
        BinOp::Rem => "%",
    };
    match op {
        BinOp::Eq => return Ok(Bool(l == r)),
        BinOp::Ne => return Ok(Bool(l != r)),
        BinOp::Or | BinOp::Xor | BinOp::And => {
            return match (&l, &r) {
                (Bool(a), Bool(b)) => Ok(Bool(match op {
                    BinOp::Or => *a || *b,
                    BinOp::And => *a && *b,
                    _ => a != b,
                })),
                _ => type_err(&l, &r, sym),
            }
        }
        BinOp::Lt | BinOp::Le | BinOp::Gt | BinOp::Ge => {
            let (Some(a), Some(b)) = (l.as_f64(), r.as_f64()) else {
                return type_err(&l, &r, sym);
            };
            return Ok(Bool(match op {
                BinOp::Lt => a < b,
                BinOp::Le => a <= b,
                BinOp::Gt => a > b,
                _ => a >= b,
            }));
        }
        _ => {}
    }
    // Strings join with `+`, as on the controller (`"x = " + to_str(x)`), within the
    // controller's 1023-character strings.
    if let (Value::Str(a), Value::Str(b), BinOp::Add) = (&l, &r, op) {
        let len = a.len() + b.len();
        if len > super::MAX_STRING_LEN {
            return Err(Fault::from(format!(
                "string + string: the result would be {len} characters, more than {}",
                super::MAX_STRING_LEN
            )));
        }
        let mut out = Vec::with_capacity(len);
        out.extend_from_slice(a);
        out.extend_from_slice(b);
        return Ok(Value::Str(out));
    }
    // In arithmetic a bool is the number 0 or 1, as on the controller
    // (`1 * get_digital_in(0)`, `3 * True + False`).
    let as_number = |v: Value| match v {
        Bool(b) => Int(i32::from(b)),
        other => other,
    };
    let (l, r) = match (&l, &r) {
        (Bool(_), Int(_) | Float(_) | Bool(_)) | (Int(_) | Float(_), Bool(_)) => {
            (as_number(l), as_number(r))
        }
        _ => (l, r),
    };
    match (&l, &r) {
        (Int(a), Int(b)) => Ok(Int(match op {
            BinOp::Add => a.wrapping_add(*b),
            BinOp::Sub => a.wrapping_sub(*b),
            BinOp::Mul => a.wrapping_mul(*b),
            BinOp::Div | BinOp::Rem if *b == 0 => {
                return Err(Fault::new(
                    K::DivisionByZero,
                    format!("division by zero ({a} {sym} 0)"),
                ))
            }
            // As UR's own driver scripts rely on (`params[1] / MULT_jointstate`, two
            // ints): `/` of two ints is a float.
            BinOp::Div => return Ok(Float(f64::from(*a) / f64::from(*b))),
            _ => a.wrapping_rem(*b),
        })),
        // A matrix (a list of lists) times a matrix or a flat list is the matrix product,
        // as in the e-Series manual's matrix expressions (`inv(M) * f`); two flat lists
        // multiply element by element.
        (List(a), List(b)) if op == BinOp::Mul && is_matrix(a) => matrix_product(a, b),
        (List(a), List(b)) if matches!(op, BinOp::Add | BinOp::Sub | BinOp::Mul | BinOp::Div) => {
            if a.len() != b.len() {
                return Err(Fault::new(
                    K::Type,
                    format!(
                        "lists of different lengths: {} {sym} {}",
                        l.to_source(),
                        r.to_source()
                    ),
                ));
            }
            let items: Result<Vec<Value>, Fault> = a
                .iter()
                .zip(b)
                .map(|(x, y)| binary(op, x.clone(), y.clone()))
                .collect();
            Ok(List(items?))
        }
        (List(a), s)
            if s.as_f64().is_some()
                && matches!(op, BinOp::Add | BinOp::Sub | BinOp::Mul | BinOp::Div) =>
        {
            let items: Result<Vec<Value>, Fault> =
                a.iter().map(|x| binary(op, x.clone(), s.clone())).collect();
            Ok(List(items?))
        }
        (s, List(b))
            if s.as_f64().is_some() && matches!(op, BinOp::Add | BinOp::Sub | BinOp::Mul) =>
        {
            let items: Result<Vec<Value>, Fault> =
                b.iter().map(|x| binary(op, s.clone(), x.clone())).collect();
            Ok(List(items?))
        }
        (Pose(a), Pose(b)) if matches!(op, BinOp::Add | BinOp::Sub) => {
            let mut p = *a;
            for (x, y) in p.iter_mut().zip(b) {
                *x = if op == BinOp::Add { *x + y } else { *x - y };
            }
            Ok(Pose(p))
        }
        _ => {
            let (Some(a), Some(b)) = (l.as_f64(), r.as_f64()) else {
                return type_err(&l, &r, sym);
            };
            Ok(Float(match op {
                BinOp::Add => a + b,
                BinOp::Sub => a - b,
                BinOp::Mul => a * b,
                BinOp::Div => a / b,
                _ => a % b,
            }))
        }
    }
}

/// At most this many multiply-adds in one matrix product (a 1000×1000 by 1000×1000
/// product would hold the controller thread for seconds).
const MAX_MATRIX_PRODUCT_OPS: usize = 1 << 22;

/// Whether a list is a matrix: non-empty, and every element a list.
pub(crate) fn is_matrix(rows: &[Value]) -> bool {
    !rows.is_empty() && rows.iter().all(|r| matches!(r, Value::List(_)))
}

/// The numbers of one row of a matrix operand of `*`.
fn matrix_row(v: &Value) -> Result<Vec<f64>, Fault> {
    let Value::List(items) = v else {
        return Err(Fault::new(
            K::Type,
            format!(
                "matrix product: a row must be a list, got {}",
                v.type_name()
            ),
        ));
    };
    items
        .iter()
        .map(|x| {
            x.as_f64().ok_or_else(|| {
                Fault::new(
                    K::Type,
                    format!(
                        "matrix product: elements must be numbers, got {}",
                        x.type_name()
                    ),
                )
            })
        })
        .collect()
}

/// `a * b` where `a` is a matrix: `b` a matrix gives the matrix product, `b` a flat list
/// (a column vector) gives a flat list. Floats, as the controller's matrices hold.
fn matrix_product(a: &[Value], b: &[Value]) -> Result<Value, Fault> {
    let left: Vec<Vec<f64>> = a.iter().map(matrix_row).collect::<Result<_, _>>()?;
    let inner = left[0].len();
    if inner == 0 || left.iter().any(|r| r.len() != inner) {
        return Err(Fault::new(
            K::Type,
            "matrix product: rows empty or of different lengths",
        ));
    }
    let (right, column): (Vec<Vec<f64>>, bool) = if is_matrix(b) {
        (b.iter().map(matrix_row).collect::<Result<_, _>>()?, false)
    } else {
        let col = matrix_row(&Value::List(b.to_vec()))?;
        (col.into_iter().map(|x| vec![x]).collect(), true)
    };
    let cols = right.first().map_or(0, Vec::len);
    if right.len() != inner || right.iter().any(|r| r.len() != cols) {
        return Err(Fault::new(
            K::Type,
            format!(
                "matrix product: a {}×{inner} matrix times a {} with {} rows",
                left.len(),
                if column { "list" } else { "matrix" },
                right.len()
            ),
        ));
    }
    if left.len().saturating_mul(inner).saturating_mul(cols) > MAX_MATRIX_PRODUCT_OPS {
        return Err(Fault::new(
            K::Type,
            "matrix product: the matrices are too large",
        ));
    }
    let product: Vec<Vec<f64>> = left
        .iter()
        .map(|row| {
            (0..cols)
                .map(|j| row.iter().zip(&right).map(|(x, r)| x * r[j]).sum())
                .collect()
        })
        .collect();
    Ok(if column {
        Value::List(product.into_iter().map(|r| Value::Float(r[0])).collect())
    } else {
        Value::List(
            product
                .into_iter()
                .map(|r| Value::List(r.into_iter().map(Value::Float).collect()))
                .collect(),
        )
    })
}
