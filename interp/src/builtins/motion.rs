//! Motion, the arm's state, and the arm's settings, on the **virtual arm**: the arm
//! follows each command in time (kinematics, speed profiles), not dynamics. See
//! `crate::arm::trajectory` for the profiles; in short:
//!
//! - `movej(q, a=1.4, v=1.05, t=0, r=0)`: a trapezoidal profile in joint space on the joint
//!   that moves furthest (a triangle when too short to reach `v`), all joints arriving
//!   together; `movel(pose, a=1.2, v=0.25, t=0, r=0)`, `movep`: the tool along the straight
//!   line, its orientation turning about one axis, along the same profile on the path
//!   length, the joints by inverse kinematics nearest the previous step's; `movec(pose_via,
//!   pose_to, ...)`: the same along the arc through `pose_via`'s position (mode 1 is taken
//!   as mode 0). `t > 0` stretches the profile to take `t`. `optimovej`/`optimovel`: like
//!   `movej`/`movel` (their `a`, `v` are fractions on the robot; here they are taken as
//!   speeds). A target given as a pose is reached through inverse kinematics nearest the
//!   joints the move starts from (out of reach: for `movej` a runtime error before the
//!   arm moves; for `movel`/`movep`/`movec` the tool sets off along its path and stops
//!   where the path leaves the arm's reach, with a protective stop, `Effect::ProtectiveStop`,
//!   as a real arm stops when the line runs it into a singularity).
//!   Every motion takes at least one step; with `r = 0` the arm is exactly at the target,
//!   at rest, in the step the move returns.
//! - Blend radius `r > 0` (m; negative is a runtime error): the move returns where the
//!   tool enters the sphere of radius `r` around its target (the program's next
//!   statements run then, as on the controller, which evaluates them on entering the
//!   blend radius). A `movej`, `movel` or `movep` commanded in that same step after one
//!   of them blends in without a stop (see `crate::arm::trajectory::blend`: joint speeds
//!   continuous, the tool within `r` of the corner, a straight-move blend a circular arc
//!   at constant tool speed). A move commanded later (a `sleep`, `sync`, a socket read
//!   ran first), or one that cannot blend (`movec` either side, a next target inside
//!   the sphere), starts when the first has
//!   stopped at its target: the lookahead holds one move. The radius is reduced so that
//!   a blend never overlaps the one before it (UR: "blends cannot overlap").
//! - A joint target outside the joints' range, ±2π (±360°, UR's e-Series and CB3 arms),
//!   is a runtime error (`movej`, `movel` with joints, `servoj`, `set_pos`); inverse
//!   kinematics only gives solutions within it.
//! - `servoj(q, a, v, t=0.002, lookahead_time=0.1, gain=300)`: straight to `q` at constant
//!   speed over `t`.
//! - `speedj(qd, a, t)`, `speedl(xd, a, t, aRot)`: the speed ramps linearly to the target
//!   at `a`, then holds (the joints integrate it; for `speedl` they follow the tool) until
//!   the next motion command; returns after `t` (one step if not given). `stopj(a)`,
//!   `stopl(a, aRot)`: ramp the speed down to zero at `a`; return at rest.
//! - A motion runs until it ends, another motion command replaces it, or the thread that
//!   commanded it is killed or the program stops (then the arm stays where it is, at
//!   rest).
//! - `get_actual_joint_positions()`, `get_target_joint_positions()`: the arm's joints now
//!   (mid-move and mid-blend too); `get_actual_tcp_pose()`, `get_target_tcp_pose()`: the
//!   tool pose now; `get_target_waypoint()`: the target of the move under way (from the
//!   start of a blend, the next move's), the tool pose at rest; speeds the speeds now;
//!   `tool_contact()`: the steps since the TCP touched the contact plane (0 without
//!   contact; see `crate::arm::force`); `is_steady()`: False while a motion (a blend too) is
//!   under way, a speed is held, the joints move, or the arm is in teach/freedrive mode.
//! - The speed slider (`Arm::speed_fraction`): every motion above runs on the motion
//!   clock, which advances by the slider's fraction each step; moves and `stopj`/`stopl`
//!   return when their motion ends on it; `servoj`, `speedj`, `speedl` return after `t`
//!   of motion time (at a fraction `f`, `t / f` of program time), so a program that
//!   streams them (UR's External Control script) follows its path at the slider's pace.
//! - `force_mode`/`end_force_mode`: see `crate::arm::force`. `teach_mode`/`freedrive_mode`:
//!   the arm stops and the operator moves the joints (`Arm::move_by_hand`) until the
//!   `end_` call or the program's end.
//! - `is_within_safety_limits(pose, qnear)`: reachable by the inverse kinematics with
//!   every joint within ±2π (joints given: each within ±2π).
//! - Settings read back by their getters: payload (`set_target_payload`, `set_payload*`
//!   -> `get_target_payload*`), TCP (`set_tcp` -> `get_tcp_offset`), gravity, base
//!   acceleration, path offset (`path_offset_*`), `set_pos` (the joints).
//! - What the robot measures of the world returns the documented fixed value of its
//!   field of the virtual arm (`crate::runtime::Arm`): `get_tcp_force()` and `force()`
//!   `World::tcp_force` (0) plus the contact plane's push, `get_joint_torques()` 0, `get_joint_temp(j)` 35.0 °C, `get_controller_temp()`
//!   30.0 °C, `get_tool_temp()` 32.0 °C, `get_tool_current()` 0.0 A;
//!   `get_tool_accelerometer_reading()` is the gravity vector seen from the flange.
//! - Settings the virtual arm has no use for (`zero_ftsensor`,
//!   `screw_driving`, ...) are accepted with their manual signatures and do nothing.

use super::{accept, builtin, float_list, floats, secs, Args, Builtin, Domain, Out};
use crate::arm::trajectory::{self, Kind, Path, Profile};
use crate::error::Fault;
use crate::event::MoveStart;
use crate::native::{index, FromArg};
use crate::runtime::Runtime;
use crate::value::Value;

const D: Domain = Domain::Motion;
const ZERO3: &[f64] = &[0.0, 0.0, 0.0];

