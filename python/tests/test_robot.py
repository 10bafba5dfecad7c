"""virtual_robot and run_robot against real servers on 127.0.0.1."""

from __future__ import annotations

import socket
import socketserver
import threading
import time
from pathlib import Path
from typing import Callable, Iterator, List

import pytest

import ursock
from ursock import CallRecord, Pose, ReadResult, RobotRun
from ursock.pytest_plugin import VirtualRobot


class _Camera(socketserver.StreamRequestHandler):
    def handle(self) -> None:
        for line in self.rfile:
            self.server.requests.append(line.decode().strip())  # type: ignore[attr-defined]
            self.wfile.write(self.server.answer(line))  # type: ignore[attr-defined]


class Camera(socketserver.ThreadingTCPServer):
    daemon_threads = True

    def __init__(self, answer: Callable[[bytes], bytes]) -> None:
        super().__init__(("127.0.0.1", 0), _Camera)
        self.answer = answer
        self.requests: List[str] = []
        threading.Thread(target=self.serve_forever, daemon=True).start()

    @property
    def port(self) -> int:
        return int(self.server_address[1])


@pytest.fixture
def camera_factory() -> Iterator[Callable[[Callable[[bytes], bytes]], Camera]]:
    started: List[Camera] = []

    def make(answer: Callable[[bytes], bytes]) -> Camera:
        server = Camera(answer)
        started.append(server)
        return server

    yield make
    for server in started:
        server.shutdown()
        server.server_close()


PROGRAM = """
def locate():
  socket_open("127.0.0.1", {port}, "camera")
  n = 0
  while n < 3:
    socket_send_line(str_cat("trigger ", n), "camera")
    pos = socket_read_ascii_float(3, "camera", 1)
    if pos[0] != 3:
      popup("the camera did not answer", error=True)
      halt
    end
    textmsg("part ", pos[1] + pos[2] + pos[3])
    n = n + 1
  end
  socket_close("camera")
end
"""


def test_each_answer_of_the_server_is_what_the_robot_read(
    virtual_robot: VirtualRobot, camera_factory: Callable[[Callable[[bytes], bytes]], Camera]
) -> None:
    # The answer depends on the request: the robot must get each one, in order.
    def answer(request: bytes) -> bytes:
        n = int(request.split()[1])
        return f"({n},{n * 10},{n * 100})".encode()

    camera = camera_factory(answer)
    run = virtual_robot(PROGRAM.format(port=camera.port))
    assert run.ok and run.outcome == "finished"
    assert camera.requests == ["trigger 0", "trigger 1", "trigger 2"]
    reads = run.calls_to("socket_read_ascii_float")
    assert [r.result for r in reads] == [ReadResult(3, [n, n * 10, n * 100]) for n in range(3)]
    assert all(r.socket == "camera" and r.outcome == "returned" and not r.sentinel for r in reads)
    assert reads[1].args == [3, "camera", 1]
    assert run.texts == ["part 0", "part 111", "part 222"]
    sends = run.calls_to("socket_send_line")
    assert [s.args[0] for s in sends] == ["trigger 0", "trigger 1", "trigger 2"]
    assert run.call("socket_open").result is True


def test_a_reply_the_robot_cannot_read_gives_the_sentinel_and_why(
    virtual_robot: VirtualRobot, camera_factory: Callable[[Callable[[bytes], bytes]], Camera]
) -> None:
    camera = camera_factory(lambda _: b"1,2,3\n")
    run = virtual_robot(PROGRAM.format(port=camera.port))
    assert run.outcome == "halted"
    read = run.call("socket_read_ascii_float")
    assert read.sentinel and not read.ok
    assert read.outcome == "timed_out"
    assert read.result == ReadResult(0, [None, None, None])
    assert read.why is not None and "parentheses" in read.why
    assert run.messages[-1].kind == "popup"
    assert run.texts == ["the camera did not answer"]


