//! The arm in time: a motion command becomes a [`Motion`], a function of the time since
//! it started, and the controller sets the arm's joints, joint speeds and tool speed from
//! it at every step (so a thread, or a client sampling [`Machine::arm`](crate::Machine::arm),
//! sees the arm move, not jump).
//!
//! - Joint moves (`movej`, `optimovej`): a trapezoidal speed profile on the distance of the
//!   joint that moves furthest (accelerate at `a`, cruise at `v`, decelerate; a triangle
//!   when the move is too short to reach `v`); every joint follows it in proportion, so all
//!   start and arrive together.
//! - Tool moves (`movel`, `movep`, `optimovel`; `movec` on its arc): the same profile on the
//!   tool's path length; the position moves along the line (or the circle through the
//!   via point), the orientation turns about one axis from the start's to the target's;
//!   the joints at each step are the inverse kinematics nearest the previous step's.
//! - A time `t > 0` stretches (or shrinks) that profile to take `t`.
//! - `servoj`: straight to its target in joint space at constant speed over its `t`.
//! - `speedj`/`stopj`: the joint speeds ramp linearly to the target (the joint whose speed
//!   changes most at `a`, the others in proportion), the joints integrate them; the speed
//!   holds until the next motion command. `speedl`/`stopl`: the same for the tool speed;
//!   the joints follow the tool by inverse kinematics.
//!
//! - Blends (`r > 0`, [`blend_start`], [`blend`]): a move returns where the tool enters the
//!   sphere of radius `r` around its target; the next move, commanded then, is planned
//!   from that target and joined by a blend: for two joint moves a quadratic Bézier in
//!   joint space (control point: the waypoint), for two straight tool moves a circular
//!   arc tangent to both lines at constant tool speed, for two tool moves of which one is
//!   circular (`movec`) a cubic Bézier in tool space tangent to both paths, inside the
//!   sphere, at constant tool speed; the rest of the next move starts
//!   at the speed the blend hands over ([`Profile::with_start_speed`]); a joint move with
//!   a tool move, a cubic Bézier in joint space between the two moves' joint speeds. A move that
//!   cannot blend waits, queued ([`Motion::next`], at most one), until the first ends at
//!   rest at its target.
//!
//! The end state of a move is its target exactly.

use crate::arm::kinematics::{self, Dh};
use crate::arm::pose::{mul, to_matrix, to_rotvec, transpose};
use crate::arm::vec3::{cross, dot, norm, scale, sub};

type M = [[f64; 3]; 3];

/// A trapezoidal speed profile over a distance: a ramp from the start speed `v0` to the
/// peak `vp`, a cruise at `vp`, a ramp down to rest. A move from rest starts at `v0 = 0`;
/// the rest of a move after a blend starts at the speed the blend hands over.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Profile {
    /// The distance.
    d: f64,
    /// Start speed, peak speed, the first ramp's (signed) acceleration and the last
    /// ramp's deceleration, of the nominal profile.
    v0: f64,
    vp: f64,
    acc1: f64,
    dec: f64,
    /// Nominal times of the first ramp, of the last ramp, and in total.
    ta1: f64,
    ta: f64,
    t0: f64,
    /// Nominal time per real second (`t` given: the nominal profile stretched).
    scale: f64,
    /// Real duration (s).
    pub total: f64,
}

impl Profile {
    /// The profile over `d` at speed `v`, acceleration `a` (not positive: no ramps), taking
    /// `t` instead if `t > 0`. The nominal time is [`kinematics::move_time`]'s.
    pub fn new(d: f64, v: f64, a: f64, t: f64) -> Profile {
        let ok = |x: f64| x.is_finite() && x > 0.0;
        let d = if ok(d) { d } else { 0.0 };
        let t0 = kinematics::move_time(d, v, a);
        let (vp, acc, ta) = if !ok(t0) {
            (0.0, 0.0, 0.0)
        } else if !ok(a) {
            (d / t0, 0.0, 0.0)
        } else if d >= v * v / a {
            (v, a, v / a)
        } else {
            let ta = (d / a).sqrt();
            (a * ta, a, ta)
        };
        let mut p = Profile {
            d,
            v0: 0.0,
            vp,
            acc1: acc,
            dec: acc,
            ta1: ta,
            ta,
            t0,
            scale: 1.0,
            total: t0,
        };
        if ok(t) && d > 0.0 {
            if ok(t0) {
                p.scale = t0 / t;
            } else {
                // No usable speed: constant speed over t.
                p.vp = d / t;
                p.t0 = t;
            }
            p.total = t;
        }
        p
    }

    /// The profile over `d` that starts at speed `v0` (the speed a blend hands over):
    /// ramps at `a` to `v` (down, if `v0` is above it), cruises, ramps down at `a` to rest;
    /// a triangle if `d` is too short to reach `v`. If `d` is too short to stop from `v0`
    /// at `a`, it decelerates from `v0` to rest over `d` at the deceleration that takes
    /// (`v0² / 2d`, above `a`). Without a usable `a` the speed is constant (`v`, or `v0`).
    pub fn with_start_speed(d: f64, v0: f64, v: f64, a: f64) -> Profile {
        let ok = |x: f64| x.is_finite() && x > 0.0;
        let d = if ok(d) { d } else { 0.0 };
        let v0 = if ok(v0) { v0 } else { 0.0 };
        let v = if ok(v) { v } else { v0 };
        let mut p = Profile {
            d,
            v0,
            vp: v,
            acc1: 0.0,
            dec: 0.0,
            ta1: 0.0,
            ta: 0.0,
            t0: 0.0,
            scale: 1.0,
            total: 0.0,
        };
        if d <= 0.0 || !ok(v) {
            return p;
        }
        if !ok(a) {
            p.vp = v;
            p.v0 = v;
            p.t0 = d / v;
            p.total = p.t0;
            return p;
        }
        // Distances of the ramps to and from cruise at v.
        let ramp_up = (v0 - v).abs() / a;
        let s1 = 0.5 * (v0 + v) * ramp_up;
        let s3 = v * v / (2.0 * a);
        if s1 + s3 <= d {
            p.vp = v;
            p.ta1 = ramp_up;
            p.acc1 = if v >= v0 { a } else { -a };
            p.ta = v / a;
            p.dec = a;
            p.t0 = p.ta1 + (d - s1 - s3) / v + p.ta;
        } else {
            // A triangle from v0: up to vp then down, both at a.
            let vp = ((2.0 * a * d + v0 * v0) / 2.0).sqrt();
            if v0 <= v && vp >= v0 {
                p.vp = vp;
                p.acc1 = a;
                p.ta1 = (vp - v0) / a;
                p.dec = a;
                p.ta = vp / a;
                p.t0 = p.ta1 + p.ta;
            } else {
                // One deceleration from v0 to rest over d.
                p.vp = v0;
                p.dec = v0 * v0 / (2.0 * d);
                p.ta = 2.0 * d / v0;
                p.t0 = p.ta;
            }
        }
        p.total = p.t0;
        p
    }

    /// A constant speed `v` over `d` (a blend along its arc); ends at that speed.
    pub fn constant(d: f64, v: f64) -> Profile {
        let ok = |x: f64| x.is_finite() && x > 0.0;
        let (d, v) = if ok(d) && ok(v) { (d, v) } else { (0.0, 0.0) };
        let t0 = if v > 0.0 { d / v } else { 0.0 };
        Profile {
            d,
            v0: v,
            vp: v,
            acc1: 0.0,
            dec: 0.0,
            ta1: 0.0,
            ta: 0.0,
            t0,
            scale: 1.0,
            total: t0,
        }
    }

    /// Its distance.
    pub fn distance(&self) -> f64 {
        self.d
    }

    /// The cruise speed and acceleration this profile moves at, in real time (a profile
    /// stretched to a time `t` moves slower than its `v` and `a`).
    pub fn speed_and_acceleration(&self) -> (f64, f64) {
        (
            self.vp * self.scale,
            self.acc1.abs().max(self.dec) * self.scale * self.scale,
        )
    }

