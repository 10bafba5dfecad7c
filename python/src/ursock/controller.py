"""``ursock controller``, the virtual UR controller, as a Python object.

:class:`UrController` starts ``ursock controller --json`` on free ports, reads the
addresses it bound from its ``listening`` events, keeps the newest events it prints
(``max_events``, 10 000 by default; older ones are counted, not kept), and
talks to its dashboard server (:meth:`UrController.dashboard`).
"""

from __future__ import annotations

import collections
import json
import os
import queue
import re
import socket
import subprocess
import threading
import random
import time
from dataclasses import dataclass
from typing import IO, Any, Callable, Dict, List, Mapping, Optional, Sequence, Tuple, Union

from ._binary import binary, help_text
from .robot import Move, moves_of, urscript_constant
from .rtde import ROBOT_MODES, RUNTIME_STATES, SAFETY_MODES, RobotState, RtdeReader

__all__ = [
    "ControllerError",
    "DashboardClient",
    "ProgramStop",
    "UrController",
    "SERVERS",
    "free_loopback_address",
]

@dataclass(frozen=True)
class ProgramStop:
    """A program that paused, stopped or ended, and why: from the controller's
    ``program`` events (``finished``, ``halted``, ``stopped``, ``error``) and its
    ``state`` events that say the program became ``PAUSED`` or ``STOPPED``."""

    #: ``"finished"``, ``"halted"``, ``"stopped"``, ``"error"`` (a program ended), or
    #: ``"paused"`` / ``"state_stopped"`` (the program state changed).
    what: str
    #: Why: ``"end_of_program"``, ``"halt"``, ``"runtime_error"``, ``"replaced"`` (a
    #: client's new program), ``"dashboard_stop"``, ``"dashboard_pause"``,
    #: ``"power_off"``, ``"protective_stop"``, ``"robot_emergency_stop"``... (the
    #: ``stop_reason`` of docs/json-events.schema.json); ``None`` if not said.
    reason: Optional[str]
    #: The program's name (empty for a state change).
    name: str = ""
    #: The runtime error's message.
    text: Optional[str] = None
    #: The runtime error's line.
    line: Optional[int] = None


def stops_of(events: Sequence[Mapping[str, Any]]) -> List[ProgramStop]:
    """The :class:`ProgramStop` list of ``program`` and ``state`` events, in order."""
    out: List[ProgramStop] = []
    for e in events:
        if e.get("event") == "program" and e.get("what") in ("finished", "halted", "stopped", "error"):
            out.append(
                ProgramStop(
                    what=str(e["what"]),
                    reason=e.get("reason"),
                    name=str(e.get("name", "")),
                    text=e.get("text"),
                    line=e.get("line"),
                )
            )
        elif e.get("event") == "state" and e.get("reason") is not None:
            what = "paused" if e.get("program") == "PAUSED" else "state_stopped"
            out.append(ProgramStop(what=what, reason=e.get("reason")))
    return out


#: The controller's servers, by the name used here, with the port a real controller
#: uses. ``ursock controller`` always serves the dashboard; the others only when its
#: ``--help`` lists their ``--NAME-port`` option.
SERVERS: Mapping[str, int] = {
    "dashboard": 29999,
    "primary": 30001,
    "secondary": 30002,
    "realtime": 30003,
    "rtde": 30004,
    "interpreter": 30020,
}

def _has_interpreter_mode(polyscope: str) -> bool:
    """Whether a PolyScope version (``5.21.0``) has interpreter mode (5.10 and later)."""
    parts = [int(p) if p.isdigit() else 0 for p in polyscope.split(".")[:2]]
    parts += [0] * (2 - len(parts))
    return (parts[0], parts[1]) >= (5, 10)


#: How many events a :class:`UrController` keeps by default (its ``max_events``).
MAX_EVENTS = 10_000
#: How many distinct event kinds :meth:`UrController.event_count` counts.
MAX_KINDS = 256
#: How many characters of the controller's stderr are kept (the newest).
MAX_STDERR = 256 * 1024


def _drain(q: "queue.Queue[Any]") -> None:
    while True:
        try:
            q.get_nowait()
        except queue.Empty:
            return


