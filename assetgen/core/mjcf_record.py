"""What a module's MJCF records besides its meshes, against its module.json.

The simulator takes a module's frames, clearance and peg mass properties from module.json,
whose hash no manifest records, and its meshes from `peg_in_hole.xml`, whose hash the
manifest does record. The MJCF carries the same numbers (the `entrance` and `bottom` sites,
the peg body's pose, its `<inertial>`, the `clearance` numeric; see assetgen.formats.mjcf),
so a module.json edited after generation shows as a disagreement with a verified MJCF.

Read with a few byte searches, not an XML parse: the sites and the body follow the inline
meshes, at the end of the file, so checking costs microseconds whatever the mesh size.
"""

from __future__ import annotations

import math
import re

TOLERANCE = 1e-9
"""Largest difference accepted between module.json's numbers (rounded to 1e-12) and the
MJCF's (shortest round-trip text; quaternions normalised)."""

_SITE = re.compile(rb'<site name="(entrance|bottom)" pos="([^"]*)" quat="([^"]*)"/>')
_BODY = re.compile(rb'<body name="peg" pos="([^"]*)" quat="([^"]*)">')
_INERTIAL = re.compile(rb'<inertial pos="([^"]*)" mass="([^"]*)" fullinertia="([^"]*)"/>')
_CLEARANCE = re.compile(rb'<numeric name="clearance" data="([^"]*)"/>')


def _numbers(text: bytes) -> list[float]:
    return [float(t) for t in text.split()]


def mjcf_record(data: bytes) -> dict[str, list[float]]:
    """The numbers a module's MJCF bytes hold besides the meshes, by module.json's names:
    `frames.entrance.pos`, `frames.entrance.quat`, `frames.bottom.*`, `frames.design_pose.*`
    (the peg body's pose), `peg.com_m`, `peg.mass_kg`, `peg.inertia_kg_m2` (xx yy zz xy xz
    yz), `clearance`. ValueError when one is not found."""
    tail_start = data.rfind(b"</asset>")
    tail = data[max(tail_start, 0) :]
    head = data[: max(data.find(b"<asset>"), 0)] or data
    out: dict[str, list[float]] = {}
    try:
        for m in _SITE.finditer(tail):
            name = m.group(1).decode()
            out[f"frames.{name}.pos"] = _numbers(m.group(2))
            out[f"frames.{name}.quat"] = _numbers(m.group(3))
        body = _BODY.search(tail)
        inertial = _INERTIAL.search(tail)
        clearance = _CLEARANCE.search(head)
        if body is None or inertial is None or clearance is None or len(out) != 4:
            raise ValueError("its sites, peg body, inertial or clearance are missing")
        out["frames.design_pose.pos"] = _numbers(body.group(1))
        out["frames.design_pose.quat"] = _numbers(body.group(2))
        out["peg.com_m"] = _numbers(inertial.group(1))
        out["peg.mass_kg"] = _numbers(inertial.group(2))
        out["peg.inertia_kg_m2"] = _numbers(inertial.group(3))
        out["clearance"] = _numbers(clearance.group(1))
    except ValueError as e:
        raise ValueError(f"not a module MJCF as assetgen writes it ({e})") from None
    return out


def _from_meta(meta: dict, key: str) -> list[float]:
    """module.json's numbers under the dotted `key`, flattened as the MJCF lists them."""
    value = meta
    for part in key.split("."):
        value = value[part]
    if key == "peg.inertia_kg_m2":
        i = value
        return [i[0][0], i[1][1], i[2][2], i[0][1], i[0][2], i[1][2]]
    return [float(v) for v in value] if isinstance(value, list) else [float(value)]


def _close(a: list[float], b: list[float]) -> bool:
    return len(a) == len(b) and all(
        math.isfinite(x) and abs(x - y) <= TOLERANCE for x, y in zip(a, b, strict=True)
    )


def _unit(q: list[float]) -> list[float]:
    n = math.sqrt(sum(v * v for v in q)) or 1.0
    return [v / n for v in q]


def meta_mismatch(meta: dict, data: bytes, name: str) -> str | None:
    """None when module.json (`meta`) holds the frames, clearance and peg mass properties
    that the module's MJCF bytes `data` (file `name`) hold; else the first field that
    differs, e.g. `module.json frames.entrance.pos disagrees with peg_in_hole.xml`."""
    try:
        stored = mjcf_record(data)
    except ValueError as e:
        return f"{name}: {e}"
    for key, value in stored.items():
        try:
            mine = _from_meta(meta, key)
        except (KeyError, TypeError, ValueError, IndexError):
            return f"module.json lacks {key} (or it is malformed)"
        if key.endswith(".quat"):  # the MJCF's are normalised; q and -q are one rotation
            a, b = _unit(mine), _unit(value)
            same = _close(a, b) or _close([-v for v in a], b)
        else:
            same = _close(mine, value)
        if not same:
            return f"module.json {key} disagrees with {name}"
    return None
