"""A small RTDE client (protocol version 2) that reads the arm's state as a client of a
UR controller does: joints, TCP pose and speed, digital and analog outputs, output
registers, robot mode, safety mode and program state. Pure Python, one socket, one
reader thread; it works against ``ursock controller`` and a real controller alike.
"""

from __future__ import annotations

import socket
import struct
import threading
import time
from dataclasses import dataclass
from typing import Any, Callable, Dict, List, Optional, Tuple

__all__ = [
    "ROBOT_MODES",
    "RUNTIME_STATES",
    "SAFETY_MODES",
    "RobotState",
    "RtdeError",
    "RtdeReader",
]

#: ``robot_mode`` numbers and their names (UR's RTDE guide).
ROBOT_MODES: Dict[int, str] = {
    -1: "NO_CONTROLLER",
    0: "DISCONNECTED",
    1: "CONFIRM_SAFETY",
    2: "BOOTING",
    3: "POWER_OFF",
    4: "POWER_ON",
    5: "IDLE",
    6: "BACKDRIVE",
    7: "RUNNING",
    8: "UPDATING_FIRMWARE",
}

#: ``safety_mode`` numbers and their names.
SAFETY_MODES: Dict[int, str] = {
    1: "NORMAL",
    2: "REDUCED",
    3: "PROTECTIVE_STOP",
    4: "RECOVERY",
    5: "SAFEGUARD_STOP",
    6: "SYSTEM_EMERGENCY_STOP",
    7: "ROBOT_EMERGENCY_STOP",
    8: "VIOLATION",
    9: "FAULT",
    10: "VALIDATE_JOINT_ID",
    11: "UNDEFINED_SAFETY_MODE",
    12: "AUTOMATIC_MODE_SAFEGUARD_STOP",
    13: "SYSTEM_THREE_POSITION_ENABLING_STOP",
}

#: ``runtime_state`` numbers and their names (the program's state).
RUNTIME_STATES: Dict[int, str] = {
    0: "STOPPING",
    1: "STOPPED",
    2: "PLAYING",
    3: "PAUSING",
    4: "PAUSED",
    5: "RESUMING",
}

#: How many int and double registers of each direction are read: 0-47, as UR's RTDE
#: guide numbers them (0-23 are shared with the fieldbus interfaces, 24-47 are general
#: purpose since PolyScope 3.9/5.3). A server without the upper ones (an older
#: controller) refuses their names and is read without them.
REGISTERS = 48
#: How many bool registers of each direction are read: 0-127 (0-63 packed in two
#: ``UINT32`` fields, 64-127 one ``BOOL`` field each, since PolyScope 3.9/5.3).
BOOL_REGISTERS = 128

_V, _O, _S, _P, _U, _M = 86, 79, 83, 80, 85, 77
_FORMATS = {
    "VECTOR6D": "6d",
    "VECTOR3D": "3d",
    "VECTOR6INT32": "6i",
    "VECTOR6UINT32": "6I",
    "DOUBLE": "d",
    "INT32": "i",
    "UINT32": "I",
    "UINT64": "Q",
    "UINT8": "B",
    "BOOL": "?",
}
#: The largest RTDE package (its size field is 16 bits).
MAX_PACKAGE = 65535

_FIELDS: List[str] = [
    "actual_q",
    "actual_qd",
    "actual_TCP_pose",
    "actual_TCP_speed",
    "actual_digital_output_bits",
    "actual_digital_input_bits",
    "standard_analog_output0",
    "standard_analog_output1",
    "robot_mode",
    "safety_mode",
    "runtime_state",
    *(
        name
        for side in ("output", "input")
        for name in (
            f"{side}_bit_registers0_to_31",
            f"{side}_bit_registers32_to_63",
            *[f"{side}_bit_register_{i}" for i in range(64, BOOL_REGISTERS)],
            *[f"{side}_int_register_{i}" for i in range(REGISTERS)],
            *[f"{side}_double_register_{i}" for i in range(REGISTERS)],
        )
    ),
]


class RtdeError(ConnectionError):
    """The RTDE server refused the client or the connection broke."""


