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

pub(crate) fn to_rotvec(m: M) -> [f64; 3] {
    let cos = ((m[0][0] + m[1][1] + m[2][2] - 1.0) / 2.0).clamp(-1.0, 1.0);
    let th = cos.acos();
    if th < 1e-12 {
        return [0.0; 3];
    }
    let s = th.sin();
    if s.abs() > 1e-6 {
        let k = th / (2.0 * s);
        return [
            (m[2][1] - m[1][2]) * k,
            (m[0][2] - m[2][0]) * k,
            (m[1][0] - m[0][1]) * k,
        ];
    }
    // θ near π: the axis from the diagonal.
    let x = ((m[0][0] + 1.0) / 2.0).max(0.0).sqrt();
    let y = ((m[1][1] + 1.0) / 2.0)
        .max(0.0)
        .sqrt()
        .copysign(m[0][1] + m[1][0]);
    let z = ((m[2][2] + 1.0) / 2.0)
        .max(0.0)
        .sqrt()
        .copysign(m[0][2] + m[2][0]);
    [x * th, y * th, z * th]
}

fn mul(a: M, b: M) -> M {
    let mut o = [[0.0; 3]; 3];
    for (i, row) in o.iter_mut().enumerate() {
        for (j, cell) in row.iter_mut().enumerate() {
            *cell = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    o
}

fn transpose(a: M) -> M {
    let mut o = [[0.0; 3]; 3];
    for (i, row) in o.iter_mut().enumerate() {
        for (j, cell) in row.iter_mut().enumerate() {
            *cell = a[j][i];
        }
    }
    o
}

fn apply(a: M, v: [f64; 3]) -> [f64; 3] {
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
