"""Issue 30: a test reads the arm as a client does (RTDE), waits on it, sends scripts,
and gets controllers on the standard ports of a loopback address of their own."""

from __future__ import annotations

import socket

import pytest

from ursock import SERVERS, RtdeReader, UrController
from ursock.pytest_plugin import ControllerFactory

PROGRAM = """def p():
  movej([0.5, -1.5, 1, -1, 0.2, 0], a=3, v=3)
  set_standard_digital_out(2, True)
  set_standard_analog_out(1, 0.25)
  write_output_integer_register(3, 42)
  write_output_float_register(4, 1.5)
  write_output_boolean_register(5, True)
end
"""


def _ready(ur: UrController) -> None:
    assert ur.dashboard("power on") == "Powering on"
    assert ur.dashboard("brake release") == "Brake releasing"
    ur.wait_for_mode("RUNNING")


def test_the_state_a_client_reads_follows_the_program(ur_controller_factory: ControllerFactory) -> None:
    ur = ur_controller_factory()
    before = ur.state()
    assert before.robot_mode == "POWER_OFF"
    assert before.safety_mode == "NORMAL"
    assert before.program_state == "STOPPED"
    assert before.digital_out[2] is False
    _ready(ur)
    ur.send_script(PROGRAM)
    ur.wait_for_mode("PLAYING")
    s = ur.wait_until(lambda s: s.digital_out[2], timeout=15)
    assert s.joints == pytest.approx([0.5, -1.5, 1, -1, 0.2, 0])
    # RTDE gives the analog output in its domain's unit: 0.25 of 0-10 V is 2.5 V.
    assert s.analog_out[1] == pytest.approx(2.5)
    assert s.int_registers[3] == 42
    assert s.double_registers[4] == 1.5
    assert s.bool_registers[5] is True
    assert len(s.tcp_pose) == 6 and len(s.tcp_speed) == 6
    ur.wait_for_mode("STOPPED")
    (move,) = ur.wait_for_event("move_end") and ur.moves()
    assert (move.function, move.outcome) == ("movej", "reached")
    assert move.joints == pytest.approx([0.5, -1.5, 1, -1, 0.2, 0])


def test_a_protective_stop_is_seen_in_the_safety_mode(ur_controller_factory: ControllerFactory) -> None:
    ur = ur_controller_factory(standard_ports=False)
    _ready(ur)
    ur.send_script("def p():\n  protective_stop()\n  sleep(10)\nend\n")
    s = ur.wait_for_mode("PROTECTIVE_STOP", timeout=10)
    assert s.safety_mode == "PROTECTIVE_STOP"


def test_wait_until_names_the_last_state_when_it_times_out(ur_controller: UrController) -> None:
    with pytest.raises(TimeoutError, match="robot_mode POWER_OFF"):
        ur_controller.wait_until(lambda s: s.robot_mode == "RUNNING", timeout=0.3)
    with pytest.raises(ValueError, match="not a robot mode"):
        ur_controller.wait_for_mode("SPRINTING")


def test_standard_ports_on_a_loopback_address_of_its_own(ur_controller_factory: ControllerFactory) -> None:
    one = ur_controller_factory(model="ur10e")
    two = ur_controller_factory()
    assert one.host != two.host
    for ur in (one, two):
        assert ur.host.startswith("127.") and ur.host != "127.0.0.1"
        assert ur.ports["dashboard"] == SERVERS["dashboard"] == 29999
        assert ur.ports["rtde"] == 30004
        # A client with no port options reaches it at the standard port.
        with socket.create_connection((ur.host, 29999), timeout=5) as c:
            assert b"Universal Robots Dashboard Server" in c.recv(256)
        with RtdeReader(ur.host) as reader:
            assert reader.state().robot_mode == "POWER_OFF"


def test_a_failed_test_shows_the_controllers_log(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(
        """
        def test_uses_a_controller(ur_controller_factory):
            ur = ur_controller_factory(standard_ports=False)
            ur.dashboard("power on")
            assert ur.dashboard("robotmode") == "Robotmode: RUNNING"
        """
    )
    result = pytester.runpytest_subprocess("-p", "no:cacheprovider")
    result.assert_outcomes(failed=1)
    out = result.stdout.str()
    assert "ursock controller 127.0.0.1" in out
    assert '"event":"dashboard"' in out and "power on" in out
    assert "command: " in out


def test_every_register_of_the_rtde_guide_is_read(ur_controller_factory: ControllerFactory) -> None:
    # UR's RTDE guide: int and double registers 0-47 (24-47 the general-purpose range),
    # bool registers 0-127 (64-127 one field each); inputs as well as outputs.
    ur = ur_controller_factory(standard_ports=False)
    _ready(ur)
    ur.send_script(
        "def p():\n"
        "  write_output_integer_register(47, -7)\n"
        "  write_output_integer_register(24, 24)\n"
        "  write_output_float_register(40, 2.25)\n"
        "  write_output_boolean_register(100, True)\n"
        "  write_output_boolean_register(127, True)\n"
        "  write_output_boolean_register(63, True)\n"
        "end\n"
    )
    s = ur.wait_until(lambda s: len(s.int_registers) == 48 and s.int_registers[47] == -7, timeout=15)
    assert s.int_registers[24] == 24
    assert s.double_registers[40] == 2.25 and len(s.double_registers) == 48
    assert len(s.bool_registers) == 128
    assert [i for i, b in enumerate(s.bool_registers) if b] == [63, 100, 127]
    assert len(s.input_int_registers) == 48 and len(s.input_double_registers) == 48
    assert len(s.input_bool_registers) == 128 and not any(s.input_bool_registers)


def test_stops_say_why_the_program_paused_or_stopped(ur_controller_factory: ControllerFactory) -> None:
    ur = ur_controller_factory(standard_ports=False)
    _ready(ur)
    ur.send_script("def one():\n  sleep(30)\nend\n")
    ur.wait_for_mode("PLAYING")
    assert ur.dashboard("pause") == "Pausing program"
    ur.wait_for_mode("PAUSED")
    assert ur.dashboard("stop") == "Stopped"
    ur.wait_for_event("program", count=2)
    ur.send_script("def two():\n  x = [1]\n  y = x[3]\nend\n")
    ur.wait_for_event("program", count=4)
    stops = ur.stops()
    assert [(s.what, s.reason, s.name) for s in stops] == [
        ("paused", "dashboard_pause", ""),
        ("stopped", "dashboard_stop", "one"),
        ("state_stopped", "dashboard_stop", ""),
        ("error", "runtime_error", "two"),
    ], stops
    assert stops[3].line == 3 and "index" in (stops[3].text or "")
