//! The motion, conveyor and dynamics built-ins' arguments: each is converted to its
//! parameter's type before the code runs (a type error naming the parameter), and each
//! refusal names the call, the parameter or the value as the program wrote it.
mod common;

use common::{messages, runtime_error};

/// A program and the runtime error it ends with.
const ERRORS: &[(&str, &str)] = &[
    (
        "movej(\"a\")\n",
        "line 1: type error: `movej` argument `q` needs 6 numbers, got string \"a\"",
    ),
    (
        "speedl([0, 0, 0, 0, 0, 0], 1, t=\"x\")\n",
        "line 1: type error: `speedl` argument `t` needs a number, got string \"x\"",
    ),
    (
        "stopl(1, aRot=\"x\")\n",
        "line 1: type error: `stopl` argument `aRot` needs a number, got string \"x\"",
    ),
    (
        "set_payload(1, cog=[1, 2])\n",
        "line 1: type error: `set_payload` argument `cog` needs 3 numbers, got list [1, 2]",
    ),
    (
        "set_target_payload(1, [0, 0, 0], inertia=[1, 0, 0, 0, 0, 200])\n",
        "line 1: `set_target_payload`: inertia [1.0, 0.0, 0.0, 0.0, 0.0, 200.0] out of range (each at most 133 kg*m^2, Ixx, Iyy, Izz not negative)",
    ),
    (
        "track_conveyor_circular(p[0, 0, 0, 0, 0, 0], 5, \"x\")\n",
        "line 1: type error: `track_conveyor_circular` argument `rotate_tool` needs a bool, got string \"x\"",
    ),
    (
        "encoder_get_tick_count(0, opt=1)\n",
        "line 1: type error: `encoder_get_tick_count` argument `opt` needs a string, got int 1",
    ),
    (
        "freedrive_mode(freeAxes=[1, 2, 0, 0, 0, 0])\n",
        "line 1: `freedrive_mode`: freeAxes [1, 2, 0, 0, 0, 0] must be 0 or 1 each",
    ),
    (
        "force_mode(p[0, 0, 0, 0, 0, 0], [0, 0, 2, 0, 0, 0], [0, 0, 0, 0, 0, 0], 2, [0.1, 0.1, 0.1, 0.1, 0.1, 0.1])\n",
        "line 1: `force_mode`: selection_vector [0, 0, 2, 0, 0, 0] must be 0 or 1 each",
    ),
    (
        "force_mode(p[0, 0, 0, 0, 0, 0], [0, 0, 1, 0, 0, 0], [0, 0, 0, 0, 0, 0], 4, [0.1, 0.1, 0.1, 0.1, 0.1, 0.1])\n",
        "line 1: `force_mode`: type 4 is not 1, 2 or 3",
    ),
    (
        "movec(p[0.3, 0.1, 0.4, 0, 3.14, 0], p[0.3, 0.2, 0.4, 0, 3.14, 0], mode=2.5)\n",
        "line 1: `movec`: mode=2.5 is neither 0 (unconstrained) nor 1 (fixed)",
    ),
    (
        "movel(p[0.3, 0.1, 0.4, 0, 3.14, 0], r=-1)\n",
        "line 1: `movel`: blend radius r=-1 m is negative (0: no blend)",
    ),
    (
        "path_offset_get(0)\n",
        "line 1: `path_offset_get`: type 0 is not 1-4",
    ),
    (
        "encoder_enable_set_tick_count(0, 5)\n",
        "line 1: `encoder_enable_set_tick_count`: range 5 is not 0-4",
    ),
    (
        "set_conveyor_tick_count(1, absolute_encoder_resolution=7)\n",
        "line 1: `set_conveyor_tick_count`: range 7 is not 0-4",
    ),
    (
        "encoder_enable_pulse_decode(0, 5, 8, 9)\n",
        "line 1: `encoder_enable_pulse_decode`: decoder type 5 is not 0-4",
    ),
    (
        "encoder_enable_pulse_decode(0, 1, 3, 9)\n",
        "line 1: `encoder_enable_pulse_decode`: pin 3 is not 8-11",
    ),
    (
        "conveyor_pulse_decode(5, 0)\n",
        "line 1: `conveyor_pulse_decode`: type 5 is not 0-4",
    ),
    (
        "encoder_get_tick_count(2)\n",
        "line 1: `encoder_get_tick_count`: no encoder 2 (0-1)",
    ),
    (
        "encoder_unwind_delta_tick_count(-1, 5)\n",
        "line 1: `encoder_unwind_delta_tick_count`: no encoder -1 (0-1)",
    ),
    (
        "get_joint_temp(6)\n",
        "line 1: `get_joint_temp`: no joint 6 (0-5)",
    ),
    (
        "force_mode_set_damping(2)\n",
        "line 1: `force_mode_set_damping`: damping 2 is not in 0-1",
    ),
    (
        "force_mode_set_gain_scaling(-1)\n",
        "line 1: `force_mode_set_gain_scaling`: scaling -1 is not in 0-2",
    ),
    (
        "jerk_gain_scaling_set(0)\n",
        "line 1: `jerk_gain_scaling_set`: gain 0 is not in 0.01-1",
    ),
    (
        "motion_version_set(3)\n",
        "line 1: `motion_version_set`: motion version 3 is not 1 or 2",
    ),
    (
        "get_inverse_kin_has_solution(p[0.3, 0.1, 0.4, 0, 3.14, 0], maxPositionError=-1)\n",
        "line 1: `get_inverse_kin_has_solution`: maxPositionError must be 0 or more, not -1",
    ),
    (
        "get_actual_joint_positions_history(100000)\n",
        "line 1: `get_actual_joint_positions_history`: 100000 steps back is beyond the history buffer (1000 steps)",
    ),
    (
        "servoj([7, 0, 0, 0, 0, 0])\n",
        "line 1: `servoj`: joint 0 target 7 rad is outside the joint limits (-6.2832 to 6.2832 rad, ±360°)",
    ),
    (
        "set_pos([0, 0, 0, 0, 0, 9])\n",
        "line 1: `set_pos`: joint 5 target 9 rad is outside the joint limits (-6.2832 to 6.2832 rad, ±360°)",
    ),
    (
        "movej([0, 0, 0, 0, 0, 9])\n",
        "line 1: `movej`: joint 5 target 9 rad is outside the joint limits (-6.2832 to 6.2832 rad, ±360°)",
    ),
    (
        "movej(p[3, 3, 3, 0, 0, 0])\n",
        "line 1: no inverse kinematics solution: p[3, 3, 3, 0, 0, 0] is out of reach",
    ),
    (
        "get_mass_matrix(q=[1, 2])\n",
        "line 1: type error: `get_mass_matrix` argument `q` needs 6 numbers, got list [1, 2]",
    ),
    (
        "get_jacobian(tcp=\"x\")\n",
        "line 1: type error: `get_jacobian` argument `tcp` needs 6 numbers, got string \"x\"",
    ),
    (
        "direct_torque(1)\n",
        "line 1: type error: `direct_torque` argument `torque` needs 6 numbers, got int 1",
    ),
    (
        "stop_conveyor_tracking(a=\"x\")\n",
        "line 1: type error: `stop_conveyor_tracking` argument `a` needs a number, got string \"x\"",
    ),
    (
        "path_offset_set_max_offset(1, \"x\")\n",
        "line 1: type error: `path_offset_set_max_offset` argument `rotLimit` needs a number, got string \"x\"",
    ),
];

