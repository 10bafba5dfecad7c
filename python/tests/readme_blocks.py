"""The files of python/README.md: each ```python block after a `<!-- file: NAME -->`
line. Run as a script, writes them into a directory:

    python python/tests/readme_blocks.py python/README.md DIR && python -m pytest DIR
"""

from __future__ import annotations

import re
import sys
from pathlib import Path
from typing import Dict

README = Path(__file__).resolve().parent.parent / "README.md"

_BLOCK = re.compile(r"<!-- file: (?P<name>[\w.]+) -->\s*```python\n(?P<code>.*?)^```", re.S | re.M)


def blocks(readme: Path = README) -> Dict[str, str]:
    """``{file name: code}`` of the README's named blocks."""
    found = {m.group("name"): m.group("code") for m in _BLOCK.finditer(readme.read_text(encoding="utf-8"))}
    if not found:
        raise ValueError(f"{readme}: no `<!-- file: NAME -->` blocks")
    return found


def write(readme: Path, directory: Path) -> Dict[str, str]:
    """Write the README's named blocks into ``directory``."""
    directory.mkdir(parents=True, exist_ok=True)
    files = blocks(readme)
    for name, code in files.items():
        (directory / name).write_text(code, encoding="utf-8")
    return files


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit("usage: readme_blocks.py README.md DIR")
    written = write(Path(sys.argv[1]), Path(sys.argv[2]))
    print("wrote " + ", ".join(sorted(written)) + f" into {sys.argv[2]}")