pub(super) const TABLE: &[Builtin] = &[
    builtin!(
        movej(q: Target, a: f64 = Float(1.4), v: f64 = Float(1.05), t: f64 = Float(0.0), r: f64 = Float(0.0))
            => |c, x, q, a, v, t, r| go(c, x, Space::Joint, q, (a, v, t, r)),
        "Moves in joint space: a trapezoidal profile on the largest joint distance (t: stretched to take t).",
    ),
    builtin!(
        movel(pose: Target, a: f64 = Float(1.2), v: f64 = Float(0.25), t: f64 = Float(0.0), r: f64 = Float(0.0))
            => |c, x, pose, a, v, t, r| go(c, x, Space::Tool, pose, (a, v, t, r)),
        "Moves the tool in a straight line: a trapezoidal profile on the distance (t: stretched to take t).",
    ),
    builtin!(
        movep(pose: Target, a: f64 = Float(1.2), v: f64 = Float(0.25), r: f64 = Float(0.0))
            => |c, x, pose, a, v, r| go(c, x, Space::Tool, pose, (a, v, 0.0, r)),
        "Process move: as movel.",
    ),
    builtin!(
        servoc(pose: Target, a: f64 = Float(1.2), v: f64 = Float(0.25), r: f64 = Float(0.0))
            => |c, x, pose, a, v, r| go(c, x, Space::Tool, pose, (a, v, 0.0, r)),
        "Servo to a pose in a circular blend: timed as movel to the pose.",
    ),
    builtin!(
        powerdown() => powerdown,
        "Shuts the robot down: the program halts and the controller running it powers the arm off (Effect::PowerOff).",
    ),
    builtin!(
        protective_stop() => protective_stop,
        "Triggers a protective stop: the arm stops and the call takes one step, so the controller running it pauses the program before the next statement (Effect::ProtectiveStop).",
    ),
    // `optimovej(goal, a=0.3, v=0.3, r=0)`, `optimovel(goal, ...)`: the manual names the
    // target `goal` (joints or a pose here).
    builtin!(
        optimovej(goal: Target, a: f64 = Float(0.3), v: f64 = Float(0.3), r: f64 = Float(0.0))
            => |c, x, goal, a, v, r| go(c, x, Space::Joint, goal, (a, v, 0.0, r)),
        "As movej (a and v taken as speeds).",
    ),
    builtin!(
        optimovel(goal: Target, a: f64 = Float(0.3), v: f64 = Float(0.3), r: f64 = Float(0.0))
            => |c, x, goal, a, v, r| go(c, x, Space::Tool, goal, (a, v, 0.0, r)),
        "As movel (a and v taken as speeds).",
    ),
    builtin!(
        movec(
            pose_via: Target,
            pose_to: Target,
            a: f64 = Float(1.2),
            v: f64 = Float(0.25),
            r: f64 = Float(0.0),
            mode: Given<'_, f64> = Int(0),
        ) => |c, x, via, to, a, v, r, mode| movec(c, x, via, to, (a, v, r), mode),
        "Circular move: the tool along the arc through pose_via to pose_to.",
    ),
    builtin!(
        servoj(
            q: [f64; 6],
            a: f64 = Float(0.0),
            v: f64 = Float(0.0),
            t: f64 = Float(0.002),
            lookahead_time: &Value = Float(0.1),
            gain: &Value = Float(300.0),
        ) => |c, x, q, a, v, t, _, _| servoj(c, x, q, (a, v, t)),
        "Moves to q at constant speed over t.",
    ),
    builtin!(
        speedj(qd: [f64; 6], a: f64, t: Option<f64> = Absent)
            => |c, x, qd, a, t| speed(c, x, Space::Joint, qd, a, t, None),
        "Ramps the joint speeds to qd at a and holds them; returns after t (one step if not given).",
    ),
    builtin!(
        speedl(xd: [f64; 6], a: f64, t: Option<f64> = Absent, aRot: Option<f64> = Absent)
            => |c, x, xd, a, t, a_rot| speed(c, x, Space::Tool, xd, a, t, a_rot),
        "Ramps the tool speed to xd at a (aRot) and holds it; returns after t (one step if not given).",
    ),
    builtin!(
        stopj(a: f64) => |c, _, a| stop(c, Space::Joint, a, None),
        "Ramps the joint speeds down to zero at a; returns at rest.",
    ),
    builtin!(
        stopl(a: f64, aRot: Option<f64> = Absent) => |c, _, a, a_rot| stop(c, Space::Tool, a, a_rot),
        "Ramps the tool speed down to zero at a (aRot); returns at rest.",
    ),
    builtin!(
        direct_torque(
            torque: [f64; 6],
            friction_comp: &Value = Bool(true),
            viscous_scale: &Value = Absent,
            coulomb_scale: &Value = Absent,
        ) => |c, _, _, _, _, _| direct_torque(c),
        "Torque control has no model here: takes one step.",
    ),
    builtin!(
        get_actual_joint_positions() => joints,
        "The commanded joints.",
    ),
    builtin!(
        get_target_joint_positions() => joints,
        "The commanded joints.",
    ),
    builtin!(
        get_joint_positions() => joints,
        "The commanded joints (CB3 name).",
    ),
    builtin!(
        get_actual_joint_positions_history(steps: i32 = Int(0)) => joints_history,
        "The joints `steps` controller steps ago (0: now); a runtime error past the history's JOINT_HISTORY_STEPS steps.",
    ),
    builtin!(
        get_actual_joint_speeds() => joint_speeds,
        "The commanded joint speeds.",
    ),
    builtin!(
        get_target_joint_speeds() => joint_speeds,
        "The commanded joint speeds.",
    ),
    builtin!(
        get_actual_tcp_pose() => tcp_pose,
        "The commanded tool pose.",
    ),
    builtin!(
        get_target_tcp_pose() => tcp_pose,
        "The commanded tool pose.",
    ),
    builtin!(
        get_actual_tcp_speed() => tcp_speed,
        "The commanded tool speed.",
    ),
    builtin!(
        get_target_tcp_speed() => tcp_speed,
        "The commanded tool speed.",
    ),
    builtin!(
        get_tcp_force() => tcp_force,
        "The force/torque sensor (base frame): World::tcp_force plus the contact plane's push on the TCP (settable: tcp_force, contact_plane, contact_stiffness).",
    ),
    builtin!(
        force() => force,
        "The norm of get_tcp_force()'s force part.",
    ),
    builtin!(
        get_actual_tool_flange_pose() => flange_pose,
        "The commanded tool pose without the TCP offset.",
    ),
    builtin!(
        get_target_waypoint() => waypoint,
        "The target of the move under way (during a blend, the next move's); at rest, the tool pose.",
    ),
    builtin!(
        get_target_tcp_pose_along_path() => tcp_pose,
        "The commanded tool pose (no conveyor or path offset is added to it here).",
    ),
    builtin!(
        get_target_tcp_speed_along_path() => tcp_speed,
        "The commanded tool speed.",
    ),
    builtin!(
        get_target_payload() => |c, _| read(c, |c| Value::Float(c.arm.payload_mass)),
        "The payload mass last set (kg; 0.0 at start).",
    ),
    builtin!(
        get_target_payload_cog() => |c, _| read(c, |c| float_list(&c.arm.payload_cog)),
        "The payload CoG last set ([x, y, z] m from the flange).",
    ),
    builtin!(
        get_target_payload_inertia() => |c, _| read(c, |c| float_list(&c.arm.payload_inertia)),
        "The payload inertia last set ([Ixx, Iyy, Izz, Ixy, Ixz, Iyz] kg*m^2).",
    ),
    builtin!(
        get_joint_torques() => |c, _| read(c, |c| floats(c.arm.world.joint_torques)),
        "The joints' torques beyond moving the arm itself: fixed, [0, 0, 0, 0, 0, 0] Nm.",
    ),
    builtin!(
        get_joint_temp(j: i32) => joint_temp,
        "The temperature of joint j (0-5): fixed, 35.0 degrees C.",
    ),
    builtin!(
        get_controller_temp() => |c, _| read(c, |c| Value::Float(c.arm.world.controller_temp)),
        "The control box temperature: fixed, 30.0 degrees C.",
    ),
    builtin!(
        get_tool_temp() => |c, _| read(c, |c| Value::Float(c.arm.world.tool_temp)),
        "The tool temperature: fixed, 32.0 degrees C.",
    ),
    builtin!(
        get_tool_current() => |c, _| read(c, |c| Value::Float(c.arm.world.tool_current)),
        "The tool current: fixed, 0.0 A (nothing draws from the tool connector).",
    ),
    builtin!(
        get_tool_accelerometer_reading() => accelerometer,
        "The gravity vector (set_gravity) in the flange's axes, m/s^2: [0, 0, 9.82] with the flange up.",
    ),
    builtin!(
        get_gravity() => |c, _| read(c, |c| float_list(&c.arm.gravity)),
        "The gravity vector last set by set_gravity ([0, 0, 9.82] at start).",
    ),
    builtin!(
        get_base_acceleration() => |c, _| read(c, |c| float_list(&c.arm.base_acceleration)),
        "The base acceleration last set by set_base_acceleration ([0, 0, 0] at start).",
    ),
    builtin!(
        get_freedrive_status() => |c, _| read(c, |_| Value::Int(0)),
        "0: normal operation (no singularity is modelled).",
    ),
    builtin!(
        get_inverse_kin_has_solution(
            pose: [f64; 6],
            qnear: Option<[f64; 6]> = Absent,
            maxPositionError: f64 = Float(1e-10),
            maxOrientationError: f64 = Float(1e-10),
            tcp: Option<[f64; 6]> = Absent,
        ) => has_solution,
        "True if get_inverse_kin has a solution: the arm reaches the pose exactly, or within maxPositionError and maxOrientationError.",
    ),
    builtin!(
        set_pos(q: [f64; 6]) => set_pos,
        "Sets the joints of the simulated robot at once (the arm at rest).",
    ),
    builtin!(
        path_offset_enable() => path_offset_enable,
        "Enables path offsetting.",
    ),
    builtin!(
        path_offset_disable(a: f64 = Float(20.0)) => |c, _, _| path_offset_disable(c),
        "Disables path offsetting: the applied offset is zero again.",
    ),
    builtin!(
        path_offset_set(offset: [f64; 6], r#type: i32) => path_offset_set,
        "Sets the offset (type 1-4), clamped to the maximum offset; applied while enabled.",
    ),
    builtin!(
        path_offset_get(r#type: i32) => path_offset_get,
        "The offset applied now (as set; zero while disabled).",
    ),
    builtin!(
        path_offset_set_alpha_filter(alpha: f64) => path_offset_set_alpha_filter,
        "Sets the offset filter coefficient (0-1; the offset is applied unfiltered here).",
    ),
    builtin!(
        path_offset_set_max_offset(transLimit: f64, rotLimit: f64) => path_offset_set_max_offset,
        "Sets the largest offset per axis (m, rad; 0.1 and 0.52 at start).",
    ),
    builtin!(
        get_tcp_offset() => |c, _| read(c, |c| Value::Pose(c.arm.tcp)),
        "The active TCP offset.",
    ),
    builtin!(
        tool_contact(direction: Option<[f64; 6]> = Absent) => tool_contact,
        "Steps since the TCP touched the contact plane (against `direction`, base frame; any if absent or zero); 0: no contact.",
    ),
    builtin!(
        is_steady() => is_steady,
        "True when no motion is under way, the joints are at rest and the arm is not in teach/freedrive mode.",
    ),
    builtin!(
        is_within_safety_limits(pose: Target, qnear: Option<[f64; 6]> = Absent) => within_safety_limits,
        "A pose: True if the inverse kinematics reach it with every joint within ±2π (TCP offset, from qnear or the joints now); joints: True if each is within ±2π.",
    ),
    builtin!(
        set_payload(m: f64, cog: Option<[f64; 3]> = Absent) => set_payload,
        "Sets the payload mass and CoG (the TCP's position if cog is left out); zero inertia.",
    ),
    builtin!(
        set_payload_mass(m: f64) => |c, _, m| set_payload_mass(c, m),
        "Sets the payload mass; zero inertia.",
    ),
    builtin!(
        set_payload_cog(CoG: [f64; 3]) => |c, _, cog| set_payload_cog(c, cog),
        "Sets the payload CoG; zero inertia.",
    ),
    builtin!(
        set_target_payload(
            m: f64,
            cog: [f64; 3],
            inertia: [f64; 6] = Floats(&[0.0; 6]),
            transition_time: f64 = Float(0.0),
        ) => |c, _, m, cog, inertia, _| set_target_payload(c, m, cog, inertia),
        "Sets the payload mass, CoG and inertia (|I| <= 133, Ixx, Iyy, Izz >= 0).",
    ),
    builtin!(
        set_tcp(pose: [f64; 6], tcp_name: &Value = Str("")) => |c, _, pose, _| set_tcp(c, pose),
        "Sets the active TCP offset (get_tcp_offset).",
    ),
    builtin!(
        set_gravity(d: [f64; 3]) => |c, _, d| set_gravity(c, d),
        "Sets the gravity vector (get_gravity, the accelerometer).",
    ),
    builtin!(
        set_base_acceleration(a: [f64; 3]) => |c, _, a| set_base_acceleration(c, a),
        "Sets the base acceleration (get_base_acceleration).",
    ),
    builtin!(
        zero_ftsensor() => accept,
        "Accepted (no force sensor).",
    ),
    builtin!(
        force_mode(
            task_frame: [f64; 6],
            selection_vector: Given<'_, [f64; 6]>,
            wrench: [f64; 6],
            r#type: i32,
            limits: [f64; 6],
        ) => force_mode,
        "Starts force mode: compliant axes move to reach the wrench at their speed limits, stopped by the contact plane (see crate::arm::force).",
    ),
    builtin!(
        end_force_mode() => end_force_mode,
        "Ends force mode: the arm stays where it is.",
    ),
    builtin!(
        force_mode_set_damping(damping: f64)
            => |c, x, v| store(c, x, v, (0.0, 1.0), |arm| &mut arm.force_mode_damping),
        "Stores the force mode damping (0-1), as force_mode_get_damping reads it.",
    ),
    builtin!(
        force_mode_set_gain_scaling(scaling: f64)
            => |c, x, v| store(c, x, v, (0.0, 2.0), |arm| &mut arm.force_mode_gain_scaling),
        "Stores the force mode gain scaling (0-2), as force_mode_get_gain_scaling reads it.",
    ),
    builtin!(
        force_mode_get_damping() => |c, _| read(c, |c| Value::Float(c.arm.force_mode_damping)),
        "The force mode damping last set (default 0).",
    ),
    builtin!(
        force_mode_get_gain_scaling()
            => |c, _| read(c, |c| Value::Float(c.arm.force_mode_gain_scaling)),
        "The force mode gain scaling last set (default 1).",
    ),
    builtin!(
        motion_version_set(version: i32) => |c, _, v| motion_version_set(c, v),
        "Stores the motion version (1 or 2) for movej/movel (the virtual arm's profiles are the same for both).",
    ),
    builtin!(
        motion_version_get() => |c, _| read(c, |c| Value::Int(c.arm.motion_version)),
        "The motion version last set (default 1).",
    ),
    builtin!(
        jerk_gain_scaling_set(gain: f64)
            => |c, x, v| store(c, x, v, (0.01, 1.0), |arm| &mut arm.jerk_gain_scaling),
        "Stores the jerk gain scaling (0.01-1) (the virtual arm's profiles have no jerk limit).",
    ),
    builtin!(
        jerk_gain_scaling_get() => |c, _| read(c, |c| Value::Float(c.arm.jerk_gain_scaling)),
        "The jerk gain scaling last set (default 1).",
    ),
    builtin!(
        freedrive_mode(
            freeAxes: Given<'_, [f64; 6]> = Ints(&[1, 1, 1, 1, 1, 1]),
            feature: [f64; 6] = Pose([0.0; 6]),
        ) => |c, _, axes, _| freedrive_mode(c, axes),
        "Freedrive: the arm stops; the operator moves the joints (Arm::move_by_hand); is_steady() False until end_freedrive_mode() or the program's end.",
    ),
    builtin!(
        end_freedrive_mode() => end_hand_mode,
        "Ends freedrive: the arm holds where the operator left it.",
    ),
    builtin!(
        teach_mode() => |c, _| hand_mode(c, TEACH),
        "Teach mode: the arm stops; the operator moves the joints (Arm::move_by_hand); is_steady() False until end_teach_mode() or the program's end.",
    ),
    builtin!(
        end_teach_mode() => end_hand_mode,
        "Ends teach mode: the arm holds where the operator left it.",
    ),
    // Settings accepted with their manual signatures (their arguments unchecked); they
    // change nothing here.
    builtin!(
        set_safety_mode_transition_hardness(r#type: &Value) => |c, x, _| accept(c, x),
        "Accepted.",
    ),
    builtin!(
        enable_external_ft_sensor(
            enable: &Value,
            sensor_mass: &Value = Float(0.0),
            sensor_measuring_offset: &Value = Floats(ZERO3),
            sensor_cog: &Value = Floats(ZERO3),
        ) => |c, x, _, _, _, _| accept(c, x),
        "Accepted (no force sensor).",
    ),
    builtin!(
        ft_rtde_input_enable(
            enable: &Value,
            sensor_mass: &Value = Float(0.0),
            sensor_measuring_offset: &Value = Floats(ZERO3),
            sensor_cog: &Value = Floats(ZERO3),
        ) => |c, x, _, _, _, _| accept(c, x),
        "Accepted (no force sensor).",
    ),
    builtin!(
        set_friction_compensation(enabled: &Value) => |c, x, _| accept(c, x),
        "Accepted.",
    ),
    builtin!(end_screw_driving() => accept, "Accepted."),
    builtin!(
        screw_driving(f: &Value, v_limit: &Value) => |c, x, _, _| accept(c, x),
        "Accepted (no forces are modelled).",
    ),
    builtin!(
        freedrive_mode_no_incorrect_payload_check() => accept,
        "Accepted (nobody pushes the virtual arm).",
    ),
    builtin!(high_holding_torque_disable() => accept, "Accepted."),
    builtin!(high_holding_torque_enable() => accept, "Accepted."),
    builtin!(
        pause_on_error_code(code: &Value, argument: &Value = Absent) => |c, x, _, _| accept(c, x),
        "Accepted (the virtual arm raises no error codes).",
    ),
    builtin!(
        position_deviation_warning(enabled: &Value, threshold: &Value = Float(0.8))
            => |c, x, _, _| accept(c, x),
        "Accepted (the virtual arm follows its target exactly).",
    ),
    builtin!(
        reset_revolution_counter(qNear: &Value = Floats(&[0.0; 6])) => |c, x, _| accept(c, x),
        "Accepted.",
    ),
    builtin!(
        tool_wrench_limit_set(
            frame_offset: &Value,
            Fx: &Value = Absent,
            Fy: &Value = Absent,
            Fz: &Value = Absent,
            Mx: &Value = Absent,
            My: &Value = Absent,
            Mz: &Value = Absent,
        ) => |c, x, _, _, _, _, _, _, _| accept(c, x),
        "Accepted (no dynamics).",
    ),
    builtin!(tool_wrench_limit_disable() => accept, "Accepted."),
    builtin!(
        set_baselight_off() => accept,
        "Accepted (UR20/UR30 base light).",
    ),
    builtin!(
        set_baselight_iec() => accept,
        "Accepted (UR20/UR30 base light).",
    ),
    builtin!(
        set_baselight_solid(r: &Value, g: &Value, b: &Value) => |c, x, _, _, _| accept(c, x),
        "Accepted (UR20/UR30 base light).",
    ),
];

/// The largest joint distance from `from` to `to`.
fn joint_distance(from: [f64; 6], to: [f64; 6]) -> f64 {
    (0..6).map(|k| (to[k] - from[k]).abs()).fold(0.0, f64::max)
}

pub use crate::runtime::JOINT_LIMIT;

/// Refuses joint targets outside the arm's range (a little rounding over ±2π passes).
fn check_joints(name: &str, q: [f64; 6]) -> Result<[f64; 6], Fault> {
    for (k, x) in q.iter().enumerate() {
        if !x.is_finite() || x.abs() > JOINT_LIMIT + 1e-9 {
            return Err(Fault::from(format!(
                "`{name}`: joint {k} target {} rad is outside the joint limits (-6.2832 to 6.2832 rad, ±360°)",
                Value::Float(*x).to_str()
            )));
        }
    }
    Ok(q)
}

/// What a motion command moves: the joints, or the tool (in the base frame).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Space {
    Joint,
    Tool,
}

/// A motion's target as the program gives it: joint positions (a list of 6 numbers) or
/// a pose.
#[derive(Debug, Clone, Copy)]
enum Target {
    Joints([f64; 6]),
    Pose([f64; 6]),
}

impl Target {
    /// True if the target is joint positions.
    fn is_joints(self) -> bool {
        matches!(self, Target::Joints(_))
    }
}

/// A list of 6 numbers (joints) or a pose; the type error names the parameter otherwise.
impl FromArg<'_> for Target {
    fn from_arg(a: &Args, v: &Value, i: usize) -> Result<Self, Fault> {
        let six = <[f64; 6]>::from_arg(a, v, i)?;
        Ok(match v {
            Value::Pose(_) => Target::Pose(six),
            _ => Target::Joints(six),
        })
    }
}

/// An argument converted to `T`, with the value as the program wrote it (for an error
/// that quotes it).
struct Given<'v, T>(T, &'v Value);

