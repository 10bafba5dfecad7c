//! Rigid transforms of poses `p[x, y, z, rx, ry, rz]` (rotation vectors, as the manual
//! defines them): `pose_trans`, `pose_inv`, `pose_add`, `pose_sub`.

type M = [[f64; 3]; 3];

pub(crate) fn to_matrix(r: [f64; 3]) -> M {
    let th = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
    if th < 1e-12 {
        return [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    }
    let (x, y, z) = (r[0] / th, r[1] / th, r[2] / th);
    let (c, s) = (th.cos(), th.sin());
    let t = 1.0 - c;
    [
        [c + x * x * t, x * y * t - z * s, x * z * t + y * s],
        [y * x * t + z * s, c + y * y * t, y * z * t - x * s],
        [z * x * t - y * s, z * y * t + x * s, c + z * z * t],
    ]
}

/// The rotation vector of a rotation matrix. θ comes from atan2(sin θ, cos θ), both read
/// off the matrix, so it keeps full precision near 0 and near π (acos alone loses half
/// the digits there); the axis from the antisymmetric part, or near π from the
/// symmetric part.
pub(crate) fn to_rotvec(m: M) -> [f64; 3] {
    let anti = [m[2][1] - m[1][2], m[0][2] - m[2][0], m[1][0] - m[0][1]];
    let two_sin = anti.iter().map(|a| a * a).sum::<f64>().sqrt();
    let cos = (m[0][0] + m[1][1] + m[2][2] - 1.0) / 2.0;
    let th = (two_sin / 2.0).atan2(cos);
    if th < 1e-12 {
        return [0.0; 3];
    }
    if two_sin > 1e-6 {
        return anti.map(|a| a / two_sin * th);
    }
    // θ near π: the axis from the symmetric part, pivoting on the largest diagonal
    // element (the others follow from the off-diagonal sums, which keep their relative
    // signs), then turned to agree with the antisymmetric part (sin θ · axis).
    let d = [m[0][0], m[1][1], m[2][2]];
    let k = if d[0] >= d[1] && d[0] >= d[2] {
        0
    } else if d[1] >= d[2] {
        1
    } else {
        2
    };
    let pivot = ((d[k] + 1.0) / 2.0).max(0.0).sqrt().max(1e-12);
    let mut axis = [0.0; 3];
    for (i, a) in axis.iter_mut().enumerate() {
        *a = if i == k {
            pivot
        } else {
            (m[i][k] + m[k][i]) / (4.0 * pivot)
        };
    }
    if axis.iter().zip(anti).map(|(a, b)| a * b).sum::<f64>() < 0.0 {
        axis = axis.map(|a| -a);
    }
    let n = axis.iter().map(|a| a * a).sum::<f64>().sqrt().max(1e-12);
    axis.map(|a| a / n * th)
}

pub(crate) fn mul(a: M, b: M) -> M {
    let mut o = [[0.0; 3]; 3];
    for (i, row) in o.iter_mut().enumerate() {
        for (j, cell) in row.iter_mut().enumerate() {
            *cell = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    o
}

pub(crate) fn transpose(a: M) -> M {
    let mut o = [[0.0; 3]; 3];
    for (i, row) in o.iter_mut().enumerate() {
        for (j, cell) in row.iter_mut().enumerate() {
            *cell = a[j][i];
        }
    }
    o
}

pub(crate) fn apply(a: M, v: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|i| (0..3).map(|k| a[i][k] * v[k]).sum())
}

fn split(p: [f64; 6]) -> ([f64; 3], M) {
    ([p[0], p[1], p[2]], to_matrix([p[3], p[4], p[5]]))
}

fn join(t: [f64; 3], r: M) -> [f64; 6] {
    let v = to_rotvec(r);
    [t[0], t[1], t[2], v[0], v[1], v[2]]
}

/// `pose_trans(p_from, p_from_to)`: `p_from_to` expressed in the frame `p_from`.
pub(crate) fn trans(a: [f64; 6], b: [f64; 6]) -> [f64; 6] {
    let (ta, ra) = split(a);
    let (tb, rb) = split(b);
    let t = apply(ra, tb);
    join([ta[0] + t[0], ta[1] + t[1], ta[2] + t[2]], mul(ra, rb))
}

/// `pose_inv(p)`.
pub(crate) fn inv(a: [f64; 6]) -> [f64; 6] {
    let (t, r) = split(a);
    let rt = transpose(r);
    let n = apply(rt, t);
    join([-n[0], -n[1], -n[2]], rt)
}

/// `pose_add(p_1, p_2)`: positions added, rotation `R2·R1`.
pub(crate) fn add(a: [f64; 6], b: [f64; 6]) -> [f64; 6] {
    let (ta, ra) = split(a);
    let (tb, rb) = split(b);
    join([ta[0] + tb[0], ta[1] + tb[1], ta[2] + tb[2]], mul(rb, ra))
}

/// `pose_sub(p_1, p_2)`: positions subtracted, rotation `R1·R2⁻¹`.
pub(crate) fn sub(a: [f64; 6], b: [f64; 6]) -> [f64; 6] {
    let (ta, ra) = split(a);
    let (tb, rb) = split(b);
    join(
        [ta[0] - tb[0], ta[1] - tb[1], ta[2] - tb[2]],
        mul(ra, transpose(rb)),
    )
}
