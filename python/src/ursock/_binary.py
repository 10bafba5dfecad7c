"""Finding the ``ursock`` executable."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import sysconfig
from functools import lru_cache
from pathlib import Path
from typing import List, Optional

__all__ = ["binary", "BinaryNotFound", "ENV_VAR"]

#: Environment variable naming the ``ursock`` executable to use (a build of your own,
#: ``target/release/ursock`` of a checkout); it wins over everything else.
ENV_VAR = "URSOCK_BINARY"

_EXE = "ursock.exe" if os.name == "nt" else "ursock"


class BinaryNotFound(FileNotFoundError):
    """No ``ursock`` executable was found."""


def _candidates() -> List[Path]:
    """Where a wheel install puts the executable: the running interpreter's scripts
    directory (a virtualenv's ``bin/`` even when the venv is not activated), then the
    user scheme's (``pip install --user``)."""
    found: List[Path] = []
    for scheme in (None, f"{os.name}_user"):
        try:
            scripts = sysconfig.get_path("scripts", scheme) if scheme else sysconfig.get_path("scripts")
        except KeyError:
            continue
        if scripts:
            found.append(Path(scripts) / _EXE)
    found.append(Path(sys.executable).parent / _EXE)
    return found


def binary(refresh: bool = False) -> Path:
    """The path of the ``ursock`` executable.

    Looked up, in order: the ``URSOCK_BINARY`` environment variable, the scripts
    directory of the running Python (where ``pip install`` put it), then ``PATH``.

    :param refresh: forget the cached answer and look again.
    :raises BinaryNotFound: when none of these has it, with what was tried.
    """
    if refresh:
        _find.cache_clear()
    return _find(os.environ.get(ENV_VAR))


@lru_cache(maxsize=4)
def _find(override: Optional[str]) -> Path:
    if override:
        path = Path(override)
        if path.is_file() and os.access(path, os.X_OK):
            return path.resolve()
        raise BinaryNotFound(f"{ENV_VAR}={override!r} is not an executable file")
    tried = _candidates()
    for path in tried:
        if path.is_file() and os.access(path, os.X_OK):
            return path
    on_path = shutil.which("ursock")
    if on_path:
        return Path(on_path)
    raise BinaryNotFound(
        "the ursock executable was not found (looked in "
        + ", ".join(str(p) for p in tried)
        + f" and on PATH); install it with `pip install ursock` (or `pip install ./python` "
        f"from a checkout), or set {ENV_VAR} to its path"
    )


def help_text(*subcommand: str, ursock: Optional[str] = None) -> str:
    """``ursock SUBCOMMAND --help``, as text (empty when it cannot be run)."""
    try:
        done = subprocess.run(
            [ursock or str(binary()), *subcommand, "--help"],
            capture_output=True,
            text=True,
            timeout=30,
            check=False,
        )
    except (OSError, subprocess.TimeoutExpired):
        return ""
    return done.stdout