    /// Distance covered and speed, `t` seconds after the start.
    pub fn at(&self, t: f64) -> (f64, f64) {
        let tau = t.max(0.0) * self.scale;
        if tau >= self.t0 || self.d <= 0.0 {
            return (self.d, 0.0);
        }
        let s1 = self.v0 * self.ta1 + 0.5 * self.acc1 * self.ta1 * self.ta1;
        let (s, sd) = if tau < self.ta1 {
            (
                self.v0 * tau + 0.5 * self.acc1 * tau * tau,
                self.v0 + self.acc1 * tau,
            )
        } else if tau <= self.t0 - self.ta {
            (s1 + self.vp * (tau - self.ta1), self.vp)
        } else {
            let left = self.t0 - tau;
            (self.d - 0.5 * self.dec * left * left, self.dec * left)
        };
        (s.clamp(0.0, self.d), sd * self.scale)
    }

    /// The time (s) at which the profile has covered `s` (bisection: the distance only
    /// grows; 60 halvings of the duration).
    pub fn time_at(&self, s: f64) -> f64 {
        let (mut lo, mut hi) = (0.0, self.total);
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if self.at(mid).0 < s {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        hi
    }
}

/// The tool's path in space: a line, or an arc of a circle.
#[derive(Debug, Clone, Copy, PartialEq)]
// The Bézier's length table keeps it `Copy` and its sampling free of allocation; a path
// lives in a motion or two at a time.
#[allow(clippy::large_enum_variant)]
pub(crate) enum Path {
    Line {
        from: [f64; 3],
        to: [f64; 3],
    },
    /// Centre, radius, the unit vectors from the centre to the start and a quarter turn on,
    /// the angle swept.
    Arc {
        c: [f64; 3],
        r: f64,
        u: [f64; 3],
        w: [f64; 3],
        angle: f64,
    },
    /// A cubic Bézier curve (a blend between a straight and a circular move, or two
    /// circular ones) by its control points, parameterised by arc length: `len[i]` is
    /// the length of the polyline through its points at `t = j / BEZIER_CHORDS`, `j <= i`.
    Bezier {
        p: [[f64; 3]; 4],
        len: [f64; BEZIER_CHORDS + 1],
    },
}

/// The chords that measure a [`Path::Bezier`]'s length: bounds the work per sample.
pub(crate) const BEZIER_CHORDS: usize = 64;

fn bezier_point(p: &[[f64; 3]; 4], t: f64) -> [f64; 3] {
    let m = 1.0 - t;
    let (b0, b1, b2, b3) = (m * m * m, 3.0 * m * m * t, 3.0 * m * t * t, t * t * t);
    std::array::from_fn(|k| b0 * p[0][k] + b1 * p[1][k] + b2 * p[2][k] + b3 * p[3][k])
}

fn bezier_tangent(p: &[[f64; 3]; 4], t: f64) -> [f64; 3] {
    let m = 1.0 - t;
    let d: [f64; 3] = std::array::from_fn(|k| {
        3.0 * m * m * (p[1][k] - p[0][k])
            + 6.0 * m * t * (p[2][k] - p[1][k])
            + 3.0 * t * t * (p[3][k] - p[2][k])
    });
    let n = norm(d);
    if n > 0.0 && n.is_finite() {
        scale(1.0 / n, d)
    } else {
        [0.0; 3]
    }
}

impl Path {
    /// The cubic Bézier through control points `p`, measured on [`BEZIER_CHORDS`] chords.
    fn bezier(p: [[f64; 3]; 4]) -> Path {
        let mut len = [0.0; BEZIER_CHORDS + 1];
        let n = BEZIER_CHORDS as f64;
        let mut prev = p[0];
        for i in 1..=BEZIER_CHORDS {
            let q = bezier_point(&p, i as f64 / n);
            len[i] = len[i - 1] + norm(sub(q, prev));
            prev = q;
        }
        Path::Bezier { p, len }
    }

    /// A Bézier's curve parameter at fraction `f` of its length.
    fn bezier_param(len: &[f64; BEZIER_CHORDS + 1], f: f64) -> f64 {
        let total = len[BEZIER_CHORDS];
        if total.is_nan() || total <= 0.0 {
            return f.clamp(0.0, 1.0);
        }
        let s = (f * total).clamp(0.0, total);
        let i = len.partition_point(|x| *x <= s).clamp(1, BEZIER_CHORDS) - 1;
        let seg = len[i + 1] - len[i];
        let frac = if seg > 0.0 { (s - len[i]) / seg } else { 0.0 };
        (i as f64 + frac.clamp(0.0, 1.0)) / BEZIER_CHORDS as f64
    }
}

fn xyz(p: [f64; 6]) -> [f64; 3] {
    [p[0], p[1], p[2]]
}
fn rot(p: [f64; 6]) -> M {
    to_matrix([p[3], p[4], p[5]])
}

impl Path {
    /// The line from `from` to `to`, or the arc from `from` through `via` to `to` (a line
    /// if the three points are on one line).
    pub fn new(from: [f64; 6], via: Option<[f64; 6]>, to: [f64; 6]) -> Path {
        let (p0, p1) = (xyz(from), xyz(to));
        let line = Path::Line { from: p0, to: p1 };
        let Some(via) = via else { return line };
        let pv = xyz(via);
        let a = sub(p0, p1);
        let b = sub(pv, p1);
        let axb = cross(a, b);
        let n2 = dot(axb, axb);
        if !n2.is_finite() || n2 < 1e-18 {
            return line;
        }
        let k = sub(scale(dot(a, a), b), scale(dot(b, b), a));
        let off = scale(1.0 / (2.0 * n2), cross(k, axb));
        let c = [p1[0] + off[0], p1[1] + off[1], p1[2] + off[2]];
        let r = norm(sub(p0, c));
        let n = cross(sub(pv, p0), sub(p1, pv));
        let nn = norm(n);
        if !(r.is_finite() && r > 1e-9 && nn > 1e-18) {
            return line;
        }
        let n = scale(1.0 / nn, n);
        let u = scale(1.0 / r, sub(p0, c));
        let w = cross(n, u);
        let e = sub(p1, c);
        let mut angle = dot(e, w).atan2(dot(e, u));
        if angle <= 0.0 {
            angle += std::f64::consts::TAU;
        }
        Path::Arc { c, r, u, w, angle }
    }

    /// Its length (m).
    pub fn length(&self) -> f64 {
        match *self {
            Path::Line { from, to } => norm(sub(to, from)),
            Path::Arc { r, angle, .. } => r * angle,
            Path::Bezier { len, .. } => len[BEZIER_CHORDS],
        }
    }

    /// What is left of the path from fraction `f` of the way on.
    fn rest_from(&self, f: f64) -> Path {
        match *self {
            Path::Line { to, .. } => Path::Line {
                from: self.at(f).0,
                to,
            },
            Path::Arc { c, r, u, w, angle } => {
                let (s, co) = (angle * f).sin_cos();
                Path::Arc {
                    c,
                    r,
                    u: std::array::from_fn(|k| co * u[k] + s * w[k]),
                    w: std::array::from_fn(|k| -s * u[k] + co * w[k]),
                    angle: angle * (1.0 - f),
                }
            }
            Path::Bezier { p, len } => {
                // De Casteljau's split at the curve parameter: the second half.
                let t = Path::bezier_param(&len, f);
                let l = |a: [f64; 3], b: [f64; 3]| -> [f64; 3] {
                    std::array::from_fn(|k| a[k] + (b[k] - a[k]) * t)
                };
                let (a, b, c) = (l(p[0], p[1]), l(p[1], p[2]), l(p[2], p[3]));
                let (d, e) = (l(a, b), l(b, c));
                Path::bezier([l(d, e), e, c, p[3]])
            }
        }
    }

