"""Checks of the source distribution (`maturin sdist` in python/), run by .ci/run.

    python python/tests/check_sdist.py sdist ursock-X.tar.gz
        the archive holds this folder's README.md where its pyproject.toml says, its
        PKG-INFO describes the package with that README, it holds the Python sources and
        the Rust packages the wheel is built from, and nothing from a target/ folder;
    python python/tests/check_sdist.py installed
        (with the Python of the venv the sdist was installed into) the installed
        distribution's description is this folder's README.md too: what a wheel built
        from the sdist puts on the index page.

Exits 1 with the reasons when a check fails. Standard library only.
"""

from __future__ import annotations

import re
import sys
import tarfile
from email.parser import Parser
from pathlib import Path
from typing import List

README = Path(__file__).resolve().parent.parent / "README.md"

# What a wheel needs from the archive, relative to its top folder.
NEEDED = [
    "pyproject.toml",
    "PKG-INFO",
    "Cargo.toml",
    "Cargo.lock",
    "src/ursock/__init__.py",
    "src/ursock/pytest_plugin.py",
    "src/ursock/py.typed",
    "ursock/Cargo.toml",
    "ursock/src/main.rs",
    "interp/Cargo.toml",
    "controller/Cargo.toml",
    "src/lib.rs",
]


def _description(metadata: str) -> str:
    """The body of a PKG-INFO/METADATA file (core metadata 2.1+: the description)."""
    message = Parser().parsestr(metadata)
    body = message.get_payload()
    return body if isinstance(body, str) else ""


def check_sdist(path: Path) -> List[str]:
    problems: List[str] = []
    readme = README.read_text(encoding="utf-8")
    with tarfile.open(path) as tar:
        names = tar.getnames()
        top = names[0].split("/")[0]

        def text(name: str) -> str:
            member = tar.extractfile(f"{top}/{name}")
            return member.read().decode("utf-8") if member else ""

        stray = [n for n in names if "/target/" in f"/{n}/"]
        if stray:
            problems.append(f"{len(stray)} files from a target/ folder, like {stray[0]}")
        missing = [name for name in NEEDED if f"{top}/{name}" not in names]
        if missing:
            return problems + [f"missing: {name}" for name in missing]
        pyproject = text("pyproject.toml")
        found = re.search(r'^readme\s*=\s*"([^"]+)"', pyproject, re.M)
        if not found:
            return problems + ["pyproject.toml names no readme"]
        named = found.group(1)
        if f"{top}/{named}" not in names:
            problems.append(f"pyproject.toml's readme {named!r} is not in the archive")
        elif text(named) != readme:
            problems.append(f"pyproject.toml's readme {named!r} is not python/README.md")
        if _description(text("PKG-INFO")).strip() != readme.strip():
            problems.append("PKG-INFO's description is not python/README.md")
        if "Description-Content-Type: text/markdown" not in text("PKG-INFO"):
            problems.append("PKG-INFO does not say the description is Markdown")
    return problems


def check_installed() -> List[str]:
    from importlib.metadata import distribution

    metadata = distribution("ursock").read_text("METADATA") or ""
    if _description(metadata).strip() != README.read_text(encoding="utf-8").strip():
        return ["the installed ursock's description is not python/README.md"]
    return []


if __name__ == "__main__":
    if sys.argv[1:2] == ["sdist"] and len(sys.argv) == 3:
        problems = check_sdist(Path(sys.argv[2]))
        what = sys.argv[2]
    elif sys.argv[1:] == ["installed"]:
        problems = check_installed()
        what = "the installed ursock"
    else:
        sys.exit("usage: check_sdist.py sdist ursock-X.tar.gz | check_sdist.py installed")
    for p in problems:
        print(f"{what}: {p}", file=sys.stderr)
    if problems:
        sys.exit(1)
    print(f"{what}: ok (python/README.md is its README and description)")
