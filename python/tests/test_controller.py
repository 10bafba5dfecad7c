"""ur_controller: ursock controller on free ports, driven through its dashboard server."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any, Dict, List

import pytest

from ursock import UrController
from ursock.controller import ports_of_event


def _wait_for(ur: UrController, command: str, reply: str, seconds: float = 10.0) -> None:
    deadline = time.monotonic() + seconds
    last = ""
    while time.monotonic() < deadline:
        last = ur.dashboard(command)
        if last == reply:
            return
        time.sleep(0.05)
    raise AssertionError(f"{command!r} still answers {last!r}, expected {reply!r}")


def test_power_on_and_robotmode_round_trip(ur_controller: UrController) -> None:
    assert ur_controller.host == "127.0.0.1"
    assert 0 < ur_controller.dashboard_port < 65536
    assert ur_controller.dashboard_port != 29999 or ur_controller.ports["dashboard"] == 29999
    assert ur_controller.dashboard("robotmode") == "Robotmode: POWER_OFF"
    assert ur_controller.dashboard("power on") == "Powering on"
    _wait_for(ur_controller, "robotmode", "Robotmode: IDLE")
    assert ur_controller.dashboard("brake release") == "Brake releasing"
    _wait_for(ur_controller, "robotmode", "Robotmode: RUNNING")
    assert ur_controller.dashboard("power off") == "Powering off"
    assert ur_controller.dashboard("robotmode") == "Robotmode: POWER_OFF"
    # The controller printed each command and its reply as a `dashboard` event.
    events = ur_controller.wait_for_event("dashboard", count=4)
    assert events[0]["command"] == "robotmode" and events[0]["reply"] == ["Robotmode: POWER_OFF"]
    assert {"command": "power on", "reply": ["Powering on"]}.items() <= events[1].items()


def test_clients_share_one_controller(ur_controller: UrController) -> None:
    with ur_controller.dashboard_client() as client:
        assert "Dashboard Server" in client.greeting
        assert client.send("power on") == "Powering on"
    _wait_for(ur_controller, "robotmode", "Robotmode: IDLE")
    ur_controller.wait_for_event("close")


def test_operator_protective_stop(ur_controller: UrController) -> None:
    ur_controller.dashboard("power on")
    _wait_for(ur_controller, "robotmode", "Robotmode: IDLE")
    ur_controller.dashboard("brake release")
    _wait_for(ur_controller, "robotmode", "Robotmode: RUNNING")
    ur_controller.operator("protective stop")
    _wait_for(ur_controller, "safetystatus", "Safetystatus: PROTECTIVE_STOP")


def test_every_port_the_controller_reports_is_exposed(ur_controller: UrController) -> None:
    # Whatever servers this ursock has: each that --help lists was started and listens.
    import socket

    expected = {"dashboard", *ur_controller.server_options()}
    assert set(ur_controller.ports) == expected
    for name, port in ur_controller.ports.items():
        with socket.create_connection((ur_controller.host, port), timeout=5):
            pass
        assert getattr(ur_controller, f"{name}_port") == port
    for name in {"primary", "secondary", "realtime", "rtde", "interpreter"} - expected:
        assert getattr(ur_controller, f"{name}_port") is None


def test_world_settings_reach_the_programs_clients_send(tmp_path: Path) -> None:
    import socket

    with UrController(world={"digital_in[2]": True, "joint_temp[0]": 41.5}) as ur:
        ur.dashboard("brake release")
        _wait_for(ur, "robotmode", "Robotmode: RUNNING")
        assert ur.primary_port is not None
        with socket.create_connection((ur.host, ur.primary_port), timeout=5) as s:
            s.sendall(b"def sense():\n  textmsg(get_standard_digital_in(2), get_joint_temp(0))\nend\n")
            message = ur.wait_for_event("message", timeout=10)[0]
    assert message["text"] == "True41.5"


def test_stop_ends_the_process() -> None:
    ur = UrController().start()
    assert ur.running
    ur.stop()
    assert not ur.running and ur.returncode is not None


def test_a_bad_option_fails_with_stderr() -> None:
    from ursock import ControllerError

    with pytest.raises(ControllerError) as info:
        UrController(polyscope="five").start()
    assert "--polyscope five" in str(info.value)


@pytest.mark.parametrize(
    "event, expected",
    [
        (
            {"event": "listening", "t": 0.0, "addr": "127.0.0.1:4001", "service": "primary"},
            {"primary": 4001},
        ),
        ({"event": "listening", "t": 0.0, "addr": "[::1]:4004", "service": "rtde"}, {"rtde": 4004}),
        (
            {"event": "ready", "t": 0.0, "addrs": {"dashboard": "127.0.0.1:4000", "rtde": "[::1]:4004"}},
            {"dashboard": 4000, "rtde": 4004},
        ),
        # Not the schema's: nothing is guessed.
        ({"event": "listening", "t": 0.0, "addr": "127.0.0.1:4000"}, {}),
        ({"event": "listening", "t": 0.0, "addr": "127.0.0.1:4001", "server": "primary"}, {}),
        ({"event": "connect", "t": 0.0, "peer": "127.0.0.1:5000", "service": "rtde"}, {}),
    ],
)
def test_ports_are_read_as_the_schema_names_them(event: Dict[str, Any], expected: Dict[str, int]) -> None:
    assert ports_of_event(event) == expected


def test_the_port_options_help_lists_are_passed_and_their_ports_exposed(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import json
    import socket
    import sys

    fake = tmp_path / "ursock"
    fake.write_text(f"#!{sys.executable}\n" + (Path(__file__).parent / "fake_ursock.py").read_text())
    fake.chmod(0o755)
    argv = tmp_path / "argv.json"
    monkeypatch.setenv("FAKE_URSOCK_ARGV", str(argv))
    with UrController(ursock=fake, startup_timeout=10) as ur:
        assert ur.server_options() == ["primary", "rtde"]
        args = json.loads(argv.read_text())
        assert args[args.index("--primary-port") + 1] == "0"
        assert args[args.index("--rtde-port") + 1] == "0"
        assert "--secondary-port" not in args and "--realtime-port" not in args
        assert set(ur.ports) == {"dashboard", "primary", "rtde"}
        assert len(set(ur.ports.values())) == 3
        assert ur.secondary_port is None and ur.realtime_port is None
        for port in (ur.dashboard_port, ur.primary_port, ur.rtde_port):
            assert port is not None
            socket.create_connection((ur.host, port), timeout=5).close()


def test_events_kept_are_bounded_and_nothing_is_queued_after_start(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import sys

    from ursock.controller import MAX_STDERR

    fake = tmp_path / "ursock"
    fake.write_text(f"#!{sys.executable}\n" + (Path(__file__).parent / "fake_ursock.py").read_text())
    fake.chmod(0o755)
    monkeypatch.setenv("FAKE_URSOCK_ARGV", str(tmp_path / "argv.json"))
    monkeypatch.setenv("FAKE_URSOCK_FLOOD", "30000")
    with UrController(ursock=fake, startup_timeout=10, max_events=1000) as ur:
        ur.wait_for_event("done", timeout=60)
        assert ur.event_count("rtde") == 30000
        events = ur.events
        assert len(events) == 1000
        assert events[-1]["event"] == "done" and events[-2]["i"] == 29999
        # 3 listening events, ready, the flood, done.
        assert ur.events_dropped == 3 + 1 + 30000 + 1 - 1000
        # The start-up queue holds nothing once start() returned.
        assert ur._queue.qsize() == 0
        deadline = time.monotonic() + 30
        while "noise 29999" not in ur.stderr and time.monotonic() < deadline:
            time.sleep(0.05)
        assert "noise 29999" in ur.stderr and "noise 0 " not in ur.stderr
        assert len(ur.stderr) <= MAX_STDERR


def test_max_events_must_be_positive() -> None:
    with pytest.raises(ValueError):
        UrController(max_events=0)


def test_start_returns_at_the_ready_event_not_at_the_startup_timeout(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import sys
    import threading

    fake = tmp_path / "ursock"
    fake.write_text(f"#!{sys.executable}\n" + (Path(__file__).parent / "fake_ursock.py").read_text())
    fake.chmod(0o755)
    monkeypatch.setenv("FAKE_URSOCK_ARGV", str(tmp_path / "argv.json"))
    ur = UrController(ursock=fake, startup_timeout=600)
    started = threading.Thread(target=ur.start, daemon=True)
    started.start()
    # A hang guard, far below the start-up timeout: `ready` ends the wait.
    started.join(60)
    try:
        assert not started.is_alive(), "start() waited for the start-up timeout"
        assert set(ur.ports) == {"dashboard", "primary", "rtde"}
    finally:
        ur.stop()