    /// The point at fraction `f` of the way, and the unit tangent there.
    fn at(&self, f: f64) -> ([f64; 3], [f64; 3]) {
        match *self {
            Path::Line { from, to } => {
                let d = sub(to, from);
                let l = norm(d);
                let t = if l > 0.0 { scale(1.0 / l, d) } else { [0.0; 3] };
                (
                    [from[0] + d[0] * f, from[1] + d[1] * f, from[2] + d[2] * f],
                    t,
                )
            }
            Path::Arc { c, r, u, w, angle } => {
                let (s, co) = (angle * f).sin_cos();
                let p = [
                    c[0] + r * (co * u[0] + s * w[0]),
                    c[1] + r * (co * u[1] + s * w[1]),
                    c[2] + r * (co * u[2] + s * w[2]),
                ];
                let t = [
                    -s * u[0] + co * w[0],
                    -s * u[1] + co * w[1],
                    -s * u[2] + co * w[2],
                ];
                (p, t)
            }
            Path::Bezier { p, len } => {
                let t = Path::bezier_param(&len, f);
                (bezier_point(&p, t), bezier_tangent(&p, t))
            }
        }
    }
}

/// What the arm does.
#[derive(Debug, Clone, PartialEq)]
#[allow(clippy::large_enum_variant)]
pub(crate) enum Kind {
    /// Joint space, along a profile on the largest joint distance.
    Joint {
        q0: [f64; 6],
        q1: [f64; 6],
        profile: Profile,
    },
    /// Tool space: position along `path`, orientation turning by `turn` (a rotation vector
    /// in the base frame) from `r0`, both along `profile` on the path length (or on the
    /// turn, for a move that only turns); joints by inverse kinematics; `q1` at the end.
    Tool {
        path: Path,
        r0: M,
        turn: [f64; 3],
        profile: Profile,
        /// The profile's distance: the path length (or the turn's angle).
        dist: f64,
        /// The target pose; the joints at the start and at the target (given, or the
        /// inverse kinematics nearest the start), and whether they were given.
        to: [f64; 6],
        q0: [f64; 6],
        q1: [f64; 6],
        given: bool,
    },
    /// Joint speeds ramping linearly from `qd0` to `qd1` over `ramp` seconds, then held.
    JointSpeed {
        q0: [f64; 6],
        qd0: [f64; 6],
        qd1: [f64; 6],
        ramp: f64,
    },
    /// Tool speed ramping linearly from `v0` to `v1` over `ramp` seconds, then held.
    ToolSpeed {
        p0: [f64; 6],
        v0: [f64; 6],
        v1: [f64; 6],
        ramp: f64,
    },
    /// A blend in joint space over `dur` seconds: the cubic Bézier from `p1` (where the
    /// blend starts) through control points `c1`, `c2` to `p2` (where the next move's
    /// path is rejoined), so that the joint speeds at its ends are the moves' there
    /// (`3 (c1 - p1) / dur`, `3 (p2 - c2) / dur`). `w`: the waypoint's joints.
    JointBlend {
        p1: [f64; 6],
        c1: [f64; 6],
        c2: [f64; 6],
        p2: [f64; 6],
        w: [f64; 6],
        dur: f64,
    },
    /// `first` for `dur` seconds, then `rest` (a blend, then the rest of the next move).
    Then {
        first: Box<Kind>,
        dur: f64,
        rest: Box<Kind>,
    },
}

/// A motion under way.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Motion {
    pub kind: Kind,
    /// The motion clock (steps) it started at.
    pub start: f64,
    /// The thread that commanded it (a kill of that thread stops the arm).
    pub owner: u32,
    /// The TCP offset the tool moves of (for tool motions).
    pub tcp: [f64; 6],
    /// The blend at its target, if the move has a blend radius: the program got control
    /// back when it began.
    pub blend: Option<BlendStart>,
    /// The move commanded after the blend began (too late to blend): it starts where and
    /// when this one ends, at rest. The controller's lookahead: at most one.
    pub next: Option<Box<Motion>>,
}

/// Where a move's blend begins: the tool enters the sphere of radius `r` (m) around the
/// target, `at` seconds after the move started.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct BlendStart {
    pub r: f64,
    pub at: f64,
    /// The motion clock (steps, see `crate::runtime::MotionClock`) at which the
    /// program gets control back (set by the controller).
    pub back: f64,
    /// The first step the program may get control back in (the one after the move's
    /// command: a move takes at least a step).
    pub after: u64,
    /// The step the program got control back in: the first whose motion clock reached
    /// `back` (`u64::MAX` until then; set by the controller).
    pub step: u64,
}

/// Where the arm is `t` seconds into a motion: joints, joint speeds, tool speed (base
/// frame), and whether the motion is over (its end state reached for good).
pub(crate) struct Sample {
    pub q: [f64; 6],
    pub qd: [f64; 6],
    /// Known tool speed (tool motions); `None`: derive it from the joints.
    pub tcp_speed: Option<[f64; 6]>,
    pub done: bool,
    /// The motion cannot go on (a straight tool move whose path has left the arm's
    /// reach): the arm stops here and the controller makes it a protective stop.
    pub stop: bool,
}

/// Whether joints `q` put the tool (offset `tcp`) at `pose`, within 0.1 mm and 1 mrad.
fn reaches(dh: &Dh, q: &[f64; 6], tcp: &[f64; 6], pose: &[f64; 6]) -> bool {
    let at = kinematics::forward(dh, *q, *tcp);
    let position = (0..3).all(|k| (at[k] - pose[k]).abs() < 1e-4);
    let r = mul(transpose(rot(at)), rot(*pose));
    let angle = to_rotvec(r);
    position && (angle[0] * angle[0] + angle[1] * angle[1] + angle[2] * angle[2]).sqrt() < 1e-3
}

/// The speed ramp's linear interpolation: speed and distance `t` s into it.
fn ramp(v0: f64, v1: f64, ramp: f64, t: f64) -> (f64, f64) {
    if ramp <= 0.0 || t >= ramp {
        let r = ramp.max(0.0);
        (v1, 0.5 * (v0 + v1) * r + v1 * (t - r).max(0.0))
    } else {
        let v = v0 + (v1 - v0) * t / ramp;
        (v, 0.5 * (v0 + v) * t)
    }
}

/// The time a speed change from `from` to `to` takes at `a` on the component that
/// changes most (0: at once).
pub(crate) fn ramp_time(from: &[f64], to: &[f64], a: f64) -> f64 {
    let most = from
        .iter()
        .zip(to)
        .map(|(x, y)| (y - x).abs())
        .fold(0.0, f64::max);
    if a.is_finite() && a > 0.0 && most.is_finite() {
        most / a
    } else {
        0.0
    }
}

impl Motion {
    /// The arm `t` seconds in; `prev_q` the joints at the previous sample (for inverse
    /// kinematics).
    pub fn sample(&self, dh: &Dh, t: f64, prev_q: [f64; 6]) -> Sample {
        self.kind.sample(dh, self.tcp, t, prev_q)
    }

    /// The target of the move under way (`get_target_waypoint`): the tool pose at its
    /// target; during a blend, the next move's target.
    pub fn waypoint(&self, dh: &Dh) -> Option<[f64; 6]> {
        match self.kind.last() {
            Kind::Joint { q1, .. } => Some(kinematics::forward(dh, *q1, self.tcp)),
            Kind::Tool { to, .. } => Some(*to),
            _ => None,
        }
    }

    /// Its duration (s): infinite for a speed held.
    pub fn duration(&self) -> f64 {
        self.kind.duration()
    }
}

impl Kind {
    /// The last move of a blended sequence (itself, for a single one), and the time it
    /// starts at.
    pub fn last_with_offset(&self) -> (&Kind, f64) {
        let mut k = self;
        let mut off = 0.0;
        // A sequence is one blend and one rest deep; the loop is bounded by that nesting.
        while let Kind::Then { dur, rest, .. } = k {
            off += *dur;
            k = rest;
        }
        (k, off)
    }

    /// The last move of a blended sequence.
    pub fn last(&self) -> &Kind {
        self.last_with_offset().0
    }

    /// Its duration (s): infinite for a speed held.
    pub fn duration(&self) -> f64 {
        match self {
            Kind::Joint { profile, .. } | Kind::Tool { profile, .. } => profile.total,
            Kind::JointBlend { dur, .. } => *dur,
            Kind::Then { dur, rest, .. } => dur + rest.duration(),
            Kind::JointSpeed { .. } | Kind::ToolSpeed { .. } => f64::INFINITY,
        }
    }

    /// The joints and tool pose (through `tcp`) where the move ends.
    pub fn end(&self, dh: &Dh, tcp: [f64; 6]) -> Option<([f64; 6], [f64; 6])> {
        match self.last() {
            Kind::Joint { q1, .. } => Some((*q1, kinematics::forward(dh, *q1, tcp))),
            Kind::Tool { q1, to, .. } => Some((*q1, *to)),
            _ => None,
        }
    }