@dataclass(frozen=True)
class RobotState:
    """One RTDE sample of the arm, as a client reads it."""

    #: Joints (rad).
    joints: List[float]
    #: Joint speeds (rad/s).
    joint_speeds: List[float]
    #: TCP pose ``[x, y, z, rx, ry, rz]`` (base frame).
    tcp_pose: List[float]
    #: TCP speed (m/s, rad/s).
    tcp_speed: List[float]
    #: Digital outputs as RTDE numbers them: standard 0-7, configurable 8-15, tool
    #: 16-17.
    digital_out: List[bool]
    #: Digital inputs, numbered the same way.
    digital_in: List[bool]
    #: Standard analog outputs 0-1, in their domain's unit (V, or A for current) as
    #: RTDE gives them.
    analog_out: List[float]
    #: ``"RUNNING"``, ``"POWER_OFF"``... (:data:`ROBOT_MODES`).
    robot_mode: str
    #: ``"NORMAL"``, ``"PROTECTIVE_STOP"``... (:data:`SAFETY_MODES`).
    safety_mode: str
    #: The program's state: ``"PLAYING"``, ``"STOPPED"``, ``"PAUSED"``...
    program_state: str
    #: Output int registers 0-47 (written by the program; ``[i]`` is register ``i``;
    #: 0-23 only from a server without the upper range).
    int_registers: List[int]
    #: Output double registers 0-47, the same way.
    double_registers: List[float]
    #: Output bool registers 0-127 (0-63 only from a server without the upper range;
    #: empty if it has none).
    bool_registers: List[bool]
    #: Input int registers 0-47: what RTDE clients wrote (the program reads them with
    #: ``read_input_integer_register``).
    input_int_registers: List[int]
    #: Input double registers 0-47.
    input_double_registers: List[float]
    #: Input bool registers 0-127.
    input_bool_registers: List[bool]
    #: Every field read, by its RTDE name.
    raw: Dict[str, Any]

    @property
    def program_running(self) -> bool:
        """A program is playing."""
        return self.program_state == "PLAYING"


def _bits(value: Any, n: int) -> List[bool]:
    return [bool((int(value) >> i) & 1) for i in range(n)] if value is not None else []


def _registers(raw: Dict[str, Any], side: str, kind: str, cast: Callable[[Any], Any]) -> List[Any]:
    """``{side}_{kind}_register_N`` from 0 up to the first one the server did not give."""
    out = []
    for i in range(REGISTERS):
        v = raw.get(f"{side}_{kind}_register_{i}")
        if v is None:
            break
        out.append(cast(v))
    return out


def _bool_registers(raw: Dict[str, Any], side: str) -> List[bool]:
    """Bool registers 0-63 from the packed fields, then 64-127 while the server gave them."""
    out = _bits(raw.get(f"{side}_bit_registers0_to_31"), 32)
    if len(out) == 32:
        out += _bits(raw.get(f"{side}_bit_registers32_to_63"), 32)
    if len(out) == 64:
        for i in range(64, BOOL_REGISTERS):
            v = raw.get(f"{side}_bit_register_{i}")
            if v is None:
                break
            out.append(bool(v))
    return out


def _state(raw: Dict[str, Any]) -> RobotState:
    def six(name: str) -> List[float]:
        v = raw.get(name)
        return list(v) if isinstance(v, tuple) else []

    return RobotState(
        joints=six("actual_q"),
        joint_speeds=six("actual_qd"),
        tcp_pose=six("actual_TCP_pose"),
        tcp_speed=six("actual_TCP_speed"),
        digital_out=_bits(raw.get("actual_digital_output_bits"), 18),
        digital_in=_bits(raw.get("actual_digital_input_bits"), 18),
        analog_out=[float(raw.get(f"standard_analog_output{i}", 0.0)) for i in range(2)],
        robot_mode=ROBOT_MODES.get(int(raw.get("robot_mode", -1)), str(raw.get("robot_mode"))),
        safety_mode=SAFETY_MODES.get(int(raw.get("safety_mode", 0)), str(raw.get("safety_mode"))),
        program_state=RUNTIME_STATES.get(int(raw.get("runtime_state", 1)), str(raw.get("runtime_state"))),
        int_registers=_registers(raw, "output", "int", int),
        double_registers=_registers(raw, "output", "double", float),
        bool_registers=_bool_registers(raw, "output"),
        input_int_registers=_registers(raw, "input", "int", int),
        input_double_registers=_registers(raw, "input", "double", float),
        input_bool_registers=_bool_registers(raw, "input"),
        raw=raw,
    )


