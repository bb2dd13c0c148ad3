"""Writing a file so that its final name only ever holds complete contents.

The text goes to `<name>.tmp` beside the target, then `os.replace` (atomic on POSIX) moves
it onto the name: a crash or a full disk mid-write leaves the previous file, or none, never
half of one, and a write that fails leaves no `.tmp` behind. (Checkpoints, MJCF and USD
writers use unique temporary names instead, since concurrent writers may share their
folder.)
"""

from __future__ import annotations

import contextlib
import json
import math
import os
from pathlib import Path
from typing import Any


def write_text(path: str | Path, text: str) -> Path:
    """Write `text` (UTF-8) to `path` atomically, creating its folder; returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    try:
        tmp.write_text(text, encoding="utf-8")
        os.replace(tmp, path)
    except BaseException:  # a full disk, a folder at `path`, Ctrl-C: no .tmp left behind
        with contextlib.suppress(OSError):
            tmp.unlink(missing_ok=True)
        raise
    return path


def strict_json(doc: dict[str, Any]) -> dict[str, Any]:
    """`doc` with its top-level NaN floats as None: strict JSON has no NaN."""
    return {k: None if isinstance(v, float) and math.isnan(v) else v for k, v in doc.items()}


def write_json(path: str | Path, doc: dict[str, Any], **dumps: Any) -> Path:
    """`write_text` of `json.dumps(doc, **dumps)`."""
    return write_text(path, json.dumps(doc, **dumps))


def write_dataset_json(path: str | Path, doc: dict[str, Any]) -> Path:
    """`doc` in the layout of every JSON file of a dataset (module.json, dataset.json):
    indent 1, sorted keys, a final newline, so equal content gives equal bytes."""
    return write_text(path, json.dumps(doc, indent=1, sort_keys=True) + "\n")