    /// The arm `t` seconds in (see [`Motion::sample`]).
    pub fn sample(&self, dh: &Dh, tcp: [f64; 6], t: f64, prev_q: [f64; 6]) -> Sample {
        match self {
            Kind::Then { first, dur, rest } => {
                if t < *dur {
                    first.sample(dh, tcp, t, prev_q)
                } else {
                    rest.sample(dh, tcp, t - dur, prev_q)
                }
            }
            Kind::JointBlend {
                p1,
                c1,
                c2,
                p2,
                dur,
                ..
            } => {
                let (q, qd) = bezier(*p1, *c1, *c2, *p2, *dur, t);
                Sample {
                    q,
                    qd,
                    tcp_speed: None,
                    done: false,
                    stop: false,
                }
            }
            Kind::Joint { q0, q1, profile } => {
                if t >= profile.total {
                    return Sample {
                        q: *q1,
                        qd: [0.0; 6],
                        tcp_speed: Some([0.0; 6]),
                        done: true,
                        stop: false,
                    };
                }
                let (s, sd) = profile.at(t);
                let d = profile.d;
                let mut q = *q0;
                let mut qd = [0.0; 6];
                if d > 0.0 {
                    for k in 0..6 {
                        let dq = q1[k] - q0[k];
                        q[k] = q0[k] + dq * (s / d);
                        qd[k] = dq * (sd / d);
                    }
                }
                Sample {
                    q,
                    qd,
                    tcp_speed: None,
                    done: false,
                    stop: false,
                }
            }
            Kind::Tool {
                path,
                r0,
                turn,
                profile,
                dist,
                to,
                q0,
                q1,
                given,
            } => {
                if t >= profile.total {
                    // The joints that follow the path to the target: the ones given, if
                    // the path led there, else the solution nearest the last step's.
                    let near = |q: &[f64; 6]| (0..6).all(|k| (q[k] - prev_q[k]).abs() < 0.1);
                    let q = if *given && near(q1) {
                        *q1
                    } else {
                        nearest_ik(dh, *to, tcp, prev_q).unwrap_or(*q1)
                    };
                    return Sample {
                        q,
                        qd: [0.0; 6],
                        tcp_speed: Some([0.0; 6]),
                        done: true,
                        stop: false,
                    };
                }
                let (s, sd) = profile.at(t);
                let f = if *dist > 0.0 { s / dist } else { 1.0 };
                let fd = if *dist > 0.0 { sd / dist } else { 0.0 };
                let (p, tangent) = path.at(f);
                let r = mul(to_matrix(scale(f, *turn)), *r0);
                let rv = to_rotvec(r);
                let pose = [p[0], p[1], p[2], rv[0], rv[1], rv[2]];
                let v = scale(fd * path.length(), tangent);
                let w = scale(fd, *turn);
                let xd = [v[0], v[1], v[2], w[0], w[1], w[2]];
                match nearest_ik(dh, pose, tcp, prev_q) {
                    Some(q) => Sample {
                        q,
                        qd: joint_speed(dh, q, tcp, xd),
                        tcp_speed: Some(xd),
                        done: false,
                        stop: false,
                    },
                    // No solution here, and none at the target either (the joints
                    // given for it are not where it is): the line has left the arm's
                    // reach. A real arm runs into a singularity there and stops with a
                    // protective stop (UR's client library tests a `movel` to an
                    // unfeasible target that way): it stops where it is.
                    None if !reaches(dh, q1, &tcp, to) => Sample {
                        q: prev_q,
                        qd: [0.0; 6],
                        tcp_speed: Some([0.0; 6]),
                        done: true,
                        stop: true,
                    },
                    // No solution here (a singularity on the way): the joints move in
                    // joint space at the same fraction of the move.
                    None => Sample {
                        q: std::array::from_fn(|k| q0[k] + (q1[k] - q0[k]) * f),
                        qd: std::array::from_fn(|k| (q1[k] - q0[k]) * fd),
                        tcp_speed: None,
                        done: false,
                        stop: false,
                    },
                }
            }
            Kind::JointSpeed {
                q0,
                qd0,
                qd1,
                ramp: r,
            } => {
                let mut q = *q0;
                let mut qd = [0.0; 6];
                for k in 0..6 {
                    let (v, x) = ramp(qd0[k], qd1[k], *r, t);
                    qd[k] = v;
                    q[k] += x;
                }
                // A stop (all speeds to 0) is over once the speed is 0.
                let stopped = qd1.iter().all(|v| *v == 0.0) && t >= *r;
                Sample {
                    q,
                    qd,
                    tcp_speed: None,
                    done: stopped,
                    stop: false,
                }
            }
            Kind::ToolSpeed {
                p0,
                v0,
                v1,
                ramp: r,
            } => {
                let mut x = [0.0; 6];
                let mut v = [0.0; 6];
                for k in 0..6 {
                    (v[k], x[k]) = ramp(v0[k], v1[k], *r, t);
                }
                // Translation added; rotation turned about the base axes.
                let rr = mul(to_matrix([x[3], x[4], x[5]]), rot(*p0));
                let rv = to_rotvec(rr);
                let pose = [
                    p0[0] + x[0],
                    p0[1] + x[1],
                    p0[2] + x[2],
                    rv[0],
                    rv[1],
                    rv[2],
                ];
                let q = nearest_ik(dh, pose, tcp, prev_q);
                let stopped = v1.iter().all(|s| *s == 0.0) && t >= *r;
                Sample {
                    q: q.unwrap_or(prev_q),
                    qd: match q {
                        Some(q) => joint_speed(dh, q, tcp, v),
                        None => [0.0; 6],
                    },
                    tcp_speed: Some(if q.is_some() { v } else { [0.0; 6] }),
                    done: stopped || q.is_none(),
                    stop: false,
                }
            }
        }
    }
}

/// Whether a move at speed `v0` can stop within `d` at deceleration `a` (none: at once).
/// The rest of a move after a blend must be able to: the move after it is not known yet,
/// and the arm must stop at the target if none comes.
fn can_stop(v0: f64, d: f64, a: f64) -> bool {
    !(a.is_finite() && a > 0.0) || v0 * v0 / (2.0 * a) <= d + 1e-12
}

/// The cubic Bézier `p1, c1, c2, p2` over `dur` seconds, `t` seconds in: joints and
/// joint speeds.
fn bezier(
    p1: [f64; 6],
    c1: [f64; 6],
    c2: [f64; 6],
    p2: [f64; 6],
    dur: f64,
    t: f64,
) -> ([f64; 6], [f64; 6]) {
    let sg = if dur > 0.0 {
        (t / dur).clamp(0.0, 1.0)
    } else {
        1.0
    };
    let u = 1.0 - sg;
    let (b0, b1, b2, b3) = (u * u * u, 3.0 * u * u * sg, 3.0 * u * sg * sg, sg * sg * sg);
    let k = if dur > 0.0 { 3.0 / dur } else { 0.0 };
    (
        std::array::from_fn(|j| b0 * p1[j] + b1 * c1[j] + b2 * c2[j] + b3 * p2[j]),
        std::array::from_fn(|j| {
            k * (u * u * (c1[j] - p1[j])
                + 2.0 * u * sg * (c2[j] - c1[j])
                + sg * sg * (p2[j] - c2[j]))
        }),
    )
}

/// Points sampled along a move to find where the tool crosses a blend's sphere (then
/// refined by 40 bisections): bounds the work of planning one blend.
const CROSSING_SAMPLES: u32 = 256;

/// The fraction of the way at which `dist` (the tool's distance from a point, at a
/// fraction of the way) crosses `r`: coming back from the end (`from_end`, where the tool
/// enters the sphere before the target) or going out from the start (where it leaves
/// the sphere around the start). `None` if it never does.
fn crossing(dist: impl Fn(f64) -> f64, r: f64, from_end: bool) -> Option<f64> {
    let n = f64::from(CROSSING_SAMPLES);
    let at = |k: u32| {
        let f = f64::from(k) / n;
        if from_end {
            1.0 - f
        } else {
            f
        }
    };
    // The first sample (from the chosen end) outside the sphere.
    let k = (1..=CROSSING_SAMPLES).find(|k| dist(at(*k)) > r)?;
    // Between the sample before it (inside) and it (outside).
    let (mut inside, mut outside) = (at(k - 1), at(k));
    for _ in 0..40 {
        let mid = 0.5 * (inside + outside);
        if dist(mid) > r {
            outside = mid;
        } else {
            inside = mid;
        }
    }
    Some(inside)
}

