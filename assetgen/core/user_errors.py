"""One line for an operating-system error a user can cause at the command line (a path that
is a file, a folder without write permission, a full disk), naming the path, the flag that
gave it, and what to do. The command line's entry point (cli.main) uses it; a library
caller gets the exception itself."""

from __future__ import annotations

import argparse
import errno
import os
from collections.abc import Sequence
from pathlib import Path

INTERRUPTED = 130
"""Exit code of a command stopped by Ctrl-C (128 + SIGINT), as a shell reports it."""


NOT_PATHS = frozenset(("command", "what", "func", "algo", "preset", "sim", "family"))
"""Argument names whose values are never paths (a subcommand, a choice)."""


def _paths(value: object) -> list[Path]:
    if isinstance(value, str | Path) and str(value):
        return [Path(value)]
    if isinstance(value, list | tuple):
        return [p for v in value for p in _paths(v)]
    return []


def given_as(args: argparse.Namespace, argv: Sequence[str], path: str | os.PathLike) -> str:
    """`path` in the words of the command line: `--out RUN` when it is, or lies under, the
    value of a flag (`--out RUN (…/file)` when under it), else the path itself."""
    target = Path(os.path.abspath(path))
    for dest, value in vars(args).items():
        if dest in NOT_PATHS:
            continue
        for given in _paths(value):
            mine = Path(os.path.abspath(given))
            if mine != target and mine not in target.parents:
                continue
            flag = "--" + dest.replace("_", "-")
            if flag not in argv:  # a positional argument: the path alone says it
                return str(path)
            return f"{flag} {given}" + ("" if mine == target else f" ({path})")
    return str(path)


def _first_file_above(path: Path) -> Path | None:
    for parent in path.parents:
        if parent.is_file():
            return parent
    return None


def os_error_message(e: OSError, args: argparse.Namespace, argv: Sequence[str]) -> str:
    """The one line for an OSError: what went wrong with which path, and what to do."""
    name = e.filename
    if name is None:
        what = errno.errorcode.get(e.errno or 0, "")
        if e.errno in (errno.ENOSPC, errno.EDQUOT):
            return "no space left on the device: free some space, then run the command again"
        return f"{e.strerror or e}{f' ({what})' if what else ''}"
    path = Path(os.fsdecode(name))
    at = given_as(args, argv, path)
    if isinstance(e, FileExistsError):
        if path.is_file():
            return f"{at} is a file where a folder is needed: give a new or existing folder"
        return f"{at} already exists: choose another path, or remove it first"
    if isinstance(e, NotADirectoryError):
        above = _first_file_above(path)
        where = f"{above} is a file" if above else "a part of it is not a folder"
        return f"{at}: {where}; give a path whose parents are folders"
    if isinstance(e, IsADirectoryError):
        return f"{at} is a folder where a file is needed: give a file's path"
    if isinstance(e, FileNotFoundError):
        return f"{at} does not exist: check the path, or create it first"
    if e.errno == errno.EROFS:
        return (
            f"cannot write {at}: its file system is read-only; copy the data to a folder you "
            "can write to (or remount it writable), then run the command again"
        )
    if isinstance(e, PermissionError):
        if not path.exists():
            verb = f"create {at}"
        elif os.access(path, os.R_OK):
            verb = f"write {at}"
        else:
            verb = f"read {at}"
        return (
            f"cannot {verb}: permission denied; use a folder you may write to, or change "
            "its permissions (chmod, chown)"
        )
    if e.errno in (errno.ENOSPC, errno.EDQUOT):
        return (
            f"no space left on the device to write {at}: free some space (or choose another "
            "folder), then run the command again"
        )
    return f"{at}: {e.strerror or e}"
