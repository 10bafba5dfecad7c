"""What a user sees when the program under test is wrong: a readable failure with
ursock's own words, not a traceback into the plugin."""

from __future__ import annotations

import pytest


def test_a_syntax_error_fails_the_test_with_line_column_and_stderr(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(
        test_program="""
        PROGRAM = '''
        def main():
          x = (1 +
        end
        '''

        def test_program(virtual_robot):
            virtual_robot(PROGRAM)
            assert False, "not reached: the fixture fails first"
        """
    )
    result = pytester.runpytest_subprocess("-p", "no:cacheprovider")
    result.assert_outcomes(failed=1)
    result.stdout.fnmatch_lines(
        [
            "*ursock robot exited with status 1*",
            "*stderr:*",
            "*ursock: line 4, column *",
            "*program:*",
            "*  > 4 | end*",
            "*| ^*",
            "*command: *ursock robot --json --script *",
        ]
    )
    result.stdout.no_fnmatch_line("*not reached*")
    # pytrace=False: the failure is ursock's message, not the plugin's source code.
    result.stdout.no_fnmatch_line("*pytest_plugin.py*")


def test_a_runtime_error_names_its_line_and_shows_the_last_calls(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(
        test_program="""
        def test_program(virtual_robot):
            virtual_robot(lines=[
                'textmsg("start")',
                'socket_send_line("x", "never_opened")',
                'values = [1, 2, 3]',
                'textmsg(values[7])',
            ], max_time=5)
        """
    )
    result = pytester.runpytest_subprocess("-p", "no:cacheprovider")
    result.assert_outcomes(failed=1)
    result.stdout.fnmatch_lines(
        [
            "*ursock robot exited with status 1*",
            "*line 4: index out of range*",
            "*program:*",
            "*  > 4 | textmsg(values?7?)*",  # fnmatch: [7] would be a class
            "*error at line 4*",
            "*last calls:*",
            '*line 2: socket_send_line("x", "never_opened") -> failed*',
        ]
    )


def test_check_false_returns_the_failed_run(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(
        test_program="""
        def test_program(virtual_robot):
            run = virtual_robot(lines=["x = ("], check=False)
            assert run.returncode == 1
            assert run.outcome == "error"  # it never started: error and end events
            assert "line 1, column" in run.error_text
            assert run.calls == [] and run.messages == []
        """
    )
    result = pytester.runpytest_subprocess("-p", "no:cacheprovider")
    result.assert_outcomes(passed=1)


def test_a_missing_binary_is_said_plainly(pytester: pytest.Pytester) -> None:
    pytester.makeini(
        """
        [pytest]
        ursock_binary = /nonexistent/ursock
        """
    )
    pytester.makepyfile(
        test_program="""
        def test_program(virtual_robot):
            virtual_robot(lines=['textmsg("x")'])
        """
    )
    result = pytester.runpytest_subprocess("-p", "no:cacheprovider")
    result.assert_outcomes(errors=1)  # the fixture's setup fails, the test never runs
    result.stdout.fnmatch_lines(["*ursock_binary = /nonexistent/ursock: * is not an executable file*"])
    result.stdout.no_fnmatch_line("*Traceback*")