fn lerp6(a: [f64; 6], b: [f64; 6], f: f64) -> [f64; 6] {
    std::array::from_fn(|k| a[k] + (b[k] - a[k]) * f)
}

fn with_rot(p: [f64; 3], r: M) -> [f64; 6] {
    let v = to_rotvec(r);
    [p[0], p[1], p[2], v[0], v[1], v[2]]
}

/// Where the blend at the end of `kind` (a move, or the rest of one after a blend)
/// begins, for blend radius `r` (m): the time the tool enters the sphere of radius `r`
/// around the target. The radius is first limited so that this blend does not overlap
/// the one before it (UR: blends cannot overlap): to the distance from the previous
/// blend's waypoint to this target less the previous radius (for a move not blended
/// into, to the move's own length). `None`: no blend (`r` not positive, or nothing left
/// of the move to blend over).
///
/// Also returns the radius it was limited to when that is less than `r` (the blends
/// would overlap, or the move is shorter than `r`): the controller warns of it.
pub(crate) fn blend_start(
    dh: &Dh,
    tcp: [f64; 6],
    kind: &Kind,
    r: f64,
) -> (Option<BlendStart>, Option<f64>) {
    if !(r.is_finite() && r > 0.0) {
        return (None, None);
    }
    let cap = radius_cap(dh, tcp, kind);
    let reduced = cap.filter(|c| *c < r).map(|c| c.max(0.0));
    (blend_start_inner(dh, tcp, kind, r), reduced)
}

/// The most a blend radius at the end of `kind` may be (see [`blend_start`]); `None`
/// for a motion that does not blend.
fn radius_cap(dh: &Dh, tcp: [f64; 6], kind: &Kind) -> Option<f64> {
    let (last, _) = kind.last_with_offset();
    match last {
        Kind::Tool { path, .. } => Some(path.length()),
        Kind::Joint { q0, q1, .. } => {
            let fk = |q: [f64; 6]| xyz(kinematics::forward(dh, q, tcp));
            let target = fk(*q1);
            Some(match kind {
                Kind::Then { first, .. } => match **first {
                    Kind::JointBlend { p1, w, .. } => {
                        norm(sub(target, fk(w))) - norm(sub(fk(p1), fk(w)))
                    }
                    _ => norm(sub(target, fk(*q0))),
                },
                _ => norm(sub(target, fk(*q0))),
            })
        }
        _ => None,
    }
}

fn blend_start_inner(dh: &Dh, tcp: [f64; 6], kind: &Kind, r: f64) -> Option<BlendStart> {
    if !(r.is_finite() && r > 0.0) {
        return None;
    }
    let (last, off) = kind.last_with_offset();
    match last {
        Kind::Tool {
            path,
            profile,
            dist,
            to,
            ..
        } => {
            // The rest of a tool move after a blend already starts past the previous
            // blend: its own length is the room left.
            let cap = path.length();
            let r = r.min(cap);
            if r <= 1e-9 || *dist <= 0.0 {
                return None;
            }
            let target = xyz(*to);
            // All of it within r (the room left is exactly r): the blend begins at once.
            let f = crossing(|f| norm(sub(path.at(f).0, target)), r, true).unwrap_or(0.0);
            Some(BlendStart {
                r,
                at: off + profile.time_at(f * dist),
                back: 0.0,
                after: 0,
                step: 0,
            })
        }
        Kind::Joint { q0, q1, profile } => {
            let fk = |q: [f64; 6]| xyz(kinematics::forward(dh, q, tcp));
            let target = fk(*q1);
            let cap = match kind {
                Kind::Then { first, .. } => match **first {
                    Kind::JointBlend { p1, w, .. } => {
                        norm(sub(target, fk(w))) - norm(sub(fk(p1), fk(w)))
                    }
                    _ => norm(sub(target, fk(*q0))),
                },
                _ => norm(sub(target, fk(*q0))),
            };
            let r = r.min(cap);
            if r <= 1e-9 || profile.distance() <= 0.0 {
                return None;
            }
            let f = crossing(|f| norm(sub(fk(lerp6(*q0, *q1, f)), target)), r, true).unwrap_or(0.0);
            Some(BlendStart {
                r,
                at: off + profile.time_at(f * profile.distance()),
                back: 0.0,
                after: 0,
                step: 0,
            })
        }
        _ => None,
    }
}

