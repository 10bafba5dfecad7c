"""Issue 30: a test sees where the arm went: moves, outputs, the final state."""

from __future__ import annotations

import pytest

from ursock import Move, RobotRun
from ursock.pytest_plugin import VirtualRobot

PICK = """
def pick():
  movej([0.5, -1.5, 1, -1, 0.2, 0], a=3, v=3)
  movel(p[0.3, -0.2, 0.4, 0, 3.14, 0], a=1.2, v=0.5, r=0.02)
  movel(p[0.3, -0.3, 0.4, 0, 3.14, 0], a=1.2, v=0.5)
  set_tool_digital_out(0, True)
  set_standard_analog_out(1, 0.25)
end
"""


def _close(a, b, tol: float = 1e-6) -> bool:
    return len(a) == len(b) and all(abs(x - y) < tol for x, y in zip(a, b))


def test_the_moves_say_where_the_arm_went_and_how(virtual_robot: VirtualRobot) -> None:
    run = virtual_robot(PICK)
    moves = run.moves()
    assert [m.function for m in moves] == ["movej", "movel", "movel"]
    assert [m.outcome for m in moves] == ["reached", "blended", "reached"]
    assert all(isinstance(m, Move) and m.arrived for m in moves)
    assert _close(moves[0].target_joints, [0.5, -1.5, 1, -1, 0.2, 0])
    assert _close(moves[0].joints, [0.5, -1.5, 1, -1, 0.2, 0])
    assert moves[1].blend_radius == 0.02
    assert moves[1].start == pytest.approx(moves[0].end)
    assert moves[0].took and moves[0].took > 0.5
    assert _close(moves[2].pose, [0.3, -0.3, 0.4, 0, 3.14, 0])
    assert run.moves("movel") == moves[1:]
    assert _close(run.final_pose(), [0.3, -0.3, 0.4, 0, 3.14, 0])
    assert _close(run.final_joints(), moves[2].joints)
    assert [(o.function, o.pin, o.value) for o in run.outputs] == [
        ("set_tool_digital_out", 0, True),
        ("set_standard_analog_out", 1, 0.25),
    ]
    arm = run.arm
    assert arm is not None and arm.tool_out == [True, False] and arm.analog_out == [0.0, 0.25]


def test_a_stream_is_one_move_with_its_sample_count(virtual_robot: VirtualRobot) -> None:
    run = virtual_robot(
        lines=[
            "q = get_actual_joint_positions()",
            "i = 0",
            "while i < 50:\n  q[0] = q[0] + 0.002\n  servoj(q, t=0.004)\n  i = i + 1\nend",
            "speedj([0.2, 0, 0, 0, 0, 0], 2, 0.1)",
            "stopj(4)",
        ]
    )
    servo, speed = run.moves()
    assert (servo.function, servo.samples, servo.outcome) == ("servoj", 50, "reached")
    assert servo.took == pytest.approx(0.2)
    assert (speed.function, speed.outcome) == ("speedj", "stopped")


def test_a_protective_stop_is_the_moves_end(virtual_robot: VirtualRobot) -> None:
    run = virtual_robot(
        lines=[
            "thread t():\n  movej([2, -1.5, 1, -1, 0.2, 0], a=0.5, v=0.5)\nend",
            "h = run t()",
            "sleep(0.2)",
            "protective_stop()",
        ],
        check=False,
    )
    assert not run.ok
    (move,) = run.moves()
    assert move.outcome == "protective_stop" and not move.arrived
    assert move.joints is not None and 0 < move.joints[0] < 2


def test_a_run_that_never_started_has_no_final_state(virtual_robot: VirtualRobot) -> None:
    run: RobotRun = virtual_robot(lines=["movej([0, 0, 0, 0, 0, 0]"], check=False)
    with pytest.raises(LookupError):
        run.final_joints()
    run = virtual_robot(lines=["movjj([0, 0, 0, 0, 0, 0])"], check=False)
    assert run.moves() == []
    # The arm did not move: it is where it started (UR's home pose).
    assert _close(run.final_joints(), [0, -1.5707963267948966, 0, -1.5707963267948966, 0, 0])
    text = run.describe_failure()
    assert "line None" not in text
    assert "did you mean `movej`?" in text
    assert run.errors[0]["code"] == "compile_error_name_not_found"


def test_a_failure_without_a_line_says_no_line(virtual_robot: VirtualRobot) -> None:
    run = virtual_robot(lines=["halt"], extra_args=["--fail-on", "halt"], check=False)
    assert run.returncode == 1
    text = run.describe_failure()
    assert "line None" not in text
    assert "the program halted" in text


def test_virtual_time_gives_the_same_moves_without_waiting(virtual_robot: VirtualRobot) -> None:
    real = virtual_robot(PICK)
    fast = virtual_robot(PICK, virtual_time=True)
    assert fast.moves() == real.moves()
    assert fast.final_joints() == real.final_joints()
    # An hour of sleep ends at once (the fixture's max_time counts program time here).
    hour = virtual_robot(lines=["sleep(3600)", 'textmsg("later")'], virtual_time=True, max_time=7200, timeout=120)
    assert hour.texts == ["later"]


def test_fail_on_an_error_popup(virtual_robot: VirtualRobot) -> None:
    run = virtual_robot(lines=['popup("no part", "Gripper", error=True)'], fail_on=["error-popup"], check=False)
    assert run.returncode == 1
    assert "error popup" in run.describe_failure()