impl<'v, T: FromArg<'v>> FromArg<'v> for Given<'v, T> {
    fn from_arg(a: &Args, v: &'v Value, i: usize) -> Result<Self, Fault> {
        Ok(Given(T::from_arg(a, v, i)?, v))
    }
}

/// A motion's target: joints (checked against the joint range), or a pose reached
/// through inverse kinematics nearest the joints the move starts from. Returns the joints
/// and the tool pose there (the pose given, for a pose).
fn target(c: &Runtime, name: &str, to: Target) -> Result<([f64; 6], [f64; 6]), Fault> {
    match to {
        Target::Pose(pose) => Ok((c.inverse(pose, c.move_start().0, c.arm.tcp)?, pose)),
        Target::Joints(q) => {
            let q = check_joints(name, q)?;
            Ok((q, c.tool_pose(q)))
        }
    }
}

/// [`target`] of a straight or circular tool move: a pose out of reach is no error
/// here. The tool sets off along its path and, where the path leaves the arm's reach,
/// stops with a protective stop (as a real arm stops when the line runs it into a
/// singularity); the joints returned are then the move's start, which do not reach
/// the pose.
fn tool_target(c: &Runtime, name: &str, to: Target) -> Result<([f64; 6], [f64; 6]), Fault> {
    match (target(c, name, to), to) {
        (Err(_), Target::Pose(pose)) => Ok((c.move_start().0, pose)),
        (other, _) => other,
    }
}

