"""``ursock`` for Python: the ``ursock`` executable (installed with this package), a
typed API over its JSON output, and a pytest plugin.

* :func:`binary` finds the executable.
* :func:`run_robot` runs a URScript program on the virtual robot against your servers
  and returns a :class:`RobotRun` (its :class:`CallRecord` list, its :class:`Message`
  list, every raw event).
* :class:`UrController` runs the virtual controller (its dashboard server and, when
  this ``ursock`` has them, the other servers) and reads the arm as a client does
  (:meth:`UrController.state`, :meth:`UrController.wait_until`, over RTDE with
  :class:`RtdeReader`).
* The pytest plugin (:mod:`ursock.pytest_plugin`, loaded by pytest on its own) gives
  the fixtures ``virtual_robot`` and ``ur_controller``.
"""

from __future__ import annotations

from ._binary import ENV_VAR, BinaryNotFound, binary
from .controller import (
    SERVERS,
    ControllerError,
    DashboardClient,
    ProgramStop,
    UrController,
    free_loopback_address,
    stops_of,
)
from .rtde import ROBOT_MODES, RUNTIME_STATES, SAFETY_MODES, RobotState, RtdeError, RtdeReader
from .robot import (
    ArmState,
    CallRecord,
    Message,
    Move,
    OutputChange,
    Pose,
    ReadResult,
    RobotRun,
    RobotRunError,
    ScriptSource,
    decode_value,
    moves_of,
    parse_events,
    run_robot,
)

__all__ = [
    "ProgramStop",
    "stops_of",
    "ROBOT_MODES",
    "RUNTIME_STATES",
    "SAFETY_MODES",
    "RobotState",
    "RtdeError",
    "RtdeReader",
    "free_loopback_address",
    "ArmState",
    "Move",
    "OutputChange",
    "ENV_VAR",
    "SERVERS",
    "BinaryNotFound",
    "CallRecord",
    "ControllerError",
    "DashboardClient",
    "Message",
    "Pose",
    "ReadResult",
    "RobotRun",
    "RobotRunError",
    "ScriptSource",
    "UrController",
    "binary",
    "decode_value",
    "parse_events",
    "moves_of",
    "run_robot",
]
