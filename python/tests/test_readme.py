"""The README's examples, run as a user would run them."""

from __future__ import annotations

import pytest

from readme_blocks import README, blocks


def test_the_readme_has_the_server_and_both_tests() -> None:
    assert set(blocks()) == {"vision_server.py", "test_vision.py", "test_dashboard.py"}


def test_the_readme_examples_pass(pytester: pytest.Pytester) -> None:
    for name, code in blocks(README).items():
        pytester.makefile(".py", **{name[: -len(".py")]: code})
    result = pytester.runpytest_subprocess("-v", "-p", "no:cacheprovider")
    result.assert_outcomes(passed=2)
    result.stdout.fnmatch_lines(
        [
            "*test_dashboard.py::test_power_on_then_release_brakes PASSED*",
            "*test_vision.py::test_the_robot_gets_the_part_position PASSED*",
        ]
    )
