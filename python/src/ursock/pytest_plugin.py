"""The pytest plugin of ``ursock`` (registered through the ``pytest11`` entry point,
so installing the package is enough).

Fixtures:

``virtual_robot``
    A function: ``virtual_robot(program)`` runs a URScript program (its text, a
    ``Path`` to a file, or ``lines=[...]`` statements) on ``ursock``'s virtual robot,
    in real time, against the servers your test started, and returns a
    :class:`ursock.RobotRun` with the typed call records and messages. When ``ursock``
    exits with an error (a syntax error, a runtime error), the test fails with what
    ``ursock`` said.

``ur_controller``
    A running :class:`ursock.UrController` (the virtual controller on free ports),
    stopped after the test: ``.host``, ``.dashboard_port`` (and ``.primary_port``,
    ``.secondary_port``, ``.realtime_port``, ``.rtde_port``, ``.interpreter_port`` when
    this ``ursock`` serves them), ``.dashboard("robotmode")``, ``.state()``,
    ``.wait_until(...)``, ``.send_script(...)``.

``ur_controller_factory``
    A function: ``ur_controller_factory(model=..., programs=..., world=...,
    standard_ports=True)`` starts a controller and returns it (stopped after the test).
    With ``standard_ports`` (the default) it serves the standard ports on a loopback
    address of its own (``127.x.y.z``), so clients without port options (ur_rtde)
    reach it at ``.host``.

When a test that used a controller fails, its log (stderr and newest events) is added
to the report as a section ``ursock controller HOST``.

Settings (``pytest.ini``, ``pyproject.toml``'s ``[tool.pytest.ini_options]``):
``ursock_max_time`` (seconds, default 30: the ``--max-time`` given to every program
that sets none) and ``ursock_binary`` (the executable to use instead of the installed
one; the ``URSOCK_BINARY`` environment variable does the same).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Generator, Iterator, List, Mapping, Optional, Protocol, Sequence, Union

import pytest

from ._binary import BinaryNotFound, binary
from .controller import ControllerError, UrController
from .robot import RobotRun, ScriptSource, run_robot

__all__ = ["ControllerFactory", "VirtualRobot", "virtual_robot", "ur_controller", "ur_controller_factory"]

#: The controllers a test started, for its report.
_CONTROLLERS = pytest.StashKey[List[UrController]]()

DEFAULT_MAX_TIME = 30.0


def pytest_addoption(parser: pytest.Parser) -> None:
    """The plugin's ini settings."""
    parser.addini(
        "ursock_max_time",
        "seconds after which virtual_robot ends a program that sets no max_time (default 30)",
        default=str(DEFAULT_MAX_TIME),
    )
    parser.addini(
        "ursock_binary",
        "the ursock executable the fixtures run (default: the installed one)",
        default="",
    )


class VirtualRobot(Protocol):
    """The type of the ``virtual_robot`` fixture (for annotating tests)."""

    def __call__(
        self,
        script: Optional[ScriptSource] = None,
        *,
        lines: Optional[Sequence[str]] = None,
        stub: Sequence[str] = (),
        max_time: Optional[float] = None,
        check: bool = True,
        **options: Any,
    ) -> RobotRun: ...


def _ursock_path(config: pytest.Config) -> Path:
    configured = str(config.getini("ursock_binary") or "").strip()
    if configured:
        path = Path(configured)
        if not path.is_absolute():
            path = Path(str(config.rootpath)) / path
        if not (path.is_file() and os.access(path, os.X_OK)):
            pytest.fail(f"ursock_binary = {configured}: {path} is not an executable file", pytrace=False)
        return path
    try:
        return binary()
    except BinaryNotFound as e:
        pytest.fail(str(e), pytrace=False)
        raise  # not reached