/// The blend radius `r` (m) of a call to `a`: not negative.
fn radius(a: &Args, r: f64) -> Result<f64, Fault> {
    if r.is_finite() && r >= 0.0 {
        Ok(r)
    } else {
        let what = if r < 0.0 {
            "is negative"
        } else {
            "is not a finite number"
        };
        Err(Fault::from(format!(
            "`{}`: blend radius r={} m {what} (0: no blend)",
            a.name,
            Value::Float(r).to_str()
        )))
    }
}

/// A move of the tool from where it starts ([`Runtime::move_start`]) along a line (or
/// the arc through `via`) to `pose` (joints `q1` there), along a trapezoidal profile,
/// blend radius `r`; returns the time until the program gets control back.
fn tool_move(
    c: &mut Runtime,
    via: Option<[f64; 6]>,
    pose: [f64; 6],
    (q1, given): ([f64; 6], bool),
    (accel, speed, t, r): (f64, f64, f64, f64),
    (name, line, fixed): (&'static str, u32, bool),
) -> f64 {
    let (q0, p0) = c.move_start();
    let path = Path::new(p0, via, pose);
    let (r0, mut turn) = trajectory::turn_between(p0, pose);
    let (mut pose, mut q1, mut given) = (pose, q1, given);
    if fixed {
        // movec mode 1: the orientation follows the arc's tangent; only pose_to's position
        // counts, and the target joints are those of the pose the arc ends in.
        let (t, end) = trajectory::fixed_turn(&path, p0, pose);
        turn = t;
        pose = end;
        q1 = c.inverse(end, q1, c.arm.tcp).unwrap_or(q0);
        given = false;
    }
    let length = path.length();
    // A move that only turns the tool is timed on its angle.
    let dist = if length > 1e-9 {
        length
    } else {
        (turn[0] * turn[0] + turn[1] * turn[1] + turn[2] * turn[2]).sqrt()
    };
    let profile = Profile::new(dist, speed, accel, t);
    let tcp = c.arm.tcp;
    let info = move_start(name, line, Some(q1), Some(pose), (accel, speed, t, r));
    c.start_move(
        Kind::Tool {
            path,
            r0,
            turn,
            profile,
            dist,
            to: pose,
            q0,
            q1,
            given,
        },
        tcp,
        r,
        info,
    )
}

/// The [`MoveStart`] of a command (its time is set when the arm sets off).
fn move_start(
    function: &'static str,
    line: u32,
    target_q: Option<[f64; 6]>,
    target_pose: Option<[f64; 6]>,
    (a, v, t, r): (f64, f64, f64, f64),
) -> MoveStart {
    MoveStart {
        line,
        function,
        at: std::time::Duration::ZERO,
        target_q,
        target_pose,
        speed: None,
        a,
        v,
        t,
        r,
    }
}

/// `movej`, `movel`, `movep`, `servoc`, `optimovej`, `optimovel`: the arm moves along a
/// trapezoidal profile (accelerate at `a` to `v`, cruise, decelerate), stretched to `t`
/// if given (0 for those without `t`), and is at the target when the move ends; with a
/// blend radius `r > 0` the program gets control back where the blend begins (see
/// [`Runtime::start_move`]). `space`: the joints move (`movej`, `optimovej`) or the tool
/// in a line (the others).
fn go(
    c: &mut Runtime,
    a: &mut Args,
    space: Space,
    to: Target,
    (accel, speed, t, r): (f64, f64, f64, f64),
) -> Result<Out, Fault> {
    let r = radius(a, r)?;
    let back = match space {
        Space::Joint => {
            let (q1, pose) = target(c, a.name, to)?;
            let q0 = c.move_start().0;
            let profile = Profile::new(joint_distance(q0, q1), speed, accel, t);
            let tcp = c.arm.tcp;
            let info = move_start(a.name, a.line, Some(q1), Some(pose), (accel, speed, t, r));
            c.start_move(Kind::Joint { q0, q1, profile }, tcp, r, info)
        }
        Space::Tool => {
            let (q1, pose) = tool_target(c, a.name, to)?;
            tool_move(
                c,
                None,
                pose,
                (q1, to.is_joints()),
                (accel, speed, t, r),
                (a.name, a.line, false),
            )
        }
    };
    Ok(Out::Motion(back, Value::None))
}

/// `movec`: along the arc from the tool's position through `pose_via`'s to `pose_to`'s
/// (a line if the three are on one). `mode=0` (unconstrained): the orientation turns
/// from the start's to `pose_to`'s; `mode=1` (fixed): it keeps its relation to the
/// arc's tangent from the start's, turning about the circle's axis by the angle swept
/// (`pose_to`'s orientation is not used); another mode is a runtime error.
fn movec(
    c: &mut Runtime,
    a: &mut Args,
    via: Target,
    to: Target,
    (accel, speed, r): (f64, f64, f64),
    Given(mode, mode_given): Given<'_, f64>,
) -> Result<Out, Fault> {
    let via = match via {
        Target::Pose(pose) => pose,
        Target::Joints(q) => c.tool_pose(check_joints(a.name, q)?),
    };
    let r = radius(a, r)?;
    let (q1, pose) = tool_target(c, a.name, to)?;
    let fixed = if mode == 0.0 {
        false
    } else if mode == 1.0 {
        true
    } else {
        return Err(Fault::from(format!(
            "`movec`: mode={} is neither 0 (unconstrained) nor 1 (fixed)",
            mode_given.to_str()
        )));
    };
    let back = tool_move(
        c,
        Some(via),
        pose,
        (q1, to.is_joints()),
        (accel, speed, 0.0, r),
        (a.name, a.line, fixed),
    );
    Ok(Out::Motion(back, Value::None))
}

/// `powerdown()`: the arm stops, the program halts at the call and
/// [`Effect::PowerOff`](crate::Effect) is left for the controller that runs it (it powers
/// the arm off; a real controller also shuts itself down, which a virtual one serving its
/// clients does not).
fn powerdown(c: &mut Runtime, _: &mut Args) -> Result<Out, Fault> {
    c.stop_at_once();
    c.effect(crate::Effect::PowerOff);
    Ok(Out::Value(Value::None))
}

/// `protective_stop()`: the arm stops at once and
/// [`Effect::ProtectiveStop`](crate::Effect) is left for the controller that runs the arm.
fn protective_stop(c: &mut Runtime, _: &mut Args) -> Result<Out, Fault> {
    c.protective_stop();
    // One step: the statements after it do not run in the step the stop happened, so a
    // controller acting on the effect after the step pauses the program
    // before them, as the real one stops it at once.
    Ok(Out::Wait(c.step_time, Value::None))
}

/// `servoj`: straight to `q` in joint space at constant speed over `t` (`a`, `v`,
/// `lookahead_time` and `gain` shape a real servo's tracking; not modelled).
fn servoj(
    c: &mut Runtime,
    a: &mut Args,
    q: [f64; 6],
    (acc, speed, t): (f64, f64, f64),
) -> Result<Out, Fault> {
    let q1 = check_joints(a.name, q)?;
    let q0 = c.arm.q;
    let profile = Profile::new(joint_distance(q0, q1), 0.0, 0.0, t);
    let tcp = c.arm.tcp;
    let pose = c.tool_pose(q1);
    let info = move_start(a.name, a.line, Some(q1), Some(pose), (acc, speed, t, 0.0));
    c.start_motion(Kind::Joint { q0, q1, profile }, tcp, Some(info));
    Ok(after_motion_time(c, t))
}

/// `speedj(qd, a, t)`, `speedl(xd, a, t, aRot)`: the speed ramps linearly from the
/// current one to the target at `a` (the component that changes most; `aRot` for the
/// tool's rotation, `a` if left out), then holds until the next motion command; returns
/// after `t` (one step if left out).
fn speed(
    c: &mut Runtime,
    a: &mut Args,
    space: Space,
    target: [f64; 6],
    acc: f64,
    t: Option<f64>,
    a_rot: Option<f64>,
) -> Result<Out, Fault> {
    let t = t.unwrap_or(c.step_time.as_secs_f64());
    let tcp = c.arm.tcp;
    let mut info = move_start(a.name, a.line, None, None, (acc, 0.0, t, 0.0));
    info.speed = Some(target);
    match space {
        Space::Joint => {
            let qd0 = c.motion_qd();
            let ramp = trajectory::ramp_time(&qd0, &target, acc);
            let q0 = c.arm.q;
            c.start_motion(
                Kind::JointSpeed {
                    q0,
                    qd0,
                    qd1: target,
                    ramp,
                },
                tcp,
                Some(info),
            );
        }
        Space::Tool => tool_speed(c, target, acc, a_rot.unwrap_or(acc), Some(info)),
    }
    Ok(after_motion_time(c, t))
}

/// Ramps the tool speed to `v1` from the current one.
fn tool_speed(c: &mut Runtime, v1: [f64; 6], acc: f64, a_rot: f64, info: Option<MoveStart>) {
    let v0 = c.motion_tcp_speed();
    let ramp = trajectory::ramp_time(&v0[..3], &v1[..3], acc).max(trajectory::ramp_time(
        &v0[3..],
        &v1[3..],
        a_rot,
    ));
    let p0 = c.tcp_pose();
    let tcp = c.arm.tcp;
    c.start_motion(Kind::ToolSpeed { p0, v0, v1, ramp }, tcp, info);
}

/// `stopj(a)`: the joint speeds ramp down to zero at `a` (the fastest joint; the others
/// in proportion); `stopl(a, aRot)`: the tool speed, at `a` (`aRot` for its rotation,
/// `a` if left out). Returns when the arm is at rest (at least one step).
fn stop(c: &mut Runtime, space: Space, acc: f64, a_rot: Option<f64>) -> Result<Out, Fault> {
    let ramp = match space {
        Space::Joint => {
            let qd0 = c.motion_qd();
            let ramp = trajectory::ramp_time(&qd0, &[0.0; 6], acc);
            let (q0, tcp) = (c.arm.q, c.arm.tcp);
            c.start_motion(
                Kind::JointSpeed {
                    q0,
                    qd0,
                    qd1: [0.0; 6],
                    ramp,
                },
                tcp,
                None,
            );
            ramp
        }
        Space::Tool => {
            let a_rot = a_rot.unwrap_or(acc);
            let v0 = c.motion_tcp_speed();
            tool_speed(c, [0.0; 6], acc, a_rot, None);
            trajectory::ramp_time(&v0[..3], &[0.0; 3], acc).max(trajectory::ramp_time(
                &v0[3..],
                &[0.0; 3],
                a_rot,
            ))
        }
    };
    // At rest when the ramp ends on the motion clock (at least a step).
    Ok(after_motion_time(c, ramp))
}

/// Returns after `t` seconds of motion time: whole steps of the motion clock (at least
/// one), so at the speed slider's fraction `f` a call takes `t / f` of program time.
fn after_motion_time(c: &Runtime, t: f64) -> Out {
    let n = secs(t)
        .as_nanos()
        .div_ceil(c.step_time.as_nanos().max(1))
        .max(1);
    let until = c.clock_now() + u64::try_from(n).unwrap_or(u64::MAX) as f64;
    Out::Motion(until, Value::None)
}

fn direct_torque(c: &mut Runtime) -> Result<Out, Fault> {
    Ok(Out::Wait(c.step_time, Value::None))
}

/// A value read off the runtime, returned now.
fn read(c: &mut Runtime, f: impl FnOnce(&Runtime) -> Value) -> Result<Out, Fault> {
    Ok(Out::Value(f(c)))
}

/// Nothing returned now.
fn done() -> Result<Out, Fault> {
    Ok(Out::Value(Value::None))
}

fn joints(c: &mut Runtime, _: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(floats(c.arm.q)))
}

