"""Checks a command makes before its long work, so that a run of hours never fails at its
last step for a reason its first could have seen: numeric flags finite and within their
bounds, output paths of the right kind (a file where a file is written, a folder where a
folder is) in a place that can be made and written. Each check raises PreflightError (a
ValueError, which every command already prints as its one-line `error: ...`) naming the
flag, its value and what to give instead, and writes nothing.

Each command declares its numeric flags' bounds beside its parser, as a {dest: Bound} dict,
and calls check_numbers(args, bounds) first thing."""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

MAX_COUNT = 2**31 - 1
"""The largest count a command accepts (envs, steps, modules, workers, ...): the engines,
torch and numpy index with 32-bit integers in places, and no run asks for more."""
MAX_SEED = 2**32 - 1
"""The largest seed of the commands that seed numpy's global generator (train, eval)."""


class PreflightError(ValueError):
    """A flag that the command refuses before any work; the message says what to give."""


@dataclass(frozen=True)
class Bound:
    """The values a numeric flag accepts: finite, at least `low` (more than `low` when
    `low_open`), at most `high` (less than `high` when `high_open`); `hint` says what to
    give (default: from the bounds)."""

    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False
    hint: str = ""

    def accepts(self, value: float) -> bool:
        if not math.isfinite(value):
            return False
        if self.low is not None and (value <= self.low if self.low_open else value < self.low):
            return False
        if self.high is None:
            return True
        return value < self.high if self.high_open else value <= self.high

    def describe(self, integer: bool) -> str:
        if self.hint:
            return self.hint
        what = "a whole number" if integer else "a finite number"
        low = self.low
        if low is not None and self.low_open:
            return f"give {what} greater than {_number(low)}" + (
                f" and at most {_number(self.high)}" if self.high is not None else ""
            )
        if low is not None and self.high is not None:
            return f"give {what} from {_number(low)} to {_number(self.high)}"
        if low is not None:
            return f"give {what} of at least {_number(low)}"
        if self.high is not None:
            return f"give {what} of at most {_number(self.high)}"
        return f"give {what}"


def _number(x: float) -> str:
    return str(x) if isinstance(x, int) else f"{x:g}"


def count(hint: str = "", low: int = 1, high: int = MAX_COUNT) -> Bound:
    """A whole number of things: at least `low` (1), at most `high` (MAX_COUNT)."""
    return Bound(low=low, high=high, hint=hint)


def positive(hint: str = "", high: float | None = None) -> Bound:
    """A finite number greater than 0 (a duration, a scale)."""
    return Bound(low=0.0, high=high, low_open=True, hint=hint)


def share(hint: str = "", whole: bool = True) -> Bound:
    """A finite number in (0, 1] (in (0, 1) when not `whole`: the share cannot be all)."""
    top = "]" if whole else ")"
    return Bound(low=0.0, high=1.0, low_open=True, high_open=not whole,
                 hint=hint or f"give a number in (0, 1{top}")  # fmt: skip


def seed(high: int | None = MAX_SEED) -> Bound:
    """A seed: a whole number from 0 (to MAX_SEED by default)."""
    to = f"from 0 to {high}" if high is not None else "of 0 or more"
    return Bound(low=0, high=high, hint=f"give a seed {to}")


def flag(dest: str) -> str:
    """An argparse dest as the command line spells it: `noise_scale` -> `--noise-scale`."""
    return "--" + dest.replace("_", "-")


def check_numbers(args: Any, bounds: dict[str, Bound]) -> None:
    """PreflightError for the first numeric flag of `args` outside its Bound; a flag that is
    absent or None (left to its default) passes."""
    for dest, bound in bounds.items():
        value = getattr(args, dest, None)
        if value is None or isinstance(value, bool):
            continue
        if not bound.accepts(value):
            raise PreflightError(f"{flag(dest)} {value}: {bound.describe(isinstance(value, int))}")


def _existing_ancestor(path: Path) -> Path:
    probe = path
    while not probe.exists() and probe != probe.parent:
        probe = probe.parent
    return probe


def _check_folder_can_hold(folder: Path, option: str, path: Path) -> None:
    """PreflightError unless `folder` exists as a writable folder or can be made."""
    where = _existing_ancestor(folder)
    if not where.is_dir():
        raise PreflightError(
            f"{option} {path}: {where} is a file, not a folder; choose another {option}"
        )
    if not os.access(where, os.W_OK | os.X_OK):
        raise PreflightError(
            f"{option} {path}: cannot write in {where} (permission denied); choose a place "
            f"you can write to ({option})"
        )


def check_output_file(path: str | Path, option: str, example: str = "results.json") -> None:
    """PreflightError unless a file can be written at `path` (its folder is made if
    missing): `path` is not a folder, and its folder exists writable or can be made.
    `example`: a file name the message offers inside a folder given instead."""
    path = Path(path)
    if path.is_dir():
        raise PreflightError(
            f"{option} {path}: is a folder; give the name of a file to write, e.g. {path / example}"
        )
    _check_folder_can_hold(path.parent, option, path)


def check_output_folder(path: str | Path, option: str) -> None:
    """PreflightError unless `path` is a folder, or can be made as one, and can be written
    in."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise PreflightError(f"{option} {path}: is a file; give a folder (new, or to write into)")
    _check_folder_can_hold(path, option, path)