/// The blend from the move `a`, `t` seconds into it (where its blend begins: the arm at
/// joints `q_now`), into the next move `b` (planned from `a`'s target), then the rest of
/// `b`; `None` if these two cannot blend (then the arm stops at `a`'s target and `b`
/// starts from there):
///
/// - `movej` into `movej`: in joint space, the quadratic Bézier from the joints now,
///   with the waypoint as control point, to the point of `b` where the tool leaves the
///   sphere it entered; its speed at each end is the moves' there (joint speeds
///   continuous), so the rest of `b` starts at the speed the blend hands over.
/// - A straight tool move (`movel`, `movep`) into another: a circular arc tangent to both
///   lines, entered where the tool is now (at distance `r` before the waypoint) and left
///   at the same distance after it along `b`, at the constant tool speed the tool has
///   now (movep's "blend circular ... constant tool speed"); it lies within `r` of the
///   waypoint. The orientation turns from `a`'s to `b`'s at those two points.
/// - Two tool moves of which one at least is circular (`movec`): a cubic Bézier in tool
///   space tangent to both paths, inside the sphere, at constant tool speed
///   ([`curve_blend`]; where none fits, the joint-space blend below).
/// - A joint move into a tool move or one into the other: a cubic Bézier in joint space
///   ([`mixed_blend`]).
/// - Not blended: `b` shorter than
///   the radius (its target inside the sphere: the blends would overlap), a turn back
///   along the same line, an arm at rest, and a blend that would take longer than
///   stopping at the waypoint and starting again (it begins so early, for a radius close
///   to the move's length, that the arm has not gathered speed: the blend moves at the
///   speed it has where it begins), and a blend after which the rest of `b` is too short
///   to stop in at `b`'s acceleration from the speed the blend hands over (the move
///   after `b` is not known yet: the arm must be able to stop at `b`'s target).
pub(crate) fn blend(
    dh: &Dh,
    tcp: [f64; 6],
    (a, t): (&Kind, f64),
    b: &Kind,
    q_now: [f64; 6],
) -> Option<Kind> {
    let (la, off) = a.last_with_offset();
    let tl = t - off;
    if tl < 0.0 {
        return None;
    }
    match (la, b) {
        (
            Kind::Joint { q0, q1, profile },
            Kind::Joint {
                q0: b0,
                q1: b1,
                profile: pb,
            },
        ) => {
            let (s, sd) = profile.at(tl);
            let d = profile.distance();
            let db = pb.distance();
            if !(sd > 1e-9 && d > 0.0 && db > 0.0) {
                return None;
            }
            let p1 = lerp6(*q0, *q1, s / d);
            let dur = 2.0 * (d - s) / sd;
            let fk = |q: [f64; 6]| xyz(kinematics::forward(dh, q, tcp));
            let w = fk(*q1);
            let r1 = norm(sub(fk(p1), w));
            let g = crossing(|f| norm(sub(fk(lerp6(*b0, *b1, f)), w)), r1, false)?;
            if !(dur > 0.0 && dur.is_finite() && g > 0.0 && g < 1.0) {
                return None;
            }
            let p2 = lerp6(*b0, *b1, g);
            // A blend slower than stopping at the waypoint (it begins before the arm has
            // gathered speed: a radius close to the move's length) is not made.
            if dur > profile.total - tl + pb.time_at(g * db) {
                return None;
            }
            let (vb, ab) = pb.speed_and_acceleration();
            if !can_stop(2.0 * g * db / dur, (1.0 - g) * db, ab) {
                return None;
            }
            let rest = Kind::Joint {
                q0: p2,
                q1: *b1,
                profile: Profile::with_start_speed((1.0 - g) * db, 2.0 * g * db / dur, vb, ab),
            };
            // The quadratic Bézier with the waypoint as control point, as a cubic.
            Some(Kind::Then {
                first: Box::new(Kind::JointBlend {
                    p1,
                    c1: lerp6(p1, *q1, 2.0 / 3.0),
                    c2: lerp6(p2, *q1, 2.0 / 3.0),
                    p2,
                    w: *q1,
                    dur,
                }),
                dur,
                rest: Box::new(rest),
            })
        }
        (
            Kind::Tool {
                path: Path::Line { from: a0, to: wp },
                r0: ra,
                turn: ta,
                profile,
                dist,
                q1: qa1,
                ..
            },
            Kind::Tool {
                path: Path::Line { to: c, .. },
                r0: rb,
                turn: tb,
                profile: pb,
                to: cto,
                q1: qb1,
                given,
                ..
            },
        ) => {
            let la_len = norm(sub(*wp, *a0));
            let lb = norm(sub(*c, *wp));
            let (s, sd) = profile.at(tl);
            let r1 = la_len - s;
            if la_len <= 1e-9 || *dist <= 0.0 || sd.is_nan() || sd <= 1e-9 || r1 <= 1e-9 || lb <= r1
            {
                return None;
            }
            let u1 = scale(1.0 / la_len, sub(*wp, *a0));
            let u2 = scale(1.0 / lb, sub(*c, *wp));
            let cos = dot(u1, u2).clamp(-1.0, 1.0);
            if cos < -1.0 + 1e-9 {
                return None;
            }
            let p1 = [a0[0] + u1[0] * s, a0[1] + u1[1] * s, a0[2] + u1[2] * s];
            let p2 = [wp[0] + u2[0] * r1, wp[1] + u2[1] * r1, wp[2] + u2[2] * r1];
            // Orientations where the blend begins and ends.
            let r_in = mul(to_matrix(scale(s / dist, *ta)), *ra);
            let g = r1 / lb;
            let r_out = mul(to_matrix(scale(g, *tb)), *rb);
            let pose_in = with_rot(p1, r_in);
            let pose_out = with_rot(p2, r_out);
            let arc = if cos > 1.0 - 1e-12 {
                Path::Line { from: p1, to: p2 }
            } else {
                // The circle tangent to both lines at distance r1 from the waypoint:
                // its centre on the bisector, its point nearest the waypoint the via.
                let theta = cos.acos();
                let bis = sub(u2, u1);
                let bis = scale(1.0 / norm(bis), bis);
                let rho = r1 / (theta / 2.0).tan();
                let dc = r1 / (theta / 2.0).sin();
                let via = [
                    wp[0] + bis[0] * (dc - rho),
                    wp[1] + bis[1] * (dc - rho),
                    wp[2] + bis[2] * (dc - rho),
                ];
                Path::new(pose_in, Some(with_rot(via, r_in)), pose_out)
            };
            let len = arc.length();
            let dur = len / sd;
            // Not made if slower than stopping at the corner (see the joint blend).
            if !(dur > 0.0 && dur.is_finite()) || dur > profile.total - tl + pb.time_at(r1) {
                return None;
            }
            let (vb, ab) = pb.speed_and_acceleration();
            if !can_stop(sd, lb - r1, ab) {
                return None;
            }
            let q_out = nearest_ik(dh, pose_out, tcp, *qa1).unwrap_or(*qa1);
            let first = Kind::Tool {
                path: arc,
                r0: r_in,
                turn: to_rotvec(mul(r_out, transpose(r_in))),
                profile: Profile::constant(len, sd),
                dist: len,
                to: pose_out,
                q0: q_now,
                q1: q_out,
                given: false,
            };
            let rest = Kind::Tool {
                path: Path::Line { from: p2, to: *c },
                r0: r_out,
                turn: scale(1.0 - g, *tb),
                profile: Profile::with_start_speed(lb - r1, sd, vb, ab),
                dist: lb - r1,
                to: *cto,
                q0: q_out,
                q1: *qb1,
                given: *given,
            };
            Some(Kind::Then {
                first: Box::new(first),
                dur,
                rest: Box::new(rest),
            })
        }
        (Kind::Tool { .. }, Kind::Tool { .. }) => curve_blend(dh, tcp, (la, tl), b, q_now)
            .or_else(|| mixed_blend(dh, tcp, (la, tl), b, q_now)),
        _ => mixed_blend(dh, tcp, (la, tl), b, q_now),
    }
}

/// How many times [`curve_blend`] halves its tangent length to keep the curve inside the
/// sphere before it gives up (then the blend is made in joint space).
const CURVE_TRIES: u32 = 6;

/// A tool-space blend between two tool moves of which one at least is circular (`movec`
/// into a straight move, a straight move into `movec`, `movec` into `movec`): the cubic
/// Bézier from where the tool is now (`a` at distance `r1` before the waypoint) to where
/// `b`'s path leaves the sphere of radius `r1` around it, tangent to both paths there
/// (its control points on the tangents, half of `r1` from its ends, or less until all four
/// lie in the sphere: the curve, inside their convex hull, then stays within `r1` of the
/// waypoint), travelled at the constant tool speed the tool has now (parameterised by
/// arc length); the orientation turns from `a`'s to `b`'s over it, as between two lines.
/// `None` where the line-to-line blend would refuse (a turn straight back, slower than
/// stopping, too little of `b` left to stop in) or no such curve fits.
fn curve_blend(
    dh: &Dh,
    tcp: [f64; 6],
    (la, tl): (&Kind, f64),
    b: &Kind,
    q_now: [f64; 6],
) -> Option<Kind> {
    let Kind::Tool {
        path: pa,
        r0: ra,
        turn: ta,
        profile,
        dist,
        q1: qa1,
        ..
    } = la
    else {
        return None;
    };
    let Kind::Tool {
        path: pbp,
        r0: rb,
        turn: tb,
        profile: pb,
        dist: db,
        to: cto,
        q1: qb1,
        given,
        ..
    } = b
    else {
        return None;
    };
    let (s, sd) = profile.at(tl);
    if !(pa.length() > 1e-9 && pbp.length() > 1e-9 && *dist > 0.0 && *db > 0.0 && sd > 1e-9) {
        return None;
    }
    let fa = (s / dist).clamp(0.0, 1.0);
    let (p1, t1) = pa.at(fa);
    let wp = pa.at(1.0).0;
    let r1 = norm(sub(p1, wp));
    if r1.is_nan() || r1 <= 1e-9 {
        return None;
    }
    let g = crossing(|f| norm(sub(pbp.at(f).0, wp)), r1, false)?;
    if !(g > 0.0 && g < 1.0 - 1e-9) {
        return None;
    }
    let (p2, t2) = pbp.at(g);
    if dot(t1, t2) < -1.0 + 1e-6 {
        return None;
    }
    let inside = |q: [f64; 3]| norm(sub(q, wp)) <= r1 * (1.0 + 1e-9);
    let mut k = 0.5 * r1;
    let mut curve = None;
    for _ in 0..CURVE_TRIES {
        let c1 = [p1[0] + k * t1[0], p1[1] + k * t1[1], p1[2] + k * t1[2]];
        let c2 = [p2[0] - k * t2[0], p2[1] - k * t2[1], p2[2] - k * t2[2]];
        if inside(c1) && inside(c2) {
            curve = Some(Path::bezier([p1, c1, c2, p2]));
            break;
        }
        k *= 0.5;
    }
    let curve = curve?;
    let len = curve.length();
    let dur = len / sd;
    let rest_d = db * (1.0 - g);
    if !(dur > 0.0 && dur.is_finite()) || dur > profile.total - tl + pb.time_at(db * g) {
        return None;
    }
    let (vb, ab) = pb.speed_and_acceleration();
    if !can_stop(sd, rest_d, ab) {
        return None;
    }
    let r_in = mul(to_matrix(scale(fa, *ta)), *ra);
    let r_out = mul(to_matrix(scale(g, *tb)), *rb);
    let pose_out = with_rot(p2, r_out);
    let q_out = nearest_ik(dh, pose_out, tcp, *qa1).unwrap_or(*qa1);
    let first = Kind::Tool {
        path: curve,
        r0: r_in,
        turn: to_rotvec(mul(r_out, transpose(r_in))),
        profile: Profile::constant(len, sd),
        dist: len,
        to: pose_out,
        q0: q_now,
        q1: q_out,
        given: false,
    };
    let rest = Kind::Tool {
        path: pbp.rest_from(g),
        r0: r_out,
        turn: scale(1.0 - g, *tb),
        profile: Profile::with_start_speed(rest_d, sd, vb, ab),
        dist: rest_d,
        to: *cto,
        q0: q_out,
        q1: *qb1,
        given: *given,
    };
    Some(Kind::Then {
        first: Box::new(first),
        dur,
        rest: Box::new(rest),
    })
}

