"""Running a URScript program on ``ursock``'s virtual robot, with typed results.

:func:`run_robot` runs ``ursock robot --json`` and parses the JSON lines it prints
(one event per line, see ``docs/json-events.md`` of the repository) into
:class:`CallRecord` and :class:`Message` values, kept in a :class:`RobotRun`.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Dict, Iterable, List, Mapping, Optional, Sequence, Tuple, Union

from ._binary import binary

__all__ = [
    "ArmState",
    "CallRecord",
    "Message",
    "Move",
    "OutputChange",
    "Pose",
    "ReadResult",
    "RobotRun",
    "RobotRunError",
    "ScriptSource",
    "decode_value",
    "moves_of",
    "parse_events",
    "robot_command",
    "run_robot",
]

#: A program: its text (``str``), or a file (``pathlib.Path`` or any ``os.PathLike``).
#: A ``str`` without a newline that names an existing file is read as that file.
ScriptSource = Union[str, "os.PathLike[str]"]


@dataclass(frozen=True)
class Pose:
    """A URScript pose ``p[x, y, z, rx, ry, rz]`` (metres, radians; a non-finite
    number is ``None``)."""

    x: Optional[float]
    y: Optional[float]
    z: Optional[float]
    rx: Optional[float]
    ry: Optional[float]
    rz: Optional[float]

    def as_list(self) -> List[Optional[float]]:
        """The six numbers, in order."""
        return [self.x, self.y, self.z, self.rx, self.ry, self.rz]


@dataclass(frozen=True)
class ReadResult:
    """What a robot read function returned as a list ``[count, v1, v2, ...]``:
    ``socket_read_ascii_float``, ``socket_read_binary_integer``,
    ``socket_read_byte_list``. ``values`` are the values after the count (a sentinel's
    ``nan`` is ``None``)."""

    count: int
    values: List[Any]

    def as_list(self) -> List[Any]:
        """The list as URScript sees it: ``[count, v1, v2, ...]``."""
        return [self.count, *self.values]


def decode_value(value: Any) -> Any:
    """A URScript value of the JSON events as a Python value.

    Numbers, booleans and ``null`` (no value, or a non-finite float) stay as they are;
    a string (``{"encoding": "utf-8", "text": ...}``) becomes ``str``, one that is not
    UTF-8 (``{"encoding": "hex", ...}``) ``bytes``; ``{"pose": [...]}`` a :class:`Pose`;
    ``{"count": n, "values": [...]}`` a :class:`ReadResult`; lists are decoded
    element by element.
    """
    if isinstance(value, list):
        return [decode_value(v) for v in value]
    if isinstance(value, dict):
        encoding = value.get("encoding")
        if encoding == "utf-8" and "text" in value:
            return value["text"]
        if encoding == "hex" and "hex" in value:
            return bytes.fromhex(value["hex"])
        if "pose" in value and isinstance(value["pose"], list) and len(value["pose"]) == 6:
            return Pose(*value["pose"])
        if "count" in value and "values" in value:
            return ReadResult(int(value["count"]), [decode_value(v) for v in value["values"]])
    return value


@dataclass(frozen=True)
class CallRecord:
    """One function call of the program (every socket function, and stubbed
    functions), from a ``call`` event."""

    #: Seconds since the start.
    t: float
    #: The program line (0: the socket_open of ``--connect``).
    line: int
    #: The column of the call's name.
    column: int
    #: The function, like ``"socket_read_ascii_float"``.
    call: str
    #: The call as URScript with its evaluated arguments, ``x = `` in front when the
    #: statement assigns it.
    source: str
    #: The socket it used, for socket functions.
    socket: Optional[str]
    #: The arguments, positional then named (decoded by :func:`decode_value`).
    args: List[Any]
    #: What it returned (decoded by :func:`decode_value`: a read gives a
    #: :class:`ReadResult`, a string read a ``str``).
    result: Any
    #: ``"returned"``, ``"timed_out"``, ``"stubbed"`` or ``"failed"``.
    outcome: str
    #: The result is a read's failure sentinel, or fewer floats than asked.
    sentinel: bool
    #: Why it failed or returned its sentinel, when known.
    why: Optional[str]
    #: The event as printed.
    raw: Mapping[str, Any] = field(repr=False, compare=False)

    @classmethod
    def from_event(cls, event: Mapping[str, Any]) -> "CallRecord":
        """The record of one ``call`` event."""
        return cls(
            t=float(event.get("t", 0.0)),
            line=int(event.get("line", 0)),
            column=int(event.get("column", 0)),
            call=str(event.get("call", "")),
            source=str(event.get("source", "")),
            socket=event.get("socket"),
            args=[decode_value(a) for a in event.get("args", [])],
            result=decode_value(event.get("result")),
            outcome=str(event.get("outcome", "")),
            sentinel=bool(event.get("sentinel", False)),
            why=event.get("why"),
            raw=dict(event),
        )

    @property
    def assigned_to(self) -> Optional[str]:
        """The variable the statement assigned the result to (``pose`` for
        ``pose = socket_read_ascii_float(3)``), if any."""
        head, sep, rest = self.source.partition(" = ")
        if sep and rest.startswith(self.call + "("):
            return head
        return None

    @property
    def ok(self) -> bool:
        """The call returned normally (no timeout, no failure, no sentinel)."""
        return self.outcome in ("returned", "stubbed") and not self.sentinel

    @property
    def values(self) -> List[Any]:
        """A read's values (after the count); ``[]`` when the result is not a read's."""
        return list(self.result.values) if isinstance(self.result, ReadResult) else []


@dataclass(frozen=True)
class Message:
    """Text the program showed (``textmsg``, ``popup``, ``varmsg``), from a
    ``message`` event."""

    #: Seconds since the start.
    t: float
    #: The program line.
    line: int
    #: ``"textmsg"``, ``"popup"`` or ``"varmsg"``.
    kind: str
    #: The text shown.
    text: str
    #: The call that showed it, with its evaluated arguments.
    source: str
    #: The event as printed.
    raw: Mapping[str, Any] = field(repr=False, compare=False)

    @classmethod
    def from_event(cls, event: Mapping[str, Any]) -> "Message":
        """The message of one ``message`` event."""
        return cls(
            t=float(event.get("t", 0.0)),
            line=int(event.get("line", 0)),
            kind=str(event.get("kind", "")),
            text=str(event.get("text", "")),
            source=str(event.get("source", "")),
            raw=dict(event),
        )


def _six(value: Any) -> Optional[List[float]]:
    return [float(x) if x is not None else float("nan") for x in value] if isinstance(value, list) else None


@dataclass(frozen=True)
class Move:
    """One move of the arm (``movej``, ``movel``, ``movep``, ``movec``...) or one stream
    of ``servoj``/``speedj``/``speedl`` commands, from its ``move_start`` and
    ``move_end`` events."""

    #: The function (``"movej"``, ``"servoj"``...).
    function: str
    #: The line of the command.
    line: int
    #: Program time it set off (s).
    start: float
    #: Program time it ended (s); ``None`` if the program ended first without saying.
    end: Optional[float]
    #: How long it took (s); ``None`` like :attr:`end`.
    took: Optional[float]
    #: ``"reached"``, ``"blended"``, ``"stopped"``, ``"protective_stop"``,
    #: ``"replaced"``, ``"halted"``; ``None`` like :attr:`end`.
    outcome: Optional[str]
    #: The target joints (rad); ``None`` for a speed stream.
    target_joints: Optional[List[float]]
    #: The target tool pose ``[x, y, z, rx, ry, rz]``; ``None`` for a speed stream.
    target_pose: Optional[List[float]]
    #: The joints where it ended (rad).
    joints: Optional[List[float]]
    #: The tool pose where it ended.
    pose: Optional[List[float]]
    #: Commands it was: a stream's sample count, 1 for a move.
    samples: int
    #: The ``a``, ``v``, ``t`` and ``r`` arguments (0 when not given).
    acceleration: float
    velocity: float
    time: float
    blend_radius: float

    @property
    def arrived(self) -> bool:
        """It reached its target (or blended into the next move)."""
        return self.outcome in ("reached", "blended")


@dataclass(frozen=True)
class OutputChange:
    """An output the program changed, from an ``output`` event."""

    #: The program line.
    line: int
    #: The function (``"set_standard_digital_out"``...).
    function: str
    #: The output as the function numbers it.
    pin: int
    #: ``True``/``False`` (digital) or a number (analog).
    value: Any


@dataclass(frozen=True)
class ArmState:
    """The arm when the program ended (the ``end`` event's ``arm``)."""

    #: Joints (rad).
    joints: List[float]
    #: Tool pose ``[x, y, z, rx, ry, rz]`` (base frame).
    pose: List[float]
    #: Digital outputs: standard 0-7, then configurable 0-7.
    digital_out: List[bool]
    #: Tool digital outputs 0-1.
    tool_out: List[bool]
    #: Standard analog outputs 0-1.
    analog_out: List[float]


def moves_of(events: Iterable[Mapping[str, Any]]) -> List[Move]:
    """The moves of ``move_start``/``move_end`` events, in order (a start and the end
    that follows it)."""
    moves: List[Move] = []
    start: Optional[Mapping[str, Any]] = None

    def close(end: Optional[Mapping[str, Any]]) -> None:
        assert start is not None
        e = end or {}
        moves.append(
            Move(
                function=str(start.get("function", "")),
                line=int(start.get("line") or 0),
                start=float(start.get("at") or 0.0),
                end=float(e["at"]) if "at" in e else None,
                took=float(e["took"]) if "took" in e else None,
                outcome=e.get("outcome"),
                target_joints=_six(start.get("target_joints")),
                target_pose=_six(start.get("target_pose")),
                joints=_six(e.get("joints")),
                pose=_six(e.get("pose")),
                samples=int(e.get("samples") or 1),
                acceleration=float(start.get("acceleration") or 0.0),
                velocity=float(start.get("velocity") or 0.0),
                time=float(start.get("time") or 0.0),
                blend_radius=float(start.get("blend_radius") or 0.0),
            )
        )

    for event in events:
        kind = event.get("event")
        if kind == "move_start":
            if start is not None:
                close(None)
            start = event
        elif kind == "move_end" and start is not None:
            close(event)
            start = None
    if start is not None:
        close(None)
    return moves


class RobotRunError(AssertionError):
    """``ursock robot`` exited with an error (a syntax error, a runtime error, a bad
    option). ``run`` holds everything it printed."""

    def __init__(self, run: "RobotRun") -> None:
        super().__init__(run.describe_failure())
        self.run = run


@dataclass
class RobotRun:
    """One run of ``ursock robot --json``: what the program did."""

    #: The command that was run.
    command: List[str]
    #: Its exit status (0: the program ended, halted or reached ``max_time``).
    returncode: int
    #: Every JSON event, in order, as parsed dicts.
    events: List[Dict[str, Any]]
    #: The socket (and stubbed) calls, in order.
    calls: List[CallRecord]
    #: The texts shown (textmsg, popup, varmsg), in order.
    messages: List[Message]
    #: Everything written on stderr (errors and notes).
    stderr: str
    #: Lines of stdout that were not JSON (none, normally).
    other_output: List[str] = field(default_factory=list)
    #: The program's text, as ursock numbered its lines (``None`` if unreadable).
    program: Optional[str] = field(default=None, repr=False)

    @property
    def ok(self) -> bool:
        """``ursock`` exited with 0."""
        return self.returncode == 0

    @property
    def outcome(self) -> Optional[str]:
        """How the program ended (the ``end`` event): ``"finished"``, ``"halted"``,
        ``"max_time"``, ``"error"``; ``None`` when no ``end`` event was printed (a
        syntax error or a bad option stops ``ursock`` before the program starts)."""
        for e in reversed(self.events):
            if e.get("event") == "end":
                return str(e.get("outcome"))
        return None

    @property
    def errors(self) -> List[Dict[str, Any]]:
        """The ``error`` events (a runtime error: its ``line``, ``column``, ``text``)."""
        return [e for e in self.events if e.get("event") == "error"]

    @property
    def notes(self) -> List[str]:
        """The texts of the ``note`` events."""
        return [str(e.get("text", "")) for e in self.events if e.get("event") == "note"]

    @property
    def texts(self) -> List[str]:
        """The texts the program showed, in order."""
        return [m.text for m in self.messages]

    @property
    def error_text(self) -> str:
        """What went wrong, as ursock said it on stderr (``""`` if nothing)."""
        return self.stderr.strip()

    def moves(self, function: Optional[str] = None) -> List[Move]:
        """The arm's moves (and servo/speed streams), in order; only those of
        ``function`` (``"movel"``) if given."""
        found = moves_of(self.events)
        return [m for m in found if function is None or m.function == function]

    @property
    def outputs(self) -> List[OutputChange]:
        """The outputs the program changed, in order."""
        return [
            OutputChange(
                line=int(e.get("line") or 0),
                function=str(e.get("function", "")),
                pin=int(e.get("pin") or 0),
                value=e.get("value"),
            )
            for e in self.events
            if e.get("event") == "output"
        ]

    @property
    def arm(self) -> Optional[ArmState]:
        """The arm when the program ended (``None`` if it never started)."""
        for e in reversed(self.events):
            if e.get("event") == "end" and isinstance(e.get("arm"), dict):
                a = e["arm"]
                return ArmState(
                    joints=_six(a.get("joints")) or [],
                    pose=_six(a.get("pose")) or [],
                    digital_out=[bool(x) for x in a.get("digital_out", [])],
                    tool_out=[bool(x) for x in a.get("tool_out", [])],
                    analog_out=[float(x) if x is not None else float("nan") for x in a.get("analog_out", [])],
                )
        return None

    def final_joints(self) -> List[float]:
        """The joints (rad) when the program ended.

        :raises LookupError: when the program never ran (a syntax error)."""
        arm = self.arm
        if arm is None:
            raise LookupError("the program never ran: no final state (" + (self.error_text or "no end event") + ")")
        return arm.joints

    def final_pose(self) -> List[float]:
        """The tool pose ``[x, y, z, rx, ry, rz]`` when the program ended.

        :raises LookupError: when the program never ran."""
        arm = self.arm
        if arm is None:
            raise LookupError("the program never ran: no final state (" + (self.error_text or "no end event") + ")")
        return arm.pose

    def calls_to(self, name: str) -> List[CallRecord]:
        """The calls of the function ``name``, in order."""
        return [c for c in self.calls if c.call == name]

    def call(self, name: str, index: int = 0) -> CallRecord:
        """The ``index``-th call of ``name`` (the first by default).

        :raises LookupError: when there are not that many, naming the calls made.
        """
        found = self.calls_to(name)
        if index >= len(found) or index < -len(found):
            made = ", ".join(c.source for c in self.calls) or "none"
            raise LookupError(f"no call #{index} of {name} (calls made: {made})")
        return found[index]

    def check(self) -> "RobotRun":
        """This run, or :class:`RobotRunError` if ursock exited with an error."""
        if not self.ok:
            raise RobotRunError(self)
        return self

    def error_position(self) -> Optional[Tuple[int, Optional[int]]]:
        """``(line, column)`` of the error ursock reported (column ``None`` for a
        runtime error), from its ``error`` event or its stderr."""
        for e in self.errors:
            if isinstance(e.get("line"), int):
                column = e.get("column")
                return (e["line"], column if isinstance(column, int) and column > 0 else None)
        m = _POSITION.search(self.stderr)
        if m:
            return (int(m.group(1)), int(m.group(2)) if m.group(2) else None)
        return None

    def excerpt(self, context: int = 2) -> str:
        """The program's lines around the error, numbered, with a caret under the
        column (``""`` when there is no error or no program text)."""
        position = self.error_position()
        if position is None or self.program is None:
            return ""
        line, column = position
        lines = self.program.splitlines()
        if not 1 <= line <= len(lines) + 1:
            return ""
        out = []
        width = len(str(min(len(lines), line + context)))
        for n in range(max(1, line - context), min(len(lines), line + context) + 1):
            mark = ">" if n == line else " "
            out.append(f"  {mark} {n:>{width}} | {lines[n - 1]}")
            if n == line and column:
                out.append("    " + " " * width + " | " + " " * (column - 1) + "^")
        if line == len(lines) + 1:
            out.append(f"  > {line:>{width}} | (end of program)")
        return "\n".join(out)

    def describe_failure(self) -> str:
        """A readable account of a failed run: the exit status, stderr, the error
        events and the last calls."""
        parts = [f"ursock robot exited with status {self.returncode}"]
        if self.error_text:
            parts.append("stderr:\n" + _indent(self.error_text))
        excerpt = self.excerpt()
        if excerpt:
            parts.append("program:\n" + excerpt)
        for e in self.errors:
            line = e.get("line")
            if isinstance(line, int) and line > 0:
                where = f" at line {line}" + (f", column {e.get('column')}" if e.get("column") else "")
            else:
                where = ""
            parts.append(f"error{where}: {e.get('text')}")
        if self.calls:
            parts.append("last calls:\n" + _indent("\n".join(_shown(c) for c in self.calls[-5:])))
        parts.append("command: " + " ".join(_quote(a) for a in self.command))
        return "\n".join(parts)


_POSITION = re.compile(r"\bline (\d+)(?:, column (\d+))?")


def _indent(text: str) -> str:
    return "\n".join("    " + line for line in text.splitlines())


def _quote(arg: str) -> str:
    return arg if arg and all(c.isalnum() or c in "-_./:=@," for c in arg) else repr(arg)


def _shown(c: CallRecord) -> str:
    return f"line {c.line}: {c.source} -> {c.outcome}" + (f" ({c.why})" if c.why else "")


def parse_events(lines: Iterable[str]) -> Tuple[List[Dict[str, Any]], List[str]]:
    """The JSON events among ``lines``, and the lines that are not events."""
    events: List[Dict[str, Any]] = []
    other: List[str] = []
    for line in lines:
        text = line.strip()
        if not text:
            continue
        try:
            event = json.loads(text)
        except ValueError:
            other.append(line)
            continue
        if isinstance(event, dict) and "event" in event:
            events.append(event)
        else:
            other.append(line)
    return events, other


def _is_path(script: ScriptSource) -> bool:
    if isinstance(script, os.PathLike):
        return True
    return "\n" not in script and len(script) < 4096 and Path(script).is_file()


def urscript_constant(value: Any) -> str:
    """``value`` written as a URScript constant: ``True``/``False``, numbers, strings
    in double quotes, lists as ``[a, b]``; a ``str`` that is already URScript (it
    starts with ``[``, ``p[`` or ``"``) is passed as it is."""
    if isinstance(value, bool):
        return "True" if value else "False"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(urscript_constant(v) for v in value) + "]"
    text = str(value)
    if text.startswith(("[", "p[", '"')):
        return text
    if '"' in text:
        raise ValueError(f"a URScript string cannot hold a double quote: {text!r}")
    return f'"{text}"'


def robot_command(
    *,
    script_file: Optional[Union[str, "os.PathLike[str]"]] = None,
    lines: Sequence[str] = (),
    connect: Optional[str] = None,
    stub: Sequence[str] = (),
    preamble: Sequence[Union[str, "os.PathLike[str]"]] = (),
    world: Optional[Mapping[str, Any]] = None,
    max_time: Optional[float] = None,
    step_time: Optional[float] = None,
    model: Optional[str] = None,
    trace: bool = False,
    extra_args: Sequence[str] = (),
    ursock: Optional[Union[str, "os.PathLike[str]"]] = None,
    virtual_time: bool = False,
    fail_on: Sequence[str] = (),
) -> List[str]:
    """The ``ursock robot ... --json`` command line for these options."""
    cmd = [str(ursock or binary()), "robot", "--json"]
    if script_file is not None:
        cmd += ["--script", os.fspath(script_file)]
    for line in lines:
        cmd += ["-e", line]
    if connect is not None:
        cmd += ["--connect", connect]
    for s in stub:
        cmd += ["--stub", s]
    for path in preamble:
        cmd += ["--preamble", os.fspath(path)]
    for name, value in (world or {}).items():
        cmd += ["--set", f"{name}={urscript_constant(value)}"]
    if max_time is not None:
        cmd += ["--max-time", repr(float(max_time))]
    if step_time is not None:
        cmd += ["--step-time", repr(float(step_time))]
    if model is not None:
        cmd += ["--model", model]
    if trace:
        cmd.append("--trace")
    if virtual_time:
        cmd.append("--virtual-time")
    if fail_on:
        cmd += ["--fail-on", ",".join(fail_on)]
    cmd += list(extra_args)
    return cmd


def run_robot(
    script: Optional[ScriptSource] = None,
    lines: Optional[Sequence[str]] = None,
    *,
    connect: Optional[str] = None,
    stub: Sequence[str] = (),
    preamble: Sequence[Union[str, "os.PathLike[str]"]] = (),
    world: Optional[Mapping[str, Any]] = None,
    max_time: Optional[float] = None,
    step_time: Optional[float] = None,
    model: Optional[str] = None,
    trace: bool = False,
    extra_args: Sequence[str] = (),
    timeout: Optional[float] = None,
    check: bool = False,
    cwd: Optional[Union[str, "os.PathLike[str]"]] = None,
    env: Optional[Mapping[str, str]] = None,
    ursock: Optional[Union[str, "os.PathLike[str]"]] = None,
    virtual_time: bool = False,
    fail_on: Sequence[str] = (),
) -> RobotRun:
    """Run a URScript program on ``ursock``'s virtual robot, in real time, against
    real servers, and return what it did.

    Give exactly one of ``script`` (the program's text, or a file: a ``Path``, or a
    ``str`` without newlines naming an existing file) and ``lines`` (statements, each
    passed as ``-e``).

    :param connect: ``HOST:PORT``: open ``socket_0`` there before the program runs.
    :param stub: ``NAME`` or ``NAME=VALUE``: functions the virtual robot lacks (a
        URCap's), made a no-op or a constant (``--stub``).
    :param preamble: files of a URCap's installation preamble, run at the top of the
        program as PolyScope writes them (``--preamble``).
    :param world: what the robot senses at the start, by ``ursock robot --set`` name:
        ``{"digital_in[3]": True, "tcp_force": [0, 0, -9.8, 0, 0, 0]}``.
    :param max_time: end a program that loops forever after this many seconds (a
        success if nothing failed before; :attr:`RobotRun.outcome` is ``"max_time"``).
    :param step_time: the controller's step (0.002 e-Series, 0.008 CB3).
    :param model: the arm (``ur5e``, ``ur10e``, ...).
    :param trace: also record the bytes both ways (``tx``/``rx`` events).
    :param virtual_time: run in virtual time while the program has no connection open
        (``--virtual-time``): a ``sleep`` or a move ends at once, with the same results
        (program times); ``max_time`` then counts program time.
    :param fail_on: what else makes the run fail (``--fail-on``): ``"halt"``,
        ``"error-popup"``, ``"popup"``.
    :param extra_args: more ``ursock robot`` options, passed as they are.
    :param timeout: kill ursock after this many seconds (default: ``max_time`` + 30,
        or 300 without ``max_time``); raises ``subprocess.TimeoutExpired``.
    :param check: raise :class:`RobotRunError` when ursock exits with an error.
    :param ursock: the executable (default: :func:`ursock.binary`).
    """
    if (script is None) == (lines is None):
        raise TypeError("run_robot: give exactly one of script= and lines=")
    if timeout is None:
        timeout = (max_time + 30.0) if max_time is not None else 300.0
    tmpdir: Optional[tempfile.TemporaryDirectory[str]] = None
    try:
        script_file: Optional[Union[str, "os.PathLike[str]"]] = None
        program: Optional[str] = "\n".join(lines) if lines is not None else None
        if script is not None:
            if _is_path(script):
                script_file = script
                try:
                    program = Path(script).read_text(encoding="utf-8")
                except (OSError, UnicodeDecodeError):
                    program = None
            else:
                program = str(script)
                tmpdir = tempfile.TemporaryDirectory(prefix="ursock-")
                script_file = Path(tmpdir.name) / "program.script"
                Path(script_file).write_text(str(script), encoding="utf-8")
        cmd = robot_command(
            script_file=script_file,
            lines=list(lines or ()),
            connect=connect,
            stub=stub,
            preamble=preamble,
            world=world,
            max_time=max_time,
            step_time=step_time,
            model=model,
            trace=trace,
            extra_args=extra_args,
            ursock=ursock,
            virtual_time=virtual_time,
            fail_on=fail_on,
        )
        done = subprocess.run(
            cmd,
            stdin=subprocess.DEVNULL,
            capture_output=True,
            text=True,
            encoding="utf-8",
            errors="replace",
            timeout=timeout,
            cwd=None if cwd is None else os.fspath(cwd),
            env=None if env is None else dict(env),
            check=False,
        )
    finally:
        if tmpdir is not None:
            tmpdir.cleanup()
    events, other = parse_events(done.stdout.splitlines())
    run = RobotRun(
        command=cmd,
        returncode=done.returncode,
        events=events,
        calls=[CallRecord.from_event(e) for e in events if e.get("event") == "call"],
        messages=[Message.from_event(e) for e in events if e.get("event") == "message"],
        stderr=done.stderr,
        other_output=other,
        program=program,
    )
    return run.check() if check else run