fn joints_history(c: &mut Runtime, _: &mut Args, back: i32) -> Result<Out, Fault> {
    let q = c
        .joint_history
        .at(c.step, i64::from(back), c.arm.q)
        .map_err(|e| Fault::from(format!("`get_actual_joint_positions_history`: {e}")))?;
    Ok(Out::Value(floats(q)))
}

fn joint_speeds(c: &mut Runtime, _: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(floats(c.arm.qd)))
}

fn tcp_pose(c: &mut Runtime, _: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(Value::Pose(c.tcp_pose())))
}

fn waypoint(c: &mut Runtime, _: &mut Args) -> Result<Out, Fault> {
    let pose = c
        .motion
        .as_ref()
        .and_then(|m| m.waypoint(&c.dh))
        .unwrap_or_else(|| c.tcp_pose());
    Ok(Out::Value(Value::Pose(pose)))
}

fn tcp_speed(c: &mut Runtime, _: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(floats(c.arm.tcp_speed)))
}

fn tcp_force(c: &mut Runtime, _: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(Value::Pose(c.measured_tcp_force())))
}

fn force(c: &mut Runtime, _: &mut Args) -> Result<Out, Fault> {
    let f = &c.measured_tcp_force();
    Ok(Out::Value(Value::Float(
        (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt(),
    )))
}

fn flange_pose(c: &mut Runtime, _: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(Value::Pose(c.flange_pose())))
}