/// Where a joint move or a straight tool move is at fraction `f` of its way: joints (the
/// inverse kinematics nearest `near`, for a tool move) and tool position.
fn move_point(
    dh: &Dh,
    tcp: [f64; 6],
    k: &Kind,
    f: f64,
    near: [f64; 6],
) -> Option<([f64; 6], [f64; 3])> {
    match k {
        Kind::Joint { q0, q1, .. } => {
            let q = lerp6(*q0, *q1, f);
            Some((q, xyz(kinematics::forward(dh, q, tcp))))
        }
        Kind::Tool { path, r0, turn, .. } => {
            let p = path.at(f).0;
            let pose = with_rot(p, mul(to_matrix(scale(f, *turn)), *r0));
            Some((nearest_ik(dh, pose, tcp, near)?, p))
        }
        _ => None,
    }
}

/// The joint speeds of a joint move or a tool move (straight or circular) at joints `q`,
/// fraction `f` of its way, moving at `s` along its profile (rad/s of its leading joint,
/// or m/s).
fn move_joint_speed(dh: &Dh, tcp: [f64; 6], k: &Kind, (q, f): ([f64; 6], f64), s: f64) -> [f64; 6] {
    match k {
        Kind::Joint { q0, q1, profile } => {
            let d = profile.distance();
            std::array::from_fn(|j| {
                if d > 0.0 {
                    (q1[j] - q0[j]) * s / d
                } else {
                    0.0
                }
            })
        }
        Kind::Tool {
            path, turn, dist, ..
        } if *dist > 0.0 => {
            let (_, tangent) = path.at(f);
            let v = scale(s * path.length() / dist, tangent);
            let w = scale(s / dist, *turn);
            joint_speed(dh, q, tcp, [v[0], v[1], v[2], w[0], w[1], w[2]])
        }
        _ => [0.0; 6],
    }
}

/// How far (as a multiple of the radius it entered at) the tool may stray from the
/// waypoint on a blend between a joint move and a tool move (a curve in joint space)
/// before the blend is not made.
const MIXED_STRAY: f64 = 1.25;

/// A joint move into a tool move, or one into the other, or a blend between tool moves
/// that [`curve_blend`] could not make: a cubic Bézier in joint space from the joints
/// now, at their speeds now, to the point of `b` where the tool leaves the sphere it
/// entered, at `b`'s speeds there (the tool's speed where the blend
/// began, at most `b`'s `v`), over the time the tool takes across the sphere's diameter
/// at that speed. Not made if the tool would stray more than [`MIXED_STRAY`] times the
/// radius from the waypoint (checked at 32 points), or if slower than stopping.
fn mixed_blend(
    dh: &Dh,
    tcp: [f64; 6],
    (la, tl): (&Kind, f64),
    b: &Kind,
    q_now: [f64; 6],
) -> Option<Kind> {
    let blendable = |k: &Kind| matches!(k, Kind::Joint { .. } | Kind::Tool { .. });
    if !(blendable(la) && blendable(b)) {
        return None;
    }
    let now = la.sample(dh, tcp, tl, q_now);
    if now.done {
        return None;
    }
    let (qw, wpose) = la.end(dh, tcp)?;
    let w = xyz(wpose);
    let fk = |q: [f64; 6]| xyz(kinematics::forward(dh, q, tcp));
    let r1 = norm(sub(fk(q_now), w));
    let twist = tcp_speed(dh, q_now, now.qd, tcp);
    let vt = norm([twist[0], twist[1], twist[2]]);
    if r1 <= 1e-9 || vt.is_nan() || vt <= 1e-9 {
        return None;
    }
    let g = crossing(
        |f| move_point(dh, tcp, b, f, qw).map_or(0.0, |(_, p)| norm(sub(p, w))),
        r1,
        false,
    )?;
    if !(g > 0.0 && g < 1.0) {
        return None;
    }
    let (q2, _) = move_point(dh, tcp, b, g, qw)?;
    let (pb, db) = match b {
        Kind::Joint { profile, .. } => (*profile, profile.distance()),
        Kind::Tool { profile, dist, .. } => (*profile, *dist),
        _ => return None,
    };
    let (vb, ab) = pb.speed_and_acceleration();
    let s2 = match b {
        Kind::Joint { .. } => vt * g * db / r1,
        _ => vt,
    }
    .min(vb);
    let dur = 2.0 * r1 / vt;
    let total_a = match la {
        Kind::Joint { profile, .. } | Kind::Tool { profile, .. } => profile.total,
        _ => return None,
    };
    if s2.is_nan()
        || s2 <= 1e-9
        || !dur.is_finite()
        || dur > total_a - tl + pb.time_at(g * db)
        || !can_stop(s2, (1.0 - g) * db, ab)
    {
        return None;
    }
    let v2 = move_joint_speed(dh, tcp, b, (q2, g), s2);
    let c1: [f64; 6] = std::array::from_fn(|j| q_now[j] + now.qd[j] * dur / 3.0);
    let c2: [f64; 6] = std::array::from_fn(|j| q2[j] - v2[j] * dur / 3.0);
    let strays = (1..32).any(|i| {
        let (q, _) = bezier(q_now, c1, c2, q2, dur, dur * f64::from(i) / 32.0);
        norm(sub(fk(q), w)) > MIXED_STRAY * r1
    });
    if strays {
        return None;
    }
    let rest = match b {
        Kind::Joint { q1, .. } => Kind::Joint {
            q0: q2,
            q1: *q1,
            profile: Profile::with_start_speed((1.0 - g) * db, s2, vb, ab),
        },
        Kind::Tool {
            path,
            r0,
            turn,
            to,
            q1,
            given,
            ..
        } => Kind::Tool {
            path: path.rest_from(g),
            r0: mul(to_matrix(scale(g, *turn)), *r0),
            turn: scale(1.0 - g, *turn),
            profile: Profile::with_start_speed((1.0 - g) * db, s2, vb, ab),
            dist: (1.0 - g) * db,
            to: *to,
            q0: q2,
            q1: *q1,
            given: *given,
        },
        _ => return None,
    };
    Some(Kind::Then {
        first: Box::new(Kind::JointBlend {
            p1: q_now,
            c1,
            c2,
            p2: q2,
            w: qw,
            dur,
        }),
        dur,
        rest: Box::new(rest),
    })
}

/// The solution nearest `near`, each joint within the arm's range.
pub(crate) fn nearest_ik(
    dh: &Dh,
    pose: [f64; 6],
    tcp: [f64; 6],
    near: [f64; 6],
) -> Option<[f64; 6]> {
    let all = kinematics::inverse(dh, pose, tcp, near);
    kinematics::nearest(&all, near)
}

/// The turn from `r0` to `r1` as a rotation vector in the base frame (`r1 = Rot(v)·r0`).
pub(crate) fn turn_between(p0: [f64; 6], p1: [f64; 6]) -> ([[f64; 3]; 3], [f64; 3]) {
    let r0 = rot(p0);
    let r1 = rot(p1);
    (r0, to_rotvec(mul(r1, transpose(r0))))
}

/// `movec` in fixed mode (`mode=1`): the orientation keeps its relation to the path's
/// tangent, starting from `p0`'s, so it turns about the circle's axis by the angle the
/// arc sweeps (a line: not at all). Returns the turn (a rotation vector in the base frame,
/// its length the swept angle, which may exceed π) and the end pose: `to`'s position with
/// that orientation (the manual: only `pose_to`'s position is used in fixed mode).
pub(crate) fn fixed_turn(path: &Path, p0: [f64; 6], to: [f64; 6]) -> ([f64; 3], [f64; 6]) {
    let turn = match *path {
        Path::Arc { u, w, angle, .. } => scale(angle, cross(u, w)),
        Path::Line { .. } | Path::Bezier { .. } => [0.0; 3],
    };
    let end = mul(to_matrix(turn), rot(p0));
    let v = to_rotvec(end);
    (turn, [to[0], to[1], to[2], v[0], v[1], v[2]])
}