def test_lines_stubs_and_values(virtual_robot: VirtualRobot) -> None:
    run = virtual_robot(
        lines=[
            "rq_activate()",
            "ok = rq_is_object_detected()",
            'textmsg("detected: ", ok)',
            "textmsg(get_actual_tcp_pose())",
        ],
        stub=["rq_activate", "rq_is_object_detected=True"],
        max_time=5,
    )
    assert [c.call for c in run.calls] == ["rq_activate", "rq_is_object_detected"]
    assert all(c.outcome == "stubbed" for c in run.calls)
    assert run.call("rq_is_object_detected").result is True
    assert run.call("rq_is_object_detected").assigned_to == "ok"
    assert run.call("rq_activate").assigned_to is None
    assert run.texts[0] == "detected: True"
    assert run.texts[1].startswith("p[")


def test_a_urcap_preamble_and_the_inputs_the_program_reads(
    virtual_robot: VirtualRobot, tmp_path: Path
) -> None:
    urcap = tmp_path / "gripper_urcap.script"
    urcap.write_text("def gripper_width():\n  return 42\nend\n", encoding="utf-8")
    run = virtual_robot(
        lines=[
            "if get_standard_digital_in(3):",
            '  textmsg("part, width ", gripper_width())',
            "end",
            "textmsg(get_tcp_force()[2], read_input_integer_register(5))",
        ],
        preamble=[urcap],
        world={"digital_in[3]": True, "tcp_force": [0, 0, -9.5, 0, 0, 0], "input_int_regs[5]": 7},
        max_time=5,
    )
    assert run.texts == ["part, width 42", "-9.57"]
    # Without the preamble the program is refused before it starts.
    refused = virtual_robot(lines=["gripper_width()"], max_time=5, check=False)
    assert not refused.ok
    assert refused.outcome == "error"


def test_a_program_from_a_file_and_a_pose_argument(
    virtual_robot: VirtualRobot,
    tmp_path: Path,
    camera_factory: Callable[[Callable[[bytes], bytes]], Camera],
) -> None:
    camera = camera_factory(lambda _: b"")
    program = tmp_path / "send_pose.script"
    program.write_text(
        f'socket_open("127.0.0.1", {camera.port})\n'
        "socket_send_line(p[0.1, -0.25, 0.3, 0, 2.5, 0])\n"
        "socket_close()\n"
    )
    for source in (program, str(program)):  # a Path, and a str naming the file
        run = virtual_robot(source, max_time=5)
        sent = run.call("socket_send_line")
        assert sent.args == [Pose(0.1, -0.25, 0.3, 0, 2.5, 0)]
        assert sent.socket == "socket_0"
    # The program ends without waiting for the server: give its thread time to read.
    deadline = time.monotonic() + 5
    while len(camera.requests) < 2 and time.monotonic() < deadline:
        time.sleep(0.01)
    assert camera.requests == ["p[0.1, -0.25, 0.3, 0, 2.5, 0]"] * 2


def test_max_time_ends_a_program_that_loops_forever(virtual_robot: VirtualRobot) -> None:
    run = virtual_robot("while True:\n  sleep(0.1)\nend\n", max_time=0.5)
    assert run.ok and run.outcome == "max_time"
    assert any("--max-time" in n for n in run.notes)


def test_a_closed_port_makes_socket_open_return_false(virtual_robot: VirtualRobot) -> None:
    with socket.socket() as s:  # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    run = virtual_robot(lines=[f'ok = socket_open("127.0.0.1", {port})', "textmsg(ok)"], max_time=10)
    opened: CallRecord = run.call("socket_open")
    assert opened.result is False and opened.outcome == "failed" and opened.why
    assert run.texts == ["False"]


def test_run_robot_without_pytest() -> None:
    run: RobotRun = ursock.run_robot(lines=['textmsg("hello")'], max_time=5)
    assert run.texts == ["hello"] and run.returncode == 0 and run.events[-1]["event"] == "end"
    bad = ursock.run_robot("x = (1\n", max_time=5)
    # A program that does not parse never starts: its error and end events say so.
    assert not bad.ok and bad.outcome == "error"
    with pytest.raises(ursock.RobotRunError) as info:
        bad.check()
    assert "line 2" in str(info.value) or "line 1" in str(info.value)
    with pytest.raises(TypeError):
        ursock.run_robot()