/// `set_payload(m, cog)`: without a CoG the controller takes the TCP's position. The
/// deprecated setters (this, `set_payload_mass`, `set_payload_cog`) reset the inertia.
fn set_payload(c: &mut Runtime, _: &mut Args, m: f64, cog: Option<[f64; 3]>) -> Result<Out, Fault> {
    let arm = &mut c.arm;
    arm.payload_mass = m;
    arm.payload_cog = cog.unwrap_or([arm.tcp[0], arm.tcp[1], arm.tcp[2]]);
    arm.payload_inertia = [0.0; 6];
    done()
}

fn set_payload_mass(c: &mut Runtime, m: f64) -> Result<Out, Fault> {
    c.arm.payload_mass = m;
    c.arm.payload_inertia = [0.0; 6];
    done()
}

fn set_payload_cog(c: &mut Runtime, cog: [f64; 3]) -> Result<Out, Fault> {
    c.arm.payload_cog = cog;
    c.arm.payload_inertia = [0.0; 6];
    done()
}

fn set_target_payload(
    c: &mut Runtime,
    m: f64,
    cog: [f64; 3],
    inertia: [f64; 6],
) -> Result<Out, Fault> {
    if inertia.iter().any(|x| x.abs() > 133.0) || inertia[..3].iter().any(|x| *x < 0.0) {
        return Err(Fault::from(format!(
            "`set_target_payload`: inertia {inertia:?} out of range (each at most 133 kg*m^2, Ixx, Iyy, Izz not negative)"
        )));
    }
    let arm = &mut c.arm;
    arm.payload_mass = m;
    arm.payload_cog = cog;
    arm.payload_inertia = inertia;
    done()
}

