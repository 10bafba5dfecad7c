"""The README's examples, run as a user would run them."""

from __future__ import annotations

import pytest

from readme_blocks import README, blocks


def test_the_readme_has_the_server_and_both_tests() -> None:
    assert set(blocks()) == {
        "vision_server.py",
        "test_vision.py",
        "test_dashboard.py",
        "test_pick.py",
        "test_controller_arm.py",
    }


def test_the_readme_examples_pass(pytester: pytest.Pytester) -> None:
    for name, code in blocks(README).items():
        pytester.makefile(".py", **{name[: -len(".py")]: code})
    result = pytester.runpytest_subprocess("-v", "-p", "no:cacheprovider")
    result.assert_outcomes(passed=4)
    result.stdout.fnmatch_lines_random(
        [
            "*test_controller_arm.py::test_a_program_sent_to_the_controller_moves_the_arm PASSED*",
            "*test_dashboard.py::test_power_on_then_release_brakes PASSED*",
            "*test_pick.py::test_the_arm_goes_down_to_the_part_and_grips PASSED*",
            "*test_vision.py::test_the_robot_gets_the_part_position PASSED*",
        ]
    )
