"""A printable clearance gauge: one plate with round holes from 0.1 to 1.0 mm of clearance,
their pegs, and each labelled with its clearance in raised seven-segment digits.

An FDM printer prints holes undersize (0.1-0.2 mm is common), which is most of a small
clearance. Printed once, the gauge shows which clearance still fits: the first peg that
goes in tells the printer's offset. It is an assembly (assetgen.families.parts) written by
the assembly layout's writer, so its files pass the same checks as every module's: each part
one closed body, every peg exactly its clearance from the plate (python-fcl, on the STL as
written), its straight insertion clear. The pegs are 32-gon prisms (Table I's circle), the
holes their exact mitred offsets (assetgen.geometry.polygon_offset).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from assetgen.core.frames import Frame
from assetgen.families.parts import Assembly, Part, Step
from assetgen.families.profile import prism
from assetgen.families.profile_bolt import box
from assetgen.geometry.polygon_offset import mitred_offset
from assetgen.params.module_params import ParamError

SIDES = 32
"""The pegs' polygon (vertices on the diameter), as Table I's circle."""
REACH = 0.05
"""How far (m) above the plate a hole is closed: beyond any material."""
EMBED = 1e-4
"""m a label's segments reach into the surface under them (so the union is one body: solids
that only touch on a face leave slivers)."""
SEGMENTS = {
    "a": ((0.0, 1.0), (1.0, 1.0)),
    "b": ((1.0, 0.5), (1.0, 1.0)),
    "c": ((1.0, 0.0), (1.0, 0.5)),
    "d": ((0.0, 0.0), (1.0, 0.0)),
    "e": ((0.0, 0.0), (0.0, 0.5)),
    "f": ((0.0, 0.5), (0.0, 1.0)),
    "g": ((0.0, 0.5), (1.0, 0.5)),
}
"""The seven segments as strokes in a unit digit cell (x right, y up)."""
DIGITS = {
    "0": "abcdef", "1": "bc", "2": "abdeg", "3": "abcdg", "4": "bcfg",
    "5": "acdfg", "6": "acdefg", "7": "abc", "8": "abcdefg", "9": "abcdfg",
}  # fmt: skip
"""Which segments light up for each digit."""


@dataclass(frozen=True)
class GaugeParams:
    """The gauge's dimensions, m."""

    clearances: tuple[float, ...] = tuple(k * 1e-4 for k in range(1, 11))
    """The holes' clearances, m (0.1 - 1.0 mm in 0.1 mm steps), each in (0, 2] mm."""
    diameter: float = 0.01
    """The pegs' diameter (their polygon's vertices on it), m."""
    peg_height: float = 0.012
    """Peg height, m."""
    depth: float = 0.006
    """Hole depth, m (the plate is this plus `floor` thick)."""
    floor: float = 0.003
    """Material under each hole, m."""
    pitch: float = 0.022
    """Distance between neighbouring holes' axes, m."""
    columns: int = 5
    """Holes per row."""
    digit: float = 0.004
    """Height of a label's digit, m (its width is 0.55 of it)."""
    stroke: float = 0.0007
    """Width of a digit's segments, m."""
    relief: float = 0.0006
    """How far the labels stand proud of the surface, m."""

    def validate(self) -> GaugeParams:
        if not self.clearances:
            raise ParamError("clearances: give at least one")
        for c in self.clearances:
            if not 0 < c <= 0.002:
                raise ParamError(f"clearance {c * 1e3:g} mm is outside (0, 2] mm")
        for name in ("diameter", "peg_height", "depth", "floor", "pitch", "digit", "stroke"):
            if not getattr(self, name) > 0:
                raise ParamError(f"{name} = {getattr(self, name)!r} m must be positive")
        if self.peg_height <= self.depth + self.relief:
            raise ParamError(
                f"peg_height = {self.peg_height * 1e3:g} mm must exceed the hole depth "
                f"({self.depth * 1e3:g} mm) so that each peg stands out of its hole"
            )
        room = self.pitch - self.diameter - 2 * max(self.clearances)
        if room < 0.003:
            raise ParamError(
                f"pitch = {self.pitch * 1e3:g} mm leaves {room * 1e3:.1f} mm between two "
                "holes; at least 3 mm"
            )
        return self

    def to_json(self) -> dict:
        return {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(self).items()}