/// A setting stored on the arm (`slot`) and read back by its getter: `v` outside the
/// range `lo`-`hi` the manual gives is refused, naming the call's parameter.
fn store(
    c: &mut Runtime,
    a: &Args,
    v: f64,
    (lo, hi): (f64, f64),
    slot: impl FnOnce(&mut crate::Arm) -> &mut f64,
) -> Result<Out, Fault> {
    if !(lo..=hi).contains(&v) {
        return Err(Fault::from(format!(
            "`{}`: {} {v} is not in {lo}-{hi}",
            a.name,
            a.params.first().map_or("?", |p| p.name)
        )));
    }
    *slot(&mut c.arm) = v;
    done()
}

fn motion_version_set(c: &mut Runtime, v: i32) -> Result<Out, Fault> {
    if v != 1 && v != 2 {
        return Err(Fault::from(format!(
            "`motion_version_set`: motion version {v} is not 1 or 2"
        )));
    }
    c.arm.motion_version = v;
    done()
}

fn joint_temp(c: &mut Runtime, a: &mut Args, j: i32) -> Result<Out, Fault> {
    let j = index(a, j, 6, "joint")?;
    Ok(Out::Value(Value::Float(c.arm.world.joint_temp[j])))
}

fn accelerometer(c: &mut Runtime, _: &mut Args) -> Result<Out, Fault> {
    // What the flange's axes see of gravity: the inverse rotation applied to it.
    let f = c.flange_pose();
    Ok(Out::Value(float_list(&super::poses::rotate(
        [-f[3], -f[4], -f[5]],
        c.arm.gravity,
    ))))
}

fn set_gravity(c: &mut Runtime, d: [f64; 3]) -> Result<Out, Fault> {
    c.arm.gravity = d;
    done()
}

fn set_base_acceleration(c: &mut Runtime, a: [f64; 3]) -> Result<Out, Fault> {
    c.arm.base_acceleration = a;
    done()
}

/// `get_inverse_kin_has_solution`: the joints nearest `qnear` (the joints now if left
/// out) through `tcp` (the active TCP if left out) reach `pose`, or come within both
/// allowed errors (each 0 or more).
fn has_solution(
    c: &mut Runtime,
    a: &mut Args,
    pose: [f64; 6],
    qnear: Option<[f64; 6]>,
    max_position: f64,
    max_orientation: f64,
    tcp: Option<[f64; 6]>,
) -> Result<Out, Fault> {
    let (max_position, max_orientation) =
        super::poses::tolerances(a, max_position, max_orientation)?;
    let qnear = qnear.unwrap_or(c.arm.q);
    let tcp = tcp.unwrap_or(c.arm.tcp);
    Ok(Out::Value(Value::Bool(
        super::poses::inverse_within(c, pose, qnear, tcp, max_position, max_orientation).is_ok(),
    )))
}

fn set_pos(c: &mut Runtime, a: &mut Args, q: [f64; 6]) -> Result<Out, Fault> {
    let q = check_joints(a.name, q)?;
    c.halt();
    c.arm.q = q;
    c.arm.qd = [0.0; 6];
    c.arm.tcp_speed = [0.0; 6];
    done()
}

/// A path offset's `type` (1-4).
fn offset_type(a: &Args, t: i32) -> Result<i32, Fault> {
    if (1..=4).contains(&t) {
        Ok(t)
    } else {
        Err(Fault::from(format!("`{}`: type {t} is not 1-4", a.name)))
    }
}

fn path_offset_enable(c: &mut Runtime, _: &mut Args) -> Result<Out, Fault> {
    c.arm.path_offset.enabled = true;
    done()
}

fn path_offset_disable(c: &mut Runtime) -> Result<Out, Fault> {
    let po = &mut c.arm.path_offset;
    po.enabled = false;
    po.offset = [0.0; 6];
    done()
}

/// `path_offset_set(offset, type)`: each element clamped to the maximum offset.
fn path_offset_set(
    c: &mut Runtime,
    a: &mut Args,
    mut offset: [f64; 6],
    t: i32,
) -> Result<Out, Fault> {
    let po = &mut c.arm.path_offset;
    po.kind = offset_type(a, t)?;
    for (k, x) in offset.iter_mut().enumerate() {
        let lim = if k < 3 { po.max_trans } else { po.max_rot };
        *x = x.clamp(-lim, lim);
    }
    po.offset = offset;
    done()
}

