"""The typed API without a robot: value decoding, records, the binary, the plugin."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

import ursock
from ursock import CallRecord, Message, Pose, ReadResult, decode_value, parse_events


def test_values_decode_to_python() -> None:
    assert decode_value({"encoding": "utf-8", "text": "café"}) == "café"
    assert decode_value({"encoding": "hex", "hex": "636166e9"}) == b"caf\xe9"
    assert decode_value({"pose": [1, 2, 3, 4, 5, None]}) == Pose(1, 2, 3, 4, 5, None)
    assert decode_value({"count": 2, "values": [1.5, 2.0]}) == ReadResult(2, [1.5, 2.0])
    assert decode_value([True, {"encoding": "utf-8", "text": "a"}, None]) == [True, "a", None]
    assert decode_value(3) == 3 and decode_value(None) is None


def test_records_from_the_documented_examples() -> None:
    # The examples of docs/json-events.md.
    events, other = parse_events(
        [
            '{"event":"call","t":0.012345,"line":2,"column":5,"call":"socket_read_ascii_float",'
            '"source":"x = socket_read_ascii_float(2)","socket":"socket_0","args":[2],'
            '"result":{"count":2,"values":[1.5,2.0]},"outcome":"returned","sentinel":false,"why":null}',
            '{"event":"message","t":0.2,"line":5,"kind":"textmsg","text":"still running",'
            '"source":"textmsg(\\"still running\\")"}',
            "",
            "not json",
        ]
    )
    assert other == ["not json"]
    call = CallRecord.from_event(events[0])
    assert (call.line, call.column, call.call, call.socket) == (2, 5, "socket_read_ascii_float", "socket_0")
    assert call.result == ReadResult(2, [1.5, 2.0]) and call.values == [1.5, 2.0]
    assert call.assigned_to == "x" and call.ok and call.result.as_list() == [2, 1.5, 2.0]
    message = Message.from_event(events[1])
    assert (message.kind, message.text, message.line) == ("textmsg", "still running", 5)


def test_the_binary_is_installed_beside_python_and_runs() -> None:
    path = ursock.binary(refresh=True)
    assert path.is_file() and os.access(path, os.X_OK)
    import subprocess

    out = subprocess.run([str(path), "--version"], capture_output=True, text=True, check=True).stdout
    assert out.startswith("ursock ")


def test_the_environment_variable_overrides_and_is_checked(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    monkeypatch.setenv(ursock.ENV_VAR, str(tmp_path / "missing"))
    with pytest.raises(ursock.BinaryNotFound, match="URSOCK_BINARY"):
        ursock.binary(refresh=True)
    monkeypatch.delenv(ursock.ENV_VAR)
    assert ursock.binary(refresh=True).name.startswith("ursock")


def test_the_plugin_is_registered_by_its_entry_point(pytestconfig: pytest.Config) -> None:
    import ursock.pytest_plugin

    assert pytestconfig.pluginmanager.get_plugin("ursock") is ursock.pytest_plugin


def test_the_package_is_typed() -> None:
    assert (Path(ursock.__file__).parent / "py.typed").is_file()


def test_every_public_name_is_in_the_readmes_api_section() -> None:
    import ursock.pytest_plugin

    readme = (Path(__file__).resolve().parent.parent / "README.md").read_text(encoding="utf-8")
    api = readme.split("## API", 1)[1].split("\n## ", 1)[0]
    names = [*ursock.__all__, *ursock.pytest_plugin.__all__]
    missing = [n for n in names if f"`{n}" not in api]
    assert missing == [], f"not in python/README.md's API section: {missing}"
