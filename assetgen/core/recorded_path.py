"""How a result file names a path: relative to the working directory when the path lies
inside it, else absolute.

Results are filed in the repository (docs/results/, checkpoints/) and read on other
machines: `/home/alice/peg/datasets/test` names nothing on a clone, `datasets/test` names the
same folder wherever the repository's commands run from its root, as they do.
"""

from __future__ import annotations

import os
from pathlib import Path


def recorded_path(path: str | Path, start: str | Path | None = None) -> str:
    """`path` relative to `start` (the working directory by default) in '/' form when it
    lies inside it; its absolute form otherwise (a folder elsewhere keeps its full name)."""
    here = Path(os.path.abspath(start if start is not None else os.getcwd()))
    full = Path(os.path.abspath(path))
    try:
        return full.relative_to(here).as_posix()
    except ValueError:
        return str(full)