/// The tool speed (base frame: linear m/s, angular rad/s) of joints `q` moving at `qd`.
pub(crate) fn tcp_speed(dh: &Dh, q: [f64; 6], qd: [f64; 6], tcp: [f64; 6]) -> [f64; 6] {
    if qd.iter().all(|v| *v == 0.0) {
        return [0.0; 6];
    }
    kinematics::tool_twist(dh, q, qd, tcp)
}

/// The joint speeds that move the tool at `v` (base frame), by the inverse kinematics a
/// short time ahead.
fn joint_speed(dh: &Dh, q: [f64; 6], tcp: [f64; 6], v: [f64; 6]) -> [f64; 6] {
    if v.iter().all(|x| *x == 0.0) {
        return [0.0; 6];
    }
    let h = 1e-6;
    let p = kinematics::forward(dh, q, tcp);
    let r = mul(to_matrix([v[3] * h, v[4] * h, v[5] * h]), rot(p));
    let rv = to_rotvec(r);
    let ahead = [
        p[0] + v[0] * h,
        p[1] + v[1] * h,
        p[2] + v[2] * h,
        rv[0],
        rv[1],
        rv[2],
    ];
    match nearest_ik(dh, ahead, tcp, q) {
        Some(q2) => std::array::from_fn(|k| (q2[k] - q[k]) / h),
        None => [0.0; 6],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_profile_ends_at_its_distance_with_the_move_time() {
        for (d, v, a, t) in [
            (1.0, 0.5, 1.0, 0.0),
            (0.01, 1.0, 1.0, 0.0),
            (1.0, 0.5, 0.0, 0.0),
            (1.0, 0.5, 1.0, 7.0),
        ] {
            let p = Profile::new(d, v, a, t);
            let want = if t > 0.0 {
                t
            } else {
                kinematics::move_time(d, v, a)
            };
            assert!((p.total - want).abs() < 1e-12);
            assert_eq!(p.at(p.total), (d, 0.0));
            // Monotonic, never faster than v (unless t stretches it shorter).
            let mut last = 0.0;
            for k in 0..=1000 {
                let (s, sd) = p.at(p.total * f64::from(k) / 1000.0);
                assert!(s >= last - 1e-15 && sd >= 0.0);
                if t == 0.0 {
                    assert!(sd <= v + 1e-12);
                }
                last = s;
            }
        }
    }

    #[test]
    fn a_profile_from_a_start_speed_is_continuous_and_ends_at_rest() {
        // (d, v0, v, a): cruise above and below v0, triangles, and too short to stop at a.
        for (d, v0, v, a) in [
            (1.0, 0.3, 0.5, 1.0),
            (1.0, 0.8, 0.5, 1.0),
            (0.05, 0.3, 0.5, 1.0),
            (0.01, 0.5, 0.5, 1.0),
            (0.5, 0.0, 0.5, 1.0),
            (0.2, 0.4, 0.4, 0.0),
        ] {
            let p = Profile::with_start_speed(d, v0, v, a);
            assert!(p.total > 0.0 && p.total.is_finite());
            assert_eq!(p.at(0.0), (0.0, v0));
            assert_eq!(p.at(p.total), (d, 0.0));
            let n = 2000;
            let dt = p.total / f64::from(n);
            let (mut last_s, mut last_v) = (0.0, v0);
            for k in 1..n {
                let (s, sd) = p.at(dt * f64::from(k));
                assert!(s >= last_s - 1e-15, "{d} {v0}: {s} < {last_s}");
                assert!(sd <= v0.max(v) + 1e-12, "{sd}");
                // The speed changes by at most the largest deceleration per sample.
                let most = a.max(v0 * v0 / (2.0 * d));
                assert!(
                    (sd - last_v).abs() <= most * dt + 1e-9,
                    "{d} {v0}: {last_v} -> {sd}"
                );
                (last_s, last_v) = (s, sd);
            }
            // time_at inverts at.
            let t = p.time_at(0.5 * d);
            assert!((p.at(t).0 - 0.5 * d).abs() < 1e-9);
        }
    }

    #[test]
    fn a_straight_blend_is_an_arc_within_r_of_the_corner_tangent_to_both_lines() {
        let dh = crate::arm::kinematics::Model::Ur5e.dh();
        let q0 = [0.3, -1.4, 1.6, -1.8, -1.57, 0.2];
        let tcp = [0.0; 6];
        let p0 = kinematics::forward(&dh, q0, tcp);
        let w = [p0[0] + 0.2, p0[1], p0[2], p0[3], p0[4], p0[5]];
        let c = [w[0] + 0.1, w[1] - 0.1, w[2], w[3], w[4], w[5]];
        let line = |from: [f64; 6], to: [f64; 6], q0: [f64; 6]| {
            let path = Path::new(from, None, to);
            let (r0, turn) = turn_between(from, to);
            let dist = path.length();
            let q1 = nearest_ik(&dh, to, tcp, q0).unwrap();
            Kind::Tool {
                path,
                r0,
                turn,
                profile: Profile::new(dist, 0.25, 1.2, 0.0),
                dist,
                to,
                q0,
                q1,
                given: false,
            }
        };
        let a = line(p0, w, q0);
        let r = 0.05;
        let start = blend_start(&dh, tcp, &a, r).0.unwrap();
        let Kind::Tool { q1: qw, .. } = a else {
            unreachable!()
        };
        let b = line(w, c, qw);
        let q_now = a.sample(&dh, tcp, start.at, q0).q;
        let k = blend(&dh, tcp, (&a, start.at), &b, q_now).unwrap();
        let Kind::Then { first, dur, .. } = &k else {
            panic!("{k:?}")
        };
        let Kind::Tool { path, .. } = **first else {
            panic!("{first:?}")
        };
        assert!(matches!(path, Path::Arc { .. }));
        for i in 0..=100 {
            let (p, _) = path.at(f64::from(i) / 100.0);
            assert!(norm(sub(p, xyz(w))) <= r + 1e-9);
        }
        // Tangent to the first line where it begins, to the second where it ends.
        let (_, t0) = path.at(0.0);
        let (_, t1) = path.at(1.0);
        assert!(norm(sub(t0, [1.0, 0.0, 0.0])) < 1e-9, "{t0:?}");
        let s = std::f64::consts::FRAC_1_SQRT_2;
        assert!(norm(sub(t1, [s, -s, 0.0])) < 1e-9, "{t1:?}");
        assert!(*dur > 0.0 && k.duration() < a.duration() + b.duration());
    }

    #[test]
    fn the_jacobian_twist_matches_a_finite_difference() {
        let dh = crate::arm::kinematics::Model::Ur5e.dh();
        let q = [0.3, -1.2, 1.4, -1.8, -1.57, 0.2];
        let qd = [0.1, -0.2, 0.3, 0.05, -0.4, 0.7];
        let tcp = [0.01, 0.02, 0.15, 0.1, 0.0, 0.2];
        let h = 1e-7;
        let a = kinematics::forward(&dh, q, tcp);
        let q2: [f64; 6] = std::array::from_fn(|k| q[k] + qd[k] * h);
        let b = kinematics::forward(&dh, q2, tcp);
        // R(b)·R(a)ᵀ ≈ I + [ω]·h.
        let m = mul(rot(b), transpose(rot(a)));
        let w = [
            (m[2][1] - m[1][2]) / 2.0,
            (m[0][2] - m[2][0]) / 2.0,
            (m[1][0] - m[0][1]) / 2.0,
        ];
        let fd = [
            (b[0] - a[0]) / h,
            (b[1] - a[1]) / h,
            (b[2] - a[2]) / h,
            w[0] / h,
            w[1] / h,
            w[2] / h,
        ];
        let j = tcp_speed(&dh, q, qd, tcp);
        for k in 0..6 {
            assert!((j[k] - fd[k]).abs() < 1e-5, "{k}: {j:?} vs {fd:?}");
        }
    }

    #[test]
    fn an_arc_passes_through_its_via_point() {
        let from = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let via = [0.0, 1.0, 0.0, 0.0, 0.0, 0.0];
        let to = [-1.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let p = Path::new(from, Some(via), to);
        assert!((p.length() - std::f64::consts::PI).abs() < 1e-12);
        let (mid, _) = p.at(0.5);
        assert!(norm(sub(mid, [0.0, 1.0, 0.0])) < 1e-12);
        let (end, _) = p.at(1.0);
        assert!(norm(sub(end, [-1.0, 0.0, 0.0])) < 1e-12);
    }
}