class RtdeReader:
    """Reads the arm's state over RTDE at ``frequency`` Hz in a background thread;
    :meth:`state` is the newest sample, :meth:`wait_until` waits for one that
    satisfies a condition. Close it (or use it as a context manager) when done.

    :raises RtdeError: when the server refuses protocol version 2 or the recipe.
    """

    def __init__(self, host: str, port: int = 30004, frequency: float = 125.0, timeout: float = 10.0) -> None:
        self.host, self.port = host, port
        self._sock = socket.create_connection((host, port), timeout=timeout)
        self._buf = b""
        self._cond = threading.Condition()
        self._latest: Optional[RobotState] = None
        self._count = 0
        self._error: Optional[str] = None
        self._closed = False
        try:
            self._send(_V, struct.pack(">H", 2))
            if not struct.unpack_from(">B", self._expect(_V))[0]:
                raise RtdeError(f"{host}:{port}: the RTDE server refused protocol version 2")
            self._recipe = self._setup(frequency)
            self._send(_S, b"")
            if not struct.unpack_from(">B", self._expect(_S))[0]:
                raise RtdeError(f"{host}:{port}: the RTDE server refused to start")
        except BaseException:
            self._sock.close()
            raise
        self._sock.settimeout(None)
        self._thread = threading.Thread(target=self._run, daemon=True, name="ursock-rtde")
        self._thread.start()

    def _setup(self, frequency: float) -> Tuple[int, List[Tuple[str, str]]]:
        names = list(_FIELDS)
        for _ in range(2):
            payload = struct.pack(">d", frequency) + ",".join(names).encode()
            self._send(_O, payload)
            reply = self._expect(_O)
            recipe = reply[0]
            types = reply[1:].decode("utf-8", "replace").split(",")
            missing = [n for n, t in zip(names, types) if t not in _FORMATS]
            if not missing and len(types) == len(names):
                return recipe, list(zip(names, types))
            names = [n for n, t in zip(names, types) if t in _FORMATS]
        raise RtdeError(f"{self.host}:{self.port}: the RTDE server refused the output recipe")

    def _send(self, kind: int, payload: bytes) -> None:
        self._sock.sendall(struct.pack(">HB", len(payload) + 3, kind) + payload)

    def _package(self) -> Tuple[int, bytes]:
        while True:
            if len(self._buf) >= 3:
                size, kind = struct.unpack_from(">HB", self._buf)
                if size < 3:
                    raise RtdeError(f"bad RTDE package size {size}")
                if len(self._buf) >= size:
                    payload = self._buf[3:size]
                    self._buf = self._buf[size:]
                    return kind, payload
            chunk = self._sock.recv(MAX_PACKAGE)
            if not chunk:
                raise RtdeError("the RTDE server closed the connection")
            self._buf += chunk

    def _expect(self, kind: int) -> bytes:
        while True:
            k, payload = self._package()
            if k == kind:
                return payload

    def _run(self) -> None:
        recipe, fields = self._recipe
        fmt = ">B" + "".join(_FORMATS[t] for _, t in fields)
        size = struct.calcsize(fmt)
        try:
            while True:
                kind, payload = self._package()
                if kind != _U or len(payload) < size or payload[0] != recipe:
                    continue
                values = struct.unpack_from(fmt, payload)[1:]
                raw: Dict[str, Any] = {}
                i = 0
                for name, t in fields:
                    f = _FORMATS[t]
                    if len(f) > 1:
                        count = int(f[:-1])
                        raw[name] = tuple(values[i : i + count])
                        i += count
                    else:
                        raw[name] = values[i]
                        i += 1
                with self._cond:
                    self._latest = _state(raw)
                    self._count += 1
                    self._cond.notify_all()
        except (OSError, RtdeError, struct.error) as e:
            with self._cond:
                if not self._closed:
                    self._error = str(e) or type(e).__name__
                self._cond.notify_all()

    def state(self, timeout: float = 5.0) -> RobotState:
        """The newest sample (waiting up to ``timeout`` s for the first).

        :raises RtdeError: when the connection broke; :raises TimeoutError: when no
            sample came."""
        return self.wait_until(lambda s: True, timeout=timeout)

    def wait_until(self, condition: Callable[[RobotState], bool], timeout: float = 10.0) -> RobotState:
        """Wait for a sample for which ``condition(state)`` is true and return it.

        :raises TimeoutError: naming the last state seen when none came in time."""
        deadline = time.monotonic() + timeout
        seen = -1
        with self._cond:
            while True:
                if self._latest is not None and self._count != seen:
                    seen = self._count
                    if condition(self._latest):
                        return self._latest
                if self._error is not None:
                    raise RtdeError(self._error)
                left = deadline - time.monotonic()
                if left <= 0:
                    last = self._latest
                    shown = (
                        "no sample"
                        if last is None
                        else f"last: robot_mode {last.robot_mode}, safety_mode {last.safety_mode}, "
                        f"program {last.program_state}, joints {[round(q, 4) for q in last.joints]}"
                    )
                    raise TimeoutError(f"the condition did not hold within {timeout} s ({shown})")
                self._cond.wait(left)

    def close(self) -> None:
        """Pause the stream and close the connection."""
        with self._cond:
            self._closed = True
        try:
            self._send(_P, b"")
        except OSError:
            pass
        try:
            self._sock.shutdown(socket.SHUT_RDWR)
        except OSError:
            pass
        self._sock.close()

    def __enter__(self) -> "RtdeReader":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