_ADDR = re.compile(r"^\[?(?P<host>[^\]]*)\]?:(?P<port>\d+)$")


class ControllerError(RuntimeError):
    """``ursock controller`` could not be started, or ended early."""


def _port_of(addr: Any) -> Optional[int]:
    """The port of ``"host:port"`` (``"[::1]:port"``), or ``None``."""
    if isinstance(addr, str):
        m = _ADDR.match(addr.strip())
        if m:
            return int(m.group("port"))
    return None


def ports_of_event(event: Mapping[str, Any]) -> Dict[str, int]:
    """The ports an event of ``ursock controller --json`` reports, by service name, as
    docs/json-events.md defines them: a ``listening`` event's ``service`` and ``addr``,
    a ``ready`` event's ``addrs`` (service to address). Other events report none."""
    kind = event.get("event")
    if kind == "listening":
        port = _port_of(event.get("addr"))
        service = event.get("service")
        if isinstance(service, str) and port is not None:
            return {service: port}
    elif kind == "ready":
        addrs = event.get("addrs")
        if isinstance(addrs, Mapping):
            found = {}
            for service, addr in addrs.items():
                port = _port_of(addr)
                if isinstance(service, str) and port is not None:
                    found[service] = port
            return found
    return {}


class DashboardClient:
    """One connection to a dashboard server: a command line out, its reply line back,
    as PolyScope's own clients speak it."""

    def __init__(self, host: str, port: int, timeout: float = 10.0) -> None:
        self._sock = socket.create_connection((host, port), timeout=timeout)
        self._reader: IO[bytes] = self._sock.makefile("rb")
        #: The line the server greets with (``Connected: Universal Robots Dashboard
        #: Server``).
        self.greeting: str = self._readline()

    def _readline(self) -> str:
        line = self._reader.readline()
        if not line:
            raise ConnectionError("the dashboard server closed the connection")
        return line.decode("utf-8", errors="replace").rstrip("\r\n")

    def send(self, command: str) -> str:
        """Send ``command`` (a newline is added) and return the reply line, without
        its newline."""
        self._sock.sendall(command.encode("utf-8") + b"\n")
        return self._readline()

    def close(self) -> None:
        """Close the connection."""
        try:
            self._reader.close()
        finally:
            self._sock.close()

    def __enter__(self) -> "DashboardClient":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


#: How many loopback addresses :func:`free_loopback_address` tries.
LOOPBACK_TRIES = 64


def free_loopback_address(ports: Sequence[int]) -> str:
    """A loopback address ``127.x.y.z`` (not 127.0.0.1) on which every port of
    ``ports`` is free now (a later bind may still lose a race).

    :raises ControllerError: when none of :data:`LOOPBACK_TRIES` random ones is."""
    rng = random.SystemRandom()
    for _ in range(LOOPBACK_TRIES):
        host = f"127.{rng.randint(1, 254)}.{rng.randint(0, 255)}.{rng.randint(1, 254)}"
        free = True
        for port in ports:
            with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
                try:
                    probe.bind((host, port))
                except OSError:
                    free = False
                    break
        if free:
            return host
    raise ControllerError(f"no loopback address 127.x.y.z with ports {list(ports)} free (tried {LOOPBACK_TRIES})")