@pytest.fixture
def virtual_robot(request: pytest.FixtureRequest) -> VirtualRobot:
    """Run a URScript program on ``ursock``'s virtual robot; returns a
    :class:`ursock.RobotRun`.

    ``virtual_robot(program)`` takes the program's text (or a ``Path``);
    ``virtual_robot(lines=[...])`` takes statements. Keywords: ``stub`` (``NAME`` or
    ``NAME=VALUE``), ``max_time`` (default: the ``ursock_max_time`` setting, 30 s),
    ``check`` (default True: fail the test when ursock exits with an error), and every
    other keyword of :func:`ursock.run_robot` (``connect``, ``step_time``, ``model``,
    ``trace``, ``extra_args``, ``timeout``...).
    """
    config = request.config
    ursock = _ursock_path(config)
    default_max_time = float(config.getini("ursock_max_time") or DEFAULT_MAX_TIME)

    def run(
        script: Optional[ScriptSource] = None,
        *,
        lines: Optional[Sequence[str]] = None,
        stub: Sequence[str] = (),
        max_time: Optional[float] = None,
        check: bool = True,
        **options: Any,
    ) -> RobotRun:
        if isinstance(script, (list, tuple)) and lines is None:
            script, lines = None, list(script)
        if (script is None) == (lines is None):
            raise TypeError("virtual_robot: give a program (text or Path) or lines=[...], not both")
        result = run_robot(
            script,
            lines,
            stub=stub,
            max_time=default_max_time if max_time is None else max_time,
            ursock=ursock,
            **options,
        )
        if check and not result.ok:
            pytest.fail(result.describe_failure(), pytrace=False)
        return result

    return run


@pytest.fixture
def ur_controller(request: pytest.FixtureRequest) -> Iterator[UrController]:
    """A running ``ursock controller`` (the virtual UR controller) on free ports of
    127.0.0.1, stopped after the test.

    ``.host``, ``.dashboard_port``, ``.ports`` (every server that listens, by name),
    ``.dashboard("power on")`` (the reply line), ``.operator("protective stop")``,
    ``.events`` (what it printed).
    """
    controller = UrController(ursock=_ursock_path(request.config))
    _remember(request, controller)
    try:
        controller.start()
    except ControllerError as e:
        pytest.fail(str(e), pytrace=False)
    try:
        yield controller
    finally:
        controller.stop()


class ControllerFactory(Protocol):
    """The type of the ``ur_controller_factory`` fixture (for annotating tests)."""

    def __call__(
        self,
        *,
        model: Optional[str] = None,
        programs: Optional[Union[str, "os.PathLike[str]"]] = None,
        world: Optional[Mapping[str, Any]] = None,
        standard_ports: bool = True,
        **options: Any,
    ) -> UrController: ...


def _remember(request: pytest.FixtureRequest, controller: UrController) -> None:
    made = request.node.stash.get(_CONTROLLERS, None)
    if made is None:
        made = []
        request.node.stash[_CONTROLLERS] = made
    made.append(controller)


@pytest.fixture
def ur_controller_factory(request: pytest.FixtureRequest) -> Iterator[ControllerFactory]:
    """Start virtual controllers: ``ur_controller_factory(model="ur10e",
    programs=path, world={"digital_in[0]": True}, standard_ports=True)`` returns a
    started :class:`ursock.UrController`; every one is stopped after the test.

    ``standard_ports=True`` (the default): the standard ports (29999, 30001-30004,
    30020) on a loopback address of its own (``.host``, ``127.x.y.z``), for clients that
    have no port options, like ur_rtde: ``RTDEReceiveInterface(ur.host)``.
    ``standard_ports=False``: free ports of 127.0.0.1 (``.ports``). Other keywords go to
    :class:`ursock.UrController` (``polyscope``, ``local``, ``preamble``, ``extra_args``...).
    """
    ursock = _ursock_path(request.config)
    made: List[UrController] = []

    def make(
        *,
        model: Optional[str] = None,
        programs: Optional[Union[str, "os.PathLike[str]"]] = None,
        world: Optional[Mapping[str, Any]] = None,
        standard_ports: bool = True,
        **options: Any,
    ) -> UrController:
        controller = UrController(
            model=model,
            programs=programs,
            world=world,
            standard_ports=standard_ports,
            ursock=ursock,
            **options,
        )
        made.append(controller)
        _remember(request, controller)
        try:
            controller.start()
        except ControllerError as e:
            pytest.fail(str(e), pytrace=False)
        return controller

    try:
        yield make
    finally:
        for controller in made:
            controller.stop()


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item: pytest.Item, call: pytest.CallInfo[None]) -> Generator[None, Any, None]:
    """A failed test's report gets the log of each controller it started."""
    outcome = yield
    report = outcome.get_result()
    if not report.failed:
        return
    for controller in item.stash.get(_CONTROLLERS, []):
        report.sections.append((f"ursock controller {controller.host}", controller.log()))