#[test]
fn wrong_arguments_are_refused_with_their_parameter_or_value_named() {
    for (src, want) in ERRORS {
        assert_eq!(runtime_error(src), *want, "{src}");
    }
}

/// A target is joints or a pose as the program gives it; settings are read back by their
/// getters; the deprecated payload setters reset the inertia.
#[test]
fn targets_keep_whether_they_are_joints_or_a_pose_and_settings_are_read_back() {
    let m = messages(
        "textmsg(is_within_safety_limits([7, 0, 0, 0, 0, 0]))
textmsg(is_within_safety_limits([1, 0, 0, 0, 0, 0]))
textmsg(is_within_safety_limits(p[0.3, 0.1, 0.4, 0, 3.14, 0]))
textmsg(is_within_safety_limits(p[3, 3, 3, 0, 0, 0]))
set_tcp(p[0, 0, 0.1, 0, 0, 0])
set_payload(2)
textmsg(get_target_payload(), get_target_payload_cog())
set_target_payload(1, [0, 0, 0], inertia=[1, 1, 1, 0, 0, 0])
set_payload_mass(3)
set_payload_cog([0.1, 0, 0])
textmsg(get_target_payload(), get_target_payload_cog())
textmsg(get_target_payload_inertia())
teach_mode()
textmsg(is_steady())
end_teach_mode()
textmsg(is_steady())
freedrive_mode()
textmsg(is_steady())
end_freedrive_mode()
textmsg(is_steady(), get_freedrive_status())
textmsg(get_controller_temp(), get_tool_temp())
textmsg(get_tool_current(), get_tcp_offset())
optimovel(get_actual_joint_positions())
movep(p[0.3, 0.1, 0.4, 0, 3.14, 0])
textmsg(get_actual_tcp_pose())
speedl([0, 0, 0.01, 0, 0, 0], 1, 0.1)
stopl(1)
speedj([0, 0, 0.1, 0, 0, 0], 1, 0.1)
stopj(1)
textmsg(get_actual_joint_speeds())
conveyor_pulse_decode(1, 0)
textmsg(encoder_get_tick_count(0, \"raw\"))
",
    );
    assert_eq!(
        m,
        [
            "False",
            "True",
            "True",
            "False",
            "2[0, 0, 0.1]",
            "3[0.1, 0, 0]",
            "[0, 0, 0, 0, 0, 0]",
            "False",
            "True",
            "False",
            "True0",
            "3032",
            "0p[0, 0, 0.1, 0, 0, 0]",
            "p[0.3, 0.1, 0.4, -0, 3.14, 0]",
            "[0, 0, 0, 0, 0, 0]",
            "0",
        ]
    );
}