class UrController:
    """A running ``ursock controller``: the virtual controller on free ports.

    Use it as a context manager, or call :meth:`start` and :meth:`stop`::

        with UrController() as ur:
            assert ur.dashboard("power on") == "Powering on"

    :param host: the address to bind (and to connect to).
    :param model: the arm model (``--model``).
    :param polyscope: the PolyScope version it reports (``--polyscope``).
    :param programs: a directory of programs ``load`` finds (``--programs``).
    :param local: start in local control (``--local``).
    :param preamble: files of the installation's URCap preamble, run in each ``.urp``
        program played (``--preamble``).
    :param world: what the robot senses from the start, by ``--set`` name:
        ``{"digital_in[3]": True}``.
    :param extra_args: more ``ursock controller`` options, passed as they are.
    :param all_servers: also start every other server (primary, secondary, real-time,
        RTDE) that this ``ursock`` has, each on a free port.
    :param startup_timeout: seconds to wait for the servers to listen.
    :param max_events: how many of the newest events :attr:`events` keeps (older ones
        are counted in :attr:`events_dropped`); a controller with a busy client prints
        thousands of events a second, and a test process must not grow with them.
    :param standard_ports: serve on the standard ports (:data:`SERVERS`: 29999, 30001,
        30002, 30003, 30004, 30020) of a loopback address of its own, ``127.x.y.z``
        chosen where they are free (unless ``host`` is given), so that a client without
        port options (ur_rtde, a driver) reaches it at ``.host``. Linux routes all of
        127.0.0.0/8 to the loopback interface; elsewhere give ``host`` an address that
        is configured.
    """

    def __init__(
        self,
        *,
        host: str = "127.0.0.1",
        model: Optional[str] = None,
        polyscope: Optional[str] = None,
        programs: Optional[Union[str, "os.PathLike[str]"]] = None,
        local: bool = False,
        preamble: Sequence[Union[str, "os.PathLike[str]"]] = (),
        world: Optional[Mapping[str, Any]] = None,
        extra_args: Sequence[str] = (),
        all_servers: bool = True,
        startup_timeout: float = 20.0,
        ursock: Optional[Union[str, "os.PathLike[str]"]] = None,
        max_events: int = MAX_EVENTS,
        standard_ports: bool = False,
    ) -> None:
        if max_events < 1:
            raise ValueError(f"max_events must be at least 1, not {max_events}")
        self._standard_ports = standard_ports
        self._host_given = host != "127.0.0.1"
        self.host = host
        self._model = model
        self._polyscope = polyscope
        self._programs = programs
        self._local = local
        self._preamble = [os.fspath(p) for p in preamble]
        self._world = dict(world or {})
        self._extra_args = list(extra_args)
        self._all_servers = all_servers
        self._startup_timeout = startup_timeout
        self._ursock = str(ursock or binary())
        #: The port of each server that listens, by name (``"dashboard"``,
        #: ``"primary"``, ``"secondary"``, ``"realtime"``, ``"rtde"``).
        self.ports: Dict[str, int] = {}
        #: The command that was run.
        self.command: List[str] = []
        self._proc: Optional[subprocess.Popen[str]] = None
        self._events: "collections.deque[Dict[str, Any]]" = collections.deque(maxlen=max_events)
        self._dropped = 0
        self._counts: Dict[str, int] = {}
        self._lock = threading.Lock()
        # The `listening` events, for start() only: nothing is queued once it returns.
        self._queue: "queue.Queue[Optional[Dict[str, Any]]]" = queue.Queue()
        self._starting = False
        self._stderr: "collections.deque[str]" = collections.deque()
        self._stderr_chars = 0
        self._threads: List[threading.Thread] = []
        self._client: Optional[DashboardClient] = None
        self._rtde: Optional[RtdeReader] = None

    # -- the process ------------------------------------------------------------------

    def server_options(self) -> List[str]:
        """The servers besides the dashboard that this ``ursock controller`` can start
        (those whose ``--NAME-port`` option its ``--help`` lists)."""
        text = help_text("controller", ursock=self._ursock)
        names = [name for name in SERVERS if name != "dashboard" and f"--{name}-port" in text]
        if self._polyscope and not _has_interpreter_mode(self._polyscope):
            # The interpreter socket is PolyScope 5.10+'s: ursock serves none before.
            names = [name for name in names if name != "interpreter"]
        return names

    def start(self) -> "UrController":
        """Start the controller and wait until its servers listen.

        :raises ControllerError: when it exits or says nothing in time, with its stderr.
        """
        if self._proc is not None:
            return self
        others = self.server_options() if self._all_servers else []
        if self._standard_ports and not self._host_given:
            self.host = free_loopback_address([SERVERS[n] for n in ("dashboard", *others)])
        port_of = (lambda name: str(SERVERS[name])) if self._standard_ports else (lambda name: "0")
        cmd = [self._ursock, "controller", "--json", "--bind", self.host, "--dashboard-port", port_of("dashboard")]
        for name in others:
            cmd += [f"--{name}-port", port_of(name)]
        if self._model:
            cmd += ["--model", self._model]
        if self._polyscope:
            cmd += ["--polyscope", self._polyscope]
        if self._programs is not None:
            cmd += ["--programs", os.fspath(self._programs)]
        if self._local:
            cmd.append("--local")
        for path in self._preamble:
            cmd += ["--preamble", path]
        for name, value in self._world.items():
            cmd += ["--set", f"{name}={urscript_constant(value)}"]
        cmd += self._extra_args
        self.command = cmd
        self._starting = True
        self._proc = subprocess.Popen(
            cmd,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            encoding="utf-8",
            errors="replace",
            bufsize=1,
        )
        self._spawn(self._read_stdout)
        self._spawn(self._read_stderr)
        try:
            self._await_listening(others)
        except BaseException:
            self.stop()
            raise
        finally:
            with self._lock:
                self._starting = False
            _drain(self._queue)
        return self

    def _spawn(self, target: Any) -> None:
        thread = threading.Thread(target=target, daemon=True, name=f"ursock-controller-{target.__name__}")
        thread.start()
        self._threads.append(thread)

    def _read_stdout(self) -> None:
        assert self._proc is not None and self._proc.stdout is not None
        for line in self._proc.stdout:
            try:
                event = json.loads(line)
            except ValueError:
                continue
            if not isinstance(event, dict):
                continue
            with self._lock:
                if len(self._events) == self._events.maxlen:
                    self._dropped += 1
                self._events.append(event)
                kind = event.get("event")
                if isinstance(kind, str) and (kind in self._counts or len(self._counts) < MAX_KINDS):
                    self._counts[kind] = self._counts.get(kind, 0) + 1
                if self._starting and kind in ("listening", "ready"):
                    self._queue.put(event)
        with self._lock:
            if self._starting:
                self._queue.put(None)

    def _read_stderr(self) -> None:
        assert self._proc is not None and self._proc.stderr is not None
        for line in self._proc.stderr:
            line = line[-MAX_STDERR:]
            with self._lock:
                self._stderr.append(line)
                self._stderr_chars += len(line)
                while self._stderr_chars > MAX_STDERR:
                    self._stderr_chars -= len(self._stderr.popleft())

    def _await_listening(self, others: List[str]) -> None:
        """Reads the start-up events until ``ready`` (every port listens) or the start-up
        timeout: ``listening`` events, then ``ready`` (docs/json-events.md)."""
        deadline = time.monotonic() + self._startup_timeout
        while True:
            now = time.monotonic()
            if now >= deadline:
                break
            try:
                event = self._queue.get(timeout=deadline - now)
            except queue.Empty:
                break
            if event is None:
                raise ControllerError(self._failure("exited before listening"))
            self.ports.update(ports_of_event(event))
            if event.get("event") == "ready":
                break
        if "dashboard" not in self.ports:
            raise ControllerError(self._failure("no dashboard server listened in time"))
        missing = [name for name in others if name not in self.ports]
        if missing:
            raise ControllerError(self._failure(f"did not say where {', '.join(missing)} listen"))

    def _failure(self, what: str) -> str:
        status = self._proc.poll() if self._proc else None
        time.sleep(0.1)  # the stderr reader's last lines
        with self._lock:
            err = "".join(self._stderr).strip()
        return (
            f"ursock controller {what}"
            + (f" (exit status {status})" if status is not None else "")
            + (f"\nstderr:\n{err}" if err else "")
            + "\ncommand: "
            + " ".join(self.command)
        )

    def stop(self, timeout: float = 5.0) -> Optional[int]:
        """Stop the controller (if still running) and return its exit status."""
        if self._rtde is not None:
            self._rtde.close()
            self._rtde = None
        if self._client is not None:
            try:
                self._client.close()
            except OSError:
                pass
            self._client = None
        proc = self._proc
        if proc is None:
            return None
        if proc.poll() is None:
            proc.terminate()
            try:
                proc.wait(timeout)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait(timeout)
        for stream in (proc.stdin, proc.stdout, proc.stderr):
            if stream is not None:
                try:
                    stream.close()
                except OSError:
                    pass
        for thread in self._threads:
            thread.join(1.0)
        return proc.returncode

    def __enter__(self) -> "UrController":
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    @property
    def running(self) -> bool:
        """The process is running."""
        return self._proc is not None and self._proc.poll() is None

    @property
    def returncode(self) -> Optional[int]:
        """The exit status, once it ended."""
        return None if self._proc is None else self._proc.poll()

    @property
    def stderr(self) -> str:
        """What it wrote on stderr so far."""
        with self._lock:
            return "".join(self._stderr)

    # -- ports ------------------------------------------------------------------------

    def _port(self, name: str) -> Optional[int]:
        return self.ports.get(name)

    @property
    def dashboard_port(self) -> int:
        """The dashboard server's port (29999 on a real controller)."""
        return self.ports["dashboard"]

    @property
    def primary_port(self) -> Optional[int]:
        """The primary interface's port (30001), when this ursock serves it."""
        return self._port("primary")

    @property
    def secondary_port(self) -> Optional[int]:
        """The secondary interface's port (30002), when this ursock serves it."""
        return self._port("secondary")

    @property
    def realtime_port(self) -> Optional[int]:
        """The real-time interface's port (30003), when this ursock serves it."""
        return self._port("realtime")

    @property
    def rtde_port(self) -> Optional[int]:
        """The RTDE interface's port (30004), when this ursock serves it."""
        return self._port("rtde")

    @property
    def interpreter_port(self) -> Optional[int]:
        """The interpreter socket's port (30020, interpreter mode; PolyScope 5.10+), when
        this ursock serves it."""
        return self._port("interpreter")

    # -- talking to it ----------------------------------------------------------------

    def dashboard(self, command: str) -> str:
        """Send one dashboard command (``"power on"``, ``"robotmode"``...) on the
        controller's shared connection and return the reply line."""
        if self._client is None:
            self._client = DashboardClient(self.host, self.dashboard_port)
        return self._client.send(command)

    def dashboard_client(self, timeout: float = 10.0) -> DashboardClient:
        """A new, separate connection to the dashboard server (close it when done)."""
        return DashboardClient(self.host, self.dashboard_port, timeout=timeout)

    def operator(self, command: str) -> None:
        """Type an operator command on the controller's standard input: what happens at
        the robot that no dashboard command causes (``"protective stop"``,
        ``"emergency stop"``, ``"release"``, ``"local"``, ``"remote"``...)."""
        if self._proc is None or self._proc.stdin is None:
            raise ControllerError("the controller is not running")
        self._proc.stdin.write(command + "\n")
        self._proc.stdin.flush()

    @property
    def events(self) -> List[Dict[str, Any]]:
        """The JSON events printed so far (``listening``, ``connect``, ``dashboard``,
        ``close``...): the newest ``max_events`` of them."""
        with self._lock:
            return list(self._events)

    @property
    def events_dropped(self) -> int:
        """How many of the oldest events :attr:`events` no longer holds."""
        with self._lock:
            return self._dropped

    def event_count(self, kind: str) -> int:
        """How many events named ``kind`` were printed, kept or not (counted for the
        first 256 kinds seen)."""
        with self._lock:
            return self._counts.get(kind, 0)

    def events_of(self, kind: str) -> List[Dict[str, Any]]:
        """The events named ``kind`` that :attr:`events` holds."""
        return [e for e in self.events if e.get("event") == kind]

    def log(self, last: int = 200) -> str:
        """What the controller said: its command, its stderr and its ``last`` newest
        events as JSON lines (what the pytest plugin shows when a test fails)."""
        with self._lock:
            err = "".join(self._stderr).strip()
            events = list(self._events)[-last:] if last > 0 else []
            dropped = self._dropped + max(0, len(self._events) - len(events))
        parts = ["command: " + " ".join(self.command)]
        if err:
            parts.append("stderr:\n" + err)
        if events:
            head = f"last {len(events)} events" + (f" ({dropped} older not shown)" if dropped else "")
            parts.append(head + ":\n" + "\n".join(json.dumps(e, separators=(",", ":")) for e in events))
        return "\n".join(parts)

    # -- the arm, as a client sees it ---------------------------------------------------

    def rtde(self) -> RtdeReader:
        """The controller's shared RTDE reader (connected on first use, closed by
        :meth:`stop`): the arm's state at 125 Hz through the controller's RTDE server.

        :raises ControllerError: when this controller serves no RTDE."""
        if self._rtde is None:
            port = self.rtde_port
            if port is None:
                raise ControllerError("this controller has no RTDE server (all_servers=False?)")
            self._rtde = RtdeReader(self.host, port)
        return self._rtde

    def state(self, timeout: float = 5.0) -> RobotState:
        """The arm now, as an RTDE client reads it: ``.joints``, ``.tcp_pose``,
        ``.tcp_speed``, ``.digital_out``, ``.analog_out``, ``.int_registers``,
        ``.double_registers``, ``.bool_registers``, ``.robot_mode``, ``.safety_mode``,
        ``.program_state``."""
        return self.rtde().state(timeout=timeout)

    def wait_until(self, condition: Callable[[RobotState], bool], timeout: float = 10.0) -> RobotState:
        """Wait until ``condition(state)`` holds for an RTDE sample and return it:
        ``ur.wait_until(lambda s: s.digital_out[1])``.

        :raises TimeoutError: naming the last state seen."""
        return self.rtde().wait_until(condition, timeout=timeout)

    def wait_for_mode(self, mode: str, timeout: float = 10.0) -> RobotState:
        """Wait until the robot mode (``"RUNNING"``, ``"IDLE"``, ``"POWER_OFF"``...),
        the safety mode (``"NORMAL"``, ``"PROTECTIVE_STOP"``...) or the program state
        (``"PLAYING"``, ``"STOPPED"``, ``"PAUSED"``) is ``mode``.

        :raises ValueError: for a name that is none of these."""
        name = mode.upper()
        if name in ROBOT_MODES.values():
            return self.wait_until(lambda s: s.robot_mode == name, timeout)
        if name in SAFETY_MODES.values():
            return self.wait_until(lambda s: s.safety_mode == name, timeout)
        if name in RUNTIME_STATES.values():
            return self.wait_until(lambda s: s.program_state == name, timeout)
        known = ", ".join([*ROBOT_MODES.values(), *SAFETY_MODES.values(), *RUNTIME_STATES.values()])
        raise ValueError(f"wait_for_mode({mode!r}): not a robot mode, safety mode or program state ({known})")

    def send_script(self, program: str, server: str = "primary") -> None:
        """Send a URScript program to the controller as a client does: its text on the
        primary (or ``server="secondary"``) interface. A program replaces the one
        running; a secondary program (``sec ...``) runs beside it."""
        port = self.ports.get(server)
        if port is None:
            raise ControllerError(f"this controller has no {server} server")
        text = program if program.endswith("\n") else program + "\n"
        with socket.create_connection((self.host, port), timeout=10.0) as conn:
            conn.sendall(text.encode("utf-8"))
            # The controller reads what arrived before the connection closes.
            conn.shutdown(socket.SHUT_WR)
            conn.settimeout(1.0)
            try:
                while conn.recv(65536):
                    pass
            except OSError:
                pass

    def stops(self) -> List[ProgramStop]:
        """Every pause, stop and end of its programs, with the reason
        (:class:`ProgramStop`), from the events :attr:`events` still holds."""
        return stops_of(self.events)

    def moves(self) -> List[Move]:
        """The moves of the programs the controller ran, from its ``move_start`` and
        ``move_end`` events (those :attr:`events` still holds)."""
        return moves_of(self.events)

    def wait_for_event(self, kind: str, count: int = 1, timeout: float = 5.0) -> List[Dict[str, Any]]:
        """Wait until at least ``count`` events named ``kind`` were printed; return those
        :attr:`events` still holds.

        :raises TimeoutError: when they do not come in time.
        """
        deadline = time.monotonic() + timeout
        while True:
            if self.event_count(kind) >= count:
                return self.events_of(kind)
            if time.monotonic() >= deadline:
                seen = self.event_count(kind)
                raise TimeoutError(f"{seen} {kind!r} events after {timeout} s, expected {count}")
            time.sleep(0.01)