def label_boxes(text: str, origin: np.ndarray, height: float, stroke: float, z0: float,
                z1: float) -> list[np.ndarray]:  # fmt: skip
    """Raised seven-segment text (digits and '.') as boxes (6, 4 half-space rows), the text's
    lower left corner at `origin` (x, y), between z0 and z1."""
    width = 0.55 * height
    boxes, x = [], float(origin[0])
    for ch in text:
        if ch == ".":
            lo = np.array([x, origin[1]])
            boxes.append(box([*lo, z0], [*(lo + stroke), z1]))
            x += 2.5 * stroke
            continue
        for seg in DIGITS[ch]:
            (x0, y0), (x1, y1) = SEGMENTS[seg]
            lo = np.array([x + x0 * (width - stroke), origin[1] + y0 * (height - stroke)])
            hi = np.array([x + x1 * (width - stroke), origin[1] + y1 * (height - stroke)])
            boxes.append(box([*lo, z0], [*(hi + stroke), z1]))
        x += width + 1.5 * stroke
    return boxes


def text_width(text: str, height: float, stroke: float) -> float:
    """The width (m) label_boxes gives `text`."""
    return sum(2.5 * stroke if ch == "." else 0.55 * height + 1.5 * stroke for ch in text)


def label(c: float) -> str:
    """A clearance (m) as its label in mm: 0.1, 0.25, 1.0."""
    return f"{c * 1e3:.2f}".rstrip("0").ljust(3, "0") if c * 1e3 < 10 else f"{c * 1e3:g}"


def build_gauge(p: GaugeParams) -> Assembly:
    """The plate (the base, its holes and labels) and one peg per clearance, each seated in
    its hole, inserted in order of clearance."""
    p.validate()
    theta = 2 * math.pi * np.arange(SIDES) / SIDES
    circle = p.diameter / 2 * np.column_stack([np.cos(theta), np.sin(theta)])
    rows = math.ceil(len(p.clearances) / p.columns)
    row_pitch = p.pitch + p.digit  # room for the label under each hole
    width, height = p.columns * p.pitch, rows * row_pitch
    plate = box([-width / 2, -height / 2, -(p.depth + p.floor)], [width / 2, height / 2, 0.0])
    holes, labels, pegs, steps = [], [], [], []
    for k, c in enumerate(p.clearances):
        col, row = k % p.columns, k // p.columns
        centre = np.array([(col + 0.5) * p.pitch - width / 2, height / 2 - (row + 0.4) * row_pitch])
        hole = mitred_offset(circle, c) + centre
        holes.append(prism(hole, -p.depth, REACH))
        text = label(c)
        below = -p.diameter / 2 - c - 1.5e-3 - p.digit  # the label's lower edge, under the hole
        at = centre + np.array([-text_width(text, p.digit, p.stroke) / 2, below])
        labels += label_boxes(text, at, p.digit, p.stroke, -EMBED, p.relief)
        # the peg: frame at its bottom face's centre, seated c above the hole's floor, its
        # label on its top face, small enough to fit there
        pose = np.eye(4)
        pose[:3, 3] = [*centre, -p.depth + c]
        small = 0.25 * p.diameter
        thin = min(p.stroke, 0.2 * small)
        at = np.array([-text_width(text, small, thin) / 2, -small / 2])
        top = label_boxes(text, at, small, thin, p.peg_height - EMBED, p.peg_height + p.relief)
        name = f"peg_{k + 1:02d}"
        pegs.append(Part(name, (prism(circle, 0.0, p.peg_height), *top), (), pose))
        bottom = pose.copy()
        bottom[2, 3] -= c
        entrance = Frame((*centre, 0.0), (1.0, 0.0, 0.0, 0.0))
        steps.append(Step(name, c, entrance, Frame.from_matrix(bottom), p.depth + 0.002))
    base = Part("base", (plate, *labels), tuple(holes))
    return Assembly(base, tuple(pegs), tuple(steps))