fn path_offset_get(c: &mut Runtime, a: &mut Args, t: i32) -> Result<Out, Fault> {
    offset_type(a, t)?;
    let po = &c.arm.path_offset;
    let o = if po.enabled { po.offset } else { [0.0; 6] };
    Ok(Out::Value(Value::Pose(o)))
}

fn path_offset_set_alpha_filter(c: &mut Runtime, _: &mut Args, alpha: f64) -> Result<Out, Fault> {
    if !(0.0..=1.0).contains(&alpha) {
        return Err(Fault::from(format!(
            "`path_offset_set_alpha_filter`: alpha {alpha} is not in 0-1"
        )));
    }
    c.arm.path_offset.alpha = alpha;
    done()
}

fn path_offset_set_max_offset(
    c: &mut Runtime,
    _: &mut Args,
    trans: f64,
    rot: f64,
) -> Result<Out, Fault> {
    let po = &mut c.arm.path_offset;
    po.max_trans = trans.abs();
    po.max_rot = rot.abs();
    done()
}

fn set_tcp(c: &mut Runtime, pose: [f64; 6]) -> Result<Out, Fault> {
    c.arm.tcp = pose;
    done()
}

/// `tool_contact(direction)`: the number of steps back to just before the TCP touched
/// the contact plane (at least 1 while it touches), 0 without contact. With a direction
/// (base frame, its first three elements) only a contact against it counts: the plane's
/// normal opposes the direction.
fn tool_contact(c: &mut Runtime, _: &mut Args, direction: Option<[f64; 6]>) -> Result<Out, Fault> {
    let direction = direction.unwrap_or([0.0; 6]);
    let f = c.measured_contact();
    let touching = f.iter().any(|x| *x != 0.0);
    let against = direction[..3].iter().all(|x| *x == 0.0)
        || f[0] * direction[0] + f[1] * direction[1] + f[2] * direction[2] < 0.0;
    if !(touching && against) {
        return Ok(Out::Value(Value::Int(0)));
    }
    let since = c.contact_since.unwrap_or(c.step);
    let steps = c.step.saturating_sub(since).saturating_add(1);
    Ok(Out::Value(Value::Int(
        i32::try_from(steps).unwrap_or(i32::MAX),
    )))
}

fn is_steady(c: &mut Runtime, _: &mut Args) -> Result<Out, Fault> {
    let still = c.motion.is_none() && c.arm.qd.iter().all(|v| *v == 0.0) && !c.arm.hand_guided();
    Ok(Out::Value(Value::Bool(still)))
}

/// `is_within_safety_limits(pose, qnear)`: a pose is within the limits if the arm's
/// inverse kinematics reach it with every joint within its range (±2π; through the
/// active TCP offset, nearest `qnear` or the joints now); joint positions if each is
/// within its range. The installation's safety planes and TCP limits are not modelled.
fn within_safety_limits(
    c: &mut Runtime,
    a: &mut Args,
    pose: Target,
    qnear: Option<[f64; 6]>,
) -> Result<Out, Fault> {
    let ok = match pose {
        Target::Pose(pose) => c.inverse(pose, qnear.unwrap_or(c.arm.q), c.arm.tcp).is_ok(),
        Target::Joints(q) => check_joints(a.name, q).is_ok(),
    };
    Ok(Out::Value(Value::Bool(ok)))
}

/// [`hand_mode`] of `teach_mode()`.
const TEACH: u8 = 1;
/// [`hand_mode`] of `freedrive_mode()`.
const FREEDRIVE: u8 = 2;

/// `teach_mode()` ([`TEACH`]), `freedrive_mode(freeAxes, feature)` ([`FREEDRIVE`]): the
/// arm stops (and leaves force mode); the operator then moves the joints
/// ([`crate::Arm::move_by_hand`]) until [`end_hand_mode`].
fn hand_mode(c: &mut Runtime, mode: u8) -> Result<Out, Fault> {
    c.stop_at_once();
    c.arm.force_mode = None;
    c.arm.hand_mode = mode;
    done()
}

/// `freedrive_mode(freeAxes, feature)`: `freeAxes` must be 0 or 1 each (`feature` is
/// checked to be a pose; the operator's joints are taken as given).
fn freedrive_mode(c: &mut Runtime, Given(axes, given): Given<'_, [f64; 6]>) -> Result<Out, Fault> {
    if axes.iter().any(|x| *x != 0.0 && *x != 1.0) {
        return Err(Fault::from(format!(
            "`freedrive_mode`: freeAxes {} must be 0 or 1 each",
            given.to_str()
        )));
    }
    hand_mode(c, FREEDRIVE)
}

/// `end_teach_mode()`, `end_freedrive_mode()`: the arm holds where the operator left it.
fn end_hand_mode(c: &mut Runtime, _: &mut Args) -> Result<Out, Fault> {
    c.arm.hand_mode = 0;
    c.arm.qd = [0.0; 6];
    c.arm.tcp_speed = [0.0; 6];
    done()
}

/// `end_force_mode()`: the arm stays where it is (at rest unless a motion is under way).
fn end_force_mode(c: &mut Runtime, _: &mut Args) -> Result<Out, Fault> {
    c.arm.force_mode = None;
    if c.motion.is_none() {
        c.arm.qd = [0.0; 6];
        c.arm.qdd = [0.0; 6];
        c.arm.tcp_speed = [0.0; 6];
    }
    done()
}

/// `force_mode(task_frame, selection_vector, wrench, type, limits)` (see
/// [`crate::arm::force`]).
fn force_mode(
    c: &mut Runtime,
    _: &mut Args,
    frame: [f64; 6],
    Given(sel, sel_given): Given<'_, [f64; 6]>,
    wrench: [f64; 6],
    kind: i32,
    limits: [f64; 6],
) -> Result<Out, Fault> {
    if sel.iter().any(|x| *x != 0.0 && *x != 1.0) {
        return Err(Fault::from(format!(
            "`force_mode`: selection_vector {} must be 0 or 1 each",
            sel_given.to_str()
        )));
    }
    let kind = match kind {
        1..=3 => kind as u8,
        _ => {
            return Err(Fault::from(format!(
                "`force_mode`: type {kind} is not 1, 2 or 3"
            )))
        }
    };
    if frame
        .iter()
        .chain(&wrench)
        .chain(&limits)
        .any(|x| !x.is_finite())
    {
        return Err(Fault::from(
            "`force_mode`: task_frame, wrench and limits must be finite numbers",
        ));
    }
    let programmed = c.tcp_pose();
    c.arm.hand_mode = 0;
    c.arm.force_mode = Some(crate::arm::force::ForceMode {
        frame,
        selection: sel.map(|x| x == 1.0),
        wrench,
        kind,
        limits,
        offset: [0.0; 6],
        programmed,
        at: c.step,
    });
    // The arm moves from this step's pose on.
    c.sampled = Some(c.step);
    done()
}
