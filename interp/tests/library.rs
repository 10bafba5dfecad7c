//! The library's breadth (#19): the e-Series 5.x built-ins added to the table, each
//! called through a real program, setters read back by their getters.
mod common;

use common::{messages, runtime_error};
use urscript_interp::builtins::{all, lookup, Default};
use urscript_interp::Effect;

/// The numbers in a message such as `[1, 2.5, 3]` or `p[0.1, 0, 0, 0, 0, 0]`.
fn nums(msg: &str) -> Vec<f64> {
    msg.trim_start_matches('p')
        .trim_matches(|c| c == '[' || c == ']')
        .split(',')
        .map(|x| x.trim().parse().unwrap_or_else(|_| panic!("{msg:?}")))
        .collect()
}

fn close(msg: &str, want: &[f64], eps: f64) {
    let got = nums(msg);
    assert_eq!(got.len(), want.len(), "{msg}");
    for (g, w) in got.iter().zip(want) {
        assert!((g - w).abs() <= eps, "{msg} is not {want:?}");
    }
}

#[test]
fn payload_setters_are_read_back() {
    let m = messages(
        "textmsg(get_target_payload())
set_target_payload(2.5, [0, 0, 0.1], [0.01, 0.02, 0.03, 0, 0, 0.001])
textmsg(get_target_payload())
textmsg(get_target_payload_cog())
textmsg(get_target_payload_inertia())
set_payload_mass(3)
textmsg(get_target_payload(), get_target_payload_cog())
textmsg(get_target_payload_inertia())
set_target_payload(1, [0, 0, 0], inertia=[1, 1, 1, 0, 0, 0], transition_time=0.5)
set_payload_cog([0.01, 0.02, 0.03])
textmsg(get_target_payload_cog(), get_target_payload_inertia())
set_tcp(p[0, 0, 0.2, 0, 0, 0], \"gripper\")
set_payload(1.5)
textmsg(get_target_payload(), get_target_payload_cog())
set_payload(2, [0, 0.1, 0])
textmsg(get_target_payload_cog())
",
    );
    assert_eq!(
        m,
        [
            "0",
            "2.5",
            "[0, 0, 0.1]",
            "[0.01, 0.02, 0.03, 0, 0, 0.001]",
            "3[0, 0, 0.1]",
            "[0, 0, 0, 0, 0, 0]",
            "[0.01, 0.02, 0.03][0, 0, 0, 0, 0, 0]",
            // Without a CoG, set_payload takes the TCP's position.
            "1.5[0, 0, 0.2]",
            "[0, 0.1, 0]",
        ]
    );
    assert!(
        runtime_error("set_target_payload(1, [0, 0, 0], [-1, 0, 0, 0, 0, 0])\n")
            .contains("out of range")
    );
    assert!(
        runtime_error("set_target_payload(1, [0, 0, 0], [0, 0, 0, 200, 0, 0])\n")
            .contains("out of range")
    );
}

#[test]
fn the_physical_world_reads_its_documented_fixed_values() {
    let m = messages(
        "textmsg(get_joint_temp(0), get_joint_temp(5))
textmsg(get_controller_temp(), get_tool_temp())
textmsg(get_tool_current())
textmsg(get_joint_torques())
textmsg(get_tcp_force(), force())
textmsg(get_freedrive_status())
",
    );
    assert_eq!(
        m,
        [
            "3535",
            "3032",
            "0",
            "[0, 0, 0, 0, 0, 0]",
            "p[0, 0, 0, 0, 0, 0]0",
            "0"
        ]
    );
    assert!(runtime_error("get_joint_temp(6)\n").contains("no joint 6"));
}

#[test]
fn gravity_base_acceleration_and_the_accelerometer() {
    let m = messages(
        "textmsg(get_gravity(), get_base_acceleration())
movej([0, -1.5707963267948966, 1.5707963267948966, -1.5707963267948966, -1.5707963267948966, 0])
textmsg(get_tool_accelerometer_reading())
set_gravity([0, 9.82, 0])
textmsg(get_gravity())
textmsg(get_tool_accelerometer_reading())
textmsg(get_actual_tool_flange_pose())
set_base_acceleration([0.1, 0, 0])
textmsg(get_base_acceleration())
",
    );
    assert_eq!(m[0], "[0, 0, 9.82][0, 0, 0]");
    // The usual ready pose points the flange down (its rotation: pi about (1, 1, 0)):
    // the flange's z axis reads -g; a gravity along base y reads along the flange's x.
    close(&m[1], &[0.0, 0.0, -9.82], 1e-9);
    assert_eq!(m[2], "[0, 9.82, 0]");
    close(&m[3], &[9.82, 0.0, 0.0], 1e-9);
    let r = std::f64::consts::PI / 2f64.sqrt();
    close(&m[4], &[-0.4919, -0.1333, 0.4879, r, r, 0.0], 1e-6);
    assert_eq!(m[5], "[0.1, 0, 0]");
}

#[test]
fn flange_pose_and_target_waypoint() {
    let m = messages(
        "set_tcp(p[0, 0, 0.1, 0, 0, 0])
movel(p[0.3, 0, 0.5, 0, 0, 0])
textmsg(get_actual_tool_flange_pose())
textmsg(get_target_waypoint())
textmsg(get_target_tcp_pose_along_path())
textmsg(get_target_tcp_speed_along_path())
textmsg(get_tcp_offset())
",
    );
    // The tool points up at (0.3, 0, 0.5): the flange is 0.1 m below it.
    close(&m[0], &[0.3, 0.0, 0.4, 0.0, 0.0, 0.0], 1e-9);
    close(&m[1], &[0.3, 0.0, 0.5, 0.0, 0.0, 0.0], 1e-9);
    close(&m[2], &[0.3, 0.0, 0.5, 0.0, 0.0, 0.0], 1e-9);
    assert_eq!(m[3], "[0, 0, 0, 0, 0, 0]");
    assert_eq!(m[4], "p[0, 0, 0.1, 0, 0, 0]");
}

#[test]
fn set_pos_sets_the_joints() {
    let m = messages(
        "set_pos([0.1, -1.2, 1.3, 0, 1.57, 0])
textmsg(get_actual_joint_positions())
",
    );
    assert_eq!(m, ["[0.1, -1.2, 1.3, 0, 1.57, 0]"]);
}

#[test]
fn path_offset_is_set_clamped_and_cleared() {
    let m = messages(
        "textmsg(path_offset_get(1))
path_offset_enable()
path_offset_set([0.2, 0, 0.01, 0, 0, 1], 1)
textmsg(path_offset_get(1))
path_offset_set_max_offset(0.5, 1.5)
path_offset_set_alpha_filter(0.1)
path_offset_set(p[0.2, 0, 0.01, 0, 0, 1], 2)
textmsg(path_offset_get(2))
path_offset_disable()
textmsg(path_offset_get(1))
path_offset_disable(a=10)
",
    );
    assert_eq!(
        m,
        [
            "p[0, 0, 0, 0, 0, 0]",
            "p[0.1, 0, 0.01, 0, 0, 0.52]",
            "p[0.2, 0, 0.01, 0, 0, 1]",
            "p[0, 0, 0, 0, 0, 0]"
        ]
    );
    assert!(runtime_error("path_offset_set([0, 0, 0, 0, 0, 0], 5)\n").contains("not 1-4"));
    assert!(runtime_error("path_offset_set_alpha_filter(2)\n").contains("not in 0-1"));
}

#[test]
fn conveyor_encoders_count_what_they_are_told() {
    let m = messages(
        "encoder_enable_set_tick_count(0, 2)
encoder_set_tick_count(0, 1234)
textmsg(encoder_get_tick_count(0), encoder_get_tick_count(0, opt=\"raw\"))
textmsg(encoder_unwind_delta_tick_count(0, 65000))
textmsg(encoder_unwind_delta_tick_count(0, -65000))
textmsg(encoder_unwind_delta_tick_count(0, 100))
textmsg(encoder_unwind_delta_tick_count(1, 100))
encoder_enable_pulse_decode(1, 1, 8, 9)
textmsg(encoder_get_tick_count(1))
track_conveyor_linear(p[1, 0, 0, 0, 0, 0], 1000.0)
track_conveyor_circular(p[0.5, 0.5, 0, 0, 0, 0], 500.0, False, encoder_index=1)
stop_conveyor_tracking()
stop_conveyor_tracking(a=15)
conveyor_pulse_decode(1, 0, 1)
conveyor_pulse_decode(2, 3)
set_conveyor_tick_count(24543)
textmsg(get_conveyor_tick_count())
set_conveyor_tick_count(200, absolute_encoder_resolution=1)
textmsg(encoder_unwind_delta_tick_count(0, 250))
",
    );
    assert_eq!(
        m,
        ["12341234", "-536", "536", "100", "None", "0", "24543", "-6"]
    );
    assert!(runtime_error(
        "encoder_enable_pulse_decode(0, 1, 8, 9)\nencoder_set_tick_count(0, 5)\n"
    )
    .contains("not enabled by encoder_enable_set_tick_count"));
    assert!(
        runtime_error("encoder_enable_set_tick_count(0, 1)\nencoder_set_tick_count(0, 256)\n")
            .contains("outside")
    );
    assert!(
        runtime_error("track_conveyor_linear(p[1, 0, 0, 0, 0, 0], 1000, 2)\n")
            .contains("no encoder 2")
    );
}

#[test]
fn outputs_flags_and_ports_are_read_back() {
    let m = messages(
        "set_standard_analog_out(1, 0.7)
set_analog_out(0, 0.25)
textmsg(get_standard_analog_out(1), get_analog_out(0))
textmsg(get_flag(3))
set_flag(3, True)
textmsg(get_flag(3), get_flag(31))
write_port_bit(3, True)
write_port_register(130, 100)
write_port_register(131, 65535)
textmsg(read_port_bit(3), read_port_bit(4))
textmsg(read_port_register(130), read_port_register(131))
textmsg(read_port_register(132))
write_output_boolean_register(127, True)
textmsg(read_output_boolean_register(127))
textmsg(read_input_boolean_register(127), read_input_integer_register(47))
textmsg(read_input_float_register(0))
set_digital_out(8, True)
textmsg(get_tool_digital_out(0), get_digital_out(8))
textmsg(get_digital_in(9), get_configurable_digital_in(7))
textmsg(get_tool_digital_in(1), get_standard_digital_in(7))
textmsg(get_analog_in(3), get_tool_analog_in(1))
",
    );
    assert_eq!(
        m,
        [
            "0.70.25",
            "False",
            "TrueFalse",
            "TrueFalse",
            "100-1",
            "0",
            "True",
            "False0",
            "0",
            "TrueTrue",
            "FalseFalse",
            "FalseFalse",
            "00"
        ]
    );
    assert!(runtime_error("set_flag(32, True)\n").contains("no flag 32"));
    assert!(runtime_error("read_input_integer_register(48)\n").contains("no register 48"));
    assert!(runtime_error("read_input_boolean_register(128)\n").contains("no register 128"));
    assert!(runtime_error("write_port_register(1, 70000)\n").contains("does not fit"));
    assert!(runtime_error("get_standard_analog_out(2)\n").contains("no analog output 2"));
}

#[test]
fn io_configuration() {
    let m = messages(
        "set_analog_outputdomain(1, 1)
set_analog_outputdomain(0, 0)
set_configurable_digital_input_action(0, \"freedrive\")
set_tool_digital_input_action(1, \"default\")
set_gp_boolean_input_action(64, \"freedrive\")
set_runstate_configurable_digital_output_to_value(5, 2)
set_runstate_tool_digital_output_to_value(1, 2)
set_runstate_standard_analog_output_to_value(1, 2)
set_runstate_gp_boolean_output_to_value(64, 2)
rtde_set_watchdog(\"input_int_register_0\", 10, \"stop\")
rtde_set_watchdog(\"input_int_register_1\", 10)
textmsg(\"ok\")
",
    );
    assert_eq!(m, ["ok"]);
    assert!(runtime_error("set_analog_outputdomain(1, 2)\n").contains("domain 2"));
    assert!(runtime_error("set_analog_outputdomain(2, 1)\n").contains("no analog output 2"));
    assert!(
        runtime_error("set_configurable_digital_input_action(0, \"jump\")\n")
            .contains("is not \"default\" or \"freedrive\"")
    );
}

#[test]
fn the_virtual_modbus_client_keeps_its_signals() {
    let m = messages(
        "modbus_add_signal(\"172.140.17.11\", 255, 5, 3, \"reg_out\")
modbus_add_signal(\"172.140.17.11\", 255, 6, 1, \"coil_out\")
modbus_add_signal(\"172.140.17.11\", 255, 7, 0, \"coil_in\")
modbus_add_signal(\"172.140.17.11\", 255, 0, 16, \"regs\", False, 3)
modbus_add_rw_signal(\"172.140.17.11\", 255, 5, 2, 15, 2, \"rw\")
modbus_set_output_register(\"reg_out\", 300, False)
modbus_set_output_signal(\"coil_out\", True)
modbus_set_output_register(\"regs\", [10, 9])
textmsg(modbus_get_signal_status(\"reg_out\"), modbus_get_signal_status(\"coil_out\"))
textmsg(modbus_get_signal_status(\"coil_in\", False), modbus_get_signal_status(\"regs\"))
textmsg(modbus_get_signal_status(\"rw\"))
textmsg(modbus_get_error(\"reg_out\"), modbus_get_time_since_signal_invalid(\"reg_out\"))
modbus_set_signal_update_frequency(\"reg_out\", 20)
modbus_set_signal_watchdog(\"reg_out\", 10.5)
modbus_request_update_signal_value(\"reg_out\")
modbus_set_digital_input_action(\"coil_in\", \"freedrive\")
modbus_set_runstate_dependent_choice(\"coil_out\", 3)
modbus_send_custom_command(\"172.140.17.11\", 103, 6, [17, 32, 2, 88])
modbus_reset_connection(\"172.140.17.11\")
modbus_delete_signal(\"reg_out\")
textmsg(\"done\")
",
    );
    assert_eq!(m, ["300True", "False[10, 9, 0]", "[0, 0]", "00", "done"]);
    assert!(runtime_error("modbus_get_signal_status(\"nope\")\n").contains("no Modbus signal"));
    assert!(runtime_error(
        "modbus_add_signal(\"1.2.3.4\", 255, 7, 0, \"in\")\nmodbus_set_output_signal(\"in\", True)\n"
    )
    .contains("cannot take"));
    assert!(
        runtime_error("modbus_add_signal(\"1.2.3.4\", 255, 7, 4, \"x\")\n")
            .contains("signal type 4")
    );
}

#[test]
fn the_virtual_operator_answers_at_once() {
    let m = messages(
        "textmsg(request_boolean_from_primary_client(\"Mark?\"))
textmsg(request_integer_from_primary_client(\"How many?\"))
textmsg(request_float_from_primary_client(\"Offset?\"))
textmsg(str_len(request_string_from_primary_client(\"Name?\")))
",
    );
    assert_eq!(m, ["False", "0", "0", "0"]);
}

#[test]
fn urmath_additions_match_the_manual_examples() {
    let m = messages(
        "textmsg(normalize([0, 5, 0]))
textmsg(normalize([0, 1, 1]))
textmsg(inv([[0, 1, 0], [0, 0, 1], [1, 0, 0]]))
textmsg(inv(p[.2, .5, .1, 1.57, 0, 3.14]))
textmsg(transpose([[1, 2], [3, 4], [5, 6]]))
textmsg(size(\"here I am\"), size([1, 2, 3, 4, 5]))
textmsg(size([[1, 2], [3, 4], [5, 6]]))
textmsg(make_list(5, \"a\"))
textmsg(make_list(0, 0, 100), make_list(2, 1.5, capacity=4))
textmsg(rotvec2rpy([3.14, 1.57, 0]))
textmsg(rpy2rotvec([3.14, 1.57, 0]))
textmsg(rotvec2rpy(rpy2rotvec([0.1, -0.2, 0.3])))
textmsg(wrench_trans(p[0, 0, 0.1, 0, 0, 0], [1, 0, 0, 0, 0, 0]))
textmsg(wrench_trans(p[0, 0, 0, 0, 0, 1.5707963267949], [1, 0, 0, 0, 0, 2]))
",
    );
    assert_eq!(m[0], "[0, 1, 0]");
    let h = std::f64::consts::FRAC_1_SQRT_2;
    close(&m[1], &[0.0, h, h], 1e-6);
    assert_eq!(m[2], "[[0, 0, 1], [1, 0, 0], [0, 1, 0]]");
    close(
        &m[3],
        &[0.19324, 0.41794, -0.29662, 1.23993, 0.0, 2.47985],
        1e-5,
    );
    assert_eq!(m[4], "[[1, 3, 5], [2, 4, 6]]");
    assert_eq!(m[5], "95");
    assert_eq!(m[6], "[3, 2]");
    assert_eq!(m[7], "[a, a, a, a, a]");
    assert_eq!(m[8], "[][1.5, 1.5]");
    close(&m[9], &[-2.80856, -0.16202, 0.9], 1e-4);
    close(&m[10], &[2.22153, 0.00177, -2.21976], 1e-5);
    close(&m[11], &[0.1, -0.2, 0.3], 1e-9);
    // A force along x at the origin, seen from 0.1 m above: a torque about -y.
    close(&m[12], &[1.0, 0.0, 0.0, 0.0, -0.1, 0.0], 1e-9);
    // Seen from a frame turned 90 degrees about z: x becomes -y.
    close(&m[13], &[0.0, -1.0, 0.0, 0.0, 0.0, 2.0], 1e-9);
    assert!(runtime_error("normalize([0, 0, 0])\n").contains("zero"));
    assert!(runtime_error("inv([[1, 2], [2, 4]])\n").contains("singular"));
    assert!(runtime_error("inv([[1, 2, 3], [2, 4, 5]])\n").contains("not square"));
    assert!(runtime_error("make_list(3, 0, 2)\n").contains("capacity"));
}

#[test]
fn settings_without_a_model_are_accepted_with_their_manual_signatures() {
    let m = messages(
        "screw_driving(5.0, 0.1)
end_screw_driving()
freedrive_mode_no_incorrect_payload_check()
end_freedrive_mode()
high_holding_torque_disable()
high_holding_torque_enable()
pause_on_error_code(173, 3)
pause_on_error_code(173)
position_deviation_warning(True, 0.8)
position_deviation_warning(False)
reset_revolution_counter()
reset_revolution_counter(qNear=[0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
tool_wrench_limit_set(p[0, 0, 0.1, 0, 0, 1.57], Mx=10, My=15)
tool_wrench_limit_set(get_tcp_offset(), Fz=50)
tool_wrench_limit_disable()
set_baselight_off()
set_baselight_iec()
set_baselight_solid(255, 0, 0)
textmsg(get_inverse_kin_has_solution(p[.1, .2, .2, 0, 3.14, 0], [0., 3.14, 1.57, .785, 0, 0]))
textmsg(get_inverse_kin_has_solution(p[.1, .2, .2, 0, 3.14, 0], maxPositionError=1e-6))
",
    );
    assert_eq!(m, ["True", "True"]);
}

/// Every function this issue added, with the parameters the e-Series 5.x manual gives.
const ADDED: &[(&str, &[&str])] = &[
    // Module internals / motion.
    ("force", &[]),
    ("get_actual_tool_flange_pose", &[]),
    ("get_target_waypoint", &[]),
    ("get_target_tcp_pose_along_path", &[]),
    ("get_target_tcp_speed_along_path", &[]),
    ("get_target_payload", &[]),
    ("get_target_payload_cog", &[]),
    ("get_target_payload_inertia", &[]),
    ("get_joint_torques", &[]),
    ("get_joint_temp", &["j"]),
    ("get_controller_temp", &[]),
    ("get_tool_temp", &[]),
    ("get_tool_current", &[]),
    ("get_tool_accelerometer_reading", &[]),
    ("get_gravity", &[]),
    ("get_base_acceleration", &[]),
    ("set_base_acceleration", &["a"]),
    ("get_freedrive_status", &[]),
    (
        "get_inverse_kin_has_solution",
        &[
            "pose",
            "qnear",
            "maxPositionError",
            "maxOrientationError",
            "tcp",
        ],
    ),
    ("set_pos", &["q"]),
    ("path_offset_enable", &[]),
    ("path_offset_disable", &["a"]),
    ("path_offset_set", &["offset", "type"]),
    ("path_offset_get", &["type"]),
    ("path_offset_set_alpha_filter", &["alpha"]),
    ("path_offset_set_max_offset", &["transLimit", "rotLimit"]),
    ("screw_driving", &["f", "v_limit"]),
    ("freedrive_mode_no_incorrect_payload_check", &[]),
    ("high_holding_torque_disable", &[]),
    ("high_holding_torque_enable", &[]),
    ("pause_on_error_code", &["code", "argument"]),
    ("position_deviation_warning", &["enabled", "threshold"]),
    ("reset_revolution_counter", &["qNear"]),
    (
        "tool_wrench_limit_set",
        &["frame_offset", "Fx", "Fy", "Fz", "Mx", "My", "Mz"],
    ),
    ("tool_wrench_limit_disable", &[]),
    ("set_baselight_off", &[]),
    ("set_baselight_iec", &[]),
    ("set_baselight_solid", &["r", "g", "b"]),
    // Conveyor tracking (motion).
    (
        "encoder_enable_pulse_decode",
        &["encoder_index", "decoder_type", "A", "B"],
    ),
    (
        "encoder_enable_set_tick_count",
        &["encoder_index", "range_id"],
    ),
    ("conveyor_pulse_decode", &["type", "A", "B"]),
    ("encoder_get_tick_count", &["encoder_index", "opt"]),
    ("get_conveyor_tick_count", &[]),
    ("encoder_set_tick_count", &["encoder_index", "count"]),
    (
        "set_conveyor_tick_count",
        &["tick_count", "absolute_encoder_resolution"],
    ),
    (
        "encoder_unwind_delta_tick_count",
        &["encoder_index", "delta_tick_count"],
    ),
    (
        "track_conveyor_linear",
        &["direction", "ticks_per_meter", "encoder_index"],
    ),
    (
        "track_conveyor_circular",
        &[
            "center",
            "ticks_per_revolution",
            "rotate_tool",
            "encoder_index",
        ],
    ),
    // Module interfaces.
    ("get_standard_analog_out", &["n"]),
    ("get_analog_out", &["n"]),
    ("get_flag", &["n"]),
    ("read_port_bit", &["address"]),
    ("read_port_register", &["address"]),
    ("write_port_bit", &["address", "value"]),
    ("write_port_register", &["address", "value"]),
    (
        "rtde_set_watchdog",
        &["variable_name", "min_frequency", "action"],
    ),
    (
        "modbus_add_signal",
        &[
            "IP",
            "slave_number",
            "signal_address",
            "signal_type",
            "signal_name",
            "sequential_mode",
            "register_count",
        ],
    ),
    (
        "modbus_add_rw_signal",
        &[
            "IP",
            "slave_number",
            "read_address",
            "read_register_count",
            "write_address",
            "write_register_count",
            "signal_name",
            "sequential_mode",
        ],
    ),
    ("modbus_delete_signal", &["signal_name"]),
    (
        "modbus_get_signal_status",
        &["signal_name", "is_secondary_program"],
    ),
    (
        "modbus_set_output_register",
        &["signal_name", "register_value", "is_secondary_program"],
    ),
    (
        "modbus_set_output_signal",
        &["signal_name", "digital_value", "is_secondary_program"],
    ),
    (
        "modbus_send_custom_command",
        &["IP", "slave_number", "function_code", "data"],
    ),
    (
        "modbus_set_digital_input_action",
        &["signal_name", "action"],
    ),
    (
        "modbus_set_signal_update_frequency",
        &["signal_name", "update_frequency"],
    ),
    ("modbus_get_error", &["signal_name", "error_source"]),
    ("modbus_get_time_since_signal_invalid", &["signal_name"]),
    ("modbus_request_update_signal_value", &["signal_name"]),
    ("modbus_reset_connection", &["connection_id", "is_blocking"]),
    (
        "modbus_set_signal_watchdog",
        &["signal_name", "new_timeout_in_sec"],
    ),
    ("request_boolean_from_primary_client", &["message"]),
    ("request_integer_from_primary_client", &["message"]),
    ("request_float_from_primary_client", &["message"]),
    ("request_string_from_primary_client", &["message"]),
    // Module ioconfiguration.
    ("set_analog_outputdomain", &["port", "domain"]),
    ("set_configurable_digital_input_action", &["port", "action"]),
    ("set_tool_digital_input_action", &["port", "action"]),
    ("set_gp_boolean_input_action", &["port", "action"]),
    (
        "set_runstate_configurable_digital_output_to_value",
        &["outputId", "state"],
    ),
    (
        "set_runstate_tool_digital_output_to_value",
        &["outputId", "state"],
    ),
    (
        "set_runstate_standard_analog_output_to_value",
        &["outputId", "state"],
    ),
    (
        "set_runstate_gp_boolean_output_to_value",
        &["outputId", "state"],
    ),
    (
        "modbus_set_runstate_dependent_choice",
        &["signal_name", "runstate_choice"],
    ),
    // Module urmath.
    ("normalize", &["v"]),
    ("inv", &["m"]),
    ("transpose", &["m"]),
    ("size", &["v"]),
    ("make_list", &["length", "initial_value", "capacity"]),
    ("rotvec2rpy", &["rotation_vector"]),
    ("rpy2rotvec", &["rpy_vector"]),
    ("wrench_trans", &["T_from_to", "w_from"]),
    // The arm's model (internals, PolyScope 5.22 and later).
    ("get_jacobian", &["q", "tcp"]),
    ("get_jacobian_time_derivative", &["q", "qd", "tcp"]),
    ("get_mass_matrix", &["q", "include_rotors_inertia"]),
    ("get_coriolis_and_centrifugal_torques", &["q", "qd"]),
    ("get_target_joint_accelerations", &[]),
    ("get_actual_joint_accelerations", &[]),
    // Settings read back.
    ("force_mode_get_damping", &[]),
    ("force_mode_get_gain_scaling", &[]),
    ("motion_version_get", &[]),
    ("motion_version_set", &["version"]),
    ("jerk_gain_scaling_get", &[]),
    ("jerk_gain_scaling_set", &["gain"]),
    // Interfaces.
    ("get_rtde_value", &["key"]),
    // Functions returning structs.
    ("estimate_payload", &["poses", "wrenches"]),
    ("time", &["mode"]),
];

#[test]
fn every_added_function_is_in_the_table_with_the_manuals_parameters() {
    for (name, params) in ADDED {
        let b = lookup(name).unwrap_or_else(|| panic!("{name} is not a built-in"));
        let got: Vec<&str> = b.params.iter().map(|p| p.name).collect();
        assert_eq!(&got, params, "{name}");
        assert!(all().iter().any(|x| x.name == *name));
    }
    // The defaults the manual gives.
    let sig = |n: &str| lookup(n).unwrap().signature();
    assert_eq!(
        sig("track_conveyor_circular"),
        "track_conveyor_circular(center, ticks_per_revolution, rotate_tool=False, encoder_index=0)"
    );
    assert_eq!(
        sig("track_conveyor_linear"),
        "track_conveyor_linear(direction, ticks_per_meter, encoder_index=0)"
    );
    assert_eq!(
        sig("encoder_get_tick_count"),
        r#"encoder_get_tick_count(encoder_index, opt="")"#
    );
    assert_eq!(
        sig("set_conveyor_tick_count"),
        "set_conveyor_tick_count(tick_count, absolute_encoder_resolution=0)"
    );
    assert_eq!(sig("path_offset_disable"), "path_offset_disable(a=20.0)");
    assert_eq!(
        sig("position_deviation_warning"),
        "position_deviation_warning(enabled, threshold=0.8)"
    );
    assert_eq!(
        sig("rtde_set_watchdog"),
        r#"rtde_set_watchdog(variable_name, min_frequency, action="pause")"#
    );
    assert_eq!(
        sig("modbus_add_signal"),
        r#"modbus_add_signal(IP, slave_number, signal_address, signal_type, signal_name, sequential_mode=False, register_count=1)"#
    );
    assert_eq!(
        sig("get_inverse_kin_has_solution"),
        "get_inverse_kin_has_solution(pose, qnear=None, maxPositionError=1e-10, maxOrientationError=1e-10, tcp=None)"
    );
    assert_eq!(sig("set_tcp"), r#"set_tcp(pose, tcp_name="")"#);
    assert_eq!(sig("optimovej"), "optimovej(goal, a=0.3, v=0.3, r=0.0)");
    assert_eq!(
        sig("get_mass_matrix"),
        "get_mass_matrix(q=None, include_rotors_inertia=False)"
    );
    assert_eq!(
        lookup("reset_revolution_counter").unwrap().params[0].default,
        Default::Floats(&[0.0; 6])
    );
    // URCap functions are never built-ins; nor is what needs a network or a GUI the
    // virtual controller does not have (`rpc_factory` is one: its calls go through the
    // machine's socket events, see tests/rpc.rs).
    assert_eq!(sig("time"), "time(mode=0)");
    assert_eq!(sig("estimate_payload"), "estimate_payload(poses, wrenches)");
    assert_eq!(
        sig("add_frame"),
        "add_frame(name, pose, ref_frame=\"base\")"
    );
    assert_eq!(sig("get_pose"), "get_pose(name, rel_frame, ref_frame=None)");
    for name in ["rq_activate", "rq_open"] {
        assert!(lookup(name).is_none(), "{name}");
    }
}

/// The numbers of a message, brackets of nested lists dropped: a matrix row by row.
fn flat(msg: &str) -> Vec<f64> {
    msg.split(['[', ']', ',', 'p'])
        .map(str::trim)
        .filter(|x| !x.is_empty())
        .map(|x| x.parse().unwrap_or_else(|_| panic!("{msg:?}")))
        .collect()
}

#[test]
fn the_jacobian_maps_joint_speeds_to_the_tool_speed() {
    // Hold a joint speed: the Jacobian times the joint speeds is the tool speed the arm
    // reports, with the active TCP and with another one given.
    let m = messages(
        "set_tcp(p[0, 0.05, 0.1, 0, 0, 0])
movej([0.2, -1.3, 1.5, -1.2, -1.4, 0.3])
speedj([0.1, -0.2, 0.15, 0.3, -0.25, 0.4], 5, 0.5)
q = get_actual_joint_positions()
qd = get_actual_joint_speeds()
textmsg(get_jacobian() * qd)
textmsg(get_actual_tcp_speed())
textmsg(get_jacobian(q, p[0, 0.05, 0.1, 0, 0, 0]) == get_jacobian())
textmsg(get_jacobian(tcp=p[0, 0, 0, 0, 0, 0]) == get_jacobian())
textmsg(get_jacobian([0, 0, 0, 0, 0, 0], p[0, 0, 0, 0, 0, 0]))
stopj(5)
",
    );
    let (jqd, speed) = (flat(&m[0]), flat(&m[1]));
    assert_eq!(jqd.len(), 6);
    for (a, b) in jqd.iter().zip(&speed) {
        assert!((a - b).abs() < 1e-5, "{m:?}");
    }
    assert!(speed.iter().any(|x| x.abs() > 0.01), "the arm moves: {m:?}");
    assert_eq!(m[2], "True");
    assert_eq!(m[3], "False");
    // At the zero position joint 1 turns about the base's z axis; the flange is at
    // x = a2 + a3, y = -(d4 + d6) (UR5e).
    let j = flat(&m[4]);
    assert_eq!(j.len(), 36);
    let col0: Vec<f64> = (0..6).map(|r| j[r * 6]).collect();
    let (x, y) = (-0.425 - 0.3922, -(0.1333 + 0.0996));
    close(&format!("{col0:?}"), &[-y, x, 0.0, 0.0, 0.0, 1.0], 1e-6);
}

#[test]
fn the_jacobian_time_derivative_is_zero_at_rest_and_follows_the_speeds() {
    let q = [0.2, -1.3, 1.5, -1.2, -1.4, 0.3];
    let qd = [0.1, -0.2, 0.15, 0.3, -0.25, 0.4];
    let m = messages(
        "movej([0.2, -1.3, 1.5, -1.2, -1.4, 0.3])
textmsg(get_jacobian_time_derivative())
textmsg(get_jacobian_time_derivative(qd=[0.1, -0.2, 0.15, 0.3, -0.25, 0.4]))
",
    );
    assert!(flat(&m[0]).iter().all(|x| *x == 0.0), "{}", m[0]);
    let want = urscript_interp::kinematics::jacobian_time_derivative(
        &urscript_interp::kinematics::Model::Ur5e.dh(),
        q,
        qd,
        [0.0; 6],
    );
    let got = flat(&m[1]);
    assert_eq!(got.len(), 36);
    for (g, w) in got.iter().zip(want.iter().flatten()) {
        assert!((g - w).abs() < 1e-5, "{} is not {want:?}", m[1]);
    }
    assert!(got.iter().any(|x| x.abs() > 1e-3));
}

#[test]
fn the_mass_matrix_carries_the_payload_and_the_rotors() {
    let src = "q = [0.0, -1.2, 1.4, -1.6, -1.57, 0.0]
m0 = get_mass_matrix(q)
textmsg(m0)
textmsg(m0[1][2] == m0[2][1], m0[0][4] == m0[4][0])
set_target_payload(5.0, [0, 0, 0.1])
m1 = get_mass_matrix(q)
textmsg(m1[0][0] > m0[0][0], m1[1][1] > m0[1][1] and m1[3][3] > m0[3][3])
m2 = get_mass_matrix(q, include_rotors_inertia=True)
textmsg(m2[0][0] - m1[0][0], m2[5][5] - m1[5][5])
textmsg(m2[0][1] - m1[0][1])
";
    let mut h = common::Harness::new(src, urscript_interp::Config::default());
    h.m.world_mut().rotor_inertia = [0.5, 0.5, 0.25, 0.1, 0.1, 0.125];
    h.run_silent(std::time::Duration::from_secs(1));
    assert_eq!(
        h.m.state(),
        &urscript_interp::State::Finished,
        "{:?}",
        h.messages
    );
    let m = &h.messages;
    let want = urscript_interp::kinematics::dynamics::mass_matrix(
        urscript_interp::kinematics::Model::Ur5e,
        [0.0, -1.2, 1.4, -1.6, -1.57, 0.0],
        &urscript_interp::kinematics::dynamics::Payload::NONE,
    );
    for (g, w) in flat(&m[0]).iter().zip(want.iter().flatten()) {
        assert!((g - w).abs() < 1e-5, "{} is not {want:?}", m[0]);
    }
    assert_eq!(m[1], "TrueTrue");
    assert_eq!(m[2], "TrueTrue");
    // The rotor inertias the world gives, on the diagonal only.
    assert_eq!(m[3], "0.50.125");
    assert_eq!(m[4], "0");
}

#[test]
fn coriolis_torques_are_zero_at_rest_and_grow_with_the_square_of_the_speeds() {
    let m = messages(
        "q = [0.3, -1.1, 1.4, -0.7, 1.2, 0.5]
qd = [0.4, -0.3, 0.8, 0.5, -0.6, 0.9]
textmsg(get_coriolis_and_centrifugal_torques())
c1 = get_coriolis_and_centrifugal_torques(q, qd)
c2 = get_coriolis_and_centrifugal_torques(q, [0.8, -0.6, 1.6, 1.0, -1.2, 1.8])
textmsg(c1)
textmsg(norm(c2 - c1 * 4) < 1e-9)
",
    );
    assert_eq!(m[0], "[0, 0, 0, 0, 0, 0]");
    let want = urscript_interp::kinematics::dynamics::coriolis_and_centrifugal_torques(
        urscript_interp::kinematics::Model::Ur5e,
        [0.3, -1.1, 1.4, -0.7, 1.2, 0.5],
        [0.4, -0.3, 0.8, 0.5, -0.6, 0.9],
        &urscript_interp::kinematics::dynamics::Payload::NONE,
    );
    close(&m[1], &want, 1e-5);
    assert!(want.iter().any(|x| x.abs() > 0.01));
    assert_eq!(m[2], "True");
}

#[test]
fn joint_accelerations_follow_the_speed_ramp() {
    // speedj ramps joint 1 up at 1 rad/s² for 0.5 s; after 0.1 s it is still ramping.
    let m = messages(
        "textmsg(get_target_joint_accelerations())
speedj([0.5, 0, 0, 0, 0, -0.25], 1.0, 0.1)
textmsg(get_target_joint_accelerations())
textmsg(get_actual_joint_accelerations())
stopj(10)
textmsg(get_actual_joint_accelerations())
",
    );
    assert_eq!(m[0], "[0, 0, 0, 0, 0, 0]");
    // The joint that moves furthest ramps at a; the others in proportion.
    close(&m[1], &[1.0, 0.0, 0.0, 0.0, 0.0, -0.5], 1e-6);
    assert_eq!(m[1], m[2]);
    assert_eq!(m[3], "[0, 0, 0, 0, 0, 0]");
}

#[test]
fn force_mode_motion_version_and_jerk_settings_are_read_back() {
    let m = messages(
        "textmsg(force_mode_get_damping(), force_mode_get_gain_scaling())
force_mode_set_damping(0.25)
force_mode_set_gain_scaling(1.5)
textmsg(force_mode_get_damping(), force_mode_get_gain_scaling())
textmsg(motion_version_get(), jerk_gain_scaling_get())
v = motion_version_get()
motion_version_set(2)
textmsg(motion_version_get())
motion_version_set(v)
jerk_gain_scaling_set(0.5)
textmsg(motion_version_get(), jerk_gain_scaling_get())
",
    );
    assert_eq!(m, ["01", "0.251.5", "11", "2", "10.5"]);
    assert!(runtime_error("force_mode_set_damping(1.5)\n").contains("damping 1.5 is not in 0-1"));
    assert!(runtime_error("force_mode_set_gain_scaling(-1)\n").contains("not in 0-2"));
    assert!(runtime_error("jerk_gain_scaling_set(0)\n").contains("gain 0 is not in 0.01-1"));
    assert!(runtime_error("motion_version_set(3)\n").contains("motion version 3 is not 1 or 2"));
}

#[test]
fn get_rtde_value_reads_the_virtual_arms_fields() {
    let src = "write_output_integer_register(3, 42)
write_output_float_register(7, 2.5)
write_output_boolean_register(1, True)
write_output_boolean_register(65, True)
set_standard_digital_out(2, True)
sync()
textmsg(get_rtde_value(\"output_int_register_3\"), get_rtde_value(\"output_double_register_7\"))
textmsg(get_rtde_value(\"output_bit_registers0_to_31\"), get_rtde_value(\"output_bit_register_65\"))
textmsg(get_rtde_value(\"actual_digital_output_bits\"), get_rtde_value(\"actual_digital_input_bits\"))
textmsg(get_rtde_value(\"input_int_register_5\"), get_rtde_value(\"actual_execution_time\"))
textmsg(get_rtde_value(\"actual_q\") == get_actual_joint_positions())
textmsg(get_rtde_value(\"actual_TCP_pose\"))
textmsg(get_rtde_value(\"robot_mode\"), get_rtde_value(\"safety_mode\"))
textmsg(get_rtde_value(\"speed_scaling\"))
textmsg(get_rtde_value(\"timestamp\"))
";
    let mut h = common::Harness::new(src, urscript_interp::Config::default());
    h.m.world_mut().input_int_regs[5] = -7;
    h.m.world_mut().execution_time = 0.42;
    h.m.world_mut().digital_in[0] = true;
    h.m.world_mut().digital_in[3] = true;
    h.run_silent(std::time::Duration::from_secs(1));
    assert_eq!(
        h.m.state(),
        &urscript_interp::State::Finished,
        "{:?}",
        h.messages
    );
    let m = &h.messages;
    assert_eq!(m[0], "422.5");
    assert_eq!(m[1], "2True");
    assert_eq!(m[2], "49");
    assert_eq!(m[3], "-70.42");
    assert_eq!(m[4], "True");
    // A VECTOR6D is a list, not a pose.
    assert!(m[5].starts_with('[') && flat(&m[5]).len() == 6, "{}", m[5]);
    assert_eq!(m[6], "71");
    assert_eq!(m[7], "1");
    // One sync() of 2 ms has passed.
    close(&format!("[{}]", m[8]), &[0.002], 1e-12);
    assert!(runtime_error("get_rtde_value(\"no_such_field\")\n")
        .contains("\"no_such_field\" is not an RTDE output field"));
    assert!(
        runtime_error("get_rtde_value(\"output_int_register_48\")\n")
            .contains("is not an RTDE output field")
    );
}

#[test]
fn the_models_functions_refuse_what_is_not_joints_and_survive_what_is_not_finite() {
    // Wrong shapes are type errors naming the argument.
    assert!(runtime_error("get_jacobian([1, 2, 3])\n")
        .contains("`get_jacobian` argument `q` needs 6 numbers"));
    assert!(runtime_error("get_mass_matrix(q=\"x\")\n").contains("argument `q` needs 6 numbers"));
    assert!(
        runtime_error("get_coriolis_and_centrifugal_torques(qd=[1, 2])\n")
            .contains("argument `qd` needs 6 numbers")
    );
    assert!(runtime_error("get_rtde_value(3)\n").contains("argument `key` needs a string"));
    // Numbers too large to mean anything give numbers, not a crash.
    let m = messages(
        "q = [1e308, -1e308, 1e308, 0, 0, 0]
j = get_jacobian(q, p[1e308, 0, 0, 0, 0, 0])
m = get_mass_matrix(q)
c = get_coriolis_and_centrifugal_torques(q, [1e308, 1e308, 0, 0, 0, 0])
d = get_jacobian_time_derivative(q, [1e308, 0, 0, 0, 0, 0])
textmsg(get_list_length(j), get_list_length(c))
",
    );
    assert_eq!(m, ["66"]);
}

/// Four TCP poses a quarter turn apart (none, about x, about y, about z) and the wrench a
/// 2 kg payload with its CoG at (0.01, 0.02, 0.05) m in the flange frame puts on the
/// flange at each, worked by hand: F = (0, 0, -2 * 9.82), T = (R cog) x F.
const PAYLOAD_POSES: &str = "h = 1.5707963267948966
P = [p[0.3, 0, 0.4, 0, 0, 0], p[0.3, 0, 0.4, h, 0, 0], p[0.3, 0, 0.4, 0, h, 0], p[0.3, 0, 0.4, 0, 0, h]]
W = [p[0, 0, -19.64, -0.3928, 0.1964, 0], [0, 0, -19.64, 0.982, 0.1964, 0], [0, 0, -19.64, -0.3928, 0.982, 0], p[0, 0, -19.64, -0.1964, -0.3928, 0]]
";

#[test]
fn estimate_payload_returns_the_mass_and_cog_that_explain_the_wrenches() {
    let m = messages(&format!(
        "{PAYLOAD_POSES}pl = estimate_payload(P, W)
textmsg(pl.mass)
textmsg(pl.cog)
set_target_payload(pl.mass, pl.cog)
textmsg(get_target_payload())
textmsg(get_target_payload_cog())
textmsg(estimate_payload(wrenches=W, poses=P) == pl)
"
    ));
    close(&format!("[{}]", m[0]), &[2.0], 1e-9);
    close(&m[1], &[0.01, 0.02, 0.05], 1e-9);
    close(&format!("[{}]", m[2]), &[2.0], 1e-9);
    close(&m[3], &[0.01, 0.02, 0.05], 1e-9);
    assert_eq!(m[4], "True");
}

#[test]
fn estimate_payload_takes_tcp_poses_and_removes_the_tcps_rotation() {
    // The same flange orientations, given as the poses of a TCP turned a quarter about
    // z and shifted 0.1 m: the estimate is the same (in the flange frame).
    let m = messages(&format!(
        "{PAYLOAD_POSES}tcp = p[0, 0.03, 0.1, 0, 0, 1.5707963267948966]
set_tcp(tcp)
T = [pose_trans(P[0], tcp), pose_trans(P[1], tcp), pose_trans(P[2], tcp), pose_trans(P[3], tcp)]
pl = estimate_payload(T, W)
textmsg(pl.mass)
textmsg(pl.cog)
set_tcp(p[0, 0, 0, 0, 0, 0])
textmsg(norm(estimate_payload(T, W).cog - pl.cog) > 0.01)
"
    ));
    close(&format!("[{}]", m[0]), &[2.0], 1e-9);
    close(&m[1], &[0.01, 0.02, 0.05], 1e-9);
    // Taken as flange poses (no TCP), the turned orientations give another CoG.
    assert_eq!(m[2], "True");
}

#[test]
fn estimate_payload_refuses_what_the_manual_refuses() {
    let e = runtime_error(&format!(
        "{PAYLOAD_POSES}estimate_payload([P[0], P[1], P[2]], [W[0], W[1], W[2]])\n"
    ));
    assert!(
        e.contains("`estimate_payload`: needs at least 4 poses, 3 given"),
        "{e}"
    );
    let e = runtime_error(&format!(
        "{PAYLOAD_POSES}estimate_payload(P, [W[0], W[1], W[2], W[3], W[0]])\n"
    ));
    assert!(
        e.contains("needs one wrench per pose: 4 poses, 5 wrenches"),
        "{e}"
    );
    // Two orientations 0.1 rad apart: less than pi/(2*4).
    let e = runtime_error(&format!(
        "{PAYLOAD_POSES}P[3] = p[0.3, 0, 0.4, 0.1, 0, 0]\nestimate_payload(P, W)\n"
    ));
    assert!(e.contains("poses 0 and 3 are 0.1000 rad apart"), "{e}");
    let e = runtime_error(&format!("{PAYLOAD_POSES}estimate_payload(P, 3)\n"));
    assert!(
        e.contains("`estimate_payload` argument `wrenches` needs a list of wrenches"),
        "{e}"
    );
    let e = runtime_error(&format!(
        "{PAYLOAD_POSES}estimate_payload([P[0], P[1], [1, 2], P[3]], W)\n"
    ));
    assert!(
        e.contains("argument `poses` needs 6 numbers in each item, item 2 is"),
        "{e}"
    );
    let e = runtime_error("estimate_payload(make_list(501, p[0, 0, 0, 0, 0, 0]), [])\n");
    assert!(e.contains("501 items in `poses`, at most 500"), "{e}");
}

#[test]
fn time_reads_the_virtual_controllers_clocks() {
    let src = "t = time()
textmsg(t)
sleep(1.5)
textmsg(time(0))
t = time(2)
textmsg(t, t.nanosec)
textmsg(time().sec + 1, struct(sec=7).sec)
";
    let mut h = common::Harness::new(src, urscript_interp::Config::default());
    h.m.world_mut().controller_uptime = std::time::Duration::from_millis(100_250);
    h.m.world_mut().system_time = std::time::Duration::from_secs(1_700_000_000);
    h.run_silent(std::time::Duration::from_secs(5));
    assert_eq!(
        h.m.state(),
        &urscript_interp::State::Finished,
        "{:?}",
        h.messages
    );
    let m = &h.messages;
    // At the start: the controller's uptime.
    assert_eq!(m[0], "struct(sec=100, nanosec=250000000)");
    // 1.5 s of program time later.
    assert_eq!(m[1], "struct(sec=101, nanosec=750000000)");
    assert_eq!(m[2], "struct(sec=1700000001, nanosec=500000000)500000000");
    // The manual's own `time().sec`: `sec` is a keyword (the `sec` program header), a
    // name after `.` and before `=` in an argument list all the same.
    assert_eq!(m[3], "1027");
}

#[test]
fn time_starts_at_zero_and_refuses_modes_the_manual_does_not_give() {
    assert_eq!(
        messages("textmsg(time(), time(2))\n"),
        ["struct(sec=0, nanosec=0)struct(sec=0, nanosec=0)"]
    );
    assert!(runtime_error("time(1)\n").contains("`time`: mode 1 is reserved"));
    assert!(runtime_error("time(3)\n").contains("`time`: no mode 3 (modes: 0, 2)"));
    assert!(runtime_error("time(\"x\")\n").contains("`time` argument `mode` needs an int"));
    // A time an int cannot hold is an error, not a wrapped number.
    let mut h = common::Harness::new("time(2)\n", urscript_interp::Config::default());
    h.m.world_mut().system_time = std::time::Duration::from_secs(1 << 31);
    h.run_silent(std::time::Duration::from_secs(1));
    match h.m.state() {
        urscript_interp::State::Error(e) => {
            assert!(e.to_string().contains("does not fit in an int"), "{e}")
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn the_struct_returning_built_ins_survive_hostile_arguments() {
    // Each either finishes or stops with a runtime error: none panics.
    let cases = [
        "estimate_payload([], [])",
        "estimate_payload([1, 2, 3, 4], [1, 2, 3, 4])",
        "estimate_payload(\"poses\", p[0, 0, 0, 0, 0, 0])",
        "estimate_payload([p[0, 0, 0, 0, 0, 0], p[0, 0, 0, 1.5, 0, 0], p[0, 0, 0, 0, 1.5, 0], p[0, 0, 0, 0, 0, 2]], make_list(4, p[0, 0, -1e300, 1e300, 0, 0]))",
        "estimate_payload([[1, 2, 3, 4, 5, \"6\"]], [])",
        "estimate_payload([p[0, 0, 0, inf, 0, 0], p[0, 0, 0, 0, nan, 0], p[0, 0, 0, 0, 0, 1], p[0, 0, 0, 1, 1, 1]], [p[inf, 0, 0, 0, 0, 0], p[nan, 0, 0, 0, 0, 0], p[0, 0, 0, 0, 0, 0], p[1e308, 1e308, 1e308, 1e308, 1e308, 1e308]])",
        "estimate_payload([p[0, 0, 0, 0, 0, 0], p[0, 0, 0, 1.5, 0, 0], p[0, 0, 0, 0, 1.5, 0], p[0, 0, 0, 0, 0, 2]], [p[1e308, 1e308, 1e308, 1e308, 1e308, 1e308], p[1e308, -1e308, 0, 0, 0, 0], p[0, 0, -1e308, 0, 0, 0], p[0, 0, 1e-308, 0, 0, 0]])",
        "time(-1)",
        "time(2147483647)",
        "time(2.5)",
        "time([0])",
    ];
    for case in cases {
        let src = format!("inf = 1e308 * 10\nnan = inf - inf\nx = {case}\ntextmsg(x)\n");
        let mut h = common::Harness::new(&src, urscript_interp::Config::default());
        h.run_silent(std::time::Duration::from_secs(1));
        assert!(
            matches!(
                h.m.state(),
                urscript_interp::State::Finished | urscript_interp::State::Error(_)
            ),
            "{case}: {:?}",
            h.m.state()
        );
    }
}

fn watchdog_machine(action: &str, enforced: bool) -> urscript_interp::Machine {
    let src = format!(
        "rtde_set_watchdog(\"input_int_register_0\", 10, \"{action}\")\nsleep(1)\ntextmsg(\"after\")\n"
    );
    let mut m = urscript_interp::Machine::new(
        urscript_interp::Program::parse(&src).unwrap(),
        urscript_interp::Config::default(),
    );
    m.world_mut().rtde_watchdogs = enforced;
    m
}

#[test]
fn rtde_watchdogs_fire_without_updates_and_stay_quiet_with_them() {
    use std::time::Duration;
    use urscript_interp::State;
    // 10 Hz: 0.1 s without an update of the field.
    let mut m = watchdog_machine("STOP", true);
    m.run_until(Duration::from_millis(98));
    assert_eq!(m.state(), &State::Running);
    m.run_until(Duration::from_millis(102));
    let State::Error(e) = m.state() else {
        panic!("{:?}", m.state())
    };
    assert!(e.message().contains("input_int_register_0"), "{e}");
    // A client writing the field every 50 ms keeps it quiet.
    let mut m = watchdog_machine("stop", true);
    for k in 1..=25u64 {
        *m.world_mut()
            .rtde_input_updates
            .entry("input_int_register_0".into())
            .or_default() += 1;
        m.run_until(Duration::from_millis(50 * k));
    }
    assert_eq!(m.state(), &State::Finished);
    // "pause" asks the controller to pause the program; the program itself goes on.
    let mut m = watchdog_machine("pause", true);
    m.run_until(Duration::from_millis(150));
    assert!(m.effects().contains(&Effect::Pause));
    // Without an RTDE server modelled (the default) nothing fires.
    let mut m = watchdog_machine("stop", false);
    m.run_until(Duration::from_secs(2));
    assert_eq!(m.state(), &State::Finished);
    // A bad action is refused.
    let mut m = urscript_interp::Machine::new(
        urscript_interp::Program::parse(
            "rtde_set_watchdog(\"input_int_register_0\", 1, \"halt\")\n",
        )
        .unwrap(),
        urscript_interp::Config::default(),
    );
    m.run_until(Duration::from_millis(10));
    assert!(matches!(m.state(), State::Error(e) if e.message().contains("action")));
}

#[test]
fn euromap67_signals_on_the_virtual_interface() {
    use std::time::Duration;
    let src = "set_euromap_output(3, True)\nset_euromap_runstate_dependent_choice(3, 1)\ntextmsg(get_euromap_output(3), get_euromap_output(4))\ntextmsg(get_euromap_input(7))\n";
    let mut m = urscript_interp::Machine::new(
        urscript_interp::Program::parse(src).unwrap(),
        urscript_interp::Config::default(),
    );
    m.world_mut().set("euromap_in[7]=True").unwrap();
    m.run_until(Duration::from_millis(10));
    assert_eq!(m.state(), &urscript_interp::State::Finished);
    let texts: Vec<String> = std::iter::from_fn(|| m.poll_event())
        .filter_map(|e| match e {
            urscript_interp::Event::Message(msg) => Some(msg.text),
            _ => None,
        })
        .collect();
    assert_eq!(texts, ["TrueFalse", "True"]);
    for bad in [
        "x = get_euromap_input(32)\n",
        "set_euromap_runstate_dependent_choice(0, 3)\n",
    ] {
        let mut m = urscript_interp::Machine::new(
            urscript_interp::Program::parse(bad).unwrap(),
            urscript_interp::Config::default(),
        );
        m.run_until(Duration::from_millis(10));
        assert!(
            matches!(m.state(), urscript_interp::State::Error(_)),
            "{bad}"
        );
    }
}

#[test]
fn powerdown_halts_the_program_and_asks_for_power_off() {
    use std::time::Duration;
    let mut m = urscript_interp::Machine::new(
        urscript_interp::Program::parse("x = 1\npowerdown()\nx = 2\n").unwrap(),
        urscript_interp::Config::default(),
    );
    m.run_until(Duration::from_millis(10));
    assert_eq!(m.state(), &urscript_interp::State::Halted);
    assert_eq!(m.global("x"), Some(&urscript_interp::Value::Int(1)));
    assert!(m.effects().contains(&Effect::PowerOff));
}
